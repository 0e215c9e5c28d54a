//! The multi-kd-tree's build parameters (its table: `trace-bench list`): the measure and the trees, then the kd-tree's, composed.

use crate::measure::Heuristic;
#[cfg(doc)]
use crate::MultiKdTree;
use tb_core::ParamKind;
use tb_kdtree::{KdParams, SahParams};

tb_core::choice! {
    /// Which trees a [`MultiKdTree`] holds.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Trees {
        /// One tree per patch, each ray the tree of its patch (§5).
        Multi = "multi",
        /// Only patch X's tree, traversed by every ray (control).
        X = "x",
        /// Only patch Y's tree, traversed by every ray (control).
        Y = "y",
        /// Only patch Z's tree, traversed by every ray (control).
        Z = "z",
    }
}

tb_core::params! {
    /// Build parameters of [`MultiKdTree`]: the heuristic and the trees, then the kd-tree's
    /// own parameters ([`KdParams`]; `c_isect` defaults to the paper's 1).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct MultiKdParams {
        /// Cell measure of the trees (Torres et al. 2012 §3-4): `sah`, `sphere-orth`,
        /// `sphere-obli`, `cube-orth`, `cube-obli`, `cos-orth`, `cos-obli`.
        measure: Heuristic = Heuristic::SphereOrth, ParamKind::Choice(Heuristic::NAMES);
        /// Exponent of the cosine heuristics' density `(ω·N)^β` (§4.3; the paper sweeps
        /// 0.5 to 20).
        beta: f32 = 2.0, ParamKind::Float { min: 0.01, max: 100.0 };
        /// `multi`: a tree per patch, chosen per ray; `x`, `y`, `z`: that patch's tree alone,
        /// for every ray (control).
        trees: Trees = Trees::Multi, ParamKind::Choice(Trees::NAMES);
        /// The kd-tree's parameters, each tree's (tb-kdtree's [`KdParams`], composed, not
        /// copied), with the paper's triangle cost: `c_isect` = `Cost_tri` = 1 (§7).
        @flatten
        kd: KdParams = KdParams {
            sah: SahParams { c_isect: 1.0, ..SahParams::default() },
            ..KdParams::default()
        };
    }
}

/// No rules beyond the ranges.
impl tb_core::ParamRules for MultiKdParams {}
