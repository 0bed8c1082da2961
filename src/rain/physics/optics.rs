//! How rain looks through a camera: extinction of far rain as haze (Weber et al. 2015), exposure,
//! streak length and alpha (Garg & Nayar 2004/2007), the thin lens's defocus.

use glam::{DVec2, DVec3};

use super::{RainRate, param_error};
use crate::Result;
use crate::scene::Camera;

// ------------------------------------------------------------------------------------------
// Extinction (far rain as haze)
// ------------------------------------------------------------------------------------------

/// Extinction coefficient of rain, m⁻¹: β = 0.312 R^0.67 km⁻¹ (Weber et al. 2015, as used by
/// astra-vision/rain-rendering). It agrees with the geometric-optics value 2 ∫ N(D) πD²/4 dD =
/// π N0/Λ³ for Marshall–Palmer within 6 % at 10–50 mm/h.
pub fn extinction_per_m(rate: RainRate) -> f64 {
    if rate.is_off() {
        0.0
    } else {
        0.312e-3 * rate.mm_per_h().powf(0.67)
    }
}

/// Fraction of light transmitted through `distance_m` of rain, e^{−β d}.
pub fn transmittance(rate: RainRate, distance_m: f64) -> f64 {
    (-extinction_per_m(rate) * distance_m.max(0.0)).exp()
}

/// Share of a drop's extinction that is diffraction: a drop much larger than the wavelength
/// removes twice its cross-section from a beam (the extinction paradox), half by refraction and
/// reflection, half diffracted within about λ/D ≈ 0.03° of the beam (D = 1 mm) — about one
/// pixel of a 1080p picture 60° wide. A transmissometer counts that half as lost; a picture
/// keeps it in the pixel it came from.
pub const DIFFRACTED_SHARE: f64 = 0.5;

/// Extinction of rain as a picture sees it, m⁻¹: [`extinction_per_m`] less its diffracted
/// share, which stays in the beam (the δ-scaling of a forward peak narrower than a pixel). What
/// is removed is exactly what the geometric optics scatter, so the same β weights the in-scatter.
pub fn imaging_extinction_per_m(rate: RainRate) -> f64 {
    (1.0 - DIFFRACTED_SHARE) * extinction_per_m(rate)
}

/// Opacity of the rain between `from_m` and `to_m` along a ray as a picture sees it (the haze
/// that stands for drops too far to draw one by one): 1 − e^{−β′ (to − from)} with the imaging
/// extinction β′ ([`imaging_extinction_per_m`]), 0 when `to ≤ from`.
pub fn haze_alpha(rate: RainRate, from_m: f64, to_m: f64) -> f64 {
    let d = (to_m - from_m).max(0.0);
    -(-imaging_extinction_per_m(rate) * d).exp_m1()
}

// ------------------------------------------------------------------------------------------
// Camera optics
// ------------------------------------------------------------------------------------------

/// Default shutter angle, degrees: 180° exposes each frame for half the frame interval.
pub const DEFAULT_SHUTTER_ANGLE_DEG: f64 = 180.0;
/// Default sensor width, mm: full-frame (36 mm) equivalent, so a field of view gives the
/// familiar focal length (60° → 31.2 mm).
pub const DEFAULT_SENSOR_WIDTH_MM: f64 = 36.0;

/// Exposure time, s: (shutter angle / 360°) / fps. 180° at 25 fps gives 1/50 s.
pub fn exposure_s(shutter_angle_deg: f64, fps: f64) -> Result<f64> {
    if !(shutter_angle_deg.is_finite() && shutter_angle_deg > 0.0 && shutter_angle_deg <= 360.0) {
        return Err(param_error(
            "camera.shutter_deg",
            shutter_angle_deg,
            "degrees in (0, 360]",
        ));
    }
    if !(fps.is_finite() && fps > 0.0 && fps <= 1000.0) {
        return Err(param_error(
            "inspect.drops.fps",
            fps,
            "frames per second in (0, 1000]",
        ));
    }
    Ok(shutter_angle_deg / 360.0 / fps)
}

/// On-screen streak length, px, of a drop moving at `speed_mps` parallel to the image plane at
/// depth `depth_m` (along the optical axis): speed × exposure × focal_px ÷ depth (pinhole
/// similar triangles). Exact for any velocity perpendicular to the optical axis.
pub fn streak_length_px(speed_mps: f64, exposure_s: f64, focal_px: f64, depth_m: f64) -> f64 {
    speed_mps * exposure_s * focal_px / depth_m
}

/// Image-plane velocity, px/s, of a point at `position_m` moving at `velocity_mps` (world
/// frame): the derivative of the pinhole projection, f/Z (v_xy − (v_z/Z) p_xy) in camera
/// coordinates. Times the exposure it is the streak vector to first order — the general form
/// of [`streak_length_px`], off by about ℓ·|v_Z|T/Z px (ℓ the streak length, v_Z the speed
/// along the optical axis); [`projected_streak_px`] is exact. `None` behind the camera.
pub fn image_velocity_pxps(
    camera: &Camera,
    position_m: DVec3,
    velocity_mps: DVec3,
) -> Option<DVec2> {
    let p = camera.camera_from_world_point(position_m);
    if p.z <= 0.0 {
        return None;
    }
    let v = camera.world_from_camera.transpose() * velocity_mps;
    let f = camera.focal_px();
    Some(DVec2::new(v.x - v.z * p.x / p.z, v.y - v.z * p.y / p.z) * (f / p.z))
}

/// The streak's exact end points, px: the projections of the drop at the start and the end of
/// the exposure, `position_m` and `position_m + velocity_mps · exposure_s`. `None` if either
/// is behind the camera.
pub fn projected_streak_px(
    camera: &Camera,
    position_m: DVec3,
    velocity_mps: DVec3,
    exposure_s: f64,
) -> Option<[DVec2; 2]> {
    let a = camera.project_world(position_m)?;
    let b = camera.project_world(position_m + velocity_mps * exposure_s)?;
    Some([a, b])
}

/// A thin lens in front of the pinhole camera: depth of field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThinLens {
    /// Sensor width, mm; with the camera's field of view it fixes the focal length.
    pub sensor_width_mm: f64,
    /// Aperture f-number N (focal length / aperture diameter).
    pub f_number: f64,
    /// Focus distance, m (along the optical axis); `f64::INFINITY` focuses at infinity.
    pub focus_m: f64,
}

impl ThinLens {
    /// A validated lens: sensor width > 0, f-number in [0.5, 64], focus distance > 0.
    pub fn new(sensor_width_mm: f64, f_number: f64, focus_m: f64) -> Result<ThinLens> {
        if !(sensor_width_mm.is_finite() && sensor_width_mm > 0.0) {
            return Err(param_error(
                "camera.sensor_width_mm",
                sensor_width_mm,
                "millimetres > 0",
            ));
        }
        if !(f_number.is_finite() && (0.5..=64.0).contains(&f_number)) {
            return Err(param_error(
                "camera.f_number",
                f_number,
                "an f-number in [0.5, 64]",
            ));
        }
        if focus_m.is_nan() || focus_m <= 0.0 {
            return Err(param_error(
                "camera.focus_m",
                focus_m,
                "metres > 0 (or inf)",
            ));
        }
        Ok(ThinLens {
            sensor_width_mm,
            f_number,
            focus_m,
        })
    }

    /// Focal length, mm: (sensor width / 2) / tan(fov_x / 2).
    pub fn focal_length_mm(&self, camera: &Camera) -> f64 {
        0.5 * self.sensor_width_mm / (0.5 * camera.fov_x_rad).tan()
    }

    /// Diameter of the circle of confusion on the sensor, mm, for a point at `depth_m`:
    /// c = |z − z_f| f² / (z (z_f − f) N) (thin lens; z, z_f object distances, f focal
    /// length). Focus at infinity gives f²/(z N). 0 at the focus distance. A focus nearer than
    /// the focal length is treated as focus at the focal length plus 1 mm.
    pub fn coc_diameter_mm(&self, camera: &Camera, depth_m: f64) -> f64 {
        let f = self.focal_length_mm(camera) * 1e-3;
        let z = depth_m.max(f * 1.0001);
        let c_m = if self.focus_m.is_infinite() {
            f * f / (z * self.f_number)
        } else {
            let zf = self.focus_m.max(f + 1e-3);
            (z - zf).abs() * f * f / (z * (zf - f) * self.f_number)
        };
        c_m * 1e3
    }

    /// Circle of confusion in pixels of the picture: c / sensor width × width_px.
    pub fn coc_diameter_px(&self, camera: &Camera, depth_m: f64) -> f64 {
        self.coc_diameter_mm(camera, depth_m) / self.sensor_width_mm * camera.width_px as f64
    }

    /// Defocus blur radius, px: half the circle of confusion.
    pub fn defocus_radius_px(&self, camera: &Camera, depth_m: f64) -> f64 {
        0.5 * self.coc_diameter_px(camera, depth_m)
    }
}

/// Mean alpha (time-averaged coverage) of a pixel inside a streak, after Garg & Nayar.
///
/// Derivation: a drop of image diameter d px covers π d²/4 px² at every instant of the
/// exposure T, so its time-averaged coverage integrates to π d²/4 over the picture whatever
/// its speed. Motion spreads it over the streak's footprint, width w and length ℓ + w
/// (ℓ = image speed × T). So the mean alpha is α = (π/4) d² / (w (ℓ + w)) — for a sharp drop
/// (w = d) that is (π/4) d/(ℓ + d) = (π/4) τ/T with τ = d/s the time the drop spends over a
/// pixel (Garg & Nayar's β = τ/T; the π/4 is a disc's mean chord over its diameter). Defocus
/// of blur diameter b widens the footprint to w = √(d² + b²) and a footprint is never smaller
/// than one pixel (a drop thinner than a pixel dims that pixel by its area fraction).
pub fn streak_alpha(diameter_px: f64, length_px: f64, blur_px: f64) -> f64 {
    let d = diameter_px.max(0.0);
    let w = (d * d + blur_px * blur_px).sqrt().max(1.0);
    let l = (length_px.max(0.0) + w).max(1.0);
    (std::f64::consts::FRAC_PI_4 * d * d / (w * l)).min(1.0)
}

/// Drops thinner than this (px) are drawn this wide, their alpha scaled down (the renderer's
/// `segment_streak`, `shaders/common/streak.wgsl`).
pub const MIN_RADIUS_PX: f64 = 0.7;
/// The renderer's cull: a streak whose peak alpha is below half an 8-bit code value is not
/// drawn. The rain plan leaves out the drop sizes that cannot reach it (`rain::volume::visible`).
pub const MIN_PEAK_ALPHA: f64 = 0.5 / 255.0;
/// Largest drawn radius of a drop, as a fraction of the picture height (near-field drops).
pub const NEAR_FIELD_MAX_RADIUS: f64 = 0.25;

/// Peak alpha on a streak's axis as the renderer draws it: a disc of radius `r_px` blurred by
/// `blur_px` (radius) drawn `r_eff = min(max(√(r² + b²), MIN_RADIUS_PX), max_radius_px)` wide
/// with coverage `r²/r_eff²` (conserved), swept `len_px`: the chord 2 r_eff over the path.
/// It grows with `r_px` and falls with `blur_px` and `len_px`, which is what makes the plan's
/// size bound conservative when fed an upper bound of r and lower bounds of b and ℓ.
pub fn streak_peak_alpha(r_px: f64, blur_px: f64, len_px: f64, max_radius_px: f64) -> f64 {
    let r_eff = (r_px * r_px + blur_px * blur_px)
        .sqrt()
        .max(MIN_RADIUS_PX)
        .min(max_radius_px);
    r_px * r_px / (r_eff * r_eff) * (2.0 * r_eff / len_px.max(1e-3)).min(1.0)
}

/// Time a drop of image diameter `diameter_px` moving at `image_speed_pxps` stays over one
/// pixel, s (Garg & Nayar's τ ≈ d/s; at most ≈ 1.2 ms for real drops, far below an exposure).
pub fn pixel_dwell_time_s(diameter_px: f64, image_speed_pxps: f64) -> f64 {
    diameter_px.max(1.0) / image_speed_pxps.max(f64::MIN_POSITIVE)
}
