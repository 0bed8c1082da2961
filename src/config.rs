//! The render configuration, with units in every name, and its validation. The CLI builds one
//! from flags (or a JSON preset); the library never sees clap.

use serde::{Deserialize, Serialize};

use crate::error::check;
use crate::{Error, Result};

/// The camera that filmed the shot (the rain is seen through it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraConfig {
    /// Horizontal field of view of the displayed picture, degrees.
    pub fov_deg: f64,
    /// Camera height above the ground, metres.
    pub height_m: f64,
    /// Pitch up (negative: down), degrees.
    pub tilt_deg: f64,
    /// Roll clockwise about the optical axis, degrees.
    pub roll_deg: f64,
    /// Pan (yaw about the world's vertical) to the right, degrees; 0 faces the world's +y.
    /// Keyed with the rest of the pose for a moving camera; the wind and the user's lights are
    /// given in the world the camera sees at t = 0.
    pub pan_deg: f64,
    /// Shutter angle, degrees; exposure = shutter/360 / fps.
    pub shutter_deg: f64,
    /// Focus distance, metres.
    pub focus_m: f64,
    /// Aperture f-number; 0 = pinhole (no defocus).
    pub f_number: f64,
    /// Sensor width, mm (36 = full-frame equivalent); with the field of view it fixes the focal
    /// length and so the depth of field.
    pub sensor_width_mm: f64,
}

impl CameraConfig {
    /// The pinhole camera of this configuration for a displayed picture of `width_px`×`height_px`.
    pub fn camera(&self, width_px: u32, height_px: u32) -> crate::scene::Camera {
        crate::scene::Camera::new(
            width_px,
            height_px,
            self.fov_deg.to_radians(),
            self.height_m,
            self.tilt_deg.to_radians(),
            self.roll_deg.to_radians(),
        )
        .panned(self.pan_deg.to_radians())
    }
}

impl Default for CameraConfig {
    fn default() -> Self {
        CameraConfig {
            fov_deg: 60.0,
            height_m: 1.6,
            tilt_deg: 0.0,
            roll_deg: 0.0,
            pan_deg: 0.0,
            shutter_deg: 180.0,
            focus_m: 6.0,
            f_number: 8.0,
            sensor_width_mm: 36.0,
        }
    }
}

/// What rain to add.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RainConfig {
    /// Rain rate, mm/h; 0 turns rain off.
    pub rate_mm_per_h: f64,
    /// Multiplier on every drop's diameter (1 = Marshall–Palmer).
    pub drop_scale: f64,
    /// Multiplier on every drop's fall speed (1 = terminal velocity).
    pub fall_speed_scale: f64,
    /// Mean wind, m/s: x to the right of the picture, y away from the camera.
    pub wind_mps: [f64; 2],
    /// RMS of the gusts along the mean wind, m/s (0 = steady wind).
    pub gust_mps: f64,
    /// Altitude of the scene, metres (thinner air: faster drops).
    pub altitude_m: f64,
    /// Multiplier on the streaks' physical coverage (1 = physical).
    pub opacity: f64,
    /// Seed of every random choice: the same seed gives the same rain.
    pub seed: u32,
    /// Nearest drop distance, metres.
    pub near_m: f64,
    /// Farthest drop distance, metres; drops are simulated only as far as they are visible
    /// (see `rain::volume`), never beyond this.
    pub far_m: f64,
    /// Distance of the filmed scene, metres: the rain between the farthest drawn drop and the
    /// scene veils it (0 turns the haze off).
    pub scene_depth_m: f64,
    /// Most drops simulated per frame; beyond it drops are weighted (see `rain::volume`).
    pub max_drops: u32,
    /// How a streak is drawn: the smooth capsule, or spread by its drop's matte.
    pub streaks: StreakStyle,
}

/// How a streak's light is laid along it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StreakStyle {
    /// A disc swept over the exposure, its colour interpolated between the ends.
    #[default]
    Simple,
    /// The same coverage, its light spread by the drop's environment matte (`drops/`): the
    /// ripple of an oscillating drop.
    Mattes,
}

/// How the GPU draws the capsule streaks (`gpu_raster`): the same picture either way.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GpuRaster {
    /// A quad per drop through the rasteriser (`rain_streaks`): fast where every core can run
    /// it, as on most GPUs.
    #[default]
    Fragments,
    /// Tiles drawn by compute (`streak_tiles`): for GPUs built for compute, whose rasteriser
    /// runs on a few of their cores. The mattes (`--streaks mattes`) and the splashes stay
    /// quads.
    Compute,
}

impl GpuRaster {
    /// The name `gpu_raster` takes, in a configuration and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            GpuRaster::Fragments => "fragments",
            GpuRaster::Compute => "compute",
        }
    }
}

impl StreakStyle {
    /// The name `rain.streaks` takes, in a configuration and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            StreakStyle::Simple => "simple",
            StreakStyle::Mattes => "mattes",
        }
    }
}

impl Default for RainConfig {
    fn default() -> Self {
        RainConfig {
            rate_mm_per_h: 10.0,
            drop_scale: 1.0,
            fall_speed_scale: 1.0,
            wind_mps: [0.0, 0.0],
            gust_mps: 0.0,
            altitude_m: 0.0,
            opacity: 1.0,
            seed: 1,
            near_m: 0.3,
            far_m: 200.0,
            scene_depth_m: 50.0,
            max_drops: 300_000,
            streaks: StreakStyle::Simple,
        }
    }
}

/// Everything that shapes the picture (not the encoding).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderConfig {
    /// The camera.
    pub camera: CameraConfig,
    /// The rain.
    pub rain: RainConfig,
    /// How the rain is lit by the frame.
    pub light: crate::lighting::LightConfig,
    /// The ground the rain lands on.
    pub ground: GroundConfig,
    /// The streak database for `rain.streaks = "mattes"`: ours (`index.json`) or a copy of
    /// Garg & Nayar's; `None`: the `drops/` shipped with the program.
    pub streak_db: Option<String>,
    /// The camera's motion: `auto` (the default) estimates its turn and zoom from the clip
    /// before the render (a still shot stays exactly still), `none` keeps the camera where
    /// the camera settings and keys put it, a path reads a pose file (`inspect camera --json`;
    /// see [`crate::scene::motion`]).
    pub camera_motion: crate::scene::motion::MotionSource,
    /// How the GPU draws the capsule streaks: `fragments` (the default) or `compute`.
    pub gpu_raster: GpuRaster,
    /// The settings that change over the shot (`[time_s, value]` keys in the JSON, see
    /// [`crate::keyframes`]); the fields above hold their values at t = 0. Serialise with
    /// [`RenderConfig::to_value`], which writes the keys back.
    #[serde(skip)]
    pub keyframes: crate::keyframes::Keyframes,
}

/// The ground under the rain (see [`crate::scene::ground`]) and the scene's depth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GroundConfig {
    /// `none` (the default: the render is as without a ground), `horizon=ROW[,roll=DEG]` or
    /// `plane=nx,ny,nz,d`. A given ground fixes the camera's tilt and roll (and, for `plane=`,
    /// its height), and streaks end where their drops land on it.
    pub mode: crate::scene::GroundMode,
    /// Minutes it has rained (at the clip's rate) before the clip starts: how wet a given
    /// ground already is (0: dry at the start; see [`crate::lighting::wetness`]).
    pub pre_rain_min: f64,
    /// The scene's depth (camera z), drops behind it hidden: a 16-bit greyscale PNG in
    /// millimetres for the whole clip, a directory of them (one per frame, in name order) or a
    /// 16-bit greyscale video (see [`crate::scene::depth`]). None: no occlusion.
    pub depth: Option<std::path::PathBuf>,
    /// Factor on the depth file's values, which are millimetres times this: 1 for a metric map,
    /// the right factor for a relative one.
    pub depth_scale: f64,
    /// The open sky, found in the frames (`auto`) or not (`off`): where it is, the scene is
    /// infinitely far and the haze leaves the sky its own radiance (see [`crate::scene::sky`]).
    pub sky: crate::scene::sky::SkyMode,
    /// Wetness and puddles keep to the ground found in the frames (`auto`) or cover everything
    /// below the horizon (`off`); a depth map, where given, decides (see
    /// [`crate::scene::ground_mask`]).
    pub mask: crate::scene::ground_mask::GroundMaskMode,
    /// Standard deviation of the fractal micro-relief the puddle simulation adds over the
    /// ground, m (0: none); the ground's image is not displaced (see [`crate::fluid::puddles`]).
    pub relief_m: f64,
    /// Seed of the micro-relief: the same seed gives the same puddles.
    pub relief_seed: u32,
    /// Puddles: the water already fallen and the clip's rain simulated on a given ground (SPH
    /// and the carpet, [`crate::fluid::puddles`]) and shaded into the picture with its ripples
    /// and reflections. Off by default: on two cores it costs about a second a frame.
    pub puddles: bool,
    /// Most SPH particles the puddles hold: the water's resolution against its cost.
    pub puddle_particles: u32,
}

impl Default for GroundConfig {
    fn default() -> GroundConfig {
        GroundConfig {
            mode: crate::scene::GroundMode::None,
            pre_rain_min: 10.0,
            depth: None,
            depth_scale: 1.0,
            sky: crate::scene::sky::SkyMode::Auto,
            mask: crate::scene::ground_mask::GroundMaskMode::Auto,
            relief_m: 0.004,
            relief_seed: 1,
            puddles: false,
            puddle_particles: 30_000,
        }
    }
}

impl GroundConfig {
    /// How a given ground wets under rain of `rate_mm_per_h` (constant through the clip, and
    /// for `pre_rain_min` before it) or, where it is keyed, of `keys` (the first key's rate
    /// before the clip); `None` without a ground or without rain.
    pub fn wetting(
        &self,
        keys: Option<&crate::keyframes::Curve<f64>>,
        rate_mm_per_h: f64,
        reach_m: f64,
    ) -> Option<crate::lighting::wetness::Wetting> {
        use crate::lighting::wetness::{RainHistory, SurfaceStore, Wetting};
        let pre_rain_s = 60.0 * self.pre_rain_min;
        let history = match keys {
            Some(k) => RainHistory::keyed(k, pre_rain_s),
            None => RainHistory::constant(rate_mm_per_h, pre_rain_s),
        };
        let wetting = Wetting {
            store: SurfaceStore::default(),
            history,
            reach_m,
        };
        (self.is_given() && wetting.ever_wet()).then_some(wetting)
    }

    /// Whether a ground is given: streaks end where their drops land.
    pub fn is_given(&self) -> bool {
        !matches!(
            self.mode,
            crate::scene::GroundMode::None | crate::scene::GroundMode::Auto
        )
    }
}

/// Largest configuration file read, bytes: presets are a few hundred bytes, and a bound keeps a
/// wrong path (a device, a huge file) from filling the memory.
pub const MAX_CONFIG_BYTES: u64 = 4 << 20;

impl RenderConfig {
    /// Reads a JSON configuration (any field may be left out). Only regular files of at most
    /// [`MAX_CONFIG_BYTES`] are read, so a FIFO or a device such as `/dev/zero` is refused at
    /// once instead of blocking or growing without bound. A relative `ground.depth` is taken
    /// from the file's folder.
    pub fn from_json_file(path: &std::path::Path) -> Result<RenderConfig> {
        use std::io::Read;
        let fail = |reason: String| Error::Config {
            path: path.display().to_string(),
            reason,
        };
        let meta = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
        if !meta.is_file() {
            return Err(fail("not a regular file".into()));
        }
        if meta.len() > MAX_CONFIG_BYTES {
            return Err(fail(format!(
                "{} bytes; a configuration is at most {} MiB",
                meta.len(),
                MAX_CONFIG_BYTES >> 20
            )));
        }
        let mut text = String::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(MAX_CONFIG_BYTES + 1).read_to_string(&mut text))
            .map_err(|e| fail(e.to_string()))?;
        if text.len() as u64 > MAX_CONFIG_BYTES {
            return Err(fail(format!(
                "more than {} MiB; a configuration is at most that",
                MAX_CONFIG_BYTES >> 20
            )));
        }
        // A byte-order mark, which some editors write, is no JSON but harmless.
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let mut config = Self::from_json(text).map_err(|e| fail(e.to_string()))?;
        // A relative depth path is the file's, as a config travels with its depth maps.
        if let Some(depth) = &config.ground.depth
            && depth.is_relative()
            && let Some(dir) = path.parent()
        {
            config.ground.depth = Some(dir.join(depth));
        }
        Ok(config)
    }

    /// Parses a JSON configuration (any field may be left out; unknown keys are errors). A
    /// top-level `description` string, which presets carry for `config --list`, is not a
    /// setting and is skipped.
    pub fn from_json(text: &str) -> std::result::Result<RenderConfig, serde_json::Error> {
        // Read straight first, so that errors keep their line and column where no setting is
        // keyed.
        let straight = match serde_json::from_str(text) {
            Ok(config) => return Ok(config),
            Err(e) => e,
        };
        let tree: serde_json::Value = serde_json::from_str(text)?;
        let keyed =
            crate::keyframes::Keyframes::take(&mut tree.clone()).map_or(true, |k| !k.is_empty());
        RenderConfig::from_value(tree).map_err(|e| if keyed { e } else { straight })
    }

    /// [`RenderConfig::from_json`] of a parsed tree: keyed settings (`[[time_s, value], ...]`)
    /// are taken into [`RenderConfig::keyframes`].
    pub fn from_value(
        mut tree: serde_json::Value,
    ) -> std::result::Result<RenderConfig, serde_json::Error> {
        use serde::de::Error as _;
        if let Some(fields) = tree.as_object_mut()
            && fields.get("description").is_some_and(|d| d.is_string())
        {
            fields.remove("description");
        }
        let keyframes =
            crate::keyframes::Keyframes::take(&mut tree).map_err(serde_json::Error::custom)?;
        let mut config: RenderConfig = serde_json::from_value(tree)?;
        config.keyframes = keyframes;
        Ok(config)
    }

    /// The configuration as JSON, keyed settings as their keys: what `config --print` shows and
    /// [`RenderConfig::from_value`] reads back.
    pub fn to_value(&self) -> serde_json::Value {
        let mut tree = serde_json::to_value(self).unwrap_or_default();
        self.keyframes.put(&mut tree);
        tree
    }

    /// The configuration at `t_s`: every keyed setting at its value then.
    pub fn at(&self, t_s: f64) -> RenderConfig {
        let mut c = self.clone();
        c.apply_keys_at(&self.keyframes, t_s);
        c
    }
}

impl RenderConfig {
    /// Each setting that holds one value (not a switch or a list), by key, with the value as a
    /// user types it (`("rain.wind_mps", "3,-1")`); `light.highlight_gain` only when set (its
    /// default is the recovery's estimate) and `ground.depth` only when given. Of
    /// [`RenderConfig::default`], these are the defaults the command line's help shows for the
    /// flags of these keys, so each default is written once, in the `Default` impls.
    pub fn setting_values(&self) -> Vec<(&'static str, String)> {
        let (c, r, l, g) = (&self.camera, &self.rain, &self.light, &self.ground);
        vec![
            ("rain.rate_mm_per_h", r.rate_mm_per_h.to_string()),
            ("rain.drop_scale", r.drop_scale.to_string()),
            ("rain.fall_speed_scale", r.fall_speed_scale.to_string()),
            (
                "rain.wind_mps",
                format!("{},{}", r.wind_mps[0], r.wind_mps[1]),
            ),
            ("rain.opacity", r.opacity.to_string()),
            ("rain.seed", r.seed.to_string()),
            ("rain.streaks", r.streaks.name().to_string()),
            ("camera.fov_deg", c.fov_deg.to_string()),
            ("camera.height_m", c.height_m.to_string()),
            ("camera.tilt_deg", c.tilt_deg.to_string()),
            ("camera.roll_deg", c.roll_deg.to_string()),
            ("camera.pan_deg", c.pan_deg.to_string()),
            ("camera.shutter_deg", c.shutter_deg.to_string()),
            ("rain.near_m", r.near_m.to_string()),
            ("rain.far_m", r.far_m.to_string()),
            ("rain.max_drops", r.max_drops.to_string()),
            ("rain.gust_mps", r.gust_mps.to_string()),
            ("rain.altitude_m", r.altitude_m.to_string()),
            ("camera.focus_m", c.focus_m.to_string()),
            ("camera.f_number", c.f_number.to_string()),
            ("camera.sensor_width_mm", c.sensor_width_mm.to_string()),
            ("light.n_max", l.n_max.to_string()),
            ("light.smoothing_s", l.smoothing_s.to_string()),
            ("light.hdr_input", l.hdr_input.name().to_string()),
            ("rain.scene_depth_m", r.scene_depth_m.to_string()),
            ("ground.mode", g.mode.to_string()),
            ("camera_motion", self.camera_motion.to_string()),
            ("ground.pre_rain_min", g.pre_rain_min.to_string()),
            ("ground.depth_scale", g.depth_scale.to_string()),
            ("ground.sky", g.sky.name().to_string()),
            ("ground.mask", g.mask.name().to_string()),
            ("ground.relief_m", g.relief_m.to_string()),
            ("ground.relief_seed", g.relief_seed.to_string()),
            ("ground.puddle_particles", g.puddle_particles.to_string()),
        ]
        .into_iter()
        .chain(
            l.highlight_gain
                .map(|v| ("light.highlight_gain", v.to_string())),
        )
        .chain(
            g.depth
                .as_ref()
                .map(|d| ("ground.depth", d.display().to_string())),
        )
        .collect()
    }
}

impl RenderConfig {
    /// A pose file moves the camera as keys do: not beside pose keys (beside a ground, its
    /// turns and zoom are taken from the ground's pose: `pipeline::motion`).
    fn validate_motion(&self) -> Result<()> {
        use crate::scene::motion::MotionSource;
        let MotionSource::File(path) = &self.camera_motion else {
            return Ok(());
        };
        let bad = |expected: &str| Error::Parameter {
            name: "camera_motion",
            value: path.display().to_string(),
            expected: expected.to_string(),
        };
        if self.keyframes.pose().into_iter().any(Option::is_some) {
            return Err(bad(
                "no keyed camera pose or field of view besides a pose file: give one of them",
            ));
        }
        Ok(())
    }

    /// The ground's checks: a mode the render can use, with values in range.
    fn validate_ground(&self) -> Result<()> {
        self.ground.mode.validate()?;
        crate::scene::depth::check_scale(self.ground.depth_scale)?;
        check(
            "ground.relief_m",
            self.ground.relief_m,
            (0.0..=0.1).contains(&self.ground.relief_m),
            "metres in [0, 0.1] (a micro-relief of millimetres to centimetres)",
        )
    }

    /// A camera pose given once — by the ground or by `camera.tilt_deg`/`camera.roll_deg`, not
    /// both — and, beside a ground, a camera that turns and zooms but stays where it is (the
    /// settings as given, not at each key: a keyed tilt moves the ground's camera).
    fn validate_ground_pose(&self) -> Result<()> {
        use crate::scene::GroundMode;
        let mode = self.ground.mode;
        let bad = |expected: &str| Error::Parameter {
            name: "ground.mode",
            value: mode.to_string(),
            expected: expected.to_string(),
        };
        match mode {
            GroundMode::None => Ok(()),
            GroundMode::Auto | GroundMode::Horizon { .. } | GroundMode::Plane { .. } => {
                // A camera that turns and zooms about its centre keeps the ground where it is
                // in the world; one that rises or falls would move it (a translation).
                if self
                    .keyframes
                    .height_m
                    .as_ref()
                    .is_some_and(|k| !k.is_constant())
                {
                    return Err(bad(
                        "no keyed camera.height_m besides it: the ground follows a camera that \
                         turns and zooms, not one that moves (use ground.mode none)",
                    ));
                }
                let c = &self.camera;
                if c.tilt_deg != 0.0 || c.roll_deg != 0.0 {
                    return Err(bad(
                        "no camera.tilt_deg or camera.roll_deg besides it: ground.mode \
                         auto/horizon=/plane= sets the camera's tilt and roll",
                    ));
                }
                // The plane's distance is the height: another one would be ignored.
                if matches!(mode, GroundMode::Plane { .. })
                    && c.height_m != CameraConfig::default().height_m
                {
                    return Err(bad(
                        "no camera.height_m besides it: plane= sets the camera's height",
                    ));
                }
                Ok(())
            }
        }
    }

    /// The camera looking at a displayed picture of `width_px`×`height_px`: the camera settings,
    /// with the tilt and roll (and for `plane=`, the height) of a given ground, so the ground
    /// is the level world plane z = 0 the rain volume stands on.
    pub fn camera(&self, width_px: u32, height_px: u32) -> Result<crate::scene::Camera> {
        Ok(self
            .posed_camera(width_px, height_px)?
            .camera(width_px, height_px))
    }

    /// The camera settings with a given ground's tilt and roll (and for `plane=`, its height)
    /// written in, for a displayed picture of `width_px`×`height_px` (`horizon=` needs the
    /// focal length): the settings pose keys move a camera from, so a moving camera beside a
    /// ground starts at the ground's pose.
    pub fn posed_camera(&self, width_px: u32, height_px: u32) -> Result<CameraConfig> {
        let c = self.camera;
        let base = c.camera(width_px, height_px);
        Ok(match self.ground.mode.fixed_pose(&base, c.height_m)? {
            None => c,
            Some(pose) => CameraConfig {
                tilt_deg: pose.tilt_rad.to_degrees(),
                roll_deg: pose.roll_rad.to_degrees(),
                height_m: pose.height_m,
                ..c
            },
        })
    }
}

impl RenderConfig {
    /// Rejects values outside their physical or practical range, naming the setting's key; keyed
    /// settings are checked at every key.
    pub fn validate(&self) -> Result<()> {
        self.validate_at_keys()?;
        self.validate_values()?;
        self.validate_ground_pose()
    }

    /// Each key's value in range, the error naming the key's time; an aperture keyed to 0
    /// (pinhole) is refused, since blur between a pinhole and a lens is not an interpolation.
    fn validate_at_keys(&self) -> Result<()> {
        if let Some(k) = &self.keyframes.f_number
            && k.keys().iter().any(|&(_, n)| n == 0.0)
        {
            return Err(Error::Parameter {
                name: "camera.f_number",
                value: "a key of 0".into(),
                expected: "keys from 0.5 to 64 (a pinhole cannot be keyed)".into(),
            });
        }
        // The plain values once, each key's applied to a copy (a track keyed every frame
        // has thousands of keys).
        let plain = RenderConfig {
            keyframes: Default::default(),
            ..self.clone()
        };
        let checked: Vec<(f64, Result<()>)> = self
            .keyframes
            .times_s()
            .into_iter()
            .map(|t| {
                let mut at = plain.clone();
                at.apply_keys_at(&self.keyframes, t);
                (t, at.validate_values())
            })
            .collect();
        let same = |a: &Result<()>, b: &Result<()>| match (a, b) {
            (
                Err(Error::Parameter { name, value, .. }),
                Err(Error::Parameter {
                    name: n, value: v, ..
                }),
            ) => name == n && value == v,
            _ => false,
        };
        let Some(i) = checked.iter().position(|(_, r)| r.is_err()) else {
            return Ok(());
        };
        // The same error at every key is no key's: it is told without a key's time.
        let keyed = checked.iter().any(|(_, r)| !same(r, &checked[i].1));
        let (t, result) = checked.into_iter().nth(i).expect("found above");
        result.map_err(|e| match e {
            Error::Parameter {
                name,
                value,
                expected,
            } if keyed => Error::Parameter {
                name,
                value: format!("{value} (keyed, at {t} s)"),
                expected,
            },
            e => e,
        })
    }

    /// [`RenderConfig::validate`] of the values at t = 0.
    fn validate_values(&self) -> Result<()> {
        let c = &self.camera;
        let r = &self.rain;
        check(
            "camera.fov_deg",
            c.fov_deg,
            c.fov_deg > 1.0 && c.fov_deg < 170.0,
            "degrees in (1, 170)",
        )?;
        check(
            "camera.height_m",
            c.height_m,
            (0.0..=1000.0).contains(&c.height_m),
            "metres in [0, 1000]",
        )?;
        check(
            "camera.tilt_deg",
            c.tilt_deg,
            (-90.0..=90.0).contains(&c.tilt_deg),
            "degrees in [-90, 90]",
        )?;
        check(
            "camera.roll_deg",
            c.roll_deg,
            (-180.0..=180.0).contains(&c.roll_deg),
            "degrees in [-180, 180]",
        )?;
        check(
            "camera.pan_deg",
            c.pan_deg,
            (-360.0..=360.0).contains(&c.pan_deg),
            "degrees in [-360, 360]",
        )?;
        check(
            "camera.focus_m",
            c.focus_m,
            c.focus_m > 0.05,
            "metres, above 0.05",
        )?;
        check(
            "camera.f_number",
            c.f_number,
            c.f_number == 0.0 || (0.5..=64.0).contains(&c.f_number),
            "0 (pinhole) or 0.5 to 64",
        )?;
        check(
            "camera.sensor_width_mm",
            c.sensor_width_mm,
            c.sensor_width_mm > 1.0 && c.sensor_width_mm <= 100.0,
            "mm in (1, 100]",
        )?;
        check(
            "camera.shutter_deg",
            c.shutter_deg,
            c.shutter_deg > 0.0 && c.shutter_deg <= 360.0,
            "degrees in (0, 360]",
        )?;
        check(
            "rain.rate_mm_per_h",
            r.rate_mm_per_h,
            (0.0..=500.0).contains(&r.rate_mm_per_h),
            "mm/h in [0, 500]",
        )?;
        check(
            "rain.drop_scale",
            r.drop_scale,
            r.drop_scale > 0.0 && r.drop_scale <= 10.0,
            "a factor in (0, 10]",
        )?;
        check(
            "rain.fall_speed_scale",
            r.fall_speed_scale,
            r.fall_speed_scale > 0.0 && r.fall_speed_scale <= 10.0,
            "a factor in (0, 10]",
        )?;
        let wind_mps = r.wind_mps[0].hypot(r.wind_mps[1]);
        if !(wind_mps.is_finite() && wind_mps <= crate::rain::wind::MAX_WIND_MPS) {
            return Err(Error::Parameter {
                name: "rain.wind_mps",
                value: format!("{},{}", r.wind_mps[0], r.wind_mps[1]),
                expected: format!(
                    "a horizontal wind of at most {} m/s (the vector's length)",
                    crate::rain::wind::MAX_WIND_MPS
                ),
            });
        }
        check(
            "rain.gust_mps",
            r.gust_mps,
            (0.0..=60.0).contains(&r.gust_mps),
            "m/s in [0, 60]",
        )?;
        check(
            "rain.altitude_m",
            r.altitude_m,
            (-500.0..=9000.0).contains(&r.altitude_m),
            "metres in [-500, 9000]",
        )?;
        check(
            "rain.opacity",
            r.opacity,
            (0.0..=100.0).contains(&r.opacity),
            "a factor in [0, 100]",
        )?;
        check(
            "rain.near_m",
            r.near_m,
            r.near_m >= 0.05 && r.near_m < r.far_m,
            "metres, ≥ 0.05 and below rain.far_m",
        )?;
        check(
            "rain.far_m",
            r.far_m,
            r.far_m <= 10_000.0,
            "metres, at most 10000",
        )?;
        check(
            "rain.scene_depth_m",
            r.scene_depth_m,
            (0.0..=100_000.0).contains(&r.scene_depth_m),
            "metres in [0, 100000]",
        )?;
        check(
            "rain.max_drops",
            r.max_drops as f64,
            (1..=20_000_000).contains(&r.max_drops),
            "drops from 1 to 20000000 (for no rain, use rain.rate_mm_per_h 0)",
        )?;
        let l = &self.light;
        for n in l.refractive_index {
            check(
                "light.refractive_index",
                n,
                (1.0..=3.0).contains(&n),
                "an index in [1, 3]",
            )?;
        }
        check(
            "light.n_max",
            l.n_max as f64,
            (1..=64).contains(&l.n_max),
            "an order from 1 to 64",
        )?;
        check(
            "light.smoothing_s",
            l.smoothing_s,
            (0.0..=10.0).contains(&l.smoothing_s),
            "seconds in [0, 10]",
        )?;
        for light in &l.lights {
            light.validate()?;
        }
        self.validate_ground()?;
        self.validate_motion()?;
        check(
            "ground.pre_rain_min",
            self.ground.pre_rain_min,
            (0.0..=100_000.0).contains(&self.ground.pre_rain_min),
            "minutes in [0, 100000]",
        )?;
        check(
            "ground.puddle_particles",
            self.ground.puddle_particles as f64,
            (100..=2_000_000).contains(&self.ground.puddle_particles),
            "particles from 100 to 2000000",
        )?;
        if self.ground.puddles && !self.ground.is_given() {
            return Err(Error::Parameter {
                name: "ground.puddles",
                value: self.ground.mode.to_string(),
                expected: "a given ground (ground.mode horizon=… or plane=…): puddles lie on it"
                    .into(),
            });
        }
        if let Some(g) = l.highlight_gain {
            check(
                "light.highlight_gain",
                g,
                (1.0..=crate::lighting::recovery::MAX_GAIN).contains(&g),
                "a factor in [1, 1000000] on the clip level",
            )?;
        }
        Ok(())
    }
}

impl RenderConfig {
    /// Every setting `keys` keys set to its value at `t_s` (the configuration's own keys are
    /// left as they are).
    pub fn apply_keys_at(&mut self, keys: &crate::keyframes::Keyframes, t_s: f64) {
        let (r, c) = (&mut self.rain, &mut self.camera);
        if let Some(k) = &keys.rate_mm_per_h {
            r.rate_mm_per_h = k.at(t_s);
        }
        if let Some(k) = &keys.wind_mps {
            r.wind_mps = k.at(t_s).to_array();
        }
        if let Some(k) = &keys.opacity {
            r.opacity = k.at(t_s);
        }
        if let Some(k) = &keys.focus_m {
            c.focus_m = k.at(t_s);
        }
        if let Some(k) = &keys.f_number {
            c.f_number = k.at(t_s);
        }
        let pose = [
            &mut c.pan_deg,
            &mut c.tilt_deg,
            &mut c.roll_deg,
            &mut c.height_m,
            &mut c.fov_deg,
        ];
        for (v, k) in pose.into_iter().zip(keys.pose()) {
            if let Some(k) = k {
                *v = k.at(t_s);
            }
        }
    }
}
