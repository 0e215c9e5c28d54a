//! Zero-cost traversal statistics.
//!
//! Kernels are generic over `C: Counter`. Timed runs use [`NoStats`], a zero-sized type whose
//! methods are empty and vanish after inlining; the counting pass uses [`TraversalStats`], one
//! per ray, kept in a local and written out once per ray (pbrt-v4's per-thread counters,
//! madmann91/bvh's `if constexpr (CaptureStats)`).
//!
//! The counters and their definitions are listed once, in [`crate::for_each_counter!`] (the same for
//! every structure; the sparse-boxes paper's Table 1 names `interior`, `leaves` and `prims`
//! N_I, N_L and r_ITM). `capped` marks a ray ended by its traversal's per-ray step cap
//! (traversals that may revisit nodes; [`crate::TraversalInfo::step_cap`]).

use serde::{Deserialize, Serialize};

/// Receives traversal events. Every method must be cheap; [`NoStats`] makes them free.
pub trait Counter: Default + Send {
    /// Whether this counter records anything (lets kernels skip bookkeeping entirely).
    const ENABLED: bool;
    /// An interior node was visited (`interior`).
    fn interior(&mut self);
    /// A leaf was visited, empty ones included (`leaves`).
    fn leaf(&mut self);
    /// `n` ray-primitive tests were performed (`prims`).
    fn prims(&mut self, n: u32);
    /// `n` ray-box (slab) tests were performed (`boxes`).
    fn boxes(&mut self, n: u32);
    /// `n` ray-splitting-plane distances were computed (`planes`).
    fn planes(&mut self, n: u32);
    /// A restart from the root or a pushed-down node, or a backtrack up the tree (`restarts`).
    fn restart(&mut self);
    /// `n` traversal steps, as the structure defines them (`steps`).
    fn steps(&mut self, n: u32);
    /// A grid cell was visited (N_T of the grid papers).
    fn cell(&mut self);
    /// One step up a parent link between augmented nodes (sparse boxes, Havran and Bittner
    /// 2007 §5.2-§5.3).
    fn up(&mut self);
    /// The ray was ended by a traversal's step cap (at most once per ray).
    fn capped(&mut self);
    /// A point-location walk handed the ray to a fallback walk where a single point cannot
    /// decide (at most once per ray): sparse boxes' `sltr` to `sltr-mask` (Havran and Bittner
    /// 2007 §5.3, made exact), the kd-tree's `sequential` and `ropes` to `restart`.
    fn handover(&mut self);
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
    fn cell(&mut self) {}
    #[inline(always)]
    fn up(&mut self) {}
    #[inline(always)]
    fn capped(&mut self) {}
    #[inline(always)]
    fn handover(&mut self) {}
}

/// Calls `$callback! { $($prefix)* name, per_ray_column, max_column, "definition"; … }` with
/// the list of per-ray counters: **the one place the counter set is written**. Everything
/// else derives from it: [`TraversalStats`]'s fields, [`COUNTERS`], [`StatsSummary`], the
/// harness's result columns and baseline check, the GPU kernels' `Stats` record
/// ([`wgsl_stats_struct`]). A new counter (a grid's cells, a multi-kd-tree's plane steps) is
/// one line here; structures that do not report it leave it out of their
/// [`crate::TraversalInfo::counters`] and their rows leave its columns empty.
#[macro_export]
macro_rules! for_each_counter {
    ($callback:ident ! { $($prefix:tt)* }) => {
        $callback! { $($prefix)*
            interior, interior_per_ray, interior_max,
                "interior nodes visited (popped or descended into and processed)";
            leaves, leaves_per_ray, leaves_max, "leaves visited (empty ones included)";
            prims, prims_per_ray, prims_max, "ray-primitive tests performed";
            boxes, boxes_per_ray, boxes_max, "ray-box (slab) tests performed";
            planes, planes_per_ray, planes_max, "ray-splitting-plane distances computed";
            restarts, restarts_per_ray, restarts_max,
                "restarts from the root or a pushed-down node, and backtracks up the tree";
            steps, steps_per_ray, steps_max,
                "traversal steps, as each structure defines them (for trees: nodes visited)";
            cells, cells_per_ray, cells_max, "grid cells visited (N_T of the grid papers)";
            ups, ups_per_ray, ups_max,
                "steps up a parent link between augmented nodes (sparse boxes)";
            handovers, handovers_per_ray, handovers_max,
                "rays a point-location walk handed to a fallback walk where one point cannot decide (0 or 1 a ray: the mean is the share handed over)";
        }
    };
}

/// One per-ray counter: its name and definition.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CounterDef {
    /// Field and column stem (`interior` → `interior_per_ray`, `interior_max`).
    pub name: &'static str,
    /// Column of its mean per ray.
    pub per_ray: &'static str,
    /// Column of its maximum over the rays.
    pub max: &'static str,
    /// What it counts (the same for every structure; README "Results columns").
    pub doc: &'static str,
}

macro_rules! define_stats {
    ($($name:ident, $per:ident, $max:ident, $doc:literal;)*) => {
        /// Per-ray traversal counts (`#[repr(C)]`, one `u32` per counter of
        /// [`crate::for_each_counter!`] and then `capped`, so a GPU kernel writes the same record).
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
        pub struct TraversalStats {
            $( #[doc = $doc] pub $name: u32, )*
            /// 1 when the ray was ended by the traversal's step cap, else 0 (not one of
            /// [`COUNTERS`]: summed, not averaged, in [`StatsSummary::capped`]).
            pub capped: u32,
        }

        /// The per-ray counters, in record order.
        pub const COUNTERS: &[CounterDef] = &[$(
            CounterDef {
                name: stringify!($name),
                per_ray: stringify!($per),
                max: stringify!($max),
                doc: $doc,
            },
        )*];

        impl TraversalStats {
            /// The counters' values in the order of [`COUNTERS`].
            pub fn values(&self) -> [u32; N_COUNTERS] {
                [$(self.$name),*]
            }

            /// A record from the `u32` words a GPU kernel wrote ([`COUNTERS`] then `capped`).
            pub fn from_words(w: &[u32; N_COUNTERS + 1]) -> Self {
                let mut it = w.iter().copied();
                let mut next = || it.next().unwrap_or(0);
                TraversalStats { $( $name: next(), )* capped: next() }
            }
        }
    };
}

for_each_counter!(define_stats! {});

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
    fn cell(&mut self) {
        self.cells += 1;
    }
    #[inline(always)]
    fn up(&mut self) {
        self.ups += 1;
    }
    #[inline(always)]
    fn capped(&mut self) {
        self.capped = 1;
    }
    #[inline(always)]
    fn handover(&mut self) {
        self.handovers += 1;
    }
}

/// Number of per-ray counters ([`COUNTERS`]).
pub const N_COUNTERS: usize = COUNTERS.len();

const _: () = assert!(
    std::mem::size_of::<TraversalStats>() == 4 * (N_COUNTERS + 1),
    "TraversalStats is one u32 per counter plus capped"
);

impl TraversalStats {
    /// `(name, value)` of every counter, in the order of [`COUNTERS`].
    pub fn fields(&self) -> [(&'static str, u32); N_COUNTERS] {
        let v = self.values();
        std::array::from_fn(|i| (COUNTERS[i].name, v[i]))
    }
}

/// The GPU kernels' per-ray counter record, generated from [`COUNTERS`] so that it always
/// matches [`TraversalStats`] word for word: `struct Stats { interior: u32, …, capped: u32 }`
/// and `fn zero_stats() -> Stats`.
pub fn wgsl_stats_struct() -> String {
    let fields: Vec<String> = COUNTERS
        .iter()
        .map(|c| format!("{}: u32", c.name))
        .chain(["capped: u32".to_string()])
        .collect();
    let zeros = ["0u"; N_COUNTERS + 1].join(", ");
    format!(
        "struct Stats {{ {} }}\nfn zero_stats() -> Stats {{ return Stats({zeros}); }}\n",
        fields.join(", ")
    )
}

/// A set of counters (a bit per entry of [`COUNTERS`]): the ones a traversal reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CounterSet(pub u32);

impl CounterSet {
    /// Every counter of [`COUNTERS`] (structures that count with [`TraversalStats`]).
    pub const ALL: CounterSet = CounterSet((1 << N_COUNTERS) - 1);
    /// None (libraries that expose no counters, such as the peers).
    pub const NONE: CounterSet = CounterSet(0);

    /// Whether counter number `i` of [`COUNTERS`] is in the set.
    pub const fn contains(self, i: usize) -> bool {
        self.0 >> i & 1 == 1
    }

    /// Whether the set is empty.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }
}

/// Mean and maximum per ray of each counter over a batch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StatsSummary {
    /// Number of rays summarised.
    pub rays: u64,
    /// Mean per ray of each counter, in the order of [`COUNTERS`].
    pub mean: [f64; N_COUNTERS],
    /// Maximum over the rays of each counter, in the order of [`COUNTERS`].
    pub max: [u32; N_COUNTERS],
    /// Rays ended by a step cap.
    pub capped: u64,
}

impl StatsSummary {
    /// The summary of one batch's per-ray records.
    pub fn from_stats(stats: &[TraversalStats]) -> Self {
        let mut sum = [0u64; N_COUNTERS];
        let mut max = [0u32; N_COUNTERS];
        let mut capped = 0u64;
        for s in stats {
            capped += (s.capped != 0) as u64;
            for (i, v) in s.values().into_iter().enumerate() {
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
