//! The water map the picture is shaded from: the carpet's water as a signed depth on its grid,
//! whose zero is the puddle's rim to a fraction of a cell (docs/method.md, "Puddles: shading").
//!
//! How it works: a puddle's rim is where its level meets the ground. The carpet knows the
//! level only on wet leaves, and a depth that drops to 0 on the first dry leaf puts the rim on
//! the leaves' grid, a staircase however it is interpolated. So on every leaf near water the
//! map carries the level of the water around it minus the leaf's own ground: positive under
//! water, negative on ground that rises above it, and the shader's interpolation puts the rim
//! where level and ground cross, between the leaves. Around each leaf the binomial kernel of
//! order 8 along x and y (σ = √2 leaves) weighs the leaves within four, and of them:
//! - all wet: the level is the surface heights' mean over 1-4-6-4-1 (the carpet takes each
//!   leaf's deepest particle, which speckles the surface at the particle scale);
//! - some wet: the level is a soft minimum of the wet leaves' surface heights within two,
//!   weighted 1-4-6-4-1 (those within 3·[`EDGE_DEPTH_M`] of the lowest, tapered), since a
//!   rim's shallow water is a particle deep where a particle lies (its cap stands above the
//!   level) and dry between; and the wet share W of the order-8 weights bounds the shown depth
//!   by E·(W − [`REACH_SHARE`]) / [`RAMP_SHARE`] (E the rim depth), so where no ground bounds
//!   the water (flat ground, a film's front) the rim is the smoothed wet area's edge, soft over
//!   about half a leaf;
//! - none wet: dry.
//!
//! The cost is a few separable passes over the grid and a 5×5 neighbourhood on leaves near a
//! rim.

use rayon::prelude::*;

use crate::fluid::carpet::Field2;

/// Water covers the ground smoothly as its shown depth rises from 0 to this, m: a puddle's rim
/// is a wet film a millimetre thick, not a cut.
pub const EDGE_DEPTH_M: f32 = 1e-3;

/// Where no ground bounds the water, none is shown where less than this share of the
/// neighbourhood's weight is wet: on a straight front, about a leaf beyond the last wet leaf's
/// edge (the first dry leaf holds 93/256 of it, the second 37/256). Well below the share
/// where the ground does bound it (its true rim between the last wet and the first dry leaf),
/// so that there the level decides.
pub const REACH_SHARE: f32 = 0.15;

/// The shown depth of water no ground bounds rises by [`EDGE_DEPTH_M`] over this much more
/// share: a rim soft over about half a leaf.
pub const RAMP_SHARE: f32 = 0.1;

/// Leaves on either side of a leaf that its neighbourhood takes in.
pub(super) const REACH: usize = 4;

/// The neighbourhood's weights along x and along y: the binomial kernel of 2·[`REACH`] (σ = √2
/// leaves).
pub(super) const KERNEL: [f32; 2 * REACH + 1] = [1.0, 8.0, 28.0, 56.0, 70.0, 56.0, 28.0, 8.0, 1.0];

/// Leaves on either side whose water gives a leaf its level.
pub(super) const LEVEL_REACH: usize = 2;

/// The level's weights along x and along y: the binomial kernel 1-4-6-4-1 (σ = 1 leaf).
pub(super) const LEVEL_KERNEL: [f32; 2 * LEVEL_REACH + 1] = [1.0, 4.0, 6.0, 4.0, 1.0];

/// The water map of a carpet whose surface heights (water where wet, ground where dry) are
/// `surface_m` and whose water depths are `depth_m`, on one grid (see the module docs): a
/// signed depth, m, negative where dry.
///
/// # Panics
/// If the two fields are not on one grid (they are the same carpet's).
pub fn water_map(surface_m: &Field2, depth_m: &Field2) -> Field2 {
    assert!(
        surface_m.nx == depth_m.nx
            && surface_m.ny == depth_m.ny
            && surface_m.values.len() == depth_m.values.len()
            && depth_m.values.len() == depth_m.nx * depth_m.ny,
        "surface and depth on one grid"
    );
    water_map_and_share(surface_m, depth_m).0
}

/// [`water_map`] and the wet share of each leaf's neighbourhood it was made with (what
/// [`super::kept_map`] keeps), by whole-grid passes.
pub(super) fn water_map_and_share(surface_m: &Field2, depth_m: &Field2) -> (Field2, Vec<f32>) {
    let (nx, ny) = (depth_m.nx, depth_m.ny);
    let on_grid = |values: Vec<f32>| Field2 {
        values,
        nx,
        ny,
        origin_m: depth_m.origin_m,
        cell_m: depth_m.cell_m,
    };
    // The wet share (separable passes: exactly 0 with no wet leaf within reach, exactly 1 with
    // no dry one).
    let share = convolved(
        &on_grid(depth_m.values.iter().map(|&d| wet_share(d)).collect()),
        &KERNEL,
    );
    // Under water all around (all of the wide neighbourhood wet), the surface smoothed over
    // the level's neighbourhood.
    let level = convolved(surface_m, &LEVEL_KERNEL);
    let values = (0..nx * ny)
        .into_par_iter()
        .map(|k| {
            let around = (&surface_m.values[..], &depth_m.values[..]);
            leaf_value(k, (nx, ny), (share.values[k], level.values[k]), around)
        })
        .collect();
    (on_grid(values), share.values)
}

/// A leaf's weight in the wet share: 1 where wet, 0 where dry.
pub(super) fn wet_share(depth_m: f32) -> f32 {
    if depth_m > 0.0 { 1.0 } else { 0.0 }
}

/// The shown depth where the wet share of the neighbourhood rises past zero: 0 at
/// [`REACH_SHARE`], the rim depth [`RAMP_SHARE`] beyond it.
pub(super) fn front(share: f32) -> f32 {
    EDGE_DEPTH_M * (share - REACH_SHARE) / RAMP_SHARE
}

/// The map's value at leaf `k` of a grid of `dims` leaves (see the module docs), from its
/// wet share `share`, its smoothed surface `level` and the carpet's `surface` and `depth`: it
/// reads the leaves within [`LEVEL_REACH`] only.
#[inline]
pub(super) fn leaf_value(
    k: usize,
    (nx, ny): (usize, usize),
    (share, level): (f32, f32),
    (surface, depth): (&[f32], &[f32]),
) -> f32 {
    let ground = surface[k] - depth[k];
    if share <= 0.0 {
        return front(0.0);
    }
    if share >= 1.0 {
        return level - ground;
    }
    (soft_minimum(k, (nx, ny), (surface, depth)) - ground).min(front(share))
}

/// [`leaf_value`] (the same value to the bit) without the soft minimum's weighted sums where
/// the front bounds the leaf anyway: the soft minimum is a weighted mean of heights no lower
/// than the lowest wet one, h_min, so where the front's depth lies below h_min − ground by
/// more than the sums' rounding, the minimum is the front's depth whatever the sums give.
/// On ground around scattered drops (a small wet share, a negative front) that is most
/// leaves.
#[inline]
pub(super) fn leaf_value_bounded(
    k: usize,
    (nx, ny): (usize, usize),
    (share, level): (f32, f32),
    (surface, depth): (&[f32], &[f32]),
) -> f32 {
    if share <= 0.0 || share >= 1.0 {
        return leaf_value(k, (nx, ny), (share, level), (surface, depth));
    }
    let ground = surface[k] - depth[k];
    let low = lowest_wet(k, (nx, ny), (surface, depth));
    let edge = front(share);
    // The weighted mean of ≤ 25 terms, each within [h_min, h_min + 3 E], rounds to within
    // 32 ulp of that range (f32: 2⁻²³ each), and the difference with the ground within one
    // more: a margin of 2⁻¹⁶ of the magnitudes is more than enough.
    let margin = (low.abs() + 3.0 * EDGE_DEPTH_M + ground.abs()) * (1.0 / 65_536.0);
    if low.is_finite() && edge < (low - ground) - margin {
        return edge;
    }
    leaf_value(k, (nx, ny), (share, level), (surface, depth))
}

/// The lowest surface height of the wet leaves within [`LEVEL_REACH`] of leaf `k` (+∞: none),
/// as [`soft_minimum`] finds it.
#[inline]
fn lowest_wet(k: usize, (nx, ny): (usize, usize), (surface, depth): (&[f32], &[f32])) -> f32 {
    let r = LEVEL_REACH;
    let (i, j) = (k % nx, k / nx);
    let (i0, i1) = (i.saturating_sub(r), (i + r + 1).min(nx));
    let (j0, j1) = (j.saturating_sub(r), (j + r + 1).min(ny));
    let mut low = f32::INFINITY;
    for jj in j0..j1 {
        let span = jj * nx + i0..jj * nx + i1;
        for (&d, &h) in depth[span.clone()].iter().zip(&surface[span]) {
            if d > 0.0 {
                low = low.min(h);
            }
        }
    }
    low
}

/// A weighted soft minimum of the surface heights h of the wet leaves within
/// [`LEVEL_REACH`] of leaf `k`, weighted w by 1-4-6-4-1 along x and y: their mean weighted by
/// w·(1 − (h − h_min)/(3 E)) where positive, E = [`EDGE_DEPTH_M`]: the lowest height where
/// one stands clear below the rest, their mean where they agree to well under E. (No wet
/// leaf: +∞.) Each sum runs over the leaves row by row.
fn soft_minimum(k: usize, (nx, ny): (usize, usize), (surface, depth): (&[f32], &[f32])) -> f32 {
    let r = LEVEL_REACH;
    let (i, j) = (k % nx, k / nx);
    let (i0, i1) = (i.saturating_sub(r), (i + r + 1).min(nx));
    let (j0, j1) = (j.saturating_sub(r), (j + r + 1).min(ny));
    let row = |jj: usize| {
        let span = jj * nx + i0..jj * nx + i1;
        depth[span.clone()].iter().zip(&surface[span])
    };
    let mut low = f32::INFINITY;
    for jj in j0..j1 {
        for (&d, &h) in row(jj) {
            if d > 0.0 {
                low = low.min(h);
            }
        }
    }
    if low == f32::INFINITY {
        // No wet leaf within reach: what the sums below would return, without them.
        return low;
    }
    let taper = 3.0 * EDGE_DEPTH_M;
    let (mut sum, mut weight) = (0.0f32, 0.0f32);
    for jj in j0..j1 {
        let wy = LEVEL_KERNEL[jj + r - j];
        for ((&d, &h), wx) in row(jj).zip(&LEVEL_KERNEL[i0 + r - i..]) {
            if d > 0.0 {
                let t = wx * wy * (1.0 - (h - low) / taper).max(0.0);
                sum += t * h;
                weight += t;
            }
        }
    }
    if weight > 0.0 { sum / weight } else { low }
}

/// `field` convolved with the binomial kernel 1-4-6-4-1 along x, then along y, the weights
/// renormalised where the kernel leaves the grid: the carpet's depth smoothed over a leaf, the
/// water map drawn with rims on the leaves' grid that the rim tests measure against.
pub fn smoothed(field: &Field2) -> Field2 {
    convolved(field, &[1.0, 4.0, 6.0, 4.0, 1.0])
}

/// `field` convolved with the odd, centred `kernel` along x, then along y, the weights
/// renormalised where the kernel leaves the grid. Both passes run a row at a time (the pass
/// along y sums whole rows, so it reads memory in order) over rayon's threads; each value is
/// summed in the kernel's order, so the result does not depend on the threads.
fn convolved(field: &Field2, kernel: &[f32]) -> Field2 {
    let (nx, ny) = (field.nx, field.ny);
    let total: f32 = kernel.iter().sum();
    let taps = |i: usize, n: usize| taps(kernel, i, n);
    let mut x = vec![0.0; field.values.len()];
    x.par_chunks_mut(nx.max(1))
        .zip(field.values.par_chunks(nx.max(1)))
        .for_each(|(out, src)| {
            for (i, o) in out.iter_mut().enumerate() {
                let (lo, weights, whole) = taps(i, nx);
                let (mut sum, mut weight) = (0.0, 0.0);
                for (s, w) in src[lo..].iter().zip(weights) {
                    sum += w * s;
                    weight += w;
                }
                // Inside the grid the weights sum to the kernel's total (exactly: small
                // integers).
                *o = if whole { sum / total } else { sum / weight };
            }
        });
    let mut values = vec![0.0; field.values.len()];
    values
        .par_chunks_mut(nx.max(1))
        .enumerate()
        .for_each(|(j, out)| {
            let (lo, weights, whole) = taps(j, ny);
            let mut sum = vec![0.0f32; nx];
            for (t, w) in weights.iter().enumerate() {
                let row = &x[(lo + t) * nx..(lo + t + 1) * nx];
                for (s, r) in sum.iter_mut().zip(row) {
                    *s += w * r;
                }
            }
            let norm = if whole {
                total
            } else {
                weights.iter().sum::<f32>()
            };
            for (o, s) in out.iter_mut().zip(&sum) {
                *o = s / norm;
            }
        });
    Field2 {
        nx,
        ny,
        origin_m: field.origin_m,
        cell_m: field.cell_m,
        values,
    }
}

/// The taps of the odd, centred `kernel` at position `i` on a line of `n`: (first index, the
/// kernel's weights from there, whether the whole kernel lies on the line).
pub(super) fn taps(kernel: &[f32], i: usize, n: usize) -> (usize, &[f32], bool) {
    let half = kernel.len() / 2;
    let (lo, hi) = (i.saturating_sub(half), (i + half + 1).min(n));
    (
        lo,
        &kernel[lo + half - i..lo + half - i + (hi - lo)],
        hi - lo == kernel.len(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(nx: usize, ny: usize, values: Vec<f32>) -> Field2 {
        Field2 {
            nx,
            ny,
            origin_m: glam::Vec2::ZERO,
            cell_m: 0.02,
            values,
        }
    }

    /// Away from the edges the smoothing keeps the water's volume and its centre, and spreads a
    /// single deep cell over the kernel's 5×5 footprint with the binomial weights.
    #[test]
    fn smoothing_keeps_volume_and_spreads_a_spike() {
        let mut values = vec![0.0f32; 15 * 11];
        values[5 * 15 + 7] = 0.256;
        let s = smoothed(&grid(15, 11, values));
        let total: f32 = s.values.iter().sum();
        assert!((total - 0.256).abs() < 1e-6, "{total}");
        assert!((s.values[5 * 15 + 7] - 0.256 * 36.0 / 256.0).abs() < 1e-7);
        assert!((s.values[3 * 15 + 5] - 0.256 / 256.0).abs() < 1e-7);
        assert_eq!(s.values[2 * 15 + 7], 0.0, "nothing beyond two cells");
    }

    /// A still pool on a slope, wet exactly where its level stands above the ground: the map's
    /// zero (where the shader's interpolation puts the rim) lies where level and ground cross,
    /// between the leaves; under water all around it is the depth.
    #[test]
    fn a_level_pool_on_a_slope_has_its_rim_where_level_meets_ground() {
        let (nx, ny) = (24, 7);
        for level in [0.0131f32, 0.0137, 0.0144] {
            let ground = |i: usize| 0.001 * i as f32;
            let (mut surface, mut depth) = (Vec::new(), Vec::new());
            for _ in 0..ny {
                for i in 0..nx {
                    let d = (level - ground(i)).max(0.0);
                    surface.push(ground(i) + d);
                    depth.push(d);
                }
            }
            let map = water_map(&grid(nx, ny, surface), &grid(nx, ny, depth));
            let row = &map.values[3 * nx..4 * nx];
            let i = row.iter().position(|&s| s <= 0.0).expect("a rim");
            let rim = (i - 1) as f32 + row[i - 1] / (row[i - 1] - row[i]);
            let truth = level / 0.001;
            assert!(
                (rim - truth).abs() < 1e-3,
                "rim at {rim}, level meets ground at {truth}"
            );
            assert!((row[3] - (level - ground(3))).abs() < 1e-6, "{row:?}");
        }
    }

    /// A film on flat ground, whatever its depth: the shown water ends where the wet share of
    /// the neighbourhood falls to the reach, about a leaf beyond the last wet one.
    #[test]
    fn a_film_on_flat_ground_ends_where_the_wet_share_falls_to_the_reach() {
        let (nx, ny) = (16, 5);
        for film in [0.004f32, 0.02] {
            let depth: Vec<f32> = (0..nx * ny)
                .map(|k| if k % nx < 8 { film } else { 0.0 })
                .collect();
            let map = water_map(&grid(nx, ny, depth.clone()), &grid(nx, ny, depth));
            let row = &map.values[2 * nx..3 * nx];
            let i = row.iter().position(|&s| s <= 0.0).expect("a rim");
            let rim = (i - 1) as f32 + row[i - 1] / (row[i - 1] - row[i]);
            // Shares 93/256 and 37/256 on the first two dry leaves.
            let share = |s: f32| EDGE_DEPTH_M * (s - REACH_SHARE) / RAMP_SHARE;
            let expected = 8.0 + share(93.0 / 256.0) / (share(93.0 / 256.0) - share(37.0 / 256.0));
            assert!((rim - expected).abs() < 1e-4, "rim at {rim}: {row:?}");
            assert!(rim > 8.5 && rim < 9.0, "{rim}");
            assert!(row[..4].iter().all(|&d| (d - film).abs() < 1e-6), "{row:?}");
        }
    }
}
