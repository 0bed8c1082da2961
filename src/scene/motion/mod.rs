//! The camera's motion from the frames: per frame, how far the camera has turned (pan, tilt,
//! roll) and zoomed since its shot's first frame, from corner tracks ([`track`]) and a robust
//! fit of a rotation-plus-zoom homography `H = K' R K⁻¹` ([`fit`]); smoothed, reset at cuts,
//! confidence-gated, and exactly still for a shot that does not move beyond a dead band.
//!
//! Each frame is matched to a *reference* frame of its shot rather than to the frame before,
//! so the estimate of a still or slowly drifting camera does not random-walk: the reference
//! moves on only when too few of its corners still follow the fit (the view has moved on). The
//! camera's translation is not estimated: a dolly or a tracking shot is read as the rotation
//! that best explains the far scene, and its parallax lowers the confidence.
//!
//! The pose of a frame is the world-from-camera rotation of the shot's first camera (the
//! configured tilt and roll, pan 0) turned by the estimated rotation, read back as the pan,
//! tilt and roll of [`crate::scene::Camera::new`] and `panned`; the zoom becomes the field of
//! view.

pub mod fit;
pub mod track;

use std::path::PathBuf;
use std::str::FromStr;

use glam::{DMat3, DVec2, DVec3};
use serde::{Deserialize, Serialize};

use self::fit::TurnZoom;
use self::track::{Image, Pyramid};
use crate::scene::Camera;
use crate::{Error, Result};

/// Where a render's camera motion comes from (`camera_motion`).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum MotionSource {
    /// The camera is still (or moved only by the camera keys). The default: `Auto` reads the
    /// whole clip before the first frame, which a preview of a long clip should not wait for
    /// (a 10-minute 1080p clip: 97 s against 0.8 s on two cores).
    #[default]
    None,
    /// Estimated from the clip before the render (a file input only).
    Auto,
    /// A pose file, as `inspect camera --json` writes it.
    File(PathBuf),
}

impl FromStr for MotionSource {
    type Err = Error;

    fn from_str(s: &str) -> Result<MotionSource> {
        match s.trim() {
            "" => Err(Error::Parameter {
                name: "camera_motion",
                value: String::new(),
                expected: "auto, none or the path of a pose file".into(),
            }),
            "none" => Ok(MotionSource::None),
            "auto" => Ok(MotionSource::Auto),
            path => Ok(MotionSource::File(PathBuf::from(path))),
        }
    }
}

impl std::fmt::Display for MotionSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MotionSource::None => f.write_str("none"),
            MotionSource::Auto => f.write_str("auto"),
            MotionSource::File(p) => write!(f, "{}", p.display()),
        }
    }
}

impl Serialize for MotionSource {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_string())
    }
}

impl<'de> Deserialize<'de> for MotionSource {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// The camera at one frame, in the pose file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FramePose {
    /// The frame's time, seconds from the clip's first frame.
    pub t: f64,
    /// Pan since the first frame, degrees, right positive.
    pub pan_deg: f64,
    /// Tilt, degrees, up positive (as `camera.tilt_deg`).
    pub tilt_deg: f64,
    /// Roll, degrees, clockwise (as `camera.roll_deg`).
    pub roll_deg: f64,
    /// Horizontal field of view, degrees.
    pub fov_deg: f64,
    /// How sure the estimate of this frame is, in [0, 1] (written by `inspect camera`; a file
    /// may leave it out).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub confidence: Option<f64>,
}

/// A camera's pose per frame: the pose file (`{"frames": [...]}`; other top-level fields, such
/// as `inspect camera`'s `shots`, are ignored on reading).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseTrack {
    /// The frames, in time order.
    pub frames: Vec<FramePose>,
}

/// Largest pose file read, bytes (about half a million frames).
pub const MAX_POSE_FILE_BYTES: u64 = 64 << 20;

impl PoseTrack {
    /// Reads and checks a pose file; the error names the setting, the file and what is wrong.
    pub fn read(path: &std::path::Path) -> Result<PoseTrack> {
        let fail = |reason: String| Error::Parameter {
            name: "camera_motion",
            value: path.display().to_string(),
            expected: format!(
                "a pose file ({{\"frames\": [{{\"t\", \"pan_deg\", …}}]}}): {reason}"
            ),
        };
        let meta = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
        if !meta.is_file() || meta.len() > MAX_POSE_FILE_BYTES {
            return Err(fail(format!(
                "a pose file is a regular file of at most {} MiB",
                MAX_POSE_FILE_BYTES >> 20
            )));
        }
        let text = std::fs::read_to_string(path).map_err(|e| fail(e.to_string()))?;
        let track: PoseTrack = serde_json::from_str(&text).map_err(|e| fail(e.to_string()))?;
        track.check().map_err(fail)?;
        Ok(track)
    }

    /// What is wrong with the frames, if anything: at least one, times ≥ 0 and increasing,
    /// angles finite, tilt within ±90°, fields of view in (1, 170)°.
    pub fn check(&self) -> std::result::Result<(), String> {
        if self.frames.is_empty() {
            return Err("no frames".into());
        }
        for (i, f) in self.frames.iter().enumerate() {
            let finite = [f.t, f.pan_deg, f.tilt_deg, f.roll_deg, f.fov_deg]
                .iter()
                .all(|v| v.is_finite());
            if !finite || f.t < 0.0 {
                return Err(format!("frame {i}: times ≥ 0 s and finite angles"));
            }
            if f.tilt_deg.abs() > 90.0 || !(f.fov_deg > 1.0 && f.fov_deg < 170.0) {
                return Err(format!(
                    "frame {i}: tilt_deg within ±90 and fov_deg in (1, 170), got {} and {}",
                    f.tilt_deg, f.fov_deg
                ));
            }
            if i > 0 && f.t <= self.frames[i - 1].t {
                return Err(format!("frame {i}: times in increasing order"));
            }
        }
        Ok(())
    }

    /// The track turned so that its first frame has tilt `tilt_deg` and roll `roll_deg`
    /// (and pan 0): every frame keeps its turn from the first one, `W' = W₀' · W₀ᵀ · W` with
    /// `W` the world-from-camera rotations, so a track estimated through a level guess follows
    /// a ground that poses the first camera otherwise. Pans are unwrapped frame to frame.
    pub fn rebased(&self, tilt_deg: f64, roll_deg: f64) -> PoseTrack {
        let rotation = |pan: f64, tilt: f64, roll: f64| {
            Camera::new(2, 2, 1.0, 1.0, tilt.to_radians(), roll.to_radians())
                .panned(pan.to_radians())
                .world_from_camera
        };
        let Some(first) = self.frames.first() else {
            return self.clone();
        };
        let turn = rotation(0.0, tilt_deg, roll_deg)
            * rotation(first.pan_deg, first.tilt_deg, first.roll_deg).transpose();
        let mut last_pan = 0.0;
        let frames = self
            .frames
            .iter()
            .map(|f| {
                let (pan, tilt, roll) =
                    pan_tilt_roll(turn * rotation(f.pan_deg, f.tilt_deg, f.roll_deg));
                let pan = pan.to_degrees();
                let pan = pan - 360.0 * ((pan - last_pan) / 360.0).round();
                last_pan = pan;
                FramePose {
                    pan_deg: pan,
                    tilt_deg: tilt.to_degrees(),
                    roll_deg: roll.to_degrees(),
                    ..*f
                }
            })
            .collect();
        PoseTrack { frames }
    }

    /// Whether every frame has the first one's pose.
    pub fn is_still(&self) -> bool {
        let p = |f: &FramePose| [f.pan_deg, f.tilt_deg, f.roll_deg, f.fov_deg];
        self.frames.windows(2).all(|w| p(&w[0]) == p(&w[1]))
    }
}

/// The pan, tilt and roll (radians) of a world-from-camera rotation, in the conventions of
/// [`Camera::new`] then [`Camera::panned`]: `W = Rz(−pan) · Rx(tilt) · L · Rz(roll)`, with `L`
/// the level camera (x → x, y → −z, z → y).
pub fn pan_tilt_roll(world_from_camera: DMat3) -> (f64, f64, f64) {
    let forward = world_from_camera * DVec3::Z;
    let tilt = forward.z.clamp(-1.0, 1.0).asin();
    let pan = forward.x.atan2(forward.y);
    let level = DMat3::from_cols(DVec3::X, DVec3::NEG_Z, DVec3::Y);
    let rz = level.transpose()
        * DMat3::from_rotation_x(-tilt)
        * DMat3::from_rotation_z(pan)
        * world_from_camera;
    (pan, tilt, rz.x_axis.y.atan2(rz.x_axis.x))
}

/// Fewest inlier tracks, and least share of the reference's corners among them, for a frame's
/// estimate to count.
pub const MIN_INLIERS: usize = 16;
/// See [`MIN_INLIERS`].
pub const MIN_INLIER_SHARE: f64 = 0.55;
/// Below this share of the reference's corners still following the fit, or beyond this turn
/// or zoom from it, the reference moves on to the current frame: a patch seen a few degrees
/// further across a wide view is stretched by the perspective (by 1/cos² of its angle off
/// the axis) and no longer matches its reference by a shift.
const RENEW_SHARE: f64 = 0.75;
/// See [`RENEW_SHARE`], degrees.
const RENEW_TURN_DEG: f64 = 3.0;
/// See [`RENEW_SHARE`].
const RENEW_ZOOM: f64 = 0.03;
/// Least share of a shot's frames with a confident estimate for its motion to be used.
pub const MIN_SHOT_CONFIDENCE: f64 = 0.8;
/// A shot whose camera never turns further than this from its first frame is still, degrees:
/// about a sample of the tracked picture at 60°, well above the noise of a tripod shot.
pub const DEAD_BAND_DEG: f64 = 0.05;
/// A shot whose zoom stays within this fraction of 1 keeps its field of view.
pub const ZOOM_DEAD_BAND: f64 = 0.005;
/// The fields of view and the largest tilt an estimated pose may take, degrees (inside the
/// settings' ranges, with room for smoothing).
const MIN_FOV_DEG: f64 = 2.0;
/// See [`MIN_FOV_DEG`].
const MAX_FOV_DEG: f64 = 165.0;
/// See [`MIN_FOV_DEG`].
const MAX_TILT_DEG: f64 = 89.0;
/// The grid corners are picked on (one per cell), and the step they are searched at.
const CELLS: (usize, usize) = (16, 9);
const CORNER_STEP: usize = 2;
/// Match residual that counts as agreeing with the fit, tracked samples.
const INLIER_SAMPLES: f64 = 1.0;
/// The width the frames are tracked at, samples.
pub const WORK_WIDTH: usize = 640;

/// One frame's reading.
#[derive(Debug, Clone, Copy)]
struct Reading {
    t_s: f64,
    shot: usize,
    /// The shot's first camera → this frame's.
    pose: TurnZoom,
    confidence: f64,
    confident: bool,
}

/// The frame the current ones are tracked from.
struct Reference {
    pyramid: Pyramid,
    corners: Vec<DVec2>,
    pose: TurnZoom,
}

/// How one shot of the clip moved.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ShotMotion {
    /// Time of the shot's first frame, s.
    pub start_s: f64,
    /// Frames in the shot.
    pub frames: usize,
    /// Share of its frames (after the first) estimated confidently.
    pub confidence: f64,
    /// Whether its motion is used (confident, and beyond the dead band).
    pub moving: bool,
    /// Largest turn from its first frame, degrees.
    pub max_turn_deg: f64,
}

/// The estimate over a clip.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// The pose of every frame.
    #[serde(flatten)]
    pub track: PoseTrack,
    /// The shots, cut where the picture changes.
    pub shots: Vec<ShotMotion>,
}

/// The camera's motion, estimated frame by frame (see the module doc).
pub struct Estimator {
    first: Camera,
    readings: Vec<Reading>,
    reference: Option<Reference>,
    shot: usize,
}

impl Estimator {
    /// An estimator for a clip whose first frame is seen by `first` (its size is the displayed
    /// picture's; its tilt, roll and field of view those of the shot's start).
    pub fn new(first: Camera) -> Estimator {
        Estimator {
            first,
            readings: Vec::new(),
            reference: None,
            shot: 0,
        }
    }

    /// The next frame: `image` of the displayed picture at `scale` displayed pixels per sample
    /// (sample i centred on pixel `(i + ½)·scale`), shown at `t_s`; `cut` starts a new shot.
    pub fn push(&mut self, image: Image, scale: f64, t_s: f64, cut: bool) {
        let pyramid = Pyramid::new(image);
        let first_frame = self.readings.is_empty();
        if cut && !first_frame {
            self.shot += 1;
        }
        let (reference, last) = match (&self.reference, self.readings.last()) {
            (Some(r), Some(last)) if !cut && last.shot == self.shot => (r, *last),
            _ => {
                self.start_reference(pyramid, TurnZoom::IDENTITY);
                self.readings.push(Reading {
                    t_s,
                    shot: self.shot,
                    pose: TurnZoom::IDENTITY,
                    confidence: 1.0,
                    confident: true,
                });
                return;
            }
        };
        // Constant velocity from the last two frames of the shot predicts where corners went.
        let before = self
            .readings
            .iter()
            .rev()
            .nth(1)
            .filter(|r| r.shot == self.shot)
            .map_or(last.pose, |r| r.pose);
        let step = TurnZoom {
            rotation: last.pose.rotation * before.rotation.transpose(),
            zoom: last.pose.zoom / before.zoom,
        };
        let predicted = last.pose.then(&step);
        let to_rel = |p: &TurnZoom| TurnZoom {
            rotation: p.rotation * reference.pose.rotation.transpose(),
            zoom: p.zoom / reference.pose.zoom,
        };
        let guess = to_rel(&predicted);
        let f_ref = self.first.focal_px() * reference.pose.zoom;
        let centre = self.first.principal_px();
        let to_norm = |q: DVec2| ((q + 0.5) * scale - centre) / f_ref;
        let to_samples = |n: DVec2| (n * f_ref + centre) / scale - 0.5;
        use rayon::prelude::*;
        let pairs: Vec<(DVec2, DVec2)> = reference
            .corners
            .par_iter()
            .filter_map(|&c| {
                let a = to_norm(c);
                let g = guess.apply(a).map_or(c, to_samples);
                track::follow(&reference.pyramid, &pyramid, c, g).map(|q| (a, to_norm(q)))
            })
            .collect();
        let seed = self.readings.len() as u64;
        let fitted = fit::fit(&pairs, INLIER_SAMPLES * scale / f_ref, seed);
        let corners = reference.corners.len().max(1);
        let (pose, confidence, renew) = match fitted {
            Some(f) => {
                let inliers = f.inliers.iter().filter(|&&k| k).count();
                let share = inliers as f64 / corners as f64;
                let ok = inliers >= MIN_INLIERS && share >= MIN_INLIER_SHARE;
                let pose = if ok {
                    reference.pose.then(&f.motion)
                } else {
                    last.pose
                };
                let far = f.motion.angle_rad().to_degrees() > RENEW_TURN_DEG
                    || (f.motion.zoom - 1.0).abs() > RENEW_ZOOM;
                (
                    pose,
                    if ok { share } else { 0.0 },
                    share < RENEW_SHARE || far,
                )
            }
            None => (last.pose, 0.0, true),
        };
        self.readings.push(Reading {
            t_s,
            shot: self.shot,
            pose,
            confidence,
            confident: confidence > 0.0,
        });
        if renew {
            self.start_reference(pyramid, pose);
        }
    }

    fn start_reference(&mut self, pyramid: Pyramid, pose: TurnZoom) {
        let corners = track::corners(&pyramid.levels[0], CELLS, CORNER_STEP);
        self.reference = Some(Reference {
            pyramid,
            corners,
            pose,
        });
    }

    /// The poses of all frames pushed, shot by shot: a shot not confident enough or within the
    /// dead band is still (every frame exactly its first camera's pose), a zoom within its dead
    /// band keeps the field of view, and the rest are smoothed by a 5-frame quadratic
    /// Savitzky–Golay filter (which keeps pans that speed up and handheld shake below about a
    /// fifth of the frame rate within 10 %).
    pub fn finish(self) -> Estimate {
        let first_w = self.first.world_from_camera;
        let (pan0, tilt0, roll0) = pan_tilt_roll(first_w);
        let fov0 = self.first.fov_x_rad;
        let mut frames = Vec::with_capacity(self.readings.len());
        let mut shots = Vec::new();
        let mut start = 0;
        while start < self.readings.len() {
            let shot = self.readings[start].shot;
            let end = start
                + self.readings[start..]
                    .iter()
                    .take_while(|r| r.shot == shot)
                    .count();
            let readings = &self.readings[start..end];
            let later = (readings.len() - 1).max(1) as f64;
            let confidence = readings[1..].iter().filter(|r| r.confident).count() as f64 / later;
            let max_turn_deg = readings
                .iter()
                .map(|r| r.pose.angle_rad().to_degrees())
                .fold(0.0, f64::max);
            let zooms = readings
                .iter()
                .any(|r| (r.pose.zoom - 1.0).abs() > ZOOM_DEAD_BAND);
            // A fit that ran off (a change of view the cut detector missed, read as a turn and
            // a zoom, compounded over the references after it) leaves the camera's range: the
            // shot is held still rather than followed there.
            let in_range = readings.iter().all(|r| {
                let fov = 2.0 * ((0.5 * fov0).tan() / r.pose.zoom).atan();
                let (_, tilt, _) = pan_tilt_roll(first_w * r.pose.rotation.transpose());
                (MIN_FOV_DEG..=MAX_FOV_DEG).contains(&fov.to_degrees())
                    && tilt.to_degrees().abs() <= MAX_TILT_DEG
            });
            if !in_range {
                log::warn!(
                    "camera motion: the shot at {:.2} s reads as a camera turned or zoomed out of \
                     range (a change of view not taken for a cut?); its camera is held still",
                    readings[0].t_s
                );
            }
            let moving = readings.len() > 1
                && confidence >= MIN_SHOT_CONFIDENCE
                && (max_turn_deg > DEAD_BAND_DEG || zooms)
                && in_range;
            shots.push(ShotMotion {
                start_s: readings[0].t_s,
                frames: readings.len(),
                confidence,
                moving,
                max_turn_deg,
            });
            // Pan, tilt, roll and the zoom's logarithm per frame, pan unwrapped.
            let mut values: Vec<[f64; 4]> = readings
                .iter()
                .map(|r| {
                    if !moving {
                        return [pan0, tilt0, roll0, 0.0];
                    }
                    let (p, t, l) = pan_tilt_roll(first_w * r.pose.rotation.transpose());
                    let z = if zooms { r.pose.zoom.ln() } else { 0.0 };
                    [p, t, l, z]
                })
                .collect();
            for i in 1..values.len() {
                for k in [0, 2] {
                    let d = values[i][k] - values[i - 1][k];
                    values[i][k] -= (d / std::f64::consts::TAU).round() * std::f64::consts::TAU;
                }
            }
            let smoothed = if moving {
                savitzky_golay(&values)
            } else {
                values
            };
            for (r, v) in readings.iter().zip(smoothed) {
                let fov = 2.0 * ((0.5 * fov0).tan() / v[3].exp()).atan();
                frames.push(FramePose {
                    t: r.t_s,
                    pan_deg: (v[0] - pan0).to_degrees(),
                    tilt_deg: v[1].to_degrees(),
                    roll_deg: v[2].to_degrees(),
                    fov_deg: fov.to_degrees(),
                    confidence: Some(r.confidence),
                });
            }
            start = end;
        }
        Estimate {
            track: PoseTrack { frames },
            shots,
        }
    }
}

/// The 5-point quadratic Savitzky–Golay smoother (Savitzky & Golay 1964, coefficients
/// (−3, 12, 17, 12, −3)/35) of each column; the two frames at each end are kept as they are.
pub fn savitzky_golay(values: &[[f64; 4]]) -> Vec<[f64; 4]> {
    const C: [f64; 5] = [-3.0, 12.0, 17.0, 12.0, -3.0];
    let mut out = values.to_vec();
    for i in 2..values.len().saturating_sub(2) {
        for (k, o) in out[i].iter_mut().enumerate() {
            *o = (0..5).map(|j| C[j] * values[i + j - 2][k]).sum::<f64>() / 35.0;
        }
    }
    out
}

/// A frame's luma as displayed, box-averaged down to about [`WORK_WIDTH`] samples wide, as the
/// tracker's image, and the displayed pixels per sample: exactly
/// [`crate::scene::horizon::Luma::from_frame`] (its plain reference), read row by row from the
/// plane where the picture is not rotated.
pub fn work_image(frame: &crate::video::YuvFrame, rotation_deg: i32) -> (Image, usize) {
    use crate::scene::horizon::Luma;
    if rotation_deg.rem_euclid(360) != 0 {
        let luma = Luma::from_frame(frame, rotation_deg, WORK_WIDTH);
        let image = Image {
            width: luma.width,
            height: luma.height,
            data: luma.data,
        };
        return (image, luma.scale);
    }
    let (fw, fh) = (frame.format.width as usize, frame.format.height as usize);
    let scale = fw.div_ceil(WORK_WIDTH).max(1);
    let (w, h) = ((fw / scale).max(1), (fh / scale).max(1));
    let max = ((1u32 << frame.format.bit_depth) - 1) as f32;
    let norm = 1.0 / (max * (scale * scale) as f32);
    let plane = &frame.planes[0];
    let wide = frame.format.bytes_per_sample() == 2;
    let mut data = Vec::with_capacity(w * h);
    let mut sums = vec![0u32; w];
    for j in 0..h {
        sums.fill(0);
        for y in j * scale..((j + 1) * scale).min(fh) {
            let row = &plane.data[y * plane.stride..];
            for (i, sum) in sums.iter_mut().enumerate() {
                for x in i * scale..((i + 1) * scale).min(fw) {
                    *sum += if wide {
                        u16::from_le_bytes([row[2 * x], row[2 * x + 1]]) as u32
                    } else {
                        row[x] as u32
                    };
                }
            }
        }
        data.extend(sums.iter().map(|&s| s as f32 * norm));
    }
    let image = Image {
        width: w,
        height: h,
        data,
    };
    (image, scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pan, tilt and roll read back from the camera they make, over the range a camera takes.
    #[test]
    fn pan_tilt_roll_inverts_the_camera_model() {
        let mut rng = crate::rng::SplitMix64(4);
        for _ in 0..200 {
            let pan = (rng.next_f64() - 0.5) * 6.0;
            let tilt = (rng.next_f64() - 0.5) * 3.0;
            let roll = (rng.next_f64() - 0.5) * 6.0;
            let cam = Camera::new(640, 360, 1.0, 1.6, tilt, roll).panned(pan);
            let (p, t, r) = pan_tilt_roll(cam.world_from_camera);
            assert!((p - pan).abs() < 1e-9, "pan {p} vs {pan}");
            assert!((t - tilt).abs() < 1e-9, "tilt {t} vs {tilt}");
            assert!((r - roll).abs() < 1e-9, "roll {r} vs {roll}");
        }
    }

    /// The smoother keeps a quadratic exactly (a pan that speeds up).
    #[test]
    fn savitzky_golay_keeps_a_quadratic() {
        let v: Vec<[f64; 4]> = (0..12)
            .map(|i| {
                let x = i as f64;
                [0.3 * x * x - x, 2.0, -x, 0.0]
            })
            .collect();
        for (a, b) in savitzky_golay(&v).iter().zip(&v) {
            for k in 0..4 {
                assert!((a[k] - b[k]).abs() < 1e-12);
            }
        }
    }

    /// The row-by-row luma is the reference's, bit for bit, at 8 and 10 bits.
    #[test]
    fn the_work_image_is_the_boxed_luma() {
        use crate::scene::horizon::Luma;
        use crate::video::{Chroma, ColorParams, FrameFormat, YuvFrame};
        for bits in [8u8, 10] {
            let format = FrameFormat {
                width: 1283,
                height: 722,
                chroma: Chroma::Cs420,
                bit_depth: bits,
            };
            let mut frame = YuvFrame::filled(format, ColorParams::bt709(bits), [64, 512, 512]);
            let mut rng = crate::rng::SplitMix64(2);
            let top = 1u64 << bits;
            let stride = frame.planes[0].stride;
            for y in 0..722 {
                for x in 0..1283 {
                    let v = (rng.next_u64() % top) as u16;
                    if bits == 8 {
                        frame.planes[0].data[y * stride + x] = v as u8;
                    } else {
                        let at = y * stride + 2 * x;
                        frame.planes[0].data[at..at + 2].copy_from_slice(&v.to_le_bytes());
                    }
                }
            }
            let (image, scale) = work_image(&frame, 0);
            let luma = Luma::from_frame(&frame, 0, WORK_WIDTH);
            assert_eq!(
                (image.width, image.height, scale),
                (luma.width, luma.height, luma.scale)
            );
            assert_eq!(image.data, luma.data);
        }
    }

    #[test]
    fn sources_parse_and_print() {
        for s in ["auto", "none", "poses.json"] {
            assert_eq!(s.parse::<MotionSource>().expect("parses").to_string(), s);
        }
        assert!("".parse::<MotionSource>().is_err());
    }
}
