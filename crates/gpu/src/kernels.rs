//! Shader modules, bind group layouts and pipeline variants of the programs structures hand
//! over, each made on first use and cached (by program name; layouts by buffer count;
//! pipelines by program, query, triangle test and counting).

use crate::{GpuError, WORKGROUP};
use std::collections::HashMap;
use std::sync::Mutex;
use tb_core::stats::wgsl_stats_struct;
use tb_core::{GpuProgram, Query, TriTestKind};

const COMMON: &str = include_str!("../shaders/common.wgsl");
const EDGE_F64: &str = include_str!("../shaders/edge_f64.wgsl");
const EDGE_F32: &str = include_str!("../shaders/edge_f32.wgsl");

/// Bindings of the prelude (rays, hits, stats, triangles, meta); a program's buffers follow.
pub(crate) const COMMON_BINDINGS: u32 = 5;

/// What is compiled of one program: its shader module and what it was compiled with, so that
/// a second program of the same name but other code is refused rather than run with the
/// first one's pipelines.
struct Module {
    module: wgpu::ShaderModule,
    source: &'static str,
    stack_size: u32,
    constants: Vec<(&'static str, f64)>,
}

/// A pipeline variant: program name, query, triangle test, counting (else timed).
type Variant = (&'static str, Query, TriTestKind, bool);

#[derive(Default)]
struct Cache {
    /// Shader modules by program name.
    modules: HashMap<&'static str, Module>,
    /// Bind group and pipeline layouts by the number of the program's own buffers.
    layouts: HashMap<usize, (wgpu::BindGroupLayout, wgpu::PipelineLayout)>,
    pipelines: HashMap<Variant, wgpu::ComputePipeline>,
}

/// The device's compiled programs; every entry is made on first use.
pub(crate) struct Kernels {
    /// Whether the watertight test's fallback runs in f64 (`SHADER_F64`).
    f64: bool,
    cache: Mutex<Cache>,
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

/// The layouts of a program with `n` buffers of its own: the common bindings 0–4, then `n`
/// read-only storage buffers at 5, 6, ….
fn layout(device: &wgpu::Device, n: usize) -> (wgpu::BindGroupLayout, wgpu::PipelineLayout) {
    let mut entries = vec![
        storage(0, true),
        storage(1, false),
        storage(2, false),
        storage(3, true),
        wgpu::BindGroupLayoutEntry {
            binding: 4,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        },
    ];
    entries.extend((0..n as u32).map(|k| storage(COMMON_BINDINGS + k, true)));
    let bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &entries,
    });
    let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &[Some(&bgl)],
        immediate_size: 0,
    });
    (bgl, pl)
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
    /// prelude, the edge fallback, the program's source.
    fn source(&self, p: &GpuProgram<'_>) -> String {
        let edge = if self.f64 { EDGE_F64 } else { EDGE_F32 };
        format!(
            "const STACK_SIZE: u32 = {}u;\nconst WORKGROUP_SIZE: u32 = {WORKGROUP}u;\n{}{COMMON}\n{edge}\n{}",
            p.stack_size,
            wgsl_stats_struct(),
            p.source
        )
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
        cache
            .layouts
            .entry(p.buffers.len())
            .or_insert_with(|| layout(device, p.buffers.len()));
        if let Some(m) = cache.modules.get(p.name) {
            if m.source != p.source || m.stack_size != p.stack_size || m.constants != p.constants {
                return Err(GpuError::Program(format!(
                    "GPU program `{}`: another program of that name (other source, stack size or constants) was compiled before; names must be unique",
                    p.name
                )));
            }
            return Ok(());
        }
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(p.name),
            source: wgpu::ShaderSource::Wgsl(self.source(p).into()),
        });
        check().map_err(|e| match e {
            GpuError::Wgpu(m) => GpuError::Program(format!("GPU program `{}`: {m}", p.name)),
            e => e,
        })?;
        cache.modules.insert(
            p.name,
            Module {
                module,
                source: p.source,
                stack_size: p.stack_size,
                constants: p.constants.clone(),
            },
        );
        Ok(())
    }

    /// The pipeline of variant `v` (made on first use) and the bind group layout of a program
    /// with `n` buffers. The program must have been prepared ([`Gpu::upload`]).
    pub(crate) fn pipeline(
        &self,
        device: &wgpu::Device,
        v: Variant,
        n: usize,
    ) -> (wgpu::ComputePipeline, wgpu::BindGroupLayout) {
        let mut cache = self.cache();
        let Cache {
            modules,
            layouts,
            pipelines,
        } = &mut *cache;
        let (bgl, pl) = &layouts[&n];
        let pipeline = pipelines
            .entry(v)
            .or_insert_with(|| {
                let (name, query, tri, count) = v;
                let m = &modules[name];
                let flag = |b: bool| if b { 1.0 } else { 0.0 };
                let mut constants = vec![
                    ("ANY", flag(query == Query::Any)),
                    ("COUNT", flag(count)),
                    ("WATERTIGHT", flag(tri == TriTestKind::Watertight)),
                    ("EXIT_SCALE", tb_core::slab::EXIT_SCALE as f64),
                ];
                constants.extend(m.constants.iter().copied());
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(name),
                    layout: Some(pl),
                    module: &m.module,
                    entry_point: Some("main"),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &constants,
                        zero_initialize_workgroup_memory: false,
                    },
                    cache: None,
                })
            })
            .clone();
        (pipeline, bgl.clone())
    }
}
