//! A labelled contact sheet of a streak database (`inspect drops --mattes sheet.png`).
//!
//! Our database: one row per drop size and view elevation (first exposure, phase 0), the
//! environment matte first (column `e`), then one column per light labelled `elevation
//! azimuth`. Garg & Nayar's: one row per camera elevation, its ten environment streaks.
//! Each tile is scaled to its own maximum and shown with a square-root tone curve, so dim
//! mattes stay readable; the numbers in `index.json` carry the absolute scale.

use std::path::Path;

use super::database::{load_index, read_matte};
use super::garg_nayar::{GargNayarDb, OSCILLATIONS, VIEW_ELEVATIONS_DEG};
use crate::Result;
use crate::lighting::inspect::Canvas;

/// Tile height, px (every streak is resampled to it).
const TILE_H: usize = 240;
/// Horizontal magnification of a streak.
const TILE_ZOOM: usize = 3;
/// Label scale (pixels per font dot) and margins.
const FONT: usize = 2;
const LABEL_W: usize = 100;
const HEADER_H: usize = 32;
const GAP: usize = 6;

/// What a sheet shows.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SheetReport {
    /// `generated` (index.json) or `garg-nayar`.
    pub source: String,
    /// Row labels, top to bottom.
    pub rows: Vec<String>,
    /// Column labels, left to right.
    pub columns: Vec<String>,
}

/// One tile: a matte of `width` columns.
struct Tile {
    width: usize,
    values: Vec<f64>,
}

fn draw(rows: &[(String, Vec<Tile>)], columns: &[String], path: &Path) -> Result<()> {
    let tile_w = rows
        .iter()
        .flat_map(|r| r.1.iter().map(|t| t.width * TILE_ZOOM))
        .max()
        .unwrap_or(1)
        + GAP;
    let w = LABEL_W + columns.len() * tile_w;
    let h = HEADER_H + rows.len() * (TILE_H + GAP);
    let mut canvas = Canvas::new(w, h, [0.0; 3]);
    let label = [1.0, 0.8, 0.3];
    // Column labels one word per line (light elevation over azimuth).
    for (c, name) in columns.iter().enumerate() {
        for (i, word) in name.split(' ').enumerate() {
            canvas.text(
                (LABEL_W + c * tile_w) as f64,
                (4 + i * 6 * FONT) as f64,
                word,
                label,
                FONT,
            );
        }
    }
    for (r, (name, tiles)) in rows.iter().enumerate() {
        let y0 = HEADER_H + r * (TILE_H + GAP);
        canvas.text(4.0, (y0 + TILE_H / 2) as f64, name, label, FONT);
        for (c, tile) in tiles.iter().enumerate() {
            let height = tile.values.len() / tile.width.max(1);
            let max = tile.values.iter().copied().fold(0.0, f64::max);
            if max <= 0.0 || height == 0 {
                continue;
            }
            let x0 = LABEL_W + c * tile_w;
            for y in 0..TILE_H {
                // Box-average the streak rows that fall in this tile row.
                let (a, b) = (
                    y * height / TILE_H,
                    ((y + 1) * height / TILE_H).max(y * height / TILE_H + 1),
                );
                for x in 0..tile.width {
                    let v = (a..b).map(|r| tile.values[r * tile.width + x]).sum::<f64>()
                        / (b - a) as f64;
                    let g = (v / max).sqrt() as f32;
                    for dx in 0..TILE_ZOOM {
                        canvas.add((x0 + x * TILE_ZOOM + dx) as f64, (y0 + y) as f64, [g; 3]);
                    }
                }
            }
        }
    }
    canvas.save(path, false)
}

/// Draws the contact sheet of the database at `db` (ours, with `index.json`, or a copy of
/// Garg & Nayar's at 16 px width) to the PNG `path`.
pub fn contact_sheet(db: &Path, path: &Path) -> Result<SheetReport> {
    crate::files::check_png_output(path)?;
    if !db.join("index.json").is_file() {
        let gn = GargNayarDb::open(db, 16)?;
        let columns: Vec<String> = (0..OSCILLATIONS).map(|k| k.to_string()).collect();
        let mut rows = Vec::new();
        for e in VIEW_ELEVATIONS_DEG {
            let tiles = (0..OSCILLATIONS)
                .map(|k| {
                    let (width, _, values) = GargNayarDb::read(&gn.env(e as f64, k)?)?;
                    Ok(Tile { width, values })
                })
                .collect::<Result<Vec<_>>>()?;
            rows.push((e.to_string(), tiles));
        }
        draw(&rows, &columns, path)?;
        return Ok(SheetReport {
            source: "garg-nayar".into(),
            rows: rows.into_iter().map(|r| r.0).collect(),
            columns,
        });
    }
    let index = load_index(db)?;
    let spec = &index.spec;
    let exposure = spec.exposures_s.first().copied().unwrap_or_default();
    let mut columns = vec!["e".to_string()];
    columns.extend(
        spec.lights
            .iter()
            .map(|l| format!("{} {}", l.elevation_deg, l.azimuth_deg)),
    );
    let mut rows = Vec::new();
    for &d in &spec.sizes_mm {
        for &v in &spec.view_elevations_deg {
            let tiles = index
                .mattes
                .iter()
                .filter(|m| {
                    m.diameter_mm == d
                        && m.exposure_s == exposure
                        && m.view_elevation_deg == v
                        && m.phase == 0.0
                })
                .map(|m| {
                    Ok(Tile {
                        width: m.width,
                        values: read_matte(db, m)?,
                    })
                })
                .collect::<Result<Vec<_>>>()?;
            rows.push((format!("{d:.1} {v}"), tiles));
        }
    }
    draw(&rows, &columns, path)?;
    Ok(SheetReport {
        source: "generated".into(),
        rows: rows.into_iter().map(|r| r.0).collect(),
        columns,
    })
}
