//! Decoded pictures as the GPU consumes and produces them: three planes, Y, Cb, Cr.
//!
//! Every input pixel format is brought to one of the planar layouts below before it leaves the
//! decoder (NV12, packed RGB, grey… go through swscale without a matrix change, which only
//! rearranges samples), so the GPU side handles exactly one family of layouts.

use super::color::ColorParams;

/// Chroma subsampling of a planar YUV picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
pub enum Chroma {
    /// Half width, half height (4:2:0).
    Cs420,
    /// Half width, full height (4:2:2).
    Cs422,
    /// Full resolution (4:4:4).
    Cs444,
}

impl Chroma {
    /// log2 of the horizontal and vertical subsampling factors.
    pub fn shift(self) -> (u32, u32) {
        match self {
            Chroma::Cs420 => (1, 1),
            Chroma::Cs422 => (1, 0),
            Chroma::Cs444 => (0, 0),
        }
    }
}

/// Size, subsampling and sample depth of a planar picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
pub struct FrameFormat {
    /// Luma width in pixels (coded picture, before display rotation).
    pub width: u32,
    /// Luma height in pixels.
    pub height: u32,
    /// Chroma subsampling.
    pub chroma: Chroma,
    /// Bits per sample: 8 (one byte per sample) or 9..=16 (two bytes, little-endian, LSB-aligned).
    pub bit_depth: u8,
}

impl FrameFormat {
    /// Bytes per sample in memory.
    pub fn bytes_per_sample(&self) -> usize {
        if self.bit_depth > 8 { 2 } else { 1 }
    }

    /// Width and height of plane `i` (0 = Y, 1 = Cb, 2 = Cr); odd sizes round up.
    pub fn plane_size(&self, i: usize) -> (u32, u32) {
        if i == 0 {
            return (self.width, self.height);
        }
        let (sx, sy) = self.chroma.shift();
        (self.width.div_ceil(1 << sx), self.height.div_ceil(1 << sy))
    }

    /// Tightly packed row length of plane `i`, bytes.
    pub fn packed_stride(&self, i: usize) -> usize {
        self.plane_size(i).0 as usize * self.bytes_per_sample()
    }
}

/// One plane's samples; rows are `stride` bytes apart (≥ the packed row length).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Plane {
    /// Samples, row-major.
    pub data: Vec<u8>,
    /// Bytes from one row to the next.
    pub stride: usize,
}

/// A decoded (or rendered) picture with its colour interpretation and timestamp.
#[derive(Debug, Clone, PartialEq)]
pub struct YuvFrame {
    /// Layout of the planes.
    pub format: FrameFormat,
    /// How the samples map to light.
    pub color: ColorParams,
    /// Y, Cb, Cr.
    pub planes: [Plane; 3],
    /// Presentation timestamp in the input stream's time base (passed through unchanged).
    pub pts: i64,
    /// Zero-based index of the frame in decode (= presentation) order.
    pub index: u64,
}

/// The one display-rotation map: coded position = m·display + offset, for a picture of coded
/// size `coded_w`×`coded_h` shown turned by `rotation_deg` (counter-clockwise, as
/// `VideoInfo::rotation_deg`; other angles than quarter turns are shown as coded).
/// Returns (column-major 2×2 matrix, offset), continuous coordinates (pixel corners).
pub fn coded_from_display(rotation_deg: i32, coded_w: f64, coded_h: f64) -> ([f64; 4], [f64; 2]) {
    match rotation_deg.rem_euclid(360) {
        // Displayed = coded turned 90° counter-clockwise: display (x, y) ← coded (W − y, x).
        90 => ([0.0, 1.0, -1.0, 0.0], [coded_w, 0.0]),
        180 => ([-1.0, 0.0, 0.0, -1.0], [coded_w, coded_h]),
        // Displayed = coded turned 90° clockwise: display (x, y) ← coded (y, H − x).
        270 => ([0.0, -1.0, 1.0, 0.0], [0.0, coded_h]),
        _ => ([1.0, 0.0, 0.0, 1.0], [0.0, 0.0]),
    }
}

/// The displayed size of a coded picture `coded_w`×`coded_h` turned by `rotation_deg`.
pub fn display_size(rotation_deg: i32, coded_w: u32, coded_h: u32) -> (u32, u32) {
    if rotation_deg.rem_euclid(180) == 90 {
        (coded_h, coded_w)
    } else {
        (coded_w, coded_h)
    }
}

/// The coded pixel shown at displayed pixel (x, y): [`coded_from_display`] at the pixel's
/// centre.
pub fn coded_pixel(rotation_deg: i32, coded_w: u32, coded_h: u32, x: u32, y: u32) -> (u32, u32) {
    let (m, off) = coded_from_display(rotation_deg, coded_w as f64, coded_h as f64);
    let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
    let cx = m[0] * px + m[2] * py + off[0];
    let cy = m[1] * px + m[3] * py + off[1];
    (
        (cx.floor().max(0.0) as u32).min(coded_w.saturating_sub(1)),
        (cy.floor().max(0.0) as u32).min(coded_h.saturating_sub(1)),
    )
}

impl YuvFrame {
    /// A picture of one flat colour given as code values `(y, cb, cr)`, tightly packed.
    pub fn filled(format: FrameFormat, color: ColorParams, yuv: [u16; 3]) -> YuvFrame {
        let planes = std::array::from_fn(|i| {
            let (w, h) = format.plane_size(i);
            let stride = format.packed_stride(i);
            let mut data = Vec::with_capacity(stride * h as usize);
            for _ in 0..(w as usize * h as usize) {
                if format.bytes_per_sample() == 1 {
                    data.push(yuv[i] as u8);
                } else {
                    data.extend_from_slice(&yuv[i].to_le_bytes());
                }
            }
            Plane { data, stride }
        });
        YuvFrame {
            format,
            color,
            planes,
            pts: 0,
            index: 0,
        }
    }

    /// Sample of plane `i` at (x, y) as an integer code value.
    pub fn sample(&self, i: usize, x: u32, y: u32) -> u16 {
        let p = &self.planes[i];
        let at = y as usize * p.stride + x as usize * self.format.bytes_per_sample();
        if self.format.bytes_per_sample() == 1 {
            p.data[at] as u16
        } else {
            u16::from_le_bytes([p.data[at], p.data[at + 1]])
        }
    }
}

#[cfg(test)]
mod rotation_tests {
    use super::*;

    /// The pixel map derived from the one affine map agrees with each quarter turn written out
    /// by hand, and the displayed size with the turn.
    #[test]
    fn coded_pixel_follows_each_quarter_turn() {
        let (w, h) = (5u32, 3u32);
        for rotation in [0, 90, 180, 270, -90, 450] {
            let (dw, dh) = display_size(rotation, w, h);
            assert_eq!((dw * dh), w * h);
            for y in 0..dh {
                for x in 0..dw {
                    let want = match rotation.rem_euclid(360) {
                        90 => (w - 1 - y, x),
                        180 => (w - 1 - x, h - 1 - y),
                        270 => (y, h - 1 - x),
                        _ => (x, y),
                    };
                    assert_eq!(
                        coded_pixel(rotation, w, h, x, y),
                        want,
                        "{rotation}° at {x},{y}"
                    );
                }
            }
        }
    }
}
