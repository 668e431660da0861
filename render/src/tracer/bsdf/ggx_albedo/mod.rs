//! # Directional albedo of the single-scattering GGX lobe, tabulated
//!
//! Two functions of the view cosine μ = wo.z and the perceptual roughness r (α = r²,
//! clamped to [`MIN_ALPHA`]), both integrals of the lobe of [`Ggx::eval_reflect`](super::Ggx):
//! - `E(μ, r)    = ∫ D·G2/(4 μo μi) · μi dωi`, the albedo of a white (F = 1) GGX mirror;
//!   below 1 because light scattered more than once between microfacets is not modelled
//!   (1 − ln 2 ≈ 0.693 at r = 1, μ = 1);
//! - `E_fw(μ, r) = ∫ (1 − wo·h)⁵ · D·G2/(4 μo μi) · μi dωi`, the same weighted by
//!   Schlick's Fresnel weight, so that a Schlick layer F = f0 + (f90 − f0)(1 − wo·h)⁵
//!   reflects exactly `f0·E + (f90 − f0)·E_fw`.
//!
//! [`Pbr`](super::Pbr) uses them to give its diffuse base only the energy its specular
//! layer leaves (Kulla & Conty 2017, "Revisiting Physically Based Shading at Imageworks";
//! the OpenPBR dielectric base uses the same albedo scaling).
//!
//! The table is 32 × 32 nodes, bilinear in (√μ, r): node i of the μ axis is μ = (i/31)²,
//! which puts nodes every ~1° near grazing where E changes fastest; node 0 repeats node 1
//! (μ ≈ 0.001, 89.94°), whose value over-estimates E below it (E falls towards the
//! horizon), the safe side for energy. The values are generated, not typed: the tests
//! below integrate every node in f64 (stratified visible-normal sampling, where the
//! integrand is G2/G1) and compare with `ggx_albedo_table.rs`; running them with
//! `TESSERA_WRITE_TABLES=1` rewrites that file.
use super::ggx::MIN_ALPHA;

mod table;

/// Nodes per axis.
pub const N: usize = 32;

/// (E, E_fw) at view cosine `mu` and perceptual roughness `roughness` (both clamped to [0, 1]).
#[allow(clippy::manual_clamp)] // see below
pub fn lookup(mu: f32, roughness: f32) -> (f32, f32) {
    // max/min rather than clamp: they map NaN to the bound instead of propagating it.
    let x = mu.max(0.0).min(1.0).sqrt() * (N - 1) as f32;
    let y = roughness.max(0.0).min(1.0) * (N - 1) as f32;
    let (i, fx) = split(x);
    let (j, fy) = split(y);
    (bilerp(&table::E, i, j, fx, fy), bilerp(&table::E_FW, i, j, fx, fy))
}

fn split(x: f32) -> (usize, f32) {
    let i = (x as usize).min(N - 2);
    (i, x - i as f32)
}

fn bilerp(t: &[[f32; N]; N], i: usize, j: usize, fx: f32, fy: f32) -> f32 {
    let row = |r: &[f32; N]| r[i] + (r[i + 1] - r[i]) * fx;
    let (a, b) = (row(&t[j]), row(&t[j + 1]));
    a + (b - a) * fy
}

/// GGX α of roughness node j.
pub fn node_alpha(j: usize) -> f64 {
    let r = j as f64 / (N - 1) as f64;
    (r * r).max(MIN_ALPHA as f64)
}

/// View cosine of μ node i (node 0 is evaluated at node 1; see the module doc).
pub fn node_mu(i: usize) -> f64 {
    let s = i.max(1) as f64 / (N - 1) as f64;
    s * s
}

#[cfg(test)]
mod tests;
