//! The puddles on the CPU back end (the `puddles` stage's work): where a pixel's ray meets the
//! ground on water, the ground under the water (the frame's own colour, decoded again for the
//! rows with water) darkened as by a film, plus the rippled surface's Fresnel reflection of
//! the picture along the mirrored ray (marched against the depth map where there is one) or,
//! beyond the frame, of the environment and the lamps (docs/method.md, "Puddles: shading").
//! Bands of rows over rayon's threads, each in blocks of 16 × 16 px that keep only the rings
//! that can reach their ground (as the shader's workgroups do); the mirror reads the canvas as
//! it was before the water (each band is written to a copy, put back once all are done), so no
//! pixel depends on the order. Pixels without water keep their bits. In f32 as the shader; the
//! plain twin [`crate::gpu::cpu::puddles`] is the reference (`tests/backend.rs`). On x86-64
//! with AVX2 and F16C each band is compiled a second time (the picture's texels converted by
//! F16C, the floors rounded inline, no library calls for either) and picked at run time, as the
//! streak raster's ([`super::streaks`]); it gives the same bits.

use glam::{Vec2, Vec3};
use half::f16;
use rayon::prelude::*;

use super::plate::Decoder;
use super::puddle_cells::{
    AxisPieces, PROBE_CELLS, WetBlocks, catmull_rom, catmull_rom_slope, footprint_pieces,
    rim_cover, rim_cover_spread,
};
use super::tile::load_texel;
use super::veil::Veil;
use super::wet_ground::{Ground, PI, darkening, ground_shown, reflectance, smoothstep};
use crate::gpu::stages::puddles::FrameWater;
use crate::gpu::stages::yuv_to_rgb::GLOW_CELL_PX;
use crate::gpu::types::{LightList, MAX_LIGHTS, Ripple};
use crate::video::YuvFrame;

mod lanes;

/// Rows per band and columns per block: a block's rings are culled once (the shader's
/// workgroup, `PIXEL_WORKGROUP`).
const BLOCK: usize = crate::gpu::stages::PIXEL_WORKGROUP as usize;

/// The reflection fades from the frame to the environment over this many pixels at its border.
const EDGE_PX: f32 = 8.0;
/// The march along the mirrored ray's image (`MARCH_*` in puddles.wgsl).
const MARCH_STRIDE_PX: f32 = 2.0;
const MARCH_MAX_STEPS: u32 = 64;
const MARCH_FARTHEST: f32 = 0.999;
const MARCH_HALVINGS: u32 = 6;
const MARCH_THICKNESS: f32 = 0.25;

/// The water of one frame over the ground.
pub struct Puddles<'a> {
    ground: &'a Ground<'a>,
    water: &'a FrameWater<'a>,
    lights: &'a LightList,
    e_up: Vec3,
    /// Where the map holds water, to pass over the blocks of pixels that see none.
    wet: WetBlocks,
}

/// What one pixel's shading reads besides the water: the canvas before the water.
struct Picture<'a> {
    canvas: &'a [f16],
    width: usize,
    height: usize,
    /// Texels converted by F16C (only in the AVX2 build: [`Puddles::band_on`]).
    f16c: bool,
}

impl Picture<'_> {
    /// The picture at coded pixel (`x`, `y`), clamped at the border.
    #[inline(always)]
    fn at(&self, x: i64, y: i64) -> Vec3 {
        let x = x.clamp(0, self.width as i64 - 1) as usize;
        let y = y.clamp(0, self.height as i64 - 1) as usize;
        let k = 4 * (y * self.width + x);
        let texel: &[f16; 4] = self.canvas[k..k + 4].try_into().expect("four values");
        let [r, g, b, _] = load_texel(texel, self.f16c);
        Vec3::new(r, g, b)
    }

    /// The picture at coded position `at` (px), bilinear between pixel centres.
    #[inline(always)]
    fn sample(&self, at: Vec2) -> Vec3 {
        let u = at - Vec2::splat(0.5);
        let i = u.floor();
        let f = u - i;
        let (x, y) = (i.x as i64, i.y as i64);
        if x >= 0 && y >= 0 && x + 1 < self.width as i64 && y + 1 < self.height as i64 {
            // Inside: the four texels without a clamp each, from one slice (the same values).
            let (w, k) = (4 * self.width, 4 * (y as usize * self.width + x as usize));
            let quad = &self.canvas[k..k + w + 8];
            let texel = |o: usize| {
                let [r, g, b, _] = load_texel(quad[o..o + 4].try_into().expect("four"), self.f16c);
                Vec3::new(r, g, b)
            };
            let (a, b, c, e) = (texel(0), texel(4), texel(w), texel(w + 4));
            return a.lerp(b, f.x).lerp(c.lerp(e, f.x), f.y);
        }
        let (a, b) = (self.at(x, y), self.at(x + 1, y));
        let (c, e) = (self.at(x, y + 1), self.at(x + 1, y + 1));
        a.lerp(b, f.x).lerp(c.lerp(e, f.x), f.y)
    }

    #[inline(always)]
    fn inside(&self, at: Vec2) -> f32 {
        at.x.min(at.y)
            .min(self.width as f32 - at.x)
            .min(self.height as f32 - at.y)
    }
}

impl<'a> Puddles<'a> {
    /// The water `water` over `ground`, the lamps `lights` mirrored beyond the frame; `None`
    /// where no ray reaches the ground.
    pub fn new(
        ground: &'a Ground<'a>,
        water: &'a FrameWater<'a>,
        lights: &'a LightList,
    ) -> Option<Puddles<'a>> {
        let cells = water.params.cells[0] as usize * water.params.cells[1] as usize;
        (ground.height_m() > 0.0 && cells > 0 && water.depth_m.len() >= cells).then(|| Puddles {
            ground,
            water,
            lights,
            e_up: ground.irradiance_up(),
            wet: WetBlocks::new(
                water.depth_m,
                water.params.cells[0] as usize,
                water.params.cells[1] as usize,
                water.params.edge_depth_m,
            ),
        })
    }

    /// Puts the water on `canvas` (RGBA f16, the frame `frame` decoded by `decoder` under
    /// `veil`, with the wet ground if any); returns the pixels under water. Runs the AVX2
    /// build where the CPU has AVX2 and F16C.
    pub fn shade(
        &self,
        canvas: &mut [f16],
        frame: &YuvFrame,
        decoder: &Decoder,
        veil: Option<&Veil>,
    ) -> usize {
        self.shade_on(canvas, frame, decoder, veil, true)
    }

    /// [`Puddles::shade`] without the AVX2 build: the same bits (`tests/backend.rs`).
    pub fn shade_baseline(
        &self,
        canvas: &mut [f16],
        frame: &YuvFrame,
        decoder: &Decoder,
        veil: Option<&Veil>,
    ) -> usize {
        self.shade_on(canvas, frame, decoder, veil, false)
    }

    fn shade_on(
        &self,
        canvas: &mut [f16],
        frame: &YuvFrame,
        decoder: &Decoder,
        veil: Option<&Veil>,
        avx2: bool,
    ) -> usize {
        let (width, height) = self.ground.coded_size;
        let bands = height.div_ceil(BLOCK);
        let avx2 = avx2 && has_avx2();
        let picture = Picture {
            canvas,
            width,
            height,
            f16c: avx2,
        };
        let done: Vec<(usize, Vec<f16>, usize)> = (0..bands)
            .into_par_iter()
            .filter_map(|band| self.band_on(band, &picture, frame, decoder, veil))
            .collect();
        let mut wet = 0;
        for (band, rows, n) in done {
            canvas[4 * width * band * BLOCK..][..rows.len()].copy_from_slice(&rows);
            wet += n;
        }
        wet
    }

    /// [`Puddles::band`], in the AVX2 build where `picture.f16c` (the CPU has AVX2 and F16C).
    fn band_on(
        &self,
        band: usize,
        picture: &Picture,
        frame: &YuvFrame,
        decoder: &Decoder,
        veil: Option<&Veil>,
    ) -> Option<(usize, Vec<f16>, usize)> {
        #[cfg(target_arch = "x86_64")]
        if picture.f16c {
            #[target_feature(enable = "avx2,f16c")]
            fn fast(
                puddles: &Puddles,
                band: usize,
                picture: &Picture,
                frame: &YuvFrame,
                decoder: &Decoder,
                veil: Option<&Veil>,
            ) -> Option<(usize, Vec<f16>, usize)> {
                puddles.band(band, picture, frame, decoder, veil)
            }
            // SAFETY: `f16c` is set only where the CPU has AVX2 and F16C (`shade_on`).
            return unsafe { fast(self, band, picture, frame, decoder, veil) };
        }
        self.band(band, picture, frame, decoder, veil)
    }

    /// Band `band`'s rows with the water, or `None` where none of its pixels is under water.
    #[inline(always)]
    fn band(
        &self,
        band: usize,
        picture: &Picture,
        frame: &YuvFrame,
        decoder: &Decoder,
        veil: Option<&Veil>,
    ) -> Option<(usize, Vec<f16>, usize)> {
        let g = self.ground;
        let width = picture.width;
        let y0 = band * BLOCK;
        let rows = BLOCK.min(picture.height - y0);
        // The cover of each pixel first (cheap): most bands of most frames have no water.
        let mut cover = vec![0f32; width * rows];
        let mut any = false;
        for x0 in (0..width).step_by(BLOCK) {
            let x1 = (x0 + BLOCK).min(width);
            if self.sees_no_water((x0, x1 - 1), (y0, y0 + rows - 1)) {
                continue;
            }
            for r in 0..rows {
                // A row of the block sees no water either where its own two ends' ground
                // points say so (a segment is a quadrilateral too): most of a wet block's rows
                // on a street with scattered puddles, for two rays instead of sixteen covers.
                if self.sees_no_water((x0, x1 - 1), (y0 + r, y0 + r)) {
                    continue;
                }
                let down = g.downward(y0 + r);
                let (start, end) = (down.start.max(x0), down.end.min(x1));
                let span = &mut cover[r * width..][start..end.max(start)];
                self.cover_span(start, y0 + r, span, picture.f16c);
                any |= span.iter().fold(false, |a, &c| a | (c > 0.0));
            }
        }
        if !any {
            return None;
        }
        let mut out = vec![0f32; 4 * width];
        let mut plate = vec![0f32; 4 * width];
        let (mut t, mut finite) = (vec![1f32; width], vec![false; width]);
        let mut grid = Vec::new();
        let mut scratch = super::plate::RowScratch::default();
        // The rings of the blocks with water.
        let rings: Vec<Vec<u32>> = (0..width.div_ceil(BLOCK))
            .map(|b| {
                let x0 = b * BLOCK;
                let wet = (0..rows).any(|r| {
                    cover[r * width + x0..][..BLOCK.min(width - x0)]
                        .iter()
                        .any(|&c| c > 0.0)
                });
                if wet && !self.ripples().is_empty() {
                    self.rings_near(x0, y0, width, picture.height)
                } else {
                    Vec::new()
                }
            })
            .collect();
        let mut band_out = vec![f16::ZERO; 4 * width * rows];
        let mut wet = 0;
        for r in 0..rows {
            let y = y0 + r;
            let row = &picture.canvas[4 * width * y..][..4 * width];
            let under = &cover[r * width..][..width];
            let dst = &mut band_out[4 * width * r..][..4 * width];
            if under.iter().all(|&c| c <= 0.0) {
                dst.copy_from_slice(row);
                continue;
            }
            super::tile::load(row, &mut out, picture.f16c);
            decoder.plate_row(frame, y as u32, &mut plate, &mut scratch);
            if let Some(v) = veil {
                v.transmittance_row(y as u32, &mut t, &mut finite);
                v.grid_row(y as u32, &mut grid);
            }
            for (x, &c) in under.iter().enumerate() {
                if c <= 0.0 {
                    continue;
                }
                let s = veil.map_or(Vec3::ZERO, |_| {
                    let cell = GLOW_CELL_PX as usize;
                    let (a, b) = (grid[x / cell], grid[x / cell + 1]);
                    let f = ((x % cell) as f32 + 0.5) / cell as f32;
                    let at = |c: usize| a[c] + (b[c] - a[c]) * f;
                    // The in-scatter and the lamps' glow, both per unit of opacity.
                    Vec3::from_array(std::array::from_fn(|k| at(k) + at(k + 3)))
                });
                let l = Vec3::from_slice(&plate[4 * x..]);
                let px = &mut out[4 * x..][..3];
                let held = Vec3::from_slice(px);
                if let Some(v) = self.pixel(x, y, c, l, t[x], s, held, &rings[x / BLOCK], picture) {
                    px.copy_from_slice(&v.to_array());
                    wet += 1;
                }
            }
            super::tile::store(&out, dst, picture.f16c);
            // Pixels without water keep their bits (f16 → f32 → f16 is exact).
        }
        Some((band, band_out, wet))
    }

    /// Whether the pixels of columns `x0..=x1` and rows `y0..=y1` surely see no water: the
    /// rays one pixel beyond the corners all go down, so every pixel's footprint (the probes
    /// of [`Puddles::water_cover`] lie within half a pixel of its ground point, to first
    /// order) lies in the quadrilateral of their ground points (the ground is the rays'
    /// central projection: convex stays convex), and no cell within two cells of that
    /// quadrilateral's bounding box is wet ([`Puddles::probe_cover`] is 0 where the 4×4 cells
    /// around its point are dry or off the map).
    fn sees_no_water(&self, (x0, x1): (usize, usize), (y0, y1): (usize, usize)) -> bool {
        let g = self.ground;
        let p = &self.water.params;
        let (lo, hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        let (mut lo, mut hi) = (lo, hi);
        for (x, y, sx, sy) in [
            (x0, y0, -1.0, -1.0),
            (x1, y0, 1.0, -1.0),
            (x0, y1, -1.0, 1.0),
            (x1, y1, 1.0, 1.0),
        ] {
            // The ray is affine in the pixel: a pixel out along each axis.
            let ray = g.ray(x, y) + sx * g.dx + sy * g.dy;
            if ray.z >= 0.0 {
                return false;
            }
            let ground = g.camera + (g.height_m() / -ray.z) * ray;
            let u = (Vec2::new(ground.x, ground.y) - Vec2::from_array(p.origin_m)) / p.cell_m
                - Vec2::splat(0.5);
            lo = lo.min(u);
            hi = hi.max(u);
        }
        self.cells_dry(lo, hi)
    }

    /// The water's cover at coded pixel (`x`, `y`) (its ray going down): 0 to 1 as the depth
    /// rises to the rim's. The plain form of the lanes' `cover_span`, its reference.
    #[cfg(test)]
    fn cover(&self, x: usize, y: usize) -> f32 {
        let (xy, per_px) = self.footprint(x, y);
        self.water_cover(xy, per_px)
    }

    /// The ground point of coded pixel (`x`, `y`) (its ray going down) and its change per
    /// pixel along x and y (`ground_per_px`: the ray is affine in the pixel, `dx` and `dy` per
    /// pixel).
    #[inline(always)]
    fn footprint(&self, x: usize, y: usize) -> (Vec2, [Vec2; 2]) {
        let g = self.ground;
        let ray = g.ray(x, y);
        let ground_z_m = g.height_m() / -ray.z;
        let ground = g.camera + ground_z_m * ray;
        let per_px = |r: Vec3| {
            let v = ground_z_m * (r - ray * (r.z / ray.z));
            Vec2::new(v.x, v.y)
        };
        (Vec2::new(ground.x, ground.y), [per_px(g.dx), per_px(g.dy)])
    }

    /// The water's cover at ground point `xy` for a pixel whose ground point moves by `per_px`:
    /// the mean of [`Puddles::probe_cover`] over the pieces of a footprint longer than
    /// [`PROBE_CELLS`] along an axis ([`Puddles::pieces`]), one probe where it is not
    /// ([`Puddles::one_probe`]).
    #[cfg(test)]
    fn water_cover(&self, xy: Vec2, per_px: [Vec2; 2]) -> f32 {
        if self.one_probe(per_px) {
            return self.probe_cover(xy, per_px);
        }
        let mut cover = 0.0;
        if let Some(pieces) = self.pieces(xy, per_px) {
            for i in 0..pieces.len(0) {
                for j in 0..pieces.len(1) {
                    if let Some((weight, at, per)) = pieces.piece(i, j) {
                        cover += weight * self.probe_cover(at, per);
                    }
                }
            }
        }
        cover
    }

    /// Whether a footprint moving by `per_px` is read in one probe: it spans at most
    /// [`PROBE_CELLS`] along each axis (most pixels).
    #[inline(always)]
    fn one_probe(&self, per_px: [Vec2; 2]) -> bool {
        let reach = PROBE_CELLS * self.water.params.cell_m;
        per_px[0].length_squared().max(per_px[1].length_squared()) <= reach * reach
    }

    /// The pieces of the long footprint at `xy` moving by `per_px`; `None` where its cells (and
    /// a margin of the probes' reach) hold no water. The cover is the sum of weight ×
    /// [`Puddles::probe_cover`] over [`Pieces::piece`] of each pair of pieces along the two
    /// axes, the first axis outside (the twin's order).
    #[inline(always)]
    fn pieces(&self, xy: Vec2, per_px: [Vec2; 2]) -> Option<Pieces> {
        let p = &self.water.params;
        // Every probe reads cells within two of its point, which lies in the footprint's box.
        let half = (per_px[0].abs() + per_px[1].abs()) * (0.5 / p.cell_m);
        let u = (xy - Vec2::from_array(p.origin_m)) / p.cell_m - Vec2::splat(0.5);
        if self.cells_dry(u - half, u + half) {
            return None;
        }
        let reach = PROBE_CELLS * p.cell_m;
        Some(Pieces {
            xy,
            per_px,
            along: [
                footprint_pieces(reach / per_px[0].length()),
                footprint_pieces(reach / per_px[1].length()),
            ],
        })
    }

    /// What the 4×4 cells a probe at ground point `xy` reads settle of its cover: 0 where none
    /// may hold water ([`Puddles::probe_cover`]'s first test), 1 where all are deep
    /// ([`WetBlocks::window_deep`]), else `None`.
    #[inline(always)]
    fn probe_settled(&self, xy: Vec2) -> Option<f32> {
        let p = &self.water.params;
        let u = (xy - Vec2::from_array(p.origin_m)) / p.cell_m - Vec2::splat(0.5);
        let i0 = u.floor();
        let (i, j) = (i0.x as i64, i0.y as i64);
        if !self.wet.window_wet(i, j) {
            Some(0.0)
        } else if self.wet.window_deep(i, j) {
            Some(1.0)
        } else {
            None
        }
    }

    /// Whether no cell that a probe at a point of the box `lo..hi` (in cells, from the first
    /// cell's centre) reads is wet: those within two cells of the box, one more for rounding.
    #[inline(always)]
    fn cells_dry(&self, lo: Vec2, hi: Vec2) -> bool {
        let p = &self.water.params;
        let (nx, ny) = (p.cells[0] as f32, p.cells[1] as f32);
        let (a, b) = ((lo - 2.0).floor(), (hi + 3.0).floor());
        if !(a.is_finite() && b.is_finite()) {
            return false;
        }
        if b.x < 0.0 || b.y < 0.0 || a.x >= nx || a.y >= ny {
            return true;
        }
        let (a, b) = (a.max(Vec2::ZERO), b.min(Vec2::new(nx - 1.0, ny - 1.0)));
        !self
            .wet
            .any((a.x as usize, b.x as usize), (a.y as usize, b.y as usize))
    }

    /// One probe's cover at ground point `xy`, its footprint moving by `per_px`: the mean of
    /// smoothstep(0, rim depth, depth) over a box of the footprint's width across the rim
    /// ([`rim_cover`]), the depth read by Catmull-Rom over the 4×4 cells around it, 0 off
    /// the map, clamped to the four nearest cells' range widened where the footprint passes
    /// their square (the twin's `footprint_range`), its change per pixel by Catmull-Rom's
    /// derivative along `per_px` (`probe_cover` of puddles.wgsl and of the twin, in their
    /// order: each row along x, then the rows along y). The clamp settles the cover from its
    /// range alone where it is all dry or all deeper than the rim (most of the ground): the
    /// same value, without the rest of the reading.
    #[inline(always)]
    fn probe_cover(&self, xy: Vec2, per_px: [Vec2; 2]) -> f32 {
        let p = &self.water.params;
        let (nx, ny) = (p.cells[0] as i64, p.cells[1] as i64);
        let u = (xy - Vec2::from_array(p.origin_m)) / p.cell_m - Vec2::splat(0.5);
        let i0 = u.floor();
        let f = u - i0;
        let (i0, j0) = (i0.x as i64 - 1, i0.y as i64 - 1);
        // No wet cell among the sixteen: the range is all dry (the shortcut below, sooner;
        // `probe_settled`).
        if !self.wet.window_wet(i0 + 1, j0 + 1) {
            return 0.0;
        }
        let map = self.water.depth_m;
        let inside = i0 >= 0 && j0 >= 0 && i0 + 4 <= nx && j0 + 4 <= ny;
        let cell = |i: i64, j: i64| {
            if inside || ((0..nx).contains(&i) && (0..ny).contains(&j)) {
                map[(j * nx + i) as usize]
            } else {
                0.0
            }
        };
        let near = [
            cell(i0 + 1, j0 + 1),
            cell(i0 + 2, j0 + 1),
            cell(i0 + 1, j0 + 2),
            cell(i0 + 2, j0 + 2),
        ];
        let (mut lo, mut hi) = (
            near[0].min(near[1]).min(near[2].min(near[3])),
            near[0].max(near[1]).max(near[2].max(near[3])),
        );
        let edge = p.edge_depth_m;
        // Widened toward the twelve cells around the four where the footprint passes their
        // square (the twin's `footprint_range`).
        let half = (per_px[0].abs() + per_px[1].abs()) * (0.5 / p.cell_m);
        let (before, after) = (
            (half - f).clamp(Vec2::ZERO, Vec2::ONE),
            (f + half - Vec2::ONE).clamp(Vec2::ZERO, Vec2::ONE),
        );
        if before.max(after).max_element() > 0.0 {
            let reach_x = [before.x, 1.0, 1.0, after.x];
            let reach_y = [before.y, 1.0, 1.0, after.y];
            let (mut down, mut up) = (0f32, 0f32);
            for (b, ry) in reach_y.iter().enumerate() {
                for (a, rx) in reach_x.iter().enumerate() {
                    let v = cell(i0 + a as i64, j0 + b as i64);
                    down = down.max(rx * ry * (lo - v).max(0.0));
                    up = up.max(rx * ry * (v - hi).max(0.0));
                }
            }
            (lo, hi) = (lo - down, hi + up);
        }
        if hi <= 0.0 {
            return 0.0;
        }
        if lo >= edge {
            return 1.0;
        }
        let (wx, wy) = (catmull_rom(f.x), catmull_rom(f.y));
        let sx = catmull_rom_slope(f.x);
        let row = |w: &[f32; 4], j: i64| {
            w[0] * cell(i0, j)
                + w[1] * cell(i0 + 1, j)
                + w[2] * cell(i0 + 2, j)
                + w[3] * cell(i0 + 3, j)
        };
        let rows = [
            row(&wx, j0),
            row(&wx, j0 + 1),
            row(&wx, j0 + 2),
            row(&wx, j0 + 3),
        ];
        let dot = |w: [f32; 4], v: [f32; 4]| w[0] * v[0] + w[1] * v[1] + w[2] * v[2] + w[3] * v[3];
        let sum = dot(wy, rows);
        let along_x = dot(
            wy,
            [
                row(&sx, j0),
                row(&sx, j0 + 1),
                row(&sx, j0 + 2),
                row(&sx, j0 + 3),
            ],
        );
        let along_y = dot(catmull_rom_slope(f.y), rows);
        let grad = Vec2::new(along_x, along_y) / p.cell_m;
        let width = Vec2::new(grad.dot(per_px[0]), grad.dot(per_px[1])).length();
        rim_cover(sum, lo, hi, width, edge)
    }

    /// The rings (indices, in ring order) whose annulus R ± 4 s meets the ground under the
    /// block from (`x0`, `y0`): the box of its four corner pixels' ground points; every ring
    /// where a corner looks at or above the horizon (`cull_rings` of puddles.wgsl).
    fn rings_near(&self, x0: usize, y0: usize, width: usize, height: usize) -> Vec<u32> {
        let g = self.ground;
        let rings = self.ripples();
        let (x1, y1) = (
            (x0 + BLOCK - 1).min(width - 1),
            (y0 + BLOCK - 1).min(height - 1),
        );
        let mut bounded = g.height_m() > 0.0;
        let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
        for (x, y) in [(x0, y0), (x1, y0), (x0, y1), (x1, y1)] {
            let ray = g.ray(x, y);
            bounded &= ray.z < 0.0;
            let at = Vec2::new(g.camera.x, g.camera.y)
                + (g.height_m() / -ray.z) * Vec2::new(ray.x, ray.y);
            lo = lo.min(at);
            hi = hi.max(at);
        }
        (0..rings.len() as u32)
            .filter(|&i| {
                let ring = &rings[i as usize];
                let c = Vec2::from_array(ring.centre_m);
                let nearest = c.clamp(lo, hi).distance(c);
                let farthest = (lo - c).abs().max((hi - c).abs()).length();
                let reach = 4.0 * ring.width_m;
                !bounded || (nearest <= ring.radius_m + reach && farthest >= ring.radius_m - reach)
            })
            .collect()
    }

    fn ripples(&self) -> &[Ripple] {
        let n = (self.water.params.ring_count as usize).min(self.water.ripples.len());
        &self.water.ripples[..n]
    }

    /// The water at coded pixel (`x`, `y`) of cover `cover`: `l` the frame's linear colour,
    /// `t` the haze's transmittance, `s` its in-scatter plus the lamps' glow (per unit of
    /// opacity, as the decode laid them), `held` the picture before the
    /// water, `rings` the block's; `None` where the pixel does not show the ground.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn pixel(
        &self,
        x: usize,
        y: usize,
        cover: f32,
        l: Vec3,
        t: f32,
        s: Vec3,
        held: Vec3,
        rings: &[u32],
        picture: &Picture,
    ) -> Option<Vec3> {
        let g = self.ground;
        let ray = g.ray(x, y);
        let d = ray.normalize();
        let ground_z_m = g.height_m() / -ray.z;
        let p = g.camera + ground_z_m * ray;
        let scene_m = g.scene_depth_m(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
        let shown = ground_shown(scene_m, ground_z_m) * g.weight(x, y, scene_m);
        if shown <= 0.0 {
            return None;
        }
        let w = &self.water.params;
        let optics = [w.water_index, w.diffuse_external, w.diffuse_internal];
        let k = darkening(l, self.e_up, optics, -d.z);
        let slope = self.ripple_slope(Vec2::new(p.x, p.y), rings);
        let normal = Vec3::new(-slope.x, -slope.y, 1.0).normalize();
        let cos_i = (-d.dot(normal)).max(0.0);
        let mirrored = d + 2.0 * cos_i * normal;
        let r = reflectance(w.water_index, cos_i);
        let a = cover * shown;
        let seen = self.rough_reflected(p, d, slope, mirrored, ground_z_m, picture);
        let change = (k - Vec3::ONE) * l + r * seen;
        let in_scatter = if t >= 1.0 { Vec3::ZERO } else { (1.0 - t) * s };
        let water = l * t + in_scatter + t * change;
        Some(held + a * (water - held))
    }

    /// The gradient of the water's height at `xy`: each kept ring's radial slope along r̂.
    #[inline(always)]
    fn ripple_slope(&self, xy: Vec2, rings: &[u32]) -> Vec2 {
        let all = self.ripples();
        let mut g = Vec2::ZERO;
        for &i in rings {
            let ring = &all[i as usize];
            let off = xy - Vec2::from_array(ring.centre_m);
            let r = off.length();
            let u = r - ring.radius_m;
            if u.abs() > 4.0 * ring.width_m || r < 1e-6 {
                continue;
            }
            let s2 = ring.width_m * ring.width_m;
            let envelope = (-0.5 * u * u / s2).exp();
            let carrier = ring.wavenumber * r - ring.phase;
            let dr = ring.amplitude_m
                * envelope
                * (-u / s2 * carrier.cos() - ring.wavenumber * carrier.sin());
            g += dr * off / r;
        }
        g
    }

    /// The reflection along `mirrored`, blurred beyond the resolved depth by the far water's
    /// RMS slope (the mean of four slopes moved by ±σ along x and y; `rough_reflected`).
    #[inline(always)]
    fn rough_reflected(
        &self,
        p: Vec3,
        d: Vec3,
        slope: Vec2,
        mirrored: Vec3,
        depth_m: f32,
        picture: &Picture,
    ) -> Vec3 {
        let w = &self.water.params;
        let s = w.resolve_depth_m;
        let sigma = if w.far_slope_rms <= 0.0 {
            0.0
        } else {
            w.far_slope_rms * smoothstep(s, 2.0 * s, depth_m)
        };
        // The smooth water's one ray, else the four rough ones; one call of the (inlined)
        // reflection.
        let smooth = sigma <= 0.0;
        let rough = !smooth;
        let mut sum = Vec3::ZERO;
        for i in 0..if rough { 4 } else { 1 } {
            let dir = if rough {
                let axis = if i < 2 { Vec2::X } else { Vec2::Y };
                let tilt = if i & 1 == 0 { sigma } else { -sigma } * axis;
                let n = Vec3::new(-(slope.x + tilt.x), -(slope.y + tilt.y), 1.0).normalize();
                let c = (-d.dot(n)).max(0.0);
                d + 2.0 * c * n
            } else {
                mirrored
            };
            let seen = self.reflected(p, dir, picture);
            if !rough {
                return seen;
            }
            sum += seen;
        }
        0.25 * sum
    }

    /// The radiance the water at ground point `p` mirrors along unit direction `dir`.
    #[inline(always)]
    fn reflected(&self, p: Vec3, dir: Vec3, picture: &Picture) -> Vec3 {
        let q = self
            .march(p, dir, picture)
            .unwrap_or_else(|| self.camera_dir(dir));
        if q.z <= 1e-6 {
            return self.environment(p, dir);
        }
        let at = self.project(q);
        let w = smoothstep(0.0, EDGE_PX, picture.inside(at));
        if w <= 0.0 {
            return self.environment(p, dir);
        }
        if w >= 1.0 {
            return picture.sample(at);
        }
        self.environment(p, dir).lerp(picture.sample(at), w)
    }

    /// Where the mirrored ray from `p` along `dir` first passes behind the filmed scene
    /// (camera space), if a depth map is set and it does within the frame (`march`).
    #[inline(always)]
    fn march(&self, p: Vec3, dir: Vec3, picture: &Picture) -> Option<Vec3> {
        if !self.ground.has_depth() {
            return None;
        }
        let q_p = self.to_camera(p);
        let q_dir = self.camera_dir(dir);
        if q_dir.z <= 1e-6 {
            return None;
        }
        let distance = |share: f32| share * q_p.z / ((1.0 - share) * q_dir.z);
        let image_px = self.project(q_dir).distance(self.project(q_p));
        let steps = (image_px / MARCH_STRIDE_PX)
            .ceil()
            .clamp(1.0, MARCH_MAX_STEPS as f32) as u32;
        let size = Vec2::new(picture.width as f32, picture.height as f32);
        let mut before = 0.0;
        for i in 1..=steps {
            let share = MARCH_FARTHEST * i as f32 / steps as f32;
            let q = q_p + distance(share) * q_dir;
            let at = self.project(q);
            if !(at.cmpge(Vec2::ZERO).all() && at.cmplt(size).all()) {
                return None;
            }
            if self.behind(q) {
                let (mut lo, mut hi) = (before, share);
                for _ in 0..MARCH_HALVINGS {
                    let mid = 0.5 * (lo + hi);
                    if self.behind(q_p + distance(mid) * q_dir) {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return Some(q_p + distance(hi) * q_dir);
            }
            before = share;
        }
        None
    }

    /// Whether camera-space point `q` lies behind the scene's surface at its pixel (but not
    /// far), where that surface stands on the ground (`behind`).
    #[inline(always)]
    fn behind(&self, q: Vec3) -> bool {
        if q.z <= 0.0 {
            return false;
        }
        let g = self.ground;
        let at = self.project(q);
        let z = g.scene_depth_m(at);
        if z <= 0.0 || q.z < z || q.z > z * (1.0 + MARCH_THICKNESS) {
            return false;
        }
        let px = at.floor().max(Vec2::ZERO);
        let ray = g.ray(px.x as u32 as usize, px.y as u32 as usize);
        ray.z >= 0.0 || z < 0.9 * g.height_m() / -ray.z
    }

    /// World direction `dir` in the camera's frame.
    #[inline(always)]
    fn camera_dir(&self, dir: Vec3) -> Vec3 {
        let r = &self.ground.rows;
        Vec3::new(r[0].dot(dir), r[1].dot(dir), r[2].dot(dir))
    }

    /// World point `w` in the camera's frame.
    #[inline(always)]
    fn to_camera(&self, w: Vec3) -> Vec3 {
        self.camera_dir(w - self.ground.camera)
    }

    /// Coded pixel position of camera-space point `q` (`project`).
    #[inline(always)]
    fn project(&self, q: Vec3) -> Vec2 {
        let g = self.ground;
        let s = g.principal + g.focal * Vec2::new(q.x, q.y) / q.z;
        g.coded(s)
    }

    /// What lies along `dir` from ground point `p` outside the frame: the SH environment, and
    /// each lamp as a normalised von Mises–Fisher lobe about its direction from `p`.
    #[inline(always)]
    fn environment(&self, p: Vec3, dir: Vec3) -> Vec3 {
        let mut c = self.ground.sky(dir);
        let kappa = self.water.params.light_lobe;
        let from_camera = p - self.ground.camera;
        let count = (self.lights.count as usize).min(MAX_LIGHTS);
        for l in &self.lights.lights[..count] {
            let [lx, ly, lz, d] = l.direction_distance;
            let omega = Vec3::new(lx, ly, lz);
            let (seen, scale) = if d <= 0.0 {
                (omega, 1.0)
            } else {
                let to_light = omega * d - from_camera;
                let r = to_light.length();
                let q = d / r.max(l.strength[3]);
                (if r > 0.0 { to_light / r } else { omega }, q * q)
            };
            let lobe = kappa / (2.0 * PI) * (kappa * (seen.dot(dir) - 1.0)).exp();
            c += Vec3::new(l.strength[0], l.strength[1], l.strength[2]) * (scale * lobe);
        }
        c
    }
}

/// The pieces of a long footprint ([`Puddles::pieces`]) along its two axes.
struct Pieces {
    xy: Vec2,
    per_px: [Vec2; 2],
    along: [AxisPieces; 2],
}

impl Pieces {
    /// How many pieces along axis `axis` (0: the first), those of no length included.
    #[inline(always)]
    fn len(&self, axis: usize) -> usize {
        self.along[axis].len()
    }

    /// The probe of piece `i` along the first axis and piece `j` along the second: its weight
    /// (its share of the footprint), its ground point and its own change per pixel; `None`
    /// where either piece has no length (it adds nothing).
    #[inline(always)]
    fn piece(&self, i: usize, j: usize) -> Option<(f32, Vec2, [Vec2; 2])> {
        let ((ta, la), (tb, lb)) = (self.along[0].piece(i), self.along[1].piece(j));
        if !(la > 0.0 && lb > 0.0) {
            return None;
        }
        let at = self.xy + ta * self.per_px[0] + tb * self.per_px[1];
        Some((la * lb, at, [la * self.per_px[0], lb * self.per_px[1]]))
    }
}

/// Whether the CPU runs the puddles' AVX2 build (AVX2, and F16C for the picture's texels).
fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("f16c");
    #[cfg(not(target_arch = "x86_64"))]
    false
}
