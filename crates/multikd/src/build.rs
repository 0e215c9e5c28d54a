//! The build of a multi-kd-tree (Torres et al. 2012 §3-4): one tb-kdtree build per patch under
//! its direction-weighted measure, the trees in one node array. The trees are built in
//! parallel where the rayon pool has threads (the harness's untimed builds: all cores).

use super::*;
use rayon::prelude::*;

impl MultiKdTree {
    /// Build the trees over shared triangles; `Err` for parameters out of range or 2^30 or
    /// more triangles (or references).
    pub fn try_build(tris: Arc<[Triangle]>, p: &MultiKdParams) -> Result<MultiKdTree, AccelError> {
        tb_core::ParamRules::check_all(p, "multi-kd")?;
        let kd = p.kd;
        let patches: Vec<usize> = match (p.measure.is_isotropic(), p.trees) {
            (true, _) => vec![0],
            (false, Trees::Multi) => vec![0, 1, 2],
            (false, Trees::X) => vec![0],
            (false, Trees::Y) => vec![1],
            (false, Trees::Z) => vec![2],
        };
        // The trees are independent: built side by side on the current rayon pool (one
        // thread: one after another), the same trees in the same order on any pool.
        let built: Vec<(usize, [f64; 3], KdTree)> = patches
            .par_iter()
            .map(|&i| {
                let w = p.measure.weights(i, p.beta as f64);
                let m = WeightedArea([w[0] as f32, w[1] as f32, w[2] as f32]);
                let t = if p.measure.is_isotropic() {
                    // The SAH: the kd-tree's own measure, so the control is that very tree.
                    KdTree::try_build(tris.clone(), &kd, &tb_kdtree::SurfaceArea)
                } else {
                    KdTree::try_build(tris.clone(), &kd, &m)
                };
                t.map(|t| (i, w, t))
            })
            .collect::<Result<_, _>>()?;
        let bounds = built[0].2.bounds();
        let budget_leaves = built.iter().map(|b| b.2.budget_leaves()).sum();
        let block = match kd.layout {
            KdLayout::DepthFirst => 1,
            KdLayout::Treelet => 1usize << kd.treelet_height,
        };
        let mut nodes: Vec<KdNode> = Vec::new();
        let mut refs: Vec<u32> = Vec::new();
        let mut trees = Vec::new();
        for (patch, weights, t) in &built {
            debug_assert_eq!(t.bounds(), bounds, "one root cell for every tree");
            // Each tree on a block boundary, so the treelet layout's implicit addressing
            // (`index & mask`) stays right.
            while !nodes.len().is_multiple_of(block) {
                nodes.push(layout::EMPTY_SLOT);
            }
            let (base, rbase) = (nodes.len() as u64, refs.len() as u64);
            if base + t.nodes().len() as u64 >= 1 << 30
                || rbase + t.prim_refs().len() as u64 >= 1 << 32
            {
                return Err(AccelError::TooLarge {
                    what: "multi-kd-tree nodes",
                    count: base + t.nodes().len() as u64,
                    limit: 1 << 30,
                });
            }
            let (base, rbase) = (base as u32, rbase as u32);
            nodes.extend(t.nodes().iter().map(|n| {
                if !n.is_leaf() {
                    KdNode::interior(n.axis(), n.split(), n.link() as u32 + base)
                } else if n.count() > 0 {
                    KdNode::leaf(n.offset() as u32 + rbase, n.count())
                } else {
                    *n
                }
            }));
            refs.extend_from_slice(t.prim_refs());
            let r = Structure::report(t);
            let get = |k: &str| r.extra.iter().find(|(n, _)| n == k).map_or(0.0, |x| x.1);
            trees.push(TreeEntry {
                patch: *patch,
                weights: *weights,
                root: base,
                slots: t.nodes().len() as u32,
                nodes: get("nodes") as u64,
                refs: t.prim_refs().len() as u64,
                leaves: get("leaves") as u64,
                cost: measured_cost(t, *weights),
            });
        }
        let mut header = [trees[0].root; 3];
        if trees.len() == 3 {
            for (h, t) in header.iter_mut().zip(&trees) {
                *h = t.root;
            }
        }
        Ok(MultiKdTree {
            nodes: Arc::new(Nodes::from_slice(&nodes)),
            refs: refs.into(),
            tris,
            bounds,
            params: *p,
            pick: p.measure,
            header,
            trees,
            aux: Arc::default(),
            budget_leaves,
        })
    }

    /// Build with `p`; panics where [`MultiKdTree::try_build`] fails.
    pub fn build(tris: &[Triangle], p: &MultiKdParams) -> MultiKdTree {
        Self::try_build(tris.into(), p).unwrap_or_else(|e| panic!("multi-kd-tree: {e}"))
    }
}

/// The SAH-type cost of `t` under the measure with weights `w`:
/// `(C_trav·Σ_interior μ(n) + C_isect·Σ_leaves μ(l)·|l|) / μ(root)`.
fn measured_cost(t: &KdTree, w: [f64; 3]) -> f64 {
    // Products in f64: at 1e30 the f32 ones overflow, at 1e-30 they vanish.
    let mu = |b: &Aabb| {
        let e = (b.max - b.min).as_dvec3();
        w[0] * (e.y * e.z) + w[1] * (e.x * e.z) + w[2] * (e.x * e.y)
    };
    let (mut ia, mut la) = (0.0, 0.0);
    let v = t.view();
    v.walk(v.root(), |i, cell, _| {
        let n = t.nodes()[i];
        if n.is_leaf() {
            la += mu(cell) * n.count() as f64;
        } else {
            ia += mu(cell);
        }
    });
    let p = &t.params().sah;
    (p.c_trav as f64 * ia + p.c_isect as f64 * la) / mu(&t.bounds())
}
