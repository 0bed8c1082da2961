//! GPU plumbing: adapter choice, the WGSL stages and their Rust twins, the per-frame compositor.
pub mod bind;
pub mod compositor;
pub mod context;
pub mod cpu;
pub mod host;
pub mod lights;
pub mod probe;
pub mod shaders;
pub mod stages;
pub mod types;
pub mod uniforms;

pub use compositor::{Compositor, GpuStageTimes, Rendered, max_drops};
pub use context::{AdapterRequest, AdapterSummary, Backend, GpuContext, list_adapters};
