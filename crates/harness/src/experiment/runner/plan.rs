//! The combinations a run measures: per scene and build, traversal x triangle test x batch x
//! device x thread count, less the rows an interrupted run already wrote (`--resume`).

use crate::experiment::batches::RayBatch;
use crate::experiment::config::{Device, Experiment, StructureSpec};
use std::collections::HashSet;
use tb_core::TriTestKind;
use tb_results::output::RowKey;
use tb_scene::rays::RayKind;

/// One row to measure.
#[derive(Clone, Copy, Debug)]
pub struct Combo {
    /// Index of the traversal in the structure's table.
    pub ti: usize,
    /// The triangle test.
    pub tri: TriTestKind,
    /// Index of the batch in the scene's batches.
    pub bi: usize,
    /// The device the row runs on.
    pub dev: Device,
    /// Worker threads (CPU), 0 on the GPU.
    pub threads: usize,
}

/// Rows of the whole experiment (for the progress bar).
pub fn total_rows(exp: &Experiment, devices: &[(Device, Vec<usize>)]) -> usize {
    let per_batch: usize = exp
        .structures
        .iter()
        .map(|s| s.param_sets.len() * s.traversals.len())
        .sum::<usize>()
        * exp.run.triangle_tests.len()
        * devices.iter().map(|(_, t)| t.len()).sum::<usize>();
    let batches: usize = exp
        .scenes
        .iter()
        .enumerate()
        .map(|(i, s)| {
            // Random and stress rays: once per table, not per view.
            let first_view = i == 0 || exp.scenes[i - 1].table != s.table;
            s.rays
                .iter()
                .map(|k| match k {
                    RayKind::Path(_) => s.bounces as usize,
                    RayKind::Random | RayKind::Stress if !first_view => 0,
                    _ => 1,
                })
                .sum::<usize>()
        })
        .sum();
    per_batch * batches
}

/// The rows of one build of a scene view: the view's label, the structure table, the
/// parameter set and the run's process (`--processes`; part of each row's identity).
#[derive(Clone, Copy)]
pub struct BuildRows<'a> {
    /// The row label of the scene view.
    pub scene: &'a str,
    /// The structure table.
    pub st: &'a StructureSpec,
    /// The parameter set, `k=v;…`.
    pub params: &'a str,
    /// The run's process, where it has several.
    pub process: Option<u32>,
}

/// The identity of a row (for `--resume`) of build `b`.
pub fn key(b: &BuildRows<'_>, c: &Combo, batch: &RayBatch) -> RowKey {
    RowKey {
        scene: b.scene.to_string(),
        structure: b.st.family.name.to_string(),
        params: b.params.to_string(),
        traversal: b.st.infos[c.ti].name.to_string(),
        device: c.dev.name().to_string(),
        threads: c.threads as u32,
        triangle_test: c.tri.name().to_string(),
        ray_kind: batch.name.clone(),
        process: b.process,
    }
}

/// The rows of build `b` still to do, in output order, and how many are already done.
pub fn todo(
    b: &BuildRows<'_>,
    tests: &[TriTestKind],
    batches: &[RayBatch],
    devices: &[(Device, Vec<usize>)],
    done: &HashSet<RowKey>,
) -> (Vec<Combo>, usize) {
    let mut out = Vec::new();
    let mut skipped = 0;
    for &ti in &b.st.traversals {
        for &tri in tests {
            for (bi, batch) in batches.iter().enumerate() {
                for (dev, threads) in devices {
                    for &threads in threads {
                        let c = Combo {
                            ti,
                            tri,
                            bi,
                            dev: *dev,
                            threads,
                        };
                        if done.contains(&key(b, &c, batch)) {
                            skipped += 1;
                        } else {
                            out.push(c);
                        }
                    }
                }
            }
        }
    }
    (out, skipped)
}
