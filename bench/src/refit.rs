//! `tessera-bench bvh`'s last figures: an animation frame's BVH refitted from the previous
//! frame's against one built anew. Every vertex of the scene moves by a smooth wave (a
//! deformation, not a rigid motion: boxes grow and start to overlap, as they do when a mesh
//! deforms between frames); the refit keeps the first tree's topology and moves its boxes
//! ([`Accel::refit`]). Printed for waves of three amplitudes: both times, the random rays' rate
//! through the refitted tree against a tree built for the moved triangles, with the hits
//! checked equal (a refitted tree is slower to walk, never wrong), and the refitted tree's wear
//! ([`Accel::wear`]), by which a worker decides to build instead.
use crate::heap;
use glam::Vec3;
use std::f32::consts::TAU;
use std::time::Instant;
use tessera_render::tracer::accel::{Accel, BvhKind};
use tessera_render::tracer::ray::Ray;

/// The waves' amplitudes as fractions of the scene's largest extent, and their wavelength.
const AMPLITUDES: [f32; 3] = [0.002, 0.01, 0.05];
const WAVELENGTH: f32 = 0.125;

pub fn run(positions: &[[Vec3; 3]], rays: &[Ray]) -> anyhow::Result<()> {
    let before = heap::live();
    let plain = held(&Accel::build(positions, BvhKind::Wide), before);
    let t = Instant::now();
    let first = Accel::build_refittable(positions, BvhKind::Wide);
    let refittable_s = t.elapsed().as_secs_f64();
    let more = match heap::counting() {
        true => format!(
            ", holding {:.1} B per triangle more than a still's",
            (held(&first, before) as f64 - plain as f64) / positions.len() as f64
        ),
        false => String::new(),
    };
    crate::say!(
        "animation frames: the first frame's refittable BVH built in {}{more}; the next frame, every vertex moved by a wave, refitted and built ({} random rays, one core):",
        seconds(refittable_s),
        rays.len()
    );
    for amplitude in AMPLITUDES {
        let moved = waved(positions, amplitude);
        let t = Instant::now();
        let refitted = first
            .refit(&moved)
            .ok_or_else(|| anyhow::anyhow!("the moved scene's tree could not be refitted"))?;
        let refit_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let rebuilt = Accel::build(&moved, BvhKind::Wide);
        let build_s = t.elapsed().as_secs_f64();
        let (refitted_hits, refitted_s) = trace(&refitted, rays);
        let (rebuilt_hits, rebuilt_s) = trace(&rebuilt, rays);
        anyhow::ensure!(
            refitted_hits == rebuilt_hits,
            "the refitted and the rebuilt tree disagree on a hit"
        );
        let wear = refitted.wear().unwrap_or(f64::NAN);
        crate::say!(
            "  wave of {:.1} % of the scene's size: refit {}, build {} ({:.1}× faster); rays through the refitted tree {:.2} M/s, {:.0} % of the rebuilt tree's {:.2} M/s (same hits); wear {:.2} ({})",
            100.0 * amplitude,
            seconds(refit_s),
            seconds(build_s),
            build_s / refit_s,
            rays.len() as f64 / refitted_s / 1e6,
            100.0 * rebuilt_s / refitted_s,
            rays.len() as f64 / rebuilt_s / 1e6,
            wear,
            if refitted.worn() {
                "worn: a worker builds this frame"
            } else {
                "a worker refits this frame"
            },
        );
    }
    Ok(())
}

/// `s` seconds, in milliseconds below a hundredth of a second (a small scene's refit).
fn seconds(s: f64) -> String {
    match s {
        s if s < 0.01 => format!("{:.3} ms", s * 1e3),
        s => format!("{s:.3} s"),
    }
}

/// The heap bytes held now beyond `before`, while `_accel` is alive.
fn held(_accel: &Accel, before: usize) -> usize {
    heap::live().saturating_sub(before)
}

/// `positions` with every vertex moved along a wave through space.
fn waved(positions: &[[Vec3; 3]], amplitude: f32) -> Vec<[Vec3; 3]> {
    let (lo, hi) = crate::field::bounds(positions);
    let size = (hi - lo).max_element();
    let k = TAU / (WAVELENGTH * size);
    let shift = |v: Vec3| {
        v + amplitude * size * Vec3::new((k * v.y).sin(), (k * v.z).sin(), (k * v.x).sin())
    };
    positions.iter().map(|t| t.map(shift)).collect()
}

/// Each ray's closest hit (triangle and t's bits) through `accel` on one thread, and the seconds.
fn trace(accel: &Accel, rays: &[Ray]) -> (Vec<Option<(u32, u32)>>, f64) {
    let t = Instant::now();
    let hits = rays
        .iter()
        .map(|r| accel.intersect(r, f32::INFINITY).map(|h| (h.prim, h.t.to_bits())))
        .collect();
    (hits, t.elapsed().as_secs_f64())
}
