//! `tessera-bench mitsuba --scene a,b,…`: time to quality over a set of scenes.
//!
//! One scene's ratio says how Tessera fares on what that scene stresses: the Cornell box is
//! multi-bounce diffuse light, where both renderers' estimators agree and the ratio is one of
//! raw speed; `many-lights` is light selection, `absorption` glass and media, `glossy` metals.
//! A farm renders all kinds, so the summary gives each scene's ratio (Tessera's best relMSE·s
//! over Mitsuba's best, at each spp) and their geometric mean, the mean that treats "twice as
//! fast" and "half as fast" as equal and opposite. Scenes Mitsuba cannot render as Tessera does
//! are listed without a ratio and left out of the mean.
//!
//! ```sh
//! tessera-bench mitsuba --scene cornell-box,cornell-small-light,glossy,phong,absorption,many-lights \
//!     --size 128 --reference-spp 4096 --repeats 2
//! ```
use super::mitsuba::{Row, best};

/// Tessera's best relMSE·s over Mitsuba's on `scene` at `spp`, if both rendered it.
fn ratio(rows: &[Row], scene: &str, spp: u32) -> Option<f64> {
    let of_scene = || rows.iter().filter(|r| r.scene == scene);
    let (t, m) = (best(of_scene(), "tessera", spp)?, best(of_scene(), "mitsuba", spp)?);
    Some(t.product() / m.product())
}

/// The geometric mean of `values`, None if there are none.
pub fn geometric_mean(values: &[f64]) -> Option<f64> {
    (!values.is_empty())
        .then(|| (values.iter().map(|v| v.ln()).sum::<f64>() / values.len() as f64).exp())
}

/// Prints each scene's ratio at each spp and their geometric mean.
pub fn print_summary(rows: &[Row], scenes: &[String], spp: &[u32]) {
    let header: Vec<String> = spp.iter().map(|s| format!("{s:>9} spp")).collect();
    crate::say!(
        "\ntime to quality, Tessera's best relMSE·s ÷ Mitsuba 3's best (below 1: Tessera sooner)"
    );
    crate::say!("  {:<22}{}", "scene", header.join(""));
    for scene in scenes {
        let cells: Vec<String> = spp
            .iter()
            .map(|&s| {
                ratio(rows, scene, s).map_or(format!("{:>13}", "—"), |r| format!("{r:>13.3}"))
            })
            .collect();
        let alone = if cells.iter().all(|c| c.trim() == "—") { "  (Tessera alone)" } else { "" };
        crate::say!("  {:<22}{}{alone}", scene, cells.join(""));
    }
    let means: Vec<String> = spp
        .iter()
        .map(|&s| {
            let ratios: Vec<f64> =
                scenes.iter().filter_map(|scene| ratio(rows, scene, s)).collect();
            geometric_mean(&ratios).map_or(format!("{:>13}", "—"), |g| format!("{g:>13.3}"))
        })
        .collect();
    let counted =
        scenes.iter().filter(|scene| spp.iter().any(|&s| ratio(rows, scene, s).is_some())).count();
    crate::say!("  {:<22}{}", format!("geometric mean ({counted})"), means.join(""));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(scene: &str, renderer: &'static str, spp: u32, seconds: f64, rel_mse: f64) -> Row {
        Row {
            scene: scene.into(),
            renderer,
            rays_per_s: None,
            sampler: "s".into(),
            spp,
            seconds,
            rel_mse,
        }
    }

    #[test]
    fn each_scene_is_compared_with_its_own_rows_and_the_mean_is_geometric() {
        let rows = [
            row("a", "tessera", 64, 1.0, 4.0),
            row("a", "tessera", 64, 1.0, 2.0),
            row("a", "mitsuba", 64, 1.0, 1.0),
            row("b", "tessera", 64, 1.0, 1.0),
            row("b", "mitsuba", 64, 2.0, 4.0),
            row("c", "tessera", 64, 1.0, 1.0),
        ];
        assert_eq!(ratio(&rows, "a", 64), Some(2.0), "the best of each renderer on that scene");
        assert_eq!(ratio(&rows, "b", 64), Some(0.125));
        assert_eq!(ratio(&rows, "c", 64), None, "Tessera alone");
        assert_eq!(ratio(&rows, "a", 256), None);
        let g = geometric_mean(&[2.0, 0.125]).unwrap();
        assert!((g - 0.5).abs() < 1e-12, "{g}");
        assert_eq!(geometric_mean(&[]), None);
    }
}
