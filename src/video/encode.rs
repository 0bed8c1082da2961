//! Encode and mux: the [`Sink`] takes rendered frames and the other streams' packets and writes
//! the output file (or stdout) with the input's timing, colour tags, rotation and metadata.
//!
//! How it works: [`Sink::create`] plans every input stream ([`plan_streams`]: render, copy,
//! AAC fallback or drop), opens the video encoder with the input stream's time base (so each
//! frame's pts passes through unchanged, CFR or VFR), adds the copied streams, and writes the
//! header, all into a hidden temporary file beside the output. [`Sink::finish`] flushes and
//! renames it onto the output; dropping an unfinished sink deletes it, so a failed or
//! interrupted job never leaves a half-written output. A PNG sequence is written into a hidden
//! temporary directory whose files are moved beside the output pattern at the end.

use std::path::{Path, PathBuf};

use ffmpeg_next::format::Pixel;
use ffmpeg_next::{self as ff, Rational};

use super::audio::AacTranscoder;
use super::decode::{CopiedPacket, init};
use super::ffi;
use super::info::{StreamAction, StreamKind, VideoInfo};
use super::layer::{Layer, LayerCodec, LayerEncoding, LayerFrame, layer_encoding};
use super::output_path::{check_output, temp_path};
use super::pixfmt::{self, Converter};
use super::{Chroma, FrameFormat, YuvFrame};
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
    /// Checks the options before any work is done (the encoders' own messages for a bad preset
    /// or CRF name neither the option nor the choices).
    pub fn validate(&self) -> Result<()> {
        if !X26X_PRESETS.contains(&self.preset.as_str()) {
            return Err(Error::Parameter {
                name: "--preset",
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
                name: "--encoder-params",
                value: format!("'{bad}'"),
                expected: "KEY=VALUE pairs joined by ':' (bframes=0:qcomp=0.8), or none".into(),
            });
        }
        if self.crf > 51 {
            return Err(Error::Parameter {
                name: "--crf",
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

/// The muxer y4m output goes through.
const Y4M: &str = "yuv4mpegpipe";

/// The muxer for an output path (`"-"` = stdout) and an optional override.
pub fn output_format(output: &str, container: Option<&str>) -> Result<ff::format::format::Output> {
    init();
    let name = container.or((output == "-").then_some(Y4M));
    let file = (output != "-").then_some(output);
    ffi::guess_output_format(name, file)
        .or_else(|| name.and_then(|n| ffi::guess_output_format(None, Some(&format!("x.{n}")))))
        .ok_or_else(|| Error::Parameter {
            name: "--format",
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
enum Route {
    Copy {
        ost: usize,
        ist_tb: Rational,
        ost_tb: Rational,
    },
    Aac(Box<AacTranscoder>),
}

/// The video encoder and its conversions.
struct VideoOut {
    encoder: ff::encoder::video::Encoder,
    ost: usize,
    enc_tb: Rational,
    ost_tb: Rational,
    /// The layout frames arrive in.
    format: FrameFormat,
    in_pixel: Pixel,
    /// Layout change for an encoder that does not take the input's layout.
    converter: Option<Converter>,
    enc_pixel: Pixel,
    /// How frames are packed when the output is an R'G'B'A layer or a matte.
    layer: Option<(Layer, LayerEncoding)>,
    /// The input's colour, for the Y'CbCr of a ProRes layer.
    color: super::ColorParams,
    /// y4m: constant rate, pts = frame counter.
    y4m: bool,
    frames: i64,
    last_pts: Option<i64>,
    warned_pts: bool,
}

/// The encoding side of a job. `Send`: the pipeline may run it on its own thread.
pub struct Sink {
    octx: Option<ff::format::context::Output>,
    output: String,
    temp: Option<PathBuf>,
    video: VideoOut,
    routes: Vec<Option<Route>>,
    info_tags: super::info::ColorTags,
    finished: bool,
    /// The source index of the first frame written: an image sequence is numbered by it.
    first_index: Option<u64>,
}

/// The image2 muxer's name (PNG sequences).
const IMAGE2: &str = "image2";

/// The hidden temporary file beside `output`, or for an image sequence the hidden directory
/// (whose name must not read as a second frame-number pattern).
fn sink_temp_path(output: &str, sequence: bool) -> PathBuf {
    let t = temp_path(Path::new(output));
    if !sequence {
        return t;
    }
    let name = t.file_name().unwrap_or_default().to_string_lossy();
    t.with_file_name(name.replace('%', "_"))
}

/// Removes a temporary output: a file, or a PNG sequence's directory.
fn discard(temp: &Path) {
    if temp.is_dir() {
        let _ = std::fs::remove_dir_all(temp);
    } else {
        let _ = std::fs::remove_file(temp);
    }
}

impl Sink {
    /// Creates the output (`"-"` = stdout) for frames shaped like `info` says, and writes its
    /// header into a temporary file beside it.
    pub fn create(output: &str, info: &VideoInfo, opts: &EncodeOptions) -> Result<Sink> {
        init();
        opts.validate()?;
        check_output(output, &[], opts.overwrite)?;
        let ofmt = output_format(output, opts.container.as_deref())?;
        let muxer = ofmt.name().to_owned();
        let plan = plan_streams(info, &ofmt, opts);
        let write_err = |reason: String| Error::OutputWrite {
            path: output.to_owned(),
            reason,
        };
        let sequence = muxer == IMAGE2;
        if sequence {
            check_sequence(output, opts)?;
        }

        let temp = (output != "-").then(|| sink_temp_path(output, sequence));
        let url = match &temp {
            Some(t) if sequence => {
                std::fs::create_dir(t).map_err(|e| write_err(e.to_string()))?;
                let name = Path::new(output).file_name().unwrap_or_default();
                t.join(name).to_string_lossy().into_owned()
            }
            Some(t) => t.to_string_lossy().into_owned(),
            None => "pipe:1".to_owned(),
        };
        let octx = ff::format::output_as(&url, &muxer).map_err(|e| write_err(e.to_string()))?;
        // From here on the temporary file exists: the guard removes it on any error.
        let mut guard = TempGuard {
            octx: Some(octx),
            temp,
        };
        let octx = guard.octx.as_mut().expect("set above");
        let global_header = octx
            .format()
            .flags()
            .contains(ff::format::Flags::GLOBAL_HEADER);

        let video = open_video(octx, info, opts, &ofmt, global_header)?;

        let mut routes: Vec<Option<Route>> = Vec::new();
        for (s, action) in info.streams.iter().zip(&plan) {
            if routes.len() <= s.index {
                routes.resize_with(s.index + 1, || None);
            }
            let ist_tb = Rational::new(s.time_base.0, s.time_base.1);
            match action {
                StreamAction::Render => {}
                StreamAction::Copy => {
                    let mut ost = octx
                        .add_stream(ff::encoder::find(ff::codec::Id::None))
                        .map_err(Error::ffmpeg("adding an output stream"))?;
                    ost.set_parameters(s.params.0.clone());
                    ffi::prepare_copied_stream(&mut ost, s.disposition);
                    ost.set_time_base(ist_tb);
                    ost.set_metadata(dictionary(&s.metadata, &[]));
                    routes[s.index] = Some(Route::Copy {
                        ost: ost.index(),
                        ist_tb,
                        ost_tb: ist_tb,
                    });
                }
                StreamAction::TranscodeAac => {
                    log::warn!(
                        "the {muxer} container cannot hold {} audio (stream #{}); \
                         re-encoding it as AAC (use .mkv or .mov to keep it unchanged)",
                        s.codec,
                        s.index
                    );
                    let t = AacTranscoder::new(octx, &s.params.0, ist_tb, global_header, output)?;
                    if let Some(mut ost) = octx.stream_mut(t.output_index()) {
                        ost.set_metadata(dictionary(&s.metadata, &[]));
                    }
                    routes[s.index] = Some(Route::Aac(Box::new(t)));
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
                }
            }
        }

        let mut metadata = dictionary(&info.metadata, &["encoder", "alpha_mode"]);
        if let Some(Layer::Alpha(mode)) = opts.layer {
            // No container has a standard field for it: a tag, in the file (MOV keeps only
            // file-level tags) and on the video stream (Matroska).
            metadata.set("alpha_mode", mode.name());
        }
        octx.set_metadata(metadata);
        let mp4_family =
            ["mp4", "mov", "ipod", "ismv", "3gp", "3g2", "psp", "f4v"].contains(&muxer.as_str());
        let mut header_opts = ff::Dictionary::new();
        if mp4_family {
            // A file gets its index up front (web playback); a pipe cannot seek back, so it
            // gets a fragmented file instead.
            let flags = if output == "-" {
                "frag_keyframe+empty_moov+default_base_moof"
            } else {
                "+faststart"
            };
            let tagged = if opts.layer.is_some_and(Layer::is_rgba) {
                "+use_metadata_tags"
            } else {
                ""
            };
            header_opts.set("movflags", &format!("{flags}{tagged}"));
        }
        if muxer == Y4M && (info.format.bit_depth > 8) {
            // FFmpeg calls high-depth y4m "unofficial" but writes it (rav1e, x264 read it).
            header_opts.set("strict", "unofficial");
        }
        octx.write_header_with(header_opts)
            .map_err(|e| write_err(format!("writing the {muxer} header: {e}")))?;

        // The muxer may have changed the time bases it was offered.
        let mut video = video;
        video.ost_tb = stream_tb(octx, video.ost);
        for route in routes.iter_mut().flatten() {
            match route {
                Route::Copy { ost, ost_tb, .. } => *ost_tb = stream_tb(octx, *ost),
                Route::Aac(t) => t.set_output_time_base(stream_tb(octx, t.output_index())),
            }
        }

        let (octx, temp) = guard.disarm();
        Ok(Sink {
            octx: Some(octx),
            output: output.to_owned(),
            temp,
            video,
            routes,
            info_tags: info.tags,
            finished: false,
            first_index: None,
        })
    }

    /// The hidden temporary file being written (`None` for stdout); renamed onto the output by
    /// [`Sink::finish`], deleted if the sink is dropped unfinished.
    pub fn temp_path(&self) -> Option<&Path> {
        self.temp.as_deref()
    }

    /// Encodes one frame. It must have the layout of the `VideoInfo` the sink was created with;
    /// its pts (input time base) is passed through.
    pub fn write_frame(&mut self, frame: &YuvFrame) -> Result<()> {
        let v = &mut self.video;
        if v.layer.is_some() {
            return Err(Error::Unsupported(
                "this output was opened for layers, not pictures".into(),
            ));
        }
        if frame.format != v.format {
            return Err(Error::Parameter {
                name: "frame",
                value: format!("{:?}", frame.format),
                expected: format!("the layout the sink was created for, {:?}", v.format),
            });
        }
        // A fresh frame each time: encoders (and the y4m muxer) may keep a reference to it.
        let mut av = ff::frame::Video::new(v.in_pixel, v.format.width, v.format.height);
        pixfmt::planes_to_av(frame, &mut av)?;
        let av = match v.converter.as_mut() {
            Some(c) => {
                let mut out = ff::frame::Video::new(v.enc_pixel, v.format.width, v.format.height);
                c.run_into(&av, &mut out)?;
                out
            }
            None => av,
        };
        let tags = self.info_tags;
        self.send_video(av, frame.pts, frame.index, tags)
    }

    /// Encodes one layer (a sink created with an R'G'B'A [`Layer`]).
    pub fn write_layer(&mut self, frame: &LayerFrame) -> Result<()> {
        let v = &self.video;
        let Some((layer, encoding)) = v.layer else {
            return Err(Error::Unsupported(
                "this output was opened for pictures, not layers".into(),
            ));
        };
        let (w, h) = (v.format.width, v.format.height);
        if (frame.width, frame.height) != (w, h) || frame.rgba.len() != 4 * (w * h) as usize {
            return Err(Error::Parameter {
                name: "layer",
                value: format!("{}x{}", frame.width, frame.height),
                expected: format!("the size the sink was created for, {w}x{h}"),
            });
        }
        let mut av = ff::frame::Video::new(encoding.pixel, w, h);
        super::layer::pack(frame, layer, encoding, &v.color, &mut av);
        let tags = layer_tags(self.info_tags, layer, encoding);
        self.first_index.get_or_insert(frame.index);
        self.send_video(av, frame.pts, frame.index, tags)
    }

    /// Encodes a rendered frame of either kind.
    pub fn write_rendered(&mut self, frame: &crate::gpu::Rendered) -> Result<()> {
        match frame {
            crate::gpu::Rendered::Picture(f) => self.write_frame(f),
            crate::gpu::Rendered::Layer(l) => self.write_layer(l),
        }
    }

    /// Stamps `av` with its pts (kept increasing) and colour tags, and encodes it.
    fn send_video(
        &mut self,
        mut av: ff::frame::Video,
        frame_pts: i64,
        index: u64,
        tags: super::info::ColorTags,
    ) -> Result<()> {
        let v = &mut self.video;
        let pts = if v.y4m {
            v.frames
        } else {
            match v.last_pts {
                Some(last) if frame_pts <= last => {
                    if !v.warned_pts {
                        log::warn!(
                            "frame {} has pts {} after {last}; shifting it to keep time moving \
                             forward",
                            index,
                            frame_pts
                        );
                        v.warned_pts = true;
                    }
                    last + 1
                }
                _ => frame_pts,
            }
        };
        v.last_pts = Some(pts);
        v.frames += 1;
        av.set_pts(Some(pts));
        av.set_kind(ff::picture::Type::None);
        av.set_color_space(tags.matrix);
        av.set_color_range(tags.range);
        av.set_color_primaries(tags.primaries);
        av.set_color_transfer_characteristic(tags.transfer);
        self.video
            .encoder
            .send_frame(&av)
            .map_err(Error::ffmpeg(format!("encoding frame {index}")))?;
        self.drain_video()
    }

    /// Writes a packet of another stream (copied, transcoded to AAC, or dropped as planned).
    pub fn write_packet(&mut self, p: CopiedPacket) -> Result<()> {
        let Some(Some(route)) = self.routes.get_mut(p.stream_index()) else {
            return Ok(());
        };
        let octx = self.octx.as_mut().expect("open until finish");
        let index = p.stream_index();
        match route {
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
                        path: self.output.clone(),
                        reason: format!("copying a packet of stream #{}: {e}", index),
                    })
            }
            Route::Aac(t) => t.push(&p.packet, octx),
        }
    }

    /// Flushes the encoders, writes the trailer and renames the temporary file onto the output.
    pub fn finish(mut self) -> Result<()> {
        self.video
            .encoder
            .send_eof()
            .map_err(Error::ffmpeg("flushing the video encoder"))?;
        self.drain_video()?;
        let octx = self.octx.as_mut().expect("open until finish");
        for route in self.routes.iter_mut().flatten() {
            if let Route::Aac(t) = route {
                t.finish(octx)?;
            }
        }
        octx.write_trailer().map_err(|e| Error::OutputWrite {
            path: self.output.clone(),
            reason: format!("finishing the file: {e}"),
        })?;
        ffi::flush_io(octx).map_err(|e| Error::OutputWrite {
            path: self.output.clone(),
            reason: io_reason(&self.output, e),
        })?;
        // Close the file before renaming it.
        drop(self.octx.take());
        if let Some(temp) = &self.temp {
            let first = self.first_index.unwrap_or(0);
            publish(temp, &self.output, first).map_err(|e| Error::OutputWrite {
                path: self.output.clone(),
                reason: format!("renaming the finished temporary file: {e}"),
            })?;
        }
        self.finished = true;
        Ok(())
    }

    fn drain_video(&mut self) -> Result<()> {
        let v = &mut self.video;
        let octx = self.octx.as_mut().expect("open until finish");
        let mut packet = ff::Packet::empty();
        loop {
            match v.encoder.receive_packet(&mut packet) {
                Ok(()) => {}
                Err(ff::Error::Other { errno }) if errno == ff::error::EAGAIN => return Ok(()),
                Err(ff::Error::Eof) => return Ok(()),
                Err(e) => return Err(Error::ffmpeg("encoding video")(e)),
            }
            packet.set_stream(v.ost);
            packet.rescale_ts(v.enc_tb, v.ost_tb);
            packet
                .write_interleaved(octx)
                .map_err(|e| Error::OutputWrite {
                    path: self.output.clone(),
                    reason: format!("writing video: {}", io_reason(&self.output, e)),
                })?;
        }
    }
}

impl Drop for Sink {
    fn drop(&mut self) {
        if !self.finished {
            drop(self.octx.take());
            if let Some(temp) = &self.temp {
                discard(temp);
            }
        }
    }
}

/// Removes the temporary file if `Sink::create` fails half-way.
struct TempGuard {
    octx: Option<ff::format::context::Output>,
    temp: Option<PathBuf>,
}

impl TempGuard {
    fn disarm(mut self) -> (ff::format::context::Output, Option<PathBuf>) {
        let octx = self.octx.take().expect("set at creation");
        (octx, self.temp.take())
    }
}

impl Drop for TempGuard {
    fn drop(&mut self) {
        drop(self.octx.take());
        if let Some(temp) = &self.temp {
            discard(temp);
        }
    }
}

/// A write error as a user reads it: a closed stdout is named as such.
fn io_reason(output: &str, e: ff::Error) -> String {
    match e {
        ff::Error::Other { errno } if errno == ff::error::EPIPE && output == "-" => {
            "stdout was closed before the video was complete".into()
        }
        ff::Error::Other { errno } if errno == ff::error::EPIPE => {
            "the reader closed the pipe before the video was complete".into()
        }
        ff::Error::Other { errno } if errno == ff::error::ENOSPC => {
            "no space left on the device".into()
        }
        e => e.to_string(),
    }
}

fn stream_tb(octx: &ff::format::context::Output, index: usize) -> Rational {
    octx.stream(index)
        .map_or(Rational::new(1, 1), |s| s.time_base())
}

fn dictionary(pairs: &[(String, String)], skip: &[&str]) -> ff::Dictionary<'static> {
    let mut d = ff::Dictionary::new();
    for (k, v) in pairs {
        if !skip.contains(&k.as_str()) {
            d.set(k, v);
        }
    }
    d
}

/// Opens the video encoder and adds its stream.
fn open_video(
    octx: &mut ff::format::context::Output,
    info: &VideoInfo,
    opts: &EncodeOptions,
    ofmt: &ff::format::format::Output,
    global_header: bool,
) -> Result<VideoOut> {
    let muxer = ofmt.name().to_owned();
    let y4m = muxer == Y4M;
    let layer = match opts.layer.filter(|l| l.is_rgba()) {
        Some(l) => Some((l, layer_encoding(&muxer, opts.codec, l)?)),
        None => None,
    };
    let encoder_name = match layer {
        Some((_, e)) => e.codec.encoder_name(),
        None => opts.codec.encoder_name(),
    };
    let codec = if y4m {
        ff::encoder::find(ff::codec::Id::WRAPPED_AVFRAME)
    } else {
        ff::encoder::find_by_name(encoder_name)
    }
    .ok_or_else(|| {
        Error::Unsupported(format!("this FFmpeg build has no {encoder_name} encoder"))
    })?;
    // Animation muxers take only their own codec but do not say so when asked.
    let animation_only = ["gif", "apng", "webp"].contains(&muxer.as_str());
    if !y4m && (animation_only || ffi::muxer_accepts(ofmt, codec.id()) == Some(false)) {
        return Err(Error::Unsupported(format!(
            "the {muxer} container cannot hold {}; use .mkv or .mov",
            codec.id().name()
        )));
    }
    let format = info.format;
    let in_pixel = pixfmt::pixel_of(&format)
        .ok_or_else(|| Error::Unsupported(format!("{}-bit video", format.bit_depth)))?;
    let odd_for = |p: Pixel| {
        pixfmt::pix_desc(p).is_some_and(|d| {
            (format.width % 2 == 1 && d.log2_chroma.0 > 0)
                || (format.height % 2 == 1 && d.log2_chroma.1 > 0)
        })
    };
    let in_pixel = layer.map_or(in_pixel, |(_, e)| e.pixel);
    let mut enc_pixel = if y4m || layer.is_some() {
        in_pixel
    } else {
        choose_pixel(&codec, in_pixel, &format)?
    };
    if !y4m && layer.is_none() && opts.codec != VideoCodec::Ffv1 && odd_for(enc_pixel) {
        // Subsampled chroma needs even sizes in H.264/HEVC/ProRes: keep the picture's size and
        // encode full-resolution chroma instead (the input's chroma is repeated, nothing is
        // lost).
        let full = FrameFormat {
            chroma: Chroma::Cs444,
            ..format
        };
        let wider = pixfmt::pixel_of(&full)
            .and_then(|p| choose_pixel(&codec, p, &full).ok())
            .filter(|&p| !odd_for(p));
        match wider {
            Some(p) => {
                log::warn!(
                    "{}x{} is odd: {} needs even sizes for {}, so the output is {} (same \
                     picture, full-resolution chroma)",
                    format.width,
                    format.height,
                    opts.codec.encoder_name(),
                    pixfmt::pixel_name(enc_pixel),
                    pixfmt::pixel_name(p)
                );
                enc_pixel = p;
            }
            None => {
                return Err(Error::Unsupported(format!(
                    "{} cannot encode {}x{} in {}: subsampled chroma needs an even size (use \
                     --codec ffv1, or crop the input)",
                    opts.codec.encoder_name(),
                    format.width,
                    format.height,
                    pixfmt::pixel_name(enc_pixel)
                )));
            }
        }
    }
    let tb = if y4m {
        // y4m is constant-rate; its muxer derives the frame rate from the time base.
        let (num, den) = info.nominal_fps();
        if info.variable_frame_rate {
            log::warn!(
                "y4m output is constant-rate: frames are written at {num}/{den} fps and the \
                 input's timing gaps are lost"
            );
        }
        Rational::new(den, num)
    } else {
        Rational::new(info.time_base.0, info.time_base.1)
    };

    let mut ctx = ff::codec::Context::new_with_codec(codec);
    ctx.set_threading(ff::threading::Config::kind(ff::threading::Type::Frame));
    let mut enc = ctx
        .encoder()
        .video()
        .map_err(Error::ffmpeg("creating the video encoder"))?;
    enc.set_width(format.width);
    enc.set_height(format.height);
    enc.set_format(enc_pixel);
    enc.set_time_base(tb);
    let (fnum, fden) = info.nominal_fps();
    enc.set_frame_rate(Some(Rational::new(fnum, fden)));
    let (sn, sd) = info.sample_aspect_ratio;
    if sn > 0 && sd > 0 {
        enc.set_aspect_ratio(Rational::new(sn, sd));
    }
    let tags = match layer {
        Some((l, e)) => layer_tags(info.tags, l, e),
        None => info.tags,
    };
    enc.set_colorspace(tags.matrix);
    enc.set_color_range(tags.range);
    enc.set_color_primaries(tags.primaries);
    enc.set_color_transfer_characteristic(tags.transfer);
    if global_header {
        enc.set_flags(ff::codec::Flags::GLOBAL_HEADER);
    }
    let mut dict = ff::Dictionary::new();
    // A layer's encoder takes the options of the codec of the same name, ProRes its 4444 profile.
    let tuned = match layer.map(|(_, e)| e.codec) {
        None => Some(opts.codec),
        Some(LayerCodec::Ffv1) => Some(VideoCodec::Ffv1),
        Some(LayerCodec::ProRes4444) => {
            dict.set("profile", "4444");
            None
        }
        Some(LayerCodec::Png) => None,
    };
    match (y4m, tuned) {
        (_, None) | (true, _) => {}
        (false, Some(VideoCodec::H264)) => {
            dict.set("preset", &opts.preset);
            dict.set("crf", &opts.crf.to_string());
            if !opts.encoder_params.is_empty() {
                dict.set("x264-params", &opts.encoder_params);
            }
        }
        (false, Some(VideoCodec::Hevc)) => {
            dict.set("preset", &opts.preset);
            dict.set("crf", &opts.crf.to_string());
            let params = match opts.encoder_params.as_str() {
                "" => "log-level=error".to_owned(),
                p => format!("log-level=error:{p}"),
            };
            dict.set("x265-params", &params);
        }
        (false, Some(VideoCodec::ProRes)) => {}
        (false, Some(VideoCodec::Ffv1)) => {
            // Version 3: slices (multi-threaded) and per-slice CRCs.
            dict.set("level", "3");
            dict.set("slicecrc", "1");
            // Every frame a keyframe: the range coder's contexts otherwise carry over from
            // frame to frame, so a chunk starting mid-GOP would code the same pictures into
            // other bytes. Intra-only, a chunk is the whole render's packets byte for byte (and
            // any frame can be cut, as archival FFV1 is written).
            dict.set("g", "1");
        }
    }
    let name = if y4m { Y4M } else { encoder_name };
    let encoder = enc
        .open_as_with(codec, dict)
        .map_err(Error::ffmpeg(format!("opening the {name} encoder")))?;

    let mut ost = octx
        .add_stream(codec)
        .map_err(Error::ffmpeg("adding the video stream"))?;
    ost.set_parameters(&encoder);
    ost.set_time_base(tb);
    if info.avg_frame_rate.0 > 0 && info.avg_frame_rate.1 > 0 && !y4m {
        ost.set_avg_frame_rate(Rational::new(info.avg_frame_rate.0, info.avg_frame_rate.1));
    }
    if let Some(vs) = info.stream(info.video_stream) {
        let mut metadata = dictionary(&vs.metadata, &["rotate", "encoder", "alpha_mode"]);
        if let Some((Layer::Alpha(mode), _)) = layer {
            // No container has a standard field for it: Matroska keeps it as a stream tag
            // (MOV only as the file tag `Sink::create` sets).
            metadata.set("alpha_mode", mode.name());
        }
        ost.set_metadata(metadata);
    }
    const IDENTITY: [i32; 9] = [1 << 16, 0, 0, 0, 1 << 16, 0, 0, 0, 1 << 30];
    if let Some(m) = &info.display_matrix
        && *m != IDENTITY
    {
        const ROTATION_MUXERS: [&str; 8] =
            ["mp4", "mov", "ipod", "ismv", "3gp", "3g2", "psp", "f4v"];
        if ROTATION_MUXERS.contains(&muxer.as_str()) {
            if !ffi::set_display_matrix(&mut ost, m) {
                log::warn!("could not attach the display rotation to the output");
            }
        } else if info.rotation_deg != 0 {
            log::warn!(
                "the {muxer} container cannot store the display rotation ({}°); the output \
                 will play unrotated (use .mp4 or .mov)",
                info.rotation_deg
            );
        }
    }
    let ost_index = ost.index();
    use ff::color::TransferCharacteristic as T;
    if matches!(info.tags.transfer, T::SMPTE2084 | T::ARIB_STD_B67) {
        log::warn!(
            "HDR input: the colour tags are kept, but mastering-display and content-light-level \
             metadata are not copied"
        );
    }

    let converter = if enc_pixel != in_pixel && layer.is_none() {
        let c = (info.color.matrix, info.color.full_range);
        Some(Converter::new(
            (in_pixel, format.width, format.height),
            (enc_pixel, format.width, format.height),
            c,
            c,
        )?)
    } else {
        None
    };
    Ok(VideoOut {
        encoder,
        ost: ost_index,
        enc_tb: tb,
        ost_tb: tb,
        format,
        in_pixel,
        converter,
        enc_pixel,
        layer,
        color: info.color,
        y4m,
        frames: 0,
        last_pts: None,
        warned_pts: false,
    })
}

/// The colour tags of a layer written as `encoding`: R'G'B' samples carry no matrix and are
/// full range, ProRes's Y'CbCr keeps the video's matrix at limited range, and a matte is linear.
fn layer_tags(
    video: super::info::ColorTags,
    layer: Layer,
    encoding: LayerEncoding,
) -> super::info::ColorTags {
    use ff::color::{Range, Space, TransferCharacteristic};
    let prores = encoding.codec == LayerCodec::ProRes4444;
    super::info::ColorTags {
        matrix: if prores { video.matrix } else { Space::RGB },
        range: if prores { Range::MPEG } else { Range::JPEG },
        primaries: video.primaries,
        transfer: if layer == Layer::Matte {
            TransferCharacteristic::Linear
        } else {
            video.transfer
        },
    }
}

/// Refuses a PNG sequence that could not be written: a layer is required (PNG holds R'G'B'A
/// layers only), the name needs a frame-number pattern, and an existing first image needs
/// `overwrite`.
fn check_sequence(output: &str, opts: &EncodeOptions) -> Result<()> {
    if !opts.layer.is_some_and(Layer::is_rgba) {
        return Err(Error::Parameter {
            name: "--output",
            value: output.to_owned(),
            expected: "a video file; image sequences are written for --layer-only or --matte"
                .into(),
        });
    }
    let name = Path::new(output)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let Some(first) = ffi::sequence_file_name(&name, 1) else {
        return Err(Error::Parameter {
            name: "--output",
            value: output.to_owned(),
            expected: "an image-sequence name with a frame number pattern, e.g. out_%05d.png"
                .into(),
        });
    };
    // FFmpeg formats the number in a buffer of 19 digits: a wider pattern names every image
    // alike, and each would overwrite the last.
    if ffi::sequence_file_name(&name, 2).as_deref() == Some(first.as_str()) {
        return Err(Error::Parameter {
            name: "--output",
            value: output.to_owned(),
            expected: "a frame number pattern of at most 19 digits, e.g. out_%05d.png".into(),
        });
    }
    let first = Path::new(output).with_file_name(first);
    if first.exists() && !opts.overwrite {
        return Err(Error::OutputExists(first));
    }
    Ok(())
}

/// Moves a finished temporary output onto `output`: renames a file, or moves each image of a
/// sequence's directory beside the output pattern and removes the directory. The images are
/// numbered by source frame (frame `first_index` is image `first_index + 1`), so the chunks of
/// a shot write their own images of one sequence and never each other's.
fn publish(temp: &Path, output: &str, first_index: u64) -> std::io::Result<()> {
    if !temp.is_dir() {
        return std::fs::rename(temp, output);
    }
    let dir = match Path::new(output).parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    // The file named like the pattern itself is the I/O context opened with the muxer; the
    // image2 muxer writes each image to a file of its own and leaves that one empty.
    let pattern = Path::new(output).file_name().unwrap_or_default();
    let text = pattern.to_string_lossy();
    let name = |number: u64| {
        i32::try_from(number)
            .ok()
            .and_then(|n| ffi::sequence_file_name(&text, n))
            .ok_or_else(|| std::io::Error::other(format!("no image name for frame {number}")))
    };
    // The muxer numbers the images it writes from 1.
    for k in 1.. {
        let written = temp.join(name(k)?);
        if !written.exists() {
            break;
        }
        std::fs::rename(written, dir.join(name(first_index + k)?))?;
    }
    std::fs::remove_file(temp.join(pattern)).or_else(|e| match e.kind() {
        std::io::ErrorKind::NotFound => Ok(()),
        _ => Err(e),
    })?;
    std::fs::remove_dir(temp)
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
