//! Image output: the layered OpenEXR master file and an 8-bit PNG preview.
//!
//! # Data model
//! [`ImageLayers`] holds the per-pixel results of a render, row-major with the
//! top row first, all `width * height` long:
//! * `rgb`: linear radiance (the pixel mean),
//! * `variance`: per-channel variance *of the pixel mean* (sample variance
//!   divided by the sample count), for denoisers and convergence checks,
//! * `samples`: how many samples each pixel received.
//!
//! # EXR layout (see [`encode_exr`])
//! One scanline part, f32 channels `R`, `G`, `B`, `variance.R`, `variance.G`,
//! `variance.B`, `samples.Y`; ZIP compression (OpenEXR `ZIP_COMPRESSION`,
//! 16-line blocks), increasing-Y line order. Caller metadata becomes typed
//! header attributes: names are written as given (use a prefix such as
//! `tessera.spp`), except that `software`, `owner`, `comments` and `capDate`
//! with text values fill the standard attributes of those names. Other names
//! reserved by OpenEXR (`channels`, `compression`, ...) are rejected.
//! Attribute order in the file is unspecified, so two encodes of the same
//! data are equal in content but not necessarily byte for byte.
//!
//! [`decode_exr`] reads that back bit for bit, and also reads foreign EXRs
//! (e.g. from Mitsuba 3 or oiiotool): the first part, scanline or tiled
//! (largest mip level), any compression the `exr` crate decodes (incl. PIZ,
//! DWAA), f16/f32/u32 samples. RGB comes from `R`, `G`, `B` (or a lone `Y`,
//! copied to all three); missing variance or sample layers are filled with 0.
//! Metadata comes back sorted by name, scalar attributes only (vectors,
//! matrices, chromaticities etc. are skipped). Text attributes are written as
//! UTF-8 and read as UTF-8 when valid, else as Latin-1. Sizes above 2^28
//! pixels, deep files and garbage are errors, never panics.
//!
//! [`write_exr`] writes a temp file in the target directory, fsyncs it and
//! renames it over the target, so readers only ever see a complete file.
//!
//! [`ImageLayers::pixel_digest`] and [`files_digest`] hash the pixels alone (not the metadata),
//! so two renders can be checked to be the same bit for bit.
//!
//! [`encode_png_preview`] is a display preview: linear → sRGB at exposure 1
//! (no auto-exposure, so previews of different renders compare directly),
//! clamped, NaN/±Inf shown black.

mod digest;
mod exr;
mod job_image;
mod png;

pub use self::digest::files_digest;
pub use self::exr::{decode_exr, encode_exr, write_exr};
pub use self::job_image::JobImage;
pub use self::png::encode_png_preview;

use anyhow::{Result, ensure};

/// The layers of a rendered image; row-major, top row first.
#[derive(Clone, Debug, Default)]
pub struct ImageLayers {
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<[f32; 3]>,
    pub variance: Vec<[f32; 3]>,
    pub samples: Vec<f32>,
}

impl ImageLayers {
    /// An all-zero image of the given size.
    pub fn zeroed(width: usize, height: usize) -> ImageLayers {
        let n = width * height;
        ImageLayers {
            width,
            height,
            rgb: vec![[0.0; 3]; n],
            variance: vec![[0.0; 3]; n],
            samples: vec![0.0; n],
        }
    }

    /// Errors unless every layer holds exactly `width * height` pixels.
    pub fn check(&self) -> Result<()> {
        let n = self.width.checked_mul(self.height);
        ensure!(n.is_some_and(|n| n > 0), "image is {}x{}: no pixels", self.width, self.height);
        for (name, len) in [
            ("rgb", self.rgb.len()),
            ("variance", self.variance.len()),
            ("samples", self.samples.len()),
        ] {
            ensure!(
                Some(len) == n,
                "layer `{name}` has {len} pixels, expected {}x{}",
                self.width,
                self.height
            );
        }
        Ok(())
    }
}

/// A typed header attribute value (the scalar types OpenEXR stores natively).
#[derive(Clone, Debug, PartialEq)]
pub enum MetaValue {
    Text(String),
    Int(i32),
    Float(f32),
    Double(f64),
}
