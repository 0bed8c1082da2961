//! The CPU twin of the `yuv_to_rgb` stage: decoded code values → linear RGB, chroma taken
//! from the co-sited sample, then the haze (`background · T + in-scatter`), through
//! [`crate::video::ColorParams::code_to_linear`].

use crate::video::YuvFrame;

/// The linear canvas of `frame` (coded orientation, row-major RGB) under the haze
/// `haze` = (in-scatter rgb, transmittance), as `RainParams::haze` holds it.
pub fn yuv_to_rgb(frame: &YuvFrame, haze: [f32; 4]) -> Vec<[f64; 3]> {
    let f = frame.format;
    let (sx, sy) = f.chroma.shift();
    let mut out = Vec::with_capacity((f.width * f.height) as usize);
    for y in 0..f.height {
        for x in 0..f.width {
            let code = [
                frame.sample(0, x, y) as f64,
                frame.sample(1, x >> sx, y >> sy) as f64,
                frame.sample(2, x >> sx, y >> sy) as f64,
            ];
            let rgb = frame.color.code_to_linear(code);
            out.push(std::array::from_fn(|k| {
                rgb[k] * haze[3] as f64 + haze[k] as f64
            }));
        }
    }
    out
}
