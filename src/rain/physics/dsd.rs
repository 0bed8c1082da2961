//! Drop-size distributions: Marshall & Palmer (1948) and gamma shapes of equal water content,
//! truncated to the drops a camera can see, sampled by inverse CDF.

use super::{RainRate, param_error};
use crate::{Error, Result};

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

/// Marshall & Palmer's slope coefficient, mm⁻¹ (Λ = 4.1 R^−0.21).
pub const MP_LAMBDA_COEFF: f64 = 4.1;
/// Marshall & Palmer's slope exponent (Λ = 4.1 R^−0.21).
pub const MP_LAMBDA_EXPONENT: f64 = 0.21;

/// Marshall & Palmer slope Λ = 4.1 R^−0.21, mm⁻¹ (R in mm/h, R > 0).
pub fn mp_lambda_per_mm(rate_mm_per_h: f64) -> f64 {
    MP_LAMBDA_COEFF * rate_mm_per_h.powf(-MP_LAMBDA_EXPONENT)
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
                name: "dsd.diameter_range_mm",
                value: format!("{d_min_mm}..{d_max_mm} mm"),
                expected: format!("0 < minimum < maximum ≤ {D_LIMIT_MM} mm"),
            });
        }
        let mp = DropSizeDistribution::mp(rate, d_min_mm, d_max_mm);
        match shape {
            DsdShape::MarshallPalmer => Ok(mp),
            DsdShape::Gamma { mu } => {
                if !(mu.is_finite() && (-2.0..=15.0).contains(&mu)) {
                    return Err(param_error("dsd.mu", mu, "a gamma shape μ in [−2, 15]"));
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
