//! Parameters of the SPH solver ([`super::Muller2003`]) and the time-step rule.
//!
//! How it works: [`SphSettings::water`] derives a consistent set from two numbers, the particle
//! spacing and the deepest water expected: h = 2Δx, the stiffness from c = 10√(2gH)
//! ([`EquationOfState::for_depth`]), the viscosity from Monaghan's α = 0.05 and the mass ρ₀Δx³.
//! [`SphSettings::validate`] turns every out-of-range value into an `Error::Parameter`.

use super::eos::{EquationOfState, STANDARD_GRAVITY_MPS2, positive};
use crate::{Error, Result};
use glam::Vec3;

pub use crate::rain::physics::water::{WATER_REST_DENSITY_KG_M3, WATER_SURFACE_TENSION_N_PER_M};
/// The default Courant number λ of the sound-speed limit.
pub const DEFAULT_COURANT: f32 = 0.4;

/// How the time step is chosen.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum TimeStep {
    /// The largest stable step: min(λh/(c + v_max), 0.25√(h/a_max), 0.125h²ρ₀/μ, `max_s`).
    Adaptive {
        /// Courant number λ of the sound-speed limit (0.4 is usual).
        courant: f32,
        /// Upper bound, s.
        max_s: f32,
    },
    /// A constant step, s (the caller is responsible for stability).
    Fixed {
        /// The step, s.
        dt_s: f32,
    },
}

/// Parameters of [`super::Muller2003`]. Build with [`SphSettings::water`] and adjust.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SphSettings {
    /// Initial particle spacing Δx, m: sets the particle volume and the surface columns.
    pub particle_spacing_m: f32,
    /// Kernel support radius h, m (2Δx by default: about 33 neighbours).
    pub smoothing_length_m: f32,
    /// Rest density ρ₀, kg/m³.
    pub rest_density_kg_m3: f32,
    /// Mass of every particle, kg (ρ₀Δx³: the water of one lattice cell).
    pub particle_mass_kg: f32,
    /// The pressure law.
    pub eos: EquationOfState,
    /// Clamp negative pressures to 0: avoids the tensile instability at the free surface.
    pub clamp_negative_pressure: bool,
    /// Dynamic viscosity μ of (5.21), Pa·s. Müller's Laplacian is a consistent ∇² estimate,
    /// so this is a real viscosity (water: 0.001; Müller 2003: 3.5).
    pub viscosity_pa_s: f32,
    /// Surface tension σ of (5.25), N/m.
    pub surface_tension_n_per_m: f32,
    /// Gravity, m/s².
    pub gravity_mps2: Vec3,
    /// The time step rule.
    pub time_step: TimeStep,
    /// Collision damping e ∈ [0, 1]: the normal velocity after a collision is −e times the one
    /// before (thesis §5.3.1 uses a factor in (0, 1)).
    pub collision_damping: f32,
    /// Ground friction ∈ [0, 1] (terrain and box floor; other walls are free-slip): the
    /// ghosts' tangential velocity is scaled by 1 − 2·friction, so 0 is free slip and 1 no slip.
    pub ground_friction: f32,
    /// Rate at which water in contact with the terrain soaks in, m/s (depth per second).
    pub infiltration_rate_mps: f32,
    /// Gravity is ramped up smoothly over this time from the start, s (0: off). A scene that
    /// starts from an unloaded lattice then settles quasi-statically instead of ringing in
    /// its slowest sound mode, which viscosity damps only over seconds (Adami, Hu & Adams
    /// 2012 do the same for their hydrostatic tank).
    pub gravity_ramp_s: f32,
}

impl SphSettings {
    /// Water at spacing `particle_spacing_m`, for pools up to `depth_m` deep: h = 2Δx,
    /// ρ₀ = 998.29, the linear law with c = 10√(2gH), σ = 0.0728 N/m, and a viscosity equal to
    /// the artificial viscosity ν = αhc/10 with α = 0.05 (Monaghan 1992), the least that keeps a
    /// weakly compressible flow stable at this resolution. Mass ρ₀Δx³: each particle carries
    /// the water of one lattice cell. The ground is no-slip, as real walls are (with it the
    /// dam-break front follows Martin & Moyce; free slip leads it by 11–15 %).
    pub fn water(particle_spacing_m: f32, depth_m: f32) -> SphSettings {
        SphSettings::water_with(particle_spacing_m, EquationOfState::for_depth(depth_m))
    }

    /// [`SphSettings::water`] with the pressure law `eos`; the viscosity follows its sound speed.
    pub fn water_with(particle_spacing_m: f32, eos: EquationOfState) -> SphSettings {
        let dx = particle_spacing_m;
        let h = 2.0 * dx;
        let rho0 = WATER_REST_DENSITY_KG_M3;
        let c = eos.sound_speed_mps();
        SphSettings {
            particle_spacing_m: dx,
            smoothing_length_m: h,
            rest_density_kg_m3: rho0,
            particle_mass_kg: rho0 * dx * dx * dx,
            eos,
            clamp_negative_pressure: true,
            viscosity_pa_s: rho0 * 0.05 * h * c / 10.0,
            surface_tension_n_per_m: WATER_SURFACE_TENSION_N_PER_M,
            gravity_mps2: Vec3::new(0.0, 0.0, -STANDARD_GRAVITY_MPS2),
            time_step: TimeStep::Adaptive {
                courant: DEFAULT_COURANT,
                max_s: 0.01,
            },
            collision_damping: 0.5,
            ground_friction: 1.0,
            infiltration_rate_mps: 0.0,
            gravity_ramp_s: 0.0,
        }
    }

    /// Checks every parameter; `Error::Parameter` names the first bad one.
    pub fn validate(&self) -> Result<()> {
        positive("sph.particle_spacing_m", self.particle_spacing_m)?;
        positive("sph.smoothing_length_m", self.smoothing_length_m)?;
        positive("sph.rest_density_kg_m3", self.rest_density_kg_m3)?;
        positive("sph.particle_mass_kg", self.particle_mass_kg)?;
        let ratio = self.smoothing_length_m / self.particle_spacing_m;
        if !(1.0..=4.0).contains(&ratio) {
            return Err(Error::Parameter {
                name: "sph.smoothing_length_m",
                value: self.smoothing_length_m.to_string(),
                expected: format!(
                    "between 1 and 4 particle spacings ({} m)",
                    self.particle_spacing_m
                ),
            });
        }
        self.eos.validate()?;
        for (name, v) in [
            ("sph.viscosity_pa_s", self.viscosity_pa_s),
            ("sph.surface_tension_n_per_m", self.surface_tension_n_per_m),
            ("sph.infiltration_rate_mps", self.infiltration_rate_mps),
            ("sph.gravity_ramp_s", self.gravity_ramp_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::Parameter {
                    name,
                    value: v.to_string(),
                    expected: "a finite number ≥ 0".into(),
                });
            }
        }
        for (name, v) in [
            ("sph.collision_damping", self.collision_damping),
            ("sph.ground_friction", self.ground_friction),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(Error::Parameter {
                    name,
                    value: v.to_string(),
                    expected: "a number in [0, 1]".into(),
                });
            }
        }
        if !self.gravity_mps2.is_finite() {
            return Err(Error::Parameter {
                name: "sph.gravity_mps2",
                value: self.gravity_mps2.to_string(),
                expected: "a finite vector".into(),
            });
        }
        match self.time_step {
            TimeStep::Adaptive { courant, max_s } => {
                if !(courant > 0.0 && courant <= 1.0) {
                    return Err(Error::Parameter {
                        name: "sph.courant",
                        value: courant.to_string(),
                        expected: "a Courant number in (0, 1]".into(),
                    });
                }
                positive("sph.max_time_step_s", max_s)
            }
            TimeStep::Fixed { dt_s } => positive("sph.time_step_s", dt_s),
        }
    }

    /// The particle's volume at rest, m/ρ₀, m³.
    pub fn particle_volume_m3(&self) -> f32 {
        self.particle_mass_kg / self.rest_density_kg_m3
    }
}
