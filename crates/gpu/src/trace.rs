//! Uploads of a structure's program and of ray batches, dispatch (split by the adapter's
//! limits), the sort passes of programs with a ray key, timing and readback.

use crate::device::Gpu;
use crate::kernels::{shape, Layouts, Shape, COMMON_BINDINGS};
use crate::persistent::Pool;
use crate::{one_line, GpuError, STATS_BYTES, WORKGROUP};
use bytemuck::{Pod, Zeroable};
use std::sync::{mpsc, Mutex};
use std::time::Instant;
use tb_core::{
    GpuArrange, GpuProgram, HitRecord, Query, Ray, TraversalStats, TriTestKind, N_COUNTERS,
};

const RAY_BYTES: u64 = 32;
const HIT_BYTES: u64 = 16;
/// The largest per-ray record (so it bounds the rays per dispatch).
const RECORD_BYTES: u64 = max(RAY_BYTES, max(HIT_BYTES, STATS_BYTES));
/// Dispatch sizes are multiples of this many rays, so every per-dispatch buffer offset is a
/// multiple of 256 bytes (the largest `min_storage_buffer_offset_alignment` WebGPU allows).
const RAY_ALIGN: u64 = 256;

const fn max(a: u64, b: u64) -> u64 {
    if a > b {
        a
    } else {
        b
    }
}

/// A structure's program resident on the GPU: its triangles, buffers and meta words, and the
/// name of the shader module that traces them ([`Gpu::upload`]).
pub struct GpuStructure {
    program: &'static str,
    arrange: Option<GpuArrange>,
    tris: wgpu::Buffer,
    /// Its buffers' number and uniform ones, and whether it is persistent ([`Shape`]).
    shape: Shape,
    /// Why its counters are its own ([`GpuProgram::own_counts`]).
    own_counts: Option<&'static str>,
    buffers: Vec<wgpu::Buffer>,
    meta: wgpu::Buffer,
    /// Host-to-device copy of the arrays, ms (buffer creation, write, wait).
    pub upload_ms: f64,
    /// Bytes uploaded (triangles and the program's buffers).
    pub bytes: u64,
}

impl GpuStructure {
    /// The name of the program it was uploaded for ([`GpuProgram::name`]).
    pub fn program(&self) -> &'static str {
        self.program
    }

    /// The program's ray arrangement ([`GpuProgram::arrange`]).
    pub fn arrange(&self) -> Option<GpuArrange> {
        self.arrange
    }

    /// Why the program's counters are its own, not the CPU's ray for ray
    /// ([`GpuProgram::own_counts`]).
    pub fn own_counts(&self) -> Option<&'static str> {
        self.own_counts
    }
}

/// A ray batch resident on the GPU with its hit and counter buffers.
pub struct GpuRays {
    n: u64,
    rays: wgpu::Buffer,
    hits: wgpu::Buffer,
    stats: wgpu::Buffer,
    /// The histograms and permutations of the last sorted trace (made on first use).
    arranged: Mutex<Option<Arranged>>,
    /// Host-to-device copy of the rays, ms.
    pub upload_ms: f64,
}

/// The arrangement buffer of a batch: per dispatch, a region of `shaders/arrange.wgsl`'s
/// layout (the `keys x workgroups` counts padded to 64 words, then the permutation).
struct Arranged {
    keys: u32,
    /// Dispatches as (first ray, rays).
    chunks: Vec<(u64, u64)>,
    /// Each dispatch's region as (byte offset, words of counts before the permutation).
    regions: Vec<(u64, u64)>,
    buffer: wgpu::Buffer,
}

/// Words before the permutation in a dispatch of `len` rays sorted by `keys` keys: the
/// `keys x workgroups` counts, padded to 64 words (as `tb_perm_base` in `arrange.wgsl`).
fn count_words(keys: u32, len: u64) -> u64 {
    (keys as u64 * len.div_ceil(WORKGROUP as u64)).next_multiple_of(64)
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
    /// For a program with a ray key ([`GpuProgram::arrange`]): the sort passes' time, ms,
    /// measured as `kernel_ms` but around their own compute pass (submitted before the
    /// trace's); not part of `kernel_ms`.
    pub sort_ms: Option<f64>,
    /// Whether `kernel_ms` comes from timestamps.
    pub timestamps: bool,
    /// Dispatches the batch was split into.
    pub dispatches: u32,
    /// Untimed passes run before the timed one: 1 for a pipeline variant's first trace (the
    /// driver may compile at the first dispatch), else 0.
    pub warm_up_passes: u32,
    /// Passes over the batch in the timed sample, back to back in one compute pass
    /// (`kernel_ms` is their time divided by this): see [`MIN_SAMPLE_MS`].
    pub passes: u32,
}

/// A timed trace ([`Gpu::trace`] of the timed variant) is a sample of back-to-back passes over
/// the batch in one compute pass, as many as make it last at least this long (measured by a
/// first, untimed pass; at most [`MAX_PASSES`]; [`Gpu::set_timed_sample`]), so that short
/// batches time the GPU at a steady state rather than one launch between host work (timed one
/// launch at a time, the same SBVH pass took 0.34 ms and 1.8 ms in one run). Repeated passes
/// write the same hits.
pub const MIN_SAMPLE_MS: f64 = 20.0;

/// The most passes in one timed sample.
pub const MAX_PASSES: u32 = 1000;

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

/// One [`TraversalStats`] record as the kernels write it ([`TraversalStats::from_words`]).
type StatsWords = [u32; N_COUNTERS + 1];

const _: () = assert!(std::mem::size_of::<GpuRay>() == std::mem::size_of::<Ray>());
const _: () = assert!(std::mem::size_of::<GpuHit>() == std::mem::size_of::<HitRecord>());
const _: () = assert!(std::mem::size_of::<StatsWords>() as u64 == STATS_BYTES);

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
        let by_binding = self.limits.max_storage_buffer_binding_size / RECORD_BYTES;
        let by_groups = self.limits.max_compute_workgroups_per_dimension as u64 * WORKGROUP as u64;
        let cap = self.dispatch_cap.unwrap_or(u64::MAX);
        (by_binding.min(by_groups).min(cap) / RAY_ALIGN * RAY_ALIGN).max(RAY_ALIGN)
    }

    /// A timed sample's least duration (ms) and most passes ([`MIN_SAMPLE_MS`] and
    /// [`MAX_PASSES`] by default; `max_passes` 1 times single passes): tests exercise the
    /// sample without waiting for it.
    pub fn set_timed_sample(&mut self, min_ms: f64, max_passes: u32) {
        self.sample = (min_ms, max_passes.max(1));
    }

    /// Cap the rays per dispatch further (rounded down to a multiple of 256, at least 256):
    /// shorter dispatches stay under a driver's watchdog, and tests exercise the split.
    pub fn limit_dispatch(&mut self, rays: u64) {
        self.dispatch_cap = Some(rays);
    }

    /// Lower `max_storage_buffer_binding_size` as this device sees it to `bytes` (never
    /// raising it): [`Gpu::upload`] then refuses arrays over `bytes` as it refuses those over
    /// the adapter's limit, and batches are split to match, so tests exercise both paths
    /// without scenes of hundreds of MiB.
    pub fn limit_binding(&mut self, bytes: u64) {
        let l = &mut self.limits.max_storage_buffer_binding_size;
        *l = (*l).min(bytes);
    }

    /// Act as an adapter without `SHADER_F64` from now on (tests of the refusal and of the
    /// f32 fallback on adapters that have it): programs that need `f64` are refused, and the
    /// watertight test's fallback of programs compiled from now on runs in f32.
    pub fn forgo_f64(&mut self) {
        self.summary.f64 = false;
        self.kernels = crate::kernels::Kernels::new(false);
    }

    /// The adapter's `max_storage_buffer_binding_size` (after [`Gpu::limit_binding`]): the
    /// largest array a program may bind.
    pub fn max_binding(&self) -> u64 {
        self.limits.max_storage_buffer_binding_size
    }

    pub(crate) fn fits(
        &self,
        what: &'static str,
        bytes: u64,
        binding: bool,
    ) -> Result<(), GpuError> {
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

    /// Upload a structure's GPU program ([`tb_core::Accel::gpu_program`]): its triangles
    /// (three `vec4<f32>` each, one per vertex), its buffers and the `meta_` uniform `(triangles, meta[0..3])`, after
    /// compiling its shader module if this is the first program of that name (timed: buffer
    /// creation, copy, wait; compiling is not).
    ///
    /// `Err`: [`GpuError::TooLarge`] for an array over one storage binding (named by
    /// [`tb_core::GpuBuffer::what`]); [`GpuError::Unsupported`] for more buffers than the
    /// adapter binds, a program with an unrolled triangle loop over too many triangles for
    /// llvmpipe, or a program that computes in `f64` ([`GpuProgram::needs_f64`]) on an adapter
    /// without `SHADER_F64`; [`GpuError::Program`] for a malformed program (a buffer that is not whole
    /// 4-byte words, a name reused with other code, WGSL that does not compile).
    pub fn upload(&self, p: &GpuProgram<'_>) -> Result<GpuStructure, GpuError> {
        self.admit(p)?;
        let n_tris = p.triangles.len() as u64;
        let flat: Vec<f32> = p
            .triangles
            .iter()
            .flat_map(|t| [t.v0, t.v1, t.v2])
            .flat_map(|v| [v.x, v.y, v.z, 0.0])
            .collect();
        let tri_bytes: &[u8] = bytemuck::cast_slice(&flat);
        self.kernels.prepare(&self.device, p, || self.check())?;
        let [m0, m1, m2] = p.meta;
        let meta = [n_tris as u32, m0, m1, m2];
        let storage = wgpu::BufferUsages::STORAGE;
        let start = Instant::now();
        let tris = self.buffer("triangles", tri_bytes, storage);
        let buffers = p
            .buffers
            .iter()
            .map(|b| {
                let usage = if b.uniform {
                    wgpu::BufferUsages::UNIFORM
                } else {
                    storage
                };
                self.buffer(b.what, &b.bytes, usage)
            })
            .collect();
        let meta = self.buffer(
            "meta",
            bytemuck::cast_slice(&meta),
            wgpu::BufferUsages::UNIFORM,
        );
        self.queue.submit([]);
        self.wait()?;
        Ok(GpuStructure {
            program: p.name,
            arrange: p.arrange,
            tris,
            shape: shape(p),
            own_counts: p.own_counts,
            buffers,
            meta,
            upload_ms: start.elapsed().as_secs_f64() * 1e3,
            bytes: tri_bytes.len() as u64
                + p.buffers.iter().map(|b| b.bytes.len() as u64).sum::<u64>(),
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
            arranged: Mutex::new(None),
            upload_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// The dispatches of a batch of `n` rays, as (first ray, rays).
    fn chunks(&self, n: u64) -> Vec<(u64, u64)> {
        let step = self.max_rays_per_dispatch();
        (0..n.div_ceil(step))
            .map(|c| (c * step, step.min(n - c * step)))
            .collect()
    }

    /// One pass of the structure's program over the batch: `count` picks the counting variant
    /// (writes per-ray [`TraversalStats`]) or the timed one (no counters). A program with a ray
    /// key ([`GpuProgram::arrange`]) first sorts each dispatch's rays by key in its own compute
    /// pass, timed on its own ([`Timing::sort_ms`]), then traces them in that order, each
    /// ray's hit and counters written at its own index.
    ///
    /// The first pass of a pipeline variant (program, query, triangle test, counting) runs
    /// twice and returns the second's times: a driver may compile the shader at its first
    /// dispatch (a first batch took 567 ms against 0.8 ms for the next, once measured), which is
    /// no part of a trace's time, whatever warm-up the caller asked for.
    ///
    /// The timed variant (`count == false`) then times a sample of back-to-back passes lasting
    /// at least [`MIN_SAMPLE_MS`] ([`Timing::passes`]); the first pass, untimed, measures
    /// how many that takes.
    pub fn trace(
        &self,
        s: &GpuStructure,
        rays: &GpuRays,
        query: Query,
        tri: TriTestKind,
        count: bool,
    ) -> Result<Timing, GpuError> {
        self.trace_sample(s, rays, query, tri, count, !count)
    }

    /// One untimed pass of the timed variant (its hits, for validation, when the timed
    /// sample is taken elsewhere, e.g. interleaved with other rows' samples).
    pub fn trace_untimed(
        &self,
        s: &GpuStructure,
        rays: &GpuRays,
        query: Query,
        tri: TriTestKind,
    ) -> Result<Timing, GpuError> {
        self.trace_sample(s, rays, query, tri, false, false)
    }

    /// [`Gpu::trace`], with a sustained sample where `sustain`.
    fn trace_sample(
        &self,
        s: &GpuStructure,
        rays: &GpuRays,
        query: Query,
        tri: TriTestKind,
        count: bool,
        sustain: bool,
    ) -> Result<Timing, GpuError> {
        let (pipeline, layouts, fresh) = self.kernels.pipeline(
            &self.device,
            (s.program, query, tri, count),
            s.shape,
            s.arrange.is_some(),
        );
        if fresh {
            self.trace_pass(s, rays, &pipeline, &layouts, 1)?;
        }
        let mut t = self.trace_pass(s, rays, &pipeline, &layouts, 1)?;
        let mut warm_up = fresh as u32;
        let (min_ms, max_passes) = self.sample;
        if sustain && t.kernel_ms < min_ms && max_passes > 1 {
            let passes = (min_ms / t.kernel_ms.max(1e-4)).ceil();
            let passes = passes.min(max_passes as f64) as u32;
            t = self.trace_pass(s, rays, &pipeline, &layouts, passes)?;
            warm_up += 1;
        }
        Ok(Timing {
            warm_up_passes: warm_up,
            ..t
        })
    }

    /// `passes` back-to-back passes of [`Gpu::trace`] with its pipeline made, in one compute
    /// pass (the sort, where the program has one, once before them): `kernel_ms` per pass.
    fn trace_pass(
        &self,
        s: &GpuStructure,
        rays: &GpuRays,
        pipeline: &wgpu::ComputePipeline,
        layouts: &Layouts,
        passes: u32,
    ) -> Result<Timing, GpuError> {
        let chunks = self.chunks(rays.n);
        let pool = s.shape.2.then(|| Pool::new(self, chunks.len()));
        let groups: Vec<wgpu::BindGroup> = chunks
            .iter()
            .enumerate()
            .map(|(c, &(first, len))| {
                let counter = pool.as_ref().map(|p| p.counter(c));
                self.bind_group(s, rays, layouts, first, len, counter)
            })
            .collect();
        // Workgroups of a chunk's dispatch: one thread per ray, or the persistent pool.
        let workgroups = |len: u64| match &pool {
            Some(p) => p.workgroups(len),
            None => len.div_ceil(WORKGROUP as u64) as u32,
        };
        let sort = match s.arrange {
            Some(a) => {
                let g1 = self.arrangement(a, rays, layouts, &chunks)?;
                let passes = self
                    .kernels
                    .sort_pipelines(&self.device, s.program, s.shape);
                let (ms, _) = self.timed_pass(|pass| {
                    for (((_, len), g0), g1) in chunks.iter().zip(&groups).zip(&g1) {
                        let wgs = len.div_ceil(WORKGROUP as u64) as u32;
                        pass.set_bind_group(0, g0, &[]);
                        pass.set_bind_group(1, g1, &[]);
                        // Histograms, the scan (one workgroup), the scatter.
                        for (p, n) in passes.iter().zip([wgs, 1, wgs]) {
                            pass.set_pipeline(p);
                            pass.dispatch_workgroups(n, 1, 1);
                        }
                    }
                })?;
                Some((g1, ms))
            }
            None => None,
        };
        let mut passes = passes.max(1);
        if let Some(p) = &pool {
            passes = p.most_passes(passes, &chunks);
        }
        let (kernel_ms, timestamps) = self.timed_pass(|pass| {
            pass.set_pipeline(pipeline);
            for _ in 0..passes {
                for (c, ((_, len), g0)) in chunks.iter().zip(&groups).enumerate() {
                    pass.set_bind_group(0, g0, &[]);
                    if let Some((g1, _)) = &sort {
                        pass.set_bind_group(1, &g1[c], &[]);
                    }
                    pass.dispatch_workgroups(workgroups(*len), 1, 1);
                }
            }
        })?;
        Ok(Timing {
            kernel_ms: kernel_ms / passes as f64,
            sort_ms: sort.map(|(_, ms)| ms),
            timestamps,
            dispatches: chunks.len() as u32,
            warm_up_passes: 0,
            passes,
        })
    }

    /// The group-0 bind group of the dispatch of rays `first .. first + len` (with a
    /// persistent program's fetch counter: its buffer and offset).
    fn bind_group(
        &self,
        s: &GpuStructure,
        rays: &GpuRays,
        layouts: &Layouts,
        first: u64,
        len: u64,
        counter: Option<(&wgpu::Buffer, u64)>,
    ) -> wgpu::BindGroup {
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
        entries.extend((COMMON_BINDINGS..).zip(&s.buffers).map(|(binding, b)| {
            wgpu::BindGroupEntry {
                binding,
                resource: b.as_entire_binding(),
            }
        }));
        if let Some((buffer, offset)) = counter {
            entries.push(wgpu::BindGroupEntry {
                binding: COMMON_BINDINGS + s.buffers.len() as u32,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer,
                    offset,
                    size: wgpu::BufferSize::new(4),
                }),
            });
        }
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &layouts.group0,
            entries: &entries,
        })
    }

    /// The group-1 bind groups (one per dispatch of `chunks`) of the batch's arrangement
    /// buffer for `a.keys` keys, the buffer made when the batch has none of that shape.
    fn arrangement(
        &self,
        a: GpuArrange,
        rays: &GpuRays,
        layouts: &Layouts,
        chunks: &[(u64, u64)],
    ) -> Result<Vec<wgpu::BindGroup>, GpuError> {
        let mut slot = rays.arranged.lock().unwrap_or_else(|p| p.into_inner());
        if slot
            .as_ref()
            .is_none_or(|x| x.keys != a.keys || x.chunks != chunks)
        {
            // Every region but the last is a multiple of 64 words (its ray count is a
            // multiple of 256), so every region starts 256-byte aligned.
            let mut regions = Vec::with_capacity(chunks.len());
            let mut bytes = 0;
            for &(_, len) in chunks {
                let counts = count_words(a.keys, len);
                regions.push((bytes, counts));
                bytes += 4 * (counts + len);
            }
            self.fits("the ray arrangement", bytes, false)?;
            let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("arrangement"),
                size: bytes.max(64),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            *slot = Some(Arranged {
                keys: a.keys,
                chunks: chunks.to_vec(),
                regions,
                buffer,
            });
        }
        let arr = slot.as_ref().expect("made above");
        let g1 = layouts
            .group1
            .as_ref()
            .expect("a program that sorts its rays has group 1");
        Ok(chunks
            .iter()
            .zip(&arr.regions)
            .map(|(&(_, len), &(offset, counts))| {
                self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: None,
                    layout: g1,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &arr.buffer,
                            offset,
                            size: wgpu::BufferSize::new(4 * (counts + len)),
                        }),
                    }],
                })
            })
            .collect())
    }

    /// Submit one compute pass (what `encode` records) and wait: its time in ms, from GPU
    /// timestamps around the pass where the adapter has them (`true`), else the wall time
    /// from submit to the end of the wait.
    pub(crate) fn timed_pass(
        &self,
        encode: impl FnOnce(&mut wgpu::ComputePass<'_>),
    ) -> Result<(f64, bool), GpuError> {
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
            encode(&mut pass);
        }
        if let Some((set, resolve, read)) = &ts {
            enc.resolve_query_set(set, 0..2, resolve, 0);
            enc.copy_buffer_to_buffer(resolve, 0, read, 0, 16);
        }
        let start = Instant::now();
        self.queue.submit([enc.finish()]);
        self.wait()?;
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(match &ts {
            Some((_, _, read)) => {
                let t: Vec<u64> = self.map_read(read, 16)?;
                let ticks = t[1].saturating_sub(t[0]) as f64;
                (
                    ticks * self.queue.get_timestamp_period() as f64 * 1e-6,
                    true,
                )
            }
            None => (wall_ms, false),
        })
    }

    /// The order of the last trace over `rays` by a program with a ray key: entry `p` is the
    /// index in the batch of the ray traced `p`-th (dispatch by dispatch, each sorted stably
    /// by key). `Err` when no such trace ran over `rays`.
    pub fn read_order(&self, rays: &GpuRays) -> Result<Vec<u32>, GpuError> {
        let slot = rays.arranged.lock().unwrap_or_else(|p| p.into_inner());
        let Some(a) = slot.as_ref() else {
            return Err(GpuError::Program(
                "no program with a ray key has traced this batch".into(),
            ));
        };
        let (words, _): (Vec<u32>, f64) = self.read_back(&a.buffer, a.buffer.size())?;
        let mut order = Vec::with_capacity(rays.n as usize);
        for (&(first, len), &(offset, counts)) in a.chunks.iter().zip(&a.regions) {
            let base = (offset / 4 + counts) as usize;
            order.extend(
                words[base..base + len as usize]
                    .iter()
                    .map(|&j| j + first as u32),
            );
        }
        Ok(order)
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
        let (s, ms): (Vec<StatsWords>, f64) = self.read_back(&rays.stats, rays.n * STATS_BYTES)?;
        Ok((s.iter().map(TraversalStats::from_words).collect(), ms))
    }

    /// Upload, trace (one pass, counting when `count`; no sustained sample), read back: the
    /// whole round trip for tests and one-off queries. Returns the hits and, when counting, the counters.
    pub fn trace_once(
        &self,
        s: &GpuStructure,
        rays: &[Ray],
        query: Query,
        tri: TriTestKind,
        count: bool,
    ) -> Result<(Vec<HitRecord>, Option<Vec<TraversalStats>>), GpuError> {
        let r = self.upload_rays(rays)?;
        self.trace_sample(s, &r, query, tri, count, false)?;
        let (hits, _) = self.read_hits(&r)?;
        let stats = if count {
            Some(self.read_stats(&r)?.0)
        } else {
            None
        };
        Ok((hits, stats))
    }
}
