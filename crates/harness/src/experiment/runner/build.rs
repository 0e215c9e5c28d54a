//! Building one structure x parameter set: timed and repeated, or loaded from the build cache
//! ([`crate::experiment::cache`]), checked with [`tb_core::Accel::validate`], with the
//! build's columns for its rows.

use crate::experiment::cache::{self, BuildCache, BuildFigures, Hit, Lookup};
use crate::experiment::heap::{self, HeapUse};
use crate::experiment::timing::median;
use std::sync::Arc;
use std::time::Instant;
use tb_core::{Accel, AccelError, Family, MemoryReport, ParamSet, Triangle};
use tb_results::output::Row;

/// One build as the passes after it see it (heat maps, convergence renders): the scene table
/// and view, the structure with its parameter set and build time, and the traversals and
/// triangle tests the config runs on it.
pub struct BuildDone<'a> {
    /// The scene table and view it was built over.
    pub scene: &'a crate::experiment::config::SceneSpec,
    /// The structure.
    pub accel: &'a dyn Accel,
    /// Its parameter set, `k=v;…`.
    pub params: &'a str,
    /// Its median build time, ms.
    pub build_ms: f64,
    /// The traversals the config runs on it (indices into its table).
    pub traversals: &'a [usize],
    /// The triangle tests the config runs.
    pub tests: &'a [tb_core::TriTestKind],
}

/// A validated build and its figures.
pub struct Built {
    /// The structure, validated.
    pub accel: Box<dyn Accel>,
    /// Median build time, ms: the structure and the auxiliary arrays the config's traversals
    /// read ([`tb_core::Accel::prepare`]).
    pub build_ms: f64,
    /// Every build's ms in the order they ran (`build_ms_runs`).
    pub build_runs: Vec<f64>,
    /// Loaded from the build cache: the figures are those of the build that made the entry
    /// (the structure), plus the auxiliary arrays prepared now.
    pub cached: bool,
    /// Built fresh and timed in this process ([`BuildPlan::timed`]): `build_timed`.
    pub timed: bool,
    mem: MemoryReport,
    sah_cost: Option<f64>,
    /// `name=value;…` of the build report's extra figures.
    build_stats: String,
    /// The heap the last build held at its peak and kept (measured where the binary counts).
    heap: Option<HeapUse>,
}

/// How a structure is built: how many times, and whether through the build cache.
#[derive(Clone, Copy, Debug)]
pub struct BuildPlan<'a> {
    /// Builds (at least one; the median time is reported).
    pub repeat: usize,
    /// Every build timed fresh (`run.time_builds`, or `repeat` above 1): the cache is not
    /// read, only written.
    pub timed: bool,
    /// The build cache, where it is on and the family can be saved.
    pub cache: Option<&'a BuildCache>,
}

/// What the cache did for a run's builds.
#[derive(Clone, Debug, Default)]
pub struct CacheUse {
    /// Structures loaded from the cache.
    pub loaded: usize,
    /// Structures built and saved to it.
    pub saved: usize,
    /// First stages ([`tb_core::Stage`]: the kd-tree under sparse boxes) loaded from the
    /// cache for a structure built over them.
    pub stages_loaded: usize,
    /// Ray samples whose oracle answers were loaded from the cache, and computed there.
    pub oracle_loaded: usize,
    /// Ray samples whose oracle answers were computed (and saved to the cache).
    pub oracle_computed: usize,
    /// One line per entry refused (and rebuilt or computed again) or not saved.
    pub notes: Vec<String>,
}

/// One structure build and its auxiliary arrays: the structure, its time and heap, and the
/// arrays' time and heap.
struct Once {
    accel: Box<dyn Accel>,
    ms: f64,
    heap: Option<HeapUse>,
    prepare_ms: f64,
    prepare_heap: Option<HeapUse>,
}

fn build_once(
    family: &'static Family,
    tris: &Arc<[Triangle]>,
    params: &ParamSet,
    traversals: &[usize],
) -> Result<Once, AccelError> {
    let (built, heap) = heap::measure(|| {
        let t0 = Instant::now();
        let accel = (family.build)(tris, params)?;
        Ok::<_, AccelError>((accel, t0.elapsed().as_secs_f64() * 1e3))
    });
    let (accel, ms) = built?;
    let (prepare_ms, prepare_heap) = prepare(accel.as_ref(), traversals);
    Ok(Once {
        accel,
        ms,
        heap,
        prepare_ms,
        prepare_heap,
    })
}

/// Build the auxiliary arrays of `traversals`: their time, ms, and heap.
fn prepare(accel: &dyn Accel, traversals: &[usize]) -> (f64, Option<HeapUse>) {
    heap::measure(|| {
        let t0 = Instant::now();
        for &ti in traversals {
            accel.prepare(ti);
        }
        t0.elapsed().as_secs_f64() * 1e3
    })
}

/// The heap of a build followed by its auxiliary arrays, from the two measured apart (each
/// above what was live before it: the arrays' peak comes on top of what the build kept).
fn combine(build: Option<HeapUse>, arrays: Option<HeapUse>) -> Option<HeapUse> {
    let (b, a) = (build?, arrays?);
    Some(HeapUse {
        peak: b.peak.max(b.kept + a.peak),
        kept: b.kept + a.kept,
    })
}

/// Build `family` over `tris` with `params` as `plan` says (the median time of its builds is
/// reported), preparing the auxiliary arrays of `traversals`, then validate the last build.
/// With a cache, an entry of this build is loaded instead where the plan does not time its
/// builds (`used` counts it; an entry that cannot be used is rebuilt with a note), and a
/// fresh build is saved.
pub fn build(
    family: &'static Family,
    tris: &Arc<[Triangle]>,
    params: &ParamSet,
    traversals: &[usize],
    plan: &BuildPlan<'_>,
    used: &mut CacheUse,
) -> Result<Built, AccelError> {
    let cache = plan
        .cache
        .zip(family.codec.as_ref())
        .map(|(c, codec)| (c, codec, cache::key(family, params, tris)));
    if let (Some((c, codec, key)), false) = (&cache, plan.timed) {
        match c.load(key, codec, tris, params) {
            Lookup::Hit(hit) => match loaded(hit, traversals) {
                Ok(b) => {
                    used.loaded += 1;
                    return Ok(b);
                }
                Err(e) => used.notes.push(format!(
                    "{} [{}]: a cached build fails its check ({e}): rebuilt",
                    family.name, params
                )),
            },
            Lookup::Miss => {}
            Lookup::Refused(why) => used.notes.push(format!("{why}: rebuilt")),
        }
    }
    let staged = family.stage.filter(|_| cache.is_some() && !plan.timed);
    let (mut built, figures) = match staged {
        Some(stage) => over_stage(&stage, tris, params, traversals, plan, used)?,
        None if plan.timed => fresh(family, tris, params, traversals, plan.repeat)?,
        // No claim reads this build's time: its builder may use every core.
        None => {
            tb_core::par::as_untimed_build(|| fresh(family, tris, params, traversals, plan.repeat))?
        }
    };
    built.timed = plan.timed;
    if let Some((c, codec, key)) = &cache {
        match c.store(key, codec, built.accel.as_ref(), figures) {
            Ok(()) => used.saved += 1,
            Err(e) => used.notes.push(format!("not saved: {e}")),
        }
    }
    Ok(built)
}

/// `repeat` fresh builds; the last one validated, with the figures a cache entry keeps.
fn fresh(
    family: &'static Family,
    tris: &Arc<[Triangle]>,
    params: &ParamSet,
    traversals: &[usize],
    repeat: usize,
) -> Result<(Built, BuildFigures), AccelError> {
    let mut times = Vec::new();
    let mut structure_ms = Vec::new();
    let mut last: Option<Once> = None;
    for _ in 0..repeat.max(1) {
        drop(last.take());
        let once = build_once(family, tris, params, traversals)?;
        times.push(once.ms + once.prepare_ms);
        structure_ms.push(once.ms);
        last = Some(once);
    }
    let once = last.expect("at least one build");
    let figures = BuildFigures {
        runs_ms: structure_ms,
        heap: once.heap.map(|h| (h.peak, h.kept)),
    };
    let heap = combine(once.heap, once.prepare_heap);
    Ok((finish(once.accel, times, heap, false)?, figures))
}

/// An untimed build over its first stage ([`tb_core::Stage`]), that stage through the cache
/// (loaded, or built and saved under its own family's key). The build's time is the first
/// stage's (as measured where it was built) and the second's; it counts as cached where the
/// first stage was loaded.
fn over_stage(
    stage: &tb_core::Stage,
    tris: &Arc<[Triangle]>,
    params: &ParamSet,
    traversals: &[usize],
    plan: &BuildPlan<'_>,
    used: &mut CacheUse,
) -> Result<(Built, BuildFigures), AccelError> {
    let base_params = (stage.params)(params)?;
    let mut base_use = CacheUse::default();
    let base = build(stage.base, tris, &base_params, &[], plan, &mut base_use)?;
    used.stages_loaded += base_use.loaded;
    used.saved += base_use.saved;
    used.notes.append(&mut base_use.notes);
    let (finished, heap) = heap::measure(|| {
        let t0 = Instant::now();
        let accel = (stage.finish)(base.accel.as_ref(), params)?;
        Ok::<_, AccelError>((accel, t0.elapsed().as_secs_f64() * 1e3))
    });
    let (accel, ms) = finished?;
    let base_ms = base.build_runs.last().copied().unwrap_or(base.build_ms);
    let base_heap = base.heap;
    let cached = base.cached;
    drop(base);
    let (prepare_ms, prepare_heap) = prepare(accel.as_ref(), traversals);
    let structure_ms = base_ms + ms;
    let figures = BuildFigures {
        runs_ms: vec![structure_ms],
        heap: combine(base_heap, heap).map(|h| (h.peak, h.kept)),
    };
    let all_heap = combine(combine(base_heap, heap), prepare_heap);
    let built = finish(accel, vec![structure_ms + prepare_ms], all_heap, cached)?;
    Ok((built, figures))
}

/// A structure loaded from the cache, its auxiliary arrays prepared now.
fn loaded(hit: Hit, traversals: &[usize]) -> Result<Built, AccelError> {
    let (prepare_ms, prepare_heap) = prepare(hit.accel.as_ref(), traversals);
    let times = hit
        .figures
        .runs_ms
        .iter()
        .map(|ms| ms + prepare_ms)
        .collect();
    let heap = hit.figures.heap.map(|(peak, kept)| HeapUse { peak, kept });
    finish(hit.accel, times, combine(heap, prepare_heap), true)
}

/// Validate `accel` and gather its figures.
fn finish(
    accel: Box<dyn Accel>,
    mut times: Vec<f64>,
    heap: Option<HeapUse>,
    cached: bool,
) -> Result<Built, AccelError> {
    accel.validate()?;
    let report = accel.build_report();
    let build_stats = tb_results::pairs::join(
        report
            .extra
            .iter()
            .map(|(k, v)| (k, (v * 1000.0).round() / 1000.0)),
    );
    let build_runs = times.clone();
    Ok(Built {
        build_runs,
        build_ms: median(&mut times),
        cached,
        timed: false,
        mem: accel.memory(),
        sah_cost: report.sah_cost,
        build_stats,
        heap,
        accel,
    })
}

impl Built {
    /// Fill the build's columns of a row of traversal `ti` (its memory, whole and structure
    /// alone, counts the auxiliary arrays that traversal reads).
    pub fn fill(&self, row: &mut Row, ti: usize) {
        row.build_ms = Some(self.build_ms);
        row.build_timed = Some(self.timed);
        row.build_ms_runs = crate::experiment::timing::ms_list(&self.build_runs);
        row.build_cached = Some(self.cached);
        let mem = self.accel.memory_for(ti);
        row.memory_bytes = Some(mem.bytes);
        row.structure_bytes = Some(mem.structure_bytes);
        row.nodes = Some(self.mem.nodes);
        row.prim_refs = Some(self.mem.prim_refs);
        row.node_bytes = Some(self.mem.node_bytes);
        row.sah_cost = self.sah_cost;
        row.build_stats = self.build_stats.clone();
        row.build_heap_peak_bytes = self.heap.map(|h| h.peak);
        row.build_heap_kept_bytes = self.heap.map(|h| h.kept);
    }
}
