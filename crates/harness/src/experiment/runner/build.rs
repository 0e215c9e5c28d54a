//! Building one structure x parameter set: timed and repeated, checked with
//! [`tb_core::Accel::validate`], with the build's columns for its rows.

use crate::experiment::heap::{self, HeapUse};
use crate::experiment::timing::median;
use std::sync::Arc;
use std::time::Instant;
use tb_core::{Accel, AccelError, Family, MemoryReport, ParamSet, Triangle};
use tb_results::output::Row;

/// A validated build and its figures.
pub struct Built {
    pub accel: Box<dyn Accel>,
    /// Median build time, ms: the structure and the auxiliary arrays the config's traversals
    /// read ([`tb_core::Accel::prepare`]).
    pub build_ms: f64,
    /// Every build's ms in the order they ran (`build_ms_runs`).
    pub build_runs: Vec<f64>,
    mem: MemoryReport,
    sah_cost: Option<f64>,
    /// `name=value;…` of the build report's extra figures.
    build_stats: String,
    /// The heap the last build held at its peak and kept (measured where the binary counts).
    heap: Option<HeapUse>,
}

/// Build `family` over `tris` with `params` `repeat` times (at least once; the median time is
/// reported), preparing the auxiliary arrays of `traversals`, then validate the last build.
pub fn build(
    family: &'static Family,
    tris: &Arc<[Triangle]>,
    params: &ParamSet,
    traversals: &[usize],
    repeat: usize,
) -> Result<Built, AccelError> {
    let mut times = Vec::new();
    let mut last = None;
    let mut heap_use = None;
    for _ in 0..repeat.max(1) {
        drop(last.take());
        let (built, used) = heap::measure(|| {
            let t0 = Instant::now();
            let accel = (family.build)(tris, params)?;
            for &ti in traversals {
                accel.prepare(ti);
            }
            Ok::<_, AccelError>((accel, t0.elapsed().as_secs_f64() * 1e3))
        });
        let (accel, ms) = built?;
        times.push(ms);
        heap_use = used;
        last = Some(accel);
    }
    let accel = last.expect("at least one build");
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
        mem: accel.memory(),
        sah_cost: report.sah_cost,
        build_stats,
        heap: heap_use,
        accel,
    })
}

impl Built {
    /// Fill the build's columns of a row of traversal `ti` (its memory, whole and structure
    /// alone, counts the auxiliary arrays that traversal reads).
    pub fn fill(&self, row: &mut Row, ti: usize) {
        row.build_ms = Some(self.build_ms);
        row.build_ms_runs = crate::experiment::timing::ms_list(&self.build_runs);
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
