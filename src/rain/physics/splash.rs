//! Splashes: whether a landing drop splashes, and the secondary droplets it throws.
//!
//! How it works (docs/method.md, "Splashes"):
//! 1. **Threshold.** The ground is wet in rain, so the impact is on a thin water film: a drop
//!    splashes when K = We·Oh^−0.4 exceeds K_c ≈ 2100 (Cossali, Coghe & Marengo 1997, the
//!    thin-film limit δ = h/D → 0 of K_c = 2100 + 5880 δ^1.44), with We = ρ D v²/σ and
//!    Oh = μ/√(ρ σ D). K = C·D^1.2·v² in SI units, so the threshold is one constant on
//!    D^1.2·v². For Gunn–Kinzer fall speeds it falls near D ≈ 1 mm: drizzle does not splash.
//!    (Mundo et al. 1995's dry-surface K = We^0.5·Re^0.25 > 57.7 is the same group to the
//!    power 1/1.6 with a lower threshold, 57.7^1.6 ≈ 660: dry ground splashes more easily.)
//! 2. **Crown.** For the first [`CROWN_S`] the drop's water rises as a crown whose radius
//!    grows as √t (Yarin & Weiss 1995), R(τ) = √((D/2)² + D v τ), and whose height rises and
//!    falls, h(τ) = (R(τ) − D/2) sin(π τ / CROWN_S). The secondary droplets leave its rim.
//! 3. **Secondary droplets.** The volume thrown out grows with the excess over the threshold,
//!    φ = [`EJECTED_FRACTION_MAX`]·(1 − K_c/K) of the drop's; the droplets shrink as K grows,
//!    d = [`DROPLET_RATIO`]·D·(K_c/K)^¼; their number follows from the volume,
//!    N = φ (D/d)³. The trends (more and smaller droplets at higher K, sizes a tenth to a fifth
//!    of D) are those of Cossali et al. 2004 and of natural raindrops (Stow & Stainer 1977);
//!    the coefficients are a modelling choice in those ranges, not a fit.
//! 4. **Flight.** Each droplet leaves the crown rim at a random moment of the crown stage with
//!    a speed of 10–40 % of the impact speed at 20–70° elevation, azimuths spread evenly
//!    around the crown, and flies ballistically until it is back on the ground.
//!
//! At most [`MAX_DROPLETS`] droplets are drawn per splash; each stands for N/n of the real
//! ones (a coverage weight), so the splash covers the picture as all N would on average.

use glam::DVec3;

use super::G_MPS2;
use super::water::{WATER_REST_DENSITY_KG_M3, WATER_SURFACE_TENSION_N_PER_M};

/// Dynamic viscosity of water at 20 °C, Pa·s.
pub const WATER_VISCOSITY_PA_S: f64 = 1.002e-3;
/// Splashing threshold on K = We·Oh^−0.4 on a thin film (Cossali et al. 1997, δ → 0).
pub const SPLASH_THRESHOLD_K: f64 = 2100.0;
/// How long the crown stands, s (crowns of millimetre drops rise and fall in 10–20 ms).
pub const CROWN_S: f64 = 0.015;
/// Largest fraction of the drop's volume thrown out as droplets (high K).
pub const EJECTED_FRACTION_MAX: f64 = 0.3;
/// Secondary droplet diameter over the drop's at the threshold.
pub const DROPLET_RATIO: f64 = 0.2;
/// Droplets drawn per splash.
pub const MAX_DROPLETS: u32 = 8;
/// Streaks per splash: the crown, then the droplets.
pub const SPLASH_SLOTS: u32 = MAX_DROPLETS + 1;
/// Launch speed range, fraction of the impact speed.
pub const LAUNCH_SPEED: [f64; 2] = [0.1, 0.4];
/// Launch elevation range, degrees above the ground.
pub const LAUNCH_ELEVATION_DEG: [f64; 2] = [20.0, 70.0];
/// First random stream of a splash (per impact: [`crate::rain::volume::cycle_uniform`] of the
/// impact's pass); droplet j uses streams FIRST + 4j … FIRST + 4j + 3.
pub const SPLASH_STREAM: u32 = 16;

/// C of K = C·D^1.2·v² (SI): (ρ/σ)·(μ/√(ρσ))^−0.4.
pub fn splash_k_coefficient() -> f64 {
    let rho = WATER_REST_DENSITY_KG_M3 as f64;
    let sigma = WATER_SURFACE_TENSION_N_PER_M as f64;
    rho / sigma * (WATER_VISCOSITY_PA_S / (rho * sigma).sqrt()).powf(-0.4)
}

/// K = We·Oh^−0.4 of a drop of diameter `d_mm` landing at `speed_mps` (normal to the ground).
pub fn splash_number(d_mm: f64, speed_mps: f64) -> f64 {
    splash_k_coefficient() * (d_mm * 1e-3).powf(1.2) * speed_mps * speed_mps
}

/// Whether a drop of `d_mm` landing at `speed_mps` splashes.
pub fn splashes(d_mm: f64, speed_mps: f64) -> bool {
    splash_number(d_mm, speed_mps) > SPLASH_THRESHOLD_K
}

/// The size of one splash: secondary droplets thrown and drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplashSize {
    /// K = We·Oh^−0.4.
    pub k: f64,
    /// Secondary droplet diameter, mm.
    pub droplet_mm: f64,
    /// Droplets thrown (real, not rounded).
    pub count: f64,
    /// Droplets drawn (≤ [`MAX_DROPLETS`]).
    pub drawn: u32,
}

/// The splash of a drop of `d_mm` landing at `speed_mps`; `None` below the threshold.
pub fn splash_size(d_mm: f64, speed_mps: f64) -> Option<SplashSize> {
    let k = splash_number(d_mm, speed_mps);
    if k <= SPLASH_THRESHOLD_K {
        return None;
    }
    let ratio = SPLASH_THRESHOLD_K / k;
    let fraction = EJECTED_FRACTION_MAX * (1.0 - ratio);
    let droplet_mm = DROPLET_RATIO * d_mm * ratio.powf(0.25);
    let count = fraction * (d_mm / droplet_mm).powi(3);
    Some(SplashSize {
        k,
        droplet_mm,
        count,
        drawn: (count.ceil() as u32).clamp(1, MAX_DROPLETS),
    })
}

/// Crown radius `tau_s` after the impact of a drop of `d_mm` at `speed_mps`, m.
pub fn crown_radius_m(d_mm: f64, speed_mps: f64, tau_s: f64) -> f64 {
    let d = d_mm * 1e-3;
    (0.25 * d * d + d * speed_mps * tau_s.max(0.0)).sqrt()
}

/// Crown height `tau_s` after the impact, m (zero outside the crown stage).
pub fn crown_height_m(d_mm: f64, speed_mps: f64, tau_s: f64) -> f64 {
    if !(0.0..=CROWN_S).contains(&tau_s) {
        return 0.0;
    }
    (crown_radius_m(d_mm, speed_mps, tau_s) - 0.5e-3 * d_mm)
        * (std::f64::consts::PI * tau_s / CROWN_S).sin()
}

/// One secondary droplet's flight: it leaves `launch_m` at `launch_s` after the impact with
/// `velocity_mps` and flies ballistically until it is back on the ground.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Droplet {
    /// Launch point relative to the impact, m (on the crown's rim).
    pub launch_m: DVec3,
    /// Launch velocity, m/s.
    pub velocity_mps: DVec3,
    /// Launch time after the impact, s.
    pub launch_s: f64,
    /// Flight time until it lands, s.
    pub flight_s: f64,
}

impl Droplet {
    /// Position relative to the impact `tau_s` after it (on the ballistic arc; not clamped to
    /// the flight).
    pub fn position_m(&self, tau_s: f64) -> DVec3 {
        let s = tau_s - self.launch_s;
        self.launch_m + self.velocity_mps * s - DVec3::Z * (0.5 * G_MPS2 * s * s)
    }
}

/// Droplet j of a splash of a drop `d_mm` landing at `speed_mps`, from four uniforms
/// `u` (azimuth jitter, elevation, speed, launch moment); `drawn` droplets share the circle.
pub fn droplet(d_mm: f64, speed_mps: f64, j: u32, drawn: u32, u: [f64; 4]) -> Droplet {
    let azimuth = std::f64::consts::TAU * (j as f64 + u[0]) / drawn.max(1) as f64;
    let elevation = (LAUNCH_ELEVATION_DEG[0]
        + (LAUNCH_ELEVATION_DEG[1] - LAUNCH_ELEVATION_DEG[0]) * u[1])
        .to_radians();
    let speed = speed_mps * (LAUNCH_SPEED[0] + (LAUNCH_SPEED[1] - LAUNCH_SPEED[0]) * u[2]);
    let launch_s = CROWN_S * u[3];
    let out = DVec3::new(azimuth.cos(), azimuth.sin(), 0.0);
    let launch_m = out * crown_radius_m(d_mm, speed_mps, launch_s)
        + DVec3::Z * crown_height_m(d_mm, speed_mps, launch_s);
    let velocity_mps = (out * elevation.cos() + DVec3::Z * elevation.sin()) * speed;
    // Back on the ground: z0 + w s − g s²/2 = 0.
    let w = velocity_mps.z;
    let flight_s = (w + (w * w + 2.0 * G_MPS2 * launch_m.z).sqrt()) / G_MPS2;
    Droplet {
        launch_m,
        velocity_mps,
        launch_s,
        flight_s,
    }
}

/// The longest a splash of a drop of `d_mm` landing at `speed_mps` lasts, s: the crown stage,
/// then the longest flight (the fastest, steepest launch from the crown's top, which stays
/// below the crown's final radius).
pub fn splash_lifetime_s(d_mm: f64, speed_mps: f64) -> f64 {
    let w = speed_mps * LAUNCH_SPEED[1] * LAUNCH_ELEVATION_DEG[1].to_radians().sin();
    let z0 = crown_radius_m(d_mm, speed_mps, CROWN_S);
    CROWN_S + (w + (w * w + 2.0 * G_MPS2 * z0).sqrt()) / G_MPS2
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rain::physics::terminal_velocity_gk_mps;

    #[test]
    fn k_is_weber_times_ohnesorge_to_the_minus_0_4() {
        let (d, v) = (2.0, 6.49);
        let (rho, sigma, mu): (f64, f64, f64) = (998.29, 0.0728, 1.002e-3);
        let we = rho * d * 1e-3 * v * v / sigma;
        let oh = mu / (rho * sigma * d * 1e-3).sqrt();
        let k = we * oh.powf(-0.4);
        assert!((splash_number(d, v) / k - 1.0).abs() < 1e-5);
    }

    #[test]
    fn drizzle_does_not_splash_and_raindrops_do() {
        let at_terminal = |d: f64| splashes(d, terminal_velocity_gk_mps(d));
        assert!(!at_terminal(0.5) && !at_terminal(0.8));
        assert!(at_terminal(1.4) && at_terminal(2.0) && at_terminal(4.0));
    }

    #[test]
    fn droplets_conserve_the_ejected_volume_and_land_on_the_ground() {
        let (d, v) = (3.0, 8.06);
        let s = splash_size(d, v).expect("splashes");
        let ejected = s.count * s.droplet_mm.powi(3);
        let want = EJECTED_FRACTION_MAX * (1.0 - SPLASH_THRESHOLD_K / s.k) * d.powi(3);
        assert!((ejected / want - 1.0).abs() < 1e-9);
        assert!(s.droplet_mm < 0.2 * d && s.droplet_mm > 0.05 * d);
        for j in 0..s.drawn {
            let p = droplet(d, v, j, s.drawn, [0.3, 0.9, 0.99, 0.5]);
            assert!(p.position_m(p.launch_s + p.flight_s).z.abs() < 1e-9);
            assert!(p.launch_s + p.flight_s <= splash_lifetime_s(d, v));
        }
    }
}
