//! Perspective camera (glTF convention: looks down local −Z, +Y up, +X right): a pinhole, or a
//! thin lens when `aperture_radius` > 0 (depth of field).
//!
//! Thin lens: the lens is a disc of radius `aperture_radius` (metres) centred on the camera
//! origin, perpendicular to the view direction; every ray through a pixel position passes
//! through the same point on the plane `focus_distance` metres in front of the lens, so that
//! plane is sharp and a point at depth z images to a disc (circle of confusion) of diameter
//! 2·aperture·|z − focus|/z on the focal plane.
//!
//! The aspect ratio always comes from the render size, never from the glTF file, so a job can
//! render any resolution without distortion. Pixel (0, 0) is the top-left corner; a sample at
//! raster position (x + u, y + v) jitters uniformly inside its pixel (box filter).
use crate::tracer::ray::Ray;
use glam::{Mat4, Vec2, Vec3};

/// A camera a render asked for that the scene does not have.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CameraError {
    #[error("no camera named {name:?} (the scene has {names:?})")]
    Unknown { name: String, names: Vec<String> },
    #[error("the scene has no perspective camera")]
    Missing,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub name: String,
    /// Camera-to-world transform (rotation and translation; scale is ignored for directions).
    pub to_world: Mat4,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// Lens radius in metres; 0 is a pinhole.
    pub aperture_radius: f32,
    /// Distance in metres from the lens to the plane in focus (along the view direction).
    pub focus_distance: f32,
}

/// A camera bound to an image size, ready to generate rays.
#[derive(Clone, Copy, Debug)]
pub struct RasterCamera {
    origin: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    half_w: f32,
    half_h: f32,
    inv_size: Vec2,
    aperture: f32,
    focus: f32,
}

impl Camera {
    pub fn pinhole(name: &str, to_world: Mat4, yfov: f32) -> Camera {
        Camera { name: name.to_string(), to_world, yfov, aperture_radius: 0.0, focus_distance: 1.0 }
    }

    pub fn has_depth_of_field(&self) -> bool {
        self.aperture_radius > 0.0
    }

    pub fn raster(&self, width: u32, height: u32) -> RasterCamera {
        let half_h = (self.yfov * 0.5).tan();
        let aspect = width as f32 / height as f32;
        let m = self.to_world;
        RasterCamera {
            origin: m.transform_point3(Vec3::ZERO),
            right: m.transform_vector3(Vec3::X).normalize(),
            up: m.transform_vector3(Vec3::Y).normalize(),
            forward: m.transform_vector3(-Vec3::Z).normalize(),
            half_w: half_h * aspect,
            half_h,
            inv_size: Vec2::new(1.0 / width as f32, 1.0 / height as f32),
            aperture: self.aperture_radius,
            focus: self.focus_distance,
        }
    }
}

impl RasterCamera {
    /// The primary ray through raster position `pixel + jitter` (jitter in [0,1)²); normalized direction.
    pub fn ray(&self, px: u32, py: u32, jitter: Vec2) -> Ray {
        let ndc = (Vec2::new(px as f32, py as f32) + jitter) * self.inv_size;
        let sx = (2.0 * ndc.x - 1.0) * self.half_w;
        let sy = (1.0 - 2.0 * ndc.y) * self.half_h;
        let dir = (self.forward + self.right * sx + self.up * sy).normalize();
        Ray::new(self.origin, dir)
    }

    /// As [`ray`](Self::ray) through the thin lens: `u_lens` picks a point on the lens disc
    /// (concentric mapping), and the ray aims at where the pinhole ray meets the focal plane.
    pub fn ray_lens(&self, px: u32, py: u32, jitter: Vec2, u_lens: Vec2) -> Ray {
        let pinhole = self.ray(px, py, jitter);
        if self.aperture <= 0.0 {
            return pinhole;
        }
        let focus = pinhole.at(self.focus / pinhole.dir.dot(self.forward));
        let lens = concentric_disk(u_lens) * self.aperture;
        let origin = self.origin + self.right * lens.x + self.up * lens.y;
        Ray::new(origin, (focus - origin).normalize())
    }
}

/// Uniform point on the unit disc (Shirley–Chiu concentric mapping).
fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_down_minus_z_and_corners_span_the_fov() {
        let cam = Camera::pinhole("c", Mat4::IDENTITY, 1.0);
        let r = cam.raster(200, 100);
        let centre = r.ray(100, 50, Vec2::ZERO);
        assert!((centre.dir - Vec3::NEG_Z).length() < 1e-6);
        let top = r.ray(100, 0, Vec2::ZERO).dir;
        assert!((top.y.atan2(-top.z) - 0.5).abs() < 1e-5, "top edge at yfov/2");
        let left = r.ray(0, 50, Vec2::ZERO).dir;
        assert!((left.x / -left.z + 2.0 * 0.5f32.tan()).abs() < 1e-5, "aspect 2 widens x");
    }

    #[test]
    fn node_rotation_turns_the_view() {
        // 180° about Y: the camera looks down +Z with +X on the image's left.
        let to_world = Mat4::from_rotation_translation(
            glam::Quat::from_xyzw(0.0, 1.0, 0.0, 0.0),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let cam = Camera::pinhole("c", to_world, 0.5);
        let r = cam.raster(64, 64);
        let centre = r.ray(32, 32, Vec2::ZERO);
        assert!((centre.origin - Vec3::new(1.0, 2.0, 3.0)).length() < 1e-6);
        assert!((centre.dir - Vec3::Z).length() < 1e-6);
        assert!(r.ray(0, 32, Vec2::ZERO).dir.x > 0.0);
    }
}
