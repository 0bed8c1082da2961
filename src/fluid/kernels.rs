//! Smoothing kernels of Müller, Charypar & Gross (2003), "Particle-based fluid simulation for
//! interactive applications" — thesis eq. (3.11)–(3.13).
//!
//! How it works: each kernel is a zero-sized type implementing [`Kernel`] (value W, gradient ∇W
//! and Laplacian ∇²W, all for a support radius `h`; W = 0 for r ≥ h). Müller uses [`Poly6`] for
//! density and the colour field, [`Spiky`] for pressure (its gradient does not vanish as
//! r → 0, so close particles still repel) and [`Viscosity`] for viscosity (its Laplacian is
//! positive everywhere, so viscosity only ever damps relative motion). Our solver keeps poly6
//! for the colour field and spiky for pressure, and computes density with spiky too, so that
//! the pressure force is the gradient of an energy (see [`super::sph`]).
//!
//! All values are in SI: W in 1/m³, ∇W in 1/m⁴, ∇²W in 1/m⁵.

use glam::Vec3;

/// A radial SPH smoothing kernel with compact support `h` (metres).
///
/// `r_vec` is always x_i − x_j, so [`Kernel::gradient`] is ∇ with respect to x_i.
pub trait Kernel: Copy + Default + Send + Sync + 'static {
    /// W(r, h), 1/m³. Zero for r ≥ h.
    fn value(r_m: f32, h_m: f32) -> f32;
    /// W from the squared distance r² (m²); kernels polynomial in r² skip the square root.
    #[inline]
    fn value_sq(r2_m2: f32, h_m: f32) -> f32 {
        Self::value(r2_m2.sqrt(), h_m)
    }
    /// ∇W(r⃗, h) with respect to x_i, 1/m⁴. Zero for r ≥ h and, by symmetry, at r = 0.
    fn gradient(r_vec_m: Vec3, h_m: f32) -> Vec3;
    /// ∇²W(r, h), 1/m⁵. Zero for r ≥ h.
    fn laplacian(r_m: f32, h_m: f32) -> f32;
}

/// Poly6 kernel, W = 315/(64π h⁹) (h² − r²)³ — thesis (3.11); Müller's density kernel (5.18),
/// used here for the colour field (5.23).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Poly6;

/// Spiky kernel (Desbrun & Gascuel 1996), W = 15/(π h⁶) (h − r)³ — thesis (3.12), used for
/// pressure (5.20) and, here, density (5.18).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Spiky;

/// Viscosity kernel, W = 15/(2π h³) (−r³/(2h³) + r²/h² + h/(2r) − 1) — thesis (3.13), whose
/// Laplacian 45/(π h⁶)(h − r) is positive; used for viscosity (5.21).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Viscosity;

/// Smallest r at which the singular kernel expressions are evaluated (as a fraction of h), so
/// that they stay finite when two particles coincide.
const R_MIN_FRACTION: f32 = 1e-6;

impl Kernel for Poly6 {
    #[inline]
    fn value(r_m: f32, h_m: f32) -> f32 {
        Self::value_sq(r_m * r_m, h_m)
    }

    #[inline]
    fn value_sq(r2: f32, h_m: f32) -> f32 {
        let h2 = h_m * h_m;
        if r2 >= h2 {
            return 0.0;
        }
        let u = h2 - r2;
        315.0 / (64.0 * std::f32::consts::PI * h2.powi(4) * h_m) * u * u * u
    }

    #[inline]
    fn gradient(r_vec_m: Vec3, h_m: f32) -> Vec3 {
        let h2 = h_m * h_m;
        let r2 = r_vec_m.length_squared();
        if r2 >= h2 {
            return Vec3::ZERO;
        }
        let u = h2 - r2;
        r_vec_m * (-945.0 / (32.0 * std::f32::consts::PI * h2.powi(4) * h_m) * u * u)
    }

    #[inline]
    fn laplacian(r_m: f32, h_m: f32) -> f32 {
        let h2 = h_m * h_m;
        let r2 = r_m * r_m;
        if r2 >= h2 {
            return 0.0;
        }
        -945.0 / (32.0 * std::f32::consts::PI * h2.powi(4) * h_m)
            * (h2 - r2)
            * (3.0 * h2 - 7.0 * r2)
    }
}

impl Kernel for Spiky {
    #[inline]
    fn value(r_m: f32, h_m: f32) -> f32 {
        if r_m >= h_m {
            return 0.0;
        }
        let u = h_m - r_m;
        15.0 / (std::f32::consts::PI * h_m.powi(6)) * u * u * u
    }

    #[inline]
    fn gradient(r_vec_m: Vec3, h_m: f32) -> Vec3 {
        let r = r_vec_m.length();
        if r >= h_m || r <= 0.0 {
            // At r = 0 the direction is undefined; the symmetric choice is no force.
            return Vec3::ZERO;
        }
        let u = h_m - r;
        r_vec_m * (-45.0 / (std::f32::consts::PI * h_m.powi(6)) * u * u / r)
    }

    #[inline]
    fn laplacian(r_m: f32, h_m: f32) -> f32 {
        if r_m >= h_m {
            return 0.0;
        }
        // W'' + 2W'/r = 6B(h − r) − 6B(h − r)²/r: singular at r = 0, clamped.
        let r = r_m.max(R_MIN_FRACTION * h_m);
        let u = h_m - r;
        let b = 15.0 / (std::f32::consts::PI * h_m.powi(6));
        6.0 * b * u - 6.0 * b * u * u / r
    }
}

impl Kernel for Viscosity {
    #[inline]
    fn value(r_m: f32, h_m: f32) -> f32 {
        if r_m >= h_m {
            return 0.0;
        }
        // Singular (h/2r) at r = 0: clamped so two coincident particles stay finite.
        let r = r_m.max(R_MIN_FRACTION * h_m);
        let h3 = h_m * h_m * h_m;
        15.0 / (2.0 * std::f32::consts::PI * h3)
            * (-r * r * r / (2.0 * h3) + r * r / (h_m * h_m) + h_m / (2.0 * r) - 1.0)
    }

    #[inline]
    fn gradient(r_vec_m: Vec3, h_m: f32) -> Vec3 {
        let r = r_vec_m.length();
        if r >= h_m || r <= 0.0 {
            return Vec3::ZERO;
        }
        let r = r.max(R_MIN_FRACTION * h_m);
        let h3 = h_m * h_m * h_m;
        r_vec_m
            * (15.0 / (2.0 * std::f32::consts::PI * h3)
                * (-3.0 * r / (2.0 * h3) + 2.0 / (h_m * h_m) - h_m / (2.0 * r * r * r)))
    }

    #[inline]
    fn laplacian(r_m: f32, h_m: f32) -> f32 {
        if r_m >= h_m {
            return 0.0;
        }
        45.0 / (std::f32::consts::PI * h_m.powi(6)) * (h_m - r_m)
    }
}

/// Kernel moments over a cubic lattice of spacing Δx (each point weighted by Δx³), which fix
/// the scale of the discrete operators. In the continuum all four are 1; at h = 2Δx the spiky
/// sum is 1.24 (its cusp at r = 0 is poorly sampled), the gradient moment 0.96, the colour sum
/// 1.01 and the Laplacian moment 0.99. Dividing by them makes density, gradients and
/// Laplacians exact on the lattice; being constants, they keep the pressure force the
/// gradient of an energy. Other packings differ: the gradient moment is 0.92 on a bcc and 0.91
/// on an fcc lattice at h = 2Δx (0.95–0.98 at h = 2.5Δx), which bounds the accuracy of
/// hydrostatic pressure once the particles rearrange (+4 % after 1 s in the column).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct LatticeMoments {
    /// Σ Δx³ W_spiky: divides the density sum, so a lattice at spacing Δx has ρ = m/Δx³.
    pub(crate) density: f32,
    /// (1/3) Σ Δx³ r |W'_spiky|: scale of the pressure gradient.
    pub(crate) gradient: f32,
    /// Σ Δx³ W_poly6: scale of the colour field c (5.23).
    pub(crate) colour: f32,
    /// (1/6) Σ Δx³ r² ∇²W_visc: scale of the viscous Laplacian (5.21).
    pub(crate) laplacian: f32,
}

impl LatticeMoments {
    /// The moments for spacing `dx_m` and support `h_m`.
    pub(crate) fn new(dx_m: f32, h_m: f32) -> LatticeMoments {
        let n = (h_m / dx_m).ceil() as i32;
        let (dx, h) = (dx_m as f64, h_m as f64);
        let v = dx * dx * dx;
        let spiky = 15.0 / (std::f64::consts::PI * h.powi(6));
        let (mut s0, mut s1, mut c0, mut l2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for i in -n..=n {
            for j in -n..=n {
                for k in -n..=n {
                    let r = ((i * i + j * j + k * k) as f64).sqrt() * dx;
                    if r >= h {
                        continue;
                    }
                    let u = h - r;
                    s0 += v * spiky * u * u * u;
                    // (1/3)·r·|W′| with |W′| = 3·(15/πh⁶)(h − r)².
                    s1 += v * r * spiky * u * u;
                    c0 += v * Poly6::value(r as f32, h_m) as f64;
                    l2 += v * r * r * Viscosity::laplacian(r as f32, h_m) as f64 / 6.0;
                }
            }
        }
        LatticeMoments {
            density: s0 as f32,
            gradient: s1 as f32,
            colour: c0 as f32,
            laplacian: l2 as f32,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// 4π ∫₀^h r² W dr by composite Simpson in f64 on the f32 kernel.
    fn volume_integral<K: Kernel>(h: f32) -> f64 {
        let n = 20_000;
        let dr = h as f64 / n as f64;
        let mut s = 0.0;
        for k in 0..=n {
            let r = k as f64 * dr;
            let w = if k == 0 {
                0.0
            } else {
                K::value(r as f32, h) as f64 * r * r
            };
            let c = if k == 0 || k == n {
                1.0
            } else if k % 2 == 1 {
                4.0
            } else {
                2.0
            };
            s += c * w;
        }
        4.0 * PI * s * dr / 3.0
    }

    #[test]
    fn kernels_are_normalised() {
        for h in [0.0457f32, 1.0] {
            assert!((volume_integral::<Poly6>(h) - 1.0).abs() < 1e-4);
            assert!((volume_integral::<Spiky>(h) - 1.0).abs() < 1e-4);
            assert!((volume_integral::<Viscosity>(h) - 1.0).abs() < 1e-4);
        }
    }

    #[test]
    fn published_constants_at_kelager_h() {
        // W_poly6(0) = 315/(64π h³) = 16414.67 at Kelager (2006)'s h = 0.0457 m.
        let w0 = Poly6::value(0.0, 0.0457);
        assert!((w0 / 16414.67 - 1.0).abs() < 1e-5, "{w0}");
        assert!((Spiky::value(0.0, 1.0) - 15.0 / std::f32::consts::PI).abs() < 1e-6);
    }

    #[test]
    fn coincident_particles_stay_finite() {
        let h = 0.01;
        assert_eq!(Spiky::gradient(Vec3::ZERO, h), Vec3::ZERO);
        assert_eq!(Viscosity::gradient(Vec3::ZERO, h), Vec3::ZERO);
        assert!(Viscosity::value(0.0, h).is_finite());
        assert!(Viscosity::laplacian(0.0, h).is_finite() && Viscosity::laplacian(0.0, h) > 0.0);
        assert!(Spiky::laplacian(0.0, h).is_finite());
    }

    /// The lattice moments tend to their continuum values (all 1) as the lattice refines.
    #[test]
    fn lattice_moments_tend_to_the_continuum() {
        let coarse = LatticeMoments::new(0.5, 1.0);
        let fine = LatticeMoments::new(1.0 / 8.0, 1.0);
        for (name, c, f) in [
            ("density", coarse.density, fine.density),
            ("gradient", coarse.gradient, fine.gradient),
            ("colour", coarse.colour, fine.colour),
            ("laplacian", coarse.laplacian, fine.laplacian),
        ] {
            assert!((f - 1.0).abs() < 0.01, "{name}: {f} at h = 8Δx");
            assert!(
                (f - 1.0).abs() <= (c - 1.0).abs() + 1e-6,
                "{name}: {c} → {f}"
            );
        }
        // Spiky's cusp: the coarse density sum is the 1.24 the docs quote.
        assert!((coarse.density - 1.236).abs() < 1e-3, "{coarse:?}");
    }
}
