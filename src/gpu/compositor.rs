//! One frame's GPU journey: upload planes → the stages in order (`yuv_to_rgb` with the haze,
//! `wet_ground` where a given ground is wet, `puddles` once water is set, `rain_simulate` once
//! per drop, `rain_splashes` with a ground, `rain_streaks`, `rgb_to_yuv` luma then chroma;
//! each an object in [`super::stages`]) → copy into a readback ring. The compositor owns the shared buffers, the
//! order and the ring; each stage's timestamp slot is its place in the order.
//!
//! ## How it works
//! The canvas is linear RGB in `Rgba16Float`, in the coded orientation of the video (display
//! rotation is applied to the streaks' vertices, not to the pixels, so a frame without rain
//! comes back bit for bit). For the rain as a layer ([`Layer`]) the canvas starts transparent
//! (the haze alone) instead of the frame, the same stages draw over it, and `rgba_out` packs
//! R'G'B'A in place of `rgb_to_yuv` (codes, or for a scene-linear layer the canvas's half
//! floats; the layer over black keeps `rgb_to_yuv`). `submit` records one frame and returns the frame
//! submitted `RING - 1` calls earlier once the ring is full: the CPU never waits on the frame
//! it just submitted, so upload, GPU work and readback of consecutive frames overlap. `flush`
//! drains the ring at the end.
//!
//! On the CPU back end ([`Backend::Cpu`], the picture path only: a layer stays on the GPU) every
//! per-pixel pass runs on the CPU ([`super::host`]), and the drops and the splashes are
//! simulated there too: no frame touches the adapter, nothing is allocated on it (no planes,
//! canvas, readback ring or masks: `GpuFrames` is the GPU's alone), none of the rain's or the
//! ground's GPU pipelines is built, and the frame is done when `submit` returns
//! (`compositor/host.rs`).

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::mpsc;

use wgpu::util::DeviceExt;

use super::GpuContext;
use super::context::Backend;
use super::host::HostColour;
use super::host::rain::HostRain;
use super::host::splashes::HostSplashes;
use super::lights::DirectLightBuffers;
use super::stages::{
    FrameResources, FrameStage, TimestampSlot, puddles::Puddles, rain_simulate::RainSimulate,
    rain_splashes::RainSplashes, rain_streaks::RainStreaks, rgb_to_yuv::RgbToYuv,
    rgba_out::RgbaOut, wet_ground::WetGround, yuv_to_rgb::YuvToRgb,
};
use super::types::{FrameParams, LightList, RainParams, Streak};
use super::uniforms::RainSetup;
use crate::video::{FrameFormat, Layer, LayerFrame, LayerSamples, Plane, YuvFrame};
use crate::{Error, Result};

mod host;
mod masks;

/// Frames in flight (readback slots).
const RING: usize = 3;

/// GPU time per stage, summed over the frames read back so far (zero where the adapter has no
/// timestamp queries).
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct GpuStageTimes {
    /// YUV planes → linear canvas.
    pub yuv_to_rgb_s: f64,
    /// Streak rasterisation (the drops were evaluated once each by `rain_simulate`).
    pub rain_streaks_s: f64,
    /// Drop states, projection and light, once per drop.
    pub rain_simulate_s: f64,
    /// Splashes of the landing drops (with a ground): their streaks and their draw.
    pub rain_splashes_s: f64,
    /// Canvas → packed YUV planes.
    pub rgb_to_yuv_s: f64,
    /// Canvas → packed R'G'B'A (the rain as a layer).
    pub rgba_out_s: f64,
    /// The wet ground (zero without one; on the CPU back end it is fused into the plate's
    /// decode and counted in `yuv_to_rgb_s`).
    pub wet_ground_s: f64,
    /// The puddles (zero without water; on the CPU back end the CPU's time).
    pub puddles_s: f64,
    /// Streaks drawn, summed over the frames (counted where the CPU draws them).
    pub streaks_drawn: u64,
    /// Splash streaks drawn, summed over the frames (counted where the CPU draws them).
    pub splashes_drawn: u64,
    /// The CPU back end's canvas tiles decoded and encoded, summed over the frames (the rest
    /// of [`tiles`](Self::tiles) passed through, their codes copied).
    pub tiles_converted: u64,
    /// The CPU back end's canvas tiles, summed over the frames.
    pub tiles: u64,
}

impl GpuStageTimes {
    /// Adds `seconds` to stage `name` (stages without a field of their own are not reported).
    fn add(&mut self, name: &str, seconds: f64) {
        let field = match name {
            "yuv_to_rgb" => &mut self.yuv_to_rgb_s,
            "rain_simulate" => &mut self.rain_simulate_s,
            "rain_splashes" => &mut self.rain_splashes_s,
            "rain_streaks" | "streak_tiles" => &mut self.rain_streaks_s,
            "rgb_to_yuv" => &mut self.rgb_to_yuv_s,
            "rgba_out" => &mut self.rgba_out_s,
            "wet_ground" => &mut self.wet_ground_s,
            "puddles" => &mut self.puddles_s,
            _ => return,
        };
        *field += seconds;
    }
}

struct InFlight {
    slot: usize,
    submission: wgpu::SubmissionIndex,
    mapped: mpsc::Receiver<std::result::Result<(), wgpu::BufferAsyncError>>,
    template: YuvFrame,
}

/// The buffers and textures frames drawn on the adapter use, made once.
struct GpuFrames {
    planes: [wgpu::Texture; 3],
    rain_buffer: wgpu::Buffer,
    direct_lights: DirectLightBuffers,
    /// The scene's depth per displayed pixel (see `set_scene_depth`).
    scene_depth: wgpu::Buffer,
    /// The open sky's weight at the glow's grid points (see `set_sky_mask`).
    sky_mask: wgpu::Buffer,
    /// The ground's weight at the glow's grid points (see `set_ground_mask`).
    ground_mask: wgpu::Buffer,
    out_buffer: wgpu::Buffer,
    out_bytes: u64,
    /// The readback ring.
    staging: Vec<wgpu::Buffer>,
    timestamps: Option<(wgpu::QuerySet, wgpu::Buffer)>,
}

/// Kept here, where the compositor produces it; the type lives in [`crate::video`].
pub use crate::video::Rendered;

/// Renders rain onto frames of one fixed format.
pub struct Compositor {
    ctx: Arc<GpuContext>,
    format: FrameFormat,
    /// What the samples of the frames are, where they come back as R'G'B'A layers.
    rgba: Option<LayerSamples>,
    frame_params: FrameParams,
    /// The adapter's side of the frames; `None` on the CPU back end, which allocates nothing
    /// on the adapter.
    gpu: Option<GpuFrames>,
    rain_drops: u32,
    /// Whether the rain was built for a depth map (see `set_scene_depth`).
    has_scene_depth: bool,
    display_size: (u32, u32),
    /// The frame's stages in order; a stage's index is its timestamp slot. On the CPU back end
    /// only the ground's, without pipelines: they hold the ground's and the water's state.
    stages: Vec<Box<dyn FrameStage>>,
    in_flight: VecDeque<InFlight>,
    next_slot: usize,
    gpu_times: GpuStageTimes,
    /// Every per-pixel pass on the CPU (the CPU back end, [`Compositor::render_on_host`]).
    host: Option<HostColour>,
    /// The drops simulated and drawn on the CPU (the CPU back end).
    host_rain: Option<HostRain>,
    /// The splashes simulated on the CPU (the CPU back end, with a ground drops land on).
    host_splashes: Option<HostSplashes>,
    /// Frames done, oldest first, older than any in flight.
    ready: VecDeque<Rendered>,
}

/// The most drops one frame can hold on `ctx`'s device: the streak buffer must fit one storage
/// binding (and one buffer), and the simulation's dispatch one grid dimension.
pub fn max_drops(ctx: &GpuContext) -> u32 {
    let limits = ctx.device.limits();
    let bytes = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let by_memory = bytes / std::mem::size_of::<Streak>() as u64;
    let by_dispatch = u64::from(limits.max_compute_workgroups_per_dimension)
        * u64::from(super::stages::rain_simulate::WORKGROUP);
    by_memory.min(by_dispatch).min(u64::from(u32::MAX)) as u32
}

impl Compositor {
    /// Builds the pipelines and buffers for frames of `format` and rain `rain`.
    pub fn new(
        ctx: Arc<GpuContext>,
        format: FrameFormat,
        color: &crate::video::ColorParams,
        rain: &RainSetup,
    ) -> Result<Compositor> {
        Compositor::with_layer(ctx, format, color, rain, None)
    }

    /// As [`Compositor::new`], writing the rain as `layer` when given.
    pub fn with_layer(
        ctx: Arc<GpuContext>,
        format: FrameFormat,
        color: &crate::video::ColorParams,
        rain: &RainSetup,
        layer: Option<Layer>,
    ) -> Result<Compositor> {
        Compositor::with_backend(ctx, format, color, rain, layer, Backend::Gpu)
    }

    /// As [`Compositor::with_layer`], the colour passes on `backend` (resolved for the
    /// adapter; a layer's stay on the GPU).
    pub fn with_backend(
        ctx: Arc<GpuContext>,
        format: FrameFormat,
        color: &crate::video::ColorParams,
        rain: &RainSetup,
        layer: Option<Layer>,
        backend: Backend,
    ) -> Result<Compositor> {
        // A layer is drawn on the GPU alone.
        let backend = if layer.is_some() {
            Backend::Gpu
        } else {
            backend
        };
        let on_cpu = ctx.backend(backend)? == Backend::Cpu;
        let rgba = layer.filter(|l| l.is_rgba()).map(Layer::samples);
        let max = ctx.max_texture_side();
        if format.width > max || format.height > max {
            return Err(Error::Unsupported(format!(
                "{}×{} exceeds this GPU's largest texture ({max} px)",
                format.width, format.height
            )));
        }
        let frame_params = FrameParams::new(&format, color);
        // The frame, in order. A layer carries the wet ground as colour and alpha over the
        // frame it was made from; the matte is the rain's coverage alone.
        let wetting = rain
            .wetting
            .as_ref()
            .filter(|_| layer != Some(Layer::Matte));
        let (gpu, stages) = if on_cpu {
            let ground = ground_stages(&ctx.device, None, layer, wetting);
            (None, ground.into_iter().collect())
        } else {
            let (gpu, stages) =
                Compositor::gpu_frames(&ctx, &format, frame_params, rain, layer, wetting)?;
            (Some(gpu), stages)
        };
        let host_rain = on_cpu.then(|| HostRain::new(&rain.columns, rain.mattes.clone()));
        let host_splashes = on_cpu.then(|| HostSplashes::new(rain)).flatten();
        Ok(Compositor {
            ctx,
            format,
            rgba,
            frame_params,
            gpu,
            rain_drops: rain.params.drop_count,
            has_scene_depth: rain.scene_depth,
            display_size: (
                rain.params.display_size_px[0] as u32,
                rain.params.display_size_px[1] as u32,
            ),
            stages,
            in_flight: VecDeque::with_capacity(RING),
            next_slot: 0,
            gpu_times: GpuStageTimes::default(),
            host: on_cpu.then(|| HostColour::new(format, color)),
            host_rain,
            host_splashes,
            ready: VecDeque::with_capacity(RING),
        })
    }

    /// The buffers and textures of frames of `format` (laid out as `frame_params`) drawn on
    /// `ctx`'s adapter, and the frame's stages bound to them (see [`frame_stages`]).
    fn gpu_frames(
        ctx: &GpuContext,
        format: &FrameFormat,
        frame_params: FrameParams,
        rain: &RainSetup,
        layer: Option<Layer>,
        wetting: Option<&crate::lighting::wetness::Wetting>,
    ) -> Result<(GpuFrames, Vec<Box<dyn FrameStage>>)> {
        let device = &ctx.device;
        let frame_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("frame_params"),
            contents: bytemuck::bytes_of(&frame_params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let planes = plane_textures(device, format);
        let canvas = canvas_texture(device, format);
        let out_words = if layer.is_some_and(Layer::is_rgba) {
            u64::from(format.width)
                * u64::from(format.height)
                * u64::from(super::stages::rgba_out::WORDS_PER_PIXEL)
        } else {
            frame_params.total_words() as u64
        };
        let out_bytes = out_words * 4;
        let out_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("packed_planes"),
            size: out_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let rain_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rain_params"),
            contents: bytemuck::bytes_of(&rain.params),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let direct_lights = DirectLightBuffers::new(device);
        direct_lights.upload_lights(&ctx.queue, &LightList::new(&[]));
        let (dw, dh) = (
            rain.params.display_size_px[0] as u32,
            rain.params.display_size_px[1] as u32,
        );
        let depth_len = if rain.scene_depth {
            dw as u64 * dh as u64
        } else {
            1
        };
        // Zeros: unknown depth, nothing hidden until a map is set.
        let scene_depth = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("scene_depth"),
            size: 4 * depth_len.max(1),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // Zeros: no sky until a mask is set.
        let (gw, gh) = super::stages::yuv_to_rgb::glow_grid_size((format.width, format.height));
        let sky_mask = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sky_mask"),
            size: 4 * u64::from(gw) * u64::from(gh),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let glow_grid = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("glow_grid"),
                size: wgpu::Extent3d {
                    width: gw,
                    height: gh,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba32Float,
                usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
            .create_view(&Default::default());
        // Ones: everything below the horizon is ground until a mask is set.
        let ground_mask = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("ground_mask"),
            contents: bytemuck::cast_slice(&vec![1.0f32; gw as usize * gh as usize]),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        let gpu_drops = rain.params.drop_count.max(1) as u64;
        let resources = FrameResources {
            frame_params: frame_buffer,
            frame: frame_params,
            planes: std::array::from_fn(|i| planes[i].create_view(&Default::default())),
            canvas: canvas.create_view(&Default::default()),
            rain_params: rain_buffer.clone(),
            columns: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("rain_columns"),
                contents: bytemuck::cast_slice(&rain.columns),
                usage: wgpu::BufferUsages::STORAGE,
            }),
            streaks: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("rain_streaks"),
                size: std::mem::size_of::<Streak>() as u64 * gpu_drops,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            glints: rain
                .mattes
                .as_ref()
                .filter(|m| !m.lights.is_empty())
                .map(|_| {
                    device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("glints"),
                        size: std::mem::size_of::<super::types::Glint>() as u64
                            * super::types::GLINTS_PER_DROP as u64
                            * gpu_drops,
                        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                        mapped_at_creation: false,
                    })
                }),
            matte_atlas: rain
                .mattes
                .as_deref()
                .map(|m| super::stages::rain_streaks::matte_texture(device, &ctx.queue, m))
                .transpose()?,
            drop_count: rain.params.drop_count,
            lights: direct_lights.clone(),
            out_words: out_buffer.clone(),
            scene_depth: scene_depth.clone(),
            glow_grid,
            sky_mask: sky_mask.clone(),
            ground_mask: ground_mask.clone(),
        };
        let stages = frame_stages(device, &resources, rain, layer, wetting);
        let timed = stages.len() as u64;
        let gpu = GpuFrames {
            planes,
            rain_buffer,
            direct_lights,
            scene_depth,
            sky_mask,
            ground_mask,
            out_buffer,
            out_bytes,
            staging: (0..RING)
                .map(|_| readback_buffer(device, out_bytes + 16 * timed))
                .collect(),
            timestamps: timestamp_queries(device, timed),
        };
        Ok((gpu, stages))
    }

    /// Where the colour passes run: [`Backend::Gpu`] or [`Backend::Cpu`].
    pub fn backend(&self) -> Backend {
        if self.host.is_some() {
            Backend::Cpu
        } else {
            Backend::Gpu
        }
    }

    /// GPU time per stage over the frames read back so far (on the CPU back end, the colour
    /// passes' CPU time in their place).
    pub fn gpu_times(&self) -> GpuStageTimes {
        self.gpu_times
    }

    /// Drops drawn per frame.
    pub fn drop_count(&self) -> u32 {
        self.rain_drops
    }

    /// Sets the drop's transfer table (R, G, B) the direct light term reads; once per job
    /// (see `LightEstimator::transfer_tables`). Until then the lights add nothing.
    pub fn set_transfer_table(&mut self, tables: &[crate::lighting::RtfTable; 3]) {
        if let Some(gpu) = &self.gpu {
            gpu.direct_lights.upload_table(&self.ctx.queue, tables);
        }
        if let Some(host) = &mut self.host {
            host.set_transfer_table(tables);
        }
        if let Some(drops) = &mut self.host_rain {
            drops.set_transfer_table(tables);
        }
        if let Some(splashes) = &mut self.host_splashes {
            splashes.set_transfer_table(tables);
        }
    }

    /// Sets the compact lights of the frames submitted from now on (see `LightList::new`).
    pub fn set_lights(&mut self, lights: &LightList) {
        if let Some(gpu) = &self.gpu {
            gpu.direct_lights.upload_lights(&self.ctx.queue, lights);
        }
        if let Some(host) = &mut self.host {
            host.set_lights(lights);
        }
        if let Some(drops) = &mut self.host_rain {
            drops.set_lights(lights);
        }
        if let Some(splashes) = &mut self.host_splashes {
            splashes.set_lights(lights);
        }
    }

    /// Sets the scene's depth for the frames submitted from now on: drops behind it are hidden.
    /// `depth` is resampled to the displayed picture where its size differs; its holes hide
    /// nothing. Needs a rain built `with_scene_depth(true)`.
    pub fn set_scene_depth(&mut self, depth: &crate::scene::DepthMap) -> Result<()> {
        let (w, h) = self.display_size;
        if !self.has_scene_depth {
            return Err(Error::Gpu(
                "a depth map for a rain built without one (RainSetup::with_scene_depth)".into(),
            ));
        }
        let map = depth.resampled(w as usize, h as usize);
        let metres: Vec<f32> = map
            .depth_m
            .iter()
            .map(|&d| if d.is_finite() && d > 0.0 { d } else { 0.0 })
            .collect();
        if let Some(gpu) = &self.gpu {
            self.ctx
                .queue
                .write_buffer(&gpu.scene_depth, 0, bytemuck::cast_slice(&metres));
        }
        if let Some(host) = &mut self.host {
            host.set_scene_depth(metres);
        }
        Ok(())
    }

    /// The puddles stage.
    fn puddles(&mut self) -> Result<&mut Puddles> {
        self.stages
            .iter_mut()
            .find_map(|s| (s.as_mut() as &mut dyn std::any::Any).downcast_mut::<Puddles>())
            .ok_or_else(|| Error::Gpu("no puddles stage".into()))
    }

    /// Sets the water depth on the ground (m per cell, world x, y on z = 0; see
    /// `fluid::Carpet::water_depth`) for the frames submitted from now on: from the first call
    /// the puddles stage is in the frame. Without it, frames are as without puddles, bit for bit.
    pub fn set_water(&mut self, depth: &crate::fluid::Field2) -> Result<()> {
        let queue = self.ctx.queue.clone();
        self.puddles()?.set_water(&queue, depth)
    }

    /// Sets the drops that landed on water (`rain::volume::impacts`) whose ripple rings the
    /// frames submitted from now on show: those alive at each frame's time, the newest
    /// `fluid::ripples::MAX_RINGS`.
    pub fn set_ripples(&mut self, impacts: &[crate::rain::volume::impacts::Impact]) -> Result<()> {
        self.puddles()?.set_ripples(impacts);
        Ok(())
    }

    /// Sets the RMS slope of the water rained on beyond camera depth `resolve_depth_m`, where
    /// single rings are finer than a pixel (`fluid::ripples::rain_slope_variance`), for the
    /// frames submitted from now on.
    pub fn set_far_ripples(&mut self, slope_rms: f64, resolve_depth_m: f64) -> Result<()> {
        self.puddles()?.set_far_ripples(slope_rms, resolve_depth_m);
        Ok(())
    }

    /// Records and submits `frame` with the rain of `rain` (see `RainSetup::params_at`).
    /// Returns the oldest finished frame once `RING` frames are in flight.
    pub fn submit(&mut self, frame: &YuvFrame, rain: &RainParams) -> Result<Option<YuvFrame>> {
        self.submit_rendered(frame, rain)?
            .map(Rendered::into_picture)
            .transpose()
    }

    /// As [`Compositor::submit`], for any output (a layer compositor's frames are layers).
    pub fn submit_rendered(
        &mut self,
        frame: &YuvFrame,
        rain: &RainParams,
    ) -> Result<Option<Rendered>> {
        if frame.format != self.format {
            return Err(Error::Unsupported(format!(
                "the picture format changed mid-stream ({:?} → {:?})",
                self.format, frame.format
            )));
        }
        for (i, plane) in frame.planes.iter().enumerate() {
            let (_, h) = self.format.plane_size(i);
            let needed = plane.stride * (h as usize - 1) + self.format.packed_stride(i);
            if plane.data.len() < needed || plane.stride < self.format.packed_stride(i) {
                return Err(Error::CorruptInput(format!(
                    "frame {}: plane {i} is too short",
                    frame.index
                )));
            }
        }
        if self.drawn_on_host() {
            while !self.in_flight.is_empty() {
                let f = self.receive()?;
                self.ready.push_back(f);
            }
            let f = self.render_on_host(frame, rain)?;
            self.ready.push_back(f);
            return Ok(self.ready.pop_front());
        }
        if self.in_flight.len() == RING {
            let f = self.receive()?;
            self.ready.push_back(f);
        }
        let Some(gpu) = &self.gpu else {
            return Err(Error::Gpu("no adapter frames on the CPU back end".into()));
        };
        let done = self.ready.pop_front();
        let queue = &self.ctx.queue;
        for (i, plane) in frame.planes.iter().enumerate() {
            let (w, h) = self.format.plane_size(i);
            queue.write_texture(
                gpu.planes[i].as_image_copy(),
                &plane.data,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(plane.stride as u32),
                    rows_per_image: Some(h),
                },
                wgpu::Extent3d {
                    width: w,
                    height: h,
                    depth_or_array_layers: 1,
                },
            );
        }
        queue.write_buffer(&gpu.rain_buffer, 0, bytemuck::bytes_of(rain));
        let device = &self.ctx.device;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame"),
        });
        for (slot, stage) in self.stages.iter().enumerate() {
            if stage.runs() {
                stage.prepare(queue, rain);
                let timestamps = gpu.timestamps.as_ref().map(|(set, _)| TimestampSlot {
                    set,
                    slot: slot as u32,
                });
                stage.record(&mut encoder, timestamps);
            }
        }
        let slot = self.next_slot;
        self.next_slot = (self.next_slot + 1) % RING;
        encoder.copy_buffer_to_buffer(&gpu.out_buffer, 0, &gpu.staging[slot], 0, gpu.out_bytes);
        if let Some((set, resolve)) = &gpu.timestamps {
            encoder.resolve_query_set(set, 0..2 * self.stages.len() as u32, resolve, 0);
            encoder.copy_buffer_to_buffer(
                resolve,
                0,
                &gpu.staging[slot],
                gpu.out_bytes,
                resolve.size(),
            );
        }
        let (tx, rx) = mpsc::channel();
        encoder.map_buffer_on_submit(&gpu.staging[slot], wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        let submission = queue.submit([encoder.finish()]);
        let template = YuvFrame {
            format: frame.format,
            color: frame.color,
            planes: Default::default(),
            pts: frame.pts,
            index: frame.index,
        };
        self.in_flight.push_back(InFlight {
            slot,
            submission,
            mapped: rx,
            template,
        });
        Ok(done)
    }

    /// Waits for the oldest frame in flight and reads it back.
    fn receive(&mut self) -> Result<Rendered> {
        let (Some(f), Some(gpu)) = (self.in_flight.pop_front(), &self.gpu) else {
            return Err(Error::Gpu("no frame in flight".into()));
        };
        self.ctx
            .device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(f.submission),
                timeout: None,
            })
            .map_err(|e| Error::Gpu(format!("waiting for frame {}: {e}", f.template.index)))?;
        f.mapped
            .recv()
            .map_err(|_| Error::Gpu("readback callback dropped".into()))?
            .map_err(|e| Error::Gpu(format!("readback of frame {}: {e}", f.template.index)))?;
        let buffer = &gpu.staging[f.slot];
        let mut out = f.template;
        let mut layer = None;
        {
            let view = buffer
                .get_mapped_range(..)
                .map_err(|e| Error::Gpu(format!("readback: {e}")))?;
            let fp = &self.frame_params;
            if let Some(samples) = self.rgba {
                layer = Some(LayerFrame {
                    width: fp.width,
                    height: fp.height,
                    rgba: bytemuck::pod_collect_to_vec(&view[..gpu.out_bytes as usize]),
                    pts: out.pts,
                    index: out.index,
                    samples,
                });
            }
            let y_len = (fp.y_row_words * fp.height) as usize * 4;
            let c_len = (fp.c_row_words * fp.chroma_height) as usize * 4;
            let bounds = [
                (0, y_len),
                (y_len, y_len + c_len),
                (y_len + c_len, y_len + 2 * c_len),
            ];
            let strides = [
                fp.y_row_words as usize * 4,
                fp.c_row_words as usize * 4,
                fp.c_row_words as usize * 4,
            ];
            for i in (0..3).filter(|_| self.rgba.is_none()) {
                out.planes[i] = Plane {
                    data: view[bounds[i].0..bounds[i].1].to_vec(),
                    stride: strides[i],
                };
            }
            if gpu.timestamps.is_some() {
                let at = gpu.out_bytes as usize;
                let ticks: Vec<u64> = view[at..at + 16 * self.stages.len()]
                    .chunks_exact(8)
                    .map(|b| u64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
                    .collect();
                let period_s = self.ctx.queue.get_timestamp_period() as f64 * 1e-9;
                let span =
                    |k: usize| ticks[2 * k + 1].saturating_sub(ticks[2 * k]) as f64 * period_s;
                for (slot, stage) in self.stages.iter().enumerate() {
                    if stage.runs() {
                        self.gpu_times.add(stage.name(), span(slot));
                    }
                }
            }
        }
        buffer.unmap();
        Ok(match layer {
            Some(l) => Rendered::Layer(l),
            None => Rendered::Picture(out),
        })
    }

    /// Reads back every frame still in flight, oldest first.
    pub fn flush(&mut self) -> Result<Vec<YuvFrame>> {
        self.flush_rendered()?
            .into_iter()
            .map(Rendered::into_picture)
            .collect()
    }

    /// As [`Compositor::flush`], for any output.
    pub fn flush_rendered(&mut self) -> Result<Vec<Rendered>> {
        while !self.in_flight.is_empty() {
            let f = self.receive()?;
            self.ready.push_back(f);
        }
        Ok(self.ready.drain(..).collect())
    }

    /// Renders one frame and waits for it (preview).
    pub fn render_one(&mut self, frame: &YuvFrame, rain: &RainParams) -> Result<YuvFrame> {
        self.render_one_rendered(frame, rain)?.into_picture()
    }

    /// As [`Compositor::render_one`], for any output.
    pub fn render_one_rendered(&mut self, frame: &YuvFrame, rain: &RainParams) -> Result<Rendered> {
        let mut out = self.flush_rendered()?;
        if let Some(f) = self.submit_rendered(frame, rain)? {
            out.push(f);
        }
        out.extend(self.flush_rendered()?);
        out.pop()
            .ok_or_else(|| Error::Gpu("no frame came back".into()))
    }
}

/// The three planes of a frame of `format`, as integer textures the first stage reads.
fn plane_textures(device: &wgpu::Device, format: &FrameFormat) -> [wgpu::Texture; 3] {
    let plane_format = if format.bytes_per_sample() == 1 {
        wgpu::TextureFormat::R8Uint
    } else {
        wgpu::TextureFormat::R16Uint
    };
    std::array::from_fn(|i| {
        let (w, h) = format.plane_size(i);
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(["plane_y", "plane_cb", "plane_cr"][i]),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: plane_format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        })
    })
}

/// The canvas: linear RGB of the frame that every stage between the first and the last reads
/// and writes.
fn canvas_texture(device: &wgpu::Device, format: &FrameFormat) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("canvas"),
        size: wgpu::Extent3d {
            width: format.width,
            height: format.height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: super::stages::rain_streaks::CANVAS_FORMAT,
        usage: wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

/// The ground's stages, the wet ground and the puddles, bound to `resources`; without them (the
/// CPU back end) they build nothing on the adapter and only hold the ground's and the water's
/// state the CPU reads each frame.
fn ground_stages(
    device: &wgpu::Device,
    resources: Option<&FrameResources>,
    layer: Option<Layer>,
    wetting: Option<&crate::lighting::wetness::Wetting>,
) -> [Box<dyn FrameStage>; 2] {
    [
        Box::new(WetGround::new(device, resources, wetting, layer.is_some())),
        Box::new(Puddles::new(device, resources, layer.is_none())),
    ]
}

/// The frame's stages on the adapter, in order: colour in (the frame, or a layer's transparent
/// start), the wet ground, the puddles, the rain (simulate, splashes, streaks), colour out.
fn frame_stages(
    device: &wgpu::Device,
    resources: &FrameResources,
    rain: &RainSetup,
    layer: Option<Layer>,
    wetting: Option<&crate::lighting::wetness::Wetting>,
) -> Vec<Box<dyn FrameStage>> {
    let ground = ground_stages(device, Some(resources), layer, wetting);
    let between = ground.into_iter().chain([
        Box::new(RainSimulate::new(device, resources)) as Box<dyn FrameStage>,
        Box::new(RainSplashes::new(device, resources, rain)),
        streaks_stage(device, resources, rain),
    ]);
    let rgba = layer.is_some_and(Layer::is_rgba);
    let start = match layer {
        None => YuvToRgb::new(device, resources),
        Some(_) => YuvToRgb::layer(device, resources),
    };
    let out: Box<dyn FrameStage> = match layer {
        Some(l) if rgba => Box::new(RgbaOut::new(device, resources, l)),
        _ => Box::new(RgbToYuv::new(device, resources)),
    };
    std::iter::once(Box::new(start) as Box<dyn FrameStage>)
        .chain(between)
        .chain([out])
        .collect()
}

/// The streaks' draw: by compute in tiles where the job asks for it and draws capsules, else
/// a quad per drop.
fn streaks_stage(
    device: &wgpu::Device,
    resources: &FrameResources,
    rain: &RainSetup,
) -> Box<dyn FrameStage> {
    match (&rain.mattes, rain.gpu_raster) {
        (None, crate::config::GpuRaster::Compute) => Box::new(
            super::stages::streak_tiles::StreakTiles::new(device, resources),
        ),
        (mattes, _) => Box::new(RainStreaks::new(device, resources, mattes.as_deref())),
    }
}

/// A query set of two timestamps per stage and the buffer they resolve into, where the device
/// can time passes.
fn timestamp_queries(device: &wgpu::Device, timed: u64) -> Option<(wgpu::QuerySet, wgpu::Buffer)> {
    device
        .features()
        .contains(wgpu::Features::TIMESTAMP_QUERY)
        .then(|| {
            let set = device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("stage_timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2 * timed as u32,
            });
            let resolve = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("stage_timestamps"),
                size: 16 * timed,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            (set, resolve)
        })
}

/// One buffer of the readback ring: a frame's packed output and its timestamps.
fn readback_buffer(device: &wgpu::Device, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}
