//! Building a [`LightTree`]: lights grouped four by four, each group's bounds in its parent's
//! lanes.
use super::{COS_MARGIN, Inner, LEAF, LightTree, WIDTH};
use crate::tracer::light::Light;
use glam::{Vec3, Vec4};

impl LightTree {
    /// A tree over `lights`, all triangles.
    pub(super) fn build(lights: &[Light]) -> LightTree {
        let leaves: Vec<Leaf> = lights.iter().map(Leaf::of).collect();
        let power = leaves.iter().map(|l| l.power).sum();
        let mut tree = LightTree {
            nodes: Vec::with_capacity(leaves.len() / 2 + 1),
            trails: vec![0; leaves.len()],
            power,
        };
        let mut ids: Vec<u32> = (0..leaves.len() as u32).collect();
        if !ids.is_empty() {
            tree.grow(&leaves, &mut ids, 0, 0);
        }
        tree
    }

    /// Appends the node over `ids` (reordered), at depth `depth` with trail prefix `trail`.
    fn grow(&mut self, leaves: &[Leaf], ids: &mut [u32], depth: u32, trail: u64) -> u32 {
        let at = self.nodes.len();
        self.nodes.push(Inner::EMPTY);
        for (k, group) in quarters(leaves, ids).into_iter().enumerate() {
            let bounds = Bounds::over(leaves, group);
            let trail = trail | (k as u64) << (2 * depth);
            let child = match group {
                [only] => {
                    self.trails[*only as usize] = trail;
                    LEAF | *only
                }
                _ => self.grow(leaves, group, depth + 1, trail),
            };
            self.nodes[at].set(k, &bounds, child);
        }
        at as u32
    }
}

/// `ids` in up to four groups: each light alone if there are at most four, else halves of
/// halves, each split at the median of the light centres along their widest spread. The
/// depth is then about log₄ n, so every trail fits its 64 bits; ties go by light index, so
/// the tree does not depend on the sort.
fn quarters<'i>(leaves: &[Leaf], ids: &'i mut [u32]) -> Vec<&'i mut [u32]> {
    if ids.len() <= WIDTH {
        return ids.chunks_mut(1).collect();
    }
    let (a, b) = halves(leaves, ids);
    let (a0, a1) = halves(leaves, a);
    let (b0, b1) = halves(leaves, b);
    vec![a0, a1, b0, b1]
}

fn halves<'i>(leaves: &[Leaf], ids: &'i mut [u32]) -> (&'i mut [u32], &'i mut [u32]) {
    let (lo, hi) = ids.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &i| {
        let c = leaves[i as usize].centre;
        (lo.min(c), hi.max(c))
    });
    let axis = (hi - lo).max_position();
    let mid = ids.len() / 2;
    ids.select_nth_unstable_by(mid, |&a, &b| {
        leaves[a as usize].centre[axis].total_cmp(&leaves[b as usize].centre[axis]).then(a.cmp(&b))
    });
    ids.split_at_mut(mid)
}

/// What the build needs of one light.
struct Leaf {
    lo: Vec3,
    hi: Vec3,
    centre: Vec3,
    normal: Vec3,
    power: f32,
    two_sided: bool,
}

impl Leaf {
    fn of(light: &Light) -> Leaf {
        let Light::Triangle { v, n, two_sided, .. } = light else {
            unreachable!("a light tree holds triangles only")
        };
        let (lo, hi) = (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2]));
        Leaf {
            lo,
            hi,
            centre: (v[0] + v[1] + v[2]) / 3.0,
            normal: *n,
            power: light.power(0.0).max(0.0),
            two_sided: *two_sided,
        }
    }
}

/// What a node knows of a group of lights.
struct Bounds {
    centre: Vec3,
    r2: f32,
    w: Vec3,
    cos_o: f32,
    power: f32,
    two_sided: bool,
}

impl Bounds {
    /// The sphere around the lights' box, their power, and the cone of their normals: its axis
    /// their normalized sum, its half-angle the widest of them from it (no trigonometry, so the
    /// same bits on every libm).
    fn over(leaves: &[Leaf], ids: &[u32]) -> Bounds {
        let (mut lo, mut hi, mut sum) = (Vec3::INFINITY, Vec3::NEG_INFINITY, Vec3::ZERO);
        let (mut power, mut two_sided) = (0.0f32, false);
        for &i in ids {
            let l = &leaves[i as usize];
            (lo, hi, sum) = (lo.min(l.lo), hi.max(l.hi), sum + l.normal);
            power += l.power;
            two_sided |= l.two_sided;
        }
        let w = sum.try_normalize().unwrap_or(leaves[ids[0] as usize].normal);
        let widest = ids.iter().map(|&i| w.dot(leaves[i as usize].normal)).fold(1.0f32, f32::min);
        // Widened by the margin: the cone must hold every normal despite rounding.
        let cos_o = (widest - COS_MARGIN).clamp(-1.0, 1.0);
        Bounds {
            centre: (lo + hi) * 0.5,
            r2: (hi - lo).length_squared() * 0.25,
            w,
            cos_o,
            power,
            two_sided,
        }
    }
}

impl Inner {
    const EMPTY: Inner = Inner {
        cx: Vec4::ZERO,
        cy: Vec4::ZERO,
        cz: Vec4::ZERO,
        r2: Vec4::ZERO,
        r: Vec4::ZERO,
        wx: Vec4::ZERO,
        wy: Vec4::ZERO,
        wz: Vec4::ONE,
        cos_o: Vec4::ONE,
        sin_o: Vec4::ZERO,
        power: Vec4::ZERO,
        power_inside: Vec4::ZERO,
        two_sided: Vec4::ZERO,
        child: [0; WIDTH],
        count: 0,
    };

    fn set(&mut self, k: usize, b: &Bounds, child: u32) {
        (self.cx[k], self.cy[k], self.cz[k]) = (b.centre.x, b.centre.y, b.centre.z);
        (self.r2[k], self.r[k]) = (b.r2, b.r2.sqrt());
        (self.wx[k], self.wy[k], self.wz[k]) = (b.w.x, b.w.y, b.w.z);
        (self.cos_o[k], self.sin_o[k]) = (b.cos_o, (1.0 - b.cos_o * b.cos_o).max(0.0).sqrt());
        (self.power[k], self.power_inside[k]) = (b.power, b.power / b.r2.max(f32::MIN_POSITIVE));
        self.two_sided[k] = if b.two_sided { 1.0 } else { 0.0 };
        self.child[k] = child;
        self.count = self.count.max(k as u32 + 1);
    }
}
