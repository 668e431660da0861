//! Rays and the floating-point error bounds that keep spawned rays off their own surface.
//!
//! Following pbrt-v4 ("Managing Rounding Error"), an intersection point carries a conservative
//! bound on its rounding error. A spawned ray starts just outside that error box along the
//! geometric normal, so it cannot re-hit the surface it leaves, at any scale, without a fixed
//! epsilon that would be too big near the origin and too small far from it.
use glam::{Vec3, Vec3A};

/// f32 unit roundoff (2⁻²⁴).
pub const MACHINE_EPSILON: f32 = f32::EPSILON * 0.5;

/// Shadow rays stop this fraction short of the target, whose own position was already offset.
pub const SHADOW_EPSILON: f32 = 1e-4;

/// γₙ = nε/(1−nε): bound on the relative error of n chained f32 operations.
pub const fn gamma(n: i32) -> f32 {
    let ne = n as f32 * MACHINE_EPSILON;
    ne / (1.0 - ne)
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    /// Not necessarily normalized; shadow rays use the full segment with `t_max` < 1.
    pub dir: Vec3,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray { origin, dir }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// A point with a per-axis absolute error bound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrPoint {
    pub p: Vec3,
    pub err: Vec3,
}

impl ErrPoint {
    pub fn exact(p: Vec3) -> ErrPoint {
        ErrPoint { p, err: Vec3::ZERO }
    }

    /// The point b0·p0 + b1·p1 + b2·p2 with pbrt-v4's bound γ₇·Σ|bᵢpᵢ|.
    pub fn from_barycentric(v: &[Vec3; 3], b0: f32, b1: f32, b2: f32) -> ErrPoint {
        let p = v[0] * b0 + v[1] * b1 + v[2] * b2;
        let abs_sum = (v[0] * b0).abs() + (v[1] * b1).abs() + (v[2] * b2).abs();
        ErrPoint { p, err: abs_sum * gamma(7) }
    }

    /// Origin for a ray leaving this point in direction `w`, pushed past the error box
    /// along the geometric normal `ng` to the side `w` points to.
    pub fn offset_origin(&self, ng: Vec3, w: Vec3) -> Vec3 {
        let d = ng.abs().dot(self.err);
        let offset = ng * if w.dot(ng) < 0.0 { -d } else { d };
        step_toward3(self.p + offset, offset)
    }

    pub fn spawn(&self, ng: Vec3, dir: Vec3) -> Ray {
        Ray::new(self.offset_origin(ng, dir), dir)
    }

    /// A segment from this point towards `to` (offset at both ends); occluded iff a hit has t < 1.
    // A hint, not a rule: left to itself the plain build called this once per light sample
    // (PGO inlined it), and inlining it made the Cornell box render 4–6 % faster (measured 2026-12-05).
    #[inline]
    pub fn spawn_to(&self, ng: Vec3, to: &ErrPoint, to_ng: Vec3) -> Ray {
        let from = self.offset_origin(ng, to.p - self.p);
        let target = if to_ng == Vec3::ZERO { to.p } else { to.offset_origin(to_ng, from - to.p) };
        Ray::new(from, target - from)
    }
}

/// [`step_toward`] on each axis, on x86_64 in SSE2 masks instead of branches: every spawned
/// ray calls it, on signs that are a coin toss.
#[cfg(target_arch = "x86_64")]
fn step_toward3(v: Vec3, dir: Vec3) -> Vec3 {
    use std::arch::x86_64::*;
    let (v, dir) = (__m128::from(Vec3A::from(v)), __m128::from(Vec3A::from(dir)));
    // SAFETY: SSE2 is part of every x86_64 target; no memory is touched.
    let stepped = unsafe {
        let zero = _mm_setzero_ps();
        let (up, down) =
            (_mm_castps_si128(_mm_cmpgt_ps(dir, zero)), _mm_castps_si128(_mm_cmplt_ps(dir, zero)));
        let positive = _mm_castps_si128(_mm_cmpgt_ps(v, zero));
        // Away from zero (up from a positive value, down from the rest) adds one to the bits,
        // towards zero subtracts one: masks are −1, so sub − add is the step.
        let add = _mm_or_si128(_mm_and_si128(up, positive), _mm_andnot_si128(positive, down));
        let sub = _mm_or_si128(_mm_andnot_si128(positive, up), _mm_and_si128(down, positive));
        let bits = _mm_castps_si128(v);
        let moved = _mm_add_epi32(bits, _mm_sub_epi32(sub, add));
        // Zeros of either sign step to the smallest subnormal of the direction's sign.
        let is_zero =
            _mm_and_si128(_mm_castps_si128(_mm_cmpeq_ps(v, zero)), _mm_or_si128(up, down));
        let from_zero =
            _mm_or_si128(_mm_set1_epi32(1), _mm_and_si128(down, _mm_set1_epi32(i32::MIN)));
        let moved =
            _mm_or_si128(_mm_andnot_si128(is_zero, moved), _mm_and_si128(is_zero, from_zero));
        // Infinities stay where the step would leave the floats.
        let inf = _mm_set1_ps(f32::INFINITY);
        let outward = _mm_or_si128(
            _mm_and_si128(up, _mm_castps_si128(_mm_cmpeq_ps(v, inf))),
            _mm_and_si128(down, _mm_castps_si128(_mm_cmpeq_ps(v, _mm_sub_ps(zero, inf)))),
        );
        _mm_castsi128_ps(_mm_or_si128(
            _mm_andnot_si128(outward, moved),
            _mm_and_si128(outward, bits),
        ))
    };
    Vec3::from(Vec3A::from(stepped))
}

#[cfg(not(target_arch = "x86_64"))]
fn step_toward3(v: Vec3, dir: Vec3) -> Vec3 {
    Vec3::new(step_toward(v.x, dir.x), step_toward(v.y, dir.y), step_toward(v.z, dir.z))
}

/// `v` moved one float up if `dir` > 0, down if `dir` < 0, else (0, NaN) left alone: up from
/// `+∞` and down from `−∞` stay, and both zeros step to the smallest subnormal of that sign.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))] // there the tests' reference for step_toward3
fn step_toward(v: f32, dir: f32) -> f32 {
    let b = v.to_bits();
    let up = if v == 0.0 {
        1
    } else if v == f32::INFINITY {
        b
    } else if v >= 0.0 {
        b.wrapping_add(1)
    } else {
        b.wrapping_sub(1)
    };
    let down = if v == 0.0 {
        0x8000_0001
    } else if v == f32::NEG_INFINITY {
        b
    } else if v > 0.0 {
        b.wrapping_sub(1)
    } else {
        b.wrapping_add(1)
    };
    f32::from_bits(if dir > 0.0 {
        up
    } else if dir < 0.0 {
        down
    } else {
        b
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn next_float_up(v: f32) -> f32 {
        step_toward(v, 1.0)
    }

    fn next_float_down(v: f32) -> f32 {
        step_toward(v, -1.0)
    }

    #[test]
    fn next_float_steps_one_ulp_across_zero() {
        assert_eq!(next_float_up(0.0), f32::from_bits(1));
        assert_eq!(next_float_up(-0.0), f32::from_bits(1));
        assert_eq!(next_float_down(0.0), -f32::from_bits(1));
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_float_down(-1.0), -1.0 - f32::EPSILON);
        assert!(next_float_up(f32::MAX).is_infinite());
        assert_eq!(next_float_up(f32::INFINITY), f32::INFINITY);
        assert_eq!(next_float_down(f32::NEG_INFINITY), f32::NEG_INFINITY);
        assert_eq!(next_float_down(f32::INFINITY), f32::MAX);
        assert!(next_float_up(f32::NAN).is_nan());
    }

    /// Position of a float in the order of the reals (both zeros at one place).
    fn rank(v: f32) -> i64 {
        let b = v.to_bits();
        if b >> 31 == 1 { -i64::from(b & 0x7fff_ffff) } else { i64::from(b) }
    }

    #[test]
    fn next_float_is_the_neighbour_in_the_order_of_the_reals() {
        let mut bits = 0x2545_f491u32;
        let specials = [0.0, -0.0, 1e-45, -1e-45, f32::MIN_POSITIVE, 1.0, -1.0, f32::MAX, f32::MIN];
        for i in 0..200_000 {
            bits ^= bits << 13;
            bits ^= bits >> 17;
            bits ^= bits << 5;
            let v = specials.get(i).copied().unwrap_or(f32::from_bits(bits));
            if !v.is_finite() {
                continue;
            }
            let (up, down) = (next_float_up(v), next_float_down(v));
            assert_eq!(rank(up), rank(v) + 1, "up from {v:e} ({:#x})", v.to_bits());
            assert_eq!(rank(down), rank(v) - 1, "down from {v:e} ({:#x})", v.to_bits());
        }
    }

    #[test]
    fn the_three_axes_step_as_each_alone() {
        let values = [
            0.0,
            -0.0,
            1e-45,
            -1e-45,
            1.5,
            -2.25,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
        ];
        let dirs = [1.0, -1.0, 0.0, -0.0, 1e-30, -7.0, f32::NAN];
        for (i, &x) in values.iter().enumerate() {
            for (j, &d) in dirs.iter().enumerate() {
                let (y, e) = (values[(i + 5) % values.len()], dirs[(j + 3) % dirs.len()]);
                let got = step_toward3(Vec3::new(x, y, -x), Vec3::new(d, e, d));
                let want = [step_toward(x, d), step_toward(y, e), step_toward(-x, d)];
                assert_eq!(
                    got.to_array().map(f32::to_bits),
                    want.map(f32::to_bits),
                    "v ({x}, {y}, {}) dir ({d}, {e}, {d})",
                    -x
                );
            }
        }
    }

    #[test]
    fn offset_origin_clears_the_error_box_on_the_side_of_the_direction() {
        let p = ErrPoint { p: Vec3::new(1e5, 2.0, -3.0), err: Vec3::splat(0.01) };
        let n = Vec3::Y;
        let up = p.offset_origin(n, Vec3::new(0.3, 1.0, 0.0));
        let down = p.offset_origin(n, Vec3::new(0.3, -1.0, 0.0));
        assert!(up.y > p.p.y + 0.01);
        assert!(down.y < p.p.y - 0.01);
        assert_eq!(up.x, p.p.x);
    }
}
