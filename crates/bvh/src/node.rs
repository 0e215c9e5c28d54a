//! The binary BVH's node: 32 bytes, a box and the left child or the first triangle.

use serde::{Deserialize, Serialize};
use tb_core::{Aabb, Vec3};

/// One node of the flattened tree, 32 bytes (`#[repr(C)]`, GPU-uploadable as 8 words).
///
/// | words | interior (`count == 0`) | leaf (`count > 0`) |
/// |---|---|---|
/// | 0..3 | box min | box min |
/// | 3 | `index`: left child; the right child is `index + 1` | `index`: first triangle in [`Bvh::triangles`](crate::Bvh::triangles) |
/// | 4..7 | box max | box max |
/// | 7 | `count = 0` | `count`: number of triangles |
///
/// The root is node 0. Children are stored after their parent, sibling pairs adjacent.
#[repr(C)]
#[derive(
    Clone, Copy, Debug, PartialEq, Serialize, Deserialize, bytemuck::Pod, bytemuck::Zeroable,
)]
pub struct BvhNode {
    /// Lower corner of the node's box.
    pub min: [f32; 3],
    /// Interior: index of the left child (right child = `index + 1`). Leaf: first triangle.
    pub index: u32,
    /// Upper corner of the node's box.
    pub max: [f32; 3],
    /// 0 for an interior node, the number of triangles (> 0) for a leaf.
    pub count: u32,
}

const _: () = assert!(std::mem::size_of::<BvhNode>() == 32);
const _: () = assert!(std::mem::align_of::<BvhNode>() == 4);

impl BvhNode {
    /// An interior node placeholder with an empty box.
    pub(crate) const EMPTY: BvhNode = BvhNode {
        min: [f32::INFINITY; 3],
        index: 0,
        max: [f32::NEG_INFINITY; 3],
        count: 0,
    };

    /// Whether the node is a leaf (`count > 0`).
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }

    /// The node's box.
    #[inline(always)]
    pub fn bounds(&self) -> Aabb {
        Aabb::new(Vec3::from_array(self.min), Vec3::from_array(self.max))
    }

    /// The triangle range `index .. index + count` of a leaf.
    #[inline(always)]
    pub fn prim_range(&self) -> std::ops::Range<usize> {
        self.index as usize..self.index as usize + self.count as usize
    }
}
