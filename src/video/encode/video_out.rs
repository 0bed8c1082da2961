//! The video encoder and its output stream: which encoder, opened with which layout, time base,
//! colour tags and options, and the frames handed to it (converted, packed and stamped).

use ffmpeg_next::format::Pixel;
use ffmpeg_next::{self as ff, Rational};

use super::options::{EncodeOptions, VideoCodec};
use super::pixel::encoder_pixels;
use super::{MP4_FAMILY, Y4M, dictionary};
use crate::video::ffi;
use crate::video::info::ColorTags;
use crate::video::layer::{Layer, LayerCodec, LayerEncoding, LayerFrame, layer_encoding};
use crate::video::pixfmt::{self, Converter};
use crate::video::{ColorParams, FrameFormat, VideoInfo, YuvFrame};
use crate::{Error, Result};

/// The video encoder and its conversions.
pub(super) struct VideoOut {
    pub(super) encoder: ff::encoder::video::Encoder,
    pub(super) ost: usize,
    pub(super) enc_tb: Rational,
    pub(super) ost_tb: Rational,
    /// The layout frames arrive in.
    format: FrameFormat,
    in_pixel: Pixel,
    /// Layout change for an encoder that does not take the input's layout.
    converter: Option<Converter>,
    enc_pixel: Pixel,
    /// How frames are packed when the output is an R'G'B'A layer or a matte.
    pub(super) layer: Option<(Layer, LayerEncoding)>,
    /// The input's colour, for the Y'CbCr of a ProRes layer.
    color: ColorParams,
    /// y4m: constant rate, pts = frame counter.
    y4m: bool,
    frames: i64,
    last_pts: Option<i64>,
    warned_pts: bool,
}

/// The encoder an output gets: y4m's wrapped frames, a layer's codec, or the one asked for.
struct EncoderChoice {
    codec: ff::Codec,
    /// The encoder's name, for messages.
    name: &'static str,
    layer: Option<(Layer, LayerEncoding)>,
}

/// Opens the video encoder and adds its stream.
pub(super) fn open_video(
    octx: &mut ff::format::context::Output,
    info: &VideoInfo,
    opts: &EncodeOptions,
    ofmt: &ff::format::format::Output,
    global_header: bool,
) -> Result<VideoOut> {
    let muxer = ofmt.name().to_owned();
    let y4m = muxer == Y4M;
    let choice = choose_encoder(ofmt, opts, y4m)?;
    let format = info.format;
    let layer_encoding = choice.layer.map(|(_, e)| e);
    let (in_pixel, enc_pixel) =
        encoder_pixels(&choice.codec, &format, layer_encoding, y4m, opts.codec)?;
    let tb = time_base(info, y4m);
    let encoder = open_encoder(&choice, info, opts, enc_pixel, tb, global_header, y4m)?;
    let ost = add_video_stream(octx, &choice, &encoder, info, tb, &muxer)?;
    use ff::color::TransferCharacteristic as T;
    if matches!(info.tags.transfer, T::SMPTE2084 | T::ARIB_STD_B67) {
        log::warn!(
            "HDR input: the colour tags are kept, but mastering-display and content-light-level \
             metadata are not copied"
        );
    }

    let converter = if enc_pixel != in_pixel && choice.layer.is_none() {
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
        ost,
        enc_tb: tb,
        ost_tb: tb,
        format,
        in_pixel,
        converter,
        enc_pixel,
        layer: choice.layer,
        color: info.color,
        y4m,
        frames: 0,
        last_pts: None,
        warned_pts: false,
    })
}

/// The encoder for `opts` in `ofmt`, refused where this FFmpeg lacks it or the container cannot
/// hold its codec.
fn choose_encoder(
    ofmt: &ff::format::format::Output,
    opts: &EncodeOptions,
    y4m: bool,
) -> Result<EncoderChoice> {
    let muxer = ofmt.name();
    let layer = match opts.layer.filter(|l| l.is_rgba()) {
        Some(l) => Some((l, layer_encoding(muxer, opts.codec, l)?)),
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
    let animation_only = ["gif", "apng", "webp"].contains(&muxer);
    if !y4m && (animation_only || ffi::muxer_accepts(ofmt, codec.id()) == Some(false)) {
        return Err(Error::Unsupported(format!(
            "the {muxer} container cannot hold {}; use .mkv or .mov",
            codec.id().name()
        )));
    }
    Ok(EncoderChoice {
        codec,
        name: if y4m { Y4M } else { encoder_name },
        layer,
    })
}

/// The encoder's time base: the input stream's, so every pts passes through unchanged; for y4m,
/// which is constant-rate, one frame.
fn time_base(info: &VideoInfo, y4m: bool) -> Rational {
    if !y4m {
        return Rational::new(info.time_base.0, info.time_base.1);
    }
    // y4m's muxer derives the frame rate from the time base.
    let (num, den) = info.nominal_fps();
    if info.variable_frame_rate {
        log::warn!(
            "y4m output is constant-rate: frames are written at {num}/{den} fps and the \
             input's timing gaps are lost"
        );
    }
    Rational::new(den, num)
}

/// Opens the chosen encoder for `info`'s pictures in `enc_pixel`, tagged with the input's
/// colour (or the layer's).
fn open_encoder(
    choice: &EncoderChoice,
    info: &VideoInfo,
    opts: &EncodeOptions,
    enc_pixel: Pixel,
    tb: Rational,
    global_header: bool,
    y4m: bool,
) -> Result<ff::encoder::video::Encoder> {
    let mut ctx = ff::codec::Context::new_with_codec(choice.codec);
    ctx.set_threading(ff::threading::Config::kind(ff::threading::Type::Frame));
    let mut enc = ctx
        .encoder()
        .video()
        .map_err(Error::ffmpeg("creating the video encoder"))?;
    enc.set_width(info.format.width);
    enc.set_height(info.format.height);
    enc.set_format(enc_pixel);
    enc.set_time_base(tb);
    let (fnum, fden) = info.nominal_fps();
    enc.set_frame_rate(Some(Rational::new(fnum, fden)));
    let (sn, sd) = info.sample_aspect_ratio;
    if sn > 0 && sd > 0 {
        enc.set_aspect_ratio(Rational::new(sn, sd));
    }
    let tags = match choice.layer {
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
    let dict = encoder_options(opts, choice.layer, y4m);
    enc.open_as_with(choice.codec, dict)
        .map_err(Error::ffmpeg(format!(
            "opening the {} encoder",
            choice.name
        )))
}

/// The encoder's private options: quality and speed for x264/x265, FFV1's layout, ProRes's
/// 4444 profile for a layer; none for y4m.
fn encoder_options(
    opts: &EncodeOptions,
    layer: Option<(Layer, LayerEncoding)>,
    y4m: bool,
) -> ff::Dictionary<'static> {
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
    dict
}

/// Adds the video stream for `encoder`, with the input video stream's frame rate, tags and
/// display rotation; returns its index.
fn add_video_stream(
    octx: &mut ff::format::context::Output,
    choice: &EncoderChoice,
    encoder: &ff::encoder::video::Encoder,
    info: &VideoInfo,
    tb: Rational,
    muxer: &str,
) -> Result<usize> {
    let y4m = muxer == Y4M;
    let mut ost = octx
        .add_stream(choice.codec)
        .map_err(Error::ffmpeg("adding the video stream"))?;
    ost.set_parameters(encoder);
    ost.set_time_base(tb);
    if info.avg_frame_rate.0 > 0 && info.avg_frame_rate.1 > 0 && !y4m {
        ost.set_avg_frame_rate(Rational::new(info.avg_frame_rate.0, info.avg_frame_rate.1));
    }
    if let Some(vs) = info.stream(info.video_stream) {
        let mut metadata = dictionary(&vs.metadata, &["rotate", "encoder", "alpha_mode"]);
        if let Some((Layer::Alpha(mode), _)) = choice.layer {
            // No container has a standard field for it: Matroska keeps it as a stream tag
            // (MOV only as the file tag the header sets).
            metadata.set("alpha_mode", mode.name());
        }
        ost.set_metadata(metadata);
    }
    attach_rotation(&mut ost, info, muxer);
    Ok(ost.index())
}

/// Gives the stream the input's display matrix where the container stores one, and says so
/// where it cannot (the output would play unrotated).
fn attach_rotation(ost: &mut ff::format::stream::StreamMut, info: &VideoInfo, muxer: &str) {
    const IDENTITY: [i32; 9] = [1 << 16, 0, 0, 0, 1 << 16, 0, 0, 0, 1 << 30];
    let Some(m) = &info.display_matrix else {
        return;
    };
    if *m == IDENTITY {
        return;
    }
    if MP4_FAMILY.contains(&muxer) {
        if !ffi::set_display_matrix(ost, m) {
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

/// The colour tags of a layer written as `encoding`: R'G'B' samples carry no matrix and are
/// full range, ProRes's Y'CbCr keeps the video's matrix at limited range, and a matte is linear.
pub(super) fn layer_tags(video: ColorTags, layer: Layer, encoding: LayerEncoding) -> ColorTags {
    use ff::color::{Range, Space, TransferCharacteristic};
    let prores = encoding.codec == LayerCodec::ProRes4444;
    ColorTags {
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

impl VideoOut {
    /// `frame` as the encoder takes it: in the encoder's layout, in a fresh AVFrame (encoders,
    /// and the y4m muxer, may keep a reference to it). Refused for a layer output or a frame of
    /// another layout.
    pub(super) fn picture(&mut self, frame: &YuvFrame) -> Result<ff::frame::Video> {
        if self.layer.is_some() {
            return Err(Error::Unsupported(
                "this output was opened for layers, not pictures".into(),
            ));
        }
        if frame.format != self.format {
            return Err(Error::Parameter {
                name: "frame",
                value: format!("{:?}", frame.format),
                expected: format!("the layout the sink was created for, {:?}", self.format),
            });
        }
        let (w, h) = (self.format.width, self.format.height);
        let mut av = ff::frame::Video::new(self.in_pixel, w, h);
        pixfmt::planes_to_av(frame, &mut av)?;
        Ok(match self.converter.as_mut() {
            Some(c) => {
                let mut out = ff::frame::Video::new(self.enc_pixel, w, h);
                c.run_into(&av, &mut out)?;
                out
            }
            None => av,
        })
    }

    /// `frame` packed as the layer output stores it, with the colour tags it is written with
    /// (given the video's `tags`). Refused for a picture output or a layer of another size.
    pub(super) fn layer(
        &self,
        frame: &LayerFrame,
        tags: ColorTags,
    ) -> Result<(ff::frame::Video, ColorTags)> {
        let Some((layer, encoding)) = self.layer else {
            return Err(Error::Unsupported(
                "this output was opened for pictures, not layers".into(),
            ));
        };
        if frame.samples != layer.samples() {
            return Err(Error::Unsupported(format!(
                "this output was opened for {:?} layer samples, not {:?}",
                layer.samples(),
                frame.samples
            )));
        }
        let (w, h) = (self.format.width, self.format.height);
        if (frame.width, frame.height) != (w, h) || frame.rgba.len() != 4 * (w * h) as usize {
            return Err(Error::Parameter {
                name: "layer",
                value: format!("{}x{}", frame.width, frame.height),
                expected: format!("the size the sink was created for, {w}x{h}"),
            });
        }
        let mut av = ff::frame::Video::new(encoding.pixel, w, h);
        crate::video::layer::pack(frame, layer, encoding, &self.color, &mut av);
        Ok((av, layer_tags(tags, layer, encoding)))
    }

    /// Stamps `av` with its pts, kept increasing (the frame counter for y4m), and the colour
    /// `tags`.
    pub(super) fn stamp(
        &mut self,
        av: &mut ff::frame::Video,
        frame_pts: i64,
        index: u64,
        tags: ColorTags,
    ) {
        let pts = if self.y4m {
            self.frames
        } else {
            match self.last_pts {
                Some(last) if frame_pts <= last => {
                    if !self.warned_pts {
                        log::warn!(
                            "frame {} has pts {} after {last}; shifting it to keep time moving \
                             forward",
                            index,
                            frame_pts
                        );
                        self.warned_pts = true;
                    }
                    last + 1
                }
                _ => frame_pts,
            }
        };
        self.last_pts = Some(pts);
        self.frames += 1;
        av.set_pts(Some(pts));
        av.set_kind(ff::picture::Type::None);
        av.set_color_space(tags.matrix);
        av.set_color_range(tags.range);
        av.set_color_primaries(tags.primaries);
        av.set_color_transfer_characteristic(tags.transfer);
    }
}
