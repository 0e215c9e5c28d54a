//! Two-stage config: raw serde structs (`deny_unknown_fields`), then a checked
//! [`Experiment`] with scenes loaded, structures resolved and sweeps expanded, before any work
//! starts. Every error names the file, the line and the key.
//!
//! The schema is documented in README.md ("Config reference"). The image and convergence
//! sections are checked in their own modules ([`images`], [`convergence`]), which the work
//! modules ([`crate::images`], [`crate::convergence`]) read from, never the other way round.

pub mod convergence;
pub mod images;

use crate::error::HarnessError;
use crate::params::expand;
use crate::registry::Registry;
use serde::Deserialize;
use std::path::{Path, PathBuf};
use tb_core::{Family, ParamSet, TraversalInfo};
use tb_core::{TriTestKind, Vec3};
use tb_scene::{Camera, PixelOrder, Scene};
use toml::Spanned;

#[derive(Deserialize)]
#[serde(untagged)]
enum OneOrMany<T> {
    One(T),
    Many(Vec<T>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    name: Option<String>,
    scenes_root: Option<String>,
    #[serde(default)]
    run: RawRun,
    #[serde(default, rename = "scene")]
    scenes: Vec<RawScene>,
    #[serde(default, rename = "structure")]
    structures: Vec<RawStructure>,
    convergence: Option<Spanned<convergence::RawConvergence>>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawRun {
    threads: Option<Spanned<OneOrMany<u32>>>,
    repeat: Option<u32>,
    warmup: Option<u32>,
    build_repeat: Option<u32>,
    triangle_test: Option<Spanned<OneOrMany<String>>>,
    devices: Option<Spanned<OneOrMany<String>>>,
    gpu_adapter: Option<String>,
    gpu_backend: Option<Spanned<String>>,
    gpu_required: Option<bool>,
    validate: Option<Spanned<toml::Value>>,
    seed: Option<u64>,
    images: Option<bool>,
    heatmap_max: Option<Spanned<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    source: Spanned<String>,
    name: Option<String>,
    rays: Option<Spanned<Vec<String>>>,
    camera: Option<Spanned<RawCamera>>,
    light: Option<[f32; 3]>,
    ao: Option<RawAo>,
    path: Option<RawPath>,
    random: Option<RawRandom>,
    validate: Option<Spanned<toml::Value>>,
    optional: Option<bool>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    eye: Option<[f32; 3]>,
    target: Option<[f32; 3]>,
    up: Option<[f32; 3]>,
    fov: Option<f32>,
    width: Option<u32>,
    height: Option<u32>,
    order: Option<PixelOrder>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAo {
    samples: Option<u32>,
    distance: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPath {
    bounces: u32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRandom {
    count: u32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStructure {
    name: Spanned<String>,
    traversals: Option<Spanned<Vec<String>>>,
    params: Option<Spanned<toml::Table>>,
}

/// Where oracle validation runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Validate {
    /// No validation; `mismatches` is empty.
    Off,
    /// Every ray of every batch.
    All,
    /// A strided sample of at most this many rays per batch (for large scenes, where brute
    /// force over all rays would take hours).
    Sample(usize),
}

/// A device the rays are traced on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Device {
    /// The host CPU, on a rayon pool per thread count.
    Cpu,
    /// A wgpu adapter (crate tb-gpu), chosen by [`GpuSpec`].
    Gpu,
}

impl Device {
    /// Config and column name: `cpu` or `gpu`.
    pub fn name(self) -> &'static str {
        match self {
            Device::Cpu => "cpu",
            Device::Gpu => "gpu",
        }
    }

    /// The device called `s` (`cpu` or `gpu`).
    pub fn from_name(s: &str) -> Option<Device> {
        [Device::Cpu, Device::Gpu]
            .into_iter()
            .find(|d| d.name() == s)
    }
}

/// Which GPU adapter the `gpu` device uses, and whether a GPU failure fails the run.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct GpuSpec {
    /// Adapter name substring and backend (`run.gpu_adapter`, `run.gpu_backend`, or
    /// `--adapter`, `--backend`).
    pub choice: tb_gpu::AdapterChoice,
    /// Exit non-zero when the GPU cannot be used (no adapter, device lost, validation error).
    /// True unless the config sets `run.gpu_required = false`; `--device gpu` forces it.
    pub required: bool,
}

/// A ray kind a scene asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKindSpec {
    Primary,
    Shadow,
    Ao,
    Path,
    Random,
    Stress,
}

impl RayKindSpec {
    const NAMES: [&'static str; 6] = ["primary", "shadow", "ao", "path", "random", "stress"];

    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "primary" => Self::Primary,
            "shadow" => Self::Shadow,
            "ao" => Self::Ao,
            "path" => Self::Path,
            "random" => Self::Random,
            "stress" => Self::Stress,
            _ => return None,
        })
    }
}

/// A checked scene entry, loaded.
pub struct SceneSpec {
    /// Label used in result rows (config `name`, else derived from the source).
    pub label: String,
    pub scene: Scene,
    pub rays: Vec<RayKindSpec>,
    pub camera: Option<Camera>,
    pub light: Option<Vec3>,
    pub ao_samples: u32,
    pub ao_distance: f32,
    pub bounces: u32,
    pub random_count: usize,
    /// Oracle validation for this scene (the scene's `validate`, else `run.validate`).
    pub validate: Validate,
}

/// A checked structure entry.
pub struct StructureSpec {
    pub family: &'static Family,
    /// The family's traversals (index = position in its table).
    pub infos: Vec<&'static TraversalInfo>,
    /// The traversals to run: indices into `infos`.
    pub traversals: Vec<usize>,
    pub param_sets: Vec<ParamSet>,
}

/// A checked experiment: everything needed to run, nothing left to fail on the config.
pub struct Experiment {
    pub name: String,
    pub file: PathBuf,
    /// The config text as read (stored in results.json).
    pub text: String,
    pub scenes_root: PathBuf,
    /// Thread counts, each ≥ 1 (0 in the config means all cores).
    pub threads: Vec<usize>,
    pub repeat: usize,
    pub warmup: usize,
    pub build_repeat: usize,
    pub triangle_tests: Vec<TriTestKind>,
    pub devices: Vec<Device>,
    pub gpu: GpuSpec,
    pub validate: Validate,
    pub seed: u64,
    pub scenes: Vec<SceneSpec>,
    pub structures: Vec<StructureSpec>,
    /// Why scenes marked `optional = true` were left out (file not under the scenes root).
    pub skipped_scenes: Vec<String>,
    /// `[run] images = true`: heat maps of primary rays ([`crate::images`]).
    pub images: Option<images::ImageSpec>,
    /// `[convergence]`: error against run time ([`crate::convergence`]).
    pub convergence: Option<convergence::ConvergenceSpec>,
}

/// Overrides from the command line.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    pub scenes_root: Option<PathBuf>,
    pub threads: Option<Vec<usize>>,
    pub repeat: Option<usize>,
    /// `--device`: replaces run.devices; listing `gpu` makes the GPU required.
    pub devices: Option<Vec<Device>>,
    /// `--adapter`: replaces run.gpu_adapter.
    pub adapter: Option<String>,
    /// `--backend`: replaces run.gpu_backend.
    pub backend: Option<tb_gpu::Backend>,
}

/// 1-based line of byte offset `pos` in `text`.
pub fn line_of(text: &str, pos: usize) -> usize {
    text[..pos.min(text.len())]
        .bytes()
        .filter(|&b| b == b'\n')
        .count()
        + 1
}

/// Where a config came from, for errors naming its file and line.
pub(crate) struct Ctx<'a> {
    pub(crate) file: &'a Path,
    pub(crate) text: &'a str,
}

impl Ctx<'_> {
    /// A config error at byte range `span` of the file.
    pub(crate) fn err(
        &self,
        span: std::ops::Range<usize>,
        key: &str,
        message: impl Into<String>,
    ) -> HarnessError {
        HarnessError::Config {
            file: self.file.to_path_buf(),
            line: line_of(self.text, span.start),
            key: key.to_string(),
            message: message.into(),
        }
    }
}

/// Parse and check `file` against the built-in registry; loads every scene. `progress` is
/// told each scene as it loads.
pub fn load(
    file: &Path,
    ov: &Overrides,
    progress: &mut dyn FnMut(&str),
) -> Result<Experiment, HarnessError> {
    let text = std::fs::read_to_string(file).map_err(|e| HarnessError::io(file, e))?;
    parse(file, &text, ov, progress)
}

/// Parse and check config `text` (read from `file`, named in errors) against the built-in
/// registry.
pub fn parse(
    file: &Path,
    text: &str,
    ov: &Overrides,
    progress: &mut dyn FnMut(&str),
) -> Result<Experiment, HarnessError> {
    parse_with(file, text, ov, &Registry::builtin(), progress)
}

/// [`parse`], resolving structures against `registry` (tests add their own structures).
pub fn parse_with(
    file: &Path,
    text: &str,
    ov: &Overrides,
    registry: &Registry,
    progress: &mut dyn FnMut(&str),
) -> Result<Experiment, HarnessError> {
    let cx = Ctx { file, text };
    let raw: RawConfig = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| line_of(text, s.start));
        let msg = e.message().trim().replace('\n', " ");
        match line {
            Some(l) => HarnessError::ConfigSyntax {
                file: file.into(),
                message: format!("line {l}: {msg}"),
            },
            None => HarnessError::ConfigSyntax {
                file: file.into(),
                message: msg,
            },
        }
    })?;

    let name = raw.name.clone().unwrap_or_else(|| {
        file.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "experiment".into())
    });
    if name.is_empty() || name.contains(['/', '\\']) || name.starts_with('.') {
        return Err(cx.err(0..0, "name", "must be a plain, non-empty file name"));
    }
    let scenes_root = ov
        .scenes_root
        .clone()
        .or_else(|| std::env::var_os("TRACE_BENCH_SCENES").map(PathBuf::from))
        .or_else(|| raw.scenes_root.as_ref().map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("scenes"));

    // [run]
    let run = &raw.run;
    let all = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let threads: Vec<usize> = match (&ov.threads, &run.threads) {
        (Some(t), _) => t.iter().map(|&n| if n == 0 { all } else { n }).collect(),
        (None, Some(t)) => {
            let span = t.span();
            let list: Vec<u32> = match t.get_ref() {
                OneOrMany::One(n) => vec![*n],
                OneOrMany::Many(v) => v.clone(),
            };
            if list.is_empty() {
                return Err(cx.err(span, "run.threads", "needs at least one thread count"));
            }
            let mut out: Vec<usize> = Vec::new();
            for n in list {
                let n = if n == 0 { all } else { n as usize };
                if n > 1024 {
                    return Err(cx.err(
                        span.clone(),
                        "run.threads",
                        format!("{n} threads is too many"),
                    ));
                }
                if !out.contains(&n) {
                    out.push(n);
                }
            }
            out
        }
        (None, None) => vec![all],
    };
    let repeat = ov.repeat.unwrap_or(run.repeat.unwrap_or(5) as usize).max(1);
    let warmup = run.warmup.unwrap_or(1) as usize;
    let build_repeat = run.build_repeat.unwrap_or(1).max(1) as usize;
    let triangle_tests = match &run.triangle_test {
        None => vec![TriTestKind::Watertight],
        Some(t) => {
            let span = t.span();
            let names = match t.get_ref() {
                OneOrMany::One(s) => vec![s.clone()],
                OneOrMany::Many(v) => v.clone(),
            };
            let mut out = Vec::new();
            for n in names {
                let k = TriTestKind::from_name(&n).ok_or_else(|| {
                    cx.err(
                        span.clone(),
                        "run.triangle_test",
                        format!("unknown triangle test `{n}` (known: watertight, moller-trumbore)"),
                    )
                })?;
                if !out.contains(&k) {
                    out.push(k);
                }
            }
            if out.is_empty() {
                return Err(cx.err(span, "run.triangle_test", "needs at least one test"));
            }
            out
        }
    };
    let devices = match &run.devices {
        None => vec![Device::Cpu],
        Some(d) => {
            let span = d.span();
            let names = match d.get_ref() {
                OneOrMany::One(s) => vec![s.clone()],
                OneOrMany::Many(v) => v.clone(),
            };
            let mut out = Vec::new();
            for n in names {
                match Device::from_name(&n) {
                    Some(d) if !out.contains(&d) => out.push(d),
                    Some(_) => {}
                    None => {
                        return Err(cx.err(
                            span.clone(),
                            "run.devices",
                            format!("unknown device `{n}` (known: cpu, gpu)"),
                        ))
                    }
                }
            }
            if out.is_empty() {
                return Err(cx.err(span, "run.devices", "needs at least one device"));
            }
            out
        }
    };
    let devices = ov.devices.clone().unwrap_or(devices);
    let backend = match (&ov.backend, &run.gpu_backend) {
        (Some(b), _) => Some(*b),
        (None, None) => None,
        (None, Some(b)) => Some(tb_gpu::Backend::from_name(b.get_ref()).ok_or_else(|| {
            cx.err(
                b.span(),
                "run.gpu_backend",
                format!(
                    "unknown backend `{}` (known: vulkan, gl, metal, dx12)",
                    b.get_ref()
                ),
            )
        })?),
    };
    let gpu = GpuSpec {
        choice: tb_gpu::AdapterChoice {
            name: ov.adapter.clone().or_else(|| run.gpu_adapter.clone()),
            backend,
        },
        required: run.gpu_required.unwrap_or(true)
            || ov
                .devices
                .as_ref()
                .is_some_and(|d| d.contains(&Device::Gpu)),
    };
    let validate = match &run.validate {
        None => Validate::All,
        Some(v) => parse_validate(&cx, v, "run.validate")?,
    };
    let seed = run.seed.unwrap_or(1);

    // [[structure]]
    if raw.structures.is_empty() {
        return Err(cx.err(0..0, "structure", "the config names no [[structure]]"));
    }
    let mut structures = Vec::new();
    for s in &raw.structures {
        let family = registry.find(s.name.get_ref()).ok_or_else(|| {
            let known: Vec<&str> = registry.families().iter().map(|s| s.name).collect();
            cx.err(
                s.name.span(),
                "structure.name",
                format!(
                    "unknown structure `{}` (known: {})",
                    s.name.get_ref(),
                    known.join(", ")
                ),
            )
        })?;
        let infos = (family.traversals)();
        let traversals = match &s.traversals {
            None => (0..infos.len()).collect(),
            Some(t) => {
                let mut out = Vec::new();
                for n in t.get_ref() {
                    let i = infos.iter().position(|ti| ti.name == n).ok_or_else(|| {
                        let known: Vec<&str> = infos.iter().map(|t| t.name).collect();
                        cx.err(
                            t.span(),
                            "structure.traversals",
                            format!(
                                "`{}` has no traversal `{n}` (known: {})",
                                family.name,
                                known.join(", ")
                            ),
                        )
                    })?;
                    if !out.contains(&i) {
                        out.push(i);
                    }
                }
                if out.is_empty() {
                    return Err(cx.err(
                        t.span(),
                        "structure.traversals",
                        "needs at least one traversal",
                    ));
                }
                out
            }
        };
        let empty = toml::Table::new();
        let (table, span) = match &s.params {
            Some(p) => (p.get_ref(), p.span()),
            None => (&empty, s.name.span()),
        };
        let param_sets = expand(family.params, &(family.defaults)(), table)
            .map_err(|(key, msg)| cx.err(span.clone(), &format!("structure.params.{key}"), msg))?;
        structures.push(StructureSpec {
            family,
            infos,
            traversals,
            param_sets,
        });
    }

    // [[scene]]
    if raw.scenes.is_empty() {
        return Err(cx.err(0..0, "scene", "the config names no [[scene]]"));
    }
    let mut scenes = Vec::new();
    let mut skipped_scenes = Vec::new();
    for s in &raw.scenes {
        let src = s.source.get_ref();
        let span = s.source.span();
        let mut kinds = Vec::new();
        match &s.rays {
            None => kinds.push(RayKindSpec::Primary),
            Some(r) => {
                for k in r.get_ref() {
                    let kind = RayKindSpec::parse(k).ok_or_else(|| {
                        cx.err(
                            r.span(),
                            "scene.rays",
                            format!(
                                "unknown ray kind `{k}` (known: {})",
                                RayKindSpec::NAMES.join(", ")
                            ),
                        )
                    })?;
                    if !kinds.contains(&kind) {
                        kinds.push(kind);
                    }
                }
                if kinds.is_empty() {
                    return Err(cx.err(r.span(), "scene.rays", "needs at least one ray kind"));
                }
            }
        }
        // Check the file exists before loading anything (cheap, reports every config error
        // before the first expensive load).
        if !src.starts_with("builtin:") {
            let p = Path::new(src);
            let full = if p.is_absolute() {
                p.to_path_buf()
            } else {
                scenes_root.join(p)
            };
            if !full.is_file() && s.optional == Some(true) {
                skipped_scenes.push(format!(
                    "{}: skipped, not found under the scenes root {} (optional = true)",
                    s.name.clone().unwrap_or_else(|| scene_label(src)),
                    scenes_root.display()
                ));
                continue;
            }
            if !full.is_file() {
                return Err(cx.err(
                    span,
                    "scene.source",
                    format!(
                        "{} not found (scenes root {}; set --scenes-root or TRACE_BENCH_SCENES)",
                        full.display(),
                        scenes_root.display()
                    ),
                ));
            }
        }
        progress(src);
        let scene = tb_scene::load(src, &scenes_root)
            .map_err(|e| cx.err(span.clone(), "scene.source", e.to_string()))?;
        if scene.triangles.is_empty() {
            return Err(cx.err(span, "scene.source", "the scene has no triangles"));
        }
        let view = scene.view.clone();
        let needs_camera = kinds.iter().any(|k| {
            matches!(
                k,
                RayKindSpec::Primary | RayKindSpec::Shadow | RayKindSpec::Ao | RayKindSpec::Path
            )
        });
        let camera = match (&s.camera, &view) {
            (None, Some(v)) => Some(v.camera),
            (None, None) => None,
            (Some(c), v) => {
                let rc = c.get_ref();
                let base = v.as_ref().map(|v| v.camera);
                let pick = |o: Option<[f32; 3]>,
                            b: Option<Vec3>,
                            key: &str|
                 -> Result<Vec3, HarnessError> {
                    o.map(Vec3::from).or(b).ok_or_else(|| {
                        cx.err(
                            c.span(),
                            &format!("scene.camera.{key}"),
                            "missing (the scene has no default view)",
                        )
                    })
                };
                let cam = Camera {
                    eye: pick(rc.eye, base.map(|b| b.eye), "eye")?,
                    target: pick(rc.target, base.map(|b| b.target), "target")?,
                    up: pick(rc.up, Some(base.map(|b| b.up).unwrap_or(Vec3::Y)), "up")?,
                    fov: rc.fov.or(base.map(|b| b.fov)).ok_or_else(|| {
                        cx.err(
                            c.span(),
                            "scene.camera.fov",
                            "missing (the scene has no default view)",
                        )
                    })?,
                    width: rc.width.or(base.map(|b| b.width)).unwrap_or(512),
                    height: rc.height.or(base.map(|b| b.height)).unwrap_or(512),
                    order: rc.order.or(base.map(|b| b.order)).unwrap_or_default(),
                };
                cam.check()
                    .map_err(|m| cx.err(c.span(), "scene.camera", m))?;
                if cam.width as u64 * cam.height as u64 > 64 << 20 {
                    return Err(cx.err(c.span(), "scene.camera", "more than 64M pixels"));
                }
                Some(cam)
            }
        };
        if needs_camera && camera.is_none() {
            return Err(cx.err(
                span,
                "scene.camera",
                "primary, shadow, ao and path rays need a camera: this scene has no default view",
            ));
        }
        if kinds.contains(&RayKindSpec::Stress) && scene.own_rays.is_empty() {
            return Err(cx.err(
                s.rays.as_ref().map(|r| r.span()).unwrap_or(span.clone()),
                "scene.rays",
                "ray kind `stress` needs a stress scene (builtin:stress/NAME) that comes with its own rays",
            ));
        }
        let light = s
            .light
            .map(Vec3::from)
            .or(view.as_ref().and_then(|v| v.light));
        let diag = scene.bounds.diagonal();
        let ao_distance =
            s.ao.as_ref()
                .and_then(|a| a.distance)
                .or(view.as_ref().map(|v| v.ao_distance))
                .unwrap_or(0.04 * diag);
        if !(ao_distance > 0.0 && ao_distance.is_finite()) {
            return Err(cx.err(span, "scene.ao.distance", "must be positive and finite"));
        }
        let ao_samples = s.ao.as_ref().and_then(|a| a.samples).unwrap_or(4);
        if ao_samples == 0 || ao_samples > 1024 {
            return Err(cx.err(span, "scene.ao.samples", "must be in 1..=1024"));
        }
        let bounces = s.path.as_ref().map(|p| p.bounces).unwrap_or(2);
        if bounces == 0 || bounces > 64 {
            return Err(cx.err(span, "scene.path.bounces", "must be in 1..=64"));
        }
        let random_count = s.random.as_ref().map(|r| r.count).unwrap_or(1 << 16) as usize;
        if random_count == 0 || random_count > 1 << 28 {
            return Err(cx.err(span, "scene.random.count", "must be in 1..=2^28"));
        }
        let label = s.name.clone().unwrap_or_else(|| scene_label(src));
        if scenes.iter().any(|o: &SceneSpec| o.label == label) {
            return Err(cx.err(
                span,
                "scene.name",
                format!("two scenes are labelled `{label}`; give one a `name`"),
            ));
        }
        let scene_validate = match &s.validate {
            None => validate,
            Some(v) => parse_validate(&cx, v, "scene.validate")?,
        };
        scenes.push(SceneSpec {
            label,
            scene,
            rays: kinds,
            camera,
            light,
            ao_samples,
            ao_distance,
            bounces,
            random_count,
            validate: scene_validate,
        });
    }

    if scenes.is_empty() {
        return Err(HarnessError::ConfigSyntax {
            file: file.into(),
            message: format!("no scene to run: {}", skipped_scenes.join("; ")),
        });
    }
    let images = images::check(&cx, run.images, run.heatmap_max.as_ref())?;
    let convergence = match &raw.convergence {
        None => None,
        Some(c) => Some(convergence::check(&cx, c, &scenes)?),
    };

    Ok(Experiment {
        name,
        file: file.to_path_buf(),
        text: text.to_string(),
        scenes_root,
        threads,
        repeat,
        warmup,
        build_repeat,
        triangle_tests,
        devices,
        gpu,
        validate,
        seed,
        scenes,
        structures,
        skipped_scenes,
        images,
        convergence,
    })
}

fn parse_validate(cx: &Ctx, v: &Spanned<toml::Value>, key: &str) -> Result<Validate, HarnessError> {
    Ok(match v.get_ref() {
        toml::Value::String(s) if s == "all" => Validate::All,
        toml::Value::String(s) if s == "off" => Validate::Off,
        toml::Value::Boolean(true) => Validate::All,
        toml::Value::Boolean(false) => Validate::Off,
        toml::Value::Integer(n) if *n > 0 => Validate::Sample(*n as usize),
        other => {
            return Err(cx.err(
                v.span(),
                key,
                format!("expected \"all\", \"off\" or a positive ray count, found {other}"),
            ))
        }
    })
}

/// A short label for a scene source: `builtin:stress/flat?x=1` → `stress/flat?x=1`,
/// `sibenik/sibenik.obj.gz` → `sibenik`.
pub fn scene_label(src: &str) -> String {
    if let Some(b) = src.strip_prefix("builtin:") {
        return b.to_string();
    }
    let file = Path::new(src)
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = file.split('.').next().unwrap_or("").to_string();
    if stem.is_empty() {
        src.to_string()
    } else {
        stem
    }
}
