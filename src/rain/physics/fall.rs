//! Terminal velocity: Gunn & Kinzer (1949) with an air-density correction for altitude, and
//! the emitter's velocity table.

use super::{D_MAX_MM, D_MIN_MM, param_error};
use crate::Result;

// ------------------------------------------------------------------------------------------
// Terminal velocity
// ------------------------------------------------------------------------------------------

/// Standard gravity, m/s².
pub const G_MPS2: f64 = 9.80665;

/// Gunn & Kinzer (1949), "The terminal velocity of fall for water droplets in stagnant air",
/// J. Meteor. 6, 243–248, Table 2: (equivalent diameter mm, terminal velocity m/s), measured at
/// 1013 hPa, 20 °C, 50 % relative humidity.
pub const GUNN_KINZER_1949: [[f64; 2]; 34] = [
    [0.1, 0.27],
    [0.2, 0.72],
    [0.3, 1.17],
    [0.4, 1.62],
    [0.5, 2.06],
    [0.6, 2.47],
    [0.7, 2.87],
    [0.8, 3.27],
    [0.9, 3.67],
    [1.0, 4.03],
    [1.2, 4.64],
    [1.4, 5.17],
    [1.6, 5.65],
    [1.8, 6.09],
    [2.0, 6.49],
    [2.2, 6.90],
    [2.4, 7.27],
    [2.6, 7.57],
    [2.8, 7.82],
    [3.0, 8.06],
    [3.2, 8.26],
    [3.4, 8.44],
    [3.6, 8.60],
    [3.8, 8.72],
    [4.0, 8.83],
    [4.2, 8.92],
    [4.4, 8.98],
    [4.6, 9.03],
    [4.8, 9.07],
    [5.0, 9.09],
    [5.2, 9.12],
    [5.4, 9.14],
    [5.6, 9.16],
    [5.8, 9.17],
];

/// Air density of Gunn & Kinzer's laboratory (1013.25 hPa, 20 °C): p/(R_d T), kg/m³.
pub const GK_AIR_DENSITY_KG_PER_M3: f64 = 1.204;

/// Terminal velocity in Gunn & Kinzer's air, m/s: piecewise-linear (hence monotone)
/// interpolation of [`GUNN_KINZER_1949`]; below 0.1 mm a Stokes-like D² law through the first
/// entry (Stokes drag gives v ∝ D²; 0.30 m/s at 0.1 mm, GK measured 0.27); above 5.8 mm
/// constant (the velocity saturates; Simmel et al. 2002 cap it at 9.17 m/s).
pub fn terminal_velocity_gk_mps(d_mm: f64) -> f64 {
    let t = &GUNN_KINZER_1949;
    let d = d_mm.max(0.0);
    if d <= t[0][0] {
        let x = d / t[0][0];
        return t[0][1] * x * x;
    }
    let i = t.partition_point(|e| e[0] < d);
    if i >= t.len() {
        return t[t.len() - 1][1];
    }
    let ([d0, v0], [d1, v1]) = (t[i - 1], t[i]);
    v0 + (v1 - v0) * (d - d0) / (d1 - d0)
}

/// Air density of the International Standard Atmosphere (troposphere, ICAO 1993), kg/m³:
/// ρ = 1.225 (1 − 2.25577e-5 h)^4.25588, h in metres above sea level (valid to 11 km).
pub fn isa_air_density_kg_per_m3(altitude_m: f64) -> f64 {
    1.225 * (1.0 - 2.25577e-5 * altitude_m).powf(4.25588)
}

/// Terminal fall speeds at one altitude: Gunn & Kinzer scaled by Foote & du Toit's (1969)
/// density correction v = v_GK (ρ_GK/ρ)^0.4, with ρ from the standard atmosphere. At sea level
/// (15 °C) the factor is 0.993; at 2000 m it is 1.074.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FallSpeed {
    altitude_m: f64,
    density_factor: f64,
}

impl FallSpeed {
    /// Lowest and highest accepted altitudes, m (the Dead Sea shore to the tropopause).
    pub const ALTITUDE_RANGE_M: (f64, f64) = (-500.0, 11_000.0);

    /// Fall speeds at `altitude_m` above sea level.
    pub fn at_altitude(altitude_m: f64) -> Result<FallSpeed> {
        let (lo, hi) = FallSpeed::ALTITUDE_RANGE_M;
        if !(altitude_m.is_finite() && (lo..=hi).contains(&altitude_m)) {
            return Err(param_error(
                "rain.altitude_m",
                altitude_m,
                "metres above sea level, from −500 to 11000",
            ));
        }
        let rho = isa_air_density_kg_per_m3(altitude_m);
        Ok(FallSpeed {
            altitude_m,
            density_factor: (GK_AIR_DENSITY_KG_PER_M3 / rho).powf(0.4),
        })
    }

    /// Fall speeds at sea level.
    pub fn sea_level() -> FallSpeed {
        let rho = isa_air_density_kg_per_m3(0.0);
        FallSpeed {
            altitude_m: 0.0,
            density_factor: (GK_AIR_DENSITY_KG_PER_M3 / rho).powf(0.4),
        }
    }

    /// Altitude, m.
    pub fn altitude_m(&self) -> f64 {
        self.altitude_m
    }

    /// The density correction factor (ρ_GK/ρ)^0.4.
    pub fn density_factor(&self) -> f64 {
        self.density_factor
    }

    /// Terminal velocity of a drop of diameter `d_mm`, m/s (a speed, ≥ 0).
    pub fn terminal_velocity_mps(&self, d_mm: f64) -> f64 {
        self.density_factor * terminal_velocity_gk_mps(d_mm)
    }

    /// Time constant τ = v_t/g, s, of a drop's horizontal velocity relaxing to the wind. For a
    /// drag force along the relative velocity balancing gravity at v_t, a small horizontal
    /// relative velocity u decays as du/dt = −g u / v_t, for linear and quadratic drag alike.
    pub fn relaxation_time_s(&self, d_mm: f64) -> f64 {
        self.terminal_velocity_mps(d_mm) / G_MPS2
    }

    /// The terminal velocity at `n ≥ 2` equally spaced diameters from `d_min_mm` to
    /// `d_max_mm` (the size distribution's range), for the GPU (see
    /// [`VelocityTable::lookup_mps`]). With 32 entries over 0.1–6 mm the table is within
    /// 0.03 m/s of the reference.
    pub fn velocity_table(&self, n: usize, d_min_mm: f64, d_max_mm: f64) -> VelocityTable {
        let n = n.max(2);
        let (lo, hi) = if d_min_mm >= 0.0 && d_max_mm > d_min_mm {
            (d_min_mm, d_max_mm)
        } else {
            (D_MIN_MM, D_MAX_MM)
        };
        let step = (hi - lo) / (n - 1) as f64;
        VelocityTable {
            d_min_mm: lo,
            d_max_mm: hi,
            v_mps: (0..n)
                .map(|i| self.terminal_velocity_mps(lo + i as f64 * step) as f32)
                .collect(),
        }
    }
}

/// Terminal velocity sampled at equally spaced diameters `d_min + i (d_max − d_min)/(n−1)`.
/// Small enough to upload as a uniform array (32 entries by default).
#[derive(Debug, Clone, PartialEq)]
pub struct VelocityTable {
    /// Diameter of the first entry, mm.
    pub d_min_mm: f64,
    /// Diameter of the last entry, mm.
    pub d_max_mm: f64,
    /// Velocities, m/s.
    pub v_mps: Vec<f32>,
}

impl VelocityTable {
    /// Default number of entries.
    pub const DEFAULT_LEN: usize = 32;

    /// Spacing of the entries, mm.
    pub fn step_mm(&self) -> f64 {
        (self.d_max_mm - self.d_min_mm) / (self.v_mps.len() - 1) as f64
    }

    /// Linear interpolation, clamped at both ends: the GPU's lookup, in `f64`.
    pub fn lookup_mps(&self, d_mm: f64) -> f64 {
        let n = self.v_mps.len();
        let x = ((d_mm - self.d_min_mm) / self.step_mm()).clamp(0.0, (n - 1) as f64);
        let i = (x as usize).min(n - 2);
        let f = x - i as f64;
        let (a, b) = (self.v_mps[i] as f64, self.v_mps[i + 1] as f64);
        a + f * (b - a)
    }
}
