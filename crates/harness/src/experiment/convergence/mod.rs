//! `[convergence]`: image error against run time, for ambient occlusion and path tracing.
//!
//! Per scene x structure x parameter set x traversal x triangle test x device x integrator, a
//! progressive render ([`tb_render::Progressive`]) runs `passes` passes through that structure
//! (every batch traced by it, so the structure's speed decides how fast the error falls); after
//! each pass a row of `convergence.csv` records the render time so far, the samples per pixel
//! and the error against a reference image (RMSE and relative MSE, [`tb_render::metrics`]).
//! Passes add `spp_per_pass` samples (`schedule = "linear"`), or double the total
//! (`"doubling"`, the default: `s, 2s, 4s, …`, evenly spaced on a log axis).
//!
//! The reference has `reference_spp` samples per pixel, another seed than the measured renders
//! (so their samples are independent), and is rendered once by the default BVH and cached
//! under `cache` with a content hash of scene, camera, integrator and sample count
//! ([`tb_render::cache`]).
//!
//! `frame_budget_ms = [100, 50, 33.3]` adds, per budget, a row of `convergence-budget.csv`
//! (same columns; `budget_ms` set there and empty in `convergence.csv`) with the samples per pixel a
//! frame reaches within that time, build time included, and its error: the irregular-grid
//! paper's Table 4 (AO samples per pixel at 10, 20 and 30 frames per second). Passes of one
//! sample run while the build time plus the render time so far plus the slowest pass so far
//! stays within the budget, and a pass that ends over it is not counted: the row reports the
//! last image within the budget and its time (build included), so `elapsed_ms ≤ budget_ms`.
//!
//! Renders run on the largest thread count of `run.threads`.

pub mod config;

use crate::error::HarnessError;
use crate::experiment::config::{Device, Experiment, SceneSpec};
use crate::experiment::convergence::config::{ConvergenceSpec, IntegratorKind};
use crate::experiment::progress::Progress;
use crate::experiment::runner::build::BuildDone;
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::time::Instant;
use tb_core::{Accel, TriTestKind};
use tb_render::cache::{load_or_render, reference_key, reference_path, Origin};
use tb_render::integrate::{render, Integrator, Progressive};
use tb_render::metrics::{rel_mse, rmse};
use tb_render::{AccelTracer, Tracer};

/// One row of `convergence.csv`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceRow {
    /// Row label of the scene.
    pub scene: String,
    /// The structure's registry name.
    pub structure: String,
    /// The full parameter set, `k=v;k=v`.
    pub params: String,
    /// The traversal's name.
    pub traversal: String,
    /// `watertight` or `moller-trumbore`.
    pub triangle_test: String,
    /// `cpu` or `gpu`.
    pub device: String,
    /// Threads of the render: the largest of `run.threads`.
    pub threads: u32,
    /// `ao` or `path`.
    pub integrator: String,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Passes done (for a budget row: passes that fit).
    pub pass: u32,
    /// Samples per pixel so far.
    pub spp: u32,
    /// Render time so far, ms (budget rows: build time included).
    pub elapsed_ms: f64,
    /// Build time of the structure, ms.
    pub build_ms: f64,
    /// Empty for a budget row with no sample within the budget (the build, or the build and
    /// the first sample, took longer).
    pub rmse: Option<f64>,
    /// Relative mean squared error against the reference; empty as `rmse` is.
    pub rel_mse: Option<f64>,
    /// The frame budget of a budget row; empty for the progressive rows.
    pub budget_ms: Option<f64>,
    /// Samples per pixel of the reference image.
    pub reference_spp: u32,
    /// Content hash of the reference (its file is `<cache>/<integrator>-<key>.exr`).
    pub reference_key: String,
}

impl ConvergenceRow {
    fn combo(&self) -> [String; 7] {
        [
            self.scene.clone(),
            self.structure.clone(),
            self.params.clone(),
            self.traversal.clone(),
            self.triangle_test.clone(),
            self.device.clone(),
            self.integrator.clone(),
        ]
    }
}

/// The rows of a convergence CSV of an interrupted run (none when it does not exist; a torn
/// last line is dropped, its combination redone).
fn read_rows(path: &Path) -> Result<Vec<ConvergenceRow>, HarnessError> {
    if !path.is_file() {
        return Ok(Vec::new());
    }
    let mut r = csv::Reader::from_path(path).map_err(|e| HarnessError::io(path, e))?;
    Ok(r.deserialize::<ConvergenceRow>().flatten().collect())
}

/// Create `path` anew with `rows` (header first) and return its writer.
fn rewrite(
    path: &Path,
    rows: &[ConvergenceRow],
) -> Result<csv::Writer<std::fs::File>, HarnessError> {
    let mut w = csv::Writer::from_path(path).map_err(|e| HarnessError::io(path, e))?;
    for row in rows {
        w.serialize(row).map_err(|e| HarnessError::io(path, e))?;
    }
    w.flush().map_err(|e| HarnessError::io(path, e))?;
    Ok(w)
}

/// Writes `convergence.csv` (progressive rows) and `convergence-budget.csv` (frame-budget rows)
/// and keeps the reference images of the run.
pub struct Runner {
    spec: ConvergenceSpec,
    path: PathBuf,
    writer: csv::Writer<std::fs::File>,
    /// `convergence-budget.csv`, when the spec has frame budgets.
    budget: Option<(PathBuf, csv::Writer<std::fs::File>)>,
    pool: rayon::ThreadPool,
    threads: usize,
    seed: u64,
    /// Combinations already in the file (kept on `--resume`).
    done: HashSet<[String; 7]>,
    /// References by (scene, integrator key): image and content hash.
    refs: HashMap<(String, String), (Vec<f32>, String)>,
}

/// The image one combination renders: the scene's triangles, the camera, the integrator
/// and the reference it is compared with.
#[derive(Clone, Copy)]
struct Image<'a> {
    tris: &'a [tb_core::Triangle],
    camera: tb_scene::Camera,
    integrator: Integrator,
    reference: &'a [f32],
}

impl Runner {
    /// Open `<out>/convergence.csv` (and `convergence-budget.csv` with frame budgets) when the
    /// experiment has a `[convergence]` section; with `resume`, keep their rows and skip their
    /// combinations. A combination is done when its progressive rows are in `convergence.csv`
    /// (they are written after its budget rows; budget rows of an unfinished one are dropped).
    pub fn open(exp: &Experiment, out: &Path, resume: bool) -> Result<Option<Self>, HarnessError> {
        let Some(spec) = exp.convergence.clone() else {
            return Ok(None);
        };
        std::fs::create_dir_all(out).map_err(|e| HarnessError::io(out, e))?;
        let path = out.join("convergence.csv");
        let old = if resume {
            read_rows(&path)?
        } else {
            Vec::new()
        };
        let done: HashSet<[String; 7]> = old.iter().map(ConvergenceRow::combo).collect();
        let writer = rewrite(&path, &old)?;
        let budget = if spec.frame_budget_ms.is_empty() {
            None
        } else {
            let bpath = out.join("convergence-budget.csv");
            let old = if resume {
                read_rows(&bpath)?
            } else {
                Vec::new()
            };
            let kept: Vec<ConvergenceRow> = old
                .into_iter()
                .filter(|r| done.contains(&r.combo()))
                .collect();
            let w = rewrite(&bpath, &kept)?;
            Some((bpath, w))
        };
        let threads = exp.run.threads.iter().copied().max().unwrap_or(1);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| HarnessError::other(format!("cannot start {threads} threads: {e}")))?;
        Ok(Some(Runner {
            spec,
            path,
            writer,
            budget,
            pool,
            threads,
            seed: exp.run.seed,
            done,
            refs: HashMap::new(),
        }))
    }

    /// Append a row to its file (budget rows to `convergence-budget.csv`) and flush.
    fn push(&mut self, row: &ConvergenceRow) -> Result<(), HarnessError> {
        let (path, w) = match (&mut self.budget, row.budget_ms) {
            (Some((p, w)), Some(_)) => (&*p, w),
            _ => (&self.path, &mut self.writer),
        };
        w.serialize(row).map_err(|e| HarnessError::io(path, e))?;
        w.flush().map_err(|e| HarnessError::io(path, e))
    }

    /// The integrator of `kind` for `scene`.
    fn integrator(&self, kind: IntegratorKind, scene: &SceneSpec) -> Integrator {
        match kind {
            IntegratorKind::Ao => Integrator::Ao {
                distance: scene.ao_distance,
            },
            IntegratorKind::Path => Integrator::Path {
                bounces: scene.bounces,
                albedo: self.spec.albedo,
            },
        }
    }

    /// The convergence renders of one built structure (`done`): every traversal x triangle
    /// test x device x integrator. Returns notes (references rendered or reused, renders cut
    /// short).
    pub fn build_done(
        &mut self,
        done: &BuildDone<'_>,
        devices: &[Device],
        gpu: Option<&crate::experiment::device::gpu::GpuDevice>,
        progress: &Progress,
    ) -> Result<Vec<String>, HarnessError> {
        let BuildDone {
            scene,
            accel,
            params,
            build_ms,
            traversals,
            tests,
        } = *done;
        let mut notes = Vec::new();
        let mut camera = scene.camera.expect("checked: every scene has a camera");
        if let Some((w, h)) = self.spec.resolution {
            camera.width = w;
            camera.height = h;
        }
        let tris = &scene.scene.triangles;
        for kind in self.spec.integrators.clone() {
            let integrator = self.integrator(kind, scene);
            let (reference, rkey) =
                self.reference(scene, camera, integrator, progress, &mut notes)?;
            for &ti in traversals {
                let tname = accel.traversals()[ti].name;
                for &tri in tests {
                    for &dev in devices {
                        let base = ConvergenceRow {
                            scene: scene.label.clone(),
                            structure: accel.name().to_string(),
                            params: params.to_string(),
                            traversal: tname.to_string(),
                            triangle_test: tri.name().to_string(),
                            device: dev.name().to_string(),
                            threads: self.threads as u32,
                            integrator: integrator.name().to_string(),
                            width: camera.width,
                            height: camera.height,
                            build_ms,
                            reference_spp: self.spec.reference_spp,
                            reference_key: rkey.clone(),
                            ..Default::default()
                        };
                        if self.done.contains(&base.combo()) {
                            continue;
                        }
                        progress.step(&format!(
                            "{}: convergence {} {} {} {}",
                            scene.label,
                            integrator.name(),
                            accel.name(),
                            tname,
                            tri.name()
                        ));
                        let tracer = match tracer_on(dev, accel, ti, tri, gpu) {
                            Ok(t) => t,
                            Err(e) => {
                                notes.push(format!(
                                    "{}: convergence of {} {} on the gpu skipped: {e}",
                                    scene.label,
                                    accel.name(),
                                    tname
                                ));
                                continue;
                            }
                        };
                        let image = Image {
                            tris,
                            camera,
                            integrator,
                            reference: &reference,
                        };
                        let rows = self.measure(&image, tracer.as_ref(), &base, &mut notes);
                        // Budget rows first: the progressive rows mark the combination done.
                        let (budget, passes): (Vec<_>, Vec<_>) =
                            rows.into_iter().partition(|r| r.budget_ms.is_some());
                        for r in budget.iter().chain(&passes) {
                            self.push(r)?;
                        }
                    }
                }
            }
        }
        Ok(notes)
    }

    /// The reference image of `integrator` for `scene` and its content hash: kept from an
    /// earlier build of the run, else loaded from the cache or rendered (and noted).
    fn reference(
        &mut self,
        scene: &SceneSpec,
        camera: tb_scene::Camera,
        integrator: Integrator,
        progress: &Progress,
        notes: &mut Vec<String>,
    ) -> Result<(Vec<f32>, String), HarnessError> {
        let tris = &scene.scene.triangles;
        let ref_key = (scene.label.clone(), integrator.key());
        if !self.refs.contains_key(&ref_key) {
            let spp = self.spec.reference_spp;
            let key = reference_key(tris, &camera, &integrator, spp, self.seed);
            let file = reference_path(&self.spec.cache, &integrator, &key);
            let seed = self.seed ^ 0x5245_4645_5245_4e43; // "REFERENC": independent samples
            progress.step(&format!(
                "{}: reference {} ({spp} spp)",
                scene.label,
                integrator.name()
            ));
            let (img, origin) = load_or_render(&file, camera.width, camera.height, || {
                let gen = crate::registry::generator(tris);
                let t = AccelTracer {
                    accel: gen.as_ref(),
                    traversal: 0,
                    tri: TriTestKind::Watertight,
                };
                self.pool
                    .install(|| render(tris, camera, integrator, seed, spp, &t, 1 << 21))
            })
            .map_err(|e| HarnessError::other(e.to_string()))?;
            notes.push(format!(
                "{}: {} reference {} {}",
                scene.label,
                integrator.name(),
                file.display(),
                match origin {
                    Origin::Cached => "reused from the cache",
                    Origin::Rendered => "rendered and cached",
                }
            ));
            self.refs.insert(ref_key.clone(), (img, key));
        }
        Ok(self.refs[&ref_key].clone())
    }

    /// The progressive render and the budget renders of one combination: `image` traced
    /// with `tracer`.
    fn measure(
        &self,
        image: &Image<'_>,
        tracer: &dyn Tracer,
        base: &ConvergenceRow,
        notes: &mut Vec<String>,
    ) -> Vec<ConvergenceRow> {
        let Image {
            tris,
            camera,
            integrator,
            reference,
        } = *image;
        let mut rows = Vec::new();
        let mut r = Progressive::new(tris, camera, integrator, self.seed);
        let mut elapsed = 0.0f64;
        for k in 0..self.spec.passes {
            if elapsed > self.spec.max_seconds * 1e3 {
                notes.push(format!(
                    "{} {} {} {}: stopped after {k} passes (max_seconds = {})",
                    base.scene,
                    base.structure,
                    base.traversal,
                    base.integrator,
                    self.spec.max_seconds
                ));
                break;
            }
            let t0 = Instant::now();
            self.pool.install(|| r.pass(tracer, self.spec.pass_spp(k)));
            elapsed += t0.elapsed().as_secs_f64() * 1e3;
            let img = r.image();
            rows.push(ConvergenceRow {
                pass: k + 1,
                spp: r.spp(),
                elapsed_ms: elapsed,
                rmse: Some(rmse(&img, reference)),
                rel_mse: Some(rel_mse(&img, reference)),
                ..base.clone()
            });
        }
        for &budget in &self.spec.frame_budget_ms {
            // Passes of one sample while the next is expected to fit (the slowest so far); a
            // pass that ends over the budget is not counted: the row reports the last image
            // within it (none when even the first sample did not fit), so `elapsed_ms` never
            // exceeds `budget_ms`.
            let mut r = Progressive::new(tris, camera, integrator, self.seed);
            let mut spent = base.build_ms;
            let mut slowest = 0.0f64;
            let mut kept: Option<(u32, u32, f64, Vec<f32>)> = None;
            let mut passes = 0u32;
            while spent + slowest <= budget && passes < 1 << 16 {
                let t0 = Instant::now();
                self.pool.install(|| r.pass(tracer, 1));
                let ms = t0.elapsed().as_secs_f64() * 1e3;
                slowest = slowest.max(ms);
                spent += ms;
                passes += 1;
                if spent > budget {
                    break;
                }
                kept = Some((passes, r.spp(), spent, r.image()));
            }
            let (pass, spp, elapsed_ms, e, rel) = match kept {
                Some((p, spp, t, img)) => (
                    p,
                    spp,
                    t,
                    Some(rmse(&img, reference)),
                    Some(rel_mse(&img, reference)),
                ),
                None => (0, 0, base.build_ms, None, None),
            };
            rows.push(ConvergenceRow {
                pass,
                spp,
                elapsed_ms,
                rmse: e,
                rel_mse: rel,
                budget_ms: Some(budget),
                ..base.clone()
            });
        }
        rows
    }
}

/// The tracer of traversal `ti` with triangle test `tri` on `dev`; why not when the GPU
/// cannot trace it.
fn tracer_on<'a>(
    dev: Device,
    accel: &'a dyn Accel,
    ti: usize,
    tri: TriTestKind,
    gpu: Option<&'a crate::experiment::device::gpu::GpuDevice>,
) -> Result<Box<dyn Tracer + 'a>, String> {
    Ok(match dev {
        Device::Cpu => Box::new(AccelTracer {
            accel,
            traversal: ti,
            tri,
        }),
        Device::Gpu => Box::new(
            gpu.ok_or_else(|| "the GPU was not opened".to_string())
                .and_then(|g| g.tracer(accel, ti, tri))?,
        ),
    })
}
