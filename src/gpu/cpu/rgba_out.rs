//! The CPU twin of the `rgba_out` stage: the layer's linear premultiplied canvas → 16-bit
//! full-range R'G'B'A codes; colour through the video's transfer ([`oetf_signed`]) after
//! premultiplication in linear light, or divided by α first (straight); α linear; the matte
//! as opaque grey α; the scene-linear layer as the canvas's own values in half floats.

use crate::video::color::oetf_signed;
use crate::video::{AlphaMode, Layer, Transfer};

/// A value in \[0, 1\] as a 16-bit code (clamped, rounded to nearest).
fn code16(v: f64) -> u16 {
    (v.clamp(0.0, 1.0) * 65535.0).round() as u16
}

/// Four samples per pixel of `canvas` (linear RGB premultiplied, and α) for `layer`: codes,
/// or the bits of half floats for [`Layer::SceneLinear`].
pub fn rgba_out(canvas: &[[f64; 4]], transfer: Transfer, layer: Layer) -> Vec<u16> {
    canvas
        .iter()
        .flat_map(|&[r, g, b, a]| {
            let colour = |scale: f64| [r, g, b].map(|c| code16(oetf_signed(transfer, c * scale)));
            match layer {
                Layer::Matte => [code16(a), code16(a), code16(a), 65535],
                Layer::SceneLinear => [r, g, b, a].map(|v| half::f16::from_f64(v).to_bits()),
                Layer::Alpha(AlphaMode::Straight) if a > 0.0 => {
                    let [r, g, b] = colour(1.0 / a);
                    [r, g, b, code16(a)]
                }
                Layer::Alpha(AlphaMode::Straight) => [0, 0, 0, code16(a)],
                Layer::Alpha(AlphaMode::Premultiplied) | Layer::OverBlack => {
                    let [r, g, b] = colour(1.0);
                    [r, g, b, code16(a)]
                }
            }
        })
        .collect()
}
