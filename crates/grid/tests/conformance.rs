//! Every grid kind and phase combination against brute force: the shared conformance suite
//! (one oracle pass for all builds), and rays along cell faces, edges and corners of every
//! stress scene's grids.

use std::sync::Arc;
use tb_core::{
    compare, Accel, AccelError, Answers, Batch, BruteForce, BuildReport, GpuProgram, HitRecord,
    MemoryReport, Query, Ray, TraversalInfo, TraversalStats, TriTestKind, Triangle, Vec3,
};
use tb_grid::{
    Densities, Initial, IrregularGrid, IrregularParams, Lattice, Precision, TwoLevelGrid,
    TwoLevelParams, UniformGrid, UniformParams, Walk,
};

/// Every configuration under test, by label.
fn configs() -> Vec<(String, Config)> {
    let mut out = vec![
        (
            "uniform".to_string(),
            Config::Uniform(UniformParams::default()),
        ),
        (
            "uniform+macro".to_string(),
            Config::Uniform(UniformParams {
                macro_regions: true,
                ..Default::default()
            }),
        ),
    ];
    out.push((
        "two-level".to_string(),
        Config::TwoLevel(TwoLevelParams::default()),
    ));
    let dense = TwoLevelParams {
        densities: Densities {
            lambda_1: 1.0,
            lambda_2: 8.0,
            ..Default::default()
        },
        ..Default::default()
    };
    out.push(("two-level-dense".to_string(), Config::TwoLevel(dense)));
    for initial in [Initial::TwoLevel, Initial::Uniform] {
        for (merge, expansion) in [(false, 0), (true, 0), (false, 2), (true, 3)] {
            let p = IrregularParams {
                initial,
                merge,
                expansion,
                densities: Densities {
                    lambda_1: if initial == Initial::Uniform {
                        5.0
                    } else {
                        0.12
                    },
                    ..Default::default()
                },
                ..Default::default()
            };
            out.push((
                format!("irregular-{}-m{}-e{expansion}", initial.name(), merge as u8),
                Config::Irregular(p),
            ));
        }
    }
    // Dense second level and a tiny α: deep octrees, many merge passes.
    let p = IrregularParams {
        densities: Densities {
            lambda_1: 0.5,
            lambda_2: 16.0,
            ..Default::default()
        },
        alpha: 1.0,
        ..Default::default()
    };
    out.push(("irregular-dense".to_string(), Config::Irregular(p)));
    // The f64 walks (kept for comparison; f32 is the default), one of each kind.
    let f64_walk = Walk {
        precision: Precision::F64,
    };
    let f64s: Vec<_> = out
        .iter()
        .filter(|(l, _)| {
            [
                "uniform+macro",
                "two-level-dense",
                "irregular-two-level-m1-e3",
            ]
            .contains(&l.as_str())
        })
        .map(|(l, c)| {
            let c = match *c {
                Config::Uniform(p) => Config::Uniform(UniformParams {
                    walk: f64_walk,
                    ..p
                }),
                Config::TwoLevel(p) => Config::TwoLevel(TwoLevelParams {
                    walk: f64_walk,
                    ..p
                }),
                Config::Irregular(p) => Config::Irregular(IrregularParams {
                    walk: f64_walk,
                    ..p
                }),
                Config::Hagrid(p) => Config::Hagrid(IrregularParams {
                    walk: f64_walk,
                    ..p
                }),
            };
            (format!("{l}-f64"), c)
        })
        .collect();
    assert_eq!(f64s.len(), 3);
    out.extend(f64s);
    // The authors' step (traversal `walk-hagrid`) on the initial grid, after merge and
    // expansion from either initial subdivision, on deep octrees and in f64.
    let hagrid: Vec<_> = out
        .iter()
        .filter_map(|(l, c)| match *c {
            Config::Irregular(p)
                if [
                    "irregular-two-level-m0-e0",
                    "irregular-two-level-m1-e3",
                    "irregular-uniform-m1-e3",
                    "irregular-dense",
                    "irregular-two-level-m1-e3-f64",
                ]
                .contains(&l.as_str()) =>
            {
                Some((format!("{l}-hagrid"), Config::Hagrid(p)))
            }
            _ => None,
        })
        .collect();
    assert_eq!(hagrid.len(), 5);
    out.extend(hagrid);
    out
}

#[derive(Clone, Copy)]
enum Config {
    Uniform(UniformParams),
    TwoLevel(TwoLevelParams),
    Irregular(IrregularParams),
    /// The irregular grid traced by `walk-hagrid`.
    Hagrid(IrregularParams),
}

enum Built {
    Uniform(UniformGrid),
    TwoLevel(TwoLevelGrid),
    Irregular(IrregularGrid),
    Hagrid(IrregularGrid),
}

impl Built {
    fn new(c: Config, tris: &[Triangle]) -> Built {
        let tris: Arc<[Triangle]> = Arc::from(tris);
        let b = match c {
            Config::Uniform(p) => Built::Uniform(UniformGrid::build(&tris, &p).unwrap()),
            Config::TwoLevel(p) => Built::TwoLevel(TwoLevelGrid::build(&tris, &p).unwrap()),
            Config::Irregular(p) => Built::Irregular(IrregularGrid::build(&tris, &p).unwrap()),
            Config::Hagrid(p) => Built::Hagrid(IrregularGrid::build(&tris, &p).unwrap()),
        };
        if let Err(e) = b.accel().validate() {
            panic!("validate: {e}");
        }
        b
    }
    fn accel(&self) -> &dyn Accel {
        match self {
            Built::Uniform(g) => g,
            Built::TwoLevel(g) => g,
            Built::Irregular(g) | Built::Hagrid(g) => g,
        }
    }
    /// The traversal under test: the kind's first, or `walk-hagrid`.
    fn traversal(&self) -> usize {
        match self {
            Built::Hagrid(g) => g
                .traversals()
                .iter()
                .position(|t| t.name == "walk-hagrid")
                .expect("the irregular grid has walk-hagrid"),
            _ => 0,
        }
    }
    fn trace(&self, batch: Batch<'_>, out: Answers<'_>) {
        self.accel().trace(self.traversal(), batch, out)
    }
    fn lattice(&self) -> &Lattice {
        match self {
            Built::Uniform(g) => g.lattice(),
            Built::TwoLevel(g) => g.lattice(),
            Built::Irregular(g) | Built::Hagrid(g) => g.base_lattice(),
        }
    }
}

/// All configurations' builds of one scene as one structure whose traversals are the
/// configurations (a test wrapper, so the suite computes the oracle once for all of them).
struct All(Vec<Built>, Vec<&'static TraversalInfo>);

impl Accel for All {
    fn name(&self) -> &'static str {
        "grids"
    }
    fn traversals(&self) -> Vec<&'static TraversalInfo> {
        self.1.clone()
    }
    fn memory(&self) -> MemoryReport {
        MemoryReport::default()
    }
    fn memory_for(&self, _: usize) -> MemoryReport {
        MemoryReport::default()
    }
    fn build_report(&self) -> BuildReport {
        BuildReport::default()
    }
    fn validate(&self) -> Result<(), AccelError> {
        self.0.iter().try_for_each(|b| b.accel().validate())
    }
    fn prepare(&self, _: usize) {}
    fn trace(&self, t: usize, batch: Batch<'_>, out: Answers<'_>) {
        self.0[t].trace(batch, out)
    }
    fn has_gpu_program(&self, _: usize) -> bool {
        false
    }
    fn gpu_program(&self, _: usize) -> Option<GpuProgram<'_>> {
        None
    }
}

#[test]
fn every_grid_and_phase_conforms() {
    let cfgs = configs();
    let infos: Vec<&'static TraversalInfo> = cfgs
        .iter()
        .map(|(l, _)| {
            &*Box::leak(Box::new(TraversalInfo::new(
                Box::leak(l.clone().into_boxed_str()),
                "",
                "",
            )))
        })
        .collect();
    tb_scene::conformance::assert_conforms(&|tris| {
        Box::new(All(
            cfgs.iter().map(|(_, c)| Built::new(*c, tris)).collect(),
            infos.clone(),
        ))
    });
}

/// Rays in cell faces, along cell edges and through cell corners of each grid (planes of its
/// lattice rounded to `f32`), at every scale of the stress scenes: every answer must match
/// brute force, and no walk may visit more cells than `res_x + res_y + res_z` (the bound
/// the monotone advance guarantees, per level for the two-level grid; there is no step cap to
/// hide a loop).
#[test]
fn rays_along_cell_faces_edges_and_corners() {
    let scenes: Vec<_> = tb_scene::conformance::suite_scenes()
        .into_iter()
        .filter(|s| s.source.starts_with("builtin:stress/"))
        .collect();
    let mut checked = 0usize;
    for scene in &scenes {
        let oracle = BruteForce::new(&scene.triangles);
        for (label, cfg) in configs()
            .into_iter()
            .filter(|(l, _)| !l.ends_with("-e2") && l != "irregular-dense")
        {
            let t = std::time::Instant::now();
            let b = Built::new(cfg, &scene.triangles);
            let lat = *b.lattice();
            let rays = lattice_rays(&lat);
            let want =
                tb_core::par::trace(&oracle, 0, Query::Closest, TriTestKind::Watertight, &rays);
            let mut got = vec![HitRecord::MISS; rays.len()];
            let mut st = vec![TraversalStats::default(); rays.len()];
            let batch = Batch::new(Query::Closest, TriTestKind::Watertight, &rays);
            b.trace(batch, Answers::new(&mut got, Some(&mut st)));
            let top = lat.res.iter().sum::<u32>();
            // A two-level walk also crosses each visited top cell's grid (at most 3 · 255 cells).
            let bound = if matches!(b, Built::TwoLevel(_)) {
                top * (1 + 3 * 255)
            } else {
                top
            };
            for (i, r) in rays.iter().enumerate() {
                if let Some(k) = compare(Query::Closest, r, &want[i], &got[i]) {
                    panic!(
                        "{} / {label}: ray {i} {} {k:?}: expected {:?}, got {:?}",
                        scene.source,
                        tb_scene::conformance::format_ray(r),
                        want[i],
                        got[i]
                    );
                }
                assert!(
                    st[i].cells <= bound,
                    "{} / {label}: ray {i} visited {} cells (bound {bound})",
                    scene.source,
                    st[i].cells
                );
            }
            checked += rays.len();
            eprintln!(
                "{} / {label}: {} rays, {:.0?}",
                scene.source,
                rays.len(),
                t.elapsed()
            );
        }
    }
    assert!(checked > 10_000, "only {checked} rays");
}

/// Up to 6 planes per axis (both ends and interior ones), as `f32`.
fn planes(lat: &Lattice, a: usize) -> Vec<f32> {
    let r = lat.res[a];
    let picks: Vec<u32> = if r <= 5 {
        (0..=r).collect()
    } else {
        vec![0, 1, r / 3, r / 2, r - 1, r]
    };
    picks
        .into_iter()
        .map(|i| (lat.min[a] + i as f64 * lat.size[a]) as f32)
        .collect()
}

fn lattice_rays(lat: &Lattice) -> Vec<Ray> {
    let p: [Vec<f32>; 3] = std::array::from_fn(|a| planes(lat, a));
    let lo: [f32; 3] = std::array::from_fn(|a| lat.min[a] as f32);
    let hi: [f32; 3] =
        std::array::from_fn(|a| (lat.min[a] + lat.res[a] as f64 * lat.size[a]) as f32);
    let ext: [f32; 3] = std::array::from_fn(|a| hi[a] - lo[a]);
    let mut rays = Vec::new();
    let v = |x: [f32; 3]| Vec3::from_array(x);
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for &x in &p[a] {
            // In the face plane x_a = x: entering from outside along b, with and without a
            // component along c, and with a signed-zero normal component.
            for (k, &y) in p[b].iter().enumerate() {
                for s in [1.0f32, -1.0] {
                    let mut o = [0.0; 3];
                    o[a] = x;
                    o[b] = if s > 0.0 {
                        lo[b] - 0.1 * ext[b]
                    } else {
                        hi[b] + 0.1 * ext[b]
                    };
                    o[c] = y.min(hi[c]).max(lo[c]);
                    let _ = k;
                    let mut d = [0.0; 3];
                    d[a] = if s > 0.0 { 0.0 } else { -0.0 };
                    d[b] = s;
                    d[c] = 0.37 * s * ext[c] / ext[b].max(f32::MIN_POSITIVE);
                    rays.push(Ray::new(v(o), v(d)));
                }
            }
            // Along each edge x_a = x, x_b = y: axis-parallel along c, both ways, starting
            // outside and starting exactly on the edge.
            for &y in &p[b] {
                for s in [1.0f32, -1.0] {
                    let mut o = [0.0; 3];
                    o[a] = x;
                    o[b] = y;
                    o[c] = if s > 0.0 {
                        lo[c] - 0.1 * ext[c]
                    } else {
                        hi[c] + 0.1 * ext[c]
                    };
                    let mut d = [0.0; 3];
                    d[c] = s;
                    rays.push(Ray::new(v(o), v(d)));
                    o[c] = p[c][p[c].len() / 2];
                    rays.push(Ray::new(v(o), v(d)));
                }
            }
        }
    }
    // Through corners: from every picked lattice corner along the cell diagonal (which passes
    // through a corner of every cell it crosses), in all 8 octants.
    for &x in &p[0] {
        for &y in &p[1] {
            for &z in &p[2] {
                for oct in 0..8 {
                    let d: [f32; 3] = std::array::from_fn(|a| {
                        let s = lat.size[a] as f32;
                        if oct >> a & 1 == 1 {
                            -s
                        } else {
                            s
                        }
                    });
                    rays.push(Ray::new(v([x, y, z]), v(d)));
                }
            }
        }
    }
    rays
}

/// The irregular-grid paper's scenes, small: the hairball (thin intertwined tubes), the crown
/// (a detailed object with gems), both animated teapots at a late frame (exploded: triangles
/// scattered; deformed) and a scene inside itself (Figure 8). Every grid and phase against
/// brute force.
#[test]
fn paper_scenes_small_conform() {
    let mut scenes: Vec<tb_scene::Scene> = [
        "builtin:hairball?strands=60&segments=24&sides=4",
        "builtin:crown?tess=1&gems=12&points=5&gem_tess=1",
        "builtin:explode?tess=4&frame=40",
        "builtin:deform?tess=4&frame=13",
    ]
    .iter()
    .map(|s| tb_scene::load(s, std::path::Path::new(".")).unwrap())
    .collect();
    let mut inset =
        tb_scene::load("builtin:city?blocks=3&storeys=4", std::path::Path::new(".")).unwrap();
    let centre = inset.bounds.center();
    inset.inset(0.05, Some(centre)).unwrap();
    inset.source.push_str("+inset");
    scenes.push(inset);
    for s in &mut scenes {
        if let Some(v) = &mut s.view {
            (v.camera.width, v.camera.height) = (48, 48);
        }
    }
    let cfgs = configs();
    let infos: Vec<&'static TraversalInfo> = cfgs
        .iter()
        .map(|(l, _)| {
            &*Box::leak(Box::new(TraversalInfo::new(
                Box::leak(l.clone().into_boxed_str()),
                "",
                "",
            )))
        })
        .collect();
    tb_scene::conformance::assert_conforms_scenes(&scenes, &|tris| {
        Box::new(All(
            cfgs.iter().map(|(_, c)| Built::new(*c, tris)).collect(),
            infos.clone(),
        ))
    });
}
