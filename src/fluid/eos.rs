//! Equations of state: pressure from density.
//!
//! How it works: the thesis (5.19) uses Desbrun's p = k(ρ − ρ₀) with k = 3 m²/s², whose sound
//! speed c = √k = 1.7 m/s lets a 10 cm column compress by gH/c² ≈ 33 % (`docs/method.md`, "Fluid").
//! We keep the linear law but choose k from the weakly-compressible rule (Monaghan 1994):
//! c ≥ 10·v_max, v_max ≈ √(2gH) for water of depth H, so density errors stay near
//! (v/c)² ≈ 1 %. Tait's law (Monaghan 1994; Becker & Teschner 2007) is offered as an alternative:
//! p = B((ρ/ρ₀)^γ − 1), B = ρ₀c²/γ, with the same sound speed at rest.

use crate::{Error, Result};

/// Standard gravity, m/s², used to turn a water depth into a velocity scale.
pub const STANDARD_GRAVITY_MPS2: f32 = 9.81;

/// The pressure law p(ρ).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum EquationOfState {
    /// Desbrun / Müller (5.19): p = k(ρ − ρ₀), k in m²/s² (J/kg); c = √k.
    Linear {
        /// The stiffness k, m²/s².
        stiffness_m2ps2: f32,
    },
    /// Tait: p = B((ρ/ρ₀)^γ − 1), B = ρ₀c²/γ.
    Tait {
        /// Sound speed at rest density, m/s.
        sound_speed_mps: f32,
        /// The exponent γ (7 for water).
        exponent: f32,
    },
}

impl EquationOfState {
    /// The thesis's gas constant, k = 3 m²/s² (≈ 30 % compression at 10 cm depth). For
    /// comparison only.
    pub const THESIS: EquationOfState = EquationOfState::Linear {
        stiffness_m2ps2: 3.0,
    };

    /// The linear law with c = 10·v_max (Monaghan's weakly-compressible rule).
    pub fn weakly_compressible(max_speed_mps: f32) -> EquationOfState {
        let c = 10.0 * max_speed_mps;
        EquationOfState::Linear {
            stiffness_m2ps2: c * c,
        }
    }

    /// The linear law for water up to `depth_m` deep: v_max = √(2gH), c = 10·v_max, so the
    /// hydrostatic compression gH/c² is 0.5 %.
    pub fn for_depth(depth_m: f32) -> EquationOfState {
        EquationOfState::weakly_compressible((2.0 * STANDARD_GRAVITY_MPS2 * depth_m).sqrt())
    }

    /// The linear law for thin sheets of moving water up to `depth_m` deep, such as the rain's
    /// films over water held at rest: c = 10√(gH), ten times their long-wave speed, so the
    /// hydrostatic compression gH/c² is 1 % (Monaghan 1994's bound; [`for_depth`](Self::for_depth)
    /// keeps 0.5 % and a dam break's 2√(gH) front below c/5). For films whose speed stays near
    /// √(gH): rain films on a street at 1.6 cm spacing (H = 2Δx) reached 0.49–0.51 m/s against
    /// √(gH) = 0.56 m/s (docs/measurements.md, "The rain's films: a sound speed from their
    /// depth"); a steep or fast sheet needs [`for_depth`](Self::for_depth)'s rule.
    pub fn for_film(depth_m: f32) -> EquationOfState {
        EquationOfState::weakly_compressible((STANDARD_GRAVITY_MPS2 * depth_m).sqrt())
    }

    /// Pressure, Pa, at density `density_kg_m3` for rest density `rest_kg_m3`.
    #[inline]
    pub fn pressure_pa(&self, density_kg_m3: f32, rest_kg_m3: f32) -> f32 {
        match *self {
            EquationOfState::Linear { stiffness_m2ps2 } => {
                stiffness_m2ps2 * (density_kg_m3 - rest_kg_m3)
            }
            EquationOfState::Tait {
                sound_speed_mps,
                exponent,
            } => {
                let b = rest_kg_m3 * sound_speed_mps * sound_speed_mps / exponent;
                b * ((density_kg_m3 / rest_kg_m3).powf(exponent) - 1.0)
            }
        }
    }

    /// Sound speed at rest, m/s: c² = dp/dρ at ρ₀.
    pub fn sound_speed_mps(&self) -> f32 {
        match *self {
            EquationOfState::Linear { stiffness_m2ps2 } => stiffness_m2ps2.sqrt(),
            EquationOfState::Tait {
                sound_speed_mps, ..
            } => sound_speed_mps,
        }
    }

    /// Checks that the law's constants are finite and positive.
    pub fn validate(&self) -> Result<()> {
        match *self {
            EquationOfState::Linear { stiffness_m2ps2 } => {
                positive("sph.eos.stiffness_m2ps2", stiffness_m2ps2)
            }
            EquationOfState::Tait {
                sound_speed_mps,
                exponent,
            } => {
                positive("sph.eos.sound_speed_mps", sound_speed_mps)?;
                if !(exponent.is_finite() && (1.0..=10.0).contains(&exponent)) {
                    return Err(Error::Parameter {
                        name: "sph.eos.exponent",
                        value: exponent.to_string(),
                        expected: "a number in [1, 10] (7 for water)".into(),
                    });
                }
                Ok(())
            }
        }
    }
}

/// `Err(Error::Parameter)` unless `value` is finite and > 0.
pub(crate) fn positive(name: &'static str, value: f32) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(Error::Parameter {
            name,
            value: value.to_string(),
            expected: "a finite number > 0".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tait_and_linear_agree_to_first_order() {
        let lin = EquationOfState::for_depth(0.1);
        let c = lin.sound_speed_mps();
        // 10·√(2·9.81·0.1) = 14.0 m/s (Monaghan's rule, `docs/method.md`, "Fluid").
        assert!((c - 14.007).abs() < 0.01, "{c}");
        let tait = EquationOfState::Tait {
            sound_speed_mps: c,
            exponent: 7.0,
        };
        let rho0 = 998.29;
        let rho = rho0 * 1.0005;
        let (pl, pt) = (lin.pressure_pa(rho, rho0), tait.pressure_pa(rho, rho0));
        assert!((pl / pt - 1.0).abs() < 5e-3, "{pl} {pt}");
    }

    #[test]
    fn invalid_constants_are_errors() {
        assert!(
            EquationOfState::Linear {
                stiffness_m2ps2: -1.0
            }
            .validate()
            .is_err()
        );
        assert!(
            EquationOfState::Tait {
                sound_speed_mps: 10.0,
                exponent: f32::NAN
            }
            .validate()
            .is_err()
        );
    }
}
