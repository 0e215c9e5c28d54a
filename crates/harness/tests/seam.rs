//! The structure seam, proved by a structure that exists only in this file: its params
//! (`params!`), its traversal table with a CPU kernel and a GPU program (WGSL below), its
//! `Family`. Registered in a `Registry` beside the built-in ones, it is listed, configured
//! (parameter sweep checked against its table), built, traced, counted and validated against
//! the oracle on the CPU and — where an adapter is found — on the GPU, by the unchanged
//! harness. Nothing outside this file names it (ARCHITECTURE.md, "Where a new structure goes").
//!
//! The structure, a *slab list*: the triangles sorted by centroid along the longest axis of
//! the scene and cut into `slabs` runs of equal size, each with its bounding box; a ray tests
//! every slab's box in order and the triangles of the slabs it enters (a one-level BVH
//! without ordering, enough to exercise boxes, leaves and a node buffer on the GPU).

use std::borrow::Cow;
use std::path::Path;
use tb_core::params::ParamKind;
use tb_core::{
    build_with, dispatch, Aabb, Counter, Family, GpuProgram, HitRecord, MemoryReport, Ray,
    Structure, Traversal, TraversalInfo, TriTest, Triangle, Vec3,
};
use tb_harness::experiment::config::{self, Overrides};
use tb_harness::experiment::runner::{self, RunOptions};
use tb_harness::registry::Registry;
use tb_results::output::Row;

tb_core::params! {
    /// Parameters of the slab list.
    #[derive(Clone, Copy, Debug, PartialEq)]
    struct SlabParams {
        /// number of slabs the sorted triangles are cut into
        slabs: u32 = 4, ParamKind::Int { min: 1, max: 64 };
    }
}

/// One slab: its box and its run of (sorted) triangles, 32 bytes as the WGSL reads it.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
struct Slab {
    min: [f32; 3],
    first: u32,
    max: [f32; 3],
    count: u32,
}

struct SlabList {
    slabs: Vec<Slab>,
    /// Triangles in slab order.
    tris: Vec<Triangle>,
    /// Scene index of each of `tris`.
    ids: Vec<u32>,
}

impl SlabList {
    fn build(tris: &[Triangle], p: &SlabParams) -> SlabList {
        let bounds = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
        let ext = bounds.max - bounds.min;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mut ids: Vec<u32> = (0..tris.len() as u32).collect();
        ids.sort_by(|&a, &b| {
            let c = |i: u32| tris[i as usize].bounds().center()[axis];
            c(a).total_cmp(&c(b))
        });
        let per = tris.len().div_ceil(p.slabs as usize).max(1);
        let sorted: Vec<Triangle> = ids.iter().map(|&i| tris[i as usize]).collect();
        let slabs = sorted
            .chunks(per)
            .enumerate()
            .map(|(k, run)| {
                let b = run.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
                Slab {
                    min: b.min.to_array(),
                    first: (k * per) as u32,
                    max: b.max.to_array(),
                    count: run.len() as u32,
                }
            })
            .collect();
        SlabList {
            slabs,
            tris: sorted,
            ids,
        }
    }

    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        self.walk_slabs::<T, C, ANY>(&self.slabs, ray, c)
    }

    fn walk_slabs<T: TriTest, C: Counter, const ANY: bool>(
        &self,
        slabs: &[Slab],
        ray: &Ray,
        c: &mut C,
    ) -> HitRecord {
        let pre = T::prepare(ray);
        let inv = ray.inv_dir();
        let mut best = HitRecord::MISS;
        let mut tmax = ray.tmax;
        for s in slabs {
            c.boxes(1);
            c.steps(1);
            let b = Aabb::new(Vec3::from_array(s.min), Vec3::from_array(s.max));
            if b.intersect(ray.origin, inv, ray.tmin, tmax).is_none() {
                continue;
            }
            c.leaf();
            for k in s.first as usize..(s.first + s.count) as usize {
                c.prims(1);
                if let Some((t, u, v)) = T::intersect(&pre, ray, &self.tris[k], tmax) {
                    tmax = t;
                    best = HitRecord {
                        t,
                        prim: self.ids[k],
                        u,
                        v,
                    };
                    if ANY {
                        return best;
                    }
                }
            }
        }
        best
    }
}

tb_core::kernel_by_query!(walk: [] SlabList);

/// A faulty walk, on request only: the last slab is never entered, so its triangles' hits
/// are lost (the wrong answers `run` must name).
struct SkipLast<'a>(&'a SlabList);

impl SkipLast<'_> {
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let n = self.0.slabs.len().saturating_sub(1);
        self.0.walk_slabs::<T, C, ANY>(&self.0.slabs[..n], ray, c)
    }
}

tb_core::kernel_by_query!(walk: [] SkipLast<'_>);

/// A faulty walk that is right while it counts: with counters compiled out (the timed
/// passes) the last slab is never entered. The counting pass then agrees with the oracle, and
/// only the check of the timed pass against the counting pass can see it.
struct SkipLastUncounted<'a>(&'a SlabList);

impl SkipLastUncounted<'_> {
    fn walk<T: TriTest, C: Counter, const ANY: bool>(&self, ray: &Ray, c: &mut C) -> HitRecord {
        let n = self.0.slabs.len() - usize::from(!C::ENABLED && self.0.slabs.len() > 1);
        self.0.walk_slabs::<T, C, ANY>(&self.0.slabs[..n], ray, c)
    }
}

tb_core::kernel_by_query!(walk: [] SkipLastUncounted<'_>);

/// The GPU program: the same walk, operation for operation, on tb-gpu's prelude.
const SLABS_WGSL: &str = r#"
struct Slab { bmin: vec3<f32>, first: u32, bmax: vec3<f32>, count: u32 }
@group(0) @binding(5) var<storage, read> slab_list: array<Slab>;
@group(0) @binding(6) var<storage, read> ids: array<u32>;

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    let p = prepare(r);
    let rb = ray_box(r);
    var best = miss();
    var tmax = r.tmax;
    for (var s = 0u; s < meta_.counts.y; s++) {
        let sl = slab_list[s];
        (*st).boxes += 1u;
        (*st).steps += 1u;
        let iv = slab(rb, sl.bmin, sl.bmax, r.tmin, tmax);
        if !(iv.x <= iv.y) {
            continue;
        }
        (*st).leaves += 1u;
        for (var k = sl.first; k < sl.first + sl.count; k++) {
            (*st).prims += 1u;
            let h = intersect(p, r, k, tmax);
            if h.w != 0.0 {
                tmax = h.x;
                best = Hit(h.x, ids[k], h.y, h.z);
                if ANY {
                    return best;
                }
            }
        }
    }
    return best;
}
"#;

fn words(v: &[u32]) -> Vec<u8> {
    v.iter().flat_map(|w| w.to_ne_bytes()).collect()
}

impl Structure for SlabList {
    const NAME: &'static str = "slab-list";
    const TRAVERSALS: &'static [Traversal<Self>] = &[
        Traversal::with_gpu(
            TraversalInfo::new("in-order", "this test", "every slab box in order"),
            dispatch,
            |s| {
                GpuProgram::new("slab-list/in-order", SLABS_WGSL, &s.tris[..])
                    .buffer(
                        "the slab array",
                        Cow::Owned(
                            s.slabs
                                .iter()
                                .flat_map(|b| {
                                    let f = |x: f32| x.to_bits();
                                    words(&[
                                        f(b.min[0]),
                                        f(b.min[1]),
                                        f(b.min[2]),
                                        b.first,
                                        f(b.max[0]),
                                        f(b.max[1]),
                                        f(b.max[2]),
                                        b.count,
                                    ])
                                })
                                .collect(),
                        ),
                    )
                    .buffer("the triangle ids", Cow::Owned(words(&s.ids)))
                    .meta([s.slabs.len() as u32, 0, 0])
                    .stack(1)
            },
        ),
        Traversal::cpu(
            TraversalInfo::new(
                "skip-last",
                "this test",
                "a faulty walk: the last slab left out",
            )
            .on_request(),
            |s, b, out| dispatch(&SkipLast(s), b, out),
        ),
        Traversal::cpu(
            TraversalInfo::new(
                "skip-last-uncounted",
                "this test",
                "a faulty walk: the last slab left out when not counting",
            )
            .on_request(),
            |s, b, out| dispatch(&SkipLastUncounted(s), b, out),
        ),
    ];

    /// Slabs, triangles and ids; `structure_bytes`: the slabs and the ids, not the triangles.
    fn own_memory(&self) -> MemoryReport {
        let structure = std::mem::size_of_val(self.slabs.as_slice())
            + std::mem::size_of_val(self.ids.as_slice());
        MemoryReport {
            bytes: (structure + std::mem::size_of_val(self.tris.as_slice())) as u64,
            structure_bytes: structure as u64,
            nodes: self.slabs.len() as u64,
            prim_refs: self.ids.len() as u64,
            node_bytes: std::mem::size_of::<Slab>() as u32,
        }
    }
}

static SLAB_LIST: Family = Family::new::<SlabList, SlabParams>(
    "test-only: triangles cut into sorted slabs, every slab box tested in order",
    |tris, set| build_with(set, |p: &SlabParams| Ok(SlabList::build(tris, p))),
);

fn registry() -> Registry {
    Registry::builtin().with(&SLAB_LIST)
}

fn config(devices: &str, slabs: &str) -> String {
    format!(
        r#"
name = "seam"
[run]
threads = [1]
repeat = 1
warmup = 0
triangle_test = ["watertight", "moller-trumbore"]
devices = [{devices}]
validate = "all"

[[scene]]
source = "builtin:cornell"
rays = ["primary", "shadow", "random"]
camera = {{ width = 24, height = 24 }}
random = {{ count = 512 }}

[[scene]]
source = "builtin:stress/axis-planes"
rays = ["stress"]

[[structure]]
name = "slab-list"
params = {{ slabs = {slabs} }}
"#
    )
}

fn run(text: &str) -> Vec<Row> {
    let summary = run_summary(text);
    assert!(summary.failures.is_empty(), "{:?}", summary.failures);
    assert!(summary.wrong_rows.is_empty(), "{:?}", summary.wrong_rows);
    summary.rows
}

fn run_summary(text: &str) -> runner::RunSummary {
    let exp = config::parse_with(
        Path::new("seam.toml"),
        text,
        &Overrides::default(),
        &registry(),
        &mut |_| {},
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let out = tempfile::tempdir().unwrap();
    let opts = RunOptions::quiet(out.path().join("run"));
    runner::run(&exp, &opts).unwrap()
}

/// A traversal that loses hits is named at the end of the run (`wrong_rows`, which
/// `run` prints and exits 3 on), each of its watertight rows with mismatches; its
/// Möller–Trumbore rows, whose misses are that test's documented findings, and the correct
/// walk's rows are not.
#[test]
fn a_walk_that_loses_hits_is_named() {
    let text = config("\"cpu\"", "4").replace(
        "params = { slabs = 4 }",
        "params = { slabs = 4 }\ntraversals = [\"in-order\", \"skip-last\"]",
    );
    let summary = run_summary(&text);
    assert!(summary.failures.is_empty(), "{:?}", summary.failures);
    let bad: Vec<&Row> = summary
        .rows
        .iter()
        .filter(|r| r.traversal == "skip-last" && r.triangle_test == "watertight")
        .filter(|r| r.mismatches.unwrap_or(0) > 0)
        .collect();
    assert!(
        !bad.is_empty(),
        "the faulty walk loses no hit: the test proves nothing"
    );
    assert_eq!(
        summary.wrong_rows.len(),
        bad.len(),
        "{:#?}",
        summary.wrong_rows
    );
    for (line, r) in summary.wrong_rows.iter().zip(&bad) {
        assert!(
            line.contains("skip-last watertight cpu")
                && line.contains(&r.ray_kind)
                && line.contains(&format!("{} of", r.mismatches.unwrap())),
            "{line}"
        );
    }
    assert!(
        summary.rows.iter().any(|r| r.traversal == "skip-last"
            && r.triangle_test == "moller-trumbore"
            && r.mismatches.unwrap_or(0) > 0),
        "the Möller–Trumbore rows lose hits too, and are not named"
    );
}

/// On the CPU the counting pass is validated against the oracle and every timed
/// pass must give the counting pass's answers, on all the rays it times (`run.timed_rays`):
/// a walk that loses hits only with counters compiled out is named, with the timed rays that
/// differ counted as mismatches, in a run of the whole batch and in one timed on a subset.
#[test]
fn a_timed_pass_that_differs_from_the_counting_pass_is_named() {
    let text = config("\"cpu\"", "4").replace(
        "params = { slabs = 4 }",
        "params = { slabs = 4 }\ntraversals = [\"in-order\", \"skip-last-uncounted\"]",
    );
    for timed in ["", "timed_rays = 100\n"] {
        let text = text.replace(
            "validate = \"all\"\n",
            &format!("validate = \"all\"\n{timed}"),
        );
        let summary = run_summary(&text);
        assert!(summary.failures.is_empty(), "{:?}", summary.failures);
        let rows = |name: &str| {
            summary
                .rows
                .iter()
                .filter(|r| r.traversal == name && r.triangle_test == "watertight")
                .filter(|r| r.timed_runs.is_some())
                .collect::<Vec<_>>()
        };
        let (good, bad) = (rows("in-order"), rows("skip-last-uncounted"));
        assert_eq!(good.len(), bad.len());
        for (g, b) in good.iter().zip(&bad) {
            // The counting passes agree: the same counters and hit rate.
            assert_eq!((g.hit_rate, g.steps_per_ray), (b.hit_rate, b.steps_per_ray));
            assert_eq!(g.mismatches, Some(0), "{g:?}");
            let n = if timed.is_empty() {
                g.rays
            } else {
                g.rays.min(100)
            };
            assert_eq!((g.timed_rays, b.timed_rays), (Some(n), Some(n)), "{g:?}");
        }
        assert!(
            bad.iter().any(|r| r.mismatches.unwrap_or(0) > 0),
            "the uncounted walk loses no timed hit: the test proves nothing"
        );
        let named = bad.iter().filter(|r| r.mismatches.unwrap_or(0) > 0).count();
        assert_eq!(summary.wrong_rows.len(), named, "{:#?}", summary.wrong_rows);
        assert!(summary
            .wrong_rows
            .iter()
            .all(|l| l.contains("skip-last-uncounted watertight cpu")));
    }
}

#[test]
fn a_structure_defined_here_is_listed_and_its_params_checked() {
    let listing = registry().listing();
    assert!(listing.contains("slab-list"), "{listing}");
    assert!(listing.contains("traversal in-order"), "{listing}");
    assert!(listing.contains("param slabs"), "{listing}");
    // Its parameter table checks configs: range and unknown keys, naming the key.
    for (slabs, want) in [
        ("0", "out of range 1..=64"),
        ("\"x\"", "expected an integer"),
    ] {
        let e = config::parse_with(
            Path::new("seam.toml"),
            &config("\"cpu\"", slabs),
            &Overrides::default(),
            &registry(),
            &mut |_| {},
        )
        .err()
        .expect("a bad value is refused")
        .to_string();
        assert!(
            e.contains("structure.params.slabs") && e.contains(want),
            "{e}"
        );
    }
    // Without the registration, the same config names an unknown structure.
    let e = config::parse(
        Path::new("seam.toml"),
        &config("\"cpu\"", "4"),
        &Overrides::default(),
        &mut |_| {},
    )
    .err()
    .expect("unregistered")
    .to_string();
    assert!(e.contains("unknown structure `slab-list`"), "{e}");
}

#[test]
fn a_structure_defined_here_runs_on_the_cpu_and_the_gpu() {
    let gpu = tb_gpu::open_or_skip().is_some();
    let devices = if gpu { "\"cpu\", \"gpu\"" } else { "\"cpu\"" };
    let rows = run(&config(devices, "[1, 4]"));
    // 2 params x 2 tests x 4 batches x devices.
    let per_device = 2 * 2 * 4;
    assert_eq!(rows.len(), per_device * if gpu { 2 } else { 1 });
    for r in &rows {
        let note = if r.device == "gpu" {
            tb_harness::experiment::device::gpu::CPU_BUILD_NOTE
        } else {
            ""
        };
        assert_eq!(r.note, note, "{r:?}");
        assert!(r.rays > 0 && r.mrays_per_s.is_some(), "{r:?}");
        assert_eq!(r.validated_rays, Some(r.rays), "{r:?}");
        if r.triangle_test == "watertight" {
            assert_eq!(r.mismatches, Some(0), "{r:?}");
        }
        // Counters as the kernel counts: one step and one box per slab.
        let slabs: f64 = if r.params == "slabs=1" { 1.0 } else { 4.0 };
        if r.ray_kind != "shadow" {
            assert_eq!(r.steps_per_ray, Some(slabs), "{r:?}");
            assert_eq!(r.boxes_per_ray, Some(slabs), "{r:?}");
        }
        assert!(r.prims_per_ray.unwrap() > 0.0, "{r:?}");
        assert_eq!(r.nodes, Some(slabs as u64), "{r:?}");
        // The structure alone (slabs and ids) and the triangle copy, as own_memory splits them.
        let (nodes, node_bytes) = (r.nodes.unwrap(), r.node_bytes.unwrap() as u64);
        let structure = nodes * node_bytes + 4 * r.prim_refs.unwrap();
        assert_eq!(r.structure_bytes, Some(structure), "{r:?}");
        let tri_bytes = r.triangles * std::mem::size_of::<Triangle>() as u64;
        assert_eq!(r.memory_bytes, Some(structure + tri_bytes), "{r:?}");
    }
    // GPU rows: the same counters and hit rates as the CPU's, row for row.
    if gpu {
        let key = |r: &Row| {
            (
                r.scene.clone(),
                r.params.clone(),
                r.triangle_test.clone(),
                r.ray_kind.clone(),
            )
        };
        for g in rows.iter().filter(|r| r.device == "gpu") {
            let c = rows
                .iter()
                .find(|r| r.device == "cpu" && key(r) == key(g))
                .expect("a CPU row per GPU row");
            if g.triangle_test == "watertight" {
                for col in tb_results::check::counter_columns() {
                    assert_eq!(c.counter(col), g.counter(col), "{col}: {g:?}");
                }
                assert_eq!(c.hit_rate, g.hit_rate, "{g:?}");
            }
            assert!(!g.adapter.is_empty());
        }
    }
}
