//! The water map's cells as the CPU back end's puddles read them: where the map holds water
//! (blocks of cells, and each probe's 4×4 cells) so that pixels and probes over dry ground are
//! settled without reading it, and the cover's own readings in f32 (the pieces of a long
//! footprint, Catmull-Rom's weights, the rim's box), each the twin's
//! ([`crate::gpu::cpu::puddles`]) as puddles.wgsl computes it.

use rayon::prelude::*;

use super::wet_ground::smoothstep;

/// Cells along a side of a [`WetBlocks`] block.
pub(super) const WET_BLOCK: usize = 8;

/// Which blocks of [`WET_BLOCK`]² cells of the water map hold water (a cell > 0), as a
/// summed-area table: whether any cell of a rectangle may be wet, at four reads. Most of a
/// street's ground is dry, and a pixel whose four nearest cells are dry has no cover.
pub(super) struct WetBlocks {
    /// Blocks along x and y.
    bx: usize,
    by: usize,
    /// Wet blocks in the blocks (0..i, 0..j), at j·(bx + 1) + i.
    sat: Vec<u32>,
    /// Per cell (i, j), whether a cell of the 4×4 a probe whose point lies in the square of
    /// the cells (i, j) to (i + 1, j + 1) reads (columns i − 1 to i + 2, rows j − 1 to j + 2) is
    /// wet: one read settles the cover of a probe among scattered wet cells.
    window: Vec<bool>,
    /// Cells along x and y.
    nx: usize,
    ny: usize,
}

impl WetBlocks {
    /// The wet blocks of the map `depth_m` of `nx × ny` cells.
    pub(super) fn new(depth_m: &[f32], nx: usize, ny: usize) -> WetBlocks {
        let (bx, by) = (nx.div_ceil(WET_BLOCK), ny.div_ceil(WET_BLOCK));
        let wet: Vec<Vec<bool>> = (0..by)
            .into_par_iter()
            .map(|b| {
                let mut row = vec![false; bx];
                for j in b * WET_BLOCK..((b + 1) * WET_BLOCK).min(ny) {
                    let cells = depth_m[j * nx..(j + 1) * nx].chunks(WET_BLOCK);
                    for (w, cells) in row.iter_mut().zip(cells) {
                        // `|`, not `any`: no branch per cell, eight compares at a time.
                        *w |= cells.iter().fold(false, |a, &d| a | (d > 0.0));
                    }
                }
                row
            })
            .collect();
        let mut sat = vec![0u32; (bx + 1) * (by + 1)];
        for j in 0..by {
            let mut run = 0;
            for i in 0..bx {
                run += wet[j][i] as u32;
                sat[(j + 1) * (bx + 1) + i + 1] = sat[j * (bx + 1) + i + 1] + run;
            }
        }
        // The windows: wet cells spread over columns i − 1 to i + 2 along each row, then
        // over rows j − 1 to j + 2.
        let spread = |i: usize, n: usize| i.saturating_sub(1)..(i + 3).min(n);
        let mut along = vec![false; nx * ny];
        along
            .par_chunks_mut(nx.max(1))
            .zip(depth_m.par_chunks(nx.max(1)))
            .for_each(|(out, row)| {
                for (i, o) in out.iter_mut().enumerate() {
                    *o = row[spread(i, nx)].iter().any(|&d| d > 0.0);
                }
            });
        let mut window = vec![false; nx * ny];
        window
            .par_chunks_mut(nx.max(1))
            .enumerate()
            .for_each(|(j, out)| {
                for jj in spread(j, ny) {
                    for (o, &w) in out.iter_mut().zip(&along[jj * nx..(jj + 1) * nx]) {
                        *o |= w;
                    }
                }
            });
        WetBlocks {
            bx,
            by,
            sat,
            window,
            nx,
            ny,
        }
    }

    /// Whether the 4×4 cells a probe reads whose point lies in the square of the cells (`i`,
    /// `j`) to (`i` + 1, `j` + 1) may hold water (a point off the map: true).
    #[inline(always)]
    pub(super) fn window_wet(&self, i: i64, j: i64) -> bool {
        if i < 0 || j < 0 || i >= self.nx as i64 || j >= self.ny as i64 {
            return true;
        }
        self.window[j as usize * self.nx + i as usize]
    }

    /// Whether a cell of columns `i0..=i1` and rows `j0..=j1` (on the map) may be wet.
    pub(super) fn any(&self, (i0, i1): (usize, usize), (j0, j1): (usize, usize)) -> bool {
        let (a, b) = (i0 / WET_BLOCK, (i1 / WET_BLOCK + 1).min(self.bx));
        let (c, d) = (j0 / WET_BLOCK, (j1 / WET_BLOCK + 1).min(self.by));
        if a >= b || c >= d {
            return false;
        }
        let at = |i: usize, j: usize| self.sat[j * (self.bx + 1) + i];
        at(b, d) + at(a, c) > at(a, d) + at(b, c)
    }
}

/// A probe of the cover spans at most this many cells along each axis of the footprint (the
/// twin's [`crate::gpu::cpu::puddles::PROBE_CELLS`]).
pub(super) const PROBE_CELLS: f32 = crate::gpu::cpu::puddles::PROBE_CELLS as f32;

/// Whole probes along an axis at most (the twin's [`crate::gpu::cpu::puddles::MAX_PROBES`]).
pub(super) const MAX_PROBES: f32 = crate::gpu::cpu::puddles::MAX_PROBES as f32;

/// The pieces of an axis of a footprint whose share a probe spans is `share` (before the
/// least), (centre's offset, length) as shares of the axis, and how many (the twin's
/// [`crate::gpu::cpu::puddles::footprint_pieces`], in f32 and in its order, as puddles.wgsl
/// computes them; at most 17).
#[inline(always)]
pub(super) fn footprint_pieces(share: f32) -> ([(f32, f32); 17], usize) {
    let mut pieces = [(0.0, 0.0); 17];
    let share = share.max(1.0 / MAX_PROBES);
    if share >= 1.0 {
        pieces[0] = (0.0, 1.0);
        return (pieces, 1);
    }
    let k = ((1.0 / share - 1.0) / 2.0).floor();
    let end = 0.5 * (1.0 - (2.0 * k + 1.0) * share);
    pieces[0] = (0.0, share);
    let mut n = 1;
    for m in 1..=k as usize {
        pieces[n] = (m as f32 * share, share);
        pieces[n + 1] = (-(m as f32) * share, share);
        n += 2;
    }
    let out = (k + 0.5) * share + 0.5 * end;
    pieces[n] = (out, end);
    pieces[n + 1] = (-out, end);
    (pieces, n + 2)
}

/// The Catmull-Rom weights of the four cells around a point at fraction `t` of the way from
/// the second to the third (the twin's [`crate::gpu::cpu::puddles::catmull_rom`], in f32).
#[inline(always)]
pub(super) fn catmull_rom(t: f32) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

/// The derivative of [`catmull_rom`]'s weights by `t`.
#[inline(always)]
pub(super) fn catmull_rom_slope(t: f32) -> [f32; 4] {
    let t2 = t * t;
    [
        0.5 * (-3.0 * t2 + 4.0 * t - 1.0),
        0.5 * (9.0 * t2 - 10.0 * t),
        0.5 * (-9.0 * t2 + 8.0 * t + 1.0),
        0.5 * (3.0 * t2 - 2.0 * t),
    ]
}

/// The mean of smoothstep(0, `edge`, clamp(s, `lo`, `hi`)) for s spread evenly over `depth` ±
/// `width`/2 (the twin's [`crate::gpu::cpu::puddles::rim_cover`], in f32).
#[inline(always)]
pub(super) fn rim_cover(depth: f32, lo: f32, hi: f32, width: f32, edge: f32) -> f32 {
    if width <= 1e-3 * edge {
        return smoothstep(0.0, edge, depth.max(lo).min(hi));
    }
    rim_cover_spread(depth, lo, hi, width, edge)
}

/// [`rim_cover`] where `width` is not negligible: below `lo` and above `hi` the clamped
/// values' share, between them the ramp's integral, ∫₀ˢ smoothstep = edge·(t³ − t⁴/2).
#[inline(always)]
pub(super) fn rim_cover_spread(depth: f32, lo: f32, hi: f32, width: f32, edge: f32) -> f32 {
    let area = |s: f32| {
        let t = s.clamp(0.0, edge) / edge;
        edge * t * t * t * (1.0 - 0.5 * t)
    };
    let (x0, x1) = (depth - 0.5 * width, depth + 0.5 * width);
    let below = (x1.min(lo) - x0).max(0.0) * smoothstep(0.0, edge, lo);
    let above = (x1 - x0.max(hi)).max(0.0) * smoothstep(0.0, edge, hi);
    let (a, b) = (x0.max(lo).min(hi), x1.max(lo).min(hi));
    let ramp = (b - a.max(edge)).max(0.0) + area(b) - area(a);
    ((below + ramp + above) / width).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether a rectangle of cells may be wet, against looking at every cell: never a wet
    /// cell missed, and a rectangle of dry blocks only is dry.
    #[test]
    fn wet_blocks_find_every_wet_cell() {
        let (nx, ny) = (37, 29);
        let mut depth = vec![0.0f32; nx * ny];
        for k in [0, 5 * nx + 9, 17 * nx + 36, 28 * nx + 16, 28 * nx] {
            depth[k] = 1e-3;
        }
        depth[20 * nx + 20] = -1e-3;
        let wet = WetBlocks::new(&depth, nx, ny);
        for j0 in 0..ny {
            for j1 in j0..ny {
                for i0 in (0..nx).step_by(3) {
                    for i1 in (i0..nx).step_by(2) {
                        let any_cell =
                            (j0..=j1).any(|j| (i0..=i1).any(|i| depth[j * nx + i] > 0.0));
                        let blocks = (j0 / WET_BLOCK..=j1 / WET_BLOCK).any(|b| {
                            (i0 / WET_BLOCK..=i1 / WET_BLOCK).any(|a| {
                                (b * WET_BLOCK..((b + 1) * WET_BLOCK).min(ny)).any(|j| {
                                    (a * WET_BLOCK..((a + 1) * WET_BLOCK).min(nx))
                                        .any(|i| depth[j * nx + i] > 0.0)
                                })
                            })
                        });
                        let got = wet.any((i0, i1), (j0, j1));
                        assert!(
                            got || !any_cell,
                            "missed a wet cell in {i0}..={i1} × {j0}..={j1}"
                        );
                        assert_eq!(got, blocks, "{i0}..={i1} × {j0}..={j1}");
                    }
                }
            }
        }
        // A probe's 4×4 window, cell by cell.
        for j in -2..ny as i64 + 2 {
            for i in -2..nx as i64 + 2 {
                let any_cell = (j - 1..=j + 2).any(|jj| {
                    (i - 1..=i + 2).any(|ii| {
                        (0..nx as i64).contains(&ii)
                            && (0..ny as i64).contains(&jj)
                            && depth[jj as usize * nx + ii as usize] > 0.0
                    })
                });
                let off = i < 0 || j < 0 || i >= nx as i64 || j >= ny as i64;
                assert_eq!(wet.window_wet(i, j), any_cell || off, "({i}, {j})");
            }
        }
    }
}
