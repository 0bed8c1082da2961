//! Rain that lands: with a ground given, a streak ends where its drop meets the ground during
//! the exposure (CPU twin and GPU), nothing of a streak reaches below the ground, and without
//! a ground the render is unchanged, byte for byte.

use std::path::Path;

use glam::DVec3;
use rain_composite::config::{CameraConfig, RainConfig, RenderConfig};
use rain_composite::gpu::cpu::rain_simulate::{self, StreakShape};
use rain_composite::gpu::probe::{probe_drops, probe_streaks};
use rain_composite::gpu::types::{LightList, RainParams};
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::rain::volume::sample_drop;
use rain_composite::scene::Camera;
use tempfile::TempDir;

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::s;

#[path = "common/binary.rs"]
mod binary;
use binary::bin;

#[path = "common/render.rs"]
mod render;
use render::{looking_down, rain_seen_by, water_tables};

const EXPOSURE_S: f64 = 0.02;

/// Heavy rain close to the camera, `w`×`h`, seen through `config`'s camera, with or without
/// the ground's impacts.
fn setup(config: &RenderConfig, w: u32, h: u32, ground: bool) -> (Camera, RainSetup) {
    let rain = RainConfig {
        rate_mm_per_h: 60.0,
        opacity: 15.0,
        near_m: 0.3,
        far_m: 8.0,
        max_drops: 20_000,
        drop_scale: 2.0,
        ..RainConfig::default()
    };
    rain_seen_by(config, (w, h), &rain, EXPOSURE_S, ground)
}

/// Where a drop at `pos_m` (mid-exposure) moving at `vel_mps` is in the picture at the start of
/// the exposure and where it meets the ground z = 0, by the camera model in `f64`: the
/// independent reference for a landing streak.
fn impact_path_px(camera: &Camera, pos_m: DVec3, vel_mps: DVec3) -> (glam::DVec2, glam::DVec2) {
    let start = pos_m - vel_mps * (0.5 * EXPOSURE_S);
    let t_hit_s = start.z / -vel_mps.z;
    let hit = start + vel_mps * t_hit_s;
    assert!(hit.z.abs() < 1e-12);
    (
        camera.project_world(start).expect("in front"),
        camera.project_world(hit).expect("in front"),
    )
}

/// The world point of a camera-space streak end.
fn world_of(camera: &Camera, c: DVec3) -> DVec3 {
    camera.position_m + camera.world_from_camera * c
}

/// A drop landing 70 % into the exposure draws a streak from where it was to where it lands:
/// its length is the projected distance fallen until the impact, and it covers each pixel for
/// 70 % of the time it would in the air. One that landed before the exposure is not drawn.
#[test]
fn a_drop_landing_mid_exposure_draws_the_path_until_its_impact() {
    let config = looking_down();
    let (camera, s) = setup(&config, 640, 360, true);
    eprintln!("far {} m, {} drops", s.volume.far_m, s.volume.simulated);
    let mut p = s.motion_at(0.0);
    p.drop_weight = 1.0;
    let mut off = p;
    off.ground_clip = 0;
    let ahead = camera.world_from_camera * DVec3::new(0.0, 0.0, 6.0);
    for vel in [DVec3::new(0.0, 0.0, -7.0), DVec3::new(2.5, -1.0, -6.0)] {
        let travel = -vel.z * EXPOSURE_S;
        // Mid-exposure height: the start is 0.7 of the exposure's fall above the ground.
        let z_mid = 0.7 * travel - 0.5 * travel;
        let pos = DVec3::new(
            camera.position_m.x + ahead.x,
            camera.position_m.y + ahead.y,
            z_mid,
        );
        let landed = rain_simulate::streak_of(&p, pos, vel, 2.0).expect("drawn");
        let (q0, q_hit) = impact_path_px(&camera, pos, vel);
        let want_px = (q_hit - q0).length();
        eprintln!(
            "{vel}: streak {:.4} px, fall until impact {want_px:.4} px (off by {:.1e})",
            landed.len_px,
            (landed.len_px - want_px).abs()
        );
        assert!(
            (landed.len_px - want_px).abs() < 1.0 && (landed.q0_px - q0).length() < 1.0,
            "{vel}: streak {} px from {}, the fall until impact {want_px} px from {q0}",
            landed.len_px,
            landed.q0_px
        );
        assert!((landed.exposed_fraction - 0.7).abs() < 1e-4);
        // In the air throughout (no ground), the same drop draws the whole exposure.
        let whole = rain_simulate::streak_of(&off, pos, vel, 2.0).expect("drawn");
        // Perspective aside, the landed path is 70 % of the whole one.
        let ratio = landed.len_px / whole.len_px;
        assert!((ratio - 0.7).abs() < 0.02, "{ratio}");
        // Coverage: in the air for 70 % of the exposure, the streak covers each pixel on its
        // path as long as before, over a path 70 % as long in time: alpha scales by 0.7 (apart
        // from the drawn width, which follows the nearest end).
        let coverage = |s: &StreakShape| s.alpha_scale * (s.r_eff_px / s.r_px).powi(2);
        assert!((coverage(&landed) / coverage(&whole) - 0.7).abs() < 1e-4);
        // Landed before the exposure opened: nothing.
        let gone = DVec3::new(pos.x, pos.y, -0.6 * travel);
        assert!(rain_simulate::streak_of(&p, gone, vel, 2.0).is_none());
        assert!(rain_simulate::streak_of(&off, gone, vel, 2.0).is_some());
    }
}

/// Every streak end of every drop, at several times, lies on or above the ground with a
/// ground given; without one some do not (so the check can fail).
#[test]
fn no_streak_reaches_below_the_ground() {
    let config = looking_down();
    let count = |ground: bool| {
        let (camera, s) = setup(&config, 320, 180, ground);
        eprintln!("{}", s.summary());
        let (mut below, mut landed) = (0, 0);
        for t in [0.0, 0.37, 1.9, 12.25] {
            let p = s.motion_at(t);
            for id in 0..s.volume.simulated {
                let d = sample_drop(s.rainfall(), id, t).expect("drop");
                let Some(st) = rain_simulate::streak_of(&p, d.position_m, d.velocity_mps, 2.0)
                else {
                    continue;
                };
                landed += (st.exposed_fraction < 1.0) as usize;
                for c in st.ends_camera_m {
                    below += (world_of(&camera, c).z < -1e-4) as usize;
                }
            }
        }
        (below, landed)
    };
    let (below_with, landed) = count(true);
    let (below_without, _) = count(false);
    eprintln!(
        "streak ends below the ground: {below_with} with a ground, {below_without} without; {landed} streaks landed"
    );
    assert_eq!(below_with, 0);
    assert!(below_without > 10, "{below_without}");
    assert!(landed > 10, "{landed}");
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-3 * (1.0 + b.abs())
}

/// The GPU ends streaks at the impact as the CPU twin does, and a landing drop's GPU streak is
/// as long as its projected fall until the impact.
#[test]
fn the_gpu_ends_streaks_at_the_impact_like_its_twin() {
    let Some(ctx) = gpu() else { return };
    let config = looking_down();
    let (camera, s) = setup(&config, 160, 90, true);
    eprintln!("{}", s.summary());
    let tables = water_tables(256);
    let (mut landed, mut compared, mut worst_px) = (0, 0, 0.0f64);
    for t in [0.4, 2.75] {
        let p: RainParams = s.motion_at(t);
        let drops = probe_drops(&ctx, &s, t, p.drop_count).expect("drops");
        let streaks = probe_streaks(&ctx, &s, &p, &LightList::new(&[]), &tables).expect("streaks");
        for (id, (g, gs)) in drops.iter().zip(&streaks).enumerate() {
            let (pos, vel) = (g.pos_m.as_dvec3(), g.vel_mps.as_dvec3());
            let cpu: Option<StreakShape> =
                rain_simulate::streak_of(&p, pos, vel, g.width_mm as f64);
            match cpu {
                Some(c) if gs.len_px >= 0.0 => {
                    compared += 1;
                    assert!(
                        close(gs.len_px as f64, c.len_px),
                        "drop {id}: {} vs {}",
                        gs.len_px,
                        c.len_px
                    );
                    assert!(
                        (gs.alpha_scale as f64 - c.alpha_scale).abs() <= 1e-3 * c.alpha_scale,
                        "drop {id}: alpha {} vs {}",
                        gs.alpha_scale,
                        c.alpha_scale
                    );
                    // Away from the near plane (which would cut the streak's start).
                    let clear = c
                        .ends_camera_m
                        .iter()
                        .all(|e| e.z > p.near_clip_m as f64 + 1e-3);
                    if c.exposed_fraction < 1.0 && clear {
                        landed += 1;
                        let (q0, q_hit) = impact_path_px(&camera, pos, vel);
                        let want = (q_hit - q0).length();
                        worst_px = worst_px.max((gs.len_px as f64 - want).abs());
                        assert!(
                            (gs.len_px as f64 - want).abs() < 1.0,
                            "drop {id}: GPU streak {} px, fall until impact {want} px",
                            gs.len_px
                        );
                    }
                }
                Some(c) => assert!(c.peak_alpha() < 0.6 / 255.0, "drop {id} hidden on the GPU"),
                None => assert!(
                    gs.len_px < 0.0 || gs.alpha_scale < 1e-2,
                    "drop {id} drawn on the GPU only"
                ),
            }
        }
    }
    eprintln!(
        "{compared} streaks compared, {landed} of them landing; worst GPU length against the \
         fall until impact {worst_px:.1e} px"
    );
    assert!(
        compared > 100 && landed > 10,
        "{compared} compared, {landed} landed"
    );
}

/// Without a ground — no flag, `--ground none`, or `ground.mode` "none" in a configuration —
/// the output is the same, byte for byte; a given ground changes it.
#[test]
fn without_a_ground_the_render_is_unchanged_byte_for_byte() {
    let dir = TempDir::new().expect("tmp");
    let input = fixtures::sky_over_ground(dir.path(), "in.mkv", (320, 180), 45, 0.12);
    let config = dir.path().join("none.json");
    std::fs::write(&config, r#"{"ground": {"mode": "none"}}"#).expect("write");
    let render = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let o = bin()
            .args([
                s(&input),
                "-o",
                s(&out),
                "--rain",
                "60",
                "--opacity",
                "20",
                "--cpu",
            ])
            .args(["--codec", "ffv1", "--fov", "90", "--drop-scale", "3"])
            .args(extra)
            .output()
            .expect("spawn");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        fixtures::framemd5(&out, "0:v:0", true)
    };
    let plain = render("plain.mkv", &["--tilt=-25"]);
    assert!(
        plain == render("none.mkv", &["--tilt=-25", "--ground", "none"]),
        "--ground none"
    );
    assert!(
        plain == render("config.mkv", &["--tilt=-25", "--config", s(&config)]),
        "ground.mode none"
    );
    // The same camera pose given by its horizon: drops now land.
    let row = {
        let c = RenderConfig {
            camera: CameraConfig {
                tilt_deg: -25.0,
                fov_deg: 90.0,
                ..CameraConfig::default()
            },
            ..RenderConfig::default()
        };
        let cam = c.camera(320, 180).expect("camera");
        rain_composite::scene::GroundPlane::LEVEL
            .horizon_row(&cam)
            .expect("row")
    };
    let landed = render("ground.mkv", &["--ground", &format!("horizon={row}")]);
    assert!(plain != landed, "a given ground changes the rain");
}

/// A 16-bit preview's luma-ish samples (the green channel) of `path`.
fn green16(path: &Path) -> (u32, u32, Vec<u16>) {
    let img = image::open(path).expect("png").into_rgb16();
    let (w, h) = img.dimensions();
    (w, h, img.pixels().map(|p| p.0[1]).collect())
}

/// The rendered picture near the horizon: with the drops kept beyond 1.5 m (the near clip of
/// `--near 3`), a pixel whose ray meets the ground nearer than that sees only ground, so rain
/// there can only be a drop below the ground. With the ground given, no such pixel changes;
/// the same camera without the ground's impacts changes some.
#[test]
fn rendered_rain_stays_above_the_ground_in_the_picture() {
    let dir = TempDir::new().expect("tmp");
    let input = fixtures::sky_over_ground(dir.path(), "in.mkv", (320, 180), 45, 0.12);
    let tilt_deg = -30.0;
    let mut config = RenderConfig::default();
    (config.camera.fov_deg, config.camera.tilt_deg) = (90.0, tilt_deg);
    config.camera.height_m = 0.5;
    let camera = config.camera(320, 180).expect("camera");
    let row = rain_composite::scene::GroundPlane::LEVEL
        .horizon_row(&camera)
        .expect("row");
    let near_clip_m = 0.5 * 3.0;
    let preview = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let o = bin()
            .args([
                "preview",
                s(&input),
                "--frame",
                "1",
                "-o",
                s(&out),
                "--bits",
                "16",
            ])
            .args(["--rain", "60", "--drop-scale", "3", "--fov", "90"])
            // Streaks 2.8 m long from a camera 0.5 m above the ground: what would reach below
            // the ground shows far into the near ground's part of the picture.
            .args([
                "--fall-speed-scale",
                "10",
                "--shutter",
                "360",
                "--camera-height",
                "0.5",
            ])
            .args([
                "--near",
                "3",
                "--f-number",
                "0",
                "--scene-depth",
                "0",
                "--cpu",
            ])
            .args(extra)
            .output()
            .expect("spawn");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        green16(&out)
    };
    let tilt = format!("--tilt={tilt_deg}");
    let (w, h, dry) = preview("dry.png", &[&tilt, "--opacity", "0"]);
    let ground = format!("horizon={row}");
    let landed = preview("ground.png", &["--opacity", "20", "--ground", &ground]).2;
    // The given ground also wets: the rain is what differs from the same ground without it.
    let dry_ground = preview("dry_ground.png", &["--opacity", "0", "--ground", &ground]).2;
    let through = preview("through.png", &[&tilt, "--opacity", "20"]).2;
    // Pixels whose ray meets the ground nearer (in camera depth) than 90 % of the near clip.
    let r_cam = camera.world_from_camera.transpose();
    let ground_only = |i: usize| {
        let px = glam::DVec2::new((i as u32 % w) as f64 + 0.5, (i as u32 / w) as f64 + 0.5);
        let ray = camera.ray_world(px);
        ray.z < 0.0 && (r_cam * (ray * (camera.position_m.z / -ray.z))).z < 0.9 * near_clip_m
    };
    let region = (0..(w * h) as usize).filter(|&i| ground_only(i)).count();
    let changed = |frame: &[u16], base: &[u16]| {
        (0..(w * h) as usize)
            .filter(|&i| ground_only(i) && frame[i].abs_diff(base[i]) > 64)
            .count()
    };
    let rain_anywhere = (0..(w * h) as usize)
        .filter(|&i| landed[i].abs_diff(dry_ground[i]) > 64)
        .count();
    let (with, without) = (changed(&landed, &dry_ground), changed(&through, &dry));
    eprintln!(
        "{region} pixels see only ground nearer than the drops; rain changes {with} of them with \
         the ground, {without} without; {rain_anywhere} pixels changed in all"
    );
    assert!(
        region > 1000 && rain_anywhere > 500,
        "{region} {rain_anywhere}"
    );
    assert_eq!(with, 0);
    assert!(without > 0, "{without}");
}

/// A given ground is the level world ground z = 0 seen by the render's camera: `horizon=ROW`
/// puts the horizon of z = 0 at ROW with the roll asked for, `plane=n,d` makes z = 0 the plane
/// n·X + d = 0 of the camera's frame at height d/|n|; and a configuration giving the pose twice
/// (`auto` included) is refused naming both.
#[test]
fn the_given_ground_is_the_level_world_ground() {
    let level = rain_composite::scene::GroundPlane::LEVEL;
    let mut c = RenderConfig::default();
    c.ground.mode = "horizon=0.3,roll=10".parse().expect("mode");
    c.validate().expect("valid");
    let cam = c.camera(640, 360).expect("camera");
    assert!((level.horizon_row(&cam).expect("row") - 0.3).abs() < 1e-12);
    assert!((level.pose(&cam).roll_rad.to_degrees() - 10.0).abs() < 1e-9);
    assert!((cam.position_m.z - c.camera.height_m).abs() < 1e-12);
    let n = DVec3::new(0.2, -0.9, 0.35);
    c.ground.mode = "plane=0.2,-0.9,0.35,2.5".parse().expect("mode");
    let cam = c.camera(640, 360).expect("camera");
    assert!((level.normal_camera(&cam) - n.normalize()).length() < 1e-12);
    assert!((cam.position_m.z - 2.5 / n.length()).abs() < 1e-12);
    c.camera.tilt_deg = 5.0;
    let e = c.validate().expect_err("pose twice").to_string();
    assert!(
        e.contains("ground.mode") && e.contains("camera.tilt_deg"),
        "{e}"
    );
    // `auto` estimates the pose too.
    let auto = RenderConfig::from_json(r#"{"ground": {"mode": "auto"}}"#).expect("parses");
    auto.validate().expect("auto");
    let e = RenderConfig::from_json(r#"{"ground": {"mode": "auto"}, "camera": {"roll_deg": 2}}"#)
        .expect("parses")
        .validate()
        .expect_err("auto with a roll")
        .to_string();
    assert!(
        e.contains("ground.mode") && e.contains("camera.roll_deg"),
        "{e}"
    );
}
