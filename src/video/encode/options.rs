//! How to write the output: the encoder, its quality settings, the container, the audio and
//! the layer, with the checks that refuse a bad setting before any work is done.

use crate::video::Layer;
use crate::{Error, Result};

/// The video encoder of the output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum VideoCodec {
    /// H.264 through libx264 (`crf`, `preset`).
    #[default]
    H264,
    /// HEVC through libx265 (`crf`, `preset`).
    Hevc,
    /// Apple ProRes through prores_ks (4:2:2 or 4:4:4, 10-bit), for editing.
    ProRes,
    /// FFV1, lossless.
    Ffv1,
}

impl VideoCodec {
    /// FFmpeg's encoder name.
    pub fn encoder_name(self) -> &'static str {
        match self {
            VideoCodec::H264 => "libx264",
            VideoCodec::Hevc => "libx265",
            VideoCodec::ProRes => "prores_ks",
            VideoCodec::Ffv1 => "ffv1",
        }
    }

    /// Parses `h264|libx264`, `hevc|h265|libx265`, `prores|prores_ks`, `ffv1`.
    pub fn from_name(name: &str) -> Option<VideoCodec> {
        Some(match name.to_ascii_lowercase().as_str() {
            "h264" | "libx264" | "avc" => VideoCodec::H264,
            "hevc" | "h265" | "libx265" => VideoCodec::Hevc,
            "prores" | "prores_ks" => VideoCodec::ProRes,
            "ffv1" => VideoCodec::Ffv1,
            _ => return None,
        })
    }
}

/// What happens to the input's audio.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum AudioMode {
    /// Copied bit for bit; AAC when the container cannot hold the codec.
    #[default]
    Copy,
    /// No audio in the output.
    None,
}

/// How to write the output.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EncodeOptions {
    /// Video encoder.
    pub codec: VideoCodec,
    /// Constant rate factor for libx264/libx265 (lower = better; 18 ≈ visually lossless).
    pub crf: u8,
    /// libx264/libx265 speed preset (`"medium"`).
    pub preset: String,
    /// libx264/libx265 options applied over `preset` and `crf`, `key=value` joined by `:` as
    /// FFmpeg's `-x264-params`/`-x265-params` take them; empty for the encoders' own defaults.
    /// The default is [`STREAK_PARAMS`].
    pub encoder_params: String,
    /// Muxer name overriding the output's extension (`"matroska"`, `"nut"`, `"mp4"`,
    /// `"yuv4mpegpipe"`); stdout defaults to `yuv4mpegpipe`.
    pub container: Option<String>,
    /// Audio handling.
    pub audio: AudioMode,
    /// Replace an existing output.
    pub overwrite: bool,
    /// Write the rain as a layer instead of the composite.
    pub layer: Option<Layer>,
}

/// The libx264/libx265 options the output is written with unless others are given: no
/// B-frames and a flatter rate control. Streaks are new in every frame, so nothing predicts
/// them: B-frames (bi-predicted, and given coarser quantisers than the frames they sit
/// between) smooth most faint streaks away, and a steeper `qcomp` raises the quantiser of the
/// busy frames rain makes. Measured against a lossless render, these keep 62–74 % of the
/// visible streak pixels where x264's defaults keep 51–62 %, for 1.3–1.5× the bytes (README,
/// "Streaks through the encoder").
pub const STREAK_PARAMS: &str = "bframes=0:qcomp=0.8";

/// The speed presets libx264 and libx265 share, fastest first.
pub const X26X_PRESETS: [&str; 10] = [
    "ultrafast",
    "superfast",
    "veryfast",
    "faster",
    "fast",
    "medium",
    "slow",
    "slower",
    "veryslow",
    "placebo",
];

impl EncodeOptions {
    /// The layer a render to `output` writes: [`Layer::SceneLinear`] for the premultiplied
    /// layer asked of an OpenEXR sequence, else the one asked for; refused where the output
    /// cannot hold it (see [`crate::video::layer::for_output`]).
    pub fn layer_for(&self, output: &str) -> Result<Option<Layer>> {
        crate::video::layer::for_output(output, self.container.as_deref(), self.codec, self.layer)
    }

    /// Checks the options before any work is done (the encoders' own messages for a bad preset
    /// or CRF name neither the option nor the choices).
    pub fn validate(&self) -> Result<()> {
        if !X26X_PRESETS.contains(&self.preset.as_str()) {
            return Err(Error::Parameter {
                name: "encode.preset",
                value: format!("'{}'", self.preset),
                expected: format!("one of {}", X26X_PRESETS.join(", ")),
            });
        }
        if let Some(bad) = self
            .encoder_params
            .split(':')
            .filter(|kv| !kv.is_empty())
            .find(|kv| {
                !kv.split_once('=')
                    .is_some_and(|(k, v)| !k.is_empty() && !v.is_empty())
            })
        {
            return Err(Error::Parameter {
                name: "encode.encoder_params",
                value: format!("'{bad}'"),
                expected: "KEY=VALUE pairs joined by ':' (bframes=0:qcomp=0.8), or none".into(),
            });
        }
        if self.crf > 51 {
            return Err(Error::Parameter {
                name: "encode.crf",
                value: self.crf.to_string(),
                expected: "0 to 51".into(),
            });
        }
        Ok(())
    }
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions {
            codec: VideoCodec::H264,
            crf: 18,
            preset: "medium".into(),
            encoder_params: STREAK_PARAMS.into(),
            container: None,
            audio: AudioMode::Copy,
            overwrite: false,
            layer: None,
        }
    }
}
