//! Where the ground is in a frame without a depth map: the part of the picture below the
//! horizon that the ground plane explains, so wetness and puddles stay off facades, walls,
//! railings and vehicles' sides standing on it.
//!
//! # Method
//!
//! A frame larger than [`WORKING_PX`](super::working_picture::WORKING_PX) (640 px) on its
//! longer side is first reduced to it by a box filter, and the mask found there is read back
//! bilinearly at the frame's grid: every threshold below is in pixels and cells of that size,
//! so a 1080p frame sees the edges and blocks a 640 px one does (found at 1080p itself, a wall's base blurred over three times
//! the pixels is no step between neighbouring pixels, and its face flooded).
//!
//! On the haze's grid of points (every `cell_px` coded pixels, as [`crate::scene::sky`]) each
//! point sums up the luma gradients of the block of pixels around it (its structure tensor).
//! A world vertical (a wall's edge, a window's frame, a railing's post, a pole, a car's door)
//! shows in the picture along the image of the world's up direction at that point, which the
//! caller gives per point (it converges to the nadir on a camera tilted down). A point is
//! **upright** where its gradients are strong (RMS at least [`UPRIGHT_ENERGY_CODES`]) and at
//! least [`UPRIGHT_SHARE`] of their energy lies across that direction: its edges run along the
//! world's verticals. The ground's own texture, foreshortened toward the horizon by the sine of
//! the ray's depression, leans the other way (its edges flatten), and the lines drawn on it
//! converge to vanishing points on the horizon, upright only right below them.
//!
//! The ground is then
//!
//! - **below the horizon** of the given ground (the caller's `below_horizon`);
//! - **not upright, nor next to an upright point** (the upright points grown by one closes the
//!   gaps between a facade's windows and a railing's posts);
//! - **connected to the picture's bottom edge** as displayed, through such points whose mean
//!   luma steps by at most [`STEP_CODES`] plus the ground's texture from the ground
//!   behind them along the flood
//!   (the road's shading and its texture pass; the step from the road to a wall's base, a kerb
//!   or a car's side does not): what stands on the road and is enclosed by its verticals and
//!   its base line (a wall's smooth panels) is cut off from it. The texture that excuses a
//!   step is the incoherent part of a block's gradients: a block straddling one blurred edge
//!   (a wall's base) has none. The ground behind a point follows each new point a quarter of
//!   the way, so a ramp of blocks down a blurred step is no path of small steps.
//! - **of the ground's colour**: its mean chroma within [`CHROMA_STEP_CODES`] of the ground's
//!   behind it, which follows each new point only a tenth of the way. Shading changes a
//!   surface's luma, hardly its chroma; a brick façade of the pavement's brightness (nothing
//!   in its luma or its verticals tells its base) is a little redder, and its red comes in
//!   over three or four blocks where the lens blurs its base.
//! - **bridged over what lies across it**: where a step stops the flood, the points on
//!   beyond, along the same row or column of the grid, are searched for the ground behind
//!   it again (its luma within a step with no texture to excuse more, its texture within
//!   [`BRIDGE_TEXTURE`], its colour within the chroma's step, the next point on too), within
//!   [`BRIDGE_POINTS`] (along a row [`BRIDGE_POINTS_ACROSS`]) and while the span lies within
//!   [`BRIDGE_RATIO`] of its near end's distance on the plane: paint (a stop line, a zebra
//!   crossing), a shadow or a band of red asphalt across the road is crossed, a low wall's
//!   face is not (from eye height the ground above its top lies three times as far as its
//!   base). The flood goes on from where it lands; what a bridge up or down the picture spans
//!   is ground (a zebra's stripes below the vanishing point, upright, too) but reaches on only
//!   what matches the ground behind the bridge. Up or down the picture it may land next to
//!   upright points that all lie behind the landing (the last of a zebra's stripes ends
//!   there), not next to verticals that go on past its row (a wall's edge, a drainpipe).
//! - **seeded where the bottom edge shows the ground**: the edge's open points whose luma is
//!   within such a step of their median. The face of a wall or a car nearer than the ground
//!   at the bottom edge, running down past the picture's edge (a wall a pan brings into view),
//!   is not reached from below.
//!
//! The region is grown back by one point into the ring it lost next to upright points (where
//! the step to it is the ground's own), then
//! eroded by one point, so every point whose block touches a vertical structure or the step to
//! one leaves it, and read bilinearly between points: its edge is soft over one cell, and lies
//! inside the ground. A ground that mirrors the sky is water already, and leaves the mask by
//! its weight as water ([`super::water`]), softly. Each frame's mask is a pure function of that frame; averaged over a
//! window by [`crate::scene::sky::SkyTracker`], it fades instead of switching.
//!
//! Not explained: a smooth wall without a vertical edge reaching the ground's region, of the
//! ground's brightness and colour at its base (it is taken for ground: a brick façade over a
//! brick pavement); a wall covering most of the bottom edge (its face is taken for the ground
//! there, and the road behind its base is cut off); lines painted on the road straight ahead
//! right below its vanishing point (upright, so a narrow dry lane along them); and ground of
//! another colour than the ground at the bottom edge's, beyond a sharp change, that does not
//! return to the ground's own within a bridge (a red cycle lane along the road, a lawn, a
//! shadow reaching the horizon): it stays dry; a low object (under half the camera's height)
//! across the road with the same ground beyond it is bridged and its face wetted.

use std::collections::VecDeque;

use rayon::prelude::*;

use super::sky::{SkyGrid, TopEdge};
use super::water;
use super::working_picture::{plane_row, reduce, working_size};
use crate::video::YuvFrame;
use crate::video::color::eotf_signed;

/// Smallest RMS luma gradient between neighbouring pixels, 8-bit codes, of a block with
/// structure: compressed noise on a smooth wall is one or two codes; the edge of a window or a
/// post across the block is tens.
pub const UPRIGHT_ENERGY_CODES: f32 = 3.0;

/// Smallest share of a block's gradient energy across the image of the world's up direction
/// that makes its structure upright: isotropic texture gives 1/2, the ground's foreshortened
/// texture less, a vertical edge 1.
pub const UPRIGHT_SHARE: f32 = 0.62;

/// Largest step of mean luma between neighbouring ground points beyond their texture, 8-bit
/// codes: the shading of a road is gentle, the base of a wall or a kerb is a step.
pub const STEP_CODES: f32 = 8.0;

/// Largest step of mean chroma (the distance in Cb, Cr, 8-bit codes) between neighbouring
/// ground points: shading leaves a grey road's chroma within a code or two a block; the base
/// of a brick façade of the pavement's brightness, or a painted car's side, steps by 6–10.
pub const CHROMA_STEP_CODES: f32 = 4.0;

/// Whether wetness and puddles keep to the ground found in the frames (`ground.mask`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GroundMaskMode {
    /// Found in each frame (see the module's method); a depth map, where given, decides.
    #[default]
    Auto,
    /// Every pixel below the horizon is ground (a depth map still keeps what stands on it dry).
    Off,
}

impl GroundMaskMode {
    /// The name the command line and the configuration use.
    pub fn name(self) -> &'static str {
        match self {
            GroundMaskMode::Auto => "auto",
            GroundMaskMode::Off => "off",
        }
    }
}

/// What the given ground says about one grid point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointView {
    /// Its ray meets the ground.
    pub below_horizon: bool,
    /// The image of the world's up direction there, in coded pixels (any length, not zero).
    pub up_px: [f32; 2],
    /// Where the ground, were it a mirror, shows the sky: the coded pixel of the ray reflected
    /// in the ground plane (`None` above the horizon or behind the camera).
    pub mirror_px: Option<[f32; 2]>,
    /// The sine of the angle its ray dips below the horizon (0 at or above it).
    pub sin_depression: f32,
}

/// Each grid point's sums over its block (the pixels x, y with (x + c/2) / c on the point,
/// less the last row and column, which have no forward step): gx², gy², gx·gy of the forward
/// luma steps, pixels, luma, and the Cb and Cr samples under each pixel (codes of the frame's
/// depth). The plain reference of [`sums`], one pixel at a time.
#[cfg(test)]
fn sums_plain(frame: &YuvFrame, grid: SkyGrid) -> Vec<[f64; 7]> {
    let f = frame.format;
    let (w, h) = (f.width as usize, f.height as usize);
    let (sx, sy) = f.chroma.shift();
    let c = grid.cell_px as usize;
    let point = |x: usize| (x + c / 2) / c;
    let mut sums = vec![[0.0f64; 7]; grid.len()];
    for (j, points) in sums.chunks_mut(grid.width).enumerate() {
        let (lo, hi) = ((j * c).saturating_sub(c / 2), (j * c + c - c / 2).min(h));
        for y in lo..hi.min(h.saturating_sub(1)) {
            for x in 0..w.saturating_sub(1) {
                let (xu, yu) = (x as u32, y as u32);
                let v = f64::from(frame.sample(0, xu, yu));
                let gx = f64::from(frame.sample(0, xu + 1, yu)) - v;
                let gy = f64::from(frame.sample(0, xu, yu + 1)) - v;
                let s = &mut points[point(x).min(grid.width - 1)];
                s[0] += gx * gx;
                s[1] += gy * gy;
                s[2] += gx * gy;
                s[3] += 1.0;
                s[4] += v;
                s[5] += f64::from(frame.sample(1, xu >> sx, yu >> sy));
                s[6] += f64::from(frame.sample(2, xu >> sx, yu >> sy));
            }
        }
    }
    sums
}

/// [`sums_plain`] in integers: each row of points' band of pixel rows summed per column over
/// whole rows (loops that vectorise), then each point's run of columns at once; the same
/// sums, exact.
fn sums(frame: &YuvFrame, grid: SkyGrid) -> Vec<[f64; 7]> {
    let f = frame.format;
    let (w, h) = (f.width as usize, f.height as usize);
    let (sx, sy) = f.chroma.shift();
    let chroma_w = f.plane_size(1).0 as usize;
    let c = grid.cell_px as usize;
    let mut sums = vec![[0.0f64; 7]; grid.len()];
    if w < 2 {
        return sums;
    }
    sums.par_chunks_mut(grid.width)
        .enumerate()
        .for_each(|(j, points)| {
            let (lo, hi) = ((j * c).saturating_sub(c / 2), (j * c + c - c / 2).min(h));
            let hi = hi.min(h.saturating_sub(1));
            if lo >= hi {
                return;
            }
            let m = w - 1;
            let mut columns = [vec![0i64; m], vec![0i64; m], vec![0i64; m], vec![0i64; m]];
            // Cb and Cr summed per chroma column over the band's rows (each chroma row as many
            // times as luma rows lie on it), spread to the luma columns per point below.
            let mut chroma = [vec![0i64; chroma_w], vec![0i64; chroma_w]];
            let mut chroma_row = Vec::new();
            for r in (lo >> sy)..=((hi - 1) >> sy) {
                let times = (hi.min((r + 1) << sy) - lo.max(r << sy)) as i64;
                for (i, sums) in chroma.iter_mut().enumerate() {
                    plane_row(frame, i + 1, r, chroma_w, &mut chroma_row);
                    for (sum, v) in sums.iter_mut().zip(&chroma_row) {
                        *sum += times * v;
                    }
                }
            }
            let (mut row, mut below) = (Vec::new(), Vec::new());
            plane_row(frame, 0, lo, w, &mut row);
            for y in lo..hi {
                plane_row(frame, 0, y + 1, w, &mut below);
                let [xx, yy, xy, luma] = &mut columns;
                for x in 0..m {
                    let v = row[x];
                    let (gx, gy) = (row[x + 1] - v, below[x] - v);
                    xx[x] += gx * gx;
                    yy[x] += gy * gy;
                    xy[x] += gx * gy;
                    luma[x] += v;
                }
                std::mem::swap(&mut row, &mut below);
            }
            let rows = (hi - lo) as f64;
            for (i, s) in points.iter_mut().enumerate() {
                // Point i holds the columns x with (x + c/2) / c == i, the last also those past.
                let x0 = (i * c).saturating_sub(c / 2).min(m);
                let x1 = if i + 1 == grid.width {
                    m
                } else {
                    (i * c + c - c / 2).min(m)
                };
                if x0 < x1 {
                    let sum = |col: &[i64]| col[x0..x1].iter().sum::<i64>() as f64;
                    let spread = |col: &[i64]| (x0..x1).map(|x| col[x >> sx]).sum::<i64>() as f64;
                    let [xx, yy, xy, luma] = &columns;
                    let [cb, cr] = &chroma;
                    *s = [
                        sum(xx),
                        sum(yy),
                        sum(xy),
                        (x1 - x0) as f64 * rows,
                        sum(luma),
                        spread(cb),
                        spread(cr),
                    ];
                }
            }
        });
    sums
}

/// Each grid point's structure tensor: mean gx², gy², gx·gy over its block (8-bit codes²,
/// coded axes), its mean luma, and its mean Cb and Cr less their neutral value (8-bit codes),
/// from `sums` of the frame ([`sums`]).
fn tensors(frame: &YuvFrame, grid: SkyGrid, mut sums: Vec<[f64; 7]>) -> Vec<[f32; 6]> {
    let f = frame.format;
    let h = f.height as usize;
    let c = grid.cell_px as usize;
    let to_8bit = 255.0 / ((1u64 << f.bit_depth) - 1) as f64;
    let neutral = f64::from(1u32 << (f.bit_depth - 1));
    // Empty blocks past the bottom edge copy the point above them, past the right edge the
    // point left of them (the bottom edge's seeds are the picture's own bottom row).
    let first = |i: usize| (i * c).saturating_sub(c / 2);
    for k in 0..sums.len() {
        if sums[k][3] == 0.0 {
            let (i, j) = (k % grid.width, k / grid.width);
            let from = if j > 0 && first(j) + 1 >= h {
                k - grid.width
            } else {
                k.saturating_sub(usize::from(i > 0))
            };
            sums[k] = sums[from];
        }
    }
    sums.iter()
        .map(|s| {
            let n = s[3].max(1.0);
            let g = to_8bit * to_8bit / n;
            let mean = |v: f64| v / n * to_8bit;
            [
                s[0] * g,
                s[1] * g,
                s[2] * g,
                mean(s[4]),
                mean(s[5] - neutral * s[3]),
                mean(s[6] - neutral * s[3]),
            ]
            .map(|v| v as f32)
        })
        .collect()
}

/// Whether a block of structure tensor `t` has edges along the image direction `up`.
fn upright(t: &[f32], up: [f32; 2]) -> bool {
    let energy = t[0] + t[1];
    if energy < UPRIGHT_ENERGY_CODES * UPRIGHT_ENERGY_CODES {
        return false;
    }
    let norm = (up[0] * up[0] + up[1] * up[1]).sqrt();
    if norm.is_nan() || norm <= 0.0 {
        return false;
    }
    // Across `up`: n = (−up.y, up.x)/|up|; E[(g·n)²] = nᵀ T n.
    let (nx, ny) = (-up[1] / norm, up[0] / norm);
    let across = nx * nx * t[0] + ny * ny * t[1] + 2.0 * nx * ny * t[2];
    across >= UPRIGHT_SHARE * energy
}

/// The share of the way from the ground's reference to a newly reached point's own luma and
/// texture by which the reference moves: the road's shading (a few codes a block) is followed,
/// a ramp of blocks down a blurred step (a wall's base, a kerb) is not.
const FOLLOW: f32 = 0.25;

/// The share of the way by which the ground's reference chroma moves to a newly reached
/// point's: shading, which the luma's reference follows, leaves a surface's chroma nearly
/// where it was, so the chroma keeps to the material the flood came from, and a façade whose
/// red comes in over three or four blocks above the pavement (its base blurred) is the step
/// it is.
const FOLLOW_CHROMA: f32 = 0.1;

/// The most points a bridge over paint, a shadow or a band across the ground spans, its
/// landing included.
const BRIDGE_POINTS: usize = 16;

/// The most points a bridge spans along a row of the picture: across a post, a pole or a
/// line painted along the ground (its other side is as near as this one, so the ratio below
/// does not bound it).
const BRIDGE_POINTS_ACROSS: usize = 4;

/// How much rougher or smoother than the ground behind a bridge its landing may be.
const BRIDGE_TEXTURE: f32 = 1.5;

/// The farthest a bridge reaches along the ground, as a multiple of where it starts (the
/// ground beyond a low wall of height H seen from a camera h up lies h / (h − H) times as far
/// as its base: 3.2 times for a 1.1 m wall from 1.6 m; a stop line 0.5 m deep 6 m away spans
/// 1.08, a zebra crossing 3 m deep at 7 m 1.43, a shadow 6 m deep at 8 m 1.75).
const BRIDGE_RATIO: f32 = 2.0;

/// A block's texture, 8-bit codes: twice the RMS gradient along its weaker direction, 2·√λ₋
/// of its structure tensor (√2 times the RMS gradient of isotropic texture). A block that
/// straddles one edge (a wall's base, a kerb, a shadow's rim) has its gradients all across it
/// and no texture: the step it holds is not excused as the ground's own.
fn texture_codes(t: &[f32]) -> f32 {
    let half_trace = 0.5 * (t[0] + t[1]);
    let det = t[0] * t[1] - t[2] * t[2];
    let smaller = half_trace - (half_trace * half_trace - det).max(0.0).sqrt();
    2.0 * smaller.max(0.0).sqrt()
}

/// The flood's seeds among the open points `bottom` of the picture's bottom edge: the
/// median of their lumas and textures is taken for the ground there (most of the edge's open
/// points show it), and a point is a seed where its luma is within a step of it (its texture
/// excusing as much as in the flood). The face of a wall or a car standing nearer than the
/// ground at the bottom edge, run down past the picture's edge, is not a seed.
fn seeds(bottom: &[usize], t: &[[f32; 6]], texture: &[f32]) -> Vec<usize> {
    if bottom.is_empty() {
        return Vec::new();
    }
    let median = |mut v: Vec<f32>| {
        v.sort_by(f32::total_cmp);
        v[v.len() / 2]
    };
    let luma = median(bottom.iter().map(|&k| t[k][3]).collect());
    let rough = median(bottom.iter().map(|&k| texture[k]).collect());
    bottom
        .iter()
        .copied()
        .filter(|&k| (t[k][3] - luma).abs() <= STEP_CODES + rough.min(texture[k]))
        .collect()
}

/// Mean lumas (8-bit codes) of `frame`'s blocks as linear light through its range and
/// transfer (white 1), as a grey of that luma.
fn linear_luma(frame: &YuvFrame, luma: &[f32]) -> Vec<f32> {
    let s = frame.color.range_scale();
    let from_8bit = ((1u64 << frame.format.bit_depth) - 1) as f64 / 255.0;
    luma.iter()
        .map(|&l| {
            let e = (f64::from(l) * from_8bit - s.y_offset) / s.y_scale;
            eotf_signed(frame.color.transfer, e) as f32
        })
        .collect()
}

/// The ground's weight at each grid point of `frame` (row-major over `grid`, 0–1; read
/// bilinearly, [`SkyGrid::weight_at`]): see the module's method. `top` is the coded edge shown
/// at the top (the ground is reached from the opposite one); `view` holds one entry per point.
///
/// A frame larger than [`WORKING_PX`](super::working_picture::WORKING_PX) is reduced to its
/// [`working_size`] first, found on a grid of the same cell there (each point's view the nearest of `view`'s, the same one where
/// the sizes' ratio is whole), and read back bilinearly at `grid`'s points: the mask is the
/// scene's, not the resolution's, its soft edge as wide in the scene, and a 1080p frame costs
/// about what a 640 px one does.
pub fn detect(frame: &YuvFrame, grid: SkyGrid, top: TopEdge, view: &[PointView]) -> Vec<f32> {
    let f = frame.format;
    let to = working_size((f.width, f.height));
    if to == (f.width, f.height) || view.len() != grid.len() || grid.is_empty() {
        return detect_at_size(frame, grid, top, view);
    }
    let small = reduce(frame, to);
    let fine = SkyGrid::new(grid.cell_px, to);
    let (sx, sy) = (
        f64::from(f.width) / f64::from(to.0),
        f64::from(f.height) / f64::from(to.1),
    );
    let c = f64::from(grid.cell_px);
    let nearest = |v: f64, n: usize| ((v / c).round().max(0.0) as usize).min(n - 1);
    let views: Vec<PointView> = (0..fine.len())
        .map(|k| {
            let at = fine.point_px(k);
            let (i, j) = (
                nearest(at.x * sx, grid.width),
                nearest(at.y * sy, grid.height),
            );
            let v = view[j * grid.width + i];
            let to_small = |p: [f32; 2]| [p[0] / sx as f32, p[1] / sy as f32];
            PointView {
                up_px: to_small(v.up_px),
                mirror_px: v.mirror_px.map(to_small),
                ..v
            }
        })
        .collect();
    let mask = detect_at_size(&small, fine, top, &views);
    let at = |i: usize, j: usize| mask[j.min(fine.height - 1) * fine.width + i.min(fine.width - 1)];
    (0..grid.len())
        .map(|k| {
            let p = grid.point_px(k);
            let (u, v) = ((p.x / sx / c) as f32, (p.y / sy / c) as f32);
            let (i, j) = (u as usize, v as usize);
            let (fx, fy) = (u.fract(), v.fract());
            let top = at(i, j) + (at(i + 1, j) - at(i, j)) * fx;
            let bottom = at(i, j + 1) + (at(i + 1, j + 1) - at(i, j + 1)) * fx;
            top + (bottom - top) * fy
        })
        .collect()
}

/// [`detect`] at the frame's own size.
fn detect_at_size(frame: &YuvFrame, grid: SkyGrid, top: TopEdge, view: &[PointView]) -> Vec<f32> {
    let n = grid.len();
    if n == 0 || view.len() != n || frame.format.width < 2 || frame.format.height < 2 {
        return vec![0.0; n];
    }
    let sums = sums(frame, grid);
    // Points whose block holds pixels of their own: one past the picture's bottom or right
    // edge copies a neighbour's, which the water rule's rows would count twice.
    let measured: Vec<bool> = sums.iter().map(|s| s[3] > 0.0).collect();
    let t = tensors(frame, grid, sums);
    let (w, h) = (grid.width, grid.height);
    let neighbours8 = |k: usize| {
        let (i, j) = ((k % w) as i64, (k / w) as i64);
        (-1i64..=1)
            .flat_map(move |dj| (-1i64..=1).map(move |di| (i + di, j + dj)))
            .filter(move |&(x, y)| {
                (x, y) != (i, j) && x >= 0 && y >= 0 && x < w as i64 && y < h as i64
            })
            .map(move |(x, y)| y as usize * w + x as usize)
    };
    let standing: Vec<bool> = (0..n).map(|k| upright(&t[k], view[k].up_px)).collect();
    let open: Vec<bool> = (0..n)
        .map(|k| view[k].below_horizon && !standing[k] && !neighbours8(k).any(|m| standing[m]))
        .collect();
    let bottom: Vec<usize> = match top {
        TopEdge::Top => (0..w).map(|i| (h - 1) * w + i).collect(),
        TopEdge::Bottom => (0..w).collect(),
        TopEdge::Left => (0..h).map(|j| j * w + w - 1).collect(),
        TopEdge::Right => (0..h).map(|j| j * w).collect(),
    };
    // The ground's luma and texture along the flood's path to each point (a quarter of the way
    // to each new point's own): a step is measured from the ground behind it, so the base of a
    // wall blurred over two or three blocks, each a part of the step, is still a step.
    let texture: Vec<f32> = t.iter().map(|t| texture_codes(t)).collect();
    let mut reference = vec![[0.0f32; 4]; n];
    let passes = |reference: &[[f32; 4]], from: usize, to: usize| {
        let [luma, rough, cb, cr] = reference[from];
        (t[to][3] - luma).abs() <= STEP_CODES + rough.min(texture[to])
            && (t[to][4] - cb).hypot(t[to][5] - cr) <= CHROMA_STEP_CODES
    };
    // How far along the ground each point lies, in camera heights (cot of its ray's dip).
    let distance: Vec<f32> = view
        .iter()
        .map(|v| {
            let s = v.sin_depression;
            if v.below_horizon && s > 0.0 {
                (1.0 - s * s).max(0.0).sqrt() / s
            } else {
                f32::INFINITY
            }
        })
        .collect();
    // From ground point `k` past its neighbour `m` onward: the points up to one that matches
    // the ground behind `k` again, as does the next one on (where there is one), all below the
    // horizon, within [`BRIDGE_POINTS`] and [`BRIDGE_RATIO`] of `k`'s distance.
    let bridge = |reference: &[[f32; 4]], k: usize, m: usize| -> Option<Vec<usize>> {
        let step = m as i64 - k as i64;
        let (i, j) = ((k % w) as i64, (k / w) as i64);
        let (di, dj) = if step.abs() == 1 {
            (step, 0)
        } else {
            (0, step.signum())
        };
        let at = |s: i64| {
            let (x, y) = (i + s * di, j + s * dj);
            (x >= 0 && y >= 0 && x < w as i64 && y < h as i64).then(|| y as usize * w + x as usize)
        };
        // The ground itself again: its luma within a step with no texture to excuse more (a
        // wall's face within the cobbles' texture of their luma is not), as rough within a
        // factor of [`BRIDGE_TEXTURE`], its chroma within the chroma's step.
        // Up or down the picture, the landing may lie next to upright points that end behind
        // it (toward `k`): the last of a zebra's stripes, upright below their vanishing point,
        // leaves the ground right beyond it unopen. A wall's verticals go on past the landing's
        // row (a drainpipe, a pilaster), and a landing beside them stays refused.
        let landable = |p: usize| {
            if open[p] || dj == 0 {
                return open[p];
            }
            let row = (p / w) as i64;
            view[p].below_horizon
                && !standing[p]
                && neighbours8(p).all(|q| !standing[q] || ((q / w) as i64 - row) * dj < 0)
        };
        let same = |p: usize| {
            let [luma, rough, cb, cr] = reference[k];
            landable(p)
                && (t[p][3] - luma).abs() <= STEP_CODES
                && (t[p][4] - cb).hypot(t[p][5] - cr) <= CHROMA_STEP_CODES
                && texture[p].max(1.0) <= BRIDGE_TEXTURE * rough.max(1.0)
                && rough.max(1.0) <= BRIDGE_TEXTURE * texture[p].max(1.0)
        };
        let most = if dj == 0 {
            BRIDGE_POINTS_ACROSS
        } else {
            BRIDGE_POINTS
        };
        for s in 2..=most as i64 {
            let (p, last) = (at(s)?, at(s - 1)?);
            let (near, far) = (
                distance[m].min(distance[last]),
                distance[m].max(distance[last]),
            );
            if !view[p].below_horizon || far > BRIDGE_RATIO * near {
                return None;
            }
            if same(p) && at(s + 1).is_none_or(|q| !landable(q) || same(q)) {
                return Some((1..=s).filter_map(at).collect());
            }
        }
        None
    };
    let mut ground = vec![false; n];
    let open_bottom: Vec<usize> = bottom.into_iter().filter(|&k| open[k]).collect();
    let mut queue: VecDeque<usize> = seeds(&open_bottom, &t, &texture).into();
    for &k in &queue {
        ground[k] = true;
        reference[k] = [t[k][3], texture[k], t[k][4], t[k][5]];
    }
    while let Some(k) = queue.pop_front() {
        let (i, j) = (k % w, k / w);
        let next = [
            (i > 0).then(|| k - 1),
            (i + 1 < w).then(|| k + 1),
            (j > 0).then(|| k - w),
            (j + 1 < h).then(|| k + w),
        ];
        for m in next.into_iter().flatten() {
            if ground[m] {
                continue;
            }
            if open[m] && passes(&reference, k, m) {
                ground[m] = true;
                let own = [t[m][3], texture[m], t[m][4], t[m][5]];
                reference[m] = std::array::from_fn(|i| {
                    let follow = if i < 2 { FOLLOW } else { FOLLOW_CHROMA };
                    reference[k][i] + follow * (own[i] - reference[k][i])
                });
                queue.push_back(m);
            } else if let Some(across) = bridge(&reference, k, m) {
                // Paint, a shadow or a band of another surface lying across the ground: the
                // ground beyond it is reached and floods on. What lies between is ground where
                // the bridge runs up or down the picture, upright lines too (a zebra's stripes
                // toward their vanishing point), but reaches on only what matches the ground
                // behind the bridge: taking its own colour for the ground's, it would spread
                // over a wall's face that a bridge crossed as readily as along a shadow.
                let Some((&landing, between)) = across.split_last() else {
                    continue;
                };
                if m.abs_diff(k) == w {
                    for &p in between {
                        if !ground[p] {
                            ground[p] = true;
                            reference[p] = reference[k];
                            queue.push_back(p);
                        }
                    }
                }
                if !ground[landing] {
                    ground[landing] = true;
                    let own = [
                        t[landing][3],
                        texture[landing],
                        t[landing][4],
                        t[landing][5],
                    ];
                    reference[landing] = std::array::from_fn(|i| {
                        let follow = if i < 2 { FOLLOW } else { FOLLOW_CHROMA };
                        reference[k][i] + follow * (own[i] - reference[k][i])
                    });
                    queue.push_back(landing);
                }
            }
        }
    }
    // Grown back by one point into the ring next to upright points (closed above against the
    // gaps), then eroded by one point (the picture's border does not erode it).
    let ring: Vec<usize> = (0..n)
        .filter(|&k| !ground[k] && view[k].below_horizon && !standing[k])
        .filter(|&k| neighbours8(k).any(|m| ground[m] && passes(&reference, m, k)))
        .collect();
    ring.into_iter().for_each(|k| ground[k] = true);
    // A ground that mirrors the sky is water already: out of the mask, softly.
    let luma: Vec<f32> = t.iter().map(|t| t[3]).collect();
    let linear = linear_luma(frame, &luma);
    let mirror: Vec<Option<[f32; 2]>> = view.iter().map(|v| v.mirror_px).collect();
    let sin_depression: Vec<f32> = view.iter().map(|v| v.sin_depression).collect();
    let points = water::Points {
        luma: &luma,
        linear: &linear,
        texture: &texture,
        ground: &ground,
        measured: &measured,
        mirror: &mirror,
        sin_depression: &sin_depression,
    };
    let (wet, _, _) = water::weights(grid, top, points);
    (0..n)
        .map(|k| {
            let open = f32::from(u8::from(ground[k] && neighbours8(k).all(|m| ground[m])));
            open * (1.0 - wet[k])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::video::ColorParams;
    use crate::video::frame::{Chroma, FrameFormat};

    /// The block sums in integers over whole rows equal the plain per-pixel ones exactly, at
    /// 8 and 10 bits, in 4:2:0, 4:2:2 and 4:4:4, for sizes that are and are not multiples of
    /// the cell (odd ones with a chroma sample past the last luma pair), and padded rows.
    #[test]
    fn the_block_sums_equal_the_plain_ones() {
        for (size, bit_depth, cell, chroma) in [
            ((64u32, 48u32), 8u8, 8u32, Chroma::Cs420),
            ((101, 37), 8, 8, Chroma::Cs420),
            ((50, 29), 10, 8, Chroma::Cs420),
            ((23, 17), 10, 5, Chroma::Cs422),
            ((31, 19), 8, 8, Chroma::Cs444),
            ((2, 2), 8, 8, Chroma::Cs420),
        ] {
            let format = FrameFormat {
                width: size.0,
                height: size.1,
                chroma,
                bit_depth,
            };
            let mut f = YuvFrame::filled(format, ColorParams::bt709(bit_depth), [16, 128, 128]);
            // Rows padded past the picture, as decoders leave them.
            let bytes = format.bytes_per_sample();
            let max = (1u64 << bit_depth) - 1;
            for (i, plane) in f.planes.iter_mut().enumerate() {
                let (w, h) = format.plane_size(i);
                let stride = format.packed_stride(i) + 3 * bytes;
                let mut data = vec![0u8; stride * h as usize];
                for y in 0..h as usize {
                    for x in 0..w as usize {
                        let r =
                            crate::rng::splitmix64((i as u64) << 40 ^ (y as u64) << 20 ^ x as u64);
                        let v = if (x / 7 + y / 5) % 2 == 0 {
                            r % (max + 1)
                        } else {
                            (x as u64 * 3) % (max + 1)
                        };
                        let at = y * stride + x * bytes;
                        if bytes == 2 {
                            data[at..at + 2].copy_from_slice(&(v as u16).to_le_bytes());
                        } else {
                            data[at] = v as u8;
                        }
                    }
                }
                plane.data = data;
                plane.stride = stride;
            }
            let grid = SkyGrid::new(cell, size);
            assert_eq!(
                sums(&f, grid),
                sums_plain(&f, grid),
                "{size:?} at {bit_depth} bits, {chroma:?}"
            );
        }
    }

    /// The texture of a block is the gradient along its weaker direction: √2 times the RMS
    /// gradient for isotropic gradients, none for one edge whatever its direction, the weaker
    /// direction's for a mix (against the eigenvalues worked by hand).
    #[test]
    fn texture_is_the_incoherent_part_of_the_gradients() {
        // Isotropic: E[gx²] = E[gy²] = 50, no correlation: λ₋ = 50, RMS √100 = 10.
        let iso = texture_codes(&[50.0, 50.0, 0.0, 0.0]);
        assert!((iso - 2f32.sqrt() * 10.0).abs() < 1e-3, "{iso}");
        // One edge at 30° from the x axis, energy 100: the tensor 100·(c², s², c·s).
        let (s, c) = 30f32.to_radians().sin_cos();
        let edge = [100.0 * c * c, 100.0 * s * s, 100.0 * c * s, 0.0];
        assert!(texture_codes(&edge) < 1e-2, "{}", texture_codes(&edge));
        // An edge along x of energy 64 over isotropic texture of 2 × 9: eigenvalues 73 and 9,
        // whichever way the edge runs (the tensor turned by 40°).
        assert!((texture_codes(&[73.0, 9.0, 0.0, 0.0]) - 6.0).abs() < 1e-4);
        let (s, c) = 40f32.to_radians().sin_cos();
        let turned = [
            73.0 * c * c + 9.0 * s * s,
            73.0 * s * s + 9.0 * c * c,
            (73.0 - 9.0) * c * s,
            0.0,
        ];
        assert!(
            (texture_codes(&turned) - 6.0).abs() < 1e-2,
            "{}",
            texture_codes(&turned)
        );
    }

    /// What finding the ground costs a frame beside finding the sky (and beside finding it at
    /// the frame's own size, unreduced), on the first frame past
    /// 1 s of `samples/street.mp4` scaled by ffmpeg to 640×360 and to 1080p (the horizon at
    /// 0.48 of the height, a level camera): `cargo test --release --lib ground_cost --
    /// --ignored --nocapture`.
    #[test]
    #[ignore = "a timing report, not a check"]
    fn ground_cost_report() {
        for (w, h) in [(640u32, 360u32), (1920, 1080)] {
            let raw = std::process::Command::new("ffmpeg")
                .args(["-v", "error", "-ss", "1", "-i", "samples/street.mp4"])
                .args(["-frames:v", "1", "-vf", &format!("scale={w}:{h}")])
                .args(["-pix_fmt", "yuv420p", "-f", "rawvideo", "-"])
                .output()
                .expect("ffmpeg runs")
                .stdout;
            let format = FrameFormat {
                width: w,
                height: h,
                chroma: Chroma::Cs420,
                bit_depth: 8,
            };
            let mut f = YuvFrame::filled(format, ColorParams::bt709(8), [16, 128, 128]);
            let mut at = 0;
            for p in &mut f.planes {
                let n = p.data.len();
                p.data.copy_from_slice(&raw[at..at + n]);
                at += n;
            }
            let grid = SkyGrid::new(8, (w, h));
            let horizon_px = 0.48 * h as f32;
            let view: Vec<PointView> = (0..grid.len())
                .map(|k| PointView {
                    below_horizon: ((k / grid.width) as f32 * 8.0) > horizon_px,
                    up_px: [0.0, -1.0],
                    mirror_px: None,
                    sin_depression: 0.0,
                })
                .collect();
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
            let ground = || detect(&f, grid, TopEdge::Top, &view);
            let full = || detect_at_size(&f, grid, TopEdge::Top, &view);
            let sky = || crate::scene::sky::detect(&f, grid, TopEdge::Top, None);
            let ground_ms = median_ms(&|| drop(std::hint::black_box(ground())));
            let full_ms = median_ms(&|| drop(std::hint::black_box(full())));
            let sky_ms = median_ms(&|| drop(std::hint::black_box(sky())));
            let to = working_size((w, h));
            let reduce_ms = median_ms(&|| drop(std::hint::black_box(reduce(&f, to))));
            let share = ground().iter().sum::<f32>() / grid.len() as f32;
            let full_share = full().iter().sum::<f32>() / grid.len() as f32;
            println!(
                "{w}x{h} median of 9: ground mask {ground_ms:.2} ms (at the frame's own size \
                 {full_ms:.2} ms; reducing it {reduce_ms:.2} ms), sky {sky_ms:.2} ms; ground share {share:.3} (at its own \
                 size {full_share:.3})"
            );
        }
    }
}
