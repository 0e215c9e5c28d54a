//! The fixed-work probe, timed beside every row so that a row is flagged when the probe
//! moves: a compute-bound kernel of fixed size (4096 workgroups
//! of 64 invocations, each 128 steps of two dependent FMAs, enough invocations to fill a
//! large GPU), timed as a sample of back-to-back passes like a trace. The number of passes is
//! fixed at the first probe of a device (as many as last [`PROBE_MIN_MS`], at most
//! [`crate::MAX_PASSES`]), so every later probe does the same work: a probe time that moves
//! between rows of one run says the GPU's state (clocks, power, another tenant) moved, not
//! the row's kernel. The runner times it before and after each GPU row.

use crate::{Gpu, GpuError};

/// The least duration of the probe's sample, ms, when its pass count is fixed.
pub const PROBE_MIN_MS: f64 = 2.0;

const WORKGROUPS: u32 = 4096;
const WORKGROUP: u32 = 64;

const SOURCE: &str = r#"
@group(0) @binding(0) var<storage, read_write> sink: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    var x = f32(id.x & 1023u) * 0.001;
    var y = 1.0 - x;
    for (var i = 0u; i < 128u; i++) {
        x = fma(x, 0.9999, y);
        y = fma(y, 0.9998, 0.0001);
    }
    sink[id.x] = x + y;
}
"#;

/// The probe's pipeline, bind group and fixed pass count, made at the first probe.
pub(crate) struct Probe {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    passes: u32,
}

impl Gpu {
    /// Time the fixed-work probe: ms per pass (module doc). The first call compiles it,
    /// warms it up and fixes its pass count.
    pub fn probe_ms(&self) -> Result<f64, GpuError> {
        let mut slot = self.probe.lock().unwrap_or_else(|p| p.into_inner());
        if slot.is_none() {
            let mut p = self.make_probe()?;
            self.probe_pass(&p)?;
            let one = self.probe_pass(&p)?;
            p.passes = ((PROBE_MIN_MS / one.max(1e-4)).ceil() as u32).clamp(1, crate::MAX_PASSES);
            *slot = Some(p);
        }
        let p = slot.as_ref().expect("made above");
        Ok(self.probe_pass(p)? / p.passes as f64)
    }

    /// The probe's fixed pass count (1 before the first probe).
    pub fn probe_passes(&self) -> u32 {
        let slot = self.probe.lock().unwrap_or_else(|p| p.into_inner());
        slot.as_ref().map_or(1, |p| p.passes)
    }

    fn probe_pass(&self, p: &Probe) -> Result<f64, GpuError> {
        let (ms, _) = self.timed_pass(|pass| {
            pass.set_pipeline(&p.pipeline);
            pass.set_bind_group(0, &p.group, &[]);
            for _ in 0..p.passes {
                pass.dispatch_workgroups(WORKGROUPS, 1, 1);
            }
        })?;
        Ok(ms)
    }

    fn make_probe(&self) -> Result<Probe, GpuError> {
        let d = &self.device;
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("probe"),
            source: wgpu::ShaderSource::Wgsl(SOURCE.into()),
        });
        let sink = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("probe sink"),
            size: (WORKGROUPS * WORKGROUP) as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("probe"),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("probe"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: sink.as_entire_binding(),
            }],
        });
        self.check()?;
        Ok(Probe {
            pipeline,
            group,
            passes: 1,
        })
    }
}
