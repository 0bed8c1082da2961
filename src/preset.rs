//! Named presets and `--set` overrides: the layers a render configuration is built from.
//!
//! Precedence, lowest first: the built-in defaults, the `--config` preset or file (its fields
//! replace the defaults'), each `--set key.path=value` in order, then the CLI's explicit flags.
//! Overrides act on the JSON tree of the fully written-out configuration, so a key that is not
//! a field of [`RenderConfig`] is refused before anything is deserialised, and a value of the
//! wrong type is refused by the same deserialiser that reads a file.

use serde_json::Value;

use crate::config::RenderConfig;
use crate::{Error, Result};

/// A configuration shipped with the program; `samples/presets/NAME.json` is the source,
/// embedded at build time so an installed binary has every preset.
#[derive(Debug, Clone, Copy)]
pub struct Preset {
    /// What `--config NAME` calls it.
    pub name: &'static str,
    /// The file's text: [`RenderConfig`] fields plus a one-line `description`.
    pub json: &'static str,
}

macro_rules! preset {
    ($name:literal) => {
        Preset {
            name: $name,
            json: include_str!(concat!("../samples/presets/", $name, ".json")),
        }
    };
}

/// Every shipped preset, by name.
pub const PRESETS: &[Preset] = &[
    preset!("backlit"),
    preset!("city"),
    preset!("default"),
    preset!("downpour"),
    preset!("drizzle"),
    preset!("night-street"),
    preset!("passing-shower"),
    preset!("steady"),
    preset!("storm"),
    preset!("windy-storm"),
];

impl Preset {
    /// The preset called `name`, if one is shipped.
    pub fn named(name: &str) -> Option<Preset> {
        PRESETS.iter().copied().find(|p| p.name == name)
    }

    /// Its one-line `description` (empty when the file has none).
    pub fn description(&self) -> String {
        serde_json::from_str::<Value>(self.json)
            .ok()
            .and_then(|v| v.get("description")?.as_str().map(str::to_string))
            .unwrap_or_default()
    }

    /// Its configuration.
    pub fn config(&self) -> Result<RenderConfig> {
        RenderConfig::from_json(self.json).map_err(|e| Error::Config {
            path: self.name.to_string(),
            reason: e.to_string(),
        })
    }
}

/// The configuration `--config ARG` names: a shipped preset when `ARG` is a bare name (no `/`,
/// no `.`), otherwise a JSON file. A bare name that is not a preset is an error listing them,
/// so a typo never silently reads a stray file of that name.
pub fn load(arg: &str) -> Result<RenderConfig> {
    if arg.contains(['/', '.']) {
        return RenderConfig::from_json_file(std::path::Path::new(arg));
    }
    match Preset::named(arg) {
        Some(p) => p.config(),
        None => Err(Error::Config {
            path: arg.to_string(),
            reason: format!(
                "no such preset; the presets are {} (a file needs a path with / or .json)",
                PRESETS
                    .iter()
                    .map(|p| p.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }),
    }
}

/// `config` with each `key.path=value` of `sets` applied in order. The value is JSON
/// (`3`, `[1.5,0]`, `null`), or else a string (`ground.mode=horizon=0.45`); array elements are
/// addressed by index (`light.lights.0.radiance_rgb`). Ranges are left to
/// [`RenderConfig::validate`] (see [`validate_layered`]).
pub fn with_overrides(config: &RenderConfig, sets: &[String]) -> Result<RenderConfig> {
    let mut tree = config.to_value();
    for set in sets {
        apply(&mut tree, set)?;
        // Deserialising after each one names the override whose value has the wrong type (the
        // reader's own message says which: "invalid type", "invalid value", a key's error).
        RenderConfig::deserialize_value(tree.clone()).map_err(|e| bad_set(set, e.to_string()))?;
    }
    RenderConfig::deserialize_value(tree).map_err(|e| bad_set("", e.to_string()))
}

fn bad_set(set: &str, reason: String) -> Error {
    Error::Override {
        assignment: set.to_string(),
        reason,
    }
}

/// Sets the value at `key.path` of `tree`; the key must exist.
fn apply(tree: &mut Value, set: &str) -> Result<()> {
    let Some((path, text)) = set.split_once('=') else {
        return Err(bad_set(set, "expected key.path=value".into()));
    };
    let value = match serde_json::from_str(text) {
        Ok(v) => v,
        // A number JSON cannot hold (1e999) is not a string.
        Err(_) if text.trim().parse::<f64>().is_ok_and(|v| !v.is_nan()) => {
            return Err(bad_set(set, format!("{text} is not a finite number")));
        }
        Err(_) => Value::String(text.to_string()),
    };
    let mut node = tree;
    let mut at = String::new();
    for key in path.split('.') {
        let within = if at.is_empty() {
            "the configuration"
        } else {
            &at
        };
        node = match node {
            Value::Object(fields) => {
                let known: Vec<String> = fields.keys().cloned().collect();
                fields.get_mut(key).ok_or_else(|| {
                    bad_set(
                        set,
                        format!("{within} has no key '{key}'; it has {}", known.join(", ")),
                    )
                })?
            }
            Value::Array(items) => {
                let len = items.len();
                key.parse::<usize>()
                    .ok()
                    .and_then(|i| items.get_mut(i))
                    .ok_or_else(|| {
                        bad_set(
                            set,
                            format!(
                                "{within} is a list of {len}: '{key}' is not an index below {len}"
                            ),
                        )
                    })?
            }
            _ => {
                return Err(bad_set(
                    set,
                    format!("{within} is a single value, it has no key '{key}'"),
                ));
            }
        };
        at = if at.is_empty() {
            key.to_string()
        } else {
            format!("{at}.{key}")
        };
    }
    *node = value;
    Ok(())
}

/// [`RenderConfig::validate`] of a configuration built with the overrides `sets`: when a value
/// is out of range and building without one override (`without(i)`) clears that error, the
/// error is that override's ([`Error::OverrideRange`]), with the allowed range, since the
/// setting the range is written for may not have been given any other way.
pub fn validate_layered(
    config: &RenderConfig,
    sets: &[String],
    without: impl Fn(usize) -> Option<RenderConfig>,
) -> Result<()> {
    let Err(error) = config.validate() else {
        return Ok(());
    };
    let Error::Parameter {
        name,
        value,
        expected,
    } = &error
    else {
        return Err(error);
    };
    let clears = |c: RenderConfig| match c.validate() {
        Ok(()) => true,
        Err(Error::Parameter { name: n, .. }) => n != *name,
        Err(_) => true,
    };
    match (0..sets.len())
        .rev()
        .find(|&i| without(i).is_some_and(clears))
    {
        Some(i) => {
            // The override's own value out of range, or a value it conflicts with.
            let given = sets[i].split_once('=').map_or("", |(_, v)| v.trim());
            let own = given == value
                || value.contains("(keyed, at ")
                || matches!((given.parse::<f64>(), value.parse::<f64>()), (Ok(a), Ok(b)) if a == b);
            Err(Error::OverrideRange {
                assignment: sets[i].clone(),
                name,
                value: value.clone(),
                expected: expected.clone(),
                own,
            })
        }
        None => Err(error),
    }
}

impl RenderConfig {
    fn deserialize_value(tree: Value) -> std::result::Result<RenderConfig, serde_json::Error> {
        RenderConfig::from_value(tree)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sets(s: &[&str]) -> Vec<String> {
        s.iter().map(|s| s.to_string()).collect()
    }

    /// An override changes exactly the value it names, of any type.
    #[test]
    fn an_override_sets_the_value_it_names() {
        let base = RenderConfig::default();
        let c = with_overrides(
            &base,
            &sets(&[
                "rain.rate_mm_per_h=25",
                "rain.wind_mps=[3,-1]",
                "ground.mode=horizon=0.45",
                "light.highlight_gain=4",
                "rain.seed=7",
            ]),
        )
        .expect("valid");
        let mut expected = base.clone();
        expected.rain.rate_mm_per_h = 25.0;
        expected.rain.wind_mps = [3.0, -1.0];
        expected.ground.mode = "horizon=0.45".parse().expect("mode");
        expected.light.highlight_gain = Some(4.0);
        expected.rain.seed = 7;
        assert_eq!(c, expected);
        // Later overrides win; list elements are addressed by index.
        let mut lit = base.clone();
        lit.light.lights.push(crate::lighting::UserLight::default());
        let c = with_overrides(
            &lit,
            &sets(&[
                "rain.seed=2",
                "rain.seed=3",
                "light.lights.0.radiance_rgb=[5,5,5]",
            ]),
        )
        .expect("valid");
        assert_eq!(c.rain.seed, 3);
        assert_eq!(c.light.lights[0].radiance_rgb, [5.0; 3]);
    }

    /// Unknown keys and wrong types are refused with a message naming the override and why.
    #[test]
    fn bad_overrides_name_the_key() {
        let base = RenderConfig::default();
        for (set, says) in [
            ("rain.rate=5", "no key 'rate'"),
            ("rain.rate_mm_per_h.x=5", "single value"),
            ("weather.rate_mm_per_h=5", "no key 'weather'"),
            ("light.lights.0.azimuth_deg=5", "not an index"),
            ("rain.rate_mm_per_h=heavy", "invalid type"),
            ("rain.seed=-1", "invalid value"),
            ("rain.wind_mps=3", "invalid type"),
            ("rain.rate_mm_per_h=1e999", "not a finite number"),
            ("rain.rate_mm_per_h", "key.path=value"),
        ] {
            let e = with_overrides(&base, &sets(&[set]))
                .expect_err(set)
                .to_string();
            assert!(e.contains(set) && e.contains(says), "{set}: {e}");
        }
    }

    /// An out-of-range override is blamed by name with the range, even among valid ones; an
    /// error no override causes is left as it is.
    #[test]
    fn out_of_range_overrides_are_named_with_the_range() {
        let base = RenderConfig::default();
        let all = sets(&["rain.seed=4", "rain.rate_mm_per_h=900", "camera.fov_deg=40"]);
        let build = |skip: Option<usize>| {
            let kept: Vec<String> = (0..all.len())
                .filter(|&i| Some(i) != skip)
                .map(|i| all[i].clone())
                .collect();
            with_overrides(&base, &kept).ok()
        };
        let c = build(None).expect("types are right");
        let e = validate_layered(&c, &all, |i| build(Some(i)))
            .expect_err("out of range")
            .to_string();
        assert!(
            e.contains("rain.rate_mm_per_h=900") && e.contains("[0, 500]"),
            "{e}"
        );
        let mut bad = c.clone();
        bad.rain.rate_mm_per_h = 10.0;
        bad.camera.fov_deg = 200.0;
        let e = validate_layered(&bad, &all, |_| Some(bad.clone()))
            .expect_err("fov")
            .to_string();
        assert!(
            e.contains("camera.fov_deg") && !e.contains("override"),
            "{e}"
        );
    }

    /// Every preset parses, validates, and says in one line what it is.
    #[test]
    fn every_preset_is_valid_and_described() {
        for p in PRESETS {
            let c = p.config().unwrap_or_else(|e| panic!("{}: {e}", p.name));
            c.validate().unwrap_or_else(|e| panic!("{}: {e}", p.name));
            let d = p.description();
            assert!(
                p.name == "default" || (!d.is_empty() && !d.contains('\n')),
                "{}: {d:?}",
                p.name
            );
            assert_eq!(load(p.name).expect("by name"), c);
        }
        let e = load("drizzel").expect_err("typo").to_string();
        assert!(e.contains("drizzle") && e.contains("windy-storm"), "{e}");
    }
}
