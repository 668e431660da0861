//! The queries compiled for x86-64 CPUs with AVX2 (x86-64-v3), chosen when the tree is built.
//!
//! The release build targets baseline x86-64 (SSE2), so a binary runs on every worker of a farm.
//! Where the CPU has AVX2, the closest-hit and shadow queries run a second copy of the same walk
//! (everything below them is `#[inline(always)]`) compiled with these features: three-operand
//! VEX instructions instead of SSE's two-operand ones (no register copies before a destructive
//! operation), BMI's bit instructions for the masks, and the node test on all eight children in
//! one 256-bit register (`accel_node_wide8.rs`). Every lane does the same IEEE operations in the
//! same order in both copies (no fused multiply–add: Rust never contracts), so the boxes culled
//! and the hits are bit-identical, and a farm of mixed CPUs still renders the same image.
//!
//! `TESSERA_NO_AVX2=1` in the environment forces the baseline copy (to compare the two).
use super::{Accel, Hit, Tally};
use crate::tracer::ray::Ray;

/// Whether this CPU runs the AVX2 copies (and the environment does not forbid it); read once.
pub(super) fn detected() -> bool {
    static DETECTED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *DETECTED.get_or_init(|| cpu_has_v3() && std::env::var_os("TESSERA_NO_AVX2").is_none())
}

fn cpu_has_v3() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        has!("avx2")
            && has!("fma")
            && has!("bmi1")
            && has!("bmi2")
            && has!("lzcnt")
            && has!("popcnt")
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

#[cfg(target_arch = "x86_64")]
impl Accel {
    /// `closest`, compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must have the enabled features ([`detected`]).
    #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
    pub(super) unsafe fn closest_avx2(
        &self,
        ray: &Ray,
        t_max: f32,
        keep: impl Fn(u32, f32, f32) -> bool,
        tally: &mut impl Tally,
    ) -> Option<Hit> {
        self.closest::<true>(ray, t_max, keep, tally)
    }

    /// `blocked`, compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must have the enabled features ([`detected`]).
    #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
    pub(super) unsafe fn blocked_avx2(
        &self,
        ray: &Ray,
        t_max: f32,
        keep: impl Fn(u32, f32, f32) -> bool,
        tally: &mut impl Tally,
    ) -> bool {
        self.blocked::<true>(ray, t_max, keep, tally)
    }
}
