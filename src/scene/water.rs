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
//! A sky without features across azimuth (an overcast) leaves nothing to correlate, but water
//! still shows it with the brightness its reflectance lends: near the horizon nearly all of the
//! sky's, looking down 20° a tenth, straight down 2 % ([`fresnel`]), over the light from the
//! water's body, while a dry ground's brightness keeps to its own albedo. So, in linear light:
//!
//! - each row's ground points give the mean of their luma and of their mirror's luma times the
//!   reflectance at their ray's depression; a line is fitted through the rows' means
//!   ([`MirrorFit`]). Water lies on a line of gain near 1 (the camera's tone curve moves it;
//!   [`GAIN_RANGE`]) that explains the rows ([`FIT_R2_LO`] → [`FIT_R2_HI`] of their variance),
//!   over rows whose mirrored light differs by [`MIN_FIT_SPREAD`] or more; a dry road lies on a
//!   flat line (gain near 0), a street darkening toward the horizon on a falling one;
//! - the line must hold over the whole range: fitted apart, the rows of less and of more
//!   mirrored light (split at their median) each rise with a gain of at least [`BEND_LO`] →
//!   [`BEND_HI`] of the line's. A dry road in a building's shadow nearer the camera and in the
//!   sun beyond brightens toward the horizon as a mirror does (a line through its rows gains
//!   0.6–0.75 and explains 85–90 % of them), but in two flat levels, each half of which is
//!   flat (0–0.29 of the line's gain); a sea's halves rise as the whole (0.85–0.97). A point
//!   past the picture's edge, whose block copies its neighbour's, counts in no row;
//! - by that evidence a point is water where it is smooth, or where its neighbourhood along its
//!   row is as bright as the line says (within [`FIT_OFF_LO`] → [`FIT_OFF_HI`]), as a choppy
//!   sea's is on average though its swells break the reflection into texture.
//!
//! Not explained: smooth dry ground beside water (the evidence is the frame's, so it dries with
//! the water); a street whose two sides mirror each other across the horizon, if its ground is
//! also smooth (measured on the samples' streets: row medians 0.2–0.47, texture ≥ 6); a dry
//! ground whose brightness happens to rise steadily toward the horizon as a mirror's would (a
//! glossy floor, a low sun's sheen; a shadow's edge blurred over most of the rows would look
//! the same); water seen where its mirror's sky lies outside the picture.

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

/// The refractive index of water.
pub const WATER_INDEX: f32 = 1.333;

/// Fewest rows for the fit of the ground's brightness to a mirror's to count.
pub const MIN_FIT_ROWS: usize = 4;

/// Least ratio of the rows' most to least mirrored light for a fit: the reflectance must
/// change over the rows, or a mirror is no different from a uniform ground.
pub const MIN_FIT_SPREAD: f32 = 1.5;

/// Share of the rows' variance the mirror's line explains at which the evidence starts.
pub const FIT_R2_LO: f32 = 0.8;

/// … and from which the ground is taken for water.
pub const FIT_R2_HI: f32 = 0.9;

/// The gains of the mirror's line that count (water under the camera's own tone curve).
pub const GAIN_RANGE: (f32, f32) = (0.5, 2.0);

/// Least intercept of the mirror's line that counts (linear, white 1): the water's body adds
/// light to what it reflects, it takes none away.
pub const MIN_BODY: f32 = -0.05;

/// Share of the line's gain that the flatter half of the rows (of less or of more mirrored
/// light, fitted apart) must show for the evidence to start: a shadow's edge or a change of
/// surface between the rows gives two flat levels, whose halves measure 0–0.29 of the line
/// through both (the test streets' shadows) …
pub const BEND_LO: f32 = 0.45;

/// … and from which the line holds: a sea's halves measure 0.85–0.97 of it (a camera's tone
/// curve, which [`GAIN_RANGE`] allows for, bends it a little).
pub const BEND_HI: f32 = 0.7;

/// Relative difference of a neighbourhood's linear luma from the mirror's line up to which it
/// is water …
pub const FIT_OFF_LO: f32 = 0.2;

/// … and from which it is not.
pub const FIT_OFF_HI: f32 = 0.4;

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

/// What the water rule reads of each grid point (one entry per point, row-major over the grid).
#[derive(Debug, Clone, Copy)]
pub struct Points<'a> {
    /// Mean luma, 8-bit codes.
    pub luma: &'a [f32],
    /// The same as linear light (through the frame's transfer, white 1).
    pub linear: &'a [f32],
    /// Texture, 8-bit codes (twice the RMS gradient along the weaker direction).
    pub texture: &'a [f32],
    /// Whether the point is ground.
    pub ground: &'a [bool],
    /// Whether its block holds pixels of its own: a point past the picture's edge copies its
    /// neighbour's luma, and counts in its row's water weight but not in the frame's
    /// evidence (there it would count the same row twice, at another depression).
    pub measured: &'a [bool],
    /// The coded pixel of its ray reflected in the ground plane.
    pub mirror: &'a [Option<[f32; 2]>],
    /// The sine of the angle its ray dips below the horizon (0 at or above it).
    pub sin_depression: &'a [f32],
}

/// The reflectance of still water (n = [`WATER_INDEX`]) to unpolarised light arriving at the
/// cosine `cos_i` of its incidence (Fresnel's equations): 0.020 straight down, 1 at grazing.
pub fn fresnel(cos_i: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin_t = (1.0 - cos_i * cos_i).sqrt() / WATER_INDEX;
    let cos_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
    let rs = (cos_i - WATER_INDEX * cos_t) / (cos_i + WATER_INDEX * cos_t);
    let rp = (cos_t - WATER_INDEX * cos_i) / (cos_t + WATER_INDEX * cos_i);
    0.5 * (rs * rs + rp * rp)
}

/// How a frame's ground follows a mirror's brightness: the ground's linear luma against the
/// sky its mirrors show times the water's reflectance there, row means fitted by a line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MirrorFit {
    /// The line's slope: 1 where the ground reflects the sky as water does.
    pub gain: f32,
    /// Its intercept: the light from the water's body.
    pub body: f32,
    /// The share of the rows' variance it explains.
    pub r2: f32,
    /// Rows fitted.
    pub rows: usize,
    /// The smaller of the gains of the rows of less and of more mirrored light, fitted apart,
    /// as a share of `gain`: near 1 where one line holds over the whole range (see [`bend`]).
    pub bend: f32,
}

impl MirrorFit {
    /// The evidence for water, 0–1: a line through [`MIN_FIT_ROWS`] rows or more that explains
    /// them ([`FIT_R2_LO`] → [`FIT_R2_HI`]) with a gain a camera's tone curve leaves near 1
    /// ([`GAIN_RANGE`]), an intercept not below [`MIN_BODY`], and that holds over the whole
    /// range of mirrored light ([`BEND_LO`] → [`BEND_HI`]), not two flat levels.
    pub fn evidence(&self) -> f32 {
        let gain = (GAIN_RANGE.0..=GAIN_RANGE.1).contains(&self.gain);
        if self.rows < MIN_FIT_ROWS || !gain || self.body < MIN_BODY {
            return 0.0;
        }
        ramp(FIT_R2_LO, FIT_R2_HI, self.r2) * ramp(BEND_LO, BEND_HI, self.bend)
    }

    /// The linear luma water shows where its mirror's sky times its reflectance is `x`.
    fn predict(&self, x: f32) -> f32 {
        self.gain * x + self.body
    }
}

/// Each point's weight as water, 0–1 (row-major over `grid`), the rows' median correlation
/// the frame's evidence came from (`None` with too few rows), and the fit of the ground's
/// brightness to a mirror's (`None` with too few rows): see the module's method. `top` is the
/// coded edge shown at the top.
pub fn weights(
    grid: SkyGrid,
    top: TopEdge,
    points: Points,
) -> (Vec<f32>, Option<f32>, Option<MirrorFit>) {
    let Points {
        luma,
        linear,
        texture,
        ground,
        measured,
        mirror,
        sin_depression,
    } = points;
    let n = grid.len();
    let (w, h) = (grid.width, grid.height);
    let c = grid.cell_px as f32;
    let mirror_at = |k: usize| {
        let [x, y] = mirror[k]?;
        let (i, j) = ((x / c).round(), (y / c).round());
        (i >= 0.0 && j >= 0.0 && (i as usize) < w && (j as usize) < h)
            .then(|| j as usize * w + i as usize)
    };
    let rows = rows(grid, top);
    // Each row's ground points with a mirror in the picture: (point, its luma, its mirror's).
    let paired: Vec<Vec<(usize, f32, f32)>> = rows
        .iter()
        .map(|row| {
            row.iter()
                .filter(|&&k| ground[k])
                .filter_map(|&k| Some((k, luma[k], luma[mirror_at(k)?])))
                .collect()
        })
        .collect();
    let pairs = |v: &[(usize, f32, f32)]| v.iter().map(|&(_, a, b)| (a, b)).collect::<Vec<_>>();
    // The frame's evidence counts each measured point once.
    let own_rows: Vec<Vec<(usize, f32, f32)>> = paired
        .iter()
        .map(|row| {
            row.iter()
                .copied()
                .filter(|&(k, _, _)| measured[k])
                .collect()
        })
        .collect();
    let correlations: Vec<f32> = own_rows
        .iter()
        .filter_map(|row| counted(&pairs(row), MIN_ROW_POINTS))
        .collect();
    let found = if correlations.len() < MIN_ROWS {
        None
    } else {
        median(correlations)
    };
    let evidence = found.map_or(0.0, |r| ramp(CORRELATION_LO, CORRELATION_HI, r));
    // Each ground point's mirrored sky times the water's reflectance there (linear light).
    let lent = |k: usize| {
        let m = mirror_at(k)?;
        (sin_depression[k] > 0.0).then(|| fresnel(sin_depression[k]) * linear[m])
    };
    let fit = mirror_fit(&own_rows, linear, &lent);
    let mirrored = fit.map_or(0.0, |f| f.evidence());
    if evidence <= 0.0 && mirrored <= 0.0 {
        return (vec![0.0; n], found, fit);
    }
    let smooth: Vec<f32> = (0..n)
        .map(|k| {
            if ground[k] {
                1.0 - ramp(SMOOTH_CODES, ROUGH_CODES, texture[k])
            } else {
                0.0
            }
        })
        .collect();
    // A point is water by its neighbourhood's mirroring (along its row, where the mirrors
    // vary), or by its neighbourhood's brightness where a mirror's would be, or else by its
    // smoothness.
    let mut own: Vec<f32> = smooth.iter().map(|&s| s * evidence.max(mirrored)).collect();
    for row in &paired {
        for (m, &(k, _, _)) in row.iter().enumerate() {
            let window =
                &row[m.saturating_sub(LOCAL_POINTS)..(m + LOCAL_POINTS + 1).min(row.len())];
            if evidence > 0.0
                && let Some(r) = counted(&pairs(window), LOCAL_POINTS + 1)
            {
                own[k] = own[k].max(evidence * ramp(CORRELATION_LO, CORRELATION_HI, r));
            }
            if let Some(f) = fit.filter(|_| mirrored > 0.0) {
                let (mut x, mut y, mut count) = (0.0, 0.0, 0.0);
                for &(j, _, _) in window {
                    if let Some(l) = lent(j) {
                        x += l;
                        y += linear[j];
                        count += 1.0;
                    }
                }
                if count > LOCAL_POINTS as f32 {
                    let expected = f.predict(x / count);
                    let off = (y / count - expected).abs() / expected.max(1e-4);
                    own[k] = own[k].max(mirrored * (1.0 - ramp(FIT_OFF_LO, FIT_OFF_HI, off)));
                }
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
            sum / 9.0
        })
        .collect();
    (spread, found, fit)
}

/// The line through the rows' mean (mirrored sky × reflectance, linear luma) of the ground
/// points `paired` with a mirror ([`MIN_ROW_POINTS`] or more a row), weighted by their points;
/// `None` with fewer than two rows or rows whose mirrored light hardly differs (under
/// [`MIN_FIT_SPREAD`] from the least to the most).
fn mirror_fit(
    paired: &[Vec<(usize, f32, f32)>],
    linear: &[f32],
    lent: &dyn Fn(usize) -> Option<f32>,
) -> Option<MirrorFit> {
    let means: Vec<(f64, f64, f64)> = paired
        .iter()
        .filter_map(|row| {
            let (mut x, mut y, mut count) = (0.0f64, 0.0f64, 0.0f64);
            for &(k, _, _) in row {
                if let Some(l) = lent(k) {
                    x += f64::from(l);
                    y += f64::from(linear[k]);
                    count += 1.0;
                }
            }
            (count >= MIN_ROW_POINTS as f64).then(|| (x / count, y / count, count))
        })
        .collect();
    fit_means(&means)
}

/// The line through the rows' `means` (mirrored light, linear luma, points), as
/// [`mirror_fit`].
fn fit_means(means: &[(f64, f64, f64)]) -> Option<MirrorFit> {
    if means.len() < 2 {
        return None;
    }
    let (lo, hi) = means.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), m| {
        (lo.min(m.0), hi.max(m.0))
    });
    if hi < f64::from(MIN_FIT_SPREAD) * lo.max(1e-6) {
        return None;
    }
    let (gain, body, r2) = line(means)?;
    let bend = bend(means, gain);
    Some(MirrorFit {
        gain: gain as f32,
        body: body as f32,
        r2: r2 as f32,
        rows: means.len(),
        bend: bend as f32,
    })
}

/// The smaller of the gains of the lines through the rows of less and of more mirrored light
/// (`means` split at their weighted median, two rows or more each side) as a share of the
/// whole line's `gain`; 0 where a half has no spread or the gain is not positive.
///
/// Water's brightness follows its mirrors' light along one line over the whole range; a dry
/// ground in a shadow and then in the sun (or any two surfaces, one beyond the other) lies on
/// two flat levels, which a line through both explains with a gain of a mirror's but which each
/// half by itself shows flat.
fn bend(means: &[(f64, f64, f64)], gain: f64) -> f64 {
    if means.len() < 4 || gain <= 0.0 {
        return 0.0;
    }
    let mut sorted = means.to_vec();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = sorted.iter().map(|m| m.2).sum();
    let mut below = 0.0;
    let median = sorted
        .iter()
        .position(|m| {
            below += m.2;
            below >= 0.5 * total
        })
        .map_or(sorted.len() / 2, |i| i + 1);
    let split = median.clamp(2, sorted.len() - 2);
    let (lo, hi) = sorted.split_at(split);
    match (line(lo), line(hi)) {
        (Some(lo), Some(hi)) => (lo.0.min(hi.0) / gain).max(0.0),
        _ => 0.0,
    }
}

/// The weighted least-squares line through `(x, y, weight)`: its gain, intercept and R².
fn line(means: &[(f64, f64, f64)]) -> Option<(f64, f64, f64)> {
    let total: f64 = means.iter().map(|m| m.2).sum();
    let (mx, my) = means.iter().fold((0.0, 0.0), |(x, y), m| {
        (x + m.0 * m.2 / total, y + m.1 * m.2 / total)
    });
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for &(x, y, count) in means {
        sxy += count * (x - mx) * (y - my);
        sxx += count * (x - mx) * (x - mx);
        syy += count * (y - my) * (y - my);
    }
    if sxx <= 0.0 || syy <= 0.0 {
        return None;
    }
    let gain = sxy / sxx;
    Some((gain, my - gain * mx, sxy * sxy / (sxx * syy)))
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

    /// Against Fresnel's equations in their angle form (rs = −sin(i − t)/sin(i + t), rp =
    /// tan(i − t)/tan(i + t), f64): ((n − 1)/(n + 1))² straight down, rp's zero at Brewster's
    /// angle (tan i = n), 1 at grazing, and the form at every degree between.
    #[test]
    fn the_reflectance_is_fresnels() {
        let n = f64::from(WATER_INDEX);
        let straight = ((n - 1.0) / (n + 1.0)).powi(2);
        assert!((f64::from(fresnel(1.0)) - straight).abs() < 1e-6);
        assert!(fresnel(0.0) > 0.999_99);
        for degrees in 1..90 {
            let i = f64::from(degrees).to_radians();
            let t = (i.sin() / n).asin();
            let rs = -(i - t).sin() / (i + t).sin();
            let rp = (i - t).tan() / (i + t).tan();
            let reference = 0.5 * (rs * rs + rp * rp);
            let got = f64::from(fresnel(i.cos() as f32));
            assert!(
                (got - reference).abs() < 2e-5,
                "{degrees}°: {got} vs {reference}"
            );
        }
        let brewster = n.atan();
        let t = (brewster.sin() / n).asin();
        let rs = (brewster - t).sin() / (brewster + t).sin();
        let at = f64::from(fresnel(brewster.cos() as f32));
        assert!((at - 0.5 * rs * rs).abs() < 1e-5, "{at}");
    }

    /// A sea's rows (the overcast calm sea of `tests/ground_mask.rs`, measured: mirrored light
    /// times reflectance, linear luma, points) lie on one line: full evidence, both halves
    /// rising as the whole. A dry road in a shadow nearer the camera and in the sun beyond
    /// (the test street with a shadow 5–10 m ahead, measured) is two flat levels: a line
    /// through them gains 0.75 and explains 85 % (evidence 0.48 by the line alone), but its
    /// upper half is nearly flat, and the evidence is none. The halves' gains against a
    /// hand-worked split.
    #[test]
    fn two_flat_levels_are_no_mirror() {
        let sea = [
            (0.2382, 0.2739, 41.0),
            (0.2003, 0.2371, 41.0),
            (0.1693, 0.1962, 41.0),
            (0.1438, 0.1680, 41.0),
        ];
        let fit = fit_means(&sea).expect("a fit");
        assert!((0.9..1.2).contains(&fit.gain) && fit.r2 > 0.99, "{fit:?}");
        assert!(fit.bend > 0.8, "{fit:?}");
        assert_eq!(fit.evidence(), 1.0);
        let shadowed = [
            (0.1982, 0.0972, 12.0),
            (0.1586, 0.0954, 19.0),
            (0.1277, 0.0833, 22.0),
            (0.1069, 0.0476, 24.0),
            (0.0919, 0.0223, 16.0),
            (0.0824, 0.0222, 16.0),
            (0.0752, 0.0248, 16.0),
            (0.0725, 0.0301, 8.0),
        ];
        let fit = fit_means(&shadowed).expect("a fit");
        assert!(
            (0.7..0.8).contains(&fit.gain) && (0.84..0.86).contains(&fit.r2),
            "{fit:?}"
        );
        let by_line = ramp(FIT_R2_LO, FIT_R2_HI, fit.r2);
        assert!(by_line > 0.4, "{by_line}");
        assert!(fit.bend < 0.3, "{fit:?}");
        assert_eq!(fit.evidence(), 0.0);
        // Rows of equal weight split two and two: below, gain 1; above, gain 0.5; the whole
        // line's gain worked from its sums.
        let rows = [
            (1.0, 1.0, 1.0),
            (2.0, 2.0, 1.0),
            (3.0, 2.5, 1.0),
            (4.0, 3.0, 1.0),
        ];
        // Means 2.5, 2.125; Σdx·dy = 1.5·1.125 + 0.5·0.125 + 0.5·0.375 + 1.5·0.875 = 3.25,
        // Σdx² = 5: gain 0.65.
        let (gain, _, _) = line(&rows).expect("a line");
        assert!((gain - 0.65).abs() < 1e-12, "{gain}");
        assert!((bend(&rows, gain) - 0.5 / 0.65).abs() < 1e-12);
        // Flat above: no bend left; a falling line: none.
        let flat = [
            (1.0, 1.0, 1.0),
            (2.0, 2.0, 1.0),
            (3.0, 2.0, 1.0),
            (4.0, 2.0, 1.0),
        ];
        let (gain, _, _) = line(&flat).expect("a line");
        assert_eq!(bend(&flat, gain), 0.0);
        assert_eq!(bend(&flat, -1.0), 0.0);
    }
}
