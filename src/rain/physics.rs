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

use std::fmt;
use std::str::FromStr;

use glam::{DVec2, DVec3};

use crate::scene::Camera;
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
        name: "--rain",
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

fn param_error(name: &'static str, value: f64, expected: &str) -> Error {
    Error::Parameter {
        name,
        value: value.to_string(),
        expected: expected.to_string(),
    }
}

// ------------------------------------------------------------------------------------------
// Drop-size distributions
// ------------------------------------------------------------------------------------------

/// Smallest simulated drop diameter, mm. Smaller drops are drizzle/cloud droplets: at 1 m with a
/// 1/50 s exposure a 0.1 mm drop already leaves an alpha of only ≈ 0.002 (invisible), and the
/// Gunn & Kinzer table starts here.
pub const D_MIN_MM: f64 = 0.1;
/// Largest simulated drop diameter, mm. Drops above about 6 mm break up aerodynamically
/// (Pruppacher & Klett 1997, ch. 10), and Gunn & Kinzer's largest measured drop is 5.8 mm.
pub const D_MAX_MM: f64 = 6.0;
/// Largest accepted truncation diameter, mm (hydrodynamic break-up limit).
pub const D_LIMIT_MM: f64 = 8.0;
/// Marshall & Palmer (1948) intercept N0, m⁻³ mm⁻¹.
pub const MP_N0_PER_M3_MM: f64 = 8000.0;
/// Density of liquid water, g/mm³ (for liquid water content in g/m³ from D in mm).
const WATER_G_PER_MM3: f64 = 1.0e-3;
/// Rate used only to keep Λ finite when rain is off (then N0 = 0 and there are no drops).
const OFF_RATE_MM_PER_H: f64 = 1.0e-3;
/// Intervals of the tabulated CDF of the gamma distribution.
const CDF_INTERVALS: usize = 2048;

/// Marshall & Palmer slope Λ = 4.1 R^−0.21, mm⁻¹ (R in mm/h, R > 0).
pub fn mp_lambda_per_mm(rate_mm_per_h: f64) -> f64 {
    4.1 * rate_mm_per_h.powf(-0.21)
}

/// The shape of the drop-size distribution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DsdShape {
    /// Marshall & Palmer (1948): N(D) = N0 e^{−ΛD}, N0 = 8000 m⁻³ mm⁻¹, Λ = 4.1 R^−0.21 mm⁻¹.
    MarshallPalmer,
    /// Gamma (Ulbrich 1983): N(D) = N0μ D^μ e^{−ΛμD}. Normalised to the Marshall–Palmer
    /// distribution of the same rate: the same median volume diameter D0 = 3.67/Λ (so
    /// Λμ = (3.67 + μ)/D0) and the same liquid water content (fixes N0μ). μ in [−2, 15];
    /// μ = 0 is Marshall–Palmer. Positive μ (2–5 is typical of measured rain) has fewer small
    /// drops.
    Gamma {
        /// Shape parameter μ (dimensionless).
        mu: f64,
    },
}

/// A drop-size distribution truncated to `[d_min_mm, d_max_mm]`, with its sampler.
#[derive(Debug, Clone)]
pub struct DropSizeDistribution {
    shape: DsdShape,
    /// Intercept: m⁻³ mm⁻¹ for Marshall–Palmer, m⁻³ mm^−(1+μ) for gamma; 0 when rain is off.
    n0: f64,
    lambda_per_mm: f64,
    d_min_mm: f64,
    d_max_mm: f64,
    number_density_per_m3: f64,
    /// Gamma only: normalised CDF at `CDF_INTERVALS + 1` equally spaced diameters.
    cdf: Vec<f64>,
}

impl DropSizeDistribution {
    /// The distribution for `rate`, truncated to [`D_MIN_MM`, `D_MAX_MM`].
    pub fn new(rate: RainRate, shape: DsdShape) -> Result<DropSizeDistribution> {
        DropSizeDistribution::truncated(rate, shape, D_MIN_MM, D_MAX_MM)
    }

    /// Marshall–Palmer for `rate` with the default truncation.
    pub fn marshall_palmer(rate: RainRate) -> DropSizeDistribution {
        DropSizeDistribution::mp(rate, D_MIN_MM, D_MAX_MM)
    }

    /// Marshall–Palmer on an already validated range.
    fn mp(rate: RainRate, a: f64, b: f64) -> DropSizeDistribution {
        let (r, n0) = if rate.is_off() {
            (OFF_RATE_MM_PER_H, 0.0)
        } else {
            (rate.mm_per_h(), MP_N0_PER_M3_MM)
        };
        let l = mp_lambda_per_mm(r);
        DropSizeDistribution {
            shape: DsdShape::MarshallPalmer,
            n0,
            lambda_per_mm: l,
            d_min_mm: a,
            d_max_mm: b,
            number_density_per_m3: n0 / l * ((-l * a).exp() - (-l * b).exp()),
            cdf: Vec::new(),
        }
    }

    /// The distribution truncated to `[d_min_mm, d_max_mm]` (0 < d_min < d_max ≤ 8 mm).
    pub fn truncated(
        rate: RainRate,
        shape: DsdShape,
        d_min_mm: f64,
        d_max_mm: f64,
    ) -> Result<DropSizeDistribution> {
        if !(d_min_mm > 0.0 && d_min_mm < d_max_mm && d_max_mm <= D_LIMIT_MM) {
            return Err(Error::Parameter {
                name: "--drop-sizes",
                value: format!("{d_min_mm}..{d_max_mm} mm"),
                expected: format!("0 < minimum < maximum ≤ {D_LIMIT_MM} mm"),
            });
        }
        let mp = DropSizeDistribution::mp(rate, d_min_mm, d_max_mm);
        match shape {
            DsdShape::MarshallPalmer => Ok(mp),
            DsdShape::Gamma { mu } => {
                if !(mu.is_finite() && (-2.0..=15.0).contains(&mu)) {
                    return Err(param_error("--dsd-mu", mu, "a gamma shape μ in [−2, 15]"));
                }
                // Same median volume diameter (Ulbrich 1983: Λ D0 ≈ 3.67 + μ) and the same
                // water content ∫N D³ dD = N0 Γ(4)/Λ⁴ = N0μ Γ(μ+4)/Λμ^(μ+4).
                let (lambda_mp, n0_mp) = (mp.lambda_per_mm, mp.n0);
                let d0 = 3.67 / lambda_mp;
                let lambda = (3.67 + mu) / d0;
                let n0 = n0_mp * 6.0 / lambda_mp.powi(4)
                    * ((mu + 4.0) * lambda.ln() - ln_gamma(mu + 4.0)).exp();
                let mut dsd = DropSizeDistribution {
                    shape,
                    n0,
                    lambda_per_mm: lambda,
                    d_min_mm,
                    d_max_mm,
                    number_density_per_m3: 0.0,
                    cdf: Vec::new(),
                };
                // Cumulative Simpson integral on a fine grid: the sampler's table.
                let h = (d_max_mm - d_min_mm) / CDF_INTERVALS as f64;
                let mut cdf = Vec::with_capacity(CDF_INTERVALS + 1);
                let mut acc = 0.0;
                cdf.push(0.0);
                for i in 0..CDF_INTERVALS {
                    let x0 = d_min_mm + i as f64 * h;
                    acc += h / 6.0
                        * (dsd.density_per_m3_mm(x0)
                            + 4.0 * dsd.density_per_m3_mm(x0 + 0.5 * h)
                            + dsd.density_per_m3_mm(x0 + h));
                    cdf.push(acc);
                }
                dsd.number_density_per_m3 = acc;
                if acc > 0.0 {
                    cdf.iter_mut().for_each(|c| *c /= acc);
                } else {
                    // Rain off: a flat CDF keeps the sampler defined.
                    let n = cdf.len() as f64 - 1.0;
                    cdf.iter_mut()
                        .enumerate()
                        .for_each(|(i, c)| *c = i as f64 / n);
                }
                dsd.cdf = cdf;
                Ok(dsd)
            }
        }
    }

    /// The distribution's shape.
    pub fn shape(&self) -> DsdShape {
        self.shape
    }

    /// The slope Λ, mm⁻¹.
    pub fn lambda_per_mm(&self) -> f64 {
        self.lambda_per_mm
    }

    /// The intercept N0 (m⁻³ mm⁻¹ for Marshall–Palmer; m⁻³ mm^−(1+μ) for gamma; 0 when off).
    pub fn n0(&self) -> f64 {
        self.n0
    }

    /// Truncation range, mm.
    pub fn range_mm(&self) -> (f64, f64) {
        (self.d_min_mm, self.d_max_mm)
    }

    /// N(D), drops per m³ per mm of diameter; 0 outside the truncation range.
    pub fn density_per_m3_mm(&self, d_mm: f64) -> f64 {
        if !(self.d_min_mm..=self.d_max_mm).contains(&d_mm) {
            return 0.0;
        }
        let e = (-self.lambda_per_mm * d_mm).exp();
        match self.shape {
            DsdShape::MarshallPalmer => self.n0 * e,
            DsdShape::Gamma { mu } => self.n0 * d_mm.powf(mu) * e,
        }
    }

    /// Drops per m³ with diameters in the truncation range. For Marshall–Palmer this is the
    /// closed form N0/Λ (e^{−ΛDmin} − e^{−ΛDmax}); 0 when rain is off.
    pub fn number_density_per_m3(&self) -> f64 {
        self.number_density_per_m3
    }

    /// Fraction of drops with diameter ≤ `d_mm`.
    pub fn cdf(&self, d_mm: f64) -> f64 {
        let (a, b) = (self.d_min_mm, self.d_max_mm);
        let d = d_mm.clamp(a, b);
        match self.shape {
            DsdShape::MarshallPalmer => {
                let l = self.lambda_per_mm;
                -(-l * (d - a)).exp_m1() / -(-l * (b - a)).exp_m1()
            }
            DsdShape::Gamma { .. } => {
                let x = (d - a) / (b - a) * CDF_INTERVALS as f64;
                let i = (x.floor() as usize).min(CDF_INTERVALS - 1);
                let f = x - i as f64;
                self.cdf[i] + f * (self.cdf[i + 1] - self.cdf[i])
            }
        }
    }

    /// Inverse CDF: the diameter (mm) of a drop drawn with uniform `u` in [0, 1].
    ///
    /// Marshall–Palmer is closed form and branch-free (the GPU's formula):
    /// `D = Dmin − ln(1 − u (1 − e^{−Λ(Dmax−Dmin)})) / Λ`. Gamma inverts the tabulated CDF.
    pub fn diameter_from_uniform_mm(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        let (a, b) = (self.d_min_mm, self.d_max_mm);
        match self.shape {
            DsdShape::MarshallPalmer => {
                let l = self.lambda_per_mm;
                let span = -(-l * (b - a)).exp_m1();
                (a - (-u * span).ln_1p() / l).clamp(a, b)
            }
            DsdShape::Gamma { .. } => {
                let i = self
                    .cdf
                    .partition_point(|&c| c <= u)
                    .clamp(1, CDF_INTERVALS)
                    - 1;
                let (c0, c1) = (self.cdf[i], self.cdf[i + 1]);
                let f = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.0 };
                let h = (b - a) / CDF_INTERVALS as f64;
                (a + (i as f64 + f.clamp(0.0, 1.0)) * h).clamp(a, b)
            }
        }
    }

    /// The inverse CDF tabulated at `n ≥ 2` equally spaced `u = i/(n−1)`, for the GPU (linear
    /// interpolation in `u` between entries).
    pub fn inverse_cdf_table(&self, n: usize) -> Vec<f32> {
        let n = n.max(2);
        (0..n)
            .map(|i| self.diameter_from_uniform_mm(i as f64 / (n - 1) as f64) as f32)
            .collect()
    }

    /// ∫ N(D) D^k dD over the truncation range (Simpson, 2048 intervals), m⁻³ mm^k.
    pub fn moment(&self, k: f64) -> f64 {
        let (a, b) = (self.d_min_mm, self.d_max_mm);
        simpson(
            |d| self.density_per_m3_mm(d) * d.powf(k),
            a,
            b,
            CDF_INTERVALS,
        )
    }

    /// Mass-weighted mean diameter Dm = M4/M3 of the truncated distribution, mm (≈ 4/Λ for
    /// Marshall–Palmer). Falls back to the range's middle when rain is off.
    pub fn mass_weighted_diameter_mm(&self) -> f64 {
        let m3 = self.moment(3.0);
        if m3 > 0.0 {
            self.moment(4.0) / m3
        } else {
            0.5 * (self.d_min_mm + self.d_max_mm)
        }
    }

    /// Liquid water content of the truncated distribution, g/m³: ρw π/6 ∫N D³ dD
    /// (≈ 0.0889 R^0.84 for untruncated Marshall–Palmer).
    pub fn liquid_water_g_per_m3(&self) -> f64 {
        WATER_G_PER_MM3 * std::f64::consts::PI / 6.0 * self.moment(3.0)
    }
}

/// Composite Simpson's rule with `n` intervals.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    (0..n)
        .map(|i| {
            let x = a + i as f64 * h;
            h / 6.0 * (f(x) + 4.0 * f(x + 0.5 * h) + f(x + h))
        })
        .sum()
}

/// ln Γ(x) for x > 0 (Lanczos approximation, g = 7, 9 terms; relative error ≈ 1e-15).
#[allow(clippy::excessive_precision)]
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_93,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_13,
        -176.615_029_162_140_59,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_571_6e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1−x) = π / sin(πx).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).abs().ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

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
                "--altitude",
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

// ------------------------------------------------------------------------------------------
// Drop shape
// ------------------------------------------------------------------------------------------

/// Axis ratio b/a (vertical over horizontal) of a falling drop of equivalent diameter `d_mm`:
/// Beard & Chuang (1987) polynomial 1.0048 + 5.7e-4 D − 2.628e-2 D² + 3.682e-3 D³ − 1.677e-4 D⁴,
/// with D clamped to [0, 7] mm (its fitted range) and the ratio to ≤ 1 (small drops are
/// spheres).
pub fn axis_ratio(d_mm: f64) -> f64 {
    let d = d_mm.clamp(0.0, 7.0);
    let r = 1.0048 + d * (5.7e-4 + d * (-2.628e-2 + d * (3.682e-3 + d * -1.677e-4)));
    r.min(1.0)
}

/// Horizontal diameter over equivalent diameter, r^−1/3: an oblate spheroid of volume πD³/6
/// and axis ratio r has horizontal axis D r^−1/3, which is the width of a streak seen from the
/// side (1.0 for small drops, 1.16 at 6 mm).
pub fn streak_width_factor(d_mm: f64) -> f64 {
    axis_ratio(d_mm).powf(-1.0 / 3.0)
}

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

/// Opacity of the rain between `from_m` and `to_m` along a ray (the haze that stands for drops
/// too far to draw one by one): 1 − e^{−β (to − from)}, 0 when `to ≤ from`.
pub fn haze_alpha(rate: RainRate, from_m: f64, to_m: f64) -> f64 {
    let d = (to_m - from_m).max(0.0);
    -(-extinction_per_m(rate) * d).exp_m1()
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
            "--shutter",
            shutter_angle_deg,
            "degrees in (0, 360]",
        ));
    }
    if !(fps.is_finite() && fps > 0.0 && fps <= 1000.0) {
        return Err(param_error("--fps", fps, "frames per second in (0, 1000]"));
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
                "--sensor-width",
                sensor_width_mm,
                "millimetres > 0",
            ));
        }
        if !(f_number.is_finite() && (0.5..=64.0).contains(&f_number)) {
            return Err(param_error(
                "--f-number",
                f_number,
                "an f-number in [0.5, 64]",
            ));
        }
        if focus_m.is_nan() || focus_m <= 0.0 {
            return Err(param_error("--focus", focus_m, "metres > 0 (or inf)"));
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

/// Time a drop of image diameter `diameter_px` moving at `image_speed_pxps` stays over one
/// pixel, s (Garg & Nayar's τ ≈ d/s; at most ≈ 1.2 ms for real drops, far below an exposure).
pub fn pixel_dwell_time_s(diameter_px: f64, image_speed_pxps: f64) -> f64 {
    diameter_px.max(1.0) / image_speed_pxps.max(f64::MIN_POSITIVE)
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
}

impl RainModel {
    /// Rain of `rate` with drop sizes of `shape` (default truncation) at `altitude_m`.
    pub fn new(rate: RainRate, shape: DsdShape, altitude_m: f64) -> Result<RainModel> {
        Ok(RainModel {
            rate,
            dsd: DropSizeDistribution::new(rate, shape)?,
            fall: FallSpeed::at_altitude(altitude_m)?,
        })
    }

    /// Marshall–Palmer rain of `rate` at sea level.
    pub fn marshall_palmer(rate: RainRate) -> RainModel {
        RainModel {
            rate,
            dsd: DropSizeDistribution::marshall_palmer(rate),
            fall: FallSpeed::sea_level(),
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
