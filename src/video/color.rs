//! How code values map to light: matrix, range and transfer, from the frame's own tags.
//!
//! The GPU converts YUV → linear RGB and back with exactly these parameters
//! (`shaders/yuv_to_rgb.wgsl`, `shaders/rgb_to_yuv.wgsl`); the functions here are their CPU
//! twins, used as the reference in tests. Both directions use one [`ColorParams`], so a frame
//! without rain comes back as it went in (no BT.601/709 mix-ups, no range crush).

use serde::Serialize;

/// The YCbCr matrix (luma coefficients Kr, Kb).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum Matrix {
    /// ITU-R BT.601 (also SMPTE 170M, BT.470BG).
    Bt601,
    /// ITU-R BT.709.
    Bt709,
    /// ITU-R BT.2020 non-constant luminance.
    Bt2020Ncl,
    /// SMPTE 240M.
    Smpte240m,
    /// FCC 73.682.
    Fcc,
}

impl Matrix {
    /// (Kr, Kb).
    pub fn kr_kb(self) -> (f64, f64) {
        match self {
            Matrix::Bt601 => (0.299, 0.114),
            Matrix::Bt709 => (0.2126, 0.0722),
            Matrix::Bt2020Ncl => (0.2627, 0.0593),
            Matrix::Smpte240m => (0.212, 0.087),
            Matrix::Fcc => (0.30, 0.11),
        }
    }
}

/// The opto-electronic transfer function the code values were encoded with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum Transfer {
    /// ITU-R BT.709 / BT.601 / BT.2020 camera OETF (piecewise: linear toe, 0.45 power).
    Bt709,
    /// IEC 61966-2-1 sRGB.
    Srgb,
    /// Pure power 2.2 (BT.470M).
    Gamma22,
    /// Pure power 2.8 (BT.470BG).
    Gamma28,
    /// Already linear.
    Linear,
    /// SMPTE ST 2084 (PQ); linear 1.0 = 203 cd/m² (BT.2408 reference white).
    Pq,
    /// ARIB STD-B67 (HLG) inverse OETF, scene-referred; linear 1.0 = reference white (75 %
    /// signal, ITU-R BT.2408), so the nominal peak is 3.77.
    Hlg,
}

impl Transfer {
    /// GPU enumeration value (see `shaders/common/color.wgsl`).
    pub fn gpu_id(self) -> u32 {
        self as u32
    }
}

/// Everything needed to turn code values into linear light and back.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ColorParams {
    /// YCbCr matrix.
    pub matrix: Matrix,
    /// Full ("JPEG", PC) range rather than limited ("MPEG", TV) range.
    pub full_range: bool,
    /// Transfer function.
    pub transfer: Transfer,
    /// Bits per sample of the code values.
    pub bit_depth: u8,
}

/// Offsets and scales turning code values into normalised Y' ∈ \[0, 1\], C ∈ \[−½, ½\].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeScale {
    /// Code value of black.
    pub y_offset: f64,
    /// Code span from black to white.
    pub y_scale: f64,
    /// Code value of zero chroma.
    pub c_offset: f64,
    /// Code span of the chroma range (from −½ to +½).
    pub c_scale: f64,
    /// Largest code value.
    pub max_code: f64,
}

impl ColorParams {
    /// BT.709 limited range, BT.709 transfer, 8-bit: the default of HD video.
    pub fn bt709(bit_depth: u8) -> ColorParams {
        ColorParams {
            matrix: Matrix::Bt709,
            full_range: false,
            transfer: Transfer::Bt709,
            bit_depth,
        }
    }

    /// The code-value offsets and scales for this range and depth (BT.601/709/2020 §2).
    pub fn range_scale(&self) -> RangeScale {
        let max_code = ((1u32 << self.bit_depth) - 1) as f64;
        let unit = (1u32 << (self.bit_depth - 8)) as f64;
        let c_offset = (1u32 << (self.bit_depth - 1)) as f64;
        if self.full_range {
            RangeScale {
                y_offset: 0.0,
                y_scale: max_code,
                c_offset,
                c_scale: max_code,
                max_code,
            }
        } else {
            RangeScale {
                y_offset: 16.0 * unit,
                y_scale: 219.0 * unit,
                c_offset,
                c_scale: 224.0 * unit,
                max_code,
            }
        }
    }

    /// Code values (Y, Cb, Cr) → linear RGB. Not clamped: out-of-gamut values survive the round
    /// trip, so a frame without rain comes back unchanged.
    pub fn code_to_linear(&self, yuv: [f64; 3]) -> [f64; 3] {
        self.code_to_encoded(yuv)
            .map(|v| eotf_signed(self.transfer, v))
    }

    /// Code values (Y, Cb, Cr) → encoded R'G'B' (before the transfer).
    pub fn code_to_encoded(&self, yuv: [f64; 3]) -> [f64; 3] {
        let s = self.range_scale();
        let y = (yuv[0] - s.y_offset) / s.y_scale;
        let cb = (yuv[1] - s.c_offset) / s.c_scale;
        let cr = (yuv[2] - s.c_offset) / s.c_scale;
        ycbcr_to_rgb(self.matrix, [y, cb, cr])
    }

    /// Linear RGB → code values (rounded and clamped to the legal code range).
    pub fn linear_to_code(&self, rgb: [f64; 3]) -> [f64; 3] {
        let s = self.range_scale();
        let e = rgb.map(|v| oetf_signed(self.transfer, v));
        let [y, cb, cr] = rgb_to_ycbcr(self.matrix, e);
        [
            (y * s.y_scale + s.y_offset).round().clamp(0.0, s.max_code),
            (cb * s.c_scale + s.c_offset).round().clamp(0.0, s.max_code),
            (cr * s.c_scale + s.c_offset).round().clamp(0.0, s.max_code),
        ]
    }
}

/// Non-linear Y'CbCr (Y' ∈ \[0, 1\], C ∈ \[−½, ½\]) → R'G'B'.
pub fn ycbcr_to_rgb(matrix: Matrix, [y, cb, cr]: [f64; 3]) -> [f64; 3] {
    let (kr, kb) = matrix.kr_kb();
    let kg = 1.0 - kr - kb;
    let r = y + 2.0 * (1.0 - kr) * cr;
    let b = y + 2.0 * (1.0 - kb) * cb;
    let g = (y - kr * r - kb * b) / kg;
    [r, g, b]
}

/// R'G'B' → non-linear Y'CbCr.
pub fn rgb_to_ycbcr(matrix: Matrix, [r, g, b]: [f64; 3]) -> [f64; 3] {
    let (kr, kb) = matrix.kr_kb();
    let kg = 1.0 - kr - kb;
    let y = kr * r + kg * g + kb * b;
    [
        y,
        (b - y) / (2.0 * (1.0 - kb)),
        (r - y) / (2.0 * (1.0 - kr)),
    ]
}

/// Encoded value → linear light, odd-extended to negative values (so the round trip of an
/// out-of-gamut pixel is exact).
pub fn eotf_signed(t: Transfer, v: f64) -> f64 {
    v.signum() * to_linear(t, v.abs())
}

/// Linear light → encoded value, odd-extended.
pub fn oetf_signed(t: Transfer, v: f64) -> f64 {
    v.signum() * from_linear(t, v.abs())
}

/// A transfer's [`eotf_signed`] as a fine table read by linear interpolation, for loops that
/// convert many samples (a `pow` a channel is the cost otherwise): the transfer follows the
/// matrix, so its input is a mix of three codes and no exact per-code table exists. The steps
/// are 2⁻¹⁰ of each power of two (the top ten bits of the mantissa), so a power curve is
/// followed as closely at black as at white; steps the line does not follow within
/// [`EotfTable::RELATIVE_ERROR`] (the linear segments' knees, PQ's foot) and values outside
/// [2⁻²⁴, 4) are computed by the function itself.
#[derive(Debug, Clone)]
pub struct EotfTable {
    transfer: Transfer,
    /// Linear light at the steps' starts (and the last step's end).
    table: Vec<f64>,
    /// Per step: whether its line strays from the curve (then the function runs).
    exact: Vec<bool>,
}

impl EotfTable {
    /// Mantissa bits that pick a step within a power of two.
    const STEP_BITS: u32 = 10;
    /// The table's first power of two, 2^`LOWEST`; it ends at 4 (out-of-gamut chroma reaches
    /// about 2.6).
    const LOWEST: i32 = -24;
    const STEPS: usize = ((2 - Self::LOWEST) as usize) << Self::STEP_BITS;
    /// How far, relative to the value, the table may stray from the function: a block mean of
    /// the frame's light moves by at most this, and a sample compared with a level decides as
    /// the function does where it lies farther than this from it.
    pub const RELATIVE_ERROR: f64 = 1e-6;

    /// The encoded value where step `i` starts.
    fn start(i: usize) -> f64 {
        let (e, m) = (i >> Self::STEP_BITS, i & ((1 << Self::STEP_BITS) - 1));
        2f64.powi(Self::LOWEST + e as i32) * (1.0 + m as f64 / f64::from(1u32 << Self::STEP_BITS))
    }

    /// The table of `transfer`.
    pub fn new(transfer: Transfer) -> EotfTable {
        let f = |e: f64| eotf_signed(transfer, e);
        let table: Vec<f64> = (0..=Self::STEPS).map(|i| f(Self::start(i))).collect();
        // The line's largest miss in a step lies at most twice as far as its miss at the
        // midpoint (at a knee; less on a smooth curve): hold the midpoint to half the bound.
        let exact = table
            .windows(2)
            .enumerate()
            .map(|(i, ab)| {
                let mid = f(0.5 * (Self::start(i) + Self::start(i + 1)));
                (0.5 * (ab[0] + ab[1]) - mid).abs() > 0.5 * Self::RELATIVE_ERROR * mid.abs()
            })
            .collect();
        EotfTable {
            transfer,
            table,
            exact,
        }
    }

    /// The transfer tabulated.
    pub fn transfer(&self) -> Transfer {
        self.transfer
    }

    /// Linear light of encoded value `e` (odd-extended), within [`Self::RELATIVE_ERROR`] of
    /// [`eotf_signed`].
    #[inline]
    pub fn apply(&self, e: f64) -> f64 {
        let bits = e.abs().to_bits();
        // The power of two and the step within it, from the bits; the rest of the mantissa is
        // the place within the step.
        let power = (bits >> 52) as i64 - 1023 - i64::from(Self::LOWEST);
        let low = 52 - Self::STEP_BITS;
        let i = ((power << Self::STEP_BITS) + ((bits >> low) & ((1 << Self::STEP_BITS) - 1)) as i64)
            as usize;
        if (0..2 - i64::from(Self::LOWEST)).contains(&power) && !self.exact[i] {
            let t = (bits & ((1 << low) - 1)) as f64 / (1u64 << low) as f64;
            let (a, b) = (self.table[i], self.table[i + 1]);
            return (a + (b - a) * t).copysign(e);
        }
        eotf_signed(self.transfer, e)
    }
}

// BT.709 OETF constants to full precision (as BT.2020 states them), so both branches meet.
const BT709_ALPHA: f64 = 1.099_296_826_809_44;
const BT709_BETA: f64 = 0.018_053_968_510_807;
// ST 2084 constants.
const PQ_M1: f64 = 2610.0 / 16384.0;
const PQ_M2: f64 = 2523.0 / 4096.0 * 128.0;
const PQ_C1: f64 = 3424.0 / 4096.0;
const PQ_C2: f64 = 2413.0 / 4096.0 * 32.0;
const PQ_C3: f64 = 2392.0 / 4096.0 * 32.0;
/// PQ peak over reference white: 10 000 / 203 cd/m².
const PQ_PEAK_OVER_WHITE: f64 = 10000.0 / 203.0;
// ARIB STD-B67 constants.
const HLG_A: f64 = 0.178_832_77;
const HLG_B: f64 = 0.284_668_92;
const HLG_C: f64 = 0.559_910_73;
/// HLG's reference white as scene light (the inverse OETF of 75 % signal, ITU-R BT.2408):
/// dividing by it puts diffuse white at 1.0 as every other transfer does.
const HLG_REF_WHITE: f64 = 0.264_962_559_786_400_15;

fn to_linear(t: Transfer, e: f64) -> f64 {
    match t {
        Transfer::Bt709 => {
            if e < 4.5 * BT709_BETA {
                e / 4.5
            } else {
                ((e + BT709_ALPHA - 1.0) / BT709_ALPHA).powf(1.0 / 0.45)
            }
        }
        Transfer::Srgb => {
            if e <= 0.04045 {
                e / 12.92
            } else {
                ((e + 0.055) / 1.055).powf(2.4)
            }
        }
        Transfer::Gamma22 => e.powf(2.2),
        Transfer::Gamma28 => e.powf(2.8),
        Transfer::Linear => e,
        Transfer::Pq => {
            let p = e.powf(1.0 / PQ_M2);
            let num = (p - PQ_C1).max(0.0);
            (num / (PQ_C2 - PQ_C3 * p)).powf(1.0 / PQ_M1) * PQ_PEAK_OVER_WHITE
        }
        Transfer::Hlg => {
            let scene = if e <= 0.5 {
                e * e / 3.0
            } else {
                (((e - HLG_C) / HLG_A).exp() + HLG_B) / 12.0
            };
            scene / HLG_REF_WHITE
        }
    }
}

fn from_linear(t: Transfer, l: f64) -> f64 {
    match t {
        Transfer::Bt709 => {
            if l < BT709_BETA {
                4.5 * l
            } else {
                BT709_ALPHA * l.powf(0.45) - (BT709_ALPHA - 1.0)
            }
        }
        Transfer::Srgb => {
            if l <= 0.003_130_8 {
                12.92 * l
            } else {
                1.055 * l.powf(1.0 / 2.4) - 0.055
            }
        }
        Transfer::Gamma22 => l.powf(1.0 / 2.2),
        Transfer::Gamma28 => l.powf(1.0 / 2.8),
        Transfer::Linear => l,
        Transfer::Pq => {
            let y = (l / PQ_PEAK_OVER_WHITE).powf(PQ_M1);
            ((PQ_C1 + PQ_C2 * y) / (1.0 + PQ_C3 * y)).powf(PQ_M2)
        }
        Transfer::Hlg => {
            let scene = l * HLG_REF_WHITE;
            if scene <= 1.0 / 12.0 {
                (3.0 * scene).sqrt()
            } else {
                HLG_A * (12.0 * scene - HLG_B).ln() + HLG_C
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL_TRANSFERS: [Transfer; 7] = [
        Transfer::Bt709,
        Transfer::Srgb,
        Transfer::Gamma22,
        Transfer::Gamma28,
        Transfer::Linear,
        Transfer::Pq,
        Transfer::Hlg,
    ];

    /// The table against the function over [−5, 5], densely and off the table's steps: within
    /// its bound everywhere (where it runs the function, exactly).
    #[test]
    fn the_transfer_table_follows_the_function() {
        for t in ALL_TRANSFERS {
            let table = EotfTable::new(t);
            let (mut worst, mut exact) = (0f64, 0);
            for i in -5_000_000..=5_000_000 {
                let e = i as f64 * 1e-6 + 3.7e-8;
                let (ours, exact_v) = (table.apply(e), eotf_signed(t, e));
                let off = (ours - exact_v).abs() / exact_v.abs().max(f64::MIN_POSITIVE);
                worst = worst.max(off);
                exact += usize::from(ours == exact_v);
            }
            eprintln!("{t:?}: worst {worst:.2e} relative, {exact} of 10⁷ exact");
            assert!(worst <= EotfTable::RELATIVE_ERROR, "{t:?}: {worst}");
            assert_eq!(table.apply(-0.3), -table.apply(0.3), "{t:?}");
        }
    }

    #[test]
    fn transfers_invert_and_are_continuous() {
        for t in ALL_TRANSFERS {
            for i in 0..=1000 {
                let e = i as f64 / 1000.0;
                let back = from_linear(t, to_linear(t, e));
                // PQ code 0 is 7e-7 above zero light by its definition (c1^m2).
                assert!((back - e).abs() < 1e-6, "{t:?} at {e}: {back}");
            }
            // No jump at the piecewise joins: neighbouring samples stay close.
            for i in 1..=10_000 {
                let (a, b) = ((i - 1) as f64 / 1e4, i as f64 / 1e4);
                assert!((to_linear(t, b) - to_linear(t, a)).abs() < 0.02 * PQ_PEAK_OVER_WHITE);
            }
        }
    }

    #[test]
    fn reference_white_and_black_map_to_one_and_zero() {
        for t in [
            Transfer::Bt709,
            Transfer::Srgb,
            Transfer::Gamma22,
            Transfer::Linear,
        ] {
            assert!((to_linear(t, 1.0) - 1.0).abs() < 1e-12);
            assert_eq!(to_linear(t, 0.0), 0.0);
        }
        // HLG: 0.5 is 1/12 of the nominal peak and 1.0 the peak (ARIB STD-B67, to its
        // constants' 8 digits), and 75 % signal is reference white (BT.2408): the peak is
        // 12 / (e^((0.75 − c)/a) + b) times white.
        let peak = 12.0 / (((0.75 - HLG_C) / HLG_A).exp() + HLG_B);
        assert!((to_linear(Transfer::Hlg, 0.75) - 1.0).abs() < 1e-12);
        assert!((to_linear(Transfer::Hlg, 1.0) - peak).abs() < 1e-6 * peak);
        assert!((to_linear(Transfer::Hlg, 0.5) - peak / 12.0).abs() < 1e-6);
        // PQ: 10000 cd/m² is code 1.0.
        assert!((to_linear(Transfer::Pq, 1.0) - PQ_PEAK_OVER_WHITE).abs() < 1e-9);
    }

    #[test]
    fn matrix_roundtrip_and_known_bt709_values() {
        // BT.709 limited 8-bit: code (235,128,128) is white, (16,128,128) black; pure red
        // is (63, 102, 240) per BT.709 tables.
        let p = ColorParams::bt709(8);
        let white = p.code_to_linear([235.0, 128.0, 128.0]);
        assert!(white.iter().all(|v| (v - 1.0).abs() < 1e-12));
        let red = p.linear_to_code([1.0, 0.0, 0.0]);
        assert_eq!(red, [63.0, 102.0, 240.0]);
        for m in [
            Matrix::Bt601,
            Matrix::Bt709,
            Matrix::Bt2020Ncl,
            Matrix::Smpte240m,
            Matrix::Fcc,
        ] {
            let rgb = [0.3, -0.2, 1.1];
            let back = ycbcr_to_rgb(m, rgb_to_ycbcr(m, rgb));
            for k in 0..3 {
                assert!((back[k] - rgb[k]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn every_code_value_survives_the_round_trip() {
        for full_range in [false, true] {
            for bit_depth in [8u8, 10] {
                let p = ColorParams {
                    matrix: Matrix::Bt601,
                    full_range,
                    transfer: Transfer::Srgb,
                    bit_depth,
                };
                let max = (1u32 << bit_depth) - 1;
                for y in (0..=max).step_by(7) {
                    for c in (0..=max).step_by(31) {
                        let code = [y as f64, c as f64, (max - c) as f64];
                        let back = p.linear_to_code(p.code_to_linear(code));
                        assert_eq!(back, code, "{p:?}");
                    }
                }
            }
        }
    }
}
