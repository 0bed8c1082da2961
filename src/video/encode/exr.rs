//! OpenEXR sequences: the scene-linear layer ([`Layer::SceneLinear`]) as one half-float RGBA
//! image a frame, the canvas's own values, premultiplied (OpenEXR defines its colour so), with
//! the input's primaries in the header's `chromaticities`.
//!
//! Written with the `exr` crate rather than FFmpeg's EXR encoder, which writes no
//! `chromaticities` (a compositor would take every input as BT.709). Each image is written into
//! the sink's hidden directory under the pattern's name for the count of frames written so far
//! (1, 2, …), as FFmpeg's image2 muxer names PNGs, so the sink publishes both kinds of sequence
//! alike: numbered by source frame.
//!
//! [`Layer::SceneLinear`]: crate::video::Layer::SceneLinear

use std::path::{Path, PathBuf};

use exr::prelude::{self as x, WritableImage as _, f16};
use ffmpeg_next::color::Primaries;

use crate::video::ffi;
use crate::video::{LayerFrame, LayerSamples, VideoInfo};
use crate::{Error, Result};

/// The CIE 1931 xy chromaticities of red, green, blue and white.
pub type Chromaticities = [[f32; 2]; 4];

/// D65, the white of most video primaries.
const D65: [f32; 2] = [0.3127, 0.3290];

/// Illuminant C, the white of System M (1953) and of generic film.
const ILLUMINANT_C: [f32; 2] = [0.310, 0.316];

/// The chromaticities of FFmpeg's primaries tag (ITU-T H.273's table 2). Untagged (or reserved)
/// primaries are taken as BT.709's, as players, compositors and OpenEXR itself (where the
/// attribute is missing) take them.
pub fn chromaticities(primaries: Primaries) -> Chromaticities {
    match primaries {
        Primaries::BT470M => [[0.67, 0.33], [0.21, 0.71], [0.14, 0.08], ILLUMINANT_C],
        Primaries::BT470BG => [[0.64, 0.33], [0.29, 0.60], [0.15, 0.06], D65],
        Primaries::SMPTE170M | Primaries::SMPTE240M => {
            [[0.630, 0.340], [0.310, 0.595], [0.155, 0.070], D65]
        }
        Primaries::Film => [[0.681, 0.319], [0.243, 0.692], [0.145, 0.049], ILLUMINANT_C],
        Primaries::BT2020 => [[0.708, 0.292], [0.170, 0.797], [0.131, 0.046], D65],
        Primaries::SMPTE428 => [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0], [1.0 / 3.0, 1.0 / 3.0]],
        Primaries::SMPTE431 => [
            [0.680, 0.320],
            [0.265, 0.690],
            [0.150, 0.060],
            [0.314, 0.351],
        ],
        Primaries::SMPTE432 => [[0.680, 0.320], [0.265, 0.690], [0.150, 0.060], D65],
        Primaries::EBU3213 => [[0.630, 0.340], [0.295, 0.605], [0.155, 0.077], D65],
        _ => [[0.640, 0.330], [0.300, 0.600], [0.150, 0.060], D65],
    }
}

/// An OpenEXR sequence being written into a hidden directory.
pub(super) struct ExrSequence {
    /// The hidden directory the images go to until the sink publishes them.
    dir: PathBuf,
    /// The output's file name, with its frame-number pattern.
    pattern: String,
    /// The output as the user named it, for messages.
    output: String,
    size: (u32, u32),
    chromaticities: Chromaticities,
    /// Width : height of a pixel.
    pixel_aspect: f32,
    frames_per_second: Option<(i32, u32)>,
    /// Images written so far.
    written: u64,
}

impl ExrSequence {
    /// A sequence of `info`'s frames written into `dir`, named like `output`.
    pub(super) fn new(dir: PathBuf, output: &str, info: &VideoInfo) -> ExrSequence {
        let (sn, sd) = info.sample_aspect_ratio;
        let (fnum, fden) = info.nominal_fps();
        ExrSequence {
            dir,
            pattern: Path::new(output)
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned(),
            output: output.to_owned(),
            size: (info.format.width, info.format.height),
            chromaticities: chromaticities(info.tags.primaries),
            pixel_aspect: if sn > 0 && sd > 0 {
                sn as f32 / sd as f32
            } else {
                1.0
            },
            frames_per_second: u32::try_from(fden)
                .ok()
                .filter(|&d| fnum > 0 && d > 0)
                .map(|d| (fnum, d)),
            written: 0,
        }
    }

    /// Writes `frame` as the next image.
    pub(super) fn write(&mut self, frame: &LayerFrame) -> Result<()> {
        let (w, h) = self.size;
        if frame.samples != LayerSamples::Half {
            return Err(Error::Unsupported(
                "an OpenEXR sequence holds scene-linear layers (half floats), not code values"
                    .into(),
            ));
        }
        if (frame.width, frame.height) != (w, h) || frame.rgba.len() != 4 * (w * h) as usize {
            return Err(Error::Parameter {
                name: "layer",
                value: format!("{}x{}", frame.width, frame.height),
                expected: format!("the size the sink was created for, {w}x{h}"),
            });
        }
        let number = self.written + 1;
        let name = i32::try_from(number)
            .ok()
            .and_then(|n| ffi::sequence_file_name(&self.pattern, n))
            .ok_or_else(|| Error::OutputWrite {
                path: self.output.clone(),
                reason: format!("no image name for frame {}", frame.index),
            })?;
        let width = w as usize;
        let pixels = x::SpecificChannels::rgba(|p: x::Vec2<usize>| {
            let at = 4 * (p.y() * width + p.x());
            let s = |k: usize| f16::from_bits(frame.rgba[at + k]);
            (s(0), s(1), s(2), s(3))
        });
        let attributes = x::LayerAttributes {
            software_name: Some(x::Text::from(concat!(
                "rain-composite ",
                env!("CARGO_PKG_VERSION")
            ))),
            frames_per_second: self.frames_per_second,
            ..Default::default()
        };
        // Lossless ZIP in blocks of 16 rows: small, quick to read, and taken by every reader
        // (FFmpeg's decoder included).
        let layer = x::Layer::new(
            (width, h as usize),
            attributes,
            x::Encoding::SMALL_LOSSLESS,
            pixels,
        );
        let mut image = x::Image::from_layer(layer);
        let [r, g, b, white] = self.chromaticities.map(|[cx, cy]| x::Vec2(cx, cy));
        image.attributes.chromaticities = Some(exr::meta::attribute::Chromaticities {
            red: r,
            green: g,
            blue: b,
            white,
        });
        image.attributes.pixel_aspect = self.pixel_aspect;
        image
            .write()
            .to_file(self.dir.join(&name))
            .map_err(|e| Error::OutputWrite {
                path: self.output.clone(),
                reason: format!("writing the OpenEXR image of frame {}: {e}", frame.index),
            })?;
        self.written = number;
        Ok(())
    }
}
