//! The render's own rays through Mitsuba 3's traversal, which is Embree: the last line of
//! `tessera-bench bvh --scene NAME` when Mitsuba is installed.
//!
//! `tessera-bench mitsuba` compares whole renders; this says how much of the difference is
//! traversal. The rays [`crate::same_rays`] logged are written to a scratch file and
//! traced by `tests/reference/embree_rays.py` (one thread, the median of its rounds) in the same
//! scene loaded from its glTF, every surface matte (materials do not change what a ray hits,
//! except alpha masks: Embree sees masked surfaces as opaque, so on `alpha-mask` its hit count
//! differs from ours and the rates compare different work; both hit counts are printed).
//! Without Mitsuba, or for the generated field (not a glTF), the study says why and goes on.
use crate::mitsuba::python_script;
use crate::same_rays::write_rays;
use tessera_render::tracer::ray_log::LoggedRay;

const INSTALL: &str = "needs `pip install mitsuba numpy` and Debian's libllvm19";

/// What the script measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmbreeRate {
    pub rays: u64,
    pub hits: u64,
    pub rays_per_s: f64,
    /// The closest-hit rays' and the shadow rays' own rates (None: no such rays).
    pub closest_per_s: Option<f64>,
    pub shadow_per_s: Option<f64>,
}

/// Traces `rays` of the bundled scene (or glTF path) `scene` through Mitsuba's Embree.
pub fn trace(python: &str, scene: &str, rays: &[LoggedRay]) -> anyhow::Result<EmbreeRate> {
    let scratch = tessera_server::scratch::ScratchDir::new("bench-embree");
    std::fs::create_dir_all(scratch.path())?;
    let file = scratch.path().join("rays.bin");
    write_rays(&file, rays)?;
    let output = python_script(python, "embree_rays.py")?
        .args(["--scene", scene, "--any-material", "--rays"])
        .arg(&file)
        .output()
        .map_err(|e| anyhow::anyhow!("cannot start {python}: {e} ({INSTALL})"))?;
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        let last = stderr.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no message");
        anyhow::bail!("{last} ({INSTALL})");
    }
    parse_total(&String::from_utf8_lossy(&output.stdout))
}

/// Reads the script's lines `closest-hit: …`, `shadow: …` and, last, `… all N rays, H hit,
/// R M rays/s`.
fn parse_total(stdout: &str) -> anyhow::Result<EmbreeRate> {
    let line = stdout
        .lines()
        .rev()
        .find(|l| l.contains(" all "))
        .ok_or_else(|| anyhow::anyhow!("the Embree script printed no total"))?;
    let kind = |prefix: &str| {
        stdout.lines().find(|l| l.starts_with(prefix)).map(|l| number_before(l, "M")).transpose()
    };
    Ok(EmbreeRate {
        rays: number_before(line, "rays")? as u64,
        hits: number_before(line, "hit")? as u64,
        rays_per_s: number_before(line, "M")? * 1e6,
        closest_per_s: kind("closest-hit:")?.map(|r| r * 1e6),
        shadow_per_s: kind("shadow:")?.map(|r| r * 1e6),
    })
}

/// The number just before the first word `word` (a trailing comma ignored) in `line`.
fn number_before(line: &str, word: &str) -> anyhow::Result<f64> {
    let words: Vec<&str> = line.split_whitespace().collect();
    let i = words
        .iter()
        .position(|w| w.trim_end_matches(',') == word)
        .ok_or_else(|| anyhow::anyhow!("no {word:?} in {line:?}"))?;
    let number = words
        .get(i.wrapping_sub(1))
        .ok_or_else(|| anyhow::anyhow!("no number before {word:?} in {line:?}"))?;
    number.parse().map_err(|_| anyhow::anyhow!("{number:?} is not a number in {line:?}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use std::os::unix::fs::PermissionsExt;
    use tessera_render::tracer::ray::Ray;
    use tessera_render::tracer::ray_log::RayQuery;

    #[test]
    fn the_scripts_total_line_is_read() {
        let out = "closest-hit: 10 rays, 8 hit, 17.43 M rays/s (median of 5 rounds, 1 thread)\n\
                   mitsuba 3.9.1 llvm_ad_rgb (Embree: True): all 1598232 rays, 919386 hit, 20.30 M rays/s\n";
        let rate = EmbreeRate {
            rays: 1_598_232,
            hits: 919_386,
            rays_per_s: 20.30e6,
            closest_per_s: Some(17.43e6),
            shadow_per_s: None,
        };
        assert_eq!(parse_total(out).unwrap(), rate);
        assert!(parse_total("closest-hit: 10 rays\n").is_err(), "no total line");
        assert!(
            parse_total("mitsuba: all x rays, 3 hit, 1 M rays/s")
                .unwrap_err()
                .to_string()
                .contains("\"x\" is not a number")
        );
    }

    /// A stand-in for python3 that checks it was handed the ray file and answers as the script.
    #[test]
    fn the_rays_reach_the_script_and_its_failure_is_said() {
        let dir = tessera_server::scratch::ScratchDir::new("bench-embree-fake");
        std::fs::create_dir_all(dir.path()).unwrap();
        let fake = |name: &str, body: &str| {
            let path = dir.path().join(name);
            std::fs::write(&path, format!("#!/bin/sh\n{body}\n")).unwrap();
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
            path.to_str().unwrap().to_owned()
        };
        // $1 is the script, then --scene NAME --any-material --rays FILE: FILE is $6.
        let answers = fake(
            "python-ok",
            r#"n=$(( $(wc -c < "$6") / 32 )); echo "mitsuba 3.9.1 llvm_ad_rgb (Embree: True): all $n rays, 1 hit, 2.50 M rays/s""#,
        );
        let ray =
            LoggedRay { ray: Ray::new(Vec3::ZERO, Vec3::X), t_max: 1.0, query: RayQuery::Occluded };
        let rate = trace(&answers, "cornell-box", &[ray; 3]).unwrap();
        assert_eq!(
            rate,
            EmbreeRate {
                rays: 3,
                hits: 1,
                rays_per_s: 2.5e6,
                closest_per_s: None,
                shadow_per_s: None
            }
        );
        let fails =
            fake("python-fails", "echo 'ModuleNotFoundError: No module named mitsuba' >&2; exit 1");
        let err = trace(&fails, "cornell-box", &[ray]).unwrap_err().to_string();
        assert!(
            err.starts_with(
                "ModuleNotFoundError: No module named mitsuba (needs `pip install mitsuba"
            ),
            "{err}"
        );
    }
}
