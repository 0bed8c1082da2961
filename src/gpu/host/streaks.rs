//! The streaks rasterised on the CPU (the `rain_streaks` stage's work, for the CPU back end):
//! binned to 64 × 32 px tiles in drop order, each band of tiles (a row of them) sorting its own
//! streaks on its own thread; each tile with streaks goes to f32 once, blends its streaks in
//! drop order (premultiplied, `src + dst·(1 − α)`, as the stage's blend state) in runs along
//! each streak's steeper axis over the pixels it can cover, [`LANES`] pixels of a run at a
//! time (the capsule's coverage, or the matte's bilinear reads with the layers chosen once per
//! streak), and goes back to f16. Tiles no streak reaches are not read or written, and a pixel
//! no streak covers keeps its bits (f16 → f32 → f16 is exact). On x86-64 with AVX2 and F16C
//! the same code is compiled a second time (8 lanes a vector, the tiles converted by F16C) and
//! picked at run time; it gives the same bits. The plain twin
//! [`crate::gpu::cpu::rain_streaks`] is the reference (`tests/backend.rs`); every pixel is
//! computed from its own coordinates and its streak's run direction, so the result does not
//! depend on the tiles, the threads or the instruction set. A renderer keeps one [`Raster`]:
//! its records, bins and tiles are reused from frame to frame.
// Lane loops index several arrays by the lane: the form the vectoriser reads best.
#![allow(clippy::needless_range_loop)]

use half::f16;
use rayon::prelude::*;

use super::blend::blend;
use super::streak_mattes::{Matte, matte_of, matte_run};
use super::streak_runs::runs_of;
use crate::drops::MatteAtlas;
use crate::drops::atlas::HALF_WIDTH_RADII;
use crate::gpu::cpu::rain_streaks::{AA_MARGIN_PX, OCCLUSION_SOFTNESS_M};
use crate::gpu::types::{Glint, RainParams, Streak};

/// A tile's width and height, px: a tile's f32 pixels (32 KiB) stay in the first-level cache
/// while its streaks blend.
pub const TILE_W: usize = 64;
/// See [`TILE_W`].
pub const TILE_H: usize = 32;

/// One drawn streak in the raster's terms (f32), in the slot of its drop; copied into the list
/// of each band of tiles it reaches, so a band reads its streaks from contiguous memory.
#[derive(Clone, Copy, Default)]
pub(super) struct Prepared {
    /// Along and across the streak (px from q0) at coded pixel (x, y)'s centre:
    /// `f[0] + x f[1] + y f[2]` (formed in f64).
    pub(super) along: [f32; 3],
    pub(super) across: [f32; 3],
    pub(super) len: f32,
    /// 1 / len, and 1 / (len + 2 ext) (the radiance's interpolation along the quad).
    pub(super) inv_len: f32,
    pub(super) inv_quad: f32,
    pub(super) r: f32,
    /// The quad's half-extent along (beyond each end) and across.
    pub(super) ext: f32,
    pub(super) across_ext: f32,
    pub(super) alpha_scale: f32,
    pub(super) radiance: [[f32; 3]; 2],
    /// The drop's depth at the path's ends (camera z, m).
    pub(super) depth_m: [f32; 2],
    /// Coded pixels the quad's box reaches (inclusive), clamped to the picture.
    pub(super) x0: u32,
    pub(super) x1: u32,
    pub(super) y0: u32,
    pub(super) y1: u32,
    /// Its index in the raster's [`Matte`]s ([`NO_MATTE`]: a capsule).
    pub(super) matte: u32,
}

/// [`Prepared::matte`] of a capsule.
const NO_MATTE: u32 = u32::MAX;

/// The display rotation: display = mᵀ (coded − offset) for pixel centres.
#[derive(Clone, Copy)]
struct Rotation {
    m: [f32; 4],
    offset: [f32; 2],
}

impl Rotation {
    fn new(p: &RainParams) -> Rotation {
        Rotation {
            m: p.coded_from_display,
            offset: p.coded_offset_px,
        }
    }

    /// Display coordinates of coded point (x, y).
    #[inline]
    fn display(&self, x: f32, y: f32) -> [f32; 2] {
        let (dx, dy) = (x - self.offset[0], y - self.offset[1]);
        [
            self.m[0] * dx + self.m[1] * dy,
            self.m[2] * dx + self.m[3] * dy,
        ]
    }

    /// Coded coordinates of display point (x, y).
    fn coded(&self, x: f32, y: f32) -> [f32; 2] {
        [
            self.m[0] * x + self.m[2] * y + self.offset[0],
            self.m[1] * x + self.m[3] * y + self.offset[1],
        ]
    }
}

/// Streaks drawn and tiles touched by one raster.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RasterCount {
    /// Streaks with a quad on the picture.
    pub streaks: usize,
    /// Tiles at least one quad's box reaches.
    pub tiles: usize,
}

/// The rain's inputs besides the streaks: the uniforms, the mattes and glints where streaks
/// are drawn with mattes, and the scene's depth per displayed pixel (metres, 0 unknown).
pub struct Rain<'a> {
    /// The frame's uniforms.
    pub params: &'a RainParams,
    /// The streak mattes (`None`: capsules).
    pub mattes: Option<&'a MatteAtlas>,
    /// [`GLINTS_PER_DROP`] per drop, as `rain_simulate`'s `main_mattes` writes them (may be
    /// empty: no glints).
    pub glints: &'a [Glint],
    /// The scene's depth per displayed pixel, row-major, metres (0: unknown).
    pub depth: Option<&'a [f32]>,
}

/// Blends `streaks` (one per drop, `len_px < 0`: not drawn) over `canvas` (RGBA f16, row-major,
/// the coded picture of `rain.params.coded_size_px`, `width` texels a row), with buffers of its
/// own (a renderer keeps a [`Raster`] instead).
pub fn rasterise(canvas: &mut [f16], width: usize, rain: &Rain, streaks: &[Streak]) -> RasterCount {
    Raster::default().draw(canvas, width, rain, streaks)
}

/// [`rasterise`] without the AVX2 build: the same bits (`tests/backend.rs` holds them equal).
pub fn rasterise_baseline(
    canvas: &mut [f16],
    width: usize,
    rain: &Rain,
    streaks: &[Streak],
) -> RasterCount {
    Raster::default().draw_baseline(canvas, width, rain, streaks)
}

/// Whether the CPU runs the raster's AVX2 build (AVX2 for the lanes, F16C for the tiles).
fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("f16c");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Streaks prepared per rayon task.
const PREPARE_CHUNK: usize = 1024;

/// [`Raster::bands`] of a streak not drawn.
const NO_BANDS: [u32; 2] = [1, 0];

/// The raster's buffers, kept from frame to frame: after the first frame a raster allocates
/// nothing and touches no fresh page (a 1080p frame's records alone are ~7.6 MB). Each drop's
/// record is written in its own slot by the thread that prepares it, so nothing is gathered or
/// concatenated; the bins hold drop indices, and each drop's bands sit in an array of their
/// own, so binning reads 8 bytes a drop, not its record.
#[derive(Default)]
pub struct Raster {
    /// Each drop's record (valid where its bands are).
    prepared: Vec<Prepared>,
    /// Each drop's first and last band of tiles ([`NO_BANDS`]: not drawn).
    bands: Vec<[u32; 2]>,
    /// Each drop's matte (with mattes; valid where its bands are).
    mattes: Vec<Matte>,
    /// Where each band's drops start in `in_band`, and a cursor per band while binning.
    band_start: Vec<u32>,
    fill: Vec<u32>,
    /// The drops of each band, in drop order.
    in_band: Vec<u32>,
    /// Each band of tiles' own buffers.
    band: Vec<BandBuffers>,
}

/// What one band of tiles works in: its streaks' records side by side, those of each tile
/// (indices into them, drop order kept), and a tile in f32.
#[derive(Default)]
pub(super) struct BandBuffers {
    local: Vec<Prepared>,
    start: Vec<u32>,
    fill: Vec<u32>,
    order: Vec<u32>,
    tile: Vec<f32>,
}

/// What every band of tiles reads: the inputs, each drop's record and matte.
struct Frame<'a> {
    rain: &'a Rain<'a>,
    rot: Rotation,
    prepared: &'a [Prepared],
    mattes: &'a [Matte],
    width: usize,
    tiles_x: usize,
}

impl Raster {
    /// [`rasterise`] in this raster's buffers.
    pub fn draw(
        &mut self,
        canvas: &mut [f16],
        width: usize,
        rain: &Rain,
        streaks: &[Streak],
    ) -> RasterCount {
        self.draw_on(canvas, width, rain, streaks, true, |_, _| {})
    }

    /// [`Raster::draw`], `ready` called once the streaks are binned and before any tile is
    /// drawn, with the canvas and the tiles the draw will read and write: where the canvas
    /// holds the plate only in some tiles, it lays the plate in the others first.
    pub fn draw_over(
        &mut self,
        canvas: &mut [f16],
        width: usize,
        rain: &Rain,
        streaks: &[Streak],
        ready: impl FnOnce(&mut [f16], &Reached),
    ) -> RasterCount {
        self.draw_on(canvas, width, rain, streaks, true, ready)
    }

    /// [`Raster::draw`] without the AVX2 build (see [`rasterise_baseline`]).
    pub fn draw_baseline(
        &mut self,
        canvas: &mut [f16],
        width: usize,
        rain: &Rain,
        streaks: &[Streak],
    ) -> RasterCount {
        self.draw_on(canvas, width, rain, streaks, false, |_, _| {})
    }

    fn draw_on(
        &mut self,
        canvas: &mut [f16],
        width: usize,
        rain: &Rain,
        streaks: &[Streak],
        avx2: bool,
        ready: impl FnOnce(&mut [f16], &Reached),
    ) -> RasterCount {
        let height = canvas.len() / (4 * width.max(1));
        let (binned, buffers) = self.bin((width, height), rain, streaks, avx2);
        ready(canvas, &binned.reached());
        let tiles = canvas
            .par_chunks_mut(4 * width * TILE_H)
            .zip(buffers.par_iter_mut())
            .enumerate()
            .map(|(ty, (rows, buffers))| binned.draw_band(ty, rows, buffers))
            .sum();
        RasterCount {
            streaks: binned.drawn,
            tiles,
        }
    }

    /// `streaks` prepared and binned for a picture of `width` × `height`, ready to be drawn
    /// band of tiles by band ([`Binned::draw_band`], each with its own of the buffers
    /// returned, one a band): the first half of a draw, which a caller that lays and packs the
    /// canvas band by band runs once for the frame.
    pub(super) fn bin<'a>(
        &'a mut self,
        (width, height): (usize, usize),
        rain: &'a Rain<'a>,
        streaks: &[Streak],
        avx2: bool,
    ) -> (Binned<'a>, &'a mut [BandBuffers]) {
        let rot = Rotation::new(rain.params);
        let n = streaks.len();
        // Grown, never shrunk: the splashes' few streaks do not cost the drops' slots.
        if self.prepared.len() < n {
            self.prepared.resize(n, Prepared::default());
            self.bands.resize(n, NO_BANDS);
        }
        let avx2 = avx2 && has_avx2();
        let (prepared, bands) = (&mut self.prepared[..n], &mut self.bands[..n]);
        let size = (width, height);
        prepared
            .par_chunks_mut(PREPARE_CHUNK)
            .zip(bands.par_chunks_mut(PREPARE_CHUNK))
            .zip(streaks.par_chunks(PREPARE_CHUNK))
            .for_each(|((prepared, bands), streaks)| {
                prepare_on(avx2, rain, &rot, streaks, size, prepared, bands);
            });
        let mattes: &[Matte] = match rain.mattes {
            Some(atlas) => {
                if self.mattes.len() < n {
                    self.mattes.resize_with(n, Matte::default);
                }
                self.mattes[..n]
                    .par_iter_mut()
                    .zip(prepared.par_iter_mut())
                    .zip(bands.par_iter())
                    .zip(streaks.par_iter())
                    .enumerate()
                    .filter(|(_, ((_, b), _))| b[0] <= b[1])
                    .for_each(|(id, (((m, p), _), s))| {
                        *m = matte_of(rain, atlas, id, s);
                        p.matte = id as u32;
                    });
                &self.mattes[..n]
            }
            None => &[],
        };
        let tiles_x = width.div_ceil(TILE_W);
        let tiles_y = height.div_ceil(TILE_H);
        // Each band of tiles' streaks by index, drop order kept (a counting sort); each band
        // sorts its own by tile.
        let start = &mut self.band_start;
        start.clear();
        start.resize(tiles_y + 1, 0);
        let mut drawn = 0;
        for b in bands.iter().filter(|b| b[0] <= b[1]) {
            drawn += 1;
            for ty in b[0]..=b[1] {
                start[ty as usize + 1] += 1;
            }
        }
        for k in 1..start.len() {
            start[k] += start[k - 1];
        }
        let fill = &mut self.fill;
        fill.clear();
        fill.extend_from_slice(start);
        let in_band = &mut self.in_band;
        in_band.resize(start[tiles_y] as usize, 0);
        for (i, b) in bands.iter().enumerate() {
            for ty in b[0]..=b[1] {
                in_band[fill[ty as usize] as usize] = i as u32;
                fill[ty as usize] += 1;
            }
        }
        if self.band.len() < tiles_y {
            self.band.resize_with(tiles_y, BandBuffers::default);
        }
        let frame = Frame {
            rain,
            rot,
            prepared,
            mattes,
            width,
            tiles_x,
        };
        let binned = Binned {
            frame,
            start,
            in_band,
            avx2,
            drawn,
        };
        (binned, &mut self.band[..tiles_y])
    }
}

/// A frame's streaks prepared and binned by band of tiles ([`Raster::bin`]).
pub(super) struct Binned<'a> {
    frame: Frame<'a>,
    start: &'a [u32],
    in_band: &'a [u32],
    avx2: bool,
    /// Streaks with a quad on the picture.
    pub(super) drawn: usize,
}

impl Binned<'_> {
    /// The tiles the draw reads and writes.
    pub(super) fn reached(&self) -> Reached<'_> {
        Reached {
            prepared: self.frame.prepared,
            start: self.start,
            in_band: self.in_band,
            tiles_x: self.frame.tiles_x,
        }
    }

    /// Draws band `ty` of tiles over `rows` (its [`TILE_H`] rows of the canvas, or fewer at
    /// the picture's foot) in `buffers` (the band's own); returns the tiles drawn.
    pub(super) fn draw_band(
        &self,
        ty: usize,
        rows: &mut [f16],
        buffers: &mut BandBuffers,
    ) -> usize {
        let list = &self.in_band[self.start[ty] as usize..self.start[ty + 1] as usize];
        band_on(self.avx2, &self.frame, ty, list, rows, buffers)
    }
}

/// The tiles one raster reads and writes: those within a drawn streak's box (see
/// [`Raster::draw_over`]).
pub struct Reached<'a> {
    prepared: &'a [Prepared],
    start: &'a [u32],
    in_band: &'a [u32],
    tiles_x: usize,
}

impl Reached<'_> {
    /// Sets `map[ty · tiles_x + tx]` for every tile reached, `tiles_x` tiles a row (leaving
    /// the rest as they are): the tiles [`band`] draws.
    pub fn mark(&self, map: &mut [bool]) {
        map.par_chunks_mut(self.tiles_x)
            .enumerate()
            .for_each(|(ty, row)| {
                let list = &self.in_band[self.start[ty] as usize..self.start[ty + 1] as usize];
                for &i in list {
                    let p = &self.prepared[i as usize];
                    row[p.x0 as usize / TILE_W..=p.x1 as usize / TILE_W].fill(true);
                }
            });
    }
}

/// [`prepare`] for each of `streaks` into its slot of `prepared` and its bands into `bands`
/// ([`NO_BANDS`] where it is not drawn), in the AVX2 build where `avx2` (the CPU has it: the
/// roundings inline, no library calls; the same bits).
fn prepare_on(
    avx2: bool,
    rain: &Rain,
    rot: &Rotation,
    streaks: &[Streak],
    size: (usize, usize),
    prepared: &mut [Prepared],
    bands: &mut [[u32; 2]],
) {
    #[inline(always)]
    fn each(
        rain: &Rain,
        rot: &Rotation,
        streaks: &[Streak],
        (width, height): (usize, usize),
        prepared: &mut [Prepared],
        bands: &mut [[u32; 2]],
    ) {
        for ((slot, band), s) in prepared.iter_mut().zip(bands).zip(streaks) {
            *band = match prepare(rain, rot, s, width, height) {
                Some(p) => {
                    *slot = p;
                    [p.y0 / TILE_H as u32, p.y1 / TILE_H as u32]
                }
                None => NO_BANDS,
            };
        }
    }
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        #[target_feature(enable = "avx2,f16c")]
        fn fast(
            rain: &Rain,
            rot: &Rotation,
            streaks: &[Streak],
            size: (usize, usize),
            prepared: &mut [Prepared],
            bands: &mut [[u32; 2]],
        ) {
            each(rain, rot, streaks, size, prepared, bands);
        }
        // SAFETY: `avx2` is set only where the CPU has AVX2 and F16C (`Raster::draw_on`).
        unsafe { fast(rain, rot, streaks, size, prepared, bands) };
        return;
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = avx2;
    each(rain, rot, streaks, size, prepared, bands);
}

/// [`band`], in the AVX2 build where `avx2` (the CPU has it).
fn band_on(
    avx2: bool,
    frame: &Frame,
    ty: usize,
    list: &[u32],
    canvas: &mut [f16],
    buffers: &mut BandBuffers,
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        #[target_feature(enable = "avx2,f16c")]
        fn fast(
            frame: &Frame,
            ty: usize,
            list: &[u32],
            canvas: &mut [f16],
            buffers: &mut BandBuffers,
        ) -> usize {
            band(frame, ty, list, canvas, buffers, true)
        }
        // SAFETY: `avx2` is set only where the CPU has AVX2 and F16C (`Raster::draw_on`).
        return unsafe { fast(frame, ty, list, canvas, buffers) };
    }
    band(frame, ty, list, canvas, buffers, false)
}

/// Draws band `ty` of tiles (`canvas`: its rows), whose streaks are `list` (drop indices in
/// drop order), in `buffers`: each tile with streaks goes to f32, blends them in drop order and
/// goes back to f16 ([`super::tile`]; `simd`: in the AVX2 build, the tiles converted by F16C and the
/// capsules blended eight pixels at a time, [`super::blend`]). Returns the tiles drawn.
#[inline(always)]
fn band(
    frame: &Frame,
    ty: usize,
    list: &[u32],
    canvas: &mut [f16],
    buffers: &mut BandBuffers,
    simd: bool,
) -> usize {
    let (width, tiles_x) = (frame.width, frame.tiles_x);
    let BandBuffers {
        local,
        start,
        fill,
        order,
        tile,
    } = buffers;
    // The band's streaks side by side (read in one sweep, then from the cache), sorted by
    // tile with drop order kept.
    local.clear();
    local.extend(list.iter().map(|&i| frame.prepared[i as usize]));
    let span = |p: &Prepared| p.x0 as usize / TILE_W..=p.x1 as usize / TILE_W;
    start.clear();
    start.resize(tiles_x + 1, 0);
    for p in local.iter() {
        for tx in span(p) {
            start[tx + 1] += 1;
        }
    }
    for k in 1..start.len() {
        start[k] += start[k - 1];
    }
    fill.clear();
    fill.extend_from_slice(start);
    order.resize(start[tiles_x] as usize, 0);
    for (i, p) in local.iter().enumerate() {
        for tx in span(p) {
            order[fill[tx] as usize] = i as u32;
            fill[tx] += 1;
        }
    }
    let rows = canvas.len() / (4 * width);
    // Every texel a tile's streaks read is loaded first: the buffer needs no clearing.
    tile.resize(4 * TILE_W * TILE_H, 0.0);
    let mut drawn = 0;
    for tx in 0..tiles_x {
        let list = &order[start[tx] as usize..start[tx + 1] as usize];
        if list.is_empty() {
            continue;
        }
        drawn += 1;
        let (x0, cols) = (tx * TILE_W, TILE_W.min(width - tx * TILE_W));
        // The next tile's texels are asked for while this one's streaks blend.
        if tx + 1 < tiles_x {
            let next = &canvas[4 * (x0 + TILE_W)..];
            super::tile::prefetch(next, 4 * width, rows, 4 * TILE_W.min(width - x0 - TILE_W));
        }
        for r in 0..rows {
            super::tile::load(
                &canvas[4 * (r * width + x0)..][..4 * cols],
                &mut tile[4 * r * TILE_W..][..4 * cols],
                simd,
            );
        }
        let area = Area {
            x0,
            x1: x0 + cols - 1,
            y0: ty * TILE_H,
            y1: ty * TILE_H + rows - 1,
        };
        for &i in list {
            let p = &local[i as usize];
            let matte = frame.mattes.get(p.matte as usize);
            draw(frame.rain, &frame.rot, p, matte, &area, tile, simd);
        }
        for r in 0..rows {
            super::tile::store(
                &tile[4 * r * TILE_W..][..4 * cols],
                &mut canvas[4 * (r * width + x0)..][..4 * cols],
                simd,
            );
        }
    }
    drawn
}

/// A tile's coded pixels (inclusive).
pub(super) struct Area {
    pub(super) x0: usize,
    pub(super) x1: usize,
    pub(super) y0: usize,
    pub(super) y1: usize,
}

/// Streak `s` in the raster's terms, or `None` where it is not drawn or its quad misses the
/// picture.
#[inline(always)]
fn prepare(
    rain: &Rain,
    rot: &Rotation,
    s: &Streak,
    width: usize,
    height: usize,
) -> Option<Prepared> {
    // Hidden (negative length; NaN as well).
    if s.len_px.is_nan() || s.len_px < 0.0 {
        return None;
    }
    let (len, r) = (s.len_px, s.r_eff_px);
    let ext = r + AA_MARGIN_PX as f32;
    let across_ext = match rain.mattes {
        None => ext,
        Some(_) => ext.max(HALF_WIDTH_RADII as f32 * r),
    };
    // The quad's corners, display → coded; its box, a pixel wider for rounding.
    let (q0, d) = (s.q0_px, s.dir);
    let n = [-d[1], d[0]];
    let mut lo = [f32::INFINITY; 2];
    let mut hi = [f32::NEG_INFINITY; 2];
    for along in [-ext, len + ext] {
        for across in [-across_ext, across_ext] {
            let c = rot.coded(
                q0[0] + d[0] * along + n[0] * across,
                q0[1] + d[1] * along + n[1] * across,
            );
            for k in 0..2 {
                lo[k] = lo[k].min(c[k]);
                hi[k] = hi[k].max(c[k]);
            }
        }
    }
    let on_picture =
        hi[0] >= 0.0 && hi[1] >= 0.0 && lo[0] <= width as f32 && lo[1] <= height as f32;
    if !on_picture {
        return None;
    }
    let clamp = |v: f32, n: usize| (v.max(0.0) as usize).min(n - 1) as u32;
    // display = M (coded − offset): along = dir · (display − q0), across = n · (display − q0).
    let m = rot.m.map(f64::from);
    let (off, q) = (rot.offset.map(f64::from), q0.map(f64::from));
    let form = |u: [f64; 2]| {
        let at0 = [
            m[0] * (0.5 - off[0]) + m[1] * (0.5 - off[1]) - q[0],
            m[2] * (0.5 - off[0]) + m[3] * (0.5 - off[1]) - q[1],
        ];
        [
            (u[0] * at0[0] + u[1] * at0[1]) as f32,
            (u[0] * m[0] + u[1] * m[2]) as f32,
            (u[0] * m[1] + u[1] * m[3]) as f32,
        ]
    };
    let (dir64, n64) = (d.map(f64::from), n.map(f64::from));
    let prepared = Prepared {
        along: form(dir64),
        across: form(n64),
        len,
        inv_len: if len >= 1e-3 { 1.0 / len } else { 0.0 },
        inv_quad: 1.0 / (len + 2.0 * ext),
        r,
        ext,
        across_ext,
        alpha_scale: s.alpha_scale,
        radiance: [
            [s.radiance0[0], s.radiance0[1], s.radiance0[2]],
            [s.radiance1[0], s.radiance1[1], s.radiance1[2]],
        ],
        depth_m: [s.radiance0[3], s.radiance1[3]],
        x0: clamp((lo[0] - 1.0).floor(), width),
        x1: clamp((hi[0] + 1.0).ceil(), width),
        y0: clamp((lo[1] - 1.0).floor(), height),
        y1: clamp((hi[1] + 1.0).ceil(), height),
        matte: NO_MATTE,
    };
    Some(prepared)
}

/// The larger of `a` and `b`, as one instruction (neither is NaN here).
#[inline(always)]
pub(super) fn larger(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// The smaller of `a` and `b` (see [`larger`]).
#[inline(always)]
pub(super) fn smaller(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// Blends streak `p` (with its `matte`) over the part of `tile` (f32 RGBA, [`TILE_W`] texels a
/// row) in `area`: in runs along the coded picture's rows or, for a streak steeper than 45°
/// there, along its columns, so that the runs are long. The direction is the streak's alone,
/// so each pixel's value does not depend on the tile. `simd`: capsules blended in the AVX2
/// build's form ([`super::blend`]).
#[inline(always)]
fn draw<'a>(
    rain: &Rain<'a>,
    rot: &Rotation,
    p: &Prepared,
    matte: Option<&Matte>,
    area: &Area,
    tile: &mut [f32],
    simd: bool,
) {
    let Some((rows, columns, (v0, v1))) = runs_of(p, matte.is_none(), area) else {
        return;
    };
    let Some((v0, v1)) = rows.reached(v0, v1) else {
        return;
    };
    for v in v0..=v1 {
        let Some((along_v, across_v, first, last)) = rows.row(v) else {
            continue;
        };
        let (x, y, stride) = if columns {
            (v, first, 4 * TILE_W)
        } else {
            (first, v, 4)
        };
        let at = 4 * ((y - area.y0) * TILE_W + x - area.x0);
        let run = Run {
            along: along_v,
            across: across_v,
            da: rows.along[2],
            dc: rows.across[2],
            first,
            count: last - first + 1,
            stride,
        };
        // Unknown depth (0) shows the drop times exactly 1: the same bits as no map.
        let occluded = |map: &'a [f32]| {
            move |k: usize, along: f32| {
                let (x, y) = if columns {
                    (v, first + k)
                } else {
                    (first + k, v)
                };
                let at = rot.display(x as f32 + 0.5, y as f32 + 0.5);
                visibility(rain.params, map, at, along, p)
            }
        };
        let px = &mut tile[at..];
        match (matte, rain.mattes, rain.depth) {
            (None, _, None) => capsule_run(p, &run, px, simd, |_, _| 1.0),
            (None, _, Some(map)) => capsule_run(p, &run, px, simd, occluded(map)),
            (Some(m), Some(atlas), None) => matte_run(p, m, atlas, &run, px, |_, _| 1.0),
            (Some(m), Some(atlas), Some(map)) => matte_run(p, m, atlas, &run, px, occluded(map)),
            (Some(_), None, _) => {}
        }
    }
}

/// A run of pixels: at coordinate `u` along it, `along + u · da` and `across + u · dc`; from
/// `first`, `count` pixels `stride` floats apart.
pub(super) struct Run {
    pub(super) along: f32,
    pub(super) across: f32,
    pub(super) da: f32,
    pub(super) dc: f32,
    pub(super) first: usize,
    pub(super) count: usize,
    pub(super) stride: usize,
}

/// Pixels of a run taken side by side: the capsule's arithmetic is one loop over this many
/// lanes (one AVX2 vector, two SSE ones), the blend a loop of its own over the pixels.
pub(super) const LANES: usize = super::blend::LANES;

/// Blends capsule `p` over `run` (its first pixel at `px[0..4]`) without branches, the alpha
/// of its `k`-th pixel times `shown(k, along)`: a pixel the disc misses blends with α = 0,
/// which leaves it exactly as it was. Each lane computes its pixel from the pixel's own
/// coordinate with the same operations, so the lanes, and the instruction set, change no bit;
/// the blend takes eight pixels at once where `simd` ([`super::blend`]: the same bits).
#[inline(always)]
fn capsule_run(
    p: &Prepared,
    run: &Run,
    px: &mut [f32],
    simd: bool,
    shown: impl Fn(usize, f32) -> f32,
) {
    let (r2, len) = (p.r * p.r, p.len);
    let [r0, r1] = p.radiance;
    let dr = [r1[0] - r0[0], r1[1] - r0[1], r1[2] - r0[2]];
    let still = len < 1e-3;
    // Clamps as selects (the vectoriser's min and max).
    let (at_least, at_most) = (larger, smaller);
    let mut k0 = 0;
    while k0 < run.count {
        let (mut alpha, mut t, mut along) = ([0f32; LANES], [0f32; LANES], [0f32; LANES]);
        // Pixel coordinates are far below 2²⁴: exact as i32 and as f32.
        let u0 = (run.first + k0) as i32;
        for l in 0..LANES {
            let uf = (u0 + l as i32) as f32;
            let a = run.along + uf * run.da;
            let across = run.across + uf * run.dc;
            let h = at_least(r2 - across * across, 0.0).sqrt();
            let swept = (at_most(at_least(a + h, 0.0), len) - at_most(at_least(a - h, 0.0), len))
                * p.inv_len;
            let here = if a.abs() < h { 1.0 } else { 0.0 };
            let cover = if still { here } else { swept };
            alpha[l] = at_most(at_least(cover * p.alpha_scale, 0.0), 1.0);
            t[l] = (a + p.ext) * p.inv_quad;
            along[l] = a;
        }
        let n = LANES.min(run.count - k0);
        // Every lane (those past the run are not blended; `shown` reads any pixel safely).
        let mut a = [0f32; LANES];
        for l in 0..LANES {
            a[l] = alpha[l] * shown(k0 + l, along[l]);
        }
        blend(
            &mut px[k0 * run.stride..],
            run.stride,
            n,
            &a,
            &t,
            r0,
            dr,
            simd,
        );
        k0 += LANES;
    }
}

/// How much of the drop shows at display point `at`, `along` px down its path, in front of
/// the scene's depth there (the twin's `visibility` of `drop_depth_m`).
fn visibility(params: &RainParams, map: &[f32], at: [f32; 2], along: f32, p: &Prepared) -> f32 {
    let (w, h) = (
        params.display_size_px[0] as usize,
        params.display_size_px[1] as usize,
    );
    if map.len() < w * h || w == 0 || h == 0 {
        return 1.0;
    }
    let px = (at[0].floor().max(0.0) as usize).min(w - 1);
    let py = (at[1].floor().max(0.0) as usize).min(h - 1);
    let scene = map[py * w + px];
    if scene <= 0.0 {
        return 1.0;
    }
    let t = if p.len >= 1e-3 {
        (along / p.len).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let drop = 1.0 / ((1.0 - t) / p.depth_m[0] + t / p.depth_m[1]);
    let x = ((scene - drop) / OCCLUSION_SOFTNESS_M as f32 + 0.5).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}
