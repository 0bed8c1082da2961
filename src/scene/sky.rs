//! The open sky in a frame: where the scene is infinitely far, so the rain's haze leaves the
//! picture its own radiance (the sky already is the air-light at infinity, Koschmieder's limit).
//!
//! # Method
//!
//! On a grid of points every `cell_px` coded pixels (the haze's glow grid), each point sums up
//! the block of pixels around it: its mean colour (R'G'B', 8-bit codes) and its texture, the
//! mean absolute difference of neighbouring luma samples. Open sky is
//!
//! - **smooth**: texture at most [`TEXTURE_CODES`] at the point and at its eight neighbours (a
//!   blue or overcast sky, its gradient, a clipped sky; facades, foliage and lamps have edges,
//!   and the neighbours' test drops the smooth bands between a facade's windows);
//! - **not foliage**: its green does not stand [`GREEN_CODES`] above red and blue;
//! - **above the horizon** where a ground is given (the caller's `below_horizon`);
//! - **connected to the picture's top edge** as displayed, through smooth points whose colour
//!   steps by at most [`STEP_CODES`] between neighbours (a sky's gradient is gentle; the step
//!   to a wall is not); or, for a sky seen behind branches that hide the top edge, a region
//!   reaching into the top third of the picture whose points are mostly a clear sky's blue
//!   ([`BLUE_CODES`]);
//! - **large**: its region covers at least [`MIN_AREA`] of the picture (a smooth panel of a
//!   facade touching the top edge is one or two percent of it).
//!
//! The region then grows one point into the smooth points of its colour next to it, and each
//! point on its rim (whose block holds the sky's edge) takes the share of its pixels whose luma
//! lies within [`STEP_CODES`] of the sky beside it: interpolated between points, the mask's edge
//! follows the real one to a few pixels. Each frame's mask is a pure function of that frame;
//! [`SkyTracker`] averages the masks of the frames in a window before it, so a cloud whose
//! texture hovers at the threshold fades the veil a little instead of switching it (no
//! pumping), and the mask at a frame depends on the frames in the window alone (a preview
//! started mid-shot sees what the render does).

use std::collections::VecDeque;

use rayon::prelude::*;

use crate::video::YuvFrame;

/// Largest mean absolute luma step between neighbouring pixels, 8-bit codes, of a sky point
/// and its neighbours: a compressed sky is well under one code a pixel; a brick wall, leaves or
/// a window's frame are several.
pub const TEXTURE_CODES: f32 = 1.6;

/// Largest colour step (any of R'G'B', 8-bit codes) between neighbouring points of one sky.
pub const STEP_CODES: f32 = 6.0;

/// Green above both red and blue (8-bit codes) that marks foliage, not sky.
pub const GREEN_CODES: f32 = 8.0;

/// A clear sky's blue: blue at least this far above red (8-bit codes), not below green by more
/// than [`STEP_CODES`], at a daylight luma of at least [`BLUE_LUMA_CODES`].
pub const BLUE_CODES: f32 = 12.0;

/// Smallest luma of a clear sky's blue, 8-bit codes.
pub const BLUE_LUMA_CODES: f32 = 80.0;

/// Smallest share of the picture's grid points a sky region holds.
pub const MIN_AREA: f64 = 0.015;

/// Whether the haze finds the open sky in the frames (`ground.sky`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SkyMode {
    /// Found in each frame (see the module's method): the sky keeps its own radiance.
    #[default]
    Auto,
    /// Not looked for: every pixel without a depth is veiled to the ground or the scene's depth
    /// (for footage whose sky the detection gets wrong).
    Off,
}

impl SkyMode {
    /// The name the command line and the configuration use.
    pub fn name(self) -> &'static str {
        match self {
            SkyMode::Auto => "auto",
            SkyMode::Off => "off",
        }
    }
}

/// The coded picture's edge that is shown at the top (the picture's upright orientation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TopEdge {
    /// Row 0 (no rotation).
    Top,
    /// The last row.
    Bottom,
    /// Column 0.
    Left,
    /// The last column.
    Right,
}

impl TopEdge {
    /// The coded edge shown at the top, from the display → coded direction of "up" (any
    /// length): the edge it points to.
    /// The coded edge shown at the top of a `coded` (width, height) picture rotated by
    /// `rotation_deg` for display.
    pub fn of_rotation(rotation_deg: i32, coded: (u32, u32)) -> TopEdge {
        let (dh, dw) = if rotation_deg.rem_euclid(180) == 90 {
            coded
        } else {
            (coded.1, coded.0)
        };
        let at =
            |y: u32| crate::video::frame::coded_pixel(rotation_deg, coded.0, coded.1, dw / 2, y);
        let (top, bottom) = (at(0), at(dh.saturating_sub(1)));
        TopEdge::from_up([
            f64::from(top.0) - f64::from(bottom.0),
            f64::from(top.1) - f64::from(bottom.1),
        ])
    }

    /// The edge `up` points to, `up` the display's "up" as a coded direction (any length).
    pub fn from_up(up: [f64; 2]) -> TopEdge {
        if up[1].abs() >= up[0].abs() {
            if up[1] <= 0.0 {
                TopEdge::Top
            } else {
                TopEdge::Bottom
            }
        } else if up[0] < 0.0 {
            TopEdge::Left
        } else {
            TopEdge::Right
        }
    }
}

/// Grid points every `cell_px` coded pixels, both ends included: point (i, j) stands at coded
/// position `cell_px · (i, j)` and sums up the block of `cell_px`² pixels around it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SkyGrid {
    /// Pixels between points.
    pub cell_px: u32,
    /// Points per row.
    pub width: usize,
    /// Rows of points.
    pub height: usize,
}

impl SkyGrid {
    /// The grid over a coded picture of `size` pixels.
    pub fn new(cell_px: u32, size: (u32, u32)) -> SkyGrid {
        let cell = cell_px.max(1);
        SkyGrid {
            cell_px: cell,
            width: size.0.div_ceil(cell) as usize + 1,
            height: size.1.div_ceil(cell) as usize + 1,
        }
    }

    /// Points in all.
    pub fn len(&self) -> usize {
        self.width * self.height
    }

    /// Whether the grid has no points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The coded position of point `k` (row-major), pixels.
    pub fn point_px(&self, k: usize) -> glam::DVec2 {
        glam::DVec2::new((k % self.width) as f64, (k / self.width) as f64) * f64::from(self.cell_px)
    }

    /// The weight of `mask` (one per point) at coded pixel (`x`, `y`): bilinear between the
    /// points around its centre, as the haze reads it.
    pub fn weight_at(&self, mask: &[f32], x: u32, y: u32) -> f32 {
        let c = self.cell_px as f32;
        let (u, v) = ((x as f32 + 0.5) / c, (y as f32 + 0.5) / c);
        let (i, j) = (u as usize, v as usize);
        let (fx, fy) = (u.fract(), v.fract());
        let at =
            |i: usize, j: usize| mask[j.min(self.height - 1) * self.width + i.min(self.width - 1)];
        let top = at(i, j) + (at(i + 1, j) - at(i, j)) * fx;
        let bottom = at(i, j + 1) + (at(i + 1, j + 1) - at(i, j + 1)) * fx;
        top + (bottom - top) * fy
    }

    /// The pixels of point (`i`, `j`)'s block in a picture of `size`: x and y ranges, never
    /// empty.
    fn block(&self, i: usize, j: usize, size: (u32, u32)) -> ([u32; 2], [u32; 2]) {
        let c = self.cell_px;
        let span = |k: usize, n: u32| {
            let centre = c * k as u32;
            let lo = centre.saturating_sub(c / 2).min(n - 1);
            [lo, (centre + c.div_ceil(2)).min(n).max(lo + 1)]
        };
        (span(i, size.0), span(j, size.1))
    }
}

/// What a grid point's block shows.
#[derive(Debug, Clone, Copy)]
struct Cell {
    /// Mean R'G'B', 8-bit codes.
    rgb: [f32; 3],
    /// Mean luma, 8-bit codes.
    luma: f32,
    /// Mean absolute luma step between neighbouring pixels, 8-bit codes.
    texture: f32,
}

/// Row `y` of plane `i` of `frame` as codes into `out` (`n` samples).
#[cfg(test)]
fn row_codes(frame: &YuvFrame, i: usize, y: u32, n: usize, out: &mut Vec<f32>) {
    let p = &frame.planes[i];
    let start = y as usize * p.stride;
    out.clear();
    if frame.format.bytes_per_sample() == 1 {
        out.extend(p.data[start..][..n].iter().map(|&v| f32::from(v)));
    } else {
        out.extend(
            p.data[start..][..2 * n]
                .chunks_exact(2)
                .map(|b| f32::from(u16::from_le_bytes([b[0], b[1]]))),
        );
    }
}

/// The plain reference of [`sums`]: per pixel, its point found by division, every sum in
/// `f32` (exact, as every partial sum is an integer below 2²⁴).
#[cfg(test)]
fn sums_plain(frame: &YuvFrame, grid: SkyGrid) -> Vec<[f32; 6]> {
    let f = frame.format;
    let (w, h) = (f.width as usize, f.height as usize);
    let (sx, sy) = f.chroma.shift();
    let (cw, _) = f.plane_size(1);
    let c = grid.cell_px as usize;
    let point = |x: usize| (x + c / 2) / c;
    // Per point: luma, Cb and Cr sums, pixels, luma steps and their count.
    let mut sums = vec![[0.0f32; 6]; grid.len()];
    // Each row of points sums its own band of pixel rows: the bands run in parallel.
    sums.par_chunks_mut(grid.width)
        .enumerate()
        .for_each(|(j, points)| {
            let (lo, hi) = ((j * c).saturating_sub(c / 2), (j * c + c - c / 2).min(h));
            let (mut above, mut row): (Vec<f32>, Vec<f32>) = (Vec::new(), Vec::new());
            let (mut cb, mut cr) = (Vec::new(), Vec::new());
            for y in lo..hi {
                row_codes(frame, 0, y as u32, w, &mut row);
                row_codes(frame, 1, (y >> sy) as u32, cw as usize, &mut cb);
                row_codes(frame, 2, (y >> sy) as u32, cw as usize, &mut cr);
                for x in 0..w {
                    let s = &mut points[point(x).min(grid.width - 1)];
                    let v = row[x];
                    s[0] += v;
                    s[1] += cb[x >> sx];
                    s[2] += cr[x >> sx];
                    s[3] += 1.0;
                    if x + 1 < w && point(x + 1) == point(x) {
                        s[4] += (row[x + 1] - v).abs();
                        s[5] += 1.0;
                    }
                    if y > lo {
                        s[4] += (v - above[x]).abs();
                        s[5] += 1.0;
                    }
                }
                std::mem::swap(&mut above, &mut row);
            }
        });
    sums
}

/// A row of samples as integer codes, without a copy for 8-bit planes.
trait Code: Copy {
    fn code(self) -> u32;
}

impl Code for u8 {
    fn code(self) -> u32 {
        u32::from(self)
    }
}

impl Code for u16 {
    fn code(self) -> u32 {
        u32::from(self)
    }
}

/// Per-column sums over one row of points' band of pixel rows: luma, luma steps to the row
/// above and to the next column, Cb and Cr; whole rows at a time, so the loops vectorise.
#[derive(Default)]
struct Columns {
    luma: Vec<u32>,
    down: Vec<u32>,
    across: Vec<u32>,
    cb: Vec<u32>,
    cr: Vec<u32>,
    rows: u32,
}

impl Columns {
    /// Adds one pixel row (`above` it: the band's previous row, if any); inlined, so that it
    /// takes the build of its caller ([`sums_on`]).
    #[inline(always)]
    fn add<T: Code>(&mut self, row: &[T], above: Option<&[T]>, cb: &[T], cr: &[T]) {
        let w = row.len();
        if self.rows == 0 {
            *self = Columns {
                luma: vec![0; w],
                down: vec![0; w],
                across: vec![0; w],
                cb: vec![0; cb.len()],
                cr: vec![0; cr.len()],
                rows: 0,
            };
        }
        self.rows += 1;
        self.luma
            .iter_mut()
            .zip(row)
            .for_each(|(s, v)| *s += v.code());
        if let Some(above) = above {
            for ((s, v), a) in self.down.iter_mut().zip(row).zip(above) {
                *s += v.code().abs_diff(a.code());
            }
        }
        for (s, pair) in self.across.iter_mut().zip(row.windows(2)) {
            *s += pair[1].code().abs_diff(pair[0].code());
        }
        self.cb.iter_mut().zip(cb).for_each(|(s, v)| *s += v.code());
        self.cr.iter_mut().zip(cr).for_each(|(s, v)| *s += v.code());
    }

    /// The sums of each point of the row (see [`sums_plain`]: luma, Cb, Cr, pixels, luma steps
    /// and their count), the same integers the plain pass adds one pixel at a time: a block's
    /// sums stay far below 2³², and below 2²⁴ for blocks up to 64 px of 10-bit codes, so the
    /// `f32` reference holds them exactly and both agree to the bit. Inlined, as [`Columns::add`].
    #[inline(always)]
    fn reduce(&self, c: usize, sx: usize, out: &mut [[f32; 6]]) {
        let (w, rows) = (self.luma.len(), self.rows);
        if rows == 0 {
            return;
        }
        // Σ over pixels x in x0..x1 of a chroma column's sum at x >> sx.
        let chroma = |col: &[u32], x0: usize, x1: usize| {
            let (k0, k1) = (x0 >> sx, (x1 - 1) >> sx);
            let all: u32 = col[k0..=k1].iter().sum::<u32>() << sx;
            all - col[k0] * (x0 - (k0 << sx)) as u32 - col[k1] * (((k1 + 1) << sx) - x1) as u32
        };
        for (i, o) in out.iter_mut().enumerate() {
            // Point i holds the pixels x with (x + c/2) / c == i.
            let x0 = (i * c).saturating_sub(c / 2).min(w);
            let x1 = (i * c + c - c / 2).min(w);
            if x0 == x1 {
                continue;
            }
            let n = (x1 - x0) as u32;
            let steps =
                self.down[x0..x1].iter().sum::<u32>() + self.across[x0..x1 - 1].iter().sum::<u32>();
            *o = [
                self.luma[x0..x1].iter().sum::<u32>(),
                chroma(&self.cb, x0, x1),
                chroma(&self.cr, x0, x1),
                n * rows,
                steps,
                (n - 1) * rows + n * (rows - 1),
            ]
            .map(|v| v as f32);
        }
    }
}

/// A row of a 16-bit plane as codes into `out` (`n` samples).
fn row_u16(frame: &YuvFrame, i: usize, y: usize, n: usize, out: &mut Vec<u16>) {
    let p = &frame.planes[i];
    out.clear();
    out.extend(
        p.data[y * p.stride..][..2 * n]
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]])),
    );
}

/// Each grid point's sums over its block of `frame` (see [`Columns::reduce`]): the pixels nearer to it
/// than to any other point. One pass over the rows, in memory order, each row of points' band
/// of rows on its own thread, every point's run of pixels summed at once; on x86-64 with AVX2
/// the same loops compiled a second time (sixteen codes a vector) and picked at run time: the
/// sums are integers, so the same.
fn sums(frame: &YuvFrame, grid: SkyGrid) -> Vec<[f32; 6]> {
    #[cfg(target_arch = "x86_64")]
    let avx2 = std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    let avx2 = false;
    sums_on(frame, grid, avx2)
}

/// [`sums`], in the AVX2 build where `avx2` (the CPU has it).
fn sums_on(frame: &YuvFrame, grid: SkyGrid, avx2: bool) -> Vec<[f32; 6]> {
    let c = grid.cell_px as usize;
    let mut sums = vec![[0.0f32; 6]; grid.len()];
    sums.par_chunks_mut(grid.width)
        .enumerate()
        .for_each(|(j, out)| {
            #[cfg(target_arch = "x86_64")]
            if avx2 {
                #[target_feature(enable = "avx2")]
                fn fast(frame: &YuvFrame, c: usize, j: usize, out: &mut [[f32; 6]]) {
                    band_sums(frame, c, j, out);
                }
                // SAFETY: `avx2` is set only where the CPU has AVX2 (`sums`).
                return unsafe { fast(frame, c, j, out) };
            }
            let _ = avx2;
            band_sums(frame, c, j, out);
        });
    sums
}

/// The sums of row `j` of points (cells of `c` px) into `out`.
#[inline(always)]
fn band_sums(frame: &YuvFrame, c: usize, j: usize, out: &mut [[f32; 6]]) {
    let f = frame.format;
    let (w, h) = (f.width as usize, f.height as usize);
    let (sx, sy) = f.chroma.shift();
    let (sx, sy) = (sx as usize, sy as usize);
    let cw = f.plane_size(1).0 as usize;
    let (lo, hi) = ((j * c).saturating_sub(c / 2), (j * c + c - c / 2).min(h));
    let mut columns = Columns::default();
    if f.bytes_per_sample() == 1 {
        let row = |i: usize, y: usize, n: usize| {
            let p = &frame.planes[i];
            &p.data[y * p.stride..][..n]
        };
        for y in lo..hi {
            let above = (y > lo).then(|| row(0, y - 1, w));
            let (cb, cr) = (row(1, y >> sy, cw), row(2, y >> sy, cw));
            columns.add(row(0, y, w), above, cb, cr);
        }
    } else {
        let (mut above, mut row) = (Vec::new(), Vec::new());
        let (mut cb, mut cr) = (Vec::new(), Vec::new());
        for y in lo..hi {
            row_u16(frame, 0, y, w, &mut row);
            row_u16(frame, 1, y >> sy, cw, &mut cb);
            row_u16(frame, 2, y >> sy, cw, &mut cr);
            columns.add(&row, (y > lo).then_some(&above[..]), &cb, &cr);
            std::mem::swap(&mut above, &mut row);
        }
    }
    columns.reduce(c, sx, out);
}

/// The per-point block sums: [`sums`], or its plain reference in tests.
type BlockSums = fn(&YuvFrame, SkyGrid) -> Vec<[f32; 6]>;

/// Each grid point's block of `frame`: the pixels nearer to it than to any other point (a
/// point past the picture's edge, whose block is empty, copies its neighbour's).
fn cells(frame: &YuvFrame, grid: SkyGrid, sum: BlockSums) -> Vec<Cell> {
    let f = frame.format;
    let mut sums = sum(frame, grid);
    // Empty blocks past the right and bottom edges copy their neighbours.
    for k in 0..sums.len() {
        if sums[k][3] == 0.0 {
            let from = if k % grid.width > 0 {
                k - 1
            } else {
                k.saturating_sub(grid.width)
            };
            sums[k] = sums[from];
        }
    }
    let range = frame.color.range_scale();
    let (kr, kb) = frame.color.matrix.kr_kb();
    let (kr, kb) = (kr as f32, kb as f32);
    let kg = 1.0 - kr - kb;
    let to_8bit = 255.0 / ((1u32 << f.bit_depth) - 1) as f32;
    sums.iter()
        .map(|s| {
            let n = s[3].max(1.0);
            let luma = (s[0] / n - range.y_offset as f32) / range.y_scale as f32;
            let cb = (s[1] / n - range.c_offset as f32) / range.c_scale as f32;
            let cr = (s[2] / n - range.c_offset as f32) / range.c_scale as f32;
            let rgb = [
                luma + 2.0 * (1.0 - kr) * cr,
                luma - (2.0 * kb * (1.0 - kb) * cb + 2.0 * kr * (1.0 - kr) * cr) / kg,
                luma + 2.0 * (1.0 - kb) * cb,
            ];
            Cell {
                rgb: rgb.map(|v| 255.0 * v),
                luma: 255.0 * luma,
                texture: s[4] / s[5].max(1.0) * to_8bit,
            }
        })
        .collect()
}

/// Largest R'G'B' difference between two cells, 8-bit codes.
fn step(a: &Cell, b: &Cell) -> f32 {
    (0..3)
        .map(|c| (a.rgb[c] - b.rgb[c]).abs())
        .fold(0.0, f32::max)
}

/// The sky weight of each grid point of `frame` (row-major over `grid`, in [0, 1]): 1 where the
/// point's whole block is open sky, a share on the sky's rim, 0 elsewhere (see the module's
/// method). `top` is the coded edge shown at the top; `below_horizon` marks the points whose
/// ray meets a given ground.
pub fn detect(
    frame: &YuvFrame,
    grid: SkyGrid,
    top: TopEdge,
    below_horizon: Option<&[bool]>,
) -> Vec<f32> {
    detect_with(frame, grid, top, below_horizon, sums)
}

/// [`detect`] with the block sums of `sum`.
fn detect_with(
    frame: &YuvFrame,
    grid: SkyGrid,
    top: TopEdge,
    below_horizon: Option<&[bool]>,
    sum: BlockSums,
) -> Vec<f32> {
    let n = grid.len();
    if n == 0 || frame.format.width == 0 || frame.format.height == 0 {
        return vec![0.0; n];
    }
    let cells = cells(frame, grid, sum);
    let (w, h) = (grid.width, grid.height);
    let smooth: Vec<bool> = cells.iter().map(|c| c.texture <= TEXTURE_CODES).collect();
    let below = |k: usize| below_horizon.is_some_and(|b| b.get(k).copied().unwrap_or(false));
    let candidate: Vec<bool> = (0..n)
        .map(|k| {
            let [r, g, b] = cells[k].rgb;
            smooth[k] && g - r.max(b) <= GREEN_CODES && !below(k)
        })
        .collect();
    // The eight neighbours in row-major order (the rim's luma sums them in this order).
    let neighbours8 = |k: usize| {
        let (i, j) = (k % w, k / w);
        let (x0, x1) = (i.saturating_sub(1), (i + 1).min(w - 1));
        let (y0, y1) = (j.saturating_sub(1), (j + 1).min(h - 1));
        (y0..=y1)
            .flat_map(move |y| (x0..=x1).map(move |x| y * w + x))
            .filter(move |&m| m != k)
    };
    let neighbours4 = |k: usize| {
        let (i, j) = (k % w, k / w);
        [
            (i > 0).then(|| k - 1),
            (i + 1 < w).then(|| k + 1),
            (j > 0).then(|| k - w),
            (j + 1 < h).then(|| k + w),
        ]
        .into_iter()
        .flatten()
    };
    let core: Vec<bool> = (0..n)
        .map(|k| candidate[k] && neighbours8(k).all(|m| smooth[m]))
        .collect();
    let edge: Vec<usize> = match top {
        TopEdge::Top => (0..w).collect(),
        TopEdge::Bottom => (0..w).map(|i| (h - 1) * w + i).collect(),
        TopEdge::Left => (0..h).map(|j| j * w).collect(),
        TopEdge::Right => (0..h).map(|j| j * w + w - 1).collect(),
    };
    // How far down the displayed picture a point lies, 0 at the top edge, 1 at the bottom.
    let depth_down = |k: usize| {
        let (i, j) = ((k % w) as f64, (k / w) as f64);
        let (wl, hl) = ((w - 1).max(1) as f64, (h - 1).max(1) as f64);
        match top {
            TopEdge::Top => j / hl,
            TopEdge::Bottom => 1.0 - j / hl,
            TopEdge::Left => i / wl,
            TopEdge::Right => 1.0 - i / wl,
        }
    };
    let blue = |c: &Cell| {
        let [r, g, b] = c.rgb;
        b - r >= BLUE_CODES && b >= g - STEP_CODES && c.luma >= BLUE_LUMA_CODES
    };
    let blue_seeds = (0..n).filter(|&k| core[k] && depth_down(k) <= 1.0 / 3.0 && blue(&cells[k]));
    let seeds: Vec<(usize, bool)> = edge
        .into_iter()
        .map(|k| (k, true))
        .chain(blue_seeds.map(|k| (k, false)))
        .collect();
    // Regions of core points reached from the top edge (or clear blue ones near it).
    let mut sky = vec![0.0f32; n];
    let mut seen = vec![false; n];
    for &(seed, on_edge) in &seeds {
        if !core[seed] || seen[seed] {
            continue;
        }
        seen[seed] = true;
        let mut region = vec![seed];
        let mut queue = VecDeque::from([seed]);
        while let Some(k) = queue.pop_front() {
            for m in neighbours4(k) {
                if core[m] && !seen[m] && step(&cells[k], &cells[m]) <= STEP_CODES {
                    seen[m] = true;
                    region.push(m);
                    queue.push_back(m);
                }
            }
        }
        let blue_share = region.iter().filter(|&&k| blue(&cells[k])).count();
        if region.len() as f64 >= MIN_AREA * n as f64 && (on_edge || 2 * blue_share > region.len())
        {
            region.iter().for_each(|&k| sky[k] = 1.0);
        }
    }
    // One ring into the smooth points of the sky's colour.
    let grown: Vec<usize> = (0..n)
        .filter(|&k| sky[k] == 0.0 && candidate[k])
        .filter(|&k| {
            neighbours8(k).any(|m| sky[m] == 1.0 && step(&cells[k], &cells[m]) <= STEP_CODES)
        })
        .collect();
    grown.iter().for_each(|&k| sky[k] = 1.0);
    // The rim: the share of each block's pixels of the sky's luma beside it.
    let size = (frame.format.width, frame.format.height);
    let to_8bit = 255.0 / ((1u32 << frame.format.bit_depth) - 1) as f32;
    let range = frame.color.range_scale();
    let rim: Vec<(usize, f32)> = (0..n)
        .filter(|&k| sky[k] == 0.0 && !below(k))
        .filter_map(|k| {
            let (sum, count) = neighbours8(k)
                .filter(|&m| sky[m] == 1.0)
                .fold((0.0f32, 0u32), |(s, c), m| (s + cells[m].luma, c + 1));
            (count > 0).then(|| (k, sum / count as f32))
        })
        .map(|(k, luma)| {
            // The sky's luma as a code of the frame's own range.
            let code = (luma / 255.0 * range.y_scale as f32 + range.y_offset as f32) * to_8bit;
            let ([x0, x1], [y0, y1]) = grid.block(k % w, k / w, size);
            let mut hits = 0u32;
            for y in y0..y1 {
                for x in x0..x1 {
                    let v = f32::from(frame.sample(0, x, y)) * to_8bit;
                    hits += u32::from((v - code).abs() <= STEP_CODES);
                }
            }
            (k, hits as f32 / ((x1 - x0) * (y1 - y0)) as f32)
        })
        .collect();
    rim.into_iter().for_each(|(k, share)| sky[k] = share);
    sky
}

/// The sky mask over time: the mean of the frames' masks over a window of `4 · settle_s`
/// before the frame, each weighted `e^(−age / settle_s)` (the light's smoothing,
/// `lighting::envmap::ShSmoother`), restarted at a scene cut: a region that comes or goes fades
/// in or out instead of switching the veil.
#[derive(Debug, Clone)]
pub struct SkyTracker {
    settle_s: f64,
    window: VecDeque<(f64, Vec<f32>)>,
    weights: Vec<f32>,
}

impl SkyTracker {
    /// A tracker with time constant `settle_s` (0: no smoothing).
    pub fn new(settle_s: f64) -> SkyTracker {
        SkyTracker {
            settle_s: settle_s.max(0.0),
            window: VecDeque::new(),
            weights: Vec::new(),
        }
    }

    /// How far back a frame's mask still counts, seconds.
    pub fn window_s(&self) -> f64 {
        4.0 * self.settle_s
    }

    /// Takes `detected`, the mask of the frame shown at `t_s` (increasing; `cut`: it starts a
    /// new scene), and returns the mask to use for it.
    pub fn update(&mut self, detected: Vec<f32>, t_s: f64, cut: bool) -> &[f32] {
        let size = detected.len();
        if cut
            || self
                .window
                .back()
                .is_some_and(|(t, w)| *t >= t_s || w.len() != size)
        {
            self.window.clear();
        }
        self.window.push_back((t_s, detected));
        let horizon = t_s - self.window_s();
        while self.window.len() > 1 && self.window.front().is_some_and(|(t, _)| *t <= horizon) {
            self.window.pop_front();
        }
        self.weights.clear();
        self.weights.resize(size, 0.0);
        let mut total = 0.0;
        for (t, mask) in &self.window {
            let weight = if self.settle_s > 0.0 {
                (-(t_s - t) / self.settle_s).exp()
            } else {
                f64::from(u8::from(*t == t_s))
            };
            total += weight;
            for (w, m) in self.weights.iter_mut().zip(mask) {
                *w += (weight as f32) * m;
            }
        }
        let norm = (1.0 / total) as f32;
        self.weights.iter_mut().for_each(|w| *w *= norm);
        &self.weights
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::video::ColorParams;
    use crate::video::frame::{Chroma, FrameFormat, Plane};

    /// A frame of `size` whose samples are a smooth ramp over random blocks and noise (`seed`),
    /// packed with `pad` bytes of stride beyond each row.
    fn frame(size: (u32, u32), chroma: Chroma, bit_depth: u8, seed: u64) -> YuvFrame {
        let format = FrameFormat {
            width: size.0,
            height: size.1,
            chroma,
            bit_depth,
        };
        let max = (1u64 << bit_depth) - 1;
        let planes = std::array::from_fn(|i| {
            let (w, h) = format.plane_size(i);
            let stride = format.packed_stride(i) + 3 * format.bytes_per_sample();
            let mut data = vec![0u8; stride * h as usize];
            for y in 0..h as u64 {
                for x in 0..w as u64 {
                    let r = crate::rng::splitmix64(seed ^ (i as u64) << 40 ^ y << 20 ^ x);
                    let v = if (x / 13 + y / 9) % 3 == 0 {
                        r % (max + 1)
                    } else {
                        (x + y) * max / u64::from(w + h)
                    };
                    let at = y as usize * stride + x as usize * format.bytes_per_sample();
                    if bit_depth > 8 {
                        data[at..at + 2].copy_from_slice(&(v as u16).to_le_bytes());
                    } else {
                        data[at] = v as u8;
                    }
                }
            }
            Plane { data, stride }
        });
        YuvFrame {
            format,
            color: ColorParams::bt709(bit_depth),
            planes,
            pts: 0,
            index: 0,
        }
    }

    #[test]
    fn the_block_sums_equal_the_plain_ones_to_the_bit() {
        let cases = [
            ((64, 36), Chroma::Cs420, 8, 8),
            ((67, 41), Chroma::Cs420, 8, 8),
            ((50, 29), Chroma::Cs422, 10, 7),
            ((45, 33), Chroma::Cs444, 12, 16),
            ((9, 5), Chroma::Cs420, 8, 1),
            ((3, 2), Chroma::Cs420, 8, 8),
        ];
        for (seed, &(size, chroma, depth, cell)) in cases.iter().enumerate() {
            let f = frame(size, chroma, depth, seed as u64);
            let grid = SkyGrid::new(cell, size);
            let plain = sums_plain(&f, grid);
            // The AVX2 build (where the CPU has it) and the baseline one.
            for fast in [sums(&f, grid), sums_on(&f, grid, false)] {
                assert_eq!(fast.len(), plain.len());
                for (k, (a, b)) in fast.iter().zip(&plain).enumerate() {
                    assert_eq!(
                        a.map(f32::to_bits),
                        b.map(f32::to_bits),
                        "{size:?} point {k}"
                    );
                }
            }
            let (a, b) = (
                detect_with(&f, grid, TopEdge::Top, None, sums),
                detect_with(&f, grid, TopEdge::Top, None, sums_plain),
            );
            let bits = |m: Vec<f32>| m.into_iter().map(f32::to_bits).collect::<Vec<_>>();
            assert_eq!(bits(a), bits(b));
        }
    }

    /// Times the block sums and the whole detection, plain and fast, on a frame of
    /// `samples/street.mp4` scaled by ffmpeg to 640×360 and to 1080p:
    /// `cargo test --release --lib sky_cost -- --ignored --nocapture`.
    #[test]
    #[ignore = "a timing report, not a check"]
    fn sky_cost_report() {
        for (w, h) in [(640u32, 360u32), (1920, 1080)] {
            report_at(w, h);
        }
    }

    fn report_at(w: u32, h: u32) {
        let scale = format!("scale={w}:{h}");
        let raw = std::process::Command::new("ffmpeg")
            .args([
                "-v",
                "error",
                "-ss",
                "1",
                "-i",
                "samples/street.mp4",
                "-frames:v",
                "1",
            ])
            .args(["-vf", &scale, "-pix_fmt", "yuv420p", "-f", "rawvideo", "-"])
            .output()
            .expect("ffmpeg runs")
            .stdout;
        let mut f = frame((w, h), Chroma::Cs420, 8, 0);
        let mut at = 0;
        for p in &mut f.planes {
            let n = p.data.len() / p.stride * (p.stride - 3);
            let rows = raw[at..at + n].chunks_exact(p.stride - 3);
            p.data
                .chunks_exact_mut(p.stride)
                .zip(rows)
                .for_each(|(d, s)| {
                    d[..s.len()].copy_from_slice(s);
                });
            at += n;
        }
        let grid = SkyGrid::new(8, (w, h));
        let median_ms = |run: &dyn Fn()| {
            let mut t: Vec<f64> = (0..9)
                .map(|_| {
                    let start = std::time::Instant::now();
                    run();
                    start.elapsed().as_secs_f64() * 1e3
                })
                .collect();
            t.sort_by(f64::total_cmp);
            t[t.len() / 2]
        };
        let detect_by = |sum: BlockSums| detect_with(&f, grid, TopEdge::Top, None, sum);
        let sums_plain_ms = median_ms(&|| drop(std::hint::black_box(sums_plain(&f, grid))));
        let sums_ms = median_ms(&|| drop(std::hint::black_box(sums(&f, grid))));
        let plain_ms = median_ms(&|| drop(std::hint::black_box(detect_by(sums_plain))));
        let fast_ms = median_ms(&|| drop(std::hint::black_box(detect_by(sums))));
        let sky = detect_by(sums);
        assert_eq!(sky, detect_by(sums_plain));
        let share = sky.iter().sum::<f32>() / sky.len() as f32;
        println!(
            "{w}x{h} median of 9: detect plain {plain_ms:.2} ms (block sums {sums_plain_ms:.2}), \
             fast {fast_ms:.2} ms (block sums {sums_ms:.2}); sky share {share:.3}"
        );
    }
}
