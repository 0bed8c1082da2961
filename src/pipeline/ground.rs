//! `--ground auto` in the render: one camera pose for the clip, from a pre-pass over its first
//! shot, before the rain is built.
//!
//! The rain volume is built once, for one camera pose (`shot::Shot::plan`), and a drop's
//! state is a pure function of (seed, drop, t): so the pose cannot follow the estimate frame by
//! frame without moving every drop. Instead the render, and the preview the same way, read the
//! clip's first [`PREPASS_S`] seconds up to the first cut (the cut detector of
//! [`horizon::GroundTracker`]), estimate the horizon on at most [`PREPASS_FRAMES`] frames evenly
//! spread over them, and combine the readings with [`horizon::aggregate`]: the mode of their up
//! directions (one frame misread — a passing truck, a Manhattan flip — does not move it), with
//! the mean confidence of the readings that agree with it (a steady estimate keeps its own).
//! Below [`horizon::MIN_CONFIDENCE`] the render falls back to no ground, with one warning; a
//! confident pose whose horizon is too far off the picture to pass as `horizon=` still sets
//! the camera's tilt and roll, without a ground. The
//! result depends on the clip alone, never on the frame previewed, so preview equals render.
//!
//! The finer line pass of an unsure frame ([`crate::scene::steep::FINE_WIDTH`], as costly as
//! the rest of the frame's estimate) can only change that frame's reading. A frame skips it
//! where the pre-pass's outcome is already settled without it ([`finer_pass_moot`]): where the
//! clip's confidence could not reach [`horizon::MIN_CONFIDENCE`] even if this frame, every frame
//! that skipped the pass and every frame still to come read with confidence 1, the clip falls
//! back to no ground whatever the pass finds. On a clip of unsure frames the pass runs on the
//! first two or three frames only.

use std::cell::Cell;

use crate::config::RenderConfig;
use crate::scene::Camera;
use crate::scene::ground::GroundMode;
use crate::scene::horizon::{self, HorizonEstimate, Luma};
use crate::scene::tracker::is_cut;
use crate::video::Source;
use crate::{Error, Result};

/// Seconds of the clip's start the pre-pass reads.
pub const PREPASS_S: f64 = 2.0;

/// Most frames the pre-pass estimates (spread evenly over what it reads).
pub const PREPASS_FRAMES: usize = 24;

/// The ground of a clip, as the pre-pass found it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClipGround {
    /// The combined estimate (its confidence as in the module doc).
    pub estimate: HorizonEstimate,
    /// Frames estimated.
    pub frames: usize,
    /// Time of the first cut, seconds, where the pre-pass stopped at one.
    pub cut_s: Option<f64>,
    /// Frames whose finer line pass ran.
    pub finer_passes: usize,
    /// Frames whose finer line pass was skipped, the outcome settled ([`finer_pass_moot`]).
    pub finer_skipped: usize,
}

/// Whether the finer line pass of frame `n` (1-based) of a pre-pass that estimates at most
/// `n_max` frames cannot change its outcome: `exact_confidence` is the sum of the confidences
/// of the earlier frames read in full (their finer pass run or not needed), `skipped` the
/// number of earlier frames that skipped it. The clip's confidence is the confidence of the
/// readings that agree with its mode over the frames read ([`horizon::aggregate`]), at most
/// the sum of all their confidences over their number; frames still to come raise both by at
/// most one each, which lifts a mean under [`horizon::MIN_CONFIDENCE`] the most when all
/// `n_max` come. So where `exact_confidence + skipped + 1 + (n_max − n)` is under
/// `MIN_CONFIDENCE · n_max`, the clip falls back to no ground whatever this frame's and the
/// skipped frames' passes would find, and whatever comes after (a cut or the clip's end only
/// lowers the bound).
pub fn finer_pass_moot(exact_confidence: f64, skipped: usize, n: usize, n_max: usize) -> bool {
    let at_most = exact_confidence + (skipped + 1) as f64 + n_max.saturating_sub(n) as f64;
    at_most < horizon::MIN_CONFIDENCE * n_max as f64
}

/// The confidence-weighted median of `values` (`(value, weight)`), `None` without weight.
pub fn weighted_median(values: &[(f64, f64)]) -> Option<f64> {
    let mut v: Vec<(f64, f64)> = values
        .iter()
        .copied()
        .filter(|&(x, w)| x.is_finite() && w > 0.0)
        .collect();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = v.iter().map(|p| p.1).sum();
    let mut acc = 0.0;
    for &(x, w) in &v {
        acc += w;
        if acc >= 0.5 * total {
            return Some(x);
        }
    }
    None
}

/// Combines per-frame readings through `camera` ([`horizon::aggregate`]); `None` without any.
pub fn combine(readings: &[HorizonEstimate], camera: &Camera) -> Option<HorizonEstimate> {
    horizon::aggregate(readings, camera)
}

/// The pre-pass over `input` with `config`'s lens (its tilt and roll are what is estimated).
pub fn estimate_clip(input: &str, config: &RenderConfig) -> Result<ClipGround> {
    if input == "-" {
        return Err(Error::Parameter {
            name: "ground.mode",
            value: "auto".into(),
            expected: "a file input: auto reads the start of the clip before the render \
                       (give horizon=ROW,roll=DEG for a stream on stdin)"
                .into(),
        });
    }
    let mut source = Source::open(input)?;
    let info = source.info().clone();
    let rot = info.rotation_deg;
    let (w, h) = crate::video::frame::display_size(rot, info.format.width, info.format.height);
    let c = &config.camera;
    let cam = Camera::new(w, h, c.fov_deg.to_radians(), c.height_m, 0.0, 0.0);
    let fps = match info.nominal_fps() {
        (n, d) if n > 0 && d > 0 => n as f64 / d as f64,
        _ => 25.0,
    };
    let window = ((PREPASS_S * fps).round() as usize).max(1);
    let every = window.div_ceil(PREPASS_FRAMES).max(1);
    let n_max = window.div_ceil(every);
    let mut readings = Vec::new();
    let mut prev: Option<[f32; 144]> = None;
    let mut cut_s = None;
    let (mut exact_confidence, mut finer_passes, mut finer_skipped) = (0.0, 0, 0);
    for i in 0..window {
        let Some(frame) = source.next_frame()? else {
            break;
        };
        let luma = Luma::from_frame(&frame, rot, horizon::WORK_WIDTH);
        let thumb = luma.thumbnail();
        if prev.is_some_and(|p| is_cut(&p, &thumb)) {
            cut_s = Some(crate::shot::frame_time_s(&info, &frame));
            break;
        }
        prev = Some(thumb);
        if i % every == 0 {
            let n = readings.len() + 1;
            // Whether the estimate asked for the finer pass, and whether it ran.
            let (asked, moot) = (
                Cell::new(false),
                finer_pass_moot(exact_confidence, finer_skipped, n, n_max),
            );
            let e = horizon::estimate_finer(
                &luma,
                || {
                    asked.set(true);
                    (!moot).then(|| Luma::from_frame(&frame, rot, crate::scene::steep::FINE_WIDTH))
                },
                &cam,
            );
            if asked.get() && moot {
                finer_skipped += 1;
            } else {
                finer_passes += usize::from(asked.get());
                exact_confidence += e.confidence;
            }
            readings.push(e);
        }
    }
    let estimate = combine(&readings, &cam)
        .ok_or_else(|| Error::CorruptInput("ground.mode auto: no frame could be decoded".into()))?;
    Ok(ClipGround {
        estimate,
        frames: readings.len(),
        cut_s,
        finer_passes,
        finer_skipped,
    })
}

/// `config` with `auto` resolved on `input`: the estimated horizon, or no ground (with one
/// warning) where the confidence is below [`horizon::MIN_CONFIDENCE`]. Other modes are kept.
pub fn resolve(config: &RenderConfig, input: &str) -> Result<RenderConfig> {
    let mut out = config.clone();
    if config.ground.mode != GroundMode::Auto {
        return Ok(out);
    }
    let g = estimate_clip(input, config)?;
    let e = &g.estimate;
    log::debug!(
        "ground: the finer line pass ran on {} frames, skipped on {} (the outcome settled)",
        g.finer_passes,
        g.finer_skipped
    );
    if let Some(cut) = g.cut_s {
        log::warn!(
            "ground: a cut at {cut:.2} s; the pose of the first shot is used for the whole clip"
        );
    }
    // A horizon too far off the picture to pass as `horizon=` (a long lens tilted steeply)
    // falls back like an unsure one.
    let found = e
        .horizon_row
        .map(|row| GroundMode::Horizon {
            row,
            roll_deg: e.roll_deg,
        })
        .filter(|m| e.confidence >= horizon::MIN_CONFIDENCE && m.validate().is_ok());
    out.ground.mode = match found {
        Some(mode) => {
            log::info!(
                "ground: auto over {} frames: {mode} (tilt {:.2}°, confidence {:.2})",
                g.frames,
                e.tilt_deg,
                e.confidence
            );
            mode
        }
        None if e.confidence >= horizon::MIN_CONFIDENCE => {
            // The pose is known even where the ground is not usable: the rain still follows
            // the camera's tilt and roll.
            log::warn!(
                "ground: the horizon found (tilt {:.1}°, roll {:.1}°) is too far off the \
                 picture: no ground, the camera posed at that tilt and roll",
                e.tilt_deg,
                e.roll_deg
            );
            out.camera.tilt_deg = e.tilt_deg;
            out.camera.roll_deg = e.roll_deg;
            GroundMode::None
        }
        None => {
            log::warn!(
                "ground: confidence {:.2} is below {}: no ground (too few straight edges agree \
                 on a horizon, or the picture reads two ways)",
                e.confidence,
                horizon::MIN_CONFIDENCE
            );
            if let Some(hint) = horizon::lens_hint(e) {
                log::warn!("ground: {hint}");
            }
            GroundMode::None
        }
    };
    Ok(out)
}
