//! A structure's GPU program, described without wgpu: what the GPU crate compiles, uploads
//! and binds for one traversal. A structure crate owns its WGSL and hands this description
//! over ([`crate::Traversal::gpu`]); the GPU crate knows only the common bindings and depends
//! on no structure crate.
//!
//! The contract with the GPU crate (`tb-gpu`, README "GPU"): the source is appended to the
//! common prelude, which declares the common bindings of group 0 — `rays` (0), `hits` (1),
//! `stats` (2), `tris` (3: the program's [`GpuProgram::triangles`], 9 floats each), `meta_`
//! (4: `counts = (triangles, meta[0], meta[1], meta[2])`) — the `Ray`, `Hit` and `Stats`
//! records (`Stats` generated from [`crate::stats::COUNTERS`]), the override constants `ANY`,
//! `COUNT`, `WATERTIGHT` and `EXIT_SCALE`, `const STACK_SIZE` ([`GpuProgram::stack_size`]),
//! the slab test and both triangle tests. The source declares its own read-only storage
//! buffers at bindings 5, 6, … in the order of [`GpuProgram::buffers`] and defines
//! `fn walk(r: Ray, st: ptr<function, Stats>) -> Hit`; the prelude's entry point calls it
//! once per ray and writes the hit (and, when `COUNT`, the counters).

use crate::geom::Triangle;
use std::borrow::Cow;

/// One read-only storage buffer of a program.
#[derive(Clone, Debug)]
pub struct GpuBuffer<'a> {
    /// What it holds (named in errors, e.g. "the BVH node array").
    pub what: &'static str,
    /// Its bytes, exactly as the WGSL declares the array.
    pub bytes: Cow<'a, [u8]>,
}

/// The GPU program of one traversal of one build.
#[derive(Clone, Debug)]
pub struct GpuProgram<'a> {
    /// Unique name of the WGSL source (shader modules and pipelines are cached by it), e.g.
    /// `bvh/ordered`.
    pub name: &'static str,
    /// The WGSL source (see the module doc for what it may use and must define).
    pub source: &'static str,
    /// The triangles bound at binding 3, in the order the program's indices refer to.
    pub triangles: Cow<'a, [Triangle]>,
    /// Further read-only buffers, bound at 5, 6, … in this order.
    pub buffers: Vec<GpuBuffer<'a>>,
    /// Words 1..=3 of the `meta_` uniform (e.g. the node count).
    pub meta: [u32; 3],
    /// Entries of the traversal stack (`const STACK_SIZE`).
    pub stack_size: u32,
    /// Further override constants of the source, by name.
    pub constants: Vec<(&'static str, f64)>,
    /// Loop iterations per ray grow with the triangle count (brute force): llvmpipe ends an
    /// invocation's loops after 65535 iterations, so such a program unrolled `k` times
    /// handles at most `k · 65000` triangles there and is refused beyond.
    pub unrolled_triangle_loop: Option<u32>,
}
