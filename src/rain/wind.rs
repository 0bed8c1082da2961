//! Wind: a mean horizontal vector plus smooth, seeded gusts, and the drops' lagged response.
//!
//! How it works: the gust is a short sum of sinusoids, a function of time only, so every drop
//! and every frame sees the same air without any state:
//!
//! ```text
//! w(t) = W̄ + Σ_k a_k cos(ω_k t + φ_k)          (a_k a horizontal vector, m/s)
//! ```
//!
//! A drop's horizontal velocity relaxes toward the air, τ dv/dt = w − v, with τ(D) = v_t(D)/g
//! ([`FallSpeed::relaxation_time_s`](super::physics::FallSpeed::relaxation_time_s)). Because the
//! forcing is a sum of sinusoids the steady state is closed form: each component is scaled by
//! g_k = 1/√(1+(ω_kτ)²) and delayed by θ_k = atan(ω_kτ), and the displacement is its exact
//! integral. Transients are ignored: a drop falling at terminal velocity has been in the air
//! far longer than τ (≤ 0.94 s) — the stateless emitter assumes every drop is in steady state.
//!
//! Gust spectrum: `GUST_COMPONENTS` = 8 components, 4 along the mean wind (longitudinal) and 4
//! across it (lateral), each set at log-spaced frequencies from 0.02 to 0.5 Hz (periods of 50 s
//! down to 2 s: WMO gusts are 3 s peaks) with a seeded jitter of ±half a log-band so the sum
//! never repeats. Amplitudes follow the Kolmogorov inertial range S(f) ∝ f^−5/3: a log-spaced
//! band of width Δf ∝ f holds variance ∝ f^−2/3, so a_k ∝ f_k^−1/3. The longitudinal RMS equals
//! the gust strength σ_u; the lateral RMS is 0.8 σ_u (σ_v/σ_u ≈ 1.9/2.4 in the neutral surface
//! layer, Panofsky & Dutton 1984). Vertical gusts are left out: drops keep their terminal
//! velocity.
//!
//! A keyed mean wind (`rain.wind_mps` as `[time_s, [x, y]]` keys, linear between them) is also
//! followed in closed form, each drop with its own lag ([`Wind::mean_lag`]); the gusts keep the
//! axis of the mean the rain is planned with.
//!
//! GPU port: the component parameters are a flat `[ax, ay, ω, φ]` array (one `vec4` each, see
//! [`Wind::component_params`]). Per frame, the CPU can pass cos/sin of (ω_k t + φ_k) in `f64`;
//! per drop, g_k cos(x − θ_k) = (cos x + ωτ sin x)/(1 + (ωτ)²) needs no `atan` and no branch.

use glam::DVec2;

use crate::keyframes::Curve;
use crate::rng::SplitMix64;

use crate::{Error, Result};

/// Number of gust components (≤ 8 keeps the GPU loop short).
pub const GUST_COMPONENTS: usize = 8;
/// Lowest and highest gust frequencies, Hz.
pub const GUST_BAND_HZ: (f64, f64) = (0.02, 0.5);
/// Lateral over longitudinal gust RMS (Panofsky & Dutton 1984: σ_v/σ_u ≈ 0.8).
pub const LATERAL_RATIO: f64 = 0.8;
/// Largest accepted mean wind or gust strength, m/s (hurricane force is 33 m/s).
pub const MAX_WIND_MPS: f64 = 60.0;

/// One gust component: `amplitude_mps · cos(omega_radps · t + phase_rad)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GustComponent {
    /// Amplitude vector (horizontal: world x, y), m/s.
    pub amplitude_mps: DVec2,
    /// Angular frequency, rad/s.
    pub omega_radps: f64,
    /// Phase, rad.
    pub phase_rad: f64,
}

/// The wind: a mean horizontal vector plus gusts.
#[derive(Debug, Clone, PartialEq)]
pub struct Wind {
    /// Mean wind (world x, y), m/s: the gusts' axis and the rain columns' shear; the mean itself
    /// where it is not keyed.
    pub mean_mps: DVec2,
    /// Gust components (empty for steady wind).
    pub gusts: Vec<GustComponent>,
    /// The mean wind over the shot, where it changes ([`Wind::with_mean_keys`]).
    pub mean_keys: Option<Curve<DVec2>>,
}

impl Wind {
    /// Still air.
    pub fn still() -> Wind {
        Wind {
            mean_mps: DVec2::ZERO,
            gusts: Vec::new(),
            mean_keys: None,
        }
    }

    /// A steady wind of `mean_mps`, without gusts.
    pub fn steady(mean_mps: DVec2) -> Result<Wind> {
        Wind::new(mean_mps, 0.0, 0)
    }

    /// Wind of mean `mean_mps` with gusts of longitudinal RMS `gust_mps` (see the module docs
    /// for the spectrum), phases and frequency jitter drawn from `seed`.
    pub fn new(mean_mps: DVec2, gust_mps: f64, seed: u64) -> Result<Wind> {
        if !(mean_mps.is_finite() && mean_mps.length() <= MAX_WIND_MPS) {
            return Err(Error::Parameter {
                name: "rain.wind_mps",
                value: format!("{},{}", mean_mps.x, mean_mps.y),
                expected: format!("a horizontal wind vector of at most {MAX_WIND_MPS} m/s"),
            });
        }
        if !(gust_mps.is_finite() && (0.0..=MAX_WIND_MPS).contains(&gust_mps)) {
            return Err(Error::Parameter {
                name: "rain.gust_mps",
                value: gust_mps.to_string(),
                expected: format!("a gust RMS from 0 to {MAX_WIND_MPS} m/s"),
            });
        }
        if gust_mps == 0.0 {
            return Ok(Wind {
                mean_mps,
                gusts: Vec::new(),
                mean_keys: None,
            });
        }
        let along = mean_mps.try_normalize().unwrap_or(DVec2::X);
        let across = along.perp();
        let mut rng = SplitMix64(seed ^ 0x05EE_D0F8_17D0);
        let per_axis = GUST_COMPONENTS / 2;
        let (f_lo, f_hi) = GUST_BAND_HZ;
        let ratio = (f_hi / f_lo).powf(1.0 / (per_axis - 1) as f64);
        let mut gusts = Vec::with_capacity(GUST_COMPONENTS);
        for (axis, rms) in [(along, gust_mps), (across, LATERAL_RATIO * gust_mps)] {
            let freqs: Vec<f64> = (0..per_axis)
                .map(|k| f_lo * ratio.powf(k as f64 + rng.next_f64() - 0.5))
                .collect();
            // a_k ∝ f^-1/3, scaled so Σ a_k²/2 = rms².
            let shape: Vec<f64> = freqs.iter().map(|f| f.powf(-1.0 / 3.0)).collect();
            let norm = rms / (0.5 * shape.iter().map(|s| s * s).sum::<f64>()).sqrt();
            for (f, s) in freqs.iter().zip(&shape) {
                gusts.push(GustComponent {
                    amplitude_mps: axis * (s * norm),
                    omega_radps: 2.0 * std::f64::consts::PI * f,
                    phase_rad: 2.0 * std::f64::consts::PI * rng.next_f64(),
                });
            }
        }
        Ok(Wind {
            mean_mps,
            gusts,
            mean_keys: None,
        })
    }

    /// This wind with its mean changing over the shot as `keys` say (linear between keys); the
    /// gusts keep their axis and spectrum. A constant curve leaves the wind as it is.
    pub fn with_mean_keys(mut self, keys: &Curve<DVec2>) -> Wind {
        self.mean_keys = (!keys.is_constant()).then(|| keys.clone());
        if self.mean_keys.is_none() {
            self.mean_mps = keys.at(0.0);
        }
        self
    }

    /// The mean wind at `t_s`, m/s.
    pub fn mean_at(&self, t_s: f64) -> DVec2 {
        self.mean_keys.as_ref().map_or(self.mean_mps, |k| k.at(t_s))
    }

    /// The mean wind's slope at `t_s`, m/s².
    pub fn mean_slope_at(&self, t_s: f64) -> DVec2 {
        self.mean_keys
            .as_ref()
            .map_or(DVec2::ZERO, |k| k.slope_at(t_s))
    }

    /// The mean wind's travel ∫₀ᵗ W̄ dt, m (what air moving with it has travelled).
    pub fn mean_travel_m(&self, t_s: f64) -> DVec2 {
        self.mean_keys
            .as_ref()
            .map_or(self.mean_mps * t_s, |k| k.integral(t_s))
    }

    /// The slope changes of the mean wind at or before `t_s`: `(t_s − t_j, Δb_j)`.
    pub fn mean_kinks_before(&self, t_s: f64) -> Vec<(f64, DVec2)> {
        self.mean_keys.as_ref().map_or(Vec::new(), |k| {
            k.kinks()
                .into_iter()
                .filter(|&(t, _)| t <= t_s)
                .map(|(t, d)| (t_s - t, d))
                .collect()
        })
    }

    /// How far a drop with time constant `tau_s` lags behind the changing mean wind: (velocity
    /// m/s, displacement m) to add to the mean wind's own. For a piecewise-linear W̄ with slope
    /// b(t) and slope changes Δb_j at t_j, τ v' + v = W̄ solves exactly to
    /// v = W̄ − τ b + τ Σ Δb_j e^{−(t−t_j)/τ}, whose integral from the (steady) start is
    /// ∫W̄ − τ (W̄(t) − W̄(0)) + τ² Σ Δb_j (1 − e^{−(t−t_j)/τ}). Zero for a steady mean.
    pub fn mean_lag(&self, t_s: f64, tau_s: f64) -> (DVec2, DVec2) {
        if self.mean_keys.is_none() || tau_s <= 0.0 {
            return (DVec2::ZERO, DVec2::ZERO);
        }
        let (mut v, mut x) = (-tau_s * self.mean_slope_at(t_s), DVec2::ZERO);
        x -= tau_s * (self.mean_at(t_s) - self.mean_at(0.0));
        for (dt, db) in self.mean_kinks_before(t_s) {
            let e = (-dt / tau_s).exp();
            v += db * (tau_s * e);
            x += db * (tau_s * tau_s * (1.0 - e));
        }
        (v, x)
    }

    /// Air velocity at time `t_s`, m/s.
    pub fn wind_velocity_mps(&self, t_s: f64) -> DVec2 {
        self.gusts.iter().fold(self.mean_at(t_s), |acc, g| {
            acc + g.amplitude_mps * (g.omega_radps * t_s + g.phase_rad).cos()
        })
    }

    /// Air displacement ∫₀ᵗ w dt, m.
    pub fn wind_displacement_m(&self, t_s: f64) -> DVec2 {
        self.drop_displacement_m(t_s, 0.0)
    }

    /// Steady-state horizontal velocity, m/s, at `t_s` of a drop whose velocity relaxes to the
    /// wind with time constant `tau_s` (τ = 0 follows the air exactly).
    pub fn drop_velocity_mps(&self, t_s: f64, tau_s: f64) -> DVec2 {
        let mean = self.mean_at(t_s) + self.mean_lag(t_s, tau_s).0;
        self.gusts.iter().fold(mean, |acc, g| {
            let x = g.omega_radps * t_s + g.phase_rad;
            let wt = g.omega_radps * tau_s.max(0.0);
            // g_k cos(x − θ_k) with g_k = 1/√(1+wt²), θ_k = atan(wt).
            acc + g.amplitude_mps * ((x.cos() + wt * x.sin()) / (1.0 + wt * wt))
        })
    }

    /// Displacement ∫₀ᵗ v dt, m, of a drop in steady state with time constant `tau_s`:
    /// W̄ t + Σ a_k g_k [sin(ω_k t + φ_k − θ_k) − sin(φ_k − θ_k)]/ω_k.
    pub fn drop_displacement_m(&self, t_s: f64, tau_s: f64) -> DVec2 {
        self.mean_travel_m(t_s) + self.mean_lag(t_s, tau_s).1 + self.gust_displacement_m(t_s, tau_s)
    }

    /// The gusts' share of [`Wind::drop_displacement_m`] (bounded: it does not grow with t).
    pub fn gust_displacement_m(&self, t_s: f64, tau_s: f64) -> DVec2 {
        self.gusts.iter().fold(DVec2::ZERO, |acc, g| {
            let wt = g.omega_radps * tau_s.max(0.0);
            // g_k sin(x − θ_k) = (sin x − wt cos x)/(1 + wt²).
            let s = |x: f64| (x.sin() - wt * x.cos()) / (1.0 + wt * wt);
            let x1 = g.omega_radps * t_s + g.phase_rad;
            acc + g.amplitude_mps * ((s(x1) - s(g.phase_rad)) / g.omega_radps)
        })
    }

    /// The gusts as a flat array `[ax, ay, ω, φ]` per component (m/s, m/s, rad/s, rad), padded
    /// with zero components to `GUST_COMPONENTS` entries, for a GPU uniform.
    pub fn component_params(&self) -> Vec<f32> {
        let mut out = Vec::with_capacity(4 * GUST_COMPONENTS);
        for g in &self.gusts {
            out.extend_from_slice(&[
                g.amplitude_mps.x as f32,
                g.amplitude_mps.y as f32,
                g.omega_radps as f32,
                g.phase_rad as f32,
            ]);
        }
        // ω = 1 on padding avoids a division by zero in the displacement; amplitude 0 cancels it.
        while out.len() < 4 * GUST_COMPONENTS {
            out.extend_from_slice(&[0.0, 0.0, 1.0, 0.0]);
        }
        out
    }

    /// Longitudinal gust RMS implied by the components, m/s (√(Σ (a·ê)²/2)).
    pub fn gust_rms_mps(&self, direction: DVec2) -> f64 {
        let e = direction.try_normalize().unwrap_or(DVec2::X);
        (0.5 * self
            .gusts
            .iter()
            .map(|g| g.amplitude_mps.dot(e).powi(2))
            .sum::<f64>())
        .sqrt()
    }
}

/// Velocity at `t_s` after a step: a drop at `v0_mps` when the wind jumps to `w_mps` at t = 0
/// relaxes as w + (v0 − w) e^{−t/τ}.
pub fn step_response_velocity_mps(v0_mps: DVec2, w_mps: DVec2, t_s: f64, tau_s: f64) -> DVec2 {
    if tau_s <= 0.0 {
        return w_mps;
    }
    w_mps + (v0_mps - w_mps) * (-t_s.max(0.0) / tau_s).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gust_rms_matches_request() {
        let w = Wind::new(DVec2::new(3.0, 4.0), 2.0, 7).unwrap();
        assert_eq!(w.gusts.len(), GUST_COMPONENTS);
        let along = DVec2::new(0.6, 0.8);
        assert!((w.gust_rms_mps(along) - 2.0).abs() < 1e-12);
        assert!((w.gust_rms_mps(along.perp()) - 1.6).abs() < 1e-12);
        // Time average over a long window: the sample RMS approaches the design RMS.
        let n = 200_000;
        let dt = 0.05;
        let var: f64 = (0..n)
            .map(|i| {
                (w.wind_velocity_mps(i as f64 * dt) - w.mean_mps)
                    .dot(along)
                    .powi(2)
            })
            .sum::<f64>()
            / n as f64;
        assert!((var.sqrt() - 2.0).abs() < 0.2, "{}", var.sqrt());
    }

    #[test]
    fn rejects_bad_wind() {
        assert!(Wind::new(DVec2::new(f64::NAN, 0.0), 0.0, 0).is_err());
        assert!(Wind::new(DVec2::new(100.0, 0.0), 0.0, 0).is_err());
        assert!(Wind::new(DVec2::ZERO, -1.0, 0).is_err());
    }

    #[test]
    fn zero_tau_follows_the_air() {
        let w = Wind::new(DVec2::new(5.0, 0.0), 3.0, 1).unwrap();
        for t in [0.0, 1.3, 77.0] {
            assert!((w.drop_velocity_mps(t, 0.0) - w.wind_velocity_mps(t)).length() < 1e-12);
        }
    }

    #[test]
    fn params_are_padded() {
        let p = Wind::steady(DVec2::new(1.0, 0.0))
            .unwrap()
            .component_params();
        assert_eq!(p.len(), 4 * GUST_COMPONENTS);
        assert!(p.iter().all(|x| x.is_finite()));
    }
}
