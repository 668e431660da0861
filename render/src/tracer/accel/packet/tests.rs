use super::*;
use crate::tracer::chi2::Rng;

/// Values in [0, 1) from the tests' shared generator.
fn stream(seed: u64) -> impl FnMut() -> f32 {
    let mut rng = Rng::new(seed);
    move || rng.f32()
}

#[test]
fn every_lane_of_a_packet_answers_as_the_triangle_alone() {
    let mut u = stream(3);
    let mut v = || Vec3::new(u(), u(), u()) * 2.0 - 1.0;
    let (mut hits, mut misses) = (0, 0);
    for i in 0..20_000u32 {
        let tris: Vec<[Vec3; 3]> = (0..4).map(|_| [v(), v(), v()]).collect();
        let origin = v() * 3.0;
        // Aimed at a point near triangle i % 4's centroid, so hits are common.
        let aim = tris[i as usize % 4].iter().sum::<Vec3>() / 3.0 + v() * 0.2;
        let ray = WatertightRay::new(origin, aim - origin);
        let t_max = if i % 3 == 0 { f32::INFINITY } else { 1.0 };
        let packet = Packet::new(&tris);
        let lanes = i % 15 + 1;
        let c = packet.test(&ray, lanes, t_max);
        assert_eq!(c.hits & !lanes, 0, "a lane not asked for answered");
        for (lane, tri) in tris.iter().enumerate().filter(|&(l, _)| lanes >> l & 1 == 1) {
            let alone = intersect_triangle(&ray, tri, t_max);
            let packed = (c.hits >> lane & 1 == 1).then(|| (c.t[lane], c.b1[lane], c.b2[lane]));
            assert_eq!(
                packed.map(|h| (h.0.to_bits(), h.1.to_bits(), h.2.to_bits())),
                alone.map(|h| (h.0.to_bits(), h.1.to_bits(), h.2.to_bits()))
            );
            if alone.is_some() { hits += 1 } else { misses += 1 }
        }
    }
    // Both outcomes were exercised.
    assert!(hits > 1000 && misses > 1000, "{hits} hits, {misses} misses");
}

#[test]
fn for_packets_visits_each_slot_of_the_group_once() {
    let mut u = stream(9);
    for _ in 0..10_000 {
        let base = (u() * 1000.0) as u32;
        let bits = (u() * (1 << 24) as f32) as u32 | 1;
        let mut seen = Vec::new();
        let mut packets = Vec::new();
        for_packets(base, bits, |packet, lanes| {
            assert!(lanes != 0 && lanes < 16);
            packets.push(packet);
            seen.extend((0..4).filter(|l| lanes >> l & 1 == 1).map(|l| packet as u32 * 4 + l));
            false
        });
        let want: Vec<u32> = (0..24).filter(|i| bits >> i & 1 == 1).map(|i| base + i).collect();
        assert_eq!(seen, want, "base {base} bits {bits:#x}");
        assert!(packets.windows(2).all(|w| w[0] < w[1]), "a packet was visited twice");
    }
}

#[test]
fn for_packets_stops_when_asked() {
    let mut calls = 0;
    let stopped = for_packets(5, 0xff_ffff, |_, _| {
        calls += 1;
        calls == 2
    });
    assert!(stopped);
    assert_eq!(calls, 2);
}

#[test]
fn a_ray_through_the_shared_edge_hits_exactly_one_side_or_both_at_the_same_t() {
    // Two triangles sharing the diagonal of the unit square; rays aimed at points of the
    // diagonal, where the f32 edge function is 0 and the f64 fallback decides.
    let a = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)];
    let b = [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
    let packet = Packet::new(&[a, b]);
    let mut u = stream(5);
    for _ in 0..5_000 {
        let s = u();
        let target = Vec3::new(s, s, 0.0);
        let origin = Vec3::new(u() * 4.0 - 2.0, u() * 4.0 - 2.0, 1.0 + u());
        let c = packet.test(&WatertightRay::new(origin, target - origin), 0b11, f32::INFINITY);
        assert_ne!(c.hits, 0, "ray to {target} from {origin} leaked between the triangles");
    }
}
