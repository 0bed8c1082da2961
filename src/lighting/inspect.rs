//! Reports and plots for the CLI (`inspect rtf`, `inspect sh`): JSON values and PNG plots drawn
//! with the `image` crate alone.
//!
//! Every function validates its parameters and returns [`Error::Parameter`] instead of
//! panicking: bands in 1..=8, ρ in [1, 10], bins in 2..=65536, n_max in 1..=64.

use std::path::Path;

use glam::DVec3;
use serde_json::{Value, json};

use crate::lighting::envmap::{EnvMapper, reconstruct_equirect};
use crate::lighting::prt::channel_optics;
use crate::lighting::rtf::{
    ChannelIndices, MAX_BINS, MAX_N_MAX, Polarisation, RtfTable, caustic_angle_rad,
};
use crate::lighting::sh;
use crate::scene::Camera;
use crate::{Error, Result};

/// A decoded image in linear-light RGB, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearImage {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// `width × height` linear RGB pixels.
    pub pixels: Vec<[f32; 3]>,
}

/// The sRGB transfer function, encoded → linear ([`crate::video::color`]'s, in `f32`).
pub fn srgb_to_linear(c: f32) -> f32 {
    crate::video::color::eotf_signed(crate::video::Transfer::Srgb, f64::from(c)) as f32
}

/// The sRGB transfer function, linear → encoded, clamped to [0, 1] first
/// ([`crate::video::color`]'s, in `f32`).
pub fn linear_to_srgb(c: f32) -> f32 {
    crate::video::color::oetf_signed(crate::video::Transfer::Srgb, f64::from(c.clamp(0.0, 1.0)))
        as f32
}

impl LinearImage {
    /// Decodes an sRGB-encoded PNG (8 or 16 bit) into linear light.
    pub fn load_png(path: &Path) -> Result<LinearImage> {
        let fail = |reason: String| Error::InputOpen {
            path: path.display().to_string(),
            reason,
        };
        let img = crate::files::read_png(path).map_err(fail)?.to_rgb32f();
        let (width, height) = (img.width() as usize, img.height() as usize);
        let pixels = img.pixels().map(|p| p.0.map(srgb_to_linear)).collect();
        Ok(LinearImage {
            width,
            height,
            pixels,
        })
    }
}

/// The report's arguments in range, named as the report's (`inspect.rtf.n_max`), before the
/// optics check them as the render's.
fn check_rtf_params(n_max: usize, bins: usize, bands: usize) -> Result<()> {
    sh::check_bands(bands)?;
    if !(1..=MAX_N_MAX).contains(&n_max) {
        return Err(Error::Parameter {
            name: "inspect.rtf.n_max",
            value: n_max.to_string(),
            expected: format!("an order in 1..={MAX_N_MAX}"),
        });
    }
    if !(2..=MAX_BINS).contains(&bins) {
        return Err(Error::Parameter {
            name: "inspect.rtf.bins",
            value: bins.to_string(),
            expected: format!("an integer in 2..={MAX_BINS}"),
        });
    }
    Ok(())
}

fn tables(rho: ChannelIndices, n_max: usize, bins: usize) -> Result<[RtfTable; 3]> {
    let optics = channel_optics(rho, n_max, Polarisation::default())?;
    Ok([
        optics[0].tabulate(bins)?,
        optics[1].tabulate(bins)?,
        optics[2].tabulate(bins)?,
    ])
}

/// The RTF for refractive index `rho` (one value or R, G, B): the table per order and in total,
/// energy per order, the truncated tail, and the zonal SH coefficients (from the γ integral and
/// from the table, with their difference). Conventions are spelled out in the output.
pub fn inspect_rtf(
    rho: impl Into<ChannelIndices>,
    n_max: usize,
    bins: usize,
    bands: usize,
) -> Result<Value> {
    let rho = rho.into();
    check_rtf_params(n_max, bins, bands)?;
    let tables = tables(rho, n_max, bins)?;
    let channels = if rho.is_single() { 1 } else { 3 };
    let delta = std::f64::consts::PI / bins as f64;
    let per_channel: Vec<Value> = tables
        .iter()
        .take(channels)
        .map(|t| {
            let o = &t.optics;
            let energy = o.energy_per_order();
            let sum: f64 = energy.iter().sum();
            let z_gamma = o.zonal(bands);
            let z_table = t.zonal(bands);
            let z_err = z_gamma
                .iter()
                .zip(&z_table)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let caustics: serde_json::Map<String, Value> = (3..=n_max.min(12))
                .filter_map(|n| {
                    caustic_angle_rad(o.rho(), n).map(|a| (n.to_string(), json!(a.to_degrees())))
                })
                .collect();
            json!({
                "rho": o.rho(),
                "energy_per_order": energy,
                "energy_per_order_from_table": t.energy_per_order(),
                "energy_sum": sum,
                "tail_energy": o.tail_energy(),
                "tail_energy_as_one_minus_sum": 1.0 - sum,
                "zonal": z_gamma,
                "zonal_from_table": z_table,
                "zonal_table_max_abs_error": z_err,
                "caustic_scattering_angle_deg": caustics,
                "table_total_per_sr": t.total,
                "table_per_order_per_sr": t.per_order,
            })
        })
        .collect();
    Ok(json!({
        "conventions": {
            "theta": "scattering angle between the environment lookup direction (towards the light) and the view ray (eye to drop); 0 = straight through the drop",
            "table": "bin m averages F over theta in [m*delta, (m+1)*delta), per steradian; integral of F over the sphere = energy",
            "thesis_D": "D = pi * F, with the thesis's theta = pi - theta",
            "zonal": "z_l = integral of F(theta) Y_l0(cos theta) over the sphere, about the view ray; measuring theta from the drop-to-eye direction flips the sign of odd l",
            "sh": "real SH without Condon-Shortley phase, index l(l+1)+m",
            "polarisation": "s and p carried separately, averaged at the exit",
        },
        "n_max": n_max,
        "bins": bins,
        "bin_width_deg": delta.to_degrees(),
        "bands": bands,
        "theta_deg": (0..bins).map(|m| ((m as f64 + 0.5) * delta).to_degrees()).collect::<Vec<_>>(),
        "channels": per_channel,
    }))
}

/// The environment SH of an image seen through `camera` (sizes must match): coefficients per
/// channel, energy per band, mean radiance, and the direction of the luminance dipole.
pub fn inspect_sh(image: &LinearImage, camera: &Camera, bands: usize) -> Result<Value> {
    let mapper = checked_mapper(image, camera, bands)?;
    let env = mapper.project(&image.pixels)?;
    let c = env.coeffs_f64();
    let lum = |v: &[f64; 3]| 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
    let dipole = if bands > 1 {
        DVec3::new(lum(&c[3]), lum(&c[1]), lum(&c[2]))
    } else {
        DVec3::ZERO
    };
    let band_energy: Vec<[f64; 3]> = (0..bands)
        .map(|l| {
            let mut e = [0.0; 3];
            for v in &c[l * l..(l + 1) * (l + 1)] {
                (0..3).for_each(|k| e[k] += v[k] * v[k]);
            }
            e
        })
        .collect();
    Ok(json!({
        "conventions": "world z up, theta from +z, phi from +x; real SH without Condon-Shortley phase, index l(l+1)+m; linear RGB",
        "bands": bands,
        "width": image.width,
        "height": image.height,
        "downsampled": mapper.small_size(),
        "coeffs": c,
        "band_energy": band_energy,
        "mean_radiance": c[0].map(|v| v / (2.0 * std::f64::consts::PI.sqrt())),
        "dipole_direction": if dipole.length() > 0.0 { dipole.normalize().to_array().to_vec() } else { vec![0.0; 3] },
    }))
}

fn checked_mapper(image: &LinearImage, camera: &Camera, bands: usize) -> Result<EnvMapper> {
    if image.width != camera.width_px as usize || image.height != camera.height_px as usize {
        return Err(Error::Parameter {
            name: "camera",
            value: format!("{}x{}", camera.width_px, camera.height_px),
            expected: format!("the image's size, {}x{}", image.width, image.height),
        });
    }
    EnvMapper::new(camera, bands)
}

/// An RGB canvas with additive drawing (the plots here and the streak contact sheet).
pub(crate) struct Canvas {
    w: usize,
    h: usize,
    px: Vec<[f32; 3]>,
}

impl Canvas {
    pub(crate) fn new(w: usize, h: usize, bg: [f32; 3]) -> Canvas {
        Canvas {
            w,
            h,
            px: vec![bg; w * h],
        }
    }

    pub(crate) fn add(&mut self, x: f64, y: f64, c: [f32; 3]) {
        if x >= 0.0 && y >= 0.0 && (x as usize) < self.w && (y as usize) < self.h {
            let p = &mut self.px[y as usize * self.w + x as usize];
            (0..3).for_each(|k| p[k] = (p[k] + c[k]).min(1.0));
        }
    }

    fn line(&mut self, a: (f64, f64), b: (f64, f64), c: [f32; 3], dash: usize) {
        let n = ((b.0 - a.0).hypot(b.1 - a.1).ceil() as usize).max(1);
        for i in 0..=n {
            if dash > 0 && (i / dash) % 2 == 1 {
                continue;
            }
            let t = i as f64 / n as f64;
            self.add(a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1), c);
        }
    }

    /// Digits, '.', '-' in a 3×5 bitmap font, `scale` pixels per dot.
    pub(crate) fn text(&mut self, x: f64, y: f64, s: &str, c: [f32; 3], scale: usize) {
        const GLYPHS: [(char, [u8; 5]); 13] = [
            ('0', [7, 5, 5, 5, 7]),
            ('1', [2, 6, 2, 2, 7]),
            ('2', [7, 1, 7, 4, 7]),
            ('3', [7, 1, 7, 1, 7]),
            ('4', [5, 5, 7, 1, 1]),
            ('5', [7, 4, 7, 1, 7]),
            ('6', [7, 4, 7, 5, 7]),
            ('7', [7, 1, 1, 1, 1]),
            ('8', [7, 5, 7, 5, 7]),
            ('9', [7, 5, 7, 1, 7]),
            ('.', [0, 0, 0, 0, 2]),
            ('-', [0, 0, 7, 0, 0]),
            ('e', [7, 5, 7, 4, 7]),
        ];
        for (i, ch) in s.chars().enumerate() {
            let Some((_, rows)) = GLYPHS.iter().find(|g| g.0 == ch) else {
                continue;
            };
            for (r, bits) in rows.iter().enumerate() {
                for col in 0..3 {
                    if bits & (4 >> col) != 0 {
                        for dy in 0..scale {
                            for dx in 0..scale {
                                let px = x + ((i * 4 + col) * scale + dx) as f64;
                                self.add(px, y + (r * scale + dy) as f64, c);
                            }
                        }
                    }
                }
            }
        }
    }

    pub(crate) fn save(&self, path: &Path, srgb: bool) -> Result<()> {
        let enc = |v: f32| {
            let v = if srgb {
                linear_to_srgb(v)
            } else {
                v.clamp(0.0, 1.0)
            };
            (v * 255.0).round() as u8
        };
        let bytes: Vec<u8> = self.px.iter().flat_map(|p| p.map(enc)).collect();
        let img =
            image::RgbImage::from_raw(self.w as u32, self.h as u32, bytes).ok_or_else(|| {
                Error::OutputWrite {
                    path: path.display().to_string(),
                    reason: "bad canvas size".into(),
                }
            })?;
        crate::files::save_png(&img, path)
    }
}

/// A polar plot of the RTF (total per channel, R/G/B curves) to a PNG at `path`. The angle is
/// the scattering angle θ (0 to the right, mirrored below the axis); the radius is log10 F over
/// six decades (grey circles, one per decade). Dashed lines mark the primary (order 3) and
/// secondary (order 4) rainbow caustics of the green channel, labelled with θ in degrees.
pub fn plot_rtf(
    rho: impl Into<ChannelIndices>,
    n_max: usize,
    bins: usize,
    path: &Path,
) -> Result<()> {
    let rho = rho.into();
    check_rtf_params(n_max, bins, 1)?;
    let tables = tables(rho, n_max, bins)?;
    let size = 900usize;
    let (cx, cy, r_max) = (size as f64 / 2.0, size as f64 / 2.0, size as f64 * 0.44);
    let mut cv = Canvas::new(size, size, [0.0; 3]);
    let f_max = tables
        .iter()
        .flat_map(|t| t.total.iter())
        .cloned()
        .fold(1e-30, f64::max);
    let top = f_max.log10().ceil();
    let decades = 6.0;
    let radius =
        |f: f64| ((f.max(1e-300).log10() - (top - decades)) / decades).clamp(0.0, 1.0) * r_max;
    let grey = [0.25, 0.25, 0.25];
    for k in 1..=decades as usize {
        let r = r_max * k as f64 / decades;
        let n = (2.0 * std::f64::consts::PI * r).ceil() as usize;
        for i in 0..n {
            let a = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            cv.add(cx + r * a.cos(), cy + r * a.sin(), grey);
        }
        cv.text(
            cx + r + 3.0,
            cy + 4.0,
            &format!("{}", top - decades + k as f64),
            grey,
            2,
        );
    }
    for deg in (0..360).step_by(30) {
        let a = (deg as f64).to_radians();
        cv.line(
            (cx, cy),
            (cx + r_max * a.cos(), cy + r_max * a.sin()),
            [0.12; 3],
            0,
        );
    }
    let colours = [[1.0, 0.15, 0.15], [0.15, 1.0, 0.15], [0.2, 0.35, 1.0]];
    let channels = if rho.is_single() { 1 } else { 3 };
    for (t, c) in tables.iter().zip(colours).take(channels) {
        let c = if channels == 1 { [1.0; 3] } else { c };
        for sign in [-1.0, 1.0] {
            let pts: Vec<(f64, f64)> = (0..t.bins)
                .map(|m| {
                    let (a, r) = (t.bin_centre_rad(m), radius(t.total[m]));
                    (cx + r * a.cos(), cy - sign * r * a.sin())
                })
                .collect();
            for w in pts.windows(2) {
                cv.line(w[0], w[1], c, 0);
            }
        }
    }
    for n in [3, 4] {
        if let Some(a) = caustic_angle_rad(rho.0[1], n) {
            let end = (cx + r_max * 1.05 * a.cos(), cy - r_max * 1.05 * a.sin());
            cv.line((cx, cy), end, [0.9, 0.8, 0.1], 6);
            cv.text(
                end.0 - 20.0,
                end.1 - 16.0,
                &format!("{:.1}", a.to_degrees()),
                [0.9, 0.8, 0.1],
                2,
            );
        }
    }
    cv.save(path, false)
}

/// The environment of `image` seen through `camera` as two equirectangular panels (each
/// 2:1, θ from +z downwards, φ from +x rightwards): left the frame → sphere mapping, right its
/// reconstruction from `bands` bands, both exposed so the mapping's 99th-percentile luminance is
/// white, sRGB-encoded, negative ringing clipped to black.
pub fn plot_sh(image: &LinearImage, camera: &Camera, bands: usize, path: &Path) -> Result<()> {
    let mapper = checked_mapper(image, camera, bands)?;
    let (w, h) = (256usize, 128usize);
    let mapped = mapper.equirect(&image.pixels, w, h)?;
    let env = mapper.project(&image.pixels)?;
    let recon = reconstruct_equirect(&env, w, h);
    let mut lum: Vec<f32> = mapped
        .iter()
        .map(|p| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2])
        .collect();
    lum.sort_by(f32::total_cmp);
    let white = lum[(lum.len() - 1) * 99 / 100].max(1e-6);
    let gap = 8;
    let mut cv = Canvas::new(2 * w + gap, h, [0.0; 3]);
    for (panel, img) in [(0, &mapped), (1, &recon)] {
        for y in 0..h {
            for x in 0..w {
                let p = img[y * w + x].map(|v| (v / white).max(0.0));
                cv.px[y * cv.w + panel * (w + gap) + x] = p;
            }
        }
    }
    cv.save(path, true)
}
