//! The encoder flags and the encoder options they make.

use anyhow::bail;
use clap::{Args, ValueEnum};
use rain_composite::video::{AlphaMode, AudioMode, EncodeOptions, Layer, VideoCodec};

#[derive(Args, Debug, Clone)]
pub struct EncodeArgs {
    /// Video codec; a layer with alpha or a matte takes its container's [default: h264].
    #[arg(long, value_enum)]
    pub codec: Option<CodecArg>,
    /// Constant rate factor (H.264/HEVC; lower is better).
    #[arg(long, default_value_t = EncodeOptions::default().crf, value_parser = clap::value_parser!(u8).range(0..=51))]
    pub crf: u8,
    /// Encoder preset (H.264/HEVC).
    #[arg(long, default_value_t = EncodeOptions::default().preset)]
    pub preset: String,
    /// More H.264/HEVC encoder options, KEY=VALUE joined by ':' (as ffmpeg's -x264-params/-x265-params), applied over --preset and --crf; the default keeps faint streaks through the encoding; none: the encoder's own defaults.
    #[arg(long, default_value_t = EncodeOptions::default().encoder_params, value_name = "KEY=VALUE[:…]")]
    pub encoder_params: String,
    /// Container for stdout (or to override the extension).
    #[arg(long, value_enum)]
    pub format: Option<FormatArg>,
    /// What to do with audio and other streams.
    #[arg(long, value_enum, default_value_t = AudioArg::from(EncodeOptions::default().audio))]
    pub audio: AudioArg,
    /// Write the rain alone: `alpha` (the default) with its alpha to .mov (ProRes 4444), .mkv (FFV1), a 16-bit PNG sequence (out_%05d.png) or a scene-linear half-float OpenEXR sequence (out_%05d.exr, nothing clipped); `black` over black, an ordinary video for a screen blend.
    #[arg(long, value_enum, num_args = 0..=1, require_equals = true, default_missing_value = "alpha", value_name = "MODE")]
    pub layer_only: Option<LayerArg>,
    /// Colour of the layer relative to its alpha [default: premultiplied].
    #[arg(long, value_enum, requires = "layer_only")]
    pub alpha: Option<AlphaArg>,
    /// Write the rain's coverage alone, as grey (to the outputs of --layer-only).
    #[arg(long, conflicts_with = "layer_only")]
    pub matte: bool,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum LayerArg {
    /// The rain with its alpha.
    Alpha,
    /// The rain over black.
    Black,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum AlphaArg {
    /// Colour multiplied by alpha in linear light.
    Premultiplied,
    /// Colour divided by alpha.
    Straight,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum CodecArg {
    /// H.264 (libx264).
    H264,
    /// HEVC (libx265).
    Hevc,
    /// Apple ProRes 422 HQ (prores_ks), 10-bit.
    Prores,
    /// FFV1, lossless.
    Ffv1,
}

impl From<CodecArg> for VideoCodec {
    fn from(c: CodecArg) -> VideoCodec {
        match c {
            CodecArg::H264 => VideoCodec::H264,
            CodecArg::Hevc => VideoCodec::Hevc,
            CodecArg::Prores => VideoCodec::ProRes,
            CodecArg::Ffv1 => VideoCodec::Ffv1,
        }
    }
}

impl From<VideoCodec> for CodecArg {
    fn from(c: VideoCodec) -> CodecArg {
        match c {
            VideoCodec::H264 => CodecArg::H264,
            VideoCodec::Hevc => CodecArg::Hevc,
            VideoCodec::ProRes => CodecArg::Prores,
            VideoCodec::Ffv1 => CodecArg::Ffv1,
        }
    }
}

#[derive(ValueEnum, Debug, Clone, Copy)]
pub enum FormatArg {
    /// YUV4MPEG2 (raw, constant frame rate).
    Y4m,
    /// NUT.
    Nut,
    /// Matroska.
    Matroska,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum AudioArg {
    /// Copy audio and other streams bit for bit (AAC where the container cannot hold them).
    Copy,
    /// Video only.
    None,
}

impl From<AudioArg> for AudioMode {
    fn from(a: AudioArg) -> AudioMode {
        match a {
            AudioArg::Copy => AudioMode::Copy,
            AudioArg::None => AudioMode::None,
        }
    }
}

impl From<AudioMode> for AudioArg {
    fn from(a: AudioMode) -> AudioArg {
        match a {
            AudioMode::Copy => AudioArg::Copy,
            AudioMode::None => AudioArg::None,
        }
    }
}

/// The encoder settings the flags ask for. Flags the output would silently ignore are refused:
/// H.264 for a layer with alpha or a matte (its container fixes the codec), `--alpha` for a
/// layer over black (it has no alpha).
pub fn encode_options(e: &EncodeArgs, overwrite: bool) -> anyhow::Result<EncodeOptions> {
    let rgba_layer = e.matte || e.layer_only == Some(LayerArg::Alpha);
    if rgba_layer && e.codec == Some(CodecArg::H264) {
        bail!(
            "--codec h264 cannot hold {}: leave --codec out (FFV1 in .mkv, ProRes 4444 in \
             .mov, 16-bit PNG or half-float OpenEXR in a sequence)",
            if e.matte {
                "the matte"
            } else {
                "a layer with alpha"
            }
        );
    }
    if e.alpha.is_some() && e.layer_only == Some(LayerArg::Black) {
        bail!("--alpha applies to --layer-only=alpha: a layer over black has no alpha");
    }
    Ok(EncodeOptions {
        codec: e
            .codec
            .map_or(EncodeOptions::default().codec, VideoCodec::from),
        crf: e.crf,
        preset: e.preset.clone(),
        encoder_params: match e.encoder_params.as_str() {
            "none" => String::new(),
            p => p.to_owned(),
        },
        container: e.format.map(|f| {
            match f {
                FormatArg::Y4m => "yuv4mpegpipe",
                FormatArg::Nut => "nut",
                FormatArg::Matroska => "matroska",
            }
            .to_string()
        }),
        audio: e.audio.into(),
        overwrite,
        layer: match (e.layer_only, e.matte) {
            (_, true) => Some(Layer::Matte),
            (Some(LayerArg::Black), _) => Some(Layer::OverBlack),
            (Some(LayerArg::Alpha), _) => Some(Layer::Alpha(match e.alpha {
                Some(AlphaArg::Straight) => AlphaMode::Straight,
                Some(AlphaArg::Premultiplied) | None => AlphaMode::Premultiplied,
            })),
            (None, false) => None,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::args::parsed;

    /// The encoder flags' defaults are the library's.
    #[test]
    fn encode_defaults_are_the_library_defaults() {
        let cli = parsed(&["rain-composite", "in.mp4"]);
        assert_eq!(
            encode_options(&cli.render.encode, false).expect("valid"),
            EncodeOptions::default()
        );
    }
}
