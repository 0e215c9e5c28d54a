//! Leaves as ranges of a leaf-ordered triangle array with a map back to scene indices: the
//! closest hit so far ([`Best`]) and a leaf's triangle loop ([`test_range`]) that the binary
//! BVH's walks (`ordered`, `while-while`) and the R-tree's share. The GPU programs' twin is
//! [`crate::gpu::LEAF_RANGES`].

use crate::{Counter, HitRecord, Ray, TriTest, Triangle};

/// The closest hit found so far: its distance and its slot in the leaf-ordered triangles
/// (`usize::MAX`: none yet), `u`, `v`.
#[derive(Clone, Copy, Debug)]
pub struct Best {
    /// Distance of the closest hit so far (`tmax` before any hit).
    pub t: f32,
    slot: usize,
    u: f32,
    v: f32,
}

impl Best {
    /// No hit before `tmax`.
    #[inline(always)]
    pub fn new(tmax: f32) -> Best {
        Best {
            t: tmax,
            slot: usize::MAX,
            u: 0.0,
            v: 0.0,
        }
    }

    /// The hit record, its triangle named by the scene index `prim_ids[slot]`.
    #[inline(always)]
    pub fn record(&self, prim_ids: &[u32]) -> HitRecord {
        if self.slot == usize::MAX {
            return HitRecord::MISS;
        }
        HitRecord {
            t: self.t,
            prim: prim_ids[self.slot],
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
                *best = Best {
                    t,
                    slot: first + k,
                    u,
                    v,
                };
            }
        }
    }
    None
}
