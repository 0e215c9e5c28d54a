//! Leaves as ranges of a leaf-ordered triangle array with a map back to scene indices: the
//! closest hit so far ([`Best`]) and a leaf's triangle loop ([`test_range`]) that the binary
//! BVH's walks (`ordered`, `while-while`) and the R-tree's share. The GPU programs' twin is
//! [`crate::gpu::LEAF_RANGES`].

use crate::{Counter, HitRecord, Ray, TriTest, Triangle};

/// The closest hit found so far, one record for every structure: its distance, the index that
/// names its triangle (`u32::MAX`: none yet) and `u`, `v`. The index is what the structure's
/// leaves hold: a slot of a leaf-ordered triangle array ([`Best::record_mapped`] maps it back to
/// the scene index: the binary BVH, CWBVH, R-tree) or the scene index itself ([`Best::record`]:
/// the kd family, whose leaves reference scene triangles, and the wide BVH, whose leaf blocks
/// carry them).
#[derive(Clone, Copy, Debug)]
pub struct Best {
    /// Distance of the closest hit so far (`tmax` before any hit).
    pub t: f32,
    id: u32,
    u: f32,
    v: f32,
}

impl Best {
    /// No hit before `tmax`.
    #[inline(always)]
    pub fn new(tmax: f32) -> Best {
        Best {
            t: tmax,
            id: u32::MAX,
            u: 0.0,
            v: 0.0,
        }
    }

    /// Keep a hit at `t` (closer than [`Best::t`]: the triangle tests are given `t` as their
    /// upper bound) of the triangle the leaf names `id`, at barycentrics `u`, `v`.
    #[inline(always)]
    pub fn hit(&mut self, t: f32, id: u32, u: f32, v: f32) {
        *self = Best { t, id, u, v };
    }

    /// Whether a triangle was hit.
    #[inline(always)]
    pub fn found(&self) -> bool {
        self.id != u32::MAX
    }

    /// The hit record when the index is the scene's triangle index; [`HitRecord::MISS`] while
    /// no triangle was hit.
    #[inline(always)]
    pub fn record(&self) -> HitRecord {
        if !self.found() {
            return HitRecord::MISS;
        }
        HitRecord {
            t: self.t,
            prim: self.id,
            u: self.u,
            v: self.v,
        }
    }

    /// The hit record when the index is a slot of leaf-ordered triangles, whose scene indices
    /// are `prim_ids`.
    #[inline(always)]
    pub fn record_mapped(&self, prim_ids: &[u32]) -> HitRecord {
        if !self.found() {
            return HitRecord::MISS;
        }
        HitRecord {
            t: self.t,
            prim: prim_ids[self.id as usize],
            u: self.u,
            v: self.v,
        }
    }
}

/// Test the triangles `leaf` (a range of slots) of the leaf-ordered `tris`: `prims` counted per
/// leaf for the closest hit (kept in `best`), per test for any hit, whose first hit is returned
/// (the walk ends). The caller counts the leaf (and its step) as its walk does.
///
/// # Safety
///
/// `leaf.end <= tris.len()`, and `prim_ids` has an entry for every slot of `tris`: the
/// structures' builders make such leaves and their `validate` checks them.
#[inline(always)]
pub unsafe fn test_range<T: TriTest, C: Counter, const ANY: bool>(
    tris: &[Triangle],
    prim_ids: &[u32],
    leaf: std::ops::Range<usize>,
    pre: &T::Pre,
    ray: &Ray,
    best: &mut Best,
    c: &mut C,
) -> Option<HitRecord> {
    // SAFETY: the caller's contract.
    let (first, count) = (leaf.start, leaf.len() as u32);
    let leaf = unsafe { tris.get_unchecked(leaf) };
    if ANY {
        for (k, tri) in leaf.iter().enumerate() {
            c.prims(1);
            if let Some((t, u, v)) = T::intersect(pre, ray, tri, best.t) {
                return Some(HitRecord {
                    t,
                    prim: prim_ids[first + k],
                    u,
                    v,
                });
            }
        }
    } else {
        c.prims(count);
        for (k, tri) in leaf.iter().enumerate() {
            if let Some((t, u, v)) = T::intersect(pre, ray, tri, best.t) {
                best.hit(t, (first + k) as u32, u, v);
            }
        }
    }
    None
}
