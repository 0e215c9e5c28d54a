//! A structure's GPU program, described without wgpu: what the GPU crate compiles, uploads
//! and binds for one traversal. A structure crate owns its WGSL (`include_str!` from its own
//! `shaders/`) and hands this description over ([`crate::Traversal::with_gpu`], read back with
//! [`crate::Accel::gpu_program`]); the GPU crate knows only the common bindings and depends on
//! no structure crate.
//!
//! # The contract with the GPU crate (`tb-gpu`, docs/GPU.md)
//!
//! The shader module is, in this order: `const STACK_SIZE: u32` ([`GpuProgram::stack_size`]),
//! `const WORKGROUP_SIZE: u32`, `struct Stats` and `fn zero_stats()` (generated from
//! [`crate::stats::COUNTERS`] by [`crate::stats::wgsl_stats_struct`]: one `u32` per counter,
//! then `capped`), the common prelude, the watertight test's exact-zero fallback (f64 where the
//! adapter has it, else f32), then [`GpuProgram::source`]. The prelude declares:
//! - the bindings of group 0: `rays` (0), `hits` (1), `stats` (2), `tris` (3: the program's
//!   [`GpuProgram::triangles`], three `vec4<f32>` each, read with `vertex(i, k)`) and the uniform
//!   `meta_` (4: `counts = (triangles, meta[0], meta[1], meta[2])`);
//! - the records `Ray`, `Hit` (and `miss()`, `MISS_PRIM`);
//! - the override constants `ANY` (any-hit query), `COUNT` (counting pass), `WATERTIGHT`
//!   (triangle test) and `EXIT_SCALE` (the slab test's, [`crate::slab::EXIT_SCALE`]);
//! - the slab test (`ray_box`, `slab`, as [`crate::slab`]) and both triangle tests
//!   (`prepare`, `intersect(pre, ray, i, tmax)`), rounding as tb-core's Rust does;
//! - `trace_ray(i)`, which calls the program's `walk` for the dispatch's ray `i` with zeroed
//!   counters, writes the returned hit and, in the counting pass, the counters; the entry
//!   point `main` (appended after the source) calls it once per thread and ray, or, for a
//!   [`GpuProgram::persistent`] program, in a loop over runs of rays fetched from a counter
//!   (tb-gpu binds it at the binding after the program's buffers).
//!
//! The source declares its own read-only buffers at bindings 5, 6, … in the order of
//! [`GpuProgram::buffers`]: storage buffers (4 at most on every adapter: WebGPU guarantees 8
//! storage buffers per stage and the prelude binds 4; buffers are bound padded to at least 64
//! bytes, so lengths come from the meta words, not `arrayLength`), or uniform buffers for the
//! constants every ray reads, such as a header ([`GpuProgram::uniform`]: `var<uniform>`, its
//! arrays of 16-byte elements, e.g. `array<vec4<u32>, 3>`), may declare further `override`
//! constants ([`GpuProgram::constants`]), and defines
//! `fn walk(r: Ray, st: ptr<function, Stats>) -> Hit`: the closest (or, when `ANY`, any) hit
//! in `[r.tmin, r.tmax)` with `prim` the scene's triangle index, counting into `*st` exactly
//! as the CPU traversal counts (the timed pass discards the counts, so the compiler may drop
//! them). To agree with the CPU ray for ray it visits nodes in the CPU's order with the
//! prelude's tests.
//!
//! A program whose source uses `f64` beyond the prelude's fallback sets
//! [`GpuProgram::needs_f64`]; the GPU crate then refuses it on adapters without
//! `SHADER_F64` (a one-line [`GpuProgram::name`]d refusal, a row's note in a run). Likewise a
//! program using subgroup operations sets [`GpuProgram::needs_subgroups`] (refused without
//! wgpu's `SUBGROUP`); one whose counters cannot be the CPU's ray for ray says why in
//! [`GpuProgram::own_counts`].
//!
//! # Ray arrangement by key
//!
//! A program may ask for its rays to be sorted before they are traced ([`GpuProgram::arrange`],
//! [`GpuArrange`]: e.g. Torres et al. 2012 §6, the multi-kd-tree's rays by tree index). Its
//! source then also defines `fn ray_key(r: Ray) -> u32`, the ray's key in `0..keys` (it may
//! read the program's own buffers; a larger value counts as `keys - 1`). Per dispatch chunk
//! the GPU crate runs, before the trace and timed on its own, a stable counting sort of the
//! chunk's ray indices by key (compute passes: per-workgroup histograms, one exclusive scan in
//! key-major order, a stable scatter by in-workgroup rank); `main` then traces ray `perm[i]`
//! in thread `i` and writes its hit and counters at the ray's own index, so hits and counters
//! come back in ray order, the same ray for ray as without the sort. The module then also
//! binds group 1, binding 0 (the sort's histograms and permutation, one storage buffer beside
//! the program's: 4 of its own buffers at most still leaves it within WebGPU's 8).
//!
//! The GPU crate compiles one module per [`GpuProgram::name`] and caches pipelines by (name,
//! query, triangle test, counting): source, stack size, constants and the number of keys are
//! fixed per name (a
//! second program of the same name with other values is refused); what varies per build goes
//! in the triangles, buffers and meta words.

use crate::geom::Triangle;
use std::borrow::Cow;

/// One read-only storage buffer of a program.
#[derive(Clone, Debug)]
pub struct GpuBuffer<'a> {
    /// What it holds (named in errors, e.g. "the BVH node array").
    pub what: &'static str,
    /// Its bytes, exactly as the WGSL declares the array.
    pub bytes: Cow<'a, [u8]>,
    /// Bound as a uniform buffer (`var<uniform>`: constants every ray reads, which a GPU
    /// serves from its constant caches), else as a read-only storage buffer.
    pub uniform: bool,
}

/// The GPU program of one traversal of one build.
#[derive(Clone, Debug)]
pub struct GpuProgram<'a> {
    /// Unique name of the program, `structure/traversal` (shader modules and pipelines are
    /// cached by it), e.g. `bvh/ordered`.
    pub name: &'static str,
    /// The WGSL source (see the module doc for what it may use and must define).
    pub source: &'static str,
    /// The triangles bound at binding 3, in the order the program's indices refer to.
    pub triangles: Cow<'a, [Triangle]>,
    /// Further read-only buffers, bound at 5, 6, … in this order (at most 4 storage buffers
    /// on every adapter; each a whole number of 4-byte words).
    pub buffers: Vec<GpuBuffer<'a>>,
    /// Words 1..=3 of the `meta_` uniform (e.g. the node count).
    pub meta: [u32; 3],
    /// Entries of the traversal stack (`const STACK_SIZE`; 0 for a program without one).
    pub stack_size: u32,
    /// Further override constants of the source, by name (added to the prelude's).
    pub constants: Vec<(&'static str, f64)>,
    /// Loop iterations per ray grow with the triangle count (brute force): llvmpipe ends an
    /// invocation's loops after 65535 iterations, so such a program unrolled `k` times
    /// handles at most `k · 65000` triangles there and is refused beyond.
    pub unrolled_triangle_loop: Option<u32>,
    /// The source computes in `f64` (declares `f64` values or `array<f64>` buffers, e.g. to
    /// repeat a CPU walk's `f64` arithmetic): tb-gpu refuses it, with one line naming the
    /// program, on an adapter without `SHADER_F64`, instead of failing to compile it.
    pub needs_f64: bool,
    /// Sort the rays by `ray_key` before tracing them (see the module doc); `None`: traced in
    /// the order given.
    pub arrange: Option<GpuArrange>,
    /// WGSL shared by several structures' programs (e.g. [`LEAF_RANGES`]), placed after the
    /// prelude and before [`GpuProgram::source`], in this order.
    pub includes: Vec<&'static str>,
    /// Why the timed passes keep wgpu's loop bounding (`force_loop_bounding`) while dropping
    /// its bounds checks (`None`: the trusted build has neither, tb-gpu's `kernels` doc). A
    /// shader loop without side effects is one a compiler may assume to end (LLVM's forward
    /// progress rule, which lavapipe's compiler applies): where that assumption changed a
    /// program's answers, the bound (a counter per loop, never reached) keeps them.
    pub bounded_loops: Option<&'static str>,
    /// Trace with persistent threads (Aila and Laine 2009, "persistent threads"): tb-gpu
    /// launches a fixed pool of workgroups, enough to fill a large GPU (fewer for a small
    /// batch), each of which fetches the next run of rays (one per thread of the
    /// workgroup, `WORKGROUP_SIZE`) from a global counter until none is left, instead of one thread per ray launched for
    /// all rays. The walk, and so every hit and counter, is the same; what changes is which
    /// thread traces a ray and when.
    pub persistent: bool,
    /// The source uses WGSL's subgroup operations (`subgroupAll`, …; naga takes them without
    /// an `enable` directive once the device has them): tb-gpu refuses the program, with one
    /// line naming it, on an adapter without wgpu's `SUBGROUP` feature.
    pub needs_subgroups: bool,
    /// Why the program's counters are its own rather than the CPU traversal's ray for ray
    /// (`None`: they are the CPU's): a walk whose steps depend on the other rays of its
    /// subgroup (speculative traversal). Its hits still answer the same query; tests compare
    /// its hits, not its counters, with the CPU's, and GPU rows carry this in their note.
    pub own_counts: Option<&'static str>,
}

/// WGSL shared by the programs whose leaves are ranges of a leaf-ordered triangle array with
/// a map back to scene indices (the BVH's and the R-tree's, each declaring `prim_ids`): the
/// closest-hit record `Best` (`no_best`, `record`) and the leaf loop `leaf_range`, counting as
/// their CPU leaves do.
pub const LEAF_RANGES: &str = include_str!("../shaders/leaf_ranges.wgsl");

/// WGSL shared by the programs with a depth-first stack of `(index, entry distance)` entries
/// (`array<vec2<u32>, STACK_SIZE>`): `pop_entered`, the next entry not entered beyond the
/// closest hit, or `NO_ENTRY`.
pub const STACK_POP: &str = include_str!("../shaders/stack_pop.wgsl");

/// Little-endian bytes of 32-bit words, as a program buffer ([`GpuProgram::buffer`]) holds
/// them: `array<u32>`, or `f32` bits of `array<f32>`.
pub fn words(w: impl IntoIterator<Item = u32>) -> Cow<'static, [u8]> {
    Cow::Owned(w.into_iter().flat_map(u32::to_le_bytes).collect())
}

impl<'a> GpuProgram<'a> {
    /// The program `name` (`structure/traversal`) of WGSL `source` over `triangles`, with no
    /// further buffer, meta word, stack, constant or arrangement: add those with the methods
    /// below, so that a new field changes this constructor and no program.
    pub fn new(
        name: &'static str,
        source: &'static str,
        triangles: impl Into<Cow<'a, [Triangle]>>,
    ) -> Self {
        GpuProgram {
            name,
            source,
            triangles: triangles.into(),
            buffers: Vec::new(),
            meta: [0; 3],
            stack_size: 0,
            constants: Vec::new(),
            unrolled_triangle_loop: None,
            needs_f64: false,
            arrange: None,
            includes: Vec::new(),
            bounded_loops: None,
            persistent: false,
            needs_subgroups: false,
            own_counts: None,
        }
    }

    /// The source uses subgroup operations ([`GpuProgram::needs_subgroups`]).
    pub fn in_subgroups(mut self) -> Self {
        self.needs_subgroups = true;
        self
    }

    /// Its counters are its own, for `why` ([`GpuProgram::own_counts`]).
    pub fn own_counts(mut self, why: &'static str) -> Self {
        self.own_counts = Some(why);
        self
    }

    /// Trace with persistent threads ([`GpuProgram::persistent`]).
    pub fn persistent(mut self) -> Self {
        self.persistent = true;
        self
    }

    /// Keep wgpu's loop bounding in the timed passes, for `why`
    /// ([`GpuProgram::bounded_loops`]).
    pub fn bounded_loops(mut self, why: &'static str) -> Self {
        self.bounded_loops = Some(why);
        self
    }

    /// Which of [`GpuProgram::buffers`] are uniform buffers: bit `k` for buffer `k` (binding
    /// `5 + k`).
    pub fn uniform_mask(&self) -> u32 {
        self.buffers
            .iter()
            .enumerate()
            .filter(|(_, b)| b.uniform)
            .fold(0, |m, (k, _)| m | 1 << k)
    }

    /// Place shared WGSL `part` (e.g. [`LEAF_RANGES`]) before the source, after those
    /// included before.
    pub fn include(mut self, part: &'static str) -> Self {
        self.includes.push(part);
        self
    }

    /// The next read-only storage buffer (bound at 5, 6, … in the order added).
    pub fn buffer(mut self, what: &'static str, bytes: impl Into<Cow<'a, [u8]>>) -> Self {
        self.buffers.push(GpuBuffer {
            what,
            bytes: bytes.into(),
            uniform: false,
        });
        self
    }

    /// The next buffer as a uniform buffer (bound at 5, 6, … in the order added, as
    /// [`GpuProgram::buffer`]): per-dispatch constants every ray reads, such as a header,
    /// declared `var<uniform>` with arrays of 16-byte elements (a WGSL uniform's layout).
    pub fn uniform(mut self, what: &'static str, bytes: impl Into<Cow<'a, [u8]>>) -> Self {
        self.buffers.push(GpuBuffer {
            what,
            bytes: bytes.into(),
            uniform: true,
        });
        self
    }

    /// Words 1..=3 of the `meta_` uniform.
    pub fn meta(mut self, meta: [u32; 3]) -> Self {
        self.meta = meta;
        self
    }

    /// Entries of the traversal stack (`const STACK_SIZE`).
    pub fn stack(mut self, entries: u32) -> Self {
        self.stack_size = entries;
        self
    }

    /// An override constant of the source.
    pub fn constant(mut self, name: &'static str, value: f64) -> Self {
        self.constants.push((name, value));
        self
    }

    /// The triangle loop is unrolled `k` times ([`GpuProgram::unrolled_triangle_loop`]).
    pub fn unrolled_triangle_loop(mut self, k: u32) -> Self {
        self.unrolled_triangle_loop = Some(k);
        self
    }

    /// The source computes in `f64` ([`GpuProgram::needs_f64`]).
    pub fn in_f64(mut self) -> Self {
        self.needs_f64 = true;
        self
    }

    /// Sort the rays by `ray_key` before the trace ([`GpuProgram::arrange`]; `None`: in the
    /// order given).
    pub fn arranged(mut self, arrange: impl Into<Option<GpuArrange>>) -> Self {
        self.arrange = arrange.into();
        self
    }
}

/// A program's ray arrangement: rays stably sorted by a small key before the trace (Torres et
/// al. 2012 §6: a counting sort on the tree index).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuArrange {
    /// Number of keys, 1 to [`GpuArrange::MAX_KEYS`]: `ray_key` returns values below it.
    pub keys: u32,
    /// Whether a row's trace time includes the sort's (the paper's "inc."); else the sort
    /// runs untimed before the trace ("n.inc."). tb-gpu times both either way
    /// (`Timing::sort_ms`); the runner adds the sort's time to the row's when `true`.
    pub timed: bool,
}

impl GpuArrange {
    /// Most keys a program may declare (histograms stay small; the scan stays within
    /// llvmpipe's loop limit at the largest dispatch).
    pub const MAX_KEYS: u32 = 16;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `uniform` marks its buffer in the mask by its position among all buffers; `buffer`
    /// does not.
    #[test]
    fn uniform_mask_names_the_uniform_buffers() {
        let tris: [Triangle; 0] = [];
        let p = GpuProgram::new("test/mask", "", &tris[..])
            .buffer("a", words([1]))
            .uniform("b", words([2]))
            .buffer("c", words([3]))
            .uniform("d", words([4]));
        assert_eq!(p.uniform_mask(), 0b1010);
        assert!(p.buffers[1].uniform && !p.buffers[2].uniform);
        assert_eq!(
            GpuProgram::new("test/none", "", &tris[..]).uniform_mask(),
            0
        );
    }
}
