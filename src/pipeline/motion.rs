//! `camera_motion` in the render: the camera's pose per frame, estimated in a pre-pass over the
//! whole clip (`auto`) or read from a pose file, turned into pose keys before the rain is
//! built, so every frame sees the rain, the lights and the haze through its own camera exactly
//! as with the camera keys (the volume is planned for every pose of the shot).
//!
//! The pre-pass reads the whole clip, whatever part a job renders, so a chunk and a preview
//! plan the same rain as the whole render. A shot that does not move (beyond the dead band of
//! [`crate::scene::motion`]) or is not estimated confidently keeps the configured camera, and a
//! clip with no moving shot adds no keys: its render is the render without `auto`. The
//! estimated motion follows the camera keys' rules: it is not estimated beside pose keys (they
//! are the manual control). Beside a ground — given or found — the ground poses the first
//! camera and the motion turns it from there: a camera turning and zooming about its centre
//! leaves the ground plane where it is in the world, so the splashes, wet ground and puddles,
//! drawn through each frame's camera, stay on it.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use super::pose_cache;
use crate::config::RenderConfig;
use crate::keyframes::{Curve, Keyframes};
use crate::scene::Camera;
use crate::scene::horizon::Luma;
use crate::scene::motion::{self, Estimate, Estimator, MotionSource, PoseTrack};
use crate::scene::tracker::is_cut;
use crate::video::Source;
use crate::{Error, Result};

/// The camera's motion over the clip `input`, whose first frame is seen through `config`'s
/// camera (its field of view, tilt and roll; pan 0). Stops with [`Error::Interrupted`] once
/// `cancel` is set.
pub fn estimate_clip(input: &str, config: &RenderConfig, cancel: &AtomicBool) -> Result<Estimate> {
    if input == "-" {
        return Err(Error::Parameter {
            name: "camera_motion",
            value: "auto".into(),
            expected: "a file input: auto reads the whole clip before the render (give a pose \
                       file or none for a stream on stdin)"
                .into(),
        });
    }
    let mut source = Source::open(input)?;
    let info = source.info().clone();
    let rot = info.rotation_deg;
    let mut estimator = Estimator::new(first_camera(config, &info)?);
    let mut prev: Option<[f32; 144]> = None;
    let mut last_t = f64::NEG_INFINITY;
    let (started, mut frames) = (Instant::now(), 0usize);
    while let Some(frame) = source.next_frame()? {
        if cancel.load(Ordering::Relaxed) {
            return Err(Error::Interrupted);
        }
        let t = crate::shot::frame_time_s(&info, &frame).max(0.0);
        if t <= last_t {
            continue;
        }
        last_t = t;
        let (image, scale) = motion::work_image(&frame, rot);
        let luma = Luma {
            width: image.width,
            height: image.height,
            data: image.data,
            scale,
        };
        let thumb = luma.thumbnail();
        let cut = prev.is_some_and(|p| is_cut(&p, &thumb));
        prev = Some(thumb);
        let image = motion::track::Image {
            width: luma.width,
            height: luma.height,
            data: luma.data,
        };
        estimator.push(image, scale as f64, t, cut);
        frames += 1;
    }
    if frames == 0 {
        return Err(Error::CorruptInput(
            "camera_motion auto: no frame could be decoded".into(),
        ));
    }
    let estimate = estimator.finish();
    log::info!(
        "camera motion: {} frames in {:.1} s ({:.1} ms a frame, decoding included), {} shot(s), \
         {} moving",
        frames,
        started.elapsed().as_secs_f64(),
        started.elapsed().as_secs_f64() * 1e3 / frames as f64,
        estimate.shots.len(),
        estimate.shots.iter().filter(|s| s.moving).count()
    );
    Ok(estimate)
}

/// The camera the first frame of the clip `info` is seen through under `config` (its ground's
/// pose, pan 0): where the estimate starts.
fn first_camera(config: &RenderConfig, info: &crate::video::VideoInfo) -> Result<Camera> {
    let (w, h) =
        crate::video::frame::display_size(info.rotation_deg, info.format.width, info.format.height);
    Ok(crate::config::CameraConfig {
        pan_deg: 0.0,
        ..config.posed_camera(w, h)?
    }
    .camera(w, h))
}

/// [`estimate_clip`], kept in and read back from `kept` (a folder: see
/// [`super::pose_cache`]) where one is given and `input` is a file.
pub fn estimate_kept(
    input: &str,
    config: &RenderConfig,
    cancel: &AtomicBool,
    kept: Option<&Path>,
) -> Result<Estimate> {
    if let Some(dir) = kept.filter(|_| input != "-") {
        let info = Source::open(input)?.info().clone();
        if let Some(key) = pose_cache::key(input, &first_camera(config, &info)?) {
            if let Some(estimate) = pose_cache::load(dir, &key) {
                log::info!(
                    "camera motion: {} frames read from {}",
                    estimate.track.frames.len(),
                    pose_cache::path(dir, &key).display()
                );
                return Ok(estimate);
            }
            let estimate = estimate_clip(input, config, cancel)?;
            pose_cache::store(dir, &key, &estimate);
            return Ok(estimate);
        }
    }
    estimate_clip(input, config, cancel)
}

/// The pose keys of `track` over the camera `posed` (`config`'s camera with its ground's pose:
/// [`RenderConfig::posed_camera`]): the pan added to `camera.pan_deg` (the file's is relative
/// to the first frame), the tilt, roll and field of view as they are; a setting the track never
/// moves off its configured value gets no key.
pub fn keys_of(
    track: &PoseTrack,
    config: &RenderConfig,
    posed: &crate::config::CameraConfig,
) -> Result<Keyframes> {
    track.check().map_err(|reason| Error::Parameter {
        name: "camera_motion",
        value: "a pose track".into(),
        expected: reason,
    })?;
    let c = posed;
    let curve = |value: &dyn Fn(&motion::FramePose) -> f64, plain: f64| {
        let keys: Vec<(f64, f64)> = track.frames.iter().map(|f| (f.t, value(f))).collect();
        // The first camera read back through its rotation differs from the settings by
        // rounding only.
        if keys.iter().all(|k| (k.1 - plain).abs() <= 1e-9) {
            return Ok(None);
        }
        Curve::track(keys).map(Some).map_err(|e| Error::Parameter {
            name: "camera_motion",
            value: "a pose track".into(),
            expected: e,
        })
    };
    // A camera set at a bound of its range (a roll of ±180°, a tilt of ±90°) and seen to move
    // a hair past it is held at the bound: the keys' ranges are the settings' ranges.
    Ok(Keyframes {
        pan_deg: curve(&|f| (c.pan_deg + f.pan_deg).clamp(-360.0, 360.0), c.pan_deg)?,
        tilt_deg: curve(&|f| f.tilt_deg.clamp(-90.0, 90.0), c.tilt_deg)?,
        roll_deg: curve(&|f| f.roll_deg.clamp(-180.0, 180.0), c.roll_deg)?,
        fov_deg: curve(&|f| f.fov_deg, c.fov_deg)?,
        ..config.keyframes.clone()
    })
}

/// The camera settings of `config` on the displayed picture of `input`, posed by its ground
/// (see [`RenderConfig::posed_camera`]); the settings as they are without a ground.
fn posed_camera(config: &RenderConfig, input: &str) -> Result<crate::config::CameraConfig> {
    if !config.ground.is_given() {
        return Ok(config.camera);
    }
    if input == "-" {
        return Err(Error::Parameter {
            name: "camera_motion",
            value: config.camera_motion.to_string(),
            expected: "a file input beside a ground (the ground poses the first frame through \
                       the picture's size)"
                .into(),
        });
    }
    let info = Source::open(input)?.info().clone();
    let (w, h) =
        crate::video::frame::display_size(info.rotation_deg, info.format.width, info.format.height);
    config.posed_camera(w, h)
}

/// `config` with `camera_motion` resolved on `input` (after the ground is): the motion as pose
/// keys where it moves the camera, and `camera_motion` set to `none` (see the module doc for
/// when `auto` adds nothing).
pub fn resolve(config: &RenderConfig, input: &str, cancel: &AtomicBool) -> Result<RenderConfig> {
    resolve_kept(config, input, cancel, None)
}

/// [`resolve`], with `auto`'s estimate kept in and read back from the folder `kept` (see
/// [`super::pose_cache`]).
pub fn resolve_kept(
    config: &RenderConfig,
    input: &str,
    cancel: &AtomicBool,
    kept: Option<&Path>,
) -> Result<RenderConfig> {
    let mut out = config.clone();
    out.camera_motion = MotionSource::None;
    let track = match &config.camera_motion {
        MotionSource::None => return Ok(out),
        MotionSource::File(path) => PoseTrack::read(path)?,
        MotionSource::Auto => {
            if config.keyframes.pose().into_iter().any(Option::is_some) {
                log::info!("camera motion: the camera keys move the camera; none estimated");
                return Ok(out);
            }
            if input == "-" {
                log::info!("camera motion: a stream on stdin is not read ahead; none estimated");
                return Ok(out);
            }
            let estimate = estimate_kept(input, config, cancel, kept)?;
            for s in estimate.shots.iter().filter(|s| !s.moving && s.frames > 1) {
                if s.confidence < motion::MIN_SHOT_CONFIDENCE {
                    log::warn!(
                        "camera motion: the shot at {:.2} s is not tracked confidently \
                         ({:.0} % of its frames); its camera is held still",
                        s.start_s,
                        100.0 * s.confidence
                    );
                }
            }
            if estimate.track.is_still() {
                return Ok(out);
            }
            estimate.track
        }
    };
    let posed = posed_camera(config, input)?;
    // Beside a ground, the ground poses the first camera: a file's turns are taken from there
    // (the estimate starts there already).
    let first = track.frames[0];
    let track = if config.ground.is_given()
        && ((first.tilt_deg - posed.tilt_deg).abs() > 1e-9
            || (first.roll_deg - posed.roll_deg).abs() > 1e-9)
    {
        log::info!(
            "camera motion: the poses start at tilt {:.2}°, roll {:.2}°; turned to start at the \
             ground's {:.2}°, {:.2}°",
            first.tilt_deg,
            first.roll_deg,
            posed.tilt_deg,
            posed.roll_deg
        );
        track.rebased(posed.tilt_deg, posed.roll_deg)
    } else {
        track
    };
    let keys = keys_of(&track, &out, &posed)?;
    // The rain volume is planned along the camera's path, summed over every turn: a long
    // handheld clip (0.5° of shake at 2 Hz sums 4° a second) can sum more than the planning
    // takes. An estimate the render would refuse is held still instead, with a warning; a pose
    // file is the user's, and is refused with the reason.
    if config.camera_motion == MotionSource::Auto {
        use crate::shot::rain::{MAX_PATH_POSES, MAX_PATH_STEP_DEG, PATH_STEP_DEG};
        let poses = keys.camera_samples_s(PATH_STEP_DEG).len();
        if PATH_STEP_DEG * poses as f64 > MAX_PATH_POSES as f64 * MAX_PATH_STEP_DEG {
            log::warn!(
                "camera motion: the estimated turns sum to about {} degrees over the clip, more \
                 than the rain can be planned for ({:.0}); the camera is held still (write the \
                 poses with inspect camera --json and pass a smoothed or shorter file)",
                poses - 1,
                MAX_PATH_POSES as f64 * MAX_PATH_STEP_DEG
            );
            return Ok(out);
        }
    }
    out.keyframes = keys;
    if out.keyframes.moves_camera() {
        log::info!(
            "camera motion: {} poses over {:.2} s",
            track.frames.len(),
            track.frames.last().map_or(0.0, |f| f.t)
        );
    }
    Ok(out)
}
