//! Lighting against independent references: closed-form SH projections, a Monte Carlo vector
//! ray tracer of a sphere, direct integration over the drop, a real HDR photograph, naga, and
//! (where an adapter exists) the WGSL twin on a GPU.

use std::f64::consts::{FRAC_PI_2, PI};

use glam::{DMat3, DVec2, DVec3};
use rain_composite::lighting::envmap::{EnvMapSettings, EnvMapper, EnvironmentSh, ShSmoother};
use rain_composite::lighting::prt::{
    RtfSh, brute_force_colour, brute_force_colour_table, channel_optics, prt_colour_f64,
};
use rain_composite::lighting::rtf::{DropOptics, Polarisation};
use rain_composite::lighting::{inspect, sh};
use rain_composite::scene::Camera;
use rayon::prelude::*;

// ---------------------------------------------------------------------------------------------
// Helpers

use rain_composite::rng::SplitMix64 as Rng;

/// A uniform random direction on the sphere.
trait RandomDir {
    fn dir(&mut self) -> DVec3;
}

impl RandomDir for Rng {
    fn dir(&mut self) -> DVec3 {
        let z = 2.0 * self.next_f64() - 1.0;
        let phi = 2.0 * PI * self.next_f64();
        let s = (1.0 - z * z).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), z)
    }
}

/// A product quadrature on the upper cap z ∈ [0, 1] only (for functions that vanish below).
fn upper_hemisphere_quadrature(n_z: usize, n_phi: usize) -> sh::SphereQuadrature {
    let (x, w) = sh::gauss_legendre(n_z);
    let mut q = sh::SphereQuadrature {
        dirs: vec![],
        weights_sr: vec![],
    };
    for (xi, wi) in x.iter().zip(&w) {
        let z = 0.5 * (xi + 1.0);
        let s = (1.0 - z * z).sqrt();
        for j in 0..n_phi {
            let phi = 2.0 * PI * (j as f64 + 0.5) / n_phi as f64;
            q.dirs.push(DVec3::new(s * phi.cos(), s * phi.sin(), z));
            q.weights_sr.push(0.5 * wi * 2.0 * PI / n_phi as f64);
        }
    }
    q
}

// ---------------------------------------------------------------------------------------------
// Spherical harmonics

#[test]
fn sh_orthonormal_up_to_8_bands() {
    // Degree ≤ 14 products: 16 Gauss nodes × 32 azimuths integrate them exactly.
    let q = sh::SphereQuadrature::gauss_legendre(16, 32);
    let n = 64;
    let ys: Vec<Vec<f64>> = q.dirs.iter().map(|d| sh::basis(*d, 8)).collect();
    let mut worst = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let g: f64 = ys
                .iter()
                .zip(&q.weights_sr)
                .map(|(y, w)| w * y[i] * y[j])
                .sum();
            let e = if i == j { 1.0 } else { 0.0 };
            worst = worst.max((g - e).abs());
        }
    }
    assert!(worst < 1e-12, "max |G − I| = {worst:e}");
}

#[test]
fn sh_cartesian_forms_equal_legendre_definition() {
    // Constants from their closed forms, written here independently of the library.
    let (sp, s) = (PI.sqrt(), |v: f64| v.sqrt());
    let c = [
        0.5 / sp,
        s(3.0 / (4.0 * PI)),
        0.5 * s(15.0 / PI),
        0.25 * s(5.0 / PI),
        0.25 * s(15.0 / PI),
        0.25 * s(35.0 / (2.0 * PI)),
        0.5 * s(105.0 / PI),
        0.25 * s(21.0 / (2.0 * PI)),
        0.25 * s(7.0 / PI),
        0.25 * s(105.0 / PI),
    ];
    let closed = |d: DVec3| {
        let (x, y, z) = (d.x, d.y, d.z);
        [
            c[0],
            c[1] * y,
            c[1] * z,
            c[1] * x,
            c[2] * x * y,
            c[2] * y * z,
            c[3] * (3.0 * z * z - 1.0),
            c[2] * x * z,
            c[4] * (x * x - y * y),
            c[5] * y * (3.0 * x * x - y * y),
            c[6] * x * y * z,
            c[7] * y * (5.0 * z * z - 1.0),
            c[8] * z * (5.0 * z * z - 3.0),
            c[7] * x * (5.0 * z * z - 1.0),
            c[9] * z * (x * x - y * y),
            c[5] * x * (x * x - 3.0 * y * y),
        ]
    };
    let mut rng = Rng(7);
    let mut dirs: Vec<DVec3> = (0..500).map(|_| rng.dir()).collect();
    dirs.extend([DVec3::Z, -DVec3::Z, DVec3::X, -DVec3::Y]);
    for d in dirs {
        let legendre = sh::basis(d, 4);
        let cart = sh::basis16_cartesian(d);
        let cf = closed(d);
        for i in 0..16 {
            assert!((legendre[i] - cf[i]).abs() < 1e-14, "i={i} d={d:?}");
            assert!((cart[i] - cf[i]).abs() < 1e-14, "i={i} d={d:?}");
        }
    }
}

#[test]
fn sh_known_projections() {
    let q = sh::SphereQuadrature::gauss_legendre(24, 48);
    let c = sh::project(|_| 1.0, &q, 8);
    assert!((c[0] - 2.0 * PI.sqrt()).abs() < 1e-13);
    assert!(c[1..].iter().all(|v| v.abs() < 1e-13));

    // Clamped cosine and hemisphere indicator about +z: exact on the upper cap (no kink).
    let cap = upper_hemisphere_quadrature(24, 48);
    let cos = sh::project(|d| d.z, &cap, 5);
    let expect = [
        PI.sqrt() / 2.0,
        (PI / 3.0).sqrt(),
        (5.0 * PI).sqrt() / 8.0,
        0.0,
        -PI.sqrt() / 16.0,
    ];
    for (l, e) in expect.iter().enumerate() {
        let got = cos[sh::index(l, 0)];
        assert!(
            (got - e).abs() < 1e-13,
            "clamped cosine z_{l} = {got} vs {e}"
        );
    }
    assert!((expect[4] - -0.110_778_365_7).abs() < 1e-10);
    let hemi = sh::project(|_| 1.0, &cap, 4);
    let expect = [
        PI.sqrt(),
        (3.0 * PI).sqrt() / 2.0,
        0.0,
        -(7.0 * PI).sqrt() / 8.0,
    ];
    for (l, e) in expect.iter().enumerate() {
        assert!(
            (hemi[sh::index(l, 0)] - e).abs() < 1e-13,
            "hemisphere z_{l}"
        );
    }
    for (i, v) in hemi.iter().enumerate() {
        if sh::index(sh::band_of(i), 0) != i {
            assert!(v.abs() < 1e-13, "non-zonal coefficient {i} = {v}");
        }
    }
}

#[test]
fn sh_zonal_rotation_matches_direct_projection() {
    // A clamped cosine about n: rotate the zonal coefficients vs project it directly on a fine
    // equirectangular grid (the kink limits that quadrature to ~1e-5).
    let n = DVec3::new(0.0, 0.6, 0.8);
    let z = [
        PI.sqrt() / 2.0,
        (PI / 3.0).sqrt(),
        (5.0 * PI).sqrt() / 8.0,
        0.0,
    ];
    let mut rotated = vec![0.0; 16];
    sh::zonal_rotate(&z, n, &mut rotated);
    let q = sh::SphereQuadrature::equirect(1024, 512);
    let direct = sh::project(|d| d.dot(n).max(0.0), &q, 4);
    for i in 0..16 {
        assert!(
            (rotated[i] - direct[i]).abs() < 1e-4,
            "{i}: {} vs {}",
            rotated[i],
            direct[i]
        );
    }
}

#[test]
fn sh_rotation_preserves_band_energy_and_values() {
    let mut rng = Rng(11);
    let coeffs: Vec<f64> = (0..64).map(|_| rng.next_f64() * 2.0 - 1.0).collect();
    let axis = DVec3::new(0.234, -0.642, 0.829).normalize();
    let rot = DMat3::from_axis_angle(axis, 0.423) * DMat3::from_rotation_z(1.1);
    let rotated = sh::rotate(&coeffs, rot);
    for (a, b) in sh::band_energy(&coeffs)
        .iter()
        .zip(sh::band_energy(&rotated))
    {
        assert!((a - b).abs() < 1e-12 * a.max(1.0), "{a} vs {b}");
    }
    // The rotated function carries values along: f_rot(R d) = f(d).
    for _ in 0..50 {
        let d = rng.dir();
        let (a, b) = (
            sh::reconstruct(&coeffs, d),
            sh::reconstruct(&rotated, rot * d),
        );
        assert!((a - b).abs() < 1e-11, "{a} vs {b}");
    }
}

#[test]
fn sh_reconstruction_error_falls_with_bands() {
    // A smooth lobe exp(2 ω·a); its L2 error after truncation is √(‖f‖² − Σ c²) (Parseval).
    let a = DVec3::new(0.3, -0.4, 0.86).normalize();
    let f = |d: DVec3| (2.0 * d.dot(a)).exp();
    let q = sh::SphereQuadrature::gauss_legendre(40, 80);
    let norm2: f64 = q
        .dirs
        .iter()
        .zip(&q.weights_sr)
        .map(|(d, w)| w * f(*d).powi(2))
        .sum();
    let c = sh::project(f, &q, 8);
    let mut last = f64::INFINITY;
    for bands in 1..=8 {
        let kept: f64 = c[..bands * bands].iter().map(|v| v * v).sum();
        let err = (norm2 - kept).max(0.0).sqrt() / norm2.sqrt();
        assert!(err < 0.7 * last, "bands {bands}: {err} vs {last}");
        last = err;
    }
    assert!(last < 1e-3, "8-band relative L2 error {last}");
}

// ---------------------------------------------------------------------------------------------
// RTF against a Monte Carlo vector ray tracer

/// Per (order, θ bin): Σ w and Σ w² for both polarisation treatments, plus ray count.
struct McTally {
    rays: usize,
    bins: usize,
    n_max: usize,
    /// [pol][order][bin] with pol 0 = separate, 1 = averaged.
    sum: [Vec<Vec<f64>>; 2],
    sum2: [Vec<Vec<f64>>; 2],
}

/// Fresnel amplitude → intensity reflectances for light in medium n1 meeting n2.
fn mc_fresnel(n1: f64, n2: f64, cos_i: f64) -> (f64, f64) {
    let sin_t2 = (n1 / n2).powi(2) * (1.0 - cos_i * cos_i);
    let cos_t = (1.0 - sin_t2).max(0.0).sqrt();
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    (rs * rs, rp * rp)
}

/// Refraction of unit `d` through a surface with unit normal `n` facing the incoming side.
fn mc_refract(d: DVec3, n: DVec3, eta: f64) -> DVec3 {
    let ci = -d.dot(n);
    let ct = (1.0 - eta * eta * (1.0 - ci * ci)).max(0.0).sqrt();
    d * eta + n * (eta * ci - ct)
}

/// Traces `rays` parallel rays (along −z) through a unit sphere of index `rho`, following every
/// reflection up to order `n_max`, splitting the weight at each interface (no roulette).
fn mc_trace(rho: f64, n_max: usize, bins: usize, rays: usize, seed: u64) -> McTally {
    let chunk = 1 << 15;
    let chunks = rays.div_ceil(chunk);
    let empty = || {
        let z = vec![vec![0.0; bins]; n_max];
        ([z.clone(), z.clone()], [z.clone(), z])
    };
    let (sum, sum2) = (0..chunks)
        .into_par_iter()
        .fold(empty, |(mut s, mut s2), c| {
            let mut rng = Rng(seed ^ (c as u64).wrapping_mul(0xA24B_AED4_963E_E407));
            let d_in = DVec3::new(0.0, 0.0, -1.0);
            let mut record = |n: usize, d_out: DVec3, w: [f64; 2]| {
                let theta = d_in.dot(d_out).clamp(-1.0, 1.0).acos();
                let m = ((theta / PI * bins as f64) as usize).min(bins - 1);
                for p in 0..2 {
                    s[p][n - 1][m] += w[p];
                    s2[p][n - 1][m] += w[p] * w[p];
                }
            };
            for _ in 0..chunk.min(rays - c * chunk) {
                // Uniform point on the projected disc → hit point on the sphere.
                let (r, phi) = (rng.next_f64().sqrt(), 2.0 * PI * rng.next_f64());
                let p = DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - r * r).max(0.0).sqrt());
                let ci = -d_in.dot(p);
                let (rs, rp) = mc_fresnel(1.0, rho, ci);
                let ra = 0.5 * (rs + rp);
                record(1, d_in - p * 2.0 * d_in.dot(p), [0.5 * (rs + rp), ra]);
                // Inside: weights (s, p, averaged).
                let (mut ws, mut wp, mut wa) = (1.0 - rs, 1.0 - rp, 1.0 - ra);
                let mut d = mc_refract(d_in, p, 1.0 / rho);
                let mut pos = p;
                for n in 2..=n_max {
                    pos += d * (-2.0 * pos.dot(d));
                    let nf = -pos; // normal facing the inside
                    let ci = -d.dot(nf);
                    let (rs, rp) = mc_fresnel(rho, 1.0, ci);
                    let ra = 0.5 * (rs + rp);
                    let out = mc_refract(d, nf, rho);
                    record(
                        n,
                        out,
                        [0.5 * (ws * (1.0 - rs) + wp * (1.0 - rp)), wa * (1.0 - ra)],
                    );
                    ws *= rs;
                    wp *= rp;
                    wa *= ra;
                    d -= nf * 2.0 * d.dot(nf);
                }
            }
            (s, s2)
        })
        .reduce(empty, |(mut a, mut a2), (b, b2)| {
            for p in 0..2 {
                for n in 0..n_max {
                    for m in 0..bins {
                        a[p][n][m] += b[p][n][m];
                        a2[p][n][m] += b2[p][n][m];
                    }
                }
            }
            (a, a2)
        });
    McTally {
        rays,
        bins,
        n_max,
        sum,
        sum2,
    }
}

fn bin_solid_angle(m: usize, bins: usize) -> f64 {
    let d = PI / bins as f64;
    2.0 * PI * ((m as f64 * d).cos() - ((m + 1) as f64 * d).cos())
}

/// Compares the table with the tally bin by bin. The MC estimate of a bin's energy is a mean
/// of N independent weights, so its standard error is √(Σw² − (Σw)²/N)/N ∝ 1/√count; bins
/// must agree within 5 standard errors, plus 1e-9 for rounding (the table's own quadrature
/// error is ~1e-12). Returns χ²/dof over well-populated bins as a global check.
fn compare_with_mc(tally: &McTally, optics: &DropOptics, pol: usize) -> f64 {
    let table = optics.tabulate(tally.bins).expect("table");
    let n_rays = tally.rays as f64;
    let (mut chi2, mut dof) = (0.0, 0usize);
    for n in 0..tally.n_max {
        for m in 0..tally.bins {
            let s = tally.sum[pol][n][m];
            let se = (tally.sum2[pol][n][m] - s * s / n_rays).max(0.0).sqrt() / n_rays;
            let e_mc = s / n_rays;
            let e_tab = table.per_order[n][m] * bin_solid_angle(m, tally.bins);
            // A bin the MC never reached must hold less than ~5 rays' worth in the table.
            let floor = 5.0 / n_rays
                * table.per_order[n]
                    .iter()
                    .cloned()
                    .fold(0.0, f64::max)
                    .min(1.0);
            assert!(
                (e_mc - e_tab).abs() <= 5.0 * se + 1e-9 + if s == 0.0 { floor } else { 0.0 },
                "ρ={} order {} bin {m}: MC {e_mc:e} ± {se:e} vs table {e_tab:e}",
                optics.rho(),
                n + 1
            );
            if tally.sum2[pol][n][m] > 0.0 && s * s / tally.sum2[pol][n][m] > 100.0 {
                chi2 += ((e_mc - e_tab) / se).powi(2);
                dof += 1;
            }
        }
        // Energy per order.
        let s: f64 = tally.sum[pol][n].iter().sum();
        let s2: f64 = tally.sum2[pol][n].iter().sum();
        let se = (s2 - s * s / n_rays).max(0.0).sqrt() / n_rays;
        let eps = optics.energy_per_order()[n];
        assert!(
            (s / n_rays - eps).abs() <= 5.0 * se + 1e-9,
            "order {} energy {} vs {eps}",
            n + 1,
            s / n_rays
        );
    }
    chi2 / dof.max(1) as f64
}

#[test]
fn rtf_matches_monte_carlo_ray_tracer() {
    let (bins, n_max, rays) = (180, 9, 1_000_000);
    for (rho, seed) in [(1.333, 1u64), (1.5, 2)] {
        let tally = mc_trace(rho, n_max, bins, rays, seed);
        for (pol, mode) in [(0, Polarisation::Separate), (1, Polarisation::Averaged)] {
            let optics = DropOptics::new(rho, n_max).unwrap().with_polarisation(mode);
            let chi2 = compare_with_mc(&tally, &optics, pol);
            eprintln!("ρ={rho} {mode:?}: χ²/dof = {chi2:.3}");
            assert!(chi2 < 1.5, "χ²/dof {chi2}");
        }
    }
}

#[test]
fn rtf_energy_is_conserved_with_the_tail() {
    for rho in [1.0, 1.0001, 1.333, 1.5, 2.0] {
        for pol in [Polarisation::Separate, Polarisation::Averaged] {
            for n_max in [1, 2, 5, 9] {
                let o = DropOptics::new(rho, n_max).unwrap().with_polarisation(pol);
                let table = o.tabulate(512).unwrap();
                let kept: f64 = table.energy_per_order().iter().sum();
                let tail = o.tail_energy();
                assert!(
                    (kept + tail - 1.0).abs() < 1e-4,
                    "ρ={rho} n_max={n_max}: {kept} + {tail}"
                );
                // The tail in closed form equals 1 − Σ ε_n.
                let sum: f64 = o.energy_per_order().iter().sum();
                assert!((1.0 - sum - tail).abs() < 1e-9);
            }
        }
    }
}

/// Descartes' minimum-deviation scattering angle for k internal reflections, closed form.
fn descartes_deg(rho: f64, k: usize) -> f64 {
    let c2 = (rho * rho - 1.0) / (k * (k + 2)) as f64;
    let g = c2.sqrt().acos();
    let b = (g.sin() / rho).asin();
    let dev = 2.0 * (g - b) + k as f64 * (PI - 2.0 * b);
    dev.cos().acos().to_degrees()
}

#[test]
fn rtf_caustics_at_descartes_angles() {
    for bins in [180, 360, 1000, 4096] {
        for rho in [1.331, 1.333, 1.337, 1.5] {
            let t = DropOptics::new(rho, 9).unwrap().tabulate(bins).unwrap();
            let d = t.bin_width_rad().to_degrees();
            // Order 3 lives on [θ_D, 180°]: its first non-zero bin holds the caustic.
            let theta3 = descartes_deg(rho, 1);
            let first = t.per_order[2].iter().position(|v| *v > 0.0).unwrap();
            let centre = t.bin_centre_rad(first).to_degrees();
            assert!(
                (centre - theta3).abs() <= 0.5 * d + 1e-9,
                "order 3 bins {bins} ρ {rho}: {centre} vs {theta3}"
            );
            // Order 4 lives on [0, θ_D]: its last non-zero bin holds the caustic.
            let theta4 = descartes_deg(rho, 2);
            let last = t.per_order[3].iter().rposition(|v| *v > 0.0).unwrap();
            let centre = t.bin_centre_rad(last).to_degrees();
            assert!(
                (centre - theta4).abs() <= 0.5 * d + 1e-9,
                "order 4 bins {bins} ρ {rho}: {centre} vs {theta4}"
            );
            // And the caustic stands out: its bin (or the lit neighbour) beats the bin 5° further
            // into the lit side by 2× (the intensity falls like 1/√(θ − θ_D) there).
            let k5 = (5.0 / d).ceil() as usize;
            let o3 = &t.per_order[2];
            assert!(
                o3[first].max(o3[first + 1]) > 2.0 * o3[first + k5],
                "order 3 peak"
            );
            let o4 = &t.per_order[3];
            assert!(
                o4[last].max(o4[last - 1]) > 2.0 * o4[last - k5],
                "order 4 peak"
            );
        }
    }
}

#[test]
fn rtf_is_finite_on_hard_cases() {
    for rho in [1.0, 1.0001, 1.333, 2.0] {
        let o = DropOptics::new(rho, 9).unwrap();
        for g in [0.0, 1e-12, FRAC_PI_2 - 1e-12, FRAC_PI_2 - 1e-15, FRAC_PI_2] {
            for n in 1..=9 {
                assert!(o.weight(n, g).is_finite() && o.weight(n, g) >= 0.0);
                assert!(o.scattering_angle_rad(n, g).is_finite());
            }
            assert!(o.tail_weight(g).is_finite());
        }
        for bins in [16, 17, 100, 1024, 4096] {
            let t = o.tabulate(bins).unwrap();
            assert!(
                t.total.iter().all(|v| v.is_finite() && *v >= 0.0),
                "ρ={rho} bins={bins}"
            );
            let z = t.zonal(8);
            assert!(z.iter().all(|v| v.is_finite()));
            let e: f64 = t.energy_per_order().iter().sum::<f64>() + o.tail_energy();
            assert!((e - 1.0).abs() < 1e-9, "ρ={rho} bins={bins}: {e}");
        }
        assert!(o.zonal(8).iter().all(|v| v.is_finite()));
    }
    // ρ = 1: nothing reflects, everything goes straight through into the first bin.
    let t = DropOptics::new(1.0, 9).unwrap().tabulate(64).unwrap();
    assert!((t.total[0] * t.bin_solid_angle_sr(0) - 1.0).abs() < 1e-9);
    assert!(t.total[1..].iter().all(|v| *v == 0.0));
}

#[test]
fn rtf_table_zonal_converges_to_gamma_integral() {
    let o = DropOptics::new(1.333, 9).unwrap();
    let exact = o.zonal(8);
    let mut last = f64::INFINITY;
    for bins in [64, 256, 1024, 4096] {
        let z = o.tabulate(bins).unwrap().zonal(8);
        let err = exact
            .iter()
            .zip(&z)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        eprintln!("bins {bins}: max |z_table − z_γ| = {err:e}");
        assert!(err < 0.5 * last);
        last = err;
    }
    // γ integral against an independent check: z_0 = Σ ε_n / √(4π).
    let eps: f64 = o.energy_per_order().iter().sum();
    assert!((exact[0] - eps / (4.0 * PI).sqrt()).abs() < 1e-12);
}

#[test]
fn rtf_table_rotation_with_interpolation() {
    let t = DropOptics::new(1.333, 9).unwrap().tabulate(180).unwrap();
    // Axis (0,0): bin centres are reproduced exactly.
    let grid = t.rotated_grid(0.0, 0.0, 8);
    for m in 0..t.bins {
        for q in 0..8 {
            assert!((grid[m * 8 + q] - t.total[m]).abs() <= 1e-12 * t.total[m].max(1.0));
        }
    }
    // Any axis: the value depends only on the angle between axis and direction, and swapping
    // the two gives the same value (reciprocity of the sphere).
    let mut rng = Rng(3);
    for _ in 0..200 {
        let (a, d) = (rng.dir(), rng.dir());
        let expect = t.interpolated(a.dot(d).clamp(-1.0, 1.0).acos());
        assert!((t.rotated(a, d) - expect).abs() <= 1e-9 * expect.max(1.0));
        assert!((t.rotated(d, a) - expect).abs() <= 1e-9 * expect.max(1.0));
    }
    // Linear interpolation halfway between two centres.
    let mid = t.bin_width_rad() * 10.0;
    assert!((t.interpolated(mid) - 0.5 * (t.total[9] + t.total[10])).abs() < 1e-12);
    // Rotated off-axis grid for (α_r, φ_s) integrates to the total energy (the table is
    // smooth enough away from caustics at 1°; a coarse φ sampling is exact by symmetry).
    let (ar, ps) = (0.7f64, 2.1f64);
    let axis = DVec3::new(ar.sin() * ps.cos(), ar.sin() * ps.sin(), ar.cos());
    let q = sh::SphereQuadrature::gauss_legendre(400, 800);
    let e: f64 = q
        .dirs
        .iter()
        .zip(&q.weights_sr)
        .map(|(d, w)| w * t.rotated(axis, *d))
        .sum();
    let total: f64 = t.energy_per_order().iter().sum();
    assert!((e - total).abs() < 5e-3, "{e} vs {total}");
}

// ---------------------------------------------------------------------------------------------
// PRT against brute force

fn water() -> [DropOptics; 3] {
    channel_optics([1.331, 1.333, 1.337].into(), 9, Polarisation::Separate).unwrap()
}

#[test]
fn prt_uniform_white_environment() {
    let optics = water();
    let rtf = RtfSh::from_optics(&optics, 4).unwrap();
    let mut env = vec![[0.0; 3]; 16];
    env[0] = [2.0 * PI.sqrt(); 3]; // L ≡ 1
    let mut rng = Rng(5);
    for _ in 0..10 {
        let v = rng.dir();
        let prt = prt_colour_f64(&env, &rtf, v);
        let brute = brute_force_colour(|_| [1.0; 3], &optics, v, 4096).unwrap();
        for c in 0..3 {
            let kept = 1.0 - optics[c].tail_energy();
            assert!((prt[c] - kept).abs() < 1e-10, "{} vs {kept}", prt[c]);
            assert!((brute[c] - kept).abs() < 1e-9, "{} vs {kept}", brute[c]);
        }
    }
}

/// Bright sky over dark ground: sky (0.6, 0.8, 1.0), ground (0.15, 0.12, 0.1).
fn sky_ground(d: DVec3) -> [f64; 3] {
    if d.z > 0.0 {
        [0.6, 0.8, 1.0]
    } else {
        [0.15, 0.12, 0.1]
    }
}

fn project_rgb(
    f: impl Fn(DVec3) -> [f64; 3],
    q: &sh::SphereQuadrature,
    bands: usize,
) -> Vec<[f64; 3]> {
    let ch: Vec<Vec<f64>> = (0..3).map(|c| sh::project(|d| f(d)[c], q, bands)).collect();
    (0..bands * bands)
        .map(|i| [ch[0][i], ch[1][i], ch[2][i]])
        .collect()
}

fn eval_rgb(coeffs: &[[f64; 3]], d: DVec3) -> [f64; 3] {
    let bands = (coeffs.len() as f64).sqrt() as usize;
    let y = sh::basis(d, bands);
    let mut out = [0.0; 3];
    for (c, yi) in coeffs.iter().zip(&y) {
        (0..3).for_each(|k| out[k] += c[k] * yi);
    }
    out
}

/// PRT vs brute force for one environment: band-limited comparison (must agree to `tol`) and
/// the full error (reported, returned).
fn prt_vs_brute(env: &EnvFn, views: &[DVec3], tol: f64) -> f64 {
    let optics = water();
    let q = sh::SphereQuadrature::equirect(512, 256);
    let mut worst_full = 0.0f64;
    for bands in [2, 4, 8] {
        let coeffs = project_rgb(env, &q, bands);
        let rtf = RtfSh::from_optics(&optics, bands).unwrap();
        for v in views {
            let prt = prt_colour_f64(&coeffs, &rtf, *v);
            let brute_bl =
                brute_force_colour(|d| eval_rgb(&coeffs, d), &optics, *v, 20_000).unwrap();
            for c in 0..3 {
                assert!(
                    (prt[c] - brute_bl[c]).abs() < tol,
                    "bands {bands} v {v:?}: {prt:?} vs {brute_bl:?}"
                );
            }
            if bands == 4 {
                let full = brute_force_colour(env, &optics, *v, 80_000).unwrap();
                let err = (0..3)
                    .map(|c| (prt[c] - full[c]).abs() / full[c].abs().max(1e-3))
                    .fold(0.0, f64::max);
                worst_full = worst_full.max(err);
            }
        }
    }
    worst_full
}

#[test]
fn prt_sky_over_ground_follows_view_direction() {
    let views = [
        DVec3::Z,
        DVec3::new(0.0, 1.0, 0.3).normalize(),
        DVec3::Y,
        DVec3::new(0.2, 0.9, -0.5).normalize(),
        -DVec3::Z,
    ];
    let full = prt_vs_brute(&sky_ground, &views, 1e-3);
    eprintln!("sky/ground: 4-band PRT vs full brute force, worst relative error {full:.4}");
    // Looking up, the drop transmits the sky (order 2 dominates, θ small): brighter, bluer.
    let optics = water();
    let rtf = RtfSh::from_optics(&optics, 4).unwrap();
    let coeffs = project_rgb(sky_ground, &sh::SphereQuadrature::equirect(512, 256), 4);
    let up = prt_colour_f64(&coeffs, &rtf, DVec3::Z);
    let down = prt_colour_f64(&coeffs, &rtf, -DVec3::Z);
    let bu = brute_force_colour(sky_ground, &optics, DVec3::Z, 80_000).unwrap();
    let bd = brute_force_colour(sky_ground, &optics, -DVec3::Z, 80_000).unwrap();
    assert!(up[2] > down[2] && bu[2] > bd[2]);
    assert!(up[2] - down[2] > 0.5 * (bu[2] - bd[2]));
}

/// The Blender "courtyard" world (CC0, tests/data/README.md): 128×64 equirectangular, 16-bit
/// PNG storing `(linear / 585.891)^(1/4)`.
fn courtyard() -> (usize, usize, Vec<[f64; 3]>) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/courtyard_128x64.png"
    );
    let img = image::ImageReader::open(path)
        .unwrap()
        .decode()
        .unwrap()
        .to_rgb16();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let px = img
        .pixels()
        .map(|p| p.0.map(|v| 585.891 * (v as f64 / 65535.0).powi(4)))
        .collect();
    (w, h, px)
}

#[test]
fn prt_real_photograph() {
    let (w, h, px) = courtyard();
    let env = move |d: DVec3| {
        let theta = d.z.clamp(-1.0, 1.0).acos();
        let phi = d.y.atan2(d.x).rem_euclid(2.0 * PI);
        let col = ((phi / (2.0 * PI) * w as f64) as usize).min(w - 1);
        let row = ((theta / PI * h as f64) as usize).min(h - 1);
        px[row * w + col]
    };
    let views = [
        DVec3::Y,
        DVec3::new(0.6, -0.7, 0.4).normalize(),
        DVec3::new(-0.3, 0.2, -0.93).normalize(),
    ];
    // Radiances up to ~600 (the sun): the band-limited agreement is relative to the mean (~4).
    let full = prt_vs_brute(&env, &views, 4e-3);
    eprintln!("courtyard: 4-band PRT vs full brute force, worst relative error {full:.4}");
}

#[test]
fn prt_table_path_agrees_with_gamma_path() {
    // brute_force_colour_table integrates the table exactly; the PRT from the table's zonal
    // coefficients must match it on a band-limited environment.
    let optics = water();
    let tables = [
        optics[0].tabulate(512).unwrap(),
        optics[1].tabulate(512).unwrap(),
        optics[2].tabulate(512).unwrap(),
    ];
    let rtf = RtfSh::from_tables(&tables, 4).unwrap();
    let coeffs = project_rgb(sky_ground, &sh::SphereQuadrature::equirect(256, 128), 4);
    let v = DVec3::new(0.3, 0.9, 0.1).normalize();
    let prt = prt_colour_f64(&coeffs, &rtf, v);
    let brute = brute_force_colour_table(|d| eval_rgb(&coeffs, d), &tables, v, 4, 64);
    for c in 0..3 {
        assert!((prt[c] - brute[c]).abs() < 1e-6, "{prt:?} vs {brute:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// Environment map

fn camera() -> Camera {
    Camera::new(320, 180, 60f64.to_radians(), 1.6, 0.0, 0.0)
}

#[test]
fn envmap_lookup_is_the_pinhole_inside_the_frame() {
    for cam in [camera(), Camera::new(320, 180, 1.2, 1.6, 0.3, -0.2)] {
        let mapper = EnvMapper::new(&cam, 4).unwrap();
        let mut rng = Rng(9);
        for _ in 0..200 {
            let px = DVec2::new(rng.next_f64() * 319.0 + 0.5, rng.next_f64() * 179.0 + 0.5);
            let lk = mapper.lookup(cam.ray_world(px));
            assert!(lk.inside && lk.blur == 0.0);
            assert!(
                (lk.pixel_px - px).length() < 1e-6,
                "{:?} vs {px:?}",
                lk.pixel_px
            );
        }
    }
    let cam = camera();
    let mapper = EnvMapper::new(&cam, 4).unwrap();
    // Zenith reads the top row, nadir the bottom row; straight behind reads the mirrored
    // centre, fully blurred.
    let up = mapper.lookup(DVec3::Z);
    assert!(!up.inside && up.pixel_px.y == 0.5);
    let down = mapper.lookup(-DVec3::Z);
    assert!(down.pixel_px.y == 179.5);
    let behind = mapper.lookup(-DVec3::Y);
    assert!((behind.pixel_px - DVec2::new(160.0, 90.0)).length() < 1e-9 && behind.blur == 1.0);
    // The mirror: a direction behind reads where its mirror image in front reads.
    let d = DVec3::new(0.2, -0.9, 0.1).normalize();
    let m = DVec3::new(d.x, -d.y, d.z);
    assert!((mapper.lookup(d).pixel_px - mapper.lookup(m).pixel_px).length() < 1e-9);
    // Horizon to the side stays on the horizon row of a level camera.
    assert!((mapper.lookup(DVec3::X).pixel_px.y - 90.0).abs() < 1e-9);
}

#[test]
fn envmap_constant_frame_gives_constant_environment() {
    let cam = camera();
    let mapper = EnvMapper::new(&cam, 4).unwrap();
    let frame = vec![[0.2f32, 0.5, 0.9]; 320 * 180];
    let env = mapper.project(&frame).unwrap();
    for k in 0..3 {
        let c0 = f64::from(env.coeffs[0][k]);
        let expect = 2.0 * PI.sqrt() * [0.2, 0.5, 0.9][k];
        assert!((c0 - expect).abs() < 1e-4 * expect, "{c0} vs {expect}");
        for c in &env.coeffs[1..] {
            assert!(f64::from(c[k]).abs() < 1e-4 * expect);
        }
    }
}

#[test]
fn envmap_bright_top_half_gives_sky_dipole() {
    let cam = camera();
    let mapper = EnvMapper::new(&cam, 4).unwrap();
    let frame: Vec<[f32; 3]> = (0..320 * 180)
        .map(|i| if i / 320 < 90 { [1.0; 3] } else { [0.1; 3] })
        .collect();
    let env = mapper.project(&frame).unwrap();
    let (c0, cz) = (env.coeffs[0][1], env.coeffs[sh::index(1, 0)][1]);
    // A pure sky/ground split of 1 / 0.1 has c_10/c_00 = √3 · 0.9/(1.1) ≈ 1.42.
    assert!(cz > 0.5 * c0, "c10 {cz} vs c00 {c0}");
    assert!(
        env.coeffs[sh::index(1, 1)][1].abs() < 0.05 * cz,
        "no x dipole"
    );
    let flipped: Vec<[f32; 3]> = frame.iter().rev().cloned().collect();
    assert!(mapper.project(&flipped).unwrap().coeffs[sh::index(1, 0)][1] < -0.5 * c0);
}

#[test]
fn envmap_rejects_bad_input() {
    let cam = camera();
    assert!(EnvMapper::new(&cam, 0).is_err());
    assert!(EnvMapper::new(&cam, 9).is_err());
    let bad = EnvMapSettings {
        blur_ramp_rad: 0.0,
        ..EnvMapSettings::default()
    };
    assert!(EnvMapper::with_settings(&cam, 4, bad).is_err());
    assert!(EnvMapper::new(&Camera::new(320, 180, 0.0, 1.6, 0.0, 0.0), 4).is_err());
    assert!(DropOptics::new(1.333, 65).is_err());
    let mapper = EnvMapper::new(&cam, 4).unwrap();
    assert!(mapper.project(&[[0.0; 3]; 10]).is_err());
    assert!(ShSmoother::new(-1.0, 0.3).is_err());
    assert!(ShSmoother::new(0.25, 0.0).is_err());
}

#[test]
fn smoother_converges_and_resets_on_cut() {
    let env = |v: f32| EnvironmentSh {
        bands: 2,
        coeffs: vec![[v, v, v], [0.1 * v; 3], [0.2 * v; 3], [0.0; 3]],
    };
    let dt = 1.0 / 30.0;
    let mut s = ShSmoother::new(0.25, 0.3).unwrap();
    let a = env(1.0);
    assert_eq!(s.update(&a, 0.0), a);
    // Small steps (a slow fade): no cut, the output lags behind and then converges.
    let mut target = 1.0f32;
    let mut t = 0.0;
    for _ in 0..10 {
        target *= 1.02;
        t += dt;
        let out = s.update(&env(target), t);
        assert!(!s.last_was_cut());
        assert!(out.coeffs[0][0] < target);
    }
    for _ in 0..300 {
        t += dt;
        s.update(&env(target), t);
    }
    t += dt;
    let out = s.update(&env(target), t);
    assert!((out.coeffs[0][0] - target).abs() < 1e-4 * target);
    // Two frames τ apart: the older weighs 1/e of the newer (an independent closed form).
    let mut s2 = ShSmoother::new(0.25, 2.0).unwrap();
    s2.update(&env(0.0), 0.0);
    let out = s2.update(&env(1.0), 0.25);
    let e = (-1.0f32).exp();
    assert!((out.coeffs[0][0] - 1.0 / (1.0 + e)).abs() < 1e-6);
    // Frames older than the window no longer count.
    let out = s2.update(&env(1.0), 0.25 + s2.window_secs() + 0.01);
    assert_eq!(out.coeffs[0][0], 1.0);
    // A cut: the next shot's light replaces the history at once.
    let b = env(5.0);
    let out = s.update(&b, t + dt);
    assert!(s.last_was_cut());
    assert_eq!(out, b);
    // The output depends only on the window: a smoother fed only the last second agrees.
    let mut long = ShSmoother::new(0.25, 0.3).unwrap();
    let mut short = ShSmoother::new(0.25, 0.3).unwrap();
    let mut last = (EnvironmentSh::zeros(2), EnvironmentSh::zeros(2));
    for i in 0..120 {
        let t = i as f64 * dt;
        let raw = env(1.0 + 0.3 * (t as f32 * 2.0).sin());
        let a = long.update(&raw, t);
        // Everything inside the last frame's window (it ends at 119·dt).
        if t > 119.0 * dt - short.window_secs() - 0.05 {
            last = (a, short.update(&raw, t));
        }
    }
    assert_eq!(last.0, last.1);
}

#[test]
fn envmap_projection_time_at_1080p() {
    let cam = Camera::new(1920, 1080, 60f64.to_radians(), 1.6, 0.0, 0.0);
    let t0 = std::time::Instant::now();
    let mapper = EnvMapper::new(&cam, 4).unwrap();
    let setup = t0.elapsed();
    let frame: Vec<[f32; 3]> = (0..1920 * 1080)
        .map(|i| [(i % 1920) as f32 / 1920.0, 0.5, 0.2])
        .collect();
    let t0 = std::time::Instant::now();
    let n = 10;
    for _ in 0..n {
        std::hint::black_box(mapper.project(&frame).unwrap());
    }
    let per = t0.elapsed() / n;
    eprintln!("1080p: setup {setup:?}, projection {per:?} per frame (test profile)");
}

// ---------------------------------------------------------------------------------------------
// Inspect helpers

#[test]
fn inspect_rtf_reports_and_validates() {
    let v = inspect::inspect_rtf([1.331, 1.333, 1.337], 9, 256, 4).unwrap();
    let ch = v["channels"].as_array().unwrap();
    assert_eq!(ch.len(), 3);
    let e: f64 = ch[1]["energy_sum"].as_f64().unwrap() + ch[1]["tail_energy"].as_f64().unwrap();
    assert!((e - 1.0).abs() < 1e-9);
    assert_eq!(ch[0]["table_total_per_sr"].as_array().unwrap().len(), 256);
    assert!(inspect::inspect_rtf(1.333, 9, 256, 9).is_err());
    assert!(inspect::inspect_rtf(0.9, 9, 256, 4).is_err());
    assert!(inspect::inspect_rtf(1.333, 0, 256, 4).is_err());
    assert!(inspect::inspect_rtf(1.333, 9, 1, 4).is_err());
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("rtf.png");
    inspect::plot_rtf([1.331, 1.333, 1.337], 9, 720, &p).unwrap();
    assert!(image::open(&p).is_ok());
    assert!(inspect::plot_rtf(1.333, 9, 720, &dir.path().join("missing/dir/x.png")).is_err());
}

#[test]
fn inspect_sh_reports_and_plots() {
    let cam = camera();
    let pixels = (0..320 * 180)
        .map(|i| {
            if i / 320 < 90 {
                [0.8, 0.9, 1.0]
            } else {
                [0.1, 0.08, 0.05]
            }
        })
        .collect();
    let img = inspect::LinearImage {
        width: 320,
        height: 180,
        pixels,
    };
    let v = inspect::inspect_sh(&img, &cam, 4).unwrap();
    assert!(v["dipole_direction"][2].as_f64().unwrap() > 0.9);
    let dir = tempfile::tempdir().unwrap();
    inspect::plot_sh(&img, &cam, 4, &dir.path().join("sh.png")).unwrap();
    let wrong = Camera::new(100, 100, 1.0, 1.6, 0.0, 0.0);
    assert!(inspect::inspect_sh(&img, &wrong, 4).is_err());
}

// ---------------------------------------------------------------------------------------------
// WGSL

const SH_WGSL: &str = include_str!("../shaders/common/sh.wgsl");

#[test]
fn wgsl_parses_and_validates() {
    let module = naga::front::wgsl::parse_str(SH_WGSL).expect("parse");
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .expect("validate");
    assert!(
        module.entry_points.is_empty(),
        "sh.wgsl must hold functions and consts only"
    );
    assert!(
        module.global_variables.is_empty(),
        "sh.wgsl must declare no bindings"
    );
    let names: Vec<_> = module
        .functions
        .iter()
        .filter_map(|(_, f)| f.name.clone())
        .collect();
    assert!(names.contains(&"sh_basis16".to_string()) && names.contains(&"prt_colour".to_string()));
}

const PARITY_WGSL: &str = r#"
struct Params { env: array<vec4<f32>, 16>, zr: vec4<f32>, zg: vec4<f32>, zb: vec4<f32> }
@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> dirs: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> out: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&dirs)) { return; }
    let d = dirs[i].xyz;
    var b = sh_basis16(d);
    for (var k = 0u; k < 16u; k++) { out[i * 20u + k] = b[k]; }
    let c = prt_colour(params.env, params.zr, params.zg, params.zb, d);
    out[i * 20u + 16u] = c.x;
    out[i * 20u + 17u] = c.y;
    out[i * 20u + 18u] = c.z;
}
"#;

/// Runs `sh_basis16` and `prt_colour` on a GPU; `None` when no adapter exists.
fn run_wgsl_parity(params: &[f32], dirs: &[[f32; 4]]) -> Option<Vec<f32>> {
    use wgpu::util::DeviceExt;
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
    let adapter =
        pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))
            .ok()?;
    eprintln!("WGSL parity on {:?}", adapter.get_info().name);
    let (device, queue) =
        pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor::default())).ok()?;
    let src = format!("{SH_WGSL}\n{PARITY_WGSL}");
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("sh_parity"),
        source: wgpu::ShaderSource::Wgsl(src.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("sh_parity"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let storage = |label, bytes: &[u8]| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage: wgpu::BufferUsages::STORAGE,
        })
    };
    let p = storage("params", bytemuck::cast_slice(params));
    let d = storage("dirs", bytemuck::cast_slice(dirs));
    let size = (dirs.len() * 20 * 4) as u64;
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("out"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let read = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    use rain_composite::gpu::bind::{bind_group, buffer};
    let bind = bind_group(
        &device,
        "sh_parity",
        &pipeline.get_bind_group_layout(0),
        &[buffer(&p), buffer(&d), buffer(&out)],
    );
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups((dirs.len() as u32).div_ceil(64), 1, 1);
    }
    enc.copy_buffer_to_buffer(&out, 0, &read, 0, size);
    queue.submit([enc.finish()]);
    read.map_async(wgpu::MapMode::Read, .., |r| r.expect("map"));
    device
        .poll(wgpu::PollType::Wait {
            submission_index: None,
            timeout: None,
        })
        .expect("poll");
    let view = read.get_mapped_range(..).expect("mapped");
    Some(bytemuck::cast_slice(&view).to_vec())
}

#[test]
fn wgsl_matches_cpu_on_gpu() {
    let optics = water();
    let rtf = RtfSh::from_optics(&optics, 4).unwrap();
    let coeffs = project_rgb(sky_ground, &sh::SphereQuadrature::equirect(128, 64), 4);
    let env = EnvironmentSh {
        bands: 4,
        coeffs: coeffs.iter().map(|c| c.map(|v| v as f32)).collect(),
    };
    let mut params: Vec<f32> = env.to_gpu_array().iter().flatten().cloned().collect();
    params.extend(rtf.to_gpu_array().iter().flatten());
    let mut rng = Rng(21);
    let dirs: Vec<DVec3> = (0..1000)
        .map(|_| rng.dir())
        .chain([DVec3::Z, -DVec3::Z, DVec3::X])
        .collect();
    let dirs_f32: Vec<[f32; 4]> = dirs
        .iter()
        .map(|d| [d.x as f32, d.y as f32, d.z as f32, 0.0])
        .collect();
    let Some(out) = run_wgsl_parity(&params, &dirs_f32) else {
        assert!(
            std::env::var_os("RAIN_COMPOSITE_REQUIRE_GPU").is_none(),
            "no GPU adapter but RAIN_COMPOSITE_REQUIRE_GPU is set"
        );
        eprintln!(
            "skipped: no GPU adapter (set RAIN_COMPOSITE_REQUIRE_GPU=1 to make this a failure)"
        );
        return;
    };
    // The CPU twin on the same f32-rounded inputs.
    let env64 = env.coeffs_f64();
    let rtf32 = RtfSh {
        bands: 4,
        zonal: rtf
            .zonal
            .iter()
            .map(|z| z.map(|v| v as f32 as f64))
            .collect(),
    };
    for (i, d) in dirs_f32.iter().enumerate() {
        let d = DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64);
        let cpu = sh::basis16_cartesian(d);
        for k in 0..16 {
            assert!(
                (out[i * 20 + k] as f64 - cpu[k]).abs() < 2e-6,
                "basis {k} at {d:?}"
            );
        }
        let c = prt_colour_f64(&env64, &rtf32, d);
        for k in 0..3 {
            assert!(
                (out[i * 20 + 16 + k] as f64 - c[k]).abs() < 1e-5 * c[k].abs().max(1.0),
                "colour {k} at {d:?}"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Speed against error (a report, not a check): run with
// `cargo test --test lighting report_speed_error -- --ignored --nocapture`.

fn fibonacci_sphere(n: usize) -> Vec<DVec3> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let s = (1.0 - z * z).sqrt();
            DVec3::new(
                s * (golden * i as f64).cos(),
                s * (golden * i as f64).sin(),
                z,
            )
        })
        .collect()
}

/// Bilinear lookup in the courtyard map (continuous, so the brute force converges).
fn courtyard_bilinear() -> impl Fn(DVec3) -> [f64; 3] + Sync {
    let (w, h, px) = courtyard();
    move |d: DVec3| {
        let u = d.y.atan2(d.x).rem_euclid(2.0 * PI) / (2.0 * PI) * w as f64 - 0.5;
        let v = (d.z.clamp(-1.0, 1.0).acos() / PI * h as f64 - 0.5).clamp(0.0, (h - 1) as f64);
        let (x0, y0) = (u.floor(), v.floor() as usize);
        let (fx, fy) = (u - x0, v - y0 as f64);
        let (x0, x1) = (
            (x0 as i64).rem_euclid(w as i64) as usize,
            ((x0 as i64) + 1).rem_euclid(w as i64) as usize,
        );
        let y1 = (y0 + 1).min(h - 1);
        let p = |x: usize, y: usize| px[y * w + x];
        [0, 1, 2].map(|k| {
            (1.0 - fy) * ((1.0 - fx) * p(x0, y0)[k] + fx * p(x1, y0)[k])
                + fy * ((1.0 - fx) * p(x0, y1)[k] + fx * p(x1, y1)[k])
        })
    }
}

/// An environment: radiance per channel for a direction.
type EnvFn = dyn Fn(DVec3) -> [f64; 3] + Sync;

#[test]
#[ignore = "report; run with --ignored --nocapture"]
fn report_speed_error_table() {
    let views = fibonacci_sphere(26);
    let envs: Vec<(&str, Box<EnvFn>)> = vec![
        ("sky/ground", Box::new(sky_ground)),
        ("courtyard", Box::new(courtyard_bilinear())),
    ];
    let rho = [1.331, 1.333, 1.337];
    let reference_optics = channel_optics(rho.into(), 40, Polarisation::Separate).unwrap();
    for (name, env) in &envs {
        let t0 = std::time::Instant::now();
        let reference: Vec<[f64; 3]> = views
            .iter()
            .map(|v| brute_force_colour(env, &reference_optics, *v, 40_000).unwrap())
            .collect();
        // Convergence of the reference itself: 4× the samples on three views.
        let conv = views[..3]
            .iter()
            .zip(&reference)
            .map(|(v, r)| {
                let b = brute_force_colour(env, &reference_optics, *v, 160_000).unwrap();
                (0..3).map(|c| (b[c] - r[c]).abs()).fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        let mean: f64 = reference
            .iter()
            .map(|r| (r[0] + r[1] + r[2]) / 3.0)
            .sum::<f64>()
            / views.len() as f64;
        eprintln!(
            "\n## {name}: reference = brute force, n_max 40, 40k samples/order ({:?}); mean drop radiance {mean:.4}; reference change at 160k samples {:.1e} (relative {:.1e})",
            t0.elapsed(),
            conv,
            conv / mean
        );
        let q = sh::SphereQuadrature::equirect(1024, 512);
        let env_full = project_rgb(env, &q, 8);
        eprintln!(
            "| bands | bins | n_max | table+zonal ms (3 ch) | max err / mean | rms err / mean |"
        );
        eprintln!("|---|---|---|---|---|---|");
        for bands in 2..=8 {
            let coeffs: Vec<[f64; 3]> = env_full[..bands * bands].to_vec();
            for bins in [64usize, 256, 1024, 4096, 0] {
                for n_max in [3usize, 5, 9, 20] {
                    if bins != 0 && bins != 1024 && n_max != 9 {
                        continue; // keep the table readable: vary one thing at a time
                    }
                    let optics = channel_optics(rho.into(), n_max, Polarisation::Separate).unwrap();
                    let t0 = std::time::Instant::now();
                    let rtf = if bins == 0 {
                        RtfSh::from_optics(&optics, bands).unwrap()
                    } else {
                        let tables = optics.map(|o| o.tabulate(bins).unwrap());
                        RtfSh::from_tables(&tables, bands).unwrap()
                    };
                    let ms = t0.elapsed().as_secs_f64() * 1e3;
                    let errs: Vec<f64> = views
                        .iter()
                        .zip(&reference)
                        .map(|(v, r)| {
                            let p = prt_colour_f64(&coeffs, &rtf, *v);
                            (0..3).map(|c| (p[c] - r[c]).abs()).fold(0.0, f64::max) / mean
                        })
                        .collect();
                    let max = errs.iter().cloned().fold(0.0, f64::max);
                    let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
                    let bins_s = if bins == 0 {
                        "γ-integral".to_string()
                    } else {
                        bins.to_string()
                    };
                    eprintln!("| {bands} | {bins_s} | {n_max} | {ms:.2} | {max:.2e} | {rms:.2e} |");
                }
            }
        }
    }
    // Per-pixel shading cost on the CPU twin (the GPU does the same ~100 flops).
    let rtf = RtfSh::from_optics(&water(), 4).unwrap();
    let coeffs = project_rgb(sky_ground, &sh::SphereQuadrature::equirect(64, 32), 4);
    let dirs = fibonacci_sphere(100_000);
    let t0 = std::time::Instant::now();
    let mut acc = 0.0;
    for d in &dirs {
        acc += prt_colour_f64(&coeffs, &rtf, *d)[0];
    }
    eprintln!(
        "\nprt_colour_f64 (CPU, 4 bands): {:.0} ns/pixel ({acc:.3})",
        t0.elapsed().as_nanos() as f64 / dirs.len() as f64
    );
}
