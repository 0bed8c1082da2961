//! The CPU twin of the `rgb_to_yuv` stage: the linear canvas → code values, luma per pixel,
//! chroma the box average of the block's per-pixel encoded chroma (the inverse of the
//! co-sited upsampling of `yuv_to_rgb`), with [`crate::video::color`]'s transfer and matrix.

use crate::video::color::{oetf_signed, rgb_to_ycbcr};
use crate::video::{ColorParams, FrameFormat};

/// The code planes (Y, Cb, Cr; row-major, tightly packed) of the linear `canvas` (row-major,
/// `format.width` × `format.height`).
pub fn rgb_to_yuv(canvas: &[[f64; 3]], format: FrameFormat, color: &ColorParams) -> [Vec<u16>; 3] {
    let s = color.range_scale();
    let (w, h) = (format.width, format.height);
    let ycc = |x: u32, y: u32| {
        let rgb = canvas[(y * w + x) as usize];
        rgb_to_ycbcr(color.matrix, rgb.map(|v| oetf_signed(color.transfer, v)))
    };
    let code = |v: f64, scale: f64, offset: f64| {
        (v * scale + offset).round().clamp(0.0, s.max_code) as u16
    };
    let luma = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| code(ycc(x, y)[0], s.y_scale, s.y_offset))
        .collect();
    let (cw, ch) = format.plane_size(1);
    let (sx, sy) = format.chroma.shift();
    let mut cb = Vec::with_capacity((cw * ch) as usize);
    let mut cr = Vec::with_capacity((cw * ch) as usize);
    for cy in 0..ch {
        for cx in 0..cw {
            let (x0, y0) = (cx << sx, cy << sy);
            let (x1, y1) = ((x0 + (1 << sx)).min(w), (y0 + (1 << sy)).min(h));
            let mut sum = [0.0; 2];
            for y in y0..y1 {
                for x in x0..x1 {
                    let c = ycc(x, y);
                    sum[0] += c[1];
                    sum[1] += c[2];
                }
            }
            let n = ((x1 - x0) * (y1 - y0)) as f64;
            cb.push(code(sum[0] / n, s.c_scale, s.c_offset));
            cr.push(code(sum[1] / n, s.c_scale, s.c_offset));
        }
    }
    [luma, cb, cr]
}
