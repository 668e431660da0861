//! Sampling warps and small shading helpers.
//!
//! Every warp maps random numbers in [0, 1) — including exactly 0 and exactly
//! 1 − 2⁻²⁴ — to finite output; hemisphere warps return unit vectors, and directions on
//! the horizon (z = 0) can occur at those boundaries for the caller to reject. Pdfs are
//! solid-angle densities.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, TAU};

/// Orthonormal basis with `n` as the local +z axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Duff et al. 2017, "Building an Orthonormal Basis, Revisited": no branch and no
    /// precision cliff near n = ±z (Frisvad's version breaks at n = −z). `n` must be unit.
    pub fn from_normal(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Frame {
            s: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            t: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }

    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Unit vector at polar angle (cos θ, sin θ) and azimuth 2π·u.
fn spherical(cos_theta: f32, sin_theta: f32, u: f32) -> Vec3 {
    let (sin_phi, cos_phi) = (TAU * u).sin_cos();
    Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta)
}

/// Cosine-weighted hemisphere by the seed's inversion θ = acos(√u.x), i.e. Malley's
/// method with the polar (not concentric) disk map. u.x = 0 gives a horizon direction.
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    // sin θ from 1 − u.x rather than 1 − cos²θ: exact at both ends of the range.
    spherical(u.x.sqrt(), (1.0 - u.x).sqrt(), u.y)
}

pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform hemisphere by inversion: z = u.x, φ = 2π u.y.
pub fn uniform_hemisphere(u: Vec2) -> Vec3 {
    // (1 − z)(1 + z) keeps sin θ accurate near the pole, where 1 − z² cancels.
    spherical(u.x, ((1.0 - u.x) * (1.0 + u.x)).sqrt(), u.y)
}

pub fn uniform_hemisphere_pdf() -> f32 {
    0.5 * FRAC_1_PI
}

/// Tries before giving up; each succeeds with probability π/6, so 64 failures in a row
/// (p ≈ 2·10⁻²¹) only happen for degenerate generators such as a constant one.
const REJECTION_TRIES: usize = 64;
/// Points this close to the centre carry a direction dominated by the 2⁻²³ input grid.
const REJECTION_MIN_LEN2: f32 = 1e-6;

/// The seed's rejection method: a uniform point in [−1, 1]³ kept if inside the unit ball,
/// normalised, and folded into z ≥ 0. After `REJECTION_TRIES` misses it returns +z, a
/// deterministic fallback that keeps the output finite (the density is then biased, but
/// only for generators that are not uniform anyway).
pub fn uniform_hemisphere_rejection(next: &mut impl FnMut() -> f32) -> Vec3 {
    for _ in 0..REJECTION_TRIES {
        let p = Vec3::new(2.0 * next() - 1.0, 2.0 * next() - 1.0, 2.0 * next() - 1.0);
        let len2 = p.length_squared();
        if len2 <= 1.0 && len2 > REJECTION_MIN_LEN2 {
            let d = p / len2.sqrt();
            return Vec3::new(d.x, d.y, d.z.abs());
        }
    }
    Vec3::Z
}

/// Barycentrics (b1, b2) uniform over a triangle, by the seed's fold of the unit square.
pub fn uniform_triangle(u: Vec2) -> (f32, f32) {
    if u.x + u.y > 1.0 { (1.0 - u.x, 1.0 - u.y) } else { (u.x, u.y) }
}

/// Phong lobe around +z: cos α = u.x^(1/(n+1)), φ = 2π u.y; needs n > −1.
pub fn phong_lobe(u: Vec2, n: f32) -> Vec3 {
    // Staying in log space keeps 1 − cos²α = −expm1(2 ln cos α) exact when the lobe is
    // narrower than the f32 spacing of cos α near 1 (n ~ 10⁶); ln 0 = −∞ gives the horizon.
    let ln_cos = u.x.ln() / (n + 1.0);
    let sin = (-(2.0 * ln_cos).exp_m1()).max(0.0).sqrt();
    spherical(ln_cos.exp(), sin, u.y)
}

pub fn phong_lobe_pdf(cos_alpha: f32, n: f32) -> f32 {
    if cos_alpha < 0.0 {
        return 0.0;
    }
    (n + 1.0) * 0.5 * FRAC_1_PI * pow_1m(1.0 - cos_alpha, n)
}

/// (1 − x)ⁿ for x ∈ [0, 1], 0 beyond. Callers pass x = 1 − cos α directly (e.g. from a
/// chord length) so that tiny x survives: powf on a rounded cos α loses it at n ~ 10⁶.
pub(crate) fn pow_1m(x: f32, n: f32) -> f32 {
    if x > 1.0 {
        0.0
    } else if n == 0.0 {
        1.0
    } else {
        (n * (-x.max(0.0)).ln_1p()).exp()
    }
}

/// Veach's power heuristic (β = 2) weight of strategy f. Written as 1/(1 + (g/f)²) so
/// that huge finite pdfs cannot overflow; delta strategies (infinite pdf) always win.
pub fn power_heuristic(nf: f32, f_pdf: f32, ng: f32, g_pdf: f32) -> f32 {
    if f_pdf == f32::INFINITY {
        return 1.0;
    }
    if g_pdf == f32::INFINITY {
        return 0.0;
    }
    let (f, g) = (nf * f_pdf, ng * g_pdf);
    if f.is_nan() || f <= 0.0 {
        return 0.0;
    }
    let r = g / f;
    let w = 1.0 / (1.0 + r * r);
    if w.is_nan() { 0.0 } else { w }
}

/// Mirror direction of `wo` about `n`; both point away from the surface.
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

/// Rec. 709 / sRGB-primaries luminance of a linear RGB colour.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracer::chi2::{self, Grid, Rng, U_MAX, edge_inputs};
    use glam::DVec3;

    const N: usize = 1_000_000;

    /// Hemisphere grid around +z sized for a Phong lobe of exponent n (σ ≈ 1/√n).
    fn grid(n: f32) -> Grid {
        Grid::hemisphere(DVec3::Z, (1.0 / (n as f64 + 1.0).sqrt()).min(1.0))
    }

    fn cosine_pdf(d: DVec3) -> f64 {
        cosine_hemisphere_pdf(d.z as f32) as f64
    }

    fn uniform_pdf(d: DVec3) -> f64 {
        let p = uniform_hemisphere_pdf() as f64;
        if d.z > 0.0 { p } else { 0.0 }
    }

    fn unit_upper(w: Vec3) -> bool {
        w.is_finite() && (w.length() - 1.0).abs() < 1e-6 && w.z >= 0.0
    }

    #[test]
    fn frame_is_orthonormal_right_handed_and_inverts() {
        let mut rng = Rng::new(1);
        let tricky = [Vec3::Z, -Vec3::Z, -Vec3::Y, Vec3::new(0.0, -1.0, -1e-8).normalize()];
        let sign = |x: f32| (x - 0.5).signum();
        let random = (0..1000).map(|_| uniform_hemisphere(rng.vec2()) * sign(rng.f32()));
        let v = Vec3::new(0.3, -0.5, 0.8);
        for n in tricky.into_iter().chain(random) {
            let f = Frame::from_normal(n);
            for (a, b) in [(f.s, f.t), (f.t, f.n), (f.n, f.s)] {
                let unit = (a.length() - 1.0).abs() < 1e-6;
                assert!(a.dot(b).abs() < 1e-6 && unit, "{n}");
            }
            assert!((f.s.cross(f.t) - f.n).length() < 1e-6, "{n}");
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-6, "{n}");
        }
    }

    #[test]
    fn chi2_hemisphere_warps() {
        let mut rng = Rng::new(2);
        let mut cosine = || Some(cosine_hemisphere(rng.vec2()));
        chi2::assert_chi2("cosine", &grid(0.0), N, &mut cosine, &cosine_pdf);
        let mut uniform = || Some(uniform_hemisphere(rng.vec2()));
        chi2::assert_chi2("uniform", &grid(0.0), N, &mut uniform, &uniform_pdf);
        let mut next = || rng.f32();
        let mut rejection = || Some(uniform_hemisphere_rejection(&mut next));
        chi2::assert_chi2("rejection", &grid(0.0), N, &mut rejection, &uniform_pdf);
    }

    #[test]
    fn chi2_phong_lobe() {
        let mut rng = Rng::new(4);
        for n in [1.0f32, 10.0, 1000.0] {
            let pdf = |d: DVec3| phong_lobe_pdf(d.z as f32, n) as f64;
            let mut lobe = || Some(phong_lobe(rng.vec2(), n));
            chi2::assert_chi2(&format!("phong lobe n={n}"), &grid(n), N, &mut lobe, &pdf);
        }
    }

    /// The lobe carried to an arbitrary axis by `Frame`, as the Phong BSDF uses it, binned
    /// on a full-sphere grid around that axis.
    #[test]
    fn chi2_phong_lobe_around_tilted_axis() {
        let (n, axis) = (300.0f32, Vec3::new(-0.6, 0.3, -0.74).normalize());
        let frame = Frame::from_normal(axis);
        let mut rng = Rng::new(7);
        let grid = Grid::sphere(axis.as_dvec3(), 1.0 / (n as f64 + 1.0).sqrt());
        let pdf = |d: DVec3| phong_lobe_pdf(d.as_vec3().dot(axis), n) as f64;
        let mut lobe = || Some(frame.to_world(phong_lobe(rng.vec2(), n)));
        chi2::assert_chi2("tilted phong lobe", &grid, N, &mut lobe, &pdf);
    }

    #[test]
    fn pdfs_integrate_to_one() {
        let check = |name: &str, grid: Grid, pdf: chi2::Pdf| {
            let (value, err) = chi2::integrate_sphere(&grid, pdf);
            chi2::assert_quadrature(name, value, 1.0, err);
        };
        check("cosine", grid(0.0), &cosine_pdf);
        check("uniform", grid(0.0), &uniform_pdf);
        for n in [0.0f32, 1.0, 10.0, 100.0] {
            let pdf = |d: DVec3| phong_lobe_pdf(d.z as f32, n) as f64;
            check(&format!("phong n={n}"), grid(n), &pdf);
        }
        // Beyond n ~ 100 an f32 cos α is a staircase at the lobe's scale, so feed the
        // chord form 1 − cos α = (x² + y²)/(1 + z) that the Phong BRDF itself uses.
        for n in [1e3f32, 1e4, 1e6] {
            let pdf = |d: DVec3| {
                let x = ((d.x * d.x + d.y * d.y) / (1.0 + d.z)) as f32;
                ((n + 1.0) * 0.5 * FRAC_1_PI * pow_1m(x, n)) as f64
            };
            check(&format!("phong n={n}"), grid(n), &pdf);
        }
    }

    /// Against f64 evaluations of the same inversion at the same random numbers.
    #[test]
    fn phong_lobe_stays_accurate_at_n_1e6() {
        let n = 1e6f32;
        let mut rng = Rng::new(5);
        let inputs = (0..100_000).map(|_| rng.vec2());
        for u in inputs.chain([Vec2::ZERO, Vec2::splat(U_MAX)]) {
            let w = phong_lobe(u, n);
            assert!(unit_upper(w), "{u} -> {w}");
            let ln_cos = (u.x as f64).ln() / (n as f64 + 1.0);
            let sin_ref = (-(2.0 * ln_cos).exp_m1()).sqrt();
            let sin = (w.x as f64).hypot(w.y as f64);
            assert!((sin - sin_ref).abs() <= 1e-3 * sin_ref, "{sin} vs {sin_ref}");
            let lobe = (n as f64 * (w.z as f64).ln()).exp();
            let pdf_ref = (n as f64 + 1.0) / std::f64::consts::TAU * lobe;
            let pdf = phong_lobe_pdf(w.z, n) as f64;
            assert!((pdf - pdf_ref).abs() <= 1e-3 * pdf_ref, "{pdf} vs {pdf_ref}");
        }
    }

    #[test]
    fn boundary_random_numbers_give_finite_output() {
        for u in edge_inputs() {
            for w in [cosine_hemisphere(u), uniform_hemisphere(u)] {
                assert!(unit_upper(w), "{u} -> {w}");
            }
            for n in [0.0, 1.0, 1e6] {
                assert!(unit_upper(phong_lobe(u, n)), "{u}, n = {n}");
            }
            let (b1, b2) = uniform_triangle(u);
            assert!(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0, "{u}: {b1}, {b2}");
            let mut toggle = [u.x, u.y].into_iter().cycle();
            let w = uniform_hemisphere_rejection(&mut || toggle.next().unwrap());
            assert!(unit_upper(w), "{u} -> {w}");
        }
        for c in [0.0, U_MAX, 1.0] {
            assert!(phong_lobe_pdf(c, 0.0).is_finite() && phong_lobe_pdf(c, 1e6).is_finite());
        }
    }

    /// Index of the sub-triangle holding (b1, b2) when the triangle is cut into m² equal
    /// ones: square (i, j) of the m × m grid, lower or upper half.
    fn sub_triangle(b1: f32, b2: f32, m: usize) -> usize {
        let (x, y) = (b1 as f64 * m as f64, b2 as f64 * m as f64);
        let (i, j) = ((x as usize).min(m - 1), (y as usize).min(m - 1));
        let upper = x.fract() + y.fract() >= 1.0;
        (i * m + j) * 2 + upper as usize
    }

    #[test]
    fn chi2_uniform_triangle() {
        let m = 16;
        let mut rng = Rng::new(6);
        let mut obs = vec![0.0; 2 * m * m];
        for _ in 0..N {
            let (b1, b2) = uniform_triangle(rng.vec2());
            obs[sub_triangle(b1, b2, m)] += 1.0;
        }
        // Lower halves with i + j ≤ m − 1 and upper halves with i + j ≤ m − 2 are inside.
        let inside = |c: usize| (c / 2) / m + (c / 2) % m + c % 2 < m;
        let each = N as f64 / (m * m) as f64;
        let exp: Vec<f64> = (0..obs.len()).map(|c| each * inside(c) as u8 as f64).collect();
        chi2::assert_counts("uniform triangle", &obs, &exp, N);
    }

    #[test]
    fn power_heuristic_edge_cases() {
        let inf = f32::INFINITY;
        assert_eq!(power_heuristic(1.0, inf, 1.0, inf), 1.0);
        assert_eq!(power_heuristic(1.0, 3.0, 1.0, inf), 0.0);
        assert_eq!(power_heuristic(0.0, 0.0, 0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(1.0, 0.0, 1.0, 2.0), 0.0);
        assert_eq!(power_heuristic(1.0, 2.0, 1.0, 0.0), 1.0);
        assert_eq!(power_heuristic(1.0, 1e30, 1.0, 1e30), 0.5);
        assert_eq!(power_heuristic(1.0, 1e-30, 1.0, 1e30), 0.0);
        let f = power_heuristic(1.0, 0.3, 2.0, 0.7);
        assert!((f + power_heuristic(2.0, 0.7, 1.0, 0.3) - 1.0).abs() < 1e-6);
        assert!((f - 0.09 / (0.09 + 1.96)).abs() < 1e-6);
    }

    #[test]
    fn reflect_and_luminance() {
        let wo = Vec3::new(0.6, 0.0, 0.8);
        assert!((reflect(wo, Vec3::Z) - Vec3::new(-0.6, 0.0, 0.8)).length() < 1e-6);
        assert!((luminance(Vec3::ONE) - 1.0).abs() < 1e-6);
        assert_eq!(luminance(Vec3::Y), 0.7152);
    }
}
