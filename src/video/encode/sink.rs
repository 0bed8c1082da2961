//! The [`Sink`]: one output being written, from its header to the rename that publishes it.

use std::path::{Path, PathBuf};

use ffmpeg_next as ff;

use super::exr::ExrSequence;
use super::header::write_header;
use super::options::EncodeOptions;
use super::streams::{Route, add_streams, output_format, plan_streams};
use super::temp::{TempGuard, check_sequence, discard, publish, sequence_dir};
use super::video_out::{VideoOut, open_video};
use super::{IMAGE2, stream_tb};
use crate::files::check_output;
use crate::video::decode::{CopiedPacket, init};
use crate::video::ffi;
use crate::video::info::{ColorTags, VideoInfo};
use crate::video::layer::is_exr;
use crate::video::{LayerFrame, Rendered, YuvFrame};
use crate::{Error, Result};

/// The encoding side of a job. `Send`: the pipeline may run it on its own thread.
pub struct Sink {
    out: Out,
    output: String,
    temp: Option<PathBuf>,
    finished: bool,
    /// The source index of the first frame written: an image sequence is numbered by it.
    first_index: Option<u64>,
}

/// What writes the frames.
enum Out {
    /// FFmpeg: a muxer, the video encoder and the other streams' routes.
    Av(Box<AvOut>),
    /// An OpenEXR sequence (the `exr` crate).
    Exr(ExrSequence),
}

/// An output written through FFmpeg.
struct AvOut {
    /// Open until the sink finishes (closed before the temporary file is renamed or removed).
    octx: Option<ff::format::context::Output>,
    video: VideoOut,
    routes: Vec<Option<Route>>,
    info_tags: ColorTags,
}

impl Sink {
    /// Creates the output (`"-"` = stdout) for frames shaped like `info` says, and writes its
    /// header into a temporary file beside it (an OpenEXR sequence: a hidden directory).
    pub fn create(output: &str, info: &VideoInfo, opts: &EncodeOptions) -> Result<Sink> {
        init();
        opts.validate()?;
        check_output(output, &[], opts.overwrite)?;
        // Refuses a layer the output cannot hold before anything is created.
        opts.layer_for(output)?;
        if is_exr(output, opts.container.as_deref()) {
            return Sink::create_exr(output, info, opts);
        }
        let ofmt = output_format(output, opts.container.as_deref())?;
        let muxer = ofmt.name().to_owned();
        let plan = plan_streams(info, &ofmt, opts);
        let sequence = muxer == IMAGE2;
        if sequence {
            check_sequence(output, opts)?;
        }

        let mut guard = TempGuard::open(output, &muxer, sequence)?;
        let octx = guard.octx();
        let global_header = octx
            .format()
            .flags()
            .contains(ff::format::Flags::GLOBAL_HEADER);
        let mut video = open_video(octx, info, opts, &ofmt, global_header)?;
        let mut routes = add_streams(octx, info, &plan, &muxer, global_header, output)?;
        write_header(octx, info, opts, &muxer, output)?;

        // The muxer may have changed the time bases it was offered.
        video.ost_tb = stream_tb(octx, video.ost);
        for route in routes.iter_mut().flatten() {
            route.adopt_time_base(octx);
        }

        let (octx, temp) = guard.disarm();
        Ok(Sink {
            out: Out::Av(Box::new(AvOut {
                octx: Some(octx),
                video,
                routes,
                info_tags: info.tags,
            })),
            output: output.to_owned(),
            temp,
            finished: false,
            first_index: None,
        })
    }

    /// An OpenEXR sequence: checked as a PNG sequence is, written into a hidden directory; the
    /// other streams (audio) have no place in it.
    fn create_exr(output: &str, info: &VideoInfo, opts: &EncodeOptions) -> Result<Sink> {
        check_sequence(output, opts)?;
        for s in info.streams.iter().filter(|s| s.index != info.video_stream) {
            log::warn!(
                "dropping {:?} stream #{} ({}): an OpenEXR sequence holds pictures only",
                s.kind,
                s.index,
                s.codec
            );
        }
        let dir = sequence_dir(output)?;
        Ok(Sink {
            out: Out::Exr(ExrSequence::new(dir.clone(), output, info)),
            output: output.to_owned(),
            temp: Some(dir),
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
        let Out::Av(av_out) = &mut self.out else {
            return Err(Error::Unsupported(
                "an OpenEXR sequence holds layers, not pictures".into(),
            ));
        };
        let av = av_out.video.picture(frame)?;
        let tags = av_out.info_tags;
        av_out.send_video(av, frame.pts, frame.index, tags, &self.output)
    }

    /// Encodes one layer (a sink created with an R'G'B'A [`Layer`](crate::video::Layer)).
    pub fn write_layer(&mut self, frame: &LayerFrame) -> Result<()> {
        match &mut self.out {
            Out::Av(av_out) => {
                let (av, tags) = av_out.video.layer(frame, av_out.info_tags)?;
                self.first_index.get_or_insert(frame.index);
                av_out.send_video(av, frame.pts, frame.index, tags, &self.output)
            }
            Out::Exr(sequence) => {
                sequence.write(frame)?;
                self.first_index.get_or_insert(frame.index);
                Ok(())
            }
        }
    }

    /// Encodes a rendered frame of either kind.
    pub fn write_rendered(&mut self, frame: &Rendered) -> Result<()> {
        match frame {
            Rendered::Picture(f) => self.write_frame(f),
            Rendered::Layer(l) => self.write_layer(l),
        }
    }

    /// Writes a packet of another stream (copied, transcoded to AAC, or dropped as planned;
    /// always dropped by an OpenEXR sequence).
    pub fn write_packet(&mut self, p: CopiedPacket) -> Result<()> {
        let Out::Av(av_out) = &mut self.out else {
            return Ok(());
        };
        let Some(Some(route)) = av_out.routes.get_mut(p.stream_index()) else {
            return Ok(());
        };
        let octx = av_out.octx.as_mut().expect("open until finish");
        route.write(p, octx, &self.output)
    }

    /// Flushes the encoders, writes the trailer and renames the temporary file onto the output
    /// (moves a sequence's images beside its pattern).
    pub fn finish(mut self) -> Result<()> {
        if let Out::Av(av_out) = &mut self.out {
            av_out.finish(&self.output)?;
        }
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
}

impl AvOut {
    /// Stamps `av` with its pts (kept increasing) and colour tags, and encodes it.
    fn send_video(
        &mut self,
        mut av: ff::frame::Video,
        frame_pts: i64,
        index: u64,
        tags: ColorTags,
        output: &str,
    ) -> Result<()> {
        self.video.stamp(&mut av, frame_pts, index, tags);
        self.video
            .encoder
            .send_frame(&av)
            .map_err(Error::ffmpeg(format!("encoding frame {index}")))?;
        self.drain_video(output)
    }

    /// Flushes the encoders, writes the trailer and closes the file.
    fn finish(&mut self, output: &str) -> Result<()> {
        self.video
            .encoder
            .send_eof()
            .map_err(Error::ffmpeg("flushing the video encoder"))?;
        self.drain_video(output)?;
        let octx = self.octx.as_mut().expect("open until finish");
        for route in self.routes.iter_mut().flatten() {
            route.finish(octx)?;
        }
        octx.write_trailer().map_err(|e| Error::OutputWrite {
            path: output.to_owned(),
            reason: format!("finishing the file: {e}"),
        })?;
        ffi::flush_io(octx).map_err(|e| Error::OutputWrite {
            path: output.to_owned(),
            reason: io_reason(output, e),
        })?;
        // Close the file before renaming it.
        drop(self.octx.take());
        Ok(())
    }

    /// Writes every packet the video encoder has ready.
    fn drain_video(&mut self, output: &str) -> Result<()> {
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
                    path: output.to_owned(),
                    reason: format!("writing video: {}", io_reason(output, e)),
                })?;
        }
    }
}

impl Drop for Sink {
    fn drop(&mut self) {
        if !self.finished {
            if let Out::Av(av_out) = &mut self.out {
                drop(av_out.octx.take());
            }
            if let Some(temp) = &self.temp {
                discard(temp);
            }
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
