//! Zero-cost traversal statistics.
//!
//! Kernels are generic over `C: Counter`. Timed runs use [`NoStats`], a zero-sized type whose
//! methods are empty and vanish after inlining; the counting pass uses [`TraversalStats`], one
//! per ray, kept in a local and written out once per ray (pbrt-v4's per-thread counters,
//! madmann91/bvh's `if constexpr (CaptureStats)`).
//!
//! Counter definitions (the same for every structure; sparse-boxes paper Table 1 names them
//! N_I, N_L and r_ITM):
//! - `interior`: interior nodes visited (popped or descended into and processed);
//! - `leaves`: leaves visited (non-empty or empty);
//! - `prims`: ray–primitive tests performed;
//! - `boxes`: ray–box (slab) tests performed;
//! - `planes`: ray–splitting-plane computations (kd-trees);
//! - `restarts`: restarts from the root or backtracks up the tree;
//! - `steps`: a structure-defined traversal step, documented on each structure (for a BVH,
//!   one step per node visited, interior or leaf);
//! - `capped`: the ray was ended by the traversal's per-ray step cap (traversals that may
//!   revisit nodes; see [`crate::Accel::has_step_cap`]).

use serde::{Deserialize, Serialize};

/// Receives traversal events. Every method must be cheap; [`NoStats`] makes them free.
pub trait Counter: Default + Send {
    /// Whether this counter records anything (lets kernels skip bookkeeping entirely).
    const ENABLED: bool;
    fn interior(&mut self);
    fn leaf(&mut self);
    fn prims(&mut self, n: u32);
    fn boxes(&mut self, n: u32);
    fn planes(&mut self, n: u32);
    fn restart(&mut self);
    fn steps(&mut self, n: u32);
    /// The ray was ended by a traversal's step cap (at most once per ray).
    fn capped(&mut self);
}

/// The counter that counts nothing (zero-sized; used for timing).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStats;

impl Counter for NoStats {
    const ENABLED: bool = false;
    #[inline(always)]
    fn interior(&mut self) {}
    #[inline(always)]
    fn leaf(&mut self) {}
    #[inline(always)]
    fn prims(&mut self, _: u32) {}
    #[inline(always)]
    fn boxes(&mut self, _: u32) {}
    #[inline(always)]
    fn planes(&mut self, _: u32) {}
    #[inline(always)]
    fn restart(&mut self) {}
    #[inline(always)]
    fn steps(&mut self, _: u32) {}
    #[inline(always)]
    fn capped(&mut self) {}
}

/// Per-ray traversal counts (32 bytes, `#[repr(C)]` so a GPU kernel can write the same record).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TraversalStats {
    pub interior: u32,
    pub leaves: u32,
    pub prims: u32,
    pub boxes: u32,
    pub planes: u32,
    pub restarts: u32,
    pub steps: u32,
    /// 1 when the ray was ended by the traversal's step cap, else 0 (not one of
    /// [`TraversalStats::fields`]: summed, not averaged, in [`StatsSummary::capped`]).
    pub capped: u32,
}

impl Counter for TraversalStats {
    const ENABLED: bool = true;
    #[inline(always)]
    fn interior(&mut self) {
        self.interior += 1;
    }
    #[inline(always)]
    fn leaf(&mut self) {
        self.leaves += 1;
    }
    #[inline(always)]
    fn prims(&mut self, n: u32) {
        self.prims += n;
    }
    #[inline(always)]
    fn boxes(&mut self, n: u32) {
        self.boxes += n;
    }
    #[inline(always)]
    fn planes(&mut self, n: u32) {
        self.planes += n;
    }
    #[inline(always)]
    fn restart(&mut self) {
        self.restarts += 1;
    }
    #[inline(always)]
    fn steps(&mut self, n: u32) {
        self.steps += n;
    }
    #[inline(always)]
    fn capped(&mut self) {
        self.capped = 1;
    }
}

impl TraversalStats {
    /// The counters in a fixed order, with the names used for result columns.
    pub fn fields(&self) -> [(&'static str, u32); 7] {
        [
            ("interior", self.interior),
            ("leaves", self.leaves),
            ("prims", self.prims),
            ("boxes", self.boxes),
            ("planes", self.planes),
            ("restarts", self.restarts),
            ("steps", self.steps),
        ]
    }
}

/// Mean and maximum per ray of each counter over a batch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StatsSummary {
    pub rays: u64,
    pub mean: [f64; 7],
    pub max: [u32; 7],
    /// Rays ended by a step cap.
    pub capped: u64,
}

impl StatsSummary {
    /// Column stems in the order of [`TraversalStats::fields`].
    pub const NAMES: [&'static str; 7] = [
        "interior", "leaves", "prims", "boxes", "planes", "restarts", "steps",
    ];

    pub fn from_stats(stats: &[TraversalStats]) -> Self {
        let mut sum = [0u64; 7];
        let mut max = [0u32; 7];
        let mut capped = 0u64;
        for s in stats {
            capped += (s.capped != 0) as u64;
            for (i, (_, v)) in s.fields().into_iter().enumerate() {
                sum[i] += v as u64;
                max[i] = max[i].max(v);
            }
        }
        let n = stats.len().max(1) as f64;
        StatsSummary {
            rays: stats.len() as u64,
            mean: sum.map(|s| s as f64 / n),
            max,
            capped,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nostats_is_zero_sized() {
        assert_eq!(std::mem::size_of::<NoStats>(), 0);
    }

    #[test]
    fn summary_means_and_maxima() {
        let a = TraversalStats {
            interior: 2,
            steps: 4,
            ..Default::default()
        };
        let b = TraversalStats {
            interior: 4,
            steps: 1,
            capped: 1,
            ..Default::default()
        };
        let s = StatsSummary::from_stats(&[a, b]);
        assert_eq!(s.capped, 1);
        assert_eq!(s.mean[0], 3.0);
        assert_eq!(s.max[0], 4);
        assert_eq!(s.mean[6], 2.5);
        assert_eq!(s.max[6], 4);
    }
}
