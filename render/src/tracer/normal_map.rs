//! # Normal maps: tangent frames, perturbed shading normals, and keeping them consistent
//!
//! glTF's `normalTexture` stores a tangent-space normal: n_t = (2c − 1)·(scale, scale, 1)
//! (linear texel c), expressed in (T, B, N) with N the interpolated shading normal, T the
//! tangent and B = (N × T)·w.
//!
//! **Tangents.** From the `TANGENT` attribute when the primitive has one (xyz interpolated,
//! w the handedness sign; transformed with the node like positions, w flipped by mirroring
//! transforms). Otherwise per triangle from its texture coordinates (the normal map's UV set,
//! after its `KHR_texture_transform`): T = ∂p/∂u, and w chosen so that B points along −∂p/∂v,
//! "up" in the image (glTF's v runs down). This is what MikkTSpace gives for a triangle
//! on its own (no averaging over shared vertices), so normal maps baked against MikkTSpace
//! tangents show faint facets on curved low-poly meshes unless the file carries its tangents.
//! Triangles whose UVs are degenerate (collinear or repeated: no ∂p/∂u) keep their
//! unperturbed normal: there is no direction to tilt towards.
//!
//! **Consistency** (pbrt's lesson: shading normals are a lie the integrator must survive).
//! A normal map can tilt the shading normal below the surface or away from the viewer. Rays
//! can never leak through the surface anyway (the integrator checks every direction against
//! the geometric normal), but a shading normal facing away from `wo` makes BSDFs evaluate at
//! cos θo ≤ 0 (black patches, divisions by ~0). [`keep_consistent`] therefore bends the
//! normal towards the geometric one, just enough that n·ng ≥ [`MIN_COS`] and
//! n·wo ≥ min(MIN_COS, ½ ng·wo) > 0: unmodified wherever the map is sane, finite always.
use glam::{Vec2, Vec3, Vec4};

/// Least cosine kept between the shading normal and the geometric normal (and the viewer).
pub const MIN_COS: f32 = 0.05;

/// Unit tangent ⟂ `n` and handedness from the `TANGENT` corners at barycentrics `b`.
pub fn tangent_from_attribute(t: &[Vec4; 3], b: [f32; 3], n: Vec3) -> Option<(Vec3, f32)> {
    let xyz = t[0].truncate() * b[0] + t[1].truncate() * b[1] + t[2].truncate() * b[2];
    let sign = if t[0].w < 0.0 { -1.0 } else { 1.0 };
    Some((orthogonal_unit(xyz, n)?, sign))
}

/// Unit tangent ⟂ `n` and handedness from a triangle's positions and texture coordinates;
/// None when the texture coordinates are degenerate.
pub fn tangent_from_uvs(p: &[Vec3; 3], uv: &[Vec2; 3], n: Vec3) -> Option<(Vec3, f32)> {
    let (dp1, dp2) = (p[1] - p[0], p[2] - p[0]);
    let (d1, d2) = (uv[1] - uv[0], uv[2] - uv[0]);
    let det = d1.x * d2.y - d1.y * d2.x;
    // Relative test: collinear UVs give det ≈ 0 at any scale of the coordinates.
    if !(det.abs() > 1e-6 * d1.length() * d2.length()) {
        return None;
    }
    let dpdu = (dp1 * d2.y - dp2 * d1.y) / det;
    let dpdv = (dp2 * d1.x - dp1 * d2.x) / det;
    let t = orthogonal_unit(dpdu, n)?;
    let sign = if n.cross(t).dot(-dpdv) < 0.0 { -1.0 } else { 1.0 };
    Some((t, sign))
}

fn orthogonal_unit(v: Vec3, n: Vec3) -> Option<Vec3> {
    let t = (v - n * n.dot(v)).normalize_or_zero();
    (t != Vec3::ZERO && t.is_finite()).then_some(t)
}

/// The shading normal for texel `c` (linear RGB) of a normal map with `scale`, in the frame
/// (tangent, (n × tangent)·sign, n). Falls back to `n` if the texel encodes no direction.
pub fn perturb(n: Vec3, (tangent, sign): (Vec3, f32), c: Vec3, scale: f32) -> Vec3 {
    let v = (c * 2.0 - Vec3::ONE) * Vec3::new(scale, scale, 1.0);
    let b = n.cross(tangent) * sign;
    (tangent * v.x + b * v.y + n * v.z).normalize_or(n)
}

/// `n` bent towards `ng` (unit, facing `wo`'s side) until n·ng ≥ MIN_COS and
/// n·wo ≥ min(MIN_COS, ½ ng·wo). Needs ng·wo > 0.
pub fn keep_consistent(n: Vec3, ng: Vec3, wo: Vec3) -> Vec3 {
    let n = bend_towards(n, ng, ng, MIN_COS);
    bend_towards(n, ng, wo, MIN_COS.min(0.5 * ng.dot(wo)))
}

/// Moves unit `n` along the chord to `ng` until d·n ≥ c (needs d·ng > c). On the chord
/// n + s(ng − n), d·n grows linearly in s and the length is ≤ 1, so the s that makes the
/// unnormalised d·n equal c is enough after normalising.
fn bend_towards(n: Vec3, ng: Vec3, d: Vec3, c: f32) -> Vec3 {
    let (a, b) = (d.dot(n), d.dot(ng));
    if a >= c {
        return n;
    }
    let s = ((c - a) / (b - a)).clamp(0.0, 1.0);
    (n + (ng - n) * s).normalize_or(ng)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracer::chi2::Rng;

    const QUAD: [Vec3; 3] = [Vec3::ZERO, Vec3::X, Vec3::Y];

    #[test]
    fn uv_tangents_follow_u_and_put_the_bitangent_up_in_the_image() {
        // u along +x, v down the image along −y: B = image up = +y = z × x, so w = +1.
        let uv = [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 0.0)];
        let (t, w) = tangent_from_uvs(&QUAD, &uv, Vec3::Z).unwrap();
        assert!((t - Vec3::X).length() < 1e-6 && w == 1.0, "{t} {w}");
        // Mirrored in u: T = −x, B still +y, so w = −1.
        let uv = [Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0), Vec2::new(1.0, 0.0)];
        let (t, w) = tangent_from_uvs(&QUAD, &uv, Vec3::Z).unwrap();
        assert!((t + Vec3::X).length() < 1e-6 && w == -1.0, "{t} {w}");
        assert!((n_cross(t, w) - Vec3::Y).length() < 1e-6);
    }

    fn n_cross(t: Vec3, w: f32) -> Vec3 {
        Vec3::Z.cross(t) * w
    }

    #[test]
    fn degenerate_uvs_give_no_tangent() {
        let same = [Vec2::splat(0.3); 3];
        let collinear = [Vec2::ZERO, Vec2::new(1e3, 1e3), Vec2::new(2e3, 2e3)];
        let tiny_but_fine = [Vec2::ZERO, Vec2::new(1e-6, 0.0), Vec2::new(0.0, 1e-6)];
        assert_eq!(tangent_from_uvs(&QUAD, &same, Vec3::Z), None);
        assert_eq!(tangent_from_uvs(&QUAD, &collinear, Vec3::Z), None);
        assert!(tangent_from_uvs(&QUAD, &tiny_but_fine, Vec3::Z).is_some());
        assert_eq!(
            tangent_from_attribute(&[Vec4::new(0.0, 0.0, 1.0, 1.0); 3], [1.0, 0.0, 0.0], Vec3::Z),
            None
        );
    }

    #[test]
    fn a_texel_tilts_the_normal_by_its_encoded_angle() {
        let theta = 0.5f32;
        let c = Vec3::new((theta.sin() + 1.0) / 2.0, 0.5, (theta.cos() + 1.0) / 2.0);
        let n = perturb(Vec3::Z, (Vec3::X, 1.0), c, 1.0);
        assert!((n - Vec3::new(theta.sin(), 0.0, theta.cos())).length() < 1e-6, "{n}");
        // Green tilts along the bitangent, and `scale` scales the tilt (then renormalises).
        let n = perturb(Vec3::Z, (Vec3::X, -1.0), Vec3::new(0.5, 1.0, 1.0), 0.5);
        assert!((n - Vec3::new(0.0, -0.5, 1.0).normalize()).length() < 1e-6, "{n}");
        assert_eq!(
            perturb(Vec3::Z, (Vec3::X, 1.0), Vec3::splat(0.5), 1.0),
            Vec3::Z,
            "no direction: keep n"
        );
    }

    #[test]
    fn consistent_normals_face_the_viewer_and_stay_above_the_surface() {
        let mut rng = Rng::new(3);
        let unit = |rng: &mut Rng| loop {
            let v = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - Vec3::ONE;
            if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        };
        for i in 0..100_000 {
            let n = unit(&mut rng);
            let mut wo = unit(&mut rng);
            wo.z = wo.z.abs().max(if i % 10 == 0 { 1e-4 } else { 1e-2 });
            let wo = wo.normalize();
            let m = keep_consistent(n, Vec3::Z, wo);
            assert!(m.is_finite() && (m.length() - 1.0).abs() < 1e-5, "{n} {wo} → {m}");
            assert!(m.z >= MIN_COS * 0.999 && m.dot(wo) > 0.0, "{n} {wo} → {m}");
            if n.z >= MIN_COS && n.dot(wo) >= MIN_COS.min(0.5 * wo.z) {
                assert_eq!(m, n, "sane normals are kept");
            }
        }
        assert!(keep_consistent(-Vec3::Z, Vec3::Z, Vec3::Z).is_finite());
    }
}
