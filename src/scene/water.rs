//! A ground that is already water: below the horizon a sea, a lake or a flooded square mirrors
//! the sky above it, so wetting it (or pooling puddles on it) draws a second, blocky
//! reflection over its own; the ground mask leaves it out.
//!
//! # Method
//!
//! A flat mirror shows, at each point below the horizon, what the ray reflected in the ground
//! plane meets; the caller gives that ray's coded pixel per grid point
//! ([`super::ground_mask::PointView::mirror_px`]). Ripples stretch the reflection along the
//! vertical (the sun's glitter column) and the Fresnel factor dims and pales it, but along a
//! line of constant depression the sky's variation across azimuth — the glow round the sun, an
//! island or a headland on the horizon — reappears below it. So:
//!
//! - each row of the ground's grid points (along the displayed horizontal) whose mirrors lie in
//!   the picture and vary (RMS at least [`MIN_SKY_CODES`]) gives the Pearson correlation of the
//!   points' luma with their mirrors' luma;
//! - the frame's evidence is the **median** of those rows' correlations (a row where the
//!   glitter column lies over the mirror of an island is an outlier, not the rule), ramped from
//!   [`CORRELATION_LO`] to [`CORRELATION_HI`];
//! - a ground point is water by that evidence times its smoothness: texture (twice the RMS
//!   gradient along its weaker direction) under [`SMOOTH_CODES`], none from [`ROUGH_CODES`]. A
//!   sea seen from its shore measures 1–3 codes, cobbles, asphalt in daylight and grass 6–25;
//! - the weights are spread by a 3 × 3 box, so the mask's edge at the shore is soft.
//!
//! Not explained: a sea under a featureless sky (nothing to correlate with, it wets as ground);
//! smooth dry ground beside water under a structured sky (the evidence is the frame's, so it
//! dries with the water); a street whose two sides mirror each other across the horizon, if its
//! ground is also smooth (measured on the samples' streets: row medians 0.2–0.4, texture ≥ 6).

use super::sky::{SkyGrid, TopEdge};

/// Smallest RMS luma variation (8-bit codes) of a row's mirrors for its correlation to count:
/// a sky uniform across azimuth has nothing to show in the water.
pub const MIN_SKY_CODES: f32 = 2.0;

/// Fewest ground points with a mirror in a row for its correlation to count.
pub const MIN_ROW_POINTS: usize = 8;

/// Fewest such rows for any evidence.
pub const MIN_ROWS: usize = 2;

/// Median row correlation at which the evidence for water starts (streets measure 0.2–0.4).
pub const CORRELATION_LO: f32 = 0.5;

/// Median row correlation from which the ground is taken for water (the sunset sea: 0.8–0.9).
pub const CORRELATION_HI: f32 = 0.7;

/// Points on either side of a point along its row over which its own mirroring is measured.
pub const LOCAL_POINTS: usize = 8;

/// Texture (8-bit codes) up to which a point is smooth as water.
pub const SMOOTH_CODES: f32 = 4.0;

/// Texture (8-bit codes) from which a point is too rough for water.
pub const ROUGH_CODES: f32 = 8.0;

fn ramp(lo: f32, hi: f32, x: f32) -> f32 {
    ((x - lo) / (hi - lo)).clamp(0.0, 1.0)
}

/// The Pearson correlation of pairs `(a, b)`, with the RMS deviation of `b`; `None` with fewer
/// than two pairs or no variation in `a`.
fn correlation(pairs: &[(f32, f32)]) -> Option<(f32, f32)> {
    let n = pairs.len() as f64;
    if pairs.len() < 2 {
        return None;
    }
    let (ma, mb) = pairs.iter().fold((0.0, 0.0), |(x, y), &(a, b)| {
        (x + f64::from(a) / n, y + f64::from(b) / n)
    });
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for &(a, b) in pairs {
        let (da, db) = (f64::from(a) - ma, f64::from(b) - mb);
        sab += da * db;
        saa += da * da;
        sbb += db * db;
    }
    (saa > 1e-9 && sbb > 1e-9).then(|| ((sab / (saa * sbb).sqrt()) as f32, (sbb / n).sqrt() as f32))
}

/// Rows of `grid`'s points along the displayed horizontal: coded rows, or columns in a picture
/// shown turned.
fn rows(grid: SkyGrid, top: TopEdge) -> Vec<Vec<usize>> {
    let (w, h) = (grid.width, grid.height);
    match top {
        TopEdge::Top | TopEdge::Bottom => (0..h)
            .map(|j| (0..w).map(|i| j * w + i).collect())
            .collect(),
        TopEdge::Left | TopEdge::Right => (0..w)
            .map(|i| (0..h).map(|j| j * w + i).collect())
            .collect(),
    }
}

/// The median of `v` (`None` when empty).
fn median(mut v: Vec<f32>) -> Option<f32> {
    v.sort_by(f32::total_cmp);
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => Some(0.5 * (v[n / 2 - 1] + v[n / 2])),
    }
}

/// A correlation that counts: enough pairs, and mirrors that vary.
fn counted(pairs: &[(f32, f32)], fewest: usize) -> Option<f32> {
    if pairs.len() < fewest {
        return None;
    }
    let (r, sky_rms) = correlation(pairs)?;
    (sky_rms >= MIN_SKY_CODES).then_some(r)
}

/// Each point's weight as water, 0–1 (row-major over `grid`), and the rows' median
/// correlation the frame's evidence came from (`None` with too few rows): see the module's
/// method. `luma` and `texture` (8-bit codes) and `ground` hold one entry per point, `mirror`
/// the coded pixel of each point's reflected ray; `top` is the coded edge shown at the top.
pub fn weights(
    grid: SkyGrid,
    top: TopEdge,
    luma: &[f32],
    texture: &[f32],
    ground: &[bool],
    mirror: &[Option<[f32; 2]>],
) -> (Vec<f32>, Option<f32>) {
    let n = grid.len();
    let (w, h) = (grid.width, grid.height);
    let c = grid.cell_px as f32;
    let mirror_luma = |k: usize| {
        let [x, y] = mirror[k]?;
        let (i, j) = ((x / c).round(), (y / c).round());
        (i >= 0.0 && j >= 0.0 && (i as usize) < w && (j as usize) < h)
            .then(|| luma[j as usize * w + i as usize])
    };
    let rows = rows(grid, top);
    // Each row's ground points with a mirror in the picture: (point, its luma, its mirror's).
    let paired: Vec<Vec<(usize, f32, f32)>> = rows
        .iter()
        .map(|row| {
            row.iter()
                .filter(|&&k| ground[k])
                .filter_map(|&k| Some((k, luma[k], mirror_luma(k)?)))
                .collect()
        })
        .collect();
    let pairs = |v: &[(usize, f32, f32)]| v.iter().map(|&(_, a, b)| (a, b)).collect::<Vec<_>>();
    let correlations: Vec<f32> = paired
        .iter()
        .filter_map(|row| counted(&pairs(row), MIN_ROW_POINTS))
        .collect();
    let found = if correlations.len() < MIN_ROWS {
        None
    } else {
        median(correlations)
    };
    let evidence = found.map_or(0.0, |r| ramp(CORRELATION_LO, CORRELATION_HI, r));
    if evidence <= 0.0 {
        return (vec![0.0; n], found);
    }
    // A point is water by its neighbourhood's mirroring (along its row, where the mirrors
    // vary), or else by its smoothness.
    let mut own: Vec<f32> = (0..n)
        .map(|k| {
            if ground[k] {
                1.0 - ramp(SMOOTH_CODES, ROUGH_CODES, texture[k])
            } else {
                0.0
            }
        })
        .collect();
    for row in &paired {
        for (m, &(k, _, _)) in row.iter().enumerate() {
            let window =
                &row[m.saturating_sub(LOCAL_POINTS)..(m + LOCAL_POINTS + 1).min(row.len())];
            if let Some(r) = counted(&pairs(window), LOCAL_POINTS + 1) {
                own[k] = own[k].max(ramp(CORRELATION_LO, CORRELATION_HI, r));
            }
        }
    }
    let (wi, hi) = (w as i64, h as i64);
    let spread = (0..n)
        .map(|k| {
            let (i, j) = ((k as i64) % wi, (k as i64) / wi);
            let mut sum = 0.0;
            for dj in -1..=1 {
                for di in -1..=1 {
                    // The picture's border repeats its edge points.
                    let (x, y) = ((i + di).clamp(0, wi - 1), (j + dj).clamp(0, hi - 1));
                    sum += own[(y * wi + x) as usize];
                }
            }
            evidence * sum / 9.0
        })
        .collect();
    (spread, found)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against a two-pass reference: a perfect copy correlates 1, a reversed ramp −1, a flat
    /// mirror gives nothing.
    #[test]
    fn the_correlation_matches_its_definition() {
        let a = [1.0f32, 4.0, 2.0, 8.0, 5.0];
        let b = [2.0f32, 3.0, 3.5, 9.0, 4.0];
        let mean = |v: &[f32]| v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len() as f64;
        let (ma, mb) = (mean(&a), mean(&b));
        let cov: f64 = a
            .iter()
            .zip(&b)
            .map(|(&x, &y)| (f64::from(x) - ma) * (f64::from(y) - mb))
            .sum();
        let va: f64 = a.iter().map(|&x| (f64::from(x) - ma).powi(2)).sum();
        let vb: f64 = b.iter().map(|&y| (f64::from(y) - mb).powi(2)).sum();
        let pairs: Vec<(f32, f32)> = a.iter().copied().zip(b.iter().copied()).collect();
        let (r, rms) = correlation(&pairs).expect("varies");
        assert!((f64::from(r) - cov / (va * vb).sqrt()).abs() < 1e-6);
        assert!((f64::from(rms) - (vb / 5.0).sqrt()).abs() < 1e-5);
        let same: Vec<(f32, f32)> = a.iter().map(|&x| (x, 3.0 * x + 1.0)).collect();
        assert!((correlation(&same).expect("varies").0 - 1.0).abs() < 1e-6);
        let reversed: Vec<(f32, f32)> = a.iter().map(|&x| (x, -x)).collect();
        assert!((correlation(&reversed).expect("varies").0 + 1.0).abs() < 1e-6);
        let flat: Vec<(f32, f32)> = a.iter().map(|&x| (x, 7.0)).collect();
        assert!(correlation(&flat).is_none());
    }
}
