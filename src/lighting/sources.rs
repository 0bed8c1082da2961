//! Compact light sources: the sun, lamps and lit windows that a display-referred frame clips,
//! and lights the user adds. They reach the drops as a direct term through the drop's exact
//! transfer function (the RTF table), because four SH bands cannot carry a source a fraction of
//! a degree wide; the environment SH keeps only the extended remainder.

use glam::DVec3;

use super::rtf::RtfTable;

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

impl LightSource {
    /// Irradiance-like strength at the camera: radiance × solid angle, per channel.
    pub fn radiance_times_solid_angle(&self) -> [f64; 3] {
        self.radiance_rgb.map(|l| l * self.solid_angle_sr)
    }
}

/// The direct term of compact sources for a drop seen along `view` (eye → drop, unit): each
/// light of radiance L and solid angle Ω in direction ω (from the drop toward the light) adds
/// `L Ω F(θ)` per channel, `cos θ = ω·v` and F the drop's phase function from the RTF table
/// ([`RtfTable::interpolated`], the table's bin averages interpolated linearly between bin
/// centres, as a linearly filtered 1-D texture does). This is the small-source limit of
/// `∫ L(ω) F(θ) dω` (rtf.rs), the same integral the SH term approximates for the extended
/// light.
///
/// A light at infinity (`distance_m = None`) has the same ω at every drop. A light at a
/// distance d from the camera sits at `d · direction` (camera at the origin); for a drop at
/// `drop_pos_from_camera_m` it is seen along the normalised `d · direction − drop` and its
/// irradiance scales by `(d / |d · direction − drop|)²` (inverse square; its solid angle is
/// measured at the camera). With `drop_pos_from_camera_m = None` the drop is at the camera.
pub fn direct_colour(
    lights: &[LightSource],
    tables: &[RtfTable; 3],
    drop_pos_from_camera_m: Option<DVec3>,
    view: DVec3,
) -> [f64; 3] {
    let v = view.normalize_or(DVec3::Z);
    let mut out = [0.0; 3];
    for l in lights {
        let dir = l.direction_world.normalize_or(DVec3::Z);
        let (omega, scale) = match (l.distance_m, drop_pos_from_camera_m) {
            (Some(d), Some(p)) if d.is_finite() && d > 0.0 => {
                let to_light = dir * d - p;
                let r = to_light.length();
                if r <= 1e-9 * d {
                    continue; // the drop sits on the light: no finite direction
                }
                (to_light / r, (d / r).powi(2))
            }
            _ => (dir, 1.0),
        };
        let theta = omega.dot(v).clamp(-1.0, 1.0).acos();
        for (c, t) in tables.iter().enumerate() {
            out[c] += l.radiance_rgb[c] * l.solid_angle_sr * scale * t.interpolated(theta);
        }
    }
    out
}
