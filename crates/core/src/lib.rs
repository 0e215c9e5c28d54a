//! trace-bench core: the vocabulary every acceleration structure shares.
//!
//! - [`geom`]: rays, boxes, triangles and hits (`#[repr(C)]`, uploadable to the GPU unchanged);
//! - [`tri`]: the two triangle tests (Möller–Trumbore 1997; Woop, Benthin, Wald 2013);
//! - [`stats`]: the [`Counter`] trait with the zero-sized [`NoStats`] and [`TraversalStats`];
//! - [`accel`]: the object-safe [`Accel`] interface (one virtual call per ray batch) and the
//!   [`Kernel`] trait whose monomorphised variants a structure dispatches to;
//! - [`params`](mod@params): parameter tables declared next to the fields ([`params!`], [`choice!`]);
//! - [`gpu`]: the wgpu-free description of a structure's GPU program;
//! - [`clip`]: conservative boxes of triangles clipped to boxes (kd-tree and SBVH builders);
//! - [`persist`]: saving a built structure and loading it again (the build cache);
//! - [`oracle`]: brute force, the ground truth;
//! - [`par`]: the one way a batch is traced on the CPU (rayon, chunks of rays);
//! - [`slab`]: the octant-specialised, NaN-safe slab test of the hierarchy traversals;
//! - [`compare`](mod@compare): the documented rule deciding whether a structure's answer matches the oracle.

#![deny(missing_docs)]

pub mod accel;
pub mod clip;
pub mod compare;
pub mod geom;
pub mod gpu;
pub mod leaves;
pub mod oracle;
pub mod par;
pub mod params;
pub mod persist;
pub mod slab;
pub mod stack;
pub mod stats;
pub mod tri;

pub use accel::{
    build_with, dispatch, Accel, AccelError, Answers, Batch, BuildFn, BuildReport, Codec, Family,
    FinishFn, HintFn, Kernel, MemoryReport, Query, Stage, Structure, TraceFn, Traversal,
    TraversalInfo, FIRST_METHOD,
};
pub use compare::{
    compare, compare_any, compare_closest, hex_f32, t_tolerance, Mismatch, MismatchKind, T_REL_TOL,
    T_ULPS,
};
pub use geom::{Aabb, HitRecord, Ray, Triangle, Vec3};
pub use gpu::{GpuArrange, GpuBuffer, GpuProgram};
pub use oracle::BruteForce;
pub use params::{
    ParamError, ParamKind, ParamRules, ParamSet, ParamSpec, ParamType, ParamValue, Params,
};
pub use persist::Persist;
pub use stats::{
    Counter, CounterDef, CounterSet, NoStats, StatsSummary, TraversalStats, COUNTERS, N_COUNTERS,
};
pub use tri::{Lanes4, MollerTrumbore, Tri4, TriTest, TriTestKind, Watertight};

#[doc(hidden)]
pub use serde as __serde;
