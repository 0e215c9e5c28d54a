//! The acceleration-structure interface.
//!
//! Dynamic dispatch happens once per ray batch ([`Accel::trace`]); inside, a structure picks a
//! monomorphised [`Kernel`] variant with [`dispatch`] (one per traversal x query x triangle test
//! x counter), so no virtual call or branch on configuration happens per node
//! (STYLE.md, "dynamic dispatch only at the batch edge").
//!
//! The seam a structure crate implements is [`Structure`]: its name, its traversal table
//! ([`Traversal`]: the facts of each traversal in a [`TraversalInfo`], its CPU kernel and, where
//! it has one, its [`GpuProgram`]) and its figures. [`Accel`], the object-safe interface the
//! harness, renderer and tests use, is derived from it; [`Family`] (one `static` per crate) is
//! what the harness's registry lists: name, doc, parameter table ([`crate::params`](mod@crate::params)) and
//! builder.
//!
//! How the interface fits the structures of the five papers:
//! - one build serves several traversals: the table lists them and [`Accel::trace`] takes the
//!   index (kd-tree review: sequential, restart, push-down, …; R-trees: stackless, ordered,
//!   stack); traversals that need extra build data name it in [`TraversalInfo::aux`] and
//!   build it on first use ([`Accel::prepare`]);
//! - a kernel sees one ray at a time and may keep any per-ray state (entry/exit intervals,
//!   restarts, short stacks, the tree chosen by direction for multi-kd-trees, a start node for
//!   sparse boxes, the cell walk of irregular grids);
//! - threading is the caller's: the runner splits a batch across threads and calls `trace` on
//!   each chunk, so structures contain no threading code.

use crate::geom::{HitRecord, Ray, Triangle};
use crate::gpu::GpuProgram;
use crate::params::{defaults_of, ParamError, ParamSet, ParamSpec, Params};
use crate::stats::{Counter, CounterSet, NoStats, TraversalStats};
use crate::tri::{MollerTrumbore, TriTest, TriTestKind, Watertight};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Which query a batch asks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Query {
    /// Closest hit in `[tmin, tmax)` (primary, ao-free bounces, random rays).
    Closest,
    /// Any hit in `[tmin, tmax)`, stopping at the first found (shadow and AO rays).
    Any,
}

/// A traversal algorithm a structure offers: everything the harness and `trace-bench list`
/// need to know about it, declared once in the structure's traversal table ([`Traversal`]).
#[derive(Clone, Copy, Debug)]
pub struct TraversalInfo {
    /// Config name, kebab-case (e.g. `ordered`, `short-stack`).
    pub name: &'static str,
    /// One line: the algorithm and its papers.
    pub doc: &'static str,
    /// The paper and section it reproduces (e.g. `Hapala & Havran 2011 §5.1`).
    pub paper: &'static str,
    /// It ends rays after a per-ray step cap and counts them ([`crate::Counter::capped`]);
    /// its rows report `capped_rays`.
    pub step_cap: bool,
    /// Auxiliary arrays it reads beyond the structure's own ([`Structure::aux_bytes`] names
    /// their sizes; [`Accel::prepare`] builds them): its memory is the structure's plus these
    /// (the kd-tree review's Table 3 "additional memory").
    pub aux: &'static [&'static str],
    /// The counters it reports; the others' columns stay empty (peers report none).
    pub counters: CounterSet,
    /// The triangle test it always uses when it ignores the requested one (Embree's own
    /// intersector); `None` when it honours [`TriTestKind`].
    pub own_triangle_test: Option<&'static str>,
    /// Run only where a config names it (`traversals = [...]`, `--structure NAME:traversal`),
    /// not by a table that lists no traversals: a baseline kept for the papers that compare
    /// against it (the BVH's `while-while`), which every other config would otherwise run.
    pub on_request: bool,
    /// On the CPU this traversal is another's walk (named): a GPU-side variant (the BVH's
    /// `while-while-speculative`, whose speculation needs a subgroup). Its CPU kernel stays
    /// (tests check the GPU program against it), but runs make no CPU rows for it, only a row
    /// whose note names the walk, so the same walk is not timed twice.
    pub cpu_as: Option<&'static str>,
}

impl TraversalInfo {
    /// A traversal reporting every counter, no step cap, no auxiliary arrays.
    pub const fn new(name: &'static str, paper: &'static str, doc: &'static str) -> Self {
        TraversalInfo {
            name,
            doc,
            paper,
            step_cap: false,
            aux: &[],
            counters: CounterSet::ALL,
            own_triangle_test: None,
            on_request: false,
            cpu_as: None,
        }
    }

    /// On the CPU, traversal `walk`'s walk ([`TraversalInfo::cpu_as`]).
    pub const fn cpu_as(mut self, walk: &'static str) -> Self {
        self.cpu_as = Some(walk);
        self
    }

    /// Run only where a config names it ([`TraversalInfo::on_request`]).
    pub const fn on_request(mut self) -> Self {
        self.on_request = true;
        self
    }

    /// With a per-ray step cap.
    pub const fn capped(mut self) -> Self {
        self.step_cap = true;
        self
    }

    /// Reading the auxiliary arrays `aux`.
    pub const fn reads(mut self, aux: &'static [&'static str]) -> Self {
        self.aux = aux;
        self
    }

    /// Reporting only `counters`.
    pub const fn counting(mut self, counters: CounterSet) -> Self {
        self.counters = counters;
        self
    }

    /// Always using its own triangle test `name`.
    pub const fn own_test(mut self, name: &'static str) -> Self {
        self.own_triangle_test = Some(name);
        self
    }
}

/// One batch to trace: the query every ray asks, the triangle test, the rays and, for a
/// traversal that takes them ([`Traversal::with_hints`]), one start hint per ray
/// ([`Accel::batch_hints`]). The trace signature's inputs in one value ([`Accel::trace`],
/// [`TraceFn`], [`dispatch`]); its outputs are an [`Answers`].
#[derive(Clone, Copy, Debug)]
pub struct Batch<'a> {
    /// Whether each ray asks for the closest hit or any hit.
    pub query: Query,
    /// The ray-triangle test the kernel runs.
    pub tri: TriTestKind,
    /// The rays to trace.
    pub rays: &'a [Ray],
    /// One start hint per ray, or `None`: the kernel finds its starts itself.
    pub hints: Option<&'a [u32]>,
}

impl<'a> Batch<'a> {
    /// `rays` asking `query` with triangle test `tri`, without start hints.
    pub fn new(query: Query, tri: TriTestKind, rays: &'a [Ray]) -> Self {
        Batch {
            query,
            tri,
            rays,
            hints: None,
        }
    }

    /// This batch with start hints `hints` (one per ray; `None`: none).
    pub fn with_hints(self, hints: Option<&'a [u32]>) -> Self {
        if let Some(h) = hints {
            assert_eq!(h.len(), self.rays.len(), "one hint per ray");
        }
        Batch { hints, ..self }
    }

    /// Its rays from `range` (and their hints).
    pub fn slice(self, range: std::ops::Range<usize>) -> Self {
        Batch {
            rays: &self.rays[range.clone()],
            hints: self.hints.map(|h| &h[range]),
            ..self
        }
    }

    /// Its consecutive parts of `n` rays (the last may be shorter), hints split alike.
    pub fn chunks(self, n: usize) -> impl Iterator<Item = Batch<'a>> {
        let len = self.rays.len();
        (0..len.div_ceil(n)).map(move |i| self.slice(i * n..((i + 1) * n).min(len)))
    }
}

/// Where a traced batch's answers go: one hit record per ray and, when counting, one counter
/// record per ray (`None`: counters compiled out, the timed pass).
#[derive(Debug)]
pub struct Answers<'a> {
    /// One hit record per ray, written by the kernel.
    pub hits: &'a mut [HitRecord],
    /// One counter record per ray when counting; `None` in the timed pass.
    pub stats: Option<&'a mut [TraversalStats]>,
}

impl<'a> Answers<'a> {
    /// Hit records only (the timed pass).
    pub fn hits(hits: &'a mut [HitRecord]) -> Self {
        Answers { hits, stats: None }
    }

    /// Hit records and, when `stats` is given, counter records.
    pub fn new(hits: &'a mut [HitRecord], stats: Option<&'a mut [TraversalStats]>) -> Self {
        if let Some(s) = &stats {
            assert_eq!(hits.len(), s.len(), "one stats record per hit record");
        }
        Answers { hits, stats }
    }

    /// The same records, borrowed again (to pass on and use after).
    pub fn reborrow(&mut self) -> Answers<'_> {
        Answers {
            hits: self.hits,
            stats: self.stats.as_deref_mut(),
        }
    }
}

/// Traces a batch with one traversal of structure `S` (single-threaded; see [`Accel::trace`]).
/// Write a table's kernels with [`kernel!`](crate::kernel), not as closures.
pub type TraceFn<S> = fn(&S, Batch<'_>, Answers<'_>);

/// The GPU program of one traversal of a build of `S`.
pub type GpuFn<S> = for<'a> fn(&'a S) -> GpuProgram<'a>;

/// Computes one start hint per ray of a batch ([`Accel::batch_hints`]): what a traversal that
/// may begin below the root (sparse boxes' start nodes, Havran and Bittner 2007 §3) would
/// otherwise find per ray, found once per batch by the caller, outside any timing.
pub type HintFn<S> = fn(&S, Query, &[Ray]) -> Vec<u32>;

/// A traversal table's CPU kernel, `kernel!(|s: &S, batch, out| body)`: a named function of
/// [`TraceFn`]'s type, never inlined. Written as a closure, a table's kernel is inlinable
/// across crates (rustc treats closures as `#[inline]`), so every crate that used the
/// structure (each test binary, the harness) compiled every kernel of its table again: minutes
/// of CI. Named, it is compiled once, in the structure's crate. `S` must be named (a nested
/// function cannot see `Self`).
#[macro_export]
macro_rules! kernel {
    (|$s:ident: &$S:ty, $b:ident, $o:ident| $body:block) => {{
        #[inline(never)]
        fn kernel($s: &$S, $b: $crate::Batch<'_>, $o: $crate::Answers<'_>) $body
        kernel as $crate::TraceFn<$S>
    }};
    (|$s:ident: &$S:ty, $b:ident, $o:ident| $body:expr) => {{
        #[inline(never)]
        fn kernel($s: &$S, $b: $crate::Batch<'_>, $o: $crate::Answers<'_>) {
            $body
        }
        kernel as $crate::TraceFn<$S>
    }};
}

/// One row of a structure's traversal table: the facts, the CPU kernel and, where there is
/// one, the GPU program and the start hints. Listing, dispatch, memory and GPU support all
/// derive from the table.
pub struct Traversal<S> {
    /// The traversal's facts: name, doc, paper, counters, auxiliary arrays.
    pub info: TraversalInfo,
    /// Its CPU kernel (written with [`kernel!`](crate::kernel)).
    pub trace: TraceFn<S>,
    /// Its GPU program, where the traversal has one.
    pub gpu: Option<GpuFn<S>>,
    /// Per-ray start hints computed once per batch by the caller, untimed (`None`: the
    /// traversal takes none, and its kernel gets batches without).
    pub hints: Option<HintFn<S>>,
}

impl<S> Traversal<S> {
    /// A row with a CPU kernel only.
    pub const fn cpu(info: TraversalInfo, trace: TraceFn<S>) -> Self {
        Traversal {
            info,
            trace,
            gpu: None,
            hints: None,
        }
    }

    /// A row with a CPU kernel and a GPU program.
    pub const fn with_gpu(info: TraversalInfo, trace: TraceFn<S>, gpu: GpuFn<S>) -> Self {
        Traversal {
            info,
            trace,
            gpu: Some(gpu),
            hints: None,
        }
    }

    /// This row taking per-ray start hints: `compute` finds them for a batch, the row's
    /// kernel reads them from [`Batch::hints`] (and must give the same answers without them).
    pub const fn with_hints(mut self, compute: HintFn<S>) -> Self {
        self.hints = Some(compute);
        self
    }
}

/// Memory used by a built structure, including every auxiliary array a traversal needs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MemoryReport {
    /// Total bytes of all arrays the traversals read (nodes, references, triangles).
    pub bytes: u64,
    /// The structure alone, as the papers' memory figures count it: nodes, references
    /// (indices), cells, voxel maps, boxes, ropes and the other auxiliary traversal arrays, but
    /// not the triangle array nor copies of scene geometry derived from it (reordered or
    /// precomputed triangles, the grids' plane-coordinate tables). `bytes - structure_bytes` is
    /// that geometry; each structure's `own_memory` says what it counts.
    #[serde(default)]
    pub structure_bytes: u64,
    /// Number of nodes (interior and leaves, including empty slots of implicit layouts).
    pub nodes: u64,
    /// Number of primitive references stored in leaves.
    pub prim_refs: u64,
    /// Size of one node in bytes.
    pub node_bytes: u32,
}

/// Structure-specific build figures, reported in the `build_stats` column and in JSON.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BuildReport {
    /// Surface-area-heuristic cost of the built tree, with the structure's own constants.
    pub sah_cost: Option<f64>,
    /// Further named figures (leaves, depth, empty leaves, …).
    pub extra: Vec<(String, f64)>,
}

/// Why a structure could not be built or is not sound (one line each).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AccelError {
    /// A parameter set that does not convert or fails the structure's own checks.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// Parameters that are each in range but not together (e.g. R-tree `m > M/2`).
    #[error("{0}")]
    Params(String),
    /// The scene exceeds what the structure can index.
    #[error("{what}: {count} is over the limit of {limit}")]
    TooLarge {
        /// What is over the limit (e.g. `BVH triangles`).
        what: &'static str,
        /// How many the scene needs.
        count: u64,
        /// The most the structure can index.
        limit: u64,
    },
    /// The structure cannot be built for this input with these parameters (the message says
    /// why and what to change).
    #[error("{0}")]
    Unsupported(String),
    /// [`Accel::validate`] found a broken invariant.
    #[error("invalid structure: {0}")]
    Invalid(String),
    /// An external library (a peer) refused.
    #[error("{library}: {message}")]
    Library {
        /// The peer library that refused.
        library: &'static str,
        /// The library's error message.
        message: String,
    },
}

/// What a structure crate implements: the structure's name, its traversal table and its
/// figures. Not object-safe; [`Accel`], its object-safe form, is implemented for every
/// `Structure` (one virtual call per ray batch, the table's kernel inside).
pub trait Structure: Send + Sync + Sized + 'static {
    /// Registry name (e.g. `bvh`).
    const NAME: &'static str;
    /// The traversal table; the index into it selects a traversal.
    const TRAVERSALS: &'static [Traversal<Self>];

    /// Memory of the arrays every traversal reads (nodes, references, triangles), with
    /// [`MemoryReport::structure_bytes`] the structure's own part of it; the names of this
    /// trait's methods differ from [`Accel`]'s so that both traits can be in scope.
    fn own_memory(&self) -> MemoryReport;

    /// Bytes of auxiliary array `aux` (one named in a [`TraversalInfo::aux`]), built or not.
    fn aux_bytes(&self, aux: &str) -> u64 {
        let _ = aux;
        0
    }

    /// Build auxiliary array `aux` now, if not yet built (traversals build what they read on
    /// first use otherwise).
    fn prepare_aux(&self, aux: &str) {
        let _ = aux;
    }

    /// Build figures (SAH cost and others).
    fn report(&self) -> BuildReport {
        BuildReport::default()
    }

    /// Check the structure's invariants.
    fn check(&self) -> Result<(), AccelError> {
        Ok(())
    }
}

/// A built acceleration structure, object-safe: derived from [`Structure`] for every
/// structure (a blanket implementation), implemented by hand only by test wrappers.
pub trait Accel: Send + Sync {
    /// Registry name of the structure (e.g. `bvh`).
    fn name(&self) -> &'static str;

    /// The traversal algorithms this build supports; the index selects one.
    fn traversals(&self) -> Vec<&'static TraversalInfo>;

    /// Memory of the arrays every traversal reads.
    fn memory(&self) -> MemoryReport;

    /// Memory that traversal number `traversal` reads: [`Accel::memory`] plus its auxiliary
    /// arrays (the kd-tree review's Table 3 "additional memory").
    fn memory_for(&self, traversal: usize) -> MemoryReport;

    /// Build figures (SAH cost and others).
    fn build_report(&self) -> BuildReport;

    /// Check the structure's invariants; `Err` names the first violation.
    fn validate(&self) -> Result<(), AccelError>;

    /// Build the auxiliary arrays traversal number `traversal` reads, so that its first
    /// traced batch does not pay for them.
    fn prepare(&self, traversal: usize);

    /// Trace `batch` with traversal number `traversal`, writing one record per ray to
    /// `out.hits` and, when `out.stats` is given, one counter record per ray.
    /// Single-threaded. The batch's hints are read only by a traversal that takes them.
    fn trace(&self, traversal: usize, batch: Batch<'_>, out: Answers<'_>);

    /// Per-ray start hints of traversal number `traversal` for `rays` (one per ray), for
    /// [`Batch::with_hints`]; `None` (the default) for traversals that take none. Callers
    /// compute them once per batch, outside timing.
    fn batch_hints(&self, traversal: usize, query: Query, rays: &[Ray]) -> Option<Vec<u32>> {
        let _ = (traversal, query, rays);
        None
    }

    /// Whether traversal number `traversal` has a GPU kernel (without building its program).
    fn has_gpu_program(&self, traversal: usize) -> bool;

    /// The GPU program of traversal number `traversal`, `None` where it has no GPU kernel.
    fn gpu_program(&self, traversal: usize) -> Option<GpuProgram<'_>>;

    /// The structure itself, for [`Codec::save`]'s downcast; `None` (the
    /// default) for test wrappers.
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        None
    }
}

fn row<S: Structure>(traversal: usize) -> &'static Traversal<S> {
    S::TRAVERSALS.get(traversal).unwrap_or_else(|| {
        panic!(
            "{}: no traversal {traversal} ({} available)",
            S::NAME,
            S::TRAVERSALS.len()
        )
    })
}

impl<S: Structure> Accel for S {
    fn name(&self) -> &'static str {
        S::NAME
    }

    fn traversals(&self) -> Vec<&'static TraversalInfo> {
        infos_of::<S>()
    }

    fn memory(&self) -> MemoryReport {
        self.own_memory()
    }

    fn memory_for(&self, traversal: usize) -> MemoryReport {
        let mut m = self.own_memory();
        let aux = row::<S>(traversal)
            .info
            .aux
            .iter()
            .map(|a| self.aux_bytes(a))
            .sum::<u64>();
        // Auxiliary arrays are traversal data (boxes, ropes, parent links): the structure's.
        m.bytes += aux;
        m.structure_bytes += aux;
        m
    }

    fn build_report(&self) -> BuildReport {
        self.report()
    }

    fn validate(&self) -> Result<(), AccelError> {
        self.check()
    }

    fn prepare(&self, traversal: usize) {
        for a in row::<S>(traversal).info.aux {
            self.prepare_aux(a);
        }
    }

    fn trace(&self, traversal: usize, batch: Batch<'_>, out: Answers<'_>) {
        let r = row::<S>(traversal);
        assert_eq!(batch.rays.len(), out.hits.len(), "one hit record per ray");
        let batch = match r.hints {
            Some(_) => batch.with_hints(batch.hints),
            None => batch.with_hints(None),
        };
        (r.trace)(self, batch, out)
    }

    fn batch_hints(&self, traversal: usize, query: Query, rays: &[Ray]) -> Option<Vec<u32>> {
        let compute = row::<S>(traversal).hints?;
        let out = compute(self, query, rays);
        assert_eq!(out.len(), rays.len(), "{}: one hint per ray", S::NAME);
        Some(out)
    }

    fn has_gpu_program(&self, traversal: usize) -> bool {
        row::<S>(traversal).gpu.is_some()
    }

    fn gpu_program(&self, traversal: usize) -> Option<GpuProgram<'_>> {
        row::<S>(traversal).gpu.map(|g| g(self))
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}

/// The traversal infos of structure `S`, in table order.
pub fn infos_of<S: Structure>() -> Vec<&'static TraversalInfo> {
    S::TRAVERSALS.iter().map(|t| &t.info).collect()
}

/// Builds a structure from the scene's triangles (shared, so several trees or a structure and
/// its oracle need no copies) and a checked parameter set.
pub type BuildFn = fn(&Arc<[Triangle]>, &ParamSet) -> Result<Box<dyn Accel>, AccelError>;

/// A structure family as the registry lists it: one `static` per structure crate, the only
/// thing the harness needs to know about it.
pub struct Family {
    /// Config name (`name = "bvh"` in a `[[structure]]` table).
    pub name: &'static str,
    /// What it is, its parameters' roles and its papers (docs/structures.md, `trace-bench
    /// list`).
    pub doc: &'static str,
    /// One short line: what it is and its papers (the README's structure table); `doc` unless
    /// [`Family::with_summary`] gives one.
    pub summary: &'static str,
    /// Its parameter table.
    pub params: &'static [ParamSpec],
    /// Its default parameters.
    pub defaults: fn() -> ParamSet,
    /// Its traversals (the index selects one in every build).
    pub traversals: fn() -> Vec<&'static TraversalInfo>,
    /// Build it.
    pub build: BuildFn,
    /// Its rules across parameters ([`crate::params::ParamRules`]), checked with the config.
    pub rules: fn(&ParamSet) -> Result<(), String>,
    /// The names of its two densities of a two-level subdivision (λ_1, λ_2 of equation 1,
    /// Pérard-Gayot et al. 2017 §4.1), where it has them: the capability the dynamic
    /// experiment's automatic density choice needs (§6.1).
    pub densities: Option<[&'static str; 2]>,
    /// How its builds are saved to and loaded from the build cache, where they can be
    /// (`Family::with_persist`, [`crate::persist`]).
    pub codec: Option<Codec>,
    /// Where its build is another family's whole build and a step after it
    /// ([`Family::with_stage`]): the build cache then keeps the first stage under that
    /// family's own key, so structures that share it build it once.
    pub stage: Option<Stage>,
    /// Its method version ([`Family::with_method`]): raised with every change of a paper rule
    /// in its builder or its traversals (CPU or GPU), so that a row made by an older method
    /// is told apart (the `method` column; a claim reads only rows of the current methods).
    /// 0: not declared.
    pub method: u32,
    /// What the current method version changed (`trace-bench list` shows it).
    pub method_change: &'static str,
}

/// The change of a family's method version 1 ([`Family::with_method`]): versions begin with
/// the builders and traversals of 2026-12-08; rows made before carry no `method` and read as
/// made by version 0.
pub const FIRST_METHOD: &str = "method versions begin (2026-12-08): rows made before carry none";

/// A build in two stages: first the whole structure of family `base` with the parameters
/// `params` names, then `finish` over it (sparse boxes: the kd-tree, then its augmented nodes,
/// Havran and Bittner 2007 §4). `finish(base(params(p)), p)` is the family's `build(p)`, bit
/// for bit: the stage only lets a build cache share the first stage between parameter sets
/// (every `d_min` of one kd-tree) and with the base family's own rows.
#[derive(Clone, Copy)]
pub struct Stage {
    /// The family whose structure is the first stage.
    pub base: &'static Family,
    /// The base family's full parameter set for this family's checked set.
    pub params: fn(&ParamSet) -> Result<ParamSet, AccelError>,
    /// The structure built over the first stage (`base`, validated) with this family's set.
    pub finish: FinishFn,
}

/// The second stage of a [`Stage`]: the structure over a first stage, with the family's set.
pub type FinishFn = fn(&dyn Accel, &ParamSet) -> Result<Box<dyn Accel>, AccelError>;

impl Family {
    /// The family of structure `S` with params `P`, built by `build`.
    pub const fn new<S: Structure, P: Params>(doc: &'static str, build: BuildFn) -> Family {
        Family {
            name: S::NAME,
            doc,
            summary: doc,
            params: P::SPECS,
            defaults: defaults_of::<P>,
            traversals: infos_of::<S>,
            build,
            rules: crate::params::no_rules,
            densities: None,
            codec: None,
            stage: None,
            method: 0,
            method_change: "",
        }
    }

    /// This family at method version `version`, whose change from the one before is
    /// `change` (see [`Family::method`]).
    pub const fn with_method(mut self, version: u32, change: &'static str) -> Family {
        self.method = version;
        self.method_change = change;
        self
    }

    /// This family built in two stages, the first another family's structure ([`Stage`]).
    pub const fn with_stage(mut self, stage: Stage) -> Family {
        self.stage = Some(stage);
        self
    }

    /// This family with a short `summary` of its `doc` (the README's structure table).
    pub const fn with_summary(mut self, summary: &'static str) -> Family {
        self.summary = summary;
        self
    }

    /// This family offering its two densities `names` (λ_1, λ_2) to the dynamic experiment.
    pub const fn with_densities(mut self, names: [&'static str; 2]) -> Family {
        self.densities = Some(names);
        self
    }

    /// This family with the rules of its parameters `P` checked before any work.
    pub const fn with_rules<P: crate::params::ParamRules>(mut self) -> Family {
        self.rules = crate::params::rules_of::<P>;
        self
    }
}

/// How a family's built structures are written and read back (see `crate::persist::Persist`).
#[derive(Clone, Copy)]
pub struct Codec {
    /// The bytes of a built structure; `Err` where `accel` is not this family's structure.
    pub save: fn(&dyn Accel) -> Result<Vec<u8>, String>,
    /// The structure saved in `bytes`, given back its triangles and parameters.
    pub load: LoadFn,
}

/// Loads a saved structure (its bytes), given back the scene's triangles and its parameters.
pub type LoadFn = fn(&[u8], &Arc<[Triangle]>, &ParamSet) -> Result<Box<dyn Accel>, String>;

/// Convert a checked set to `P` and build with `f` (the usual body of a [`BuildFn`]).
pub fn build_with<P: Params, S: Structure>(
    set: &ParamSet,
    f: impl FnOnce(&P) -> Result<S, AccelError>,
) -> Result<Box<dyn Accel>, AccelError> {
    let p = P::from_set(set)?;
    Ok(Box::new(f(&p)?))
}

/// One traversal algorithm for one ray, generic over the triangle test and the counter.
pub trait Kernel: Sync {
    /// Closest hit in `[ray.tmin, ray.tmax)`, or [`HitRecord::MISS`].
    fn closest<T: TriTest, C: Counter>(&self, ray: &Ray, c: &mut C) -> HitRecord;
    /// Any hit in `[ray.tmin, ray.tmax)`, or [`HitRecord::MISS`].
    fn any<T: TriTest, C: Counter>(&self, ray: &Ray, c: &mut C) -> HitRecord;
}

/// A `validate()` check shared by structures that store triangles in leaf order with a map
/// back to scene indices: `prim_ids` must be a permutation of `0..n_tris`.
pub fn check_permutation(prim_ids: &[u32], n_tris: usize) -> Result<(), AccelError> {
    let err = |m: String| Err(AccelError::Invalid(m));
    if prim_ids.len() != n_tris {
        return err(format!(
            "{} prim_ids for {n_tris} triangles",
            prim_ids.len()
        ));
    }
    let mut seen = vec![false; n_tris];
    for (i, &id) in prim_ids.iter().enumerate() {
        let id = id as usize;
        if id >= n_tris {
            return err(format!("prim_ids[{i}] = {id} out of range"));
        }
        if std::mem::replace(&mut seen[id], true) {
            return err(format!("triangle {id} appears twice in prim_ids"));
        }
    }
    Ok(())
}

/// Implement [`Kernel`] for traversal types whose one method `$walk::<T, C, ANY>(ray, c)`
/// serves both queries (`ANY = false`: closest hit, `true`: any hit). Each type is written
/// `[generics] Type`, e.g. `kernel_by_query!(walk: [] Havran<'_>, [const M: u8] Walk<'_, M>)`.
#[macro_export]
macro_rules! kernel_by_query {
    ($walk:ident: $([$($gen:tt)*] $ty:ty),+ $(,)?) => {$(
        impl<$($gen)*> $crate::Kernel for $ty {
            #[inline]
            fn closest<T: $crate::TriTest, C: $crate::Counter>(
                &self,
                ray: &$crate::Ray,
                c: &mut C,
            ) -> $crate::HitRecord {
                self.$walk::<T, C, false>(ray, c)
            }

            #[inline]
            fn any<T: $crate::TriTest, C: $crate::Counter>(
                &self,
                ray: &$crate::Ray,
                c: &mut C,
            ) -> $crate::HitRecord {
                self.$walk::<T, C, true>(ray, c)
            }
        }
    )+};
}

/// Implement [`Kernel`] for hierarchy walks with a method
/// `walk::<T, C, ANY, OCT>(&self, ray, &RayBox, c)`, specialised by the ray's octant through
/// [`crate::by_octant!`] (the BVH's and the R-tree's): an `octant_walk` per query, then
/// [`kernel_by_query!`] on it; generics as there.
#[macro_export]
macro_rules! kernel_by_octant {
    ($([$($gen:tt)*] $ty:ty),+ $(,)?) => {$(
        impl<$($gen)*> $ty {
            #[inline(always)]
            fn octant_walk<T: $crate::TriTest, C: $crate::Counter, const ANY: bool>(
                &self,
                ray: &$crate::Ray,
                c: &mut C,
            ) -> $crate::HitRecord {
                $crate::by_octant!(self, ray, c, ANY)
            }
        }
        $crate::kernel_by_query!(octant_walk: [$($gen)*] $ty);
    )+};
}

#[inline(always)]
fn run<K: Kernel, T: TriTest, C: Counter>(k: &K, query: Query, ray: &Ray, c: &mut C) -> HitRecord {
    match query {
        Query::Closest => k.closest::<T, C>(ray, c),
        Query::Any => k.any::<T, C>(ray, c),
    }
}

fn batch<K: Kernel, T: TriTest>(k: &K, query: Query, rays: &[Ray], out: Answers<'_>) {
    assert_eq!(rays.len(), out.hits.len(), "one hit record per ray");
    match out.stats {
        None => {
            for (r, h) in rays.iter().zip(out.hits.iter_mut()) {
                *h = run::<K, T, NoStats>(k, query, r, &mut NoStats);
            }
        }
        Some(stats) => {
            assert_eq!(rays.len(), stats.len(), "one stats record per ray");
            for ((r, h), s) in rays.iter().zip(out.hits.iter_mut()).zip(stats.iter_mut()) {
                let mut local = TraversalStats::default();
                *h = run::<K, T, TraversalStats>(k, query, r, &mut local);
                *s = local;
            }
        }
    }
}

/// Run kernel `k` over a batch, choosing the monomorphised variant for the triangle test and
/// for counting (`out.stats` given) or timing (`None`, counters compiled out).
pub fn dispatch<K: Kernel>(k: &K, b: Batch<'_>, out: Answers<'_>) {
    match b.tri {
        TriTestKind::Watertight => batch::<K, Watertight>(k, b.query, b.rays, out),
        TriTestKind::MollerTrumbore => batch::<K, MollerTrumbore>(k, b.query, b.rays, out),
    }
}
