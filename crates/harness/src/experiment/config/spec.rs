//! The checked parts of a config that the runner, the devices and the reports read: scenes,
//! structures, devices, validation.

use std::sync::Arc;
use tb_core::{Family, ParamSet, TraversalInfo, Vec3};
use tb_scene::rays::RayKind;
use tb_scene::{Camera, Scene};

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

/// The devices rows are written for, each with its thread counts: the run's thread counts on
/// the CPU; one row, `threads = 0`, on the GPU (one host thread drives it).
pub fn device_threads(devices: &[Device], threads: &[usize]) -> Vec<(Device, Vec<usize>)> {
    devices
        .iter()
        .map(|&d| match d {
            Device::Cpu => (d, threads.to_vec()),
            Device::Gpu => (d, vec![0]),
        })
        .collect()
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

/// A checked scene entry, loaded: one per scene table, or one per view of a table with
/// `views` (the views share the loaded scene, and the runner builds each structure once for
/// all of them).
pub struct SceneSpec {
    /// Label used in result rows: the table's label (config `name`, else derived from the
    /// source), `TABLE@VIEW` for a view of a table with `views`.
    pub label: String,
    /// The scene table's label: equal to `label` without views; the views of one table share
    /// it, their scene and their builds (and form one shard unit with each build).
    pub table: String,
    /// The loaded scene (shared by the views of one table).
    pub scene: Arc<Scene>,
    /// The ray kinds the scene asks for (`rays`).
    pub rays: Vec<RayKind>,
    /// The view's camera; `None` without one (no primary or secondary rays then).
    pub camera: Option<Camera>,
    /// Point light of the shadow rays; `None`: shadow batches are skipped.
    pub light: Option<Vec3>,
    /// AO rays per primary hit (`ao.samples`).
    pub ao_samples: u32,
    /// Longest AO ray (`ao.distance`).
    pub ao_distance: f32,
    /// Diffuse path-tracing bounces, one batch each (`path.bounces`).
    pub bounces: u32,
    /// Random rays in the batch (`random.count`).
    pub random_count: usize,
    /// Oracle validation for this scene (the scene's `validate`, else `run.validate`).
    pub validate: Validate,
}

/// A checked structure entry.
pub struct StructureSpec {
    /// The registry family the entry names.
    pub family: &'static Family,
    /// The family's traversals (index = position in its table).
    pub infos: Vec<&'static TraversalInfo>,
    /// The traversals to run: indices into `infos`.
    pub traversals: Vec<usize>,
    /// The parameter sets to build, the `params` sweep expanded.
    pub param_sets: Vec<ParamSet>,
    /// `time_builds` of the table: `Some(false)`, its builds are untimed and loaded from the
    /// build cache where they can be, though the run times its builds (no claim reads these
    /// builds' times); `Some(true)`, timed though the run does not; `None`, as the run says
    /// ([`StructureSpec::builds_timed`]).
    pub time_builds: Option<bool>,
}

impl StructureSpec {
    /// Whether this table's builds are timed (built fresh `run.build_repeat` times, never
    /// loaded from the cache): its own `time_builds`, else the run's (`run.time_builds`, or
    /// `run.build_repeat` above 1).
    pub fn builds_timed(&self, run: &super::RunSettings) -> bool {
        self.time_builds
            .unwrap_or(run.time_builds || run.build_repeat > 1)
    }
}
