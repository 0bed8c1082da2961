//! Adapter choice and device creation.
//!
//! Preference: discrete GPU > integrated GPU > virtual > CPU (Mesa lavapipe/llvmpipe), Vulkan
//! before GL. `--adapter NAME` picks by case-insensitive substring, `--cpu` keeps CPU adapters
//! only. CPU adapters are never refused: they are what CI and GPU-less machines have.

use crate::{Error, Result};

/// How to choose the adapter.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AdapterRequest {
    /// Case-insensitive substring of the adapter's name.
    pub name: Option<String>,
    /// Only software (CPU) adapters.
    pub cpu_only: bool,
    /// Where the per-pixel colour passes run.
    pub backend: Backend,
}

/// Where the per-pixel colour passes (planes → hazed canvas, canvas → code values) run. On a
/// CPU adapter the GPU's shaders are JIT code on the same cores, at about 100 ns a pixel for a
/// conversion that plain vectorised Rust does in a few: there the CPU back end
/// ([`crate::gpu::host`]) runs them, and every other per-frame pass with them (the drops and
/// the splashes simulated too): no frame goes to the adapter.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// The CPU on a CPU adapter (lavapipe, llvmpipe, WARP, SwiftShader) or one the GPU back
    /// end cannot run on ([`GPU_BACKEND_NEEDS`]), else the GPU.
    #[default]
    Auto,
    /// The GPU's shaders.
    Gpu,
    /// The CPU back end.
    Cpu,
}

/// What the GPU back end needs of an adapter beyond compute shaders: the streaks' draw
/// (`rain_streaks`, and the splashes' through it) reads the streaks from a storage buffer in its
/// vertex shader, which GLES 3.1-class adapters may not allow (no vertex-stage storage blocks).
pub const GPU_BACKEND_NEEDS: wgpu::DownlevelFlags = wgpu::DownlevelFlags::VERTEX_STORAGE;

impl Backend {
    /// `Gpu` or `Cpu` for an adapter of type `device` with downlevel capabilities `flags`:
    /// `Auto` picks the CPU back end on a CPU adapter and on one that lacks
    /// [`GPU_BACKEND_NEEDS`], the GPU elsewhere; `None` where `Gpu` is asked of an adapter that
    /// lacks them.
    pub fn resolve(self, device: wgpu::DeviceType, flags: wgpu::DownlevelFlags) -> Option<Backend> {
        let gpu_runs = flags.contains(GPU_BACKEND_NEEDS);
        match self {
            Backend::Auto if device == wgpu::DeviceType::Cpu || !gpu_runs => Some(Backend::Cpu),
            Backend::Auto => Some(Backend::Gpu),
            Backend::Gpu if !gpu_runs => None,
            b => Some(b),
        }
    }

    /// The name the command line and the reports use.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Auto => "auto",
            Backend::Gpu => "gpu",
            Backend::Cpu => "cpu",
        }
    }
}

/// One adapter as `rain-composite adapters` lists it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct AdapterSummary {
    /// Adapter name as the driver reports it.
    pub name: String,
    /// Backend (Vulkan, Gl…).
    pub backend: String,
    /// Discrete, integrated, virtual, CPU or other.
    pub device_type: String,
    /// Driver name and version.
    pub driver: String,
}

/// The device and queue every GPU stage uses, with the adapter they came from.
#[derive(Debug)]
pub struct GpuContext {
    /// The chosen adapter.
    pub adapter: wgpu::Adapter,
    /// The logical device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
}

/// An instance for `backends`, narrowed further by `WGPU_BACKEND` when the user sets it.
fn instance(backends: wgpu::Backends) -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    desc.backends &= backends;
    wgpu::Instance::new(desc)
}

/// Every adapter with compute shaders, best first. The primary backends (Vulkan, Metal, DX12)
/// are asked first; GL is probed only when they offer none, because initialising it on a
/// headless Linux machine prints EGL/Wayland complaints (`XDG_RUNTIME_DIR is invalid`) on
/// stderr that a user reads as a failure.
fn compute_adapters() -> Vec<wgpu::Adapter> {
    let usable = |backends| {
        let mut adapters = pollster::block_on(instance(backends).enumerate_adapters(backends));
        adapters.retain(|a| {
            a.get_downlevel_capabilities()
                .flags
                .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
        });
        adapters
    };
    let mut adapters = usable(wgpu::Backends::PRIMARY);
    if adapters.is_empty() {
        adapters = usable(wgpu::Backends::SECONDARY);
    }
    adapters.sort_by_key(|a| rank(&a.get_info()));
    adapters
}

fn rank(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let device = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    let backend = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    };
    (device, backend)
}

fn summary(info: &wgpu::AdapterInfo) -> AdapterSummary {
    AdapterSummary {
        name: info.name.clone(),
        backend: format!("{:?}", info.backend),
        device_type: format!("{:?}", info.device_type),
        driver: format!("{} {}", info.driver, info.driver_info)
            .trim()
            .to_string(),
    }
}

/// The adapters a job can use, best first (GL ones only where no primary backend has one).
pub fn list_adapters() -> Vec<AdapterSummary> {
    compute_adapters()
        .iter()
        .map(|a| summary(&a.get_info()))
        .collect()
}

impl GpuContext {
    /// Picks an adapter per `request` and opens a device on it.
    pub fn new(request: &AdapterRequest) -> Result<GpuContext> {
        let mut adapters = compute_adapters();
        adapters.retain(|a| {
            let info = a.get_info();
            let name_ok = request
                .name
                .as_ref()
                .is_none_or(|n| info.name.to_lowercase().contains(&n.to_lowercase()));
            let cpu_ok = !request.cpu_only || info.device_type == wgpu::DeviceType::Cpu;
            name_ok && cpu_ok
        });
        let Some(adapter) = adapters.into_iter().next() else {
            let what = match (&request.name, request.cpu_only) {
                (Some(n), _) => format!("no adapter named like '{n}' (see `rain-composite adapters`)"),
                (None, true) => "no CPU adapter (install Mesa's lavapipe: mesa-vulkan-drivers)".into(),
                (None, false) => "no adapter with compute shaders (install a Vulkan driver or mesa-vulkan-drivers)".into(),
            };
            return Err(Error::Gpu(what));
        };
        let limits = wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits());
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: adapter.limits().max_storage_buffer_binding_size,
            max_buffer_size: adapter.limits().max_buffer_size,
            max_compute_workgroups_per_dimension: adapter
                .limits()
                .max_compute_workgroups_per_dimension,
            // The downlevel four storage buffers a stage, as asked: every stage keeps within
            // them (the lamps' glow is a texture), so GLES 3.1-class adapters build them all.
            ..limits
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("rain-composite"),
            // Timestamps, where the adapter has them, time each GPU stage for `bench`.
            required_features: adapter.features() & wgpu::Features::TIMESTAMP_QUERY,
            required_limits: limits,
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| {
            Error::Gpu(format!(
                "cannot open a device on '{}': {e}",
                adapter.get_info().name
            ))
        })?;
        Ok(GpuContext {
            adapter,
            device,
            queue,
        })
    }

    /// The chosen adapter, for logs and benchmark tables.
    pub fn summary(&self) -> AdapterSummary {
        summary(&self.adapter.get_info())
    }

    /// The back end `requested` resolves to on this adapter (see [`Backend::resolve`]); an
    /// error where the GPU back end is asked of an adapter that cannot run it.
    pub fn backend(&self, requested: Backend) -> Result<Backend> {
        let info = self.adapter.get_info();
        let flags = self.adapter.get_downlevel_capabilities().flags;
        requested.resolve(info.device_type, flags).ok_or_else(|| {
            Error::Gpu(format!(
                "'{}' cannot read storage buffers in vertex shaders (wgpu's VERTEX_STORAGE), \
                 which the GPU back end draws the streaks with; the CPU back end renders \
                 pictures (not layers) without it",
                info.name
            ))
        })
    }

    /// Largest 2D texture side this device accepts.
    pub fn max_texture_side(&self) -> u32 {
        self.device.limits().max_texture_dimension_2d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wgpu::{DeviceType, DownlevelFlags};

    /// `auto` falls back to the CPU back end on an adapter whose vertex shaders cannot read
    /// storage buffers, whatever its type; `gpu` there is refused rather than left to fail in
    /// the streak stage's validation; `cpu` needs nothing of the adapter.
    #[test]
    fn backend_needs_vertex_storage_for_the_gpu() {
        let full = DownlevelFlags::all();
        let gles = DownlevelFlags::all() - DownlevelFlags::VERTEX_STORAGE;
        let types = [
            DeviceType::DiscreteGpu,
            DeviceType::IntegratedGpu,
            DeviceType::VirtualGpu,
            DeviceType::Cpu,
            DeviceType::Other,
        ];
        for device in types {
            let cpu = device == DeviceType::Cpu;
            let auto_full = Backend::Auto.resolve(device, full);
            assert_eq!(
                auto_full,
                Some(if cpu { Backend::Cpu } else { Backend::Gpu })
            );
            assert_eq!(Backend::Auto.resolve(device, gles), Some(Backend::Cpu));
            assert_eq!(Backend::Gpu.resolve(device, full), Some(Backend::Gpu));
            assert_eq!(Backend::Gpu.resolve(device, gles), None);
            for flags in [full, gles, DownlevelFlags::empty()] {
                assert_eq!(Backend::Cpu.resolve(device, flags), Some(Backend::Cpu));
            }
        }
    }
}
