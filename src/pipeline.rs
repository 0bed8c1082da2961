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
use crate::gpu::types::{LightList, RainParams};
use crate::gpu::uniforms::{self as emitter, RainSetup};
use crate::gpu::{AdapterRequest, Compositor, GpuContext, Rendered};
use crate::lighting::{EnvironmentSh, FrameLight, LightEstimator};
use crate::scene::Camera;
use crate::video::{EncodeOptions, Sink, Source, SourceItem, VideoInfo, YuvFrame};
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

/// The streak database shipped with the program.
pub const DEFAULT_STREAK_DB: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/drops");

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
    let setup = emitter::build(
        &camera_for(info, config)?,
        &config.camera,
        &rain,
        exposure,
        info.rotation_deg,
        (info.format.width, info.format.height),
    )?;
    let mattes = match config.rain.streaks {
        crate::config::StreakStyle::Simple => None,
        crate::config::StreakStyle::Mattes => {
            let dir = config.streak_db.as_deref().unwrap_or(DEFAULT_STREAK_DB);
            let atlas = crate::drops::MatteAtlas::load(std::path::Path::new(dir), exposure)?;
            Some(std::sync::Arc::new(atlas))
        }
    };
    Ok(setup
        .with_ground(config.ground.is_given())
        .with_wetting(config.ground.wetting(config.rain.rate_mm_per_h))
        .with_mattes(mattes))
}

/// Seconds since the start of the stream at `frame`.
pub fn frame_time_s(info: &VideoInfo, frame: &YuvFrame) -> f64 {
    (frame.pts - info.start_pts) as f64 * info.time_base.0 as f64 / info.time_base.1 as f64
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
}

enum ToEncode {
    Frame(Rendered),
    Packet(crate::video::CopiedPacket),
    /// Everything was sent: flush and publish the output. A channel that closes without it
    /// means the job failed, and the unfinished Sink removes its temporary file.
    Finish,
}

/// Runs `job`. `progress` is called after every written frame; `cancel` stops the job cleanly
/// (the partial output is removed).
pub fn render(
    job: &Job,
    cancel: &AtomicBool,
    progress: &mut dyn FnMut(Progress),
) -> Result<Summary> {
    job.render.validate()?;
    job.encode.validate()?;
    crate::video::check_output(&job.output, &[&job.input], job.encode.overwrite)?;
    let started = Instant::now();
    let source = Source::open(&job.input)?;
    let info = source.info().clone();
    let sink = Sink::create(&job.output, &info, &job.encode)?;
    let ctx = Arc::new(GpuContext::new(&job.adapter)?);
    let rain = rain_for(&info, &job.render, &ctx)?;
    log::info!("{}", rain.summary());
    let mut compositor = Compositor::with_layer(
        ctx.clone(),
        info.format,
        &info.color,
        &rain,
        job.encode.layer,
    )?;
    let mut lighting = LightFeed::new(&info, &job.render, &rain)?;
    lighting.upload_table(&mut compositor);

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
                let item = source.next_item();
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
    let gpu_result = (|| -> Result<()> {
        let mut send = |f: Rendered, written: &mut u64| -> Result<()> {
            out_tx
                .send(ToEncode::Frame(f))
                .map_err(|_| Error::EncoderStopped)?;
            *written += 1;
            progress(Progress {
                frames_done: *written,
                frames_total: info.frame_count,
                elapsed_s: started.elapsed().as_secs_f64(),
            });
            Ok(())
        };
        for item in &in_rx {
            if cancel.load(Ordering::Relaxed) {
                return Err(Error::Interrupted);
            }
            match item? {
                SourceItem::Frame(frame) => {
                    let t = Instant::now();
                    let (params, lights) =
                        lighting.params(&rain, &frame, frame_time_s(&info, &frame));
                    compositor.set_lights(&lights);
                    let done = compositor.submit_rendered(&frame, &params)?;
                    stages.submit_s += t.elapsed().as_secs_f64();
                    if let Some(done) = done {
                        send(done, &mut written)?;
                    }
                }
                SourceItem::Packet(p) => {
                    if out_tx.send(ToEncode::Packet(p)).is_err() {
                        break;
                    }
                }
            }
        }
        let t = Instant::now();
        let rest = compositor.flush_rendered()?;
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
    stages.gpu = compositor.gpu_times();
    stages.decode_s = decode_time.as_secs_f64();
    stages.encode_s = encode_time.as_secs_f64();
    Ok(Summary {
        frames,
        elapsed_s: started.elapsed().as_secs_f64(),
        stages,
        drops: compositor.drop_count(),
        adapter: ctx.summary().name,
    })
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
///
/// The light of a frame depends on the frames shortly before it (temporal smoothing), so
/// those are decoded and fed first, exactly as the full render sees them.
pub fn preview(
    input: &str,
    at: FrameSelector,
    render: &RenderConfig,
    adapter: &AdapterRequest,
    cancel: &AtomicBool,
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
    let target = match at {
        FrameSelector::At(t) => source.seek_to_time(t)?,
        FrameSelector::Index(n) => source.frame_at_index(n)?,
    };
    let ctx = Arc::new(GpuContext::new(adapter)?);
    let rain = rain_for(&info, render, &ctx)?;
    log::info!("{}", rain.summary());
    let mut lighting = LightFeed::new(&info, render, &rain)?;
    let t_target = frame_time_s(&info, &target);
    if let Some(window) = lighting.window_secs() {
        let from = (t_target - window).max(0.0);
        let mut frame = source.seek_to_time(from)?;
        while frame.pts < target.pts {
            check()?;
            let t = frame_time_s(&info, &frame);
            if t > t_target - window {
                lighting.params(&rain, &frame, t);
            }
            frame = source
                .next_frame()?
                .ok_or_else(|| Error::OutOfRange("the clip ended before the frame".into()))?;
        }
    }
    check()?;
    let (params, lights) = lighting.params(&rain, &target, t_target);
    let mut compositor = Compositor::new(ctx, info.format, &info.color, &rain)?;
    lighting.upload_table(&mut compositor);
    compositor.set_lights(&lights);
    let out = compositor.render_one(&target, &params)?;
    check()?;
    Ok((out, info))
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
            Some(l) => l.update(frame, t_s),
            None => FrameLight {
                env: EnvironmentSh::zeros(4),
                lights: Vec::new(),
            },
        };
        rain.frame_uniforms(t_s, &light, self.drop_zonal)
    }
}
