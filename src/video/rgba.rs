//! 8-bit RGBA pictures (an editor's frames, sRGB and display-referred) ↔ the planar frames
//! the renderer takes.
//!
//! A host such as a frei0r filter hands over packed R, G, B, A bytes. They become 16-bit
//! 4:4:4 full-range BT.709 Y'CbCr tagged with the sRGB transfer ([`RGBA8_COLOR`]): sixteen
//! bits keep every 8-bit colour apart with room to spare (the round trip's error is below a
//! hundredth of an 8-bit step), 4:4:4 keeps full chroma, and the renderer decodes the sRGB
//! transfer to the same linear light a `preview` of an RGB file decodes. So a frame the
//! renderer leaves untouched comes back bit for bit; alpha is not rendered and passes through.

use rayon::prelude::*;

use super::color::{Matrix, Transfer, rgb_to_ycbcr, ycbcr_to_rgb};
use super::{Chroma, ColorParams, FrameFormat, Plane, YuvFrame};
use crate::{Error, Result};

/// How the planes made from 8-bit RGBA are to be read: full-range BT.709 at 16 bits with the
/// sRGB transfer (the primaries of sRGB are BT.709's).
pub const RGBA8_COLOR: ColorParams = ColorParams {
    matrix: Matrix::Bt709,
    full_range: true,
    transfer: Transfer::Srgb,
    bit_depth: 16,
};

/// The planar layout of a `width`×`height` RGBA picture: 4:4:4 at 16 bits.
pub fn rgba8_format(width: u32, height: u32) -> FrameFormat {
    FrameFormat {
        width,
        height,
        chroma: Chroma::Cs444,
        bit_depth: 16,
    }
}

/// Bytes of a tightly packed `width`×`height` RGBA picture, or an error when the size
/// overflows.
fn rgba_len(width: u32, height: u32) -> Result<usize> {
    (width as usize)
        .checked_mul(height as usize)
        .and_then(|n| n.checked_mul(4))
        .ok_or_else(|| Error::Unsupported(format!("a {width}×{height} picture")))
}

fn size_error(what: &str, len: usize, width: u32, height: u32) -> Error {
    Error::Parameter {
        name: "frame",
        value: format!("{what} of {len} bytes"),
        expected: format!("{width}×{height} RGBA pixels, 4 bytes each"),
    }
}

/// The planes of a tightly packed 8-bit RGBA picture (rows top to bottom), in
/// [`RGBA8_COLOR`]; alpha is ignored.
pub fn planes_from_rgba8(rgba: &[u8], width: u32, height: u32) -> Result<YuvFrame> {
    let len = rgba_len(width, height)?;
    if rgba.len() != len || width == 0 || height == 0 {
        return Err(size_error("a picture", rgba.len(), width, height));
    }
    let format = rgba8_format(width, height);
    let stride = format.packed_stride(0);
    let s = RGBA8_COLOR.range_scale();
    let code = |v: f64, offset: f64, scale: f64| -> [u8; 2] {
        ((v * scale + offset).round().clamp(0.0, s.max_code) as u16).to_le_bytes()
    };
    let mut planes: [Vec<u8>; 3] = std::array::from_fn(|_| vec![0u8; stride * height as usize]);
    let [y_plane, cb_plane, cr_plane] = &mut planes;
    y_plane
        .par_chunks_mut(stride)
        .zip(cb_plane.par_chunks_mut(stride))
        .zip(cr_plane.par_chunks_mut(stride))
        .zip(rgba.par_chunks(width as usize * 4))
        .for_each(|(((y_row, cb_row), cr_row), src)| {
            for (x, px) in src.chunks_exact(4).enumerate() {
                let rgb = [px[0], px[1], px[2]].map(|v| f64::from(v) / 255.0);
                let [y, cb, cr] = rgb_to_ycbcr(RGBA8_COLOR.matrix, rgb);
                y_row[2 * x..2 * x + 2].copy_from_slice(&code(y, s.y_offset, s.y_scale));
                cb_row[2 * x..2 * x + 2].copy_from_slice(&code(cb, s.c_offset, s.c_scale));
                cr_row[2 * x..2 * x + 2].copy_from_slice(&code(cr, s.c_offset, s.c_scale));
            }
        });
    Ok(YuvFrame {
        format,
        color: RGBA8_COLOR,
        planes: planes.map(|data| Plane { data, stride }),
        pts: 0,
        index: 0,
    })
}

/// Writes `frame` as tightly packed 8-bit RGBA into `out`: R'G'B' by the frame's own matrix
/// and range (chroma from the co-sited sample), rounded to the nearest code, and the alpha of
/// `alpha_from` (an RGBA picture of the same size, usually the input).
pub fn rgba8_from_planes(frame: &YuvFrame, alpha_from: &[u8], out: &mut [u8]) -> Result<()> {
    let f = frame.format;
    let len = rgba_len(f.width, f.height)?;
    if out.len() != len {
        return Err(size_error("an output", out.len(), f.width, f.height));
    }
    if alpha_from.len() != len {
        return Err(size_error(
            "an alpha source",
            alpha_from.len(),
            f.width,
            f.height,
        ));
    }
    for (i, plane) in frame.planes.iter().enumerate() {
        let (_, h) = f.plane_size(i);
        let need = (h as usize).saturating_sub(1) * plane.stride + f.packed_stride(i);
        if plane.stride < f.packed_stride(i) || plane.data.len() < need {
            return Err(Error::Parameter {
                name: "frame",
                value: format!(
                    "plane {i}: {} bytes, stride {}",
                    plane.data.len(),
                    plane.stride
                ),
                expected: format!("{h} rows of at least {} bytes", f.packed_stride(i)),
            });
        }
    }
    let (sx, sy) = f.chroma.shift();
    let s = frame.color.range_scale();
    let matrix = frame.color.matrix;
    let row_bytes = f.width as usize * 4;
    out.par_chunks_mut(row_bytes)
        .zip(alpha_from.par_chunks(row_bytes))
        .enumerate()
        .for_each(|(y, (dst, alpha))| {
            let y = y as u32;
            for x in 0..f.width {
                let ycc = [
                    (f64::from(frame.sample(0, x, y)) - s.y_offset) / s.y_scale,
                    (f64::from(frame.sample(1, x >> sx, y >> sy)) - s.c_offset) / s.c_scale,
                    (f64::from(frame.sample(2, x >> sx, y >> sy)) - s.c_offset) / s.c_scale,
                ];
                let rgb = ycbcr_to_rgb(matrix, ycc);
                let at = x as usize * 4;
                for k in 0..3 {
                    dst[at + k] = (rgb[k].clamp(0.0, 1.0) * 255.0).round() as u8;
                }
                dst[at + 3] = alpha[at + 3];
            }
        });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every 8-bit colour (a 3-step lattice plus both ends of each channel) goes to planes and
    /// back unchanged, alpha with it.
    #[test]
    fn every_colour_comes_back() {
        let levels: Vec<u8> = (0..=255u8).step_by(3).chain([254, 255]).collect();
        let n = levels.len();
        let mut rgba = Vec::with_capacity(n * n * n * 4);
        for &r in &levels {
            for &g in &levels {
                for &b in &levels {
                    rgba.extend_from_slice(&[r, g, b, r ^ g ^ b]);
                }
            }
        }
        let (w, h) = ((n * n) as u32, n as u32);
        let frame = planes_from_rgba8(&rgba, w, h).unwrap();
        assert_eq!(frame.format, rgba8_format(w, h));
        let mut back = vec![0u8; rgba.len()];
        rgba8_from_planes(&frame, &rgba, &mut back).unwrap();
        assert!(back == rgba, "the round trip changed a colour");
    }

    /// Grey stays neutral: chroma at the centre code, luma the 8-bit value times 257.
    #[test]
    fn grey_is_neutral_and_white_is_full_scale() {
        let rgba = [0, 0, 0, 255, 128, 128, 128, 255, 255, 255, 255, 255];
        let frame = planes_from_rgba8(&rgba, 3, 1).unwrap();
        for (x, v) in [(0, 0u16), (1, 128 * 257), (2, 65535)] {
            assert_eq!(frame.sample(0, x, 0), v);
            assert_eq!(frame.sample(1, x, 0), 32768);
            assert_eq!(frame.sample(2, x, 0), 32768);
        }
    }

    #[test]
    fn wrong_sizes_are_errors() {
        assert!(planes_from_rgba8(&[0; 12], 2, 2).is_err());
        assert!(planes_from_rgba8(&[], 0, 0).is_err());
        let frame = planes_from_rgba8(&[0; 16], 2, 2).unwrap();
        assert!(rgba8_from_planes(&frame, &[0; 16], &mut [0; 12]).is_err());
        assert!(rgba8_from_planes(&frame, &[0; 8], &mut [0; 16]).is_err());
    }
}
