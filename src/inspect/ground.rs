//! `inspect ground`: the ground estimated at one time of a clip, and its plot.

use std::path::Path;

use glam::{DVec2, DVec3};
use serde_json::{Value, json};

use crate::config::CameraConfig;
use crate::scene::Camera;
use crate::scene::ground::{horizon_points_px, up_from_tilt_roll};
use crate::scene::horizon::{self, GroundTracker, HorizonEstimate, Luma};
use crate::shot::frame_time_s;
use crate::video::{Source, YuvFrame};
use crate::{Error, Result};

/// Seconds of past frames the estimate at a time averages over (the tracker's window).
pub const WINDOW_S: f64 = 0.5;

/// The estimate at `at_s` of the clip `input` through `camera`'s intrinsics (its tilt and roll
/// are what is estimated), from the frames of the [`WINDOW_S`] before it; the target frame
/// and its rotation, and the mean cost per frame in milliseconds.
pub fn estimate_at(
    input: &str,
    at_s: f64,
    camera: &CameraConfig,
) -> Result<(HorizonEstimate, HorizonEstimate, YuvFrame, i32, f64, usize)> {
    let mut source = Source::open(input)?;
    let info = source.info().clone();
    let target = source.seek_to_time(at_s)?;
    let t_target = frame_time_s(&info, &target);
    let fps = {
        let (n, d) = info.nominal_fps();
        if n > 0 && d > 0 {
            n as f64 / d as f64
        } else {
            25.0
        }
    };
    let window = ((WINDOW_S * fps).round() as usize).max(1);
    let rot = info.rotation_deg;
    let (w, h) = if rot.rem_euclid(180) == 90 {
        (info.format.height, info.format.width)
    } else {
        (info.format.width, info.format.height)
    };
    let cam = Camera::new(w, h, camera.fov_deg.to_radians(), camera.height_m, 0.0, 0.0);
    let mut tracker = GroundTracker::new(window);
    let mut cost_s = 0.0;
    let mut frames = 0usize;
    let mut feed = |frame: &YuvFrame, tracker: &mut GroundTracker| {
        let t0 = std::time::Instant::now();
        let luma = Luma::from_frame(frame, rot, horizon::WORK_WIDTH);
        let raw = horizon::estimate_finer(
            &luma,
            || {
                Some(Luma::from_frame(
                    frame,
                    rot,
                    crate::scene::steep::FINE_WIDTH,
                ))
            },
            &cam,
        );
        let smooth = tracker.update(raw, &luma, &cam);
        cost_s += t0.elapsed().as_secs_f64();
        frames += 1;
        (raw, smooth)
    };
    let from = (t_target - WINDOW_S).max(0.0);
    if from < t_target {
        let mut frame = source.seek_to_time(from)?;
        while frame.pts < target.pts {
            if frame_time_s(&info, &frame) > t_target - WINDOW_S {
                feed(&frame, &mut tracker);
            }
            frame = source
                .next_frame()?
                .ok_or_else(|| Error::OutOfRange("the clip ended before the frame".into()))?;
        }
    }
    let (raw, smooth) = feed(&target, &mut tracker);
    let ms = cost_s * 1e3 / frames as f64;
    Ok((raw, smooth, target, rot, ms, frames))
}

fn estimate_json(e: &HorizonEstimate) -> Value {
    json!({
        "horizon_row": e.horizon_row,
        "tilt_deg": e.tilt_deg,
        "roll_deg": e.roll_deg,
        "confidence": e.confidence,
        "ambiguity": e.ambiguity,
        "evidence": {
            "segments": e.segments,
            "vertical_inliers": e.vertical_inliers,
            "horizontal_inliers": e.horizontal_inliers,
            "horizon_inliers": e.horizon_inliers,
            "steep_lines": e.steep_lines,
            "families": e.families,
            "level_offset": e.level_offset,
            "focal_scale_sq": e.focal_scale_sq,
            "sky_above": e.sky_above,
            "sky_over_ground": e.sky_over_ground,
            "sky_ahead": e.sky_ahead,
        },
        "lens_fov_deg": e.lens_fov_deg,
        "lens_hint": horizon::lens_hint(e),
        "refused": horizon::refusal(e),
    })
}

/// The report: the smoothed estimate (what an automatic ground would use), the target frame's own,
/// and the decision (`auto` or `none` below [`horizon::MIN_CONFIDENCE`]).
pub fn report(input: &str, at_s: f64, camera: &CameraConfig, plot: Option<&Path>) -> Result<Value> {
    let (raw, smooth, frame, rot, ms, frames) = estimate_at(input, at_s, camera)?;
    let ground = if smooth.confidence >= horizon::MIN_CONFIDENCE {
        "auto"
    } else if let Some(why) = horizon::refusal(&smooth) {
        log::warn!("ground: refused, {why}: no ground");
        if let Some(hint) = horizon::lens_hint(&smooth) {
            log::warn!("ground: {hint}");
        }
        "none"
    } else {
        log::warn!(
            "ground: confidence {:.2} is below {}: no ground (too few straight edges agree on a horizon)",
            smooth.confidence,
            horizon::MIN_CONFIDENCE
        );
        "none"
    };
    if let Some(path) = plot {
        let shown = (ground == "auto").then_some(&smooth);
        plot_ground(&frame, rot, camera, shown, path)?;
    }
    let mut v = estimate_json(&smooth);
    v["ground"] = json!(ground);
    v["min_confidence"] = json!(horizon::MIN_CONFIDENCE);
    v["frame"] = estimate_json(&raw);
    v["frames_used"] = json!(frames);
    v["ms_per_frame"] = json!(ms);
    v["fov_deg"] = json!(camera.fov_deg);
    v["camera_height_m"] = json!(camera.height_m);
    Ok(v)
}

/// Draws the frame with the horizon (red) and a 1 m grid on the ground (yellow, to 30 m
/// ahead and ±10 m aside) through the estimated camera at `camera.height_m`; the frame alone
/// when there is no estimate to show.
pub fn plot_ground(
    frame: &YuvFrame,
    rot: i32,
    camera: &CameraConfig,
    est: Option<&HorizonEstimate>,
    path: &Path,
) -> Result<()> {
    let (w, h, rgb16) = crate::video::still::to_rgb16(frame, rot);
    let mut img = image::RgbImage::from_fn(w, h, |x, y| {
        let i = 3 * (y * w + x) as usize;
        image::Rgb([0, 1, 2].map(|c| (rgb16[i + c] >> 8) as u8))
    });
    let save = |img: &image::RgbImage| crate::files::save_png(img, path);
    let Some(est) = est else {
        return save(&img);
    };
    let cam = Camera::new(
        w,
        h,
        camera.fov_deg.to_radians(),
        camera.height_m,
        est.tilt_deg.to_radians(),
        est.roll_deg.to_radians(),
    );
    let mut dot = |p: DVec2, colour: [u8; 3]| {
        if p.x >= 0.0 && p.y >= 0.0 && p.x < w as f64 && p.y < h as f64 {
            img.put_pixel(p.x as u32, p.y as u32, image::Rgb(colour));
        }
    };
    let mut line = |a: DVec3, b: DVec3| {
        let n = 2000;
        for k in 0..=n {
            let p = a.lerp(b, k as f64 / n as f64);
            if let Some(px) = cam.project_world(p) {
                dot(px, [255, 220, 0]);
            }
        }
    };
    for i in -10..=10 {
        line(
            DVec3::new(i as f64, 0.5, 0.0),
            DVec3::new(i as f64, 30.0, 0.0),
        );
    }
    for j in 1..=30 {
        line(
            DVec3::new(-10.0, j as f64, 0.0),
            DVec3::new(10.0, j as f64, 0.0),
        );
    }
    let up = up_from_tilt_roll(est.tilt_deg.to_radians(), est.roll_deg.to_radians());
    if let Some((a, b)) = horizon_points_px(up, &cam) {
        let n = 4 * (w + h) as usize;
        for k in 0..=n {
            let p = a.lerp(b, k as f64 / n as f64);
            for d in [-1.0, 0.0, 1.0] {
                let q = p + DVec2::new(0.0, d);
                if q.x >= 0.0 && q.y >= 0.0 && q.x < w as f64 && q.y < h as f64 {
                    img.put_pixel(q.x as u32, q.y as u32, image::Rgb([255, 40, 40]));
                }
            }
        }
    }
    save(&img)
}
