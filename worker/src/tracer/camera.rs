//! Perspective pinhole camera (glTF convention: looks down local −Z, +Y up, +X right).
//!
//! The aspect ratio always comes from the render size, never from the glTF file, so a job can
//! render any resolution without distortion. Pixel (0, 0) is the top-left corner; a sample at
//! raster position (x + u, y + v) jitters uniformly inside its pixel (box filter).
use crate::tracer::ray::Ray;
use glam::{Mat4, Vec2, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub name: String,
    /// Camera-to-world transform (rotation and translation; scale is ignored for directions).
    pub to_world: Mat4,
    /// Vertical field of view in radians.
    pub yfov: f32,
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
}

impl Camera {
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_down_minus_z_and_corners_span_the_fov() {
        let cam = Camera { name: "c".into(), to_world: Mat4::IDENTITY, yfov: 1.0 };
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
        let to_world = Mat4::from_rotation_translation(glam::Quat::from_xyzw(0.0, 1.0, 0.0, 0.0), Vec3::new(1.0, 2.0, 3.0));
        let cam = Camera { name: "c".into(), to_world, yfov: 0.5 };
        let r = cam.raster(64, 64);
        let centre = r.ray(32, 32, Vec2::ZERO);
        assert!((centre.origin - Vec3::new(1.0, 2.0, 3.0)).length() < 1e-6);
        assert!((centre.dir - Vec3::Z).length() < 1e-6);
        assert!(r.ray(0, 32, Vec2::ZERO).dir.x > 0.0);
    }
}
