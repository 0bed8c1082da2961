//! One render job from input to output, and single-frame preview.
//!
//! ## How it works
//! Three threads joined by bounded channels, data flowing one way:
//! `decode` (the [`Source`]: frames and packets to copy) → `gpu` (this thread: lighting and
//! the [`Compositor`], up to three frames in flight) → `encode` (the [`Sink`]). The rain at a
//! frame is a pure function of the frame's time `t = (pts − start) · time_base` and of that
//! frame alone, so [`preview`] renders exactly what [`render`] writes at the same frame.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

use crate::config::RenderConfig;
use crate::fluid::puddles::checkpoint::{self, Checkpoints};
use crate::fluid::puddles::{PuddleSettings, PuddleSim};
use crate::gpu::types::{LightList, RainParams};
use crate::gpu::uniforms::{self as emitter, RainSetup};
use crate::gpu::{AdapterRequest, Compositor, GpuContext, Rendered};
use crate::lighting::{EnvironmentSh, FrameLight, LightEstimator};
use crate::rain::volume::GroundRain;
use crate::scene::Camera;
use crate::scene::depth::DepthSource;
use crate::video::{EncodeOptions, Layer, Sink, Source, SourceItem, VideoInfo, YuvFrame};
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
}

/// The camera looking at the displayed picture of `info`.
pub fn camera_for(info: &VideoInfo, config: &RenderConfig) -> Result<Camera> {
    let (w, h) = display_size(info);
    config.camera(w, h)
}

fn display_size(info: &VideoInfo) -> (u32, u32) {
    crate::video::frame::display_size(info.rotation_deg, info.format.width, info.format.height)
}

/// Exposure time: shutter angle over 360° times the frame duration (180° → 1/(2·fps)), by
/// [`crate::rain::physics::exposure_s`] at the clip's frame rate: the average rate, else the
/// nominal one, else 25 fps (a rate outside what the physics accepts counts as unknown).
pub fn exposure_s(info: &VideoInfo, config: &RenderConfig) -> Result<f64> {
    let fps = [info.avg_frame_rate, info.frame_rate]
        .into_iter()
        .filter(|&(num, den)| num > 0 && den > 0)
        .map(|(num, den)| num as f64 / den as f64)
        .find(|&fps| crate::rain::physics::exposure_s(360.0, fps).is_ok())
        .unwrap_or(25.0);
    crate::rain::physics::exposure_s(config.camera.shutter_deg, fps)
}

/// The streak database of the source tree the program was built from.
pub const DEFAULT_STREAK_DB: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/drops");

/// Where `--streaks mattes` finds its database without `--streak-db`: beside an installed
/// program (`../share/rain-composite/drops` or `drops/` next to the executable), else the source
/// tree it was built from. `None` when none holds an `index.json`.
pub fn default_streak_db() -> Option<std::path::PathBuf> {
    let exe_dir = std::env::current_exe()
        .ok()
        .and_then(|e| e.parent().map(std::path::Path::to_path_buf));
    let installed = exe_dir
        .into_iter()
        .flat_map(|d| [d.join("../share/rain-composite/drops"), d.join("drops")]);
    installed
        .chain(std::iter::once(std::path::PathBuf::from(DEFAULT_STREAK_DB)))
        .find(|d| d.join("index.json").is_file())
}

/// The rain of a shot, within what `ctx`'s device can hold: a drop budget above the device's
/// limit is lowered to it, with a warning naming the limit (the plan then shrinks the far
/// distance and weights drops exactly as for any other budget).
pub fn rain_for(info: &VideoInfo, config: &RenderConfig, ctx: &GpuContext) -> Result<RainSetup> {
    let exposure = exposure_s(info, config)?;
    if exposure > 1.0 {
        let fps = config.camera.shutter_deg / 360.0 / exposure;
        return Err(Error::Parameter {
            name: "--shutter",
            value: config.camera.shutter_deg.to_string(),
            expected: format!(
                "an exposure of at most 1 s: this clip runs at {fps:.3} fps, so at most {:.1} degrees",
                360.0 * fps
            ),
        });
    }
    let cap = crate::gpu::max_drops(ctx);
    let mut rain = config.rain;
    if rain.max_drops > cap {
        log::warn!(
            "--max-drops {} is more than this GPU holds in one frame ({cap} drops: its largest \
             storage buffer is {} MiB); using {cap}",
            rain.max_drops,
            ctx.device.limits().max_storage_buffer_binding_size >> 20
        );
        rain.max_drops = cap;
    }
    let setup = emitter::build_keyed(
        &camera_for(info, config)?,
        &config.camera,
        &rain,
        &config.keyframes,
        exposure,
        info.rotation_deg,
        (info.format.width, info.format.height),
    )?;
    let mattes = match config.rain.streaks {
        crate::config::StreakStyle::Simple => None,
        crate::config::StreakStyle::Mattes => {
            let dir = match &config.streak_db {
                Some(dir) => std::path::PathBuf::from(dir),
                None => default_streak_db().ok_or_else(|| Error::Parameter {
                    name: "--streaks",
                    value: "mattes".into(),
                    expected: "a streak database, and none is installed beside the program \
                               (../share/rain-composite/drops, or drops/ next to it): pass \
                               --streak-db DIR (made by `rain-composite drops generate`)"
                        .into(),
                })?,
            };
            let atlas = crate::drops::MatteAtlas::load(&dir, exposure)?;
            Some(std::sync::Arc::new(atlas))
        }
    };
    Ok(setup
        .with_ground(config.ground.is_given())
        .with_wetting(config.ground.wetting(
            config.keyframes.rate_mm_per_h.as_ref(),
            config.rain.rate_mm_per_h,
            config.rain.scene_depth_m,
        ))
        .with_scene_depth(config.ground.depth.is_some())
        .with_mattes(mattes))
}

/// The scene's depth of a job (`--depth`), opened and checked before any frame is decoded: a
/// directory or video with fewer maps than the clip has frames is refused here.
fn depth_for(config: &RenderConfig, info: &VideoInfo) -> Result<Option<DepthSource>> {
    let Some(path) = &config.ground.depth else {
        return Ok(None);
    };
    let depth = DepthSource::open(path, config.ground.depth_scale)?;
    if let (Some(maps), Some(frames)) = (depth.frame_count(), info.frame_count) {
        if maps < frames {
            return Err(Error::Parameter {
                name: "--depth",
                value: path.display().to_string(),
                expected: format!("a depth map per frame: {maps} maps for {frames} frames"),
            });
        }
    }
    Ok(Some(depth))
}

/// Sets the depth of frame `index` on `compositor`: a still once, when `first`, a map per frame
/// otherwise.
fn feed_depth(
    depth: &mut Option<DepthSource>,
    compositor: &mut Compositor,
    index: u64,
    first: bool,
) -> Result<()> {
    match depth {
        Some(DepthSource::Still(map)) if first => compositor.set_scene_depth(map),
        Some(DepthSource::Still(_)) | None => Ok(()),
        Some(d) => compositor.set_scene_depth(d.at(index)?.as_ref()),
    }
}

/// Seconds since the start of the stream at `frame`.
pub fn frame_time_s(info: &VideoInfo, frame: &YuvFrame) -> f64 {
    (frame.pts - info.start_pts) as f64 * info.time_base.0 as f64 / info.time_base.1 as f64
}

/// Which frames of the shot a job renders. A chunk holds exactly the frames, and the packets
/// of the copied streams (audio), that a full render writes between its bounds, with the same
/// timestamps, so chunks joined with `ffmpeg -f concat -c copy` are the full render.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum FrameRange {
    /// The whole shot.
    #[default]
    All,
    /// Frames whose zero-based index (presentation order) is in `[start, end)`; no end: to
    /// the last frame.
    Indices {
        /// First frame rendered.
        start: u64,
        /// First frame not rendered.
        end: Option<u64>,
    },
    /// Frames whose time (seconds from the first frame) is in `[from_s, to_s)`.
    Times {
        /// Earliest time rendered.
        from_s: f64,
        /// First time not rendered.
        to_s: Option<f64>,
    },
}

impl std::fmt::Display for FrameRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let end = |e: Option<String>| e.unwrap_or_default();
        match *self {
            FrameRange::All => write!(f, "all frames"),
            FrameRange::Indices { start, end: e } => {
                write!(f, "frames {start}..{}", end(e.map(|e| e.to_string())))
            }
            FrameRange::Times { from_s, to_s } => match to_s {
                Some(to_s) => write!(f, "times {from_s} s..{to_s} s"),
                None => write!(f, "times from {from_s} s on"),
            },
        }
    }
}

impl FrameRange {
    /// Where a frame of index `index` shown at `t_s` lies: before the range, in it, or after.
    fn place(&self, index: u64, t_s: f64) -> std::cmp::Ordering {
        use std::cmp::Ordering::*;
        let (start, end) = match *self {
            FrameRange::All => return Equal,
            FrameRange::Indices { start, end } => (index < start, end.is_some_and(|e| index >= e)),
            FrameRange::Times { from_s, to_s } => (t_s < from_s, to_s.is_some_and(|e| t_s >= e)),
        };
        match (start, end) {
            (true, _) => Less,
            (false, true) => Greater,
            _ => Equal,
        }
    }

    /// About when the range starts, seconds from the first frame (where to start decoding).
    fn start_s(&self, info: &VideoInfo) -> f64 {
        match *self {
            FrameRange::All => 0.0,
            FrameRange::Indices { start, .. } => {
                let (num, den) = info.nominal_fps();
                start as f64 * den as f64 / num.max(1) as f64
            }
            FrameRange::Times { from_s, .. } => from_s,
        }
    }

    /// Rejects an empty or reversed range.
    pub fn validate(&self) -> Result<()> {
        let empty = match *self {
            FrameRange::All => false,
            FrameRange::Indices { start, end } => end.is_some_and(|e| e <= start),
            FrameRange::Times { from_s, to_s } => {
                !(from_s.is_finite() && from_s >= 0.0)
                    || to_s.is_some_and(|e| !e.is_finite() || e <= from_s)
            }
        };
        if empty {
            return Err(Error::Parameter {
                name: "--frames/--from/--to",
                value: self.to_string(),
                expected: "a range that starts at or after 0 and ends after it starts".into(),
            });
        }
        Ok(())
    }
}

/// How far apart in time a container may store the packets of its streams (audio against
/// video), seconds. A chunk decodes this much before its first frame and reads this much past
/// its last, so every audio packet inside its bounds is seen.
const INTERLEAVE_SLACK_S: f64 = 2.0;

/// Whether the packet time `a` (pts, time base) is before `b`, exactly.
fn earlier((pa, (na, da)): (i64, (i32, i32)), (pb, (nb, db)): (i64, (i32, i32))) -> bool {
    // pa·na/da < pb·nb/db with positive denominators, in integers.
    let wide = |x: i64, y: i32, z: i32| i128::from(x) * i128::from(y) * i128::from(z);
    wide(pa, na, db) < wide(pb, nb, da)
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
    Packet(crate::video::CopiedPacket),
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
    let started = Instant::now();
    let mut source = Source::open(&job.input)?;
    let info = source.info().clone();
    let depth = depth_for(&job.render, &info)?;
    let config = crate::scene::ground_auto::resolve(&job.render, &job.input)?;
    let sink = Sink::create(&job.output, &info, &job.encode)?;
    let rain = RainCompositor::with_layer(&config, &info, &job.adapter, job.encode.layer)?;
    let mut rain = match depth {
        Some(d) => rain.with_depth(d),
        None => rain,
    };
    if let Some(c) = &job.checkpoints {
        rain = rain.with_checkpoints(c.clone());
    }
    let mut rain = rain.with_cancel(cancel);
    // A chunk starts decoding where the frames that light its first frame begin (as a preview
    // does), less the interleaving slack for the audio; a pipe is read from the start.
    let warm_from_s = job.frames.start_s(&info) - rain.light_window_s() - INTERLEAVE_SLACK_S;
    let mut first = None;
    if warm_from_s > 0.0 && source.is_seekable() {
        // The seek goes to the frames that light the chunk, before it: a chunk beyond the clip
        // is named by its own start.
        let frame = source.seek_to_time(warm_from_s).map_err(|e| match e {
            Error::OutOfRange(_) => Error::OutOfRange(format!(
                "{} s is beyond the last frame of '{}'",
                job.frames.start_s(&info),
                job.input
            )),
            e => e,
        })?;
        first = Some(SourceItem::Frame(frame));
    }
    let mut chunk = ChunkCut::new(job.frames, &info);

    let (in_tx, in_rx) = mpsc::sync_channel::<Result<SourceItem>>(CHANNEL_DEPTH);
    let (out_tx, out_rx) = mpsc::sync_channel::<ToEncode>(CHANNEL_DEPTH);
    let stop = Arc::new(AtomicBool::new(false));
    let decode_stop = stop.clone();
    let decoder = std::thread::Builder::new()
        .name("decode".into())
        .spawn(move || {
            let mut source = source;
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
                if in_tx.send(item).is_err() || end || decode_stop.load(Ordering::Relaxed) {
                    break;
                }
            }
            spent
        })
        .map_err(Error::io("starting the decode thread"))?;
    let encoder = std::thread::Builder::new()
        .name("encode".into())
        .spawn(move || -> Result<(u64, Duration)> {
            let mut sink = sink;
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
        .map_err(Error::io("starting the encode thread"))?;

    let mut stages = StageTimes::default();
    let mut written = 0u64;
    let frames_total = match job.frames {
        FrameRange::All => info.frame_count,
        FrameRange::Indices { start, end } => {
            let last = match (end, info.frame_count) {
                (Some(e), Some(n)) => Some(e.min(n)),
                (e, n) => e.or(n),
            };
            last.map(|l| l.saturating_sub(start))
        }
        FrameRange::Times { .. } => None,
    };
    let gpu_result = (|| -> Result<()> {
        let mut send = |f: Rendered, written: &mut u64| -> Result<()> {
            out_tx
                .send(ToEncode::Frame(f))
                .map_err(|_| Error::EncoderStopped)?;
            *written += 1;
            progress(Progress {
                frames_done: *written,
                frames_total,
                elapsed_s: started.elapsed().as_secs_f64(),
            });
            Ok(())
        };
        let send_packets = |packets: Vec<crate::video::CopiedPacket>| -> Result<()> {
            for p in packets {
                out_tx
                    .send(ToEncode::Packet(p))
                    .map_err(|_| Error::EncoderStopped)?;
            }
            Ok(())
        };
        for item in &in_rx {
            if cancel.load(Ordering::Relaxed) {
                return Err(Error::Interrupted);
            }
            match item? {
                SourceItem::Frame(frame) => {
                    let t_s = frame_time_s(&info, &frame);
                    match chunk.frame(&frame, t_s) {
                        Cut::Before => {
                            // Lights the frames of the chunk (temporal smoothing).
                            rain.observe(&frame, t_s);
                            continue;
                        }
                        Cut::Done => break,
                        Cut::After(packets) => {
                            send_packets(packets)?;
                            continue;
                        }
                        Cut::In(packets) => send_packets(packets)?,
                    }
                    let t = Instant::now();
                    let done = rain.submit(&frame, t_s)?;
                    stages.submit_s += t.elapsed().as_secs_f64();
                    if let Some(done) = done {
                        send(done, &mut written)?;
                    }
                }
                SourceItem::Packet(p) => {
                    let Some(p) = chunk.packet(p) else {
                        continue;
                    };
                    if out_tx.send(ToEncode::Packet(p)).is_err() {
                        break;
                    }
                }
            }
        }
        if !chunk.started {
            return Err(Error::OutOfRange(format!(
                "no frame of '{}' lies in {}",
                job.input, job.frames
            )));
        }
        send_packets(chunk.finish())?;
        let t = Instant::now();
        let rest = rain.flush()?;
        stages.readback_s += t.elapsed().as_secs_f64();
        for f in rest {
            send(f, &mut written)?;
        }
        Ok(())
    })();
    stop.store(true, Ordering::Relaxed);
    drop(in_rx);
    if gpu_result.is_err() {
        // Closing the channel without finishing tells the encoder to give up; its Sink is
        // dropped unfinished, which removes the temporary file.
        drop(out_tx);
        let encoded = encoder.join();
        let _ = decoder.join();
        let err = gpu_result.err().unwrap_or(Error::Interrupted);
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
    })
}

/// What to do with a frame, for [`ChunkCut`].
enum Cut {
    /// Before the chunk: feed the light only.
    Before,
    /// In the chunk: render it, after writing these held packets.
    In(Vec<crate::video::CopiedPacket>),
    /// After the chunk, while packets of its time may still come: skip it, writing these
    /// held packets.
    After(Vec<crate::video::CopiedPacket>),
    /// Far enough past the chunk: stop reading.
    Done,
}

/// Cuts a job's frames and copied packets to its [`FrameRange`]. The bounds are the
/// timestamps of the chunk's first frame and of the first frame after it (none at the ends of
/// the shot); a packet belongs to the chunk whose bounds hold its pts, so chunks split the
/// audio exactly where they split the video, every packet going to one chunk. Packets arrive
/// before the frames of their time are decoded, so a packet is held until a frame at or after
/// it settles which side of a bound it lies on.
struct ChunkCut {
    range: FrameRange,
    video_tb: (i32, i32),
    /// Packets whose side of a bound is not known yet, in demux order.
    held: Vec<crate::video::CopiedPacket>,
    /// Whether the chunk's first frame was seen.
    started: bool,
    lower: Option<i64>,
    /// The latest frame of the chunk: a packet before it is before the upper bound.
    latest: Option<i64>,
    upper: Option<(i64, f64)>,
}

impl ChunkCut {
    fn new(range: FrameRange, info: &VideoInfo) -> ChunkCut {
        ChunkCut {
            range,
            video_tb: info.time_base,
            held: Vec::new(),
            started: false,
            lower: None,
            latest: None,
            upper: None,
        }
    }

    /// What to do with `frame`, shown at `t_s`; [`Cut::In`] carries the held packets it settles.
    fn frame(&mut self, frame: &YuvFrame, t_s: f64) -> Cut {
        use std::cmp::Ordering::*;
        match self.range.place(frame.index, t_s) {
            Less => Cut::Before,
            Equal => {
                if !self.started {
                    self.started = true;
                    self.lower = (frame.index > 0).then_some(frame.pts);
                }
                self.latest = Some(frame.pts);
                Cut::In(self.release())
            }
            Greater => {
                if self.upper.is_none() {
                    self.upper = Some((frame.pts, t_s));
                    let settled = self.release();
                    self.held.clear();
                    return Cut::After(settled);
                }
                match self.upper {
                    Some((_, upper_s)) if t_s >= upper_s + INTERLEAVE_SLACK_S => Cut::Done,
                    _ => Cut::After(Vec::new()),
                }
            }
        }
    }

    /// The packet, when it is known to belong to the chunk; held while that is open.
    fn packet(&mut self, p: crate::video::CopiedPacket) -> Option<crate::video::CopiedPacket> {
        if self.range == FrameRange::All {
            return Some(p);
        }
        match self.side(&p) {
            Some(true) => Some(p),
            Some(false) => None,
            None => {
                self.held.push(p);
                None
            }
        }
    }

    /// The held packets of the shot's end (no frame after the chunk came).
    fn finish(&mut self) -> Vec<crate::video::CopiedPacket> {
        let held = std::mem::take(&mut self.held);
        match self.started {
            true => held
                .into_iter()
                .filter(|p| self.side(p) != Some(false))
                .collect(),
            false => Vec::new(),
        }
    }

    /// The held packets now known to belong to the chunk (those known not to are dropped).
    fn release(&mut self) -> Vec<crate::video::CopiedPacket> {
        let held = std::mem::take(&mut self.held);
        let mut out = Vec::new();
        for p in held {
            match self.side(&p) {
                Some(true) => out.push(p),
                Some(false) => {}
                None => self.held.push(p),
            }
        }
        out
    }

    /// Whether `p` lies within the bounds; `None` while that is not known yet.
    fn side(&self, p: &crate::video::CopiedPacket) -> Option<bool> {
        if !self.started {
            return None;
        }
        let Some(pts) = p.packet.pts() else {
            return Some(self.upper.is_none());
        };
        let at = (pts, (p.time_base.numerator(), p.time_base.denominator()));
        if self.lower.is_some_and(|l| earlier(at, (l, self.video_tb))) {
            return Some(false);
        }
        match (self.upper, self.latest) {
            (Some((u, _)), _) => Some(earlier(at, (u, self.video_tb))),
            (None, Some(l)) if earlier(at, (l, self.video_tb)) => Some(true),
            _ => None,
        }
    }
}

/// Which frame to preview.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FrameSelector {
    /// The first frame at or after this time, seconds from the stream's start.
    At(f64),
    /// The frame with this zero-based index.
    Index(u64),
}

/// Renders one frame exactly as [`render`] would; returns it with the stream's description.
/// The puddles' water starts from the latest of `checkpoints` at or before the frame, if any.
///
/// The light of a frame depends on the frames shortly before it (temporal smoothing), so
/// those are decoded and fed first, exactly as the full render sees them.
pub fn preview(
    input: &str,
    at: FrameSelector,
    render: &RenderConfig,
    adapter: &AdapterRequest,
    checkpoints: Option<&Checkpoints>,
    cancel: &'static AtomicBool,
) -> Result<(YuvFrame, VideoInfo)> {
    render.validate()?;
    let check = || {
        if cancel.load(Ordering::Relaxed) {
            Err(Error::Interrupted)
        } else {
            Ok(())
        }
    };
    let mut source = Source::open(input)?;
    let info = source.info().clone();
    let depth = depth_for(render, &info)?;
    let render = &crate::scene::ground_auto::resolve(render, input)?;
    let target = match at {
        FrameSelector::At(t) => source.seek_to_time(t)?,
        FrameSelector::Index(n) => source.frame_at_index(n)?,
    };
    let mut rain = RainCompositor::new(render, &info, adapter)?;
    if let Some(d) = depth {
        rain = rain.with_depth(d);
    }
    if let Some(c) = checkpoints {
        rain = rain.with_checkpoints(c.clone());
    }
    rain = rain.with_cancel(cancel);
    let t_target = frame_time_s(&info, &target);
    let window = rain.light_window_s();
    if window > 0.0 {
        let from = (t_target - window).max(0.0);
        let mut frame = source.seek_to_time(from)?;
        while frame.pts < target.pts {
            check()?;
            let t = frame_time_s(&info, &frame);
            if t > t_target - window {
                rain.observe(&frame, t);
            }
            frame = source
                .next_frame()?
                .ok_or_else(|| Error::OutOfRange("the clip ended before the frame".into()))?;
        }
    }
    check()?;
    let out = rain.render(&target, t_target)?;
    check()?;
    Ok((out, info))
}

/// Rain added to a shot's frames one at a time: the library API for embedding the compositor in
/// an editor or another pipeline, and what [`render`] and [`preview`] run on.
///
/// Frames go in shown order with their time in seconds from the shot's first frame (see
/// [`frame_time_s`]): the rain at a frame is a pure function of that time, and the light of a
/// frame is smoothed over the frames shortly before it, so to start mid-shot, first
/// [`observe`](Self::observe) the frames of [`light_window_s`](Self::light_window_s) before it.
///
/// ```
/// # fn main() -> rain_composite::Result<()> {
/// use rain_composite::{RainCompositor, config::RenderConfig, gpu::AdapterRequest};
/// use rain_composite::{pipeline::frame_time_s, video::Source};
///
/// let mut source = Source::open(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/city.mp4"))?;
/// let info = source.info().clone();
/// let mut config = RenderConfig::default();
/// config.rain.rate_mm_per_h = 30.0;
/// let mut rain = RainCompositor::new(&config, &info, &AdapterRequest::default())?;
/// let frame = source.next_frame()?.expect("a first frame");
/// let wet = rain.render(&frame, frame_time_s(&info, &frame))?;
/// assert_eq!((wet.format, wet.pts), (frame.format, frame.pts));
/// assert_ne!(wet.planes[0].data, frame.planes[0].data, "rain changes the picture");
/// # Ok(())
/// # }
/// ```
pub struct RainCompositor {
    rain: RainSetup,
    compositor: Compositor,
    lighting: LightFeed,
    depth: Option<DepthSource>,
    depth_fed: bool,
    puddles: PuddleFeed,
    adapter: String,
}

impl RainCompositor {
    /// The compositor for a shot described by `info` (from [`Source::info`]), on the adapter
    /// `adapter` asks for; `config` is validated.
    pub fn new(
        config: &RenderConfig,
        info: &VideoInfo,
        adapter: &AdapterRequest,
    ) -> Result<RainCompositor> {
        RainCompositor::with_layer(config, info, adapter, None)
    }

    /// As [`new`](Self::new), writing the rain as `layer` (with alpha, over black, or the
    /// matte; see [`Layer`]) when given: frames then come back from
    /// [`submit`](Self::submit) and [`flush`](Self::flush) as [`Rendered::Layer`].
    pub fn with_layer(
        config: &RenderConfig,
        info: &VideoInfo,
        adapter: &AdapterRequest,
        layer: Option<Layer>,
    ) -> Result<RainCompositor> {
        config.validate()?;
        let ctx = Arc::new(GpuContext::new(adapter)?);
        let rain = rain_for(info, config, &ctx)?;
        log::info!("{}", rain.summary());
        let mut compositor =
            Compositor::with_layer(ctx.clone(), info.format, &info.color, &rain, layer)?;
        let lighting = LightFeed::new(info, config, &rain)?;
        lighting.upload_table(&mut compositor);
        let puddles = PuddleFeed::new(info, config, layer)?;
        Ok(RainCompositor {
            rain,
            compositor,
            lighting,
            depth: None,
            depth_fed: false,
            puddles,
            adapter: ctx.summary().name,
        })
    }

    /// Hides the drops behind the scene's depth (`--depth`; opened by the caller, as a render
    /// does before decoding): a still for every frame, or a map per frame index.
    pub fn with_depth(mut self, depth: DepthSource) -> RainCompositor {
        self.depth = Some(depth);
        self
    }

    /// Keeps the puddles' water in `checkpoints` and starts from the latest one at or before
    /// the first frame rendered (see [`crate::fluid::puddles::checkpoint`]); no effect without
    /// puddles.
    pub fn with_checkpoints(mut self, checkpoints: Checkpoints) -> RainCompositor {
        if let PuddleFeed::Pending(plan) = &mut self.puddles {
            plan.checkpoints = Some(checkpoints);
        }
        self
    }

    /// Stops the long work inside a frame (the water's fast-forward to the first frame) with
    /// [`Error::Interrupted`] once `cancel` is set: the flag the caller's frame loop polls.
    pub fn with_cancel(mut self, cancel: &'static AtomicBool) -> RainCompositor {
        if let PuddleFeed::Pending(plan) = &mut self.puddles {
            plan.cancel = Some(cancel);
        }
        self
    }

    /// The uniforms, lights and depth of the frame shown at `t_s`, set on the compositor.
    fn prepare(&mut self, frame: &YuvFrame, t_s: f64) -> Result<RainParams> {
        // Running water advances on its own thread beside the frame's light estimation (the
        // other CPU task of a frame; neither reads the other), joined before its map goes up.
        let ((params, lights), water) = match &self.puddles {
            PuddleFeed::On(_) => {
                let (puddles, rain, lighting) = (&mut self.puddles, &self.rain, &mut self.lighting);
                std::thread::scope(|scope| {
                    let water = scope.spawn(|| puddles.advance(frame.index, t_s));
                    (lighting.params(rain, frame, t_s), water.join())
                })
            }
            _ => (
                self.lighting.params(&self.rain, frame, t_s),
                Ok(Ok(Vec::new())),
            ),
        };
        let mut hits = water.map_err(|_| Error::Gpu("the water's thread panicked".into()))??;
        self.compositor.set_lights(&lights);
        feed_depth(
            &mut self.depth,
            &mut self.compositor,
            frame.index,
            !self.depth_fed,
        )?;
        self.depth_fed = true;
        hits.extend(
            self.puddles
                .start(&self.rain, &mut self.depth, frame.index, t_s)?,
        );
        self.puddles.show(&mut self.compositor, &hits, t_s)?;
        Ok(params)
    }

    /// How far back, seconds, earlier frames change the light of a frame (0 without light).
    pub fn light_window_s(&self) -> f64 {
        self.lighting.window_secs().unwrap_or(0.0)
    }

    /// Takes the light of a frame shown at `t_s` into account without rendering it.
    pub fn observe(&mut self, frame: &YuvFrame, t_s: f64) {
        self.lighting.params(&self.rain, frame, t_s);
    }

    /// The frame shown at `t_s` with rain, waiting for the GPU.
    pub fn render(&mut self, frame: &YuvFrame, t_s: f64) -> Result<YuvFrame> {
        let params = self.prepare(frame, t_s)?;
        self.compositor.render_one(frame, &params)
    }

    /// Pipelined [`render`](Self::render): queues the frame and returns an earlier one when it
    /// is done (up to three are in flight); [`flush`](Self::flush) returns the rest.
    pub fn submit(&mut self, frame: &YuvFrame, t_s: f64) -> Result<Option<Rendered>> {
        let params = self.prepare(frame, t_s)?;
        self.compositor.submit_rendered(frame, &params)
    }

    /// The frames still in flight, in order.
    pub fn flush(&mut self) -> Result<Vec<Rendered>> {
        self.compositor.flush_rendered()
    }

    /// Drops drawn per frame.
    pub fn drop_count(&self) -> u32 {
        self.compositor.drop_count()
    }

    /// GPU time per stage so far.
    pub fn gpu_times(&self) -> crate::gpu::GpuStageTimes {
        self.compositor.gpu_times()
    }

    /// The adapter's name.
    pub fn adapter(&self) -> &str {
        &self.adapter
    }
}

/// Feeds the puddles (`--puddles`): the simulation is built at the first frame rendered (with
/// the relief of the clip's first depth map, if any) and brought to its time — from the clip's
/// start or from kept water, so a preview or a chunk sees the water a whole render shows
/// there; then each frame
/// hands it the drops that landed since the last one, and the compositor its water map and
/// the impacts of the last ring life for the ripples.
enum PuddleFeed {
    /// No puddles.
    Off,
    /// Waiting for the first frame.
    Pending(Box<PuddlePlan>),
    /// Running.
    On(Box<PuddleRun>),
}

/// What the water is built from at the first frame.
struct PuddlePlan {
    camera: Camera,
    fps: f64,
    config: RenderConfig,
    checkpoints: Option<Checkpoints>,
    /// Stops the fast-forward.
    cancel: Option<&'static AtomicBool>,
}

/// The water during a job.
struct PuddleRun {
    sim: crate::fluid::puddles::PuddleSim,
    /// All the rain landing on the ground: the drawn drops' and the stream beyond them.
    rain: GroundRain,
    /// The render's camera (which rings the picture resolves).
    camera: Camera,
    /// The rings finer than a pixel, as a rough surface.
    far: FarRipples,
    /// The clip time the rain has been fed up to, s.
    fed_s: f64,
    /// The impacts of the last ring life whose rings the picture resolves (at most
    /// `RING_POOL`, the newest).
    recent: Vec<crate::rain::volume::Impact>,
    /// Where the water is kept.
    keep: Option<Keeping>,
}

/// Where a run keeps its water, under which fingerprint.
struct Keeping {
    checkpoints: Checkpoints,
    fingerprint: String,
}

impl PuddleRun {
    /// Keeps the water after frame `index` if it is a frame to keep; a file that cannot be
    /// written costs a later chunk time, not this render its output, so it is a warning.
    fn keep(&self, index: u64) {
        if let Some(Keeping {
            checkpoints,
            fingerprint,
        }) = &self.keep
            && checkpoints.keeps(index)
            && let Err(e) = checkpoints.save(fingerprint, index, &self.sim)
        {
            log::warn!("puddles: the water after frame {index} was not kept: {e}");
        }
    }
}

impl PuddleFeed {
    fn new(info: &VideoInfo, config: &RenderConfig, layer: Option<Layer>) -> Result<PuddleFeed> {
        // The matte is the rain's coverage alone: no water in it.
        if !config.ground.puddles || layer == Some(Layer::Matte) {
            return Ok(PuddleFeed::Off);
        }
        Ok(PuddleFeed::Pending(Box::new(PuddlePlan {
            camera: camera_for(info, config)?,
            fps: crate::fluid::puddles::report::clip_fps(info),
            config: config.clone(),
            checkpoints: None,
            cancel: None,
        })))
    }

    /// Builds the water at the first frame rendered (frame `index`, shown at `t_s`); returns the
    /// impacts of the last ring life, for the ripples (none once running).
    fn start(
        &mut self,
        rain: &RainSetup,
        depth: &mut Option<DepthSource>,
        index: u64,
        t_s: f64,
    ) -> Result<Vec<crate::rain::volume::Impact>> {
        use crate::fluid::ripples::RING_LIFE_S;
        let PuddleFeed::Pending(plan) = self else {
            return Ok(Vec::new());
        };
        let rain = GroundRain::new(&rain.volume, &rain.model, &rain.wind, rain.params.seed);
        let Some((sim, keep)) = plan.build(&rain, depth, index, t_s)? else {
            log::warn!(
                "--puddles: the {} shows no ground within reach; no puddles",
                if depth.is_some() {
                    "depth map"
                } else {
                    "picture"
                }
            );
            *self = PuddleFeed::Off;
            return Ok(Vec::new());
        };
        let hits = rain.impacts_between(&sim.ground_rect(), (t_s - RING_LIFE_S).max(0.0), t_s);
        let camera = plan.camera;
        let far = FarRipples::new(&rain, &camera);
        log::info!(
            "puddles: {:.0} drops land per m²·s; single rings to {:.1} m, beyond them water of \
             RMS slope {:.3}",
            rain.flux_at(t_s),
            far.resolve_depth_m,
            (rain.flux_at(t_s) * far.slope_variance_per_flux).sqrt()
        );
        let run = PuddleRun {
            sim,
            rain,
            camera,
            far,
            fed_s: t_s,
            recent: Vec::new(),
            keep,
        };
        run.keep(index);
        *self = PuddleFeed::On(Box::new(run));
        Ok(hits)
    }

    /// Feeds running water the rain that landed since the last frame and runs it to `t_s`
    /// (frame `index`, kept if due); returns those impacts.
    fn advance(&mut self, index: u64, t_s: f64) -> Result<Vec<crate::rain::volume::Impact>> {
        let PuddleFeed::On(run) = self else {
            return Ok(Vec::new());
        };
        if t_s <= run.fed_s {
            return Ok(Vec::new());
        }
        let hits = run
            .rain
            .impacts_between(&run.sim.ground_rect(), run.fed_s, t_s);
        run.sim.advance_to(t_s, &hits)?;
        run.fed_s = t_s;
        run.keep(index);
        Ok(hits)
    }

    /// The water map, the rings the picture resolves (with `hits`, the frame's new impacts) and
    /// the far water's roughness at `t_s`, to the compositor.
    fn show(
        &mut self,
        compositor: &mut Compositor,
        hits: &[crate::rain::volume::Impact],
        t_s: f64,
    ) -> Result<()> {
        use crate::fluid::ripples::{keep_resolved_rings, rings_on_water};
        if let PuddleFeed::On(run) = self {
            let water = run.sim.shown_depth();
            keep_resolved_rings(&mut run.recent, hits, t_s, &run.camera);
            compositor.set_water(&water)?;
            compositor.set_ripples(&rings_on_water(&run.recent, &water))?;
            let slope_rms = (run.rain.flux_at(t_s) * run.far.slope_variance_per_flux).sqrt();
            compositor.set_far_ripples(slope_rms, run.far.resolve_depth_m)?;
        }
        Ok(())
    }
}

/// The ripples where single rings are finer than a pixel: the water's mean square slope per
/// unit impact flux ([`rain_slope_variance`](crate::fluid::ripples::rain_slope_variance) over
/// the sizes that land) and the camera depth where a ring of the mean landing size spans
/// [`MIN_RING_WAVELENGTH_PX`](crate::fluid::ripples::MIN_RING_WAVELENGTH_PX).
struct FarRipples {
    slope_variance_per_flux: f64,
    resolve_depth_m: f64,
}

impl FarRipples {
    fn new(rain: &GroundRain, camera: &Camera) -> FarRipples {
        use crate::fluid::ripples::{
            MIN_RING_WAVELENGTH_PX, WAVELENGTH_PER_DIAMETER, rain_slope_variance,
        };
        let sizes_mm = rain.impact_diameters_mm(8);
        let mean_mm = sizes_mm.iter().sum::<f64>() / sizes_mm.len() as f64;
        FarRipples {
            slope_variance_per_flux: rain_slope_variance(1.0, &sizes_mm),
            resolve_depth_m: WAVELENGTH_PER_DIAMETER * mean_mm * 1e-3 * camera.focal_px()
                / MIN_RING_WAVELENGTH_PX,
        }
    }
}

impl PuddlePlan {
    /// The water at `t_s`, with where to keep it: from the latest checkpoint at or before
    /// frame `index` if there is one, otherwise built at the clip's start; either way
    /// fast-forwarded to `t_s`. `None` where no ground is in view.
    fn build(
        &self,
        rain: &GroundRain,
        depth: &mut Option<DepthSource>,
        index: u64,
        t_s: f64,
    ) -> Result<Option<(PuddleSim, Option<Keeping>)>> {
        let started = Instant::now();
        let settings = PuddleSettings::of(&self.config);
        let fingerprint = checkpoint::fingerprint(&self.config, &self.camera, self.fps, &settings);
        let kept = self
            .checkpoints
            .as_ref()
            .and_then(|c| c.latest(&fingerprint, index));
        let keep = self.checkpoints.clone().map(|checkpoints| Keeping {
            checkpoints,
            fingerprint,
        });
        // Built either way: a checkpoint leaves out what the configuration fixes.
        let Some(fresh) = self.new_sim(depth, &settings)? else {
            return Ok(None);
        };
        let (from, mut sim) = match kept {
            Some((kept_index, sim)) => (
                format!("from the checkpoint of frame {kept_index}"),
                sim.with_fixed_parts_of(fresh),
            ),
            None => ("from the clip's start".to_string(), fresh),
        };
        if t_s > sim.time_s() {
            let never = AtomicBool::new(false);
            sim.advance_with_rain_or_stop(rain, t_s, self.cancel.unwrap_or(&never))?;
        }
        let (cap, capped) = sim.particle_cap();
        log::info!(
            "puddles: {} particles (cap {cap}{}), water brought to {t_s:.2} s {from} in {:.1} s",
            sim.ledger().particles_present,
            if capped { ", reached" } else { "" },
            started.elapsed().as_secs_f64()
        );
        Ok(Some((sim, keep)))
    }

    /// The water at the clip's start, on the relief of the clip's first depth map (if any):
    /// the ground a whole render starts from, whichever frame a chunk starts at.
    fn new_sim(
        &self,
        depth: &mut Option<DepthSource>,
        settings: &PuddleSettings,
    ) -> Result<Option<PuddleSim>> {
        let camera = &self.camera;
        let map = match depth {
            Some(d) => Some(
                d.at(0)?
                    .resampled(camera.width_px as usize, camera.height_px as usize)
                    .depth_m
                    .into_iter()
                    .map(|z| if z.is_finite() { z } else { 0.0 })
                    .collect::<Vec<f32>>(),
            ),
            None => None,
        };
        PuddleSim::new(&self.config, camera, map.as_deref(), self.fps, settings)
    }
}

/// Feeds each frame's light to the GPU: from a [`LightEstimator`] where anything shows light,
/// none where nothing would (no drops, no haze).
struct LightFeed {
    estimator: Option<LightEstimator>,
    drop_zonal: [[f32; 4]; 3],
}

impl LightFeed {
    fn new(info: &VideoInfo, render: &RenderConfig, rain: &RainSetup) -> Result<LightFeed> {
        let needed = rain.drop_count() > 0 || rain.haze_alpha > 0.0 || rain.wetting.is_some();
        let estimator = if needed {
            Some(LightEstimator::new(
                &camera_for(info, render)?,
                info.rotation_deg,
                &render.light,
            )?)
        } else {
            None
        };
        let drop_zonal = estimator
            .as_ref()
            .map_or([[0.0; 4]; 3], |l| l.drop_zonal_gpu());
        Ok(LightFeed {
            estimator,
            drop_zonal,
        })
    }

    /// How far back frames affect the light, when there is light to compute.
    fn window_secs(&self) -> Option<f64> {
        self.estimator
            .as_ref()
            .map(|l| l.window_secs())
            .filter(|&w| w > 0.0)
    }

    /// The drop's transfer table for the direct light term, once per job.
    fn upload_table(&self, compositor: &mut Compositor) {
        if let Some(l) = &self.estimator {
            compositor.set_transfer_table(l.transfer_tables());
        }
    }

    /// The GPU uniforms of `frame`, shown at `t_s`: the rain's and the compact lights'.
    fn params(&mut self, rain: &RainSetup, frame: &YuvFrame, t_s: f64) -> (RainParams, LightList) {
        let light = match &mut self.estimator {
            Some(l) => {
                if rain.keys.moves_camera()
                    && let Err(e) = l.set_camera(&rain.camera_at(t_s))
                {
                    // Unreachable for validated keys (every field of view in range).
                    log::warn!("light at {t_s:.3} s seen through the first camera: {e}");
                }
                l.update(frame, t_s)
            }
            None => FrameLight {
                env: EnvironmentSh::zeros(4),
                lights: Vec::new(),
            },
        };
        rain.frame_uniforms(t_s, &light, self.drop_zonal)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Times in different time bases compare exactly: equal instants are not earlier either
    /// way, and one tick apart is.
    #[test]
    fn packet_times_compare_exactly_across_time_bases() {
        for k in [1i64, 7, 3_600, 86_399] {
            let audio = (48_000 * k, (1, 48_000));
            let video = (12_800 * k, (1, 12_800));
            assert!(!earlier(audio, video) && !earlier(video, audio), "{k} s");
            assert!(
                earlier((48_000 * k - 1, (1, 48_000)), video),
                "{k} s less a tick"
            );
            assert!(
                earlier(video, (48_000 * k + 1, (1, 48_000))),
                "{k} s and a tick"
            );
        }
        // NTSC: frame 30 000 at 1001/30000 s is exactly 1001 s.
        assert!(!earlier(
            (30_000, (1001, 30_000)),
            (1001 * 90_000, (1, 90_000))
        ));
    }

    /// A range places a frame by index or by time, half-open, the end left open when absent.
    #[test]
    fn ranges_are_half_open() {
        use std::cmp::Ordering::*;
        let by_index = FrameRange::Indices {
            start: 10,
            end: Some(20),
        };
        let places: Vec<_> = [9, 10, 19, 20].map(|i| by_index.place(i, 0.0)).into();
        assert_eq!(places, [Less, Equal, Equal, Greater]);
        let by_time = FrameRange::Times {
            from_s: 1.0,
            to_s: None,
        };
        assert_eq!(by_time.place(0, 0.96), Less);
        assert_eq!(by_time.place(0, 1.0), Equal);
        assert_eq!(by_time.place(0, 1e6), Equal);
        for empty in [
            FrameRange::Indices {
                start: 5,
                end: Some(5),
            },
            FrameRange::Times {
                from_s: 2.0,
                to_s: Some(1.0),
            },
        ] {
            assert!(empty.validate().is_err(), "{empty}");
        }
    }
}
