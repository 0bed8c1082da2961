//! Rain microphysics and the camera optics that decide how a drop looks on screen.
//!
//! How it works: a rain rate `R` (mm/h) fixes a drop-size distribution (Marshall & Palmer 1948,
//! or a gamma distribution with the same water content), truncated to the drops a camera can
//! see. Each drop takes a constant diameter, drawn by inverse CDF from one uniform number, and
//! falls at its terminal velocity (Gunn & Kinzer 1949, corrected for air density at altitude).
//! The camera turns that motion into a streak: its length is the image-plane distance travelled
//! during the exposure, its width the projected diameter (widened by defocus), and its alpha the
//! fraction of the exposure the drop covers each pixel (Garg & Nayar 2004/2007). Rain farther
//! than the emitter's far distance is folded into an extinction haze (Weber et al. 2015).
//!
//! Everything here is plain `f64` and closed form or a small table, so the GPU can port each
//! per-drop function to WGSL in `f32`; these functions are the CPU reference it is tested
//! against. Units are in the names: `_mm`, `_m`, `_mps`, `_s`, `_px`.

mod dsd;
mod fall;
mod optics;
mod shape;
pub mod splash;
pub mod water;

pub use dsd::*;
pub use fall::*;
pub use optics::*;
pub use shape::*;

use std::fmt;
use std::str::FromStr;

use crate::{Error, Result};

// ------------------------------------------------------------------------------------------
// Rain rate and intensity classes
// ------------------------------------------------------------------------------------------

/// Largest accepted rain rate, mm/h. The world record one-hour rate is about 300 mm/h; 500 leaves
/// room for stylised storms while rejecting typos (e.g. a rate in mm/day).
pub const MAX_RAIN_MM_PER_H: f64 = 500.0;

/// Named rain intensities, after the AMS Glossary ("Rain", "Drizzle") and the WMO-style table
/// light ≤ 2.5, moderate 2.6–10, heavy 10.1–50, violent > 50 mm/h.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RainClass {
    /// Drizzle: below 0.5 mm/h (AMS: heavy drizzle starts at 0.5 mm/h, ≈ 0.02 in/h).
    Drizzle,
    /// Light rain: 0.5 to 2.5 mm/h (AMS and WMO: trace to 2.5 mm/h).
    Light,
    /// Moderate rain: 2.5 to 10 mm/h (WMO; AMS puts the top at 7.6 mm/h).
    Moderate,
    /// Heavy rain: 10 to 50 mm/h (WMO).
    Heavy,
    /// Violent rain: above 50 mm/h (WMO).
    Violent,
}

impl RainClass {
    /// Every class, lightest first.
    pub const ALL: [RainClass; 5] = [
        RainClass::Drizzle,
        RainClass::Light,
        RainClass::Moderate,
        RainClass::Heavy,
        RainClass::Violent,
    ];

    /// The name a user types (`--rain heavy`).
    pub fn name(self) -> &'static str {
        match self {
            RainClass::Drizzle => "drizzle",
            RainClass::Light => "light",
            RainClass::Moderate => "moderate",
            RainClass::Heavy => "heavy",
            RainClass::Violent => "violent",
        }
    }

    /// The rate a named class stands for, mm/h: roughly the geometric middle of the class's
    /// range (drizzle 0.3 inside AMS "moderate drizzle" 0.25–0.5; light 1 in 0.5–2.5; moderate 5
    /// in 2.6–10; heavy 20 in 10–50; violent 75, a typical tropical downpour above 50).
    pub fn representative_mm_per_h(self) -> f64 {
        match self {
            RainClass::Drizzle => 0.3,
            RainClass::Light => 1.0,
            RainClass::Moderate => 5.0,
            RainClass::Heavy => 20.0,
            RainClass::Violent => 75.0,
        }
    }

    /// The class a rate falls in; `None` for no rain (0 mm/h).
    pub fn classify(rate_mm_per_h: f64) -> Option<RainClass> {
        match rate_mm_per_h {
            r if r.is_nan() || r <= 0.0 => None,
            r if r < 0.5 => Some(RainClass::Drizzle),
            r if r <= 2.5 => Some(RainClass::Light),
            r if r <= 10.0 => Some(RainClass::Moderate),
            r if r <= 50.0 => Some(RainClass::Heavy),
            _ => Some(RainClass::Violent),
        }
    }
}

/// A validated rain rate, mm/h, in `[0, MAX_RAIN_MM_PER_H]`; 0 turns rain off.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd)]
pub struct RainRate {
    mm_per_h: f64,
}

impl RainRate {
    /// No rain.
    pub const OFF: RainRate = RainRate { mm_per_h: 0.0 };

    /// A rate in mm/h; rejects NaN, negative and rates above [`MAX_RAIN_MM_PER_H`].
    pub fn from_mm_per_h(mm_per_h: f64) -> Result<RainRate> {
        if mm_per_h.is_finite() && (0.0..=MAX_RAIN_MM_PER_H).contains(&mm_per_h) {
            Ok(RainRate { mm_per_h })
        } else {
            Err(rain_error(mm_per_h.to_string()))
        }
    }

    /// Parses `"12.5"`, `"12.5mm/h"`, `"12.5 mm/h"` or a class name (`"heavy"`), case-insensitive.
    pub fn parse(text: &str) -> Result<RainRate> {
        let t = text.trim().to_ascii_lowercase();
        if let Some(class) = RainClass::ALL.iter().find(|c| c.name() == t) {
            return RainRate::from_mm_per_h(class.representative_mm_per_h());
        }
        let number = t.strip_suffix("mm/h").unwrap_or(&t).trim();
        match number.parse::<f64>() {
            Ok(r) if r.is_finite() && (0.0..=MAX_RAIN_MM_PER_H).contains(&r) => {
                Ok(RainRate { mm_per_h: r })
            }
            _ => Err(rain_error(text.to_string())),
        }
    }

    /// The rate, mm/h.
    pub fn mm_per_h(self) -> f64 {
        self.mm_per_h
    }

    /// Whether rain is off (0 mm/h).
    pub fn is_off(self) -> bool {
        self.mm_per_h <= 0.0
    }

    /// The intensity class; `None` when off.
    pub fn class(self) -> Option<RainClass> {
        RainClass::classify(self.mm_per_h)
    }
}

fn rain_error(value: String) -> Error {
    Error::Parameter {
        name: "rain.rate_mm_per_h",
        value,
        expected: format!(
            "a rate in mm/h from 0 (off) to {MAX_RAIN_MM_PER_H}, or one of drizzle, light, \
             moderate, heavy, violent"
        ),
    }
}

impl FromStr for RainRate {
    type Err = Error;
    fn from_str(s: &str) -> Result<RainRate> {
        RainRate::parse(s)
    }
}

impl fmt::Display for RainRate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} mm/h", self.mm_per_h)
    }
}

pub(super) fn param_error(name: &'static str, value: f64, expected: &str) -> Error {
    Error::Parameter {
        name,
        value: value.to_string(),
        expected: expected.to_string(),
    }
}

// ------------------------------------------------------------------------------------------
// The bundle
// ------------------------------------------------------------------------------------------

/// The physics of one rain: rate, drop sizes, fall speeds.
#[derive(Debug, Clone)]
pub struct RainModel {
    /// The rain rate.
    pub rate: RainRate,
    /// The drop-size distribution.
    pub dsd: DropSizeDistribution,
    /// Terminal velocities at the scene's altitude.
    pub fall: FallSpeed,
    /// The rate over the shot where it changes (`None`: `rate` throughout). `rate` and `dsd`
    /// are then the peak's, and each drop falls or not as [`RainModel::keeps`] says.
    pub rate_keys: Option<crate::keyframes::Curve<f64>>,
}

impl RainModel {
    /// This rain with its rate changing as `keys` say; `self` must be the rain of the keys'
    /// peak rate (the rate the emitter plans for).
    pub fn with_rate_keys(mut self, keys: &crate::keyframes::Curve<f64>) -> RainModel {
        self.rate_keys = (!keys.is_constant()).then(|| keys.clone());
        self
    }

    /// The probability that a drop of diameter `d_mm` drawn from this (peak) rain belongs to
    /// the rain of `rate_mm_per_h`. Marshall–Palmer keeps N₀ and steepens Λ = 4.1 R^−0.21 as
    /// the rate falls, so N(D; R)/N(D; R_peak) = e^{−(Λ(R) − Λ_peak) D} ≤ 1: thinning the peak's
    /// drops by it leaves exactly the Marshall–Palmer drops of R, sizes included (0 at R = 0).
    pub fn keeps(&self, rate_mm_per_h: f64, d_mm: f64) -> f64 {
        if rate_mm_per_h <= 0.0 {
            return 0.0;
        }
        let excess = dsd::mp_lambda_per_mm(rate_mm_per_h) - self.dsd.lambda_per_mm();
        (-excess.max(0.0) * d_mm).exp()
    }

    /// Rain of `rate` with drop sizes of `shape` (default truncation) at `altitude_m`.
    pub fn new(rate: RainRate, shape: DsdShape, altitude_m: f64) -> Result<RainModel> {
        Ok(RainModel {
            rate,
            dsd: DropSizeDistribution::new(rate, shape)?,
            fall: FallSpeed::at_altitude(altitude_m)?,
            rate_keys: None,
        })
    }

    /// Marshall–Palmer rain of `rate` at sea level.
    pub fn marshall_palmer(rate: RainRate) -> RainModel {
        RainModel {
            rate,
            dsd: DropSizeDistribution::marshall_palmer(rate),
            fall: FallSpeed::sea_level(),
            rate_keys: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_rates_and_classes() {
        assert_eq!(RainRate::parse("12.5").unwrap().mm_per_h(), 12.5);
        assert_eq!(RainRate::parse(" 3 mm/h").unwrap().mm_per_h(), 3.0);
        assert_eq!(RainRate::parse("HEAVY").unwrap().mm_per_h(), 20.0);
        assert!(RainRate::parse("0").unwrap().is_off());
        for bad in ["-1", "501", "nan", "inf", "", "soaking"] {
            assert!(RainRate::parse(bad).is_err(), "{bad}");
        }
        // Every representative rate lies in its own class.
        for c in RainClass::ALL {
            assert_eq!(RainClass::classify(c.representative_mm_per_h()), Some(c));
        }
    }

    #[test]
    fn ln_gamma_matches_known_values() {
        let pi = std::f64::consts::PI;
        assert!((ln_gamma(0.5) - pi.sqrt().ln()).abs() < 1e-13);
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-13);
        assert!((ln_gamma(1.0)).abs() < 1e-13);
        // Γ(1.5) = √π / 2.
        assert!((ln_gamma(1.5) - (0.5 * pi.sqrt()).ln()).abs() < 1e-13);
    }

    #[test]
    fn mp_closed_form_density_matches_quadrature() {
        for r in [0.1, 1.0, 10.0, 300.0] {
            let dsd = DropSizeDistribution::marshall_palmer(RainRate::from_mm_per_h(r).unwrap());
            let q = dsd.moment(0.0);
            assert!((q / dsd.number_density_per_m3() - 1.0).abs() < 1e-9, "{r}");
        }
    }

    #[test]
    fn gamma_with_mu_zero_is_marshall_palmer() {
        let rate = RainRate::from_mm_per_h(10.0).unwrap();
        let mp = DropSizeDistribution::marshall_palmer(rate);
        let g = DropSizeDistribution::new(rate, DsdShape::Gamma { mu: 0.0 }).unwrap();
        assert!((g.n0() / MP_N0_PER_M3_MM - 1.0).abs() < 1e-9);
        assert!((g.number_density_per_m3() / mp.number_density_per_m3() - 1.0).abs() < 1e-9);
        for u in [0.0, 0.1, 0.5, 0.9, 0.999, 1.0] {
            let (a, b) = (
                mp.diameter_from_uniform_mm(u),
                g.diameter_from_uniform_mm(u),
            );
            assert!((a - b).abs() < 1e-4, "{u}: {a} {b}");
        }
    }

    #[test]
    fn gamma_keeps_water_content() {
        let rate = RainRate::from_mm_per_h(10.0).unwrap();
        // Untruncated MP water content π ρw N0/Λ⁴ (g/m³); widen the truncation to compare.
        let l = mp_lambda_per_mm(10.0);
        let lwc = std::f64::consts::PI * 1e-3 * 8000.0 / l.powi(4);
        for mu in [-1.0, 2.0, 5.0] {
            let g =
                DropSizeDistribution::truncated(rate, DsdShape::Gamma { mu }, 1e-4, 8.0).unwrap();
            assert!((g.liquid_water_g_per_m3() / lwc - 1.0).abs() < 0.01, "{mu}");
        }
    }

    #[test]
    fn velocity_is_monotone_and_continuous() {
        let mut last = 0.0;
        for i in 0..=700 {
            let v = terminal_velocity_gk_mps(i as f64 * 0.01);
            assert!(v >= last);
            assert!(v - last < 0.06, "jump at {}", i as f64 * 0.01);
            last = v;
        }
    }

    #[test]
    fn velocity_table_tracks_reference() {
        let fall = FallSpeed::sea_level();
        let table = fall.velocity_table(VelocityTable::DEFAULT_LEN, D_MIN_MM, D_MAX_MM);
        let mut worst: f64 = 0.0;
        for i in 10..=600 {
            let d = i as f64 * 0.01;
            let (a, b) = (table.lookup_mps(d), fall.terminal_velocity_mps(d));
            worst = worst.max((a - b).abs());
        }
        assert!(worst < 0.03, "{worst}");
    }

    #[test]
    fn isa_density_matches_standard_table() {
        // ICAO standard atmosphere: 1.2250 kg/m³ at 0 m, 1.1117 at 1000 m, 0.7364 at 5000 m.
        for (h, rho) in [(0.0, 1.2250), (1000.0, 1.1117), (5000.0, 0.7364)] {
            assert!(
                (isa_air_density_kg_per_m3(h) / rho - 1.0).abs() < 1e-3,
                "{h}"
            );
        }
        assert!(FallSpeed::at_altitude(20_000.0).is_err());
        assert!(FallSpeed::at_altitude(f64::NAN).is_err());
    }

    #[test]
    fn axis_ratio_follows_beard_chuang_and_is_clamped() {
        // Beard & Chuang (1987) fit values (pytmatrix/disdrodb): 0.9826 at 1 mm, 0.7061 at 5 mm.
        assert!((axis_ratio(1.0) - 0.9826).abs() < 1e-4);
        assert!((axis_ratio(5.0) - 0.7061).abs() < 1e-4);
        assert_eq!(axis_ratio(0.0), 1.0);
        assert!(axis_ratio(50.0) > 0.5);
        assert!(streak_width_factor(6.0) > 1.1 && streak_width_factor(0.2) == 1.0);
    }

    #[test]
    fn extinction_agrees_with_geometric_optics() {
        // Extinction efficiency 2 for drops ≫ wavelength: β = 2 ∫ N πD²/4 dD = π N0/Λ³.
        for r in [1.0, 10.0, 50.0, 300.0] {
            let l = mp_lambda_per_mm(r);
            let geom = std::f64::consts::PI * 8000.0 / l.powi(3) * 1e-6;
            let beta = extinction_per_m(RainRate::from_mm_per_h(r).unwrap());
            assert!((beta / geom - 1.0).abs() < 0.2, "{r}: {beta} vs {geom}");
        }
        assert_eq!(haze_alpha(RainRate::OFF, 0.0, 1e9), 0.0);
    }

    /// The haze a picture sees keeps the diffracted half of the extinction in the beam: its
    /// transmittance over a path is the square root of the transmissometer's.
    #[test]
    fn the_haze_keeps_the_diffracted_half_in_the_beam() {
        for (r, d) in [(1.0, 500.0), (10.0, 70.0), (75.0, 300.0)] {
            let rate = RainRate::from_mm_per_h(r).unwrap();
            let seen = 1.0 - haze_alpha(rate, 20.0, 20.0 + d);
            let measured = transmittance(rate, d);
            assert!(
                (seen - measured.sqrt()).abs() < 1e-12,
                "{r} mm/h over {d} m"
            );
            assert!(seen > measured);
        }
    }

    #[test]
    fn exposure_from_shutter_angle() {
        assert!((exposure_s(180.0, 25.0).unwrap() - 0.02).abs() < 1e-15);
        assert!(exposure_s(0.0, 25.0).is_err());
        assert!(exposure_s(180.0, 0.0).is_err());
        assert!(exposure_s(361.0, 25.0).is_err());
    }

    #[test]
    fn streak_alpha_limits() {
        // A sharp drop wider than a pixel: (π/4) d/(ℓ + d).
        let a = streak_alpha(4.0, 36.0, 0.0);
        assert!((a - std::f64::consts::FRAC_PI_4 * 0.1).abs() < 1e-12);
        // A still drop covers its disc: π/4.
        assert!((streak_alpha(10.0, 0.0, 0.0) - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        assert_eq!(streak_alpha(0.0, 10.0, 3.0), 0.0);
    }
}
