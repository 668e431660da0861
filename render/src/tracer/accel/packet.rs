//! Triangles four to a packet (one coordinate of four triangles per SIMD register) and the
//! watertight ray–triangle test (Woop, Benthin and Wald 2013, as in pbrt-v4) run on the four
//! lanes at once.
//!
//! Why packets: a wide-BVH node hands over every triangle of the leaves a ray enters at once,
//! and on the Cornell box a ray tested 4.25 triangles one by one, a fifth of all render
//! instructions (callgrind, 2026-12-02). Four lanes cost little more than one.
//!
//! Watertightness: an edge function is a·b − c·d with two rounded f32 products. Two triangles
//! sharing an edge compute the same two products and subtract them in opposite order, so their
//! values are exactly opposite and no ray passes between them. A value of exactly zero (a ray
//! through an edge, or rounding to it) is decided again in f64, where products of f32s are exact
//! (pbrt-v3/v4 do the same). Every lane does the same IEEE operations as a one-lane test, so a
//! triangle's hit does not depend on the packet it sits in.
use crate::tracer::ray::gamma;
use glam::{DVec3, Vec3, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use rayon::prelude::*;

/// Per-ray constants: the axis permutation and shear that map the ray to +z through the
/// origin, each in every lane. Kept small (and built inline), as it is made for every ray.
pub(super) struct WatertightRay {
    perm: [usize; 3],
    /// origin[kx], origin[ky], origin[kz].
    o: [Vec4; 3],
    /// The shear: −d[kx]/d[kz], −d[ky]/d[kz], 1/d[kz].
    s: [Vec4; 3],
}

impl WatertightRay {
    #[inline(always)]
    pub(super) fn new(origin: Vec3, dir: Vec3) -> WatertightRay {
        let kz = dir.abs().max_position();
        let next = |k: usize| if k == 2 { 0 } else { k + 1 };
        let (kx, ky) = (next(kz), next(next(kz)));
        // One SIMD division: the bits of −d[kx]/d[kz], −d[ky]/d[kz], 1/d[kz].
        let shear = Vec3A::new(-dir[kx], -dir[ky], 1.0) / Vec3A::splat(dir[kz]);
        let o = [Vec4::splat(origin[kx]), Vec4::splat(origin[ky]), Vec4::splat(origin[kz])];
        let s = [Vec4::splat(shear.x), Vec4::splat(shear.y), Vec4::splat(shear.z)];
        WatertightRay { perm: [kx, ky, kz], o, s }
    }
}

/// Four triangles: `c[vertex][axis]`, lane i is triangle i.
#[derive(Clone, Copy, Default)]
pub(super) struct Packet {
    c: [[Vec4; 3]; 3],
}

/// What a packet test found: lanes `hits` hit with 0 < t ≤ t_max (t conservatively positive).
pub(super) struct Candidates {
    pub(super) hits: u32,
    pub(super) t: Vec4,
    pub(super) b1: Vec4,
    pub(super) b2: Vec4,
}

impl Candidates {
    /// (lane, t, b1, b2) of each hit, lowest lane first.
    #[inline(always)]
    pub(super) fn iter(&self) -> impl Iterator<Item = (usize, f32, f32, f32)> + '_ {
        set_bits(self.hits).map(|l| (l, self.t[l], self.b1[l], self.b2[l]))
    }
}

/// Indices of the set bits of `mask`, lowest first.
#[inline(always)]
pub(super) fn set_bits(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            i
        })
    })
}

impl Packet {
    /// Triangles in lanes 0.. (at most four); other lanes are zero and must not be asked for.
    pub(super) fn new(tris: &[[Vec3; 3]]) -> Packet {
        let mut p = Packet::default();
        tris.iter().enumerate().take(4).for_each(|(lane, t)| p.set(lane, t));
        p
    }

    fn set(&mut self, lane: usize, t: &[Vec3; 3]) {
        for (j, v) in t.iter().enumerate() {
            for axis in 0..3 {
                self.c[j][axis][lane] = v[axis];
            }
        }
    }

    pub(super) fn triangle(&self, lane: usize) -> [Vec3; 3] {
        std::array::from_fn(|j| {
            Vec3::new(self.c[j][0][lane], self.c[j][1][lane], self.c[j][2][lane])
        })
    }

    /// The watertight test on the lanes set in `lanes`.
    #[inline(always)]
    pub(super) fn test(&self, ray: &WatertightRay, lanes: u32, t_max: f32) -> Candidates {
        let [kx, ky, kz] = ray.perm;
        // z is taken again after the edge functions rather than kept through them: fewer live
        // registers there, fewer spills among SSE2's sixteen (−1 % traversal instructions).
        let dz = |j: usize| self.c[j][kz] - ray.o[2];
        let vertex = |j: usize| -> (Vec4, Vec4) {
            let dz = dz(j);
            ((self.c[j][kx] - ray.o[0]) + ray.s[0] * dz, (self.c[j][ky] - ray.o[1]) + ray.s[1] * dz)
        };
        let (p0, p1, p2) = (vertex(0), vertex(1), vertex(2));
        let mut e =
            [p1.0 * p2.1 - p1.1 * p2.0, p2.0 * p0.1 - p2.1 * p0.0, p0.0 * p1.1 - p0.1 * p1.0];
        let zero = Vec4::ZERO;
        let on_edge = (e[0].cmpeq(zero) | e[1].cmpeq(zero) | e[2].cmpeq(zero)).bitmask() & lanes;
        if on_edge != 0 {
            exact_edges(&mut e, [p0, p1, p2], on_edge);
        }
        let (p0, p1, p2) = ((p0.0, p0.1, dz(0)), (p1.0, p1.1, dz(1)), (p2.0, p2.1, dz(2)));
        let [e0, e1, e2] = e;
        let outside = (e0.cmplt(zero) | e1.cmplt(zero) | e2.cmplt(zero))
            & (e0.cmpgt(zero) | e1.cmpgt(zero) | e2.cmpgt(zero));
        let det = e0 + e1 + e2;
        let sz = ray.s[2];
        let (z0, z1, z2) = (p0.2 * sz, p1.2 * sz, p2.2 * sz);
        let t_scaled = e0 * z0 + e1 * z1 + e2 * z2;
        let limit = det * Vec4::splat(t_max);
        let ahead = (det.cmplt(zero) & t_scaled.cmplt(zero) & t_scaled.cmpge(limit))
            | (det.cmpgt(zero) & t_scaled.cmpgt(zero) & t_scaled.cmple(limit));
        let mut hits = (ahead & !outside).bitmask() & lanes;
        if hits == 0 {
            return Candidates { hits, t: zero, b1: zero, b2: zero };
        }
        let inv_det = Vec4::ONE / det;
        let t = t_scaled * inv_det;
        let bound = t_error_bound([p0.0, p1.0, p2.0], [p0.1, p1.1, p2.1], [z0, z1, z2], e, inv_det);
        for lane in set_bits(t.cmple(bound).bitmask() & hits) {
            if !positive_in_f64(ray, &self.triangle(lane)) {
                hits &= !(1 << lane);
            }
        }
        Candidates { hits, t, b1: e1 * inv_det, b2: e2 * inv_det }
    }
}

/// Edge functions of the lanes in `lanes` again in f64: the products of f32s are exact there, so
/// the sign is exact, and neighbours still get opposite values.
#[cold]
fn exact_edges(e: &mut [Vec4; 3], p: [(Vec4, Vec4); 3], lanes: u32) {
    for l in set_bits(lanes) {
        let f = |a: (Vec4, Vec4), b: (Vec4, Vec4)| {
            (a.0[l] as f64 * b.1[l] as f64 - a.1[l] as f64 * b.0[l] as f64) as f32
        };
        e[0][l] = f(p[1], p[2]);
        e[1][l] = f(p[2], p[0]);
        e[2][l] = f(p[0], p[1]);
    }
}

/// pbrt-v4's conservative bound on the error of t (edge functions of plain f32 products), so
/// that hits behind the origin are rejected.
#[inline(always)]
fn t_error_bound(x: [Vec4; 3], y: [Vec4; 3], z: [Vec4; 3], e: [Vec4; 3], inv_det: Vec4) -> Vec4 {
    let max3 = |v: [Vec4; 3]| v[0].abs().max(v[1].abs()).max(v[2].abs());
    let (max_xt, max_yt, max_zt, max_e) = (max3(x), max3(y), max3(z), max3(e));
    let g = |n: i32| Vec4::splat(gamma(n));
    let delta_z = g(3) * max_zt;
    let delta_x = g(5) * (max_xt + max_zt);
    let delta_y = g(5) * (max_yt + max_zt);
    let delta_e = Vec4::splat(2.0) * (g(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    Vec4::splat(3.0) * (g(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs()
}

/// The f32 bound on t is loose for thin triangles far away (it can exceed t itself); before
/// rejecting such a hit, redo the test in f64, where the same bound is 2²⁹ times tighter.
#[cold]
fn positive_in_f64(ray: &WatertightRay, v: &[Vec3; 3]) -> bool {
    let [kx, ky, kz] = ray.perm;
    let o = DVec3::new(ray.o[0].x as f64, ray.o[1].x as f64, ray.o[2].x as f64);
    let s = DVec3::new(ray.s[0].x as f64, ray.s[1].x as f64, ray.s[2].x as f64);
    let p = v.map(|q| {
        let d = DVec3::new(q[kx] as f64, q[ky] as f64, q[kz] as f64) - o;
        DVec3::new(d.x + s.x * d.z, d.y + s.y * d.z, d.z * s.z)
    });
    let e = [
        p[1].x * p[2].y - p[1].y * p[2].x,
        p[2].x * p[0].y - p[2].y * p[0].x,
        p[0].x * p[1].y - p[0].y * p[1].x,
    ];
    let det = e[0] + e[1] + e[2];
    let t = (e[0] * p[0].z + e[1] * p[1].z + e[2] * p[2].z) / det;
    let g = |n: f64| n * f64::EPSILON * 0.5 / (1.0 - n * f64::EPSILON * 0.5);
    let max = |f: fn(&DVec3) -> f64| p.iter().map(|q| f(q).abs()).fold(0.0, f64::max);
    let (mx, my, mz) = (max(|q| q.x), max(|q| q.y), max(|q| q.z));
    let (dx, dy, dz) = (g(5.0) * (mx + mz), g(5.0) * (my + mz), g(3.0) * mz);
    let de = 2.0 * (g(2.0) * mx * my + dy * mx + dx * my);
    let me = e.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    // Shearing in f64 adds error of the order of the f32 inputs' own rounding; count it in.
    let bound = 3.0 * (g(3.0) * me * mz + de * mz + dz * me) / det.abs() + g(8.0) * mz;
    t > bound
}

/// The tree's triangles in its slot order, four to a packet: slot s is lane s % 4 of packet s / 4.
pub(super) struct Packets {
    packets: Vec<Packet>,
}

impl Packets {
    /// The triangles `slot(0..count)`, without a copy of them all first (36 bytes a
    /// triangle: on a million, 35 MiB less at the end of a build); packets are filled in
    /// parallel, each from its own four slots.
    pub(super) fn new(count: usize, slot: impl Fn(usize) -> [Vec3; 3] + Sync) -> Packets {
        const RUN: usize = 1024;
        let mut packets = vec![Packet::default(); count.div_ceil(4)];
        // Runs of packets, each a plain loop: per-packet tasks cost a single thread a fifth more.
        packets.par_chunks_mut(RUN).enumerate().for_each(|(run, chunk)| {
            for (k, packet) in chunk.iter_mut().enumerate() {
                let first = 4 * (run * RUN + k);
                for lane in 0..(count - first).min(4) {
                    packet.set(lane, &slot(first + lane));
                }
            }
        });
        Packets { packets }
    }

    pub(super) fn triangle(&self, slot: usize) -> [Vec3; 3] {
        self.packets[slot / 4].triangle(slot % 4)
    }

    /// The box of slot `slot`'s triangle, empty for a triangle never hit (NaN corners).
    pub(super) fn slot_box(&self, slot: usize) -> Aabb {
        let [a, b, c] = self.triangle(slot);
        match a.is_nan() {
            true => Aabb::INVALID,
            false => Aabb { min: a.min(b).min(c).into(), max: a.max(b).max(c).into() },
        }
    }

    #[inline(always)]
    pub(super) fn test(
        &self,
        ray: &WatertightRay,
        packet: usize,
        lanes: u32,
        t_max: f32,
    ) -> Candidates {
        self.packets[packet].test(ray, lanes, t_max)
    }
}

/// Calls `each(packet, lanes)` for every packet holding one of the slots `base + i`, i a set bit
/// of `bits`, with the lanes of those slots, packet by packet; stops when `each` returns true
/// and says whether it did.
#[inline(always)]
pub(super) fn for_packets(base: u32, bits: u32, mut each: impl FnMut(usize, u32) -> bool) -> bool {
    // Bit i + 3 stands for slot base + i, so a packet starting up to three slots before `base`
    // has its lane 0 at a non-negative shift.
    let mut pending = u64::from(bits) << 3;
    while pending != 0 {
        let slot = base + pending.trailing_zeros() - 3;
        let packet = slot / 4;
        let shift = packet * 4 + 3 - base;
        let lanes = ((pending >> shift) & 0xF) as u32;
        pending &= !(0xF << shift);
        if each(packet as usize, lanes) {
            return true;
        }
    }
    false
}

/// Watertight test of one triangle: (t, b1, b2) for a hit with t conservatively > 0 and
/// t ≤ t_max. The same operations as its lane of a packet test.
pub(super) fn intersect_triangle(
    ray: &WatertightRay,
    v: &[Vec3; 3],
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    let c = Packet::new(std::slice::from_ref(v)).test(ray, 1, t_max);
    (c.hits & 1 != 0).then_some((c.t.x, c.b1.x, c.b2.x))
}

#[cfg(test)]
mod tests;
