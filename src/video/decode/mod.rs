//! Demux and decode: the [`Source`] yields decoded video frames in one of our planar layouts and,
//! interleaved in demux order, the packets of the other streams for the output to copy.
//!
//! How it works: [`Source::open`] reads ahead up to a few hundred video packets (to judge
//! whether the frame rate is variable) and decodes until the first frame, whose real pixel
//! format and colour tags define [`VideoInfo`]. Packets are read with `Packet::read` directly,
//! so a read error is seen, not swallowed: a damaged packet or frame is a `log::warn!` with its
//! frame number and decoding goes on (as the ffmpeg CLI does); a stream from which no frame at
//! all can be decoded is [`Error::CorruptInput`]. Timestamps are the decoder's best-effort
//! timestamps in the stream's own time base, never rebased.
//!
//! Frames leave in one of the planar layouts of [`super::frame`] with tightly packed planes
//! (`Plane::stride == FrameFormat::packed_stride(i)`): copying rows out of FFmpeg's padded,
//! pooled buffers costs little next to decoding and lets the buffers go back to the decoder.

mod seek;

use std::collections::VecDeque;

use ffmpeg_next::{self as ff, Rational, Rescale};

use super::info::{self, ColorTags, VideoInfo};
use super::pixfmt::{self, Converter, SourceLayout};
use super::{ColorParams, FrameFormat, Transfer, YuvFrame};
use crate::{Error, Result};

/// A packet of a non-rendered stream, to be written by the sink (copied or transcoded).
pub struct CopiedPacket {
    pub(crate) packet: ff::Packet,
    pub(crate) time_base: Rational,
}

impl CopiedPacket {
    /// Index of the input stream the packet belongs to.
    pub fn stream_index(&self) -> usize {
        self.packet.stream()
    }

    /// Presentation time in seconds, when the packet has one.
    pub fn time_s(&self) -> Option<f64> {
        self.packet
            .pts()
            .map(|p| p as f64 * f64::from(self.time_base))
    }
}

impl std::fmt::Debug for CopiedPacket {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CopiedPacket")
            .field("stream", &self.packet.stream())
            .field("pts", &self.packet.pts())
            .field("size", &self.packet.size())
            .finish()
    }
}

/// One step of the input, in demux order.
#[derive(Debug)]
pub enum SourceItem {
    /// A decoded video frame.
    Frame(YuvFrame),
    /// A packet of another stream.
    Packet(CopiedPacket),
}

/// How many video packets [`Source::open`] reads ahead to judge the frame rate.
const LOOKAHEAD_PACKETS: usize = 300;
/// Upper bound on the bytes held by the read-ahead.
const LOOKAHEAD_BYTES: usize = 64 << 20;
/// Damaged packets in a row after which the demuxer is considered lost.
const MAX_BAD_PACKETS_IN_A_ROW: u32 = 1000;

/// The decoding side of a job. `Send`: the pipeline may run it on its own thread.
pub struct Source {
    input: ff::format::context::Input,
    path: String,
    seekable: bool,
    video: usize,
    tb: Rational,
    decoder: ff::decoder::Video,
    /// Packets read ahead and not processed yet.
    pending: VecDeque<ff::Packet>,
    /// Frames and packets ready to hand out.
    ready: VecDeque<SourceItem>,
    input_done: bool,
    decoder_done: bool,
    layout: Option<(SourceLayout, FrameFormat, ColorParams)>,
    converter: Option<((ff::format::Pixel, u32, u32), Converter)>,
    raw: ff::frame::Video,
    next_index: u64,
    last_pts: Option<i64>,
    /// Ticks of one frame at the nominal rate (for frames without a timestamp).
    frame_ticks: i64,
    bad_packets_in_a_row: u32,
    /// Timestamp continuity across joined segments, per stream (the video's included).
    clocks: std::collections::HashMap<usize, StreamClock>,
    /// The container may restart or jump its clocks (MPEG-TS).
    discontinuous: bool,
    /// Decoding started from a seek, not the first frame (frame counts are partial).
    sought: bool,
    warned_resize: bool,
    warned_interlaced: bool,
    info: Option<VideoInfo>,
}

/// One stream's timestamp continuity: the shift applied since the last discontinuity and the
/// latest timestamp handed out.
#[derive(Debug, Clone, Copy, Default)]
struct StreamClock {
    offset: i64,
    last: Option<i64>,
}

/// A forward leap in a discontinuous container's clock treated as a new segment, seconds
/// (ffmpeg's `-dts_delta_threshold` default).
const DISCONTINUITY_LEAP_S: f64 = 10.0;

/// Brings FFmpeg up once and keeps its own logging quiet (our errors and warnings carry its
/// messages); [`set_ffmpeg_log_level`] raises it for debugging.
pub fn init() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        if let Err(e) = ff::init() {
            log::warn!("FFmpeg initialisation: {e}");
        }
        ff::util::log::set_level(ff::util::log::Level::Fatal);
    });
}

/// Sets FFmpeg's own stderr logging (default: fatal errors only).
pub fn set_ffmpeg_log_level(level: ff::util::log::Level) {
    init();
    ff::util::log::set_level(level);
}

impl Source {
    /// Opens a file, or stdin for `"-"` (a y4m, NUT, Matroska or MPEG-TS stream; no seeking).
    pub fn open(input: &str) -> Result<Source> {
        init();
        let url = if input == "-" { "pipe:0" } else { input };
        let ictx = ff::format::input(url).map_err(|e| open_error(input, e))?;
        let seekable = input != "-";
        let stream = ictx
            .streams()
            .best(ff::media::Type::Video)
            .ok_or_else(|| Error::NoVideo(input.to_owned()))?;
        let video = stream.index();
        let tb = stream.time_base();
        let mut ctx = ff::codec::Context::from_parameters(stream.parameters())
            .map_err(Error::ffmpeg("reading the video stream parameters"))?;
        ctx.set_threading(ff::threading::Config::kind(ff::threading::Type::Frame));
        let mut dec = ctx.decoder();
        dec.set_packet_time_base(tb);
        let codec_id = stream.parameters().id();
        let decoder = dec.video().map_err(|e| match e {
            ff::Error::DecoderNotFound => {
                Error::Unsupported(format!("no decoder for video codec {}", codec_id.name()))
            }
            e => Error::ffmpeg(format!("opening the {} decoder", codec_id.name()))(e),
        })?;
        let fps = stream.rate();
        let frame_ticks = if fps.numerator() > 0 && fps.denominator() > 0 {
            1i64.rescale(fps.invert(), tb).max(1)
        } else {
            1
        };
        let mut source = Source {
            input: ictx,
            path: input.to_owned(),
            seekable,
            video,
            tb,
            decoder,
            pending: VecDeque::new(),
            ready: VecDeque::new(),
            input_done: false,
            decoder_done: false,
            layout: None,
            converter: None,
            raw: ff::frame::Video::empty(),
            next_index: 0,
            last_pts: None,
            frame_ticks,
            bad_packets_in_a_row: 0,
            clocks: std::collections::HashMap::new(),
            discontinuous: false,
            sought: false,
            warned_resize: false,
            warned_interlaced: false,
            info: None,
        };
        source.discontinuous = super::ffi::input_allows_discontinuities(&source.input);
        let vfr_by_scan = source.read_ahead()?;
        while !source
            .ready
            .iter()
            .any(|i| matches!(i, SourceItem::Frame(_)))
        {
            if !source.pump()? {
                break;
            }
        }
        let first = source.ready.iter().find_map(|i| match i {
            SourceItem::Frame(f) => Some(f.pts),
            SourceItem::Packet(_) => None,
        });
        let Some(first_pts) = first else {
            return Err(Error::CorruptInput(format!(
                "no video frame could be decoded from '{input}'"
            )));
        };
        source.info = Some(source.build_info(first_pts, vfr_by_scan));
        Ok(source)
    }

    /// What the input is; see [`VideoInfo`].
    pub fn info(&self) -> &VideoInfo {
        // Set at the end of `open`, which is the only constructor.
        self.info.as_ref().expect("Source::info is set by open")
    }

    /// Whether [`Source::seek_to_time`] and [`Source::frame_at_index`] can work (not stdin).
    pub fn is_seekable(&self) -> bool {
        self.seekable
    }

    /// The next decoded frame or packet of another stream, in demux order; `None` at the end.
    pub fn next_item(&mut self) -> Result<Option<SourceItem>> {
        loop {
            if let Some(item) = self.ready.pop_front() {
                return Ok(Some(item));
            }
            if !self.pump()? {
                return Ok(None);
            }
        }
    }

    // ---- reading and decoding ----

    /// Reads the look-ahead; returns whether the timestamps already show a variable rate.
    fn read_ahead(&mut self) -> Result<bool> {
        let mut pts = Vec::new();
        let mut bytes = 0usize;
        while pts.len() < LOOKAHEAD_PACKETS && bytes < LOOKAHEAD_BYTES {
            let Some(packet) = self.read_packet()? else {
                break;
            };
            bytes += packet.size();
            if packet.stream() == self.video {
                if let Some(p) = packet.pts() {
                    pts.push(p);
                }
            }
            self.pending.push_back(packet);
        }
        Ok(timestamps_vary(&mut pts))
    }

    /// One packet from the demuxer, or `None` at the end (clean or not).
    fn read_packet(&mut self) -> Result<Option<ff::Packet>> {
        if self.input_done {
            return Ok(None);
        }
        loop {
            let mut packet = ff::Packet::empty();
            match packet.read(&mut self.input) {
                Ok(()) => {
                    self.bad_packets_in_a_row = 0;
                    return Ok(Some(packet));
                }
                Err(ff::Error::Eof) => {
                    self.input_done = true;
                    return Ok(None);
                }
                Err(ff::Error::InvalidData) if super::ffi::input_at_eof(&self.input) => {
                    // The container promised more than the file holds: a truncated input is
                    // an error (a damaged packet inside a complete file is only a warning).
                    self.input_done = true;
                    return Err(Error::CorruptInput(format!(
                        "'{}' ends early near frame {} (truncated?)",
                        self.path, self.next_index
                    )));
                }
                Err(ff::Error::InvalidData) => {
                    self.bad_packets_in_a_row += 1;
                    if self.bad_packets_in_a_row <= 10 {
                        log::warn!(
                            "'{}': skipping unreadable data near frame {}",
                            self.path,
                            self.next_index
                        );
                    }
                    if self.bad_packets_in_a_row >= MAX_BAD_PACKETS_IN_A_ROW {
                        return Err(Error::CorruptInput(format!(
                            "'{}': the demuxer lost sync near frame {}",
                            self.path, self.next_index
                        )));
                    }
                }
                Err(e) => {
                    // A terminal read error (truncated file, I/O error).
                    self.input_done = true;
                    return Err(Error::CorruptInput(format!(
                        "'{}' cannot be read past frame {}: {e}",
                        self.path, self.next_index
                    )));
                }
            }
        }
    }

    /// Processes one packet (or the end of input) into `ready`; false once everything is out.
    fn pump(&mut self) -> Result<bool> {
        if self.decoder_done {
            return Ok(false);
        }
        let packet = match self.pending.pop_front() {
            Some(p) => Some(p),
            None => self.read_packet()?,
        };
        match packet {
            Some(packet) if packet.stream() == self.video => {
                self.send_video(&packet)?;
            }
            Some(mut packet) => {
                let time_base = self
                    .input
                    .stream(packet.stream())
                    .map(|s| s.time_base())
                    .unwrap_or(self.tb);
                if let Some(dts) = packet.dts().or(packet.pts()) {
                    let duration = packet.duration().max(1);
                    let shifted = self.continuous(packet.stream(), dts, duration, time_base);
                    let offset = shifted - dts;
                    if offset != 0 {
                        packet.set_dts(packet.dts().map(|t| t + offset));
                        packet.set_pts(packet.pts().map(|t| t + offset));
                    }
                }
                self.ready
                    .push_back(SourceItem::Packet(CopiedPacket { packet, time_base }));
            }
            None => {
                // End of input: drain the decoder.
                if let Err(e) = self.decoder.send_eof()
                    && e != ff::Error::Eof
                {
                    log::warn!("'{}': flushing the decoder: {e}", self.path);
                }
                self.drain()?;
                self.decoder_done = true;
                // A file cut short often still reads to a clean end of file (the demuxer stops
                // at the last whole packet): compare with the frame count its index promised.
                if let Some(expected) = self.info.as_ref().and_then(|i| i.frame_count)
                    && !self.sought
                    && (self.next_index as f64) < 0.9 * expected as f64
                {
                    return Err(Error::CorruptInput(format!(
                        "'{}' ends early: {} of the {expected} frames its index lists (truncated?)",
                        self.path, self.next_index
                    )));
                }
            }
        }
        Ok(true)
    }

    fn send_video(&mut self, packet: &ff::Packet) -> Result<()> {
        if packet.is_corrupt() {
            log::warn!(
                "'{}': damaged video packet near frame {}",
                self.path,
                self.next_index
            );
        }
        for _ in 0..2 {
            match self.decoder.send_packet(packet) {
                Ok(()) => return self.drain(),
                Err(ff::Error::Other { errno }) if errno == ff::error::EAGAIN => self.drain()?,
                Err(e) => {
                    log::warn!(
                        "'{}': damaged video packet near frame {}: {e}",
                        self.path,
                        self.next_index
                    );
                    return self.drain();
                }
            }
        }
        log::warn!(
            "'{}': the decoder refused a video packet near frame {}",
            self.path,
            self.next_index
        );
        Ok(())
    }

    /// Receives every frame the decoder has ready.
    fn drain(&mut self) -> Result<()> {
        let mut errors = 0;
        loop {
            match self.decoder.receive_frame(&mut self.raw) {
                Ok(()) => {
                    let frame = self.convert_raw()?;
                    self.ready.push_back(SourceItem::Frame(frame));
                }
                Err(ff::Error::Other { errno }) if errno == ff::error::EAGAIN => return Ok(()),
                Err(ff::Error::Eof) => return Ok(()),
                Err(e) => {
                    log::warn!(
                        "'{}': frame {} could not be decoded: {e}",
                        self.path,
                        self.next_index
                    );
                    errors += 1;
                    if errors > 64 {
                        return Ok(());
                    }
                }
            }
        }
    }

    /// Turns the decoder's frame into a [`YuvFrame`] in the source layout.
    fn convert_raw(&mut self) -> Result<YuvFrame> {
        let index = self.next_index;
        if self.raw.is_corrupt() || !self.raw.decode_error_flags().is_empty() {
            log::warn!(
                "'{}': frame {index} is damaged (decoded with concealment)",
                self.path
            );
        }
        if self.raw.is_interlaced() && !self.warned_interlaced {
            log::warn!(
                "'{}' is interlaced: the rain is drawn on whole frames and the output is marked \
                 progressive (deinterlace first, e.g. with ffmpeg's bwdif, for moving shots)",
                self.path
            );
            self.warned_interlaced = true;
        }
        let (w, h, pixel) = (self.raw.width(), self.raw.height(), self.raw.format());
        if self.layout.is_none() {
            self.layout = Some(self.decide_layout()?);
        }
        let (layout, format, color) = self.layout.expect("layout decided above");
        let same_size = w == format.width && h == format.height;
        if !same_size && !self.warned_resize {
            log::warn!(
                "'{}': the picture size changes to {w}x{h} at frame {index}; scaling to {}x{}",
                self.path,
                format.width,
                format.height
            );
            self.warned_resize = true;
        }
        let direct = layout.direct
            && same_size
            && pixfmt::layout_of(pixel).map(|l| (l.0, l.1))
                == Some((format.chroma, format.bit_depth))
            && super::ffi::strides_positive(&self.raw);
        let planes = if direct {
            pixfmt::planes_from_av(&self.raw, &format)
        } else {
            let key = (pixel, w, h);
            if self.converter.as_ref().map(|c| c.0) != Some(key) {
                let target = pixfmt::pixel_of(&format)
                    .ok_or_else(|| Error::Unsupported(format!("{}-bit video", format.bit_depth)))?;
                // YUV → YUV: the same matrix and range on both sides, so samples are only
                // rearranged. RGB: converted with the matrix and range `color` states.
                let src = (color.matrix, color.full_range);
                let conv = Converter::new(
                    key,
                    (target, format.width, format.height),
                    src,
                    (color.matrix, color.full_range),
                )?;
                self.converter = Some((key, conv));
            }
            let conv = &mut self.converter.as_mut().expect("converter set above").1;
            pixfmt::planes_from_av(conv.run(&self.raw)?, &format)
        };
        let pts = match self.raw.timestamp().or(self.raw.pts()) {
            Some(p) => self.continuous(self.video, p, self.frame_ticks, self.tb),
            None => self.last_pts.map_or(0, |p| p + self.frame_ticks),
        };
        self.last_pts = Some(pts);
        self.next_index += 1;
        Ok(YuvFrame {
            format,
            color,
            planes,
            pts,
            index,
        })
    }

    /// `ts` of `stream` on a clock that keeps running across joined segments, the way ffmpeg
    /// treats them: where the timestamps step back by more than one `step` (or, in containers
    /// that allow discontinuities, leap forward by more than [`DISCONTINUITY_LEAP_S`]), the
    /// new segment is shifted to follow the last timestamp by one `step`, and the shift is
    /// kept for the rest of the stream. Each stream keeps its own clock.
    fn continuous(&mut self, stream: usize, ts: i64, step: i64, time_base: Rational) -> i64 {
        let leap = (DISCONTINUITY_LEAP_S * f64::from(time_base.invert())) as i64;
        let discontinuous = self.discontinuous;
        let clock = self.clocks.entry(stream).or_default();
        let t = ts + clock.offset;
        if let Some(last) = clock.last {
            let back = t < last - step;
            let jump = discontinuous && t > last + leap.max(step);
            if back || jump {
                let shifted = last + step;
                clock.offset += shifted - t;
                if stream == self.video {
                    log::warn!(
                        "'{}': the timestamps {} by {:.3} s at frame {} (joined recordings?); the \
                         time goes on at the frame rate from there",
                        self.path,
                        if back { "go back" } else { "leap ahead" },
                        ((t - last).abs() as f64) * f64::from(time_base),
                        self.next_index
                    );
                }
                clock.last = Some(shifted);
                return shifted;
            }
        }
        clock.last = Some(clock.last.map_or(t, |l| l.max(t)));
        t
    }

    /// Chooses the layout and colour interpretation from the first decoded frame.
    fn decide_layout(&self) -> Result<(SourceLayout, FrameFormat, ColorParams)> {
        let layout = pixfmt::source_layout(self.raw.format())?;
        let format = FrameFormat {
            width: self.raw.width(),
            height: self.raw.height(),
            chroma: layout.chroma,
            bit_depth: layout.bit_depth,
        };
        if format.width == 0 || format.height == 0 {
            return Err(Error::CorruptInput(format!(
                "'{}': the video has no picture size",
                self.path
            )));
        }
        let tags = self.frame_tags();
        let color = if layout.rgb {
            let (matrix, full_range) = pixfmt::RGB_SOURCE_COLOR;
            let mut c = info::color_params(&tags, format.height, format.bit_depth, true);
            if tags.transfer == ff::color::TransferCharacteristic::Unspecified {
                c.transfer = Transfer::Srgb;
            }
            ColorParams {
                matrix,
                full_range,
                ..c
            }
        } else {
            // Grey formats are full range in FFmpeg's convention unless tagged otherwise.
            info::color_params(
                &tags,
                format.height,
                format.bit_depth,
                layout.jpeg || layout.gray,
            )
        };
        Ok((layout, format, color))
    }

    /// The first frame's tags, falling back to the decoder's (container-level) ones.
    fn frame_tags(&self) -> ColorTags {
        use ff::color;
        let f = &self.raw;
        let d = &self.decoder;
        ColorTags {
            matrix: Some(f.color_space())
                .filter(|s| *s != color::Space::Unspecified)
                .unwrap_or(d.color_space()),
            range: Some(f.color_range())
                .filter(|s| *s != color::Range::Unspecified)
                .unwrap_or(d.color_range()),
            primaries: Some(f.color_primaries())
                .filter(|s| *s != color::Primaries::Unspecified)
                .unwrap_or(d.color_primaries()),
            transfer: Some(f.color_transfer_characteristic())
                .filter(|s| *s != color::TransferCharacteristic::Unspecified)
                .unwrap_or(d.color_transfer_characteristic()),
        }
    }

    fn build_info(&self, first_pts: i64, vfr_by_scan: bool) -> VideoInfo {
        let (layout, format, color) = self.layout.expect("a frame was decoded");
        let stream = self
            .input
            .stream(self.video)
            .expect("the video stream exists");
        let mut tags = self.frame_tags();
        if layout.rgb {
            // Say on the output what the conversion assumed.
            tags.matrix = ff::color::Space::BT709;
            tags.range = ff::color::Range::JPEG;
            if tags.primaries == ff::color::Primaries::Unspecified {
                tags.primaries = ff::color::Primaries::BT709;
            }
            if tags.transfer == ff::color::TransferCharacteristic::Unspecified {
                tags.transfer = ff::color::TransferCharacteristic::IEC61966_2_1;
            }
        } else if color.full_range && tags.range == ff::color::Range::Unspecified {
            tags.range = ff::color::Range::JPEG;
        }
        let r = stream.rate();
        let avg = stream.avg_frame_rate();
        let rates_differ = r.numerator() > 0
            && avg.numerator() > 0
            && (f64::from(r) - f64::from(avg)).abs() > 0.01 * f64::from(r);
        let duration_s = {
            let d = stream.duration();
            if d > 0 && d != ff::ffi::AV_NOPTS_VALUE {
                Some(d as f64 * f64::from(self.tb))
            } else if self.input.duration() > 0 {
                Some(self.input.duration() as f64 / f64::from(ff::ffi::AV_TIME_BASE))
            } else {
                None
            }
        };
        let matrix = info::display_matrix(&stream);
        VideoInfo {
            format,
            color,
            tags,
            rotation_deg: matrix.as_ref().map_or(0, info::rotation_from_matrix),
            display_matrix: matrix,
            sample_aspect_ratio: info::pair(
                Some(self.raw.aspect_ratio())
                    .filter(|r| r.numerator() > 0)
                    .unwrap_or_else(|| self.decoder.aspect_ratio()),
            ),
            time_base: info::pair(self.tb),
            frame_rate: info::pair(r),
            avg_frame_rate: info::pair(avg),
            start_pts: first_pts,
            duration_s,
            frame_count: u64::try_from(stream.frames()).ok().filter(|&n| n > 0),
            variable_frame_rate: vfr_by_scan || rates_differ,
            codec_name: stream.parameters().id().name().to_owned(),
            container: self.input.format().name().to_owned(),
            pixel_format: pixfmt::pixel_name(self.decoder.format()),
            video_stream: self.video,
            metadata: info::dict_pairs(&self.input.metadata()),
            streams: self
                .input
                .streams()
                .map(|s| info::stream_info(&s))
                .collect(),
        }
    }
}

/// Whether sorted frame intervals vary by more than timestamp rounding (2 ticks or 1 %).
fn timestamps_vary(pts: &mut [i64]) -> bool {
    pts.sort_unstable();
    let deltas: Vec<i64> = pts
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|&d| d > 0)
        .collect();
    let (Some(&min), Some(&max)) = (deltas.iter().min(), deltas.iter().max()) else {
        return false;
    };
    max - min > 2.max(min / 100)
}

/// Maps an open failure to our error: missing/unreadable → InputOpen; a file FFmpeg recognises
/// by its content but cannot open (truncated MP4 without its index) → CorruptInput; anything
/// else (a text file named .mp4) → InputOpen saying it is not a video file.
fn open_error(input: &str, e: ff::Error) -> Error {
    if e == ff::Error::InvalidData && input != "-" {
        let head = std::fs::File::open(input).and_then(|f| {
            use std::io::Read;
            let mut buf = Vec::new();
            f.take(1 << 16).read_to_end(&mut buf)?;
            Ok(buf)
        });
        if let Ok(head) = head {
            return match super::ffi::probe_content(&head) {
                Some((format, score)) if score > 25 => Error::CorruptInput(format!(
                    "'{input}' looks like {format} but cannot be read ({e}); is it truncated?"
                )),
                _ => Error::InputOpen {
                    path: input.to_owned(),
                    reason: "not a video file FFmpeg recognises".into(),
                },
            };
        }
    }
    let reason = match e {
        ff::Error::Other { errno }
            if [ff::error::ENOENT, ff::error::EACCES, ff::error::EISDIR].contains(&errno) =>
        {
            e.to_string()
        }
        ff::Error::Other { .. } | ff::Error::InvalidData => {
            format!("FFmpeg cannot read its header as video ({e}); is it a video file?")
        }
        e => e.to_string(),
    };
    Error::InputOpen {
        path: input.to_owned(),
        reason,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_jitter_is_not_variable_rate() {
        // 29.97 fps in a 1/1000 time base: 33/34 ms alternate.
        let mut pts: Vec<i64> = (0..100)
            .map(|i| (i as f64 * 1000.0 / 29.97).round() as i64)
            .collect();
        assert!(!timestamps_vary(&mut pts));
        let mut gap: Vec<i64> = (0..10).map(|i| i * 40).chain([1000, 1040]).collect();
        assert!(timestamps_vary(&mut gap));
    }
}
