//! The [`Renderer`]: rain added to a shot's frames one at a time. Every front end renders
//! through it: the render job, the preview, the benchmark, and hosts that hand over frames.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use super::depth_feed::DepthFeed;
use super::ground_mask_feed::GroundMaskFeed;
use super::light_feed::LightFeed;
use super::sky_feed::SkyFeed;
use super::water_feed::PuddleFeed;
use crate::config::RenderConfig;
use crate::fluid::puddles::checkpoint::Checkpoints;
use crate::gpu::types::RainParams;
use crate::gpu::uniforms::RainSetup;
use crate::gpu::{AdapterRequest, Compositor, GpuContext, Rendered};
use crate::shot::{Footage, Shot};
use crate::video::{Layer, YuvFrame};
use crate::{Error, Result};

/// Rain added to a shot's frames one at a time: owns the GPU context, the shot's packed rain,
/// and the feeds of light, water and depth that each frame needs.
///
/// Frames go in shown order with their time in seconds from the shot's first frame (see
/// [`crate::shot::frame_time_s`]): the rain at a frame is a pure function of that time, and the
/// light of a frame is smoothed over the frames shortly before it, so to start mid-shot, first
/// [`observe`](Self::observe) the frames of [`light_window_s`](Self::light_window_s) before it.
/// The crate's front page shows one rendering a frame of a generated picture.
pub struct Renderer {
    rain: RainSetup,
    compositor: Compositor,
    lighting: LightFeed,
    depth: DepthFeed,
    sky: SkyFeed,
    ground_mask: GroundMaskFeed,
    puddles: PuddleFeed,
    adapter: String,
}

// A host may build a renderer on one thread and render or drop it on another.
const _: fn() = || {
    fn send<T: Send>() {}
    send::<Renderer>();
};

impl Renderer {
    /// The renderer of `footage` under `config` (validated), on the adapter `adapter` asks for.
    pub fn new(
        config: &RenderConfig,
        footage: &Footage,
        adapter: &AdapterRequest,
    ) -> Result<Renderer> {
        Renderer::with_layer(config, footage, adapter, None)
    }

    /// As [`new`](Self::new), writing the rain as `layer` (with alpha, over black, or the
    /// matte; see [`Layer`]) when given: frames then come back from
    /// [`submit`](Self::submit) and [`flush`](Self::flush) as [`Rendered::Layer`]. The depth
    /// `config` names is opened here, before any frame.
    pub fn with_layer(
        config: &RenderConfig,
        footage: &Footage,
        adapter: &AdapterRequest,
        layer: Option<Layer>,
    ) -> Result<Renderer> {
        config.validate()?;
        let depth = DepthFeed::open(config, footage.frame_count)?;
        let ctx = Arc::new(GpuContext::new(adapter)?);
        let cap = crate::gpu::max_drops(&ctx);
        if config.rain.max_drops > cap {
            log::warn!(
                "rain.max_drops {} is more than this GPU holds in one frame ({cap} drops: its \
                 largest storage buffer is {} MiB); using {cap}",
                config.rain.max_drops,
                ctx.device.limits().max_storage_buffer_binding_size >> 20
            );
        }
        let shot = Shot::plan(footage, config, Some(cap))?;
        log::info!("{}", shot.rain.summary());
        let lighting = LightFeed::new(&shot)?;
        let sky = SkyFeed::new(&shot);
        let ground_mask = GroundMaskFeed::new(&shot);
        let puddles = PuddleFeed::new(&shot, layer);
        let rain = RainSetup::pack(shot.rain);
        let mut compositor = Compositor::with_backend(
            ctx.clone(),
            footage.format,
            &footage.color,
            &rain,
            layer,
            adapter.backend,
        )?;
        lighting.upload_table(&mut compositor);
        Ok(Renderer {
            rain,
            compositor,
            lighting,
            depth,
            sky,
            ground_mask,
            puddles,
            adapter: ctx.summary().name,
        })
    }

    /// Keeps the puddles' water in `checkpoints` and starts from the latest one at or before
    /// the first frame rendered (see [`crate::fluid::puddles::checkpoint`]); no effect without
    /// puddles.
    pub fn with_checkpoints(mut self, checkpoints: Checkpoints) -> Renderer {
        if let PuddleFeed::Pending(plan) = &mut self.puddles {
            plan.checkpoints = Some(checkpoints);
        }
        self
    }

    /// The frames carry pictures quantised to `bits` bits, fewer than their code values hold
    /// (an editor's 8-bit RGBA converted losslessly to 16-bit planes): the light's recovery
    /// judges clipping at that depth, as for the same picture decoded at its own depth.
    pub fn with_source_bits(mut self, bits: u8) -> Renderer {
        self.lighting.set_source_bits(bits);
        self
    }

    /// Stops the long work inside a frame (the water's fast-forward to the first frame) with
    /// [`Error::Interrupted`] once `cancel` is set: the flag the caller's frame loop polls.
    pub fn with_cancel(mut self, cancel: &'static AtomicBool) -> Renderer {
        if let PuddleFeed::Pending(plan) = &mut self.puddles {
            plan.cancel = Some(cancel);
        }
        self
    }

    /// Starts building the puddles' water for the first frame to be rendered (frame `index`,
    /// shown at `t_s`) on its own thread, beside the frames observed before it; rendering
    /// that frame takes it (the same water as built there). No effect without puddles or
    /// once the water runs. Call after [`with_checkpoints`](Self::with_checkpoints) and
    /// [`with_cancel`](Self::with_cancel).
    pub fn begin_water(&mut self, index: u64, t_s: f64) -> Result<()> {
        self.puddles
            .begin(&self.rain, &mut self.depth.source, index, t_s)
    }

    /// The uniforms, lights, depth and water of the frame shown at `t_s`, set on the
    /// compositor.
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
        self.depth.feed(&mut self.compositor, frame.index)?;
        let cut = self.lighting.last_was_cut();
        self.sky
            .feed(&mut self.compositor, frame, &params, t_s, cut)?;
        self.ground_mask
            .feed(&mut self.compositor, frame, &params, t_s, cut)?;
        hits.extend(
            self.puddles
                .start(&self.rain, &mut self.depth.source, frame.index, t_s)?,
        );
        self.puddles.show(&mut self.compositor, &hits, t_s)?;
        Ok(params)
    }

    /// How far back, seconds, earlier frames change the light and the sky of a frame (0 without
    /// light).
    pub fn light_window_s(&self) -> f64 {
        self.lighting
            .window_secs()
            .unwrap_or(0.0)
            .max(self.sky.window_s())
            .max(self.ground_mask.window_s())
    }

    /// Takes the light and the sky of a frame shown at `t_s` into account without rendering
    /// it.
    pub fn observe(&mut self, frame: &YuvFrame, t_s: f64) {
        let (params, _) = self.lighting.params(&self.rain, frame, t_s);
        let cut = self.lighting.last_was_cut();
        self.sky.observe(frame, &params, t_s, cut);
        self.ground_mask.observe(frame, &params, t_s, cut);
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

    /// Where the colour passes run (see [`crate::gpu::Backend`]).
    pub fn backend(&self) -> crate::gpu::Backend {
        self.compositor.backend()
    }
}
