//! The container and every input stream's fate in it: which muxer an output gets, what each
//! stream becomes (rendered, copied, re-encoded as AAC or dropped), and the output streams that
//! carry the copied and re-encoded ones.

use ffmpeg_next::{self as ff, Rational};

use super::options::{AudioMode, EncodeOptions};
use super::{Y4M, dictionary, stream_tb};
use crate::video::audio::AacTranscoder;
use crate::video::decode::{CopiedPacket, init};
use crate::video::ffi;
use crate::video::info::{StreamAction, StreamInfo, StreamKind, VideoInfo};
use crate::{Error, Result};

/// The muxer for an output path (`"-"` = stdout) and an optional override.
pub fn output_format(output: &str, container: Option<&str>) -> Result<ff::format::format::Output> {
    init();
    let name = container.or((output == "-").then_some(Y4M));
    let file = (output != "-").then_some(output);
    ffi::guess_output_format(name, file)
        .or_else(|| name.and_then(|n| ffi::guess_output_format(None, Some(&format!("x.{n}")))))
        .ok_or_else(|| Error::Parameter {
            name: "encode.container",
            value: name.unwrap_or(output).to_owned(),
            expected:
                "a container FFmpeg can write (mp4, mov, mkv, webm, nut, y4m…), given by the \
                   output's extension or by name"
                    .into(),
        })
}

/// Decides, for each of `info.streams` (same order), what an output in `ofmt` does with it.
pub fn plan_streams(
    info: &VideoInfo,
    ofmt: &ff::format::format::Output,
    opts: &EncodeOptions,
) -> Vec<StreamAction> {
    let muxer = ofmt.name().to_owned();
    info.streams
        .iter()
        .map(|s| {
            if s.index == info.video_stream {
                return StreamAction::Render;
            }
            if muxer == Y4M {
                return StreamAction::Drop(format!("{Y4M} carries one video stream only"));
            }
            let id = s.params.0.id();
            if id == ff::codec::Id::None {
                return StreamAction::Drop(format!("{:?} stream of unknown codec", s.kind));
            }
            let accepts = ffi::muxer_accepts(ofmt, id);
            match s.kind {
                StreamKind::Video => {
                    StreamAction::Drop("only the main video stream is rendered".into())
                }
                StreamKind::Audio if opts.audio == AudioMode::None => {
                    StreamAction::Drop("audio disabled".into())
                }
                StreamKind::Audio => match accepts {
                    Some(false) if ffi::muxer_accepts(ofmt, ff::codec::Id::AAC) != Some(false) => {
                        StreamAction::TranscodeAac
                    }
                    Some(false) => StreamAction::Drop(format!("{muxer} cannot hold {}", s.codec)),
                    _ => StreamAction::Copy,
                },
                StreamKind::Subtitle | StreamKind::Attachment => match accepts {
                    Some(false) => StreamAction::Drop(format!("{muxer} cannot hold {}", s.codec)),
                    _ => StreamAction::Copy,
                },
                StreamKind::Data | StreamKind::Unknown => match accepts {
                    Some(true) => StreamAction::Copy,
                    _ => StreamAction::Drop(format!("{muxer} cannot hold {} data", s.codec)),
                },
            }
        })
        .collect()
}

/// Where a copied or transcoded input stream goes.
pub(super) enum Route {
    Copy {
        ost: usize,
        ist_tb: Rational,
        ost_tb: Rational,
    },
    Aac(Box<AacTranscoder>),
}

/// Adds the output streams `plan` asks for besides the video (before the header is written),
/// and returns the route of each input stream, indexed by its input index (`None`: not written).
pub(super) fn add_streams(
    octx: &mut ff::format::context::Output,
    info: &VideoInfo,
    plan: &[StreamAction],
    muxer: &str,
    global_header: bool,
    output: &str,
) -> Result<Vec<Option<Route>>> {
    let mut routes: Vec<Option<Route>> = Vec::new();
    for (s, action) in info.streams.iter().zip(plan) {
        if routes.len() <= s.index {
            routes.resize_with(s.index + 1, || None);
        }
        routes[s.index] = match action {
            StreamAction::Render => None,
            StreamAction::Copy => Some(copy_stream(octx, s)?),
            StreamAction::TranscodeAac => {
                log::warn!(
                    "the {muxer} container cannot hold {} audio (stream #{}); \
                     re-encoding it as AAC (use .mkv or .mov to keep it unchanged)",
                    s.codec,
                    s.index
                );
                let ist_tb = Rational::new(s.time_base.0, s.time_base.1);
                let t = AacTranscoder::new(octx, &s.params.0, ist_tb, global_header, output)?;
                if let Some(mut ost) = octx.stream_mut(t.output_index()) {
                    ost.set_metadata(dictionary(&s.metadata, &[]));
                }
                Some(Route::Aac(Box::new(t)))
            }
            StreamAction::Drop(reason) => {
                if reason != "audio disabled" {
                    log::warn!(
                        "dropping {:?} stream #{} ({}): {reason}",
                        s.kind,
                        s.index,
                        s.codec
                    );
                }
                None
            }
        };
    }
    Ok(routes)
}

/// An output stream with the parameters, disposition, time base and tags of input stream `s`,
/// whose packets are copied into it unchanged.
fn copy_stream(octx: &mut ff::format::context::Output, s: &StreamInfo) -> Result<Route> {
    let ist_tb = Rational::new(s.time_base.0, s.time_base.1);
    let mut ost = octx
        .add_stream(ff::encoder::find(ff::codec::Id::None))
        .map_err(Error::ffmpeg("adding an output stream"))?;
    ost.set_parameters(s.params.0.clone());
    ffi::prepare_copied_stream(&mut ost, s.disposition);
    ost.set_time_base(ist_tb);
    ost.set_metadata(dictionary(&s.metadata, &[]));
    Ok(Route::Copy {
        ost: ost.index(),
        ist_tb,
        ost_tb: ist_tb,
    })
}

impl Route {
    /// Takes the time base the muxer settled on when it wrote the header (it may change the one
    /// it was offered).
    pub(super) fn adopt_time_base(&mut self, octx: &ff::format::context::Output) {
        match self {
            Route::Copy { ost, ost_tb, .. } => *ost_tb = stream_tb(octx, *ost),
            Route::Aac(t) => t.set_output_time_base(stream_tb(octx, t.output_index())),
        }
    }

    /// Writes one packet of the input stream: rescaled and copied, or re-encoded.
    pub(super) fn write(
        &mut self,
        p: CopiedPacket,
        octx: &mut ff::format::context::Output,
        output: &str,
    ) -> Result<()> {
        let index = p.stream_index();
        match self {
            Route::Copy {
                ost,
                ist_tb,
                ost_tb,
            } => {
                let mut packet = p.packet;
                packet.rescale_ts(*ist_tb, *ost_tb);
                packet.set_position(-1);
                packet.set_stream(*ost);
                packet
                    .write_interleaved(octx)
                    .map_err(|e| Error::OutputWrite {
                        path: output.to_owned(),
                        reason: format!("copying a packet of stream #{}: {e}", index),
                    })
            }
            Route::Aac(t) => t.push(&p.packet, octx),
        }
    }

    /// Flushes a re-encoding route's encoder into the output (a copy has nothing to flush).
    pub(super) fn finish(&mut self, octx: &mut ff::format::context::Output) -> Result<()> {
        match self {
            Route::Copy { .. } => Ok(()),
            Route::Aac(t) => t.finish(octx),
        }
    }
}
