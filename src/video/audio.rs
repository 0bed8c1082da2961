//! The AAC fallback for audio the output container cannot hold as it is (PCM into MP4).
//!
//! How it works: packets are decoded, converted to planar float at the same rate and channel
//! layout (software resampling, format change only), queued, and cut into the encoder's
//! 1024-sample frames for FFmpeg's native `aac` encoder. The first frame keeps the source's
//! first timestamp (rescaled to 1/sample-rate), so a start offset stays in sync with the video.

use ffmpeg_next::format::Sample;
use ffmpeg_next::format::sample::Type as SampleType;
use ffmpeg_next::software::resampling;
use ffmpeg_next::{self as ff, ChannelLayout, Rational, Rescale};

use crate::{Error, Result};

/// Bit rate per channel of the fallback encoder (bits/s); 128 kb/s for stereo.
const BITS_PER_CHANNEL: usize = 64_000;

/// Decodes one input audio stream and re-encodes it as AAC into one output stream.
pub(crate) struct AacTranscoder {
    decoder: ff::decoder::Audio,
    encoder: ff::encoder::audio::Encoder,
    resampler: Option<(ResampleKey, resampling::Context)>,
    layout: ChannelLayout,
    rate: u32,
    frame_size: usize,
    /// Planar samples waiting for a full encoder frame.
    queue: Vec<Vec<f32>>,
    /// pts of the first queued sample, in 1/rate.
    next_pts: Option<i64>,
    in_tb: Rational,
    ost_index: usize,
    ost_tb: Rational,
    decoded: ff::frame::Audio,
    /// The output as the user named it, for error messages.
    output: String,
}

type ResampleKey = (Sample, u64, u32);

const FLTP: Sample = Sample::F32(SampleType::Planar);

impl AacTranscoder {
    /// Opens the decoder and the AAC encoder and adds the output stream.
    pub fn new(
        octx: &mut ff::format::context::Output,
        params: &ff::codec::Parameters,
        in_tb: Rational,
        global_header: bool,
        output: &str,
    ) -> Result<AacTranscoder> {
        let mut dec = ff::codec::Context::from_parameters(params.clone())
            .map_err(Error::ffmpeg("reading the audio stream parameters"))?
            .decoder();
        dec.set_packet_time_base(in_tb);
        let decoder = dec.audio().map_err(Error::ffmpeg(format!(
            "opening the {} decoder",
            params.id().name()
        )))?;
        let rate = decoder.rate();
        let channels = i32::from(decoder.channels()).max(1);
        let layout = Some(decoder.channel_layout())
            .filter(|l| !l.is_empty() && l.channels() == channels)
            .unwrap_or_else(|| ChannelLayout::default(channels));

        let codec = ff::encoder::find(ff::codec::Id::AAC)
            .ok_or_else(|| Error::Unsupported("this FFmpeg build has no AAC encoder".into()))?;
        let mut enc = ff::codec::Context::new_with_codec(codec)
            .encoder()
            .audio()
            .map_err(Error::ffmpeg("creating the AAC encoder"))?;
        enc.set_rate(rate as i32);
        enc.set_channel_layout(layout);
        enc.set_format(FLTP);
        enc.set_bit_rate((BITS_PER_CHANNEL * channels as usize).min(320_000));
        enc.set_time_base(Rational::new(1, rate as i32));
        if global_header {
            enc.set_flags(ff::codec::Flags::GLOBAL_HEADER);
        }
        let encoder = enc
            .open_as(codec)
            .map_err(Error::ffmpeg("opening the AAC encoder"))?;
        let frame_size = (encoder.frame_size() as usize).max(1);
        let mut ost = octx
            .add_stream(codec)
            .map_err(Error::ffmpeg("adding the AAC stream"))?;
        ost.set_parameters(&encoder);
        ost.set_time_base(Rational::new(1, rate as i32));
        let ost_index = ost.index();
        Ok(AacTranscoder {
            decoder,
            encoder,
            resampler: None,
            layout,
            rate,
            frame_size,
            queue: vec![Vec::new(); channels as usize],
            next_pts: None,
            in_tb,
            ost_index,
            ost_tb: Rational::new(1, rate as i32),
            decoded: ff::frame::Audio::empty(),
            output: output.to_owned(),
        })
    }

    /// Index of the output stream.
    pub fn output_index(&self) -> usize {
        self.ost_index
    }

    /// The output stream's time base as the muxer settled it (after the header).
    pub fn set_output_time_base(&mut self, tb: Rational) {
        self.ost_tb = tb;
    }

    /// Decodes one packet and writes whatever complete AAC frames result.
    pub fn push(
        &mut self,
        packet: &ff::Packet,
        octx: &mut ff::format::context::Output,
    ) -> Result<()> {
        if let Err(e) = self.decoder.send_packet(packet) {
            log::warn!(
                "audio packet at pts {:?} could not be decoded: {e}",
                packet.pts()
            );
            return Ok(());
        }
        self.drain_decoder(octx)
    }

    /// Flushes the decoder, the last partial frame and the encoder.
    pub fn finish(&mut self, octx: &mut ff::format::context::Output) -> Result<()> {
        let _ = self.decoder.send_eof();
        self.drain_decoder(octx)?;
        if !self.queue[0].is_empty() {
            // The native AAC encoder accepts a short last frame.
            let n = self.queue[0].len();
            self.encode_queued(n, octx)?;
        }
        let _ = self.encoder.send_eof();
        self.drain_encoder(octx)
    }

    fn drain_decoder(&mut self, octx: &mut ff::format::context::Output) -> Result<()> {
        loop {
            match self.decoder.receive_frame(&mut self.decoded) {
                Ok(()) => {}
                Err(ff::Error::Other { errno }) if errno == ff::error::EAGAIN => return Ok(()),
                Err(ff::Error::Eof) => return Ok(()),
                Err(e) => {
                    log::warn!("audio frame could not be decoded: {e}");
                    continue;
                }
            }
            if self.next_pts.is_none() {
                let first = self.decoded.timestamp().or(self.decoded.pts()).unwrap_or(0);
                self.next_pts = Some(first.rescale(self.in_tb, Rational::new(1, self.rate as i32)));
            }
            self.queue_decoded()?;
            while self.queue[0].len() >= self.frame_size {
                self.encode_queued(self.frame_size, octx)?;
            }
        }
    }

    /// Converts the decoded frame to planar float and appends it to the queue.
    fn queue_decoded(&mut self) -> Result<()> {
        let frame = &self.decoded;
        let channels = i32::from(frame.channels()).max(1);
        let in_layout = Some(frame.channel_layout())
            .filter(|l| !l.is_empty() && l.channels() == channels)
            .unwrap_or_else(|| ChannelLayout::default(channels));
        if channels as usize != self.queue.len() || frame.rate() != self.rate {
            return Err(Error::Unsupported(format!(
                "audio changes to {} channels at {} Hz mid-stream",
                channels,
                frame.rate()
            )));
        }
        let key = (frame.format(), in_layout.bits(), frame.rate());
        if self.resampler.as_ref().map(|r| r.0) != Some(key) {
            let ctx = resampling::Context::get(
                frame.format(),
                in_layout,
                frame.rate(),
                FLTP,
                self.layout,
                self.rate,
            )
            .map_err(Error::ffmpeg("setting up audio sample conversion"))?;
            self.resampler = Some((key, ctx));
        }
        let (_, ctx) = self.resampler.as_mut().expect("resampler set above");
        let mut out = ff::frame::Audio::empty();
        // Same rate: only the sample format changes, so every input sample comes out now.
        ctx.run(frame, &mut out)
            .map_err(Error::ffmpeg("converting audio samples"))?;
        let n = out.samples();
        for (ch, q) in self.queue.iter_mut().enumerate() {
            q.extend_from_slice(&out.plane::<f32>(ch)[..n]);
        }
        Ok(())
    }

    fn encode_queued(&mut self, n: usize, octx: &mut ff::format::context::Output) -> Result<()> {
        let mut frame = ff::frame::Audio::new(FLTP, n, self.layout);
        frame.set_rate(self.rate);
        for (ch, q) in self.queue.iter_mut().enumerate() {
            frame.plane_mut::<f32>(ch)[..n].copy_from_slice(&q[..n]);
            q.drain(..n);
        }
        let pts = self.next_pts.unwrap_or(0);
        frame.set_pts(Some(pts));
        self.next_pts = Some(pts + n as i64);
        self.encoder
            .send_frame(&frame)
            .map_err(Error::ffmpeg("encoding AAC"))?;
        self.drain_encoder(octx)
    }

    fn drain_encoder(&mut self, octx: &mut ff::format::context::Output) -> Result<()> {
        let mut packet = ff::Packet::empty();
        while self.encoder.receive_packet(&mut packet).is_ok() {
            packet.set_stream(self.ost_index);
            packet.rescale_ts(Rational::new(1, self.rate as i32), self.ost_tb);
            packet
                .write_interleaved(octx)
                .map_err(|e| Error::OutputWrite {
                    path: self.output.clone(),
                    reason: format!("writing AAC audio: {e}"),
                })?;
        }
        Ok(())
    }
}
