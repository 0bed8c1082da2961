//! The ground: `auto` against synthetic shots rendered through the project's own camera model
//! with a known tilt and roll; the hard cases; depth maps with holes and of another size.

use glam::DVec3;
use rain_composite::scene::horizon::{self, GroundTracker, Luma};
use rain_composite::scene::{Camera, DepthMap};
use rain_composite::video::YuvFrame;

#[path = "common/fixtures.rs"]
mod fixtures;
#[path = "common/street.rs"]
mod street;

use street::{Block, Pose};

const FOV_DEG: f64 = 60.0;

/// Posts and buildings: (x, y) of their centres on the ground, half width and height, metres.
const BOXES: [(f64, f64, f64, f64); 8] = [
    (-3.0, 8.0, 0.15, 4.0),
    (2.5, 6.0, 0.15, 4.0),
    (4.0, 14.0, 0.15, 4.0),
    (-5.0, 18.0, 0.15, 4.0),
    (1.0, 25.0, 0.15, 4.0),
    (-1.5, 4.5, 0.15, 4.0),
    (-16.0, 34.0, 6.0, 24.0),
    (17.0, 40.0, 7.0, 30.0),
];

/// Luma in [0, 1] seen along world ray `d` from `o`: posts and two buildings (shaded per face), a paving of
/// 0.6 m stones with dark joints, turned 20° from the view, and a smooth sky.
fn radiance(o: DVec3, d: DVec3) -> f64 {
    let mut best = (f64::MAX, 0.0);
    for &(x, y, half, top_m) in &BOXES {
        let b = Block {
            centre: [x, y],
            half: [half, half],
            top_m,
            shade: 1.0,
            building: top_m > 6.0,
        };
        if let Some((t0, axis)) = b.entry(o, d).filter(|&(t0, _)| t0 < best.0) {
            // Faces shaded by orientation; buildings have a dark band at each 3 m floor.
            let floor = b.building && ((o + d * t0).z / 3.0).fract() < 0.2;
            best = (t0, [0.25, 0.45, 0.7][axis] * if floor { 0.5 } else { 1.0 });
        }
    }
    if d.z < 0.0 {
        let t = -o.z / d.z;
        if t < best.0 {
            return street::paving(o + d * t, t, 20.0, 0.6);
        }
    }
    if best.0 < f64::MAX {
        return best.1;
    }
    0.75 + 0.2 * d.z.max(0.0)
}

/// The camera of `tilt_deg` and `roll_deg`: a 60° view 1.6 m up.
fn pose(tilt_deg: f64, roll_deg: f64) -> Pose {
    Pose {
        tilt_deg,
        roll_deg,
        fov_deg: FOV_DEG,
        height_m: 1.6,
    }
}

/// A frame of the scene through a camera of `tilt_deg` and `roll_deg`, 2×2 supersampled.
fn render(tilt_deg: f64, roll_deg: f64, scene: fn(DVec3, DVec3) -> f64) -> YuvFrame {
    street::render(&pose(tilt_deg, roll_deg).camera(), scene)
}

fn intrinsics() -> Camera {
    pose(0.0, 0.0).intrinsics()
}

fn estimate(frame: &YuvFrame) -> horizon::HorizonEstimate {
    let luma = Luma::from_frame(frame, 0, horizon::WORK_WIDTH);
    horizon::estimate(&luma, &intrinsics())
}

/// The true horizon row of a camera (from the plane, not from the estimator's formula).
fn true_row(tilt_deg: f64, roll_deg: f64) -> Option<f64> {
    pose(tilt_deg, roll_deg).horizon_row()
}

fn check(tilt_deg: f64, roll_deg: f64) {
    let est = estimate(&render(tilt_deg, roll_deg, radiance));
    let row = true_row(tilt_deg, roll_deg).expect("crosses");
    let got = est.horizon_row.expect("estimated row");
    eprintln!("tilt {tilt_deg} roll {roll_deg}: {est:?} (true row {row:.4})");
    assert!(est.confidence > horizon::MIN_CONFIDENCE, "{est:?}");
    assert!((got - row).abs() < 0.02, "row {got} vs {row}");
    assert!(
        (est.roll_deg - roll_deg).abs() < 1.0,
        "roll {} vs {roll_deg}",
        est.roll_deg
    );
}

/// Where the picture reads two ways (the Manhattan ambiguity), the estimate is either right
/// (horizon within 2 % of the height, roll within 1°) or not confident; returns whether it was
/// confident.
fn right_or_unsure(tilt_deg: f64, roll_deg: f64) -> bool {
    let est = estimate(&render(tilt_deg, roll_deg, radiance));
    let row = true_row(tilt_deg, roll_deg).expect("crosses");
    eprintln!("tilt {tilt_deg} roll {roll_deg}: {est:?} (true row {row:.4})");
    let confident = est.confidence >= horizon::MIN_CONFIDENCE;
    if confident {
        let got = est.horizon_row.expect("estimated row");
        assert!(
            (got - row).abs() < 0.02,
            "confidently wrong: row {got} vs {row}"
        );
        assert!(
            (est.roll_deg - roll_deg).abs() < 1.0,
            "confidently wrong: {est:?}"
        );
    }
    confident
}

#[test]
fn auto_finds_a_level_camera() {
    check(0.0, 0.0);
}

#[test]
fn auto_finds_tilt_and_roll() {
    check(8.0, -6.0);
}

#[test]
fn auto_with_a_roll_of_30_degrees() {
    check(-5.0, 30.0);
}

/// Looking down at the street: the horizon is above the picture. The estimate is right, but
/// with few vertical edges and the horizon far off the picture the calibrated confidence says
/// so less surely (steep views down are right about three times in four).
#[test]
fn auto_with_the_horizon_above_the_frame() {
    let row = true_row(-40.0, 4.0).expect("crosses");
    assert!(row < 0.0, "{row}");
    let est = estimate(&render(-40.0, 4.0, radiance));
    eprintln!("{est:?} (true row {row:.4})");
    assert!(
        (est.horizon_row.expect("row") - row).abs() < 0.02,
        "{est:?}"
    );
    assert!((est.roll_deg - 4.0).abs() < 1.0, "{est:?}");
    assert!(est.confidence > 0.5, "{est:?}");
}

/// Looking up past the posts: the horizon is below the picture, and the building edges alone
/// fit a camera looking down (the Manhattan ambiguity) about as well as the truth: the priors
/// pick the truth, but the reading is ambiguous, so it must be right or not confident.
#[test]
fn auto_with_the_horizon_below_the_frame() {
    let row = true_row(25.0, -3.0).expect("crosses");
    assert!(row > 1.0, "{row}");
    right_or_unsure(25.0, -3.0);
}

/// Soft blobs and no straight edge: the confidence stays below the threshold.
#[test]
fn no_straight_lines_means_low_confidence() {
    fn blobs(_o: DVec3, d: DVec3) -> f64 {
        let mut v = 0.4;
        for (i, c) in [(0.3, 0.1, 0.9), (-0.4, -0.1, 0.9), (0.0, 0.25, 0.95)]
            .iter()
            .enumerate()
        {
            let c = DVec3::new(c.0, c.1, c.2).normalize();
            v += 0.15 * (i as f64 + 1.0) * (-(1.0 - d.dot(c)) * 60.0).exp();
        }
        v.min(1.0)
    }
    let est = estimate(&render(0.0, 0.0, blobs));
    eprintln!("{est:?}");
    assert!(est.confidence < horizon::MIN_CONFIDENCE, "{est:?}");
}

/// The tracker averages agreeing frames and forgets the previous shot at a cut.
#[test]
fn tracker_resets_at_a_cut() {
    let cam = intrinsics();
    let a = render(8.0, -6.0, radiance);
    let b = render(-20.0, 10.0, |o, d| 1.0 - radiance(o, d));
    let mut tracker = GroundTracker::new(5);
    for f in [&a, &a, &a] {
        let luma = Luma::from_frame(f, 0, horizon::WORK_WIDTH);
        tracker.update(horizon::estimate(&luma, &cam), &luma, &cam);
    }
    let luma = Luma::from_frame(&b, 0, horizon::WORK_WIDTH);
    let est = tracker.update(horizon::estimate(&luma, &cam), &luma, &cam);
    assert!(
        (est.tilt_deg + 20.0).abs() < 2.0 && (est.roll_deg - 10.0).abs() < 2.0,
        "{est:?}"
    );
}

/// Holes (zero, NaN) stay unknown and do not drag their neighbours; a map of another size
/// is resampled (against a brute-force bilinear of the known plane it samples).
#[test]
fn depth_map_holes_and_resampling() {
    // A plane of depth 2 + x/10 metres in millimetres with holes.
    let (w, h) = (40, 30);
    let mut mm: Vec<f32> = (0..w * h)
        .map(|i| ((2.0 + (i % w) as f64 / 10.0) * 1000.0) as f32)
        .collect();
    mm[5 * w + 7] = 0.0;
    mm[6 * w + 7] = f32::NAN;
    for x in 20..24 {
        for y in 10..14 {
            mm[y * w + x] = 0.0;
        }
    }
    let map = DepthMap::from_values(w, h, &mm, 1e-3).expect("valid");
    assert!(map.at(7, 5).is_none() && map.at(7, 6).is_none() && map.at(8, 5).is_some());
    let up = map.resampled(80, 45);
    // Everywhere known the resampled value is the plane's at that position (a linear field
    // is reproduced exactly by bilinear weights that skip holes, within f32).
    for y in 0..45 {
        for x in 0..80 {
            let fx = ((x as f64 + 0.5) * 0.5 - 0.5).clamp(0.0, 39.0);
            let d = up.depth_m[y * 80 + x];
            if d.is_finite() {
                // Along x the field is linear; renormalised weights keep it within one
                // sample's step where a neighbour is missing.
                assert!(
                    (d as f64 - (2.0 + fx / 10.0)).abs() < 0.1 + 1e-4,
                    "{x},{y}: {d}"
                );
            }
        }
    }
    // The 4×4 hole (x 20..24, y 10..14) is still a hole at its centre: output (44, 18) samples
    // source (21.75, 11.83), whose four neighbours are all holes.
    assert!(up.depth_m[18 * 80 + 44].is_nan());
    assert!(up.depth_m.iter().all(|v| !v.is_finite() || *v > 1.9));
    let down = map.resampled(13, 7);
    assert_eq!((down.width, down.height, down.depth_m.len()), (13, 7, 91));
    assert!(down.known_fraction() > 0.9);
}

/// A 16-bit PNG in millimetres reads back in metres, with `--depth-scale`.
#[test]
fn depth_png_in_millimetres() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("d.png");
    let img = image::ImageBuffer::<image::Luma<u16>, _>::from_fn(8, 4, |x, _| {
        image::Luma([if x == 0 { 0 } else { 1000 * x as u16 }])
    });
    img.save(&path).expect("write");
    let map = DepthMap::load_png(&path, 1.0).expect("read");
    assert!(map.at(0, 0).is_none());
    assert!((map.at(3, 2).expect("known") - 3.0).abs() < 1e-6);
    let scaled = DepthMap::load_png(&path, 2.5).expect("read");
    assert!((scaled.at(3, 2).expect("known") - 7.5).abs() < 1e-5);
    let e = DepthMap::load_png(&path, 0.0)
        .expect_err("scale 0")
        .to_string();
    assert!(e.contains("ground.depth_scale"), "{e}");
}

/// Cost of one frame's estimate (a report, not a test: speed is measured side by side, never
/// asserted). `cargo test --release --test ground cost_per_frame -- --ignored --nocapture`
#[test]
#[ignore = "timing report"]
fn cost_per_frame() {
    let frame = render(8.0, -6.0, radiance);
    let t = std::time::Instant::now();
    let n = 5;
    for _ in 0..n {
        std::hint::black_box(estimate(&frame));
    }
    let ms = t.elapsed().as_secs_f64() * 1e3 / n as f64;
    eprintln!("auto ground: {ms:.2} ms per 640x360 frame");
}

/// Ground modes as a user writes them: wrong values are refused naming the setting and the
/// range, and every valid mode prints back as it parses.
#[test]
fn ground_modes_parse_and_name_their_errors() {
    use rain_composite::scene::GroundMode;
    for (text, range) in [
        ("horizon=0.5,roll=95", "(-90, 90)"),
        ("plane=0,-1,0,0", "d ≠ 0"),
        // n·X = d read as n·X + d = 0: a ceiling, the camera upside down or on its side.
        ("plane=0,1,0,1.6", "rolls the camera by"),
        ("plane=1,0,0,1.6", "rolls the camera by"),
        ("plane=0,1e-30,0,1.6", "length above 1e-9"),
        ("sky", "horizon=ROW"),
    ] {
        let err = text
            .parse::<GroundMode>()
            .and_then(|m| m.validate().map(|()| m))
            .expect_err(text)
            .to_string();
        assert!(
            err.contains("ground.mode") && err.contains(range),
            "{text}: {err}"
        );
    }
    for text in ["none", "auto", "horizon=0.4,roll=2.5", "plane=0,-1,0.1,1.6"] {
        let mode: GroundMode = text.parse().expect(text);
        mode.validate().expect(text);
        assert_eq!(
            mode.to_string().parse::<GroundMode>().expect("round trip"),
            mode
        );
    }
    // A plane sets the camera's height: a height given besides it (as `--set
    // camera.height_m` or in a configuration) would be ignored, so it is refused.
    let mut config = rain_composite::config::RenderConfig::default();
    config.ground.mode = "plane=0,-1,0,1.6".parse().expect("mode");
    config.validate().expect("a plane alone");
    config.camera.height_m = 3.0;
    let err = config.validate().expect_err("two heights").to_string();
    assert!(
        err.contains("camera.height_m") && err.contains("plane="),
        "{err}"
    );
}

/// Across tilts: near level, down 20°, and rolled 20° while looking up, the reading is
/// clear and must be found; looking up 15°–45° and down 30° the picture reads two ways, and
/// each estimate must be right or not confident (looking up 40° and 45°, the priors pick the
/// wrong reading).
#[test]
fn auto_across_tilts() {
    for (t, r) in [(5.0, 0.0), (-20.0, 0.0), (12.0, -20.0)] {
        check(t, r);
    }
    let ambiguous = [
        (15.0, 0.0),
        (30.0, -3.0),
        (35.0, 0.0),
        (45.0, 0.0),
        (-30.0, -5.0),
    ];
    let confident = ambiguous
        .iter()
        .filter(|&&(t, r)| right_or_unsure(t, r))
        .count();
    eprintln!(
        "{confident} of {} ambiguous shots confident",
        ambiguous.len()
    );
}

/// Looking up 40° at the posts and buildings, the edges fit a camera looking down about 14° as
/// well as the truth (the Manhattan ambiguity) and the priors used to pick the wrong one with
/// confidence 0.99: now the estimate is either right or not confident, so `auto` falls back.
#[test]
fn looking_up_40_degrees_is_not_confidently_wrong() {
    let est = estimate(&render(40.0, 0.0, radiance));
    let row = true_row(40.0, 0.0).expect("crosses");
    eprintln!("tilt 40: {est:?} (true row {row:.4})");
    let right = est
        .horizon_row
        .is_some_and(|r| (r - row).abs() < 0.02 && est.roll_deg.abs() < 1.0);
    assert!(
        right || est.confidence < horizon::MIN_CONFIDENCE,
        "confidently wrong: {est:?}"
    );
}

/// The readings of a clip combine by their confidence-weighted median: a misread frame does not
/// move it, and frames that disagree lower the confidence.
#[test]
fn clip_readings_combine_robustly() {
    use rain_composite::pipeline::ground::{combine, weighted_median};
    use rain_composite::scene::ground::up_from_tilt_roll;
    // An outlier does not drag it (the weighted mean here is 4.3).
    let m = weighted_median(&[(1.0, 1.0), (1.5, 1.0), (50.0, 0.2), (2.0, 1.0)]);
    assert_eq!(m, Some(1.5));
    assert_eq!(
        weighted_median(&[(1.0, 0.2), (3.0, 1.0), (2.0, 0.2)]),
        Some(3.0)
    );
    assert_eq!(weighted_median(&[(1.0, 0.0)]), None);
    let cam = intrinsics();
    let reading = |t: f64, r: f64, c: f64| {
        let mut e = estimate(&render(0.0, 0.0, radiance));
        e.up_cam = up_from_tilt_roll(t.to_radians(), r.to_radians());
        (e.tilt_deg, e.roll_deg, e.confidence) = (t, r, c);
        e
    };
    let steady: Vec<_> = (0..5)
        .map(|i| reading(8.0 + 0.1 * i as f64, -6.0, 0.9))
        .collect();
    let mut flipped = steady.clone();
    flipped.push(reading(-50.0, 10.0, 0.95));
    let a = combine(&steady, &cam).expect("combined");
    let b = combine(&flipped, &cam).expect("combined");
    // The median moves by one reading at most (the weighted mean would be at −1.0°).
    assert!((a.tilt_deg - 8.2).abs() < 1e-9, "{a:?}");
    assert!((b.tilt_deg - 8.2).abs() < 0.1 + 1e-9, "{b:?}");
    assert!((a.confidence - 0.9).abs() < 1e-9, "{a:?}");
    assert!(
        b.confidence < a.confidence,
        "{} vs {}",
        b.confidence,
        a.confidence
    );
}

/// The pre-pass skips an unsure frame's finer line pass only where the clip's outcome is
/// settled without it (`finer_pass_moot`): on random clips of confident and unsure readings, a
/// clip that skipped any pass is refused by the aggregate (`horizon::aggregate`), both as read
/// and with every skipped reading replaced by an adversary (confidence 1, along each reading's
/// direction in turn, or random) and for every cut the clip could end at. The rule skips on
/// many of the clips, so the check is not vacuous.
#[test]
fn the_finer_pass_is_skipped_only_where_the_outcome_is_settled() {
    use rain_composite::pipeline::ground::finer_pass_moot;
    use rain_composite::rng::SplitMix64;
    use rain_composite::scene::ground::up_from_tilt_roll;
    let cam = intrinsics();
    let base = estimate(&render(0.0, 0.0, radiance));
    let reading = |t: f64, r: f64, c: f64| {
        let mut e = base;
        e.up_cam = up_from_tilt_roll(t.to_radians(), r.to_radians());
        (e.tilt_deg, e.roll_deg, e.confidence) = (t, r, c);
        e
    };
    let mut rng = SplitMix64(25);
    let (mut clips_skipping, mut skips, mut adversaries) = (0, 0, 0);
    for _ in 0..400 {
        let n_max = 2 + (rng.next_f64() * 23.0) as usize;
        // Each clip has a share of confident frames and readings near one pose or scattered.
        let share_confident = rng.next_f64();
        let scatter_deg = [0.3, 3.0, 30.0][(rng.next_f64() * 3.0) as usize];
        let mut clip = Vec::new();
        let mut skipped = Vec::new();
        let mut exact = 0.0;
        for n in 1..=n_max {
            let confident = rng.next_f64() < share_confident;
            let c = if confident {
                0.9 + 0.1 * rng.next_f64()
            } else {
                0.9 * rng.next_f64() * rng.next_f64()
            };
            let e = reading(
                5.0 + scatter_deg * (rng.next_f64() - 0.5),
                -3.0 + scatter_deg * (rng.next_f64() - 0.5),
                c,
            );
            // An unsure frame asks for the finer pass.
            if !confident && finer_pass_moot(exact, skipped.len(), n, n_max) {
                skipped.push(n - 1);
            } else {
                exact += c;
            }
            clip.push(e);
        }
        if skipped.is_empty() {
            continue;
        }
        clips_skipping += 1;
        skips += skipped.len();
        // Every prefix holding a skipped frame (the clip cut there or ending), as read and
        // with the skipped frames replaced.
        for end in skipped[0] + 1..=n_max {
            let prefix = &clip[..end];
            let refused = |readings: &[horizon::HorizonEstimate]| {
                horizon::aggregate(readings, &cam)
                    .expect("readings")
                    .confidence
                    < horizon::MIN_CONFIDENCE
            };
            assert!(
                refused(prefix),
                "skipped {skipped:?} of {n_max}, cut at {end}"
            );
            let mut towards: Vec<_> = prefix.iter().map(|e| (e.tilt_deg, e.roll_deg)).collect();
            towards.push((rng.next_f64() * 40.0 - 20.0, rng.next_f64() * 40.0 - 20.0));
            for (t, r) in towards {
                let mut adversary = prefix.to_vec();
                for &k in skipped.iter().filter(|&&k| k < end) {
                    adversary[k] = reading(t, r, 1.0);
                }
                assert!(
                    refused(&adversary),
                    "skipped {skipped:?} of {n_max}, cut at {end}, all at ({t}, {r})"
                );
                adversaries += 1;
            }
        }
    }
    eprintln!("{clips_skipping} clips skipped {skips} passes; {adversaries} adversaries refused");
    assert!(
        clips_skipping > 100 && skips > 1000,
        "{clips_skipping} clips, {skips} skips"
    );
}

/// On the street sample, whose frames are all unsure (its lens is refused), the pre-pass runs
/// the finer pass on the first two of its 17 frames only, and still falls back to no ground.
#[test]
fn the_pre_pass_runs_the_finer_pass_until_the_outcome_is_settled() {
    use rain_composite::config::RenderConfig;
    use rain_composite::pipeline::ground::estimate_clip;
    use rain_composite::scene::GroundMode;
    let mut config = RenderConfig::default();
    config.ground.mode = GroundMode::Auto;
    let g = estimate_clip("samples/street.mp4", &config).expect("estimate");
    eprintln!("{g:?}");
    assert_eq!(g.frames, 17);
    assert_eq!((g.finer_passes, g.finer_skipped), (2, 15));
    assert!(g.estimate.confidence < horizon::MIN_CONFIDENCE);
}

/// Writes `frames` (640×360 4:2:0) as an FFV1 clip at 25 fps.
fn clip(dir: &std::path::Path, name: &str, frames: &[YuvFrame]) -> std::path::PathBuf {
    let raw = dir.join(format!("{name}.yuv"));
    let mut bytes = Vec::new();
    for f in frames {
        for (i, p) in f.planes.iter().enumerate() {
            let (w, h) = f.format.plane_size(i);
            for y in 0..h as usize {
                bytes.extend_from_slice(&p.data[y * p.stride..y * p.stride + w as usize]);
            }
        }
    }
    std::fs::write(&raw, bytes).expect("raw");
    let out = dir.join(format!("{name}.mkv"));
    fixtures::ffmpeg(&[
        "-f",
        "rawvideo",
        "-pix_fmt",
        "yuv420p",
        "-s",
        "640x360",
        "-r",
        "25",
        "-i",
        raw.to_str().expect("utf-8"),
        "-c:v",
        "ffv1",
        out.to_str().expect("utf-8"),
    ]);
    out
}

/// `--ground auto` in the render: the pre-pass over a clip of the synthetic shot finds its
/// horizon and roll, stops at a cut (the pose of the first shot), and resolves to no ground for
/// a clip without straight edges; the render with `auto` equals the render with the horizon it
/// found, given by hand.
#[test]
fn auto_in_the_render() {
    use rain_composite::config::RenderConfig;
    use rain_composite::pipeline::ground::{estimate_clip, resolve};
    use rain_composite::scene::GroundMode;
    fn blobs(_o: DVec3, d: DVec3) -> f64 {
        0.4 + 0.3 * (-(1.0 - d.dot(DVec3::new(0.2, 0.1, 0.97).normalize())) * 60.0).exp()
    }
    fn bright(_o: DVec3, _d: DVec3) -> f64 {
        0.95
    }
    let dir = tempfile::TempDir::new().expect("tmp");
    let shot = render(8.0, -6.0, radiance);
    let next = render(0.0, 0.0, bright);
    let cut = clip(
        dir.path(),
        "cut",
        &[shot.clone(), shot.clone(), shot.clone(), next.clone(), next],
    );
    let other = render(0.0, 0.0, blobs);
    let mut config = RenderConfig::default();
    config.ground.mode = GroundMode::Auto;
    let g = estimate_clip(cut.to_str().expect("utf-8"), &config).expect("estimate");
    let row = true_row(8.0, -6.0).expect("crosses");
    eprintln!("{g:?} (true row {row:.4})");
    assert!(
        (1..=3).contains(&g.frames),
        "the pre-pass stops at the cut: {}",
        g.frames
    );
    assert!(
        g.cut_s.is_some_and(|t| (t - 0.12).abs() < 1e-6),
        "{:?}",
        g.cut_s
    );
    let e = g.estimate;
    assert!(e.confidence >= horizon::MIN_CONFIDENCE, "{e:?}");
    assert!((e.horizon_row.expect("row") - row).abs() < 0.02, "{e:?}");
    assert!((e.roll_deg + 6.0).abs() < 1.0, "{e:?}");

    let flat = clip(dir.path(), "blobs", &[other.clone(), other]);
    let resolved = resolve(&config, flat.to_str().expect("utf-8")).expect("resolve");
    assert_eq!(resolved.ground.mode, GroundMode::None);

    let resolved = resolve(&config, cut.to_str().expect("utf-8")).expect("resolve");
    let GroundMode::Horizon { .. } = resolved.ground.mode else {
        panic!("{:?}", resolved.ground.mode)
    };
    let render_with = |name: &str, ground: &str| {
        let out = dir.path().join(name);
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_rain-composite"))
            .arg(&cut)
            .arg("-o")
            .arg(&out)
            .args([
                "--rain",
                "30",
                "--max-drops",
                "20000",
                "--cpu",
                "--codec",
                "ffv1",
            ])
            .args(["--ground", ground])
            .output()
            .expect("spawn");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        fixtures::framemd5(&out, "0:v:0", true)
    };
    let given = resolved.ground.mode.to_string();
    assert!(
        render_with("auto.mkv", "auto") == render_with("given.mkv", &given),
        "{given}"
    );
}

/// A steady shot keeps its confidence over time: the tracker over identical frames gives the
/// frame's own estimate and confidence (it used to fall with the agreement's 50th power), and
/// the mode ignores a flipped frame, which only takes its share of the confidence away.
#[test]
fn a_steady_estimate_keeps_its_confidence_over_time() {
    use rain_composite::scene::ground::up_from_tilt_roll;
    let cam = intrinsics();
    let frame = render(8.0, -6.0, radiance);
    let luma = Luma::from_frame(&frame, 0, horizon::WORK_WIDTH);
    let one = horizon::estimate(&luma, &cam);
    let mut tracker = GroundTracker::new(12);
    let mut last = one;
    for _ in 0..12 {
        last = tracker.update(one, &luma, &cam);
    }
    assert!((last.confidence - one.confidence).abs() < 1e-9, "{last:?}");
    assert!((last.up_cam - one.up_cam).length() < 1e-9, "{last:?}");
    // Readings jittered by ±0.5° agree; a flipped one does not move the mode.
    let mut readings: Vec<_> = (0..8)
        .map(|i| {
            let mut e = one;
            let (t, r) = (
                8.0 + 0.5 * ((i % 3) as f64 - 1.0),
                -6.0 + 0.25 * (i % 2) as f64,
            );
            e.up_cam = up_from_tilt_roll(t.to_radians(), r.to_radians());
            (e.tilt_deg, e.roll_deg, e.confidence) = (t, r, 0.95);
            e
        })
        .collect();
    let steady = horizon::aggregate(&readings, &cam).expect("readings");
    assert!((steady.confidence - 0.95).abs() < 1e-9, "{steady:?}");
    let mut flipped = one;
    flipped.up_cam = up_from_tilt_roll(-60f64.to_radians(), 25f64.to_radians());
    (flipped.tilt_deg, flipped.roll_deg, flipped.confidence) = (-60.0, 25.0, 0.99);
    readings.push(flipped);
    let mixed = horizon::aggregate(&readings, &cam).expect("readings");
    assert!((mixed.tilt_deg - steady.tilt_deg).abs() < 1e-9, "{mixed:?}");
    assert!((mixed.roll_deg - steady.roll_deg).abs() < 1e-9, "{mixed:?}");
    assert!(
        (mixed.confidence - 0.95 * 8.0 / 9.0).abs() < 1e-9,
        "{mixed:?}"
    );
}

/// `--ground auto` on a clip filmed looking up 78° between towers (a steep view of the
/// synthetic city, read from its verticals' vanishing point with the sky around it): the
/// pre-pass poses the camera confidently (its up direction within 1° of the truth; the ground
/// it engages lies five picture heights below the frame, out of sight), and the rain drawn
/// through the resolved settings has its streaks converging on the true zenith within 2°.
#[test]
fn a_steep_view_poses_the_rain() {
    use rain_composite::config::RenderConfig;
    use rain_composite::pipeline::ground::resolve;
    use rain_composite::scene::GroundMode;
    let (scene, pose, cam) = street::steep_shot(7, 23);
    let frame = street::render(&cam, |o, d| scene.radiance(o, d));
    let dir = tempfile::TempDir::new().expect("tmp");
    let path = clip(dir.path(), "up", &[frame.clone(), frame.clone(), frame]);
    let mut config = RenderConfig::default();
    config.ground.mode = GroundMode::Auto;
    config.camera.fov_deg = pose.fov_deg;
    let resolved = resolve(&config, path.to_str().expect("utf-8")).expect("resolve");
    // The pose the rain is drawn through: the ground's where one engaged (its horizon far below
    // the picture), else the camera's own tilt and roll.
    let camera = resolved.camera.camera(street::W, street::H);
    let (tilt_deg, roll_deg) = match resolved
        .ground
        .mode
        .fixed_pose(&camera, pose.height_m)
        .expect("valid")
    {
        Some(p) => (p.tilt_rad.to_degrees(), p.roll_rad.to_degrees()),
        None => (resolved.camera.tilt_deg, resolved.camera.roll_deg),
    };
    eprintln!(
        "true tilt {:.2} roll {:.2}; resolved {tilt_deg:.2} {roll_deg:.2} ({})",
        pose.tilt_deg, pose.roll_deg, resolved.ground.mode
    );
    let up = |t: f64, r: f64| {
        rain_composite::scene::ground::up_from_tilt_roll(t.to_radians(), r.to_radians())
    };
    let off_deg = up(tilt_deg, roll_deg)
        .angle_between(up(pose.tilt_deg, pose.roll_deg))
        .to_degrees();
    assert!(off_deg < 1.0, "posed {off_deg:.2}° off");
    let zenith = cam
        .project_world(cam.position_m + DVec3::Z * 100.0)
        .expect("the zenith is in front");
    let (judged, worst) = street::streaks_off_nadir(&pose, tilt_deg, roll_deg, zenith);
    eprintln!("{judged} streaks, worst {worst:.2}° off the zenith at {zenith}");
    assert!(judged > 100, "{judged} streaks judged");
    assert!(worst < 2.0, "a streak {worst:.2}° off the zenith");
}
