//! The shape of a falling, oscillating drop: Beard & Chuang's oblate equilibrium (the same
//! axis ratio the streak widths use) deformed by the two Rayleigh modes that dominate a falling
//! drop, the axisymmetric oblate–prolate mode (2,0) and the transverse mode (3,1)
//! (Garg & Nayar 2006, after Beard & Kubesh; physics notes §3.4):
//!
//! r(θ, φ, t) = r_eq(θ) · [1 + A₂₀ P₂(cos θ) cos ω₂t + A₃₁ P₃¹(cos θ) cos φ cos ω₃t],
//!
//! with θ measured from the vertical, φ from the transverse mode's axis, and the Rayleigh
//! frequencies ω_n² = σ n(n−1)(n+2)/(ρ a³) for the equivalent radius a.

use glam::DVec3;

use crate::rain::physics::axis_ratio;

/// Surface tension of water at 20 °C, N/m.
pub const WATER_SURFACE_TENSION_N_PER_M: f64 = 0.0728;
/// Density of water, kg/m³.
pub const WATER_DENSITY_KG_PER_M3: f64 = 1000.0;

/// Rayleigh frequency of mode n, Hz: f_n = (1/2π) √(σ n(n−1)(n+2)/(ρ a³)) (physics notes §3.4:
/// 343.5 Hz for the (2,0) mode of a 1 mm drop).
pub fn rayleigh_frequency_hz(n: u32, diameter_m: f64) -> f64 {
    let a = 0.5 * diameter_m;
    let n = n as f64;
    let omega2 = WATER_SURFACE_TENSION_N_PER_M * n * (n - 1.0) * (n + 2.0)
        / (WATER_DENSITY_KG_PER_M3 * a * a * a);
    omega2.sqrt() / std::f64::consts::TAU
}

/// Oscillation amplitudes (relative radius) of the two modes.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Amplitudes {
    /// A₂₀, the oblate–prolate mode.
    pub a20: f64,
    /// A₃₁, the transverse mode.
    pub a31: f64,
}

impl Amplitudes {
    /// No oscillation: the equilibrium shape.
    pub const NONE: Amplitudes = Amplitudes { a20: 0.0, a31: 0.0 };

    /// The amplitudes the generator uses by default: A₂₀ = 0.025 D/mm (capped at 0.1),
    /// A₃₁ = A₂₀/2, growing with size (larger drops oscillate more). A₂₀ = 0.05 swings the axis
    /// ratio of a 2 mm drop by ±0.075. Their fitted values could not be read, so these are a
    /// model choice, neither their fit nor a measurement.
    pub fn for_diameter_mm(d_mm: f64) -> Amplitudes {
        let a20 = (0.025 * d_mm).min(0.1);
        Amplitudes {
            a20,
            a31: 0.5 * a20,
        }
    }
}

/// A drop of equivalent diameter D whose shape oscillates about its equilibrium.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OscillatingDrop {
    /// Horizontal semi-axis of the equilibrium spheroid, m.
    pub semi_horizontal_m: f64,
    /// Vertical semi-axis of the equilibrium spheroid, m.
    pub semi_vertical_m: f64,
    /// Mode amplitudes.
    pub amplitudes: Amplitudes,
    /// Angular frequencies ω₂, ω₃ of the (2,0) and (3,1) modes, rad/s.
    pub omega_rad_per_s: [f64; 2],
    /// Horizontal unit axis of the transverse mode (φ = 0).
    pub transverse_axis: DVec3,
}

/// The drop's shape frozen at one instant: the coefficients of the surface r(θ, φ).
#[derive(Debug, Clone, Copy)]
pub struct Shape {
    inv_a2: f64,
    inv_b2: f64,
    /// A₂₀ cos ω₂t.
    alpha: f64,
    /// A₃₁ cos ω₃t.
    beta: f64,
    axis: DVec3,
    /// Radius of a sphere that holds the drop at every phase, m.
    pub bound_m: f64,
}

impl OscillatingDrop {
    /// A drop of equivalent diameter `diameter_m`: Beard & Chuang's spheroid (volume πD³/6)
    /// oscillating with `amplitudes` at the Rayleigh frequencies, the transverse mode along
    /// `transverse_axis` (horizontal).
    pub fn new(diameter_m: f64, amplitudes: Amplitudes, transverse_axis: DVec3) -> OscillatingDrop {
        let r = axis_ratio(diameter_m * 1e3);
        let a = 0.5 * diameter_m;
        OscillatingDrop {
            semi_horizontal_m: a * r.powf(-1.0 / 3.0),
            semi_vertical_m: a * r.powf(2.0 / 3.0),
            amplitudes,
            omega_rad_per_s: [2, 3]
                .map(|n| std::f64::consts::TAU * rayleigh_frequency_hz(n, diameter_m)),
            transverse_axis: DVec3::new(transverse_axis.x, transverse_axis.y, 0.0).normalize(),
        }
    }

    /// The shape at drop age `t_s`.
    pub fn at(&self, t_s: f64) -> Shape {
        let Amplitudes { a20, a31 } = self.amplitudes;
        // |P₂| ≤ 1 and |(3/2)(5c²−1)s| ≤ 2 on the sphere.
        let bound =
            self.semi_horizontal_m.max(self.semi_vertical_m) * (1.0 + a20.abs() + 2.0 * a31.abs());
        Shape {
            inv_a2: self.semi_horizontal_m.powi(-2),
            inv_b2: self.semi_vertical_m.powi(-2),
            alpha: a20 * (self.omega_rad_per_s[0] * t_s).cos(),
            beta: a31 * (self.omega_rad_per_s[1] * t_s).cos(),
            axis: self.transverse_axis,
            bound_m: bound * 1.000_001,
        }
    }
}

impl Shape {
    /// r(c, q) and its partial derivatives, with c = cos θ = ẑ·p̂ and q = sin θ cos φ = x̂′·p̂
    /// (the surface is a polynomial in these two, so no trigonometry per evaluation).
    fn radius(&self, c: f64, q: f64) -> (f64, f64, f64) {
        let c2 = c * c;
        let g = (1.0 - c2) * self.inv_a2 + c2 * self.inv_b2;
        let r_eq = 1.0 / g.sqrt();
        let dr_eq = -r_eq * r_eq * r_eq * c * (self.inv_b2 - self.inv_a2);
        let p31 = 1.5 * (5.0 * c2 - 1.0);
        let s = 1.0 + self.alpha * 0.5 * (3.0 * c2 - 1.0) + self.beta * p31 * q;
        let ds_dc = 3.0 * c * self.alpha + 15.0 * c * q * self.beta;
        let ds_dq = self.beta * p31;
        (r_eq * s, dr_eq * s + r_eq * ds_dc, r_eq * ds_dq)
    }

    /// Implicit surface F(p) = |p| − r(p̂): negative inside, positive outside.
    pub fn implicit(&self, p: DVec3) -> f64 {
        let len = p.length();
        if len == 0.0 {
            return -1.0;
        }
        let (r, _, _) = self.radius(p.z / len, p.dot(self.axis) / len);
        len - r
    }

    /// Outward unit normal at a surface point: ∇F = p̂ − (r_c ∇c + r_q ∇q), ∇c = (ẑ − c p̂)/|p|,
    /// ∇q = (x̂′ − q p̂)/|p|.
    pub fn normal(&self, p: DVec3) -> DVec3 {
        let len = p.length();
        let u = p / len;
        let (c, q) = (u.z, u.dot(self.axis));
        let (_, r_c, r_q) = self.radius(c, q);
        let grad = u - (r_c * (DVec3::Z - c * u) + r_q * (self.axis - q * u)) / len;
        grad.normalize()
    }

    /// Where a ray from outside first enters the drop, as a distance along `dir` (unit), or
    /// `None`. The chord through the bounding sphere is sampled for a point inside, then the
    /// crossing bisected; chords shorter than 1/64 of the bounding diameter (a rim of about
    /// 0.03 % of the silhouette) are missed.
    pub fn entry(&self, origin: DVec3, dir: DVec3) -> Option<f64> {
        let b = origin.dot(dir);
        let disc = b * b - (origin.length_squared() - self.bound_m * self.bound_m);
        if disc <= 0.0 {
            return None;
        }
        let (s0, s1) = (-b - disc.sqrt(), -b + disc.sqrt());
        const N: usize = 64;
        let h = (s1 - s0) / N as f64;
        let inside = (1..N)
            .map(|k| s0 + k as f64 * h)
            .find(|&s| self.implicit(origin + s * dir) < 0.0)?;
        Some(self.bisect(origin, dir, inside - h, inside))
    }

    /// Where a ray starting on the surface and heading inwards leaves the drop again. The drop is
    /// convex for the amplitudes used, so the ray is inside until that single crossing.
    pub fn exit(&self, origin: DVec3, dir: DVec3) -> f64 {
        let far = 2.0 * self.bound_m + origin.length();
        let near = 1e-9 * self.bound_m;
        self.bisect(origin, dir, far, near)
    }

    /// The crossing of F between `outside` and `inside` distances, to machine precision.
    fn bisect(&self, origin: DVec3, dir: DVec3, mut outside: f64, mut inside: f64) -> f64 {
        for _ in 0..60 {
            let mid = 0.5 * (outside + inside);
            if mid == outside || mid == inside {
                break;
            }
            if self.implicit(origin + mid * dir) < 0.0 {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        0.5 * (outside + inside)
    }
}
