//! Shader modules, pipeline variants, uploads, dispatch and readback.

use crate::device::{one_line, Gpu};
use crate::{GpuError, STATS_BYTES, WORKGROUP};
use bytemuck::{Pod, Zeroable};
use std::collections::HashMap;
use std::sync::{mpsc, Mutex};
use std::time::Instant;
use tb_bvh::Bvh;
use tb_core::{HitRecord, Query, Ray, TraversalStats, TriTestKind, Triangle};

const COMMON: &str = include_str!("../shaders/common.wgsl");
const EDGE_F64: &str = include_str!("../shaders/edge_f64.wgsl");
const EDGE_F32: &str = include_str!("../shaders/edge_f32.wgsl");
const BRUTE: &str = include_str!("../shaders/brute.wgsl");
const BVH: &str = include_str!("../shaders/bvh.wgsl");

/// Bytes of one ray, the largest per-ray record (so it bounds the rays per dispatch).
const RAY_BYTES: u64 = 32;
const HIT_BYTES: u64 = 16;
/// Dispatch sizes are multiples of this many rays, so every per-dispatch buffer offset is a
/// multiple of 256 bytes (the largest `min_storage_buffer_offset_alignment` WebGPU allows).
const RAY_ALIGN: u64 = 256;
/// Triangles brute force handles on llvmpipe: its loop unrolled 8 times (brute.wgsl), under
/// llvmpipe's limit of 65535 loop iterations per invocation.
const LLVMPIPE_BRUTE_MAX: u64 = 8 * 65_000;

/// A structure to upload: which kernel traces it, and its flat arrays.
#[derive(Clone, Copy)]
pub enum Structure<'a> {
    /// Brute force over the scene's triangles (tb_core::BruteForce, the oracle).
    BruteForce(&'a [Triangle]),
    /// The BVH's nodes, leaf-ordered triangles and primitive ids (traversal `ordered`).
    Bvh(&'a Bvh),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Kind {
    Brute,
    Bvh,
}

/// A structure resident on the GPU.
pub struct GpuStructure {
    kind: Kind,
    tris: wgpu::Buffer,
    nodes: Option<wgpu::Buffer>,
    prim_ids: Option<wgpu::Buffer>,
    meta: wgpu::Buffer,
    /// Host-to-device copy of the arrays, ms (buffer creation, write, wait).
    pub upload_ms: f64,
    /// Bytes uploaded.
    pub bytes: u64,
}

/// A ray batch resident on the GPU with its hit and counter buffers.
pub struct GpuRays {
    n: u64,
    rays: wgpu::Buffer,
    hits: wgpu::Buffer,
    stats: wgpu::Buffer,
    /// Host-to-device copy of the rays, ms.
    pub upload_ms: f64,
}

impl GpuRays {
    /// Rays in the batch.
    pub fn len(&self) -> usize {
        self.n as usize
    }

    /// Whether the batch is empty.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }
}

/// Duration of one pass of a kernel over a batch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// Kernel time, ms: GPU timestamps around the compute pass where the adapter has
    /// `TIMESTAMP_QUERY`, else wall time from submit to the end of the wait.
    pub kernel_ms: f64,
    /// Whether `kernel_ms` comes from timestamps.
    pub timestamps: bool,
    /// Dispatches the batch was split into.
    pub dispatches: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuRay([f32; 8]);

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuHit {
    t: f32,
    prim: u32,
    u: f32,
    v: f32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuStats([u32; 8]);

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuNode {
    min: [f32; 3],
    index: u32,
    max: [f32; 3],
    count: u32,
}

const _: () = assert!(std::mem::size_of::<GpuRay>() == std::mem::size_of::<Ray>());
const _: () = assert!(std::mem::size_of::<GpuHit>() == std::mem::size_of::<HitRecord>());
const _: () = assert!(std::mem::size_of::<GpuStats>() == std::mem::size_of::<TraversalStats>());
const _: () = assert!(std::mem::size_of::<GpuNode>() == std::mem::size_of::<tb_bvh::BvhNode>());

type Variant = (Kind, Query, TriTestKind, bool);

/// Shader modules, layouts and the pipelines made so far (one per variant, on first use).
pub(crate) struct Kernels {
    brute: wgpu::ShaderModule,
    bvh: wgpu::ShaderModule,
    brute_layout: (wgpu::BindGroupLayout, wgpu::PipelineLayout),
    bvh_layout: (wgpu::BindGroupLayout, wgpu::PipelineLayout),
    pipelines: Mutex<HashMap<Variant, wgpu::ComputePipeline>>,
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

fn layout(device: &wgpu::Device, bvh: bool) -> (wgpu::BindGroupLayout, wgpu::PipelineLayout) {
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
    if bvh {
        entries.push(storage(5, true));
        entries.push(storage(6, true));
    }
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
    pub(crate) fn new(device: &wgpu::Device, f64: bool) -> Kernels {
        let header = format!("const STACK_SIZE: u32 = {}u;\n", tb_bvh::STACK_SIZE);
        let edge = if f64 { EDGE_F64 } else { EDGE_F32 };
        let module = |label: &str, body: &str| {
            let src = format!("{header}{COMMON}\n{edge}\n{body}");
            device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(src.into()),
            })
        };
        Kernels {
            brute: module("brute.wgsl", BRUTE),
            bvh: module("bvh.wgsl", BVH),
            brute_layout: layout(device, false),
            bvh_layout: layout(device, true),
            pipelines: Mutex::new(HashMap::new()),
        }
    }

    fn pipeline(&self, device: &wgpu::Device, v: Variant) -> wgpu::ComputePipeline {
        let mut cache = self.pipelines.lock().unwrap_or_else(|p| p.into_inner());
        cache
            .entry(v)
            .or_insert_with(|| {
                let (kind, query, tri, count) = v;
                let (module, layout) = match kind {
                    Kind::Brute => (&self.brute, &self.brute_layout.1),
                    Kind::Bvh => (&self.bvh, &self.bvh_layout.1),
                };
                let flag = |b: bool| if b { 1.0 } else { 0.0 };
                let constants = [
                    ("ANY", flag(query == Query::Any)),
                    ("COUNT", flag(count)),
                    ("WATERTIGHT", flag(tri == TriTestKind::Watertight)),
                    ("EXIT_SCALE", tb_core::slab::EXIT_SCALE as f64),
                ];
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: None,
                    layout: Some(layout),
                    module,
                    entry_point: Some("main"),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &constants,
                        zero_initialize_workgroup_memory: false,
                    },
                    cache: None,
                })
            })
            .clone()
    }
}

/// The records `first .. first + len` of a per-ray buffer with records of `stride` bytes.
fn range(buf: &wgpu::Buffer, first: u64, len: u64, stride: u64) -> wgpu::BindingResource<'_> {
    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
        buffer: buf,
        offset: first * stride,
        size: wgpu::BufferSize::new(len * stride),
    })
}

impl Gpu {
    /// Rays per dispatch: bounded by `max_storage_buffer_binding_size` (per bound ray range) and
    /// `max_compute_workgroups_per_dimension` x [`WORKGROUP`], a multiple of 256.
    pub fn max_rays_per_dispatch(&self) -> u64 {
        let by_binding = self.limits.max_storage_buffer_binding_size / RAY_BYTES;
        let by_groups = self.limits.max_compute_workgroups_per_dimension as u64 * WORKGROUP as u64;
        let cap = self.dispatch_cap.unwrap_or(u64::MAX);
        (by_binding.min(by_groups).min(cap) / RAY_ALIGN * RAY_ALIGN).max(RAY_ALIGN)
    }

    /// Cap the rays per dispatch further (rounded down to a multiple of 256, at least 256):
    /// shorter dispatches stay under a driver's watchdog, and tests exercise the split.
    pub fn limit_dispatch(&mut self, rays: u64) {
        self.dispatch_cap = Some(rays);
    }

    fn fits(&self, what: &'static str, bytes: u64, binding: bool) -> Result<(), GpuError> {
        let l = &self.limits;
        if bytes > l.max_buffer_size || (binding && bytes > l.max_storage_buffer_binding_size) {
            return Err(GpuError::TooLarge {
                what,
                bytes,
                limit: l.max_storage_buffer_binding_size,
                max_buffer: l.max_buffer_size,
            });
        }
        Ok(())
    }

    /// A buffer holding `data` (at least 64 bytes: zero-sized bindings are invalid, and a runtime array binding must hold one element).
    fn buffer(&self, label: &str, data: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        let size = (data.len() as u64).max(64).next_multiple_of(4);
        let buf = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: usage | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        if !data.is_empty() {
            self.queue.write_buffer(&buf, 0, data);
        }
        buf
    }

    /// Copy a structure's flat arrays to the device (timed: buffer creation, copy, wait).
    pub fn upload(&self, s: Structure<'_>) -> Result<GpuStructure, GpuError> {
        let (kind, tris, nodes, prim_ids): (Kind, &[Triangle], Vec<GpuNode>, &[u32]) = match s {
            Structure::BruteForce(t) => (Kind::Brute, t, Vec::new(), &[]),
            Structure::Bvh(b) => (
                Kind::Bvh,
                b.triangles(),
                b.nodes()
                    .iter()
                    .map(|n| GpuNode {
                        min: n.min,
                        index: n.index,
                        max: n.max,
                        count: n.count,
                    })
                    .collect(),
                b.prim_ids(),
            ),
        };
        let flat: Vec<f32> = tris
            .iter()
            .flat_map(|t| [t.v0, t.v1, t.v2])
            .flat_map(|v| v.to_array())
            .collect();
        let tri_bytes: &[u8] = bytemuck::cast_slice(&flat);
        let node_bytes: &[u8] = bytemuck::cast_slice(&nodes);
        let id_bytes: &[u8] = bytemuck::cast_slice(prim_ids);
        if kind == Kind::Brute
            && self.summary.driver.contains("llvmpipe")
            && tris.len() as u64 > LLVMPIPE_BRUTE_MAX
        {
            return Err(GpuError::Unsupported(format!(
                "brute force over {} triangles on llvmpipe: it ends a shader's loops after 65535 iterations, so at most {LLVMPIPE_BRUTE_MAX} triangles",
                tris.len()
            )));
        }
        self.fits("the triangle array", tri_bytes.len() as u64, true)?;
        self.fits("the BVH node array", node_bytes.len() as u64, true)?;
        self.fits("the primitive-id array", id_bytes.len() as u64, true)?;
        let meta = [tris.len() as u32, nodes.len() as u32, 0, 0];
        let storage = wgpu::BufferUsages::STORAGE;
        let start = Instant::now();
        let tris_buf = self.buffer("triangles", tri_bytes, storage);
        let (nodes_buf, ids_buf) = match kind {
            Kind::Brute => (None, None),
            Kind::Bvh => (
                Some(self.buffer("nodes", node_bytes, storage)),
                Some(self.buffer("prim_ids", id_bytes, storage)),
            ),
        };
        let meta_buf = self.buffer(
            "meta",
            bytemuck::cast_slice(&meta),
            wgpu::BufferUsages::UNIFORM,
        );
        self.queue.submit([]);
        self.wait()?;
        Ok(GpuStructure {
            kind,
            tris: tris_buf,
            nodes: nodes_buf,
            prim_ids: ids_buf,
            meta: meta_buf,
            upload_ms: start.elapsed().as_secs_f64() * 1e3,
            bytes: (tri_bytes.len() + node_bytes.len() + id_bytes.len()) as u64,
        })
    }

    /// Copy a ray batch to the device and allocate its hit and counter buffers (timed: the
    /// ray copy and wait).
    pub fn upload_rays(&self, rays: &[Ray]) -> Result<GpuRays, GpuError> {
        let n = rays.len() as u64;
        self.fits("the ray batch", n * RAY_BYTES, false)?;
        self.fits("the counter buffer", n * STATS_BYTES, false)?;
        let data: Vec<GpuRay> = rays
            .iter()
            .map(|r| {
                let (o, d) = (r.origin, r.dir);
                GpuRay([o.x, o.y, o.z, r.tmin, d.x, d.y, d.z, r.tmax])
            })
            .collect();
        let out = |label: &str, bytes: u64| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.max(16),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let hits = out("hits", n * HIT_BYTES);
        let stats = out("stats", n * STATS_BYTES);
        let start = Instant::now();
        let rays_buf = self.buffer(
            "rays",
            bytemuck::cast_slice(&data),
            wgpu::BufferUsages::STORAGE,
        );
        self.queue.submit([]);
        self.wait()?;
        Ok(GpuRays {
            n,
            rays: rays_buf,
            hits,
            stats,
            upload_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// One pass of the structure's kernel over the batch: `count` picks the counting variant
    /// (writes per-ray [`TraversalStats`]) or the timed one (no counters).
    pub fn trace(
        &self,
        s: &GpuStructure,
        rays: &GpuRays,
        query: Query,
        tri: TriTestKind,
        count: bool,
    ) -> Result<Timing, GpuError> {
        let pipeline = self
            .kernels
            .pipeline(&self.device, (s.kind, query, tri, count));
        let bgl = match s.kind {
            Kind::Brute => &self.kernels.brute_layout.0,
            Kind::Bvh => &self.kernels.bvh_layout.0,
        };
        let step = self.max_rays_per_dispatch();
        let mut groups = Vec::new();
        let mut first = 0u64;
        while first < rays.n {
            let len = step.min(rays.n - first);
            let mut entries = vec![
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: range(&rays.rays, first, len, RAY_BYTES),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: range(&rays.hits, first, len, HIT_BYTES),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: range(&rays.stats, first, len, STATS_BYTES),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: s.tris.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: s.meta.as_entire_binding(),
                },
            ];
            if let (Some(nodes), Some(ids)) = (&s.nodes, &s.prim_ids) {
                entries.push(wgpu::BindGroupEntry {
                    binding: 5,
                    resource: nodes.as_entire_binding(),
                });
                entries.push(wgpu::BindGroupEntry {
                    binding: 6,
                    resource: ids.as_entire_binding(),
                });
            }
            let bg = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: bgl,
                entries: &entries,
            });
            groups.push((bg, len.div_ceil(WORKGROUP as u64) as u32));
            first += len;
        }
        let ts = self.summary.timestamps.then(|| {
            let set = self.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: None,
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            });
            let resolve = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: None,
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let read = self.staging(16);
            (set, resolve, read)
        });
        self.check()?;
        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: None,
                timestamp_writes: ts
                    .as_ref()
                    .map(|(set, _, _)| wgpu::ComputePassTimestampWrites {
                        query_set: set,
                        beginning_of_pass_write_index: Some(0),
                        end_of_pass_write_index: Some(1),
                    }),
            });
            pass.set_pipeline(&pipeline);
            for (bg, wgs) in &groups {
                pass.set_bind_group(0, bg, &[]);
                pass.dispatch_workgroups(*wgs, 1, 1);
            }
        }
        if let Some((set, resolve, read)) = &ts {
            enc.resolve_query_set(set, 0..2, resolve, 0);
            enc.copy_buffer_to_buffer(resolve, 0, read, 0, 16);
        }
        let start = Instant::now();
        self.queue.submit([enc.finish()]);
        self.wait()?;
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        let kernel_ms = match &ts {
            Some((_, _, read)) => {
                let t: Vec<u64> = self.map_read(read, 16)?;
                let ticks = t[1].saturating_sub(t[0]) as f64;
                ticks * self.queue.get_timestamp_period() as f64 * 1e-6
            }
            None => wall_ms,
        };
        Ok(Timing {
            kernel_ms,
            timestamps: ts.is_some(),
            dispatches: groups.len() as u32,
        })
    }

    fn staging(&self, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: size.max(16),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Map `buf` (a staging buffer holding `bytes` bytes of results) and copy them out.
    fn map_read<T: Pod>(&self, buf: &wgpu::Buffer, bytes: u64) -> Result<Vec<T>, GpuError> {
        if bytes == 0 {
            return Ok(Vec::new());
        }
        let (tx, rx) = mpsc::channel();
        buf.map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv()
            .map_err(|e| GpuError::Lost(e.to_string()))?
            .map_err(|e| GpuError::Wgpu(one_line(&e.to_string())))?;
        let out = {
            let view = buf
                .get_mapped_range(0..bytes)
                .map_err(|e| GpuError::Wgpu(one_line(&e.to_string())))?;
            bytemuck::pod_collect_to_vec(&view[..])
        };
        buf.unmap();
        Ok(out)
    }

    /// Copy `src`'s first `bytes` bytes back to the host (timed: copy, wait, map).
    fn read_back<T: Pod>(&self, src: &wgpu::Buffer, bytes: u64) -> Result<(Vec<T>, f64), GpuError> {
        let staging = self.staging(bytes);
        let start = Instant::now();
        let mut enc = self.device.create_command_encoder(&Default::default());
        if bytes > 0 {
            enc.copy_buffer_to_buffer(src, 0, &staging, 0, bytes);
        }
        self.queue.submit([enc.finish()]);
        let out = self.map_read(&staging, bytes)?;
        Ok((out, start.elapsed().as_secs_f64() * 1e3))
    }

    /// The hits of the last [`Gpu::trace`] over `rays`, and the readback time in ms.
    pub fn read_hits(&self, rays: &GpuRays) -> Result<(Vec<HitRecord>, f64), GpuError> {
        let (h, ms): (Vec<GpuHit>, f64) = self.read_back(&rays.hits, rays.n * HIT_BYTES)?;
        let hits = h
            .into_iter()
            .map(|h| HitRecord {
                t: h.t,
                prim: h.prim,
                u: h.u,
                v: h.v,
            })
            .collect();
        Ok((hits, ms))
    }

    /// The per-ray counters of the last counting [`Gpu::trace`] over `rays`, and the readback
    /// time in ms.
    pub fn read_stats(&self, rays: &GpuRays) -> Result<(Vec<TraversalStats>, f64), GpuError> {
        let (s, ms): (Vec<GpuStats>, f64) = self.read_back(&rays.stats, rays.n * STATS_BYTES)?;
        let stats = s
            .into_iter()
            .map(|GpuStats(a)| TraversalStats {
                interior: a[0],
                leaves: a[1],
                prims: a[2],
                boxes: a[3],
                planes: a[4],
                restarts: a[5],
                steps: a[6],
                capped: a[7],
            })
            .collect();
        Ok((stats, ms))
    }

    /// Upload, trace (one pass, counting when `count`), read back: the whole round trip for
    /// tests and one-off queries. Returns the hits and, when counting, the counters.
    pub fn trace_once(
        &self,
        s: &GpuStructure,
        rays: &[Ray],
        query: Query,
        tri: TriTestKind,
        count: bool,
    ) -> Result<(Vec<HitRecord>, Option<Vec<TraversalStats>>), GpuError> {
        let r = self.upload_rays(rays)?;
        self.trace(s, &r, query, tri, count)?;
        let (hits, _) = self.read_hits(&r)?;
        let stats = if count {
            Some(self.read_stats(&r)?.0)
        } else {
            None
        };
        Ok((hits, stats))
    }
}
