//! The haze's glow around compact lights: the GPU stage against its CPU twin, the twin's halo
//! against a brute-force integral along the ray, and no lights adding nothing.
//! Set `RAIN_COMPOSITE_REQUIRE_GPU=1` to turn a missing adapter into a failure.

use glam::DVec3;
use rain_composite::config::{CameraConfig, RainConfig};
use rain_composite::gpu::cpu::{rgb_to_yuv, yuv_to_rgb};
use rain_composite::gpu::types::{LightList, RainParams};
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::lighting::LightSource;
use rain_composite::scene::Camera;
use rain_composite::video::{Chroma, ColorParams, FrameFormat, YuvFrame};

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/render.rs"]
mod render;
use render::{lit, render_with, water_tables};

#[path = "common/pictures.rs"]
mod pictures;
use pictures::codes;

const W: u32 = 96;
const H: u32 = 64;
/// The haze from the farthest drawn drop to the scene, metres, and its transmittance.
const HAZE_NEAR_M: f64 = 3.0;
const HAZE_FAR_M: f64 = 50.0;
const HAZE_T: f64 = 0.85;

fn camera() -> Camera {
    Camera::new(W, H, 60f64.to_radians(), 1.6, 0.0, 0.0)
}

/// No drops; a dim environment; the haze given by the constants above.
fn setup_and_params(cam: &Camera) -> (RainSetup, RainParams) {
    let setup = rain_composite::shot::rain::plan(
        cam,
        &CameraConfig::default(),
        &RainConfig {
            rate_mm_per_h: 0.0,
            ..RainConfig::default()
        },
        1.0 / 50.0,
        0,
        (W, H),
    )
    .map(RainSetup::pack)
    .expect("rain");
    let mut p = lit(&setup, 0.0, &[(0, [0.05, 0.05, 0.08])], None);
    p.haze = [HAZE_NEAR_M as f32, HAZE_FAR_M as f32, 0.0, HAZE_T as f32];
    (setup, p)
}

/// A dark night frame, 8-bit BT.709 4:2:0.
fn dark_frame() -> YuvFrame {
    let format = FrameFormat {
        width: W,
        height: H,
        chroma: Chroma::Cs420,
        bit_depth: 8,
    };
    YuvFrame::filled(format, ColorParams::bt709(8), [24, 130, 126])
}

/// The GPU frame with `lights` in the haze, and the CPU twins' (yuv_to_rgb with the glow →
/// rgb_to_yuv).
fn both(lights: &[LightSource]) -> ([Vec<u16>; 3], [Vec<u16>; 3]) {
    let ctx = gpu().expect("adapter");
    let cam = camera();
    let (setup, p) = setup_and_params(&cam);
    let frame = dark_frame();
    let tables = water_tables(1024);
    let list = LightList::new(lights);
    let gpu = codes(&render_with(&ctx, &frame, &setup, &p, |comp| {
        comp.set_transfer_table(&tables);
        comp.set_lights(&list);
    }));
    let canvas = yuv_to_rgb::yuv_to_rgb_lit(&frame, &p, &list, &tables);
    (
        gpu,
        rgb_to_yuv::rgb_to_yuv(&canvas, frame.format, &frame.color),
    )
}

#[test]
fn gpu_glow_matches_the_cpu_twin() {
    if gpu().is_none() {
        return;
    }
    let cam = camera();
    let (gpu, cpu) = both(&render::lamps(&cam));
    let mut worst = 0;
    for (g, c) in gpu[0].iter().zip(&cpu[0]) {
        worst = worst.max(g.abs_diff(*c));
    }
    for (g, c) in gpu.iter().zip(&cpu).skip(1) {
        for (a, b) in g.iter().zip(c) {
            worst = worst.max(a.abs_diff(*b));
        }
    }
    assert!(worst <= 1, "{worst} codes off");
    // The halo shows: the luma next to the lamp at infinity is well above the veil's far from
    // both lamps.
    let luma = |x: u32, y: u32| gpu[0][(y * W + x) as usize];
    assert!(
        luma(72, 30) >= luma(50, 60) + 5,
        "{} {}",
        luma(72, 30),
        luma(50, 60)
    );
}

/// Without lights the glow adds nothing: the GPU frame is the one without any light list, and
/// the twin's canvas is exactly the unlit one.
#[test]
fn no_lights_add_nothing() {
    let cam = camera();
    let (_, p) = setup_and_params(&cam);
    let frame = dark_frame();
    let tables = water_tables(1024);
    let unlit = yuv_to_rgb::yuv_to_rgb(&frame, &p);
    let lit = yuv_to_rgb::yuv_to_rgb_lit(&frame, &p, &LightList::new(&[]), &tables);
    assert_eq!(unlit, lit);
    if gpu().is_none() {
        return;
    }
    let (gpu, cpu) = both(&[]);
    let worst = gpu
        .iter()
        .zip(&cpu)
        .flat_map(|(g, c)| g.iter().zip(c).map(|(a, b)| a.abs_diff(*b)))
        .max();
    assert!(worst <= Some(1));
}

/// The halo's profile along a row through each lamp, against a brute-force integral along the
/// ray: a fine Riemann sum over s of β e^(−β (s − s_near)) · L Ω (d / r)² · F(θ) (β the haze's
/// extinction as a picture sees it: the diffracted half of a drop's extinction stays within
/// 0.03° of the beam, so what the beam loses is what the geometric optics F scatter), with F
/// from a table eight times finer read as its bin averages, and the geometry in plain vectors.
#[test]
fn glow_follows_the_single_scattering_integral() {
    let cam = camera();
    let (_, p) = setup_and_params(&cam);
    let coarse = water_tables(1024);
    let fine = water_tables(8192);
    let beta = -HAZE_T.ln() / (HAZE_FAR_M - HAZE_NEAR_M);
    for lamp in render::lamps(&cam) {
        let list = LightList::new(std::slice::from_ref(&lamp));
        let lamp_px = {
            let mut best = (0, 0, -2.0);
            for y in 0..H {
                for x in 0..W {
                    let d = yuv_to_rgb::view_ray(&p, x, y).normalize();
                    let c = d.dot(lamp.direction_world);
                    if c > best.2 {
                        best = (x, y, c);
                    }
                }
            }
            (best.0, best.1)
        };
        let min_m = lamp.min_distance_m().unwrap_or(0.0);
        let mut profile = Vec::new();
        for x in 0..W {
            let y = lamp_px.1;
            // The ray through the pixel's centre.
            let v = yuv_to_rgb::view_ray(&p, x, y).normalize();
            let glow = yuv_to_rgb::haze_glow_along(&p, &list, &coarse, v);
            let steps = 100_000;
            let ds = (HAZE_FAR_M - HAZE_NEAR_M) / steps as f64;
            let mut truth = [0.0; 3];
            for i in 0..steps {
                let s = HAZE_NEAR_M + (i as f64 + 0.5) * ds;
                let drop = v * s;
                let (to_light, scale) = match lamp.distance_m {
                    None => (lamp.direction_world, 1.0),
                    Some(d) => {
                        let r: DVec3 = lamp.direction_world * d - drop;
                        (r.normalize(), (d / r.length().max(min_m)).powi(2))
                    }
                };
                let theta = to_light.dot(v).clamp(-1.0, 1.0).acos();
                let w = beta * (-beta * (s - HAZE_NEAR_M)).exp() * ds * scale;
                for k in 0..3 {
                    truth[k] +=
                        w * lamp.radiance_rgb[k] * lamp.solid_angle_sr * fine[k].value(theta);
                }
            }
            profile.push((x, glow, truth));
        }
        // The halo peaks at the lamp; a lamp at a finite distance is seen by the haze's drops
        // under angles that sweep through the bows, which 16 samples follow to a few per cent
        // of the peak.
        let peak: f64 = profile.iter().map(|(_, _, t)| t[1]).fold(0.0, f64::max);
        let (x_peak, _, _) = profile
            .iter()
            .max_by(|a, b| a.2[1].total_cmp(&b.2[1]))
            .expect("a row");
        assert!(
            x_peak.abs_diff(lamp_px.0) <= 1,
            "the halo peaks at the lamp"
        );
        let tolerance = if lamp.distance_m.is_some() {
            0.02
        } else {
            0.002
        };
        for (x, glow, truth) in &profile {
            for k in 0..3 {
                let err = (glow[k] - truth[k]).abs();
                assert!(
                    err <= 0.01 * truth[k] + tolerance * peak,
                    "lamp at {:?} m, pixel {x}: channel {k}: {} vs {} (peak {peak})",
                    lamp.distance_m,
                    glow[k],
                    truth[k]
                );
            }
        }
    }
}
