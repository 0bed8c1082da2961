//! The canvas → packed code values on the CPU (the `rgb_to_yuv` stage's work), luma and chroma
//! in one pass over each chroma block's rows. The canvas is f16, so the transfer (linear →
//! encoded) is an exact table over all 65 536 f16 values; the matrix and the rounding follow.

use rayon::prelude::*;

use crate::gpu::types::FrameParams;
use crate::video::color::oetf_signed;
use crate::video::{ColorParams, FrameFormat, Plane};

/// Linear → code values for one picture format.
pub struct Encoder {
    layout: FrameParams,
    /// The encoded value of each f16 (by its bits), computed in f64.
    oetf: Vec<f32>,
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
}

impl Encoder {
    /// The encoder of frames of `format` coded in `color`.
    pub fn new(format: FrameFormat, color: &ColorParams) -> Encoder {
        let s = color.range_scale();
        let (kr, kb) = color.matrix.kr_kb();
        let oetf = (0..=u16::MAX)
            .map(|bits| oetf_signed(color.transfer, half::f16::from_bits(bits).to_f64()) as f32)
            .collect();
        Encoder {
            layout: FrameParams::new(&format, color),
            oetf,
            kr: kr as f32,
            kg: (1.0 - kr - kb) as f32,
            kb: kb as f32,
            cb_per: (s.c_scale / (2.0 * (1.0 - kb))) as f32,
            cr_per: (s.c_scale / (2.0 * (1.0 - kr))) as f32,
            y_scale: s.y_scale as f32,
            y_offset: s.y_offset as f32,
            c_offset: s.c_offset as f32,
            max_code: s.max_code as f32,
        }
    }

    /// The code planes of `canvas` (RGBA f16 bits, rows `stride` texels apart), each row padded
    /// to whole 32-bit words as the GPU packs them.
    pub fn encode(&self, canvas: &[u16], stride: usize) -> [Plane; 3] {
        let l = &self.layout;
        let (y_row, c_row) = (4 * l.y_row_words as usize, 4 * l.c_row_words as usize);
        let rows = 1usize << l.chroma_shift_y;
        let mut y = vec![0u8; y_row * l.height as usize];
        let mut cb = vec![0u8; c_row * l.chroma_height as usize];
        let mut cr = cb.clone();
        y.par_chunks_mut(y_row * rows)
            .zip(cb.par_chunks_mut(c_row))
            .zip(cr.par_chunks_mut(c_row))
            .enumerate()
            .for_each(|(cy, ((luma, cb), cr))| {
                self.block_row(canvas, stride, cy, luma, [cb, cr]);
            });
        [(y, y_row), (cb, c_row), (cr, c_row)].map(|(data, stride)| Plane { data, stride })
    }

    /// The luma rows of chroma row `cy` into `luma` and its chroma into `chroma`.
    fn block_row(
        &self,
        canvas: &[u16],
        stride: usize,
        cy: usize,
        luma: &mut [u8],
        chroma: [&mut [u8]; 2],
    ) {
        let l = &self.layout;
        let (w, h) = (l.width as usize, l.height as usize);
        let (sx, sy) = (l.chroma_shift_x, l.chroma_shift_y);
        let y_row = 4 * l.y_row_words as usize;
        let y0 = cy << sy;
        let y1 = (y0 + (1 << sy)).min(h);
        let cw = l.chroma_width as usize;
        let mut sums = vec![[0f32; 2]; cw];
        let bytes = l.bytes_per_sample as usize;
        for y in y0..y1 {
            let row = &canvas[4 * y * stride..][..4 * w];
            let out = &mut luma[(y - y0) * y_row..][..y_row];
            for (x, px) in row.chunks_exact(4).enumerate() {
                let r = self.oetf[px[0] as usize];
                let g = self.oetf[px[1] as usize];
                let b = self.oetf[px[2] as usize];
                let yv = self.kr * r + self.kg * g + self.kb * b;
                put(out, x, bytes, self.code(yv * self.y_scale + self.y_offset));
                let s = &mut sums[x >> sx];
                s[0] += b - yv;
                s[1] += r - yv;
            }
        }
        let rows = (y1 - y0) as f32;
        let [cb, cr] = chroma;
        for (cx, s) in sums.iter().enumerate() {
            let x0 = cx << sx;
            let n = rows * (((x0 + (1 << sx)).min(w) - x0) as f32);
            let [b, r] = [s[0] * self.cb_per, s[1] * self.cr_per].map(|v| v / n + self.c_offset);
            put(cb, cx, bytes, self.code(b));
            put(cr, cx, bytes, self.code(r));
        }
    }

    /// A code value: rounded, clamped to the legal codes.
    #[inline]
    fn code(&self, v: f32) -> u16 {
        v.round().clamp(0.0, self.max_code) as u16
    }
}

/// Writes sample `i` of a row of `bytes`-byte samples.
#[inline]
fn put(row: &mut [u8], i: usize, bytes: usize, code: u16) {
    if bytes == 1 {
        row[i] = code as u8;
    } else {
        row[2 * i..2 * i + 2].copy_from_slice(&code.to_le_bytes());
    }
}
