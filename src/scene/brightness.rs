//! The picture's brightness in blocks, for the pose search: how it correlates with elevation
//! above a candidate horizon, and where the sky — smooth, bright blocks — lies.
//!
//! The picture is cut into 32 columns of square-ish blocks; each keeps its ray, its mean luma
//! and its mean gradient. Two measures follow for any direction:
//!
//! - [`Brightness::correlation`]: the correlation of the blocks' means with their elevation
//!   `r · n` above the horizon of `n` (daylight skies are brighter than what stands under
//!   them). Elevation is linear in `n`, so moments kept once give it for any `n`.
//! - [`Brightness::sky_share`]: the share of *sky blocks* — smooth (mean absolute step between
//!   neighbouring samples under [`SKY_GRADIENT_MAX`]) and among the picture's brightest
//!   ([`SKY_BRIGHT_QUANTILE`]) — among the quarter of the blocks nearest a direction. It tells
//!   a view up between facades (the sky all around the point where the verticals meet) and a
//!   level view looking up (the sky across the top of the picture) from the Manhattan
//!   alternatives that read the same lines (see [`crate::scene::horizon`]).
//! - [`Brightness::sky_above`]: the same share in the quarter highest above the horizon of an
//!   up direction, where a smooth block is bright also when it is brighter than
//!   [`SKY_BELOW_QUANTILE`] of the blocks below that horizon. A dusk sky is darker at the top
//!   than its glow at the horizon, so the picture's brightest blocks are the glow alone; its
//!   top is still brighter than the sea or land under it. [`Brightness::sky_over_ground`]
//!   counts only the latter.

use glam::{DMat3, DVec3};

use crate::scene::Camera;
use crate::scene::horizon::Luma;

/// A block is smooth, for the sky, where the mean absolute difference between neighbouring
/// samples (horizontal plus vertical, luma in [0, 1]) is under this: about two 8-bit codes.
pub const SKY_GRADIENT_MAX: f64 = 0.008;

/// A block is bright, for the sky, where its mean is at least this quantile of the blocks'.
pub const SKY_BRIGHT_QUANTILE: f64 = 0.7;

/// A smooth block above the horizon is bright, for [`Brightness::sky_above`], where its mean
/// is at least this quantile of the means of the blocks below that horizon (not their
/// maximum: a sun's glitter on water or a street light is brighter than the sky's top).
pub const SKY_BELOW_QUANTILE: f64 = 0.9;

/// Fewest blocks below the horizon with which [`SKY_BELOW_QUANTILE`] is judged (one row of
/// blocks); with fewer, only the picture's brightest blocks are sky.
const SKY_BELOW_MIN_BLOCKS: usize = 32;

/// Moments of the luma's block means and their rays, and each block's smoothness.
#[derive(Debug, Clone)]
pub struct Brightness {
    /// Number of blocks.
    count: f64,
    /// Σ r over the blocks' unit rays.
    sum_r: DVec3,
    /// Σ r rᵀ.
    sum_rr: DMat3,
    /// Σ (v − v̄) r, `v` the block means.
    sum_dr: DVec3,
    /// √Σ (v − v̄)².
    norm: f64,
    /// Each block's unit ray and whether it is a sky block (smooth and bright).
    blocks: Vec<(DVec3, bool)>,
    /// Each block's mean and whether it is smooth.
    means: Vec<(f64, bool)>,
}

impl Brightness {
    /// The blocks of `luma` seen through `camera`'s intrinsics; `None` for a flat picture.
    pub fn new(luma: &Luma, camera: &Camera) -> Option<Brightness> {
        const COLS: usize = 32;
        let rows = (COLS * luma.height / luma.width.max(1)).max(2);
        let (f, c) = (camera.focal_px(), camera.principal_px());
        let sx = camera.width_px as f64 / luma.width as f64;
        let sy = camera.height_px as f64 / luma.height as f64;
        let w = luma.width;
        // (ray, mean, mean gradient)
        let mut blocks: Vec<(DVec3, f64, f64)> = Vec::with_capacity(COLS * rows);
        for by in 0..rows {
            let (y0, y1) = (by * luma.height / rows, (by + 1) * luma.height / rows);
            for bx in 0..COLS {
                let (x0, x1) = (bx * w / COLS, (bx + 1) * w / COLS);
                if x1 <= x0 || y1 <= y0 {
                    continue;
                }
                let (mut sum, mut grad) = (0.0f64, 0.0f64);
                for y in y0..y1 {
                    for x in x0..x1 {
                        let v = luma.data[y * w + x];
                        sum += v as f64;
                        if x + 1 < w && y + 1 < luma.height {
                            grad += ((luma.data[y * w + x + 1] - v).abs()
                                + (luma.data[(y + 1) * w + x] - v).abs())
                                as f64;
                        }
                    }
                }
                let (px, py) = (0.5 * (x0 + x1) as f64 * sx, 0.5 * (y0 + y1) as f64 * sy);
                let r = DVec3::new((px - c.x) / f, (py - c.y) / f, 1.0).normalize();
                let k = ((x1 - x0) * (y1 - y0)) as f64;
                blocks.push((r, sum / k, grad / k));
            }
        }
        let count = blocks.len() as f64;
        let mean = blocks.iter().map(|b| b.1).sum::<f64>() / count.max(1.0);
        let mut means: Vec<f64> = blocks.iter().map(|b| b.1).collect();
        means.sort_by(f64::total_cmp);
        let bright = means
            .get((SKY_BRIGHT_QUANTILE * means.len() as f64) as usize)
            .copied()
            .unwrap_or(f64::MAX);
        let mut b = Brightness {
            count,
            sum_r: DVec3::ZERO,
            sum_rr: DMat3::ZERO,
            sum_dr: DVec3::ZERO,
            norm: 0.0,
            blocks: blocks
                .iter()
                .map(|&(r, v, g)| (r, g < SKY_GRADIENT_MAX && v >= bright))
                .collect(),
            means: blocks
                .iter()
                .map(|&(_, v, g)| (v, g < SKY_GRADIENT_MAX))
                .collect(),
        };
        for &(r, v, _) in &blocks {
            b.sum_r += r;
            b.sum_rr += DMat3::from_cols(r * r.x, r * r.y, r * r.z);
            b.sum_dr += r * (v - mean);
            b.norm += (v - mean) * (v - mean);
        }
        b.norm = b.norm.sqrt();
        (b.norm > 1e-6).then_some(b)
    }

    /// Correlation of brightness with elevation above the horizon of `n`, in [−1, 1].
    pub fn correlation(&self, n: DVec3) -> f64 {
        let se = self.sum_r.dot(n);
        let var = (n.dot(self.sum_rr * n) - se * se / self.count).max(0.0);
        if var < 1e-12 {
            return 0.0;
        }
        self.sum_dr.dot(n) / (self.norm * var.sqrt())
    }

    /// The share of sky blocks among the quarter of the blocks whose rays lie nearest the
    /// direction `d` (the largest `r · d`): with `d` the up direction, the quarter highest above
    /// the horizon; with `d` a point in the picture, the quarter around it.
    pub fn sky_share(&self, d: DVec3) -> f64 {
        let mut near: Vec<(f64, bool)> = self.blocks.iter().map(|b| (b.0.dot(d), b.1)).collect();
        near.sort_by(|a, b| b.0.total_cmp(&a.0));
        near.truncate(near.len().div_ceil(4));
        near.iter().filter(|b| b.1).count() as f64 / near.len().max(1) as f64
    }

    /// The share of sky blocks among the quarter of the blocks highest above the horizon of
    /// the up direction `up`, a smooth block counting as sky where it is among the picture's
    /// brightest or brighter than [`SKY_BELOW_QUANTILE`] of the blocks below that horizon: the
    /// sky is judged against what stands under it, not against its own glow.
    pub fn sky_above(&self, up: DVec3) -> f64 {
        self.sky_above_by(up, true)
    }

    /// [`Brightness::sky_above`] with only the smooth blocks brighter than
    /// [`SKY_BELOW_QUANTILE`] of the blocks below the horizon counting as sky (the picture's
    /// brightest where fewer than a row of blocks lie below it): the sky over what stands
    /// under it. Bright smooth surfaces on both sides of a horizon (flat roofs seen from above,
    /// read as a level view) count in [`Brightness::sky_above`] but mostly not here; see
    /// [`crate::scene::steep::SKY_OVER_GROUND`].
    pub fn sky_over_ground(&self, up: DVec3) -> f64 {
        self.sky_above_by(up, false)
    }

    fn sky_above_by(&self, up: DVec3, brightest: bool) -> f64 {
        let mut below: Vec<f64> = (self.blocks.iter().zip(&self.means))
            .filter(|(b, _)| b.0.dot(up) < 0.0)
            .map(|(_, m)| m.0)
            .collect();
        below.sort_by(f64::total_cmp);
        let brightest = brightest || below.len() < SKY_BELOW_MIN_BLOCKS;
        let under = if below.len() >= SKY_BELOW_MIN_BLOCKS {
            below[((SKY_BELOW_QUANTILE * below.len() as f64) as usize).min(below.len() - 1)]
        } else {
            f64::MAX
        };
        let mut near: Vec<(f64, bool)> = (self.blocks.iter().zip(&self.means))
            .map(|(b, m)| (b.0.dot(up), (brightest && b.1) || (m.1 && m.0 >= under)))
            .collect();
        near.sort_by(|a, b| b.0.total_cmp(&a.0));
        near.truncate(near.len().div_ceil(4));
        near.iter().filter(|b| b.1).count() as f64 / near.len().max(1) as f64
    }
}
