//! What the integrator knows about a hit: position, frames, BSDF, emission — and the alpha
//! test that decides whether a triangle is hit at all.
use crate::tracer::bsdf::Bsdf;
use crate::tracer::effects::EffectSet;
use crate::tracer::integrator::Integrator;
use crate::tracer::ray::{ErrPoint, Ray};
use crate::tracer::sampling::Frame;
use glam::{Vec2, Vec3};

pub(crate) struct Surface {
    pub p: ErrPoint,
    /// Geometric normal, facing the incoming ray for double-sided materials and glass.
    pub ng: Vec3,
    pub frame: Frame,
    pub wo: Vec3,
    pub bsdf: Option<Bsdf>,
    pub le: Vec3,
    pub light: u32,
    /// Distance from the ray origin (for absorption).
    pub dist: f32,
    /// The ray hit the front face (entering a glass volume).
    pub front: bool,
    /// Absorption inside the volume behind this surface (glass with a volume; else zero).
    pub sigma_a: Vec3,
}

impl Surface {
    /// The medium a ray is in after crossing this surface from `medium`: entering a glass volume
    /// through its front face puts it inside; leaving through the back puts it in air. Thin
    /// glass has no inside.
    pub fn medium_behind(&self, medium: Vec3) -> Vec3 {
        if self.sigma_a == Vec3::ZERO && medium == Vec3::ZERO {
            return Vec3::ZERO;
        }
        if self.front { self.sigma_a } else { Vec3::ZERO }
    }
}

impl Integrator<'_> {
    /// The first surface along `ray` that kernel `E` sees (alpha-cut hits skipped).
    #[inline]
    pub(crate) fn surface<E: EffectSet>(&self, ray: &Ray, u_glass: f32) -> Option<Surface> {
        let hit = if E::ALPHA {
            self.scene.accel.intersect_where(ray, f32::INFINITY, |prim, b1, b2| self.opaque(prim, b1, b2))
        } else {
            self.scene.accel.intersect(ray, f32::INFINITY)
        }?;
        let mesh = &self.scene.mesh;
        let i = hit.prim as usize;
        let b0 = 1.0 - hit.b1 - hit.b2;
        let v = &mesh.positions[i];
        let p = ErrPoint::from_barycentric(v, b0, hit.b1, hit.b2);
        let mut ng = self.scene.face_normals[i];
        let nv = &mesh.normals[i];
        let mut ns = (nv[0] * b0 + nv[1] * hit.b1 + nv[2] * hit.b2).normalize_or(ng);
        let wo_world = -ray.dir.normalize();
        let material = &self.scene.materials[mesh.material[i] as usize];
        let le = material.emitted(ng, wo_world);
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        let front = ng.dot(wo_world) > 0.0;
        let glass = if E::GLASS { material.glass } else { None };
        let two_sided = material.double_sided || glass.is_some();
        if !front && two_sided {
            ng = -ng;
            ns = -ns;
        }
        let uv = if E::SURFACES || E::ALPHA { self.uv(material.base_color_texture.map_or(0, |t| t.tex_coord), i, hit.b1, hit.b2) } else { Vec2::ZERO };
        let bsdf = (front || two_sided)
            .then(|| material.bsdf_for::<E>(uv, &self.scene.textures, u_glass, front))
            .filter(|b| !b.is_black());
        let frame = Frame::from_normal(ns);
        let wo = frame.to_local(wo_world);
        let sigma_a = glass.filter(|g| !g.thin).map_or(Vec3::ZERO, |g| g.sigma_a);
        let dist = hit.t * ray.dir.length();
        Some(Surface { p, ng, frame, wo, bsdf, le, light: self.scene.tri_light[i], dist, front, sigma_a })
    }

    /// Texture coordinates of UV set `set` at barycentrics (b1, b2) of triangle `i`.
    fn uv(&self, set: u32, i: usize, b1: f32, b2: f32) -> Vec2 {
        let uvs = &self.scene.mesh.uvs[i][set.min(1) as usize];
        uvs[0] * (1.0 - b1 - b2) + uvs[1] * b1 + uvs[2] * b2
    }

    /// Whether the alpha test keeps the hit at (b1, b2) on triangle `prim`.
    pub(crate) fn opaque(&self, prim: u32, b1: f32, b2: f32) -> bool {
        let material = &self.scene.materials[self.scene.mesh.material[prim as usize] as usize];
        let Some(cutoff) = material.alpha_cutoff else { return true };
        let uv = self.uv(material.base_color_texture.map_or(0, |t| t.tex_coord), prim as usize, b1, b2);
        material.alpha_at(uv, &self.scene.textures) >= cutoff
    }

    /// Shadow-ray test as kernel `E` sees it (alpha-cut triangles let light through).
    #[inline]
    pub(crate) fn occluded<E: EffectSet>(&self, ray: &Ray, t_max: f32) -> bool {
        if E::ALPHA {
            self.scene.accel.occluded_where(ray, t_max, |prim, b1, b2| self.opaque(prim, b1, b2))
        } else {
            self.scene.accel.occluded(ray, t_max)
        }
    }
}
