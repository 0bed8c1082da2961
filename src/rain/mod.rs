//! Rain: CPU physics only — drop sizes, fall speeds, wind, the planned rain volume and the
//! stateless drop (the CPU twin of `shaders/common/drops.wgsl`). Packing it for the GPU is
//! `gpu::uniforms`' job.
pub mod physics;
pub mod volume;
pub mod wind;
