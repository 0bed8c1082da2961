//! Synthetic pictures the GPU tests render on, built code value by code value, and the code
//! values of a rendered frame read back.
#![allow(dead_code)]

use rain_composite::video::{Chroma, ColorParams, FrameFormat, Plane, YuvFrame};

/// A picture of `format` in `color` whose sample of plane `i` (0 = Y) at (x, y) is
/// `code(i, x, y)`; rows tightly packed, the first frame of a clip (`pts` and `index` 0).
pub fn picture(
    format: FrameFormat,
    color: ColorParams,
    code: impl Fn(usize, u32, u32) -> u16,
) -> YuvFrame {
    padded_picture(format, color, 0, code)
}

/// As [`picture`], each row followed by `pad` unused samples (as FFmpeg pads its frames).
pub fn padded_picture(
    format: FrameFormat,
    color: ColorParams,
    pad: usize,
    code: impl Fn(usize, u32, u32) -> u16,
) -> YuvFrame {
    let bytes = format.bytes_per_sample();
    let planes = std::array::from_fn(|i| {
        let (w, h) = format.plane_size(i);
        let stride = format.packed_stride(i) + pad * bytes;
        let mut data = vec![0u8; stride * h as usize];
        for y in 0..h {
            for x in 0..w {
                let v = code(i, x, y);
                let at = y as usize * stride + x as usize * bytes;
                if bytes == 1 {
                    data[at] = v as u8;
                } else {
                    data[at..at + 2].copy_from_slice(&v.to_le_bytes());
                }
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

/// A 4:4:4 10-bit BT.709 picture whose luma is `luma(x, y)` and chroma `chroma(x, y, plane)`.
pub fn picture_444(
    width: u32,
    height: u32,
    luma: impl Fn(u32, u32) -> u16,
    chroma: impl Fn(u32, u32, usize) -> u16,
) -> YuvFrame {
    let format = FrameFormat {
        width,
        height,
        chroma: Chroma::Cs444,
        bit_depth: 10,
    };
    picture(format, ColorParams::bt709(10), |i, x, y| {
        if i == 0 { luma(x, y) } else { chroma(x, y, i) }
    })
}

/// A deterministic hash of plane `i`'s pixel (x, y), spread over 25 bits: reduced modulo a
/// code range it scatters code values over a picture with no pattern a stage could favour.
pub fn scatter(i: usize, x: u32, y: u32) -> u32 {
    (x * 37 + y * 91 + i as u32 * 53).wrapping_mul(2654435761) >> 7
}

/// Code values of every plane of `frame`, row-major, tightly packed.
pub fn codes(frame: &YuvFrame) -> [Vec<u16>; 3] {
    std::array::from_fn(|i| plane_codes(frame, i))
}

/// Code values of plane `i` (0 = Y) of `frame`, row-major, tightly packed.
pub fn plane_codes(frame: &YuvFrame, i: usize) -> Vec<u16> {
    let (w, h) = frame.format.plane_size(i);
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| frame.sample(i, x, y))
        .collect()
}

/// An 8-bit 4:2:0 BT.709 limited-range picture of `width` × `height` from non-linear
/// R′G′B′ values in [0, 1] (row-major; clamped), each chroma sample from its co-sited pixel.
pub fn bt709_420_from_rgb(width: u32, height: u32, rgb: &[[f64; 3]]) -> YuvFrame {
    let format = FrameFormat {
        width,
        height,
        chroma: Chroma::Cs420,
        bit_depth: 8,
    };
    let (kr, kb) = (0.2126, 0.0722);
    let ycc = |x: u32, y: u32| {
        let [r, g, b] = rgb[(y * width + x) as usize].map(|v| v.clamp(0.0, 1.0));
        let luma = kr * r + (1.0 - kr - kb) * g + kb * b;
        [
            16.0 + 219.0 * luma,
            128.0 + 224.0 * (b - luma) / (2.0 * (1.0 - kb)),
            128.0 + 224.0 * (r - luma) / (2.0 * (1.0 - kr)),
        ]
        .map(|v: f64| v.round().clamp(0.0, 255.0) as u16)
    };
    picture(format, ColorParams::bt709(8), |i, x, y| {
        if i == 0 {
            ycc(x, y)[0]
        } else {
            ycc(2 * x, 2 * y)[i]
        }
    })
}

/// Of a `w`×`h` picture labelled pixel by pixel (row-major), the pixels at least `margin` px
/// from any pixel of another label.
pub fn interior<T: PartialEq>(labels: &[T], (w, h): (u32, u32), margin: i64) -> Vec<bool> {
    (0..(w * h) as usize)
        .map(|i| {
            let (x, y) = ((i as u32 % w) as i64, (i as u32 / w) as i64);
            (-margin..=margin).all(|dy| {
                (-margin..=margin).all(|dx| {
                    let (u, v) = (x + dx, y + dy);
                    u < 0
                        || v < 0
                        || u >= w as i64
                        || v >= h as i64
                        || labels[(v as u32 * w + u as u32) as usize] == labels[i]
                })
            })
        })
        .collect()
}
