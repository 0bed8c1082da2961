//! CPU twins of the GPU stages, one file per stage, plain `f64` Rust written from the method
//! rather than from the WGSL: the references `tests/gpu.rs` holds each stage to, and the seed of
//! a CPU back end.
pub mod rain_simulate;
pub mod rain_splashes;
pub mod rain_streaks;
pub mod rgb_to_yuv;
pub mod rgba_out;
pub mod wet_ground;
pub mod yuv_to_rgb;
