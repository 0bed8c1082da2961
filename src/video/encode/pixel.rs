//! The layout the video encoder is given: the input's own where the encoder takes it, else the
//! closest one it does take, with full-resolution chroma for an odd-sized picture.

use ffmpeg_next as ff;
use ffmpeg_next::format::Pixel;

use super::options::VideoCodec;
use crate::video::layer::LayerEncoding;
use crate::video::pixfmt;
use crate::video::{Chroma, FrameFormat};
use crate::{Error, Result};

/// The pixel format frames arrive in (the input's layout, or a layer's packing) and the one the
/// encoder takes (`codec` being `video_codec`'s encoder, unless y4m or a layer is written).
pub(super) fn encoder_pixels(
    codec: &ff::Codec,
    format: &FrameFormat,
    layer: Option<LayerEncoding>,
    y4m: bool,
    video_codec: VideoCodec,
) -> Result<(Pixel, Pixel)> {
    let in_pixel = pixfmt::pixel_of(format)
        .ok_or_else(|| Error::Unsupported(format!("{}-bit video", format.bit_depth)))?;
    let in_pixel = layer.map_or(in_pixel, |e| e.pixel);
    if y4m || layer.is_some() {
        return Ok((in_pixel, in_pixel));
    }
    let enc_pixel = choose_pixel(codec, in_pixel, format)?;
    if video_codec == VideoCodec::Ffv1 || !odd_for(format, enc_pixel) {
        return Ok((in_pixel, enc_pixel));
    }
    let full = full_chroma(codec, format, enc_pixel, video_codec)?;
    Ok((in_pixel, full))
}

/// Whether pixel format `p` subsamples chroma along a side of `format` that is odd.
fn odd_for(format: &FrameFormat, p: Pixel) -> bool {
    pixfmt::pix_desc(p).is_some_and(|d| {
        (format.width % 2 == 1 && d.log2_chroma.0 > 0)
            || (format.height % 2 == 1 && d.log2_chroma.1 > 0)
    })
}

/// The 4:4:4 layout an odd-sized picture is encoded in where `enc_pixel` subsamples chroma.
/// Subsampled chroma needs even sizes in H.264/HEVC/ProRes: the picture keeps its size and the
/// input's chroma is repeated, so nothing is lost.
fn full_chroma(
    codec: &ff::Codec,
    format: &FrameFormat,
    enc_pixel: Pixel,
    video_codec: VideoCodec,
) -> Result<Pixel> {
    let full = FrameFormat {
        chroma: Chroma::Cs444,
        ..*format
    };
    let wider = pixfmt::pixel_of(&full)
        .and_then(|p| choose_pixel(codec, p, &full).ok())
        .filter(|&p| !odd_for(format, p));
    match wider {
        Some(p) => {
            log::warn!(
                "{}x{} is odd: {} needs even sizes for {}, so the output is {} (same \
                 picture, full-resolution chroma)",
                format.width,
                format.height,
                video_codec.encoder_name(),
                pixfmt::pixel_name(enc_pixel),
                pixfmt::pixel_name(p)
            );
            Ok(p)
        }
        None => Err(Error::Unsupported(format!(
            "{} cannot encode {}x{} in {}: subsampled chroma needs an even size (use \
             encode.codec ffv1, or crop the input)",
            video_codec.encoder_name(),
            format.width,
            format.height,
            pixfmt::pixel_name(enc_pixel)
        ))),
    }
}

/// The encoder's pixel format: the input's layout if supported, else the closest supported
/// planar layout: first one that loses no bit depth and no chroma, then the fewest bits and
/// chroma samples added (a warning explains the change).
fn choose_pixel(codec: &ff::Codec, wanted: Pixel, format: &FrameFormat) -> Result<Pixel> {
    let supported: Vec<Pixel> = codec
        .video()
        .ok()
        .and_then(|v| v.formats())
        .map(|f| f.collect())
        .unwrap_or_default();
    if supported.is_empty() || supported.contains(&wanted) {
        return Ok(wanted);
    }
    let richness = |c: Chroma| match c {
        Chroma::Cs420 => 0i32,
        Chroma::Cs422 => 1,
        Chroma::Cs444 => 2,
    };
    let want_depth = i32::from(format.bit_depth);
    let want_chroma = richness(format.chroma);
    let best = supported
        .iter()
        .filter_map(|&p| {
            let (chroma, depth, jpeg) = pixfmt::layout_of(p)?;
            (!jpeg).then_some((p, richness(chroma), i32::from(depth)))
        })
        .min_by_key(|&(_, chroma, depth)| {
            (
                depth < want_depth,
                chroma < want_chroma,
                (depth - want_depth).abs(),
                (chroma - want_chroma).abs(),
            )
        })
        .map(|(p, _, _)| p)
        .ok_or_else(|| {
            Error::Unsupported(format!(
                "{} takes none of the planar YUV layouts",
                codec.name()
            ))
        })?;
    log::warn!(
        "{} cannot encode {}; encoding {} instead",
        codec.name(),
        pixfmt::pixel_name(wanted),
        pixfmt::pixel_name(best)
    );
    Ok(best)
}
