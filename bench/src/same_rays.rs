//! The last part of `tessera-bench bvh`: the render's own rays, logged by an untimed render,
//! traced alone through our BVH and through obvhs's, against the render itself. This is the
//! fair comparison with obvhs's own traversal: random
//! rays from anywhere in the scene's box are not what a path tracer traces (its rays start on
//! surfaces, camera rays are coherent, and shadow rays end at a light).
//!
//! The machine drifts by ±15 % within minutes, more than the differences measured, so the three
//! timings run back to back in rounds and each round gives its own ratios; the median round
//! and the range are printed.
use crate::bvh::{BvhBench, render_one_core};
use crate::overhead::settings;
use crate::stock::{StockBvh, ours_counted, ours_logged};
use std::path::Path;
use tessera_render::tracer::RenderOptions;
use tessera_render::tracer::accel::{Accel, WalkCounts};
use tessera_render::tracer::ray_log::{LoggedRay, RayLog, RayQuery};
use tessera_render::tracer::{Scene, render_tile};

/// One round's rates, in rays per second on one core.
#[derive(Clone, Copy, Debug)]
struct Round {
    render: f64,
    ours: f64,
    stock: f64,
    /// Ours on the closest-hit rays alone and on the shadow rays alone, as Embree is timed.
    ours_closest: f64,
    ours_shadow: f64,
}

pub fn run(scene: &Scene, stock: &StockBvh, b: &BvhBench) -> anyhow::Result<()> {
    let (size, spp, rounds) = (b.size, b.spp, b.rounds);
    let logged = log_rays(scene, size, spp)?;
    if let Some(path) = &b.save_rays {
        write_rays(path, &logged)?;
        crate::say!("wrote the render's {} rays to {}", logged.len(), path.display());
    }
    let (shadows, closests): (Vec<LoggedRay>, Vec<LoggedRay>) =
        logged.iter().partition(|r| r.query == RayQuery::Occluded);
    let shadow = shadows.len();
    let mut hits = (0, 0);
    let mut all = Vec::with_capacity(rounds);
    for _ in 0..rounds.max(1) {
        let secs = render_timed(scene, size, spp, &logged)?;
        let (ours_hits, ours_s) = ours_logged(&scene.accel, &logged);
        let (stock_hits, stock_s) = stock.trace_logged(&logged);
        hits = (ours_hits, stock_hits);
        let n = logged.len() as f64;
        let rate = |rays: &[LoggedRay]| rays.len() as f64 / ours_logged(&scene.accel, rays).1;
        all.push(Round {
            render: n / secs,
            ours: n / ours_s,
            stock: n / stock_s,
            ours_closest: rate(&closests),
            ours_shadow: rate(&shadows),
        });
    }
    crate::say!(
        "the render's own {} rays ({:.0} % shadow rays) traced alone, {} rounds back to back: ours {} M rays/s ({} hit), obvhs's {} M rays/s ({} hit), the render {} M rays/s",
        logged.len(),
        100.0 * shadow as f64 / logged.len().max(1) as f64,
        all.len(),
        spread(&all, |r| r.ours / 1e6),
        hits.0,
        spread(&all, |r| r.stock / 1e6),
        hits.1,
        spread(&all, |r| r.render / 1e6),
    );
    crate::say!(
        "path tracing = {} % of obvhs's rate on its own rays (target ≥ 70 %); tracing is {} % of the render's time",
        spread(&all, |r| 100.0 * r.render / r.stock),
        spread(&all, |r| 100.0 * r.render / r.ours),
    );
    say_walk(&scene.accel, &logged);
    say_embree(b, &logged, &all);
    Ok(())
}

/// The work of our walk per ray, by kind of ray.
fn say_walk(accel: &Accel, logged: &[LoggedRay]) {
    let (closest, shadow) = ours_counted(accel, logged);
    let per_ray = |c: &WalkCounts| {
        let (nodes, packets, triangles) = c.per_ray();
        format!("{nodes:.2} node tests, {packets:.2} packet tests ({triangles:.2} triangles)")
    };
    crate::say!(
        "our walk per ray: closest-hit rays {}; shadow rays {}",
        per_ray(&closest),
        per_ray(&shadow)
    );
}

/// The same rays through Mitsuba's traversal (Embree), when the scene is a glTF and Mitsuba is
/// installed; otherwise why not.
fn say_embree(b: &BvhBench, logged: &[LoggedRay], rounds: &[Round]) {
    let Some(scene) = &b.scene else {
        crate::say!(
            "Mitsuba's traversal (Embree) not measured: the generated field is not a glTF (try --scene)"
        );
        return;
    };
    match crate::embree::trace(&b.python, scene, logged) {
        Ok(e) => crate::say!(
            "the same rays through Mitsuba's traversal (Embree, one core): {:.2} M rays/s ({} hit); ours is {:.0} % of it (closest-hit rays: {}, shadow rays: {})",
            e.rays_per_s / 1e6,
            e.hits,
            100.0 * median(rounds, |r| r.ours) / e.rays_per_s,
            share(median(rounds, |r| r.ours_closest), e.closest_per_s),
            share(median(rounds, |r| r.ours_shadow), e.shadow_per_s),
        ),
        Err(e) => crate::say!("Mitsuba's traversal (Embree) not measured: {e:#}"),
    }
}

/// "ours X against Embree's Y M rays/s" for one kind of ray, or "none" when there were none.
fn share(ours: f64, embree: Option<f64>) -> String {
    match embree {
        Some(e) if ours.is_finite() => format!(
            "ours {:.2} against {:.2} M rays/s, {:.0} %",
            ours / 1e6,
            e / 1e6,
            100.0 * ours / e
        ),
        _ => "none".into(),
    }
}

/// A figure of every round, in increasing order.
fn sorted(rounds: &[Round], figure: impl Fn(&Round) -> f64) -> Vec<f64> {
    let mut v: Vec<f64> = rounds.iter().map(figure).collect();
    v.sort_by(f64::total_cmp);
    v
}

/// The median round's figure.
fn median(rounds: &[Round], figure: impl Fn(&Round) -> f64) -> f64 {
    let v = sorted(rounds, figure);
    v[v.len() / 2]
}

/// "median (min–max)" of a figure over the rounds.
fn spread(rounds: &[Round], figure: impl Fn(&Round) -> f64) -> String {
    let v = sorted(rounds, figure);
    let precision = if v[v.len() / 2] >= 20.0 { 0 } else { 2 };
    format!("{:.p$} ({:.p$}–{:.p$})", v[v.len() / 2], v[0], v[v.len() - 1], p = precision)
}

/// The seconds [`render_one_core`] takes, checking that it traced the rays [`log_rays`] logged
/// (the same render, so its rate is the rate of those rays).
pub(crate) fn render_timed(
    scene: &Scene,
    size: u32,
    spp: u32,
    logged: &[LoggedRay],
) -> anyhow::Result<f64> {
    let (traced, secs) = render_one_core(scene, size, spp)?;
    anyhow::ensure!(
        traced == logged.len() as u64,
        "the render traced {traced} rays, its log holds {}",
        logged.len()
    );
    Ok(secs)
}

/// Every ray of the render [`render_one_core`] times, in the order it traced them.
pub(crate) fn log_rays(scene: &Scene, size: u32, spp: u32) -> anyhow::Result<Vec<LoggedRay>> {
    let settings = settings(size)?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let log = RayLog::new();
    pool.install(|| {
        render_tile(
            scene,
            &settings,
            settings.full_frame(),
            0..spp,
            &RenderOptions { ray_log: Some(&log), ..RenderOptions::default() },
        )
    })
    .map_err(anyhow::Error::msg)?;
    Ok(log.take())
}

/// The `--save-rays` file: 8 little-endian f32 per ray (see [`BvhBench::save_rays`]).
pub(crate) fn write_rays(path: &Path, rays: &[LoggedRay]) -> anyhow::Result<()> {
    let mut bytes = Vec::with_capacity(rays.len() * 32);
    for r in rays {
        let kind = match r.query {
            RayQuery::Closest => 0.0f32,
            RayQuery::Occluded => 1.0,
        };
        for v in [r.ray.origin.to_array(), r.ray.dir.to_array()]
            .concat()
            .into_iter()
            .chain([r.t_max, kind])
        {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(path, bytes)
        .map_err(|e| anyhow::anyhow!("cannot write rays to {}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use tessera_render::tracer::ray::Ray;

    #[test]
    fn saved_rays_are_eight_little_endian_floats_each_in_order() {
        let rays = [
            LoggedRay {
                ray: Ray::new(Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, -1.0, 0.5)),
                t_max: f32::INFINITY,
                query: RayQuery::Closest,
            },
            LoggedRay {
                ray: Ray::new(Vec3::new(-4.0, 0.25, 9.0), Vec3::new(2.0, 0.0, -3.0)),
                t_max: 0.999,
                query: RayQuery::Occluded,
            },
        ];
        let dir = tessera_server::scratch::ScratchDir::new("saved-rays");
        std::fs::create_dir_all(dir.path()).unwrap();
        let path = dir.path().join("rays.bin");
        write_rays(&path, &rays).unwrap();
        let floats: Vec<f32> = std::fs::read(&path)
            .unwrap()
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(
            floats,
            [
                1.0,
                2.0,
                3.0,
                0.0,
                -1.0,
                0.5,
                f32::INFINITY,
                0.0,
                -4.0,
                0.25,
                9.0,
                2.0,
                0.0,
                -3.0,
                0.999,
                1.0
            ]
        );
        let err = write_rays(&dir.path().join("no-such-dir/rays.bin"), &rays).unwrap_err();
        assert!(err.to_string().starts_with("cannot write rays to "), "{err}");
    }
}
