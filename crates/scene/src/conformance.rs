//! The shared oracle suite: every structure x traversal must answer every ray of every suite
//! scene as brute force does ([`mod@tb_core::compare`]).
//!
//! A structure crate's test is one line:
//! ```ignore
//! tb_scene::conformance::assert_conforms(&|tris| Box::new(MyAccel::build(tris)));
//! ```
//! It builds each suite scene once, traces every batch with every traversal the build offers,
//! and panics listing the failing rays (origin and direction as exact hex floats) when any
//! answer differs with the watertight test. Möller–Trumbore is run as well and its mismatch
//! counts are printed, not asserted (run `cargo test -- --nocapture` to see the tables).
//!
//! Batches per scene ([`batches`]): the scene's own rays (`stress`), and where it has a view,
//! `primary`, `shadow` (when it has a light), `ao` ([`AO_SAMPLES`] per hit), `path1`, `path2`;
//! then `random` ([`RANDOM_RAYS`] rays in the scene bounds). Secondary kinds are generated from
//! the oracle's hits with the triangle test under check, with the fixed seeds below.

use crate::rays::{self, RayBatch, RayKind};
use crate::scene::Scene;
use std::path::Path;
use tb_core::{
    compare, hex_f32, Accel, BruteForce, HitRecord, Mismatch, Ray, TriTestKind, Triangle,
};

/// AO samples per primary hit.
pub const AO_SAMPLES: u32 = 4;
/// Random rays per scene.
pub const RANDOM_RAYS: usize = 2000;
/// Seeds of the generated kinds (AO; path bounce `k` uses `PATH_SEED + k`; random).
pub const AO_SEED: u64 = 0xA0;
/// Seed of the path bounces: bounce `k` uses `PATH_SEED + k`.
pub const PATH_SEED: u64 = 0x9A7B;
/// Seed of the random rays.
pub const RANDOM_SEED: u64 = 0x5EED;
/// Procedural scenes' cameras are scaled down to about this many pixels in the suite.
pub const MAX_SUITE_PIXELS: u32 = 32 * 32;
/// Procedural scenes larger than this are left out of the suite (brute force would be slow).
pub const MAX_SUITE_TRIANGLES: usize = 5000;

/// The outcome of one (scene, ray kind, traversal, triangle test) case.
#[derive(Clone, Debug)]
pub struct CaseResult {
    /// Name of the scene.
    pub scene: String,
    /// Name of the ray kind ([`crate::rays::RayKind::name`]).
    pub ray_kind: String,
    /// Name of the traversal.
    pub traversal: String,
    /// The ray-triangle test used.
    pub tri: TriTestKind,
    /// Number of rays traced.
    pub rays: usize,
    /// Number of rays whose answer differs from the oracle's.
    pub mismatches: usize,
    /// The first (up to 5) mismatching rays.
    pub first: Vec<Mismatch>,
}

/// Stress scenes the suite runs again at extreme scales.
const EXTREME: &[&str] = &[
    "stress/near-surfaces?scale=1e-30",
    "stress/near-surfaces?scale=1e30",
];

/// Small procedural scenes of the suite (parameters chosen for about 1000 triangles).
const PROCEDURAL: &[&str] = &[
    "cornell",
    "sphereflake?size=1&tess=1",
    "mount?size=4",
    "tetra?size=4",
    "soup?count=1000",
    "teapot?tess=4",
    "teapot-stadium?teapot_tess=3&segments=8",
];

/// The CPU oracle suite's scenes ([`check`], [`assert_conforms`]): [`suite_scenes`] and
/// `near-surfaces` at scales 1e-30 and 1e30 (the property test at the extremes; scale 1
/// is among the stress scenes). The GPU checks use them too with the watertight test (its
/// finish where f32's products leave their range, `watertight_wide`), and
/// [`suite_scenes`] with Möller–Trumbore, which has no such finish on either device
/// (docs/results.md, "Numerical notes").
pub fn oracle_scenes() -> Vec<Scene> {
    let mut out = suite_scenes();
    for spec in EXTREME {
        let src = format!("builtin:{spec}");
        match crate::source::load(&src, Path::new(".")) {
            Ok(s) => out.push(s),
            Err(e) => panic!("stress scene {src} does not load: {e}"),
        }
    }
    out
}

/// The scenes of every check: every stress scene with default parameters, then small procedural
/// scenes (cameras scaled down to about [`MAX_SUITE_PIXELS`] pixels); those failing to load or
/// larger than [`MAX_SUITE_TRIANGLES`] are skipped, with a note on stderr.
pub fn suite_scenes() -> Vec<Scene> {
    let mut out = Vec::new();
    for info in crate::stress::LIST {
        let src = format!("builtin:{}", info.name);
        match crate::source::load(&src, Path::new(".")) {
            Ok(s) => out.push(s),
            Err(e) => panic!("stress scene {src} does not load: {e}"),
        }
    }
    for spec in PROCEDURAL {
        let src = format!("builtin:{spec}");
        match crate::source::load(&src, Path::new(".")) {
            Ok(s) if !s.triangles.is_empty() && s.triangles.len() <= MAX_SUITE_TRIANGLES => {
                out.push(shrink_camera(s))
            }
            Ok(s) => eprintln!(
                "conformance: skipping {src}: {} triangles (limit {MAX_SUITE_TRIANGLES})",
                s.triangles.len()
            ),
            Err(e) => eprintln!("conformance: skipping {src}: {e}"),
        }
    }
    out
}

/// Keep the suite fast: a view camera with more than [`MAX_SUITE_PIXELS`] pixels is scaled
/// down to about that many, keeping its aspect ratio.
fn shrink_camera(mut s: Scene) -> Scene {
    if let Some(view) = &mut s.view {
        let c = &mut view.camera;
        let pixels = c.width as f64 * c.height as f64;
        if pixels > MAX_SUITE_PIXELS as f64 {
            let f = (MAX_SUITE_PIXELS as f64 / pixels).sqrt();
            c.width = ((c.width as f64 * f).round() as u32).max(1);
            c.height = ((c.height as f64 * f).round() as u32).max(1);
        }
    }
    s
}

use tb_core::par::trace as trace_par;

/// The batches of `scene` with the oracle's answers for the triangle test `tri`.
fn batches_with_oracle(
    scene: &Scene,
    oracle: &BruteForce,
    tri: TriTestKind,
) -> Vec<(RayBatch, Vec<HitRecord>)> {
    let tris = &scene.triangles;
    let trace = |kind: RayKind, rays: &[Ray]| trace_par(oracle, 0, kind.query(), tri, rays);
    let mut out = Vec::new();
    if !scene.own_rays.is_empty() {
        let hits = trace(RayKind::Stress, &scene.own_rays);
        out.push((
            RayBatch {
                kind: RayKind::Stress,
                rays: scene.own_rays.clone(),
            },
            hits,
        ));
    }
    if let Some(view) = &scene.view {
        let prim = rays::primary(&view.camera);
        let prim_hits = trace(RayKind::Primary, &prim);
        let mut secondary = Vec::new();
        if let Some(light) = view.light {
            secondary.push((
                RayKind::Shadow,
                rays::shadow(tris, &prim, &prim_hits, light),
            ));
        }
        let ao = rays::ao(
            tris,
            &prim,
            &prim_hits,
            AO_SAMPLES,
            view.ao_distance,
            AO_SEED,
        );
        secondary.push((RayKind::Ao, ao));
        let mut paths = Vec::new();
        let (mut prev, mut prev_hits) = (prim.clone(), prim_hits.clone());
        for k in 1..=2u32 {
            let b = rays::bounce(tris, &prev, &prev_hits, PATH_SEED + k as u64);
            let h = trace(RayKind::Path(k), &b);
            paths.push((RayKind::Path(k), b.clone(), h.clone()));
            (prev, prev_hits) = (b, h);
        }
        out.push((
            RayBatch {
                kind: RayKind::Primary,
                rays: prim,
            },
            prim_hits,
        ));
        for (kind, rays) in secondary {
            let hits = trace(kind, &rays);
            out.push((RayBatch { kind, rays }, hits));
        }
        for (kind, rays, hits) in paths {
            out.push((RayBatch { kind, rays }, hits));
        }
    }
    let random = rays::random(&scene.bounds, RANDOM_RAYS, RANDOM_SEED);
    let hits = trace(RayKind::Random, &random);
    out.push((
        RayBatch {
            kind: RayKind::Random,
            rays: random,
        },
        hits,
    ));
    out
}

/// The ray batches of `scene` for the triangle test `tri`: own rays, primary, shadow, ao,
/// path1, path2 (from the oracle's hits with `tri`), random.
pub fn batches(scene: &Scene, tri: TriTestKind) -> Vec<RayBatch> {
    let oracle = BruteForce::new(&scene.triangles);
    batches_with_oracle(scene, &oracle, tri)
        .into_iter()
        .map(|(b, _)| b)
        .collect()
}

/// Scene name for tables: the source without `builtin:`.
fn scene_name(s: &Scene) -> String {
    s.source
        .strip_prefix("builtin:")
        .unwrap_or(&s.source)
        .to_string()
}

/// Run the suite for one triangle test: for each suite scene build once, validate, and for
/// each traversal and batch compare every ray with brute force. Oracle answers are computed
/// once per (scene, batch) and shared by all traversals.
pub fn check(build: &dyn Fn(&[Triangle]) -> Box<dyn Accel>, tri: TriTestKind) -> Vec<CaseResult> {
    check_scenes(&oracle_scenes(), build, tri)
}

/// [`check`] over the given scenes.
pub fn check_scenes(
    scenes: &[Scene],
    build: &dyn Fn(&[Triangle]) -> Box<dyn Accel>,
    tri: TriTestKind,
) -> Vec<CaseResult> {
    let mut out = Vec::new();
    for scene in scenes {
        let name = scene_name(scene);
        let accel = build(&scene.triangles);
        if let Err(e) = accel.validate() {
            panic!("{}: validate() failed on scene {name}: {e}", accel.name());
        }
        // The oracle's answers for every batch, computed once and shared by all traversals.
        let oracle = BruteForce::new(&scene.triangles);
        let data = batches_with_oracle(scene, &oracle, tri);
        for (ti, info) in accel.traversals().iter().enumerate() {
            for (batch, expected) in &data {
                let query = batch.kind.query();
                let got = trace_par(accel.as_ref(), ti, query, tri, &batch.rays);
                assert_eq!(got.len(), batch.rays.len());
                let mut mismatches = 0;
                let mut first = Vec::new();
                for (i, ((ray, e), g)) in batch.rays.iter().zip(expected).zip(&got).enumerate() {
                    let kind = compare(query, ray, e, g);
                    if let Some(kind) = kind {
                        mismatches += 1;
                        if first.len() < 5 {
                            first.push(Mismatch {
                                index: i,
                                ray: *ray,
                                expected: *e,
                                got: *g,
                                kind,
                            });
                        }
                    }
                }
                out.push(CaseResult {
                    scene: name.clone(),
                    ray_kind: batch.kind.name(),
                    traversal: info.name.to_string(),
                    tri,
                    rays: batch.rays.len(),
                    mismatches,
                    first,
                });
            }
        }
    }
    out
}

/// A ray as exact hex floats: `o=(x,y,z) d=(x,y,z) t=[tmin,tmax)`.
pub fn format_ray(r: &Ray) -> String {
    let v = |p: tb_core::Vec3| format!("({},{},{})", hex_f32(p.x), hex_f32(p.y), hex_f32(p.z));
    format!(
        "o={} d={} t=[{},{})",
        v(r.origin),
        v(r.dir),
        hex_f32(r.tmin),
        hex_f32(r.tmax)
    )
}

fn format_hit(h: &HitRecord) -> String {
    if h.is_hit() {
        format!("prim {} t={} ({})", h.prim, h.t, hex_f32(h.t))
    } else {
        "miss".into()
    }
}

/// The results as a table: scene, kind, traversal, test, rays, mismatches.
pub fn format_table(results: &[CaseResult]) -> String {
    let w = results
        .iter()
        .map(|r| r.scene.len())
        .max()
        .unwrap_or(0)
        .max(5);
    let mut s = format!(
        "{:<w$} {:<8} {:<16} {:<16} {:>7} {:>10}\n",
        "scene", "kind", "traversal", "test", "rays", "mismatches"
    );
    for r in results {
        s += &format!(
            "{:<w$} {:<8} {:<16} {:<16} {:>7} {:>10}\n",
            r.scene,
            r.ray_kind,
            r.traversal,
            r.tri.name(),
            r.rays,
            r.mismatches
        );
    }
    s
}

/// The failing cases with their first mismatching rays.
pub fn format_failures(results: &[CaseResult]) -> String {
    let mut s = String::new();
    for r in results.iter().filter(|r| r.mismatches > 0) {
        s += &format!(
            "{} / {} / {} / {}: {} of {} rays differ\n",
            r.scene,
            r.ray_kind,
            r.traversal,
            r.tri.name(),
            r.mismatches,
            r.rays
        );
        for m in &r.first {
            s += &format!(
                "  ray {} {:?}: {}\n    expected {}, got {}\n",
                m.index,
                m.kind,
                format_ray(&m.ray),
                format_hit(&m.expected),
                format_hit(&m.got)
            );
        }
    }
    s
}

/// Assert that the structure built by `build` answers every suite ray as brute force does with
/// the watertight test (panics listing the failing cases otherwise), then run Möller–Trumbore
/// and print its mismatch counts per scene (reported, not asserted).
pub fn assert_conforms(build: &dyn Fn(&[Triangle]) -> Box<dyn Accel>) {
    assert_conforms_scenes(&oracle_scenes(), build)
}

/// [`assert_conforms`] over the given scenes.
pub fn assert_conforms_scenes(scenes: &[Scene], build: &dyn Fn(&[Triangle]) -> Box<dyn Accel>) {
    let wt = check_scenes(scenes, build, TriTestKind::Watertight);
    println!("conformance, watertight test:\n{}", format_table(&wt));
    let failed: usize = wt.iter().filter(|r| r.mismatches > 0).count();
    if failed > 0 {
        panic!(
            "{failed} conformance case(s) differ from brute force (watertight test):\n{}",
            format_failures(&wt)
        );
    }
    let mt = check_scenes(scenes, build, TriTestKind::MollerTrumbore);
    let mut per_scene: Vec<(String, usize, usize)> = Vec::new();
    for r in &mt {
        match per_scene.iter_mut().find(|(s, _, _)| *s == r.scene) {
            Some(e) => {
                e.1 += r.rays;
                e.2 += r.mismatches;
            }
            None => per_scene.push((r.scene.clone(), r.rays, r.mismatches)),
        }
    }
    println!("conformance, moller-trumbore test (reported, not asserted):");
    let w = per_scene.iter().map(|p| p.0.len()).max().unwrap_or(0);
    for (s, rays, mism) in per_scene {
        println!("  {s:<w$} {rays:>7} rays {mism:>6} mismatches");
    }
    if mt.iter().any(|r| r.mismatches > 0) {
        println!("{}", format_failures(&mt));
    }
}

/// `n` overlapping triangles in the plane `z = 0` (a corner in the unit square, legs up to half
/// of it, from a fixed generator): nearly every split plane cuts most of them, the input on
/// which reference-splitting builders ran away (2,000 made a kd-tree of 190M references).
/// The builders' bound tests use it.
pub fn coplanar_overlaps(n: usize) -> Vec<Triangle> {
    let mut s = 12345u64;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let (x, y) = (next(), next());
            let p = |dx: f32, dy: f32| tb_core::Vec3::new(x + dx, y + dy, 0.0);
            Triangle::new(p(0.0, 0.0), p(0.5 * next(), 0.0), p(0.0, 0.5 * next()))
        })
        .collect()
}

/// `n` random rays (seed `seed`) in the bounds of `tris` grown by 0.5 on every side: across
/// the plane of [`coplanar_overlaps`] from both sides and grazing it, for the bound tests.
pub fn rays_around(tris: &[Triangle], n: usize, seed: u64) -> Vec<Ray> {
    let b = tb_core::Aabb::from_points(tris.iter().flat_map(|t| [t.v0, t.v1, t.v2]));
    let grown = tb_core::Aabb {
        min: b.min - tb_core::Vec3::splat(0.5),
        max: b.max + tb_core::Vec3::splat(0.5),
    };
    rays::random(&grown, n, seed)
}

/// How many of `rays` traversal `traversal` of `accel` answers (with `query`, watertight test)
/// differently from brute force over `tris` ([`tb_core::compare`](mod@tb_core::compare)).
pub fn differences(
    accel: &dyn Accel,
    traversal: usize,
    tris: &[Triangle],
    rays: &[Ray],
    query: tb_core::Query,
) -> usize {
    let oracle = BruteForce::new(tris);
    let got = tb_core::par::count(accel, traversal, query, TriTestKind::Watertight, rays).0;
    let want = tb_core::par::count(&oracle, 0, query, TriTestKind::Watertight, rays).0;
    rays.iter()
        .zip(got.iter().zip(&want))
        .filter(|(r, (g, w))| tb_core::compare::compare(query, r, w, g).is_some())
        .count()
}
