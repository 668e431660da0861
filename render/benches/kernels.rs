//! Kernel benchmarks (criterion): the pieces a path sample is made of, on the Cornell box.
//!
//! `cargo bench -p tessera-render --bench kernels` (add `-- sampler` etc. to filter). Whole
//! renders and the comparison with Mitsuba 3 are `tessera-bench` subcommands; these isolate one
//! kernel each, so a change to one shows up without the noise of the rest:
//! - `sampler/*`: one 2D draw (Sobol, independent) at a fresh (pixel, sample) per iteration;
//! - `accel/closest` and `accel/occluded`: rays from points on the box's surfaces in random
//!   directions (the rays a path tracer traces after the camera), watertight test included;
//! - `path/li`: one whole camera path sample (`mis` + Sobol, the matte kernel the Cornell box
//!   selects), all of the above and shading;
//! - `path/tile`: a 16×16 tile at 16 samples per pixel (a unit's default batch) through
//!   `render_tile` on one thread, as renders take them (a pixel's samples in a row, its sampler
//!   seeds kept): the kernel closest to whole frames.
use criterion::{Criterion, Throughput, black_box, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use std::path::Path;
use tessera_render::tracer::RenderOptions;
use tessera_render::tracer::Scene;
use tessera_render::tracer::film::Tile;
use tessera_render::tracer::integrator::{Integrator, PathSettings};
use tessera_render::tracer::kernel::Kernel;
use tessera_render::tracer::ray::Ray;
use tessera_render::tracer::render::{RenderSettings, render_tile};
use tessera_render::tracer::sampler::{Sampler, SamplerKind};

fn cornell() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box.gltf");
    tessera_render::scene::load_bytes(&std::fs::read(&path).expect("scenes/cornell-box.gltf"), None)
        .expect("scene")
}

/// A fixed xorshift stream of numbers in [0, 1).
fn uniform_stream() -> impl FnMut() -> f32 {
    let mut s = 0x9e37_79b9_7f4a_7c15_u64;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Rays leaving random points of random triangles (slightly inside the box) in random directions.
fn surface_rays(scene: &Scene, count: usize) -> Vec<Ray> {
    let mut u = uniform_stream();
    let tris = &scene.mesh.positions;
    let centre = tris.iter().flatten().fold(Vec3::ZERO, |a, v| a + *v) / (3 * tris.len()) as f32;
    (0..count)
        .map(|_| {
            let t = &tris[((u() * tris.len() as f32) as usize).min(tris.len() - 1)];
            let (a, b) = (u(), u());
            let (b1, b2) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
            let p = t[0] * (1.0 - b1 - b2) + t[1] * b1 + t[2] * b2;
            let origin = p + (centre - p) * 1e-3;
            let (z, phi) = (1.0 - 2.0 * u(), std::f32::consts::TAU * u());
            let r = (1.0 - z * z).max(0.0).sqrt();
            Ray::new(origin, Vec3::new(r * phi.cos(), z, r * phi.sin()))
        })
        .collect()
}

fn sampler(c: &mut Criterion) {
    let mut g = c.benchmark_group("sampler");
    for kind in [SamplerKind::Sobol, SamplerKind::Independent] {
        let mut i = 0u32;
        g.bench_function(kind.name(), |b| {
            b.iter(|| {
                i = i.wrapping_add(1);
                let mut s = Sampler::start(kind, 7, i & 255, i >> 8, i);
                black_box(s.get_2d())
            })
        });
    }
    g.finish();
}

fn accel(c: &mut Criterion) {
    let scene = cornell();
    let rays = surface_rays(&scene, 4096);
    let mut g = c.benchmark_group("accel");
    let mut k = 0usize;
    g.bench_function("closest", |b| {
        b.iter(|| {
            k = (k + 1) % rays.len();
            black_box(scene.accel.intersect(&rays[k], f32::INFINITY))
        })
    });
    g.bench_function("occluded", |b| {
        b.iter(|| {
            k = (k + 1) % rays.len();
            black_box(scene.accel.occluded(&rays[k], 0.25))
        })
    });
    g.finish();
}

fn path(c: &mut Criterion) {
    let scene = cornell();
    let camera = scene.camera(None).expect("camera").raster(256, 256);
    let integrator = Integrator::new(&scene, Vec3::ZERO, PathSettings::default());
    let mut i = 0u32;
    c.bench_function("path/li", |b| {
        b.iter(|| {
            i = i.wrapping_add(1);
            let (px, py) = (i % 256, (i / 256) % 256);
            let mut s = Sampler::start(SamplerKind::Sobol, 1, px, py, i >> 16);
            let jitter: Vec2 = s.get_2d();
            black_box(integrator.li_for::<Kernel<0>>(camera.ray(px, py, jitter), &mut s))
        })
    });
}

fn tile(c: &mut Criterion) {
    let scene = cornell();
    let settings = RenderSettings {
        width: 256,
        height: 256,
        seed: 1,
        sampler: SamplerKind::Sobol,
        path: PathSettings::default(),
        background: Vec3::ZERO,
        camera: None,
    };
    // The middle of the frame: walls, both boxes and the floor.
    let (tile, spp) = (Tile { x0: 120, y0: 120, w: 16, h: 16 }, 16);
    let one_thread = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    let mut g = c.benchmark_group("path");
    g.throughput(Throughput::Elements(u64::from(tile.w * tile.h * spp)));
    g.bench_function("tile", |b| {
        b.iter(|| {
            one_thread.install(|| {
                black_box(
                    render_tile(&scene, &settings, tile, 0..spp, &RenderOptions::default())
                        .expect("tile"),
                )
            })
        })
    });
    g.finish();
}

criterion_group!(benches, sampler, accel, path, tile);
criterion_main!(benches);
