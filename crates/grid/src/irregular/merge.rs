//! The irregular grid's cells in the making (Pérard-Gayot et al. 2017): the work of a build
//! ([`Work`]), §4.2 SAH cell merging and §4.3 cell expansion.

use super::*;

/// The cells, references and second-level map of a build in progress.
pub(super) struct Work {
    pub(super) cells: Vec<Cell>,
    pub(super) refs: Vec<u32>,
    pub(super) map: Vec<u32>,
    pub(super) n_top: usize,
    /// `map` is one level, each base voxel's cell ([`cell_at`]; `dmax = 0` only), until
    /// [`unflatten`] gives it the top words.
    pub(super) flat: bool,
}

/// The binned references of the top level (§4.1): `refs[start[c]..start[c + 1]]` are the
/// triangles overlapping top cell `c`, sorted.
pub(super) struct Binned {
    pub(super) start: Vec<u32>,
    pub(super) refs: Vec<u32>,
}

/// SAH cost of a cell with `n` references and box `lo..hi` (§4.2, without the division by the
/// scene's area): `(C_i |T| + C_t) · SA(B)`.
pub(super) fn cost(
    base: &Lattice,
    n: usize,
    lo: [u32; 3],
    hi: [u32; 3],
    p: &IrregularParams,
) -> f64 {
    let e: [f64; 3] = std::array::from_fn(|a| (hi[a] - lo[a]) as f64 * base.size[a]);
    (p.c_i as f64 * n as f64 + p.c_t as f64) * 2.0 * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0])
}

/// A cell as the merge sees it: its box and its range of references.
type CellView = ([u32; 3], [u32; 3], std::ops::Range<usize>);

/// Steps (1)-(3) of a merge pass along `axis` (§4.2) over `n` cells, cell `i` given by
/// `cell(i)` and the cell holding a base voxel by `at(v)`: (1) every cell whose neighbour
/// across its upper face has the same extent on the other two axes, and whose merge lowers the
/// SAH cost, becomes a merge candidate; (2) along each merge chain, candidates at even
/// positions merge with their successor, those at odd positions are residue (pairwise merges
/// only); (3) the references of the kept cells, in order (merged pairs united, sorted).
/// Returns `link` (per cell: its partner when it absorbs one, `ABSORBED | c` when absorbed by
/// `c`, `NONE` otherwise) and the new references.
pub(super) fn plan_merge(
    base: &Lattice,
    n: usize,
    axis: usize,
    cell: impl Fn(usize) -> CellView + Sync,
    at: impl Fn([u32; 3]) -> u32 + Sync,
    refs: &[u32],
    p: &IrregularParams,
) -> (Vec<u32>, Vec<u32>) {
    let pass = MergePlan {
        base,
        n,
        axis,
        cell,
        at,
        refs,
    };
    let mut link = pass.candidates(p);
    pass.pair_chains(&mut link);
    let new_refs = pass.kept_refs(&link);
    (link, new_refs)
}

/// The cells a merge pass plans over ([`plan_merge`]'s arguments but the costs).
struct MergePlan<'a, C, A> {
    base: &'a Lattice,
    n: usize,
    axis: usize,
    cell: C,
    at: A,
    refs: &'a [u32],
}

impl<C, A> MergePlan<'_, C, A>
where
    C: Fn(usize) -> CellView + Sync,
    A: Fn([u32; 3]) -> u32 + Sync,
{
    /// (1) Candidates: per cell, the neighbour across its upper face where the two merge
    /// (same extent on the other axes, lower SAH cost merged), or NONE.
    fn candidates(&self, p: &IrregularParams) -> Vec<u32> {
        let (base, axis, refs) = (self.base, self.axis, self.refs);
        (0..self.n)
            .into_par_iter()
            .map(|i| {
                let (lo, hi, r) = (self.cell)(i);
                if hi[axis] >= base.res[axis] {
                    return NONE;
                }
                let mut v = lo;
                v[axis] = hi[axis];
                let j = (self.at)(v);
                let (nlo, nhi, nr) = (self.cell)(j as usize);
                let same = (0..3).all(|a| a == axis || (nlo[a] == lo[a] && nhi[a] == hi[a]));
                if !same || nlo[axis] != hi[axis] {
                    return NONE;
                }
                let (ra, rb) = (&refs[r], &refs[nr]);
                let mut mhi = hi;
                mhi[axis] = nhi[axis];
                let merged = cost(base, union_len(ra, rb), lo, mhi, p);
                let apart = cost(base, ra.len(), lo, hi, p) + cost(base, rb.len(), nlo, nhi, p);
                if apart > merged {
                    j
                } else {
                    NONE
                }
            })
            .collect()
    }

    /// (2) Chains, walked from their heads (one bit per cell): a head is a candidate that its
    /// lower neighbour does not target. Even positions merge with their successor: `link[c]`
    /// stays the partner `t`, and `link[t]` becomes `ABSORBED | c`.
    fn pair_chains(&self, link: &mut [u32]) {
        let (n, axis) = (self.n, self.axis);
        let heads: Vec<u64> = {
            let link = &*link;
            let head = |i: usize| {
                if link[i] == NONE {
                    return false;
                }
                let (lo, _, _) = (self.cell)(i);
                if lo[axis] == 0 {
                    return true;
                }
                let mut v = lo;
                v[axis] -= 1;
                link[(self.at)(v) as usize] != i as u32
            };
            (0..n.div_ceil(64))
                .into_par_iter()
                .map(|b| {
                    (0..64.min(n - 64 * b)).fold(0u64, |m, k| m | (head(64 * b + k) as u64) << k)
                })
                .collect()
        };
        for (b, &bits) in heads.iter().enumerate() {
            let mut bits = bits;
            while bits != 0 {
                let mut c = (64 * b + bits.trailing_zeros() as usize) as u32;
                bits &= bits - 1;
                loop {
                    let t = link[c as usize];
                    if t == NONE {
                        break;
                    }
                    let next = link[t as usize];
                    link[t as usize] = ABSORBED | c;
                    if next == NONE {
                        break;
                    }
                    c = next;
                }
            }
        }
    }

    /// (3) The references of the kept cells in order (merged pairs united), written block by
    /// block in parallel.
    fn kept_refs(&self, link: &[u32]) -> Vec<u32> {
        const BLOCK: usize = 1 << 14;
        let (n, refs, cell) = (self.n, self.refs, &self.cell);
        let size = |i: usize| match partner(link[i]) {
            Some(t) => union_len(&refs[cell(i).2], &refs[cell(t).2]),
            None if link[i] == NONE => cell(i).2.len(),
            None => 0,
        };
        let totals: Vec<usize> = (0..n.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| (b * BLOCK..n.min((b + 1) * BLOCK)).map(size).sum())
            .collect();
        let mut new_refs = vec![0u32; totals.iter().sum()];
        let mut slices = Vec::with_capacity(totals.len());
        let mut rest: &mut [u32] = &mut new_refs;
        for &s in &totals {
            let (a, b) = rest.split_at_mut(s);
            slices.push(a);
            rest = b;
        }
        slices.into_par_iter().enumerate().for_each(|(b, out)| {
            let mut at = 0;
            for i in b * BLOCK..n.min((b + 1) * BLOCK) {
                let own = &refs[cell(i).2];
                match partner(link[i]) {
                    Some(t) => at += union_into(own, &refs[cell(t).2], &mut out[at..]),
                    None if link[i] == NONE => {
                        out[at..at + own.len()].copy_from_slice(own);
                        at += own.len();
                    }
                    None => {}
                }
            }
        });
        new_refs
    }
}

/// The partner a merge candidate absorbs (`link` of [`plan_merge`]).
pub(super) fn partner(l: u32) -> Option<usize> {
    (l != NONE && l & ABSORBED == 0).then_some(l as usize)
}

/// Whether `link` marks a cell absorbed by another.
pub(super) fn absorbed(l: u32) -> bool {
    l != NONE && l & ABSORBED != 0
}

/// The cell holding base voxel `v`: through the two-level map, or, for a `flat` map (a grid
/// whose top cells are its voxels, `dmax = 0`, while it is built), its one level.
#[inline(always)]
pub(super) fn cell_at(map: &[u32], flat: bool, top: &Lattice, dmax: u32, v: [u32; 3]) -> u32 {
    if flat {
        map[top.index(v)]
    } else {
        lookup(map, top, dmax, v)
    }
}

/// One merge pass along `axis` (§4.2, [`plan_merge`]), in place: (3) merged cells replace
/// their pairs, the others stay, in order; (4) the voxel map's entries point to the new
/// cells. The scratch is one word per cell and per kept cell (the paper's merge is not in
/// place, §6.1; the cells here are compacted in place so that the build's peak stays near the
/// final size).
pub(super) fn merge_pass(
    base: &Lattice,
    dmax: u32,
    w: &mut Work,
    axis: usize,
    p: &IrregularParams,
) {
    let n = w.cells.len();
    let top = top_lattice(base, dmax);
    let (mut link, new_refs) = {
        let (cells, map, flat) = (&w.cells, &w.map, w.flat);
        plan_merge(
            base,
            n,
            axis,
            |i| (cells[i].lo, cells[i].hi, cells[i].range()),
            |v| cell_at(map, flat, &top, dmax, v),
            &w.refs,
            p,
        )
    };
    // Merged boxes and reference counts first (a partner may lie before its cell and be
    // overwritten by the compaction; partners are never written here), then the kept cells
    // moved down in order; `link` becomes the new index of every old cell.
    for i in 0..n {
        if let Some(t) = partner(link[i]) {
            let u = union_len(&w.refs[w.cells[i].range()], &w.refs[w.cells[t].range()]);
            let hi = w.cells[t].hi[axis];
            let c = &mut w.cells[i];
            c.hi[axis] = hi;
            c.end = c.begin + u as u32;
        }
    }
    let mut k = 0usize;
    let mut begin = 0u32;
    for i in 0..n {
        if absorbed(link[i]) {
            continue;
        }
        let len = w.cells[i].range().len() as u32;
        let mut c = w.cells[i];
        c.begin = begin;
        c.end = begin + len;
        begin += len;
        w.cells[k] = c;
        link[i] = k as u32;
        k += 1;
    }
    for i in 0..n {
        if absorbed(link[i]) {
            let c = (link[i] & !ABSORBED) as usize;
            link[i] = link[c];
        }
    }
    w.cells.truncate(k);
    w.refs = new_refs;
    let first = if w.flat { 0 } else { w.n_top };
    w.map[first..]
        .par_iter_mut()
        .for_each(|e| *e = link[*e as usize]);
}

/// The first merge pass along x of a grid whose initial cells are its voxels (`dmax = 0`: a
/// uniform initial grid, Table 5), made from the `binned` references without those cells: the
/// kept cells, their references and a flat voxel map (the pass's `link`, each voxel's new
/// cell; [`unflatten`] adds the top words at the end). The same cells, references and map as
/// the initial subdivision (`Subdivision::initial`) followed by [`merge_pass`] along x,
/// without the 32-byte cell per voxel, and the binned references freed before the kept cells are made: the build's
/// peak on Conference at λ = 5 went from 8.3x the final structure to 2.7x (the second pass's,
/// now the largest).
pub(super) fn merge_first_x(base: &Lattice, binned: Binned, p: &IrregularParams) -> Work {
    let Binned { start, refs } = binned;
    let n = base.count();
    // The kept cells' reference counts (merged pairs united), so that the binned references
    // are freed before the cells are made.
    let (mut link, new_refs, lens) = {
        let range = |i: usize| start[i] as usize..start[i + 1] as usize;
        let unit = |i: usize| {
            let lo = base.voxel_of(i);
            (lo, lo.map(|x| x + 1), range(i))
        };
        let (link, new_refs) = plan_merge(base, n, 0, unit, |v| base.index(v) as u32, &refs, p);
        let mut lens = Vec::with_capacity(link.iter().filter(|&&l| !absorbed(l)).count());
        for (i, &l) in link.iter().enumerate() {
            match partner(l) {
                Some(t) => lens.push(union_len(&refs[range(i)], &refs[range(t)]) as u32),
                None if l == NONE => lens.push(range(i).len() as u32),
                None => {}
            }
        }
        (link, new_refs, lens)
    };
    drop((start, refs));
    let mut cells = Vec::with_capacity(lens.len());
    let mut begin = 0u32;
    for i in 0..n {
        if absorbed(link[i]) {
            continue;
        }
        let lo = base.voxel_of(i);
        let mut hi = lo.map(|x| x + 1);
        if partner(link[i]).is_some() {
            hi[0] += 1;
        }
        let len = lens[cells.len()];
        cells.push(Cell {
            lo,
            begin,
            hi,
            end: begin + len,
        });
        begin += len;
        link[i] = (cells.len() - 1) as u32;
    }
    for i in 0..n {
        if absorbed(link[i]) {
            let c = (link[i] & !ABSORBED) as usize;
            link[i] = link[c];
        }
    }
    Work {
        cells,
        refs: new_refs,
        map: link,
        n_top: n,
        flat: true,
    }
}

/// The two-level voxel map of a `flat` build map (`dmax = 0`): a top word per voxel (depth 0,
/// its entry in the second level), then the flat map as the second level.
pub(super) fn unflatten(flat: Vec<u32>) -> Vec<u32> {
    let n = flat.len();
    let mut map = Vec::with_capacity(2 * n);
    map.extend((0..n).map(|t| (n + t) as u32));
    map.extend_from_slice(&flat);
    map
}

pub(super) fn top_lattice(base: &Lattice, dmax: u32) -> Lattice {
    Lattice {
        min: base.min,
        size: base.size.map(|s| s * (1u64 << dmax) as f64),
        inv_size: base.inv_size.map(|s| s / (1u64 << dmax) as f64),
        res: base.res.map(|r| r >> dmax),
        ..*base
    }
}

/// §4.3: `passes` expansion passes. In each, every cell tries to grow its box across each face
/// in turn (x, y, z; lower and upper side): it may when every cell beyond that face, over the
/// face's extent, holds a subset of its references, and it grows by the smallest distance
/// those cells reach beyond the face. Neighbours are found in the voxel map, whose cells keep
/// their merged (unexpanded) boxes, so cells grow independently (one rayon task each), and a
/// later pass reaches farther neighbours. Returns the grown boxes.
pub(super) fn expand(
    base: &Lattice,
    dmax: u32,
    w: &Work,
    passes: u32,
) -> Vec<([u32; 3], [u32; 3])> {
    let top = top_lattice(base, dmax);
    let cells = &w.cells;
    let refs = &w.refs;
    cells
        .par_iter()
        .map(|c| {
            let own = &refs[c.range()];
            let (mut lo, mut hi) = (c.lo, c.hi);
            for _ in 0..passes {
                for a in 0..3 {
                    let (b, cc) = ((a + 1) % 3, (a + 2) % 3);
                    for upper in [false, true] {
                        let x = if upper {
                            if hi[a] >= base.res[a] {
                                continue;
                            }
                            hi[a]
                        } else {
                            if lo[a] == 0 {
                                continue;
                            }
                            lo[a] - 1
                        };
                        let mut amount = u32::MAX;
                        let mut ok = true;
                        let mut vb = lo[b];
                        'face: while vb < hi[b] {
                            let mut next_b = hi[b];
                            let mut vc = lo[cc];
                            while vc < hi[cc] {
                                let mut v = [0; 3];
                                v[a] = x;
                                v[b] = vb;
                                v[cc] = vc;
                                let nb = &cells[cell_at(&w.map, w.flat, &top, dmax, v) as usize];
                                if !is_subset(&refs[nb.range()], own) {
                                    ok = false;
                                    break 'face;
                                }
                                amount = amount.min(if upper {
                                    nb.hi[a] - x
                                } else {
                                    x + 1 - nb.lo[a]
                                });
                                next_b = next_b.min(nb.hi[b]);
                                vc = nb.hi[cc];
                            }
                            vb = next_b;
                        }
                        if ok && amount != u32::MAX {
                            if upper {
                                hi[a] += amount;
                            } else {
                                lo[a] -= amount;
                            }
                        }
                    }
                }
            }
            (lo, hi)
        })
        .collect()
}
