//! CPU twins of the GPU stages, one file per stage, plain `f64` Rust written from the method
//! rather than from the WGSL: the references `tests/gpu.rs` holds each stage to, and the seed of
//! a CPU back end.
pub mod puddles;
pub mod rain_simulate;
pub mod rain_splashes;
pub mod rain_streaks;
pub mod rgb_to_yuv;
pub mod rgba_out;
pub mod wet_ground;
pub mod yuv_to_rgb;

/// World point `w` in the camera frame of the uniforms `p` (x right, y down, z forward, m).
pub(crate) fn to_camera(p: &crate::gpu::types::RainParams, w: glam::DVec3) -> glam::DVec3 {
    let v3 = |a: &[f32]| glam::DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
    let d = w - v3(&p.camera_pos_m);
    glam::DVec3::new(
        v3(&p.camera_from_world_0).dot(d),
        v3(&p.camera_from_world_1).dot(d),
        v3(&p.camera_from_world_2).dot(d),
    )
}
