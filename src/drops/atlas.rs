//! The environment mattes a render draws, resampled onto one common grid and normalised, in the
//! layer order the `rain_streaks` stage indexes (size bin × view bin × phase).
//!
//! A layer's grid spans the streak's footprint: `u` ∈ [0, 1] from the tail of the drop's disc at
//! shutter open to its head at shutter close (along = −r … len + r on screen), and `v` ∈
//! [−[`HALF_WIDTH_RADII`], +] drop radii across. Each layer is scaled so that ∫∫ N du dv = 1:
//! the renderer spreads the streak's Garg–Nayar coverage (πr² px² per unit alpha) by N, so a
//! matte moves light along the streak without changing how much the streak holds.
//!
//! After the environment layers come the point-light layers (size bin × view bin × light
//! direction × phase), for the glints of each drop's strongest compact lights.

use std::path::Path;

use super::database::{Index, load_index, read_matte};
use super::garg_nayar::{self, GargNayarDb};
use crate::{Error, Result};

/// Texels across a layer.
pub const ATLAS_WIDTH: usize = 12;
/// Texels along a layer.
pub const ATLAS_HEIGHT: usize = 256;
/// Half the layer's width, in drop radii (our database's mattes are 1.5 diameters wide).
pub const HALF_WIDTH_RADII: f64 = 1.5;
/// Most size and view bins the stage takes (`MatteParams` in the WGSL).
pub const MAX_MATTE_BINS: usize = 8;
/// Most point-light directions the stage takes (`MAX_MATTE_LIGHTS` in the WGSL).
pub const MAX_MATTE_LIGHTS: usize = 16;

/// Light elevations drawn from a copy of Garg & Nayar's point-light part, degrees: its grid
/// (−90…90° in 20° steps) every 40°, about the horizontal and above it, where street lamps and
/// the sun are.
pub const GARG_NAYAR_LIGHT_ELEVATIONS_DEG: [f64; 3] = [-30.0, 10.0, 50.0];
/// Light azimuths drawn from it (as [`super::LightAngles`]: from the camera's side round to
/// behind the drop), degrees: its grid (10…170° in 20° steps) every 40°. With the elevations,
/// 15 ≤ [`MAX_MATTE_LIGHTS`] directions.
pub const GARG_NAYAR_LIGHT_AZIMUTHS_DEG: [f64; 5] = [10.0, 50.0, 90.0, 130.0, 170.0];

/// The mattes of a render, uploaded once per job.
#[derive(Debug, Clone, PartialEq)]
pub struct MatteAtlas {
    /// Drop diameters of the size bins, mm, ascending.
    pub sizes_mm: Vec<f64>,
    /// Camera elevations of the view bins, degrees, ascending.
    pub views_deg: Vec<f64>,
    /// Oscillation phases per (size, view).
    pub phases: usize,
    /// Directions (unit, drop → light) of the point-light mattes, in the frame of
    /// [`super::LightAngles::direction`]: x image right, y away from the camera, z up; empty
    /// where the database has none.
    pub lights: Vec<glam::DVec3>,
    /// `ATLAS_WIDTH × ATLAS_HEIGHT` texels per layer, row-major, layer
    /// `(size · views + view) · phases + phase`.
    pub texels: Vec<f32>,
}

/// Bilinear sample of a `w × h` row-major image at continuous pixel coordinates (centres at
/// +0.5); zero outside.
fn bilinear(texel: impl Fn(usize) -> f64, w: usize, h: usize, x: f64, y: f64) -> f64 {
    let (fx, fy) = (x - 0.5, y - 0.5);
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let at = |xi: f64, yi: f64| {
        if xi < 0.0 || yi < 0.0 || xi >= w as f64 || yi >= h as f64 {
            0.0
        } else {
            texel(yi as usize * w + xi as usize)
        }
    };
    let top = at(x0, y0) * (1.0 - tx) + at(x0 + 1.0, y0) * tx;
    let bottom = at(x0, y0 + 1.0) * (1.0 - tx) + at(x0 + 1.0, y0 + 1.0) * tx;
    top * (1.0 - ty) + bottom * ty
}

/// One layer: `source(u, v)` sampled at the grid's texel centres, scaled to ∫∫ N du dv = 1.
fn layer(source: impl Fn(f64, f64) -> f64) -> Result<Vec<f32>> {
    let mut texels = Vec::with_capacity(ATLAS_WIDTH * ATLAS_HEIGHT);
    for j in 0..ATLAS_HEIGHT {
        for i in 0..ATLAS_WIDTH {
            let u = (j as f64 + 0.5) / ATLAS_HEIGHT as f64;
            let v = HALF_WIDTH_RADII * (2.0 * (i as f64 + 0.5) / ATLAS_WIDTH as f64 - 1.0);
            texels.push(source(u, v).max(0.0));
        }
    }
    let cell = (1.0 / ATLAS_HEIGHT as f64) * (2.0 * HALF_WIDTH_RADII / ATLAS_WIDTH as f64);
    let integral: f64 = texels.iter().sum::<f64>() * cell;
    if integral <= 0.0 {
        return Err(Error::Unsupported("a streak matte is empty".into()));
    }
    Ok(texels.iter().map(|t| (t / integral) as f32).collect())
}

impl MatteAtlas {
    /// Loads the environment mattes of the database at `dir`: this project's layout
    /// (`index.json`, every size, the views and phases of its grid, for `exposure_s`), or a
    /// copy of Garg & Nayar's (one size, 1.6 mm; their five views and ten oscillations).
    pub fn load(dir: &Path, exposure_s: f64) -> Result<MatteAtlas> {
        if dir.join("index.json").is_file() {
            Self::from_index(dir, &load_index(dir)?, exposure_s)
        } else if dir.join("env_light_database").is_dir() {
            Self::from_garg_nayar(dir)
        } else {
            let reason = if dir.exists() {
                "not a streak database (no index.json, no env_light_database/)"
            } else {
                "no such folder: a streak database is a folder with index.json, made by \
                 `rain-composite drops generate`"
            };
            Err(Error::InputOpen {
                path: dir.display().to_string(),
                reason: reason.into(),
            })
        }
    }

    /// The environment mattes of one of our databases.
    pub fn from_index(dir: &Path, index: &Index, exposure_s: f64) -> Result<MatteAtlas> {
        let spec = &index.spec;
        let mut sizes_mm = spec.sizes_mm.clone();
        let mut views_deg = spec.view_elevations_deg.clone();
        sizes_mm.sort_by(f64::total_cmp);
        views_deg.sort_by(f64::total_cmp);
        if sizes_mm.len() > MAX_MATTE_BINS || views_deg.len() > MAX_MATTE_BINS {
            return Err(Error::Unsupported(format!(
                "a streak database of at most {MAX_MATTE_BINS} sizes and views"
            )));
        }
        let phases = spec.phases.max(1);
        let lights: Vec<_> = spec.lights.iter().take(MAX_MATTE_LIGHTS).copied().collect();
        let mut texels = Vec::new();
        // The environment layers, then the point-light layers.
        let mut picks = Vec::new();
        for &d in &sizes_mm {
            for &v in &views_deg {
                picks.extend((0..phases).map(|k| (d, v, k, None)));
            }
        }
        for &d in &sizes_mm {
            for &v in &views_deg {
                for l in &lights {
                    picks.extend((0..phases).map(|k| (d, v, k, Some(*l))));
                }
            }
        }
        for (d, v, k, light) in picks {
            let phase = k as f64 / phases as f64;
            let (entry, _) =
                index
                    .pick(d, exposure_s, v, phase, light)
                    .ok_or_else(|| Error::InputOpen {
                        path: dir.display().to_string(),
                        reason: format!("no matte for {d} mm, view {v}°, phase {k}"),
                    })?;
            let m = read_matte(dir, entry)?;
            // The footprint: the disc's tail at shutter open to its head at close.
            let radius_px = 0.5 * entry.diameter_mm / entry.pixel_mm;
            let first_row = entry.start_row - radius_px;
            let rows = entry.travel_px + 2.0 * radius_px;
            let mid = 0.5 * entry.width as f64;
            texels.extend(layer(|u, v| {
                bilinear(
                    |k| m[k],
                    entry.width,
                    entry.height,
                    mid + v * radius_px,
                    first_row + u * rows,
                )
            })?);
        }
        Ok(MatteAtlas {
            sizes_mm,
            views_deg,
            phases,
            lights: lights.iter().map(|l| l.direction()).collect(),
            texels,
        })
    }

    /// The mattes of Garg & Nayar's database: the 16-px-wide set, its image width taken as the
    /// drop's diameter and its height as the footprint. Where the copy has its point-light
    /// part, the point-light layers follow, for the directions of
    /// [`GARG_NAYAR_LIGHT_ELEVATIONS_DEG`] × [`GARG_NAYAR_LIGHT_AZIMUTHS_DEG`], each the nearest
    /// file that exists.
    pub fn from_garg_nayar(dir: &Path) -> Result<MatteAtlas> {
        let db = GargNayarDb::open(dir, 16)?;
        let lights: Vec<super::LightAngles> = if dir.join("point_light_database").is_dir() {
            GARG_NAYAR_LIGHT_ELEVATIONS_DEG
                .iter()
                .flat_map(|&elevation_deg| {
                    GARG_NAYAR_LIGHT_AZIMUTHS_DEG
                        .iter()
                        .map(move |&azimuth_deg| super::LightAngles {
                            elevation_deg,
                            azimuth_deg,
                        })
                })
                .collect()
        } else {
            Vec::new()
        };
        let picks = garg_nayar::VIEW_ELEVATIONS_DEG
            .iter()
            .flat_map(|&view| (0..garg_nayar::OSCILLATIONS).map(move |osc| (view, None, osc)));
        let point_picks = garg_nayar::VIEW_ELEVATIONS_DEG.iter().flat_map(|&view| {
            lights.iter().flat_map(move |l| {
                (0..garg_nayar::OSCILLATIONS).map(move |osc| (view, Some(*l), osc))
            })
        });
        let mut texels = Vec::new();
        for (view, light, osc) in picks.chain(point_picks) {
            let pick = match light {
                None => db.env(view as f64, osc)?,
                Some(l) => db.point(view as f64, l.elevation_deg, l.azimuth_deg, osc)?,
            };
            let (w, h, m) = GargNayarDb::read(&pick)?;
            texels.extend(layer(|u, v| {
                bilinear(|k| m[k], w, h, 0.5 * w as f64 * (1.0 + v), u * h as f64)
            })?);
        }
        Ok(MatteAtlas {
            sizes_mm: vec![1.6],
            views_deg: garg_nayar::VIEW_ELEVATIONS_DEG.map(f64::from).to_vec(),
            phases: garg_nayar::OSCILLATIONS,
            lights: lights.iter().map(super::LightAngles::direction).collect(),
            texels,
        })
    }

    /// The first point-light layer.
    pub fn light_layer0(&self) -> usize {
        self.sizes_mm.len() * self.views_deg.len() * self.phases
    }

    /// Layers in the atlas.
    pub fn layers(&self) -> usize {
        self.texels.len() / (ATLAS_WIDTH * ATLAS_HEIGHT)
    }

    /// How far across the streak, in drop radii, any layer's [`MatteAtlas::sample`] is not
    /// zero (at most [`HALF_WIDTH_RADII`]): a layer's read is zero from the centre of the
    /// outermost empty column outwards. The rasteriser's quads need reach no farther.
    pub fn reach_radii(&self) -> f64 {
        let mut columns = [false; ATLAS_WIDTH];
        for (k, &t) in self.texels.iter().enumerate() {
            columns[k % ATLAS_WIDTH] |= t != 0.0;
        }
        // Texel centres at i + 0.5: v = H (2 x / W − 1) in radii.
        let radii = |x: f64| HALF_WIDTH_RADII * (2.0 * x / ATLAS_WIDTH as f64 - 1.0);
        let right = columns
            .iter()
            .rposition(|&c| c)
            .map_or(0.0, |i| radii(i as f64 + 1.5));
        let left = columns
            .iter()
            .position(|&c| c)
            .map_or(0.0, |i| -radii(i as f64 - 0.5));
        right.max(left).min(HALF_WIDTH_RADII)
    }

    /// N at grid position (u, v) of `layer`, bilinear between texel centres, zero outside the
    /// grid (the stage's `matte_at`).
    pub fn sample(&self, layer: usize, u: f64, v: f64) -> f64 {
        let base = layer * ATLAS_WIDTH * ATLAS_HEIGHT;
        let texels = &self.texels[base..base + ATLAS_WIDTH * ATLAS_HEIGHT];
        let x = (v / HALF_WIDTH_RADII + 1.0) * 0.5 * ATLAS_WIDTH as f64;
        let y = u * ATLAS_HEIGHT as f64;
        bilinear(|k| texels[k] as f64, ATLAS_WIDTH, ATLAS_HEIGHT, x, y)
    }
}
