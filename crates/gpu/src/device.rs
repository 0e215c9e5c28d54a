//! Adapter and device selection, error capture, and blocking waits.

use crate::{one_line, GpuError};
use std::sync::{Arc, Mutex};

/// A wgpu backend the user may ask for (`--backend`, `run.gpu_backend`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Backend {
    /// Vulkan (Linux, Windows, Android; lavapipe is Mesa's software Vulkan).
    Vulkan,
    /// OpenGL / OpenGL ES (EGL on Linux).
    Gl,
    /// Metal (macOS, iOS).
    Metal,
    /// Direct3D 12 (Windows).
    Dx12,
}

impl Backend {
    /// Every backend, in the order `trace-bench` names them.
    pub const ALL: [Backend; 4] = [Backend::Vulkan, Backend::Gl, Backend::Metal, Backend::Dx12];

    /// Config and CLI name: `vulkan`, `gl`, `metal`, `dx12`.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Vulkan => "vulkan",
            Backend::Gl => "gl",
            Backend::Metal => "metal",
            Backend::Dx12 => "dx12",
        }
    }

    /// The backend called `s` (see [`Backend::name`]).
    pub fn from_name(s: &str) -> Option<Backend> {
        Self::ALL.into_iter().find(|b| b.name() == s)
    }

    fn wgpu(self) -> wgpu::Backends {
        match self {
            Backend::Vulkan => wgpu::Backends::VULKAN,
            Backend::Gl => wgpu::Backends::GL,
            Backend::Metal => wgpu::Backends::METAL,
            Backend::Dx12 => wgpu::Backends::DX12,
        }
    }
}

/// Which adapter to use: the first (by [`Gpu::new`]'s preference) whose name contains `name`
/// (case-insensitive), on `backend` or on any native backend.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct AdapterChoice {
    /// Substring of the adapter name (`--adapter`).
    pub name: Option<String>,
    /// Backend (`--backend`); `None` tries Vulkan, Metal and DX12, then GL if they have none.
    pub backend: Option<Backend>,
}

/// What a result row and the run metadata say about the adapter.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterSummary {
    /// Adapter name as the driver reports it (e.g. `llvmpipe (LLVM 15.0.6, 256 bits)`).
    pub name: String,
    /// wgpu backend (`vulkan`, `gl`, …).
    pub backend: String,
    /// Driver name and version (e.g. `llvmpipe Mesa 22.3.6 (LLVM 15.0.6)`).
    pub driver: String,
    /// `DiscreteGpu`, `IntegratedGpu`, `VirtualGpu`, `Cpu` or `Other`.
    pub device_type: String,
    /// Whether kernel times come from GPU timestamp queries (else wall time around
    /// submit-and-wait).
    pub timestamps: bool,
    /// Whether the watertight test's exact-zero fallback runs in f64 as on the CPU.
    pub f64: bool,
    /// PCI vendor and device ids (`wgpu::AdapterInfo`; 0x10de: NVIDIA), 0 where the backend
    /// does not say.
    pub pci: (u32, u32),
    /// The subgroup sizes the adapter may use (wgpu's `SUBGROUP` feature; lavapipe: 8, NVIDIA:
    /// 32), `None` without the feature: programs that need subgroups are refused.
    pub subgroups: Option<(u32, u32)>,
}

impl AdapterSummary {
    /// The `adapter_type` column: `discrete`, `integrated`, `virtual`, `software` (a CPU
    /// rasterizer: lavapipe, llvmpipe, SwiftShader) or `other`.
    pub fn kind(&self) -> &'static str {
        match self.device_type.as_str() {
            "DiscreteGpu" => "discrete",
            "IntegratedGpu" => "integrated",
            "VirtualGpu" => "virtual",
            "Cpu" => "software",
            _ => "other",
        }
    }

    /// `name / backend / driver`, the `adapter` column of GPU rows.
    pub fn label(&self) -> String {
        format!("{} / {} / {}", self.name, self.backend, self.driver)
    }

    fn from_info(info: &wgpu::AdapterInfo, timestamps: bool, f64: bool, subgroups: bool) -> Self {
        let driver = [info.driver.as_str(), info.driver_info.as_str()]
            .iter()
            .filter(|s| !s.is_empty())
            .copied()
            .collect::<Vec<_>>()
            .join(" ");
        AdapterSummary {
            name: info.name.clone(),
            backend: info.backend.to_str().to_string(),
            driver,
            device_type: format!("{:?}", info.device_type),
            timestamps,
            f64,
            pci: (info.vendor, info.device),
            subgroups: subgroups.then_some((info.subgroup_min_size, info.subgroup_max_size)),
        }
    }
}

/// An open GPU device with the programs compiled on it so far; see the crate doc.
pub struct Gpu {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    pub(crate) summary: AdapterSummary,
    pub(crate) limits: wgpu::Limits,
    pub(crate) kernels: crate::kernels::Kernels,
    /// Optional cap on rays per dispatch ([`Gpu::limit_dispatch`]).
    pub(crate) dispatch_cap: Option<u64>,
    /// A timed sample's least duration, ms, and most passes ([`Gpu::set_timed_sample`]).
    pub(crate) sample: (f64, u32),
    /// Most workgroups of a persistent program's dispatch ([`Gpu::set_persistent_groups`]).
    pub(crate) persistent_groups: u32,
    /// First uncaptured error or device loss, reported by the next wait.
    errors: Arc<Mutex<Option<GpuError>>>,
    /// The fixed-work probe, made at its first use ([`Gpu::probe_ms`]).
    pub(crate) probe: Mutex<Option<crate::probe::Probe>>,
}

fn type_rank(t: wgpu::DeviceType) -> u8 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

/// Where the device's callbacks leave the first error they see.
type ErrorSlot = Arc<Mutex<Option<GpuError>>>;

/// The adapter `choice` selects (see [`Gpu::new`] for the order).
fn choose_adapter(choice: &AdapterChoice) -> Result<wgpu::Adapter, GpuError> {
    let primary = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
    let enumerate = |backends: wgpu::Backends| {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = backends;
        let instance = wgpu::Instance::new(desc);
        pollster::block_on(instance.enumerate_adapters(backends))
    };
    let mut adapters = match choice.backend {
        Some(b) => enumerate(b.wgpu()),
        None => enumerate(primary),
    };
    // GL only when asked for or when no native backend has an adapter (probing EGL
    // prints warnings on headless machines).
    if choice.backend.is_none() && adapters.is_empty() {
        adapters = enumerate(wgpu::Backends::GL);
    }
    let all: Vec<String> = adapters
        .iter()
        .map(|a| {
            let i = a.get_info();
            format!("{} ({})", i.name, i.backend.to_str())
        })
        .collect();
    if let Some(name) = &choice.name {
        let needle = name.to_lowercase();
        adapters.retain(|a| a.get_info().name.to_lowercase().contains(&needle));
    }
    adapters.sort_by_key(|a| {
        let i = a.get_info();
        (type_rank(i.device_type), i.backend == wgpu::Backend::Gl)
    });
    adapters.into_iter().next().ok_or_else(|| {
        let backend = choice.backend.map_or("any backend", Backend::name);
        let filter = choice
            .name
            .as_deref()
            .map_or(String::new(), |n| format!(", name containing `{n}`"));
        let seen = if all.is_empty() {
            "none present".to_string()
        } else {
            format!("present: {}", all.join(", "))
        };
        GpuError::NoAdapter(format!("{backend}{filter}; {seen}"))
    })
}

/// Install the device's error and device-lost callbacks: the first uncaptured error or loss
/// (but the `Destroyed` of dropping it) goes into the returned slot.
fn watch_errors(device: &wgpu::Device) -> ErrorSlot {
    let errors: ErrorSlot = Arc::new(Mutex::new(None));
    let sink = errors.clone();
    device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
        let mut slot = sink.lock().unwrap_or_else(|p| p.into_inner());
        slot.get_or_insert(GpuError::Wgpu(one_line(&e.to_string())));
    }));
    let sink = errors.clone();
    device.set_device_lost_callback(move |reason, msg| {
        // Dropping the device at the end of a run reports `Destroyed`: not an error.
        if reason != wgpu::DeviceLostReason::Destroyed {
            let mut slot = sink.lock().unwrap_or_else(|p| p.into_inner());
            slot.get_or_insert(GpuError::Lost(one_line(&format!("{reason:?}: {msg}"))));
        }
    });
    errors
}

impl Gpu {
    /// Open the adapter `choice` selects. Among matching adapters, discrete GPUs come first,
    /// then integrated, virtual, other and CPU (software) adapters; GL is tried only when no
    /// backend is named and Vulkan, Metal and DX12 offer no adapter.
    pub fn new(choice: &AdapterChoice) -> Result<Gpu, GpuError> {
        let adapter = choose_adapter(choice)?;
        let info = adapter.get_info();
        let features = adapter.features();
        let timestamps = features.contains(wgpu::Features::TIMESTAMP_QUERY);
        let f64 = features.contains(wgpu::Features::SHADER_F64);
        let subgroups = features.contains(wgpu::Features::SUBGROUP);
        let mut required = wgpu::Features::empty();
        if subgroups {
            required |= wgpu::Features::SUBGROUP;
        }
        if timestamps {
            required |= wgpu::Features::TIMESTAMP_QUERY;
        }
        if f64 {
            required |= wgpu::Features::SHADER_F64;
        }
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("trace-bench"),
            required_features: required,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::RequestDevice {
            adapter: info.name.clone(),
            message: one_line(&e.to_string()),
        })?;
        let errors = watch_errors(&device);
        let kernels = crate::kernels::Kernels::new(f64);
        let gpu = Gpu {
            device,
            queue,
            summary: AdapterSummary::from_info(&info, timestamps, f64, subgroups),
            limits,
            kernels,
            dispatch_cap: None,
            sample: (crate::MIN_SAMPLE_MS, crate::MAX_PASSES),
            persistent_groups: crate::PERSISTENT_GROUPS,
            errors,
            probe: Mutex::new(None),
        };
        gpu.check()?;
        Ok(gpu)
    }

    /// The adapter in use.
    pub fn adapter(&self) -> &AdapterSummary {
        &self.summary
    }

    /// Block until all submitted work is done; report the first error seen since the last
    /// check (validation, out of memory, device lost).
    pub(crate) fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Lost(one_line(&e.to_string())))?;
        self.check()
    }

    /// Report (and clear) the first error captured so far.
    pub(crate) fn check(&self) -> Result<(), GpuError> {
        let mut slot = self.errors.lock().unwrap_or_else(|p| p.into_inner());
        match slot.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}
