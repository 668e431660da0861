//! `tessera-bench bvh`: a generated scene of about a million triangles — a grid of displaced
//! spheres — or a bundled scene (`--scene cornell-box`): its BVH build time, incoherent
//! closest-hit rays per second (one core, then all), the same rays through obvhs's stock
//! traversal and triangle test, a path-traced render's rays per second on one core against both
//! (the target: rendering keeps ≥ 70 % of the traversal rate, i.e. shading and sampling cost
//! less than tracing), and the process's peak resident memory. Last, the render's own rays
//! (logged by a second render) are traced alone through both BVHs: the fair comparison, since
//! random rays are not the rays a path tracer traces (see [`crate::stock`]); for a glTF
//! scene, where Mitsuba 3 is installed, also through its traversal, Embree
//! ([`crate::embree`]). Last, an animation frame's BVH refitted against one built anew
//! ([`crate::refit`]).
//!
//! The field is generated ([`crate::field`]; no mesh file is shipped).
use crate::field::{bounds, field_parts, sphere_field};
use crate::heap;
use crate::overhead::settings;
use crate::stock::StockBvh;
use crate::{refit, same_rays};
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::path::PathBuf;
use std::time::Instant;
use tessera_render::tracer::RenderOptions;
use tessera_render::tracer::ray::Ray;
use tessera_render::tracer::{Scene, render_tile};

/// The path-traced render's default width and height, and samples per pixel: a few hundred
/// thousand rays, enough for stable rates in a second or two (also `speed_floor.rs`'s render).
pub const RENDER_SIZE: u32 = 128;
pub const RENDER_SPP: u32 = 16;

#[derive(Clone, Debug, clap::Args)]
pub struct BvhBench {
    /// Triangles to generate (rounded to whole spheres).
    #[arg(long, default_value_t = 1_000_000)]
    pub triangles: usize,
    /// Random rays to trace (origins inside the scene's bounds, uniform directions).
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: usize,
    /// A bundled scene (or a glTF path) instead of the generated field.
    #[arg(long)]
    pub scene: Option<String>,
    /// The render's width and height in pixels (`mis` + Sobol, one thread).
    #[arg(long, default_value_t = RENDER_SIZE)]
    pub size: u32,
    /// The render's samples per pixel.
    #[arg(long, default_value_t = RENDER_SPP)]
    pub spp: u32,
    /// Rounds of (render, its rays through our BVH, through obvhs's), timed back to back so
    /// that the machine's drift touches all three alike; the median round is reported.
    #[arg(long, default_value_t = 5)]
    pub rounds: usize,
    /// Also write the render's own rays to this file, for another renderer's traversal to trace
    /// (`tests/reference/embree_rays.py`): per ray, 8 little-endian f32: origin, direction,
    /// t_max (in units of the direction), and 0 for a closest-hit or 1 for a shadow ray.
    #[arg(long)]
    pub save_rays: Option<PathBuf>,
    /// Python interpreter with the `mitsuba` package, to trace the render's rays through
    /// Mitsuba's traversal (Embree) too; a bundled scene or glTF only.
    #[arg(long, default_value = "python3")]
    pub python: String,
}

pub fn run(b: &BvhBench) -> anyhow::Result<()> {
    // Its peak is reported as what a worker holds: with the allocator set as a worker's.
    tessera_server::purge::for_scene_builders();
    // Random rays start anywhere in the geometry's box (for the field: the spheres', not the light's).
    // The global thread pool's own allocations are not the scene's: start it first.
    rayon::current_num_threads();
    let start = heap::live();
    let (scene, build, label, ray_box, mesh_bytes) = match &b.scene {
        Some(name) => {
            heap::reset_peak();
            let t = Instant::now();
            let scene = tessera_server::bundled::load(name)?;
            let build = t.elapsed().as_secs_f64();
            let ray_box = bounds(&scene.mesh.positions);
            (scene, build, format!("{name}, loaded"), ray_box, None)
        }
        None => {
            let spheres = sphere_field(b.triangles);
            let ray_box = bounds(&spheres);
            let (mesh, materials, camera) = field_parts(spheres);
            let mesh_bytes = heap::live().saturating_sub(start);
            heap::reset_peak();
            let t = Instant::now();
            let scene = Scene::new(mesh, materials, vec![], vec![camera], vec![]);
            (
                scene,
                t.elapsed().as_secs_f64(),
                "displaced spheres under a light".to_string(),
                ray_box,
                Some(mesh_bytes),
            )
        }
    };
    let accel = &scene.accel;
    crate::say!(
        "{} triangles ({label}): scene (wide BVH, lights, bounds) built in {:.3} s on {} threads",
        scene.mesh.len(),
        build,
        rayon::current_num_threads()
    );
    say_heap(start, mesh_bytes, &scene);
    let rays = random_rays(b.rays, ray_box);
    let trace = |r: &Ray| accel.intersect(r, f32::INFINITY).is_some() as u64;
    let t1 = Instant::now();
    let hits_one: u64 = rays.iter().map(trace).sum();
    let one = rays.len() as f64 / t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let hits_all: u64 = rays.par_iter().map(trace).sum();
    let all = rays.len() as f64 / t2.elapsed().as_secs_f64();
    anyhow::ensure!(hits_one == hits_all, "single- and multi-threaded traversal disagree");
    crate::say!(
        "{} incoherent closest-hit rays ({:.0} % hit): {:.2} M rays/s on one core, {:.2} M rays/s on {} threads",
        rays.len(),
        100.0 * hits_one as f64 / rays.len() as f64,
        one / 1e6,
        all / 1e6,
        rayon::current_num_threads()
    );
    let (traced, secs) = render_one_core(&scene, b.size, b.spp)?;
    if let Some(m) = tessera_worker::memory::process_memory() {
        crate::say!(
            "peak resident memory, the scene built, traced and rendered (what a worker holds, plus the {} MiB of random rays): {:.0} MiB",
            (rays.len() * size_of::<Ray>()) >> 20,
            m.peak_rss_bytes as f64 / f64::from(1 << 20)
        );
    }
    let stock = StockBvh::new(&scene.mesh.positions);
    let (stock_hits, stock_s) = stock.trace(&rays);
    let stock_rate = rays.len() as f64 / stock_s;
    crate::say!(
        "the same rays through obvhs's own traversal and Möller–Trumbore test: {:.2} M rays/s on one core ({stock_hits} hits); ours is {:.0} % of it",
        stock_rate / 1e6,
        100.0 * one / stock_rate
    );
    let rendering = traced as f64 / secs;
    crate::say!(
        "path tracing it ({0}×{0}, {1} spp, mis + Sobol, camera + bounce + shadow rays): {2:.2} M rays/s on one core ({3:.1} rays per sample) = {4:.0} % of our traversal rate above, {5:.0} % of obvhs's",
        b.size,
        b.spp,
        rendering / 1e6,
        traced as f64 / (f64::from(b.size * b.size) * f64::from(b.spp)),
        100.0 * rendering / one,
        100.0 * rendering / stock_rate
    );
    drop(rays);
    same_rays::run(&scene, &stock, b)?;
    drop(stock);
    refit::run(&scene.mesh.positions, &random_rays(b.rays.min(250_000), ray_box))
}

/// Renders the whole frame on a pool of one thread; returns the rays traced and the seconds.
pub(crate) fn render_one_core(scene: &Scene, size: u32, spp: u32) -> anyhow::Result<(u64, f64)> {
    let settings = settings(size)?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let t = Instant::now();
    let sums = pool
        .install(|| {
            render_tile(scene, &settings, settings.full_frame(), 0..spp, &RenderOptions::default())
        })
        .map_err(anyhow::Error::msg)?;
    Ok((sums.rays, t.elapsed().as_secs_f64()))
}

/// Rays from random points of the box `(lo, hi)` in uniformly random directions (a fixed
/// xorshift stream, so every run traces the same rays).
fn random_rays(count: usize, (lo, hi): (Vec3, Vec3)) -> Vec<Ray> {
    let mut s = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..count)
        .map(|_| {
            let origin = lo + (hi - lo) * Vec3::new(next(), next(), next());
            let (z, phi) = (1.0 - 2.0 * next(), 2.0 * PI * next());
            let r = (1.0 - z * z).max(0.0).sqrt();
            Ray::new(origin, Vec3::new(r * phi.cos(), z, r * phi.sin()))
        })
        .collect()
}

/// What the scene holds on the heap and how high the heap went while it was built (counted from
/// `start`, the bytes held before the study; `generated`: the generated mesh's bytes, held
/// before the build started).
fn say_heap(start: usize, generated: Option<usize>, scene: &Scene) {
    if !heap::counting() {
        return;
    }
    let per = |bytes: usize| bytes as f64 / scene.mesh.len().max(1) as f64;
    let (held, peak, mesh) = (
        heap::live().saturating_sub(start),
        heap::peak().saturating_sub(start),
        scene.mesh.heap_bytes(),
    );
    let rest = held.saturating_sub(mesh);
    match generated {
        Some(generated) => crate::say!(
            "heap: the mesh {} as generated ({:.0} B per triangle), {} in the scene ({:.0} B per triangle: positions, normals (one per triangle when flat), materials; no UVs); the rest of the scene {} ({:.0} B per triangle: BVH, triangles in packets, face normals, lights); the build peaked at {} with the mesh ({:.0} B per triangle)",
            amount(generated),
            per(generated),
            amount(mesh),
            per(mesh),
            amount(rest),
            per(rest),
            amount(peak),
            per(peak)
        ),
        None => crate::say!(
            "heap: the loaded scene holds {} ({:.0} B per triangle; its mesh {:.0} B); loading and building peaked at {}",
            amount(held),
            per(held),
            per(mesh),
            amount(peak)
        ),
    }
}

/// `bytes` in MiB, or KiB for a small scene.
fn amount(bytes: usize) -> String {
    match bytes {
        b if b >= 10 << 20 => format!("{:.0} MiB", b as f64 / f64::from(1 << 20)),
        b => format!("{:.0} KiB", b as f64 / 1024.0),
    }
}
