//! Planes → the hazed linear canvas on the CPU (the `yuv_to_rgb` stage's work): code values to
//! normalised Y'CbCr (exact; Y' a row at a time, the chroma's terms of the matrix once per
//! chroma sample and chroma row, spread over the pixels and rows that share it), the matrix,
//! the transfer through a fine table, the haze's veil
//! ([`super::veil`]), then f16, eight pixels at a time (one cell of the veil's grid) in lanes
//! the compiler vectorises; on x86-64 with AVX2 and F16C the same code is compiled a second
//! time, the table read by gathers ([`super::lanes`]), and picked at run time. On 8-bit
//! pictures R and B, which depend on two codes each, come from exact tables by code
//! (`CodeTables`). Every pixel is computed with the same operations in the same order either
//! way (Rust never fuses a multiply and an add), so both builds give the same bits
//! (`tests/backend.rs`).

// Lane loops index several arrays by the lane: the form the vectoriser reads best.
#![allow(clippy::needless_range_loop)]

use half::f16;
use rayon::prelude::*;

use super::lanes::{self, LANES, gather, gather_pairs};
use super::streaks::{TILE_H, TILE_W};
use super::veil::{GridPoint, Veil};
use super::wet_ground::WetGround;
use crate::gpu::stages::yuv_to_rgb::GLOW_CELL_PX;
use crate::video::color::eotf_signed;
use crate::video::{ColorParams, FrameFormat, Transfer, YuvFrame};

/// Rows per unit of work: a few, so both cores stay busy on small pictures too.
const BAND_ROWS: usize = 8;

/// Encoded values the transfer's table spans, from 0 (odd-extended below). Out-of-gamut
/// chroma reaches about 2.6; beyond the table the exact function runs.
const EOTF_SPAN: f32 = 4.0;

/// Steps of the transfer's table over [0, `EOTF_SPAN`]: linear interpolation between steps of
/// 1/4096 is within 1e-7 of the function, well inside the f16 canvas's half step (2.4e-4
/// relative), so the table costs no code value.
const EOTF_STEPS: usize = 16384;

// A lane block is one cell of the veil's grid: its pixels share the cell's two grid columns.
const _: () = assert!(GLOW_CELL_PX as usize == LANES);
// A tile is whole lane blocks.
const _: () = assert!(TILE_W.is_multiple_of(LANES));

/// The transfer (encoded → linear, odd-extended) as a table interpolated linearly. The
/// transfer follows the matrix, so it is a function of three codes, not one: no exact
/// per-code table exists for it. Each step keeps its own and the next value side by side, so
/// the eight lanes' two values come from one read each.
pub struct Eotf {
    transfer: Transfer,
    /// The table at steps `i` and `i + 1`, for `i` in `0..EOTF_STEPS`.
    pairs: Vec<[f32; 2]>,
}

impl Eotf {
    /// The table of `transfer`.
    pub fn new(transfer: Transfer) -> Eotf {
        let step = f64::from(EOTF_SPAN) / EOTF_STEPS as f64;
        let at = |i: usize| eotf_signed(transfer, i as f64 * step) as f32;
        let pairs = (0..EOTF_STEPS).map(|i| [at(i), at(i + 1)]).collect();
        Eotf { transfer, pairs }
    }

    /// Linear light of encoded value `e`.
    #[inline]
    pub fn apply(&self, e: f32) -> f32 {
        let at = e.abs() * (EOTF_STEPS as f32 / EOTF_SPAN);
        if at < EOTF_STEPS as f32 {
            let i = at as usize;
            let [a, b] = self.pairs[i];
            (a + (b - a) * (at - i as f32)).copysign(e)
        } else {
            eotf_signed(self.transfer, f64::from(e)) as f32
        }
    }

    /// [`apply`](Self::apply) to eight lanes, with the same operations; `avx2`: the table read
    /// by gathers (see [`lanes::gather_pairs`]).
    #[inline(always)]
    fn lanes(&self, e: [f32; LANES], avx2: bool) -> [f32; LANES] {
        let last = (EOTF_STEPS - 1) as f32;
        let (mut at, mut i) = ([0f32; LANES], [0i32; LANES]);
        let mut inside = true;
        for l in 0..LANES {
            at[l] = e[l].abs() * (EOTF_STEPS as f32 / EOTF_SPAN);
            inside &= at[l] < EOTF_STEPS as f32;
            // The far side of the table (and NaN) reads its last step; the exact function
            // follows.
            let clamped = at[l].min(last);
            // SAFETY: `clamped` is finite and in [0, EOTF_STEPS − 1] (`at` is an absolute
            // value or NaN, and `min` takes `last` over NaN), so it truncates to an i32.
            i[l] = unsafe { clamped.to_int_unchecked::<i32>() };
        }
        let mut step = [0u32; LANES];
        for l in 0..LANES {
            step[l] = i[l] as u32;
        }
        let (a, b) = gather_pairs(&self.pairs, step, avx2);
        let mut out = [0f32; LANES];
        for l in 0..LANES {
            out[l] = (a[l] + (b[l] - a[l]) * (at[l] - i[l] as f32)).copysign(e[l]);
        }
        if !inside {
            for l in 0..LANES {
                out[l] = self.apply(e[l]);
            }
        }
        out
    }
}

/// For 8-bit codes, linear R and B as exact tables over the two codes each depends on: R' is
/// Y' + `cr_r` Cr and B' is Y' + `cb_b` Cb, so each entry is [`Eotf::apply`] of the value the
/// lanes form from that luma code and that chroma code, and a pixel's R or B is one read
/// instead of the transfer's two and its interpolation. (G' mixes three codes: it keeps the
/// transfer's table.) 256 KiB each, indexed `luma · 256 + chroma`.
struct CodeTables {
    r: Vec<f32>,
    b: Vec<f32>,
}

/// Code values → linear RGB for one picture format.
pub struct Decoder {
    format: FrameFormat,
    /// Y' = (code − `y_offset`) / `y_scale`, C = (code − `c_offset`) / `c_scale`: integers, so
    /// the f32 quotient is the exact value rounded once.
    y_offset: f32,
    y_scale: f32,
    c_offset: f32,
    c_scale: f32,
    /// R' = Y' + `cr_r` Cr, G' = Y' − `cb_g` Cb − `cr_g` Cr, B' = Y' + `cb_b` Cb.
    cr_r: f32,
    cb_g: f32,
    cr_g: f32,
    cb_b: f32,
    eotf: Eotf,
    /// R and B by their codes (8-bit pictures, unless turned off: the plain form then).
    code_tables: Option<Box<CodeTables>>,
    /// Whether the AVX2 build runs (the CPU has AVX2 and F16C, and it was not turned off).
    avx2: bool,
}

impl Decoder {
    /// The decoder of frames of `format` coded in `color`.
    pub fn new(format: FrameFormat, color: &ColorParams) -> Decoder {
        let s = color.range_scale();
        let (kr, kb) = color.matrix.kr_kb();
        let kg = 1.0 - kr - kb;
        let mut decoder = Decoder {
            format,
            y_offset: s.y_offset as f32,
            y_scale: s.y_scale as f32,
            c_offset: s.c_offset as f32,
            c_scale: s.c_scale as f32,
            cr_r: (2.0 * (1.0 - kr)) as f32,
            cb_g: (2.0 * kb * (1.0 - kb) / kg) as f32,
            cr_g: (2.0 * kr * (1.0 - kr) / kg) as f32,
            cb_b: (2.0 * (1.0 - kb)) as f32,
            eotf: Eotf::new(color.transfer),
            code_tables: None,
            avx2: lanes::has_avx2_f16c(),
        };
        decoder.set_code_tables(format.bit_depth == 8);
        decoder
    }

    /// Turns the AVX2 build off where `off` (the same bits, slower).
    pub(super) fn set_baseline(&mut self, off: bool) {
        self.avx2 = !off && lanes::has_avx2_f16c();
    }

    /// R and B read from [`CodeTables`] where `on` (8-bit pictures only), else through the
    /// transfer's table as G: the same bits.
    pub(super) fn set_code_tables(&mut self, on: bool) {
        self.code_tables = (on && self.format.bit_depth == 8).then(|| {
            let code = |v: u32| v as f32;
            let table = |k: f32| -> Vec<f32> {
                (0..1u32 << 16)
                    .map(|i| {
                        let luma = (code(i >> 8) - self.y_offset) / self.y_scale;
                        let c = (code(i & 255) - self.c_offset) / self.c_scale;
                        self.eotf.apply(luma + k * c)
                    })
                    .collect()
            };
            Box::new(CodeTables {
                r: table(self.cr_r),
                b: table(self.cb_b),
            })
        });
    }

    /// Writes the linear canvas of `frame` under `veil` (RGBA f16, alpha 1) into `canvas`, the
    /// wet ground `wet` fused in where given (it reads the plate before the haze, the haze's
    /// transmittance and in-scatter of the same row).
    pub fn decode(
        &self,
        frame: &YuvFrame,
        veil: Option<&Veil>,
        wet: Option<&WetGround>,
        canvas: &mut [f16],
    ) {
        let w = self.format.width as usize;
        canvas
            .par_chunks_mut(4 * w * BAND_ROWS)
            .enumerate()
            .for_each_init(RowScratch::default, |scratch, (band, out)| {
                let at = Band {
                    frame,
                    veil,
                    wet,
                    y0: band * BAND_ROWS,
                };
                self.band_on(&at, out, scratch);
            });
    }

    /// Rows `y0`… of the canvas [`decode`](Self::decode) writes, into `out` (whole rows,
    /// `4 · width` texels each): each pixel as `decode` lays it, for a caller that works band
    /// by band.
    pub(super) fn decode_rows(
        &self,
        frame: &YuvFrame,
        (veil, wet): (Option<&Veil>, Option<&WetGround>),
        y0: usize,
        out: &mut [f16],
        scratch: &mut RowScratch,
    ) {
        let at = Band {
            frame,
            veil,
            wet,
            y0,
        };
        self.band_on(&at, out, scratch);
    }

    /// The rows of a band of the canvas (`out`), in the AVX2 build where the decoder runs it.
    fn band_on(&self, at: &Band, out: &mut [f16], s: &mut RowScratch) {
        let w = self.format.width as usize;
        s.chroma_row = None;
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            #[target_feature(enable = "avx2,f16c")]
            fn fast(d: &Decoder, at: &Band, out: &mut [f16], s: &mut RowScratch, w: usize) {
                for (k, row) in out.chunks_exact_mut(4 * w).enumerate() {
                    d.row(at, (at.y0 + k) as u32, row, s, true);
                }
            }
            // SAFETY: `avx2` is set only where the CPU has AVX2 and F16C
            // (`lanes::has_avx2_f16c`).
            return unsafe { fast(self, at, out, s, w) };
        }
        for (k, row) in out.chunks_exact_mut(4 * w).enumerate() {
            self.row(at, (at.y0 + k) as u32, row, s, false);
        }
    }

    /// Row `y` of the canvas into `out`, a lane block (one cell of the veil's grid) at a time:
    /// the plate, the veil, then f16 (through RGBA f32 on a row the wet ground reaches; it
    /// reads the plate before the haze and the haze's row).
    #[inline(always)]
    fn row(&self, at: &Band, y: u32, out: &mut [f16], s: &mut RowScratch, avx2: bool) {
        let w = self.format.width as usize;
        self.row_codes(at.frame, y, s);
        if let Some(v) = at.veil {
            s.transmittance.resize(w, 0.0);
            s.finite.resize(w, false);
            v.transmittance_row(y, &mut s.transmittance, &mut s.finite);
            s.transmittance.resize(s.y.len(), 1.0);
            s.finite.resize(s.y.len(), true);
            v.grid_row(y, &mut s.grid);
        }
        let wet = at.wet.filter(|g| g.touches(y as usize));
        if wet.is_some() {
            s.plate.resize(4 * w, 0.0);
            s.rgba.resize(4 * w, 0.0);
        }
        for x0 in (0..w).step_by(LANES) {
            let n = LANES.min(w - x0);
            let mut rgb = self.plate_lanes(s, x0, avx2);
            if wet.is_some() {
                put_rgba(&rgb, &mut s.plate[4 * x0..][..4 * n]);
            }
            if at.veil.is_some() {
                let cell = x0 / LANES;
                let (t, finite) = (&s.transmittance[x0..], &s.finite[x0..]);
                veil_lanes(&mut rgb, t, finite, &s.grid[cell], &s.grid[cell + 1]);
            }
            if wet.is_some() {
                put_rgba(&rgb, &mut s.rgba[4 * x0..][..4 * n]);
            } else {
                store_lanes(&rgb, &mut out[4 * x0..][..4 * n], avx2);
            }
        }
        if let Some(g) = wet {
            let haze = at.veil.map(|_| (&s.transmittance[..w], &s.grid[..]));
            g.row(y as usize, &s.plate, haze, &mut s.rgba);
            super::tile::store(&s.rgba, out, avx2);
        }
    }

    /// Lays the plate of `frame` alone (no haze, no wet ground: then the canvas is the plate)
    /// in the tiles set in `need` (one flag per [`TILE_W`] × [`TILE_H`] tile, row-major) of
    /// `canvas`, each pixel as [`decode`](Self::decode) lays it; the other tiles keep their bits.
    pub fn decode_tiles(&self, frame: &YuvFrame, need: &[bool], canvas: &mut [f16]) {
        let w = self.format.width as usize;
        canvas
            .par_chunks_mut(4 * w * TILE_H)
            .zip(need.par_chunks(w.div_ceil(TILE_W)))
            .enumerate()
            .filter(|(_, (_, need))| need.contains(&true))
            .for_each_init(RowScratch::default, |s, (ty, (out, need))| {
                self.tiles_on(frame, ty * TILE_H, need, out, s);
            });
    }

    /// [`tiles`](Self::tiles), in the AVX2 build where the decoder runs it.
    fn tiles_on(
        &self,
        frame: &YuvFrame,
        y0: usize,
        need: &[bool],
        out: &mut [f16],
        s: &mut RowScratch,
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            #[target_feature(enable = "avx2,f16c")]
            fn fast(
                d: &Decoder,
                frame: &YuvFrame,
                y0: usize,
                need: &[bool],
                out: &mut [f16],
                s: &mut RowScratch,
            ) {
                d.tiles(frame, y0, need, out, s, true);
            }
            // SAFETY: `avx2` is set only where the CPU has AVX2 and F16C
            // (`lanes::has_avx2_f16c`).
            return unsafe { fast(self, frame, y0, need, out, s) };
        }
        self.tiles(frame, y0, need, out, s, false);
    }

    /// The plate in the tiles set in `need` along the rows from `y0` (`out`: those rows).
    #[inline(always)]
    fn tiles(
        &self,
        frame: &YuvFrame,
        y0: usize,
        need: &[bool],
        out: &mut [f16],
        s: &mut RowScratch,
        avx2: bool,
    ) {
        let w = self.format.width as usize;
        s.chroma_row = None;
        for (k, row) in out.chunks_exact_mut(4 * w).enumerate() {
            self.row_codes(frame, (y0 + k) as u32, s);
            for (tx, _) in need.iter().enumerate().filter(|(_, n)| **n) {
                for x0 in (tx * TILE_W..((tx + 1) * TILE_W).min(w)).step_by(LANES) {
                    let n = LANES.min(w - x0);
                    let rgb = self.plate_lanes(s, x0, avx2);
                    store_lanes(&rgb, &mut row[4 * x0..][..4 * n], avx2);
                }
            }
        }
    }

    /// The plate's linear RGBA along row `y` (alpha 1).
    pub(super) fn plate_row(&self, frame: &YuvFrame, y: u32, rgba: &mut [f32], s: &mut RowScratch) {
        let w = self.format.width as usize;
        s.chroma_row = None;
        self.row_codes(frame, y, s);
        for x0 in (0..w).step_by(LANES) {
            let n = LANES.min(w - x0);
            put_rgba(
                &self.plate_lanes(s, x0, false),
                &mut rgba[4 * x0..][..4 * n],
            );
        }
    }

    /// The codes of row `y` into `s`: luma, and each chroma code over the pixels that share it,
    /// padded with zeros to whole lane blocks; the normalised luma Y' per pixel, and each
    /// channel's chroma term (`cr_r` Cr, −(`cb_g` Cb + `cr_g` Cr), `cb_b` Cb: R' G' B' are Y'
    /// plus them) per chroma sample, spread over its pixels. A chroma row is read and its terms
    /// formed once for the rows that share it (two in 4:2:0), while `s.chroma_row` says which
    /// row they are (the callers clear it for each frame).
    #[inline(always)]
    fn row_codes(&self, frame: &YuvFrame, y: u32, s: &mut RowScratch) {
        let f = self.format;
        let w = f.width as usize;
        let (_, sy) = f.chroma.shift();
        let cy = (y >> sy) as usize;
        let padded = w.div_ceil(LANES) * LANES;
        codes(frame, 0, y as usize, w, &mut s.y);
        s.y.resize(padded, 0);
        // Zipped slices: no bounds checks, so the loops vectorise.
        s.luma.resize(padded, 0.0);
        let (y_offset, y_scale) = (self.y_offset, self.y_scale);
        for (luma, &code) in s.luma.iter_mut().zip(&s.y) {
            *luma = (f32::from(code) - y_offset) / y_scale;
        }
        if s.chroma_row != Some(cy) {
            self.chroma_codes(frame, cy, s);
        }
        if self.code_tables.is_some() {
            // Each pixel's entry in the R and B tables: its luma code and its chroma code.
            s.at_r.resize(padded, 0);
            s.at_b.resize(padded, 0);
            for (at, (&y, &c)) in s.at_r.iter_mut().zip(s.y.iter().zip(&s.cr)) {
                *at = u32::from(y) << 8 | u32::from(c);
            }
            for (at, (&y, &c)) in s.at_b.iter_mut().zip(s.y.iter().zip(&s.cb)) {
                *at = u32::from(y) << 8 | u32::from(c);
            }
        }
    }

    /// Chroma row `cy`'s codes and terms into `s` (see [`row_codes`](Self::row_codes)).
    #[inline(always)]
    fn chroma_codes(&self, frame: &YuvFrame, cy: usize, s: &mut RowScratch) {
        let f = self.format;
        let w = f.width as usize;
        let (sx, _) = f.chroma.shift();
        let (cw, _) = f.plane_size(1);
        let padded = w.div_ceil(LANES) * LANES;
        s.chroma_row = Some(cy);
        let cw = cw as usize;
        // The chroma row's codes and terms per chroma sample, in `s.cb`, `s.cr` and `s.terms`
        // first, spread over the pixels after.
        codes(frame, 1, cy, cw, &mut s.chroma);
        codes(frame, 2, cy, cw, &mut s.chroma_cr);
        // With the code tables only G' needs its term.
        let all = self.code_tables.is_none();
        let [r, g, b] = &mut s.terms;
        for (k, out) in [&mut *r, &mut *g, &mut *b].into_iter().enumerate() {
            out.clear();
            if all || k == 1 {
                out.resize(cw, 0.0);
            }
        }
        let (c_offset, c_scale) = (self.c_offset, self.c_scale);
        let (cr_r, cb_g, cr_g, cb_b) = (self.cr_r, self.cb_g, self.cr_g, self.cb_b);
        let pairs = || s.chroma.iter().zip(&s.chroma_cr);
        for (g, (&cb, &cr)) in g.iter_mut().zip(pairs()) {
            let cb = (f32::from(cb) - c_offset) / c_scale;
            let cr = (f32::from(cr) - c_offset) / c_scale;
            *g = -(cb_g * cb + cr_g * cr);
        }
        if all {
            for ((r, b), (&cb, &cr)) in r.iter_mut().zip(b.iter_mut()).zip(pairs()) {
                let cb = (f32::from(cb) - c_offset) / c_scale;
                let cr = (f32::from(cr) - c_offset) / c_scale;
                *r = cr_r * cr;
                *b = cb_b * cb;
            }
        }
        spread(&s.chroma, sx, w, padded, &mut s.cb);
        spread(&s.chroma_cr, sx, w, padded, &mut s.cr);
        for (terms, out) in s.terms.iter().zip(&mut s.term_px) {
            if terms.is_empty() {
                out.clear();
            } else {
                spread(terms, sx, w, padded, out);
            }
        }
    }

    /// Linear R, G and B of the eight pixels from `x0` of the row in `s` ([`row_codes`](Self::row_codes)).
    #[inline(always)]
    fn plate_lanes(&self, s: &RowScratch, x0: usize, avx2: bool) -> [[f32; LANES]; 3] {
        let luma = &s.luma[x0..][..LANES];
        let eotf = &self.eotf;
        if let Some(t) = &self.code_tables {
            let term = &s.term_px[1][x0..][..LANES];
            let mut g = [0f32; LANES];
            for l in 0..LANES {
                g[l] = luma[l] + term[l];
            }
            // Codes of an 8-bit picture are below 256: each index lies inside the tables.
            let (mut at_r, mut at_b) = ([0u32; LANES], [0u32; LANES]);
            at_r.copy_from_slice(&s.at_r[x0..][..LANES]);
            at_b.copy_from_slice(&s.at_b[x0..][..LANES]);
            return [
                gather(&t.r, at_r, 0, avx2),
                eotf.lanes(g, avx2),
                gather(&t.b, at_b, 0, avx2),
            ];
        }
        let mut e = [[0f32; LANES]; 3];
        for c in 0..3 {
            let term = &s.term_px[c][x0..][..LANES];
            for l in 0..LANES {
                e[c][l] = luma[l] + term[l];
            }
        }
        // No closures here: they would leave the AVX2 build.
        [
            eotf.lanes(e[0], avx2),
            eotf.lanes(e[1], avx2),
            eotf.lanes(e[2], avx2),
        ]
    }
}

/// What a band's rows read.
struct Band<'a> {
    frame: &'a YuvFrame,
    veil: Option<&'a Veil<'a>>,
    wet: Option<&'a WetGround<'a>>,
    y0: usize,
}

/// Per-band buffers, reused row after row.
#[derive(Default)]
pub(super) struct RowScratch {
    /// The row's codes per pixel, padded to whole lane blocks.
    y: Vec<u16>,
    cb: Vec<u16>,
    cr: Vec<u16>,
    /// A chroma row's Cb and Cr codes.
    chroma: Vec<u16>,
    chroma_cr: Vec<u16>,
    /// The normalised luma Y' per pixel.
    luma: Vec<f32>,
    /// The chroma terms of R', G' and B' per chroma sample (those the decoder needs; the
    /// others empty), and per pixel.
    terms: [Vec<f32>; 3],
    term_px: [Vec<f32>; 3],
    /// The chroma row `cb`, `cr` and the terms hold (`None`: none yet for this frame).
    chroma_row: Option<usize>,
    /// Each pixel's entries in the R and B code tables (8-bit pictures).
    at_r: Vec<u32>,
    at_b: Vec<u32>,
    /// The row as RGBA f32, and the plate before the haze (rows the wet ground reaches).
    rgba: Vec<f32>,
    plate: Vec<f32>,
    transmittance: Vec<f32>,
    finite: Vec<bool>,
    grid: Vec<GridPoint>,
}

/// The first `n` codes of row `y` of plane `i` into `out`, clamped to the depth's largest code
/// (a stray high bit in a 10-bit sample stays in range).
#[inline(always)]
fn codes(frame: &YuvFrame, i: usize, y: usize, n: usize, out: &mut Vec<u16>) {
    let p = &frame.planes[i];
    let max = ((1u32 << frame.format.bit_depth) - 1) as u16;
    out.clear();
    if frame.format.bytes_per_sample() == 1 {
        out.extend(p.data[y * p.stride..][..n].iter().map(|&v| u16::from(v)));
    } else {
        out.extend(
            p.data[y * p.stride..][..2 * n]
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]).min(max)),
        );
    }
}

/// The values of a chroma row (`row`) spread over the `w` pixels of a luma row (each over
/// 2^`shift` pixels), padded with zeros to `padded`, into `out`.
#[inline(always)]
fn spread<T: Copy + Default>(row: &[T], shift: u32, w: usize, padded: usize, out: &mut Vec<T>) {
    out.clear();
    if shift == 0 {
        out.extend_from_slice(&row[..w.min(row.len())]);
    } else {
        out.resize(2 * row.len(), T::default());
        for (pair, &v) in out.chunks_exact_mut(2).zip(row) {
            pair[0] = v;
            pair[1] = v;
        }
        out.truncate(w);
    }
    out.resize(padded, T::default());
}

/// The first `out.len() / 4` lanes of `rgb` as RGBA f16 texels (alpha 1) into `out`.
#[inline(always)]
fn store_lanes(rgb: &[[f32; LANES]; 3], out: &mut [f16], avx2: bool) {
    if out.len() == 4 * LANES {
        lanes::store_rgb(rgb, out, avx2);
    } else {
        let mut texels = [f16::ZERO; 4 * LANES];
        lanes::store_rgb(rgb, &mut texels, avx2);
        out.copy_from_slice(&texels[..out.len()]);
    }
}

/// The first `out.len() / 4` lanes of `rgb` as RGBA f32 (alpha 1) into `out`.
#[inline(always)]
fn put_rgba(rgb: &[[f32; LANES]; 3], out: &mut [f32]) {
    for (l, px) in out.chunks_exact_mut(4).enumerate() {
        px.copy_from_slice(&[rgb[0][l], rgb[1][l], rgb[2][l], 1.0]);
    }
}

/// `plate · T' + (1 − T') · S + (1 − T) · L` over a lane block (`t`, `finite`: from its first
/// pixel; `a`, `b`: its cell's grid columns), T' = T + (1 − T) · sky where the pixel's
/// distance is not known finite (see [`super::veil`]).
#[inline(always)]
fn veil_lanes(
    rgb: &mut [[f32; LANES]; 3],
    t: &[f32],
    finite: &[bool],
    a: &GridPoint,
    b: &GridPoint,
) {
    let (t, finite) = (&t[..LANES], &finite[..LANES]);
    // The pixels' places in their cell: the interpolation's weights.
    let f: [f32; LANES] = std::array::from_fn(|l| (l as f32 + 0.5) / LANES as f32);
    let mut veil = [0f32; LANES];
    for l in 0..LANES {
        // The sky's weight, or +0 where the distance is known: a mask, not a branch (the
        // select stays in the lanes).
        let open = a[6] + (b[6] - a[6]) * f[l];
        let keep = 0u32.wrapping_sub(u32::from(!finite[l]));
        let sky = f32::from_bits(open.to_bits() & keep);
        veil[l] = t[l] + (1.0 - t[l]) * sky;
    }
    // A channel at a time, its lanes side by side.
    for c in 0..3 {
        for l in 0..LANES {
            let (s, g) = (
                a[c] + (b[c] - a[c]) * f[l],
                a[c + 3] + (b[c + 3] - a[c + 3]) * f[l],
            );
            rgb[c][l] = rgb[c][l] * veil[l] + (1.0 - veil[l]) * s + (1.0 - t[l]) * g;
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::video::{ColorParams, Matrix, Transfer};

    /// With R and B read from the 8-bit code tables the decode gives the plain form's bits
    /// (every R and B through the transfer's table) on a picture holding every pair of luma
    /// and chroma codes, in both ranges and several matrices and transfers, with the AVX2 build
    /// and without.
    #[test]
    fn code_tables_decode_as_the_transfer() {
        use crate::video::{Chroma, FrameFormat, YuvFrame};
        let format = FrameFormat {
            width: 512,
            height: 256,
            chroma: Chroma::Cs444,
            bit_depth: 8,
        };
        for (matrix, transfer, full_range) in [
            (Matrix::Bt709, Transfer::Srgb, false),
            (Matrix::Bt601, Transfer::Bt709, true),
            (Matrix::Bt2020Ncl, Transfer::Pq, false),
        ] {
            let color = ColorParams {
                matrix,
                full_range,
                transfer,
                bit_depth: 8,
            };
            // Luma = x mod 256 and Cb = Cr = y in the left half; Cb and Cr swapped roles
            // (Cb = 255 − y) in the right, so R and B each meet every pair.
            let mut frame = YuvFrame::filled(format, color, [0, 0, 0]);
            for y in 0..256usize {
                for x in 0..512usize {
                    frame.planes[0].data[y * 512 + x] = (x % 256) as u8;
                    frame.planes[1].data[y * 512 + x] = if x < 256 { y } else { 255 - y } as u8;
                    frame.planes[2].data[y * 512 + x] = y as u8;
                }
            }
            for avx2 in [true, false] {
                let mut plain = super::Decoder::new(format, &color);
                plain.set_code_tables(false);
                plain.set_baseline(!avx2);
                let mut fast = super::Decoder::new(format, &color);
                fast.set_baseline(!avx2);
                assert!(fast.code_tables.is_some() && plain.code_tables.is_none());
                let mut canvases = [Vec::new(), Vec::new()];
                for (d, canvas) in [&plain, &fast].into_iter().zip(&mut canvases) {
                    *canvas = vec![half::f16::ZERO; 4 * 512 * 256];
                    d.decode(&frame, None, None, canvas);
                }
                let bits = |c: &[half::f16]| c.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert!(
                    bits(&canvases[0]) == bits(&canvases[1]),
                    "{matrix:?}, {transfer:?}, full range {full_range}, AVX2 {avx2}"
                );
            }
        }
    }

    /// The decode's rows (each chroma row's terms formed once for the rows that share it, the
    /// tables' indices and Y' a row at a time) give, bit for bit, each pixel decoded on its
    /// own from its three codes: in 4:2:0 and 4:2:2, 8 and 10 bits, odd sizes, with the AVX2
    /// build and without, and for a second frame decoded with the first frame's buffers from
    /// the row the first ended on (a chroma row kept from the first would show).
    #[test]
    fn decoded_rows_are_each_pixel_on_its_own() {
        use crate::video::{Chroma, FrameFormat, YuvFrame};
        let mut state = 11u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 33) as u32
        };
        for (chroma, bit_depth) in [(Chroma::Cs420, 8), (Chroma::Cs422, 8), (Chroma::Cs420, 10)] {
            let format = FrameFormat {
                width: 77,
                height: 19,
                chroma,
                bit_depth,
            };
            let color = ColorParams::bt709(bit_depth);
            let max = (1u32 << bit_depth) - 1;
            let mut frames: Vec<YuvFrame> = (0..2)
                .map(|_| YuvFrame::filled(format, color, [0, 0, 0]))
                .collect();
            for frame in &mut frames {
                for plane in &mut frame.planes {
                    if bit_depth == 8 {
                        plane.data.iter_mut().for_each(|v| *v = next() as u8);
                    } else {
                        for pair in plane.data.chunks_exact_mut(2) {
                            pair.copy_from_slice(&((next() % (max + 1)) as u16).to_le_bytes());
                        }
                    }
                }
            }
            let (w, h) = (format.width as usize, format.height as usize);
            for avx2 in [true, false] {
                let mut d = super::Decoder::new(format, &color);
                d.set_baseline(!avx2);
                let mut scratch = super::RowScratch::default();
                for (frame, y0) in [(&frames[0], 0), (&frames[1], h - 1), (&frames[1], 0)] {
                    let mut rows = vec![half::f16::ZERO; 4 * w * (h - y0)];
                    d.decode_rows(frame, (None, None), y0, &mut rows, &mut scratch);
                    let (sx, sy) = format.chroma.shift();
                    let code = |i: usize, x: usize, y: usize| -> f32 {
                        let p = &frame.planes[i];
                        if bit_depth == 8 {
                            f32::from(p.data[y * p.stride + x])
                        } else {
                            let at = y * p.stride + 2 * x;
                            f32::from(u16::from_le_bytes([p.data[at], p.data[at + 1]]))
                        }
                    };
                    for y in y0..h {
                        for x in 0..w {
                            let luma = (code(0, x, y) - d.y_offset) / d.y_scale;
                            let (cx, cy) = (x >> sx, y >> sy);
                            let cb = (code(1, cx, cy) - d.c_offset) / d.c_scale;
                            let cr = (code(2, cx, cy) - d.c_offset) / d.c_scale;
                            let rgb = [
                                luma + d.cr_r * cr,
                                luma + -(d.cb_g * cb + d.cr_g * cr),
                                luma + d.cb_b * cb,
                            ]
                            .map(|e| half::f16::from_f32(d.eotf.apply(e)).to_bits());
                            let px = &rows[4 * ((y - y0) * w + x)..][..3];
                            let px = [px[0].to_bits(), px[1].to_bits(), px[2].to_bits()];
                            assert_eq!(px, rgb, "{chroma:?} {bit_depth} bits, ({x}, {y})");
                        }
                    }
                }
            }
        }
    }

    /// The normalised Y'CbCr in f32 (code − offset) / scale is the exact value rounded once:
    /// the same as the f64 quotient rounded to f32, for every code of every depth and range.
    #[test]
    fn f32_quotients_are_the_exact_values_rounded() {
        for bit_depth in 8..=16 {
            for full_range in [false, true] {
                let color = ColorParams {
                    matrix: Matrix::Bt709,
                    full_range,
                    transfer: Transfer::Bt709,
                    bit_depth,
                };
                let s = color.range_scale();
                let d = super::Decoder::new(
                    crate::video::FrameFormat {
                        width: 2,
                        height: 2,
                        chroma: crate::video::Chroma::Cs420,
                        bit_depth,
                    },
                    &color,
                );
                for c in 0..1u32 << bit_depth {
                    let y = ((f64::from(c) - s.y_offset) / s.y_scale) as f32;
                    let cb = ((f64::from(c) - s.c_offset) / s.c_scale) as f32;
                    let code = c as f32;
                    assert_eq!(y, (code - d.y_offset) / d.y_scale, "{bit_depth}, {c}");
                    assert_eq!(cb, (code - d.c_offset) / d.c_scale, "{bit_depth}, {c}");
                }
            }
        }
    }
}
