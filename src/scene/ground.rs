//! The ground: a plane in the world frame, and how it fixes the camera's pose.
//!
//! The world frame is z up with the camera `height_m` above the ground `z = 0` (see
//! [`crate::scene`]). What the picture alone can tell about the ground is its orientation
//! relative to the camera — the **horizon** — which is the same thing as the camera's tilt and
//! roll relative to gravity. The ground's distance (the camera height) stays a user value: no
//! single frame can know the scale.
//!
//! Conventions, shared with [`Camera::new`]: the ground's upward normal seen in camera space
//! (x right, y down, z forward) is
//!
//! ```text
//! n_cam(tilt, roll) = (−cos t · sin r, −cos t · cos r, sin t)
//! ```
//!
//! so the horizon — the image of the directions with `n_cam · d = 0` — crosses the picture's
//! vertical centre line at `y = cy + f · tan t / cos r` and slopes by `dy/dx = −tan r`. The
//! functions here go both ways: horizon row and roll → tilt (for `--ground horizon=…`), plane
//! → tilt and roll (for `--ground plane=…`), and a plane seen by a camera → the row, tilt and
//! roll that, passed back as `--tilt`/`--roll`, reproduce that camera.

use std::fmt;
use std::str::FromStr;

use glam::{DVec2, DVec3};

use crate::scene::Camera;
use crate::{Error, Result};

/// A plane `normal · p = level_m` in the world frame; `normal` is unit and points up (to the
/// side the camera is on).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundPlane {
    /// Unit upward normal, world frame.
    pub normal: DVec3,
    /// Offset along the normal, metres: `normal · p = level_m` on the plane.
    pub level_m: f64,
}

/// The camera's pose relative to a ground plane, in the conventions of `--tilt` and `--roll`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundPose {
    /// Pitch up (negative: down), radians.
    pub tilt_rad: f64,
    /// Roll clockwise about the optical axis, radians.
    pub roll_rad: f64,
    /// Height of the camera above the plane, metres.
    pub height_m: f64,
}

impl GroundPlane {
    /// The level ground `z = 0` that [`Camera::new`] places its camera above.
    pub const LEVEL: GroundPlane = GroundPlane {
        normal: DVec3::Z,
        level_m: 0.0,
    };

    /// Signed height of a world point above the plane, metres.
    pub fn height_above_m(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.level_m
    }

    /// Where a ray from `origin` along `dir` meets the plane (distance along `dir`, in units of
    /// its length), if it does ahead of the origin. `None` for a ray parallel to the plane.
    pub fn intersect(&self, origin: DVec3, dir: DVec3) -> Option<f64> {
        let denom = self.normal.dot(dir);
        if denom.abs() < 1e-12 {
            return None;
        }
        let s = -self.height_above_m(origin) / denom;
        (s > 0.0).then_some(s)
    }

    /// The plane given in `camera`'s own frame (x right, y down, z forward, metres) as
    /// `n · X + d = 0`, placed in the world frame of `camera`. The signs of `n` and `d` are
    /// chosen so that the camera is above the plane (`d > 0` after normalising); a plane
    /// through the camera (`d = 0`) or a zero normal is refused.
    pub fn from_camera_frame(camera: &Camera, n: [f64; 3], d: f64) -> Result<GroundPlane> {
        let (n_cam, height_m) = camera_frame_plane(n, d)?;
        let normal = (camera.world_from_camera * n_cam).normalize();
        Ok(GroundPlane {
            normal,
            level_m: normal.dot(camera.position_m) - height_m,
        })
    }

    /// The ground's upward normal in `camera`'s frame.
    pub fn normal_camera(&self, camera: &Camera) -> DVec3 {
        camera.world_from_camera.transpose() * self.normal
    }

    /// The tilt, roll and height that make [`Camera::new`] see this plane as `camera` sees it:
    /// passing them back as `--tilt`, `--roll` and `--camera-height` reproduces the camera.
    pub fn pose(&self, camera: &Camera) -> GroundPose {
        let (tilt_rad, roll_rad) = tilt_roll_from_up(self.normal_camera(camera));
        GroundPose {
            tilt_rad,
            roll_rad,
            height_m: self.height_above_m(camera.position_m),
        }
    }

    /// The horizon of this plane in `camera`'s picture: the row (a fraction of the height from
    /// the top) where it crosses the vertical centre line. `None` when the horizon does not
    /// cross that line (roll of ±90°, or the camera looking straight up or down).
    pub fn horizon_row(&self, camera: &Camera) -> Option<f64> {
        horizon_row_of_up(self.normal_camera(camera), camera)
    }
}

/// Shortest normal `plane=` takes: a shorter one is rounding noise, not a direction.
pub const MIN_PLANE_NORMAL: f64 = 1e-9;

/// Normalises a camera-frame plane `n · X + d = 0` so that the camera is above it: the unit
/// upward normal and the camera's height. A plane that would turn the camera on its side or
/// upside down (|roll| ≥ 90°) is refused: it is almost always the plane written as
/// `n · X = d` (level ground 1.6 m below is `0,-1,0,1.6`, not `0,1,0,1.6`).
pub fn camera_frame_plane(n: [f64; 3], d: f64) -> Result<(DVec3, f64)> {
    let v = DVec3::from_array(n);
    let len = v.length();
    let bad = |expected: &str| Error::Parameter {
        name: "ground.mode",
        value: format!("plane={},{},{},{}", n[0], n[1], n[2], d),
        expected: expected.to_string(),
    };
    if !(len.is_finite() && len > MIN_PLANE_NORMAL && d.is_finite()) {
        return Err(bad(&format!(
            "a finite normal nx,ny,nz of length above {MIN_PLANE_NORMAL:e} and a finite d"
        )));
    }
    if d == 0.0 {
        return Err(bad("a plane not through the camera (d ≠ 0)"));
    }
    let s = d.signum();
    let up = v * (s / len);
    let (_, roll) = tilt_roll_from_up(up);
    if roll.to_degrees().abs() >= 90.0 {
        return Err(bad(&format!(
            "n·X + d = 0 in the camera frame (y down), a ground below the camera: this one \
             rolls the camera by {:.0}° (level ground 1.6 m below is plane=0,-1,0,1.6)",
            roll.to_degrees()
        )));
    }
    Ok((up, d.abs() / len))
}

/// The ground's upward normal in camera space for a camera of `tilt_rad` and `roll_rad`
/// (the module's `n_cam`).
pub fn up_from_tilt_roll(tilt_rad: f64, roll_rad: f64) -> DVec3 {
    let (st, ct) = tilt_rad.sin_cos();
    let (sr, cr) = roll_rad.sin_cos();
    DVec3::new(-ct * sr, -ct * cr, st)
}

/// The inverse of [`up_from_tilt_roll`]: tilt in [−π/2, π/2], roll in (−π, π] (0 when the
/// camera looks straight up or down, where roll is undefined).
pub fn tilt_roll_from_up(up_cam: DVec3) -> (f64, f64) {
    let n = up_cam.normalize();
    let tilt = n.z.clamp(-1.0, 1.0).asin();
    let roll = if n.x.hypot(n.y) < 1e-12 {
        0.0
    } else {
        (-n.x).atan2(-n.y)
    };
    (tilt, roll)
}

/// Horizon row (fraction of the height from the top, at the vertical centre line) of a ground
/// with upward camera-space normal `up_cam`, seen by `camera`'s intrinsics.
pub fn horizon_row_of_up(up_cam: DVec3, camera: &Camera) -> Option<f64> {
    // n · (0, y − cy, f) = 0 → y − cy = −f n_z / n_y.
    if up_cam.y.abs() < 1e-9 {
        return None;
    }
    let y = camera.principal_px().y - camera.focal_px() * up_cam.z / up_cam.y;
    let row = y / camera.height_px as f64;
    row.is_finite().then_some(row)
}

/// Tilt (radians) of a camera with `camera`'s intrinsics whose horizon crosses the vertical
/// centre line at `row` (fraction of the height from the top) with roll `roll_rad`.
pub fn tilt_from_horizon(row: f64, roll_rad: f64, camera: &Camera) -> f64 {
    let dy = row * camera.height_px as f64 - camera.principal_px().y;
    (dy * roll_rad.cos() / camera.focal_px()).atan()
}

/// Two picture points of the horizon of a ground with upward normal `up_cam` (pixels), for
/// drawing; `None` when the horizon is not in front of the camera in any direction.
pub fn horizon_points_px(up_cam: DVec3, camera: &Camera) -> Option<(DVec2, DVec2)> {
    // The horizon line in pixels: n_x (x − cx) + n_y (y − cy) + n_z f = 0.
    let (c, f) = (camera.principal_px(), camera.focal_px());
    let (a, b, k) = (up_cam.x, up_cam.y, up_cam.z * f);
    let w = camera.width_px as f64;
    let h = camera.height_px as f64;
    if b.abs() >= a.abs() {
        if b.abs() < 1e-12 {
            return None;
        }
        let y = |x: f64| c.y - (a * (x - c.x) + k) / b;
        Some((DVec2::new(0.0, y(0.0)), DVec2::new(w, y(w))))
    } else {
        let x = |y: f64| c.x - (b * (y - c.y) + k) / a;
        Some((DVec2::new(x(0.0), 0.0), DVec2::new(x(h), h)))
    }
}

/// What `--ground` asks for.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum GroundMode {
    /// No ground: the render is as without this option.
    #[default]
    None,
    /// Estimated from the frames (see [`crate::scene::horizon`]).
    Auto,
    /// The horizon crosses the vertical centre line at `row` (fraction of the picture height
    /// from the top; outside [0, 1] when the horizon is out of the picture), rolled by
    /// `roll_deg` (clockwise, as `--roll`).
    Horizon {
        /// Fraction of the height from the top.
        row: f64,
        /// Degrees, clockwise.
        roll_deg: f64,
    },
    /// A plane `n · X + d = 0` in the camera's frame (x right, y down, z forward, metres), as a
    /// plane fit to a depth map or a reconstruction gives it; `|d|/|n|` is the camera height.
    Plane {
        /// Normal (any length; normalised on use).
        normal: [f64; 3],
        /// Offset, metres (times `|normal|`).
        d_m: f64,
    },
}

/// Largest `|ROW|` of `horizon=ROW`: 20 picture heights off the centre is a camera within a
/// degree or two of straight up or down, beyond which the horizon says nothing usable.
pub const MAX_HORIZON_ROW: f64 = 20.0;

impl GroundMode {
    /// Checks the values' ranges, naming `ground.mode`.
    pub fn validate(&self) -> Result<()> {
        let bad = |expected: &str| Error::Parameter {
            name: "ground.mode",
            value: self.to_string(),
            expected: expected.to_string(),
        };
        match *self {
            GroundMode::None | GroundMode::Auto => Ok(()),
            GroundMode::Horizon { row, roll_deg } => {
                if !(row.is_finite() && row.abs() <= MAX_HORIZON_ROW) {
                    return Err(bad(
                        "horizon=ROW with ROW a fraction of the picture height from the top in [-20, 20]",
                    ));
                }
                if !(roll_deg.is_finite() && roll_deg.abs() < 90.0) {
                    return Err(bad("roll=DEG in (-90, 90)"));
                }
                Ok(())
            }
            GroundMode::Plane { normal, d_m } => camera_frame_plane(normal, d_m).map(|_| ()),
        }
    }

    /// The ground plane and the camera's pose for a fixed mode (`horizon=` or `plane=`), given
    /// the camera's intrinsics (its own tilt and roll are replaced). `None` for `none` and
    /// `auto` (the latter depends on the frames).
    pub fn fixed_pose(&self, camera: &Camera, height_m: f64) -> Result<Option<GroundPose>> {
        self.validate()?;
        Ok(match *self {
            GroundMode::None | GroundMode::Auto => None,
            GroundMode::Horizon { row, roll_deg } => {
                let roll_rad = roll_deg.to_radians();
                Some(GroundPose {
                    tilt_rad: tilt_from_horizon(row, roll_rad, camera),
                    roll_rad,
                    height_m,
                })
            }
            GroundMode::Plane { normal, d_m } => {
                let (up, h) = camera_frame_plane(normal, d_m)?;
                let (tilt_rad, roll_rad) = tilt_roll_from_up(up);
                Some(GroundPose {
                    tilt_rad,
                    roll_rad,
                    height_m: h,
                })
            }
        })
    }
}

impl fmt::Display for GroundMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GroundMode::None => write!(f, "none"),
            GroundMode::Auto => write!(f, "auto"),
            GroundMode::Horizon { row, roll_deg } if *roll_deg == 0.0 => {
                write!(f, "horizon={row}")
            }
            GroundMode::Horizon { row, roll_deg } => write!(f, "horizon={row},roll={roll_deg}"),
            GroundMode::Plane { normal, d_m } => {
                write!(f, "plane={},{},{},{}", normal[0], normal[1], normal[2], d_m)
            }
        }
    }
}

impl FromStr for GroundMode {
    type Err = Error;

    fn from_str(s: &str) -> Result<GroundMode> {
        let bad = || Error::Parameter {
            name: "ground.mode",
            value: s.to_string(),
            expected: "auto, none, horizon=ROW[,roll=DEG] or plane=nx,ny,nz,d".into(),
        };
        let num = |t: &str| t.trim().parse::<f64>().map_err(|_| bad());
        let t = s.trim();
        let mode = if t == "none" {
            GroundMode::None
        } else if t == "auto" {
            GroundMode::Auto
        } else if let Some(rest) = t.strip_prefix("horizon=") {
            let mut parts = rest.split(',');
            let row = num(parts.next().ok_or_else(bad)?)?;
            let roll_deg = match parts.next() {
                None => 0.0,
                Some(p) => num(p.trim().strip_prefix("roll=").ok_or_else(bad)?)?,
            };
            if parts.next().is_some() {
                return Err(bad());
            }
            GroundMode::Horizon { row, roll_deg }
        } else if let Some(rest) = t.strip_prefix("plane=") {
            let v: Vec<f64> = rest.split(',').map(num).collect::<Result<_>>()?;
            let [nx, ny, nz, d] = v[..] else {
                return Err(bad());
            };
            GroundMode::Plane {
                normal: [nx, ny, nz],
                d_m: d,
            }
        } else {
            return Err(bad());
        };
        mode.validate()?;
        Ok(mode)
    }
}

impl serde::Serialize for GroundMode {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_string())
    }
}

impl<'de> serde::Deserialize<'de> for GroundMode {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(tilt_deg: f64, roll_deg: f64) -> Camera {
        Camera::new(
            640,
            360,
            60f64.to_radians(),
            1.6,
            tilt_deg.to_radians(),
            roll_deg.to_radians(),
        )
    }

    /// `n_cam` is what the camera model says the world's up is (checked against the camera's
    /// own rotation, not the formula).
    #[test]
    fn up_normal_matches_the_camera_rotation() {
        for &(t, r) in &[
            (0.0, 0.0),
            (25.0, 0.0),
            (-40.0, 12.0),
            (11.3, -30.0),
            (80.0, 45.0),
        ] {
            let c = cam(t, r);
            let up = c.world_from_camera.transpose() * DVec3::Z;
            let formula = up_from_tilt_roll(f64::to_radians(t), f64::to_radians(r));
            assert!((up - formula).length() < 1e-12, "{t} {r}");
            let (t2, r2) = tilt_roll_from_up(up);
            assert!((t2.to_degrees() - t).abs() < 1e-9 && (r2.to_degrees() - r).abs() < 1e-9);
        }
    }

    /// The horizon row is where distant level points project: a point 10 km away at the
    /// camera's height, straight ahead in the vertical plane of the centre column.
    #[test]
    fn horizon_row_is_where_far_level_points_project() {
        for &(t, r) in &[(0.0, 0.0), (10.0, 0.0), (-20.0, 15.0), (5.0, -30.0)] {
            let c = cam(t, r);
            let row = GroundPlane::LEVEL.horizon_row(&c).expect("crosses");
            // Search along the centre column for the ray that is level.
            let (mut lo, mut hi) = (-1e5, 1e5);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                let z = c.ray_world(DVec2::new(320.0, mid)).z;
                if z > 0.0 { lo = mid } else { hi = mid }
            }
            assert!(
                (row * 360.0 - lo).abs() < 1e-6,
                "{t} {r}: {row} vs {}",
                lo / 360.0
            );
            // And `horizon=ROW,roll=R` gives the tilt back.
            let tilt = tilt_from_horizon(row, r.to_radians(), &c);
            assert!((tilt.to_degrees() - t).abs() < 1e-9);
        }
    }

    /// Round trip: a camera-frame plane → pose → a camera built from that pose sees the
    /// level ground exactly as the plane.
    #[test]
    fn plane_pose_round_trip() {
        let level = cam(0.0, 0.0);
        let n = [0.2, -0.9, 0.35];
        let plane = GroundPlane::from_camera_frame(&level, n, 2.5).expect("valid");
        let pose = plane.pose(&level);
        assert!((pose.height_m - 2.5 / DVec3::from_array(n).length()).abs() < 1e-12);
        let back = Camera::new(
            640,
            360,
            60f64.to_radians(),
            pose.height_m,
            pose.tilt_rad,
            pose.roll_rad,
        );
        let up = back.world_from_camera.transpose() * DVec3::Z;
        assert!((up - DVec3::from_array(n).normalize()).length() < 1e-12);
        assert!(GroundPlane::from_camera_frame(&level, n, 0.0).is_err());
        assert!(GroundPlane::from_camera_frame(&level, [0.0; 3], 1.0).is_err());
    }

    #[test]
    fn modes_parse_and_print_back() {
        for s in [
            "none",
            "auto",
            "horizon=0.4",
            "horizon=-0.25,roll=12.5",
            "plane=0,-1,0,1.6",
        ] {
            let m: GroundMode = s.parse().expect(s);
            assert_eq!(m.to_string(), s);
        }
        for s in [
            "",
            "sky",
            "horizon=",
            "horizon=0.5,tilt=3",
            "horizon=0.5,roll=95",
            "plane=0,0,0,1",
            "plane=1,2,3",
            "horizon=nan",
        ] {
            let e = s.parse::<GroundMode>().expect_err(s).to_string();
            assert!(e.contains("ground.mode"), "{e}");
        }
    }
}
