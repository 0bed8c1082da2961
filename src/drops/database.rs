//! The streak database: a grid of [`StreakSetup`]s (drop size × exposure × view elevation ×
//! oscillation phase), each rendered once for the uniform environment and every light, written
//! as 16-bit greyscale PNGs beside an `index.json` that says what each file is and how to turn
//! its code values back into matte values.
//!
//! Every pixel is a sum in a fixed order over its own samples, so the files are bit-identical
//! whatever the number of threads.

use std::path::Path;

use super::shape::{Amplitudes, rayleigh_frequency_hz};
use super::streak::{LightAngles, Streak, StreakSetup};
use crate::lighting::rtf::WATER_RHO;
use crate::{Error, Result};

/// Version of the `index.json` layout.
pub const INDEX_FORMAT: u32 = 1;

/// What to generate.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DatabaseSpec {
    /// Equivalent drop diameters, mm.
    pub sizes_mm: Vec<f64>,
    /// Exposure times, s.
    pub exposures_s: Vec<f64>,
    /// Camera elevations, degrees.
    pub view_elevations_deg: Vec<f64>,
    /// Point-light directions relative to the camera.
    pub lights: Vec<LightAngles>,
    /// Oscillation phases per streak, evenly spaced over the (2,0) period.
    pub phases: usize,
    /// Pixels across the drop's equivalent diameter (the database's scale).
    pub pixels_per_diameter: f64,
    /// Samples per pixel side and time steps per pixel of travel.
    pub samples: usize,
    /// Highest scattering order traced.
    pub orders: usize,
    /// Angular radius of the point lights, degrees.
    pub light_width_deg: f64,
    /// Refractive index of water.
    pub rho: f64,
}

impl Default for DatabaseSpec {
    /// The set shipped in `drops/`: three sizes across the visible range, the 1/60 s exposure
    /// of Garg & Nayar's database, three view elevations, lights in front of, beside and behind
    /// the drop at three elevations (azimuths 180°–360° are the mirror images), four phases.
    fn default() -> DatabaseSpec {
        let lights = [-45.0, 0.0, 45.0]
            .into_iter()
            .flat_map(|elevation_deg| {
                [0.0, 45.0, 90.0, 135.0, 180.0].map(|azimuth_deg| LightAngles {
                    elevation_deg,
                    azimuth_deg,
                })
            })
            .collect();
        DatabaseSpec {
            sizes_mm: vec![1.0, 2.0, 4.0],
            exposures_s: vec![1.0 / 60.0],
            view_elevations_deg: vec![0.0, 30.0, 60.0],
            lights,
            phases: 4,
            pixels_per_diameter: 8.0,
            samples: 2,
            orders: 6,
            light_width_deg: 3.0,
            rho: WATER_RHO,
        }
    }
}

/// One PNG of the database.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MatteEntry {
    /// Path relative to the database folder.
    pub file: String,
    /// Equivalent drop diameter, mm.
    pub diameter_mm: f64,
    /// Exposure time, s.
    pub exposure_s: f64,
    /// Camera elevation, degrees.
    pub view_elevation_deg: f64,
    /// The point light, or `None` for the uniform environment.
    pub light: Option<LightAngles>,
    /// Oscillation phase at shutter open, fraction of the (2,0) period.
    pub phase: f64,
    /// Mode amplitudes used.
    pub amplitudes: Amplitudes,
    /// (2,0) and (3,1) frequencies, Hz.
    pub mode_frequencies_hz: [f64; 2],
    /// Terminal velocity, m/s.
    pub fall_speed_mps: f64,
    /// Pixel pitch, mm.
    pub pixel_mm: f64,
    /// Image width, px.
    pub width: usize,
    /// Image height, px.
    pub height: usize,
    /// Distance the drop's centre travels down the image in the exposure, px.
    pub travel_px: f64,
    /// Row of the drop's centre at shutter open (pixel units from the top edge).
    pub start_row: f64,
    /// Matte value of code 65535: matte = code / 65535 × scale (radiance for the environment,
    /// sr⁻¹ per unit irradiance for a light, times the exposure fraction).
    pub scale: f64,
    /// Σ matte over the pixels, px².
    pub sum_px2: f64,
    /// The drop's time-averaged projected area, px²: what the matte of a drop of radiance 1
    /// sums to. A renderer divides by it to spread the streak's light without changing it.
    pub coverage_px2: f64,
}

/// `index.json`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Index {
    /// Layout version ([`INDEX_FORMAT`]).
    pub format: u32,
    /// The command that made it.
    pub generator: String,
    /// The grid.
    pub spec: DatabaseSpec,
    /// Every file.
    pub mattes: Vec<MatteEntry>,
}

impl Index {
    /// The matte a renderer would draw for a drop of `diameter_mm`, exposure `exposure_s`, seen
    /// from elevation `view_deg`, at oscillation `phase` (fraction of the (2,0) period), lit by
    /// the uniform environment (`light = None`) or a light at (elevation, azimuth) degrees:
    /// the nearest size, exposure, view and phase of the grid, then the nearest light
    /// direction. Lights at azimuths beyond 180° use the mirror image, so the second value says
    /// whether to flip the matte left–right.
    pub fn pick(
        &self,
        diameter_mm: f64,
        exposure_s: f64,
        view_deg: f64,
        phase: f64,
        light: Option<LightAngles>,
    ) -> Option<(&MatteEntry, bool)> {
        let nearest = |values: &[f64], x: f64| {
            values
                .iter()
                .copied()
                .min_by(|a, b| (a - x).abs().total_cmp(&(b - x).abs()))
        };
        let d = nearest(&self.spec.sizes_mm, diameter_mm)?;
        // Exposures compare by ratio (1/50 is nearer 1/60 than 1/30 is).
        let t = self.spec.exposures_s.iter().copied().min_by(|a, b| {
            (a / exposure_s)
                .ln()
                .abs()
                .total_cmp(&(b / exposure_s).ln().abs())
        })?;
        let v = nearest(&self.spec.view_elevations_deg, view_deg)?;
        let phases = self.spec.phases.max(1) as f64;
        let p = (phase.rem_euclid(1.0) * phases).round().rem_euclid(phases) / phases;
        let (light, mirror) = match light {
            None => (None, false),
            Some(l) => {
                let az = l.azimuth_deg.rem_euclid(360.0);
                let mirror = az > 180.0;
                let want = LightAngles {
                    elevation_deg: l.elevation_deg,
                    azimuth_deg: if mirror { 360.0 - az } else { az },
                }
                .direction();
                let best =
                    self.spec.lights.iter().copied().max_by(|a, b| {
                        a.direction().dot(want).total_cmp(&b.direction().dot(want))
                    })?;
                (Some(best), mirror)
            }
        };
        self.mattes
            .iter()
            .find(|m| {
                m.diameter_mm == d
                    && m.exposure_s == t
                    && m.view_elevation_deg == v
                    && m.phase == p
                    && m.light == light
            })
            .map(|m| (m, mirror))
    }
}

/// One streak's setup from the grid.
pub fn setup(
    spec: &DatabaseSpec,
    d_mm: f64,
    exposure_s: f64,
    view_deg: f64,
    phase_index: usize,
) -> StreakSetup {
    StreakSetup {
        diameter_m: d_mm * 1e-3,
        amplitudes: Amplitudes::for_diameter_mm(d_mm),
        exposure_s,
        view_elevation_deg: view_deg,
        phase: phase_index as f64 / spec.phases.max(1) as f64,
        transverse_azimuth_deg: 0.0,
        pixel_m: d_mm * 1e-3 / spec.pixels_per_diameter,
        samples: spec.samples,
        orders: spec.orders,
        rho: spec.rho,
        light_width_deg: spec.light_width_deg,
    }
}

/// The folder of one drop size and exposure, e.g. `d2.00mm_t16.67ms`.
pub fn folder_name(d_mm: f64, exposure_s: f64) -> String {
    format!("d{d_mm:.2}mm_t{:.2}ms", exposure_s * 1e3)
}

/// Quantises a matte to 16 bits, scaled to its maximum; returns the codes and the scale.
pub fn quantise(matte: &[f64]) -> (Vec<u16>, f64) {
    let max = matte.iter().copied().fold(0.0, f64::max);
    if max <= 0.0 {
        return (vec![0; matte.len()], 0.0);
    }
    let codes = matte
        .iter()
        .map(|v| (v / max * 65535.0).round() as u16)
        .collect();
    (codes, max)
}

/// Writes `bytes` to `path` through a temporary file beside it, so a failure never leaves a
/// partial file under the final name.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let fail = |e: std::io::Error| Error::OutputWrite {
        path: path.display().to_string(),
        reason: e.to_string(),
    };
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes).map_err(fail)?;
    std::fs::rename(&tmp, path).map_err(fail)
}

/// A 16-bit greyscale PNG in memory.
pub fn encode_png16(width: usize, height: usize, codes: &[u16]) -> Result<Vec<u8>> {
    let img = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(
        width as u32,
        height as u32,
        codes.to_vec(),
    )
    .ok_or_else(|| Error::Unsupported("matte size does not match its pixels".into()))?;
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .map_err(|e| Error::Unsupported(format!("encoding a matte PNG: {e}")))?;
    Ok(bytes)
}

/// The index entries of one rendered streak (environment first, then the lights in order), and
/// the mattes they describe.
pub fn entries(
    spec: &DatabaseSpec,
    setup: &StreakSetup,
    streak: &Streak,
) -> Vec<(MatteEntry, Vec<f64>)> {
    let d_mm = setup.diameter_m * 1e3;
    let folder = folder_name(d_mm, setup.exposure_s);
    let phase_index = (setup.phase * spec.phases as f64).round() as usize;
    let stem = format!("{folder}/v{}_p{phase_index}", setup.view_elevation_deg);
    let coverage_px2: f64 = streak.coverage.iter().sum();
    let make = |light: Option<LightAngles>, matte: &[f64]| {
        let file = match light {
            None => format!("{stem}_env.png"),
            Some(l) => format!("{stem}_l{}_{}.png", l.elevation_deg, l.azimuth_deg),
        };
        let entry = MatteEntry {
            file,
            diameter_mm: d_mm,
            exposure_s: setup.exposure_s,
            view_elevation_deg: setup.view_elevation_deg,
            light,
            phase: setup.phase,
            amplitudes: setup.amplitudes,
            mode_frequencies_hz: [2, 3].map(|n| rayleigh_frequency_hz(n, setup.diameter_m)),
            fall_speed_mps: streak.fall_speed_mps,
            pixel_mm: setup.pixel_m * 1e3,
            width: streak.width,
            height: streak.height,
            travel_px: streak.travel_px,
            start_row: streak.start_row,
            scale: quantise(matte).1,
            sum_px2: matte.iter().sum(),
            coverage_px2,
        };
        (entry, matte.to_vec())
    };
    std::iter::once(make(None, &streak.env))
        .chain(
            spec.lights
                .iter()
                .zip(&streak.lights)
                .map(|(l, m)| make(Some(*l), m)),
        )
        .collect()
}

/// Most oscillation phases per streak: the oscillation's period is sampled finely long before.
pub const MAX_PHASES: usize = 64;

/// Most samples per pixel side (and time steps per pixel of travel).
pub const MAX_SAMPLES: usize = 16;

/// Most streaks in one database (each writes a matte per light): a bound on the files and the
/// time a mistyped count costs.
pub const MAX_STREAKS: usize = 10_000;

/// Renders the whole grid into `dir` (created if missing) and writes `index.json` last.
/// `progress` is called after each streak with (done, total); `cancel` stops the work between
/// two streaks with [`Error::Interrupted`] (the mattes already written stay, `index.json` is
/// not written).
pub fn generate(
    spec: &DatabaseSpec,
    dir: &Path,
    cancel: &std::sync::atomic::AtomicBool,
    mut progress: impl FnMut(usize, usize),
) -> Result<Index> {
    let count = |name: &'static str, value: usize, max: usize| {
        if (1..=max).contains(&value) {
            Ok(())
        } else {
            Err(Error::Parameter {
                name,
                value: value.to_string(),
                expected: format!("1 to {max}"),
            })
        }
    };
    count("drops.phases", spec.phases, MAX_PHASES)?;
    count("drops.samples", spec.samples, MAX_SAMPLES)?;
    for (name, len) in [
        ("drops.sizes_mm", spec.sizes_mm.len()),
        ("drops.exposures_s", spec.exposures_s.len()),
        ("drops.view_elevations_deg", spec.view_elevations_deg.len()),
    ] {
        if len == 0 {
            return Err(Error::Parameter {
                name,
                value: "(none)".into(),
                expected: "at least one value".into(),
            });
        }
    }
    let streaks = [
        spec.sizes_mm.len(),
        spec.exposures_s.len(),
        spec.view_elevations_deg.len(),
        spec.phases,
    ]
    .iter()
    .try_fold(1usize, |n, &k| n.checked_mul(k))
    .filter(|&n| n <= MAX_STREAKS);
    if streaks.is_none() {
        return Err(Error::Parameter {
            name: "drops.streaks",
            value: format!(
                "{} × {} × {} × {}",
                spec.sizes_mm.len(),
                spec.exposures_s.len(),
                spec.view_elevations_deg.len(),
                spec.phases
            ),
            expected: format!("at most {MAX_STREAKS} streaks in all"),
        });
    }
    let mut jobs = Vec::new();
    for &d in &spec.sizes_mm {
        for &t in &spec.exposures_s {
            for &v in &spec.view_elevations_deg {
                for k in 0..spec.phases {
                    let s = setup(spec, d, t, v, k);
                    s.validate()?;
                    jobs.push(s);
                }
            }
        }
    }
    let mut index = Index {
        format: INDEX_FORMAT,
        generator: format!(
            "rain-composite {} drops generate",
            env!("CARGO_PKG_VERSION")
        ),
        spec: spec.clone(),
        mattes: Vec::new(),
    };
    for (i, job) in jobs.iter().enumerate() {
        if cancel.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(Error::Interrupted);
        }
        let streak = job.render_or_stop(&spec.lights, cancel)?;
        for (entry, matte) in entries(spec, job, &streak) {
            let path = dir.join(&entry.file);
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).map_err(|e| Error::OutputWrite {
                    path: parent.display().to_string(),
                    reason: e.to_string(),
                })?;
            }
            let (codes, _) = quantise(&matte);
            write_atomic(&path, &encode_png16(entry.width, entry.height, &codes)?)?;
            index.mattes.push(entry);
        }
        progress(i + 1, jobs.len());
    }
    let json =
        serde_json::to_string_pretty(&index).map_err(|e| Error::Unsupported(e.to_string()))?;
    write_atomic(&dir.join("index.json"), json.as_bytes())?;
    Ok(index)
}

/// Largest `index.json` read, bytes: one of [`MAX_STREAKS`] streaks under a few dozen lights
/// takes tens of MiB.
pub const MAX_INDEX_BYTES: u64 = 256 << 20;

/// Reads `index.json` of a database folder (a regular file of at most [`MAX_INDEX_BYTES`]).
pub fn load_index(dir: &Path) -> Result<Index> {
    let path = dir.join("index.json");
    let bytes =
        crate::files::read_regular(&path, MAX_INDEX_BYTES).map_err(|reason| Error::InputOpen {
            path: path.display().to_string(),
            reason,
        })?;
    serde_json::from_slice(&bytes).map_err(|e| Error::InputOpen {
        path: path.display().to_string(),
        reason: format!("not a streak index: {e}"),
    })
}

/// Reads one matte of a database back as matte values (code / 65535 × scale).
pub fn read_matte(dir: &Path, entry: &MatteEntry) -> Result<Vec<f64>> {
    let path = dir.join(&entry.file);
    let fail = |reason: String| Error::InputOpen {
        path: path.display().to_string(),
        reason,
    };
    let img = crate::files::read_png(&path).map_err(fail)?.into_luma16();
    if (img.width() as usize, img.height() as usize) != (entry.width, entry.height) {
        return Err(fail(format!(
            "{}×{} px, the index says {}×{}",
            img.width(),
            img.height(),
            entry.width,
            entry.height
        )));
    }
    Ok(img
        .into_raw()
        .iter()
        .map(|&c| c as f64 / 65535.0 * entry.scale)
        .collect())
}
