//! Real spherical harmonics (thesis chapter 4) up to [`MAX_BANDS`] bands.
//!
//! ## Conventions (shared by the environment, the RTF and `shaders/common/sh.wgsl`)
//!
//! - Directions: world frame, **z up**; θ is measured from +z and φ from +x towards +y, so
//!   `dir = (sinθ cosφ, sinθ sinφ, cosθ)`.
//! - Index `i = l(l+1) + m`, bands `l = 0..bands-1`, `bands²` coefficients.
//! - Definition (4.14): `√2 K_l^m cos(mφ) P_l^m(cosθ)` for m > 0, `√2 K_l^m sin(|m|φ)
//!   P_l^|m|(cosθ)` for m < 0, `K_l^0 P_l^0(cosθ)` for m = 0, with `K` from (4.15).
//! - **No Condon–Shortley phase** ("convention A"): `P_m^m = (2m−1)!! (1−x²)^{m/2}`, i.e. (4.8)
//!   without its `(−1)^m`. Then every Cartesian form has a positive constant
//!   (`Y_1,−1 = +0.4886 y`, `Y_1,1 = +0.4886 x`), as in most shader code. Coefficients in the
//!   Condon–Shortley convention differ by `(−1)^m`: mixing the two breaks odd-m products.
//!
//! ## How it works
//!
//! The associated Legendre functions come from the stable recurrence (4.7)–(4.10), run on
//! `P_l^m / sin^m θ` (a polynomial in `z`); the `sin^m θ cos(mφ)` and `sin^m θ sin(mφ)` factors
//! are the real and imaginary parts of `(x + i y)^m`. This avoids `atan2` and is exact at the
//! poles. Projections use explicit quadratures (directions with solid-angle weights) rather than
//! Monte Carlo (4.18): for band-limited work a Gauss–Legendre × uniform-φ product rule is exact.

use glam::{DMat3, DVec3};

use crate::{Error, Result};

/// The largest number of bands supported (64 coefficients).
pub const MAX_BANDS: usize = 8;

/// Number of coefficients for `bands` bands.
pub const fn num_coeffs(bands: usize) -> usize {
    bands * bands
}

/// Coefficient index of `(l, m)`: `l(l+1) + m`.
pub const fn index(l: usize, m: i32) -> usize {
    ((l * (l + 1)) as isize + m as isize) as usize
}

/// Band `l` of coefficient index `i`.
pub fn band_of(i: usize) -> usize {
    (i as f64).sqrt().floor() as usize
}

/// Checks a user-supplied band count (`1..=8`).
pub fn check_bands(bands: usize) -> Result<()> {
    if (1..=MAX_BANDS).contains(&bands) {
        Ok(())
    } else {
        Err(Error::Parameter {
            name: "inspect.bands",
            value: bands.to_string(),
            expected: format!("an integer in 1..={MAX_BANDS}"),
        })
    }
}

fn factorial(n: usize) -> f64 {
    (1..=n).map(|k| k as f64).product()
}

/// `K_l^m` for `0 ≤ m ≤ l < MAX_BANDS`, computed once (`[l][m]`).
static K_TABLE: std::sync::LazyLock<[[f64; MAX_BANDS]; MAX_BANDS]> =
    std::sync::LazyLock::new(|| {
        let mut k = [[0.0; MAX_BANDS]; MAX_BANDS];
        for (l, row) in k.iter_mut().enumerate() {
            for (m, v) in row.iter_mut().enumerate().take(l + 1) {
                *v = k_norm(l, m as i32);
            }
        }
        k
    });

/// Normalisation `K_l^m = sqrt((2l+1)/(4π) · (l−|m|)!/(l+|m|)!)` (4.15).
pub fn k_norm(l: usize, m: i32) -> f64 {
    let am = m.unsigned_abs() as usize;
    ((2 * l + 1) as f64 / (4.0 * std::f64::consts::PI) * factorial(l - am) / factorial(l + am))
        .sqrt()
}

/// Legendre polynomial `P_l(x)` by Bonnet's recurrence (4.10 with m = 0).
pub fn legendre(l: usize, x: f64) -> f64 {
    let (mut p0, mut p1) = (1.0, x);
    if l == 0 {
        return p0;
    }
    for k in 2..=l {
        let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = p2;
    }
    p1
}

/// Zonal basis function `Y_l0(cosθ) = K_l^0 P_l(cosθ)`.
pub fn zonal_basis(l: usize, cos_theta: f64) -> f64 {
    k_norm(l, 0) * legendre(l, cos_theta)
}

/// `∫_a^b P_l(t) dt`, exactly: `(P_{l+1} − P_{l−1}) / (2l+1)` evaluated between the limits.
pub fn legendre_integral(l: usize, a: f64, b: f64) -> f64 {
    if l == 0 {
        return b - a;
    }
    let f = |t: f64| (legendre(l + 1, t) - legendre(l - 1, t)) / (2 * l + 1) as f64;
    f(b) - f(a)
}

/// Evaluates all `bands²` basis functions at `dir` (normalised here; a zero vector reads as +z).
///
/// # Panics
/// If `bands > MAX_BANDS` or `out.len() < bands²` (programming errors, not user input).
pub fn eval_basis(dir: DVec3, bands: usize, out: &mut [f64]) {
    assert!(bands <= MAX_BANDS && out.len() >= bands * bands);
    let d = dir.normalize_or(DVec3::Z);
    let (x, y, z) = (d.x, d.y, d.z);
    let kt = &*K_TABLE;
    // (x + iy)^m = sin^m θ (cos mφ + i sin mφ)
    let (mut cm, mut sm) = (1.0, 0.0);
    // P_m^m / sin^m θ = (2m−1)!!, no Condon–Shortley phase (4.8).
    let mut pmm = 1.0;
    for m in 0..bands {
        if m > 0 {
            pmm *= (2 * m - 1) as f64;
            let c = cm * x - sm * y;
            sm = cm * y + sm * x;
            cm = c;
        }
        // Upward recurrence in l at fixed m (4.9, 4.10).
        let mut p_prev = 0.0;
        let mut p = pmm;
        for l in m..bands {
            if l == m + 1 {
                p_prev = p;
                p = z * (2 * m + 1) as f64 * pmm;
            } else if l > m + 1 {
                let next =
                    (z * (2 * l - 1) as f64 * p - (l + m - 1) as f64 * p_prev) / (l - m) as f64;
                p_prev = p;
                p = next;
            }
            let k = kt[l][m];
            if m == 0 {
                out[index(l, 0)] = k * p;
            } else {
                let s = std::f64::consts::SQRT_2 * k * p;
                out[index(l, m as i32)] = s * cm;
                out[index(l, -(m as i32))] = s * sm;
            }
        }
    }
}

/// The basis as a fresh vector (convenience for tests and tools).
pub fn basis(dir: DVec3, bands: usize) -> Vec<f64> {
    let mut out = vec![0.0; bands * bands];
    eval_basis(dir, bands, &mut out);
    out
}

/// Cartesian forms of the first 16 functions: the CPU twin of `sh_basis16` in
/// `shaders/common/sh.wgsl`, constant for constant (keep the two in sync). `d` must be unit.
pub fn basis16_cartesian(d: DVec3) -> [f64; 16] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_094_791_773_878_14,
        0.488_602_511_902_919_9 * y,
        0.488_602_511_902_919_9 * z,
        0.488_602_511_902_919_9 * x,
        1.092_548_430_592_079_2 * x * y,
        1.092_548_430_592_079_2 * y * z,
        0.315_391_565_252_520_05 * (3.0 * z * z - 1.0),
        1.092_548_430_592_079_2 * x * z,
        0.546_274_215_296_039_6 * (x * x - y * y),
        0.590_043_589_926_643_5 * y * (3.0 * x * x - y * y),
        2.890_611_442_640_554 * x * y * z,
        0.457_045_799_464_465_8 * y * (5.0 * z * z - 1.0),
        0.373_176_332_590_115_4 * z * (5.0 * z * z - 3.0),
        0.457_045_799_464_465_8 * x * (5.0 * z * z - 1.0),
        1.445_305_721_320_277 * z * (x * x - y * y),
        0.590_043_589_926_643_5 * x * (x * x - 3.0 * y * y),
    ]
}

/// [`basis16_cartesian`] in `f32` at unit (x, y, z), as the shader computes it: the CPU back
/// end's per-pixel and per-drop loops call it (inlined, so the vectoriser takes it whole).
#[inline(always)]
pub fn basis16_cartesian_f32(x: f32, y: f32, z: f32) -> [f32; 16] {
    [
        0.282_094_8,
        0.488_602_5 * y,
        0.488_602_5 * z,
        0.488_602_5 * x,
        1.092_548_4 * x * y,
        1.092_548_4 * y * z,
        0.315_391_57 * (3.0 * z * z - 1.0),
        1.092_548_4 * x * z,
        0.546_274_2 * (x * x - y * y),
        0.590_043_6 * y * (3.0 * x * x - y * y),
        2.890_611_4 * x * y * z,
        0.457_045_8 * y * (5.0 * z * z - 1.0),
        0.373_176_33 * z * (5.0 * z * z - 3.0),
        0.457_045_8 * x * (5.0 * z * z - 1.0),
        1.445_305_7 * z * (x * x - y * y),
        0.590_043_6 * x * (x * x - 3.0 * y * y),
    ]
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on `P_n`); exact for degree ≤ 2n−1.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            // P_n'(x) = n (x P_n − P_{n−1}) / (x² − 1)
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        nodes[i] = x;
        nodes[n - 1 - i] = -x;
        weights[i] = w;
        weights[n - 1 - i] = w;
    }
    if n % 2 == 1 {
        nodes[n / 2] = 0.0;
    }
    (nodes, weights)
}

/// Composite Gauss–Legendre rule on `[a, b]`: `panels` equal panels of `order` points.
pub fn composite_gauss(a: f64, b: f64, panels: usize, order: usize) -> Vec<(f64, f64)> {
    let (x, w) = gauss_legendre(order);
    let h = (b - a) / panels as f64;
    let mut out = Vec::with_capacity(panels * order);
    for p in 0..panels {
        let c = a + (p as f64 + 0.5) * h;
        for (xi, wi) in x.iter().zip(&w) {
            out.push((c + 0.5 * h * xi, 0.5 * h * wi));
        }
    }
    out
}

/// Direction of the centre of texel `(col, row)` of a `width × height` equirectangular map:
/// `φ = 2π(col+½)/width`, `θ = π(row+½)/height` (row 0 at the zenith).
pub fn equirect_direction(col: usize, row: usize, width: usize, height: usize) -> DVec3 {
    let phi = 2.0 * std::f64::consts::PI * (col as f64 + 0.5) / width as f64;
    let theta = std::f64::consts::PI * (row as f64 + 0.5) / height as f64;
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// Exact solid angle of an equirectangular texel in row `row`:
/// `(2π/width)(cos θ_top − cos θ_bottom)`. The weights of a map sum to exactly 4π.
pub fn equirect_texel_solid_angle_sr(row: usize, width: usize, height: usize) -> f64 {
    let pi = std::f64::consts::PI;
    let t0 = pi * row as f64 / height as f64;
    let t1 = pi * (row + 1) as f64 / height as f64;
    2.0 * pi / width as f64 * (t0.cos() - t1.cos())
}

/// Directions on the sphere with solid-angle weights (steradians) that sum to 4π.
#[derive(Debug, Clone)]
pub struct SphereQuadrature {
    /// Unit directions.
    pub dirs: Vec<DVec3>,
    /// Solid angle of each direction's cell, steradians.
    pub weights_sr: Vec<f64>,
}

impl SphereQuadrature {
    /// Gauss–Legendre in `cosθ` × uniform `φ`: exact for spherical polynomials of degree
    /// `≤ min(2 n_theta − 1, n_phi − 1)`.
    pub fn gauss_legendre(n_theta: usize, n_phi: usize) -> SphereQuadrature {
        let (zs, ws) = gauss_legendre(n_theta);
        let dphi = 2.0 * std::f64::consts::PI / n_phi as f64;
        let mut dirs = Vec::with_capacity(n_theta * n_phi);
        let mut weights_sr = Vec::with_capacity(n_theta * n_phi);
        for (z, w) in zs.iter().zip(&ws) {
            let s = (1.0 - z * z).max(0.0).sqrt();
            for j in 0..n_phi {
                let phi = (j as f64 + 0.5) * dphi;
                dirs.push(DVec3::new(s * phi.cos(), s * phi.sin(), *z));
                weights_sr.push(w * dphi);
            }
        }
        SphereQuadrature { dirs, weights_sr }
    }

    /// Texel centres of an equirectangular map with exact texel solid angles, row-major.
    pub fn equirect(width: usize, height: usize) -> SphereQuadrature {
        let mut dirs = Vec::with_capacity(width * height);
        let mut weights_sr = Vec::with_capacity(width * height);
        for row in 0..height {
            let w = equirect_texel_solid_angle_sr(row, width, height);
            for col in 0..width {
                dirs.push(equirect_direction(col, row, width, height));
                weights_sr.push(w);
            }
        }
        SphereQuadrature { dirs, weights_sr }
    }
}

/// Projection (4.16) `c_i = ∫ f Y_i dω` of samples `values[k] = f(quad.dirs[k])`.
pub fn project_samples(values: &[f64], quad: &SphereQuadrature, bands: usize) -> Vec<f64> {
    let mut c = vec![0.0; bands * bands];
    let mut y = vec![0.0; bands * bands];
    for ((v, d), w) in values.iter().zip(&quad.dirs).zip(&quad.weights_sr) {
        eval_basis(*d, bands, &mut y);
        for (ci, yi) in c.iter_mut().zip(&y) {
            *ci += v * w * yi;
        }
    }
    c
}

/// Projection (4.16) of a function of direction.
pub fn project(f: impl Fn(DVec3) -> f64, quad: &SphereQuadrature, bands: usize) -> Vec<f64> {
    let values: Vec<f64> = quad.dirs.iter().map(|d| f(*d)).collect();
    project_samples(&values, quad, bands)
}

/// Reconstruction (4.19) `f̃(dir) = Σ c_i Y_i(dir)`; the band count is `√coeffs.len()`.
pub fn reconstruct(coeffs: &[f64], dir: DVec3) -> f64 {
    let bands = (coeffs.len() as f64).sqrt() as usize;
    let y = basis(dir, bands);
    coeffs.iter().zip(&y).map(|(c, y)| c * y).sum()
}

/// Zonal-harmonic rotation: the coefficients of `g(ω·axis)` from the zonal coefficients `z_l` of
/// `g` about +z: `c_lm = sqrt(4π/(2l+1)) z_l Y_lm(axis)`. Writes `zonal.len()²` values.
pub fn zonal_rotate(zonal: &[f64], axis: DVec3, out: &mut [f64]) {
    let bands = zonal.len();
    eval_basis(axis, bands, out);
    for (l, z) in zonal.iter().enumerate() {
        let s = (4.0 * std::f64::consts::PI / (2 * l + 1) as f64).sqrt() * z;
        out[l * l..(l + 1) * (l + 1)]
            .iter_mut()
            .for_each(|v| *v *= s);
    }
}

/// Per-band rotation matrices for `rot` (row-major, `(2l+1)²` each): the rotated coefficients
/// `c' = M c` describe `f(rot⁻¹ ω)`. Built by exact quadrature of `∫ Y_i(ω) Y_j(rot⁻¹ω) dω`
/// (a degree-2l spherical polynomial, so `l+2` Gauss nodes × `2l+2` φ samples are exact).
pub fn rotation_matrices(rot: DMat3, bands: usize) -> Vec<Vec<f64>> {
    let inv = rot.transpose();
    (0..bands)
        .map(|l| {
            let n = 2 * l + 1;
            let quad = SphereQuadrature::gauss_legendre(l + 2, 2 * l + 2);
            let mut m = vec![0.0; n * n];
            let mut ya = vec![0.0; (l + 1) * (l + 1)];
            let mut yb = vec![0.0; (l + 1) * (l + 1)];
            for (d, w) in quad.dirs.iter().zip(&quad.weights_sr) {
                eval_basis(*d, l + 1, &mut ya);
                eval_basis(inv * *d, l + 1, &mut yb);
                for i in 0..n {
                    for j in 0..n {
                        m[i * n + j] += w * ya[l * l + i] * yb[l * l + j];
                    }
                }
            }
            m
        })
        .collect()
}

/// Rotates coefficients: the result describes `f(rot⁻¹ ω)`, i.e. `f` carried along by `rot`.
pub fn rotate(coeffs: &[f64], rot: DMat3) -> Vec<f64> {
    let bands = (coeffs.len() as f64).sqrt() as usize;
    let mats = rotation_matrices(rot, bands);
    let mut out = vec![0.0; coeffs.len()];
    for (l, m) in mats.iter().enumerate() {
        let n = 2 * l + 1;
        for i in 0..n {
            out[l * l + i] = (0..n).map(|j| m[i * n + j] * coeffs[l * l + j]).sum();
        }
    }
    out
}

/// Energy per band `Σ_m c_lm²`; invariant under rotation.
pub fn band_energy(coeffs: &[f64]) -> Vec<f64> {
    let bands = (coeffs.len() as f64).sqrt() as usize;
    (0..bands)
        .map(|l| coeffs[l * l..(l + 1) * (l + 1)].iter().map(|c| c * c).sum())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The f32 basis is the f64 one rounded: a mistyped constant moves a function by far more
    /// than f32's rounding.
    #[test]
    fn the_f32_basis_is_the_f64_basis() {
        for k in 0..500 {
            // Directions spread over the sphere by the golden angle.
            let z = 1.0 - (2 * k + 1) as f64 / 500.0;
            let phi = k as f64 * 2.399_963_229_728_653;
            let r = (1.0 - z * z).sqrt();
            let d = DVec3::new(r * phi.cos(), r * phi.sin(), z);
            let exact = basis16_cartesian(d);
            let single = basis16_cartesian_f32(d.x as f32, d.y as f32, d.z as f32);
            for (e, s) in exact.iter().zip(single) {
                assert!((e - s as f64).abs() < 2e-6, "{e} vs {s} at {d}");
            }
        }
    }

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        let (x, w) = gauss_legendre(7);
        for k in 0..14 {
            let exact = if k % 2 == 0 {
                2.0 / (k + 1) as f64
            } else {
                0.0
            };
            let got: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(k)).sum();
            assert!((got - exact).abs() < 1e-14, "k={k}: {got} vs {exact}");
        }
    }

    #[test]
    fn index_round_trip() {
        assert_eq!(index(0, 0), 0);
        assert_eq!(index(1, -1), 1);
        assert_eq!(index(3, 3), 15);
        for i in 0..64 {
            let l = band_of(i);
            assert!(l * l <= i && i < (l + 1) * (l + 1));
        }
    }

    #[test]
    fn addition_theorem() {
        // Σ_m Y_lm(d)² = (2l+1)/(4π) for every direction, poles included.
        for d in [DVec3::Z, -DVec3::Z, DVec3::new(0.3, -0.5, 0.81), DVec3::X] {
            let y = basis(d, 8);
            for l in 0..8 {
                let s: f64 = y[l * l..(l + 1) * (l + 1)].iter().map(|v| v * v).sum();
                let e = (2 * l + 1) as f64 / (4.0 * std::f64::consts::PI);
                assert!((s - e).abs() < 1e-12, "l={l} d={d:?}: {s} vs {e}");
            }
        }
    }

    #[test]
    fn bands_are_validated() {
        assert!(check_bands(0).is_err());
        assert!(check_bands(9).is_err());
        assert!(check_bands(4).is_ok());
    }
}
