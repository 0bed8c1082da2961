//! What the GPU tests render with: the rain setups they share, the uniforms of a frame under a
//! given sky, water's transfer tables, and one frame through the compositor.
#![allow(dead_code)]

use std::sync::Arc;

use rain_composite::config::{CameraConfig, RainConfig, RenderConfig};
use rain_composite::gpu::types::RainParams;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::gpu::{Compositor, GpuContext};
use rain_composite::lighting::prt::channel_optics;
use rain_composite::lighting::rtf::{ChannelIndices, Polarisation, RtfTable, WATER_RHO_RGB};
use rain_composite::lighting::{EnvironmentSh, FrameLight, LightSource};
use rain_composite::scene::Camera;
use rain_composite::video::YuvFrame;

/// Water's transfer tables, one a colour channel (water's RGB refractive indices, five orders),
/// at `bins` bins.
pub fn water_tables(bins: usize) -> [RtfTable; 3] {
    channel_optics(ChannelIndices(WATER_RHO_RGB), 5, Polarisation::default())
        .expect("optics")
        .map(|o| o.tabulate(bins).expect("table"))
}

/// The zonal transfer coefficients the tests light drops with, alike in every channel.
pub const ZONAL: [[f32; 4]; 3] = [[1.0, 0.4, 0.2, 0.1]; 3];

/// A bluish sky, brighter overhead (SH coefficients 0 and 2).
pub const BLUISH_SKY: [(usize, [f32; 3]); 2] = [(0, [0.9, 1.0, 1.3]), (2, [0.3, 0.3, 0.4])];

/// The uniforms of `setup` at `t_s` under an environment whose only nonzero SH coefficients
/// are `env` (index, rgb), without lamps; the haze's transmittance set to `haze` where given
/// (else as `setup` places it).
pub fn lit(
    setup: &RainSetup,
    t_s: f64,
    env: &[(usize, [f32; 3])],
    haze: Option<f32>,
) -> RainParams {
    let mut sh = EnvironmentSh::zeros(4);
    for &(i, c) in env {
        sh.coeffs[i] = c;
    }
    let mut p = setup.params_at(
        t_s,
        &FrameLight {
            env: sh,
            lights: Vec::new(),
        },
        ZONAL,
    );
    if let Some(t) = haze {
        p.haze = [0.0, 0.0, 0.0, t];
    }
    p
}

/// `frame` rendered with `setup` at `p` by a fresh compositor.
pub fn render(
    ctx: &Arc<GpuContext>,
    frame: &YuvFrame,
    setup: &RainSetup,
    p: &RainParams,
) -> YuvFrame {
    render_with(ctx, frame, setup, p, |_| {})
}

/// As [`render`], `prepare` given the compositor first (transfer tables, lamps, a depth map…).
pub fn render_with(
    ctx: &Arc<GpuContext>,
    frame: &YuvFrame,
    setup: &RainSetup,
    p: &RainParams,
    prepare: impl FnOnce(&mut Compositor),
) -> YuvFrame {
    let mut comp =
        Compositor::new(ctx.clone(), frame.format, &frame.color, setup).expect("compositor");
    prepare(&mut comp);
    comp.render_one(frame, p).expect("render")
}

/// No rain drawn and the ground z = 0 under `camera`, its picture stored turned by
/// `rotation_deg` (coded ≠ displayed where it is a quarter turn).
pub fn dry_ground(camera: &Camera, rotation_deg: i32) -> RainSetup {
    let coded = if rotation_deg % 180 == 0 {
        (camera.width_px, camera.height_px)
    } else {
        (camera.height_px, camera.width_px)
    };
    let rain = RainConfig {
        rate_mm_per_h: 0.0,
        ..RainConfig::default()
    };
    rain_composite::shot::rain::plan(
        camera,
        &CameraConfig::default(),
        &rain,
        0.01,
        rotation_deg,
        coded,
    )
    .map(RainSetup::pack)
    .expect("rain")
    .with_ground(true)
}

/// The render configuration of a camera looking down at the street: the ground's horizon
/// crosses the picture's centre line 10 % of the height from the top (a 90° lens tilted down
/// by about 22°, 1.6 m up).
pub fn looking_down() -> RenderConfig {
    let mut c = RenderConfig::default();
    c.ground.mode = "horizon=0.1".parse().expect("mode");
    c.camera.fov_deg = 90.0;
    c
}

/// `rain` seen by `config`'s camera on a `w`×`h` picture, exposed `exposure_s`, the drops
/// landing on the ground or not (`ground`).
pub fn rain_seen_by(
    config: &RenderConfig,
    (w, h): (u32, u32),
    rain: &RainConfig,
    exposure_s: f64,
    ground: bool,
) -> (Camera, RainSetup) {
    let camera = config.camera(w, h).expect("camera");
    let setup = rain_composite::shot::rain::plan(
        &camera,
        &CameraConfig::default(),
        rain,
        exposure_s,
        0,
        (w, h),
    )
    .map(RainSetup::pack)
    .expect("rain")
    .with_ground(ground);
    (camera, setup)
}

/// A lamp at infinity right of centre and one 12 m away up to the left.
pub fn lamps(cam: &Camera) -> Vec<LightSource> {
    let at = |x: f64, y: f64| cam.ray_world(glam::DVec2::new(x, y)).normalize();
    vec![
        LightSource {
            direction_world: at(70.0, 30.0),
            solid_angle_sr: 2e-4,
            radiance_rgb: [1600.0, 1200.0, 600.0],
            distance_m: None,
        },
        LightSource {
            direction_world: at(25.0, 15.0),
            solid_angle_sr: 1e-4,
            radiance_rgb: [300.0, 300.0, 350.0],
            distance_m: Some(12.0),
        },
    ]
}
