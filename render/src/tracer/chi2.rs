//! Test-only statistics for the sampling code (pbrt-v4 style).
//!
//! `assert_chi2` bins sampled directions on a (θ, φ) grid around an axis, over the sphere
//! or the hemisphere. Rows are warped, θ(t) = k·atan(s·tan(tπ/2)) with k = 2 (sphere) or
//! 1 (hemisphere), so that a lobe of angular width ~s gets half of them; s = 1 is uniform
//! in θ. Expected counts come from adaptive Simpson integration of the pdf over each cell;
//! failed samples (None) form one extra cell expecting the pdf mass missing from the grid.
//! Cells expecting < 5 samples are pooled and the p-value comes from the regularized
//! incomplete gamma function. Every hypothesis test in the suite is rejected at
//! `SIGNIFICANCE` with a Šidák correction over `SUITE_TESTS`.

use glam::{DVec3, Vec2, Vec3};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// A density over directions, evaluated in f64.
pub type Pdf<'a> = &'a dyn Fn(DVec3) -> f64;
/// Draws one direction, or None when the sampler fails.
pub type Sampler<'a> = &'a mut dyn FnMut() -> Option<Vec3>;

/// Pass, or a message saying which hypothesis was rejected and why.
pub type Outcome = Result<(), String>;

/// Largest value the renderer's generators return: 1 − 2⁻²⁴.
pub const U_MAX: f32 = 1.0 - 1.0 / 16_777_216.0;
pub const SIGNIFICANCE: f64 = 0.01;
/// Number of hypothesis tests (`assert_p` calls) a full run makes; update when adding one.
pub const SUITE_TESTS: u32 = 116;
const THETA_CELLS: usize = 32;
const PHI_CELLS: usize = 64;

/// Per-test level such that the whole suite falsely fails with probability `SIGNIFICANCE`.
pub fn alpha() -> f64 {
    1.0 - (1.0 - SIGNIFICANCE).powf(1.0 / SUITE_TESTS as f64)
}

/// Every pairing of 0, ½ and `U_MAX`: the boundary inputs of a 2D warp.
pub fn edge_inputs() -> [Vec2; 9] {
    let e = [0.0, 0.5, U_MAX];
    [0, 1, 2, 3, 4, 5, 6, 7, 8].map(|k| Vec2::new(e[k / 3], e[k % 3]))
}

/// Errs, with `detail` for diagnosis, when p-value `p` rejects the hypothesis `name`.
pub fn test_p(name: &str, p: f64, detail: &str) -> Outcome {
    let msg = || format!("{name}: rejected, p = {p:.2e} < {:.2e}; {detail}", alpha());
    if p >= alpha() { Ok(()) } else { Err(msg()) }
}

pub fn assert_p(name: &str, p: f64, detail: &str) {
    test_p(name, p, detail).unwrap_or_else(|e| panic!("{e}"));
}

/// PCG32 (O'Neill 2014, XSH-RR 64/32), fixed stream.
pub struct Rng(u64);

impl Rng {
    const MUL: u64 = 6364136223846793005;
    const INC: u64 = 1442695040888963407;

    pub fn new(seed: u64) -> Rng {
        let mut r = Rng(seed.wrapping_add(Self::INC));
        r.next_u32();
        r
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.0;
        self.0 = old.wrapping_mul(Self::MUL).wrapping_add(Self::INC);
        ((((old >> 18) ^ old) >> 27) as u32).rotate_right((old >> 59) as u32)
    }

    /// On the 2⁻²⁴ grid of [0, 1), like the renderer's sampler, so U_MAX is reachable.
    pub fn f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    pub fn vec2(&mut self) -> Vec2 {
        Vec2::new(self.f32(), self.f32())
    }
}

/// Two-sided p-value of a standard normal deviate (z² is χ² with one degree of freedom).
pub fn normal_p(z: f64) -> f64 {
    gamma_q(0.5, 0.5 * z * z)
}

/// p-value of the hypothesis "true mean ≤ bound" given an estimate and its standard error.
pub fn mean_at_most_p(mean: f64, std_error: f64, bound: f64) -> f64 {
    let z = (mean - bound) / std_error.max(f64::MIN_POSITIVE);
    if z <= 0.0 { 1.0 } else { 0.5 * normal_p(z) }
}

/// ln Γ(a) for a ∈ ½ℕ (all that χ² tests need), by Γ(a) = (a − 1)·Γ(a − 1) down to
/// Γ(1) = 1 or Γ(½) = √π.
fn ln_gamma_half_integer(a: f64) -> f64 {
    assert!(a > 0.0 && (2.0 * a).fract() == 0.0, "ln Γ({a}) unsupported");
    let mut sum = if a.fract() == 0.0 { 0.0 } else { 0.5 * PI.ln() };
    let mut x = a - 1.0;
    while x > 0.0 {
        sum += x.ln();
        x -= 1.0;
    }
    sum
}

/// Regularized upper incomplete gamma Q(a, x), a ∈ ½ℕ (Numerical Recipes §6.2: series
/// below x = a + 1, Lentz continued fraction above).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let prefactor = (-x + a * x.ln() - ln_gamma_half_integer(a)).exp();
    if x < a + 1.0 {
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        return (1.0 - sum * prefactor).max(0.0);
    }
    let tiny = 1e-300;
    let (mut b, mut c, mut d) = (x + 1.0 - a, 1.0 / tiny, 1.0 / (x + 1.0 - a));
    let mut h = d;
    for i in 1..10_000 {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        d = 1.0 / if d.abs() < tiny { tiny } else { d };
        c = b + an / c;
        c = if c.abs() < tiny { tiny } else { c };
        h *= d * c;
        if (d * c - 1.0).abs() < 1e-16 {
            break;
        }
    }
    prefactor * h
}

/// χ² statistic and degrees of freedom with pbrt's pooling of low-expectation cells.
/// Errs if a cell with zero expectation received more than a rounding-level count.
pub fn chi2_stat(obs: &[f64], exp: &[f64], n: usize) -> Result<(f64, usize), String> {
    let mut order: Vec<usize> = (0..obs.len()).collect();
    order.sort_by(|&a, &b| exp[a].total_cmp(&exp[b]));
    let (mut stat, mut dof, mut pool_o, mut pool_e) = (0.0, 0usize, 0.0, 0.0);
    for i in order {
        if exp[i] == 0.0 {
            if obs[i] > n as f64 * 1e-5 {
                return Err(format!("{} samples where none expected", obs[i]));
            }
        } else if exp[i] < 5.0 || (pool_e > 0.0 && pool_e < 5.0) {
            pool_o += obs[i];
            pool_e += exp[i];
        } else {
            stat += (obs[i] - exp[i]).powi(2) / exp[i];
            dof += 1;
        }
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e).powi(2) / pool_e;
        dof += 1;
    }
    if dof < 2 {
        return Err(format!("only {dof} usable cells"));
    }
    Ok((stat, dof - 1))
}

pub fn test_counts(name: &str, obs: &[f64], exp: &[f64], n: usize) -> Outcome {
    let (stat, dof) = chi2_stat(obs, exp, n).map_err(|e| format!("{name}: {e}"))?;
    let mut worst: Vec<usize> = (0..obs.len()).filter(|&i| exp[i] > 0.0).collect();
    worst.sort_by(|&a, &b| {
        let r = |i: usize| (obs[i] - exp[i]).powi(2) / exp[i];
        r(b).total_cmp(&r(a))
    });
    let cell = |&i: &usize| format!("#{i}: {} vs {:.1}", obs[i], exp[i]);
    let worst: Vec<String> = worst.iter().take(4).map(cell).collect();
    let detail = format!("χ² = {stat:.1}, dof = {dof}, worst cells {worst:?}");
    test_p(name, gamma_q(0.5 * dof as f64, 0.5 * stat), &detail)
}

pub fn assert_counts(name: &str, obs: &[f64], exp: &[f64], n: usize) {
    test_counts(name, obs, exp, n).unwrap_or_else(|e| panic!("{e}"));
}

/// Direction grid around `axis`, over the sphere or over the hemisphere (θ ≤ π/2) —
/// the latter puts the horizon on a cell edge; see the module doc for the θ warp.
pub struct Grid {
    s: DVec3,
    t: DVec3,
    n: DVec3,
    scale: f64,
    /// 2 for the sphere, 1 for the hemisphere: θ(t) = k·atan(s·tan(tπ/2)).
    k: f64,
}

impl Grid {
    pub fn sphere(axis: DVec3, scale: f64) -> Grid {
        Grid::new(axis, scale, 2.0)
    }

    /// For pdfs that vanish below the plane orthogonal to `axis`.
    pub fn hemisphere(axis: DVec3, scale: f64) -> Grid {
        Grid::new(axis, scale, 1.0)
    }

    fn new(axis: DVec3, scale: f64, k: f64) -> Grid {
        let n = axis.normalize();
        let s = n.any_orthonormal_vector();
        let t = n.cross(s);
        Grid { s, t, n, scale, k }
    }

    /// Grid cells plus one for directions outside a hemisphere grid.
    fn cells(&self) -> usize {
        THETA_CELLS * PHI_CELLS + 1
    }

    fn theta(&self, t: f64) -> f64 {
        self.k * (self.scale * (t * FRAC_PI_2).tan()).atan()
    }

    fn cell_of(&self, d: DVec3) -> usize {
        let (x, y, z) = (d.dot(self.s), d.dot(self.t), d.dot(self.n));
        let theta = x.hypot(y).atan2(z);
        if theta > self.k * FRAC_PI_2 {
            return self.cells() - 1;
        }
        let t = ((theta / self.k).tan() / self.scale).atan() / FRAC_PI_2;
        let u = y.atan2(x).rem_euclid(TAU) / TAU;
        let i = ((t * THETA_CELLS as f64) as usize).min(THETA_CELLS - 1);
        let j = ((u * PHI_CELLS as f64) as usize).min(PHI_CELLS - 1);
        i * PHI_CELLS + j
    }

    /// ∫ pdf dω over every cell (0 outside a hemisphere grid) and a bound on the total
    /// quadrature error.
    pub fn integrate_cells(&self, pdf: Pdf, tol: f64) -> (Vec<f64>, f64) {
        let g = |theta: f64, phi: f64| {
            let (st, ct) = theta.sin_cos();
            let (sp, cp) = phi.sin_cos();
            pdf(self.s * (st * cp) + self.t * (st * sp) + self.n * ct) * st
        };
        let row = |i: usize| self.theta(i as f64 / THETA_CELLS as f64);
        let col = |j: usize| j as f64 * TAU / PHI_CELLS as f64;
        let mut err = 0.0;
        let mut cells: Vec<f64> = (0..self.cells() - 1)
            .map(|c| {
                let (i, j) = (c / PHI_CELLS, c % PHI_CELLS);
                let (v, e) = simpson(&g, [row(i), row(i + 1), col(j), col(j + 1)], tol, 6);
                err += e;
                v
            })
            .collect();
        cells.push(0.0);
        (cells, err)
    }
}

/// Adaptive 2D Simpson on the rectangle [x0, x1] × [y0, y1]. Nodes on its edges are
/// nudged inward so that a discontinuity on a cell edge (the horizon) is seen from inside.
fn simpson(g: &dyn Fn(f64, f64) -> f64, r: [f64; 4], tol: f64, depth: u32) -> (f64, f64) {
    const NODE: [f64; 5] = [1e-9, 0.25, 0.5, 0.75, 1.0 - 1e-9];
    const W4: [f64; 5] = [1.0 / 12.0, 4.0 / 12.0, 2.0 / 12.0, 4.0 / 12.0, 1.0 / 12.0];
    const W2: [f64; 5] = [1.0 / 6.0, 0.0, 4.0 / 6.0, 0.0, 1.0 / 6.0];
    let [x0, x1, y0, y1] = r;
    let (mut s4, mut s2) = (0.0, 0.0);
    for a in 0..5 {
        for b in 0..5 {
            let v = g(x0 + (x1 - x0) * NODE[a], y0 + (y1 - y0) * NODE[b]);
            s4 += W4[a] * W4[b] * v;
            s2 += W2[a] * W2[b] * v;
        }
    }
    let area = (x1 - x0) * (y1 - y0);
    let (s4, err) = (s4 * area, (s4 - s2).abs() * area);
    if err <= tol || depth == 0 {
        return (s4, err);
    }
    let (xm, ym) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let (xs, ys) = ([x0, xm, x1], [y0, ym, y1]);
    let (mut sum, mut err) = (0.0, 0.0);
    for k in 0..4 {
        let quadrant = [xs[k % 2], xs[k % 2 + 1], ys[k / 2], ys[k / 2 + 1]];
        let (v, e) = simpson(g, quadrant, 0.25 * tol, depth - 1);
        (sum, err) = (sum + v, err + e);
    }
    (sum, err)
}

/// ∫ pdf dω over the sphere and a bound on the quadrature error.
pub fn integrate_sphere(grid: &Grid, pdf: Pdf) -> (f64, f64) {
    let (cells, err) = grid.integrate_cells(pdf, 1e-9);
    (cells.iter().sum(), err)
}

/// Relative rounding bound of an f32 pdf: a few dozen operations of ≤ 2⁻²⁴ each.
const F32_PDF_REL: f64 = 64.0 / 16_777_216.0;

/// Quadrature result equals `expected` within its error bound plus f32 rounding.
pub fn assert_quadrature(name: &str, value: f64, expected: f64, err: f64) {
    let tol = err + F32_PDF_REL * expected.abs();
    let msg = format!("{name}: ∫ = {value:.8}, expected {expected:.8} ± {tol:.1e}");
    assert!((value - expected).abs() <= tol, "{msg}");
}

/// Density of the half vector h = normalize(wo + wi) at `h` when wi has density
/// `pdf_wi`: pdf_wi(wi)·|dωi/dωh| with |dωi/dωh| = 4 wo·h (Walter et al. 2007).
pub fn half_vector_density(wo: Vec3, h: DVec3, pdf_wi: impl Fn(Vec3) -> f32) -> f64 {
    let (o, cos) = (wo.as_dvec3(), wo.as_dvec3().dot(h));
    let wi = (2.0 * cos * h - o).as_vec3();
    if cos <= 0.0 {
        return 0.0;
    }
    pdf_wi(wi) as f64 * 4.0 * cos
}

/// χ² goodness of fit of `n` draws of `sample` against `pdf` on `grid`.
pub fn test_chi2(name: &str, grid: &Grid, n: usize, sample: Sampler, pdf: Pdf) -> Outcome {
    let mut obs = vec![0.0; grid.cells() + 1];
    for _ in 0..n {
        let cell = sample().map_or(grid.cells(), |d| {
            assert!(d.is_finite(), "{name}: non-finite sample {d}");
            grid.cell_of(d.as_dvec3())
        });
        obs[cell] += 1.0;
    }
    // 0.01 expected samples per cell keeps quadrature error far below the counting noise.
    let (mut exp, _) = grid.integrate_cells(pdf, 0.01 / n as f64);
    let mass: f64 = exp.iter().sum();
    exp.iter_mut().for_each(|e| *e *= n as f64);
    exp.push(((1.0 - mass) * n as f64).max(0.0));
    test_counts(name, &obs, &exp, n)
}

pub fn assert_chi2(name: &str, grid: &Grid, n: usize, sample: Sampler, pdf: Pdf) {
    test_chi2(name, grid, n, sample, pdf).unwrap_or_else(|e| panic!("{e}"));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracer::sampling::{cosine_hemisphere, phong_lobe, phong_lobe_pdf};

    #[test]
    fn incomplete_gamma_matches_tables() {
        // χ² quantiles x with upper tail q at dof 1, 10, 100; at dof 2, Q is e^{−x/2}.
        let dofs = [1.0, 10.0, 100.0];
        let xs = [3.841_458_820_694_124, 23.209_251_158_954_36, 149.449_252_779_038_6];
        for (k, q) in [0.05, 0.01, 0.001].into_iter().enumerate() {
            let got = gamma_q(0.5 * dofs[k], 0.5 * xs[k]);
            assert!((got - q).abs() < 1e-9 * q, "dof {}: {got}", dofs[k]);
        }
        assert!((gamma_q(1.0, 3.5) - (-3.5f64).exp()).abs() < 1e-14);
        assert!((normal_p(1.959_963_984_540_054) - 0.05).abs() < 1e-12);
    }

    /// The harness must be able to fail: cosine samples against the uniform pdf, and a
    /// Phong lobe sampled with n = 10 against the pdf for n = 11.
    #[test]
    fn chi2_rejects_a_wrong_pdf() {
        let mut rng = Rng::new(99);
        let uniform = |d: DVec3| if d.z > 0.0 { 0.5 / PI } else { 0.0 };
        let mut cosine = || Some(cosine_hemisphere(rng.vec2()));
        let grid = Grid::hemisphere(DVec3::Z, 1.0);
        assert!(test_chi2("gross", &grid, 100_000, &mut cosine, &uniform).is_err());
        let n11 = |d: DVec3| phong_lobe_pdf(d.z as f32, 11.0) as f64;
        let mut lobe = || Some(phong_lobe(rng.vec2(), 10.0));
        let grid = Grid::hemisphere(DVec3::Z, 0.3);
        assert!(test_chi2("subtle", &grid, 1_000_000, &mut lobe, &n11).is_err());
    }
}
