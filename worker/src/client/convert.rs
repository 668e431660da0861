//! Between the wire types of `tessera_proto` and the tracer's own (the tracer knows no proto).
use glam::Vec3;
use std::str::FromStr;
use tessera_proto::{PartialSums, RenderParams, TileRect, WirePixel};
use tessera_render::tracer::integrator::{PathSettings, UnknownEstimator};
use tessera_render::tracer::light::UnknownLightSampler;
use tessera_render::tracer::sampler::{SamplerKind, UnknownSamplerKind};
use tessera_render::tracer::{Estimator, LightSampler, RenderSettings, Roulette, Tile, TileSums};

/// A unit's sums in wire form, bit for bit (`max_weight` widened to f64 exactly).
/// `samples` is the unit's sample range `[start, end)`.
pub fn to_wire(sums: &TileSums, samples: [u32; 2]) -> PartialSums {
    let t = sums.tile;
    PartialSums {
        tile: TileRect { x0: t.x0, y0: t.y0, w: t.w, h: t.h },
        samples,
        dropped: sums.dropped,
        max_weight: f64::from(sums.max_weight),
        pixels: sums
            .pixels
            .iter()
            .map(|p| WirePixel {
                sum: p.sum,
                sum_sq: p.sum_sq,
                sum_lum_sq: p.sum_lum_sq,
                count: p.count,
            })
            .collect(),
    }
}

/// Render parameters a worker cannot render with.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BadParams {
    #[error(transparent)]
    Estimator(#[from] UnknownEstimator),
    #[error(transparent)]
    Sampler(#[from] UnknownSamplerKind),
    #[error(transparent)]
    LightSampler(#[from] UnknownLightSampler),
    #[error("image size {width}×{height} is empty")]
    EmptyImage { width: u32, height: u32 },
    #[error("background {0:?} must be finite and ≥ 0")]
    Background([f32; 3]),
}

/// The tracer's settings for a job's render parameters.
pub fn render_settings(params: &RenderParams) -> Result<RenderSettings, BadParams> {
    let estimator = Estimator::from_str(&params.estimator)?;
    let sampler = SamplerKind::from_str(&params.sampler)?;
    // None: parameters from a coordinator whose jobs all chose automatically.
    let light_sampler =
        params.light_sampler.as_deref().map_or(Ok(LightSampler::Auto), LightSampler::from_str)?;
    if params.width == 0 || params.height == 0 {
        return Err(BadParams::EmptyImage { width: params.width, height: params.height });
    }
    if !params.background.iter().all(|c| c.is_finite() && *c >= 0.0) {
        return Err(BadParams::Background(params.background));
    }
    Ok(RenderSettings {
        width: params.width,
        height: params.height,
        seed: params.seed,
        sampler,
        path: PathSettings {
            estimator,
            roulette: params.roulette_depth.map_or_else(Roulette::default, Roulette::from_depth),
            max_depth: params.max_depth,
            light_sampler,
        },
        background: Vec3::from_array(params.background),
        camera: params.camera.clone(),
    })
}

pub(crate) fn tile(rect: TileRect) -> Tile {
    Tile { x0: rect.x0, y0: rect.y0, w: rect.w, h: rect.h }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tessera_render::tracer::PixelSums;

    fn params() -> RenderParams {
        RenderParams {
            width: 64,
            height: 48,
            seed: 7,
            estimator: "bsdf".into(),
            sampler: "independent".into(),
            camera: Some("Camera".into()),
            max_depth: 12,
            roulette_depth: Some(7),
            light_sampler: Some("tree".into()),
            background: [0.5, 0.25, 0.0],
            animation: None,
            fps: tessera_proto::job::DEFAULT_FPS,
        }
    }

    #[test]
    fn render_settings_maps_every_field() {
        let s = render_settings(&params()).unwrap();
        assert_eq!((s.width, s.height, s.seed), (64, 48, 7));
        assert_eq!(s.sampler, SamplerKind::Independent);
        assert_eq!(
            s.path,
            PathSettings {
                estimator: Estimator::Bsdf,
                roulette: Roulette::Throughput { min_depth: 7 },
                max_depth: 12,
                light_sampler: LightSampler::Tree
            }
        );
        assert_eq!(s.background, Vec3::new(0.5, 0.25, 0.0));
        assert_eq!(s.camera.as_deref(), Some("Camera"));
    }

    #[test]
    fn roulette_depth_zero_is_off_and_absent_is_the_default() {
        let off = render_settings(&RenderParams { roulette_depth: Some(0), ..params() }).unwrap();
        assert_eq!(off.path.roulette, Roulette::Off);
        let old = render_settings(&RenderParams { roulette_depth: None, ..params() }).unwrap();
        assert_eq!(old.path.roulette, Roulette::default());
    }

    #[test]
    fn every_light_sampler_maps_and_absent_is_auto() {
        for l in LightSampler::ALL {
            let s =
                render_settings(&RenderParams { light_sampler: Some(l.name().into()), ..params() })
                    .unwrap();
            assert_eq!(s.path.light_sampler, l);
        }
        let old = render_settings(&RenderParams { light_sampler: None, ..params() }).unwrap();
        assert_eq!(old.path.light_sampler, LightSampler::Auto);
    }

    #[test]
    fn render_settings_refuses_bad_params() {
        for (p, why) in [
            (RenderParams { estimator: "magic".into(), ..params() }, "estimator"),
            (RenderParams { sampler: "halton".into(), ..params() }, "sampler"),
            (RenderParams { light_sampler: Some("bvh".into()), ..params() }, "light sampler"),
            (RenderParams { width: 0, ..params() }, "empty"),
            (RenderParams { background: [f32::NAN, 0.0, 0.0], ..params() }, "background"),
        ] {
            let e = render_settings(&p).unwrap_err().to_string();
            assert!(e.contains(why), "{e:?} should mention {why}");
        }
    }

    #[test]
    fn to_wire_is_bit_exact_and_decodes() {
        let tile = Tile { x0: 3, y0: 5, w: 2, h: 1 };
        let mut sums = TileSums::new(tile);
        sums.pixels[0] = PixelSums {
            sum: [0.1, 1e-300, 3.0],
            sum_sq: [0.01, 0.0, 9.0],
            sum_lum_sq: 0.3,
            count: 3,
        };
        sums.pixels[1] = PixelSums {
            sum: [f64::MIN_POSITIVE, 2.0, 0.7],
            sum_sq: [0.0, 4.0, 0.49],
            sum_lum_sq: 1.1,
            count: 2,
        };
        sums.dropped = 1;
        sums.max_weight = 1.1f32;
        let wire = to_wire(&sums, [8, 11]);
        let back = PartialSums::decode(&wire.encode()).unwrap();
        assert_eq!(back, wire);
        assert_eq!(back.tile, TileRect { x0: 3, y0: 5, w: 2, h: 1 });
        assert_eq!(back.max_weight.to_bits(), f64::from(1.1f32).to_bits());
        for (w, p) in back.pixels.iter().zip(&sums.pixels) {
            assert_eq!(w.sum.map(f64::to_bits), p.sum.map(f64::to_bits));
            assert_eq!(w.sum_sq.map(f64::to_bits), p.sum_sq.map(f64::to_bits));
            assert_eq!(w.sum_lum_sq.to_bits(), p.sum_lum_sq.to_bits());
            assert_eq!(w.count, p.count);
        }
    }
}
