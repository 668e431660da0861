//! A digest of an image's pixels, to check that two renders are the same bit for bit.
//!
//! The EXR files of two renders of one job's settings differ even when their pixels do not
//! (render time, job id and renderer metadata, attribute order), so comparing files says
//! nothing. The digest covers what the farm promises to reproduce: the size and every layer
//! Tessera writes (`rgb`, `variance`, `samples`), as the bits of their f32 values. Renders of
//! the same settings by workers of one renderer id give the same digest whatever the number
//! of workers, their threads and the order results arrive in; so do two builds of the same
//! source that differ only in how they were optimised (`deploy/build-pgo.sh` checks its
//! build that way).
use super::{ImageLayers, decode_exr};
use anyhow::{Context, Result};
use sha2::{Digest, Sha256};
use std::path::PathBuf;

/// Tag hashed first, so that a change to what is hashed changes every digest.
const VERSION: &[u8] = b"tessera pixels v1";

impl ImageLayers {
    /// SHA-256 of the size and the bits of every layer.
    pub fn pixel_digest(&self) -> [u8; 32] {
        let mut h = Sha256::new();
        h.update(VERSION);
        h.update((self.width as u64).to_le_bytes());
        h.update((self.height as u64).to_le_bytes());
        for v in self.rgb.iter().chain(&self.variance).flatten().chain(&self.samples) {
            h.update(v.to_bits().to_le_bytes());
        }
        h.finalize().into()
    }
}

/// Hex digest of the EXR images in `files`: one file's own digest, or for a sequence the
/// digest of its frames' digests in order.
pub fn files_digest(files: &[PathBuf]) -> Result<String> {
    let mut digests = Vec::with_capacity(files.len());
    for path in files {
        let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        let (image, _) =
            decode_exr(&bytes).with_context(|| format!("decoding {}", path.display()))?;
        digests.push(image.pixel_digest());
    }
    Ok(match digests.as_slice() {
        [one] => hex::encode(one),
        many => hex::encode(Sha256::digest(many.concat())),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::encode_exr;

    fn image() -> ImageLayers {
        let mut img = ImageLayers::zeroed(3, 2);
        for (i, p) in img.rgb.iter_mut().enumerate() {
            *p = [i as f32 * 0.25, 1.0 / (i as f32 + 1.0), -0.0];
        }
        img.variance[4] = [1e-6, 2e-6, 3e-6];
        img.samples.fill(16.0);
        img
    }

    #[test]
    fn one_bit_of_any_layer_changes_the_digest() {
        let base = image().pixel_digest();
        let mut rgb = image();
        rgb.rgb[5][1] = f32::from_bits(rgb.rgb[5][1].to_bits() ^ 1);
        let mut var = image();
        var.variance[0][2] = f32::from_bits(1);
        let mut spp = image();
        spp.samples[3] = 17.0;
        let mut signed_zero = image();
        signed_zero.rgb[0][2] = 0.0;
        for changed in [rgb, var, spp, signed_zero] {
            assert_ne!(changed.pixel_digest(), base);
        }
        assert_eq!(image().pixel_digest(), base);
    }

    #[test]
    fn size_is_part_of_the_digest() {
        let (a, mut b) = (ImageLayers::zeroed(2, 3), ImageLayers::zeroed(3, 2));
        assert_ne!(a.pixel_digest(), b.pixel_digest());
        b.width = 2;
        b.height = 3;
        assert_eq!(a.pixel_digest(), b.pixel_digest());
    }

    #[test]
    fn files_with_different_metadata_and_the_same_pixels_agree() {
        let dir = std::env::temp_dir().join(format!("tessera-digest-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let meta = |t: f64| {
            vec![("tessera.render_time_s".to_string(), crate::output::MetaValue::Double(t))]
        };
        let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
        std::fs::write(&a, encode_exr(&image(), &meta(1.0)).unwrap()).unwrap();
        std::fs::write(&b, encode_exr(&image(), &meta(2.0)).unwrap()).unwrap();
        assert_ne!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
        let one = files_digest(std::slice::from_ref(&a)).unwrap();
        assert_eq!(one, hex::encode(image().pixel_digest()));
        assert_eq!(files_digest(std::slice::from_ref(&b)).unwrap(), one);
        let seq = files_digest(&[a.clone(), b.clone()]).unwrap();
        assert_ne!(seq, one, "a sequence hashes its frames' digests");
        assert!(
            files_digest(&[dir.join("missing.exr")])
                .unwrap_err()
                .to_string()
                .contains("missing.exr")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
