//! Compact light sources: the sun, lamps and lit windows that a display-referred frame clips,
//! and lights the user adds. They reach the drops as a direct term through the drop's exact
//! transfer function (the RTF table), because four SH bands cannot carry a source a fraction of
//! a degree wide; the environment SH keeps only the extended remainder.

use glam::DVec3;

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
