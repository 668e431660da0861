//! What the integrator knows about a hit: position, frames, BSDF, emission — and the alpha
//! test that decides whether a triangle is hit at all.
//!
//! Texture coordinates (both UV sets), textured emission and normal maps are computed only by
//! kernels with `E::SURFACES` (the scene has textures, normal maps or non-Lambert surfaces);
//! the matte kernel reads none of them. Normal maps perturb the shading normal after it is
//! turned to the geometric normal's side and before two-sided flipping, and are then kept
//! consistent with the geometric normal and the viewer ([`normal_map::keep_consistent`]).
use crate::tracer::bsdf::Bsdf;
use crate::tracer::integrator::Integrator;
use crate::tracer::kernel::EffectSet;
use crate::tracer::material::{Material, NormalTexture};
use crate::tracer::normal_map;
use crate::tracer::ray::{ErrPoint, Ray};
#[cfg(feature = "bench")]
use crate::tracer::ray_log::RayQuery;
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
    // Always, with `Integrator::emitted`, rather than left to the inliner: after changes elsewhere
    // the plain build made `emitted` a call, so every hit's `Surface` was stored and copied to be
    // lent to it (+2.5 % instructions, +4 % time on the Cornell box; docs/dev/performance-log.md, 2026-12-06).
    #[inline(always)]
    pub(crate) fn surface<E: EffectSet>(&self, ray: &Ray, u_glass: f32) -> Option<Surface> {
        #[cfg(feature = "bench")]
        if let Some(log) = self.ray_log {
            log.push(ray, f32::INFINITY, RayQuery::Closest);
        }
        let hit = if E::ALPHA {
            self.scene
                .accel
                .intersect_where(ray, f32::INFINITY, |prim, b1, b2| self.opaque(prim, b1, b2))
        } else {
            self.scene.accel.intersect(ray, f32::INFINITY)
        }?;
        let mesh = &self.scene.mesh;
        let i = hit.prim as usize;
        let b = [1.0 - hit.b1 - hit.b2, hit.b1, hit.b2];
        let v = &mesh.positions[i];
        let p = ErrPoint::from_barycentric(v, b[0], b[1], b[2]);
        let mut ng = self.scene.face_normals[i];
        let nv = mesh.normals_of(i);
        let mut ns = (nv[0] * b[0] + nv[1] * b[1] + nv[2] * b[2]).normalize_or(ng);
        let wo_world = -ray.dir.normalize();
        let material = &self.scene.materials[mesh.material[i] as usize];
        let uvs = if E::SURFACES || E::ALPHA { self.uvs(i, b) } else { [Vec2::ZERO; 2] };
        let mut le = material.emitted(ng, wo_world);
        if E::SURFACES && le != Vec3::ZERO {
            le = material.emission_at(&uvs, &self.scene.textures);
        }
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        if E::SURFACES
            && let Some(nt) = &material.normal_texture
        {
            ns = self.normal_mapped(nt, i, b, &uvs, ns);
        }
        let front = ng.dot(wo_world) > 0.0;
        let glass = if E::GLASS { material.glass } else { None };
        let two_sided = material.double_sided || glass.is_some();
        if !front && two_sided {
            ng = -ng;
            ns = -ns;
        }
        if E::SURFACES && material.normal_texture.is_some() && (front || two_sided) {
            ns = normal_map::keep_consistent(ns, ng, wo_world);
        }
        let bsdf = (front || two_sided)
            .then(|| material.bsdf_for::<E>(&uvs, &self.scene.textures, u_glass, front))
            .filter(|b| !b.is_black());
        let frame = Frame::from_normal(ns);
        let wo = frame.to_local(wo_world);
        let sigma_a = glass.filter(|g| !g.thin).map_or(Vec3::ZERO, |g| g.sigma_a);
        let dist = hit.t * ray.dir.length();
        Some(Surface {
            p,
            ng,
            frame,
            wo,
            bsdf,
            le,
            light: self.scene.tri_light[i],
            dist,
            front,
            sigma_a,
        })
    }

    /// Both UV sets at barycentrics `b` of triangle `i`.
    pub(crate) fn uvs(&self, i: usize, b: [f32; 3]) -> [Vec2; 2] {
        self.scene.mesh.uvs_of(i).map(|t| t[0] * b[0] + t[1] * b[1] + t[2] * b[2])
    }

    /// The shading normal `ns` (front side) perturbed by the material's normal map.
    fn normal_mapped(
        &self,
        nt: &NormalTexture,
        i: usize,
        b: [f32; 3],
        uvs: &[Vec2; 2],
        ns: Vec3,
    ) -> Vec3 {
        let mesh = &self.scene.mesh;
        let tangent = match mesh.tangents.get(i) {
            Some(t) if t[0].w != 0.0 => normal_map::tangent_from_attribute(t, b, ns),
            _ => {
                let uv = mesh.uvs_of(i)[nt.texture.tex_coord.min(1) as usize]
                    .map(|uv| nt.texture.transform.apply(uv));
                normal_map::tangent_from_uvs(&mesh.positions[i], &uv, ns)
            }
        };
        let Some(tangent) = tangent else { return ns };
        normal_map::perturb(
            ns,
            tangent,
            nt.texture.sample(&self.scene.textures, uvs).truncate(),
            nt.scale,
        )
    }

    /// Whether the alpha test keeps the hit at (b1, b2) on triangle `prim`.
    pub(crate) fn opaque(&self, prim: u32, b1: f32, b2: f32) -> bool {
        let material: &Material =
            &self.scene.materials[self.scene.mesh.material[prim as usize] as usize];
        let Some(cutoff) = material.alpha_cutoff else { return true };
        let uvs = self.uvs(prim as usize, [1.0 - b1 - b2, b1, b2]);
        material.alpha_at(&uvs, &self.scene.textures) >= cutoff
    }

    /// Shadow-ray test as kernel `E` sees it (alpha-cut triangles let light through).
    #[inline]
    pub(crate) fn occluded<E: EffectSet>(&self, ray: &Ray, t_max: f32) -> bool {
        #[cfg(feature = "bench")]
        if let Some(log) = self.ray_log {
            log.push(ray, t_max, RayQuery::Occluded);
        }
        if E::ALPHA {
            self.scene.accel.occluded_where(ray, t_max, |prim, b1, b2| self.opaque(prim, b1, b2))
        } else {
            self.scene.accel.occluded(ray, t_max)
        }
    }
}
