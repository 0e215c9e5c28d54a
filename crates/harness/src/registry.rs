//! The registry of named structures: config name → builder, parameters, traversals, doc.
//! `trace-bench list` prints it (pbrt's `CreateAccelerator`, ripgrep's flag table).
//!
//! Where a new structure goes: add its crate to the workspace, then one [`StructureInfo`]
//! entry here with a `build` function converting the checked [`ParamSet`] to the structure's
//! own params struct.

use crate::params::{ParamKind, ParamSet, ParamSpec};
use tb_core::{Accel, BruteForce, TraversalInfo, Triangle};

/// A builder: triangles and checked parameters to a built structure, or why not.
pub type BuildFn = fn(&[Triangle], &ParamSet) -> Result<Box<dyn Accel>, String>;

/// One buildable structure.
pub struct StructureInfo {
    /// Config name (`name = "bvh"` in a `[[structure]]` table).
    pub name: &'static str,
    /// One line: what it is and its paper.
    pub doc: &'static str,
    pub params: &'static [ParamSpec],
    /// The traversals every build of it offers (index = position).
    pub traversals: &'static [TraversalInfo],
    /// Build from triangles with checked parameters.
    pub build: BuildFn,
}

const BVH_PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "bins",
        kind: ParamKind::Int { min: 2, max: 256 },
        default: "16",
        doc: "SAH bins per axis (Wald 2007, binned SAH)",
    },
    ParamSpec {
        name: "max_leaf",
        kind: ParamKind::Int { min: 1, max: 255 },
        default: "4",
        doc: "largest leaf; larger nodes are always split",
    },
    ParamSpec {
        name: "min_leaf",
        kind: ParamKind::Int { min: 1, max: 255 },
        default: "1",
        doc: "nodes this small always become leaves",
    },
    ParamSpec {
        name: "c_trav",
        kind: ParamKind::Float {
            min: 1e-6,
            max: 1e6,
        },
        default: "1.0",
        doc: "SAH cost of a traversal step, C_trav (MacDonald and Booth 1990)",
    },
    ParamSpec {
        name: "c_isect",
        kind: ParamKind::Float {
            min: 1e-6,
            max: 1e6,
        },
        default: "1.0",
        doc: "SAH cost of a triangle test, C_isect",
    },
];

const RTREE_PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "m",
        kind: ParamKind::Int { min: 2, max: 8 },
        default: "2",
        doc: "least entries per node, m (Feldmann section 2.2; 2 <= m <= M/2)",
    },
    ParamSpec {
        name: "big_m",
        kind: ParamKind::Int { min: 4, max: 16 },
        default: "4",
        doc: "most entries per node, M (Feldmann section 2.2)",
    },
    ParamSpec {
        name: "strategy",
        kind: ParamKind::Choice(&[
            "min-volume",
            "min-surface",
            "min-overlap",
            "r-star",
            "r-star-srfc",
            "str",
        ]),
        default: "r-star-srfc",
        doc: "ChooseSubtree strategy (section 5.1, Table 1), or Sort-Tile-Recursive bulk loading",
    },
    ParamSpec {
        name: "reinsert",
        kind: ParamKind::Bool,
        default: "true",
        doc: "forced reinsertion on overflow (R*-tree; Table 2)",
    },
    ParamSpec {
        name: "reinsert_share",
        kind: ParamKind::Float {
            min: 0.01,
            max: 0.5,
        },
        default: "0.3",
        doc: "share of entries a forced reinsertion ejects (Beckmann et al. 1990: 30%)",
    },
    ParamSpec {
        name: "child_order",
        kind: ParamKind::Choice(&["insertion", "sorted-x", "sorted-y", "sorted-z"]),
        default: "insertion",
        doc: "order of the entries within a packed node (section 3.1, Figure 3)",
    },
];

const KD_PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "builder",
        kind: ParamKind::Choice(&["sweep", "sweep-nlog2n", "binned"]),
        default: "sweep",
        doc: "exact SAH event sweep O(N log N) / O(N log^2 N) (Wald and Havran 2006), min-max binning (Shevtsov et al. 2007)",
    },
    ParamSpec {
        name: "bins",
        kind: ParamKind::Int { min: 2, max: 1024 },
        default: "32",
        doc: "bins per axis, `binned` builder only",
    },
    ParamSpec {
        name: "c_trav",
        kind: ParamKind::Float { min: 1e-6, max: 1e6 },
        default: "1.0",
        doc: "SAH traversal cost C_trav (Hapala and Havran 2011, section 2)",
    },
    ParamSpec {
        name: "c_isect",
        kind: ParamKind::Float { min: 1e-6, max: 1e6 },
        default: "1.5",
        doc: "SAH triangle test cost C_isect",
    },
    ParamSpec {
        name: "empty_bonus",
        kind: ParamKind::Float { min: 0.0, max: 0.999 },
        default: "0.2",
        doc: "a split with an empty side costs (1 - bonus) times the SAH",
    },
    ParamSpec {
        name: "max_depth",
        kind: ParamKind::Int { min: 0, max: 64 },
        default: "0",
        doc: "depth limit; 0 = round(8 + 1.3 log2 N) (Havran)",
    },
    ParamSpec {
        name: "min_leaf",
        kind: ParamKind::Int { min: 0, max: 1024 },
        default: "1",
        doc: "nodes with at most this many triangles become leaves",
    },
    ParamSpec {
        name: "short_stack",
        kind: ParamKind::Int { min: 1, max: 32 },
        default: "4",
        doc: "entries of the short stack (`short-stack` traversal; Horn et al. 2007)",
    },
    ParamSpec {
        name: "step_cap",
        kind: ParamKind::Int {
            min: 1,
            max: 1 << 30,
        },
        default: "100000",
        doc: "per-ray step cap of the restart-type traversals; capped rays are counted",
    },
    ParamSpec {
        name: "layout",
        kind: ParamKind::Choice(&["depth-first", "treelet"]),
        default: "depth-first",
        doc: "node layout: left child next to its parent, or subtrees in aligned blocks (Havran 1999; Hapala and Havran 2011, section 6)",
    },
    ParamSpec {
        name: "treelet_height",
        kind: ParamKind::Int { min: 2, max: 8 },
        default: "3",
        doc: "levels per treelet block, 2^h 8-byte slots (3 = one 64-byte cache line)",
    },
];

fn build_kdtree(tris: &[Triangle], p: &ParamSet) -> Result<Box<dyn Accel>, String> {
    let params = tb_kdtree::KdParams {
        builder: match p.str("builder") {
            "sweep" => tb_kdtree::KdBuilder::Sweep,
            "sweep-nlog2n" => tb_kdtree::KdBuilder::SweepNlog2n,
            _ => tb_kdtree::KdBuilder::Binned,
        },
        bins: p.int("bins") as u32,
        c_trav: p.float("c_trav") as f32,
        c_isect: p.float("c_isect") as f32,
        empty_bonus: p.float("empty_bonus") as f32,
        max_depth: p.int("max_depth") as u32,
        min_leaf: p.int("min_leaf") as u32,
        short_stack: p.int("short_stack") as u32,
        step_cap: p.int("step_cap") as u32,
        layout: match p.str("layout") {
            "treelet" => tb_kdtree::KdLayout::Treelet,
            _ => tb_kdtree::KdLayout::DepthFirst,
        },
        treelet_height: p.int("treelet_height") as u32,
    };
    params.check()?;
    Ok(Box::new(tb_kdtree::KdTree::build(tris, &params)))
}

fn build_rtree(tris: &[Triangle], p: &ParamSet) -> Result<Box<dyn Accel>, String> {
    let params = tb_rtree::RtreeParams {
        m: p.int("m") as u32,
        big_m: p.int("big_m") as u32,
        strategy: tb_rtree::Strategy::from_name(p.str("strategy")).ok_or("unknown strategy")?,
        reinsert: p.bool("reinsert"),
        reinsert_share: p.float("reinsert_share") as f32,
        child_order: tb_rtree::ChildOrder::from_name(p.str("child_order"))
            .ok_or("unknown child order")?,
    };
    Ok(Box::new(tb_rtree::Rtree::try_build(tris, &params)?))
}

#[cfg(feature = "embree")]
const EMBREE_PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "quality",
        kind: ParamKind::Choice(&["low", "medium", "high"]),
        default: "high",
        doc: "RTC_BUILD_QUALITY (high: spatial splits)",
    },
    ParamSpec {
        name: "compact",
        kind: ParamKind::Bool,
        default: "false",
        doc: "RTC_SCENE_FLAG_COMPACT",
    },
    ParamSpec {
        name: "robust",
        kind: ParamKind::Bool,
        default: "true",
        doc: "RTC_SCENE_FLAG_ROBUST",
    },
    ParamSpec {
        name: "build_threads",
        kind: ParamKind::Int { min: 0, max: 1024 },
        default: "1",
        doc: "Embree build threads (0 = all; 1 compares with our single-threaded builders)",
    },
];

#[cfg(feature = "embree")]
fn build_embree(tris: &[Triangle], p: &ParamSet) -> Result<Box<dyn Accel>, String> {
    let params = tb_peers::embree::EmbreeParams {
        quality: match p.str("quality") {
            "low" => 0,
            "medium" => 1,
            _ => 2,
        },
        compact: p.bool("compact"),
        robust: p.bool("robust"),
        build_threads: p.int("build_threads") as u32,
    };
    Ok(Box::new(tb_peers::embree::EmbreePeer::build(
        tris, &params,
    )?))
}

#[cfg(feature = "obvhs")]
const OBVHS_PARAMS: &[ParamSpec] = &[ParamSpec {
    name: "preset",
    kind: ParamKind::Choice(tb_peers::obvhs::PRESETS),
    default: "medium",
    doc: "obvhs BvhBuildParams preset",
}];

#[cfg(feature = "obvhs")]
fn build_obvhs(tris: &[Triangle], p: &ParamSet) -> Result<Box<dyn Accel>, String> {
    Ok(Box::new(tb_peers::obvhs::ObvhsPeer::build(
        tris,
        p.str("preset"),
    )?))
}

#[cfg(feature = "bvh-rs")]
fn build_bvh_rs(tris: &[Triangle], _: &ParamSet) -> Result<Box<dyn Accel>, String> {
    Ok(Box::new(tb_peers::bvh_rs::BvhRsPeer::build(tris)))
}

fn build_brute(tris: &[Triangle], _: &ParamSet) -> Result<Box<dyn Accel>, String> {
    Ok(Box::new(BruteForce::new(tris)))
}

/// The BVH parameters of a checked parameter set.
pub fn bvh_params(p: &ParamSet) -> tb_bvh::BvhParams {
    tb_bvh::BvhParams {
        bins: p.int("bins") as u32,
        max_leaf: p.int("max_leaf") as u32,
        min_leaf: p.int("min_leaf") as u32,
        c_trav: p.float("c_trav") as f32,
        c_isect: p.float("c_isect") as f32,
    }
}

fn build_bvh(tris: &[Triangle], p: &ParamSet) -> Result<Box<dyn Accel>, String> {
    let params = bvh_params(p);
    params.check()?;
    Ok(Box::new(tb_bvh::Bvh::build(tris, &params)))
}

static STRUCTURES: &[StructureInfo] = &[
    StructureInfo {
        name: "brute-force",
        doc: "every ray against every triangle: the oracle",
        params: &[],
        traversals: tb_core::oracle::TRAVERSALS,
        build: build_brute,
    },
    StructureInfo {
        name: "bvh",
        doc: "binned SAH BVH, 32-byte flat nodes (MacDonald and Booth 1990; Wald 2007)",
        params: BVH_PARAMS,
        traversals: tb_bvh::TRAVERSALS,
        build: build_bvh,
    },
    StructureInfo {
        name: "kdtree",
        doc: "SAH kd-tree with perfect splits, 8-byte nodes; the traversals of the kd-tree review (Hapala and Havran 2011)",
        params: KD_PARAMS,
        traversals: tb_kdtree::TRAVERSALS,
        build: build_kdtree,
    },
    StructureInfo {
        name: "rtree",
        doc: "R-tree by successive insertion, packed level-order layout (Feldmann, R-trees)",
        params: RTREE_PARAMS,
        traversals: tb_rtree::TRAVERSALS,
        build: build_rtree,
    },
    #[cfg(feature = "embree")]
    StructureInfo {
        name: "embree",
        doc: "peer: Intel Embree 3 single rays (feature `embree`)",
        params: EMBREE_PARAMS,
        traversals: tb_peers::NATIVE,
        build: build_embree,
    },
    #[cfg(feature = "obvhs")]
    StructureInfo {
        name: "obvhs",
        doc: "peer: obvhs PLOC-built compressed wide BVH8 (feature `obvhs`)",
        params: OBVHS_PARAMS,
        traversals: tb_peers::NATIVE,
        build: build_obvhs,
    },
    #[cfg(feature = "bvh-rs")]
    StructureInfo {
        name: "bvh-rs",
        doc:
            "peer: the `bvh` crate (svenstaro), closest hit from its candidates (feature `bvh-rs`)",
        params: &[],
        traversals: tb_peers::NATIVE,
        build: build_bvh_rs,
    },
];

/// All registered structures.
pub fn structures() -> &'static [StructureInfo] {
    STRUCTURES
}

/// The structure named `name`.
pub fn find(name: &str) -> Option<&'static StructureInfo> {
    STRUCTURES.iter().find(|s| s.name == name)
}

/// The accelerator used to generate secondary rays (shadow, AO, path bounces) from primary
/// hits: the default BVH with the experiment's triangle test. It is built only when a scene
/// asks for secondary rays.
pub fn generator(tris: &[Triangle]) -> Box<dyn Accel> {
    Box::new(tb_bvh::Bvh::build(tris, &tb_bvh::BvhParams::default()))
}

/// The listing printed by `trace-bench list`.
pub fn listing() -> String {
    let mut s = String::new();
    for st in STRUCTURES {
        s.push_str(&format!("{:<14} {}\n", st.name, st.doc));
        for t in st.traversals {
            s.push_str(&format!("  traversal {:<18} {}\n", t.name, t.doc));
        }
        for p in st.params {
            s.push_str(&format!(
                "  param {:<22} default {:<6} {}\n",
                p.name, p.default, p.doc
            ));
        }
    }
    s
}
