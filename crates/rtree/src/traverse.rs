//! The traversals of an [`Rtree`] (paper sections 4.1, 4.2 and 5.2): the paper's three and our
//! two variants of Listings 1 and 2 (`stackless-skip-empty`, `ordered-pop-cull`).
//!
//! All use the slab test of [`tb_core::Aabb::intersect`] (near/far planes chosen by the sign
//! of `1/dir`, the `NaN` of `0·inf` ignored by the max/min folds, the exit distance scaled by
//! `1 + 2·gamma(3)`, Ize 2013), clipped to `[tmin, closest hit so far]`: a box entered beyond
//! the closest hit is culled (the paper's `t < t_min` test). Any hit: the same walks,
//! returning at the first triangle hit.

use crate::{Rtree, RtreeNode, MAX_LEVELS, MAX_M};
use tb_core::leaves::{test_range, Best};
use tb_core::slab::{RayBox, EXIT_SCALE};
use tb_core::stack;
use tb_core::{Counter, HitRecord, Ray, TriTest};

/// Test the triangles of leaf `node`; with `ANY`, return the first hit.
#[inline(always)]
fn leaf<T: TriTest, C: Counter, const ANY: bool>(
    tree: &Rtree,
    node: &RtreeNode,
    pre: &T::Pre,
    ray: &Ray,
    best: &mut Best,
    c: &mut C,
) -> Option<HitRecord> {
    c.leaf();
    let (tris, ids) = (tree.triangles.as_slice(), tree.prim_ids.as_slice());
    // SAFETY: `Rtree::build` makes leaves whose runs lie inside `triangles`, each slot with its
    // primitive id (checked by `validate`).
    unsafe {
        test_range::<T, C, ANY>(
            tris,
            ids,
            {
                let first = node.index as usize;
                first..first + node.count as usize
            },
            pre,
            ray,
            best,
            c,
        )
    }
}

/// The set-up the stack walks (`ordered`, `ordered-pop-cull`, `stack`) share: the root's box
/// tested (one box; one step when hit), then the node array, `M`, the prepared ray and an
/// empty closest-hit record; `None` for an empty tree or a ray that misses the root.
#[inline(always)]
fn enter_root<'a, T: TriTest, C: Counter, const OCT: u8>(
    tree: &'a Rtree,
    ray: &Ray,
    rb: &RayBox,
    c: &mut C,
) -> Option<(&'a [RtreeNode], usize, T::Pre, Best)> {
    let nodes = tree.nodes();
    let root = nodes.first()?;
    let pre = T::prepare(ray);
    let best = Best::new(ray.tmax);
    c.boxes(1);
    let (tn, tf) = rb.slab::<OCT>(&root.min, &root.max, ray.tmin, best.t);
    if tn > tf {
        return None;
    }
    c.steps(1);
    Some((nodes, tree.big_m(), pre, best))
}

/// `stackless` (paper section 4.1, Listing 1) and, with `SKIP_EMPTY`, our
/// `stackless-skip-empty`: depth-first over the implicit layout with no stack. At slot `n`:
/// unless it is empty (the paper's `isEmptyNode`: `count == 0`, no box test), if its box is
/// hit within `[tmin, t_min]`, an intermediate node proceeds with its first entry
/// `n_e(n) = M·n + 1`, a leaf tests its triangles; otherwise (or after a leaf) the walk moves
/// to the next sibling `n + 1`, climbing to the parent `n_p(n) = ⌊(n − 1)/M⌋` while `n` is the
/// last entry (`χ(n) = M − 1`) and ending when it climbs back to the root. As in Listing 1,
/// `stackless` visits the empty sibling slots that follow a node's last entry one by one
/// (lines 4 and 19-29: the sibling step does not look at the next slot); `stackless-skip-empty`
/// treats an empty next sibling like `χ(n) = M − 1` (non-empty entries come first, so nothing
/// follows it), the same result with fewer slots visited. `steps` counts the slots visited
/// (iterations of Listing 1's loop), empty ones included.
pub(crate) struct Stackless<'a, const SKIP_EMPTY: bool>(pub &'a Rtree);

impl<const SKIP_EMPTY: bool> Stackless<'_, SKIP_EMPTY> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool, const OCT: u8>(
        &self,
        ray: &Ray,
        rb: &RayBox,
        c: &mut C,
    ) -> HitRecord {
        let tree = self.0;
        let nodes = tree.nodes();
        if nodes.is_empty() {
            return HitRecord::MISS;
        }
        let m = tree.big_m();
        // `n_p` by a shift when `M` is a power of two (the default `M = 4`).
        let shift = m.is_power_of_two().then(|| m.trailing_zeros());
        let first_leaf = tree.first_leaf as usize;
        let pre = T::prepare(ray);
        let mut best = Best::new(ray.tmax);
        let mut n = 0usize;
        'walk: loop {
            // SAFETY: `n` is the root, an entry `M·n + 1` of an intermediate node (which the
            // complete layout always holds) or a sibling `n + 1` within the same node.
            let node = unsafe { nodes.get_unchecked(n) };
            c.steps(1);
            // `skip-empty` never reaches an empty slot.
            if SKIP_EMPTY || !node.is_empty() {
                c.boxes(1);
                let (tn, tf) = rb.slab::<OCT>(&node.min, &node.max, ray.tmin, best.t);
                if tn <= tf {
                    if n < first_leaf {
                        c.interior();
                        n = n * m + 1;
                        continue;
                    }
                    if let Some(h) = leaf::<T, C, ANY>(tree, node, &pre, ray, &mut best, c) {
                        return h;
                    }
                }
            }
            // Next sibling, climbing past last entries.
            loop {
                if n == 0 {
                    break 'walk;
                }
                let parent = match shift {
                    Some(s) => (n - 1) >> s,
                    None => (n - 1) / m,
                };
                let last = n == parent * m + m;
                // SAFETY: `n` is not its parent's last entry, so `n + 1` is a sibling slot.
                if !last && (!SKIP_EMPTY || !unsafe { nodes.get_unchecked(n + 1) }.is_empty()) {
                    n += 1;
                    break;
                }
                c.restart();
                n = parent;
            }
        }
        best.record_mapped(&tree.prim_ids)
    }
}

tb_core::kernel_by_octant!([const SKIP_EMPTY: bool] Stackless<'_, SKIP_EMPTY>);

/// `ordered` (paper section 4.2, Listing 2) and, with `POP_CULL`, our `ordered-pop-cull`: one
/// stack of at most `M` entries per level. At an intermediate node of level `l`, the boxes of
/// its entries are tested and those hit within `[tmin, t_min]` are pushed on stack `l` with
/// their entry distance (Listing 2, lines 12-16: the only cull against `t_min`), kept sorted
/// by insertion sort so that the nearest is on top. The walk continues with the top of the
/// lowest non-empty stack, climbing a level when a stack runs empty, and ends when the root
/// level's stack is empty. `ordered` enters every popped entry, as Listing 2 does (lines
/// 27-32); `ordered-pop-cull` (closest hit only) also drops a popped entry whose entry
/// distance lies beyond the closest hit found since it was pushed, and with it its whole stack
/// (sorted, so every entry below it is farther still).
pub(crate) struct Ordered<'a, const POP_CULL: bool>(pub &'a Rtree);

impl<const POP_CULL: bool> Ordered<'_, POP_CULL> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool, const OCT: u8>(
        &self,
        ray: &Ray,
        rb: &RayBox,
        c: &mut C,
    ) -> HitRecord {
        let tree = self.0;
        let Some((nodes, m, pre, mut best)) = enter_root::<T, C, OCT>(tree, ray, rb, c) else {
            return HitRecord::MISS;
        };
        let top = tree.root_level as usize;
        let mut stacks = [const { stack::Stack::<(u32, f32), MAX_M>::new() }; MAX_LEVELS];
        let mut n = 0usize;
        let mut l = top;
        'walk: loop {
            // SAFETY: `n` is the root or an entry pushed from an intermediate node.
            let node = unsafe { nodes.get_unchecked(n) };
            if l > 0 {
                c.interior();
                let st = &mut stacks[l];
                let first = n * m + 1;
                // SAFETY: the entries `M·n + 1 … M·n + count` of an intermediate node exist in
                // the complete layout (`count ≤ M`).
                let children = unsafe { nodes.get_unchecked(first..first + node.count as usize) };
                for (i, child) in children.iter().enumerate() {
                    c.boxes(1);
                    let (tn, tf) = rb.slab::<OCT>(&child.min, &child.max, ray.tmin, best.t);
                    if tn <= tf {
                        // Insertion sort: decreasing distance from bottom to top.
                        st.insert_by(((first + i) as u32, tn), |e, x| x.1 < e.1);
                    }
                }
            } else if let Some(h) = leaf::<T, C, ANY>(tree, node, &pre, ray, &mut best, c) {
                return h;
            }
            // The next node: top of the lowest non-empty stack.
            loop {
                while l <= top && stacks[l].is_empty() {
                    l += 1;
                }
                let Some((child, d)) = stacks.get_mut(l).and_then(stack::Stack::pop) else {
                    break 'walk;
                };
                if !POP_CULL || ANY || d <= best.t * EXIT_SCALE {
                    n = child as usize;
                    l -= 1;
                    c.steps(1);
                    break;
                }
                stacks[l].clear();
            }
        }
        best.record_mapped(&tree.prim_ids)
    }
}

tb_core::kernel_by_octant!([const POP_CULL: bool] Ordered<'_, POP_CULL>);

/// Entries of the `stack` traversal's stack: at most `M − 1` pending entries per level above
/// the current node and `M` at its own.
const STACK_SIZE: usize = MAX_LEVELS * MAX_M;

/// `stack` (paper section 5.2, Table 3 third column): conventional depth-first with one
/// stack. At an intermediate node the boxes of its entries are tested; those hit are pushed
/// with their entry distance in reverse memory order (so entries are visited in memory order,
/// as by `stackless`); an entry popped after a hit closer than its entry distance has been
/// found is skipped (the paper's "skip AABBs further away than any intersection already
/// encountered").
pub(crate) struct Stack<'a>(pub &'a Rtree);

impl Stack<'_> {
    #[inline(always)]
    fn walk<T: TriTest, C: Counter, const ANY: bool, const OCT: u8>(
        &self,
        ray: &Ray,
        rb: &RayBox,
        c: &mut C,
    ) -> HitRecord {
        let tree = self.0;
        let Some((nodes, m, pre, mut best)) = enter_root::<T, C, OCT>(tree, ray, rb, c) else {
            return HitRecord::MISS;
        };
        let first_leaf = tree.first_leaf as usize;
        let mut stack = stack::Stack::<(u32, f32), STACK_SIZE>::new();
        let mut n = 0usize;
        'walk: loop {
            // SAFETY: `n` is the root or an entry pushed from an intermediate node.
            let node = unsafe { nodes.get_unchecked(n) };
            if n < first_leaf {
                c.interior();
                let first = n * m + 1;
                for i in (0..node.count as usize).rev() {
                    // SAFETY: as in `Ordered`: entries of an intermediate node exist.
                    let child = unsafe { nodes.get_unchecked(first + i) };
                    c.boxes(1);
                    let (tn, tf) = rb.slab::<OCT>(&child.min, &child.max, ray.tmin, best.t);
                    if tn <= tf {
                        stack.push(((first + i) as u32, tn));
                    }
                }
            } else if let Some(h) = leaf::<T, C, ANY>(tree, node, &pre, ray, &mut best, c) {
                return h;
            }
            let Some((child, _)) = stack.pop_until(|e| ANY || e.1 <= best.t * EXIT_SCALE) else {
                break 'walk;
            };
            n = child as usize;
            c.steps(1);
        }
        best.record_mapped(&tree.prim_ids)
    }
}

tb_core::kernel_by_octant!([] Stack<'_>);
