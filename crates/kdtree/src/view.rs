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
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdStart {
    pub node: u32,
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
    pub min: [f32; 3],
    pub parent: u32,
    pub max: [f32; 3],
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

/// "No neighbour": a rope leaving the root cell.
pub const NO_ROPE: u32 = u32::MAX;

/// The ropes of every node of `v` (review §3.3; Havran et al. 1998, Popov et al. 2007), from
/// its cells `back`: for face `2·axis + side` (side 0: the min face, 1: the max face) the
/// deepest node whose cell holds the whole face on the other side, pushed down from the
/// parent's ropes (Popov et al.'s rope optimisation): through a split parallel to the face to
/// the adjacent child, through a split missing the face to the child holding it. Meaningful for
/// leaves; interior nodes keep their (pushed-down) ropes too. Over the trees rooted at `roots`
/// (see [`back_nodes`]): a rope never leaves its tree.
pub fn ropes(v: &KdView, back: &[BackNode], roots: &[u32]) -> Vec<[u32; 6]> {
    let nodes = v.nodes;
    let mut out = vec![[NO_ROPE; 6]; nodes.len()];
    if nodes.is_empty() {
        return out;
    }
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
    let mut stack: Vec<_> = roots.iter().map(|&r| (r as usize, [NO_ROPE; 6])).collect();
    while let Some((i, mut r)) = stack.pop() {
        let b = &back[i];
        for (f, rope) in r.iter_mut().enumerate() {
            *rope = push(*rope, f, &b.min, &b.max);
        }
        out[i] = r;
        let n = nodes[i];
        if !n.is_leaf() {
            let a = n.axis();
            let (left, right) = v.children(i);
            let (mut rl, mut rr) = (r, r);
            rl[2 * a + 1] = right as u32;
            rr[2 * a] = left as u32;
            stack.push((right, rr));
            stack.push((left, rl));
        }
    }
    out
}

/// The auxiliary arrays a kernel reads: empty for the traversals that read none.
#[derive(Clone, Copy, Default)]
pub struct Aux<'a> {
    /// Cell and parent per node (`backtrack`, `ropes`).
    pub back: &'a [BackNode],
    /// Six ropes per node (`ropes`).
    pub ropes: &'a [[u32; 6]],
}
