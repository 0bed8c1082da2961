//! Settings that change over a shot: a number of the configuration written as a list of
//! `[time_s, value]` keys (`"rate_mm_per_h": [[0, 0], [4, 30]]`), linear between keys and held
//! outside them.
//!
//! Only settings the stateless rain can follow without a drop changing mid-air are keyed:
//! - `rain.rate_mm_per_h`: whether a drop falls is decided once per pass through its column, at
//!   its birth above the view (`rain::volume::drop`, "Changing rain"), so rain starts and
//!   stops from the top of the frame and no drop pops in or out mid-air;
//! - `rain.wind_mps`: the drops follow the changing wind with their own lag τ = v_t/g, in
//!   closed form (`rain::wind::MeanWind`);
//! - `rain.opacity`, `camera.focus_m`, `camera.f_number`: per frame (a focus pull);
//! - the camera's pose and zoom, `camera.pan_deg`, `tilt_deg`, `roll_deg`, `height_m`,
//!   `fov_deg` (a pan, a tilt, a crane, a zoom): the rain stays in the world while the camera
//!   moves; the volume is planned for the envelope of the frusta over the shot
//!   (`rain::volume`, "A moving camera") and each frame sees it through its own camera.
//!
//! The others are refused with the reason: a drop's size and speed are fixed for its life
//! (`drop_scale`, `fall_speed_scale`, `altitude_m`), the exposure sets the streaks' length the
//! far distance is planned with (`shutter_deg`), the near and far distances are planned once,
//! and the gusts' strength is part of their closed-form spectrum (key `rain.wind_mps` for a
//! gust building up).

use glam::DVec2;
use serde_json::Value;

/// Most keys per setting (the rate's and the wind's keys travel in a GPU uniform).
pub const MAX_KEYS: usize = 16;

/// A value a key can hold.
pub trait KeyValue: Copy + PartialEq + std::fmt::Debug {
    /// `a + (b − a)·s`.
    fn lerp(a: Self, b: Self, s: f64) -> Self;
    /// The value of a JSON key, if it has this type.
    fn from_json(v: &Value) -> Option<Self>;
    /// The value as JSON.
    fn to_json(self) -> Value;
    /// Whether every component is finite.
    fn is_finite(self) -> bool;
}

impl KeyValue for f64 {
    fn lerp(a: f64, b: f64, s: f64) -> f64 {
        a + (b - a) * s
    }
    fn from_json(v: &Value) -> Option<f64> {
        v.as_f64()
    }
    fn to_json(self) -> Value {
        serde_json::json!(self)
    }
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
}

impl KeyValue for DVec2 {
    fn lerp(a: DVec2, b: DVec2, s: f64) -> DVec2 {
        a + (b - a) * s
    }
    fn from_json(v: &Value) -> Option<DVec2> {
        match v.as_array()?.as_slice() {
            [x, y] => Some(DVec2::new(x.as_f64()?, y.as_f64()?)),
            _ => None,
        }
    }
    fn to_json(self) -> Value {
        serde_json::json!([self.x, self.y])
    }
    fn is_finite(self) -> bool {
        DVec2::is_finite(self)
    }
}

/// A keyed setting: `[time_s, value]` keys, strictly increasing in time from t ≥ 0.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve<V> {
    keys: Vec<(f64, V)>,
}

impl<V: KeyValue> Curve<V> {
    /// A curve from its keys, at most `MAX_KEYS` of them, checked as [`Curve::track`] checks
    /// them; the error says what is wrong with them.
    pub fn new(keys: Vec<(f64, V)>) -> Result<Curve<V>, String> {
        if keys.is_empty() || keys.len() > MAX_KEYS {
            return Err(format!("from 1 to {MAX_KEYS} keys, got {}", keys.len()));
        }
        Curve::track(keys)
    }

    /// A measured track (one key per frame, as the camera's motion estimated from a clip):
    /// [`Curve::new`]'s checks without its count limit, for curves read only on the CPU.
    pub fn track(keys: Vec<(f64, V)>) -> Result<Curve<V>, String> {
        if keys.is_empty() {
            return Err("at least one key".into());
        }
        if let Some((t, v)) = keys
            .iter()
            .find(|(t, v)| !(t.is_finite() && *t >= 0.0 && v.is_finite()))
        {
            return Err(format!(
                "the key [{t}, {v:?}]: times are seconds ≥ 0 and values finite"
            ));
        }
        if let Some(w) = keys.windows(2).find(|w| w[1].0 <= w[0].0) {
            return Err(format!(
                "times in increasing order ({} s then {} s)",
                w[0].0, w[1].0
            ));
        }
        Ok(Curve { keys })
    }

    /// The same value at every time.
    pub fn constant(value: V) -> Curve<V> {
        Curve {
            keys: vec![(0.0, value)],
        }
    }

    /// The keys, in time order.
    pub fn keys(&self) -> &[(f64, V)] {
        &self.keys
    }

    /// Whether the value never changes.
    pub fn is_constant(&self) -> bool {
        self.keys.windows(2).all(|w| w[0].1 == w[1].1)
    }

    /// The value at `t_s`: linear between keys, held before the first and after the last.
    pub fn at(&self, t_s: f64) -> V {
        let i = self.keys.partition_point(|&(t, _)| t <= t_s);
        match (i, self.keys.get(i)) {
            (0, _) => self.keys[0].1,
            (_, None) => self.keys[i - 1].1,
            (_, Some(&(t1, v1))) => {
                let (t0, v0) = self.keys[i - 1];
                V::lerp(v0, v1, (t_s - t0) / (t1 - t0))
            }
        }
    }

    /// The keys as JSON.
    fn to_json(&self) -> Value {
        Value::Array(
            self.keys
                .iter()
                .map(|&(t, v)| serde_json::json!([t, v.to_json()]))
                .collect(),
        )
    }

    /// Keys from JSON: a list of `[time_s, value]`.
    fn from_json(v: &Value) -> Result<Curve<V>, String> {
        let keys = v
            .as_array()
            .ok_or("a list of [time_s, value] keys")?
            .iter()
            .map(|k| match k.as_array().map(Vec::as_slice) {
                Some([t, v]) => Some((t.as_f64()?, V::from_json(v)?)),
                _ => None,
            })
            .collect::<Option<Vec<_>>>()
            .ok_or("a list of [time_s, value] keys")?;
        Curve::new(keys)
    }
}

impl Curve<f64> {
    /// The largest value.
    pub fn max(&self) -> f64 {
        self.keys
            .iter()
            .map(|k| k.1)
            .fold(f64::NEG_INFINITY, f64::max)
    }
}

impl Curve<DVec2> {
    /// The slope at `t_s` (right-hand at a key; 0 outside the keys).
    pub fn slope_at(&self, t_s: f64) -> DVec2 {
        let i = self.keys.partition_point(|&(t, _)| t <= t_s);
        match (i, self.keys.get(i)) {
            (0, _) | (_, None) => DVec2::ZERO,
            (_, Some(&(t1, v1))) => {
                let (t0, v0) = self.keys[i - 1];
                (v1 - v0) / (t1 - t0)
            }
        }
    }

    /// ∫₀ᵗ of the curve (exact: piecewise quadratic).
    pub fn integral(&self, t_s: f64) -> DVec2 {
        let t_s = t_s.max(0.0);
        let first = self.keys[0];
        let mut sum = first.1 * t_s.min(first.0);
        for w in self.keys.windows(2) {
            let (t0, t1) = (w[0].0, w[1].0.min(t_s));
            if t1 <= t0 {
                break;
            }
            sum += (w[0].1 + self.at(t1)) * (0.5 * (t1 - t0));
        }
        let (t_last, v_last) = self.keys[self.keys.len() - 1];
        sum + v_last * (t_s - t_last).max(0.0)
    }

    /// The slope's changes: `(time_s, new slope − old slope)` at each key where it changes
    /// (the curve is flat before its first key and after its last).
    pub fn kinks(&self) -> Vec<(f64, DVec2)> {
        let k = &self.keys;
        let slope = |i: usize| -> DVec2 {
            match (i.checked_sub(1).map(|j| k[j]), k.get(i)) {
                (Some((t0, v0)), Some(&(t1, v1))) => (v1 - v0) / (t1 - t0),
                _ => DVec2::ZERO,
            }
        };
        (0..k.len())
            .map(|i| (k[i].0, slope(i + 1) - slope(i)))
            .filter(|&(_, d)| d != DVec2::ZERO)
            .collect()
    }
}

/// The keyed settings of a configuration (`None`: constant, as its plain value says).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Keyframes {
    /// `rain.rate_mm_per_h`.
    pub rate_mm_per_h: Option<Curve<f64>>,
    /// `rain.wind_mps`.
    pub wind_mps: Option<Curve<DVec2>>,
    /// `rain.opacity`.
    pub opacity: Option<Curve<f64>>,
    /// `camera.focus_m`.
    pub focus_m: Option<Curve<f64>>,
    /// `camera.f_number`.
    pub f_number: Option<Curve<f64>>,
    /// `camera.pan_deg`.
    pub pan_deg: Option<Curve<f64>>,
    /// `camera.tilt_deg`.
    pub tilt_deg: Option<Curve<f64>>,
    /// `camera.roll_deg`.
    pub roll_deg: Option<Curve<f64>>,
    /// `camera.height_m`.
    pub height_m: Option<Curve<f64>>,
    /// `camera.fov_deg`.
    pub fov_deg: Option<Curve<f64>>,
}

/// The settings that may be keyed, as `section.field`.
pub const KEYED: [&str; 10] = [
    "rain.rate_mm_per_h",
    "rain.wind_mps",
    "rain.opacity",
    "camera.focus_m",
    "camera.f_number",
    "camera.pan_deg",
    "camera.tilt_deg",
    "camera.roll_deg",
    "camera.height_m",
    "camera.fov_deg",
];

/// The keyed camera settings that move the camera (pose and zoom).
const POSE: [&str; 5] = [
    "camera.pan_deg",
    "camera.tilt_deg",
    "camera.roll_deg",
    "camera.height_m",
    "camera.fov_deg",
];

/// Why a numeric setting cannot be keyed.
fn refusal(path: &str) -> &'static str {
    match path {
        "rain.drop_scale" | "rain.fall_speed_scale" | "rain.altitude_m" => {
            "a drop keeps its size and fall speed for its whole fall"
        }
        "rain.gust_mps" => {
            "the gusts' strength is fixed by their spectrum; key rain.wind_mps for a gust \
             building up"
        }
        "rain.seed" | "rain.max_drops" => "it fixes which drops exist",
        "camera.shutter_deg" => {
            "the exposure sets how long the streaks are, and the far distance is planned with it"
        }
        _ => "the rain volume is planned once per shot",
    }
}

impl Keyframes {
    /// Whether nothing is keyed.
    pub fn is_empty(&self) -> bool {
        *self == Keyframes::default()
    }

    /// Every key time of every keyed setting, sorted, without repeats.
    pub fn times_s(&self) -> Vec<f64> {
        let mut times: Vec<f64> = [
            &self.rate_mm_per_h,
            &self.opacity,
            &self.focus_m,
            &self.f_number,
        ]
        .into_iter()
        .chain(self.pose())
        .flatten()
        .flat_map(|c| c.keys().iter().map(|k| k.0))
        .chain(
            self.wind_mps
                .iter()
                .flat_map(|c| c.keys().iter().map(|k| k.0)),
        )
        .collect();
        times.sort_by(f64::total_cmp);
        times.dedup();
        times
    }

    /// Takes the keyed settings out of a configuration tree, leaving in their place the value
    /// at t = 0 (what time-independent readers of the configuration see). The error names the
    /// setting.
    pub fn take(tree: &mut Value) -> Result<Keyframes, String> {
        let mut keys = Keyframes::default();
        for section in ["rain", "camera"] {
            let Some(fields) = tree.get_mut(section).and_then(Value::as_object_mut) else {
                continue;
            };
            for (field, value) in fields.iter_mut() {
                let path = format!("{section}.{field}");
                // A constant wind is itself a list of two numbers.
                let keyed = match value.as_array() {
                    Some(items) if path == "rain.wind_mps" => {
                        items.first().is_some_and(Value::is_array)
                    }
                    Some(_) => true,
                    None => false,
                };
                if !keyed {
                    continue;
                }
                if !KEYED.contains(&path.as_str()) {
                    return Err(format!(
                        "{path} cannot change over a shot ({}); settings that can: {}",
                        refusal(&path),
                        KEYED.join(", ")
                    ));
                }
                let bad = |e: String| format!("{path}: {e}");
                match path.as_str() {
                    "rain.wind_mps" => {
                        let c = Curve::<DVec2>::from_json(value).map_err(bad)?;
                        *value = c.at(0.0).to_json();
                        keys.wind_mps = Some(c);
                    }
                    _ => {
                        let c = Curve::<f64>::from_json(value).map_err(bad)?;
                        *value = c.at(0.0).to_json();
                        let slot = match path.as_str() {
                            "rain.rate_mm_per_h" => &mut keys.rate_mm_per_h,
                            "rain.opacity" => &mut keys.opacity,
                            "camera.focus_m" => &mut keys.focus_m,
                            "camera.pan_deg" => &mut keys.pan_deg,
                            "camera.tilt_deg" => &mut keys.tilt_deg,
                            "camera.roll_deg" => &mut keys.roll_deg,
                            "camera.height_m" => &mut keys.height_m,
                            "camera.fov_deg" => &mut keys.fov_deg,
                            _ => &mut keys.f_number,
                        };
                        *slot = Some(c);
                    }
                }
            }
        }
        Ok(keys)
    }

    /// Writes the keyed settings into a configuration tree (the inverse of [`Keyframes::take`]).
    pub fn put(&self, tree: &mut Value) {
        let mut set = |path: &str, v: Value| {
            let (section, field) = path.split_once('.').unwrap_or(("", path));
            if let Some(fields) = tree.get_mut(section).and_then(Value::as_object_mut) {
                fields.insert(field.to_string(), v);
            }
        };
        let scalars = [
            ("rain.rate_mm_per_h", &self.rate_mm_per_h),
            ("rain.opacity", &self.opacity),
            ("camera.focus_m", &self.focus_m),
            ("camera.f_number", &self.f_number),
        ]
        .into_iter()
        .chain(POSE.into_iter().zip(self.pose()));
        for (path, c) in scalars {
            if let Some(c) = c {
                set(path, c.to_json());
            }
        }
        if let Some(c) = &self.wind_mps {
            set("rain.wind_mps", c.to_json());
        }
    }

    /// The pose and zoom curves: pan, tilt, roll, height and field of view.
    pub fn pose(&self) -> [&Option<Curve<f64>>; 5] {
        [
            &self.pan_deg,
            &self.tilt_deg,
            &self.roll_deg,
            &self.height_m,
            &self.fov_deg,
        ]
    }

    /// Whether the camera moves or zooms over the shot (a pose or field-of-view key that
    /// changes).
    pub fn moves_camera(&self) -> bool {
        self.pose().into_iter().flatten().any(|c| !c.is_constant())
    }

    /// The times the camera is sampled at to plan the rain volume for the whole shot: from 0
    /// to the last pose key, no two neighbours further apart than `step_deg` along the camera's
    /// path (the pan, tilt, roll and field-of-view changes summed over the keys between them,
    /// which bounds the rotation and the widening between two poses), and every height key.
    /// Keys closer than that along the path are merged, so a track keyed every frame (the
    /// estimated motion) is planned for as many poses as its turn needs. Sorted, from 0.
    pub fn camera_samples_s(&self, step_deg: f64) -> Vec<f64> {
        let fine = self.camera_steps_s(step_deg);
        let angles = [&self.pan_deg, &self.tilt_deg, &self.roll_deg, &self.fov_deg];
        let at = |t: f64| -> [f64; 4] { angles.map(|k| k.as_ref().map_or(0.0, |k| k.at(t))) };
        let path = |a: f64, b: f64| -> f64 {
            let (a, b) = (at(a), at(b));
            (0..4).map(|i| (b[i] - a[i]).abs()).sum()
        };
        let height_keys: Vec<f64> = self
            .height_m
            .iter()
            .flat_map(|c| c.keys().iter().map(|k| k.0))
            .collect();
        let mut out = vec![fine[0]];
        let mut since = 0.0;
        for w in fine.windows(2) {
            let d = path(w[0], w[1]);
            let last = *out.last().expect("one");
            if last != w[0] && (since + d > step_deg.max(1e-3) || height_keys.contains(&w[0])) {
                out.push(w[0]);
                since = 0.0;
            }
            since += d;
        }
        let end = fine[fine.len() - 1];
        if *out.last().expect("one") != end {
            out.push(end);
        }
        out
    }

    /// Every pose key, and between keys steps that turn the camera by at most `step_deg`.
    fn camera_steps_s(&self, step_deg: f64) -> Vec<f64> {
        let mut keys: Vec<f64> = self
            .pose()
            .into_iter()
            .flatten()
            .flat_map(|c| c.keys().iter().map(|k| k.0))
            .chain([0.0])
            .collect();
        keys.sort_by(f64::total_cmp);
        keys.dedup();
        let angles = [&self.pan_deg, &self.tilt_deg, &self.roll_deg];
        let turn = |t: f64| -> [f64; 3] { angles.map(|k| k.as_ref().map_or(0.0, |k| k.at(t))) };
        let mut out = vec![keys[0]];
        for w in keys.windows(2) {
            let (a, b) = (turn(w[0]), turn(w[1]));
            let total: f64 = (0..3).map(|i| (b[i] - a[i]).abs()).sum();
            let n = (total / step_deg.max(1e-3)).ceil().max(1.0) as usize;
            out.extend((1..=n).map(|i| w[0] + (w[1] - w[0]) * i as f64 / n as f64));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Curve<f64> {
        Curve::new(vec![(1.0, 0.0), (3.0, 30.0), (4.0, 10.0)]).expect("valid")
    }

    #[test]
    fn values_are_linear_between_keys_and_held_outside() {
        let c = ramp();
        assert_eq!(c.at(0.0), 0.0);
        assert_eq!(c.at(1.0), 0.0);
        assert_eq!(c.at(2.5), 22.5);
        assert_eq!(c.at(3.5), 20.0);
        assert_eq!(c.at(100.0), 10.0);
        assert_eq!(c.max(), 30.0);
    }

    #[test]
    fn bad_keys_are_refused() {
        assert!(Curve::new(vec![(1.0, 0.0), (1.0, 2.0)]).is_err());
        assert!(Curve::new(vec![(-1.0, 0.0)]).is_err());
        assert!(Curve::<f64>::new(vec![]).is_err());
        assert!(Curve::new(vec![(0.0, f64::NAN)]).is_err());
        assert!(Curve::new((0..=MAX_KEYS).map(|i| (i as f64, 0.0)).collect()).is_err());
    }

    /// The integral and the kinks against a midpoint sum and finite differences.
    #[test]
    fn wind_integral_and_kinks_match_numerics() {
        let c = Curve::new(vec![
            (0.5, DVec2::new(0.0, 1.0)),
            (2.0, DVec2::new(6.0, -2.0)),
            (2.5, DVec2::new(6.0, 0.0)),
        ])
        .expect("valid");
        for t in [0.3, 1.0, 2.2, 7.0] {
            let n = 200_000;
            let h = t / n as f64;
            let sum: DVec2 = (0..n).map(|i| c.at((i as f64 + 0.5) * h) * h).sum();
            assert!((c.integral(t) - sum).length() < 1e-6, "t {t}");
        }
        let kinks = c.kinks();
        let slopes = [
            DVec2::new(4.0, -2.0),
            DVec2::new(-4.0, 6.0),
            DVec2::new(0.0, -4.0),
        ];
        assert_eq!(kinks.len(), 3);
        for ((t, d), (tk, want)) in kinks.iter().zip([0.5, 2.0, 2.5].into_iter().zip(slopes)) {
            assert_eq!(*t, tk);
            assert!((*d - want).length() < 1e-9, "{d} vs {want}");
        }
    }

    /// The planned poses: every key, and no two neighbours turned apart by more than the step
    /// (the pan, tilt and roll changes summed).
    #[test]
    fn camera_samples_bound_the_turn_between_poses() {
        let keys = Keyframes {
            pan_deg: Some(Curve::new(vec![(0.5, 0.0), (2.0, 30.0)]).expect("pan")),
            roll_deg: Some(Curve::new(vec![(1.0, 0.0), (1.5, -4.0)]).expect("roll")),
            ..Keyframes::default()
        };
        let s = keys.camera_samples_s(1.0);
        assert_eq!(s[0], 0.0);
        assert_eq!(s[s.len() - 1], 2.0);
        let turn = |t: f64| {
            keys.pan_deg.as_ref().map_or(0.0, |k| k.at(t))
                - keys.roll_deg.as_ref().map_or(0.0, |k| k.at(t))
        };
        for w in s.windows(2) {
            assert!(w[1] > w[0]);
            // Pan and roll move in opposite senses here, so their changes add up in `turn`.
            assert!((turn(w[1]) - turn(w[0])).abs() <= 1.0 + 1e-9, "{w:?}");
        }
        assert!(s.len() <= 36, "{} poses for a turn of 34°", s.len());
    }

    /// A track keyed every frame that shakes back and forth is sampled by its path: the summed
    /// changes between neighbours within the step (a back-and-forth is not merged away), and
    /// far fewer poses than frames where it moves little.
    #[test]
    fn a_track_keyed_every_frame_is_sampled_along_its_path() {
        let frames: Vec<(f64, f64)> = (0..250)
            .map(|i| {
                (
                    i as f64 / 25.0,
                    0.2 * i as f64 / 25.0 + 0.3 * (i as f64).sin(),
                )
            })
            .collect();
        let keys = Keyframes {
            pan_deg: Some(Curve::track(frames.clone()).expect("track")),
            ..Keyframes::default()
        };
        assert!(Curve::new(frames.clone()).is_err(), "more than MAX_KEYS");
        let s = keys.camera_samples_s(1.0);
        let pan = keys.pan_deg.as_ref().expect("pan");
        for w in s.windows(2) {
            let path: f64 = frames
                .windows(2)
                .filter(|f| f[0].0 >= w[0] && f[1].0 <= w[1])
                .map(|f| (f[1].1 - f[0].1).abs())
                .sum();
            assert!(path <= 1.0 + 1e-9, "{w:?}: {path}");
            assert!((pan.at(w[1]) - pan.at(w[0])).abs() <= 1.0 + 1e-9);
        }
        assert!(s.len() < 150 && s.len() > 20, "{} poses", s.len());
    }

    #[test]
    fn keyed_settings_round_trip_and_unkeyable_ones_are_named() {
        let mut tree = serde_json::json!({
            "rain": {"rate_mm_per_h": [[0, 0], [4, 30]], "wind_mps": [[0, [0, 0]], [3, [8, 1]]]},
            "camera": {"focus_m": 3.0}
        });
        let original = tree.clone();
        let keys = Keyframes::take(&mut tree).expect("keyable");
        assert_eq!(tree["rain"]["rate_mm_per_h"], serde_json::json!(0.0));
        assert_eq!(tree["rain"]["wind_mps"], serde_json::json!([0.0, 0.0]));
        assert_eq!(keys.times_s(), vec![0.0, 3.0, 4.0]);
        keys.put(&mut tree);
        let back = Keyframes::take(&mut tree.clone()).expect("again");
        assert_eq!(back, keys);
        assert_eq!(tree["camera"], original["camera"]);

        // The camera's pose and zoom.
        let mut moving = serde_json::json!({
            "camera": {"pan_deg": [[0, 0], [2, 40]], "height_m": [[1, 1.6], [3, 4]], "tilt_deg": 2}
        });
        let keys = Keyframes::take(&mut moving).expect("pose keys");
        assert!(keys.moves_camera());
        assert_eq!(moving["camera"]["pan_deg"], serde_json::json!(0.0));
        assert_eq!(moving["camera"]["height_m"], serde_json::json!(1.6));
        keys.put(&mut moving);
        assert_eq!(Keyframes::take(&mut moving.clone()).expect("again"), keys);
        let mut still = serde_json::json!({"camera": {"fov_deg": [[0, 50], [2, 50]]}});
        assert!(
            !Keyframes::take(&mut still)
                .expect("constant")
                .moves_camera()
        );

        let mut constant = serde_json::json!({"rain": {"wind_mps": [3, 1]}});
        assert!(Keyframes::take(&mut constant).expect("constant").is_empty());
        let mut bad = serde_json::json!({"rain": {"drop_scale": [[0, 1], [2, 3]]}});
        let e = Keyframes::take(&mut bad).expect_err("refused");
        assert!(
            e.contains("rain.drop_scale") && e.contains("rain.rate_mm_per_h"),
            "{e}"
        );
        let mut bad = serde_json::json!({"camera": {"focus_m": [[2, 1], [1, 3]]}});
        let e = Keyframes::take(&mut bad).expect_err("unordered");
        assert!(
            e.starts_with("camera.focus_m: times in increasing order"),
            "{e}"
        );
    }
}
