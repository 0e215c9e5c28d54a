//! `structure_bytes`: each grid's structure alone, as Pérard-Gayot et al.'s
//! Tables 2 and 5 and Figure 8 count it, is the sum of its own arrays as the build report
//! lists them; `bytes` adds exactly the plane-coordinate tables and the triangle array. The
//! figures are computed apart (the build's report, the memory report), so a drift in either
//! fails here.

use std::path::Path;
use std::sync::Arc;
use tb_core::{Accel, Triangle};
use tb_grid::{
    Initial, IrregularGrid, IrregularParams, TwoLevelGrid, TwoLevelParams, UniformGrid,
    UniformParams,
};

fn scene() -> Arc<[Triangle]> {
    tb_scene::load("builtin:teapot?tess=4", Path::new("."))
        .unwrap()
        .triangles
        .into()
}

fn figure(a: &dyn Accel, name: &str) -> u64 {
    let r = a.build_report();
    let v = r.extra.iter().find(|e| e.0 == name);
    v.unwrap_or_else(|| panic!("no {name} in {:?}", r.extra)).1 as u64
}

fn tri_bytes(tris: &[Triangle]) -> u64 {
    std::mem::size_of_val(tris) as u64
}

/// Checks both figures of `a` against its parts: `own` (the structure's arrays) and
/// `copies` (planes; the triangles are added here), for every traversal.
fn check(a: &dyn Accel, own: &[&str], copies: &[&str], tris: &[Triangle]) {
    let structure: u64 = own.iter().map(|k| figure(a, k)).sum();
    let geometry: u64 = copies.iter().map(|k| figure(a, k)).sum::<u64>() + tri_bytes(tris);
    let m = a.memory();
    assert!(m.structure_bytes > 0);
    assert_eq!(m.structure_bytes, structure, "{}: {own:?}", a.name());
    assert_eq!(m.bytes - m.structure_bytes, geometry, "{}", a.name());
    assert_eq!(4 * m.prim_refs, figure(a, "refs_bytes"), "{}", a.name());
    for t in 0..a.traversals().len() {
        assert_eq!(a.memory_for(t), m, "{}", a.name());
    }
}

#[test]
fn uniform_grid_structure_is_cells_refs_and_macro_regions() {
    let tris = scene();
    for macro_regions in [false, true] {
        let p = UniformParams {
            macro_regions,
            ..UniformParams::default()
        };
        let g = UniformGrid::build(&tris, &p).unwrap();
        assert_eq!(figure(&g, "macro_bytes") > 0, macro_regions);
        check(
            &g,
            &["cells_bytes", "refs_bytes", "macro_bytes"],
            &["planes_bytes"],
            &tris,
        );
    }
}

#[test]
fn two_level_grid_structure_is_tops_cells_and_refs() {
    let tris = scene();
    let g = TwoLevelGrid::build(&tris, &TwoLevelParams::default()).unwrap();
    check(&g, &["top_bytes", "cells_bytes", "refs_bytes"], &[], &tris);
}

#[test]
fn irregular_grid_structure_is_voxel_map_cells_and_refs() {
    let tris = scene();
    for (initial, merge) in [
        (Initial::TwoLevel, true),
        (Initial::Uniform, true),
        (Initial::TwoLevel, false),
    ] {
        let params = IrregularParams {
            initial,
            merge,
            ..IrregularParams::default()
        };
        let p = format!("{initial:?} merge={merge}");
        let g = IrregularGrid::build(&tris, &params).unwrap();
        let m = g.memory();
        assert_eq!(32 * m.nodes, figure(&g, "cells_bytes"), "{p}");
        // Table 2's figure, under the key the SBVH's Aila–Laine layout shares.
        assert_eq!(figure(&g, "paper_bytes"), m.structure_bytes, "{p}");
        check(
            &g,
            &["voxel_map_bytes", "cells_bytes", "refs_bytes"],
            &["planes_bytes"],
            &tris,
        );
    }
}
