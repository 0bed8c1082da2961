//! Compact light sources: the sun, lamps and lit windows that a display-referred frame clips,
//! and lights the user adds. They reach the drops as a direct term through the drop's exact
//! transfer function (the RTF table), because four SH bands cannot carry a source a fraction of
//! a degree wide; the environment SH keeps only the extended remainder.
//!
//! ## How it works
//!
//! A drop seen along the view ray `v` (unit, eye → drop) has radiance `∫ L(ω) F(θ) dω`, with
//! `ω` the direction from the drop toward where the light comes from and `θ = ∠(ω, v)` the
//! scattering angle of [`rtf`](super::rtf): θ = 0 is light passing straight through the drop,
//! θ = π light from behind the eye reflected straight back. A source of mean radiance `L` over a
//! small solid angle `Ω` around `ω` contributes `L·Ω·F(θ)` (F per steradian, linearly
//! interpolated between the table's bin centres). With the sun behind the camera the drops at
//! 42° from the antisolar point scatter at θ ≈ 138°: the primary bow sits at θ ≈ 138° in this
//! convention (the thesis measures from the source side, `θ_thesis = π − θ ≈ 42°`).
//!
//! A source at infinity has the same `ω` and `Ω` at every drop. A source at a finite distance
//! `d` from the camera sits at `camera + d·direction`; a drop at `p` (from the camera) sees it
//! along `ω = (d·direction − p)/|…|` with solid angle `Ω (d/|d·direction − p|)²`: irradiance
//! falls with the square of the drop's distance. The distance is clamped where `Ω` would exceed
//! a hemisphere (a drop inside the luminaire), so the term stays finite.
//!
//! The GPU twin is `direct_light` in `shaders/common/lights.wgsl`.

use glam::DVec3;

use super::rtf::RtfTable;
use crate::error::check;
use crate::{Error, Result};

/// One compact light source, seen from the camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSource {
    /// Unit vector from the camera toward the light, world frame (z up).
    pub direction_world: DVec3,
    /// Solid angle the source subtends at the camera, steradians.
    pub solid_angle_sr: f64,
    /// Mean radiance over the source, linear RGB in the frame's linear units (1.0 = the
    /// frame's white).
    pub radiance_rgb: [f64; 3],
    /// Distance from the camera, metres; `None` for a source at infinity (the sun, a far
    /// window), whose irradiance is the same at every drop.
    pub distance_m: Option<f64>,
}

/// Smallest distance from a drop to a light, metres, whatever the light's size (keeps a point
/// light finite).
pub const MIN_LIGHT_DISTANCE_M: f64 = 1e-3;

impl LightSource {
    /// Irradiance-like strength at the camera: radiance × solid angle, per channel.
    pub fn radiance_times_solid_angle(&self) -> [f64; 3] {
        self.radiance_rgb.map(|l| l * self.solid_angle_sr)
    }

    /// Closest a drop may be to the light, metres: where the source would fill a hemisphere
    /// (`Ω (d/r)² = 2π`), and at least [`MIN_LIGHT_DISTANCE_M`]. `None` at infinity.
    pub fn min_distance_m(&self) -> Option<f64> {
        self.distance_m.map(|d| {
            (d * (self.solid_angle_sr.max(0.0) / (2.0 * std::f64::consts::PI)).sqrt())
                .max(MIN_LIGHT_DISTANCE_M)
        })
    }

    /// The light as a drop at `drop_pos_from_camera_m` (world axes, metres from the camera)
    /// sees it: unit direction from the drop toward the light, and the factor on its solid
    /// angle `(d_camera/d_drop)²`. A light at infinity, or no drop position, gives the camera's
    /// view of it (factor 1).
    pub fn seen_from(&self, drop_pos_from_camera_m: Option<DVec3>) -> (DVec3, f64) {
        let (Some(d), Some(p), Some(r_min)) = (
            self.distance_m,
            drop_pos_from_camera_m,
            self.min_distance_m(),
        ) else {
            return (self.direction_world, 1.0);
        };
        let to_light = self.direction_world * d - p;
        let r = to_light.length();
        let dir = if r > 0.0 {
            to_light / r
        } else {
            self.direction_world
        };
        let r = r.max(r_min);
        (dir, (d / r) * (d / r))
    }
}

/// Scattering angle between unit vectors `a` and `b`, radians, accurate near 0 and π
/// (`atan2(|a×b|, a·b)`).
pub fn angle_between_rad(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// Drop radiance from compact sources, per channel (linear RGB, the lights' units): for each
/// light, `L·Ω·F_c(θ)` with `F_c` the channel's RTF table in sr⁻¹ interpolated at
/// `θ = ∠(ω, v)`, `ω` from the drop toward the light and `v = view` (eye → drop, normalised
/// here). θ = 0 is straight through the drop; the primary bow is near θ = 138°.
///
/// `drop_pos_from_camera_m` is the drop's position relative to the camera in world axes,
/// metres; with it, lights at a finite distance are seen from the drop (direction from the drop,
/// solid angle scaled by `(d_camera/d_drop)²`, see [`LightSource::seen_from`]). `None` takes
/// every light as the camera sees it. Exact for sources small against the table's features
/// (F varies little across the source); a source wider than a degree or two on a bow caustic is
/// smoothed by its centre value.
pub fn direct_colour(
    lights: &[LightSource],
    tables: &[RtfTable; 3],
    drop_pos_from_camera_m: Option<DVec3>,
    view: DVec3,
) -> [f64; 3] {
    let v = view.normalize_or(DVec3::Z);
    let mut out = [0.0; 3];
    for light in lights {
        let (omega, scale) = light.seen_from(drop_pos_from_camera_m);
        let theta = angle_between_rad(omega, v);
        let strength = light.radiance_times_solid_angle();
        for c in 0..3 {
            out[c] += strength[c] * scale * tables[c].interpolated(theta);
        }
    }
    out
}

/// Default angular diameter of a user light, degrees: a street-lamp luminaire (0.3–0.5 m
/// across) seen from 5–10 m subtends about 2–6°; 3° sits in that range. Only `L·Ω` matters for
/// a light much smaller than the RTF's features, so the size mostly sets the radiance that
/// gives a chosen brightness.
pub const DEFAULT_ANGULAR_DIAMETER_DEG: f64 = 3.0;

/// A light the frame does not show (a street lamp behind the camera), given by the user.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UserLight {
    /// Degrees from the camera's view direction, right positive.
    pub azimuth_deg: f64,
    /// Degrees from the camera's view direction, up positive, in [-90, 90].
    pub elevation_deg: f64,
    /// Mean radiance over the source, linear RGB relative to the frame's white (1.0). A street
    /// lamp in a night scene exposed for the road is of order 10³–10⁵.
    pub radiance_rgb: [f64; 3],
    /// Distance from the camera, metres; absent for a light at infinity (the sun).
    pub distance_m: Option<f64>,
    /// Angular diameter seen from the camera, degrees (fixes the solid angle).
    pub angular_diameter_deg: f64,
}

impl Default for UserLight {
    fn default() -> Self {
        UserLight {
            azimuth_deg: 0.0,
            elevation_deg: 0.0,
            radiance_rgb: [0.0; 3],
            distance_m: None,
            angular_diameter_deg: DEFAULT_ANGULAR_DIAMETER_DEG,
        }
    }
}

impl UserLight {
    /// Rejects values outside their range, naming the key.
    pub fn validate(&self) -> Result<()> {
        check(
            "light.lights.azimuth_deg",
            self.azimuth_deg,
            (-360.0..=360.0).contains(&self.azimuth_deg),
            "degrees in [-360, 360]",
        )?;
        check(
            "light.lights.elevation_deg",
            self.elevation_deg,
            (-90.0..=90.0).contains(&self.elevation_deg),
            "degrees in [-90, 90]",
        )?;
        for l in self.radiance_rgb {
            check(
                "light.lights.radiance_rgb",
                l,
                (0.0..=1e9).contains(&l),
                "a radiance ≥ 0 (and at most 1e9) relative to the frame's white",
            )?;
        }
        if let Some(d) = self.distance_m {
            check(
                "light.lights.distance_m",
                d,
                d > 0.0 && d <= 1e7,
                "metres, above 0 (and at most 1e7)",
            )?;
        }
        check(
            "light.lights.angular_diameter_deg",
            self.angular_diameter_deg,
            self.angular_diameter_deg > 0.0 && self.angular_diameter_deg <= 90.0,
            "degrees in (0, 90]",
        )
    }

    /// Solid angle of the light's disc, steradians: `2π (1 − cos(δ/2))`.
    pub fn solid_angle_sr(&self) -> f64 {
        2.0 * std::f64::consts::PI * (1.0 - (0.5 * self.angular_diameter_deg.to_radians()).cos())
    }

    /// The light in the world, for a camera whose rotation is `world_from_camera` (camera
    /// space: +x right, +y down, +z forward).
    pub fn source(&self, world_from_camera: glam::DMat3) -> LightSource {
        let (az, el) = (
            self.azimuth_deg.to_radians(),
            self.elevation_deg.to_radians(),
        );
        let cam = DVec3::new(el.cos() * az.sin(), -el.sin(), el.cos() * az.cos());
        LightSource {
            direction_world: (world_from_camera * cam).normalize_or(DVec3::Z),
            solid_angle_sr: self.solid_angle_sr(),
            radiance_rgb: self.radiance_rgb,
            distance_m: self.distance_m,
        }
    }

    /// Parses the CLI form `az,el,r,g,b[,distance_m]` (degrees, radiance relative to the
    /// frame's white, metres).
    pub fn parse(text: &str) -> Result<UserLight> {
        let bad = || Error::Parameter {
            name: "light.lights",
            value: text.to_string(),
            expected: "az,el,r,g,b[,distance_m]: degrees right and up of the view \
                       direction, radiance relative to the frame's white, metres"
                .into(),
        };
        let v: Vec<f64> = text
            .split(',')
            .map(|p| p.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| bad())?;
        let light = match v[..] {
            [az, el, r, g, b] => UserLight {
                azimuth_deg: az,
                elevation_deg: el,
                radiance_rgb: [r, g, b],
                ..UserLight::default()
            },
            [az, el, r, g, b, d] => UserLight {
                azimuth_deg: az,
                elevation_deg: el,
                radiance_rgb: [r, g, b],
                distance_m: Some(d),
                ..UserLight::default()
            },
            _ => return Err(bad()),
        };
        light.validate()?;
        Ok(light)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn user_light_directions_follow_the_camera() {
        let cam = crate::scene::Camera::new(640, 360, 1.0, 1.6, 0.0, 0.0);
        let ahead = UserLight::default().source(cam.world_from_camera);
        assert!((ahead.direction_world - DVec3::Y).length() < 1e-12);
        let right = UserLight {
            azimuth_deg: 90.0,
            ..UserLight::default()
        };
        assert!((right.source(cam.world_from_camera).direction_world - DVec3::X).length() < 1e-12);
        let up = UserLight {
            elevation_deg: 90.0,
            ..UserLight::default()
        };
        assert!((up.source(cam.world_from_camera).direction_world - DVec3::Z).length() < 1e-12);
        let behind = UserLight {
            azimuth_deg: 180.0,
            ..UserLight::default()
        };
        let d = behind.source(cam.world_from_camera).direction_world;
        assert!((d + DVec3::Y).length() < 1e-12);
    }

    #[test]
    fn parse_and_validate_name_the_key() {
        let l = UserLight::parse("10,-5,100,90,80,4.5").expect("valid");
        assert_eq!(l.distance_m, Some(4.5));
        assert_eq!(l.radiance_rgb, [100.0, 90.0, 80.0]);
        for (text, key) in [
            ("0,95,1,1,1", "light.lights.elevation_deg"),
            ("0,0,-1,1,1", "light.lights.radiance_rgb"),
            ("0,0,1,1,1,0", "light.lights.distance_m"),
            ("0,0,1,1,inf", "light.lights.radiance_rgb"),
            ("0,0,1,1", "light.lights"),
            ("a,0,1,1,1", "light.lights"),
        ] {
            match UserLight::parse(text) {
                Err(Error::Parameter { name, .. }) => assert_eq!(name, key, "{text}"),
                other => panic!("{text}: {other:?}"),
            }
        }
    }

    #[test]
    fn a_drop_inside_the_luminaire_stays_finite() {
        let l = LightSource {
            direction_world: DVec3::Y,
            solid_angle_sr: 1e-3,
            radiance_rgb: [1.0; 3],
            distance_m: Some(3.0),
        };
        let (dir, scale) = l.seen_from(Some(DVec3::Y * 3.0));
        assert!(dir.is_finite());
        // Never more than a hemisphere of the source's radiance.
        assert!(scale * l.solid_angle_sr <= 2.0 * std::f64::consts::PI * (1.0 + 1e-12));
        // Twice as far from the drop as from the camera: a quarter of the irradiance.
        let (_, s) = l.seen_from(Some(-DVec3::Y * 3.0));
        assert!((s - 0.25).abs() < 1e-12);
    }
}

#[cfg(test)]
mod config_tests {
    use crate::Error;
    use crate::config::RenderConfig;

    #[test]
    fn config_lights_are_read_and_validated() {
        let ok: RenderConfig = serde_json::from_str(
            r#"{"light": {"lights": [{"azimuth_deg": 170, "elevation_deg": 20,
                "radiance_rgb": [3000, 2600, 2000], "distance_m": 4}]}}"#,
        )
        .expect("parses");
        ok.validate().expect("valid");
        let l = ok.light.lights[0];
        assert_eq!(l.angular_diameter_deg, super::DEFAULT_ANGULAR_DIAMETER_DEG);
        let bad: RenderConfig = serde_json::from_str(
            r#"{"light": {"lights": [{"elevation_deg": 100, "radiance_rgb": [1, 1, 1]}]}}"#,
        )
        .expect("parses");
        match bad.validate() {
            Err(Error::Parameter { name, expected, .. }) => {
                assert_eq!(name, "light.lights.elevation_deg");
                assert!(expected.contains("[-90, 90]"), "{expected}");
            }
            other => panic!("{other:?}"),
        }
    }
}
