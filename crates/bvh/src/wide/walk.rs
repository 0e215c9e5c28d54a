//! The `ordered` traversal of a wide tree: all child boxes of a node tested at once (SSE, AVX or a lane loop), the hit children visited nearest first (Wald, Benthin and Boulos 2008).

use super::*;
use tb_core::leaves::Best;

/// Which instruction set tests a node's child boxes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Isa {
    Scalar,
    #[cfg(target_arch = "x86_64")]
    Sse,
    #[cfg(target_arch = "x86_64")]
    Avx,
    /// The AVX test compiled for AVX-512 (VL) CPUs: the same instructions' results, with the
    /// 32 vector registers and mask registers at the compiler's disposal.
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

impl Isa {
    /// The best for width `n` on this CPU (`scalar` forces the lane loop).
    pub(crate) fn detect(n: usize, scalar: bool) -> Isa {
        if scalar {
            return Isa::Scalar;
        }
        #[cfg(target_arch = "x86_64")]
        {
            if n == 4 {
                return Isa::Sse;
            }
            if n == 8
                && std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512vl")
            {
                return Isa::Avx512;
            }
            if n == 8 && std::arch::is_x86_feature_detected!("avx") {
                return Isa::Avx;
            }
        }
        let _ = n;
        Isa::Scalar
    }
}

/// Per-ray data of the wide node test: origin and `1/dir` per axis, and, per axis, the offset
/// (in floats from the start of a node) of the near and far plane rows.
#[derive(Clone, Copy)]
struct WideRay {
    org: [f32; 3],
    inv: [f32; 3],
    near: [usize; 3],
    far: [usize; 3],
}

impl WideRay {
    fn new<const N: usize>(ray: &Ray) -> Self {
        let inv = ray.inv_dir().to_array();
        let mut near = [0; 3];
        let mut far = [0; 3];
        for a in 0..3 {
            // `min` rows at `a·N`, `max` rows at `(3 + a)·N`; a negative `1/dir` (also −0's
            // −inf) makes `max` the near plane, as in `RayBox::new`.
            let (lo, hi) = (a * N, (3 + a) * N);
            (near[a], far[a]) = if inv[a] < 0.0 { (hi, lo) } else { (lo, hi) };
        }
        WideRay {
            org: ray.origin.to_array(),
            inv,
            near,
            far,
        }
    }
}

impl WideRay {
    /// The scalar slab test (`RayBox::slab`) of the binary root box.
    #[inline(always)]
    fn root_slab(&self, root: &BvhNode, tmin: f32, tmax: f32) -> (f32, f32) {
        let (mut n, mut f) = (tmin, tmax);
        for a in 0..3 {
            let lo = if self.inv[a] < 0.0 {
                root.max[a]
            } else {
                root.min[a]
            };
            n = max_num(n, (lo - self.org[a]) * self.inv[a]);
        }
        for a in 0..3 {
            let hi = if self.inv[a] < 0.0 {
                root.min[a]
            } else {
                root.max[a]
            };
            f = min_num(f, (hi - self.org[a]) * self.inv[a]);
        }
        (n, f * EXIT_SCALE)
    }
}

/// Tests all `N` child boxes of a node: returns the mask of hit children (bit `i` for slot
/// `i`) and their entry distances.
trait BoxTest<const N: usize> {
    /// Whether leaves are tested four triangles at once ([`TriTest::intersect4`]).
    const SIMD_LEAVES: bool;
    /// # Safety
    /// The instruction set of the implementation must be available.
    unsafe fn test(node: &WideNode<N>, r: &WideRay, tmin: f32, tmax: f32) -> (u32, [f32; N]);
}

/// The lane loop, the scalar slab test of `tb_core::slab` per child.
struct Scalar;

impl<const N: usize> BoxTest<N> for Scalar {
    const SIMD_LEAVES: bool = false;
    #[inline(always)]
    unsafe fn test(node: &WideNode<N>, r: &WideRay, tmin: f32, tmax: f32) -> (u32, [f32; N]) {
        let p = node as *const WideNode<N> as *const f32;
        let mut tn = [0.0f32; N];
        let mut mask = 0;
        for i in 0..N {
            // SAFETY: the offsets are row starts (< 6·N) of the node's 6·N box floats.
            let pl = |off: usize| unsafe { *p.add(off + i) };
            let tx0 = (pl(r.near[0]) - r.org[0]) * r.inv[0];
            let ty0 = (pl(r.near[1]) - r.org[1]) * r.inv[1];
            let tz0 = (pl(r.near[2]) - r.org[2]) * r.inv[2];
            let tx1 = (pl(r.far[0]) - r.org[0]) * r.inv[0];
            let ty1 = (pl(r.far[1]) - r.org[1]) * r.inv[1];
            let tz1 = (pl(r.far[2]) - r.org[2]) * r.inv[2];
            let n = max_num(max_num(max_num(tmin, tx0), ty0), tz0);
            let f = min_num(min_num(min_num(tmax, tx1), ty1), tz1) * EXIT_SCALE;
            tn[i] = n;
            mask |= ((n <= f) as u32) << i;
        }
        (mask, tn)
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use std::arch::x86_64::*;

    /// Four lanes with SSE (baseline on x86-64).
    pub(super) struct Sse;

    impl BoxTest<4> for Sse {
        const SIMD_LEAVES: bool = true;
        #[inline(always)]
        unsafe fn test(node: &WideNode<4>, r: &WideRay, tmin: f32, tmax: f32) -> (u32, [f32; 4]) {
            // SAFETY: SSE is part of x86-64; the loads read rows inside the node.
            unsafe {
                let p = node as *const WideNode<4> as *const f32;
                let plane = |off: usize, a: usize| {
                    let v = _mm_load_ps(p.add(off));
                    _mm_mul_ps(_mm_sub_ps(v, _mm_set1_ps(r.org[a])), _mm_set1_ps(r.inv[a]))
                };
                // `_mm_max_ps(t, acc)` is `t > acc ? t : acc`: a NaN `t` leaves `acc`, as
                // `max_num(acc, t)` (same for min).
                let mut n = _mm_set1_ps(tmin);
                let mut f = _mm_set1_ps(tmax);
                for a in 0..3 {
                    n = _mm_max_ps(plane(r.near[a], a), n);
                }
                for a in 0..3 {
                    f = _mm_min_ps(plane(r.far[a], a), f);
                }
                f = _mm_mul_ps(f, _mm_set1_ps(EXIT_SCALE));
                let mask = _mm_movemask_ps(_mm_cmple_ps(n, f)) as u32;
                let mut tn = [0.0f32; 4];
                _mm_storeu_ps(tn.as_mut_ptr(), n);
                (mask, tn)
            }
        }
    }

    /// Eight lanes with AVX.
    pub(super) struct Avx;

    impl BoxTest<8> for Avx {
        const SIMD_LEAVES: bool = true;
        #[inline(always)]
        unsafe fn test(node: &WideNode<8>, r: &WideRay, tmin: f32, tmax: f32) -> (u32, [f32; 8]) {
            // SAFETY: the caller runs this inside an `avx` function on a CPU that has it; the
            // loads read rows inside the (32-byte aligned) node.
            unsafe {
                let p = node as *const WideNode<8> as *const f32;
                let plane = |off: usize, a: usize| {
                    let v = _mm256_load_ps(p.add(off));
                    _mm256_mul_ps(
                        _mm256_sub_ps(v, _mm256_set1_ps(r.org[a])),
                        _mm256_set1_ps(r.inv[a]),
                    )
                };
                let mut n = _mm256_set1_ps(tmin);
                let mut f = _mm256_set1_ps(tmax);
                for a in 0..3 {
                    n = _mm256_max_ps(plane(r.near[a], a), n);
                }
                for a in 0..3 {
                    f = _mm256_min_ps(plane(r.far[a], a), f);
                }
                f = _mm256_mul_ps(f, _mm256_set1_ps(EXIT_SCALE));
                let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(n, f)) as u32;
                let mut tn = [0.0f32; 8];
                _mm256_storeu_ps(tn.as_mut_ptr(), n);
                (mask, tn)
            }
        }
    }
}

/// The entry points of the SIMD walks: each is `walk` with box test `$test` on a node width of
/// `$n`, compiled with the instruction sets `$features` enabled (so that `walk` and the box
/// and triangle tests it inlines use them).
macro_rules! simd_entries {
    ($($(#[doc = $doc:literal])* $name:ident, $features:literal, $n:literal, $test:ident;)*) => {$(
        $(#[doc = $doc])*
        /// # Safety
        /// The CPU must have the instruction sets, and `N` must be the width named.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $features)]
        unsafe fn $name<T: TriTest, C: Counter, const ANY: bool>(
            &self,
            ray: &Ray,
            c: &mut C,
        ) -> HitRecord {
            assert!(N == $n);
            // SAFETY: N = $n, so the cast is the identity; the caller guarantees the
            // instruction sets.
            unsafe {
                let me: &Wide<'_, $n> = &*(self as *const Self as *const Wide<'_, $n>);
                me.walk::<x86::$test, T, C, ANY>(ray, c)
            }
        }
    )*};
}

/// The `ordered` traversal of a wide [`Bvh`] of width `N`.
pub(crate) struct Wide<'a, const N: usize> {
    pub nodes: &'a [WideNode<N>],
    pub blocks: &'a [LeafBlock],
    pub isa: Isa,
    /// The binary root (its box is tested first).
    pub root: Option<&'a BvhNode>,
}

/// A pending child: node index or first leaf block, triangle count (0: interior), entry
/// distance.
#[derive(Clone, Copy)]
struct Entry {
    index: u32,
    count: u32,
    t: f32,
}

impl<const N: usize> Wide<'_, N> {
    #[inline(always)]
    fn traverse<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        match self.isa {
            // SAFETY: `Isa::detect` chose SSE (x86-64 baseline) for N = 4 only.
            #[cfg(target_arch = "x86_64")]
            Isa::Sse => unsafe { self.walk_sse::<T, C, ANY>(ray, c) },
            // SAFETY: `Isa::detect` chose AVX for N = 8 on a CPU that has it.
            #[cfg(target_arch = "x86_64")]
            Isa::Avx => unsafe { self.walk_avx::<T, C, ANY>(ray, c) },
            // SAFETY: `Isa::detect` chose AVX-512 for N = 8 on a CPU that has it.
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => unsafe { self.walk_avx512::<T, C, ANY>(ray, c) },
            // SAFETY: the scalar test needs nothing.
            Isa::Scalar => unsafe { self.walk::<Scalar, T, C, ANY>(ray, c) },
        }
    }

    simd_entries! {
        /// SSE (x86-64's baseline) for N = 4.
        walk_sse, "sse2", 4, Sse;
        /// AVX for N = 8.
        walk_avx, "avx", 8, Avx;
        /// The same AVX walk compiled with AVX-512 enabled (more registers, mask registers;
        /// the same operations and results).
        walk_avx512, "avx,avx2,avx512f,avx512vl", 8, Avx;
    }

    /// # Safety
    /// `B`'s instruction set must be available.
    #[inline(always)]
    unsafe fn walk<B: BoxTest<N>, T: TriTest, C: Counter, const ANY: bool>(
        &self,
        ray: &Ray,
        c: &mut C,
    ) -> HitRecord {
        let nodes = self.nodes;
        let blocks = self.blocks;
        let Some(root) = self.root else {
            return HitRecord::MISS;
        };
        // A NaN origin or direction misses every triangle (both tests compare with NaN); it
        // would also "enter" the empty slots' boxes, which must never be visited.
        if ray.origin.is_nan() || ray.dir.is_nan() {
            return HitRecord::MISS;
        }
        let tmin = ray.tmin;
        c.boxes(1);
        let r = WideRay::new::<N>(ray);
        let (tn, tf) = r.root_slab(root, tmin, ray.tmax);
        let root_hit = tn <= tf;
        if !root_hit {
            return HitRecord::MISS;
        }
        let pre = T::prepare(ray);
        let mut best = Best::new(ray.tmax);
        let mut stack = Stack::<Entry, WIDE_STACK_SIZE>::new();
        let mut cur = Entry {
            index: 0,
            count: 0,
            t: tn,
        };
        'walk: loop {
            if cur.count == 0 {
                c.interior();
                c.steps(1);
                // SAFETY: interior entries hold node indices made by `collapse` (checked by
                // `validate`).
                let node = unsafe { nodes.get_unchecked(cur.index as usize) };
                if C::ENABLED {
                    c.boxes(node.children() as u32);
                }
                // SAFETY: the caller guarantees `B`'s instruction set.
                let (mask, tn) = unsafe { B::test(node, &r, tmin, best.t) };
                if mask != 0 {
                    cur = descend::<N, ANY>(node, mask, &tn, &mut stack);
                    continue 'walk;
                }
            } else {
                c.leaf();
                c.steps(1);
                let first = cur.index as usize;
                let count = cur.count as usize;
                // SAFETY: a leaf's ⌈count / 4⌉ blocks lie inside `blocks` (checked by
                // `validate`).
                let leaf = unsafe { blocks.get_unchecked(first..first + count.div_ceil(4)) };
                if ANY {
                    if let Some(h) = any_hit_leaf::<B, T, C, N>(&pre, ray, leaf, count, best.t, c) {
                        return h;
                    }
                } else {
                    c.prims(cur.count);
                    closest_hit_leaf::<B, T, N>(&pre, ray, leaf, count, &mut best);
                }
            }
            let Some(e) = stack.pop_until(|e| ANY || e.t <= best.t * EXIT_SCALE) else {
                break 'walk;
            };
            cur = e;
        }
        best.record()
    }
}

/// The next entry after a node whose children `mask` were hit (at entry distances `tn`;
/// `mask != 0`): the nearest hit child, the others pushed on `stack` farthest first (with
/// `ANY`, in slot order: order does not decide an any-hit answer).
#[inline(always)]
fn descend<const N: usize, const ANY: bool>(
    node: &WideNode<N>,
    mut mask: u32,
    tn: &[f32; N],
    stack: &mut Stack<Entry, WIDE_STACK_SIZE>,
) -> Entry {
    let first = mask.trailing_zeros() as usize;
    mask &= mask - 1;
    if mask == 0 {
        return Entry {
            index: node.child[first],
            count: node.count[first],
            t: tn[first],
        };
    }
    if ANY {
        // Any hit: order does not decide the answer; push the others as found.
        while mask != 0 {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            stack.push(Entry {
                index: node.child[i],
                count: node.count[i],
                t: tn[i],
            });
        }
        return Entry {
            index: node.child[first],
            count: node.count[first],
            t: tn[first],
        };
    }
    // Several hit: sort by entry distance (insertion sort, ≤ 8, the farthest on top), push
    // all but the nearest, farthest first.
    let mut hit = Stack::<(f32, usize), N>::new();
    hit.push((tn[first], first));
    while mask != 0 {
        let i = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        hit.insert_by((tn[i], i), |e, x| x.0 > e.0);
    }
    let sorted = hit.as_slice();
    for &(t, i) in sorted[1..].iter().rev() {
        // At most N − 1 entries per level and a depth of at most MAX_DEPTH (checked by
        // `validate`): in range.
        stack.push(Entry {
            index: node.child[i],
            count: node.count[i],
            t,
        });
    }
    let (t, i) = sorted[0];
    Entry {
        index: node.child[i],
        count: node.count[i],
        t,
    }
}

/// Any hit in the `count` triangles of `leaf` within `[tmin, best_t)`: the first in triangle
/// order ends the ray; the triangles before it and it are the ones counted as tested.
#[inline(always)]
fn any_hit_leaf<B: BoxTest<N>, T: TriTest, C: Counter, const N: usize>(
    pre: &T::Pre,
    ray: &Ray,
    leaf: &[LeafBlock],
    count: usize,
    best_t: f32,
    c: &mut C,
) -> Option<HitRecord> {
    for (j, b) in leaf.iter().enumerate() {
        let lanes = (count - 4 * j).min(4);
        if let Some((i, (t, u, v))) = first_hit::<B, T, N>(pre, ray, b, lanes, best_t) {
            c.prims(i as u32 + 1);
            return Some(HitRecord {
                t,
                prim: b.prim[i],
                u,
                v,
            });
        }
        c.prims(lanes as u32);
    }
    None
}

/// Test the `count` triangles of `leaf` (four at once with SIMD leaves), keeping the closest
/// hit in `best`.
#[inline(always)]
fn closest_hit_leaf<B: BoxTest<N>, T: TriTest, const N: usize>(
    pre: &T::Pre,
    ray: &Ray,
    leaf: &[LeafBlock],
    count: usize,
    best: &mut Best,
) {
    for (j, b) in leaf.iter().enumerate() {
        let lanes = (count - 4 * j).min(4);
        if B::SIMD_LEAVES {
            let l = T::intersect4(pre, ray, &b.tris, best.t);
            let mut cand = (l.hit | l.redo) & ((1 << lanes) - 1);
            while cand != 0 {
                let i = cand.trailing_zeros() as usize;
                cand &= cand - 1;
                let h = if l.redo & (1 << i) != 0 {
                    T::intersect(pre, ray, &b.tris.lane(i), best.t)
                } else if T::still_hits(&l, i, best.t) {
                    Some((l.t[i], l.u[i], l.v[i]))
                } else {
                    None
                };
                if let Some((t, u, v)) = h {
                    best.hit(t, b.prim[i], u, v);
                }
            }
        } else {
            for i in 0..lanes {
                let tri = b.tris.lane(i);
                if let Some((t, u, v)) = T::intersect(pre, ray, &tri, best.t) {
                    best.hit(t, b.prim[i], u, v);
                }
            }
        }
    }
}

/// The first of the `lanes` triangles of block `b` (in lane order) that the ray hits within
/// `[tmin, tmax)`: its lane and `(t, u, v)`, as the scalar loop finds it.
#[inline(always)]
fn first_hit<B: BoxTest<N>, T: TriTest, const N: usize>(
    pre: &T::Pre,
    ray: &Ray,
    b: &LeafBlock,
    lanes: usize,
    tmax: f32,
) -> Option<(usize, (f32, f32, f32))> {
    if B::SIMD_LEAVES {
        let l = T::intersect4(pre, ray, &b.tris, tmax);
        let mut cand = (l.hit | l.redo) & ((1 << lanes) - 1);
        while cand != 0 {
            let i = cand.trailing_zeros() as usize;
            cand &= cand - 1;
            if l.redo & (1 << i) == 0 {
                return Some((i, (l.t[i], l.u[i], l.v[i])));
            }
            if let Some(h) = T::intersect(pre, ray, &b.tris.lane(i), tmax) {
                return Some((i, h));
            }
        }
        None
    } else {
        (0..lanes).find_map(|i| T::intersect(pre, ray, &b.tris.lane(i), tmax).map(|h| (i, h)))
    }
}

tb_core::kernel_by_query!(traverse: [const N: usize] Wide<'_, N>);
