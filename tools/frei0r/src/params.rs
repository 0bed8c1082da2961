//! The plug-in's parameters: what each is called, how a host's value maps to a setting of the
//! render (frei0r doubles live in [0, 1], and GStreamer offers no other range), and the render
//! configuration they make over a preset.
//!
//! The order is the order FFmpeg's `filter_params` takes them in (positional, `|`-separated),
//! so the most used come first. A parameter left at its default takes the preset's value, so
//! `preset=storm` alone gives the storm, and a host that sets every parameter to its default
//! (GStreamer does) changes nothing.

use std::ffi::{CStr, CString};

use rain_composite::config::{RenderConfig, StreakStyle};
use rain_composite::scene::GroundMode;
use rain_composite::{Error, Result};

use crate::abi::{PARAM_BOOL, PARAM_DOUBLE, PARAM_POSITION, PARAM_STRING};

/// One parameter as `f0r_get_param_info` describes it.
pub struct Spec {
    /// The name MLT addresses it by (GStreamer: lower case, `_` → `-`).
    pub name: &'static CStr,
    /// `F0R_PARAM_*`.
    pub kind: i32,
    /// The mapping, as the host shows it.
    pub explanation: &'static CStr,
}

/// Index of each parameter.
pub mod index {
    /// Rain rate.
    pub const RATE: usize = 0;
    /// Wind across the picture.
    pub const WIND: usize = 1;
    /// Opacity factor.
    pub const OPACITY: usize = 2;
    /// Seed.
    pub const SEED: usize = 3;
    /// Preset name or configuration file.
    pub const PRESET: usize = 4;
    /// Field of view.
    pub const FOV: usize = 5;
    /// Camera tilt.
    pub const TILT: usize = 6;
    /// The horizon's row.
    pub const HORIZON: usize = 7;
    /// Ground on or off.
    pub const GROUND: usize = 8;
    /// Streak style.
    pub const STREAKS: usize = 9;
    /// Time offset.
    pub const TIME_OFFSET: usize = 10;
    /// Time scale.
    pub const TIME_SCALE: usize = 11;
    /// Frame rate.
    pub const FRAME_RATE: usize = 12;
}

/// Every parameter, in `filter_params` order.
pub const SPECS: [Spec; 13] = [
    Spec {
        name: c"rain_rate",
        kind: PARAM_DOUBLE,
        explanation: c"Rain rate: 100*v mm/h (0.1 = 10 mm/h moderate, 0.5 = 50 mm/h heavy). Default 0.1: the preset's",
    },
    Spec {
        name: c"wind",
        kind: PARAM_DOUBLE,
        explanation: c"Wind across the picture: 40*(v-0.5) m/s, to the right above 0.5. Default 0.5: the preset's",
    },
    Spec {
        name: c"opacity",
        kind: PARAM_DOUBLE,
        explanation: c"Factor on the streaks' physical opacity: 2*v (0.5 = physical). Default 0.5: the preset's",
    },
    Spec {
        name: c"seed",
        kind: PARAM_DOUBLE,
        explanation: c"Seed of the rain: 1 + round(1000000*v); the same seed gives the same rain. Default 0: the preset's",
    },
    Spec {
        name: c"preset",
        kind: PARAM_STRING,
        explanation: c"A shipped preset (default, drizzle, steady, storm, downpour, windy-storm, city, backlit, night-street, passing-shower) or the path of a JSON configuration; the parameters left at their defaults take its values",
    },
    Spec {
        name: c"fov",
        kind: PARAM_DOUBLE,
        explanation: c"Horizontal field of view: 120*v degrees (0.5 = 60). Default 0.5: the preset's",
    },
    Spec {
        name: c"tilt",
        kind: PARAM_DOUBLE,
        explanation: c"Camera pitch: 180*(v-0.5) degrees, up above 0.5. Ignored with the ground on. Default 0.5: the preset's",
    },
    Spec {
        name: c"horizon",
        kind: PARAM_POSITION,
        explanation: c"With the ground on: y is the horizon's row, from 0 (top) to 1 (bottom); it sets the camera's tilt. x is not used",
    },
    Spec {
        name: c"ground",
        kind: PARAM_BOOL,
        explanation: c"A level ground below the horizon: streaks end on it, drops splash, it wets. Default off: the preset's",
    },
    Spec {
        name: c"streaks",
        kind: PARAM_STRING,
        explanation: c"Streak style: simple (smooth capsules) or mattes (each drop's oscillating matte; needs the streak database). Default simple: the preset's",
    },
    Spec {
        name: c"time_offset",
        kind: PARAM_DOUBLE,
        explanation: c"Seconds added to the host's time: 3600*v (0.001 = 3.6 s). Default 0",
    },
    Spec {
        name: c"time_scale",
        kind: PARAM_DOUBLE,
        explanation: c"Shot seconds per host second: 1000^(2v-1) (0.5 = 1, 0.25 = 1/31.6, 0 = 1/1000 for a host counting milliseconds; FFmpeg's milliseconds are recognised). Default 0.5",
    },
    Spec {
        name: c"frame_rate",
        kind: PARAM_DOUBLE,
        explanation: c"The footage's frame rate, which sets the exposure (streak length): 100*v fps (0.25 = 25, 0.2997 = 29.97). Default 0.25",
    },
];

/// The parameters' current values, as the host set them.
#[derive(Debug, Clone, PartialEq)]
pub struct Params {
    /// Every `double` and `bool` parameter, by index (unused for the others).
    pub numbers: [f64; SPECS.len()],
    /// The horizon's position.
    pub horizon: [f64; 2],
    /// The preset's name or file.
    pub preset: CString,
    /// The streak style's name.
    pub streaks: CString,
}

impl Default for Params {
    fn default() -> Params {
        let mut numbers = [0.0; SPECS.len()];
        numbers[index::RATE] = 0.1;
        numbers[index::WIND] = 0.5;
        numbers[index::OPACITY] = 0.5;
        numbers[index::SEED] = 0.0;
        numbers[index::FOV] = 0.5;
        numbers[index::TILT] = 0.5;
        numbers[index::GROUND] = 0.0;
        numbers[index::TIME_OFFSET] = 0.0;
        numbers[index::TIME_SCALE] = 0.5;
        numbers[index::FRAME_RATE] = 0.25;
        Params {
            numbers,
            horizon: [0.5, 0.5],
            preset: c"default".to_owned(),
            streaks: c"simple".to_owned(),
        }
    }
}

/// Longest time offset, seconds (v = 1).
pub const MAX_OFFSET_S: f64 = 3600.0;

impl Params {
    /// Whether parameter `i` differs from its default (so it overrides the preset).
    fn set(&self, i: usize) -> bool {
        self.numbers[i] != Params::default().numbers[i]
    }

    /// The frame rate the exposure is computed for.
    pub fn fps(&self) -> f64 {
        100.0 * self.numbers[index::FRAME_RATE]
    }

    /// Shot seconds per second of the host's clock.
    pub fn time_scale(&self) -> f64 {
        1000f64.powf(2.0 * self.numbers[index::TIME_SCALE] - 1.0)
    }

    /// Seconds added to the host's time (after the scale).
    pub fn time_offset_s(&self) -> f64 {
        MAX_OFFSET_S * self.numbers[index::TIME_OFFSET]
    }

    /// The render configuration: the preset, the parameters that differ from their defaults
    /// over it, the light estimated afresh for every frame (hosts render frames in any order
    /// and on several instances at once, so no frame may depend on the ones before it).
    /// Refuses what a host's frames cannot give: puddles (the water is simulated from the
    /// clip's first frame on), a ground estimated from the clip, a depth sequence.
    pub fn config(&self) -> Result<RenderConfig> {
        let name = text(&self.preset, "preset")?;
        let mut c = rain_composite::preset::load(if name.is_empty() { "default" } else { name })?;
        let n = &self.numbers;
        let k = &mut c.keyframes;
        if self.set(index::RATE) {
            c.rain.rate_mm_per_h = 100.0 * n[index::RATE];
            k.rate_mm_per_h = None;
        }
        if self.set(index::WIND) {
            c.rain.wind_mps[0] = 40.0 * (n[index::WIND] - 0.5);
            k.wind_mps = None;
        }
        if self.set(index::OPACITY) {
            c.rain.opacity = 2.0 * n[index::OPACITY];
            k.opacity = None;
        }
        if self.set(index::SEED) {
            let seed = (1.0 + (1e6 * n[index::SEED]).round()).clamp(1.0, f64::from(u32::MAX));
            c.rain.seed = seed as u32;
        }
        if self.set(index::FOV) {
            c.camera.fov_deg = 120.0 * n[index::FOV];
            k.fov_deg = None;
        }
        if self.set(index::TILT) {
            c.camera.tilt_deg = 180.0 * (n[index::TILT] - 0.5);
            k.tilt_deg = None;
        }
        if n[index::GROUND] >= 0.5 {
            c.ground.mode = GroundMode::Horizon {
                row: self.horizon[1],
                roll_deg: 0.0,
            };
            // The horizon sets the pose.
            c.camera.tilt_deg = 0.0;
            c.camera.roll_deg = 0.0;
            k.tilt_deg = None;
            k.roll_deg = None;
        }
        let streaks = text(&self.streaks, "streaks")?;
        match streaks {
            "simple" | "" => {}
            "mattes" => c.rain.streaks = StreakStyle::Mattes,
            other => {
                return Err(Error::Parameter {
                    name: "streaks",
                    value: other.to_string(),
                    expected: "simple or mattes".into(),
                });
            }
        }
        c.light.smoothing_s = 0.0;
        refuse_what_needs_the_clip(&c)?;
        c.validate()?;
        Ok(c)
    }
}

/// A string parameter as UTF-8.
fn text<'a>(s: &'a CString, name: &'static str) -> Result<&'a str> {
    s.to_str().map_err(|_| Error::Parameter {
        name,
        value: s.to_string_lossy().into_owned(),
        expected: "UTF-8 text".into(),
    })
}

/// The settings whose state runs through the whole clip, which a host's frames (any order,
/// several instances) cannot carry.
fn refuse_what_needs_the_clip(c: &RenderConfig) -> Result<()> {
    if c.ground.puddles {
        return Err(Error::Unsupported(
            "puddles in the frei0r plug-in: the water is simulated from the clip's first frame \
             on, and an editor hands over frames in any order; render puddles with \
             `rain-composite --puddles`, or turn ground.puddles off in the configuration"
                .into(),
        ));
    }
    if c.ground.mode == GroundMode::Auto {
        return Err(Error::Unsupported(
            "ground.mode auto in the frei0r plug-in: the ground is estimated from the clip; \
             turn the ground parameter on and place the horizon instead"
                .into(),
        ));
    }
    if let Some(depth) = &c.ground.depth
        && !depth
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        return Err(Error::Unsupported(format!(
            "the depth '{}' in the frei0r plug-in: only one PNG depth map for every frame \
             (the plug-in is not told which frame of a sequence it is given)",
            depth.display()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_library_defaults_with_the_light_per_frame() {
        let c = Params::default().config().unwrap();
        let mut want = RenderConfig::default();
        want.light.smoothing_s = 0.0;
        assert_eq!(c, want);
        assert_eq!(Params::default().fps(), 25.0);
        assert_eq!(Params::default().time_scale(), 1.0);
        assert_eq!(Params::default().time_offset_s(), 0.0);
    }

    #[test]
    fn parameters_left_at_their_defaults_keep_the_preset() {
        let mut p = Params {
            preset: c"storm".to_owned(),
            ..Params::default()
        };
        let storm = rain_composite::preset::load("storm").unwrap();
        assert_eq!(p.config().unwrap().rain, storm.rain);
        p.numbers[index::RATE] = 0.3;
        p.numbers[index::WIND] = 0.6;
        let c = p.config().unwrap();
        assert_eq!(c.rain.rate_mm_per_h, 30.0);
        assert!((c.rain.wind_mps[0] - 4.0).abs() < 1e-12);
        assert_eq!(c.rain.seed, storm.rain.seed);
    }

    #[test]
    fn each_mapping_reaches_its_setting() {
        let mut p = Params::default();
        p.numbers[index::OPACITY] = 1.0;
        p.numbers[index::SEED] = 0.000_041;
        p.numbers[index::FOV] = 0.75;
        p.numbers[index::TILT] = 0.625;
        p.streaks = c"mattes".to_owned();
        // The streak database may be missing where the test runs; the mapping is what counts.
        let c = match p.config() {
            Ok(c) => c,
            Err(e) => {
                assert!(e.to_string().contains("streak"), "{e}");
                p.streaks = c"simple".to_owned();
                p.config().unwrap()
            }
        };
        assert_eq!(c.rain.opacity, 2.0);
        assert_eq!(c.rain.seed, 42);
        assert_eq!(c.camera.fov_deg, 90.0);
        assert_eq!(c.camera.tilt_deg, 22.5);
        p.numbers[index::GROUND] = 1.0;
        p.horizon = [0.0, 0.4];
        let c = p.config().unwrap();
        assert_eq!(
            c.ground.mode,
            GroundMode::Horizon {
                row: 0.4,
                roll_deg: 0.0
            }
        );
        assert_eq!(c.camera.tilt_deg, 0.0);
        p.numbers[index::TIME_SCALE] = 0.0;
        p.numbers[index::TIME_OFFSET] = 0.5;
        p.numbers[index::FRAME_RATE] = 0.3;
        assert!((p.time_scale() - 0.001).abs() < 1e-15);
        assert_eq!(p.time_offset_s(), 1800.0);
        assert!((p.fps() - 30.0).abs() < 1e-12);
    }

    #[test]
    fn what_needs_the_whole_clip_is_refused_by_name() {
        let dir = std::env::temp_dir().join(format!("frei0r-params-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("puddles.json");
        std::fs::write(
            &file,
            r#"{"ground": {"mode": "horizon=0.5", "puddles": true}}"#,
        )
        .unwrap();
        let p = Params {
            preset: CString::new(file.to_str().unwrap()).unwrap(),
            ..Params::default()
        };
        let e = p.config().unwrap_err().to_string();
        assert!(e.contains("puddles"), "{e}");
        let p = Params {
            preset: c"no-such-preset".to_owned(),
            ..Params::default()
        };
        assert!(p.config().is_err());
        let p = Params {
            streaks: c"wavy".to_owned(),
            ..Params::default()
        };
        assert!(
            p.config()
                .unwrap_err()
                .to_string()
                .contains("simple or mattes")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
