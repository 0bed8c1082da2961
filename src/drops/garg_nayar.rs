//! A user's copy of Garg & Nayar's original rain-streak database (Columbia CAVE, 2006; it has
//! no licence, so it is never shipped). The layout (physics notes §4.1):
//!
//! ```text
//! env_light_database/size{W}/cv{E}_osc{K}.png                  E ∈ {0,20,…,80}, K ∈ 0..10
//! env_light_database/txt/normalized_env_max.txt               "cvE" then 10 multipliers
//! point_light_database/size{W}/dcam{EE}/cv{E}_v{V}_h{H}_osc{K}.png
//! point_light_database/txt/dcam{EE}_point_max.txt             "vV", then "hH" + 10 multipliers
//! ```
//!
//! W is the streak width in pixels (4, 8, 16, 32), E the camera elevation, V the light's
//! elevation (−90…90 in 20° steps), H its azimuth (10…170 in 20° steps); some (V, H) pairs are
//! missing. Each PNG is scaled to 65535; matte = code / 65535 × multiplier. A request picks the
//! nearest file that exists.

use std::path::{Path, PathBuf};

use crate::{Error, Result};

/// Camera elevations of the database, degrees.
pub const VIEW_ELEVATIONS_DEG: [i32; 5] = [0, 20, 40, 60, 80];
/// Light elevations of the point-light part, degrees.
pub const LIGHT_ELEVATIONS_DEG: [i32; 10] = [-90, -70, -50, -30, -10, 10, 30, 50, 70, 90];
/// Light azimuths of the point-light part, degrees.
pub const LIGHT_AZIMUTHS_DEG: [i32; 9] = [10, 30, 50, 70, 90, 110, 130, 150, 170];
/// Oscillation images per configuration.
pub const OSCILLATIONS: usize = 10;

/// A file picked for a request: where it is and its brightness multiplier.
#[derive(Debug, Clone, PartialEq)]
pub struct Pick {
    /// The PNG.
    pub path: PathBuf,
    /// matte = code / 65535 × multiplier.
    pub multiplier: f64,
    /// The angles of the file picked: camera elevation, and the light's (V, H) if any.
    pub view_elevation_deg: i32,
    /// The light's elevation and azimuth, degrees, for a point-light file.
    pub light_deg: Option<(i32, i32)>,
}

/// A Garg & Nayar database folder at one streak width.
#[derive(Debug, Clone)]
pub struct GargNayarDb {
    root: PathBuf,
    width_px: u32,
}

fn nearest(values: &[i32], x: f64) -> i32 {
    let mut best = values[0];
    for &v in values {
        if (v as f64 - x).abs() < (best as f64 - x).abs() {
            best = v;
        }
    }
    best
}

fn open_error(path: &Path, reason: impl Into<String>) -> Error {
    Error::InputOpen {
        path: path.display().to_string(),
        reason: reason.into(),
    }
}

/// The 10 multipliers following the line `header`, on the same line or the next.
fn multipliers(path: &Path, header: &str) -> Result<Vec<f64>> {
    let text = std::fs::read_to_string(path).map_err(|e| open_error(path, e.to_string()))?;
    let mut tokens = text.split_whitespace();
    while let Some(t) = tokens.next() {
        if t == header {
            let values: Vec<f64> = tokens
                .by_ref()
                .take(OSCILLATIONS)
                .map_while(|t| t.parse().ok())
                .collect();
            if values.len() == OSCILLATIONS {
                return Ok(values);
            }
            return Err(open_error(
                path,
                format!("'{header}' is not followed by {OSCILLATIONS} numbers"),
            ));
        }
    }
    Err(open_error(path, format!("no '{header}' entry")))
}

/// The 10 multipliers of light (V, H) in a `dcamEE_point_max.txt`: lines `vV` open a block of
/// lines `hH m0 … m9`.
fn point_multipliers(path: &Path, v: i32, h: i32) -> Result<Vec<f64>> {
    let text = std::fs::read_to_string(path).map_err(|e| open_error(path, e.to_string()))?;
    let (v_line, h_tag) = (format!("v{v}"), format!("h{h}"));
    let mut in_block = false;
    for line in text.lines().map(str::trim) {
        if line.starts_with('v') {
            in_block = line == v_line;
        } else if in_block && line.split_whitespace().next() == Some(h_tag.as_str()) {
            let values: Vec<f64> = line
                .split_whitespace()
                .skip(1)
                .map_while(|t| t.parse().ok())
                .collect();
            if values.len() == OSCILLATIONS {
                return Ok(values);
            }
        }
    }
    Err(open_error(
        path,
        format!("no {OSCILLATIONS} multipliers for v{v} h{h}"),
    ))
}

impl GargNayarDb {
    /// Opens the database at `root` for streaks `width_px` wide; checks that the environment
    /// part is there.
    pub fn open(root: &Path, width_px: u32) -> Result<GargNayarDb> {
        let db = GargNayarDb {
            root: root.to_path_buf(),
            width_px,
        };
        let env = root
            .join("env_light_database")
            .join(format!("size{width_px}"));
        if !env.is_dir() {
            return Err(open_error(
                root,
                format!(
                    "not a Garg & Nayar streak database (no env_light_database/size{width_px}/)"
                ),
            ));
        }
        Ok(db)
    }

    /// The environment-light streak nearest to camera elevation `view_deg`, oscillation `osc`.
    pub fn env(&self, view_deg: f64, osc: usize) -> Result<Pick> {
        let e = nearest(&VIEW_ELEVATIONS_DEG, view_deg);
        let osc = osc % OSCILLATIONS;
        let base = self.root.join("env_light_database");
        let txt = base.join("txt").join("normalized_env_max.txt");
        let path = base
            .join(format!("size{}", self.width_px))
            .join(format!("cv{e}_osc{osc}.png"));
        if !path.is_file() {
            return Err(open_error(&path, "missing from the database"));
        }
        Ok(Pick {
            multiplier: multipliers(&txt, &format!("cv{e}"))?[osc],
            path,
            view_elevation_deg: e,
            light_deg: None,
        })
    }

    /// The point-light streak nearest to the request (light elevation and azimuth, degrees,
    /// in the database's convention): the nearest camera elevation, then among the files that
    /// exist the light direction at the smallest angle.
    pub fn point(
        &self,
        view_deg: f64,
        light_elevation_deg: f64,
        light_azimuth_deg: f64,
        osc: usize,
    ) -> Result<Pick> {
        let e = nearest(&VIEW_ELEVATIONS_DEG, view_deg);
        let osc = osc % OSCILLATIONS;
        let base = self.root.join("point_light_database");
        let folder = base
            .join(format!("size{}", self.width_px))
            .join(format!("dcam{e:02}"));
        let dir = |el: f64, az: f64| {
            let (el, az) = (el.to_radians(), az.to_radians());
            [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()]
        };
        let want = dir(light_elevation_deg, light_azimuth_deg);
        let mut best: Option<(f64, i32, i32, PathBuf)> = None;
        for v in LIGHT_ELEVATIONS_DEG {
            for h in LIGHT_AZIMUTHS_DEG {
                let path = folder.join(format!("cv{e}_v{v}_h{h}_osc{osc}.png"));
                let d = dir(v as f64, h as f64);
                let cos = want[0] * d[0] + want[1] * d[1] + want[2] * d[2];
                if best.as_ref().is_none_or(|b| cos > b.0) && path.is_file() {
                    best = Some((cos, v, h, path));
                }
            }
        }
        let Some((_, v, h, path)) = best else {
            return Err(open_error(
                &folder,
                "no point-light streaks for this camera elevation",
            ));
        };
        let txt = base.join("txt").join(format!("dcam{e:02}_point_max.txt"));
        let multiplier = point_multipliers(&txt, v, h)?[osc];
        Ok(Pick {
            path,
            multiplier,
            view_elevation_deg: e,
            light_deg: Some((v, h)),
        })
    }

    /// Reads a picked file as matte values (code / 65535 × multiplier), with its size.
    pub fn read(pick: &Pick) -> Result<(usize, usize, Vec<f64>)> {
        let img = crate::files::read_png(&pick.path)
            .map_err(|e| open_error(&pick.path, e))?
            .into_luma16();
        let (w, h) = (img.width() as usize, img.height() as usize);
        Ok((
            w,
            h,
            img.into_raw()
                .iter()
                .map(|&c| c as f64 / 65535.0 * pick.multiplier)
                .collect(),
        ))
    }
}
