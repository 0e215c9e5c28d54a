//! The build parameters of sparse boxes (its table: `trace-bench list`): `d_min` and the kd-tree's, composed.

use tb_core::ParamKind;
use tb_kdtree::{KdLayout, KdParams, SahParams};

tb_core::params! {
    /// Build parameters: `d_min`, the kd-tree's SAH split search (tb-kdtree's [`SahParams`],
    /// composed, not copied) and the step cap; the tree is laid out depth-first.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct SparseParams {
        /// d_min: an interior node is augmented when its depth distance to the nearest
        /// augmented ancestor exceeds d_min (Havran and Bittner 2007 §4; the root always is).
        d_min: u32 = 2, ParamKind::Int { min: 1, max: 16 };
        /// the kd-tree's SAH split search (tb-kdtree's [`SahParams`])
        @flatten
        sah: SahParams = SahParams::default();
        /// Per-ray step cap of SLTR and SEQ (a guard; capped rays are counted).
        step_cap: u32 = tb_kdtree::STEP_CAP, ParamKind::Int { min: 1, max: 1 << 30 };
    }
}

impl SparseParams {
    /// The kd-tree's parameters (depth-first layout).
    pub fn kd(&self) -> KdParams {
        KdParams {
            sah: self.sah,
            step_cap: self.step_cap,
            layout: KdLayout::DepthFirst,
            ..KdParams::default()
        }
    }

    /// Levels between augmented nodes: `d_min + 1`.
    pub fn period(&self) -> u32 {
        self.d_min + 1
    }
}

/// No rules beyond the ranges: the kd-tree parameters it composes are in range when its own
/// entries are.
impl tb_core::ParamRules for SparseParams {}
