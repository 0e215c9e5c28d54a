//! Wide BVHs (BVH4, BVH8): nodes of up to `N` children collapsed from the binary tree, child
//! boxes stored as structure-of-arrays so that one SIMD instruction tests a slab plane of all
//! children (Wald, Benthin and Boulos 2008, "Getting rid of packets — efficient SIMD
//! single-ray traversal using multi-branching BVHs"; Dammertz et al. 2008, "Shallow bounding
//! volume hierarchies for fast SIMD ray tracing of incoherent rays").
//!
//! - **Collapse** ([`collapse`]), `collapse = "sah"` (default): the SAH-optimal wide tree over
//!   the binary one by dynamic programming (Ylitie, Karras and Laine 2017, "Efficient
//!   incoherent ray traversal on GPUs through compressed wide BVHs", HPG, §3.1; see [`Dp`]):
//!   per binary node and number of slots, the least cost of a leaf, an interior wide node, or
//!   the subtree spread over several slots of its parent, then the choices read back top-down.
//!   A subtree of at most `max_leaf` triangles may become one wide leaf (its triangle slots are
//!   consecutive in both builders' leaf order); binary leaves stay leaves whatever their size.
//!   The cost model is the builders' (`C_trav` per wide node, `C_isect` and `leaf_cost` per
//!   leaf; [`sah`]). `collapse = "greedy"`: each wide node starts from the two children of a
//!   binary node and repeatedly opens the interior child of largest surface area (the one a
//!   ray is most likely to enter) until it has `N` children or only leaves remain (Wald et al.
//!   2008 §3); binary leaves stay leaves. Either way the triangles keep the binary tree's
//!   order, so the wide tree shares its triangle and primitive-id arrays.
//! - **Traversal** ([`Wide`]): depth-first with a stack; at an interior node all children's
//!   boxes are tested at once (the slab test of [`tb_core::slab`], lane by lane the same
//!   operations in the same order, so every lane's answer equals the scalar test's bit for bit:
//!   `NaN`-ignoring max/min folds, exit distance scaled by [`EXIT_SCALE`]), the hit children
//!   sorted by entry distance, the nearest visited next and the others pushed farthest first
//!   (any-hit queries skip the sort: the first hit found ends the ray wherever it is).
//!   Which plane of each slab is near is chosen once per ray by the sign of `1/dir` (as offsets
//!   into the node, Embree's approach), so the node test has no per-lane select.
//! - **SIMD**: BVH4 uses SSE (part of x86-64), BVH8 AVX when the CPU has it (runtime
//!   detection, once per batch); on AVX-512 CPUs the same AVX walk is compiled with AVX-512
//!   enabled (the same operations and results; the compiler gets 32 vector registers and mask
//!   registers: 3-4 % more MRays/s on the reference machine); a scalar lane loop everywhere
//!   else (and when `simd = "scalar"`).
//! - **Leaves** ([`LeafBlock`]): each leaf's triangles are copied into blocks of four in
//!   structure-of-arrays layout (as Embree's `triangle4`), with their primitive ids, so that
//!   the SIMD paths test four triangles at once ([`TriTest::intersect4`]: the watertight or
//!   Möller–Trumbore test lane by lane with the scalar operations, bit for bit the scalar
//!   answers). The block's hit lanes are then resolved in triangle order with
//!   [`TriTest::still_hits`] against the closest hit so far, which gives exactly the scalar
//!   loop's hit (the same triangle, `t`, `u`, `v`), and the counters count the triangles the
//!   scalar loop tests (any-hit: up to the first hit). `simd = "scalar"` tests the lanes one
//!   by one with [`TriTest::intersect`], the reference.
//!
//! Counters keep their binary meaning: `interior` and `leaves` count wide nodes and leaves
//! visited (`steps` their sum), `boxes` the child boxes tested (1 for the root, then one per
//! child of each interior node visited), `prims` the triangle tests.

//!
//! Files: `collapse` (the cost model, the SAH-optimal and greedy collapses), `pack` (leaves into
//! [`LeafBlock`]s and back), `walk` (the SIMD node tests and the `ordered` traversal), `check`
//! (the wide tree against its binary one).

mod check;
mod collapse;
mod pack;
mod walk;

pub(crate) use check::check;
pub(crate) use collapse::{collapse, sah, CostModel};
pub(crate) use pack::{pack_leaves, unpack_leaves};
pub(crate) use walk::{Isa, Wide};

#[cfg(doc)]
use crate::Bvh;
use crate::{BvhNode, BvhParams, Collapse, LeafCost};
use tb_core::slab::{max_num, min_num, EXIT_SCALE};
use tb_core::stack::Stack;
use tb_core::{Aabb, Counter, HitRecord, Ray, Tri4, TriTest, Triangle, Vec3};

/// Marks an empty child slot in [`WideNode::count`] (its box is empty: `min = +inf`,
/// `max = −inf`, which every ray with a non-NaN origin misses).
pub const EMPTY_SLOT: u32 = u32::MAX;

/// The binary tree's depth bound (see `build::MEDIAN_DEPTH`); a wide tree is no deeper.
const MAX_DEPTH: usize = crate::traverse::STACK_SIZE;

/// Stack entries of the wide traversal: a node visit pushes at most `N − 1` entries per level,
/// so `7 · depth + 1` suffice for `N ≤ 8` (checked by `validate`).
pub const WIDE_STACK_SIZE: usize = 7 * MAX_DEPTH + 1;

/// A node of a wide BVH with `N` child slots, `32·N` bytes, 32-byte aligned.
///
/// Child `i`'s box is `(min[0][i], min[1][i], min[2][i])`–`(max[0][i], ...)`; `count[i]` is
/// 0 for an interior child (`child[i]` its node index), the number of triangles of a leaf
/// (`child[i]` its first [`LeafBlock`] in [`Bvh::leaf_blocks`], the leaf's `⌈count / 4⌉`
/// blocks consecutive), or [`EMPTY_SLOT`]. Used slots come first. (The GPU program gets a copy
/// whose leaves name their first triangle in [`Bvh::triangles`] instead.)
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WideNode<const N: usize> {
    /// Lower corners of the children's boxes, `min[axis][slot]`.
    pub min: [[f32; N]; 3],
    /// Upper corners of the children's boxes, `max[axis][slot]`.
    pub max: [[f32; N]; 3],
    /// Per slot: the child's node index, or a leaf's first [`LeafBlock`].
    pub child: [u32; N],
    /// Per slot: 0 for an interior child, a leaf's triangle count, or [`EMPTY_SLOT`].
    pub count: [u32; N],
}

// SAFETY: only f32 and u32 arrays, `8·N` four-byte words: `32·N` bytes, a multiple of the
// alignment, so there is no padding; every bit pattern is valid.
unsafe impl<const N: usize> bytemuck::Zeroable for WideNode<N> {}
// SAFETY: as above.
unsafe impl<const N: usize> bytemuck::Pod for WideNode<N> {}

impl<const N: usize> WideNode<N> {
    const EMPTY: Self = WideNode {
        min: [[f32::INFINITY; N]; 3],
        max: [[f32::NEG_INFINITY; N]; 3],
        child: [0; N],
        count: [EMPTY_SLOT; N],
    };

    /// Child `i`'s box.
    pub fn child_bounds(&self, i: usize) -> Aabb {
        Aabb::new(
            Vec3::new(self.min[0][i], self.min[1][i], self.min[2][i]),
            Vec3::new(self.max[0][i], self.max[1][i], self.max[2][i]),
        )
    }

    /// Number of used slots.
    pub fn children(&self) -> usize {
        self.count.iter().take_while(|&&c| c != EMPTY_SLOT).count()
    }

    fn set(&mut self, i: usize, b: &BvhNode, child: u32, count: u32) {
        for a in 0..3 {
            self.min[a][i] = b.min[a];
            self.max[a][i] = b.max[a];
        }
        self.child[i] = child;
        self.count[i] = count;
    }
}

/// Four triangles of a wide leaf (lanes past the leaf's end repeat its block's first triangle,
/// as [`Tri4::new`] pads, with primitive id `u32::MAX`), 160 bytes.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LeafBlock {
    /// The four triangles, in the SIMD test's layout.
    pub tris: Tri4,
    /// The scene index of each lane's triangle.
    pub prim: [u32; 4],
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Builder, Bvh, WideNodes};
    use collapse::Dp;
    use tb_core::Accel;

    /// A deterministic generator of floats in `[0, 1)` (xorshift; no dependency).
    fn uniform(mut x: u64) -> impl FnMut() -> f32 {
        move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    fn scenes() -> Vec<(&'static str, Vec<Triangle>)> {
        let load = |s: &str| {
            tb_scene::load(s, std::path::Path::new("."))
                .unwrap()
                .triangles
        };
        let mut rnd = uniform(0x9e3779b97f4a7c15);
        let mut v = || Vec3::new(rnd(), rnd(), rnd());
        let soup = (0..3000)
            .map(|_| {
                let c = v() * 10.0;
                Triangle::new(c, c + v() * 0.6 - 0.3, c + v() * 0.6 - 0.3)
            })
            .collect();
        vec![
            ("soup", soup),
            ("teapot", load("builtin:teapot?tess=4")),
            ("sphereflake", load("builtin:sphereflake?size=2&tess=1")),
            ("city", load("builtin:city?blocks=3&storeys=4")),
        ]
    }

    fn wide_sah(b: &Bvh) -> f64 {
        let cm = CostModel::of(b.params());
        let root = b.nodes()[0].bounds();
        match b.wide_nodes() {
            WideNodes::W4(w) => sah(w, &root, &cm),
            WideNodes::W8(w) => sah(w, &root, &cm),
            WideNodes::None => None,
        }
        .expect("a wide tree with a root of positive area")
    }

    /// The SAH collapse keeps every triangle slot in exactly one wide leaf (`validate`, the
    /// checks the greedy collapse passes) and its tree costs no more than the greedy one's
    /// under the same cost model (the dynamic programme minimises over a set of trees that
    /// holds the greedy tree), strictly less on most builds.
    #[test]
    fn sah_collapse_is_valid_and_no_worse_than_greedy() {
        let (mut builds, mut better) = (0, 0);
        for (name, tris) in scenes() {
            for builder in [Builder::Binned, Builder::Sbvh] {
                for leaf_cost in LeafCost::ALL.iter().copied() {
                    for width in [4, 8] {
                        let p = |collapse| BvhParams {
                            builder,
                            leaf_cost,
                            width,
                            collapse,
                            ..BvhParams::binary()
                        };
                        let greedy = Bvh::build(&tris, &p(Collapse::Greedy));
                        let dp = Bvh::build(&tris, &p(Collapse::Sah));
                        let what = format!("{name} {builder:?} {leaf_cost:?} w{width}");
                        assert_eq!(greedy.nodes(), dp.nodes(), "{what}: same binary tree");
                        greedy
                            .validate()
                            .unwrap_or_else(|e| panic!("{what} greedy: {e}"));
                        dp.validate().unwrap_or_else(|e| panic!("{what} sah: {e}"));
                        let (g, d) = (wide_sah(&greedy), wide_sah(&dp));
                        assert!(d <= g * (1.0 + 1e-9), "{what}: sah {d} > greedy {g}");
                        builds += 1;
                        better += (d < g * (1.0 - 1e-6)) as u32;
                    }
                }
            }
        }
        assert!(
            2 * better > builds,
            "SAH collapse better on only {better} of {builds}"
        );
    }

    /// The DP's cost of the root equals the SAH cost of the tree it reads back (the choices
    /// are read back faithfully), and merged leaves respect `max_leaf`.
    #[test]
    fn dp_cost_is_the_built_trees_cost() {
        for (name, tris) in scenes() {
            for leaf_cost in LeafCost::ALL.iter().copied() {
                let p = BvhParams {
                    leaf_cost,
                    max_leaf: 8,
                    ..BvhParams::binary()
                };
                let bin = crate::build::build(&tris, &p).0;
                let cm = CostModel::of(&p);
                let dp = Dp::<8>::solve(&bin, &cm);
                let mut w = Vec::new();
                dp.make(&bin, 0, &mut w);
                let root = bin[0].bounds();
                let area = root.area() as f64;
                let l = bin[0].index as usize;
                let (_, dist) = Dp::<8>::distribute(&dp.cost[l], &dp.cost[l + 1], 8);
                let want = (cm.c_trav * area + dist) / area;
                let got = sah(&w, &root, &cm).unwrap();
                assert!(
                    (got - want).abs() <= 1e-9 * want,
                    "{name} {leaf_cost:?}: tree {got}, DP {want}"
                );
                for n in &w {
                    for s in 0..n.children() {
                        let c = n.count[s];
                        let is_bin_leaf = bin.iter().any(|b| b.is_leaf() && b.count == c);
                        assert!(c == 0 || c <= 8 || is_bin_leaf, "{name}: leaf of {c}");
                    }
                }
            }
        }
    }

    /// Every instruction set the CPU has gives the scalar lane loop's hits and counters bit
    /// for bit (the AVX walk compiled with and without AVX-512 included): closest and any hit,
    /// both triangle tests, rays from inside and outside the scenes.
    #[test]
    fn every_isa_equals_the_lane_loop() {
        use tb_core::{
            dispatch, Answers, Batch, HitRecord, Query, Ray, TraversalStats, TriTestKind,
        };
        let mut rnd = uniform(0x2545f4914f6cdd1d);
        let mut isas = vec![walk::Isa::Scalar];
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx") {
                isas.push(walk::Isa::Avx);
            }
            if walk::Isa::detect(8, false) == walk::Isa::Avx512 {
                isas.push(walk::Isa::Avx512);
            }
        }
        for (name, tris) in scenes() {
            let p = BvhParams {
                width: 8,
                leaf_cost: LeafCost::Blocks,
                ..BvhParams::binary()
            };
            let b = Bvh::build(&tris, &p);
            let WideNodes::W8(nodes) = b.wide_nodes() else {
                panic!("a width-8 build has wide nodes")
            };
            let bounds = b.nodes()[0].bounds();
            let rays: Vec<Ray> = (0..4000)
                .map(|_| {
                    let mut v = || Vec3::new(rnd(), rnd(), rnd());
                    let o = bounds.min + (bounds.max - bounds.min) * (v() * 1.4 - 0.2);
                    let d = (v() - 0.5).normalize_or(Vec3::X);
                    Ray::new(o, d)
                })
                .collect();
            for tri in TriTestKind::ALL {
                for q in [Query::Closest, Query::Any] {
                    let run = |isa| {
                        let k = walk::Wide {
                            nodes,
                            blocks: &b.blocks[..],
                            isa,
                            root: b.nodes().first(),
                        };
                        let mut hits = vec![HitRecord::MISS; rays.len()];
                        let mut stats = vec![TraversalStats::default(); rays.len()];
                        let out = Answers::new(&mut hits, Some(&mut stats));
                        dispatch(&k, Batch::new(q, tri, &rays), out);
                        (hits, stats)
                    };
                    let reference = run(walk::Isa::Scalar);
                    assert!(reference.0.iter().any(|h| h.is_hit()), "{name}");
                    for &isa in &isas[1..] {
                        let got = run(isa);
                        assert!(got.0 == reference.0, "{name} {isa:?} {q:?} {}", tri.name());
                        assert!(got.1 == reference.1, "{name} {isa:?} {q:?} {}", tri.name());
                    }
                }
            }
        }
    }
}
