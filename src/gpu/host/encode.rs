//! The canvas → packed code values on the CPU (the `rgb_to_yuv` stage's work), luma and chroma
//! in one pass over each chroma block's rows. The canvas is f16, so the transfer (linear →
//! encoded) is an exact table over all 65 536 f16 values; the matrix and the rounding follow,
//! a loop over a row's pixels for the compiler to vectorise, compiled a second time for AVX2
//! and picked at run time: the same bits. (The table is read a load at a time: AVX2's gathers
//! were no faster on the machine measured, see `docs/measurements.md`.)

// Lane loops index several arrays by the pixel: the form the vectoriser reads best.
#![allow(clippy::needless_range_loop)]

use std::ops::Range;

use rayon::prelude::*;

use super::lanes;
use super::streaks::{TILE_H, TILE_W};
use crate::gpu::types::FrameParams;
use crate::video::color::oetf_signed;
use crate::video::{ColorParams, FrameFormat, Plane, YuvFrame};

// A tile's rows and columns hold whole chroma blocks (at most 2 × 2 pixels), so a tile's
// codes depend on its own pixels alone.
const _: () = assert!(TILE_W.is_multiple_of(2) && TILE_H.is_multiple_of(2));

/// 2²³: adding it to a value in [0, 2²³] and taking it away again rounds the value to an
/// integer, ties to even (the spacing of f32 there is 1), as WGSL's `round` does.
const ROUNDER: f32 = 8_388_608.0;

/// Linear → code values for one picture format.
pub struct Encoder {
    layout: FrameParams,
    /// The encoded value of each f16 (by its bits), computed in f64.
    oetf: Box<[f32; 1 << 16]>,
    kr: f32,
    kg: f32,
    kb: f32,
    /// Code steps per unit of B' − Y' and of R' − Y'.
    cb_per: f32,
    cr_per: f32,
    y_scale: f32,
    y_offset: f32,
    c_offset: f32,
    max_code: f32,
    /// Whether the AVX2 build runs (the CPU has it, and it was not turned off).
    avx2: bool,
}

/// A block row's buffers, reused from one to the next.
#[derive(Default)]
struct Scratch {
    /// A row's luma codes.
    codes: Vec<u16>,
    /// A row's B' − Y' and R' − Y' per pixel.
    b_y: Vec<f32>,
    r_y: Vec<f32>,
    /// Their sums over each chroma block, then its codes.
    sums: [Vec<f32>; 2],
    chroma: [Vec<u16>; 2],
}

impl Encoder {
    /// The encoder of frames of `format` coded in `color`.
    pub fn new(format: FrameFormat, color: &ColorParams) -> Encoder {
        let s = color.range_scale();
        let (kr, kb) = color.matrix.kr_kb();
        let oetf: Vec<f32> = (0..=u16::MAX)
            .map(|bits| oetf_signed(color.transfer, half::f16::from_bits(bits).to_f64()) as f32)
            .collect();
        Encoder {
            layout: FrameParams::new(&format, color),
            oetf: oetf.try_into().expect("one entry per f16"),
            kr: kr as f32,
            kg: (1.0 - kr - kb) as f32,
            kb: kb as f32,
            cb_per: (s.c_scale / (2.0 * (1.0 - kb))) as f32,
            cr_per: (s.c_scale / (2.0 * (1.0 - kr))) as f32,
            y_scale: s.y_scale as f32,
            y_offset: s.y_offset as f32,
            c_offset: s.c_offset as f32,
            max_code: s.max_code as f32,
            avx2: lanes::has_avx2_f16c(),
        }
    }

    /// This encoder without its AVX2 build where `off` (the same bits, slower).
    pub(super) fn set_baseline(&mut self, off: bool) {
        self.avx2 = !off && lanes::has_avx2_f16c();
    }

    /// The code planes of `canvas` (RGBA f16 bits, rows `stride` texels apart), each row padded
    /// to whole 32-bit words as the GPU packs them.
    pub fn encode(&self, canvas: &[u16], stride: usize) -> [Plane; 3] {
        self.encode_tiles(canvas, stride, None)
    }

    /// [`encode`](Self::encode) where `from` is `None`; else only the tiles set in `from`'s
    /// flags (one per [`TILE_W`] × [`TILE_H`] tile, row-major) are encoded from the canvas,
    /// and every other tile's codes are `from`'s frame's own, copied (clamped to the depth's
    /// largest code, as the decode reads them).
    pub fn encode_tiles(
        &self,
        canvas: &[u16],
        stride: usize,
        from: Option<(&YuvFrame, &[bool])>,
    ) -> [Plane; 3] {
        let l = &self.layout;
        let (y_row, c_row) = (4 * l.y_row_words as usize, 4 * l.c_row_words as usize);
        let rows = 1usize << l.chroma_shift_y;
        let w = l.width as usize;
        let tiles_x = w.div_ceil(TILE_W);
        let mut y = vec![0u8; y_row * l.height as usize];
        let mut cb = vec![0u8; c_row * l.chroma_height as usize];
        let mut cr = cb.clone();
        y.par_chunks_mut(y_row * rows)
            .zip(cb.par_chunks_mut(c_row))
            .zip(cr.par_chunks_mut(c_row))
            .enumerate()
            .for_each_init(Scratch::default, |s, (cy, ((luma, cb), cr))| {
                let Some((frame, tiles)) = from else {
                    return self.block_row_on(canvas, stride, cy, 0..w, luma, [cb, cr], s);
                };
                self.copy_block_row(frame, cy, luma, [cb, cr]);
                let ty = (cy << l.chroma_shift_y) / TILE_H;
                let need = &tiles[ty * tiles_x..][..tiles_x];
                let mut tx = 0;
                while tx < tiles_x {
                    if !need[tx] {
                        tx += 1;
                        continue;
                    }
                    let run = need[tx..].iter().take_while(|&&n| n).count();
                    let cols = tx * TILE_W..((tx + run) * TILE_W).min(w);
                    self.block_row_on(canvas, stride, cy, cols, luma, [cb, cr], s);
                    tx += run;
                }
            });
        [(y, y_row), (cb, c_row), (cr, c_row)].map(|(data, stride)| Plane { data, stride })
    }

    /// `frame`'s codes of chroma row `cy` (and of its luma rows) into `luma` and `chroma`, as
    /// [`block_row`](Self::block_row) lays them out, each clamped to the depth's largest code.
    fn copy_block_row(&self, frame: &YuvFrame, cy: usize, luma: &mut [u8], chroma: [&mut [u8]; 2]) {
        let l = &self.layout;
        let bytes = l.bytes_per_sample as usize;
        let y_row = 4 * l.y_row_words as usize;
        let max = ((1u32 << frame.format.bit_depth) - 1) as u16;
        let copy = |src: &[u8], dst: &mut [u8]| {
            if bytes == 1 {
                dst.copy_from_slice(src);
            } else {
                for (o, i) in dst.chunks_exact_mut(2).zip(src.chunks_exact(2)) {
                    let code = u16::from_le_bytes([i[0], i[1]]).min(max);
                    o.copy_from_slice(&code.to_le_bytes());
                }
            }
        };
        let (w, cw) = (l.width as usize * bytes, l.chroma_width as usize * bytes);
        let y0 = cy << l.chroma_shift_y;
        let y1 = (y0 + (1 << l.chroma_shift_y)).min(l.height as usize);
        let p = &frame.planes[0];
        for y in y0..y1 {
            copy(
                &p.data[y * p.stride..][..w],
                &mut luma[(y - y0) * y_row..][..w],
            );
        }
        for (i, out) in chroma.into_iter().enumerate() {
            let p = &frame.planes[i + 1];
            copy(&p.data[cy * p.stride..][..cw], &mut out[..cw]);
        }
    }

    /// [`block_row`](Self::block_row), in the AVX2 build where the encoder runs it.
    #[allow(clippy::too_many_arguments)]
    fn block_row_on(
        &self,
        canvas: &[u16],
        stride: usize,
        cy: usize,
        cols: Range<usize>,
        luma: &mut [u8],
        chroma: [&mut [u8]; 2],
        s: &mut Scratch,
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            #[target_feature(enable = "avx2,f16c")]
            fn fast(
                e: &Encoder,
                canvas: &[u16],
                stride: usize,
                cy: usize,
                cols: Range<usize>,
                luma: &mut [u8],
                chroma: [&mut [u8]; 2],
                s: &mut Scratch,
            ) {
                e.block_row(canvas, stride, cy, cols, luma, chroma, s)
            }
            // SAFETY: `avx2` is set only where the CPU has AVX2 and F16C (`lanes::has_avx2_f16c`).
            return unsafe { fast(self, canvas, stride, cy, cols, luma, chroma, s) };
        }
        self.block_row(canvas, stride, cy, cols, luma, chroma, s)
    }

    /// The luma rows of chroma row `cy` over the columns `cols` (from the start of a chroma
    /// block to the end of one, or of the row) into `luma` and that span's chroma into
    /// `chroma`: per row, the pixels' luma codes and chroma differences in lanes, then the
    /// differences summed over each block in the pixels' order. A pixel's codes depend on its
    /// block alone, so a span's are those of the whole row.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn block_row(
        &self,
        canvas: &[u16],
        stride: usize,
        cy: usize,
        cols: Range<usize>,
        luma: &mut [u8],
        chroma: [&mut [u8]; 2],
        s: &mut Scratch,
    ) {
        let l = &self.layout;
        let (w, h) = (l.width as usize, l.height as usize);
        let (sx, sy) = (l.chroma_shift_x, l.chroma_shift_y);
        let y_row = 4 * l.y_row_words as usize;
        let y0 = cy << sy;
        let y1 = (y0 + (1 << sy)).min(h);
        let bytes = l.bytes_per_sample as usize;
        let oetf = &*self.oetf;
        let (xa, n) = (cols.start, cols.len());
        let (ca, cn) = (xa >> sx, n.div_ceil(1 << sx));
        s.codes.resize(n, 0);
        s.b_y.resize(n, 0.0);
        s.r_y.resize(n, 0.0);
        for sums in &mut s.sums {
            sums.clear();
            sums.resize(cn, 0.0);
        }
        for y in y0..y1 {
            let row = &canvas[4 * (y * stride + xa)..][..4 * n];
            for (x, px) in row.chunks_exact(4).enumerate() {
                let r = oetf[usize::from(px[0])];
                let g = oetf[usize::from(px[1])];
                let b = oetf[usize::from(px[2])];
                let yv = self.kr * r + self.kg * g + self.kb * b;
                s.codes[x] = self.code(yv * self.y_scale + self.y_offset);
                s.b_y[x] = b - yv;
                s.r_y[x] = r - yv;
            }
            put_row(&mut luma[(y - y0) * y_row + xa * bytes..], &s.codes, bytes);
            let [sb, sr] = &mut s.sums;
            let step = 1 << sx;
            for ((sb, sr), (b, r)) in sb
                .iter_mut()
                .zip(sr.iter_mut())
                .zip(s.b_y.chunks(step).zip(s.r_y.chunks(step)))
            {
                for (b, r) in b.iter().zip(r) {
                    *sb += b;
                    *sr += r;
                }
            }
        }
        let rows = (y1 - y0) as f32;
        let [sb, sr] = &s.sums;
        let [cb, cr] = &mut s.chroma;
        cb.resize(cn, 0);
        cr.resize(cn, 0);
        for k in 0..cn {
            let x0 = (ca + k) << sx;
            let n = rows * (((x0 + (1 << sx)).min(w) - x0) as f32);
            let b = sb[k] * self.cb_per / n + self.c_offset;
            let r = sr[k] * self.cr_per / n + self.c_offset;
            cb[k] = self.code(b);
            cr[k] = self.code(r);
        }
        let [out_b, out_r] = chroma;
        put_row(&mut out_b[ca * bytes..], cb, bytes);
        put_row(&mut out_r[ca * bytes..], cr, bytes);
    }

    /// A code value: clamped to the legal codes, rounded to the nearest (ties to even, as the
    /// GPU's `round`) without a library call.
    #[inline(always)]
    fn code(&self, v: f32) -> u16 {
        ((v.clamp(0.0, self.max_code) + ROUNDER) - ROUNDER) as u16
    }
}

/// `codes` into the start of a row of `bytes`-byte samples.
#[inline(always)]
fn put_row(row: &mut [u8], codes: &[u16], bytes: usize) {
    if bytes == 1 {
        for (o, &c) in row.iter_mut().zip(codes) {
            *o = c as u8;
        }
    } else {
        for (o, &c) in row.chunks_exact_mut(2).zip(codes) {
            o.copy_from_slice(&c.to_le_bytes());
        }
    }
}
