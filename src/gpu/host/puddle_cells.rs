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
    /// Per cell (i, j) as `window`, whether all sixteen cells of that 4×4 lie on the map and
    /// hold at least the rim's depth with a margin ([`WetBlocks::new`]): the probe's cover is
    /// then 1 whatever its footprint, without the reading.
    deep: Vec<bool>,
    /// Cells along x and y.
    nx: usize,
    ny: usize,
}

impl WetBlocks {
    /// The wet blocks of the map `depth_m` of `nx × ny` cells, the deep windows for the rim's
    /// depth `edge_m`.
    ///
    /// A probe whose sixteen cells all hold v ≥ `edge_m` has a range whose low end stays at or
    /// above `edge_m` after its widening in exact arithmetic (the widening takes at most
    /// lo − v ≤ lo − `edge_m` off it), so its cover is 1. In f32 the widened low end,
    /// lo − r·(lo − v) with 0 ≤ r ≤ 1, each operation rounded, may fall below v by a few
    /// roundings of values ≤ the map's largest depth M: a cell counts as deep only from
    /// `edge_m` + 2⁻²⁰·M on (a margin of sixteen times such errors), finite, and `edge_m` > 0.
    pub(super) fn new(depth_m: &[f32], nx: usize, ny: usize, edge_m: f32) -> WetBlocks {
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
        let deep = deep_windows(depth_m, nx, ny, edge_m);
        WetBlocks {
            bx,
            by,
            sat,
            window,
            deep,
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

    /// Whether the 4×4 cells a probe reads whose point lies in the square of the cells (`i`,
    /// `j`) to (`i` + 1, `j` + 1) all lie on the map and are deep ([`WetBlocks::new`]): its cover
    /// is 1.
    #[inline(always)]
    pub(super) fn window_deep(&self, i: i64, j: i64) -> bool {
        if i < 0 || j < 0 || i >= self.nx as i64 || j >= self.ny as i64 {
            return false;
        }
        self.deep[j as usize * self.nx + i as usize]
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

/// Per cell (i, j) of the `nx × ny` map `depth_m`, whether columns i − 1 to i + 2 and rows
/// j − 1 to j + 2 all lie on the map and hold at least `edge_m` + 2⁻²⁰·M (M the map's largest
/// finite depth; [`WetBlocks::new`]), finite; none where `edge_m` is not above 0.
fn deep_windows(depth_m: &[f32], nx: usize, ny: usize, edge_m: f32) -> Vec<bool> {
    let mut deep = vec![false; nx * ny];
    if edge_m.is_nan() || edge_m <= 0.0 || nx < 4 || ny < 4 {
        return deep;
    }
    let largest = depth_m
        .par_chunks(nx)
        .map(|row| {
            row.iter()
                .filter(|d| d.is_finite())
                .fold(0f32, |a, &d| a.max(d))
        })
        .reduce(|| 0.0, f32::max);
    let floor_m = edge_m + largest * (1.0 / (1u32 << 20) as f32);
    // Along each row, then over rows: every cell of the window at or above the floor.
    let mut along = vec![false; nx * ny];
    along
        .par_chunks_mut(nx)
        .zip(depth_m.par_chunks(nx))
        .for_each(|(out, row)| {
            for i in 1..nx - 2 {
                out[i] = row[i - 1..i + 3]
                    .iter()
                    .all(|&d| d.is_finite() && d >= floor_m);
            }
        });
    deep.par_chunks_mut(nx)
        .enumerate()
        .filter(|(j, _)| (1..ny - 2).contains(j))
        .for_each(|(j, out)| {
            out.copy_from_slice(&along[(j - 1) * nx..][..nx]);
            for jj in j..j + 3 {
                for (o, &a) in out.iter_mut().zip(&along[jj * nx..][..nx]) {
                    *o &= a;
                }
            }
        });
    deep
}

/// A probe of the cover spans at most this many cells along each axis of the footprint (the
/// twin's [`crate::gpu::cpu::puddles::PROBE_CELLS`]).
pub(super) const PROBE_CELLS: f32 = crate::gpu::cpu::puddles::PROBE_CELLS as f32;

/// Whole probes along an axis at most (the twin's [`crate::gpu::cpu::puddles::MAX_PROBES`]).
pub(super) const MAX_PROBES: f32 = crate::gpu::cpu::puddles::MAX_PROBES as f32;

/// The pieces of an axis of a footprint whose share a probe spans is `share` (before the
/// least), made one at a time by [`AxisPieces::piece`] (the twin's
/// [`crate::gpu::cpu::puddles::footprint_pieces`], in f32 and in its order, as puddles.wgsl
/// computes them; at most 17): no array to fill and copy for each far pixel.
#[inline(always)]
pub(super) fn footprint_pieces(share: f32) -> AxisPieces {
    let share = share.max(1.0 / MAX_PROBES);
    if share >= 1.0 {
        return AxisPieces {
            share: 1.0,
            whole: 0,
            end: 0.0,
            out: 0.0,
        };
    }
    let k = ((1.0 / share - 1.0) / 2.0).floor();
    let end = 0.5 * (1.0 - (2.0 * k + 1.0) * share);
    AxisPieces {
        share,
        whole: k as usize,
        end,
        out: (k + 0.5) * share + 0.5 * end,
    }
}

/// An axis's pieces ([`footprint_pieces`]): the centre piece of length `share`, `whole` pieces
/// of that length out on each side, then two of length `end` centred at ± `out` (none where the
/// centre piece is the whole axis: `share` 1).
#[derive(Clone, Copy, Debug)]
pub(super) struct AxisPieces {
    share: f32,
    whole: usize,
    end: f32,
    out: f32,
}

impl AxisPieces {
    /// How many pieces.
    #[inline(always)]
    pub(super) fn len(&self) -> usize {
        if self.share >= 1.0 {
            1
        } else {
            2 * self.whole + 3
        }
    }

    /// Piece `i` (< [`AxisPieces::len`]): (centre's offset, length) as shares of the axis; the
    /// centre, then the whole pieces out from it (+, − in turn), then the ends (+, −).
    #[inline(always)]
    pub(super) fn piece(&self, i: usize) -> (f32, f32) {
        let share = self.share;
        if i == 0 {
            return (0.0, share);
        }
        if i <= 2 * self.whole {
            let m = i.div_ceil(2) as f32;
            return if i % 2 == 1 {
                (m * share, share)
            } else {
                (-m * share, share)
            };
        }
        let sign = if i == 2 * self.whole + 1 { 1.0 } else { -1.0 };
        (sign * self.out, self.end)
    }
}

/// The pieces of [`footprint_pieces`] as an array (and how many): the plain form the lazy one is
/// checked against.
#[cfg(test)]
fn footprint_pieces_array(share: f32) -> ([(f32, f32); 17], usize) {
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

    /// The deep windows against reading each window's sixteen cells: on the map, finite, at
    /// or above the rim's depth plus the margin; a cell at exactly the rim's depth (or just
    /// above it, within the margin), an infinite or NaN cell, or the map's border is not deep.
    #[test]
    fn deep_windows_hold_sixteen_deep_cells() {
        let (nx, ny, edge) = (23, 19, 0.001f32);
        let largest = 0.5f32;
        let floor_m = edge + largest / (1u32 << 20) as f32;
        let mut depth: Vec<f32> = (0..nx * ny)
            .map(|k| {
                let h = (k as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 40;
                if h.is_multiple_of(53) {
                    edge
                } else {
                    0.002 + 0.01 * (h % 7) as f32
                }
            })
            .collect();
        depth[3 * nx + 4] = largest;
        depth[5 * nx + 5] = f32::INFINITY;
        depth[11 * nx + 11] = f32::NAN;
        depth[15 * nx + 15] = edge + 1e-9;
        depth[16 * nx + 3] = 0.0;
        let wet = WetBlocks::new(&depth, nx, ny, edge);
        let mut seen = [0; 2];
        for j in -2..ny as i64 + 2 {
            for i in -2..nx as i64 + 2 {
                let all = (j - 1..=j + 2).all(|jj| {
                    (i - 1..=i + 2).all(|ii| {
                        (0..nx as i64).contains(&ii)
                            && (0..ny as i64).contains(&jj)
                            && depth[jj as usize * nx + ii as usize] >= floor_m
                            && depth[jj as usize * nx + ii as usize].is_finite()
                    })
                });
                assert_eq!(wet.window_deep(i, j), all, "({i}, {j})");
                seen[usize::from(all)] += 1;
            }
        }
        assert!(seen[0] > 50 && seen[1] > 30, "{seen:?}");
        // No rim depth above 0: nothing deep.
        let none = WetBlocks::new(&depth, nx, ny, 0.0);
        assert!((0..ny as i64).all(|j| (0..nx as i64).all(|i| !none.window_deep(i, j))));
    }

    /// The pieces made one at a time are the array's, bit for bit, and they tile the axis
    /// (each piece of some length starting where the one before it along the axis ends, from
    /// −½ to ½; the end pieces may have none), over shares from a probe's whole axis down past the least.
    #[test]
    fn axis_pieces_are_the_arrays() {
        let mut shares: Vec<f32> = (1..=4000).map(|k| k as f32 / 3000.0).collect();
        shares.extend([1.0 / 15.0, 1.0 / 3.0, 0.2, 1e-6, 0.0, 2.0, 1.0, 0.999_999]);
        for share in shares {
            let (array, n) = footprint_pieces_array(share);
            let lazy = footprint_pieces(share);
            assert_eq!(lazy.len(), n, "share {share}");
            let mut spans: Vec<(f32, f32)> = (0..n)
                .map(|i| {
                    let (t, l) = lazy.piece(i);
                    assert_eq!(
                        (t.to_bits(), l.to_bits()),
                        (array[i].0.to_bits(), array[i].1.to_bits()),
                        "share {share}, piece {i}"
                    );
                    (t - 0.5 * l, t + 0.5 * l)
                })
                .filter(|(a, b)| b > a)
                .collect();
            spans.sort_by(|a, b| a.0.total_cmp(&b.0));
            assert!(
                (spans[0].0 + 0.5).abs() < 1e-5,
                "share {share}: starts at {}",
                spans[0].0
            );
            let last = spans[spans.len() - 1].1;
            assert!((last - 0.5).abs() < 1e-5, "share {share}: ends at {last}");
            for w in spans.windows(2) {
                assert!((w[1].0 - w[0].1).abs() < 1e-5, "share {share}: {w:?}");
            }
        }
    }

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
        let wet = WetBlocks::new(&depth, nx, ny, 0.002);
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
