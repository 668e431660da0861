//! `tessera-bench bvh`: a generated scene of about a million triangles — a grid of displaced
//! spheres — its BVH build time, incoherent closest-hit rays per second (one core, then all),
//! the same rays through obvhs's stock traversal and triangle test (the yardstick of issue #9:
//! our watertight, tree-space-scaled path should keep ≥ 70 % of its speed), and the process's
//! peak resident memory.
//!
//! The scene is generated here (no mesh file is shipped): `spheres`² spheres on a grid, each a
//! UV sphere of `segments` × `segments / 2` quads whose radius wobbles by ±15 %
//! (sin 5θ · sin 7φ), so the triangles are small, numerous and not axis-aligned.
use rayon::prelude::*;
use std::f32::consts::PI;
use std::time::Instant;
use tessera_worker::tracer::accel::{Accel, BvhKind};
use tessera_worker::tracer::ray::Ray;
use glam::Vec3;

#[derive(Clone, Debug, clap::Args)]
pub struct BvhBench {
    /// Triangles to generate (rounded to whole spheres).
    #[arg(long, default_value_t = 1_000_000)]
    pub triangles: usize,
    /// Random rays to trace (origins inside the field, uniform directions).
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: usize,
}

pub fn run(b: &BvhBench) -> anyhow::Result<()> {
    let tris = sphere_field(b.triangles);
    let t0 = Instant::now();
    let accel = Accel::build(&tris, BvhKind::Wide);
    let build = t0.elapsed().as_secs_f64();
    println!("{} triangles (displaced spheres): wide BVH built in {:.3} s on {} threads", tris.len(), build, rayon::current_num_threads());
    let rays = random_rays(b.rays, field_size(b.triangles));
    let trace = |r: &Ray| accel.intersect(r, f32::INFINITY).is_some() as u64;
    let t1 = Instant::now();
    let hits_one: u64 = rays.iter().map(trace).sum();
    let one = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let hits_all: u64 = rays.par_iter().map(trace).sum();
    let all = t2.elapsed().as_secs_f64();
    anyhow::ensure!(hits_one == hits_all, "single- and multi-threaded traversal disagree");
    println!(
        "{} incoherent closest-hit rays ({:.0} % hit): {:.2} M rays/s on one core, {:.2} M rays/s on {} threads",
        rays.len(),
        100.0 * hits_one as f64 / rays.len() as f64,
        rays.len() as f64 / one / 1e6,
        rays.len() as f64 / all / 1e6,
        rayon::current_num_threads()
    );
    let stock = obvhs_stock(&tris, &rays);
    println!(
        "the same rays through obvhs's own traversal and Möller–Trumbore test: {:.2} M rays/s on one core ({} hits); ours is {:.0} % of it",
        rays.len() as f64 / stock.1 / 1e6,
        stock.0,
        100.0 * stock.1 / one
    );
    if let Some(kib) = peak_rss_kib() {
        println!("peak resident memory: {:.0} MiB", kib as f64 / 1024.0);
    }
    Ok(())
}

const SEGMENTS: usize = 128;

/// Triangles of one sphere: `SEGMENTS` × `SEGMENTS / 2` quads, two triangles each.
const PER_SPHERE: usize = SEGMENTS * SEGMENTS;

fn spheres_per_side(triangles: usize) -> usize {
    ((triangles as f64 / PER_SPHERE as f64).sqrt().ceil() as usize).max(1)
}

/// Edge length of the square field the spheres stand on (spheres 2 apart).
fn field_size(triangles: usize) -> f32 {
    spheres_per_side(triangles) as f32 * 2.0
}

fn sphere_field(triangles: usize) -> Vec<[Vec3; 3]> {
    let n = spheres_per_side(triangles);
    let count = triangles.div_ceil(PER_SPHERE).max(1);
    let mut tris = Vec::with_capacity(count * PER_SPHERE);
    for k in 0..count {
        let centre = Vec3::new((k % n) as f32 * 2.0 + 1.0, 1.0, (k / n) as f32 * 2.0 + 1.0);
        let point = |i: usize, j: usize| {
            let (theta, phi) = (PI * j as f32 / (SEGMENTS / 2) as f32, 2.0 * PI * i as f32 / SEGMENTS as f32);
            let r = 0.8 * (1.0 + 0.15 * (5.0 * theta).sin() * (7.0 * phi).sin());
            centre + r * Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())
        };
        for j in 0..SEGMENTS / 2 {
            for i in 0..SEGMENTS {
                let (a, b, c, d) = (point(i, j), point(i + 1, j), point(i, j + 1), point(i + 1, j + 1));
                tris.push([a, c, b]);
                tris.push([b, c, d]);
            }
        }
    }
    tris
}

/// Rays from random points of the field's bounding box in uniformly random directions
/// (a fixed xorshift stream, so every run traces the same rays).
fn random_rays(count: usize, size: f32) -> Vec<Ray> {
    let mut s = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..count)
        .map(|_| {
            let origin = Vec3::new(next() * size, next() * 2.0, next() * size);
            let (z, phi) = (1.0 - 2.0 * next(), 2.0 * PI * next());
            let r = (1.0 - z * z).max(0.0).sqrt();
            Ray::new(origin, Vec3::new(r * phi.cos(), z, r * phi.sin()))
        })
        .collect()
}

/// obvhs as its own benchmarks use it: a wide BVH of the same triangles (same build
/// parameters), its closest-hit traversal and its (not watertight) triangle test. Returns the
/// hits and the single-core seconds.
fn obvhs_stock(tris: &[[Vec3; 3]], rays: &[Ray]) -> (u64, f64) {
    use obvhs::triangle::Triangle;
    let tris: Vec<Triangle> = tris.iter().map(|t| Triangle { v0: t[0].into(), v1: t[1].into(), v2: t[2].into() }).collect();
    let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(&tris, obvhs::BvhBuildParams::medium_build(), &mut std::time::Duration::default());
    let t = Instant::now();
    let hits = rays
        .iter()
        .map(|r| {
            let ray = obvhs::ray::Ray::new(r.origin.into(), r.dir.into(), 0.0, f32::INFINITY);
            let mut hit = obvhs::ray::RayHit::none();
            bvh.ray_traverse(ray, &mut hit, |ray, id| tris[bvh.primitive_indices[id] as usize].intersect(ray)) as u64
        })
        .sum();
    (hits, t.elapsed().as_secs_f64())
}

/// VmHWM from /proc/self/status (Linux), in KiB.
fn peak_rss_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status.lines().find_map(|l| l.strip_prefix("VmHWM:")?.trim().strip_suffix("kB")?.trim().parse().ok())
}
