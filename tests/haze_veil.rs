//! The haze's veil by distance (Koschmieder): with a ground, each pixel below the horizon is
//! veiled by the rain between the farthest drawn drop and the point where its ray meets the
//! ground, against the closed form through the pinhole; above the horizon, and without a
//! ground, by the rain to the scene's depth as before.

use rain_composite::config::{CameraConfig, RainConfig};
use rain_composite::gpu::cpu::yuv_to_rgb::{haze_transmittance, yuv_to_rgb};
use rain_composite::gpu::types::RainParams;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::lighting::{EnvironmentSh, FrameLight};
use rain_composite::scene::Camera;
use rain_composite::video::{Chroma, ColorParams, FrameFormat, YuvFrame};

const W: u32 = 96;
const H: u32 = 64;
const NEAR_M: f64 = 3.0;
const FAR_M: f64 = 50.0;
const BETA_PER_M: f64 = 0.02;
const CAMERA_HEIGHT_M: f64 = 1.6;

/// A level camera 1.6 m above the ground, a uniform grey environment, the haze above.
fn params(ground: bool) -> (Camera, RainParams) {
    let config = CameraConfig {
        height_m: CAMERA_HEIGHT_M,
        ..CameraConfig::default()
    };
    let camera = config.camera(W, H);
    let setup = rain_composite::shot::rain::plan(
        &camera,
        &config,
        &RainConfig {
            rate_mm_per_h: 0.0,
            ..RainConfig::default()
        },
        1.0 / 50.0,
        0,
        (W, H),
    )
    .map(RainSetup::pack)
    .expect("setup")
    .with_ground(ground);
    let mut env = EnvironmentSh::zeros(4);
    env.coeffs[0] = [0.8, 0.8, 0.8];
    let mut p = setup.params_at(
        0.0,
        &FrameLight {
            env,
            lights: Vec::new(),
        },
        [[1.0, 0.4, 0.2, 0.1]; 3],
    );
    p.haze = [
        NEAR_M as f32,
        FAR_M as f32,
        BETA_PER_M as f32,
        (-BETA_PER_M * (FAR_M - NEAR_M)).exp() as f32,
    ];
    (camera, p)
}

/// Closed form: a level pinhole at height h sees the ground along pixel row y (centre y + ½)
/// at the depression angle δ = atan((y + ½ − c_y)/f) and the distance h / sin δ along its ray.
fn koschmieder(camera: &Camera, x: u32, y: u32) -> f64 {
    let c = camera.principal_px();
    let f = camera.focal_px();
    let (dx, dy) = (x as f64 + 0.5 - c.x, y as f64 + 0.5 - c.y);
    let far = (-BETA_PER_M * (FAR_M - NEAR_M)).exp();
    if dy <= 0.0 {
        return far;
    }
    // The ray (dx, dy, f) in camera units; its length to the ground is h · |ray| / dy.
    let s_m = CAMERA_HEIGHT_M * (dx * dx + dy * dy + f * f).sqrt() / dy;
    if s_m >= FAR_M {
        far
    } else {
        (-BETA_PER_M * (s_m - NEAR_M).max(0.0)).exp()
    }
}

#[test]
fn veil_follows_each_ray_s_distance_to_the_ground() {
    let (camera, p) = params(true);
    let mut below = 0;
    for y in 0..H {
        for x in 0..W {
            let t = haze_transmittance(&p, None, x, y);
            let want = koschmieder(&camera, x, y);
            assert!(
                (t - want).abs() < 1e-5,
                "({x}, {y}): transmittance {t} vs the closed form {want}"
            );
            below += (want > p.haze[3] as f64 + 1e-3) as usize;
        }
    }
    // The near ground is clearer than the scene's depth: a third of the picture here.
    assert!(
        below > (W * H / 4) as usize,
        "{below} pixels nearer than the scene"
    );
    // The bottom row (the nearest ground) is the clearest, and clearness falls toward the
    // horizon row by row.
    let col = W / 2;
    for y in H / 2 + 1..H {
        assert!(haze_transmittance(&p, None, col, y) >= haze_transmittance(&p, None, col, y - 1));
    }
    // Without a ground: the constant veil to the scene's depth everywhere.
    let (_, flat) = params(false);
    for y in 0..H {
        for x in 0..W {
            assert_eq!(haze_transmittance(&flat, None, x, y), flat.haze[3] as f64);
        }
    }
}

/// The composite: background · T + (1 − T) · in-scatter, with T per pixel; a pixel of the near
/// road keeps more of the frame than one at the horizon.
#[test]
fn near_road_keeps_the_frame_far_road_takes_the_air_light() {
    let (camera, p) = params(true);
    let format = FrameFormat {
        width: W,
        height: H,
        chroma: Chroma::Cs444,
        bit_depth: 8,
    };
    // A black frame: what is left is the air-light alone, (1 − T) · in-scatter.
    let frame = YuvFrame::filled(format, ColorParams::bt709(8), [16, 128, 128]);
    let canvas = yuv_to_rgb(&frame, &p);
    let at = |x: u32, y: u32| canvas[(y * W + x) as usize][1];
    let near = at(W / 2, H - 1);
    let horizon = at(W / 2, H / 2 + 1);
    let sky = at(W / 2, 2);
    assert!(
        near > 0.0 && near < horizon,
        "near {near}, horizon {horizon}"
    );
    assert!(
        (horizon - sky).abs() <= 0.2 * sky,
        "horizon {horizon}, sky {sky}"
    );
    // The air-light's ratio between two ground pixels is the ratio of their opacities.
    let (t_near, t_horizon) = (
        koschmieder(&camera, W / 2, H - 1),
        koschmieder(&camera, W / 2, H / 2 + 1),
    );
    let ratio = near / horizon;
    let want = (1.0 - t_near) / (1.0 - t_horizon);
    assert!((ratio / want - 1.0).abs() < 0.05, "{ratio} vs {want}");
}
