//! How far speed alone could take the time-to-quality ratio: the last line of each scene's
//! `tessera-bench mitsuba` comparison, when Mitsuba ran.
//!
//! The ratio is Tessera's relMSE·s over Mitsuba's. However fast its shading and sampling became,
//! Tessera's time per sample would still include tracing its rays. Suppose it traced them as
//! fast as Embree does (Mitsuba's traversal, the fastest CPU traversal that runs here) and spent
//! nothing at all on anything else. Its time would then shrink by the render's rays/s over
//! Embree's on the same rays, and so would the ratio at the same error. The product is a floor,
//! not a target: a ratio below it needs less error at equal spp (a better estimator), since no
//! amount of speed gets there.
//!
//! Both rates are one core's, measured on one render (`tessera-bench bvh`'s default size and
//! spp, `mis` + Sobol): the render timed alone (the faster of two runs), and its
//! logged rays through Embree ([`crate::embree`]). Rays per sample do not depend on the
//! image's size or the thread count, so one core's rates stand for the compared render's.
use crate::bvh::{RENDER_SIZE as SIZE, RENDER_SPP as SPP};
use crate::embree::{self, EmbreeRate};
use crate::same_rays::{log_rays, render_timed};
use tessera_render::tracer::Scene;

/// Prints the floor under each (spp, ratio) of bundled scene `name`, or why it was not measured.
pub fn say(python: &str, name: &str, scene: &Scene, ratios: &[(u32, f64)]) {
    if ratios.is_empty() {
        return;
    }
    match rates(python, name, scene) {
        Ok((render, embree)) => {
            let share = render / embree.rays_per_s;
            let floors: Vec<String> = ratios
                .iter()
                .map(|&(spp, ratio)| format!("{:.3} at {spp} spp", ratio * share))
                .collect();
            crate::say!(
                "speed alone: on one core the render traces {:.2} M rays/s and Embree {:.2} M rays/s of the same {} rays; with every ray traced at Embree's rate and nothing else costing any time, the ratio would be {:.0} % of the above: {} (target ≤ 0.33; lower needs less error at equal spp)",
                render / 1e6,
                embree.rays_per_s / 1e6,
                embree.rays,
                100.0 * share,
                floors.join(", ")
            );
        }
        Err(e) => crate::say!("speed alone: not measured ({e:#})"),
    }
}

/// (the render's rays per second, Embree's rate on the same rays), one core each.
fn rates(python: &str, name: &str, scene: &Scene) -> anyhow::Result<(f64, EmbreeRate)> {
    let rays = log_rays(scene, SIZE, SPP)?;
    // Embree first: where it cannot run, the two timed renders would be wasted.
    let embree = embree::trace(python, name, &rays)?;
    let fastest =
        render_timed(scene, SIZE, SPP, &rays)?.min(render_timed(scene, SIZE, SPP, &rays)?);
    Ok((rays.len() as f64 / fastest, embree))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn without_mitsuba_it_says_why_instead_of_failing() {
        let scene = tessera_render::scene::load_bytes(
            tessera_server::bundled::get("cornell-box").expect("bundled"),
            None,
        )
        .expect("loads");
        let err = rates("/nonexistent/python3", "cornell-box", &scene).expect_err("no interpreter");
        assert!(format!("{err:#}").contains("/nonexistent/python3"), "{err:#}");
        say("/nonexistent/python3", "cornell-box", &scene, &[(64, 1.7)]);
    }
}
