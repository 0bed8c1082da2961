//! The shot: the facts a render takes from the input's description and the configuration
//! (the camera, the exposure, the frame rate, the picture's layout) and the rain planned for
//! it, as one value, planned on the CPU before any GPU work. Everything below the pipeline
//! that needs "the camera of this clip" or "the time of this frame" reads it from here.

pub mod rain;

pub use rain::RainPlan;

use crate::config::{RenderConfig, StreakStyle};
use crate::scene::Camera;
use crate::video::{ColorParams, FrameFormat, VideoInfo, YuvFrame};
use crate::{Error, Result};

/// What a shot's frames are, all a render needs of the input: the coded layout, the colour,
/// the display rotation and the frame rate. A clip's comes from its [`VideoInfo`]; a host that
/// hands over pictures (an editor's plug-in, a test) describes its own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footage {
    /// Layout of the frames (coded size, before display rotation).
    pub format: FrameFormat,
    /// Numerical colour interpretation of the frames.
    pub color: ColorParams,
    /// Display rotation, degrees counter-clockwise, in {0, 90, 180, 270}.
    pub rotation_deg: i32,
    /// Frames per second.
    pub fps: f64,
    /// How many frames the shot has, when known.
    pub frame_count: Option<u64>,
}

impl Footage {
    /// The footage of a clip: its rate is the average, else the nominal one, else 25 fps (a
    /// rate outside what the rain's physics accepts counts as unknown).
    pub fn of(info: &VideoInfo) -> Footage {
        let fps = [info.avg_frame_rate, info.frame_rate]
            .into_iter()
            .filter(|&(num, den)| num > 0 && den > 0)
            .map(|(num, den)| num as f64 / den as f64)
            .find(|&fps| crate::rain::physics::exposure_s(360.0, fps).is_ok())
            .unwrap_or(25.0);
        Footage {
            format: info.format,
            color: info.color,
            rotation_deg: info.rotation_deg,
            fps,
            frame_count: info.frame_count,
        }
    }

    /// Pictures of `format` in `color`, upright, at `fps` frames per second, however many.
    pub fn picture(format: FrameFormat, color: ColorParams, fps: f64) -> Footage {
        Footage {
            format,
            color,
            rotation_deg: 0,
            fps,
            frame_count: None,
        }
    }

    /// The displayed picture's size: the coded one turned by the display rotation.
    pub fn display_size(&self) -> (u32, u32) {
        crate::video::frame::display_size(self.rotation_deg, self.format.width, self.format.height)
    }

    /// The camera looking at the displayed picture under `config`.
    pub fn camera(&self, config: &RenderConfig) -> Result<Camera> {
        let (w, h) = self.display_size();
        config.camera(w, h)
    }

    /// Exposure time: shutter angle over 360° times the frame duration (180° → 1/(2·fps)), by
    /// [`crate::rain::physics::exposure_s`].
    pub fn exposure_s(&self, config: &RenderConfig) -> Result<f64> {
        crate::rain::physics::exposure_s(config.camera.shutter_deg, self.fps)
    }
}

/// A shot: its camera, timing and picture layout, and the rain planned for it.
#[derive(Debug, Clone)]
pub struct Shot {
    /// The configuration the shot was planned from (its ground resolved).
    pub config: RenderConfig,
    /// The camera looking at the displayed picture, at the shot's start.
    pub camera: Camera,
    /// Exposure time of a frame, s.
    pub exposure_s: f64,
    /// What the frames are.
    pub footage: Footage,
    /// The rain.
    pub rain: RainPlan,
}

impl Shot {
    /// Plans the shot of `footage` under `config` (validated), with at most
    /// `max_drops` drops a frame where the device that draws them holds fewer than the
    /// configuration asks for (the plan then shrinks the far distance and weights drops exactly
    /// as for any other budget; the caller, who knows the device, says so).
    pub fn plan(footage: &Footage, config: &RenderConfig, max_drops: Option<u32>) -> Result<Shot> {
        config.validate()?;
        let exposure = footage.exposure_s(config)?;
        if exposure > 1.0 {
            let fps = config.camera.shutter_deg / 360.0 / exposure;
            return Err(Error::Parameter {
                name: "camera.shutter_deg",
                value: config.camera.shutter_deg.to_string(),
                expected: format!(
                    "an exposure of at most 1 s: this clip runs at {fps:.3} fps, so at most {:.1} degrees",
                    360.0 * fps
                ),
            });
        }
        let mut rain_config = config.rain;
        if let Some(cap) = max_drops.filter(|&cap| rain_config.max_drops > cap) {
            rain_config.max_drops = cap;
        }
        let camera = footage.camera(config)?;
        let (w, h) = footage.display_size();
        let posed = config.posed_camera(w, h)?;
        check_pose_keys(config, &posed)?;
        let plan = rain::plan_keyed(
            &camera,
            &posed,
            &rain_config,
            &config.keyframes,
            exposure,
            footage.rotation_deg,
            (footage.format.width, footage.format.height),
        )?;
        let mattes = match config.rain.streaks {
            StreakStyle::Simple => None,
            StreakStyle::Mattes => {
                let dir = match &config.streak_db {
                    Some(dir) => std::path::PathBuf::from(dir),
                    None => default_streak_db().ok_or_else(|| Error::Parameter {
                        name: "rain.streaks",
                        value: "mattes".into(),
                        expected: "a streak database, and none is installed beside the program \
                                   (../share/rain-composite/drops, or drops/ next to it): pass \
                                   streak_db DIR (made by `rain-composite drops generate`)"
                            .into(),
                    })?,
                };
                let atlas = crate::drops::MatteAtlas::load(&dir, exposure)?;
                Some(std::sync::Arc::new(atlas))
            }
        };
        let rain = plan
            .with_ground(config.ground.is_given())
            .with_wetting(config.ground.wetting(
                config.keyframes.rate_mm_per_h.as_ref(),
                config.rain.rate_mm_per_h,
                config.rain.scene_depth_m,
            ))
            .with_scene_depth(config.ground.depth.is_some())
            .with_mattes(mattes)
            .with_gpu_raster(config.gpu_raster);
        Ok(Shot {
            config: config.clone(),
            camera,
            exposure_s: exposure,
            footage: *footage,
            rain,
        })
    }
}

/// Most a keyed tilt or roll may start off a given ground's, degrees (rounding in a pose file).
pub const POSE_KEY_TOLERANCE_DEG: f64 = 0.01;

/// Beside a given ground, a keyed tilt or roll is the camera's own, as without one, so it
/// starts where the ground puts the camera (`posed`): the ground is then where the picture
/// shows it at the first frame, and stays in the world as the camera turns.
fn check_pose_keys(config: &RenderConfig, posed: &crate::config::CameraConfig) -> Result<()> {
    if !config.ground.is_given() {
        return Ok(());
    }
    let k = &config.keyframes;
    for (name, key, value) in [
        ("camera.tilt_deg", &k.tilt_deg, posed.tilt_deg),
        ("camera.roll_deg", &k.roll_deg, posed.roll_deg),
    ] {
        if let Some(at_0) = key.as_ref().map(|c| c.at(0.0))
            && (at_0 - value).abs() > POSE_KEY_TOLERANCE_DEG
        {
            return Err(Error::Parameter {
                name,
                value: format!("keys from {at_0}"),
                expected: format!(
                    "keys from the ground's {value:.3}° (ground.mode {} poses the first frame; \
                     key the pan and the field of view, or start these keys there)",
                    config.ground.mode
                ),
            });
        }
    }
    Ok(())
}

/// The camera looking at the displayed picture of `info`.
pub fn camera_for(info: &VideoInfo, config: &RenderConfig) -> Result<Camera> {
    Footage::of(info).camera(config)
}

/// Exposure time of a frame of `info` under `config` (see [`Footage::exposure_s`]).
pub fn exposure_s(info: &VideoInfo, config: &RenderConfig) -> Result<f64> {
    Footage::of(info).exposure_s(config)
}

/// Seconds since the start of the stream at `frame`.
pub fn frame_time_s(info: &VideoInfo, frame: &YuvFrame) -> f64 {
    (frame.pts - info.start_pts) as f64 * info.time_base.0 as f64 / info.time_base.1 as f64
}

/// The streak database of the source tree the program was built from.
pub const DEFAULT_STREAK_DB: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/drops");

/// Where `--streaks mattes` finds its database without `--streak-db`: beside an installed
/// program (`../share/rain-composite/drops` or `drops/` next to the executable), else the source
/// tree it was built from. `None` when none holds an `index.json`.
pub fn default_streak_db() -> Option<std::path::PathBuf> {
    let exe_dir = std::env::current_exe()
        .ok()
        .and_then(|e| e.parent().map(std::path::Path::to_path_buf));
    let installed = exe_dir
        .into_iter()
        .flat_map(|d| [d.join("../share/rain-composite/drops"), d.join("drops")]);
    installed
        .chain(std::iter::once(std::path::PathBuf::from(DEFAULT_STREAK_DB)))
        .find(|d| d.join("index.json").is_file())
}
