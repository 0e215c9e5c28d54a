//! Node layouts (Hapala and Havran 2011 §6): where the children of a node lie in the node array.
//!
//! - [`DepthFirst`] (§6.1, Wald et al. 2001): nodes in depth-first order, the left child next
//!   to its parent, the right child's index in the node ([`KdNode::link`]). Every node is used.
//! - [`Treelet`] (§6.2, Havran 1999, "corresponding to the van Emde Boas layout"; also called the
//!   treelet layout): the tree is cut into subtrees of `h` levels, each stored in a block of
//!   `2^h` slots aligned to the block size (64 bytes, one cache line, for `h = 3`), in the
//!   implicit heap order of a complete binary tree of `2^h − 1` nodes (the block's last slot is
//!   padding). Inside a block the children of local slot `k` are at `2k + 1` and `2k + 2`
//!   (computed from the address, no pointer); only the nodes on the block's lowest level store
//!   a link: the first slot of a pair of adjacent blocks holding the left and the right child
//!   subtree. Slots a subtree does not fill (a leaf above the block's lowest level, a child
//!   subtree shallower than `h`) stay empty: memory traded for fewer cache lines per path, as
//!   the review says. Szécsi's (2003) filling of the empty slots is not implemented.
//!
//! The traversals are generic over [`Layout`], so each layout gets its own compiled kernels and
//! the depth-first one pays nothing for the option. The node array is 64-byte aligned in both.

use crate::KdNode;

tb_core::choice! {
    /// Which node layout a [`crate::KdTree`] is stored in (parameter `layout`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum KdLayout {
        /// Depth-first order, left child next to the parent (review §6.1).
        DepthFirst = "depth-first",
        /// Regular subtrees of `treelet_height` levels in aligned blocks (review §6.2).
        Treelet = "treelet",
    }
}

/// Child addressing of a node layout.
pub trait Layout: Copy + Send + Sync {
    /// Nodes in depth-first order: the subtree of node `i` is `i ..` its right sibling's
    /// index, so a node's index tells which child's subtree holds it (the restart-type
    /// traversals use that instead of keeping the path to the last leaf).
    const DEPTH_FIRST: bool;

    /// The children `(left, right)` of interior node `n` stored at index `i`.
    fn children(self, i: usize, n: KdNode) -> (usize, usize);
}

/// [`KdLayout::DepthFirst`]: left child at `i + 1`, right child at the node's link.
#[derive(Clone, Copy, Debug)]
pub struct DepthFirst;

impl Layout for DepthFirst {
    const DEPTH_FIRST: bool = true;

    #[inline(always)]
    fn children(self, i: usize, n: KdNode) -> (usize, usize) {
        (i + 1, n.link())
    }
}

/// [`KdLayout::Treelet`] with blocks of `2^h` slots.
#[derive(Clone, Copy, Debug)]
pub struct Treelet {
    /// `2^h − 1`: the local slot of index `i` is `i & mask` (blocks are aligned).
    mask: usize,
}

impl Treelet {
    /// Addressing of blocks of `height` levels (`2^height` slots); `height` in `1..=16`.
    pub fn new(height: u32) -> Treelet {
        debug_assert!((1..=16).contains(&height));
        Treelet {
            mask: (1 << height) - 1,
        }
    }

    /// Slots per block.
    #[inline(always)]
    fn slots(self) -> usize {
        self.mask + 1
    }

    /// Whether local slot `k` lies above the block's lowest level (its children in the block).
    #[inline(always)]
    fn inner(self, k: usize) -> bool {
        2 * k + 2 < self.mask
    }
}

impl Layout for Treelet {
    const DEPTH_FIRST: bool = false;

    #[inline(always)]
    fn children(self, i: usize, n: KdNode) -> (usize, usize) {
        let k = i & self.mask;
        // Written as selects: `i + k + 1` is slot `2k + 1` of this block.
        let inner = self.inner(k);
        let left = if inner { i + k + 1 } else { n.link() };
        let step = if inner { 1 } else { self.slots() };
        (left, left + step)
    }
}

/// An unused slot: an empty leaf (unreachable from the root).
pub const EMPTY_SLOT: KdNode = KdNode { bits: 3, data: 0 };

/// One cache line of nodes: the unit of allocation of [`Nodes`], so that the array (and every
/// treelet block of at most 64 bytes) starts on a line.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
struct Line([KdNode; 8]);

/// The node array, 64-byte aligned (a plain `Vec<KdNode>` is only 4-byte aligned, and a large
/// allocation usually starts 16 bytes into a page, so a 64-byte treelet block would straddle
/// two lines).
#[derive(Clone, Debug, Default)]
pub struct Nodes {
    lines: Vec<Line>,
    len: usize,
}

impl Nodes {
    /// Copy the nodes `v` into whole lines, the last line's tail filled with [`EMPTY_SLOT`].
    pub fn from_slice(v: &[KdNode]) -> Nodes {
        let mut lines = vec![Line([EMPTY_SLOT; 8]); v.len().div_ceil(8)];
        for (i, n) in v.iter().enumerate() {
            lines[i / 8].0[i % 8] = *n;
        }
        Nodes {
            lines,
            len: v.len(),
        }
    }

    /// The nodes as one contiguous slice (the padding of the last line left out).
    pub fn as_slice(&self) -> &[KdNode] {
        // SAFETY: `Line` is `repr(C)` around `[KdNode; 8]` with no padding (size 64 = 8 × 8),
        // so the lines are `8 · lines.len() >= len` contiguous, initialised nodes.
        unsafe { std::slice::from_raw_parts(self.lines.as_ptr().cast::<KdNode>(), self.len) }
    }

    /// The nodes as one contiguous mutable slice (the padding of the last line left out).
    pub fn as_mut_slice(&mut self) -> &mut [KdNode] {
        // SAFETY: as in `as_slice`, through the unique borrow.
        unsafe {
            std::slice::from_raw_parts_mut(self.lines.as_mut_ptr().cast::<KdNode>(), self.len)
        }
    }

    /// Bytes held (whole lines).
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.lines.as_slice())
    }
}

/// Saved as the plain node sequence, read back into whole lines.
impl serde::Serialize for Nodes {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.as_slice().serialize(s)
    }
}

impl<'de> serde::Deserialize<'de> for Nodes {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(Nodes::from_slice(&Vec::<KdNode>::deserialize(d)?))
    }
}

impl std::ops::Deref for Nodes {
    type Target = [KdNode];
    fn deref(&self) -> &[KdNode] {
        self.as_slice()
    }
}

impl std::ops::DerefMut for Nodes {
    fn deref_mut(&mut self) -> &mut [KdNode] {
        self.as_mut_slice()
    }
}

impl PartialEq for Nodes {
    fn eq(&self, other: &Nodes) -> bool {
        self.as_slice() == other.as_slice()
    }
}

/// Re-lay the depth-first tree `dfs` (root 0, left child next, link = right child) into
/// treelet blocks of `2^height` slots (see [`Treelet`]). Child subtrees are placed depth-first,
/// so the blocks of a subtree lie together. Panics if the layout needs 2^30 slots or more (the
/// link field's range).
pub fn to_treelets(dfs: &[KdNode], height: u32) -> Vec<KdNode> {
    if dfs.is_empty() {
        return Vec::new();
    }
    let t = Treelet::new(height);
    let slots = t.slots();
    let mut out = vec![EMPTY_SLOT; slots];
    // (node in `dfs`, its slot in `out`)
    let mut stack = vec![(0usize, 0usize)];
    while let Some((d, o)) = stack.pop() {
        let n = dfs[d];
        if n.is_leaf() {
            out[o] = n;
            continue;
        }
        let (l, r) = DepthFirst.children(d, n);
        let k = o & t.mask;
        let (lo, ro) = if t.inner(k) {
            out[o] = KdNode::interior(n.axis(), n.split(), 0);
            (o + k + 1, o + k + 2)
        } else {
            let b = out.len();
            assert!(
                b + 2 * slots < 1 << 30,
                "kd-tree: the treelet layout needs 2^30 slots or more"
            );
            out.resize(b + 2 * slots, EMPTY_SLOT);
            out[o] = KdNode::interior(n.axis(), n.split(), b as u32);
            (b, b + slots)
        };
        stack.push((r, ro));
        stack.push((l, lo));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn treelet_addressing() {
        let t = Treelet::new(3);
        let n = KdNode::interior(0, 1.0, 40);
        // Local slots 0..=2 have their children in the block.
        assert_eq!(t.children(8, n), (9, 10));
        assert_eq!(t.children(9, n), (11, 12));
        assert_eq!(t.children(10, n), (13, 14));
        // Slots 3..=6 are the lowest level: a pair of blocks at the link.
        for k in 3..7 {
            assert_eq!(t.children(8 + k, n), (40, 48));
        }
        assert_eq!(DepthFirst.children(5, n), (6, 40));
    }

    #[test]
    fn nodes_are_line_aligned() {
        let v: Vec<KdNode> = (0..21).map(|i| KdNode::leaf(i, 1)).collect();
        let n = Nodes::from_slice(&v);
        assert_eq!(n.as_slice(), v.as_slice());
        assert_eq!(n.as_ptr() as usize % 64, 0);
        assert_eq!(n.bytes(), 3 * 64);
    }
}
