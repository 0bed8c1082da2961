//! The canvas → packed code values on the CPU (the `rgb_to_yuv` stage's work), luma and chroma
//! in one pass over each chroma block's rows. The canvas is f16, so the transfer (linear →
//! encoded) is an exact table over all 65 536 f16 values; the matrix and the rounding follow,
//! eight pixels at a time: in the AVX2 build (picked at run time) each channel's bits taken
//! from the texels with shifts and the table read by one gather, else lanes the compiler
//! vectorises; the chroma blocks' sums eight at a time. The plain loop, one pixel at a time,
//! is the reference (the baseline build): the same bits.

// Lane loops index several arrays by the pixel: the form the vectoriser reads best.
#![allow(clippy::needless_range_loop)]

use std::ops::Range;

use rayon::prelude::*;

use super::lanes::{self, LANES};
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
    /// Whether a row's pixels and a 4:2:0 or 4:2:2 row's chroma sums go [`LANES`] at a time
    /// ([`Encoder::pixel_lanes`], [`pair_sums`]; else one at a time, the plain form).
    lanes: bool,
}

/// A block row's buffers, reused from one to the next.
#[derive(Default)]
pub(super) struct Scratch {
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
            lanes: true,
        }
    }

    /// This encoder without its AVX2 build, and in the plain form (one pixel at a time), where
    /// `off` (the same bits, slower).
    pub(super) fn set_baseline(&mut self, off: bool) {
        self.avx2 = !off && lanes::has_avx2_f16c();
        self.lanes = !off;
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
                    return self.block_row_on((canvas, 0), stride, cy, 0..w, luma, [cb, cr], s);
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
                    self.block_row_on((canvas, 0), stride, cy, cols, luma, [cb, cr], s);
                    tx += run;
                }
            });
        [(y, y_row), (cb, c_row), (cr, c_row)].map(|(data, stride)| Plane { data, stride })
    }

    /// Zeroed code planes for this format, laid out as [`encode`](Self::encode) returns
    /// them, and the luma rows of one chroma row.
    pub(super) fn blank_planes(&self) -> ([Plane; 3], usize) {
        let l = &self.layout;
        let (y_row, c_row) = (4 * l.y_row_words as usize, 4 * l.c_row_words as usize);
        let plane = |stride: usize, rows: u32| Plane {
            data: vec![0u8; stride * rows as usize],
            stride,
        };
        let planes = [
            plane(y_row, l.height),
            plane(c_row, l.chroma_height),
            plane(c_row, l.chroma_height),
        ];
        (planes, 1 << l.chroma_shift_y)
    }

    /// The codes of canvas rows `y0`… (`canvas`: whole rows from `y0`, RGBA f16 bits, a
    /// whole number of chroma rows or the picture's last) into `luma`, `cb` and `cr` (those
    /// rows' spans of the planes of [`blank_planes`](Self::blank_planes)): each code as
    /// [`encode`](Self::encode) makes it, for a caller that works band by band.
    pub(super) fn encode_rows(
        &self,
        canvas: &[u16],
        y0: usize,
        [luma, cb, cr]: [&mut [u8]; 3],
        s: &mut Scratch,
    ) {
        let l = &self.layout;
        let (y_row, c_row) = (4 * l.y_row_words as usize, 4 * l.c_row_words as usize);
        let (w, sy) = (l.width as usize, l.chroma_shift_y);
        let rows = 1usize << sy;
        let cy0 = y0 >> sy;
        for (k, ((luma, cb), cr)) in luma
            .chunks_mut(y_row * rows)
            .zip(cb.chunks_mut(c_row))
            .zip(cr.chunks_mut(c_row))
            .enumerate()
        {
            self.block_row_on((canvas, y0), w, cy0 + k, 0..w, luma, [cb, cr], s);
        }
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
        (canvas, row0): (&[u16], usize),
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
                canvas: (&[u16], usize),
                stride: usize,
                cy: usize,
                cols: Range<usize>,
                luma: &mut [u8],
                chroma: [&mut [u8]; 2],
                s: &mut Scratch,
            ) {
                e.block_row(canvas, stride, cy, cols, luma, chroma, s, true)
            }
            // SAFETY: `avx2` is set only where the CPU has AVX2 and F16C (`lanes::has_avx2_f16c`).
            return unsafe { fast(self, (canvas, row0), stride, cy, cols, luma, chroma, s) };
        }
        self.block_row((canvas, row0), stride, cy, cols, luma, chroma, s, false)
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
        (canvas, row0): (&[u16], usize),
        stride: usize,
        cy: usize,
        cols: Range<usize>,
        luma: &mut [u8],
        chroma: [&mut [u8]; 2],
        s: &mut Scratch,
        simd: bool,
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
            let row = &canvas[4 * ((y - row0) * stride + xa)..][..4 * n];
            let [sb, sr] = &mut s.sums;
            let step = 1 << sx;
            if self.lanes {
                self.pixel_lanes(row, &mut s.codes, &mut s.b_y, &mut s.r_y, simd);
                put_row(&mut luma[(y - y0) * y_row + xa * bytes..], &s.codes, bytes);
                if step == 2 {
                    pair_sums(&s.b_y, sb);
                    pair_sums(&s.r_y, sr);
                    continue;
                }
            } else {
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
            }
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
        let (cb_per, cr_per, c_offset, max_code) =
            (self.cb_per, self.cr_per, self.c_offset, self.max_code);
        let (cb, cr) = (&mut cb[..cn], &mut cr[..cn]);
        let pixels = |k: usize| {
            let x0 = (ca + k) << sx;
            rows * (((x0 + (1 << sx)).min(w) - x0) as f32)
        };
        if self.lanes {
            // Every block but a last one cut by the picture's edge holds whole pairs: one
            // count for them all, so the loop vectorises; the last block as the plain loop.
            let full = rows * (1u32 << sx) as f32;
            let (sb, sr) = (&sb[..cn], &sr[..cn]);
            for k in 0..cn {
                cb[k] = code(sb[k] * cb_per / full + c_offset, max_code);
                cr[k] = code(sr[k] * cr_per / full + c_offset, max_code);
            }
            if let Some(k) = cn.checked_sub(1) {
                let n = pixels(k);
                cb[k] = code(sb[k] * cb_per / n + c_offset, max_code);
                cr[k] = code(sr[k] * cr_per / n + c_offset, max_code);
            }
        } else {
            for k in 0..cn {
                let n = pixels(k);
                cb[k] = self.code(sb[k] * cb_per / n + c_offset);
                cr[k] = self.code(sr[k] * cr_per / n + c_offset);
            }
        }
        let [out_b, out_r] = chroma;
        put_row(&mut out_b[ca * bytes..], cb, bytes);
        put_row(&mut out_r[ca * bytes..], cr, bytes);
    }

    /// The plain loop's luma codes and chroma differences of `row`'s pixels (RGBA f16 bits)
    /// into `codes`, `b_y` and `r_y` (one per pixel), [`LANES`] pixels at a time: in the AVX2
    /// build where `simd` ([`x86::pixels`]: the table read by a gather a channel), else the
    /// table read a load a lane and the same operations on each lane in lanes the compiler
    /// vectorises; the pixels past the last whole group one at a time.
    #[inline(always)]
    fn pixel_lanes(
        &self,
        row: &[u16],
        codes: &mut [u16],
        b_y: &mut [f32],
        r_y: &mut [f32],
        simd: bool,
    ) {
        let oetf = &*self.oetf;
        let (kr, kg, kb) = (self.kr, self.kg, self.kb);
        let (y_scale, y_offset, max_code) = (self.y_scale, self.y_offset, self.max_code);
        let n = row.len() / 4;
        let (codes, b_y, r_y) = (&mut codes[..n], &mut b_y[..n], &mut r_y[..n]);
        let whole = n / LANES * LANES;
        let groups = row[..4 * whole]
            .chunks_exact(4 * LANES)
            .zip(codes.chunks_exact_mut(LANES))
            .zip(b_y.chunks_exact_mut(LANES).zip(r_y.chunks_exact_mut(LANES)));
        for ((px, codes), (b_y, r_y)) in groups {
            #[cfg(target_arch = "x86_64")]
            if simd {
                let k = [kr, kg, kb, y_scale, y_offset, max_code];
                // SAFETY: `simd` is set only in the AVX2 build, which runs only where the CPU
                // has AVX2 (`block_row_on`); every f16's bits index the 2¹⁶-entry table.
                unsafe { x86::pixels(px, oetf, &k, codes, b_y, r_y) };
                continue;
            }
            let _ = simd;
            let (mut r, mut g, mut b) = ([0f32; LANES], [0f32; LANES], [0f32; LANES]);
            for l in 0..LANES {
                r[l] = oetf[usize::from(px[4 * l])];
                g[l] = oetf[usize::from(px[4 * l + 1])];
                b[l] = oetf[usize::from(px[4 * l + 2])];
            }
            for l in 0..LANES {
                let yv = kr * r[l] + kg * g[l] + kb * b[l];
                codes[l] = code(yv * y_scale + y_offset, max_code);
                b_y[l] = b[l] - yv;
                r_y[l] = r[l] - yv;
            }
        }
        for x in whole..n {
            let px = &row[4 * x..][..4];
            let (r, g, b) = (
                oetf[usize::from(px[0])],
                oetf[usize::from(px[1])],
                oetf[usize::from(px[2])],
            );
            let yv = kr * r + kg * g + kb * b;
            codes[x] = code(yv * y_scale + y_offset, max_code);
            b_y[x] = b - yv;
            r_y[x] = r - yv;
        }
    }

    /// A code value: clamped to the legal codes, rounded to the nearest (ties to even, as the
    /// GPU's `round`) without a library call.
    #[inline(always)]
    fn code(&self, v: f32) -> u16 {
        ((v.clamp(0.0, self.max_code) + ROUNDER) - ROUNDER) as u16
    }
}

/// [`Encoder::code`] (its plain form) with the largest code `max_code`: the clamp as two selects (NaN and −0
/// give 0, as `clamp` and the saturating cast give), and the integral value in range cast
/// through i32 unchecked, so that lanes of it vectorise.
#[inline(always)]
fn code(v: f32, max_code: f32) -> u16 {
    let low = if v > 0.0 { v } else { 0.0 };
    let clamped = if low < max_code { low } else { max_code };
    // SAFETY: `clamped` is in [0, max_code] (NaN fails `v > 0`), so the rounded value is a
    // whole number in [0, 65 535]: an i32.
    unsafe { ((clamped + ROUNDER) - ROUNDER).to_int_unchecked::<i32>() as u16 }
}

/// Adds each pair of `values` to its block's sum in `sums` (pixels 2k and 2k + 1 to sum k,
/// in that order; an odd last pixel alone), [`LANES`] blocks at a time: the plain loop's
/// additions in its order, so the same sums.
#[inline(always)]
fn pair_sums(values: &[f32], sums: &mut [f32]) {
    let whole = values.len() / (2 * LANES) * LANES;
    for (sum, pairs) in sums[..whole]
        .chunks_exact_mut(LANES)
        .zip(values.chunks_exact(2 * LANES))
    {
        let (mut even, mut odd) = ([0f32; LANES], [0f32; LANES]);
        for l in 0..LANES {
            even[l] = pairs[2 * l];
            odd[l] = pairs[2 * l + 1];
        }
        for l in 0..LANES {
            sum[l] += even[l];
            sum[l] += odd[l];
        }
    }
    for (sum, pair) in sums[whole..].iter_mut().zip(values[2 * whole..].chunks(2)) {
        for v in pair {
            *sum += v;
        }
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

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::{
        __m256, __m256i, _mm_packus_epi32, _mm_storeu_si128, _mm256_add_ps, _mm256_and_si256,
        _mm256_castps_si256, _mm256_castsi256_ps, _mm256_castsi256_si128, _mm256_cvttps_epi32,
        _mm256_extracti128_si256, _mm256_i32gather_ps, _mm256_loadu_si256, _mm256_max_ps,
        _mm256_min_ps, _mm256_mul_ps, _mm256_permute4x64_epi64, _mm256_set1_epi64x, _mm256_set1_ps,
        _mm256_setzero_ps, _mm256_shuffle_ps, _mm256_srli_epi64, _mm256_storeu_ps, _mm256_sub_ps,
    };

    use super::{LANES, ROUNDER};

    /// See [`super::Encoder::pixel_lanes`]: eight pixels' RGBA f16 bits `px` (32 values) →
    /// their luma codes, B' − Y' and R' − Y', with `k` = [kr, kg, kb, y_scale, y_offset,
    /// max_code]: each channel's bits picked from the pixels' 64-bit texels, the table read by
    /// a gather, then the plain loop's operations in its order (no fused multiply-add; the
    /// clamp as [`super::code`]'s selects, which `max` and `min` are with these operands).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn pixels(
        px: &[u16],
        oetf: &[f32; 1 << 16],
        k: &[f32; 6],
        codes: &mut [u16],
        b_y: &mut [f32],
        r_y: &mut [f32],
    ) {
        assert!(px.len() >= 4 * LANES && codes.len() >= LANES);
        assert!(b_y.len() >= LANES && r_y.len() >= LANES);
        // SAFETY: the lengths are checked above; every index is a 16-bit value, inside the
        // 2¹⁶-entry table; loads and stores unaligned.
        unsafe {
            // Pixels 0–3 and 4–7, a 64-bit texel each: R in bits 0–15, G 16–31, B 32–47.
            let lo = _mm256_loadu_si256(px.as_ptr().cast::<__m256i>());
            let hi = _mm256_loadu_si256(px.as_ptr().add(16).cast::<__m256i>());
            let low16 = _mm256_set1_epi64x(0xFFFF);
            let channel = |shift: i32| -> __m256i {
                let (a, b) = match shift {
                    0 => (lo, hi),
                    16 => (_mm256_srli_epi64::<16>(lo), _mm256_srli_epi64::<16>(hi)),
                    _ => (_mm256_srli_epi64::<32>(lo), _mm256_srli_epi64::<32>(hi)),
                };
                let (a, b) = (_mm256_and_si256(a, low16), _mm256_and_si256(b, low16));
                // Each texel's low 32 bits: pixels 0 1 4 5 | 2 3 6 7, then in order.
                let mixed =
                    _mm256_shuffle_ps::<0x88>(_mm256_castsi256_ps(a), _mm256_castsi256_ps(b));
                _mm256_permute4x64_epi64::<0xD8>(_mm256_castps_si256(mixed))
            };
            let table = oetf.as_ptr();
            let read = |at: __m256i| -> __m256 { _mm256_i32gather_ps::<4>(table, at) };
            let (r, g, b) = (read(channel(0)), read(channel(16)), read(channel(32)));
            let set = |v: f32| _mm256_set1_ps(v);
            let yv = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(set(k[0]), r), _mm256_mul_ps(set(k[1]), g)),
                _mm256_mul_ps(set(k[2]), b),
            );
            let v = _mm256_add_ps(_mm256_mul_ps(yv, set(k[3])), set(k[4]));
            let clamped = _mm256_min_ps(_mm256_max_ps(v, _mm256_setzero_ps()), set(k[5]));
            let rounded = _mm256_sub_ps(_mm256_add_ps(clamped, set(ROUNDER)), set(ROUNDER));
            let whole = _mm256_cvttps_epi32(rounded);
            let packed = _mm_packus_epi32(
                _mm256_castsi256_si128(whole),
                _mm256_extracti128_si256::<1>(whole),
            );
            _mm_storeu_si128(codes.as_mut_ptr().cast(), packed);
            _mm256_storeu_ps(b_y.as_mut_ptr(), _mm256_sub_ps(b, yv));
            _mm256_storeu_ps(r_y.as_mut_ptr(), _mm256_sub_ps(r, yv));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Encoder;
    use crate::video::{Chroma, ColorParams, FrameFormat, Matrix, Transfer};

    /// The lanes form (in the AVX2 build where the CPU has it, else the vectorised loop) gives
    /// the plain form's codes: every f16 value in each channel (NaN, infinities, negatives,
    /// subnormals among them), at odd and even widths, in 4:2:0, 4:2:2 and 4:4:4, 8-bit and
    /// 10-bit, limited and full range, whole rows and spans of tiles.
    #[test]
    fn lanes_encode_as_the_plain_form() {
        let mut state = 11u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 33) as u32
        };
        for (k, (chroma, bit_depth, full_range)) in [
            (Chroma::Cs420, 8, false),
            (Chroma::Cs422, 10, true),
            (Chroma::Cs444, 8, true),
            (Chroma::Cs420, 10, false),
        ]
        .into_iter()
        .enumerate()
        {
            let width = [263, 256, 101, 130][k];
            let height = 66;
            let format = FrameFormat {
                width,
                height,
                chroma,
                bit_depth,
            };
            let color = ColorParams {
                matrix: Matrix::Bt709,
                full_range,
                transfer: [Transfer::Srgb, Transfer::Pq, Transfer::Bt709, Transfer::Hlg][k],
                bit_depth,
            };
            // Every f16 in each channel somewhere; most texels in [0, 1.2] as a picture's.
            let texels = (width * height) as usize;
            let mut canvas = vec![0u16; 4 * texels];
            for (i, v) in canvas.iter_mut().enumerate() {
                *v = if (i / 4) % 3 == 0 {
                    ((i / 4 * 3 + i % 4) % 65_536) as u16
                } else {
                    half::f16::from_f32((next() % 1200) as f32 / 1000.0).to_bits()
                };
            }
            let mut plain = Encoder::new(format, &color);
            plain.set_baseline(true);
            let fast = Encoder::new(format, &color);
            let (a, b) = (
                plain.encode(&canvas, width as usize),
                fast.encode(&canvas, width as usize),
            );
            for (i, (a, b)) in a.iter().zip(&b).enumerate() {
                assert!(
                    a.data == b.data,
                    "{chroma:?}, {bit_depth}-bit: plane {i} differs"
                );
            }
            // Spans of tiles: the frame's own codes elsewhere, the canvas's in the tiles set.
            let frame =
                crate::video::YuvFrame::filled(format, color, [40, 500 % (1 << bit_depth), 90]);
            let tiles: Vec<bool> = (0..width.div_ceil(64) * height.div_ceil(32))
                .map(|t| t % 3 != 1)
                .collect();
            let from = Some((&frame, &tiles[..]));
            let (a, b) = (
                plain.encode_tiles(&canvas, width as usize, from),
                fast.encode_tiles(&canvas, width as usize, from),
            );
            for (i, (a, b)) in a.iter().zip(&b).enumerate() {
                assert!(
                    a.data == b.data,
                    "{chroma:?}, {bit_depth}-bit: tiles' plane {i} differs"
                );
            }
        }
    }
}
