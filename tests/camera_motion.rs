//! The camera's motion estimated from the frames: synthetic shots rendered through the
//! project's own camera model (a textured sphere of directions around a camera that turns and
//! zooms about its centre) at seeded random poses, the estimate against the poses drawn; a
//! still shot stays exactly still; a cut resets; the drops of a pan stay in the world through
//! the estimated cameras; the pose file round-trips through `inspect camera`.

use std::sync::atomic::AtomicBool;

use glam::DVec3;
use rain_composite::config::{CameraConfig, RainConfig, RenderConfig};
use rain_composite::gpu::cpu::rain_simulate::streak_of;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::rain::volume::sample_drop;
use rain_composite::rng::{SplitMix64, splitmix64};
use rain_composite::scene::Camera;
use rain_composite::scene::motion::track::Image;
use rain_composite::scene::motion::{Estimator, MotionSource, PoseTrack};

#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::{ffmpeg, s};

const SIZE: (u32, u32) = (640, 360);
const FPS: f64 = 25.0;

/// Lattice value noise in 3-D, smoothstep-interpolated, in [0, 1].
fn value_noise(p: DVec3, seed: u64) -> f64 {
    let c = p.floor();
    let f = p - c;
    let s = f * f * (DVec3::splat(3.0) - 2.0 * f);
    let h = |dx: i64, dy: i64, dz: i64| {
        let k = splitmix64(
            seed ^ ((c.x as i64 + dx) as u64).wrapping_mul(0x9E37_79B9)
                ^ ((c.y as i64 + dy) as u64).wrapping_mul(0x85EB_CA6B_0000)
                ^ ((c.z as i64 + dz) as u64).wrapping_mul(0xC2B2_AE35_0000_0000),
        );
        (k >> 11) as f64 / (1u64 << 53) as f64
    };
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let x00 = lerp(h(0, 0, 0), h(1, 0, 0), s.x);
    let x10 = lerp(h(0, 1, 0), h(1, 1, 0), s.x);
    let x01 = lerp(h(0, 0, 1), h(1, 0, 1), s.x);
    let x11 = lerp(h(0, 1, 1), h(1, 1, 1), s.x);
    lerp(lerp(x00, x10, s.y), lerp(x01, x11, s.y), s.z)
}

/// The world's brightness in the direction `d`: three octaves of noise (about 3°, 1° and 0.4°
/// cells), so corners exist at every field of view drawn.
fn world(d: DVec3, seed: u64) -> f64 {
    0.5 * value_noise(d * 20.0, seed)
        + 0.3 * value_noise(d * 60.0, seed + 1)
        + 0.2 * value_noise(d * 150.0, seed + 2)
}

/// The frame `camera` sees of the world `seed`, with sensor noise of σ `noise` drawn by
/// `noise_seed`.
fn frame(camera: &Camera, seed: u64, noise: f64, noise_seed: u64) -> Image {
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    let mut rng = SplitMix64(noise_seed);
    let data = (0..w * h)
        .map(|i| {
            let px = glam::DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            let n = if noise > 0.0 {
                // Uniform with standard deviation `noise`.
                (rng.next_f64() - 0.5) * noise * 12f64.sqrt()
            } else {
                0.0
            };
            (world(camera.ray_world(px), seed) + n) as f32
        })
        .collect();
    Image {
        width: w,
        height: h,
        data,
    }
}

/// A camera's pose at one frame.
#[derive(Debug, Clone, Copy)]
struct Pose {
    pan_deg: f64,
    tilt_deg: f64,
    roll_deg: f64,
    fov_deg: f64,
}

impl Pose {
    fn camera(&self) -> Camera {
        CameraConfig {
            fov_deg: self.fov_deg,
            tilt_deg: self.tilt_deg,
            roll_deg: self.roll_deg,
            pan_deg: self.pan_deg,
            ..CameraConfig::default()
        }
        .camera(SIZE.0, SIZE.1)
    }
}

/// A panning shot drawn with `seed`: field of view 40–90°, a non-integer tilt −40…+20° and
/// roll ±20° at the start, a pan of 5–30°/s either way with a slow tilt, handheld shake
/// (0.3–1° at 1–4 Hz on each axis), and on every other shot a zoom in of up to 15 %.
fn panning_shot(seed: u64, frames: usize) -> Vec<Pose> {
    let mut r = SplitMix64(seed);
    let mut u = |a: f64, b: f64| a + (b - a) * r.next_f64();
    let fov0 = u(40.0, 90.0);
    let (tilt0, roll0) = (u(-40.0, 20.0), u(-20.0, 20.0));
    let pan_rate = u(5.0, 30.0) * if u(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
    let tilt_rate = u(-3.0, 3.0);
    let shake: Vec<(f64, f64, f64)> = (0..3)
        .map(|_| (u(0.3, 1.0), u(1.0, 4.0), u(0.0, std::f64::consts::TAU)))
        .collect();
    let zoom_end = if seed.is_multiple_of(2) {
        u(1.0, 1.15)
    } else {
        1.0
    };
    (0..frames)
        .map(|i| {
            let t = i as f64 / FPS;
            let wave = |k: usize| {
                let (a, f, ph) = shake[k];
                a * ((std::f64::consts::TAU * f * t + ph).sin() - ph.sin())
            };
            let zoom = 1.0 + (zoom_end - 1.0) * t / (frames as f64 / FPS);
            Pose {
                pan_deg: pan_rate * t + wave(0),
                tilt_deg: tilt0 + tilt_rate * t + wave(1),
                roll_deg: roll0 + wave(2),
                fov_deg: 2.0 * ((0.5 * fov0.to_radians()).tan() / zoom).atan().to_degrees(),
            }
        })
        .collect()
}

/// The estimate of a shot whose first camera is known (its field of view, tilt and roll, as
/// `--fov`, `--tilt` and `--roll` give them), from its frames.
fn estimate(poses: &[Pose], world_seed: u64, noise: f64) -> PoseTrack {
    let first = Pose {
        pan_deg: 0.0,
        ..poses[0]
    }
    .camera();
    let mut e = Estimator::new(first);
    for (i, p) in poses.iter().enumerate() {
        let img = frame(&p.camera(), world_seed, noise, 1000 + i as u64);
        e.push(img, 1.0, i as f64 / FPS, false);
    }
    e.finish().track
}

/// Worst per-frame errors: pan, tilt, roll (degrees) and zoom (fraction).
fn errors(track: &PoseTrack, poses: &[Pose]) -> [f64; 4] {
    let mut worst = [0.0f64; 4];
    let half_tan = |fov: f64| (0.5 * fov.to_radians()).tan();
    for (f, p) in track.frames.iter().zip(poses) {
        let e = [
            f.pan_deg - (p.pan_deg - poses[0].pan_deg),
            f.tilt_deg - p.tilt_deg,
            f.roll_deg - p.roll_deg,
            half_tan(p.fov_deg) / half_tan(f.fov_deg) - 1.0,
        ];
        for k in 0..4 {
            worst[k] = worst[k].max(e[k].abs());
        }
    }
    worst
}

/// Seeded panning shots with shake and zoom: every frame's pan within 0.5°, tilt and roll
/// within 0.5°, zoom within 1 %.
#[test]
fn panning_shots_are_estimated_within_half_a_degree() {
    let frames = 40;
    let mut all = [0.0f64; 4];
    for seed in 0..6u64 {
        let poses = panning_shot(seed, frames);
        let track = estimate(&poses, 50 + seed, 0.004);
        assert_eq!(track.frames.len(), frames);
        let e = errors(&track, &poses);
        eprintln!(
            "shot {seed}: fov {:.1}°, tilt {:.1}°, roll {:.1}°, pan over {:.1}°: worst pan {:.3}°, \
             tilt {:.3}°, roll {:.3}°, zoom {:.2} %",
            poses[0].fov_deg,
            poses[0].tilt_deg,
            poses[0].roll_deg,
            poses[frames - 1].pan_deg,
            e[0],
            e[1],
            e[2],
            100.0 * e[3]
        );
        for k in 0..4 {
            all[k] = all[k].max(e[k]);
        }
    }
    assert!(
        all[0] < 0.5 && all[1] < 0.5 && all[2] < 0.5 && all[3] < 0.01,
        "{all:?}"
    );
}

/// A tripod shot with sensor noise: every frame exactly the first camera's pose, so the
/// render adds no keys and is the render of a still camera.
#[test]
fn a_still_shot_gives_exactly_no_motion() {
    let still = Pose {
        pan_deg: 0.0,
        tilt_deg: -7.3,
        roll_deg: 2.1,
        fov_deg: 63.0,
    };
    let poses = vec![still; 30];
    let track = estimate(&poses, 7, 0.01);
    assert!(track.is_still(), "{:?}", &track.frames[..3]);
    for f in &track.frames {
        assert_eq!(f.pan_deg, 0.0);
        let pose = [f.tilt_deg, f.roll_deg, f.fov_deg];
        for (v, want) in pose.into_iter().zip([-7.3, 2.1, 63.0]) {
            assert!((v - want).abs() < 1e-9, "{f:?}");
        }
    }
    let mut config = RenderConfig::default();
    (
        config.camera.tilt_deg,
        config.camera.roll_deg,
        config.camera.fov_deg,
    ) = (-7.3, 2.1, 63.0);
    let keys =
        rain_composite::pipeline::motion::keys_of(&track, &config, &config.camera).expect("keys");
    assert!(keys.is_empty(), "{keys:?}");
}

/// A tripod shot with a large textured object crossing it (two fifths of the picture, as a
/// passing bus or a test pattern's moving parts): the object's corners do not move the camera.
#[test]
fn a_moving_object_does_not_move_a_still_camera() {
    let still = Pose {
        pan_deg: 0.0,
        tilt_deg: 3.0,
        roll_deg: 0.0,
        fov_deg: 60.0,
    };
    let camera = still.camera();
    let background = frame(&camera, 21, 0.0, 0);
    let object = frame(&camera, 22, 0.0, 0);
    let mut e = Estimator::new(camera);
    let (w, h) = (SIZE.0 as usize, SIZE.1 as usize);
    for i in 0..30usize {
        let mut img = background.clone();
        let x0 = 40 + 6 * i;
        for y in h / 5..4 * h / 5 {
            for x in x0..(x0 + w / 2).min(w) {
                img.data[y * w + x] = object.data[y * w + x - 6 * i];
            }
        }
        e.push(img, 1.0, i as f64 / FPS, false);
    }
    let estimate = e.finish();
    assert!(estimate.track.is_still(), "{:?}", estimate.shots);
}

/// The drops of an estimated pan stay in the world: each drop's streak on a frame is its world
/// position seen through that frame's estimated camera (within 0.05 px, as the keyed camera
/// test holds the keys; a level camera, so a falling drop's streak stays in a plane parallel to
/// the picture and its middle is the projection of its position), and within half a degree of
/// where the true camera sees it.
#[test]
fn the_drops_of_a_pan_follow_the_estimated_camera() {
    let frames = 26;
    let poses: Vec<Pose> = (0..frames)
        .map(|i| {
            let t = i as f64 / FPS;
            Pose {
                pan_deg: 20.0 * t + 0.6 * (9.0 * t).sin(),
                tilt_deg: 0.0,
                roll_deg: 1.5,
                fov_deg: 60.0,
            }
        })
        .collect();
    let track = estimate(&poses, 11, 0.004);
    let mut config = RenderConfig::default();
    config.camera.roll_deg = 1.5;
    let keys =
        rain_composite::pipeline::motion::keys_of(&track, &config, &config.camera).expect("keys");
    assert!(keys.moves_camera());
    let rain = RainConfig {
        rate_mm_per_h: 20.0,
        wind_mps: [0.0, 0.0],
        far_m: 15.0,
        seed: 5,
        ..RainConfig::default()
    };
    let camera = config.camera.camera(SIZE.0, SIZE.1);
    let setup = rain_composite::shot::rain::plan_keyed(
        &camera,
        &config.camera,
        &rain,
        &keys,
        0.02,
        0,
        SIZE,
    )
    .map(RainSetup::pack)
    .expect("rain");
    let f = camera.focal_px();
    let (mut drawn, mut worst_est, mut worst_true) = (0, 0.0f64, 0.0f64);
    for (i, pose) in poses.iter().enumerate().step_by(5) {
        let t = i as f64 / FPS;
        let params = setup.motion_at(t);
        let estimated = setup.camera_at(t);
        let truth = pose.camera();
        for id in 0..setup.drop_count() as u64 {
            let Some(d) = sample_drop(setup.rainfall(), id, t) else {
                continue;
            };
            let Some(s) = streak_of(&params, d.position_m, d.velocity_mps, d.width_mm) else {
                continue;
            };
            drawn += 1;
            let mid = s.q0_px + s.dir * (0.5 * s.len_px);
            let est = estimated.project_world(d.position_m).expect("in front");
            worst_est = worst_est.max((mid - est).length());
            // Angles rather than pixels: near drops are far off the axis.
            let a = truth.ray_world(mid);
            let seen = (d.position_m - truth.position_m).normalize();
            worst_true = worst_true.max(a.angle_between(seen).to_degrees());
        }
    }
    eprintln!(
        "{drawn} streaks: within {worst_est:.3} px of the estimated cameras, {worst_true:.3}° of \
         the true ones (f {f:.0} px)"
    );
    assert!(drawn > 1000, "{drawn}");
    assert!(worst_est < 0.05, "{worst_est} px");
    assert!(worst_true < 0.5, "{worst_true}°");
}

/// Writes the frames of `shots` (each a list of poses over its own world, and its brightness)
/// as a lossless clip.
fn clip_of(dir: &std::path::Path, shots: &[(&[Pose], u64, f32)]) -> std::path::PathBuf {
    let raw = dir.join("frames.gray");
    let mut bytes = Vec::new();
    for (poses, seed, gain) in shots {
        for (i, p) in poses.iter().enumerate() {
            let img = frame(&p.camera(), *seed, 0.0, i as u64);
            bytes.extend(
                img.data
                    .iter()
                    .map(|v| (16.0 + 219.0 * (gain * v).clamp(0.0, 1.0)).round() as u8),
            );
        }
    }
    std::fs::write(&raw, bytes).expect("raw frames");
    let clip = dir.join("pan.mkv");
    let size = format!("{}x{}", SIZE.0, SIZE.1);
    ffmpeg(&[
        "-f",
        "rawvideo",
        "-pix_fmt",
        "gray",
        "-s",
        &size,
        "-r",
        "25",
        "-i",
        s(&raw),
        "-vf",
        "format=yuv420p",
        "-c:v",
        "ffv1",
        "-color_range",
        "tv",
        s(&clip),
    ]);
    clip
}

/// Two panning shots joined by a cut, through the pre-pass on a real clip: the second shot
/// starts again from the configured camera, each shot's poses follow its own camera, and the
/// pose file `inspect camera` writes, read back with `camera_motion` set to it, gives the same
/// pose keys as `auto`.
#[test]
fn a_cut_resets_and_the_pose_file_round_trips() {
    let dir = tempfile::tempdir().expect("tmp");
    let a: Vec<Pose> = (0..20)
        .map(|i| Pose {
            pan_deg: 1.2 * i as f64,
            tilt_deg: 0.0,
            roll_deg: 0.0,
            fov_deg: 60.0,
        })
        .collect();
    let b: Vec<Pose> = (0..20)
        .map(|i| Pose {
            pan_deg: 90.0 - 0.8 * i as f64,
            tilt_deg: 0.4 * i as f64,
            roll_deg: 0.0,
            fov_deg: 60.0,
        })
        .collect();
    // The second shot is of a darker world, as a cut changes the picture's blocks.
    let clip = clip_of(dir.path(), &[(&a, 3, 1.0), (&b, 4, 0.45)]);
    let report = rain_composite::inspect::camera(s(&clip), &CameraConfig::default())
        .expect("inspect camera");
    let track: PoseTrack = serde_json::from_value(report.clone()).expect("a pose file");
    assert_eq!(track.frames.len(), 40);
    let shots = report["shots"].as_array().expect("shots");
    assert_eq!(shots.len(), 2, "{shots:?}");
    assert!((shots[1]["start_s"].as_f64().expect("start") - 0.8).abs() < 1e-9);
    let second = &track.frames[20];
    assert_eq!(
        [second.pan_deg, second.tilt_deg],
        [0.0, 0.0],
        "reset at the cut"
    );
    for (k, (f, p)) in track.frames.iter().zip(a.iter().chain(&b)).enumerate() {
        let first = if k < 20 { a[0] } else { b[0] };
        assert!(
            (f.pan_deg - (p.pan_deg - first.pan_deg)).abs() < 0.5
                && (f.tilt_deg - p.tilt_deg).abs() < 0.5,
            "frame {k}: {f:?} vs {p:?}"
        );
    }
    let file = dir.path().join("poses.json");
    std::fs::write(&file, serde_json::to_string_pretty(&report).expect("json")).expect("write");
    let cancel = AtomicBool::new(false);
    let by_file = RenderConfig {
        camera_motion: MotionSource::File(file),
        ..RenderConfig::default()
    };
    by_file.validate().expect("valid");
    let from_file =
        rain_composite::pipeline::motion::resolve(&by_file, s(&clip), &cancel).expect("file");
    let by_auto = RenderConfig {
        camera_motion: MotionSource::Auto,
        ..RenderConfig::default()
    };
    let auto =
        rain_composite::pipeline::motion::resolve(&by_auto, s(&clip), &cancel).expect("auto");
    assert!(auto.keyframes.moves_camera());
    assert_eq!(from_file.keyframes, auto.keyframes);
    assert_eq!(from_file.camera_motion, MotionSource::None);
    from_file.validate().expect("the resolved keys are valid");

    // Beside a ground, the ground poses the first camera and the motion turns it from there:
    // auto starts at the ground's tilt, and the pose file (estimated through a level camera)
    // is turned to start there, frame for frame the same turns.
    let mut grounded = by_auto.clone();
    grounded.ground.mode = "horizon=0.6".parse().expect("mode");
    let posed = grounded.posed_camera(SIZE.0, SIZE.1).expect("posed");
    // The horizon below the centre: a camera looking up.
    assert!(posed.tilt_deg > 3.0, "{posed:?}");
    let auto_grounded = rain_composite::pipeline::motion::resolve(&grounded, s(&clip), &cancel)
        .expect("auto with a ground");
    grounded.camera_motion = by_file.camera_motion.clone();
    grounded.validate().expect("a pose file beside a ground");
    let file_grounded = rain_composite::pipeline::motion::resolve(&grounded, s(&clip), &cancel)
        .expect("file with a ground");
    let (a, b) = (&auto_grounded.keyframes, &file_grounded.keyframes);
    assert!(a.moves_camera() && b.moves_camera());
    let tilt = a.tilt_deg.as_ref().expect("tilt keys");
    assert!((tilt.at(0.0) - posed.tilt_deg).abs() < 1e-9);
    for k in 0..40 {
        let t = k as f64 / FPS;
        let (ca, cb) = (camera_of(a, &posed, t), camera_of(b, &posed, t));
        let turn = (ca.world_from_camera.transpose() * cb.world_from_camera)
            .col(2)
            .angle_between(DVec3::Z)
            .to_degrees();
        assert!(turn < 0.02, "frame {k}: {turn}°");
    }
}

/// The camera `keys` make of `posed` at `t_s`, on the test picture.
fn camera_of(
    keys: &rain_composite::keyframes::Keyframes,
    posed: &CameraConfig,
    t_s: f64,
) -> Camera {
    let mut at = RenderConfig {
        camera: *posed,
        ..RenderConfig::default()
    };
    at.apply_keys_at(keys, t_s);
    at.camera.camera(SIZE.0, SIZE.1)
}

/// A pan with handheld shake over a known ground (tilt −8.3°, roll 2.7°, given as its horizon),
/// through the pre-pass on a real clip: every frame's uniforms — which the splashes, the wet
/// ground and the puddles map the ground through — show each ground point where the true
/// camera of that frame sees it, within a fraction of a pixel, and the water's ground covers
/// every frame's view (the first frame's alone would not).
#[test]
fn the_ground_stays_in_the_world_through_an_estimated_pan() {
    use rain_composite::fluid::puddles::{PuddleSettings, PuddleSim};
    use rain_composite::gpu::cpu::yuv_to_rgb::view_ray_at;
    use rain_composite::scene::{GroundMode, GroundPlane};
    use rain_composite::shot::{Footage, Shot};
    use rain_composite::video::{Chroma, ColorParams, FrameFormat};

    let dir = tempfile::tempdir().expect("tmp");
    let poses: Vec<Pose> = (0..30)
        .map(|i| {
            let t = i as f64 / FPS;
            Pose {
                pan_deg: 18.0 * t + 0.5 * (7.0 * t).sin(),
                tilt_deg: -8.3 + 0.3 * (5.0 * t).sin(),
                roll_deg: 2.7 + 0.2 * (3.0 * t).sin(),
                fov_deg: 60.0,
            }
        })
        .collect();
    let clip = clip_of(dir.path(), &[(&poses, 21, 1.0)]);
    let first = poses[0].camera();
    let row = GroundPlane::LEVEL.horizon_row(&first).expect("a horizon");
    let mut config = RenderConfig::default();
    config.ground.mode = GroundMode::Horizon {
        row,
        roll_deg: poses[0].roll_deg,
    };
    config.ground.puddles = true;
    config.camera_motion = MotionSource::Auto;
    config.validate().expect("auto beside a ground");
    let cancel = AtomicBool::new(false);
    let resolved =
        rain_composite::pipeline::motion::resolve(&config, s(&clip), &cancel).expect("resolve");
    assert!(resolved.keyframes.moves_camera());
    let format = FrameFormat {
        width: SIZE.0,
        height: SIZE.1,
        chroma: Chroma::Cs420,
        bit_depth: 8,
    };
    let footage = Footage::picture(format, ColorParams::bt709(8), FPS);
    let shot = Shot::plan(&footage, &resolved, None).expect("a shot");
    let setup = RainSetup::pack(shot.rain.clone());
    let (mut worst_true, mut worst_own, mut points) = (0.0f64, 0.0f64, 0);
    let track = shot.rain.camera_track();
    let settings = PuddleSettings {
        max_distance_m: 6.0,
        max_particles: 500,
        ..PuddleSettings::default()
    };
    let build = |cameras: &[Camera]| {
        PuddleSim::seen_by(&resolved, cameras, None, FPS, &settings)
            .expect("valid")
            .expect("ground in view")
            .ground_rect()
    };
    let whole = build(&track.poses(1.0));
    let first_only = build(&[track.first()]);
    let (mut outside_whole, mut outside_first) = (0, 0);
    for (i, pose) in poses.iter().enumerate() {
        let t = i as f64 / FPS;
        let p = setup.motion_at(t);
        let truth = pose.camera();
        let own = setup.camera_at(t);
        let eye = DVec3::from_array(p.camera_pos_m.map(f64::from));
        for j in 0..=18 {
            for k in 0..=32 {
                let px = glam::DVec2::new(k as f64 * 20.0, j as f64 * 20.0);
                let ray = view_ray_at(&p, px);
                if ray.normalize().z > -0.02 {
                    continue;
                }
                // The ground point this pixel shows, as the ground's stages find it.
                let hit = eye + ray * (eye.z / -ray.z);
                points += 1;
                let seen = truth.project_world(hit).expect("in front");
                worst_true = worst_true.max((seen - px).length());
                let again = own.project_world(hit).expect("in front");
                worst_own = worst_own.max((again - px).length());
                if (hit - eye).truncate().length() < settings.max_distance_m {
                    let inside = |r: &rain_composite::rain::volume::GroundRect| {
                        let g = hit.truncate();
                        g.cmpge(r.min_m - 1e-6).all() && g.cmple(r.max_m + 1e-6).all()
                    };
                    outside_whole += usize::from(!inside(&whole));
                    outside_first += usize::from(!inside(&first_only));
                }
            }
        }
    }
    eprintln!(
        "{points} ground points over 30 frames: within {worst_true:.3} px of the true cameras, \
         {worst_own:.4} px of the estimated ones; outside the water's ground: {outside_whole} \
         (the first view's alone: {outside_first})"
    );
    assert!(points > 5000, "{points}");
    assert!(worst_true < 0.5, "{worst_true} px");
    assert!(worst_own < 0.01, "{worst_own} px");
    assert_eq!(outside_whole, 0);
    assert!(outside_first > 100, "{outside_first}");
}

/// `auto`'s estimate kept beside the water: read back as it was found, under the same file
/// and first camera only; a damaged file is estimated anew.
#[test]
fn the_estimate_is_kept_and_read_back() {
    use rain_composite::pipeline::motion::estimate_kept;
    use rain_composite::pipeline::pose_cache;
    let dir = tempfile::tempdir().expect("tmp");
    let poses: Vec<Pose> = (0..12)
        .map(|i| Pose {
            pan_deg: 0.8 * i as f64,
            tilt_deg: 0.0,
            roll_deg: 0.0,
            fov_deg: 60.0,
        })
        .collect();
    let clip = clip_of(dir.path(), &[(&poses, 5, 1.0)]);
    let kept = dir.path().join("in.water");
    let cancel = AtomicBool::new(false);
    let config = RenderConfig::default();
    let fresh = estimate_kept(s(&clip), &config, &cancel, Some(&kept)).expect("estimate");
    let files = || std::fs::read_dir(&kept).map_or(0, |d| d.count());
    assert_eq!(files(), 1);
    let first = config.camera.camera(SIZE.0, SIZE.1);
    let key = pose_cache::key(s(&clip), &first).expect("a file");
    let read = pose_cache::load(&kept, &key).expect("kept");
    assert_eq!(read, fresh);
    assert_eq!(
        estimate_kept(s(&clip), &config, &cancel, Some(&kept)).expect("read back"),
        fresh
    );
    // Another first camera is another estimate.
    let mut wider = config.clone();
    wider.camera.fov_deg = 70.0;
    let other = estimate_kept(s(&clip), &wider, &cancel, Some(&kept)).expect("estimate");
    assert_eq!(files(), 2);
    assert!(other.track.frames.last().expect("frames").pan_deg > fresh.track.frames[11].pan_deg);
    // A damaged file is passed over and written again.
    let file = pose_cache::path(&kept, &key);
    std::fs::write(&file, b"{\"key\": 1").expect("damage");
    assert!(pose_cache::load(&kept, &key).is_none());
    assert_eq!(
        estimate_kept(s(&clip), &config, &cancel, Some(&kept)).expect("again"),
        fresh
    );
    assert_eq!(pose_cache::load(&kept, &key).expect("rewritten"), fresh);
    // The file is a pose file.
    let track = PoseTrack::read(&file).expect("a pose file");
    assert_eq!(track, fresh.track);
}

/// Report (run with `--ignored --nocapture`): the estimation's cost per frame at 720p and
/// 1080p, median of a panning shot's frames: the frame's luma boxed down to the tracked width,
/// and the tracking and fit (the same work at both sizes: the tracked picture is 640 wide).
/// Decoding is the render's own cost and is not counted.
#[test]
#[ignore]
fn report_motion_costs() {
    use rain_composite::video::{Chroma, ColorParams, FrameFormat, YuvFrame};
    use std::time::Instant;
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let poses: Vec<Pose> = panning_shot(3, 30);
    let images: Vec<Image> = poses
        .iter()
        .map(|p| frame(&p.camera(), 9, 0.004, 1))
        .collect();
    let first = Pose {
        pan_deg: 0.0,
        ..poses[0]
    }
    .camera();
    let mut e = Estimator::new(first);
    let mut track_ms = Vec::new();
    for (i, img) in images.iter().enumerate() {
        let start = Instant::now();
        e.push(img.clone(), 1.0, i as f64 / FPS, false);
        track_ms.push(start.elapsed().as_secs_f64() * 1e3);
    }
    println!("| picture | luma to 640 wide (ms) | tracking and fit (ms) |");
    println!("|---|---|---|");
    for (w, h) in [(1280u32, 720u32), (1920, 1080)] {
        let format = FrameFormat {
            width: w,
            height: h,
            chroma: Chroma::Cs420,
            bit_depth: 8,
        };
        let mut frame = YuvFrame::filled(format, ColorParams::bt709(8), [128, 128, 128]);
        let stride = frame.planes[0].stride;
        for (k, v) in frame.planes[0].data.iter_mut().enumerate() {
            let (x, y) = (k % stride, k / stride);
            *v = (16 + (x * 7 + y * 13 + (x * y) % 31) % 200) as u8;
        }
        let luma_ms: Vec<f64> = (0..15)
            .map(|_| {
                let start = Instant::now();
                std::hint::black_box(rain_composite::scene::motion::work_image(&frame, 0));
                start.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        println!(
            "| {w}×{h} | {:.1} | {:.1} |",
            median(luma_ms),
            median(track_ms.clone())
        );
    }
}
