//! The scenes the CPU back end's benches share: the rain planned for a view, the sky that
//! lights its drops, the water drop's transfer tables and the frame format.
// Each bench uses a part of these.
#![allow(dead_code)]

use rain_composite::config::{CameraConfig, RainConfig};
use rain_composite::gpu::types::RainParams;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::lighting::prt::channel_optics;
use rain_composite::lighting::rtf::{ChannelIndices, Polarisation, RtfTable, WATER_RHO_RGB};
use rain_composite::lighting::{EnvironmentSh, FrameLight};
use rain_composite::scene::Camera;
use rain_composite::video::{Chroma, FrameFormat};

/// A level view of a 1080p picture, 1.6 m up, 60° across.
pub fn camera_1080p() -> Camera {
    Camera::new(1920, 1080, 60f64.to_radians(), 1.6, 0.0, 0.0)
}

/// `rain` planned for `camera`'s picture with the default lens, exposed 1/50 s, unrotated.
pub fn rain_setup(camera: &Camera, rain: &RainConfig) -> RainSetup {
    rain_composite::shot::rain::plan(
        camera,
        &CameraConfig::default(),
        rain,
        1.0 / 50.0,
        0,
        (camera.width_px, camera.height_px),
    )
    .map(RainSetup::pack)
    .expect("rain")
}

/// The default rain (10 mm/h) over `camera`'s picture.
pub fn default_rain(camera: &Camera) -> RainSetup {
    rain_setup(camera, &RainConfig::default())
}

/// The frame's uniforms at `t_s` under a bluish sky brighter overhead, without compact lights,
/// with a fixed zonal transfer for the drops.
pub fn sky_params(setup: &RainSetup, t_s: f64) -> RainParams {
    let mut env = EnvironmentSh::zeros(4);
    env.coeffs[0] = [0.8, 0.9, 1.0];
    env.coeffs[2] = [0.3, 0.35, 0.5];
    let light = FrameLight {
        env,
        lights: Vec::new(),
    };
    setup.params_at(t_s, &light, [[1.0, 0.4, 0.2, 0.1]; 3])
}

/// The water drop's transfer tables per channel: orders 1..=5, 1024 bins.
pub fn water_tables() -> [RtfTable; 3] {
    channel_optics(ChannelIndices(WATER_RHO_RGB), 5, Polarisation::default())
        .expect("optics")
        .map(|o| o.tabulate(1024).expect("table"))
}

/// An 8-bit 4:2:0 picture of `width` × `height`.
pub fn format_420(width: u32, height: u32) -> FrameFormat {
    FrameFormat {
        width,
        height,
        chroma: Chroma::Cs420,
        bit_depth: 8,
    }
}

/// The CPU time all of this process's threads have run so far, ms, from the kernel's per-thread
/// scheduler statistics (0 where /proc has none): on a shared machine a bench timed by it does
/// not count the time other work held the cores.
pub fn cpu_ms() -> f64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    let ns: u64 = tasks
        .flatten()
        .filter_map(|t| std::fs::read_to_string(t.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .sum();
    ns as f64 * 1e-6
}

/// [`cpu_ms`] as a duration, for criterion's custom timings.
pub fn cpu_time() -> std::time::Duration {
    std::time::Duration::from_secs_f64(cpu_ms() * 1e-3)
}
