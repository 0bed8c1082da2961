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
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Poly6;

/// Spiky kernel (Desbrun & Gascuel 1996), W = 15/(π h⁶) (h − r)³ — thesis (3.12), used for
/// pressure (5.20) and, here, density (5.18).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Spiky;

/// Viscosity kernel, W = 15/(2π h³) (−r³/(2h³) + r²/h² + h/(2r) − 1) — thesis (3.13), whose
/// Laplacian 45/(π h⁶)(h − r) is positive; used for viscosity (5.21).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
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
        // physics notes §5.1: W_poly6(0) = 315/(64π h³) = 16414.67 at h = 0.0457.
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
}
