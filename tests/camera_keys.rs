//! A moving camera (keyed pan, tilt, roll, height, field of view): the drops stay in the world
//! and each frame sees them through its own camera; the volume planned for the whole shot
//! holds every drop any frame sees.

use glam::{DMat3, DVec2, DVec3};
use rain_composite::config::{CameraConfig, RainConfig, RenderConfig};
use rain_composite::gpu::cpu::rain_simulate::streak_of;
use rain_composite::gpu::probe::{probe_drops, probe_streaks};
use rain_composite::gpu::types::LightList;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::keyframes::{Curve, Keyframes};
use rain_composite::lighting::frame_light::rtf_tables;
use rain_composite::lighting::{LightConfig, LightEstimator};
use rain_composite::rain::volume::Rainfall;
use rain_composite::rain::volume::sample_drop;
use rain_composite::scene::Camera;
use rain_composite::video::{Chroma, ColorParams, FrameFormat, YuvFrame};

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

const SIZE: (u32, u32) = (960, 540);

fn ramp(keys: &[(f64, f64)]) -> Option<Curve<f64>> {
    Some(Curve::new(keys.to_vec()).expect("keys"))
}

/// The rain of `rain` seen by `config` with `keys`: the camera at t = 0 and the setup.
fn rain_of(config: CameraConfig, rain: RainConfig, keys: &Keyframes) -> (Camera, RainSetup) {
    let camera = config.camera(SIZE.0, SIZE.1);
    let setup =
        rain_composite::shot::rain::plan_keyed(&camera, &config, &rain, keys, 0.02, 0, SIZE)
            .map(RainSetup::pack)
            .expect("rain");
    (camera, setup)
}

/// A small, still rain (no wind or gusts), few enough drops for the twin.
fn light_rain() -> RainConfig {
    RainConfig {
        rate_mm_per_h: 5.0,
        wind_mps: [0.0, 0.0],
        gust_mps: 0.0,
        far_m: 15.0,
        seed: 5,
        ..RainConfig::default()
    }
}

/// A level camera panned right by `pan_deg`, written out by hand: right, down, forward.
fn panned_by_hand(pan_deg: f64, camera: &Camera) -> Camera {
    let (s, c) = pan_deg.to_radians().sin_cos();
    Camera {
        world_from_camera: DMat3::from_cols(
            DVec3::new(c, -s, 0.0),
            DVec3::NEG_Z,
            DVec3::new(s, c, 0.0),
        ),
        ..*camera
    }
}

/// Pan 0 → 20° over 1 s: the streak of each drop at 1 s is its world position (which no camera
/// enters) seen through the panned camera, and a drop on the centre column of the unpanned
/// picture appears f·tan 20° to the left of the centre.
#[test]
fn a_pan_moves_the_image_of_drops_fixed_in_the_world() {
    let keys = Keyframes {
        pan_deg: ramp(&[(0.0, 0.0), (1.0, 20.0)]),
        ..Keyframes::default()
    };
    // Heavier rain than the others: the drops drawn near the picture's centre column are few.
    let rain = RainConfig {
        rate_mm_per_h: 20.0,
        ..light_rain()
    };
    let (camera, setup) = rain_of(CameraConfig::default(), rain, &keys);
    let params = setup.motion_at(1.0);
    let panned = panned_by_hand(20.0, &camera);
    let f = camera.focal_px();
    let centre_x = camera.principal_px().x;
    let want_x = centre_x - f * 20f64.to_radians().tan();
    let (mut drawn, mut on_axis) = (0, 0);
    for id in 0..setup.drop_count() as u64 {
        let Some(d) = sample_drop(setup.rainfall(), id, 1.0) else {
            continue;
        };
        let Some(s) = streak_of(&params, d.position_m, d.velocity_mps, d.width_mm) else {
            continue;
        };
        drawn += 1;
        let mid = s.q0_px + s.dir * (0.5 * s.len_px);
        let by_hand = panned.project_world(d.position_m).expect("in front");
        assert!(
            (mid - by_hand).length() < 0.05,
            "drop {id}: {mid} vs {by_hand}"
        );
        let before = camera.project_world(d.position_m);
        if before.is_some_and(|q| (q.x - centre_x).abs() < 0.5) {
            on_axis += 1;
            assert!(
                (mid.x - want_x).abs() < 1.0,
                "drop {id}: x {} vs {want_x}",
                mid.x
            );
        }
    }
    assert!(
        drawn > 1000 && on_axis > 3,
        "{drawn} drawn, {on_axis} on the axis"
    );
}

/// Drops drawn in the picture between the near distance and `far_m` at `t_s`, through the
/// frame's own camera (drawn: each plan simulates only the sizes that can show under its
/// poses, so the drawn drops, not the simulated ones, are what must agree).
fn in_view_count(setup: &RainSetup, t_s: f64, far_m: f64) -> usize {
    let camera = setup.camera_at(t_s);
    let params = setup.motion_at(t_s);
    let v = &setup.volume;
    (0..setup.drop_count() as u64)
        .filter_map(|id| {
            sample_drop(
                Rainfall::new(v, &setup.model, &setup.wind, setup.params.seed),
                id,
                t_s,
            )
        })
        .filter(|d| streak_of(&params, d.position_m, d.velocity_mps, d.width_mm).is_some())
        .filter(|d| {
            let c = camera.camera_from_world_point(d.position_m);
            c.z >= v.near_m
                && c.z <= far_m
                && camera.project_camera(c).is_some_and(|q| {
                    q.x >= 0.0
                        && q.y >= 0.0
                        && q.x < camera.width_px as f64
                        && q.y < camera.height_px as f64
                })
        })
        .count()
}

/// No holes in the envelope: at each frame of a 0 → 60° pan with a tilt and a zoom the drops
/// drawn in view are as many as a still camera at that pose draws, within Poisson noise (3σ),
/// and the planned volume grows with the envelope.
#[test]
fn a_moving_camera_sees_as_much_rain_as_a_still_one_at_each_pose() {
    let keys = Keyframes {
        pan_deg: ramp(&[(0.0, 0.0), (2.0, 60.0)]),
        tilt_deg: ramp(&[(0.0, 0.0), (2.0, 15.0)]),
        fov_deg: ramp(&[(0.5, 60.0), (2.0, 45.0)]),
        ..Keyframes::default()
    };
    let rain = light_rain();
    let (_, moving) = rain_of(CameraConfig::default(), rain, &keys);
    assert!(!moving.volume.budget_binds, "no budget");
    for t in [0.0, 0.37, 1.0, 1.61, 2.0] {
        let mut at = RenderConfig::default();
        at.apply_keys_at(&keys, t);
        let (_, still) = rain_of(at.camera, rain, &Keyframes::default());
        // The moving camera's far distance is the farthest any of its poses sees rain.
        let far_m = moving.volume.far_m.min(still.volume.far_m);
        let (a, b) = (
            in_view_count(&moving, t, far_m),
            in_view_count(&still, t, far_m),
        );
        let sigma = ((a + b) as f64).sqrt();
        eprintln!("t {t}: moving {a}, still {b} (σ {sigma:.0})");
        assert!(
            (a as f64 - b as f64).abs() <= 3.0 * sigma,
            "t {t}: {a} drops in view, a still camera sees {b}"
        );
        assert!(b > 500, "t {t}: {b}");
        assert!(moving.volume.grid.volume_m3 > 1.5 * still.volume.grid.volume_m3);
    }
}

/// The GPU draws each frame's drops through the frame's camera as the twin does, for a pan,
/// a tilt, a roll, a crane and a zoom together.
#[test]
fn the_gpu_follows_the_keyed_camera_as_the_twin_does() {
    let Some(ctx) = gpu() else { return };
    let keys = Keyframes {
        pan_deg: ramp(&[(0.0, -10.0), (1.0, 25.0)]),
        tilt_deg: ramp(&[(0.0, 5.0), (1.0, -10.0)]),
        roll_deg: ramp(&[(0.0, 0.0), (1.0, 4.0)]),
        height_m: ramp(&[(0.0, 1.6), (1.0, 3.0)]),
        fov_deg: ramp(&[(0.0, 60.0), (1.0, 40.0)]),
        ..Keyframes::default()
    };
    let (_, setup) = rain_of(CameraConfig::default(), light_rain(), &keys);
    let tables = rtf_tables(&Default::default()).expect("tables");
    for t in [0.0, 0.6, 1.0] {
        let params = setup.motion_at(t);
        let list = LightList::new(&[]);
        let gpu_streaks = probe_streaks(&ctx, &setup, &params, &list, &tables).expect("streaks");
        let drops = probe_drops(&ctx, &setup, t, params.drop_count).expect("drops");
        let (mut drawn, mut mismatched) = (0, 0);
        for (g, d) in gpu_streaks.iter().zip(&drops) {
            let cpu = streak_of(
                &params,
                d.pos_m.as_dvec3(),
                d.vel_mps.as_dvec3(),
                d.width_mm as f64,
            );
            match cpu {
                Some(c) if g.len_px >= 0.0 => {
                    drawn += 1;
                    let q = DVec2::new(g.q0_px[0] as f64, g.q0_px[1] as f64);
                    assert!((q - c.q0_px).length() < 0.02 * (1.0 + c.len_px), "t {t}");
                }
                None if g.len_px < 0.0 => {}
                _ => mismatched += 1,
            }
        }
        assert!(
            drawn > 500 && mismatched <= 3,
            "t {t}: {drawn}, {mismatched} mismatched"
        );
    }
}

/// The keyed camera's uniforms at t are the unkeyed camera's at that pose: focal length,
/// centre and rotation (a zoom, a crane, a pan).
#[test]
fn each_frame_gets_the_camera_at_its_pose() {
    let keys = Keyframes {
        pan_deg: ramp(&[(0.0, 0.0), (2.0, 30.0)]),
        height_m: ramp(&[(0.0, 1.6), (2.0, 4.0)]),
        fov_deg: ramp(&[(0.0, 60.0), (2.0, 30.0)]),
        ..Keyframes::default()
    };
    let (_, setup) = rain_of(CameraConfig::default(), light_rain(), &keys);
    let p = setup.motion_at(1.0);
    let still = CameraConfig {
        pan_deg: 15.0,
        height_m: 2.8,
        fov_deg: 45.0,
        ..CameraConfig::default()
    }
    .camera(SIZE.0, SIZE.1);
    assert!((p.focal_px as f64 - still.focal_px()).abs() < 1e-3);
    assert!((p.camera_pos_m[2] as f64 - 2.8).abs() < 1e-6);
    let forward = DVec3::new(
        p.camera_from_world_2[0] as f64,
        p.camera_from_world_2[1] as f64,
        p.camera_from_world_2[2] as f64,
    );
    let want = DVec3::new(15f64.to_radians().sin(), 15f64.to_radians().cos(), 0.0);
    assert!((forward - want).length() < 1e-6, "{forward}");
}

/// Beside a ground a camera may turn and zoom but not move: a keyed height is refused, naming
/// the ground; shutter keys are refused with their reason.
#[test]
fn moving_camera_refusals_are_named() {
    let mut config = RenderConfig::default();
    config.ground.mode = "horizon=0.6".parse().expect("mode");
    config.keyframes.pan_deg = ramp(&[(0.0, 0.0), (1.0, 10.0)]);
    config.validate().expect("a pan beside a ground");
    config.keyframes.height_m = ramp(&[(0.0, 1.6), (1.0, 3.0)]);
    let e = config
        .validate()
        .expect_err("ground with a crane")
        .to_string();
    assert!(
        e.contains("ground.mode") && e.contains("camera.height_m"),
        "{e}"
    );
    let mut tree = serde_json::json!({"camera": {"shutter_deg": [[0, 180], [1, 90]]}});
    let e = Keyframes::take(&mut tree).expect_err("shutter");
    assert!(
        e.contains("camera.shutter_deg") && e.contains("exposure"),
        "{e}"
    );
}

/// Every point any frame sees lies in a column: points drawn uniformly in the frustum slab
/// (near to far) of frames between the planned poses, of a pan with a tilt, a roll, a crane and
/// a zoom, found in the column grid by their cell and height.
#[test]
fn the_envelope_holds_every_frame_between_the_planned_poses() {
    let keys = Keyframes {
        pan_deg: ramp(&[(0.0, 0.0), (1.0, 50.0), (2.0, 35.0)]),
        tilt_deg: ramp(&[(0.0, -5.0), (2.0, 10.0)]),
        roll_deg: ramp(&[(0.0, 0.0), (2.0, -6.0)]),
        height_m: ramp(&[(0.0, 1.6), (2.0, 2.5)]),
        fov_deg: ramp(&[(0.0, 60.0), (1.3, 35.0)]),
        ..Keyframes::default()
    };
    let (_, setup) = rain_of(CameraConfig::default(), light_rain(), &keys);
    let grid = &setup.volume.grid;
    // Cell corners are the grid's origin plus whole cells.
    let origin = grid.columns[0].cell_min_m;
    let cells: std::collections::HashMap<(i64, i64), (f64, f64)> = grid
        .columns
        .iter()
        .map(|c| {
            let k = ((c.cell_min_m - origin) / grid.cell_size_m).round();
            ((k.x as i64, k.y as i64), (c.z_lo_m, c.z_hi_m))
        })
        .collect();
    let (near, far) = (setup.volume.near_m, setup.volume.far_m);
    let mut outside = 0;
    let n = 40_000u32;
    for i in 0..n {
        let u = |k: u32| rain_composite::rain::volume::drop_uniform(9, i, k);
        // Times off the planned samples (irrational steps); depth uniform in volume.
        let t = 2.0 * u(0);
        let camera = setup.camera_at(t);
        let s = (near.powi(3) + u(1) * (far.powi(3) - near.powi(3))).cbrt();
        let px = DVec2::new(
            u(2) * camera.width_px as f64,
            u(3) * camera.height_px as f64,
        );
        let ray = camera.ray_world(px);
        let axis = camera.world_from_camera * DVec3::Z;
        let p = camera.position_m + ray * (s / ray.dot(axis));
        if p.z < 0.0 {
            continue; // below the ground the volume stands on
        }
        let uv = DVec2::new(p.x, p.y) - grid.slope * p.z;
        let k = ((uv - origin) / grid.cell_size_m).floor();
        let inside = cells
            .get(&(k.x as i64, k.y as i64))
            .is_some_and(|&(lo, hi)| p.z >= lo - 1e-9 && p.z <= hi + 1e-9);
        outside += !inside as u32;
    }
    assert_eq!(
        outside, 0,
        "{outside} of {n} points seen outside the columns"
    );
}

/// Report (run with `--ignored --nocapture`): what a 0 → 60° pan costs against a still camera
/// at 1280×720 — drops simulated, the plan's time, and the light's per-frame remapping.
#[test]
#[ignore]
fn report_moving_camera_costs() {
    use rain_composite::lighting::envmap::EnvMapper;
    use std::time::Instant;
    let camera = CameraConfig::default().camera(1280, 720);
    let rain = RainConfig::default();
    println!("| camera | poses | drops | columns' volume (m³) | plan (ms) |");
    println!("|---|---|---|---|---|");
    for (name, pan) in [
        ("still", None),
        ("pan 0 → 60° over 4 s", ramp(&[(0.0, 0.0), (4.0, 60.0)])),
    ] {
        let keys = Keyframes {
            pan_deg: pan,
            ..Keyframes::default()
        };
        let start = Instant::now();
        let setup = rain_composite::shot::rain::plan_keyed(
            &camera,
            &CameraConfig::default(),
            &rain,
            &keys,
            0.02,
            0,
            (1280, 720),
        )
        .map(RainSetup::pack)
        .expect("rain");
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let poses = if keys.moves_camera() {
            keys.camera_samples_s(1.0).len()
        } else {
            1
        };
        println!(
            "| {name} | {poses} | {} | {:.1} | {ms:.0} |",
            setup.drop_count(),
            setup.volume.grid.volume_m3
        );
    }
    // The light per turned frame: the environment rotated in SH (a zoom rebuilds the map).
    let frame = frame_of(1280, 720, |p| [0.02 + 0.01 * (p.y / 720.0); 3]);
    let mut light = LightEstimator::new(&camera, 0, &LightConfig::default()).expect("light");
    let runs = 20;
    let mut ms = [0.0; 2];
    for (k, turned) in [false, true].into_iter().enumerate() {
        let start = Instant::now();
        for i in 0..runs {
            let pan_deg = if turned { 1.0 + i as f64 } else { 0.0 };
            let c = CameraConfig {
                pan_deg,
                ..CameraConfig::default()
            };
            light.set_camera(&c.camera(1280, 720)).expect("camera");
            std::hint::black_box(light.update(&frame, i as f64 / 25.0));
        }
        ms[k] = start.elapsed().as_secs_f64() * 1e3 / runs as f64;
    }
    println!(
        "light per frame: {:.1} ms still, {:.1} ms turning; the map rebuilt (a zoom): {:.1} ms",
        ms[0],
        ms[1],
        {
            let start = Instant::now();
            std::hint::black_box(EnvMapper::new(&camera, 4).expect("mapper"));
            start.elapsed().as_secs_f64() * 1e3
        }
    );
}

/// A 4:4:4 8-bit BT.709 frame whose displayed pixel (x, y) has linear RGB `f(x, y)`.
fn frame_of(w: u32, h: u32, f: impl Fn(DVec2) -> [f64; 3]) -> YuvFrame {
    let color = ColorParams::bt709(8);
    let format = FrameFormat {
        width: w,
        height: h,
        chroma: Chroma::Cs444,
        bit_depth: 8,
    };
    let mut frame = YuvFrame::filled(format, color, [0, 0, 0]);
    for y in 0..h as usize {
        for x in 0..w as usize {
            let code = color.linear_to_code(f(DVec2::new(x as f64 + 0.5, y as f64 + 0.5)));
            for (i, plane) in frame.planes.iter_mut().enumerate() {
                plane.data[y * plane.stride + x] = code[i] as u8;
            }
        }
    }
    frame
}

/// A lamp fixed in the world, filmed by a camera panning 0 → 30°: the light recovered from
/// each frame, read through that frame's camera, stays at the lamp's world direction within a
/// degree; read through the first camera (the test can tell) it swings with the pan.
#[test]
fn a_lamp_fixed_in_the_world_stays_put_while_the_camera_pans() {
    let (w, h) = (320, 180);
    let pan = Curve::new(vec![(0.0, 0.0), (1.2, 30.0)]).expect("pan");
    let camera_at = |t: f64| {
        CameraConfig {
            pan_deg: pan.at(t),
            ..CameraConfig::default()
        }
        .camera(w, h)
    };
    let (az, el) = (10f64.to_radians(), 8f64.to_radians());
    let lamp = DVec3::new(az.sin() * el.cos(), az.cos() * el.cos(), el.sin());
    // A dark street (world-fixed: darker sky above the horizon) and a clipped lamp 1.2° wide.
    let scene = |ray: DVec3| {
        if ray.angle_between(lamp) < 1.2f64.to_radians() {
            [1.0; 3]
        } else if ray.z > 0.0 {
            [0.01, 0.01, 0.012]
        } else {
            [0.03, 0.03, 0.028]
        }
    };
    let config = LightConfig::default();
    let mut follows = LightEstimator::new(&camera_at(0.0), 0, &config).expect("light");
    let mut still = LightEstimator::new(&camera_at(0.0), 0, &config).expect("light");
    let (mut worst_deg, mut swing_deg) = (0.0f64, 0.0f64);
    for k in 0..=30 {
        let t = k as f64 / 25.0;
        let camera = camera_at(t);
        let frame = frame_of(w, h, |px| scene(camera.ray_world(px)));
        follows.set_camera(&camera).expect("camera");
        // The turned environment against one mapped through this camera from scratch.
        let fresh = LightEstimator::new(&camera, 0, &config).expect("light");
        let (a, b) = (follows.environment(&frame), fresh.environment(&frame));
        let scale = b.coeffs[0][1].abs();
        for (x, y) in a.coeffs.iter().zip(&b.coeffs) {
            for c in 0..3 {
                assert!((x[c] - y[c]).abs() <= 1e-4 * scale, "t {t}: {x:?} vs {y:?}");
            }
        }
        let brightest = |l: &rain_composite::lighting::FrameLight| {
            l.lights
                .iter()
                .max_by(|a, b| a.solid_angle_sr.total_cmp(&b.solid_angle_sr))
                .map(|s| s.direction_world.angle_between(lamp).to_degrees())
                .expect("the lamp is found")
        };
        worst_deg = worst_deg.max(brightest(&follows.update(&frame, t)));
        swing_deg = swing_deg.max(brightest(&still.update(&frame, t)));
    }
    eprintln!("lamp direction: within {worst_deg:.2}° following the camera, {swing_deg:.1}° not");
    assert!(worst_deg < 1.0, "{worst_deg}°");
    assert!(swing_deg > 10.0, "{swing_deg}°");
}

/// Planning costs milliseconds a pose, so a camera that turns far is planned for a bounded
/// number of poses (a coarser step, the envelope still holding every frame's drops), and a
/// camera that spins beyond what a coarse step covers is refused by name, at once.
#[test]
fn a_camera_that_turns_far_is_planned_for_bounded_poses() {
    let started = std::time::Instant::now();
    let two_turns = Keyframes {
        pan_deg: ramp(&[(0.0, 0.0), (2.0, 720.0)]),
        ..Keyframes::default()
    };
    let (_, setup) = rain_of(CameraConfig::default(), light_rain(), &two_turns);
    for t in [0.0, 0.5, 1.3, 2.0] {
        assert!(in_view_count(&setup, t, setup.volume.far_m) > 100, "t {t}");
    }
    let spin: Vec<(f64, f64)> = (0..16)
        .map(|k| (k as f64, if k % 2 == 0 { -360.0 } else { 360.0 }))
        .collect();
    let spinning = Keyframes {
        pan_deg: ramp(&spin),
        ..Keyframes::default()
    };
    let config = CameraConfig::default();
    let camera = config.camera(SIZE.0, SIZE.1);
    let e = rain_composite::shot::rain::plan_keyed(
        &camera,
        &config,
        &light_rain(),
        &spinning,
        0.02,
        0,
        SIZE,
    )
    .map(RainSetup::pack)
    .map(|_| ())
    .expect_err("a spin of 30 turns is refused")
    .to_string();
    assert!(e.contains("camera keys") && e.contains("3600"), "{e}");
    assert!(started.elapsed().as_secs() < 60, "{:?}", started.elapsed());
}
