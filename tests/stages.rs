//! Every GPU stage against its CPU twin (`gpu::cpu`, `rain::volume::sample_drop`), on whatever
//! adapter the machine has (lavapipe in CI); the drop twin under non-default settings; and
//! long clips: a drop ten hours in is placed as precisely as one ten seconds in.
//! Set `RAIN_COMPOSITE_REQUIRE_GPU=1` to turn a missing adapter into a failure.

use std::sync::Arc;

use rain_composite::config::{CameraConfig, RainConfig};
use rain_composite::gpu::GpuContext;
use rain_composite::gpu::cpu::{
    rain_simulate, rain_splashes, rain_streaks, rgb_to_yuv, yuv_to_rgb,
};
use rain_composite::gpu::probe::{probe_drops, probe_splashes, probe_streaks};
use rain_composite::gpu::shaders::Stage;
use rain_composite::gpu::types::{LightList, RainParams};
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::rain::volume::sample_drop;
use rain_composite::scene::Camera;
use rain_composite::video::{Chroma, ColorParams, FrameFormat, Matrix, Transfer, YuvFrame};

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/render.rs"]
mod render;
use render::{BLUISH_SKY, render_with, water_tables};

#[path = "common/pictures.rs"]
mod pictures;
use pictures::{codes, scatter};

/// One frame case: a picture format, its colour, and a display rotation.
struct Case {
    format: FrameFormat,
    color: ColorParams,
    rotation_deg: i32,
}

fn cases() -> Vec<Case> {
    let color = |matrix, full_range, transfer, bit_depth| ColorParams {
        matrix,
        full_range,
        transfer,
        bit_depth,
    };
    vec![
        Case {
            format: FrameFormat {
                width: 48,
                height: 32,
                chroma: Chroma::Cs420,
                bit_depth: 8,
            },
            color: ColorParams::bt709(8),
            rotation_deg: 0,
        },
        Case {
            format: FrameFormat {
                width: 40,
                height: 24,
                chroma: Chroma::Cs422,
                bit_depth: 10,
            },
            color: color(Matrix::Bt601, true, Transfer::Srgb, 10),
            rotation_deg: 90,
        },
        Case {
            format: FrameFormat {
                width: 33,
                height: 17,
                chroma: Chroma::Cs444,
                bit_depth: 8,
            },
            color: color(Matrix::Bt709, false, Transfer::Bt709, 8),
            rotation_deg: 180,
        },
    ]
}

/// A picture of scattered, mildly saturated code values.
fn picture(case: &Case) -> YuvFrame {
    let max = (1u32 << case.format.bit_depth) - 1;
    let mid = (max + 1) as f64 / 2.0;
    pictures::picture(case.format, case.color, |i, x, y| {
        let v = scatter(i, x, y) % (max + 1);
        if i > 0 {
            (mid + (v as f64 - mid) * 0.3).round() as u16
        } else {
            (v / 2 + max / 8) as u16
        }
    })
}

/// Heavy close rain over the case's displayed picture.
fn rain_for(case: &Case, rain: &RainConfig) -> RainSetup {
    let f = case.format;
    let (w, h) = rain_composite::video::frame::display_size(case.rotation_deg, f.width, f.height);
    let camera = Camera::new(w, h, 1.0, 1.6, 0.05, 0.0);
    rain_composite::shot::rain::plan(
        &camera,
        &CameraConfig::default(),
        rain,
        1.0 / 50.0,
        case.rotation_deg,
        (f.width, f.height),
    )
    .map(RainSetup::pack)
    .expect("rain")
}

fn heavy_rain() -> RainConfig {
    RainConfig {
        rate_mm_per_h: 60.0,
        opacity: 15.0,
        near_m: 0.3,
        far_m: 5.0,
        max_drops: 3000,
        ..RainConfig::default()
    }
}

/// The uniforms at `t_s` in a bluish environment brighter overhead, with a haze veil lit by
/// a sky brighter to one side.
fn lit(setup: &RainSetup, t_s: f64) -> RainParams {
    let mut p = render::lit(setup, t_s, &BLUISH_SKY, Some(0.9));
    p.env_sh[3] = [0.4, 0.3, 0.2, 0.0]; // brighter to one side
    p
}

/// Largest code difference and the share of samples that differ by more than one code.
fn compare(gpu: &[Vec<u16>; 3], cpu: &[Vec<u16>; 3]) -> (u16, f64) {
    let (mut worst, mut off, mut n) = (0u16, 0usize, 0usize);
    for (g, c) in gpu.iter().zip(cpu) {
        assert_eq!(g.len(), c.len());
        for (a, b) in g.iter().zip(c) {
            let d = a.abs_diff(*b);
            worst = worst.max(d);
            off += (d > 1) as usize;
            n += 1;
        }
    }
    (worst, off as f64 / n as f64)
}

/// The GPU frame with rain `setup` at `params`, and the CPU twins' frame: yuv_to_rgb →
/// rain_streaks (of the GPU's own streaks, so only rasterisation and blending are compared) →
/// rgb_to_yuv.
fn both_frames(
    ctx: &Arc<GpuContext>,
    case: &Case,
    setup: &RainSetup,
    params: &RainParams,
) -> ([Vec<u16>; 3], [Vec<u16>; 3], usize) {
    let frame = picture(case);
    let tables = water_tables(256);
    let gpu = render_with(ctx, &frame, setup, params, |comp| {
        comp.set_transfer_table(&tables)
    });
    let streaks = if params.drop_count > 0 {
        probe_streaks(ctx, setup, params, &LightList::new(&[]), &tables).expect("streaks")
    } else {
        Vec::new()
    };
    let mut canvas = yuv_to_rgb::yuv_to_rgb(&frame, params);
    rain_streaks::rain_streaks(&mut canvas, params, &streaks);
    let cpu = rgb_to_yuv::rgb_to_yuv(&canvas, case.format, &case.color);
    let drawn = streaks.iter().filter(|s| s.len_px >= 0.0).count();
    (codes(&gpu), cpu, drawn)
}

/// One loop over every stage: each against its CPU twin, on small frames of three formats
/// (4:2:0 8-bit BT.709, 4:2:2 10-bit full-range sRGB turned 90°, 4:4:4 8-bit turned 180°).
#[test]
fn every_stage_matches_its_cpu_twin() {
    let Some(ctx) = gpu() else { return };
    for stage in Stage::ALL {
        for case in cases() {
            let what = format!("{} on {:?}", stage.name(), case.format);
            match stage {
                // The colour stages, through a hazy frame without drops (a rainless frame
                // round-trips unchanged, so the haze is what exercises both directions).
                Stage::YuvToRgb | Stage::RgbToYuv => {
                    let setup = rain_for(
                        &case,
                        &RainConfig {
                            rate_mm_per_h: 0.0,
                            ..RainConfig::default()
                        },
                    );
                    let params = lit(&setup, 0.0);
                    // With a ground the veil follows each ray's distance to it (Koschmieder):
                    // the haze from 2 m, β = 0.05/m, the scene at 60 m.
                    let mut grounded = params;
                    grounded.ground_clip = 1;
                    grounded.haze = [2.0, 60.0, 0.05, (-0.05f32 * 58.0).exp()];
                    for (veil, params) in [("constant", params), ("by distance", grounded)] {
                        let (gpu, cpu, _) = both_frames(&ctx, &case, &setup, &params);
                        let (worst, share) = compare(&gpu, &cpu);
                        eprintln!("{what}, veil {veil}: worst {worst} codes");
                        // The canvas is f16 on the GPU: an encoded value a hair from a rounding
                        // edge may land one code away.
                        assert!(worst <= 1, "{what}, veil {veil}: {worst} codes off");
                        assert!(share == 0.0, "{what}, veil {veil}");
                    }
                }
                // The layer's output stage, on a canvas of its own: `tests/layers.rs`
                // (`rgba_out_matches_its_cpu_twin`).
                Stage::RgbaOut => {}
                // The drop states and the streaks they draw.
                Stage::RainProbe | Stage::RainSimulate => {
                    let setup = rain_for(&case, &heavy_rain());
                    let t = 1.3;
                    let params = lit(&setup, t);
                    let drops = probe_drops(&ctx, &setup, t, params.drop_count).expect("drops");
                    let streaks = probe_streaks(
                        &ctx,
                        &setup,
                        &params,
                        &LightList::new(&[]),
                        &water_tables(256),
                    )
                    .expect("streaks");
                    let (mut off, mut drawn) = (0, 0);
                    for (id, (g, s)) in drops.iter().zip(&streaks).enumerate() {
                        let c = sample_drop(setup.rainfall(), id as u64, t).expect("drop");
                        let err = (g.pos_m.as_dvec3() - c.position_m).length();
                        off += (err > 2e-3) as usize;
                        assert!(
                            (g.width_mm as f64 - c.width_mm).abs() < 1e-4 * c.width_mm,
                            "{what}"
                        );
                        if stage == Stage::RainSimulate {
                            let cpu = rain_simulate::streak_of(
                                &params,
                                g.pos_m.as_dvec3(),
                                g.vel_mps.as_dvec3(),
                                g.width_mm as f64,
                            );
                            match cpu {
                                Some(c) if s.len_px >= 0.0 => {
                                    drawn += 1;
                                    assert!(
                                        (s.len_px as f64 - c.len_px).abs()
                                            <= 1e-3 * (1.0 + c.len_px),
                                        "{what}: drop {id}"
                                    );
                                    assert!(
                                        (s.r_eff_px as f64 - c.r_eff_px).abs()
                                            <= 1e-3 * (1.0 + c.r_eff_px),
                                        "{what}: drop {id}"
                                    );
                                }
                                Some(c) => assert!(
                                    c.peak_alpha() < 0.6 / 255.0,
                                    "{what}: drop {id} hidden on the GPU"
                                ),
                                None => assert!(
                                    s.len_px < 0.0 || s.alpha_scale < 1e-2,
                                    "{what}: drop {id} drawn on the GPU only"
                                ),
                            }
                        }
                    }
                    eprintln!(
                        "{what}: {} drops, {off} off, {drawn} streaks compared",
                        drops.len()
                    );
                    assert!(off <= 2, "{what}: {off} drops off");
                    assert!(
                        stage != Stage::RainSimulate || drawn > 20,
                        "{what}: {drawn} streaks"
                    );
                }
                // Needs a ground and a wetting: tests/wet_ground.rs holds it to its twin.
                Stage::WetGround => {}
                // Needs water on the ground: tests/puddles_shade.rs holds it to its twin.
                Stage::Puddles => {}
                // The streaks drawn by compute (`--gpu-raster compute`) through the compositor,
                // held to the same twin as the quads (tests/streak_tiles.rs: to the quads).
                Stage::StreakTiles => {
                    let rain = RainConfig {
                        max_drops: 1500,
                        ..heavy_rain()
                    };
                    let mut setup = rain_for(&case, &rain);
                    setup.plan.gpu_raster = rain_composite::config::GpuRaster::Compute;
                    let params = lit(&setup, 2.1);
                    let (gpu, cpu, drawn) = both_frames(&ctx, &case, &setup, &params);
                    assert!(drawn > 20, "{what}: {drawn} streaks");
                    let (worst, share) = compare(&gpu, &cpu);
                    eprintln!("{what}: {drawn} streaks, worst {worst} codes, {share:.4} > 1 code");
                    assert!(worst <= 3, "{what}: {worst} codes off");
                    assert!(share < 0.02, "{what}: {share} of samples > 1 code off");
                }
                // Rasterisation and premultiplied blending of the streaks.
                // The splashes of the drops that land, the ground given (geometry and
                // coverage; their light is the drops' own, checked above).
                Stage::RainSplashes => {
                    // Looking down 40° at the ground 1.6 m below, drops (and so splashes)
                    // drawn 4× their size: the splashes of a tiny frame span pixels.
                    let f = case.format;
                    let (w, h) = rain_composite::video::frame::display_size(
                        case.rotation_deg,
                        f.width,
                        f.height,
                    );
                    let rain = RainConfig {
                        drop_scale: 4.0,
                        max_drops: 50_000,
                        ..heavy_rain()
                    };
                    let setup = rain_composite::shot::rain::plan(
                        &Camera::new(w, h, 1.0, 1.6, -0.7, 0.0),
                        &CameraConfig::default(),
                        &rain,
                        1.0 / 50.0,
                        case.rotation_deg,
                        (f.width, f.height),
                    )
                    .map(RainSetup::pack)
                    .expect("rain")
                    .with_ground(true);
                    let t = 1.3;
                    let params = lit(&setup, t);
                    let (ids, gpu) = probe_splashes(
                        &ctx,
                        &setup,
                        &params,
                        &LightList::new(&[]),
                        &water_tables(256),
                    )
                    .expect("splashes");
                    let slots = rain_composite::rain::physics::splash::SPLASH_SLOTS as usize;
                    let mut drawn = 0;
                    for (g, &id) in ids.iter().enumerate() {
                        let (_, cpu) = rain_splashes::splash_streaks(&setup, &params, id as u64, t);
                        for c in cpu {
                            let s = &gpu[g * slots + c.slot as usize];
                            // At a cut (a pixel wide, the faintest drawn) f32 may fall either side.
                            if s.len_px < 0.0 {
                                continue;
                            }
                            drawn += 1;
                            let q0 = glam::DVec2::new(s.q0_px[0] as f64, s.q0_px[1] as f64);
                            let off = (q0 - c.shape.q0_px).length();
                            assert!(off < 0.05, "{what}: drop {id} slot {}: {off} px", c.slot);
                        }
                    }
                    eprintln!(
                        "{what}: {drawn} splash streaks of {} landing drops",
                        ids.len()
                    );
                }
                Stage::RainStreaks => {
                    // At most 1500 drops on these tiny frames: the f16 canvas's rounding grows
                    // with the opaque streaks piled on one pixel.
                    let rain = RainConfig {
                        max_drops: 1500,
                        ..heavy_rain()
                    };
                    let setup = rain_for(&case, &rain);
                    let params = lit(&setup, 2.1);
                    let (gpu, cpu, drawn) = both_frames(&ctx, &case, &setup, &params);
                    assert!(drawn > 20, "{what}: {drawn} streaks");
                    let (worst, share) = compare(&gpu, &cpu);
                    eprintln!("{what}: {drawn} streaks, worst {worst} codes, {share:.4} > 1 code");
                    // f16 canvas and per-draw blending on the GPU against f64 on the CPU.
                    assert!(worst <= 3, "{what}: {worst} codes off");
                    assert!(share < 0.02, "{what}: {share} of samples > 1 code off");
                    let rainless = rain_for(
                        &case,
                        &RainConfig {
                            rate_mm_per_h: 0.0,
                            ..RainConfig::default()
                        },
                    );
                    let (plain, _, _) = both_frames(&ctx, &case, &rainless, &lit(&rainless, 2.1));
                    assert!(compare(&gpu, &plain).0 > 3, "{what}: the rain shows");
                }
            }
        }
    }
}

/// Drop states GPU against CPU twin at `t_s`: (largest position error among drops that wrapped
/// alike, drops that wrapped on one side only). Checks velocity, drawn diameter and width.
fn drop_errors(ctx: &GpuContext, setup: &RainSetup, t_s: f64, what: &str) -> (f64, usize) {
    let gpu = probe_drops(ctx, setup, t_s, 4096).expect("probe");
    assert!(gpu.len() > 500, "{what}: {} drops", gpu.len());
    let (mut worst, mut wrapped) = (0.0f64, 0);
    for (id, g) in gpu.iter().enumerate() {
        let c = sample_drop(setup.rainfall(), id as u64, t_s).expect("drop");
        let dv = (g.vel_mps.as_dvec3() - c.velocity_mps).length();
        assert!(dv < 1e-3, "{what} t={t_s}: drop {id} velocity off by {dv}");
        assert!(
            (g.diameter_mm as f64 - c.drawn_mm).abs() < 1e-4 * c.drawn_mm,
            "{what}: drop {id} drawn {} vs {}",
            g.diameter_mm,
            c.drawn_mm
        );
        assert!(
            (g.width_mm as f64 - c.width_mm).abs() < 1e-4 * c.width_mm,
            "{what}: drop {id} width"
        );
        let err = (g.pos_m.as_dvec3() - c.position_m).length();
        // f32 against f64: a drop a hair from its column's end (or a cell's side) may wrap on
        // one side only, and lands a column height (or a cell) away.
        let cell = setup.volume.grid.cell_size_m.min_element();
        if err > 0.5 * cell {
            wrapped += 1;
        } else {
            worst = worst.max(err);
        }
    }
    (worst, wrapped)
}

/// The drop twin under non-default settings: drop and fall-speed scales, a lens, display
/// rotations, gusts and wind, alone and together.
#[test]
fn drops_match_the_cpu_twin_under_swept_settings() {
    let Some(ctx) = gpu() else { return };
    // Heavy rain: where long or blurred streaks leave only the large drops visible at 320×180
    // (the plan simulates only those), still several hundred drops.
    let base = RainConfig {
        rate_mm_per_h: 150.0,
        seed: 5,
        ..RainConfig::default()
    };
    let lens = CameraConfig {
        f_number: 2.0,
        focus_m: 3.0,
        ..CameraConfig::default()
    };
    let sweeps: Vec<(&str, RainConfig, CameraConfig, i32)> = vec![
        (
            "drop scale 2.5",
            RainConfig {
                drop_scale: 2.5,
                ..base
            },
            CameraConfig::default(),
            0,
        ),
        (
            "fall speed ×0.4",
            RainConfig {
                fall_speed_scale: 0.4,
                ..base
            },
            CameraConfig::default(),
            0,
        ),
        (
            "fall speed ×3",
            RainConfig {
                fall_speed_scale: 3.0,
                ..base
            },
            CameraConfig::default(),
            0,
        ),
        ("lens f/2 at 3 m", base, lens, 0),
        ("rotated 90°", base, CameraConfig::default(), 90),
        (
            "gusts 4 m/s",
            RainConfig {
                gust_mps: 4.0,
                ..base
            },
            CameraConfig::default(),
            0,
        ),
        (
            "wind (6, −3) m/s",
            RainConfig {
                wind_mps: [6.0, -3.0],
                ..base
            },
            CameraConfig::default(),
            0,
        ),
        (
            "all together",
            RainConfig {
                drop_scale: 1.7,
                fall_speed_scale: 1.6,
                gust_mps: 3.0,
                wind_mps: [-4.0, 2.5],
                ..base
            },
            lens,
            270,
        ),
    ];
    for (what, rain, camera_config, rotation) in sweeps {
        let (w, h) = rain_composite::video::frame::display_size(rotation, 320, 180);
        let camera = Camera::new(w, h, 1.0, 1.6, 0.05, 0.0);
        let setup = rain_composite::shot::rain::plan(
            &camera,
            &camera_config,
            &rain,
            0.02,
            rotation,
            (320, 180),
        )
        .map(RainSetup::pack)
        .expect("rain");
        assert_eq!(
            setup.volume.motion.diameter_scale, rain.drop_scale,
            "{what}"
        );
        for t in [0.4, 7.9] {
            let (worst, wrapped) = drop_errors(&ctx, &setup, t, what);
            eprintln!("{what} t={t}: worst {worst:.1e} m, {wrapped} wrapped on one side");
            assert!(worst < 1e-4, "{what} t={t}: {worst} m");
            assert!(wrapped <= 4, "{what} t={t}: {wrapped} wrapped on one side");
        }
    }
}

/// Long clips: a drop ten hours in is placed as precisely against the CPU twin as one ten
/// seconds in (with the time as one `f32`, its step alone at 36 000 s is 3.9 ms, 2.5 cm of
/// fall at 6.5 m/s, and the phases' products lose far more).
#[test]
fn a_drop_ten_hours_in_is_placed_as_precisely_as_ten_seconds_in() {
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
    let (short, short_wrapped) = drop_errors(&ctx, &setup, 10.25, "t = 10 s");
    let (long, long_wrapped) = drop_errors(&ctx, &setup, 36_000.25, "t = 10 h");
    eprintln!(
        "largest position error: {short:.2e} m at 10 s, {long:.2e} m at 10 h \
         ({short_wrapped} and {long_wrapped} wrapped on one side)"
    );
    // The same tolerance at both times.
    let tolerance = 1e-4;
    assert!(short < tolerance && long < tolerance, "{short} m, {long} m");
    assert!(short_wrapped <= 4 && long_wrapped <= 4);
}
