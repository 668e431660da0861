//! What a walk of the wide tree did: nodes tested, triangle packets tested and the triangles
//! in them. `tessera-bench bvh` prints these per ray beside the rates, so a change to the tree or
//! the walk can be told apart from a change to the cost of each step.
//!
//! The tracer's own queries count into `()`, whose methods are empty: the counting code is
//! compiled away there (the walk is generic over [`Tally`]).

/// Counts accumulated over any number of walks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WalkCounts {
    /// Walks counted.
    pub rays: u64,
    /// Node tests (each tests all eight child boxes).
    pub nodes: u64,
    /// Packet tests (each tests up to four triangles at once).
    pub packets: u64,
    /// Triangles those packet tests were asked about.
    pub triangles: u64,
}

impl WalkCounts {
    /// Each count per ray counted: (nodes, packets, triangles).
    pub fn per_ray(&self) -> (f64, f64, f64) {
        let n = self.rays.max(1) as f64;
        (self.nodes as f64 / n, self.packets as f64 / n, self.triangles as f64 / n)
    }
}

/// Where a walk reports its steps.
pub(super) trait Tally {
    fn ray(&mut self);
    fn node(&mut self);
    /// A packet test of the lanes set in `lanes`.
    fn packet(&mut self, lanes: u32);
}

impl Tally for () {
    #[inline(always)]
    fn ray(&mut self) {}
    #[inline(always)]
    fn node(&mut self) {}
    #[inline(always)]
    fn packet(&mut self, _: u32) {}
}

impl Tally for WalkCounts {
    fn ray(&mut self) {
        self.rays += 1;
    }
    fn node(&mut self) {
        self.nodes += 1;
    }
    fn packet(&mut self, lanes: u32) {
        self.packets += 1;
        self.triangles += u64::from(lanes.count_ones());
    }
}
