//! Where the water went: the puddles' water balance, before the clip in cubic metres and
//! during it in particles.
//!
//! Before the clip, the rain of `--pre-rain` minutes over the simulated ground is split, in
//! this order: the surface's pores and film take their share (the linear store of
//! [`crate::lighting::wetness`], S(0) at the clip's start) and lose what evaporates from it,
//! ∫₀ᵀ S/τ dt = S∞·(T − (1 − e^{−kT})/k); what the store shed soaks into the road at the
//! infiltration rate; the rest runs over the relief, filling its depressions
//! ([`super::fill`]) or running off the edges. The water in the depressions becomes particles
//! of one volume each where the picture shows them (the rest is counted, not simulated); less
//! than one particle's worth is left over. During the clip every
//! particle is counted by the solver's ledger ([`crate::fluid::MassLedger`]): the initial
//! ones, one per S raindrops landed (5.31), out through the edges, soaked in.

use crate::fluid::MassLedger;
use crate::lighting::wetness::SurfaceStore;

/// The water balance of a [`super::PuddleSim`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WaterLedger {
    /// Simulated ground, m².
    pub area_m2: f64,
    /// Rain that fell on it before the clip, m³.
    pub pre_rain_m3: f64,
    /// Held in the surface's pores and film at the clip's start, m³ (the wetness store).
    pub film_m3: f64,
    /// Evaporated from the film before the clip, m³.
    pub evaporated_m3: f64,
    /// Soaked into the ground before the clip, m³.
    pub infiltrated_m3: f64,
    /// Ran off the simulated ground before the clip, m³.
    pub run_off_m3: f64,
    /// Held in the relief's depressions at the clip's start, m³.
    pub puddles_m3: f64,
    /// Of the puddles, what is less than one particle and not simulated, m³.
    pub below_one_particle_m3: f64,
    /// Of the puddles, what is not simulated, m³: outside the picture (or, rarely, beyond the
    /// particle cap).
    pub unsimulated_m3: f64,
    /// Volume of one particle, m³.
    pub particle_volume_m3: f64,
    /// Particles placed in the puddles at the start.
    pub initial_particles: u64,
    /// Raindrops that landed on the simulated ground during the clip.
    pub rain_drops: u64,
    /// Raindrops that landed while the particles were at the cap: they wet the ground, add no
    /// water.
    pub rain_drops_over_cap: u64,
    /// Physical volume of the drops counted in `rain_drops`, m³ (each S of them make one
    /// particle, 5.31).
    pub rain_drop_volume_m3: f64,
    /// Particles born from the rain during the clip.
    pub rain_particles: u64,
    /// The solver's particle ledger (initial and rain particles in; out through the edges;
    /// soaked in).
    pub particles: MassLedger,
    /// Particles in the simulation now.
    pub particles_present: u64,
}

/// The pre-clip split of `rain_m` (m of water over the ground, fallen over `duration_s` at a
/// constant rate) into (film, evaporated, infiltrated, left to run), each m of water.
pub fn pre_rain_split(
    store: &SurfaceStore,
    rain_m: f64,
    duration_s: f64,
    infiltration_mps: f64,
) -> (f64, f64, f64, f64) {
    if !(rain_m > 0.0 && duration_s > 0.0) {
        return (0.0, 0.0, 0.0, 0.0);
    }
    let p_mm_per_s = rain_m * 1e3 / duration_s;
    let k = p_mm_per_s / store.capacity_mm + 1.0 / store.drying_s;
    let full_mm = p_mm_per_s / k;
    let film_mm = full_mm * (1.0 - (-k * duration_s).exp());
    let evaporated_mm =
        full_mm * (duration_s - (1.0 - (-k * duration_s).exp()) / k) / store.drying_s;
    let shed_m = (rain_m - 1e-3 * (film_mm + evaporated_mm)).max(0.0);
    let infiltrated_m = (infiltration_mps * duration_s).min(shed_m);
    (
        1e-3 * film_mm,
        1e-3 * evaporated_mm,
        infiltrated_m,
        shed_m - infiltrated_m,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_split_adds_up_and_matches_the_store_stepped_by_euler() {
        let store = SurfaceStore::default();
        let (t, rain_m) = (600.0, 10e-3 / 6.0);
        let (film, evap, inf, run) = pre_rain_split(&store, rain_m, t, 0.5e-3 / 3600.0);
        assert!((film + evap + inf + run - rain_m).abs() < 1e-15);
        // dS/dt = P(1 − S/C) − S/τ stepped by small Euler steps, evaporation summed.
        let p = rain_m * 1e3 / t;
        let (mut s, mut e, dt) = (0.0, 0.0, 1e-3);
        for _ in 0..(t / dt) as usize {
            let loss = s / store.drying_s;
            s += dt * (p * (1.0 - s / store.capacity_mm) - loss);
            e += dt * loss;
        }
        assert!((film * 1e3 - s).abs() < 1e-5, "{} vs {s}", film * 1e3);
        assert!((evap * 1e3 - e).abs() < 1e-5, "{} vs {e}", evap * 1e3);
        assert!((store.after(0.0, 10.0, t) - film * 1e3).abs() < 1e-12);
    }
}
