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
