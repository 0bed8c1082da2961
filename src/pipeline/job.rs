//! One render job from input to output: three threads joined by bounded channels, data
//! flowing one way — `decode` (the [`Source`]: frames and packets to copy) → this thread (the
//! [`Renderer`], up to three frames in flight) → `encode` (the [`Sink`]).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

use super::chunk::{ChunkCut, Cut, FrameRange, INTERLEAVE_SLACK_S};
use super::renderer::Renderer;
use crate::config::RenderConfig;
use crate::fluid::puddles::checkpoint::Checkpoints;
use crate::gpu::{AdapterRequest, Rendered};
use crate::shot::{Footage, frame_time_s};
use crate::video::{CopiedPacket, EncodeOptions, Sink, Source, SourceItem, VideoInfo};
use crate::{Error, Result};

/// Frames or packets buffered between two threads.
const CHANNEL_DEPTH: usize = 4;

/// Where the job is, for progress reporting.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Progress {
    /// Frames written so far.
    pub frames_done: u64,
    /// Frames expected in all, when the container says.
    pub frames_total: Option<u64>,
    /// Seconds since the job started.
    pub elapsed_s: f64,
}

/// Wall time spent per stage, summed over the job.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct StageTimes {
    /// Demuxing and decoding (decode thread).
    pub decode_s: f64,
    /// Lighting input and recording/submitting GPU work, uploads included (GPU thread).
    pub submit_s: f64,
    /// Waiting for the GPU and reading frames back (GPU thread).
    pub readback_s: f64,
    /// Encoding and muxing (encode thread).
    pub encode_s: f64,
    /// GPU execution time per stage (timestamp queries; zero where unsupported).
    pub gpu: crate::gpu::GpuStageTimes,
}

/// What a finished job reports.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Summary {
    /// Frames written.
    pub frames: u64,
    /// Wall time, seconds.
    pub elapsed_s: f64,
    /// Per-stage times.
    pub stages: StageTimes,
    /// Drops drawn per frame.
    pub drops: u32,
    /// The adapter used.
    pub adapter: String,
    /// Where the colour passes ran.
    pub backend: crate::gpu::Backend,
}

/// A full render: `input` → rain → `output`.
#[derive(Debug, Clone)]
pub struct Job {
    /// Input path, or `-` for stdin.
    pub input: String,
    /// Output path, or `-` for stdout.
    pub output: String,
    /// What the picture looks like.
    pub render: RenderConfig,
    /// How it is encoded.
    pub encode: EncodeOptions,
    /// Which adapter.
    pub adapter: AdapterRequest,
    /// Which frames (a chunk of the shot, or all of it).
    pub frames: FrameRange,
    /// Where the puddles' water is kept and read (`None`: neither).
    pub checkpoints: Option<Checkpoints>,
}

enum ToEncode {
    Frame(Rendered),
    Packet(CopiedPacket),
    /// Everything was sent: flush and publish the output. A channel that closes without it
    /// means the job failed, and the unfinished Sink removes its temporary file.
    Finish,
}

/// Runs `job`. `progress` is called after every written frame; `cancel` stops the job cleanly
/// (the partial output is removed), also within a frame's long work such as the water's
/// fast-forward, so it is a static like the flag a signal handler sets.
pub fn render(
    job: &Job,
    cancel: &'static AtomicBool,
    progress: &mut dyn FnMut(Progress),
) -> Result<Summary> {
    job.render.validate()?;
    job.encode.validate()?;
    job.frames.validate()?;
    crate::video::check_output(&job.output, &[&job.input], job.encode.overwrite)?;
    // An OpenEXR sequence holds the layer scene-linear, as the canvas has it.
    let layer = job.encode.layer_for(&job.output)?;
    let started = Instant::now();
    let mut source = Source::open(&job.input)?;
    let info = source.info().clone();
    let config = super::ground::resolve(&job.render, &job.input)?;
    let kept = job.checkpoints.as_ref().map(|c| c.dir.as_path());
    let config = super::motion::resolve_kept(&config, &job.input, cancel, kept)?;
    let sink = Sink::create(&job.output, &info, &job.encode)?;
    let rain = Renderer::with_layer(&config, &Footage::of(&info), &job.adapter, layer)?;
    let rain = match &job.checkpoints {
        Some(c) => rain.with_checkpoints(c.clone()),
        None => rain,
    };
    let mut rain = rain.with_cancel(cancel);
    let first = warm_up_seek(job, &info, &mut source, rain.light_window_s())?;

    let (in_tx, in_rx) = mpsc::sync_channel::<Result<SourceItem>>(CHANNEL_DEPTH);
    let (out_tx, out_rx) = mpsc::sync_channel::<ToEncode>(CHANNEL_DEPTH);
    let stop = Arc::new(AtomicBool::new(false));
    let decoder = spawn_decoder(source, first, in_tx, stop.clone())?;
    let encoder = spawn_encoder(sink, out_rx)?;

    let mut stages = StageTimes::default();
    let mut frames = FrameLoop {
        job,
        info: &info,
        chunk: ChunkCut::new(job.frames, &info),
        out: &out_tx,
        written: 0,
        frames_total: frames_total(job.frames, &info),
        started,
        progress,
    };
    let gpu_result = frames.run(&in_rx, &mut rain, &mut stages, cancel);
    stop.store(true, Ordering::Relaxed);
    drop(in_rx);
    if let Err(err) = gpu_result {
        // Closing the channel without finishing tells the encoder to give up; its Sink is
        // dropped unfinished, which removes the temporary file.
        drop(out_tx);
        let encoded = encoder.join();
        let _ = decoder.join();
        // When the encoder stopped first (a full disk, a closed pipe), its error is the cause.
        return Err(match (err, encoded) {
            (Error::EncoderStopped, Ok(Err(cause))) => cause,
            (Error::EncoderStopped, _) => Error::OutputWrite {
                path: job.output.clone(),
                reason: "the encoder stopped".into(),
            },
            (err, _) => err,
        });
    }
    // If the encoder already stopped, its own error comes out of `join` below.
    let _ = out_tx.send(ToEncode::Finish);
    drop(out_tx);
    let decode_time = decoder
        .join()
        .map_err(|_| Error::Gpu("the decode thread panicked".into()))?;
    let (frames, encode_time) = encoder
        .join()
        .map_err(|_| Error::Gpu("the encode thread panicked".into()))??;
    stages.gpu = rain.gpu_times();
    stages.decode_s = decode_time.as_secs_f64();
    stages.encode_s = encode_time.as_secs_f64();
    Ok(Summary {
        frames,
        elapsed_s: started.elapsed().as_secs_f64(),
        stages,
        drops: rain.drop_count(),
        adapter: rain.adapter().to_string(),
        backend: rain.backend(),
    })
}

/// Seeks a chunk's source to where the frames that light its first frame begin (as a preview
/// does), less the interleaving slack for the audio; returns the frame found there. A pipe, or
/// a chunk at the clip's start, is read from the start (`None`).
fn warm_up_seek(
    job: &Job,
    info: &VideoInfo,
    source: &mut Source,
    light_window_s: f64,
) -> Result<Option<SourceItem>> {
    let warm_from_s = job.frames.start_s(info) - light_window_s - INTERLEAVE_SLACK_S;
    if warm_from_s <= 0.0 || !source.is_seekable() {
        return Ok(None);
    }
    // The seek goes to the frames that light the chunk, before it: a chunk beyond the clip is
    // named by its own start.
    let frame = source.seek_to_time(warm_from_s).map_err(|e| match e {
        Error::OutOfRange(_) => Error::OutOfRange(format!(
            "{} s is beyond the last frame of '{}'",
            job.frames.start_s(info),
            job.input
        )),
        e => e,
    })?;
    Ok(Some(SourceItem::Frame(frame)))
}

/// Frames a job writes, when the container says how many the clip has.
fn frames_total(range: FrameRange, info: &VideoInfo) -> Option<u64> {
    match range {
        FrameRange::All => info.frame_count,
        FrameRange::Indices { start, end } => {
            let last = match (end, info.frame_count) {
                (Some(e), Some(n)) => Some(e.min(n)),
                (e, n) => e.or(n),
            };
            last.map(|l| l.saturating_sub(start))
        }
        FrameRange::Times { .. } => None,
    }
}

/// The decode thread: sends `first`, then the source's items, until the end, an error, a
/// closed channel or `stop`; returns the time it spent decoding.
fn spawn_decoder(
    mut source: Source,
    mut first: Option<SourceItem>,
    in_tx: mpsc::SyncSender<Result<SourceItem>>,
    stop: Arc<AtomicBool>,
) -> Result<std::thread::JoinHandle<Duration>> {
    std::thread::Builder::new()
        .name("decode".into())
        .spawn(move || {
            let mut spent = Duration::ZERO;
            loop {
                let t = Instant::now();
                let item = match first.take() {
                    Some(f) => Ok(Some(f)),
                    None => source.next_item(),
                };
                spent += t.elapsed();
                let end = !matches!(item, Ok(Some(_)));
                let item = match item {
                    Ok(Some(i)) => Ok(i),
                    Ok(None) => break,
                    Err(e) => Err(e),
                };
                if in_tx.send(item).is_err() || end || stop.load(Ordering::Relaxed) {
                    break;
                }
            }
            spent
        })
        .map_err(Error::io("starting the decode thread"))
}

/// The encode thread: writes frames and packets until [`ToEncode::Finish`], then publishes the
/// output; returns the frames written and the time spent. A channel closed without `Finish`
/// is a failed job: the unfinished sink removes its temporary file.
fn spawn_encoder(
    mut sink: Sink,
    out_rx: mpsc::Receiver<ToEncode>,
) -> Result<std::thread::JoinHandle<Result<(u64, Duration)>>> {
    std::thread::Builder::new()
        .name("encode".into())
        .spawn(move || -> Result<(u64, Duration)> {
            let mut spent = Duration::ZERO;
            let mut frames = 0;
            for item in out_rx {
                let t = Instant::now();
                match item {
                    ToEncode::Frame(f) => {
                        sink.write_rendered(&f)?;
                        frames += 1;
                    }
                    ToEncode::Packet(p) => sink.write_packet(p)?,
                    ToEncode::Finish => {
                        if frames == 0 {
                            return Err(Error::CorruptInput("no frame could be decoded".into()));
                        }
                        sink.finish()?;
                        return Ok((frames, spent + t.elapsed()));
                    }
                }
                spent += t.elapsed();
            }
            Err(Error::Interrupted)
        })
        .map_err(Error::io("starting the encode thread"))
}

/// The job's own thread: each decoded item cut to the job's range, frames rendered, frames
/// and packets sent on to the encoder in order.
struct FrameLoop<'a> {
    job: &'a Job,
    info: &'a VideoInfo,
    chunk: ChunkCut,
    out: &'a mpsc::SyncSender<ToEncode>,
    written: u64,
    frames_total: Option<u64>,
    started: Instant,
    progress: &'a mut dyn FnMut(Progress),
}

impl FrameLoop<'_> {
    /// Renders every frame of the range that `in_rx` brings, then the frames still in flight.
    fn run(
        &mut self,
        in_rx: &mpsc::Receiver<Result<SourceItem>>,
        rain: &mut Renderer,
        stages: &mut StageTimes,
        cancel: &AtomicBool,
    ) -> Result<()> {
        for item in in_rx {
            if cancel.load(Ordering::Relaxed) {
                return Err(Error::Interrupted);
            }
            match item? {
                SourceItem::Frame(frame) => {
                    let t_s = frame_time_s(self.info, &frame);
                    match self.chunk.frame(&frame, t_s) {
                        Cut::Before => {
                            // Lights the frames of the chunk (temporal smoothing).
                            rain.observe(&frame, t_s);
                            continue;
                        }
                        Cut::Done => break,
                        Cut::After(packets) => {
                            self.send_packets(packets)?;
                            continue;
                        }
                        Cut::In(packets) => self.send_packets(packets)?,
                    }
                    let t = Instant::now();
                    let done = rain.submit(&frame, t_s)?;
                    stages.submit_s += t.elapsed().as_secs_f64();
                    if let Some(done) = done {
                        self.send(done)?;
                    }
                }
                SourceItem::Packet(p) => {
                    let Some(p) = self.chunk.packet(p) else {
                        continue;
                    };
                    if self.out.send(ToEncode::Packet(p)).is_err() {
                        break;
                    }
                }
            }
        }
        if !self.chunk.started {
            return Err(Error::OutOfRange(format!(
                "no frame of '{}' lies in {}",
                self.job.input, self.job.frames
            )));
        }
        let held = self.chunk.finish();
        self.send_packets(held)?;
        let t = Instant::now();
        let rest = rain.flush()?;
        stages.readback_s += t.elapsed().as_secs_f64();
        for f in rest {
            self.send(f)?;
        }
        Ok(())
    }

    /// Sends a rendered frame to the encoder and reports progress.
    fn send(&mut self, f: Rendered) -> Result<()> {
        self.out
            .send(ToEncode::Frame(f))
            .map_err(|_| Error::EncoderStopped)?;
        self.written += 1;
        (self.progress)(Progress {
            frames_done: self.written,
            frames_total: self.frames_total,
            elapsed_s: self.started.elapsed().as_secs_f64(),
        });
        Ok(())
    }

    /// Sends copied packets to the encoder.
    fn send_packets(&self, packets: Vec<CopiedPacket>) -> Result<()> {
        for p in packets {
            self.out
                .send(ToEncode::Packet(p))
                .map_err(|_| Error::EncoderStopped)?;
        }
        Ok(())
    }
}
