//! Rays and the floating-point error bounds that keep spawned rays off their own surface.
//!
//! Following pbrt-v4 ("Managing Rounding Error"), an intersection point carries a conservative
//! bound on its rounding error. A spawned ray starts just outside that error box along the
//! geometric normal, so it cannot re-hit the surface it leaves, at any scale, without a fixed
//! epsilon that would be too big near the origin and too small far from it.
use glam::Vec3;

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
        let mut offset = ng * d;
        if w.dot(ng) < 0.0 {
            offset = -offset;
        }
        let mut po = self.p + offset;
        for i in 0..3 {
            if offset[i] > 0.0 {
                po[i] = next_float_up(po[i]);
            } else if offset[i] < 0.0 {
                po[i] = next_float_down(po[i]);
            }
        }
        po
    }

    pub fn spawn(&self, ng: Vec3, dir: Vec3) -> Ray {
        Ray::new(self.offset_origin(ng, dir), dir)
    }

    /// A segment from this point towards `to` (offset at both ends); occluded iff a hit has t < 1.
    pub fn spawn_to(&self, ng: Vec3, to: &ErrPoint, to_ng: Vec3) -> Ray {
        let from = self.offset_origin(ng, to.p - self.p);
        let target = if to_ng == Vec3::ZERO { to.p } else { to.offset_origin(to_ng, from - to.p) };
        Ray::new(from, target - from)
    }
}

pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v >= 0.0 { bits + 1 } else { bits - 1 };
    f32::from_bits(bits)
}

pub fn next_float_down(v: f32) -> f32 {
    if v.is_infinite() && v < 0.0 {
        return v;
    }
    let v = if v == 0.0 { -0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v > 0.0 { bits - 1 } else { bits + 1 };
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_float_steps_one_ulp_across_zero() {
        assert_eq!(next_float_up(0.0), f32::from_bits(1));
        assert_eq!(next_float_up(-0.0), f32::from_bits(1));
        assert_eq!(next_float_down(0.0), -f32::from_bits(1));
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_float_down(-1.0), -1.0 - f32::EPSILON);
        assert!(next_float_up(f32::MAX).is_infinite());
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
