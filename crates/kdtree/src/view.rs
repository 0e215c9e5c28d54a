//! What the kernels read: a borrowed view of one kd-tree ([`KdView`]), where a walk begins
//! ([`KdStart`]), and the auxiliary arrays of `backtrack` and `ropes` ([`BackNode`], the ropes),
//! built from a view only when one of those traversals asks for them.

use crate::{split_cell, DepthFirst, KdLayout, KdNode, Layout, Treelet};
use tb_core::{Aabb, Triangle};

/// A borrowed view of one kd-tree ([`crate::KdTree::view`]): everything a traversal kernel
/// reads besides the auxiliary arrays. `Copy`, so a kernel holds it by value; several trees may
/// share one triangle array (multi-kd-trees) and a walk may begin below the root ([`KdStart`]:
/// sparse boxes). Only a built tree makes one, so the kernels may trust its indices.
#[derive(Clone, Copy, Debug)]
pub struct KdView<'a> {
    /// The nodes, root first, in layout `layout` (see [`KdNode`]).
    pub nodes: &'a [KdNode],
    /// Leaf references: a leaf owns `refs[offset .. offset + count]`, indices into `tris`.
    pub refs: &'a [u32],
    /// The triangles the references index.
    pub tris: &'a [Triangle],
    /// The root cell.
    pub bounds: Aabb,
    /// Where the children of a node lie.
    pub layout: KdLayout,
    /// Levels per block of the treelet layout.
    pub treelet_height: u32,
    /// Entries of the circular stack of `short-stack` and `stack-spilling`.
    pub short_stack: u32,
    /// Per-ray step cap of the restart-type traversals.
    pub step_cap: u32,
}

/// Where a walk begins: a node and its cell. Every traversal treats the start node as the root:
/// the ray is clipped to `cell`, restarts begin again at the start node, `backtrack` climbs no
/// higher, a rope leaving the cell ends the walk, and point location descends from it.
/// Made by [`KdView::root`] and [`KdView::start_at`], so the cell is the node's.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct KdStart {
    /// Index of the start node in the node array.
    pub node: u32,
    /// The start node's cell, to which every ray is clipped first.
    pub cell: Aabb,
}

impl KdStart {
    /// The start node's index.
    pub fn node(&self) -> usize {
        self.node as usize
    }

    /// Its cell.
    pub fn cell(&self) -> Aabb {
        self.cell
    }
}

impl<'a> KdView<'a> {
    /// The nodes, root first (see [`KdNode`]).
    pub fn nodes(&self) -> &'a [KdNode] {
        self.nodes
    }

    /// Leaf references: a leaf owns `refs()[offset .. offset + count]`, triangle indices.
    pub fn refs(&self) -> &'a [u32] {
        self.refs
    }

    /// The triangles the references index.
    pub fn triangles(&self) -> &'a [Triangle] {
        self.tris
    }

    /// The root cell.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The root and its cell: walks over the whole tree.
    pub fn root(&self) -> KdStart {
        KdStart {
            node: 0,
            cell: self.bounds,
        }
    }

    /// The children `(left, right)` of interior node `i` (for code off the traversals' hot
    /// paths; the kernels are compiled per [`Layout`]).
    pub fn children(&self, i: usize) -> (usize, usize) {
        let n = self.nodes[i];
        match self.layout {
            KdLayout::DepthFirst => DepthFirst.children(i, n),
            KdLayout::Treelet => Treelet::new(self.treelet_height).children(i, n),
        }
    }

    /// Call `f(node_index, cell, depth)` for every node of the subtree of `from`, depth-first,
    /// `from` at depth 0. Nothing for an empty tree.
    pub fn walk(&self, from: KdStart, mut f: impl FnMut(usize, &Aabb, u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = vec![(from.node as usize, from.cell, 0u32)];
        while let Some((i, cell, d)) = stack.pop() {
            f(i, &cell, d);
            let n = self.nodes[i];
            if !n.is_leaf() {
                let (l, r) = split_cell(&cell, n.axis(), n.split());
                let (li, ri) = self.children(i);
                stack.push((ri, r, d + 1));
                stack.push((li, l, d + 1));
            }
        }
    }

    /// The start at node `node` (its cell found by a walk from the root); `None` for an index
    /// that is no node of the tree (out of range, or an unused slot of the treelet layout).
    pub fn start_at(&self, node: usize) -> Option<KdStart> {
        let mut found = None;
        self.walk(self.root(), |i, cell, _| {
            if i == node {
                found = Some(KdStart {
                    node: node as u32,
                    cell: *cell,
                });
            }
        });
        found
    }
}

/// The auxiliary record of a node for the `backtrack` traversal (Foley and Sugerman 2005):
/// the node's cell and its parent's index (0 for the root). 32 bytes, `#[repr(C)]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BackNode {
    /// Lower corner of the node's cell.
    pub min: [f32; 3],
    /// Index of the node's parent (a root is its own parent).
    pub parent: u32,
    /// Upper corner of the node's cell.
    pub max: [f32; 3],
    /// Unused (0): pads the record to 32 bytes.
    pub pad: u32,
}

const _: () = assert!(std::mem::size_of::<BackNode>() == 32);

/// Per node of `v`: its cell and its parent (the `backtrack` auxiliary array), over the trees
/// rooted at `roots` (one root for a kd-tree; several trees in one node array for
/// multi-kd-trees), each root its own parent. Nodes of no tree keep a blank record.
pub fn back_nodes(v: &KdView, roots: &[u32]) -> Vec<BackNode> {
    let blank = BackNode {
        min: [0.0; 3],
        parent: 0,
        max: [0.0; 3],
        pad: 0,
    };
    let mut back = vec![blank; v.nodes.len()];
    for &root in roots {
        let from = KdStart {
            node: root,
            cell: v.bounds,
        };
        if !v.nodes.is_empty() {
            back[root as usize].parent = root;
        }
        v.walk(from, |i, cell, _| {
            back[i].min = cell.min.to_array();
            back[i].max = cell.max.to_array();
            if !v.nodes[i].is_leaf() {
                let (l, r) = v.children(i);
                back[l].parent = i as u32;
                back[r].parent = i as u32;
            }
        });
    }
    back
}

/// The leaves of the trees of `v` rooted at `roots` (unused treelet slots are none).
pub fn leaf_count(v: &KdView, roots: &[u32]) -> usize {
    let mut n = 0;
    if v.nodes.is_empty() {
        return 0;
    }
    for &root in roots {
        let from = KdStart {
            node: root,
            cell: v.bounds,
        };
        v.walk(from, |i, _, _| n += usize::from(v.nodes[i].is_leaf()));
    }
    n
}

/// "No neighbour": a rope leaving the root cell.
pub const NO_ROPE: u32 = u32::MAX;

/// A leaf's record of the `ropes` traversal: its cell and its six ropes, 48 bytes (review
/// §3.3: ropes and boxes are stored in the leaves, Havran et al. 1998). Rope `2·axis + side`
/// (side 0: the min face, 1: the max face) is the deepest node whose cell holds the whole face
/// on the other side, or [`NO_ROPE`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafRopes {
    /// Lower corner of the leaf's cell.
    pub min: [f32; 3],
    /// Upper corner of the leaf's cell.
    pub max: [f32; 3],
    /// Per face `2·axis + side`, the neighbour node across it ([`NO_ROPE`]: on the root cell).
    pub ropes: [u32; 6],
}

const _: () = assert!(std::mem::size_of::<LeafRopes>() == 48);

/// The rank of a set of nodes among the indices of a node array: one bit per node and, per 64
/// nodes, the count of members before them. Records kept per member in node order are found
/// by the rank of their node (a popcount), with no per-node index.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct NodeRank {
    bits: Box<[u64]>,
    base: Box<[u32]>,
}

impl NodeRank {
    /// The rank of `members` among `nodes` nodes (members out of range are left out).
    pub fn new(nodes: usize, members: impl IntoIterator<Item = u32>) -> NodeRank {
        let words = nodes.div_ceil(64);
        let mut bits = vec![0u64; words];
        for m in members {
            if let Some(w) = bits.get_mut(m as usize / 64) {
                *w |= 1 << (m % 64);
            }
        }
        let mut base = Vec::with_capacity(words);
        let mut n = 0u32;
        for w in &bits {
            base.push(n);
            n += w.count_ones();
        }
        NodeRank {
            bits: bits.into(),
            base: base.into(),
        }
    }

    /// The number of members before `node` (its record, if it is a member).
    #[inline(always)]
    pub fn rank(&self, node: usize) -> usize {
        let (w, b) = (node / 64, node % 64);
        (self.base[w] + (self.bits[w] & ((1u64 << b) - 1)).count_ones()) as usize
    }

    /// The record of `node`, if it is a member.
    #[inline(always)]
    pub fn find(&self, node: u32) -> Option<usize> {
        let word = *self.bits.get(node as usize / 64)?;
        (word >> (node % 64) & 1 == 1).then(|| self.rank(node as usize))
    }

    /// The GPU's words: per 64 nodes the bits' low and high words and the count before.
    pub fn words(&self) -> impl Iterator<Item = u32> + '_ {
        self.bits
            .iter()
            .zip(self.base.iter())
            .flat_map(|(&w, &n)| [w as u32, (w >> 32) as u32, n])
    }

    /// Bytes it occupies.
    pub fn bytes(&self) -> u64 {
        Self::bytes_for(self.bits.len() * 64)
    }

    /// Bytes it occupies over `nodes` nodes.
    pub fn bytes_for(nodes: usize) -> u64 {
        (nodes.div_ceil(64) * 12) as u64
    }
}

/// The `ropes` auxiliary array ([`crate::ROPES_AUX`]): per leaf, in node order, its
/// [`LeafRopes`], found by the leaf's [`NodeRank`].
#[derive(Clone, Debug, Default)]
pub struct Ropes {
    /// One record per leaf, in node order.
    pub leaves: Vec<LeafRopes>,
    /// The leaves among the node indices: a leaf's record is `leaves[rank.rank(node)]`.
    pub rank: NodeRank,
}

impl Ropes {
    /// The record of leaf `node` (a leaf of the trees the ropes were built over).
    #[inline(always)]
    pub fn leaf(&self, node: usize) -> &LeafRopes {
        &self.leaves[self.rank.rank(node)]
    }

    /// Bytes it occupies.
    pub fn bytes(&self) -> u64 {
        Self::bytes_for(self.leaves.len(), self.rank.bits.len() * 64)
    }

    /// Bytes of the records of `leaves` leaves and the rank over `nodes` nodes.
    pub fn bytes_for(leaves: usize, nodes: usize) -> u64 {
        (leaves * std::mem::size_of::<LeafRopes>()) as u64 + NodeRank::bytes_for(nodes)
    }

    /// The GPU's words: the rank's ([`NodeRank::words`]), then 12 per leaf record.
    pub fn words(&self) -> impl Iterator<Item = u32> + '_ {
        self.rank.words().chain(self.leaves.iter().flat_map(|l| {
            let (lo, hi) = (l.min.map(f32::to_bits), l.max.map(f32::to_bits));
            [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]]
                .into_iter()
                .chain(l.ropes)
        }))
    }
}

/// The ropes of the leaves of `v` (review §3.3; Havran et al. 1998, Popov et al. 2007), over
/// the trees rooted at `roots` (see [`back_nodes`]; a rope never leaves its tree): for face
/// `2·axis + side` the deepest node whose cell holds the whole face on the other side, pushed
/// down from the parent's ropes (Popov et al.'s rope optimisation): through a split parallel
/// to the face to the adjacent child, through a split missing the face to the child holding
/// it. Only the leaves keep theirs, with their cells, as the review stores them.
pub fn ropes(v: &KdView, roots: &[u32]) -> Ropes {
    let nodes = v.nodes;
    if nodes.is_empty() {
        return Ropes::default();
    }
    let back = back_nodes(v, roots);
    let push = |mut t: u32, f: usize, min: &[f32; 3], max: &[f32; 3]| -> u32 {
        while t != NO_ROPE {
            let n = nodes[t as usize];
            if n.is_leaf() {
                break;
            }
            let (a, s) = (n.axis(), n.split());
            let (left, right) = v.children(t as usize);
            let (left, right) = (left as u32, right as u32);
            t = if a == f / 2 {
                if f % 2 == 1 {
                    left
                } else {
                    right
                }
            } else if s <= min[a] {
                right
            } else if s >= max[a] {
                left
            } else {
                break;
            };
        }
        t
    };
    let mut leaves = Vec::new();
    let mut stack: Vec<_> = roots.iter().map(|&r| (r as usize, [NO_ROPE; 6])).collect();
    while let Some((i, mut r)) = stack.pop() {
        let b = &back[i];
        for (f, rope) in r.iter_mut().enumerate() {
            *rope = push(*rope, f, &b.min, &b.max);
        }
        let n = nodes[i];
        if n.is_leaf() {
            leaves.push((
                i as u32,
                LeafRopes {
                    min: b.min,
                    max: b.max,
                    ropes: r,
                },
            ));
        } else {
            let a = n.axis();
            let (left, right) = v.children(i);
            let (mut rl, mut rr) = (r, r);
            rl[2 * a + 1] = right as u32;
            rr[2 * a] = left as u32;
            stack.push((right, rr));
            stack.push((left, rl));
        }
    }
    leaves.sort_unstable_by_key(|l| l.0);
    Ropes {
        rank: NodeRank::new(nodes.len(), leaves.iter().map(|l| l.0)),
        leaves: leaves.into_iter().map(|l| l.1).collect(),
    }
}

/// The auxiliary arrays a kernel reads: empty for the traversals that read none.
#[derive(Clone, Copy, Default)]
pub struct Aux<'a> {
    /// Cell and parent per node (`backtrack`).
    pub back: &'a [BackNode],
    /// Cell and six ropes per leaf (`ropes`).
    pub ropes: Option<&'a Ropes>,
}

/// The auxiliary arrays of the trees of one node array, each built on first use from their
/// view and roots: `backtrack`'s cells and parent links ([`crate::BACKTRACK_AUX`]) and
/// `ropes`' leaf records ([`crate::ROPES_AUX`]). The kd-tree keeps one over its tree,
/// multi-kd one over its three.
#[derive(Debug, Default)]
pub struct AuxArrays {
    back: std::sync::OnceLock<Vec<BackNode>>,
    ropes: std::sync::OnceLock<Ropes>,
}

impl AuxArrays {
    /// The [`crate::BACKTRACK_AUX`] array of the trees of `v` at `roots`.
    pub fn back_nodes(&self, v: &KdView, roots: &[u32]) -> &[BackNode] {
        self.back.get_or_init(|| back_nodes(v, roots))
    }

    /// The [`crate::ROPES_AUX`] array of the trees of `v` at `roots`.
    pub fn ropes(&self, v: &KdView, roots: &[u32]) -> &Ropes {
        self.ropes.get_or_init(|| ropes(v, roots))
    }

    /// Build the array named `aux` (an auxiliary array of a traversal table row); others are
    /// not this structure's.
    pub fn prepare(&self, aux: &str, v: &KdView, roots: &[u32]) {
        match aux {
            crate::BACKTRACK_AUX => {
                self.back_nodes(v, roots);
            }
            crate::ROPES_AUX => {
                self.ropes(v, roots);
            }
            _ => {}
        }
    }

    /// Whether the array named `aux` is built.
    pub fn built(&self, aux: &str) -> bool {
        match aux {
            crate::BACKTRACK_AUX => self.back.get().is_some(),
            crate::ROPES_AUX => self.ropes.get().is_some(),
            _ => false,
        }
    }
}
