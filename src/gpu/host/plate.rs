//! Planes → the hazed linear canvas on the CPU (the `yuv_to_rgb` stage's work): code values to
//! normalised Y'CbCr through exact per-code tables, the matrix once per chroma sample, the
//! transfer through a fine table, the haze's veil ([`super::veil`]), then f16 a row at a time.

use half::f16;
use half::slice::HalfFloatSliceExt;
use rayon::prelude::*;

use super::veil::Veil;
use super::wet_ground::WetGround;
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

/// The transfer (encoded → linear, odd-extended) as a table interpolated linearly. The
/// transfer follows the matrix, so it is a function of three codes, not one: no exact
/// per-code table exists for it.
pub struct Eotf {
    transfer: Transfer,
    table: Vec<f32>,
}

impl Eotf {
    /// The table of `transfer`.
    pub fn new(transfer: Transfer) -> Eotf {
        let step = f64::from(EOTF_SPAN) / EOTF_STEPS as f64;
        let table = (0..=EOTF_STEPS)
            .map(|i| eotf_signed(transfer, i as f64 * step) as f32)
            .collect();
        Eotf { transfer, table }
    }

    /// Linear light of encoded value `e`.
    #[inline]
    pub fn apply(&self, e: f32) -> f32 {
        let at = e.abs() * (EOTF_STEPS as f32 / EOTF_SPAN);
        if at < EOTF_STEPS as f32 {
            let i = at as usize;
            let (a, b) = (self.table[i], self.table[i + 1]);
            (a + (b - a) * (at - i as f32)).copysign(e)
        } else {
            eotf_signed(self.transfer, f64::from(e)) as f32
        }
    }
}

/// Code values → linear RGB for one picture format.
pub struct Decoder {
    format: FrameFormat,
    /// Luma code → Y' ∈ [0, 1] and chroma code → C ∈ [−½, ½]: exact (one rounding to f32).
    luma: Vec<f32>,
    chroma: Vec<f32>,
    /// R' = Y' + `cr_r` Cr, G' = Y' − `cb_g` Cb − `cr_g` Cr, B' = Y' + `cb_b` Cb.
    cr_r: f32,
    cb_g: f32,
    cr_g: f32,
    cb_b: f32,
    eotf: Eotf,
}

impl Decoder {
    /// The decoder of frames of `format` coded in `color`.
    pub fn new(format: FrameFormat, color: &ColorParams) -> Decoder {
        let s = color.range_scale();
        let codes = 1usize << format.bit_depth;
        let table = |offset: f64, scale: f64| -> Vec<f32> {
            (0..codes)
                .map(|c| ((c as f64 - offset) / scale) as f32)
                .collect()
        };
        let (kr, kb) = color.matrix.kr_kb();
        let kg = 1.0 - kr - kb;
        Decoder {
            format,
            luma: table(s.y_offset, s.y_scale),
            chroma: table(s.c_offset, s.c_scale),
            cr_r: (2.0 * (1.0 - kr)) as f32,
            cb_g: (2.0 * kb * (1.0 - kb) / kg) as f32,
            cr_g: (2.0 * kr * (1.0 - kr) / kg) as f32,
            cb_b: (2.0 * (1.0 - kb)) as f32,
            eotf: Eotf::new(color.transfer),
        }
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
            .for_each(|(band, out)| {
                let mut rgba = vec![0f32; 4 * w];
                let mut plate = Vec::new();
                let mut scratch = RowScratch::default();
                for (k, row) in out.chunks_exact_mut(4 * w).enumerate() {
                    let y = (band * BAND_ROWS + k) as u32;
                    self.plate_row(frame, y, &mut rgba, &mut scratch);
                    let wet = wet.filter(|g| g.touches(y as usize));
                    if wet.is_some() {
                        plate.clone_from(&rgba);
                    }
                    if let Some(v) = veil {
                        veil_row(v, y, &mut rgba, &mut scratch);
                    }
                    if let Some(g) = wet {
                        let haze = veil.map(|_| (&scratch.transmittance[..], &scratch.grid[..]));
                        g.row(y as usize, &plate, haze, &mut rgba);
                    }
                    row.convert_from_f32_slice(&rgba);
                }
            });
    }

    /// The plate's linear RGBA along row `y`.
    pub(super) fn plate_row(&self, frame: &YuvFrame, y: u32, rgba: &mut [f32], s: &mut RowScratch) {
        let f = self.format;
        let (sx, sy) = f.chroma.shift();
        let (cw, _) = f.plane_size(1);
        let cy = (y >> sy) as usize;
        codes(frame, 0, y as usize, f.width as usize, &mut s.y);
        codes(frame, 1, cy, cw as usize, &mut s.cb);
        codes(frame, 2, cy, cw as usize, &mut s.cr);
        // The matrix's chroma terms once per chroma sample.
        s.chroma.clear();
        s.chroma.extend(s.cb.iter().zip(&s.cr).map(|(&cb, &cr)| {
            let (cb, cr) = (self.chroma[cb as usize], self.chroma[cr as usize]);
            [
                self.cr_r * cr,
                -(self.cb_g * cb + self.cr_g * cr),
                self.cb_b * cb,
            ]
        }));
        for (x, (px, &code)) in rgba.chunks_exact_mut(4).zip(&s.y).enumerate() {
            let luma = self.luma[code as usize];
            let c = s.chroma[x >> sx];
            px[0] = self.eotf.apply(luma + c[0]);
            px[1] = self.eotf.apply(luma + c[1]);
            px[2] = self.eotf.apply(luma + c[2]);
            px[3] = 1.0;
        }
    }
}

/// Per-band buffers, reused row after row.
#[derive(Default)]
pub(super) struct RowScratch {
    y: Vec<u16>,
    cb: Vec<u16>,
    cr: Vec<u16>,
    chroma: Vec<[f32; 3]>,
    transmittance: Vec<f32>,
    finite: Vec<bool>,
    grid: Vec<super::veil::GridPoint>,
}

/// The first `n` codes of row `y` of plane `i` into `out`, clamped to the depth's largest code
/// (a stray high bit in a 10-bit sample cannot index past the tables).
fn codes(frame: &YuvFrame, i: usize, y: usize, n: usize, out: &mut Vec<u16>) {
    let p = &frame.planes[i];
    let max = (1u32 << frame.format.bit_depth) - 1;
    out.clear();
    if frame.format.bytes_per_sample() == 1 {
        out.extend(p.data[y * p.stride..][..n].iter().map(|&v| u16::from(v)));
    } else {
        out.extend(
            p.data[y * p.stride..][..2 * n]
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]).min(max as u16)),
        );
    }
}

/// `plate · T' + (1 − T') · S + (1 − T) · L` along row `y`, T' = T + (1 − T) · sky where the
/// pixel's distance is not known finite (see [`super::veil`]).
fn veil_row(v: &Veil, y: u32, rgba: &mut [f32], s: &mut RowScratch) {
    let w = rgba.len() / 4;
    s.transmittance.resize(w, 0.0);
    s.finite.resize(w, false);
    v.transmittance_row(y, &mut s.transmittance, &mut s.finite);
    v.grid_row(y, &mut s.grid);
    let cell = crate::gpu::stages::yuv_to_rgb::GLOW_CELL_PX as usize;
    let pixels = rgba
        .chunks_exact_mut(4)
        .zip(&s.transmittance)
        .zip(&s.finite);
    for (x, ((px, &t), &finite)) in pixels.enumerate() {
        let (g, f) = (x / cell, ((x % cell) as f32 + 0.5) / cell as f32);
        let (a, b) = (s.grid[g], s.grid[g + 1]);
        let at = |c: usize| a[c] + (b[c] - a[c]) * f;
        let sky = if finite { 0.0 } else { at(6) };
        let veil = t + (1.0 - t) * sky;
        for (c, v) in px[..3].iter_mut().enumerate() {
            *v = *v * veil + (1.0 - veil) * at(c) + (1.0 - t) * at(c + 3);
        }
    }
}
