//! The kd-tree's node: 8 bytes, two GPU words (Hapala and Havran 2011 §6).

/// One node of the flattened tree, 8 bytes (review §6; `#[repr(C)]`, two GPU words).
///
/// | | `bits` | `data` |
/// |---|---|---|
/// | interior | `link << 2 \| axis` (axis 0, 1, 2) | split position (`f32` bits) |
/// | leaf | `count << 2 \| 3` | offset of the first reference in [`crate::KdTree::prim_refs`] |
///
/// The root is node 0. Where the children are depends on the layout ([`crate::Layout`]): in the
/// default depth-first order the left child is the next node and the link is the right
/// child's index; in the treelet layout the link is used only on a block's lowest level.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct KdNode {
    /// Interior: `link << 2 | axis`; leaf: `count << 2 | 3` (the low two bits tell which).
    pub bits: u32,
    /// Interior: the split position's `f32` bits; leaf: the offset of its first reference.
    pub data: u32,
}

const _: () = assert!(std::mem::size_of::<KdNode>() == 8);

impl KdNode {
    /// An interior node splitting `axis` at `split`, with link `link` (see [`crate::Layout`]).
    pub fn interior(axis: usize, split: f32, link: u32) -> KdNode {
        debug_assert!(axis < 3 && link < (1 << 30));
        KdNode {
            bits: link << 2 | axis as u32,
            data: split.to_bits(),
        }
    }

    /// A leaf of `count` references starting at `offset`.
    pub fn leaf(offset: u32, count: u32) -> KdNode {
        debug_assert!(count < (1 << 30));
        KdNode {
            bits: count << 2 | 3,
            data: offset,
        }
    }

    /// Whether this is a leaf (the low two bits of `bits` are 3).
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.bits & 3 == 3
    }

    /// Split axis of an interior node (3 for a leaf).
    #[inline(always)]
    pub fn axis(&self) -> usize {
        (self.bits & 3) as usize
    }

    /// Split position of an interior node.
    #[inline(always)]
    pub fn split(&self) -> f32 {
        f32::from_bits(self.data)
    }

    /// Link of an interior node: the right child in the depth-first layout (the left child is
    /// the node's index + 1), the first child slot on a treelet block's lowest level.
    #[inline(always)]
    pub fn link(&self) -> usize {
        (self.bits >> 2) as usize
    }

    /// Number of references of a leaf.
    #[inline(always)]
    pub fn count(&self) -> u32 {
        self.bits >> 2
    }

    /// Offset of a leaf's first reference.
    #[inline(always)]
    pub fn offset(&self) -> usize {
        self.data as usize
    }
}
