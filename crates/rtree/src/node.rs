//! The R-tree's node: 32 bytes (Feldmann et al. 2015 §3): a box and the first child or triangle.

use serde::{Deserialize, Serialize};
use tb_core::{Aabb, Vec3};

/// One slot of the packed level-order array, 32 bytes (`#[repr(C)]`, GPU-uploadable as 8
/// words). Whether a slot is a leaf follows from its index (slots `≥ Δ_L(0)` are leaves).
///
/// | words | intermediate node | leaf | empty slot |
/// |---|---|---|---|
/// | 0..3 | box min | box min | `+inf` |
/// | 3 | `index`: 0 (entries at `M·i + 1 …`) | `index`: first triangle in [`Rtree::triangles`](crate::Rtree::triangles) | 0 |
/// | 4..7 | box max | box max | `−inf` |
/// | 7 | `count`: entries (non-empty first) | `count`: triangles | 0 |
#[repr(C)]
#[derive(
    Clone, Copy, Debug, PartialEq, Serialize, Deserialize, bytemuck::Pod, bytemuck::Zeroable,
)]
pub struct RtreeNode {
    /// Lower corner of the slot's box (`+inf` for an empty slot).
    pub min: [f32; 3],
    /// Leaf: its first triangle in [`Rtree::triangles`](crate::Rtree::triangles); else 0.
    pub index: u32,
    /// Upper corner of the slot's box (`−inf` for an empty slot).
    pub max: [f32; 3],
    /// Intermediate node: its entries; leaf: its triangles; empty slot: 0.
    pub count: u32,
}

const _: () = assert!(std::mem::size_of::<RtreeNode>() == 32);

impl tb_core::persist::Slot for RtreeNode {
    const EMPTY: RtreeNode = RtreeNode::EMPTY;
}

impl RtreeNode {
    /// An empty slot: the empty box, no entries.
    pub const EMPTY: RtreeNode = RtreeNode {
        min: [f32::INFINITY; 3],
        index: 0,
        max: [f32::NEG_INFINITY; 3],
        count: 0,
    };

    /// Whether this is an empty slot of the complete layout (paper: `isEmptyNode`).
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The slot's box.
    #[inline(always)]
    pub fn bounds(&self) -> Aabb {
        Aabb::new(Vec3::from_array(self.min), Vec3::from_array(self.max))
    }
}
