//! kd-trees with sparse boxes: Havran and Bittner, "Stackless Ray Traversal for kD-Trees with
//! Sparse Boxes" (2007), building on Havran and Bittner, "Ray tracing with sparse boxes"
//! (SCCG 2007).
//!
//! - **Tree**: any kd-tree the kd-tree crate's builders produce ([`tb_kdtree::KdTree`], SAH with
//!   perfect splits, depth-first layout), borrowed through its [`tb_kdtree::KdView`] and
//!   sharing the scene's triangle array: this crate copies no node.
//! - **Augmented nodes** (§4): the root and every interior node whose depth distance to its
//!   nearest augmented ancestor exceeds `d_min` carry a bounding box (the node's cell, 24
//!   bytes) and a link to their parent augmented node ([`AugNode`]). Since every ancestor of a
//!   node is interior, the augmented nodes are exactly the interior nodes at depths that are
//!   multiples of `d_min + 1`, so a kernel knows a node is augmented from its depth; the
//!   records are kept in depth-first (node index) order and a node's record is found by binary
//!   search when a walk climbs from it. Figures: `n_b` (N_B, boxes stored), `m_kd_bytes` (M_KD
//!   with a box priced as §4's text: 8-byte nodes, 4-byte references, 24-byte box and 4-byte
//!   parent link per augmented node), `paper_bytes` / `paper_ratio` (a box priced as Table 1's
//!   M_KD implies, [`PAPER_BOX_BYTES`]) and our real bytes (`aug_bytes`: 32-byte records, one
//!   depth byte per box, the records' rank).
//! - **Start nodes** (§3): a walk may begin at the deepest augmented node whose cell contains
//!   the ray origin ([`SparseBoxes::start_node`]), found once per batch by the caller (the
//!   hint seam, [`tb_core::Accel::batch_hints`]; primary rays of one camera share the eye's,
//!   secondary rays get the one of their origin: the generating hit point, offset off the
//!   surface, lies in the leaf where the generating ray terminated, so this is that leaf's
//!   augmented ancestor unless the offset crosses an augmented cell's face; a test measures
//!   how often). Hints are found outside the timed pass.
//! - **Traversals** (§5; the table `<SparseBoxes as Structure>::TRAVERSALS`): `htr` and `seq`
//!   are the kd-tree's `recursive-direction` (HTR, §5.1) and `sequential` (Kaplan's SEQ) over
//!   the same tree; `btr` / `btr-root` the bottom-up traversal (§5.2, Alg. 2) from the start
//!   node / the root; `sltr` / `sltr-root` the stackless bottom-up traversal as the paper's
//!   Algorithm 3 (§5.3: after each leaf the origin shifted past the leaf's exit and located
//!   from the last augmented node, or from the first parent augmented node holding it, each
//!   parent's `ComputeMaxT` one box test; a ray lying in a split plane walked once per side
//!   of it, as `seq` walks it); `sltr-handover` the same but such a ray handed to `sltr-mask`
//!   (`sltr`'s earlier reading); `sltr-mask` / `sltr-mask-root` our variant of it
//!   (no shift and no point location: the next leaf from a per-depth mask, exactly HTR's
//!   leaves). The paper's configs and claims read `sltr`. See module `traverse` for the
//!   kernels and how Algorithm 3's epsilon is made exact.
//!
//! - **GPU**: `sltr-mask` and `sltr-mask-root` as a WGSL kernel (`shaders/sltr_mask.wgsl`), the
//!   CPU walk statement for statement (hits and counters equal ray for ray on lavapipe, checked
//!   by the harness's `gpu_oracle` test); there the start node is located per ray inside the
//!   timed kernel (the GPU device takes no hints). The paper's `sltr` has no GPU kernel.
//!
//! Counters: `interior` (N_I), `leaves` (N_L), `prims` (r_ITM) as the kd-tree's, and a parent
//! link followed (Alg. 2's and Alg. 3's `TraverseUp`) counts as one interior node traversed:
//! Table 1's N_I is "the number of traversed interior nodes", and Figure 2 has SLTR traverse
//! the hierarchy "using only the down-links between nodes and parent links between augmented
//! nodes" (the other reading, down steps only, is `interior - ups`); `ups`: parent links
//! followed; `boxes`: ray–box tests with the stored boxes (and the start cell); `restarts`:
//! continuations after the traversal stack ran dry (BTR) or after a leaf (SLTR);
//! `handovers`: rays SLTR handed to `sltr-mask` (module `traverse`).
//!
//! Memory: `m_kd_bytes` prices a box as the text of §4 describes it (a 24-byte box and a
//! 4-byte parent link: 28 bytes); `paper_bytes` as Table 1's M_KD does (40 bytes, see
//! [`PAPER_BOX_BYTES`]); `aug_bytes` and `structure_bytes` are what we allocate.

#![deny(missing_docs)]

mod build;
mod check;
mod gpu;
mod params;
mod report;
mod traverse;

pub use params::SparseParams;

use std::sync::Arc;
use tb_core::{
    build_with, Aabb, Accel, AccelError, Answers, Batch, BuildReport, Family, HitRecord,
    MemoryReport, Query, Ray, Structure, Traversal, TraversalInfo, TraversalStats, TriTestKind,
    Triangle, Vec3,
};
use tb_kdtree::{KdLayout, KdTree, NodeRank, SurfaceArea, STACK_SIZE};

/// The auxiliary array of augmented nodes (boxes and parent links), read by BTR and SLTR.
pub const BOXES_AUX: &str = "sparse-boxes";

/// Bytes a sparse box adds to M_KD in the paper's Table 1 (`paper_bytes`). The text (§4) says
/// what a box holds: "storing a bounding box requires 24 bytes" and "a single pointer to the
/// parent augmented node", 28 bytes (`m_kd_bytes`). Table 1's M_KD implies more: (M_KD(BTR) −
/// M_KD(HTR)) / N_B is (117 − 89) MB / 0.725M = 38.6 bytes on arena and (64 − 42) MB / 0.557M =
/// 39.5 on city; with the printed figures rounded (megabytes ±0.5, N_B ±0.0005M) that is
/// 37.2-40.0 (arena) and 37.7-41.3 (city) bytes for MB = 10^6, 39.0-42.0 and 39.5-43.3 for
/// MB = 2^20. 40 is the one whole size inside all four ranges, and the paper's own parts give it when an augmented node
/// is a node of its own kind ("the augmented node is constructed ... otherwise we construct a
/// simple interior node", §4): the 8-byte interior node, the 24-byte box and the 4-byte link
/// (36 bytes) in a 48-byte record (16-byte alignment) instead of an 8-byte simple node, 40
/// bytes more. 28 lies outside every range. The layout is our reading; the 40 is Table 1's.
pub const PAPER_BOX_BYTES: u32 = 40;

/// Bytes a box holds as §4 describes it: the box (24) and the parent link (4) (`m_kd_bytes`).
pub const TEXT_BOX_BYTES: u32 = 28;

/// The structure in the registry.
pub static FAMILY: Family = Family::new::<SparseBoxes, SparseParams>(
    "a `kdtree` (depth-first; its builder parameters) with sparse boxes: augmented nodes (box and \
     parent link) every `d_min + 1` levels, start nodes found once per batch outside timing \
     (Havran and Bittner 2007); `htr` and `seq` are the kd-tree's `recursive-direction` and \
     `sequential` over the same tree; `sltr` is the paper's Alg. 3, `sltr-mask` our variant",
    |tris, set| {
        build_with(set, |p: &SparseParams| {
            SparseBoxes::try_build(tris.clone(), p)
        })
    },
)
.with_summary(
    "a kd-tree with sparse boxes: augmented nodes, start nodes, BTR and SLTR (Havran and \
     Bittner 2007)",
)
.with_rules::<SparseParams>()
.with_persist::<SparseBoxes>()
.with_stage(tb_core::Stage {
    base: &tb_kdtree::FAMILY,
    params: |set| {
        let p: SparseParams = tb_core::Params::from_set(set)?;
        Ok(tb_core::Params::to_set(&p.kd()))
    },
    finish: |base, set| {
        let kd = base
            .as_any()
            .and_then(|a| a.downcast_ref::<KdTree>())
            .ok_or_else(|| {
                AccelError::Unsupported("sparse boxes: the first stage is not a kd-tree".into())
            })?;
        build_with(set, |p: &SparseParams| Ok(SparseBoxes::over(kd.clone(), p)))
    },
})
.with_method(
    3,
    "HTR runs in BTR's kernel without its climb and SEQ in SLTR's with no augmented node but \
     the root (its hand-over to kd-restart kept), so that each pair is timed in one kernel, \
     their counts unchanged; version 2: BTR's TraverseUp climbs from \
     lastAugmentedNode, the deepest augmented node on the last leaf's path (Alg. 2), testing \
     every parent's box up to the root's",
);

impl tb_core::Persist for SparseBoxes {
    fn attach(
        &mut self,
        tris: &Arc<[Triangle]>,
        params: &tb_core::ParamSet,
    ) -> Result<(), tb_core::ParamError> {
        let p: SparseParams = tb_core::persist::params_from(params)?;
        tb_core::Persist::attach(&mut self.kd, tris, &tb_core::Params::to_set(&p.kd()))?;
        self.params = p;
        Ok(())
    }
}

/// An augmented node (§4): the node's cell and the index of its parent augmented node's record
/// (0, the root's, for the root), and the kd-tree node it belongs to. 32 bytes, `#[repr(C)]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AugNode {
    /// Lower corner of the node's cell.
    pub min: [f32; 3],
    /// Index of the parent augmented node's record (0 for the root).
    pub parent: u32,
    /// Upper corner of the node's cell.
    pub max: [f32; 3],
    /// The kd-tree node this record belongs to.
    pub node: u32,
}

const _: () = assert!(std::mem::size_of::<AugNode>() == 32);

impl AugNode {
    /// Its box.
    pub fn cell(&self) -> Aabb {
        Aabb::new(Vec3::from_array(self.min), Vec3::from_array(self.max))
    }
}

/// A kd-tree with sparse boxes (see the crate doc): the kd-tree (shared arrays), its augmented
/// nodes in node order and their depths.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct SparseBoxes {
    kd: KdTree,
    /// Not saved by the build cache (its key): given back by [`tb_core::Persist::attach`].
    #[serde(skip)]
    params: SparseParams,
    aug: Arc<[AugNode]>,
    /// The record of an augmented node in constant time (SLTR's climb from the last augmented
    /// node it passed, the start node's point location, [`SparseBoxes::aug_of`]): records are
    /// in node order, so a node's record is the number of augmented nodes before it, a
    /// [`NodeRank`] (one bit per kd-tree node, a count per 64 nodes: 0.19 bytes per node). The
    /// binary search over the records it replaces missed the cache at every level, a fifth of
    /// SLTR's time (perf, Sponza primary rays).
    rank: Arc<NodeRank>,
    depth: Arc<[u8]>,
}

impl SparseBoxes {
    /// The kd-tree below the boxes.
    pub fn kd(&self) -> &KdTree {
        &self.kd
    }

    /// The parameters it was built with.
    pub fn params(&self) -> &SparseParams {
        &self.params
    }

    /// The augmented nodes, in node order (record 0 is the root's).
    pub fn augmented(&self) -> &[AugNode] {
        &self.aug
    }

    /// A copy with the records replaced by `aug` (tests of `validate`).
    #[doc(hidden)]
    pub fn with_records(&self, aug: Vec<AugNode>) -> SparseBoxes {
        SparseBoxes {
            rank: NodeRank::new(self.kd.nodes().len(), aug.iter().map(|a| a.node)).into(),
            aug: aug.into(),
            ..self.clone()
        }
    }

    /// Depth of the node of each augmented record.
    pub fn aug_depths(&self) -> &[u8] {
        &self.depth
    }

    /// The record of kd-tree node `node`, if it is augmented.
    pub fn aug_of(&self, node: usize) -> Option<usize> {
        self.rank.find(node as u32)
    }

    /// The start node of a ray (§3) as a record index: the deepest augmented node whose cell
    /// contains `origin` strictly inside every face that is not a face of the root cell (0,
    /// the root, for an origin outside the root cell, on a split plane of the root, or not
    /// finite). Strictness makes the ray leave the start cell only after its origin, so every
    /// other cell it meets lies beyond the start cell's exit (module `traverse`).
    pub fn start_node(&self, origin: Vec3) -> u32 {
        traverse::locate(&self.kd.view(), &self.rank, self.params.period(), origin)
    }

    /// [`Self::start_node`] for every ray (hint 0 for rays with `tmin != 0`: their segment
    /// does not begin at the origin); consecutive rays sharing an origin (a camera) share the
    /// one point location.
    pub fn start_nodes(&self, rays: &[Ray]) -> Vec<u32> {
        let mut last: Option<(Vec3, u32)> = None;
        rays.iter()
            .map(|r| {
                if r.tmin != 0.0 {
                    return 0;
                }
                match last {
                    Some((o, h)) if o == r.origin => h,
                    _ => {
                        let h = self.start_node(r.origin);
                        last = Some((r.origin, h));
                        h
                    }
                }
            })
            .collect()
    }

    /// Bytes of the augmented records, their depths and their rank (what BTR and SLTR read
    /// beyond the kd-tree).
    fn boxes_bytes(&self) -> u64 {
        (std::mem::size_of_val(&*self.aug) + self.depth.len()) as u64 + self.rank.bytes()
    }
}

/// Start hints of the start-node rows.
fn hints(s: &SparseBoxes, _: Query, rays: &[Ray]) -> Vec<u32> {
    s.start_nodes(rays)
}

impl Structure for SparseBoxes {
    const NAME: &'static str = "sparse-boxes";

    /// HTR and SEQ (in BTR's and SLTR's kernels, so that each pair is timed in one kernel),
    /// BTR and SLTR from the start node (hints) and from the root (Havran and Bittner 2007
    /// Table 1).
    const TRAVERSALS: &'static [Traversal<Self>] = &[
        Traversal::cpu(
            TraversalInfo::new(
                "htr",
                "Havran & Bittner 2007 §5.1, Alg. 1",
                "HTR: the stack traversal from the root over the same tree (Havran & Bittner \
                 2007 §5.1, Alg. 1) in BTR's kernel without its climb, so that BTR and HTR are \
                 timed in one kernel; the kd-tree's recursive-direction decisions, leaves and \
                 counts; no boxes read but the root's",
            ),
            tb_core::kernel!(|s: &SparseBoxes, batch, out| {
                traverse::trace::<{ traverse::HTR }>(s, batch, false, out)
            }),
        ),
        Traversal::cpu(
            TraversalInfo::new(
                "btr",
                "Havran & Bittner 2007 §5.2, Alg. 2",
                "BTR: stack traversal from the start node (deepest augmented node holding the \
                 origin, found once per batch, untimed); when the stack runs dry, climb the \
                 parent links to a box extending beyond the finished box's exit and go on \
                 there, the finished subtree skipped (Havran & Bittner 2007 §5.2, Alg. 2)",
            )
            .reads(&[BOXES_AUX]),
            tb_core::kernel!(|s: &SparseBoxes, batch, out| {
                traverse::trace::<{ traverse::BTR }>(s, batch, true, out)
            }),
        )
        .with_hints(hints),
        Traversal::cpu(
            TraversalInfo::new(
                "btr-root",
                "Havran & Bittner 2007 §5.2, Alg. 2",
                "BTR started at the root (the start node's share of the gain separated: the \
                 same walk as HTR)",
            )
            .reads(&[BOXES_AUX]),
            tb_core::kernel!(|s: &SparseBoxes, batch, out| {
                traverse::trace::<{ traverse::BTR }>(s, batch, false, out)
            }),
        ),
        Traversal::cpu(
            TraversalInfo::new(
                "sltr",
                "Havran & Bittner 2007 §5.3, Alg. 3",
                "SLTR as the paper's Algorithm 3: stackless; from the start node (found once \
                 per batch, untimed) down to the leaf holding the origin; after each leaf the \
                 origin shifted just past the leaf's exit (exactly, not by a fixed epsilon) and \
                 located from the last augmented node while its box holds it, else from the \
                 first parent augmented node whose box does (ComputeMaxT per parent); the \
                 point location of `seq`, a ray lying in a split plane walked once per side \
                 as `seq` walks it; a point the rounding cannot place handed to `sltr-mask` \
                 (`handovers`) (Havran & Bittner 2007 §5.3, Alg. 3)",
            )
            .capped()
            .reads(&[BOXES_AUX]),
            tb_core::kernel!(|s: &SparseBoxes, batch, out| {
                traverse::trace::<{ traverse::SLTR }>(s, batch, true, out)
            }),
        )
        .with_hints(hints),
        Traversal::cpu(
            TraversalInfo::new(
                "sltr-handover",
                "Havran & Bittner 2007 §5.3, Alg. 3",
                "SLTR (Alg. 3) as `sltr`, but a ray lying in a split plane handed to \
                 `sltr-mask` from the root (keeping its closest hit) instead of walked once per \
                 side of the plane as `seq` walks it: `sltr`'s earlier, less faithful \
                 reading; `handovers` counts the rays handed over",
            )
            .capped()
            .reads(&[BOXES_AUX]),
            tb_core::kernel!(|s: &SparseBoxes, batch, out| {
                traverse::trace::<{ traverse::SLTR_HANDOVER }>(s, batch, true, out)
            }),
        )
        .with_hints(hints),
        Traversal::cpu(
            TraversalInfo::new(
                "sltr-root",
                "Havran & Bittner 2007 §5.3, Alg. 3",
                "SLTR (Alg. 3) started at the root",
            )
            .capped()
            .reads(&[BOXES_AUX]),
            tb_core::kernel!(|s: &SparseBoxes, batch, out| {
                traverse::trace::<{ traverse::SLTR }>(s, batch, false, out)
            }),
        ),
        Traversal::with_gpu(
            TraversalInfo::new(
                "sltr-mask",
                "Havran & Bittner 2007 §5.3 (a variant of Alg. 3)",
                "our stackless variant of SLTR, not the paper's Alg. 3: from the start node \
                 down to a leaf, then on from the last augmented node, climbing parent links \
                 when it is finished; the next leaf found from a per-depth mask of the nodes \
                 the ray went both ways at and the last leaf's index, no shift and no point \
                 location, so it visits exactly HTR's leaves",
            )
            .capped()
            .reads(&[BOXES_AUX]),
            tb_core::kernel!(|s: &SparseBoxes, batch, out| {
                traverse::trace::<{ traverse::SLTR_MASK }>(s, batch, true, out)
            }),
            |s| s.gpu_sltr_mask(true),
        )
        .with_hints(hints),
        Traversal::with_gpu(
            TraversalInfo::new(
                "sltr-mask-root",
                "Havran & Bittner 2007 §5.3 (a variant of Alg. 3)",
                "`sltr-mask` started at the root",
            )
            .capped()
            .reads(&[BOXES_AUX]),
            tb_core::kernel!(|s: &SparseBoxes, batch, out| {
                traverse::trace::<{ traverse::SLTR_MASK }>(s, batch, false, out)
            }),
            |s| s.gpu_sltr_mask(false),
        ),
        Traversal::cpu(
            TraversalInfo::new(
                "seq",
                "Havran & Bittner 2007 §6 (Kaplan 1985)",
                "SEQ: the sequential traversal (Kaplan 1985) over the same tree in SLTR's kernel \
                 with no augmented node but the root (every point located from the root, a point \
                 rounding cannot place handed to kd-restart), so that SLTR and SEQ are timed in \
                 one kernel; the kd-tree's `sequential` counts; no boxes read",
            )
            .capped(),
            tb_core::kernel!(|s: &SparseBoxes, batch, out| {
                traverse::trace::<{ traverse::SEQ }>(s, batch, false, out)
            }),
        ),
    ];

    /// The kd-tree's nodes, references and triangles; BTR and SLTR add the boxes
    /// ([`BOXES_AUX`]).
    ///
    /// `structure_bytes`, the paper's M_KD in our sizes: the kd-tree's nodes and references
    /// (the kd-tree's own `structure_bytes`) plus, for BTR and SLTR, the augmented nodes'
    /// records, depths and rank (`aug_bytes`); not the scene's triangle array. The paper's own
    /// accounting (8 a node, 4 a reference, and a box at 28 bytes as §4's text prices it or at
    /// 40 as Table 1 does) is `m_kd_bytes` / `paper_bytes` / `m_kd_htr_bytes`.
    fn own_memory(&self) -> MemoryReport {
        Accel::memory(&self.kd)
    }

    /// [`BOXES_AUX`]: 32 bytes and a depth byte per augmented node.
    fn aux_bytes(&self, aux: &str) -> u64 {
        match aux {
            BOXES_AUX => self.boxes_bytes(),
            _ => 0,
        }
    }

    /// The build report: see `report.rs`.
    fn report(&self) -> BuildReport {
        self.report_figures()
    }

    /// The kd-tree's checks, then: one record per augmented node (the root and the interior
    /// nodes at depths that are multiples of `d_min + 1`) in node order, with the node's cell
    /// and depth, linked to the augmented ancestor `d_min + 1` levels up, whose box holds it.
    fn check(&self) -> Result<(), AccelError> {
        Accel::validate(&self.kd)?;
        self.check_invariants().map_err(AccelError::Invalid)
    }
}

/// Trace `rays` with traversal `ti` of a [`SparseBoxes`] given as `Accel` with its hints
/// computed first (tests and tools; the harness does this through [`tb_core::par`]).
pub fn trace_hinted(
    s: &SparseBoxes,
    ti: usize,
    q: Query,
    tri: TriTestKind,
    rays: &[Ray],
    stats: Option<&mut [TraversalStats]>,
) -> Vec<HitRecord> {
    let h = s.batch_hints(ti, q, rays);
    let mut hits = vec![HitRecord::MISS; rays.len()];
    let batch = Batch::new(q, tri, rays).with_hints(h.as_deref());
    s.trace(ti, batch, Answers::new(&mut hits, stats));
    hits
}
