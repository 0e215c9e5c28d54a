//! Leaves of a wide tree as blocks of four triangles ([`LeafBlock`]), and back (the GPU layout).

use super::*;

/// Copy each leaf's triangles of the collapsed tree into [`LeafBlock`]s and make the leaf
/// slots name their first block (in node order, so siblings' blocks are adjacent). Returns
/// the blocks and, per block, the triangle slot of its lane 0.
pub(crate) fn pack_leaves<const N: usize>(
    nodes: &mut [WideNode<N>],
    tris: &[Triangle],
    prim_ids: &[u32],
) -> (Vec<LeafBlock>, Vec<u32>) {
    let mut blocks = Vec::new();
    let mut first = Vec::new();
    for n in nodes.iter_mut() {
        for s in 0..n.children() {
            if n.count[s] == 0 {
                continue;
            }
            let start = n.child[s] as usize;
            let end = start + n.count[s] as usize;
            n.child[s] = blocks.len() as u32;
            for k in (start..end).step_by(4) {
                let e = (k + 4).min(end);
                let mut prim = [u32::MAX; 4];
                prim[..e - k].copy_from_slice(&prim_ids[k..e]);
                blocks.push(LeafBlock {
                    tris: Tri4::new(&tris[k..e]),
                    prim,
                });
                first.push(k as u32);
            }
        }
    }
    (blocks, first)
}

/// The nodes with each leaf naming its first triangle (the GPU program's layout) instead of
/// its first block.
pub(crate) fn unpack_leaves<const N: usize>(
    nodes: &[WideNode<N>],
    block_first: &[u32],
) -> Vec<WideNode<N>> {
    let mut out = nodes.to_vec();
    for n in &mut out {
        for s in 0..n.children() {
            if n.count[s] != 0 {
                n.child[s] = block_first[n.child[s] as usize];
            }
        }
    }
    out
}
