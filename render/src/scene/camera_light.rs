//! A glTF node's perspective camera (with the thin lens of its `extras`) and its
//! `KHR_lights_punctual` light, placed by the node's world transform and validated.
use super::SceneError;
use crate::tracer::camera::Camera;
use crate::tracer::light::Light;
use glam::{Mat4, Vec3};

pub(super) fn camera(
    node: &gltf::Node,
    cam: &gltf::Camera,
    p: &gltf::camera::Perspective,
    world: Mat4,
) -> Result<Camera, SceneError> {
    let yfov = p.yfov();
    if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
        return Err(SceneError::new(format!(
            "camera {}: yfov {yfov} is not in (0, π)",
            cam.index()
        )));
    }
    let name =
        cam.name().or(node.name()).map_or_else(|| format!("camera{}", cam.index()), str::to_string);
    let (aperture_radius, focus_distance) =
        lens(cam).map_err(|e| SceneError::new(format!("camera {}: {e}", cam.index())))?;
    Ok(Camera { name, to_world: world, yfov, aperture_radius, focus_distance })
}

/// The thin lens from the camera's `extras`: `{"aperture_radius": metres, "focus_distance":
/// metres}`; a pinhole (radius 0) when absent. A non-zero aperture needs a focus distance.
fn lens(cam: &gltf::Camera) -> Result<(f32, f32), String> {
    let Some(raw) = cam.extras() else { return Ok((0.0, 1.0)) };
    let v: serde_json::Value =
        serde_json::from_str(raw.get()).map_err(|e| format!("extras: {e}"))?;
    let num = |key: &str| match v.get(key) {
        None => Ok(None),
        Some(x) => {
            x.as_f64().map(|f| Some(f as f32)).ok_or(format!("extras.{key} must be a number"))
        }
    };
    let aperture = num("aperture_radius")?.unwrap_or(0.0);
    if !(aperture.is_finite() && aperture >= 0.0) {
        return Err(format!("extras.aperture_radius {aperture} must be finite and ≥ 0"));
    }
    match num("focus_distance")? {
        Some(f) if f.is_finite() && f > 0.0 => Ok((aperture, f)),
        Some(f) => Err(format!("extras.focus_distance {f} must be finite and > 0")),
        None if aperture > 0.0 => Err("extras.aperture_radius needs extras.focus_distance".into()),
        None => Ok((0.0, 1.0)),
    }
}

pub(super) fn punctual(
    light: &gltf::khr_lights_punctual::Light,
    world: Mat4,
) -> Result<Light, SceneError> {
    use gltf::khr_lights_punctual::Kind;
    let i = light.index();
    let colour = Vec3::from(light.color()) * light.intensity();
    if !colour.is_finite() || colour.min_element() < 0.0 {
        return Err(SceneError::new(format!(
            "light {i}: colour × intensity must be finite and ≥ 0"
        )));
    }
    let position = world.transform_point3(Vec3::ZERO);
    let axis = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
    if axis == Vec3::ZERO {
        return Err(SceneError::new(format!("light {i}: node transform collapses its direction")));
    }
    Ok(match light.kind() {
        Kind::Point => Light::Point { position, intensity: colour },
        Kind::Directional => Light::Directional { dir: axis, irradiance: colour },
        Kind::Spot { inner_cone_angle, outer_cone_angle } => {
            if !(0.0 <= inner_cone_angle
                && inner_cone_angle < outer_cone_angle
                && outer_cone_angle <= std::f32::consts::FRAC_PI_2)
            {
                return Err(SceneError::new(format!(
                    "light {i}: spot cone angles must satisfy 0 ≤ inner < outer ≤ π/2 (got {inner_cone_angle}, {outer_cone_angle})"
                )));
            }
            Light::Spot {
                position,
                axis,
                intensity: colour,
                cos_inner: inner_cone_angle.cos(),
                cos_outer: outer_cone_angle.cos(),
            }
        }
    })
}
