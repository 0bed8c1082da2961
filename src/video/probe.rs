//! `rain-composite probe`: what an input holds and what an output would do with each stream.

use std::fmt;

use serde::Serialize;

use super::encode::{self, EncodeOptions};
use super::ffi;
use super::info::{StreamAction, VideoInfo};
use super::{Chroma, Source};
use crate::{Error, Result};

/// A description of an input; `Serialize` for `--json`, `Display` for people.
#[derive(Debug, Clone, Serialize)]
pub struct ProbeReport {
    /// The input as given.
    pub input: String,
    /// The muxer the stream plan was made for (`None`: no plan).
    pub output_container: Option<String>,
    /// Everything about the input; each stream's `action` is filled when a container was given.
    pub video: VideoInfo,
}

/// Opens `input` (decoding only its first frame) and, when `output_container` names a muxer
/// (`"mp4"`) or an output file (`"out.mkv"`), plans what that output would do with each
/// stream under the default [`EncodeOptions`].
pub fn probe(input: &str, output_container: Option<&str>) -> Result<ProbeReport> {
    let source = Source::open(input)?;
    let mut video = source.info().clone();
    let mut muxer = None;
    if let Some(c) = output_container {
        let ofmt = ffi::guess_output_format(Some(c), None)
            .or_else(|| ffi::guess_output_format(None, Some(c)))
            .or_else(|| ffi::guess_output_format(None, Some(&format!("x.{c}"))))
            .ok_or_else(|| Error::Parameter {
                name: "probe.for_output",
                value: c.to_owned(),
                expected: "a container name (mp4, mkv, nut…) or an output file name".into(),
            })?;
        let plan = encode::plan_streams(&video, &ofmt, &EncodeOptions::default());
        for (s, a) in video.streams.iter_mut().zip(plan) {
            s.action = Some(a);
        }
        muxer = Some(ofmt.name().to_owned());
    }
    Ok(ProbeReport {
        input: input.to_owned(),
        output_container: muxer,
        video,
    })
}

impl fmt::Display for ProbeReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = &self.video;
        write!(f, "{} ({})", self.input, v.container)?;
        if let Some(d) = v.duration_s {
            write!(f, ", {d:.3} s")?;
        }
        writeln!(f)?;
        let chroma = match v.format.chroma {
            Chroma::Cs420 => "4:2:0",
            Chroma::Cs422 => "4:2:2",
            Chroma::Cs444 => "4:4:4",
        };
        let (num, den) = v.avg_frame_rate;
        let fps = if den > 0 {
            num as f64 / den as f64
        } else {
            0.0
        };
        writeln!(
            f,
            "  video: {} {}x{} {} → {chroma} {}-bit; {:?} {} range, {:?} transfer",
            v.codec_name,
            v.format.width,
            v.format.height,
            v.pixel_format,
            v.format.bit_depth,
            v.color.matrix,
            if v.color.full_range {
                "full"
            } else {
                "limited"
            },
            v.color.transfer,
        )?;
        let [m, r, p, t] = v.tags.names();
        writeln!(
            f,
            "  tags: matrix {m}, range {r}, primaries {p}, transfer {t}"
        )?;
        write!(
            f,
            "  timing: {fps:.3} fps {} (r_frame_rate {}/{}), time base {}/{}",
            if v.variable_frame_rate {
                "variable"
            } else {
                "constant"
            },
            v.frame_rate.0,
            v.frame_rate.1,
            v.time_base.0,
            v.time_base.1
        )?;
        if let Some(n) = v.frame_count {
            write!(f, ", {n} frames")?;
        }
        writeln!(f)?;
        if v.rotation_deg != 0 {
            writeln!(
                f,
                "  display rotation: {}° counter-clockwise",
                v.rotation_deg
            )?;
        }
        for s in &v.streams {
            write!(f, "  #{} {:?}: {}", s.index, s.kind, s.codec)?;
            if !s.details.is_empty() {
                write!(f, ", {}", s.details)?;
            }
            if let Some(lang) = s.metadata.iter().find(|(k, _)| k == "language") {
                write!(f, " [{}]", lang.1)?;
            }
            match &s.action {
                Some(StreamAction::Render) => write!(f, " → render")?,
                Some(StreamAction::Copy) => write!(f, " → copy")?,
                Some(StreamAction::TranscodeAac) => write!(f, " → re-encode as AAC")?,
                Some(StreamAction::Drop(why)) => write!(f, " → drop ({why})")?,
                None => {}
            }
            writeln!(f)?;
        }
        Ok(())
    }
}
