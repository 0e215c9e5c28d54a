//! `[dynamic]`: ray tracing animated scenes with a rebuild every frame, the experiment of
//! Pérard-Gayot et al. 2017 (§6.3, Table 4): how many ambient-occlusion samples per pixel fit
//! a frame budget (100, 50, 33 ms) at 1024x1024, build and primary rays included, for the
//! two-level grid and the irregular grid with their densities chosen automatically.
//!
//! **Automatic density choice** (§6.3, "Parameter selection"): λ_2 = `ratio` · λ_1 (1 : 8);
//! at the first listed frame, each candidate λ_1 (ascending) is built and timed, until a build
//! takes more than half of the largest budget. Per budget, among the candidates whose build
//! took at most half that budget, the one giving the most samples per pixel is chosen (the
//! paper's "highest acceleration structure quality"; ties go to the faster build); when none
//! fits, the smallest. The candidates' figures go to `dynamic-choice.csv`.
//!
//! **Per frame** (`frames`), the scene is generated at that frame (`frame=F` appended to its
//! built-in source), the structure rebuilt from scratch with the chosen densities (timed:
//! median of `run.build_repeat`), primary rays traced (closest hit, median of `run.repeat`
//! timed runs after `run.warmup`) and one AO sample per primary hit traced (any hit within the
//! scene's AO distance, timed the same way). `spp = floor((budget − build − primary) / ao)`,
//! at least 0: samples are extrapolated from one traced sample per pixel (every sample is a
//! fresh batch of the same size), and ray generation is not counted (the paper's budget holds
//! build and traversal only). One row per scene x structure x parameter set x budget x frame
//! in `dynamic.csv`. Everything runs on the largest `run.threads` (0: all cores).

pub mod config;

use crate::error::HarnessError;
use crate::experiment::config::{Experiment, SceneSpec, StructureSpec};
use crate::experiment::dynamic::config::DynamicSpec;
use crate::experiment::timing::median;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;
use tb_core::{Accel, Family, ParamSet, ParamValue, Query, TriTestKind, Triangle};
pub use tb_results::tables::{ChoiceRow, DynamicRow};

/// Samples per pixel that fit `budget` after the build and the primary rays.
pub fn samples_within(budget: f64, build_ms: f64, primary_ms: f64, ao_ms: f64) -> u32 {
    let left = budget - build_ms - primary_ms;
    if left <= 0.0 || ao_ms <= 0.0 {
        return 0;
    }
    (left / ao_ms).floor().min(u32::MAX as f64) as u32
}

/// Build, primary and AO timings of one frame with one parameter set.
struct Frame {
    build_ms: f64,
    primary_ms: f64,
    ao_ms: f64,
}

/// The experiment's runner state.
struct Ctx<'a> {
    exp: &'a Experiment,
    spec: &'a DynamicSpec,
    pool: rayon::ThreadPool,
}

/// Run the `[dynamic]` section: writes `<out>/dynamic.csv` and `<out>/dynamic-choice.csv`;
/// returns notes (densities chosen).
pub fn run(
    exp: &Experiment,
    out: &Path,
    progress: &dyn Fn(&str),
) -> Result<Vec<String>, HarnessError> {
    let Some(spec) = &exp.dynamic else {
        return Ok(Vec::new());
    };
    std::fs::create_dir_all(out).map_err(|e| HarnessError::io(out, e))?;
    let threads = exp.run.threads.iter().copied().max().unwrap_or(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| HarnessError::other(format!("cannot start {threads} threads: {e}")))?;
    let cx = Ctx { exp, spec, pool };
    let path = out.join("dynamic.csv");
    let cpath = out.join("dynamic-choice.csv");
    let mut w = csv::Writer::from_path(&path).map_err(|e| HarnessError::io(&path, e))?;
    let mut cw = csv::Writer::from_path(&cpath).map_err(|e| HarnessError::io(&cpath, e))?;
    let mut notes = Vec::new();
    // Per scene x structure x budget: frames, samples per pixel over them, frames with none
    // and the mean build + primary time that left none (the summary says what was measured).
    let mut tally: Tally = Vec::new();
    for scene in &exp.scenes {
        for st in &exp.structures {
            for base in &st.param_sets {
                let chosen = cx.choose(scene, st, base, progress, &mut cw, &cpath)?;
                for (b, (l1, why)) in spec.budget_ms.iter().zip(&chosen) {
                    notes.push(format!(
                        "dynamic: {} {} at {b} ms: lambda_1 = {l1}, lambda_2 = {} ({why})",
                        scene.label,
                        st.family.name,
                        l1 * spec.ratio
                    ));
                }
                for &frame in &spec.frames {
                    progress(&format!(
                        "{}: dynamic frame {frame}, {}",
                        scene.label, st.family.name
                    ));
                    let tris = cx.load_frame(scene, frame)?;
                    // One build per distinct choice.
                    let mut done: Vec<(f64, Frame, String)> = Vec::new();
                    for (&budget, &(l1, _)) in spec.budget_ms.iter().zip(&chosen) {
                        if !done.iter().any(|(l, _, _)| *l == l1) {
                            let params = with_densities(st.family, base, l1, l1 * spec.ratio);
                            let f = cx.frame(scene, st, &params, &tris)?;
                            done.push((l1, f, params.to_string()));
                        }
                        let (_, f, params) = done.iter().find(|(l, _, _)| *l == l1).unwrap();
                        let row = DynamicRow {
                            scene: scene.label.clone(),
                            source: frame_source(&scene.scene.source, frame),
                            structure: st.family.name.to_string(),
                            params: params.clone(),
                            threads: threads as u32,
                            width: spec.resolution.0,
                            height: spec.resolution.1,
                            budget_ms: budget,
                            frame,
                            triangles: tris.len() as u64,
                            lambda_1: l1,
                            lambda_2: l1 * spec.ratio,
                            build_ms: f.build_ms,
                            primary_ms: f.primary_ms,
                            ao_ms_per_spp: f.ao_ms,
                            spp: samples_within(budget, f.build_ms, f.primary_ms, f.ao_ms),
                        };
                        w.serialize(&row).map_err(|e| HarnessError::io(&path, e))?;
                        w.flush().map_err(|e| HarnessError::io(&path, e))?;
                        count(&mut tally, &scene.label, st.family.name, &row);
                    }
                }
            }
        }
    }
    notes.extend(tally_notes(tally));
    Ok(notes)
}

/// Per scene x structure x budget: frames, samples per pixel over them, frames with none
/// and the total build + primary time of those.
type Tally<'a> = Vec<(String, &'a str, f64, u32, u64, u32, f64)>;

/// Count `row` of `scene` and `structure` in its budget's tally.
fn count<'a>(tally: &mut Tally<'a>, scene: &str, structure: &'a str, row: &DynamicRow) {
    let key = (scene.to_owned(), structure, row.budget_ms);
    let i = match tally
        .iter()
        .position(|t| (t.0.as_str(), t.1, t.2) == (&key.0, key.1, key.2))
    {
        Some(i) => i,
        None => {
            tally.push((key.0, key.1, key.2, 0, 0, 0, 0.0));
            tally.len() - 1
        }
    };
    let t = &mut tally[i];
    t.3 += 1;
    t.4 += u64::from(row.spp);
    if row.spp == 0 {
        t.5 += 1;
        t.6 += row.build_ms + row.primary_ms;
    }
}

/// The summary notes of the tallies: mean samples per pixel, and the frames that fit none.
fn tally_notes(tally: Tally) -> Vec<String> {
    let mut out = Vec::new();
    for (scene, structure, budget, frames, spp, zero, over) in tally {
        let why = if zero > 0 {
            format!(
                "; {zero} of {frames} frames fit no sample: build + primary rays took {:.1} ms on average there",
                over / zero as f64
            )
        } else {
            String::new()
        };
        out.push(format!(
            "dynamic: {scene} {structure} within {budget} ms: {:.2} AO samples per pixel on average over {frames} frames{why}",
            spp as f64 / frames.max(1) as f64
        ));
    }
    out
}

/// `source` with `frame=F` added to its parameters.
fn frame_source(source: &str, frame: u32) -> String {
    let sep = if source.contains('?') { '&' } else { '?' };
    format!("{source}{sep}frame={frame}")
}

/// `base` with the family's two densities (λ_1, λ_2: [`tb_core::Family::densities`], checked
/// with the config) replaced.
fn with_densities(family: &Family, base: &ParamSet, l1: f64, l2: f64) -> ParamSet {
    let [n1, n2] = family
        .densities
        .expect("the config check admits only families with densities");
    let mut p = base.clone();
    for (n, v) in p.0.iter_mut() {
        if *n == n1 {
            *v = ParamValue::Float(l1);
        } else if *n == n2 {
            *v = ParamValue::Float(l2);
        }
    }
    p
}

impl Ctx<'_> {
    /// The scene's triangles at `frame`.
    fn load_frame(&self, scene: &SceneSpec, frame: u32) -> Result<Arc<[Triangle]>, HarnessError> {
        let src = frame_source(&scene.scene.source, frame);
        let s = tb_scene::load(&src, &self.exp.scenes_root)
            .map_err(|e| HarnessError::other(format!("dynamic: {}: {e}", scene.label)))?;
        Ok(s.triangles.into())
    }

    /// Per budget, the chosen λ_1 and why.
    fn choose(
        &self,
        scene: &SceneSpec,
        st: &StructureSpec,
        base: &ParamSet,
        progress: &dyn Fn(&str),
        cw: &mut csv::Writer<std::fs::File>,
        cpath: &Path,
    ) -> Result<Vec<(f64, String)>, HarnessError> {
        let frame = self.spec.frames[0];
        let tris = self.load_frame(scene, frame)?;
        let largest = self.spec.budget_ms.iter().copied().fold(0.0, f64::max);
        let mut tried: Vec<(f64, Frame)> = Vec::new();
        for &l1 in &self.spec.lambda_1 {
            progress(&format!(
                "{}: dynamic density choice {} lambda_1 = {l1}",
                scene.label, st.family.name
            ));
            let params = with_densities(st.family, base, l1, l1 * self.spec.ratio);
            let f = self.frame(scene, st, &params, &tris)?;
            let row = ChoiceRow {
                scene: scene.label.clone(),
                structure: st.family.name.to_string(),
                params: params.to_string(),
                frame,
                lambda_1: l1,
                lambda_2: l1 * self.spec.ratio,
                build_ms: f.build_ms,
                primary_ms: f.primary_ms,
                ao_ms_per_spp: f.ao_ms,
            };
            cw.serialize(&row).map_err(|e| HarnessError::io(cpath, e))?;
            cw.flush().map_err(|e| HarnessError::io(cpath, e))?;
            let over = f.build_ms > 0.5 * largest;
            tried.push((l1, f));
            if over {
                break;
            }
        }
        Ok(self
            .spec
            .budget_ms
            .iter()
            .map(|&b| {
                let best =
                    tried
                        .iter()
                        .filter(|(_, f)| f.build_ms <= 0.5 * b)
                        .max_by(|(_, x), (_, y)| {
                            let (sx, sy) = (
                                samples_within(b, x.build_ms, x.primary_ms, x.ao_ms),
                                samples_within(b, y.build_ms, y.primary_ms, y.ao_ms),
                            );
                            sx.cmp(&sy).then(y.build_ms.total_cmp(&x.build_ms))
                        });
                match best {
                    Some((l1, f)) => (
                        *l1,
                        format!(
                            "build {:.1} ms at frame {frame}, the most samples among {} candidates \
                             building within half the budget",
                            f.build_ms,
                            tried.iter().filter(|(_, f)| f.build_ms <= 0.5 * b).count()
                        ),
                    ),
                    None => (
                        tried[0].0,
                        format!(
                            "no candidate builds within half the budget (smallest: {:.1} ms); \
                             the smallest taken",
                            tried[0].1.build_ms
                        ),
                    ),
                }
            })
            .collect())
    }

    /// Build (timed), primary rays and one AO sample per pixel (timed) of one frame.
    fn frame(
        &self,
        scene: &SceneSpec,
        st: &StructureSpec,
        params: &ParamSet,
        tris: &Arc<[Triangle]>,
    ) -> Result<Frame, HarnessError> {
        let fail = |e: tb_core::AccelError| {
            HarnessError::other(format!(
                "dynamic: {} {} [{params}]: {e}",
                scene.label, st.family.name
            ))
        };
        let mut builds = Vec::new();
        let mut accel: Option<Box<dyn Accel>> = None;
        for _ in 0..self.exp.run.build_repeat.max(1) {
            drop(accel.take());
            let t0 = Instant::now();
            let a = self
                .pool
                .install(|| (st.family.build)(tris, params))
                .map_err(fail)?;
            a.prepare(0);
            builds.push(t0.elapsed().as_secs_f64() * 1e3);
            accel = Some(a);
        }
        let accel = accel.expect("at least one build");
        accel.validate().map_err(fail)?;
        let mut camera = scene
            .camera
            .expect("checked: every dynamic scene has a camera");
        (camera.width, camera.height) = self.spec.resolution;
        let primary = tb_scene::rays::primary(&camera);
        let tri = TriTestKind::Watertight;
        let time = |query: Query, rays: &[tb_core::Ray]| -> Vec<f64> {
            let plan = &self.exp.run.timing;
            for _ in 0..plan.warmup {
                self.pool
                    .install(|| tb_core::par::trace(accel.as_ref(), 0, query, tri, rays));
            }
            (0..plan.repeat.max(1))
                .map(|_| {
                    let t0 = Instant::now();
                    self.pool
                        .install(|| tb_core::par::trace(accel.as_ref(), 0, query, tri, rays));
                    t0.elapsed().as_secs_f64() * 1e3
                })
                .collect()
        };
        let mut pt = time(Query::Closest, &primary);
        let hits = self
            .pool
            .install(|| tb_core::par::trace(accel.as_ref(), 0, Query::Closest, tri, &primary));
        let ao = tb_scene::rays::ao(
            tris,
            &primary,
            &hits,
            1,
            scene.ao_distance,
            self.exp.run.seed,
        );
        let mut at = time(Query::Any, &ao);
        Ok(Frame {
            build_ms: median(&mut builds),
            primary_ms: median(&mut pt),
            ao_ms: median(&mut at),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_fit_what_is_left_of_the_budget() {
        assert_eq!(samples_within(100.0, 20.0, 10.0, 7.0), 10);
        assert_eq!(samples_within(100.0, 20.0, 10.0, 70.0), 1);
        assert_eq!(samples_within(33.3, 30.0, 10.0, 1.0), 0);
        assert_eq!(samples_within(50.0, 10.0, 10.0, 0.0), 0);
        assert_eq!(
            frame_source("builtin:explode", 3),
            "builtin:explode?frame=3"
        );
        assert_eq!(
            frame_source("builtin:explode?tess=4", 3),
            "builtin:explode?tess=4&frame=3"
        );
    }
}
