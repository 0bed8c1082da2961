//! The fill's water laid into the particle columns: each column's binned water replaced by
//! the fill's depth at its centre, the total kept.
//!
//! Binning vertices into columns of another spacing aliases (columns of one, two or no
//! vertices), a pattern of spikes and holes the stepped water smooths out but water at rest
//! would keep; so each column takes the depth read bilinearly at its centre instead, scaled
//! so the total stays the binned total.

use glam::Vec2;

/// The fill's depth grid and the columns' grid: `(nx, cell, origin)` of the fill's
/// vertices, `(cx, lo, spacing)` of the columns (`cx` per row, the first's corner at `lo`).
pub(super) type Grids = ((usize, f32, Vec2), (usize, Vec2, f32));

/// Replaces each column's binned water in `water` by the fill's depth `depth_m` at its centre
/// (bilinear between the fill's vertices) times its area, scaled so the total stays the
/// binned total. The columns of a row share their place between two rows of vertices: where
/// both rows are dry, the depth is 0 without reading it and the sum skips it (adding +0
/// changes no sum that is not ±0, and one that is stays ≤ 0, so the total's test is the
/// same).
pub(super) fn resample(water: &mut [f64], depth_m: &[f32], grids: Grids) {
    let ((nx, cell, origin), (cx, lo, spacing)) = grids;
    let d = depth_m;
    let ny = d.len() / nx.max(1);
    if nx < 2 || ny < 2 || cx == 0 {
        return;
    }
    let most = Vec2::new((nx - 1) as f32, (ny - 1) as f32);
    // Whether each vertex row holds water.
    let wet: Vec<bool> = d
        .chunks_exact(nx)
        .map(|row| row.iter().any(|&z| z != 0.0))
        .collect();
    let area = (spacing as f64).powi(2);
    // Zeroed pages: the dry rows' are never touched.
    let mut sampled = vec![0.0f64; water.len()];
    let mut total_sampled = 0.0f64;
    for (r, row) in sampled.chunks_mut(cx).enumerate() {
        // A column's centre, its place on the vertices' grid, clamped: the row's (x and y
        // apart, as the plain form's vectors compute them), without a division per column.
        let at = |c: usize| {
            let xy = lo + (Vec2::new(c as f32, r as f32) + 0.5) * spacing;
            ((xy - origin) / cell).clamp(Vec2::ZERO, most)
        };
        let gy = at(0).y;
        let j = (gy as usize).min(ny - 2);
        // The row's columns read vertex rows j and j + 1 only.
        if !wet[j] && !wet[j + 1] {
            continue;
        }
        let v = (gy - j as f32) as f64;
        let (lower, upper) = (&d[j * nx..][..nx], &d[(j + 1) * nx..][..nx]);
        for (c, s) in row.iter_mut().enumerate() {
            let gx = at(c).x;
            let i = (gx as usize).min(nx - 2);
            let u = (gx - i as f32) as f64;
            let z = (1.0 - v) * ((1.0 - u) * lower[i] as f64 + u * lower[i + 1] as f64)
                + v * ((1.0 - u) * upper[i] as f64 + u * upper[i + 1] as f64);
            *s = z * area;
            total_sampled += *s;
        }
    }
    let total = water.iter().sum::<f64>();
    if total_sampled > 0.0 {
        let scale = total / total_sampled;
        for (w, s) in water.iter_mut().zip(sampled) {
            *w = s * scale;
        }
    }
}

/// [`resample`] in its plain form, every column read: the reference it is tested against.
#[cfg(test)]
fn resample_plain(water: &mut [f64], depth_m: &[f32], grids: Grids) {
    let ((nx, cell, origin), (cx, lo, spacing)) = grids;
    let d = depth_m;
    let ny = d.len() / nx.max(1);
    if nx < 2 || ny < 2 {
        return;
    }
    let depth_at = |p: Vec2| -> f64 {
        let g =
            ((p - origin) / cell).clamp(Vec2::ZERO, Vec2::new((nx - 1) as f32, (ny - 1) as f32));
        let (i, j) = ((g.x as usize).min(nx - 2), (g.y as usize).min(ny - 2));
        let (u, v) = ((g.x - i as f32) as f64, (g.y - j as f32) as f64);
        let at = |i: usize, j: usize| d[j * nx + i] as f64;
        (1.0 - v) * ((1.0 - u) * at(i, j) + u * at(i + 1, j))
            + v * ((1.0 - u) * at(i, j + 1) + u * at(i + 1, j + 1))
    };
    let area = (spacing as f64).powi(2);
    let sampled: Vec<f64> = (0..water.len())
        .map(|c| {
            let xy = lo + (Vec2::new((c % cx) as f32, (c / cx) as f32) + 0.5) * spacing;
            depth_at(xy) * area
        })
        .collect();
    let (total, total_sampled) = (water.iter().sum::<f64>(), sampled.iter().sum::<f64>());
    if total_sampled > 0.0 {
        let scale = total / total_sampled;
        for (w, s) in water.iter_mut().zip(sampled) {
            *w = s * scale;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::splitmix64;

    /// Scattered puddles (a few wet vertices, some on the grid's edges, rows wholly dry)
    /// under columns finer and coarser than the vertices, reaching past the grid on every
    /// side: the columns' water is the plain resample's to the bit.
    #[test]
    fn the_columns_are_the_plain_resample_to_the_bit() {
        let (nx, ny) = (61, 47);
        let mut state = 99u64;
        let mut depth = vec![0.0f32; nx * ny];
        for _ in 0..10 {
            state = splitmix64(state);
            let (ci, cj) = (
                (state % nx as u64) as i64,
                ((state >> 20) % ny as u64) as i64,
            );
            let r = 1 + (state >> 40) % 4;
            for j in cj - r as i64..=cj + r as i64 {
                for i in ci - r as i64..=ci + r as i64 {
                    if (0..nx as i64).contains(&i) && (0..ny as i64).contains(&j) {
                        state = splitmix64(state);
                        depth[j as usize * nx + i as usize] = 1e-3 * ((state >> 40) % 7) as f32;
                    }
                }
            }
        }
        let dry_rows = depth
            .chunks(nx)
            .filter(|r| r.iter().all(|&z| z == 0.0))
            .count();
        assert!(dry_rows > 3, "{dry_rows} dry rows");
        let (cell, origin) = (0.02, Vec2::new(-0.4, 1.1));
        for spacing in [0.016, 0.011, 0.037] {
            let lo = origin - Vec2::splat(0.07);
            let cols = ((Vec2::new(nx as f32, ny as f32) * cell + 0.1) / spacing).floor();
            let (cx, cy) = (cols.x as usize, cols.y as usize);
            let mut binned = vec![0.0f64; cx * cy];
            for (k, w) in binned.iter_mut().enumerate() {
                state = splitmix64(state);
                if state.is_multiple_of(3) {
                    *w = 1e-7 * (k % 13) as f64;
                }
            }
            let grids = ((nx, cell, origin), (cx, lo, spacing));
            let (mut fast, mut plain) = (binned.clone(), binned.clone());
            resample(&mut fast, &depth, grids);
            resample_plain(&mut plain, &depth, grids);
            assert!(fast != binned);
            assert!(
                fast.iter()
                    .zip(&plain)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "spacing {spacing}"
            );
        }
    }
}
