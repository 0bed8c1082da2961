//! The rain as a layer for editors: what a layer render writes ([`Layer`]), the frames it
//! carries ([`LayerFrame`]), which layer an output holds ([`for_output`]) and how each
//! container stores them.
//!
//! Every effect on the canvas is an *over* in linear light with premultiplied colour,
//! `out = effect.rgb + background · (1 − effect.α)`; a layer render starts from a transparent
//! canvas instead of the frame and runs the same stages, so the layer over the frame, in
//! linear light, is the composite.

use ffmpeg_next::format::Pixel;

use super::VideoCodec;
use crate::{Error, Result};

/// How colour relates to alpha in a written layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum AlphaMode {
    /// Colour already multiplied by alpha, in linear light (the canvas as it is).
    #[default]
    Premultiplied,
    /// Colour divided by alpha where alpha > 0 (0 where it is 0).
    Straight,
}

impl AlphaMode {
    /// The name written into the container's metadata.
    pub fn name(self) -> &'static str {
        match self {
            AlphaMode::Premultiplied => "premultiplied",
            AlphaMode::Straight => "straight",
        }
    }
}

/// What a render writes instead of the composite.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Layer {
    /// The rain with its alpha (R'G'B'A).
    Alpha(AlphaMode),
    /// The rain with its alpha as the canvas holds it: scene-linear, premultiplied, in half
    /// floats, nothing clipped (an OpenEXR sequence; [`Layer::Alpha`] premultiplied asked of an
    /// `.exr` output becomes this, see [`for_output`]).
    SceneLinear,
    /// The rain over black, an ordinary video (for a screen or add blend).
    OverBlack,
    /// The coverage alpha alone, as grey.
    Matte,
}

impl Layer {
    /// Whether frames are RGBA layers rather than Y'CbCr pictures.
    pub fn is_rgba(self) -> bool {
        !matches!(self, Layer::OverBlack)
    }

    /// What the samples of this layer's frames are.
    pub fn samples(self) -> LayerSamples {
        match self {
            Layer::SceneLinear => LayerSamples::Half,
            _ => LayerSamples::Codes,
        }
    }
}

/// Whether `output` names an OpenEXR sequence: its extension is `.exr` and no container is
/// forced on it.
pub fn is_exr(output: &str, container: Option<&str>) -> bool {
    container.is_none()
        && std::path::Path::new(output)
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// The layer a render to `output` writes when `layer` is asked for (`codec` asked for, and
/// `container` forced on the output, if any): an OpenEXR sequence holds the scene-linear
/// layer, so the premultiplied layer becomes [`Layer::SceneLinear`] there; what an EXR cannot
/// hold, or only an EXR can, is refused.
pub fn for_output(
    output: &str,
    container: Option<&str>,
    codec: VideoCodec,
    layer: Option<Layer>,
) -> Result<Option<Layer>> {
    if !is_exr(output, container) {
        return match layer {
            Some(Layer::SceneLinear) => Err(Error::Unsupported(
                "a scene-linear layer is written as an OpenEXR sequence (out_%05d.exr)".into(),
            )),
            l => Ok(l),
        };
    }
    if codec != VideoCodec::H264 {
        return Err(Error::Unsupported(format!(
            "an OpenEXR sequence is written as half-float OpenEXR images, not with \
             encode.codec {}: leave encode.codec out",
            codec.encoder_name()
        )));
    }
    match layer {
        Some(Layer::Alpha(AlphaMode::Premultiplied) | Layer::SceneLinear) => {
            Ok(Some(Layer::SceneLinear))
        }
        Some(Layer::Alpha(AlphaMode::Straight)) => Err(Error::Parameter {
            name: "encode.alpha",
            value: "straight".into(),
            expected: "premultiplied for an OpenEXR sequence: OpenEXR defines its colour as \
                       premultiplied"
                .into(),
        }),
        Some(Layer::Matte) => Err(Error::Unsupported(
            "encode.matte is written to .mkv, .mov or a PNG sequence; an OpenEXR sequence \
             holds the layer with alpha (encode.layer)"
                .into(),
        )),
        Some(Layer::OverBlack) => Err(Error::Unsupported(
            "the layer over black is a video; an OpenEXR sequence holds the layer with alpha \
             (encode.layer alpha)"
                .into(),
        )),
        None => Err(Error::Parameter {
            name: "job.output",
            value: output.to_owned(),
            expected: "a video file; image sequences are written for encode.layer or \
                       encode.matte"
                .into(),
        }),
    }
}

/// What the 16 bits of a layer's sample are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LayerSamples {
    /// Full-range code values: colour encoded with the video's transfer, alpha (and the
    /// matte's grey) linear, all clipped to \[0, 1\].
    Codes,
    /// IEEE 754 half floats, linear light, premultiplied: the canvas itself
    /// ([`Layer::SceneLinear`]).
    Half,
}

/// A rendered layer: four 16-bit samples R, G, B, A a pixel, row-major in the coded
/// orientation, as `samples` says.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerFrame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Four samples per pixel: R, G, B, A.
    pub rgba: Vec<u16>,
    /// What the samples are.
    pub samples: LayerSamples,
    /// Presentation time, input time base.
    pub pts: i64,
    /// Zero-based index in the stream.
    pub index: u64,
}

/// How a layer is encoded in one container: the codec and the pixel format it is given (with
/// alpha for the layer, grey for the matte).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LayerEncoding {
    /// The encoder.
    pub codec: LayerCodec,
    /// Pixel format of the encoder's input.
    pub pixel: Pixel,
}

/// The encoders that keep alpha.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LayerCodec {
    /// PNG images, 16 bits per sample (an image sequence).
    Png,
    /// ProRes 4444 with alpha (lossy colour, lossless 16-bit alpha in the bitstream).
    ProRes4444,
    /// FFV1, lossless.
    Ffv1,
}

impl LayerCodec {
    /// FFmpeg's encoder name.
    pub fn encoder_name(self) -> &'static str {
        match self {
            LayerCodec::Png => "png",
            LayerCodec::ProRes4444 => "prores_ks",
            LayerCodec::Ffv1 => "ffv1",
        }
    }
}

/// The encoding of `layer` in muxer `muxer` (codec `codec` asked for), or the error that names
/// the containers that can hold it.
pub fn layer_encoding(muxer: &str, codec: VideoCodec, layer: Layer) -> Result<LayerEncoding> {
    let matte = layer == Layer::Matte;
    let chosen = match muxer {
        "image2" => Some(LayerCodec::Png),
        "mov" if matches!(codec, VideoCodec::H264 | VideoCodec::ProRes) => {
            Some(LayerCodec::ProRes4444)
        }
        "matroska" if matches!(codec, VideoCodec::H264 | VideoCodec::Ffv1) => {
            Some(LayerCodec::Ffv1)
        }
        _ => None,
    };
    let Some(chosen) = chosen else {
        // H.264 is the default, not a codec asked for: the container alone is at fault.
        let with_codec = match codec {
            VideoCodec::H264 => String::new(),
            c => format!(" with encode.codec {}", c.encoder_name()),
        };
        let (name, exr) = if matte {
            ("encode.matte", "")
        } else {
            ("encode.layer", ", an OpenEXR sequence (out_%05d.exr)")
        };
        return Err(Error::Unsupported(format!(
            "{name} writes an alpha layer, which {muxer} output{with_codec} cannot hold: write \
             .mov (ProRes 4444), .mkv (FFV1), a PNG sequence (out_%05d.png){exr}, and leave \
             encode.codec out"
        )));
    };
    let pixel = match (chosen, matte) {
        (LayerCodec::Png, false) => Pixel::RGBA64BE,
        (LayerCodec::Png, true) => Pixel::GRAY16BE,
        (LayerCodec::ProRes4444, false) => Pixel::YUVA444P10LE,
        (LayerCodec::ProRes4444, true) => Pixel::YUV444P10LE,
        (LayerCodec::Ffv1, false) => Pixel::GBRAP16LE,
        (LayerCodec::Ffv1, true) => Pixel::GRAY16LE,
    };
    Ok(LayerEncoding {
        codec: chosen,
        pixel,
    })
}

/// Packs `frame` (R'G'B'A 16-bit codes) into `av`, an empty frame of `encoding.pixel`: RGBA and
/// grey samples as they are; ProRes's Y'CbCr from R'G'B' with the video's matrix
/// (`color.matrix`), 10-bit limited range, and its alpha rescaled to 10 bits.
pub fn pack(
    frame: &LayerFrame,
    layer: Layer,
    encoding: LayerEncoding,
    color: &super::ColorParams,
    av: &mut ffmpeg_next::frame::Video,
) {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let px = |x: usize, y: usize| &frame.rgba[4 * (y * w + x)..4 * (y * w + x) + 4];
    let mut put = |plane: usize, x: usize, y: usize, bytes: [u8; 2]| {
        let stride = av.stride(plane);
        let row = &mut av.data_mut(plane)[y * stride..];
        row[2 * x..2 * x + 2].copy_from_slice(&bytes);
    };
    let ten_bit = |v: f64, scale: f64, offset: f64| {
        ((v * scale + offset).round().clamp(0.0, 1023.0) as u16).to_le_bytes()
    };
    for y in 0..h {
        for x in 0..w {
            let p = px(x, y);
            match encoding.pixel {
                Pixel::RGBA64BE => {
                    for (k, &v) in p.iter().enumerate() {
                        put(0, 4 * x + k, y, v.to_be_bytes());
                    }
                }
                Pixel::GRAY16BE => put(0, x, y, p[0].to_be_bytes()),
                Pixel::GRAY16LE => put(0, x, y, p[0].to_le_bytes()),
                Pixel::GBRAP16LE => {
                    for (plane, k) in [(0, 1), (1, 2), (2, 0), (3, 3)] {
                        put(plane, x, y, p[k].to_le_bytes());
                    }
                }
                _ => {
                    // ProRes: Y'CbCr 4:4:4 at 10 bits, limited range (+ alpha, full range).
                    let e = [p[0], p[1], p[2]].map(|v| f64::from(v) / 65535.0);
                    let [luma, cb, cr] = super::color::rgb_to_ycbcr(color.matrix, e);
                    put(0, x, y, ten_bit(luma, 876.0, 64.0));
                    put(1, x, y, ten_bit(cb, 896.0, 512.0));
                    put(2, x, y, ten_bit(cr, 896.0, 512.0));
                    if layer != Layer::Matte {
                        put(3, x, y, ten_bit(f64::from(p[3]) / 65535.0, 1023.0, 0.0));
                    }
                }
            }
        }
    }
}
