//! The build of sparse boxes (Havran and Bittner 2007 §4): a tb-kdtree build, then its
//! augmented nodes.

use super::*;

impl SparseBoxes {
    /// Build over shared triangles; `Err` for parameters out of range or too many triangles.
    pub fn try_build(tris: Arc<[Triangle]>, p: &SparseParams) -> Result<SparseBoxes, AccelError> {
        tb_core::ParamRules::check_all(p, "sparse-boxes")?;
        let kd = KdTree::try_build(tris, &p.kd(), &SurfaceArea)?;
        Ok(Self::augment(kd, p))
    }

    /// Sparse boxes over `kd`, a kd-tree built with `p.kd()` (the family's second stage,
    /// [`tb_core::Stage`]: the same structure as [`SparseBoxes::try_build`] when `kd` is that
    /// build's tree). Panics where `kd` is not laid out depth-first.
    pub fn over(kd: KdTree, p: &SparseParams) -> SparseBoxes {
        Self::augment(kd, p)
    }

    /// Build over a copy of `tris`; panics on bad parameters.
    pub fn build(tris: &[Triangle], p: &SparseParams) -> SparseBoxes {
        Self::try_build(tris.into(), p).unwrap_or_else(|e| panic!("sparse-boxes: {e}"))
    }

    /// Augment a depth-first kd-tree (§4): records for the root and every interior node at a
    /// depth that is a multiple of `d_min + 1`, in node order, each linked to the nearest
    /// augmented ancestor.
    fn augment(kd: KdTree, p: &SparseParams) -> SparseBoxes {
        assert_eq!(kd.params().layout, KdLayout::DepthFirst);
        let period = p.period();
        let v = kd.view();
        let mut aug: Vec<AugNode> = Vec::new();
        let mut depth = Vec::new();
        // The most recent record per augmented level (preorder: the ancestor's).
        let mut level = vec![0u32; STACK_SIZE + 2];
        v.walk(v.root(), |i, cell, d| {
            let n = v.nodes()[i];
            if i != 0 && (n.is_leaf() || d % period != 0) {
                return;
            }
            let k = (d / period) as usize;
            let parent = if k == 0 { 0 } else { level[k - 1] };
            level[k] = aug.len() as u32;
            aug.push(AugNode {
                min: cell.min.to_array(),
                parent,
                max: cell.max.to_array(),
                node: i as u32,
            });
            depth.push(d as u8);
        });
        SparseBoxes {
            rank: NodeRank::new(kd.nodes().len(), aug.iter().map(|a| a.node)).into(),
            kd,
            params: *p,
            aug: aug.into(),
            depth: depth.into(),
        }
    }
}
