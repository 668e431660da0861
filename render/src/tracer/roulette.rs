//! # Russian roulette — ending paths early without bias
//!
//! A path that survives with probability q has its throughput β divided by q, so the expected
//! image is the same whatever q is; what q decides is where the time goes. Two forms:
//! - `Threshold { threshold, p }` — the seed's: once max(β·η²) is below `threshold`, stop with
//!   probability `p`;
//! - `Throughput { min_depth }` — the default (pbrt-v4, Mitsuba 3): from the `min_depth`-th
//!   non-specular bounce on, survive with probability max(β·η²), capped at 1.
//!
//! Job setting: `roulette_depth` (`POST /v1/jobs`, `--roulette-depth`), 0 = off, default
//! [`DEFAULT_ROULETTE_DEPTH`]. Measurements behind the defaults (2026-12-03 and 2026-12-04):
//! docs/dev/performance-log.md.
use glam::Vec3;

/// Russian roulette on the path throughput β.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Roulette {
    Off,
    /// The seed's form: once max(β·η²) < `threshold`, stop with probability `p`, else β /= 1 − p.
    Threshold {
        threshold: f32,
        p: f32,
    },
    /// From the `min_depth`-th non-specular bounce on, survive with probability max(β·η²)
    /// (capped at 1), so a surviving path's throughput outside glass never exceeds 1 in any
    /// channel. Specular bounces (smooth glass) do not count: they neither spread nor lose
    /// light the way a rough bounce does, and counting them ended the caustic paths that only
    /// BSDF sampling finds (glass scenes: 2.3–3.2× lower relMSE at equal spp and time;
    /// docs/dev/performance-log.md, 2026-12-04). `PathSettings::max_depth` still bounds such a chain.
    Throughput {
        min_depth: u32,
    },
}

/// The non-specular bounce from which [`Roulette::default`] may end paths. Five, as in
/// Mitsuba 3: against three on eleven bundled scenes it lowered relMSE at equal spp everywhere,
/// and relMSE × seconds in 19 of 22 cases (up to 2.2× on glass; the other three within
/// run-to-run time noise, ≤ 9 %); docs/dev/performance-log.md, 2026-12-04.
pub const DEFAULT_ROULETTE_DEPTH: u32 = 5;

impl Roulette {
    /// Throughput roulette from the `depth`-th non-specular bounce on; 0 turns roulette off.
    pub fn from_depth(depth: u32) -> Roulette {
        if depth == 0 { Roulette::Off } else { Roulette::Throughput { min_depth: depth } }
    }

    /// Applies Russian roulette after a path's `rough_bounces`-th non-specular bounce; false when
    /// the path stops. Survivors are reweighted by 1/q.
    /// Decisions look at β·`eta_scale` (pbrt-v4's `etaScale`, Mitsuba's η²): inside glass β is
    /// 1/η² of the light it carries out again, and judging β alone ended ~56 % of paths in a
    /// pane of glass that lost them nothing. `u` is asked for only when the path may stop.
    pub fn survives(
        self,
        rough_bounces: u32,
        beta: &mut Vec3,
        eta_scale: f32,
        u: impl FnOnce() -> f32,
    ) -> bool {
        let carried = beta.max_element() * eta_scale;
        let q = match self {
            Roulette::Off => return true,
            Roulette::Threshold { threshold, p } => {
                if carried >= threshold {
                    return true;
                }
                1.0 - p
            }
            Roulette::Throughput { min_depth } => {
                if rough_bounces < min_depth || carried >= 1.0 {
                    return true;
                }
                carried
            }
        };
        if !(u() < q) {
            return false;
        }
        *beta /= q;
        true
    }
}

impl Default for Roulette {
    fn default() -> Roulette {
        Roulette::from_depth(DEFAULT_ROULETTE_DEPTH)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn throughput_roulette_waits_for_its_depth_then_survives_with_beta_times_eta_squared() {
        let rr = Roulette::from_depth(2);
        let mut beta = Vec3::splat(0.3);
        assert!(rr.survives(1, &mut beta, 1.0, || unreachable!("no draw before the depth")));
        assert_eq!(beta, Vec3::splat(0.3));
        // Inside glass (η² = 2.25) the path carries 0.675 of its light: u = 0.5 survives and
        // is reweighted by 1/0.675; judged on β alone (q = 0.3) it would have ended.
        assert!(rr.survives(2, &mut beta, 2.25, || 0.5));
        assert!((beta.x - 0.3 / 0.675).abs() < 1e-6, "{beta}");
        assert!(!rr.survives(2, &mut Vec3::splat(0.3), 1.0, || 0.5));
        // At or above 1 nothing is drawn; off never draws.
        assert!(rr.survives(9, &mut Vec3::splat(0.5), 2.25, || unreachable!()));
        assert!(Roulette::from_depth(0).survives(
            9,
            &mut Vec3::splat(1e-9),
            1.0,
            || unreachable!()
        ));
    }
}
