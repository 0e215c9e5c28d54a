//! Shader modules, bind group layouts and pipeline variants of the programs structures hand
//! over, each made on first use and cached (by program name; layouts by buffer count and
//! whether the program sorts its rays; pipelines by program, query, triangle test and
//! counting, the sort passes' by program).
//!
//! Each program is compiled twice from the same source: with wgpu's runtime checks (bounds
//! checks on every access, a bound on every loop) for the counting variant, and as a trusted
//! module without them ([`wgpu::ShaderRuntimeChecks::unchecked`]) for the timed variant and
//! the sort passes, so that timed kernels run as written. The trusted module is
//! the same WGSL, validated by naga as the checked one; every program's timed variant is
//! tested ray for ray against its counting (checked) variant and the CPU (tb-harness's
//! `gpu_oracle`, the structure crates' GPU tests). A program may keep the loop bound
//! without the bounds checks ([`GpuProgram::bounded_loops`]: sparse boxes' mask walk, whose
//! loops lavapipe's compiler took to end). `TRACE_BENCH_GPU_CHECKED=1` compiles the timed
//! variant with the checks too.

use crate::{GpuError, WORKGROUP};
use std::collections::HashMap;
use std::sync::Mutex;
use tb_core::stats::wgsl_stats_struct;
use tb_core::{GpuProgram, Query, TriTestKind};

const COMMON: &str = include_str!("../shaders/prelude.wgsl");
const EDGE_F64: &str = include_str!("../shaders/edge_f64.wgsl");
const EDGE_F32: &str = include_str!("../shaders/edge_f32.wgsl");
const UNSORTED: &str = include_str!("../shaders/unsorted.wgsl");
const ARRANGE: &str = include_str!("../shaders/arrange.wgsl");
const ENTRY: &str = include_str!("../shaders/entry.wgsl");
const PERSISTENT: &str = include_str!("../shaders/persistent.wgsl");

/// The entry points of the sort passes of a program with a ray key (`shaders/arrange.wgsl`),
/// in the order they run.
pub(crate) const SORT_PASSES: [&str; 3] = ["tb_histogram", "tb_scan", "tb_scatter"];

/// Bindings of the prelude (rays, hits, stats, triangles, meta); a program's buffers follow.
pub(crate) const COMMON_BINDINGS: u32 = 5;

/// What is compiled of one program: its shader module and what it was compiled with, so that
/// a second program of the same name but other code is refused rather than run with the
/// first one's pipelines.
struct Module {
    /// With wgpu's runtime checks: the counting variant.
    module: wgpu::ShaderModule,
    /// Without them (trusted): the timed variant and the sort passes.
    trusted: wgpu::ShaderModule,
    source: &'static str,
    includes: Vec<&'static str>,
    stack_size: u32,
    constants: Vec<(&'static str, f64)>,
    /// Keys of its ray arrangement (0: none).
    keys: u32,
    /// Persistent threads ([`GpuProgram::persistent`]).
    persistent: bool,
    /// Subgroup operations ([`GpuProgram::needs_subgroups`]).
    subgroups: bool,
}

/// Layouts of a program: group 0 (the common bindings and its buffers), group 1 (the
/// arrangement buffer) where it sorts its rays, and the pipeline layout of both.
#[derive(Clone)]
pub(crate) struct Layouts {
    pub(crate) group0: wgpu::BindGroupLayout,
    pub(crate) group1: Option<wgpu::BindGroupLayout>,
    pipeline: wgpu::PipelineLayout,
}

/// A program's own buffers: how many, and which are uniform buffers (bit `k` for buffer `k`,
/// [`tb_core::GpuProgram::uniform_mask`]; the others are read-only storage buffers), and
/// whether it is persistent (its fetch counter bound after them).
pub(crate) type Shape = (usize, u32, bool);

/// The shape of `p`'s bindings.
pub(crate) fn shape(p: &GpuProgram<'_>) -> Shape {
    (p.buffers.len(), p.uniform_mask(), p.persistent)
}

/// A pipeline variant: program name, query, triangle test, counting (else timed).
type Variant = (&'static str, Query, TriTestKind, bool);

#[derive(Default)]
struct Cache {
    /// Shader modules by program name.
    modules: HashMap<&'static str, Module>,
    /// Bind group and pipeline layouts by the program's own buffers ([`Shape`]) and whether
    /// it sorts its rays.
    layouts: HashMap<(Shape, bool), Layouts>,
    pipelines: HashMap<Variant, wgpu::ComputePipeline>,
    /// The sort passes' pipelines ([`SORT_PASSES`]) by program name.
    sorts: HashMap<&'static str, Vec<wgpu::ComputePipeline>>,
}

/// The device's compiled programs; every entry is made on first use.
pub(crate) struct Kernels {
    /// Whether the watertight test's fallback runs in f64 (`SHADER_F64`).
    f64: bool,
    cache: Mutex<Cache>,
}

/// `TRACE_BENCH_GPU_CHECKED=1`: the timed variant keeps wgpu's runtime checks (module doc).
pub fn checked_only() -> bool {
    std::env::var_os("TRACE_BENCH_GPU_CHECKED").is_some_and(|v| v == "1")
}

fn uniform(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// The layouts of a program with buffers of its own of `shape`: the common bindings 0–4, then
/// its buffers at 5, 6, … (uniform where the shape's mask says, else read-only storage), then
/// a persistent program's fetch counter (read-write storage); and, when it sorts its rays
/// (`arranged`), group 1 with the arrangement buffer.
fn layout(device: &wgpu::Device, (n, uniforms, persistent): Shape, arranged: bool) -> Layouts {
    let mut entries = vec![
        storage(0, true),
        storage(1, false),
        storage(2, false),
        storage(3, true),
        uniform(4),
    ];
    entries.extend((0..n as u32).map(|k| {
        let binding = COMMON_BINDINGS + k;
        if uniforms >> k & 1 == 1 {
            uniform(binding)
        } else {
            storage(binding, true)
        }
    }));
    if persistent {
        entries.push(storage(COMMON_BINDINGS + n as u32, false));
    }
    let group0 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &entries,
    });
    let group1 = arranged.then(|| {
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("arrangement"),
            entries: &[storage(0, false)],
        })
    });
    let groups: Vec<Option<&wgpu::BindGroupLayout>> = std::iter::once(Some(&group0))
        .chain(group1.as_ref().map(Some))
        .collect();
    let pipeline = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &groups,
        immediate_size: 0,
    });
    Layouts {
        group0,
        group1,
        pipeline,
    }
}

impl Kernels {
    pub(crate) fn new(f64: bool) -> Kernels {
        Kernels {
            f64,
            cache: Mutex::new(Cache::default()),
        }
    }

    fn cache(&self) -> std::sync::MutexGuard<'_, Cache> {
        self.cache.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The full WGSL of `p`: `STACK_SIZE`, `WORKGROUP_SIZE`, the `Stats` record, the common
    /// prelude, the edge fallback, `ray_index` (with `KEYS` and the sort passes for a program
    /// that sorts its rays), the shared parts it includes, the program's source, the entry
    /// point (one thread per ray, or persistent threads with the fetch counter bound after
    /// the program's buffers).
    fn source(&self, p: &GpuProgram<'_>) -> String {
        let entry = if p.persistent {
            PERSISTENT.replace(
                "POOL_BINDING",
                &(COMMON_BINDINGS as usize + p.buffers.len()).to_string(),
            )
        } else {
            ENTRY.to_string()
        };
        let edge = if self.f64 { EDGE_F64 } else { EDGE_F32 };
        let order = match p.arrange {
            Some(a) => format!("const KEYS: u32 = {}u;\n{ARRANGE}", a.keys),
            None => UNSORTED.to_string(),
        };
        format!(
            "const STACK_SIZE: u32 = {}u;\nconst WORKGROUP_SIZE: u32 = {WORKGROUP}u;\n{}{COMMON}\n{edge}\n{order}\n{}\n{}\n{entry}",
            p.stack_size,
            wgsl_stats_struct(),
            p.includes.join("\n"),
            p.source
        )
    }

    /// Keys of `p`'s arrangement, 0 for none.
    fn keys(p: &GpuProgram<'_>) -> u32 {
        p.arrange.map_or(0, |a| a.keys)
    }

    /// Compile `p`'s shader module and make its layouts, unless done before; `Err` when a
    /// program of the same name with other code was compiled before, or (from `check`) when
    /// the module does not compile, in which case nothing is cached.
    pub(crate) fn prepare(
        &self,
        device: &wgpu::Device,
        p: &GpuProgram<'_>,
        check: impl FnOnce() -> Result<(), GpuError>,
    ) -> Result<(), GpuError> {
        let mut cache = self.cache();
        let keys = Self::keys(p);
        let shape = shape(p);
        cache
            .layouts
            .entry((shape, keys > 0))
            .or_insert_with(|| layout(device, shape, keys > 0));
        if let Some(m) = cache.modules.get(p.name) {
            if m.source != p.source
                || m.includes != p.includes
                || m.stack_size != p.stack_size
                || m.constants != p.constants
                || m.keys != keys
                || m.persistent != p.persistent
                || m.subgroups != p.needs_subgroups
            {
                return Err(GpuError::Program(format!(
                    "GPU program `{}`: another program of that name (other source, stack size, constants, keys or entry) was compiled before; names must be unique",
                    p.name
                )));
            }
            return Ok(());
        }
        let source = self.source(p);
        let desc = || wgpu::ShaderModuleDescriptor {
            label: Some(p.name),
            source: wgpu::ShaderSource::Wgsl(source.as_str().into()),
        };
        let module = device.create_shader_module(desc());
        check().map_err(|e| match e {
            GpuError::Wgpu(m) => GpuError::Program(format!("GPU program `{}`: {m}", p.name)),
            e => e,
        })?;
        let trusted = if checked_only() {
            module.clone()
        } else {
            let mut checks = wgpu::ShaderRuntimeChecks::unchecked();
            // A program whose answers changed when its loops lost their bound keeps it.
            checks.force_loop_bounding = p.bounded_loops.is_some();
            // SAFETY: the module is the checked one's WGSL, validated above; its accesses stay
            // within the buffers and its loops end (bounded by the structure's depth, step
            // cap or counts), which the ray-for-ray tests of every program against its checked
            // build and the CPU confirm (module doc).
            unsafe { device.create_shader_module_trusted(desc(), checks) }
        };
        cache.modules.insert(
            p.name,
            Module {
                module,
                trusted,
                source: p.source,
                includes: p.includes.clone(),
                stack_size: p.stack_size,
                constants: p.constants.clone(),
                keys,
                persistent: p.persistent,
                subgroups: p.needs_subgroups,
            },
        );
        Ok(())
    }

    /// The override constants of `m`'s pipelines: the prelude's for variant (query, triangle
    /// test, counting), then the program's own.
    fn constants(m: &Module, query: Query, tri: TriTestKind, count: bool) -> Vec<(&str, f64)> {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        let mut constants = vec![
            ("ANY", flag(query == Query::Any)),
            ("COUNT", flag(count)),
            ("WATERTIGHT", flag(tri == TriTestKind::Watertight)),
            ("EXIT_SCALE", tb_core::slab::EXIT_SCALE as f64),
        ];
        constants.extend(m.constants.iter().copied());
        constants
    }

    fn make_pipeline(
        device: &wgpu::Device,
        module: &wgpu::ShaderModule,
        l: &Layouts,
        entry: &str,
        constants: &[(&str, f64)],
    ) -> wgpu::ComputePipeline {
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&l.pipeline),
            module,
            entry_point: Some(entry),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                zero_initialize_workgroup_memory: false,
            },
            cache: None,
        })
    }

    /// The pipeline of variant `v` (made on first use) and the layouts of a program with
    /// buffers of `shape` (sorting its rays when `arranged`), and whether the pipeline was made
    /// by this call (its first dispatch may include the driver's compilation). The program
    /// must have been prepared ([`Gpu::upload`]).
    pub(crate) fn pipeline(
        &self,
        device: &wgpu::Device,
        v: Variant,
        shape: Shape,
        arranged: bool,
    ) -> (wgpu::ComputePipeline, Layouts, bool) {
        let mut cache = self.cache();
        let Cache {
            modules,
            layouts,
            pipelines,
            ..
        } = &mut *cache;
        let l = &layouts[&(shape, arranged)];
        let fresh = !pipelines.contains_key(&v);
        let pipeline = pipelines
            .entry(v)
            .or_insert_with(|| {
                let (name, query, tri, count) = v;
                let m = &modules[name];
                let constants = Self::constants(m, query, tri, count);
                let module = if count { &m.module } else { &m.trusted };
                Self::make_pipeline(device, module, l, "main", &constants)
            })
            .clone();
        (pipeline, l.clone(), fresh)
    }

    /// The pipelines of the sort passes ([`SORT_PASSES`]) of program `name`, which sorts its
    /// rays and has been prepared.
    pub(crate) fn sort_pipelines(
        &self,
        device: &wgpu::Device,
        name: &'static str,
        shape: Shape,
    ) -> Vec<wgpu::ComputePipeline> {
        let mut cache = self.cache();
        let Cache {
            modules,
            layouts,
            sorts,
            ..
        } = &mut *cache;
        let l = &layouts[&(shape, true)];
        sorts
            .entry(name)
            .or_insert_with(|| {
                let m = &modules[name];
                let constants = Self::constants(m, Query::Closest, TriTestKind::Watertight, false);
                SORT_PASSES
                    .iter()
                    .map(|entry| Self::make_pipeline(device, &m.trusted, l, entry, &constants))
                    .collect()
            })
            .clone()
    }
}

#[cfg(test)]
mod tests {
    /// The prelude's `γ(n)` constants are tb-core's, bit for bit (the triangle tests' error
    /// bounds on the GPU equal the CPU's).
    #[test]
    fn prelude_gammas_are_the_cpus() {
        for n in [2u8, 3, 5, 9] {
            let decl = format!("const GAMMA{n}: f32 = {:e};", tb_core::tri::gamma(n as f32));
            assert!(
                super::COMMON.contains(&decl),
                "prelude.wgsl must declare `{decl}`"
            );
        }
    }
}
