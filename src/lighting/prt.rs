//! Precomputed radiance transfer for raindrops (thesis §5.1.2, after Wang et al. 2006 and Sloan,
//! Kautz & Snyder 2002; `docs/method.md`, "Lighting"): the drop colour for a view ray is
//! the dot product of the environment's SH coefficients with the RTF's, rotated onto the ray.
//!
//! ## How it works
//!
//! The RTF depends only on `θ = ∠(ω, v)`, so it is zonal about the view ray `v` (eye → drop,
//! see [`rtf`](super::rtf)). Its coefficients for the ray are the zonal-harmonic rotation
//! `T_lm(v) = sqrt(4π/(2l+1)) z_l Y_lm(v)` of its zonal coefficients `z_l`, and the drop's
//! radiance is `Σ_lm L_lm T_lm(v)` per channel. This replaces the thesis's precomputed set of
//! directions `C_d` with nearest-neighbour lookup: there is nothing to look up, and nothing to
//! quantise. The GPU mirror is `prt_colour` in `shaders/common/sh.wgsl`.
//!
//! [`brute_force_colour`] is the independent reference: it integrates the environment over the
//! rays that hit the drop (impact angle γ × azimuth about v), without SH or tables.

use glam::DVec3;
use rayon::prelude::*;

use crate::lighting::envmap::EnvironmentSh;
use crate::lighting::rtf::{ChannelIndices, DropOptics, Polarisation, RtfTable};
use crate::lighting::sh;
use crate::{Error, Result};

/// `sqrt(4π/(2l+1))`, the zonal-rotation factor of band l.
pub fn zonal_factor(l: usize) -> f64 {
    (4.0 * std::f64::consts::PI / (2 * l + 1) as f64).sqrt()
}

/// The RTF's zonal SH coefficients `z_l` per colour channel, about the view ray.
#[derive(Debug, Clone, PartialEq)]
pub struct RtfSh {
    /// Number of bands.
    pub bands: usize,
    /// `zonal[l] = [z_l(R), z_l(G), z_l(B)]`.
    pub zonal: Vec<[f64; 3]>,
}

impl RtfSh {
    /// From the optics, integrated over γ ([`DropOptics::zonal`]): the accurate path.
    pub fn from_optics(optics: &[DropOptics; 3], bands: usize) -> Result<RtfSh> {
        sh::check_bands(bands)?;
        let z: Vec<Vec<f64>> = optics.iter().map(|o| o.zonal(bands)).collect();
        Ok(RtfSh {
            bands,
            zonal: (0..bands).map(|l| [z[0][l], z[1][l], z[2][l]]).collect(),
        })
    }

    /// From tabulated RTFs ([`RtfTable::zonal`]): carries the table's binning error.
    pub fn from_tables(tables: &[RtfTable; 3], bands: usize) -> Result<RtfSh> {
        sh::check_bands(bands)?;
        let z: Vec<Vec<f64>> = tables.iter().map(|t| t.zonal(bands)).collect();
        Ok(RtfSh {
            bands,
            zonal: (0..bands).map(|l| [z[0][l], z[1][l], z[2][l]]).collect(),
        })
    }

    /// Water drops with per-channel indices, orders `1..=n_max`, default polarisation.
    pub fn water(rho: impl Into<ChannelIndices>, n_max: usize, bands: usize) -> Result<RtfSh> {
        let optics = channel_optics(rho.into(), n_max, Polarisation::default())?;
        RtfSh::from_optics(&optics, bands)
    }

    /// The RTF's coefficients `T_lm(v)` per channel for view ray `view` (eye → drop).
    pub fn transfer(&self, view: DVec3) -> Vec<[f64; 3]> {
        let y = sh::basis(view, self.bands);
        y.iter()
            .enumerate()
            .map(|(i, yi)| {
                let l = sh::band_of(i);
                let s = zonal_factor(l) * yi;
                let z = self.zonal[l];
                [s * z[0], s * z[1], s * z[2]]
            })
            .collect()
    }

    /// GPU layout for up to 4 bands, as `RainParams::drop_zonal`: three `vec4<f32>`, one per
    /// channel (R, G, B), each holding `(z_0, z_1, z_2, z_3)`; missing bands are zero, bands above 4 are dropped (a lower-band
    /// approximation). These are the raw `z_l`: the shader applies `sqrt(4π/(2l+1))`.
    pub fn to_gpu_array(&self) -> [[f32; 4]; 3] {
        let mut out = [[0.0f32; 4]; 3];
        for (l, z) in self.zonal.iter().take(4).enumerate() {
            for c in 0..3 {
                out[c][l] = z[c] as f32;
            }
        }
        out
    }

    /// GPU layout for up to 8 bands: two `vec4<f32>` per channel, channel-major
    /// (`R: z_0..z_3, R: z_4..z_7, G: …, B: …`), zero-padded.
    pub fn to_gpu_array_8(&self) -> [f32; 24] {
        let mut out = [0.0f32; 24];
        for (l, z) in self.zonal.iter().take(8).enumerate() {
            for c in 0..3 {
                out[8 * c + l] = z[c] as f32;
            }
        }
        out
    }
}

/// Three [`DropOptics`], one per channel.
pub fn channel_optics(
    rho: ChannelIndices,
    n_max: usize,
    polarisation: Polarisation,
) -> Result<[DropOptics; 3]> {
    let o = |r| DropOptics::new(r, n_max).map(|o| o.with_polarisation(polarisation));
    Ok([o(rho.0[0])?, o(rho.0[1])?, o(rho.0[2])?])
}

/// Drop radiance per channel for view ray `view`: `Σ_lm L_lm T_lm(v)` over the bands both
/// sides have (the CPU twin of `prt_colour` in `sh.wgsl`).
pub fn prt_colour(env: &EnvironmentSh, rtf: &RtfSh, view: DVec3) -> [f64; 3] {
    let coeffs: Vec<[f64; 3]> = env.coeffs.iter().map(|c| c.map(f64::from)).collect();
    prt_colour_f64(&coeffs, rtf, view)
}

/// [`prt_colour`] on `f64` environment coefficients (`bands²` of them).
pub fn prt_colour_f64(env: &[[f64; 3]], rtf: &RtfSh, view: DVec3) -> [f64; 3] {
    let bands = rtf.bands.min((env.len() as f64).sqrt() as usize);
    let mut y = [0.0; sh::MAX_BANDS * sh::MAX_BANDS];
    sh::eval_basis(view, bands, &mut y);
    let mut out = [0.0; 3];
    for l in 0..bands {
        let f = zonal_factor(l);
        let t = rtf.zonal[l].map(|z| f * z);
        for i in l * l..(l + 1) * (l + 1) {
            for c in 0..3 {
                out[c] += env[i][c] * t[c] * y[i];
            }
        }
    }
    out
}

/// An orthonormal frame `(e1, e2)` perpendicular to the unit vector `v`.
fn frame_about(v: DVec3) -> (DVec3, DVec3) {
    let helper = if v.z.abs() < 0.9 { DVec3::Z } else { DVec3::X };
    let e1 = helper.cross(v).normalize();
    (e1, v.cross(e1))
}

/// Reference drop radiance, by direct integration of env × RTF over the sphere, parameterised
/// by the rays that hit the drop: `Σ_n ∫₀^{π/2} w_n(γ) sin 2γ ⟨env(θ_n(γ), φ)⟩_φ dγ`, where the
/// lookup direction makes angle `θ_n(γ)` with `view` at azimuth φ. This is the definition of
/// `∫ env(ω) F(ω·v) dω` before any binning or SH truncation, exact at the caustics.
/// `samples` ≈ number of (γ, φ) nodes per order and channel (at least 64).
pub fn brute_force_colour(
    env_fn: impl Fn(DVec3) -> [f64; 3] + Sync,
    optics: &[DropOptics; 3],
    view: DVec3,
    samples: usize,
) -> Result<[f64; 3]> {
    if samples < 64 {
        return Err(Error::Parameter {
            name: "samples",
            value: samples.to_string(),
            expected: "at least 64".into(),
        });
    }
    let v = view.normalize_or(DVec3::Z);
    let (e1, e2) = frame_about(v);
    let n_phi = ((samples as f64).sqrt().ceil() as usize).max(8);
    let panels = (samples / n_phi / 8).max(1);
    let mut out = [0.0; 3];
    for (c, o) in optics.iter().enumerate() {
        let mut cuts = vec![0.0, std::f64::consts::FRAC_PI_2];
        cuts.extend((3..=o.n_max()).filter_map(|n| o.extremum_rad(n)));
        cuts.sort_by(f64::total_cmp);
        let nodes: Vec<(f64, f64)> = cuts
            .windows(2)
            .flat_map(|w| {
                let p = ((w[1] - w[0]) / std::f64::consts::FRAC_PI_2 * panels as f64).ceil();
                sh::composite_gauss(w[0], w[1], (p as usize).max(1), 8)
            })
            .collect();
        out[c] = nodes
            .par_iter()
            .map(|&(g, wg)| {
                let s = wg * (2.0 * g).sin();
                let mut acc = 0.0;
                for n in 1..=o.n_max() {
                    let w = o.weight(n, g);
                    if w == 0.0 {
                        continue;
                    }
                    let psi = o.deflection_rad(n, g);
                    let (st, ct) = (psi.sin().abs(), psi.cos());
                    let mut ring = 0.0;
                    for j in 0..n_phi {
                        let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n_phi as f64;
                        let d = v * ct + (e1 * phi.cos() + e2 * phi.sin()) * st;
                        ring += env_fn(d)[c];
                    }
                    acc += w * ring / n_phi as f64;
                }
                s * acc
            })
            .sum();
    }
    Ok(out)
}

/// Reference drop radiance from tabulated RTFs: `Σ_m F_m ∫_{bin m} env dω`, each bin integrated
/// with `n_sub` Gauss nodes in cos θ × `n_phi` azimuths about the view ray. Measures what the
/// table itself (rather than SH truncation) does to the colour.
pub fn brute_force_colour_table(
    env_fn: impl Fn(DVec3) -> [f64; 3] + Sync,
    tables: &[RtfTable; 3],
    view: DVec3,
    n_sub: usize,
    n_phi: usize,
) -> [f64; 3] {
    let v = view.normalize_or(DVec3::Z);
    let (e1, e2) = frame_about(v);
    let (gx, gw) = sh::gauss_legendre(n_sub.max(1));
    let mut out = [0.0; 3];
    for (c, t) in tables.iter().enumerate() {
        let d = t.bin_width_rad();
        out[c] = (0..t.bins)
            .into_par_iter()
            .map(|m| {
                let (c0, c1) = (((m + 1) as f64 * d).cos(), (m as f64 * d).cos());
                let (mid, half) = (0.5 * (c0 + c1), 0.5 * (c1 - c0));
                let mut acc = 0.0;
                for (x, w) in gx.iter().zip(&gw) {
                    let ct = mid + half * x;
                    let st = (1.0 - ct * ct).max(0.0).sqrt();
                    let mut ring = 0.0;
                    for j in 0..n_phi {
                        let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n_phi as f64;
                        ring += env_fn(v * ct + (e1 * phi.cos() + e2 * phi.sin()) * st)[c];
                    }
                    acc += w * half * ring * 2.0 * std::f64::consts::PI / n_phi as f64;
                }
                t.total[m] * acc
            })
            .sum();
    }
    out
}
