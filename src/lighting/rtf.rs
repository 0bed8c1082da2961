//! The raindrop radiance-transfer function (RTF): geometric optics of a sphere (thesis 5.1.2,
//! eq. 5.4–5.16, Algorithm 1 `Computar_RTF`, after Wang et al. 2006).
//!
//! ## What the RTF is here
//!
//! A drop seen along the view ray `v` (unit, **eye → drop**) has the mean radiance, over its
//! projected disc, `L_drop(v) = ∫ L_env(ω) F(θ) dω`, where `ω` is the environment lookup
//! direction (pointing **towards** the light source) and `θ = ∠(ω, v)`, `cos θ = ω·v`. So θ is
//! the *scattering angle*: θ = 0 is light from straight behind the drop passing through it
//! undeviated (order 2 at normal incidence), θ = π is light from behind the eye reflected
//! straight back (order 1 at normal incidence). `F` (sr⁻¹) is the drop's phase function,
//! normalised so that `∫ F dω = Σ_n ε_n` (1 with all orders): a drop in a uniform environment of
//! radiance 1 has radiance 1. The thesis's `D = I_n/I_in` (5.14) equals `π F`, and its θ is
//! measured from the source side (`θ_thesis = π − θ`); measuring from `−v` instead of `v` flips
//! the zonal coefficients by `(−1)^l`.
//!
//! ## How it works
//!
//! A ray at incidence γ refracts to β = asin(sin γ/ρ) (5.4) and leaves after `n − 2` internal
//! reflections deflected by `ψ_n = (n−1)(2β − π) − 2γ + π` (5.5); `θ_n = arccos(cos ψ_n)`.
//! Parallel light through impact parameters in dγ carries the power fraction `sin 2γ dγ`, of
//! which order n keeps `w_n(γ)`: `R` for n = 1, `T² R^{n−2}` for n ≥ 2 (5.10). `Σ_n w_n = 1`
//! (`R + T²/(1−R) = 1`), so the tail beyond `n_max` is `T R^{n_max−1}` in closed form.
//!
//! The table follows the thesis's bin-averaged method (5.13)–(5.14): θ ∈ [0, π] is cut into
//! equal bins J_m of width Δ and γ ∈ [0, π/2] into bins J_k of the same width; bin m receives
//! `Σ_k ∫_{J_k ∩ Θ_n⁻¹(J_m)} w_n sin 2γ dγ`, divided by its solid angle. Bin averages stay finite
//! at the rainbow caustics (where dψ/dγ = 0) and at ρ = 1 (all energy in bin 0). Two
//! refinements over Algorithm 1: the overlaps `J_k ∩ Θ_n⁻¹(J_m)` are exact (the preimages of
//! the bin edges are solved for on each monotone piece of ψ_n instead of interpolating ψ
//! linearly between γ samples), and `μ` is integrated over each overlap (6-point Gauss) instead
//! of being taken at the γ-bin centre; the bin's solid angle is the exact `2π(cos mΔ −
//! cos(m+1)Δ)` instead of `2πΔ sin α_m`. The sweep is still linear: every monotone piece of ψ_n
//! (split at the extremum m_n, like the two sweeps of Algorithm 1) is walked once, merging the
//! γ-bin edges with the θ-bin-edge crossings in order. For ρ → 1 the Fresnel factors change
//! within `√(1 − 1/ρ²)` of grazing incidence, so extra γ edges are graded geometrically there.
//!
//! Polarisation: for unpolarised light the s and p components never mix in a sphere (every
//! interface of a path shares one plane of incidence), so the exact weight is
//! `½(w_n^s + w_n^p)` ([`Polarisation::Separate`], the default: exact for unpolarised light at
//! the same cost). The thesis's and Wang's product of averaged reflectances
//! ([`Polarisation::Averaged`]) is exact only for n = 1; it overstates the primary bow by ~8 %.

use glam::DVec3;

use crate::lighting::sh;
use crate::{Error, Result};

/// Refractive index of water relative to air in the visible (≈ 589 nm).
pub const WATER_RHO: f64 = 1.333;
/// Per-channel indices (R ≈ 656 nm, G ≈ 546 nm, B ≈ 450 nm) for rainbow dispersion.
pub const WATER_RHO_RGB: [f64; 3] = [1.331, 1.333, 1.337];
/// Default highest order (thesis 5.16, after Wang et al.).
pub const DEFAULT_N_MAX: usize = 9;
/// Default number of θ bins of the table.
pub const DEFAULT_BINS: usize = 1024;
/// Largest accepted `n_max` (the tail beyond 64 orders is below 1e-6 for water).
pub const MAX_N_MAX: usize = 64;
/// Largest accepted number of bins (0.003° per bin).
pub const MAX_BINS: usize = 1 << 16;

/// How Fresnel factors combine along a path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum Polarisation {
    /// s and p carried separately and averaged at the exit (exact for unpolarised light).
    #[default]
    Separate,
    /// Unpolarised reflectance `(R_s + R_p)/2` at every interface (thesis, Wang et al.).
    Averaged,
}

/// Refractive indices per colour channel (R, G, B); a single value applies to all three.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelIndices(pub [f64; 3]);

impl From<f64> for ChannelIndices {
    fn from(rho: f64) -> Self {
        ChannelIndices([rho; 3])
    }
}

impl From<[f64; 3]> for ChannelIndices {
    fn from(rho: [f64; 3]) -> Self {
        ChannelIndices(rho)
    }
}

impl ChannelIndices {
    /// True when all three channels share one index.
    pub fn is_single(&self) -> bool {
        self.0[0] == self.0[1] && self.0[1] == self.0[2]
    }
}

/// Fresnel reflectances `(R_s, R_p)` for light in air meeting a medium of relative index
/// `rho ≥ 1` at incidence cosine `cos_i` (Prahl's B4–B9 in cosine form, finite everywhere:
/// `R = 0` for ρ = 1, `R → 1` at grazing incidence for ρ > 1). By reciprocity the same values
/// hold for the internal reflection at the refraction angle β.
pub fn fresnel(rho: f64, cos_i: f64) -> (f64, f64) {
    if rho == 1.0 {
        return (0.0, 0.0);
    }
    let ci = cos_i.clamp(0.0, 1.0);
    let sin_t2 = (1.0 - ci * ci) / (rho * rho);
    let ct = (1.0 - sin_t2).max(0.0).sqrt();
    let rs = (ci - rho * ct) / (ci + rho * ct);
    let rp = (rho * ci - ct) / (rho * ci + ct);
    (rs * rs, rp * rp)
}

/// Folds a deflection ψ onto the scattering angle `arccos(cos ψ) ∈ [0, π]` (5.6–5.7).
pub fn fold_angle(psi: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    (psi - two_pi * (psi / two_pi).round()).abs()
}

/// Scattering angle of the order-n caustic (Descartes' minimum deviation,
/// `cos²γ = (ρ²−1)/(n(n−2))`), if order n has one (n ≥ 3 and ρ < n − 1).
pub fn caustic_angle_rad(rho: f64, n: usize) -> Option<f64> {
    let optics = DropOptics::new(rho, n.max(1)).ok()?;
    let g = optics.extremum_rad(n)?;
    Some(optics.scattering_angle_rad(n, g))
}

/// The optics of one drop: relative index, highest order, polarisation handling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DropOptics {
    rho: f64,
    n_max: usize,
    polarisation: Polarisation,
}

/// Per-γ Fresnel factors, computed once and reused by every order.
#[derive(Debug, Clone, Copy)]
struct Fresnel {
    rs: f64,
    rp: f64,
}

impl DropOptics {
    /// A drop of relative index `rho` (≥ 1) keeping orders `1..=n_max`.
    pub fn new(rho: f64, n_max: usize) -> Result<DropOptics> {
        if !(rho.is_finite() && (1.0..=10.0).contains(&rho)) {
            return Err(Error::Parameter {
                name: "rho",
                value: rho.to_string(),
                expected: "a refractive index in [1, 10] (water ≈ 1.333)".into(),
            });
        }
        if !(1..=MAX_N_MAX).contains(&n_max) {
            return Err(Error::Parameter {
                name: "light.n_max",
                value: n_max.to_string(),
                expected: format!("an order in 1..={MAX_N_MAX}"),
            });
        }
        Ok(DropOptics {
            rho,
            n_max,
            polarisation: Polarisation::default(),
        })
    }

    /// The same drop with another polarisation treatment.
    pub fn with_polarisation(mut self, polarisation: Polarisation) -> DropOptics {
        self.polarisation = polarisation;
        self
    }

    /// Relative refractive index ρ.
    pub fn rho(&self) -> f64 {
        self.rho
    }

    /// Highest order kept.
    pub fn n_max(&self) -> usize {
        self.n_max
    }

    /// Polarisation treatment.
    pub fn polarisation(&self) -> Polarisation {
        self.polarisation
    }

    /// Refraction angle β = asin(sin γ / ρ) (5.4).
    pub fn refraction_angle_rad(&self, gamma: f64) -> f64 {
        (gamma.sin() / self.rho).clamp(-1.0, 1.0).asin()
    }

    /// Deflection ψ_n(γ) = (n−1)(2β − π) − 2γ + π (5.5); ψ_1 = π − 2γ.
    pub fn deflection_rad(&self, n: usize, gamma: f64) -> f64 {
        let beta = self.refraction_angle_rad(gamma);
        (n as f64 - 1.0) * (2.0 * beta - std::f64::consts::PI) - 2.0 * gamma + std::f64::consts::PI
    }

    /// dψ_n/dγ = 2(n−1) cos γ / (ρ cos β) − 2.
    pub fn deflection_slope(&self, n: usize, gamma: f64) -> f64 {
        let dbeta = if self.rho == 1.0 {
            1.0
        } else {
            let s = gamma.sin() / self.rho;
            gamma.cos() / (self.rho * (1.0 - s * s).max(1e-300).sqrt())
        };
        2.0 * (n as f64 - 1.0) * dbeta - 2.0
    }

    /// Scattering angle θ_n(γ) ∈ [0, π] (5.7, measured from the forward direction).
    pub fn scattering_angle_rad(&self, n: usize, gamma: f64) -> f64 {
        fold_angle(self.deflection_rad(n, gamma))
    }

    /// The interior extremum m_n of ψ_n on (0, π/2), where `cos² m_n = (ρ²−1)/(n(n−2))`: the
    /// rainbow caustic of order n. `None` for n ≤ 2, ρ = 1 or ρ ≥ n − 1.
    pub fn extremum_rad(&self, n: usize) -> Option<f64> {
        if n < 3 {
            return None;
        }
        let c2 = (self.rho * self.rho - 1.0) / (n * (n - 2)) as f64;
        (c2 > 0.0 && c2 < 1.0).then(|| c2.sqrt().acos())
    }

    fn fresnel_at(&self, gamma: f64) -> Fresnel {
        let (rs, rp) = fresnel(self.rho, gamma.cos());
        Fresnel { rs, rp }
    }

    fn order_weight(&self, f: Fresnel, n: usize) -> f64 {
        let w = |r: f64| {
            if n == 1 {
                r
            } else {
                (1.0 - r) * (1.0 - r) * r.powi(n as i32 - 2)
            }
        };
        match self.polarisation {
            Polarisation::Separate => 0.5 * (w(f.rs) + w(f.rp)),
            Polarisation::Averaged => w(0.5 * (f.rs + f.rp)),
        }
    }

    fn tail(&self, f: Fresnel) -> f64 {
        // Σ_{n > N} T² R^{n−2} = T² R^{N−1} / (1 − R) = T R^{N−1}.
        let t = |r: f64| (1.0 - r) * r.powi(self.n_max as i32 - 1);
        match self.polarisation {
            Polarisation::Separate => 0.5 * (t(f.rs) + t(f.rp)),
            Polarisation::Averaged => t(0.5 * (f.rs + f.rp)),
        }
    }

    /// Power fraction w_n(γ) of order n (5.10): R for n = 1, T² R^{n−2} for n ≥ 2.
    pub fn weight(&self, n: usize, gamma: f64) -> f64 {
        self.order_weight(self.fresnel_at(gamma), n)
    }

    /// Power fraction of all orders beyond n_max at incidence γ, `T R^{n_max−1}`.
    pub fn tail_weight(&self, gamma: f64) -> f64 {
        self.tail(self.fresnel_at(gamma))
    }

    /// Breakpoints graded geometrically towards grazing incidence, where the Fresnel factors
    /// change over a width `√(1 − 1/ρ²)` in γ (tiny when ρ → 1; empty for ρ = 1).
    fn grazing_breaks(&self) -> Vec<f64> {
        let half_pi = std::f64::consts::FRAC_PI_2;
        let width = (1.0 - 1.0 / (self.rho * self.rho)).sqrt();
        if width == 0.0 {
            return Vec::new();
        }
        (0..60)
            .map(|j| half_pi - 4.0 * width * 0.5f64.powi(j))
            .filter(|g| *g > 0.0 && half_pi - g > 1e-14)
            .collect()
    }

    /// γ quadrature nodes on [0, π/2] split at every order's extremum and graded towards
    /// grazing incidence (composite 8-point Gauss, about `panels` panels over the range).
    fn gamma_nodes(&self, panels: usize) -> Vec<(f64, f64)> {
        let half_pi = std::f64::consts::FRAC_PI_2;
        let mut cuts = vec![0.0, half_pi];
        cuts.extend((3..=self.n_max).filter_map(|n| self.extremum_rad(n)));
        cuts.extend(self.grazing_breaks());
        cuts.sort_by(f64::total_cmp);
        cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-15);
        let mut nodes = Vec::new();
        for w in cuts.windows(2) {
            let p = ((w[1] - w[0]) / half_pi * panels as f64).ceil().max(1.0) as usize;
            nodes.extend(sh::composite_gauss(w[0], w[1], p, 8));
        }
        nodes
    }

    /// Energy fraction per order, `ε_n = ∫₀^{π/2} w_n(γ) sin 2γ dγ`, n = 1..=n_max.
    pub fn energy_per_order(&self) -> Vec<f64> {
        let mut e = vec![0.0; self.n_max];
        for (g, w) in self.gamma_nodes(64) {
            let f = self.fresnel_at(g);
            let s = w * (2.0 * g).sin();
            for (n, en) in e.iter_mut().enumerate() {
                *en += s * self.order_weight(f, n + 1);
            }
        }
        e
    }

    /// Energy fraction of the orders beyond n_max, integrated from the closed-form tail
    /// `T R^{n_max−1}` (independent of the per-order sums).
    pub fn tail_energy(&self) -> f64 {
        self.gamma_nodes(64)
            .iter()
            .map(|(g, w)| w * (2.0 * g).sin() * self.tail_weight(*g))
            .sum()
    }

    /// Zonal SH coefficients of F about the view ray, integrated over γ (no caustic
    /// singularities): `z_l = Σ_n ∫ w_n(γ) sin 2γ Y_l0(cos ψ_n(γ)) dγ`, l = 0..bands-1.
    pub fn zonal(&self, bands: usize) -> Vec<f64> {
        let mut z = vec![0.0; bands];
        let k: Vec<f64> = (0..bands).map(|l| sh::k_norm(l, 0)).collect();
        for (g, w) in self.gamma_nodes(256) {
            let f = self.fresnel_at(g);
            let s = w * (2.0 * g).sin();
            for n in 1..=self.n_max {
                let c = self.deflection_rad(n, g).cos();
                let a = s * self.order_weight(f, n);
                let (mut p0, mut p1) = (1.0, c);
                for (l, zl) in z.iter_mut().enumerate() {
                    let p = match l {
                        0 => 1.0,
                        1 => c,
                        _ => {
                            let p2 = ((2 * l - 1) as f64 * c * p1 - (l - 1) as f64 * p0) / l as f64;
                            p0 = p1;
                            p1 = p2;
                            p2
                        }
                    };
                    *zl += a * k[l] * p;
                }
            }
        }
        z
    }

    /// Tabulates F per order over `bins` equal θ bins on [0, π] (5.13–5.16).
    pub fn tabulate(&self, bins: usize) -> Result<RtfTable> {
        if !(2..=MAX_BINS).contains(&bins) {
            return Err(Error::Parameter {
                name: "rtf.bins",
                value: bins.to_string(),
                expected: format!("an integer in 2..={MAX_BINS}"),
            });
        }
        let delta = std::f64::consts::PI / bins as f64;
        let mut per_order = Vec::with_capacity(self.n_max);
        for n in 1..=self.n_max {
            let mut energy = vec![0.0; bins];
            self.sweep_order(n, bins, &mut energy);
            for (m, e) in energy.iter_mut().enumerate() {
                *e /= bin_solid_angle_sr(m, delta);
            }
            per_order.push(energy);
        }
        let total = (0..bins)
            .map(|m| per_order.iter().map(|o| o[m]).sum())
            .collect();
        Ok(RtfTable {
            bins,
            optics: *self,
            per_order,
            total,
        })
    }

    /// Adds order n's energy per θ bin into `energy` (Algorithm 1, with exact overlaps).
    fn sweep_order(&self, n: usize, bins: usize, energy: &mut [f64]) {
        let half_pi = std::f64::consts::FRAC_PI_2;
        let delta = std::f64::consts::PI / bins as f64;
        let (gx, gw) = sh::gauss_legendre(6);
        let integral = |a: f64, b: f64| -> f64 {
            let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
            gx.iter()
                .zip(&gw)
                .map(|(x, w)| {
                    let g = c + h * x;
                    w * h * (2.0 * g).sin() * self.weight(n, g)
                })
                .sum()
        };
        // ψ-band k (ψ ∈ (kΔ, (k+1)Δ)) → θ bin, with exact integer folding (θ edges mΔ map to
        // the ψ levels 2πj ± mΔ, all multiples of Δ because π = bins·Δ).
        let two_b = 2 * bins as i64;
        let bin_of = |k: i64| -> usize {
            let k = k.rem_euclid(two_b);
            if k < bins as i64 {
                k as usize
            } else {
                (two_b - 1 - k) as usize
            }
        };
        // γ-bin edges J_k (plus grading towards grazing incidence), sorted.
        let mut edges: Vec<f64> = (1..)
            .map(|k| k as f64 * delta)
            .take_while(|g| *g < half_pi)
            .collect();
        edges.extend(self.grazing_breaks());
        edges.sort_by(f64::total_cmp);
        edges.push(half_pi);
        let mut cuts = vec![0.0];
        if let Some(g) = self.extremum_rad(n) {
            cuts.push(g);
        }
        cuts.push(half_pi);
        for piece in cuts.windows(2) {
            let (a, b) = (piece[0], piece[1]);
            let (pa, pb) = (self.deflection_rad(n, a), self.deflection_rad(n, b));
            // ψ constant (ρ = 1, order 2): the whole piece lands in one bin, no crossings.
            let flat = (pb - pa).abs() <= 1e-13 * delta;
            let down = pb < pa;
            // First ψ band and the last level crossed strictly inside (pb, pa) or (pa, pb).
            let (mut k, k_last) = if flat {
                ((0.5 * (pa + pb) / delta).floor() as i64, i64::MIN)
            } else if down {
                (
                    (pa / delta).ceil() as i64 - 1,
                    (pb / delta).floor() as i64 + 1,
                )
            } else {
                ((pa / delta).floor() as i64, (pb / delta).ceil() as i64 - 1)
            };
            // The next level to cross, and the γ of that crossing.
            let mut next_level = if down { k } else { k + 1 };
            let more_levels = |l: i64| !flat && if down { l >= k_last } else { l <= k_last };
            let mut cur = a;
            let mut next_root = if more_levels(next_level) {
                self.solve_deflection(n, next_level as f64 * delta, cur, b)
            } else {
                f64::INFINITY
            };
            let mut j_edge = edges.partition_point(|g| *g <= a); // next γ edge
            while cur < b {
                let edge = edges[j_edge.min(edges.len() - 1)].min(b);
                let end = edge.min(next_root).max(cur);
                energy[bin_of(k)] += integral(cur, end);
                if end >= next_root {
                    k += if down { -1 } else { 1 };
                    next_level += if down { -1 } else { 1 };
                    next_root = if more_levels(next_level) {
                        self.solve_deflection(n, next_level as f64 * delta, end, b)
                    } else {
                        f64::INFINITY
                    };
                }
                if end >= edge {
                    j_edge += 1;
                }
                if end >= b {
                    break;
                }
                cur = end;
            }
        }
    }

    /// γ in [lo, hi] with ψ_n(γ) = level, on a monotone piece (safeguarded Newton).
    fn solve_deflection(&self, n: usize, level: f64, lo: f64, hi: f64) -> f64 {
        let f = |g: f64| self.deflection_rad(n, g) - level;
        let (mut lo, mut hi) = (lo, hi);
        let (flo, fhi) = (f(lo), f(hi));
        if flo == 0.0 {
            return lo;
        }
        if fhi == 0.0 || flo.signum() == fhi.signum() {
            // Rounding at an end of the piece: the crossing sits on that end.
            return if flo.abs() < fhi.abs() { lo } else { hi };
        }
        let rising = fhi > 0.0;
        let mut g = lo + (hi - lo) * flo / (flo - fhi);
        for _ in 0..200 {
            let v = f(g);
            if v == 0.0 {
                return g;
            }
            if (v > 0.0) == rising {
                hi = g;
            } else {
                lo = g;
            }
            if hi - lo <= 4.0 * f64::EPSILON * hi.max(1e-300) {
                break;
            }
            let slope = self.deflection_slope(n, g);
            let newton = g - v / slope;
            g = if slope != 0.0 && newton > lo && newton < hi && (v / slope).abs() < 0.5 * (hi - lo)
            {
                newton
            } else {
                0.5 * (lo + hi)
            };
        }
        g.clamp(lo, hi)
    }
}

/// Exact solid angle of θ bin m of width Δ: `2π (cos mΔ − cos (m+1)Δ)`.
pub fn bin_solid_angle_sr(m: usize, delta: f64) -> f64 {
    let (a, b) = (m as f64 * delta, (m + 1) as f64 * delta);
    // 4π sin((a+b)/2) sin((b−a)/2): no cancellation near θ = 0.
    4.0 * std::f64::consts::PI * (0.5 * (a + b)).sin() * (0.5 * (b - a)).sin()
}

/// The tabulated RTF: bin averages of F (sr⁻¹) over θ bins `[mΔ, (m+1)Δ)`, Δ = π/bins.
#[derive(Debug, Clone)]
pub struct RtfTable {
    /// Number of θ bins.
    pub bins: usize,
    /// The optics it was computed for.
    pub optics: DropOptics,
    /// `per_order[n−1][m]`: F of order n in bin m, sr⁻¹.
    pub per_order: Vec<Vec<f64>>,
    /// `Σ_n per_order[n−1][m]` (5.16).
    pub total: Vec<f64>,
}

impl RtfTable {
    /// Bin width Δ = π/bins, radians.
    pub fn bin_width_rad(&self) -> f64 {
        std::f64::consts::PI / self.bins as f64
    }

    /// Centre α_m = (m + ½)Δ of bin m, radians.
    pub fn bin_centre_rad(&self, m: usize) -> f64 {
        (m as f64 + 0.5) * self.bin_width_rad()
    }

    /// Solid angle of bin m, steradians.
    pub fn bin_solid_angle_sr(&self, m: usize) -> f64 {
        bin_solid_angle_sr(m, self.bin_width_rad())
    }

    /// Energy per order held by the table, `Σ_m F_m Ω_m`.
    pub fn energy_per_order(&self) -> Vec<f64> {
        self.per_order
            .iter()
            .map(|o| {
                o.iter()
                    .enumerate()
                    .map(|(m, f)| f * self.bin_solid_angle_sr(m))
                    .sum()
            })
            .collect()
    }

    /// Zonal coefficients of the piecewise-constant table about the view ray:
    /// `z_l = Σ_m F_m 2π K_l ∫_{cos(m+1)Δ}^{cos mΔ} P_l(t) dt` (exact per bin).
    pub fn zonal(&self, bands: usize) -> Vec<f64> {
        let d = self.bin_width_rad();
        (0..bands)
            .map(|l| {
                let k = 2.0 * std::f64::consts::PI * sh::k_norm(l, 0);
                self.total
                    .iter()
                    .enumerate()
                    .map(|(m, f)| {
                        let (t1, t0) = ((m as f64 * d).cos(), ((m + 1) as f64 * d).cos());
                        f * k * sh::legendre_integral(l, t0, t1)
                    })
                    .sum()
            })
            .collect()
    }

    /// F at scattering angle θ: the bin average containing θ (piecewise constant).
    pub fn value(&self, theta_rad: f64) -> f64 {
        let m = (theta_rad / self.bin_width_rad())
            .floor()
            .clamp(0.0, (self.bins - 1) as f64);
        self.total[m as usize]
    }

    /// F at θ interpolated linearly between bin centres (the thesis's
    /// `D(α') ≈ (1 − r'/Δ) D_{m'} + (r'/Δ) D_{m'+1}`, with `α' = α_{m'} + r'`), clamped at the ends.
    pub fn interpolated(&self, theta_rad: f64) -> f64 {
        let u = theta_rad / self.bin_width_rad() - 0.5;
        if u <= 0.0 {
            return self.total[0];
        }
        let m = u.floor() as usize;
        if m + 1 >= self.bins {
            return self.total[self.bins - 1];
        }
        let r = u - m as f64;
        (1.0 - r) * self.total[m] + r * self.total[m + 1]
    }

    /// The thesis's table rotation: F for view direction `axis` and lookup direction `dir`,
    /// found by rotating `dir` with `R⁻¹`, where R takes +z (the table's axis, "(0,0)") to
    /// `axis` about `+z × axis`, and interpolating at the rotated polar angle α'.
    pub fn rotated(&self, axis: DVec3, dir: DVec3) -> f64 {
        let r_inv = rotation_from_z(axis.normalize_or(DVec3::Z)).transpose();
        let d = r_inv * dir.normalize_or(DVec3::Z);
        self.interpolated(d.z.clamp(-1.0, 1.0).acos())
    }

    /// `D_(r,s,m,q)` for the incoming direction (α_r, φ_s): the table rotated onto that axis,
    /// sampled at the bin centres α_m and `φ_q = 2π q / q_count`; row-major `[m][q]`.
    pub fn rotated_grid(&self, alpha_r: f64, phi_s: f64, q_count: usize) -> Vec<f64> {
        let axis = spherical_dir(alpha_r, phi_s);
        let mut out = Vec::with_capacity(self.bins * q_count);
        for m in 0..self.bins {
            for q in 0..q_count {
                let phi = 2.0 * std::f64::consts::PI * q as f64 / q_count as f64;
                out.push(self.rotated(axis, spherical_dir(self.bin_centre_rad(m), phi)));
            }
        }
        out
    }
}

/// `(sinθ cosφ, sinθ sinφ, cosθ)`.
pub fn spherical_dir(theta: f64, phi: f64) -> DVec3 {
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// The rotation taking +z to the unit vector `to`, about the axis `+z × to` (any rotation with
/// this property serves, thesis 5.1.2; this one is continuous except at `to = −z`).
pub fn rotation_from_z(to: DVec3) -> glam::DMat3 {
    let axis = DVec3::Z.cross(to);
    let s = axis.length();
    let c = to.z;
    if s < 1e-15 {
        return if c > 0.0 {
            glam::DMat3::IDENTITY
        } else {
            glam::DMat3::from_rotation_x(std::f64::consts::PI)
        };
    }
    glam::DMat3::from_axis_angle(axis / s, s.atan2(c))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_limits() {
        let (rs, rp) = fresnel(1.333, 1.0);
        let r0 = ((1.333f64 - 1.0) / 2.333).powi(2);
        assert!((rs - r0).abs() < 1e-15 && (rp - r0).abs() < 1e-15);
        let (rs, rp) = fresnel(1.333, 0.0);
        assert!((rs - 1.0).abs() < 1e-12 && (rp - 1.0).abs() < 1e-12);
        // Brewster: R_p = 0 at tan γ = ρ.
        let g = 1.333f64.atan();
        assert!(fresnel(1.333, g.cos()).1 < 1e-20);
        assert_eq!(fresnel(1.0, 0.0), (0.0, 0.0));
    }

    #[test]
    fn weights_sum_to_one_with_tail() {
        for rho in [1.0, 1.0001, 1.333, 2.0] {
            for pol in [Polarisation::Separate, Polarisation::Averaged] {
                let o = DropOptics::new(rho, 5).unwrap().with_polarisation(pol);
                for g in [0.0, 0.3, 1.0, 1.5, std::f64::consts::FRAC_PI_2] {
                    let s: f64 = (1..=5).map(|n| o.weight(n, g)).sum::<f64>() + o.tail_weight(g);
                    assert!((s - 1.0).abs() < 1e-12, "rho {rho} γ {g}: {s}");
                }
            }
        }
    }

    #[test]
    fn extremum_is_stationary() {
        let o = DropOptics::new(1.333, 9).unwrap();
        for n in 3..=9 {
            let g = o.extremum_rad(n).unwrap();
            assert!(o.deflection_slope(n, g).abs() < 1e-9);
        }
    }

    #[test]
    fn parameters_are_validated() {
        assert!(DropOptics::new(0.9, 9).is_err());
        assert!(DropOptics::new(f64::NAN, 9).is_err());
        assert!(DropOptics::new(1.333, 0).is_err());
        assert!(DropOptics::new(1.333, 9).unwrap().tabulate(1).is_err());
    }
}
