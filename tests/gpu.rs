//! GPU stages against their CPU twins, on whatever adapter the machine has (lavapipe in CI).
//! Set `RAIN_COMPOSITE_REQUIRE_GPU=1` (CI does) to turn a missing adapter into a failure.

use std::sync::Arc;

use glam::DVec2;
use rain_composite::config::{CameraConfig, RainConfig};
use rain_composite::gpu::types::RainParams;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::gpu::{Compositor, GpuContext, probe::probe_drops};
use rain_composite::lighting::{EnvironmentSh, FrameLight, RtfSh};
use rain_composite::rain::physics::streak_width_factor;
use rain_composite::rain::volume::sample_drop;
use rain_composite::scene::Camera;
use rain_composite::video::{Chroma, ColorParams, FrameFormat, Matrix, Transfer, YuvFrame};

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/pictures.rs"]
mod pictures;
use pictures::{padded_picture, plane_codes, scatter};

/// A deterministic picture of scattered code values. `chroma_spread` in (0, 1] narrows chroma
/// around neutral: at 1 many pixels are far out of the RGB gamut (fine for SDR transfers, whose
/// odd extension round-trips them), while PQ's curve has a pole just below code 2.0, so HDR
/// cases keep R'G'B' within the encodable range as real footage does.
fn test_frame(format: FrameFormat, color: ColorParams, chroma_spread: f64) -> YuvFrame {
    let max = (1u32 << format.bit_depth) - 1;
    let mid = (max + 1) as f64 / 2.0;
    // Rows padded like FFmpeg's.
    let frame = padded_picture(format, color, 7, |i, x, y| {
        let v = scatter(i, x, y) % (max + 1);
        if i > 0 {
            (mid + (v as f64 - mid) * chroma_spread).round() as u16
        } else {
            v as u16
        }
    });
    YuvFrame {
        pts: 42,
        index: 3,
        ..frame
    }
}

/// Uniforms at `t_s` with the drops in a uniform white environment of radiance 1 (a drop then
/// shows radiance 1, less the truncated orders).
fn lit(setup: &RainSetup, t_s: f64) -> RainParams {
    let mut env = EnvironmentSh::zeros(4);
    env.coeffs[0] = [2.0 * std::f32::consts::PI.sqrt(); 3];
    let rtf = RtfSh::water(1.333, 9, 4).expect("rtf");
    let zonal = rtf.to_gpu_array();
    setup.params_at(
        t_s,
        &FrameLight {
            env,
            lights: Vec::new(),
        },
        zonal,
    )
}

fn no_rain(format: &FrameFormat) -> RainSetup {
    let camera = Camera::new(format.width, format.height, 1.0, 1.6, 0.0, 0.0);
    let rain = RainConfig {
        rate_mm_per_h: 0.0,
        ..RainConfig::default()
    };
    rain_composite::shot::rain::plan(
        &camera,
        &CameraConfig::default(),
        &rain,
        0.01,
        0,
        (format.width, format.height),
    )
    .map(RainSetup::pack)
    .expect("rain")
}

#[test]
fn frames_without_rain_come_back_unchanged() {
    let Some(ctx) = gpu() else { return };
    let cases = [
        (
            Chroma::Cs420,
            8,
            Matrix::Bt709,
            false,
            Transfer::Bt709,
            64,
            48,
        ),
        (
            Chroma::Cs420,
            8,
            Matrix::Bt601,
            true,
            Transfer::Srgb,
            33,
            17,
        ),
        (
            Chroma::Cs422,
            10,
            Matrix::Bt2020Ncl,
            false,
            Transfer::Pq,
            40,
            20,
        ),
        (
            Chroma::Cs444,
            10,
            Matrix::Bt709,
            true,
            Transfer::Hlg,
            16,
            16,
        ),
        (
            Chroma::Cs420,
            8,
            Matrix::Bt709,
            false,
            Transfer::Bt709,
            321,
            241,
        ),
    ];
    for (chroma, bit_depth, matrix, full_range, transfer, w, h) in cases {
        let format = FrameFormat {
            width: w,
            height: h,
            chroma,
            bit_depth,
        };
        let color = ColorParams {
            matrix,
            full_range,
            transfer,
            bit_depth,
        };
        let spread = if transfer == Transfer::Pq { 0.3 } else { 1.0 };
        let input = test_frame(format, color, spread);
        let mut comp =
            Compositor::new(ctx.clone(), format, &color, &no_rain(&format)).expect("compositor");
        assert_eq!(comp.drop_count(), 0);
        let out = comp
            .render_one(&input, &lit(&no_rain(&format), 0.0))
            .expect("render");
        assert_eq!((out.pts, out.index), (42, 3));
        // Legal code values come back exactly; codes outside the legal range may clamp.
        let mut off = 0usize;
        let mut total = 0usize;
        for i in 0..3 {
            let (pw, ph) = format.plane_size(i);
            for y in 0..ph {
                for x in 0..pw {
                    total += 1;
                    let a = input.sample(i, x, y) as i32;
                    let b = out.sample(i, x, y) as i32;
                    if a != b {
                        off += 1;
                        assert!(
                            (a - b).abs() <= 1,
                            "{chroma:?} {bit_depth} {matrix:?} plane {i} ({x},{y}): {a} → {b}"
                        );
                    }
                }
            }
        }
        // f16 canvas: at most a handful of codes move by one (10-bit PQ is the hardest case).
        assert!(
            off * 1000 <= total,
            "{chroma:?} {bit_depth} {transfer:?}: {off} of {total} samples changed"
        );
    }
}

#[test]
fn gpu_drops_match_the_cpu_reference() {
    let Some(ctx) = gpu() else { return };
    let camera = Camera::new(640, 360, 1.1, 1.6, 0.1, 0.0);
    let rain = RainConfig {
        rate_mm_per_h: 25.0,
        wind_mps: [3.0, -1.0],
        gust_mps: 2.0,
        seed: 7,
        ..RainConfig::default()
    };
    let setup = rain_composite::shot::rain::plan(
        &camera,
        &CameraConfig::default(),
        &rain,
        0.02,
        0,
        (640, 360),
    )
    .map(RainSetup::pack)
    .expect("rain");
    assert!(setup.drop_count() > 1000);
    for t in [0.0f64, 0.7, 13.25] {
        let gpu_states = probe_drops(&ctx, &setup, t, 4096).expect("probe");
        let mut wrapped = 0;
        for (id, g) in gpu_states.iter().enumerate() {
            let c = sample_drop(setup.rainfall(), id as u64, t).expect("drop");
            let c_pos = c.position_m.as_vec3();
            assert!(
                (g.vel_mps - c.velocity_mps.as_vec3()).length() < 1e-3 * (1.0 + t as f32),
                "drop {id} t={t}"
            );
            assert!((g.diameter_mm - c.diameter_mm as f32).abs() < 1e-4);
            let width = c.diameter_mm * streak_width_factor(c.diameter_mm);
            assert!(
                (g.width_mm as f64 - width).abs() < 1e-4 * width,
                "drop {id}: width"
            );
            let err = (g.pos_m - c_pos).length();
            if err > 2e-3 * (1.0 + t as f32) {
                // f32 against f64: a drop a hair from its column's end may wrap on one side only.
                wrapped += 1;
                assert!(wrapped <= 4, "drop {id} t={t}: {:?} vs {c_pos:?}", g.pos_m);
            }
        }
    }
}

#[test]
fn rain_brightens_a_dark_frame_and_falls_down_the_picture() {
    let Some(ctx) = gpu() else { return };
    let format = FrameFormat {
        width: 160,
        height: 120,
        chroma: Chroma::Cs420,
        bit_depth: 8,
    };
    let color = ColorParams::bt709(8);
    let dark = YuvFrame::filled(format, color, [40, 128, 128]);
    let camera = Camera::new(160, 120, 1.0, 1.6, 0.0, 0.0);
    let rain = RainConfig {
        rate_mm_per_h: 50.0,
        opacity: 20.0,
        near_m: 0.3,
        far_m: 6.0,
        ..RainConfig::default()
    };
    let setup = rain_composite::shot::rain::plan(
        &camera,
        &CameraConfig::default(),
        &rain,
        1.0 / 50.0,
        0,
        (160, 120),
    )
    .map(RainSetup::pack)
    .expect("rain");
    let mut comp = Compositor::new(ctx.clone(), format, &color, &setup).expect("compositor");
    let a = comp.render_one(&dark, &lit(&setup, 1.0)).expect("render");
    let b = comp.render_one(&dark, &lit(&setup, 1.04)).expect("render");
    let (la, lb) = (plane_codes(&a, 0), plane_codes(&b, 0));
    assert!(
        la.iter().all(|&v| v >= 40),
        "rain never darkens a dark frame"
    );
    assert!(
        la.iter().filter(|&&v| v > 45).count() > 50,
        "streaks are drawn"
    );
    assert_ne!(la, lb, "consecutive frames differ");
    // The projected drops move down the picture between the two times.
    let probe0 = probe_drops(&ctx, &setup, 1.0, 2000).expect("probe");
    let probe1 = probe_drops(&ctx, &setup, 1.04, 2000).expect("probe");
    let mut down = 0;
    let mut seen = 0;
    for (p, q) in probe0.iter().zip(&probe1) {
        if let (Some(u), Some(v)) = (
            camera.project_world(p.pos_m.as_dvec3()),
            camera.project_world(q.pos_m.as_dvec3()),
        ) {
            if (v - u).length() < 60.0 && u.y > 0.0 && u.y < 120.0 {
                seen += 1;
                down += (v.y > u.y) as i32;
            }
        }
    }
    assert!(
        seen > 20 && down * 10 >= seen * 9,
        "{down} of {seen} drops moved down"
    );
    let _ = DVec2::ZERO;
}

/// Luma of a rainy render of a flat dark frame minus the flat level.
fn rain_luma(ctx: &Arc<GpuContext>, rain: RainConfig, time_s: f64) -> (u32, u32, Vec<f64>) {
    let (w, h) = (240u32, 160u32);
    let format = FrameFormat {
        width: w,
        height: h,
        chroma: Chroma::Cs420,
        bit_depth: 8,
    };
    let color = ColorParams::bt709(8);
    let dark = YuvFrame::filled(format, color, [30, 128, 128]);
    let camera = Camera::new(w, h, 1.0, 1.6, 0.0, 0.0);
    let setup = rain_composite::shot::rain::plan(
        &camera,
        &CameraConfig::default(),
        &rain,
        1.0 / 50.0,
        0,
        (w, h),
    )
    .map(RainSetup::pack)
    .expect("rain");
    let mut comp = Compositor::new(ctx.clone(), format, &color, &setup).expect("compositor");
    let out = comp
        .render_one(&dark, &lit(&setup, time_s))
        .expect("render");
    let luma = plane_codes(&out, 0)
        .iter()
        .map(|&c| c as f64 - 30.0)
        .collect();
    (w, h, luma)
}

/// Structure-tensor orientation of the streaks: mean of gx·gy over the picture. Streaks
/// running down-right (in the picture, y down) have gradients along (1, −1): negative.
fn streak_lean(w: u32, h: u32, l: &[f64]) -> f64 {
    let at = |x: u32, y: u32| l[(y * w + x) as usize];
    let mut jxy = 0.0;
    let mut jxx_plus_jyy = 0.0;
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let gx = 0.5 * (at(x + 1, y) - at(x - 1, y));
            let gy = 0.5 * (at(x, y + 1) - at(x, y - 1));
            jxy += gx * gy;
            jxx_plus_jyy += gx * gx + gy * gy;
        }
    }
    jxy / jxx_plus_jyy.max(1e-9)
}

#[test]
fn streaks_lean_with_the_wind() {
    let Some(ctx) = gpu() else { return };
    let base = RainConfig {
        rate_mm_per_h: 30.0,
        opacity: 30.0,
        near_m: 0.5,
        far_m: 5.0,
        ..RainConfig::default()
    };
    let lean = |wind_x: f64| {
        let (w, h, l) = rain_luma(
            &ctx,
            RainConfig {
                wind_mps: [wind_x, 0.0],
                ..base
            },
            2.0,
        );
        streak_lean(w, h, &l)
    };
    let (still, right, left) = (lean(0.0), lean(6.0), lean(-6.0));
    // Wind to the right: drops move right while falling, streaks run down-right.
    assert!(right < -0.05, "right wind lean {right}");
    assert!(left > 0.05, "left wind lean {left}");
    assert!(
        still.abs() < 0.5 * right.abs().min(left.abs()),
        "still air lean {still}"
    );
}

#[test]
fn the_same_seed_gives_the_same_rain_and_another_does_not() {
    let Some(ctx) = gpu() else { return };
    let rain = RainConfig {
        rate_mm_per_h: 20.0,
        opacity: 10.0,
        seed: 11,
        ..RainConfig::default()
    };
    let a = rain_luma(&ctx, rain, 3.0).2;
    let b = rain_luma(&ctx, rain, 3.0).2;
    let c = rain_luma(&ctx, RainConfig { seed: 12, ..rain }, 3.0).2;
    assert_eq!(a, b);
    assert_ne!(a, c);
    assert!(a.iter().any(|&v| v > 0.0));
}

/// Hard cameras: straight up, straight down, 5° and 150° fields of view, violent wind-driven
/// rain crossing the near plane. The render must stay finite and local: no streak may smear
/// over the picture (a screen-sized quad would raise the mean of a dark frame far above the
/// physical coverage), and the plan must stay finite.
#[test]
fn hard_cameras_render_finite_local_streaks() {
    let Some(ctx) = gpu() else { return };
    let (w, h) = (192u32, 108u32);
    let format = FrameFormat {
        width: w,
        height: h,
        chroma: Chroma::Cs420,
        bit_depth: 8,
    };
    let color = ColorParams::bt709(8);
    let dark = YuvFrame::filled(format, color, [20, 128, 128]);
    let cases = [
        ("straight up", 60.0f64, 90.0f64, [0.0, 0.0], 25.0),
        ("straight down", 60.0, -90.0, [0.0, 0.0], 25.0),
        ("5° telephoto", 5.0, 0.0, [0.0, 0.0], 25.0),
        ("150° fisheye", 150.0, 0.0, [0.0, 0.0], 25.0),
        ("violent, 40 m/s wind", 60.0, 0.0, [40.0, 5.0], 300.0),
    ];
    for (name, fov_deg, tilt_deg, wind, rate) in cases {
        let camera = Camera::new(w, h, fov_deg.to_radians(), 1.6, tilt_deg.to_radians(), 0.0);
        // No haze: only the streaks change the picture.
        let rain = RainConfig {
            rate_mm_per_h: rate,
            wind_mps: wind,
            near_m: 0.1,
            scene_depth_m: 0.0,
            ..RainConfig::default()
        };
        let setup = rain_composite::shot::rain::plan(
            &camera,
            &CameraConfig::default(),
            &rain,
            1.0 / 50.0,
            0,
            (w, h),
        )
        .map(RainSetup::pack)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(
            setup.params.drop_weight.is_finite() && setup.params.drop_weight > 0.0,
            "{name}"
        );
        assert!(
            setup
                .columns
                .iter()
                .all(|c| c.height_m.is_finite() && c.z_lo_m.is_finite()),
            "{name}"
        );
        let mut comp = Compositor::new(ctx.clone(), format, &color, &setup).expect("compositor");
        let out = comp.render_one(&dark, &lit(&setup, 3.0)).expect("render");
        let luma: Vec<f64> = plane_codes(&out, 0).iter().map(|&c| c as f64).collect();
        let mean_rise = luma.iter().map(|v| v - 20.0).sum::<f64>() / luma.len() as f64;
        // Streaks stay streaks: the mean rise stays a small fraction of the way to white.
        assert!(mean_rise < 0.1 * 215.0, "{name}: mean rise {mean_rise}");
        eprintln!(
            "{name}: {} drops, mean rise {mean_rise:.2}",
            setup.drop_count()
        );
        assert!(
            luma.iter().all(|&v| v >= 20.0),
            "{name}: rain never darkens a dark frame here"
        );
    }
}

/// `rain_simulate` against its CPU twin (`gpu::cpu::rain_simulate::streak_of`, `prt_colour`,
/// `direct_colour`): streak geometry, near-field drops capped, and each end's radiance from the
/// environment plus a sun and a near lamp, for drops at the GPU's own positions.
#[test]
fn gpu_streaks_match_the_cpu_twin_with_lights() {
    use glam::DVec3;
    use rain_composite::gpu::cpu::rain_simulate::{NEAR_FIELD_MAX_RADIUS, streak_of};
    use rain_composite::gpu::probe::probe_streaks;
    use rain_composite::gpu::types::LightList;
    use rain_composite::lighting::prt::{channel_optics, prt_colour};
    use rain_composite::lighting::rtf::{ChannelIndices, Polarisation, WATER_RHO_RGB};
    use rain_composite::lighting::{LightSource, direct_colour};

    let Some(ctx) = gpu() else { return };
    // A long lens wide open, focused far: drops near the lens blur into large discs.
    let camera = Camera::new(640, 360, 0.45, 1.6, 0.05, 0.0);
    let lens = CameraConfig {
        fov_deg: 0.45f64.to_degrees(),
        f_number: 2.0,
        focus_m: 20.0,
        ..CameraConfig::default()
    };
    // Opacity well above 1 keeps the faint defocused streaks above the visibility cut.
    let rain = RainConfig {
        rate_mm_per_h: 40.0,
        near_m: 0.1,
        opacity: 30.0,
        seed: 11,
        ..RainConfig::default()
    };
    let setup = rain_composite::shot::rain::plan(&camera, &lens, &rain, 0.01, 0, (640, 360))
        .map(RainSetup::pack)
        .expect("rain");
    let optics =
        channel_optics(ChannelIndices(WATER_RHO_RGB), 9, Polarisation::default()).expect("optics");
    let tables = optics.map(|o| o.tabulate(1024).expect("table"));
    let rtf = RtfSh::from_optics(&optics, 4).expect("rtf");
    let mut env = EnvironmentSh::zeros(4);
    env.coeffs[0] = [0.8, 0.9, 1.0];
    env.coeffs[2] = [0.3, 0.35, 0.5];
    env.coeffs[7] = [0.05, -0.02, 0.01];
    let lights = vec![
        LightSource {
            direction_world: DVec3::new(0.3, -0.8, 0.5).normalize(),
            solid_angle_sr: 6.8e-5,
            radiance_rgb: [2e4, 1.9e4, 1.7e4],
            distance_m: None,
        },
        LightSource {
            direction_world: DVec3::new(0.14, 0.99, 0.08).normalize(),
            solid_angle_sr: 2e-3,
            radiance_rgb: [3000.0, 2500.0, 1500.0],
            distance_m: Some(6.0),
        },
    ];
    let t = 2.5;
    let params = setup.params_at(
        t,
        &FrameLight {
            env: env.clone(),
            lights: lights.clone(),
        },
        rtf.to_gpu_array(),
    );
    let list = LightList::new(&lights);
    let gpu_streaks = probe_streaks(&ctx, &setup, &params, &list, &tables).expect("streaks");
    let drops = probe_drops(&ctx, &setup, t, params.drop_count).expect("drops");
    let (mut drawn, mut capped, mut mismatched, mut lit) = (0, 0, 0, 0);
    let (mut compared, mut steep) = (0, 0);
    for (id, (g, d)) in gpu_streaks.iter().zip(&drops).enumerate() {
        let cpu = streak_of(
            &params,
            d.pos_m.as_dvec3(),
            d.vel_mps.as_dvec3(),
            d.width_mm as f64,
        );
        let Some(c) = cpu else {
            mismatched += (g.len_px >= 0.0) as usize;
            continue;
        };
        if g.len_px < 0.0 {
            mismatched += 1;
            continue;
        }
        drawn += 1;
        let near_cap = NEAR_FIELD_MAX_RADIUS * 360.0;
        capped += (c.r_eff_px >= near_cap * 0.999) as usize;
        let close = |a: f32, b: f64, tol: f64| (a as f64 - b).abs() <= tol * (1.0 + b.abs());
        assert!(
            close(g.r_eff_px, c.r_eff_px, 1e-3),
            "drop {id}: r_eff {} vs {}",
            g.r_eff_px,
            c.r_eff_px
        );
        assert!(
            close(g.alpha_scale, c.alpha_scale, 2e-3),
            "drop {id}: alpha {} vs {}",
            g.alpha_scale,
            c.alpha_scale
        );
        assert!(
            close(g.len_px, c.len_px, 1e-3),
            "drop {id}: len {} vs {}",
            g.len_px,
            c.len_px
        );
        assert!(
            close(g.q0_px[0], c.q0_px.x, 1e-3) && close(g.q0_px[1], c.q0_px.y, 1e-3),
            "drop {id}: q0"
        );
        for (k, gr) in [g.radiance0, g.radiance1].iter().enumerate() {
            let offset = camera.world_from_camera * c.ends_camera_m[k];
            let sh = prt_colour(&env, &rtf, offset);
            let direct = direct_colour(&lights, &tables, Some(offset), offset);
            for ch in 0..3 {
                let want = (sh[ch] + direct[ch]).max(0.0);
                let err = (gr[ch] as f64 - want).abs();
                // On a bow caustic F steps by several times per 0.18° bin, so the f32 angle's
                // last bits show; elsewhere the two agree to f32 rounding.
                if err > 2e-3 * want + 1e-4 {
                    steep += 1;
                    assert!(
                        err <= 2e-2 * want,
                        "drop {id} end {k} channel {ch}: GPU {} vs CPU {want} (SH {}, lights {})",
                        gr[ch],
                        sh[ch],
                        direct[ch]
                    );
                }
                compared += 1;
            }
            lit += (direct[1] > sh[1]) as usize;
        }
    }
    eprintln!(
        "{drawn} streaks compared, {capped} capped near the lens, {lit} ends lit mostly by \
         the lights, {mismatched} visibility mismatches, {steep} of {compared} radiances \
         beyond f32 rounding"
    );
    assert!(
        steep * 200 <= compared,
        "{steep} of {compared} radiances off"
    );
    assert!(
        lit * 10 < compared,
        "the environment never dominates: {lit} of {compared}"
    );
    assert!(drawn > 500, "{drawn} streaks");
    assert!(capped > 0, "no near-field drop reached the cap");
    assert!(
        lit > 0,
        "the lights never dominate: the test would not see them"
    );
    // f32 against f64 at the visibility threshold.
    assert!(
        mismatched * 200 <= drawn,
        "{mismatched} visibility mismatches"
    );
}

/// Cost of the direct light term in `rain_simulate`: the stage with 0, 1 and 16 lights on the
/// default rain of a 720p frame (run with `--ignored --nocapture`; medians of 15 runs, readback
/// included and the same in all three).
#[test]
#[ignore]
fn direct_light_cost() {
    use glam::DVec3;
    use rain_composite::gpu::probe::SimulateProbe;
    use rain_composite::gpu::types::LightList;
    use rain_composite::lighting::{LightConfig, LightEstimator, LightSource};

    let Some(ctx) = gpu() else { return };
    let camera = CameraConfig::default().camera(1280, 720);
    let setup = rain_composite::shot::rain::plan(
        &camera,
        &CameraConfig::default(),
        &RainConfig::default(),
        0.01,
        0,
        (1280, 720),
    )
    .map(RainSetup::pack)
    .expect("rain");
    let lighting = LightEstimator::new(&camera, 0, &LightConfig::default()).expect("lighting");
    let probe = SimulateProbe::new(&ctx, &setup, setup.drop_count(), lighting.transfer_tables());
    let params = lit(&setup, 1.0);
    let lamp = |i: usize| LightSource {
        direction_world: DVec3::new((i as f64).sin(), (i as f64).cos(), 0.2).normalize(),
        solid_angle_sr: 2e-3,
        radiance_rgb: [1000.0; 3],
        distance_m: i.is_multiple_of(2).then_some(3.0 + i as f64),
    };
    for n in [0usize, 1, 16, 0, 1, 16] {
        let lights = LightList::new(&(0..n).map(lamp).collect::<Vec<_>>());
        let mut t = Vec::new();
        for _ in 0..15 {
            let start = std::time::Instant::now();
            probe.run(&ctx, &params, &lights).expect("run");
            t.push(start.elapsed().as_secs_f64() * 1e3);
        }
        t.sort_by(f64::total_cmp);
        eprintln!(
            "{n:2} lights: rain_simulate + readback {:.2} ms (median), {} drops",
            t[t.len() / 2],
            setup.drop_count()
        );
    }
}

/// The haze's in-scatter along each pixel's ray is the drop's PRT colour of the environment for
/// that ray (here: brighter up and to the right), in a picture displayed rotated
/// by 90°: the GPU's coded → display → ray mapping is held to the CPU camera, pixel by pixel.
#[test]
fn haze_in_scatter_follows_each_pixels_ray() {
    use rain_composite::lighting::prt_colour;
    let Some(ctx) = gpu() else { return };
    // Coded 48×80, displayed 80×48 (rotated 90°).
    let (cw, ch) = (48u32, 80u32);
    let (dw, dh) = (ch, cw);
    let format = FrameFormat {
        width: cw,
        height: ch,
        chroma: Chroma::Cs444,
        bit_depth: 8,
    };
    let color = ColorParams {
        full_range: true,
        ..ColorParams::bt709(8)
    };
    let black = YuvFrame::filled(format, color, [0, 128, 128]);
    let camera = Camera::new(dw, dh, 70f64.to_radians(), 1.6, 10f64.to_radians(), 0.0);
    let rain = RainConfig {
        rate_mm_per_h: 20.0,
        scene_depth_m: 5000.0,
        ..RainConfig::default()
    };
    let setup = rain_composite::shot::rain::plan(
        &camera,
        &CameraConfig::default(),
        &rain,
        1.0 / 50.0,
        90,
        (cw, ch),
    )
    .map(RainSetup::pack)
    .expect("rain");
    assert!(setup.haze_alpha > 0.01, "haze {}", setup.haze_alpha);
    // An environment brighter up and to the right of the view.
    let mut env = EnvironmentSh::zeros(4);
    let toward = camera.world_from_camera * glam::DVec3::new(0.5, -0.3, 1.0).normalize();
    let y = rain_composite::lighting::sh::basis(toward, 4);
    for (c, yi) in env.coeffs.iter_mut().zip(&y) {
        *c = [(3.0 * yi) as f32, (2.0 * yi) as f32, (1.0 * yi) as f32];
    }
    env.coeffs[0] = [0.3, 0.3, 0.3];
    let rtf = RtfSh::water(1.333, 9, 4).expect("rtf");
    let mut params = setup.params_at(
        1.0,
        &FrameLight {
            env: env.clone(),
            lights: Vec::new(),
        },
        rtf.to_gpu_array(),
    );
    params.drop_count = 0; // the veil alone
    let mut comp = Compositor::new(ctx, format, &color, &setup).expect("compositor");
    let out = comp.render_one(&black, &params).expect("render");
    let alpha = setup.haze_alpha;
    let mut worst = 0.0f64;
    let mut brightest = 0.0f64;
    for yd in 0..dh {
        for xd in 0..dw {
            let ray = camera.ray_world(DVec2::new(xd as f64 + 0.5, yd as f64 + 0.5));
            let want = prt_colour(&env, &rtf, ray).map(|v| (v * alpha).max(0.0));
            let code = color.linear_to_code(want);
            // Displayed (x, y) ← coded (W − 1 − y, x) for a 90° display rotation.
            let (xc, yc) = (cw - 1 - yd, xd);
            let got = [0, 1, 2].map(|i| f64::from(out.sample(i, xc, yc)));
            for i in 0..3 {
                worst = worst.max((got[i] - code[i].round()).abs());
            }
            brightest = brightest.max(got[0]);
        }
    }
    assert!(
        brightest > 60.0,
        "the veil must show: brightest luma {brightest}"
    );
    assert!(worst <= 1.0, "GPU veil off the CPU by {worst} code values");
}
