//! The collapse of the binary tree into wide nodes: the SAH-optimal one by dynamic programming (Ylitie, Karras and Laine 2017 §3.1) and the greedy one (Wald et al. 2008 §3), and the cost model both are judged by.

use super::*;

/// The SAH cost model of a wide tree: `C_trav` per wide interior node (one visit tests all its
/// child boxes at once), `C_isect·c(n)` per leaf of `n` triangles (`c` of [`LeafCost`]), both
/// times the node's surface area; the collapse's merged leaves hold at most `max_leaf`
/// triangles.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CostModel {
    pub c_trav: f64,
    pub c_isect: f64,
    pub leaf: LeafCost,
    pub max_leaf: u32,
}

impl CostModel {
    pub(crate) fn of(p: &BvhParams) -> Self {
        CostModel {
            c_trav: p.c_trav as f64,
            c_isect: p.c_isect as f64,
            leaf: p.leaf_cost,
            max_leaf: p.max_leaf,
        }
    }

    #[inline]
    fn leaf(&self, area: f64, n: u32) -> f64 {
        self.c_isect * area * self.leaf.units(n as usize) as f64
    }
}

/// Collapse the binary tree `bin` (root 0, see [`BvhNode`]) into wide nodes of `N` slots,
/// root first, children after their parent, by `how`.
pub(crate) fn collapse<const N: usize>(
    bin: &[BvhNode],
    how: Collapse,
    cost: &CostModel,
) -> Vec<WideNode<N>> {
    assert!((2..=8).contains(&N));
    let mut out = Vec::new();
    if bin.is_empty() {
        return out;
    }
    out.reserve(bin.len() / (N - 1) + 1);
    match how {
        Collapse::Greedy => {
            make(bin, 0, &mut out);
        }
        Collapse::Sah => {
            let dp = Dp::<N>::solve(bin, cost);
            dp.make(bin, 0, &mut out);
        }
    }
    out
}

/// The SAH-optimal collapse (Ylitie, Karras and Laine 2017, "Efficient incoherent ray
/// traversal on GPUs through compressed wide BVHs", HPG, §3.1), bottom-up over the binary tree.
///
/// `cost[n][i − 1]` is the least SAH cost (unnormalised) of binary node `n`'s subtree when it
/// fills at most `i` child slots of a wide node:
/// - `i = 1`: the cheaper of a *leaf* holding all of the subtree's triangles,
///   `C_isect·A(n)·c(P(n))` (allowed for a binary leaf, whatever its size, or for a subtree of
///   at most `max_leaf` triangles whose slots are consecutive, so that the wide leaf is one
///   range as the traversal and [`pack_leaves`] want), and an *interior* wide node,
///   `C_trav·A(n) + distribute(n, N)`;
/// - `i > 1`: the cheaper of `distribute(n, i)` and `cost[n][i − 2]` (fewer slots);
/// - `distribute(n, j) = min_{0<k<j} cost[l][k − 1] + cost[r][j − k − 1]` over the binary
///   children `l`, `r` (a binary leaf cannot distribute: it fills one slot).
///
/// Children follow their parents in the binary array, so one backward pass solves all nodes;
/// [`Dp::make`] then reads the choices back top-down. The greedy collapse's trees are among
/// the trees this minimises over (wide leaves binary leaves, each wide node's children a cut of
/// a binary subtree), so its cost is never higher under the same [`CostModel`] ([`sah`]).
pub(super) struct Dp<const N: usize> {
    pub(super) cost: Vec<[f64; N]>,
    /// `choice[n][0]`: 0 for a leaf, else the `k` of `distribute(n, N)` (interior);
    /// `choice[n][i − 1]`, `i > 1`: 0 for fewer slots, else the `k` of `distribute(n, i)`.
    choice: Vec<[u8; N]>,
    /// First triangle slot and triangle count of each subtree.
    range: Vec<(u32, u32)>,
}

impl<const N: usize> Dp<N> {
    pub(super) fn solve(bin: &[BvhNode], cm: &CostModel) -> Self {
        let n = bin.len();
        let mut cost = vec![[f64::INFINITY; N]; n];
        let mut choice = vec![[0u8; N]; n];
        // (first slot, triangle count, slots consecutive)
        let mut range = vec![(0u32, 0u32); n];
        let mut contiguous = vec![true; n];
        for i in (0..n).rev() {
            let b = &bin[i];
            let area = b.bounds().area() as f64;
            if b.is_leaf() {
                range[i] = (b.index, b.count);
                cost[i] = [cm.leaf(area, b.count); N];
                continue;
            }
            let (l, r) = (b.index as usize, b.index as usize + 1);
            let ((fl, nl), (fr, nr)) = (range[l], range[r]);
            range[i] = (fl.min(fr), nl + nr);
            contiguous[i] = contiguous[l] && contiguous[r] && (fl + nl == fr || fr + nr == fl);
            let (k_int, dist_n) = Self::distribute(&cost[l], &cost[r], N);
            let interior = cm.c_trav * area + dist_n;
            let tris = nl + nr;
            let leaf_ok = contiguous[i] && tris <= cm.max_leaf;
            let leaf = if leaf_ok {
                cm.leaf(area, tris)
            } else {
                f64::INFINITY
            };
            // `leaf_ok` too: where areas overflow both costs are infinite, and a leaf that
            // is not allowed must not win the tie.
            let (c, ch) = if leaf_ok && leaf <= interior {
                (leaf, 0)
            } else {
                (interior, k_int)
            };
            cost[i][0] = c;
            choice[i][0] = ch;
            for j in 2..=N {
                let (k, d) = Self::distribute(&cost[l], &cost[r], j);
                if d < cost[i][j - 2] {
                    cost[i][j - 1] = d;
                    choice[i][j - 1] = k;
                } else {
                    cost[i][j - 1] = cost[i][j - 2];
                    choice[i][j - 1] = 0;
                }
            }
        }
        Dp {
            cost,
            choice,
            range,
        }
    }

    /// `distribute(n, j)` from the children's costs: the best `k` (slots of the left child)
    /// and the cost.
    pub(super) fn distribute(cl: &[f64; N], cr: &[f64; N], j: usize) -> (u8, f64) {
        let mut best = (1u8, f64::INFINITY);
        for k in 1..j {
            let c = cl[k - 1] + cr[j - k - 1];
            if c < best.1 {
                best = (k as u8, c);
            }
        }
        best
    }

    /// The binary nodes that fill the (at most `i`) slots of node `n`'s subtree.
    fn gather(&self, bin: &[BvhNode], n: usize, i: usize, out: &mut Vec<usize>) {
        let k = self.choice[n][i - 1] as usize;
        if i == 1 || bin[n].is_leaf() {
            out.push(n);
        } else if k == 0 {
            self.gather(bin, n, i - 1, out);
        } else {
            let l = bin[n].index as usize;
            self.gather(bin, l, k, out);
            self.gather(bin, l + 1, i - k, out);
        }
    }

    /// Make the wide node of binary node `n` (interior; the root always is, even where one
    /// leaf would be cheaper) from the choices; returns its index in `out`.
    pub(super) fn make(&self, bin: &[BvhNode], n: usize, out: &mut Vec<WideNode<N>>) -> u32 {
        let mut kids = Vec::with_capacity(N);
        if bin[n].is_leaf() {
            kids.push(n);
        } else {
            let l = bin[n].index as usize;
            let k = match self.choice[n][0] {
                0 => Self::distribute(&self.cost[l], &self.cost[l + 1], N).0,
                k => k,
            } as usize;
            self.gather(bin, l, k, &mut kids);
            self.gather(bin, l + 1, N - k, &mut kids);
        }
        let me = out.len();
        out.push(WideNode::EMPTY);
        for (slot, &k) in kids.iter().enumerate() {
            let b = &bin[k];
            let (child, count) = if b.is_leaf() {
                (b.index, b.count)
            } else if self.choice[k][0] == 0 {
                self.range[k]
            } else {
                (self.make(bin, k, out), 0)
            };
            out[me].set(slot, b, child, count);
        }
        me as u32
    }
}

/// The SAH cost of a wide tree under `cm`: `(C_trav·Σ_nodes A(node) + C_isect·Σ_leaves
/// A(leaf)·c(|leaf|)) / A(root)`, each node's box the one in its parent's slot (the root's
/// `root`); `None` for an empty tree or a root of zero area. The quantity [`Dp`] minimises.
pub(crate) fn sah<const N: usize>(
    nodes: &[WideNode<N>],
    root: &Aabb,
    cm: &CostModel,
) -> Option<f64> {
    let root_area = root.area() as f64;
    if nodes.is_empty() || root_area.is_nan() || root_area <= 0.0 {
        return None;
    }
    let mut sum = 0.0;
    let mut stack = vec![(0usize, root_area)];
    while let Some((i, area)) = stack.pop() {
        sum += cm.c_trav * area;
        let n = &nodes[i];
        for s in 0..n.children() {
            let a = n.child_bounds(s).area() as f64;
            if n.count[s] == 0 {
                stack.push((n.child[s] as usize, a));
            } else {
                sum += cm.leaf(a, n.count[s]);
            }
        }
    }
    let c = sum / root_area;
    c.is_finite().then_some(c)
}

/// Make the wide node for binary node `i` (its children, opened greedily by area); returns
/// its index in `out`.
fn make<const N: usize>(bin: &[BvhNode], i: usize, out: &mut Vec<WideNode<N>>) -> u32 {
    let root = &bin[i];
    let mut kids: Vec<usize> = if root.is_leaf() {
        vec![i]
    } else {
        vec![root.index as usize, root.index as usize + 1]
    };
    while kids.len() < N {
        let best = kids
            .iter()
            .enumerate()
            .filter(|(_, &k)| !bin[k].is_leaf())
            .max_by(|a, b| {
                let (aa, ba) = (bin[*a.1].bounds().area(), bin[*b.1].bounds().area());
                aa.total_cmp(&ba)
            })
            .map(|(j, _)| j);
        let Some(j) = best else { break };
        let k = kids[j];
        let l = bin[k].index as usize;
        kids[j] = l;
        kids.insert(j + 1, l + 1);
    }
    let me = out.len();
    out.push(WideNode::EMPTY);
    for (slot, &k) in kids.iter().enumerate() {
        let b = &bin[k];
        let (child, count) = if b.is_leaf() {
            (b.index, b.count)
        } else {
            (make(bin, k, out), 0)
        };
        out[me].set(slot, b, child, count);
    }
    me as u32
}
