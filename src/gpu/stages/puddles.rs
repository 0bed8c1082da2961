//! Stage `puddles`: standing water on the ground, with ripple rings and the frame mirrored in it
//! (`shaders/puddles.wgsl`; CPU twin [`crate::gpu::cpu::puddles`]). The stage has work only once
//! a water map is set ([`Puddles::set_water`]); until then it builds nothing and the frame is
//! untouched. It copies the canvas first and reads the copy, so the mirror image is the picture
//! before any water, and pixels without water keep their value bit for bit; the ground under
//! the water is the frame's own, from the planes (the wet ground's film is replaced, not
//! darkened again). The water keeps to the ground mask (`FrameResources::ground_mask`).

use super::{FrameResources, FrameStage, PIXEL_WORKGROUP, TimestampSlot, workgroups};
use crate::fluid::Field2;
use crate::fluid::puddles::shown;
use crate::fluid::ripples::{MAX_RINGS, Ring, live_rings};
use crate::gpu::bind::{bind_group, buffer, view};
use crate::gpu::shaders::Stage;
use crate::gpu::types::{PuddleParams, RainParams, Ripple};
use crate::lighting::wetness::FilmOptics;
use crate::rain::volume::impacts::Impact;
use crate::{Error, Result};

/// Water covers the ground smoothly as its depth rises from 0 to this, m: a puddle's rim is a
/// wet film a millimetre thick, not a cut (the water map's own ramp, [`shown::EDGE_DEPTH_M`]).
pub const EDGE_DEPTH_M: f64 = shown::EDGE_DEPTH_M as f64;

/// Concentration κ of a compact light's mirror image on the water, rad⁻²: a lobe of about 1.8°
/// (1/√κ), the glitter of a surface that is never quite still.
pub const LIGHT_LOBE: f64 = 1000.0;

/// The uniforms of a water map whose first cell's corner stands at world `origin_m`, with
/// `cells` cells of `cell_m` metres: water's optics, no rings and no far glitter yet (each frame
/// sets those).
pub fn water_params(origin_m: [f32; 2], cell_m: f32, cells: [u32; 2]) -> PuddleParams {
    let optics = FilmOptics::water();
    PuddleParams {
        origin_m,
        cell_m,
        edge_depth_m: EDGE_DEPTH_M as f32,
        cells,
        ring_count: 0,
        far_slope_rms: 0.0,
        water_index: optics.index as f32,
        diffuse_external: optics.diffuse_external as f32,
        diffuse_internal: optics.diffuse_internal as f32,
        light_lobe: LIGHT_LOBE as f32,
        resolve_depth_m: 0.0,
        _pad0: 0.0,
        _pad1: 0.0,
        _pad2: 0.0,
    }
}

/// The stage: the shared resources it binds, and its own once water is set.
pub struct Puddles {
    /// The shared resources where the pass runs on the adapter; `None` on the CPU back end,
    /// which shades from [`Puddles::frame_water`] (then nothing is built on the adapter).
    bound: Option<Bound>,
    /// Whether frames are pictures; for a layer the water is written as the layer's colour and
    /// alpha over the frame (entry point `layer`).
    picture: bool,
    /// The map's placement (origin, cell, cells) and the water's optics, once water is set.
    base: Option<PuddleParams>,
    job: Option<Water>,
    rings: Vec<Ring>,
    /// The far water's RMS slope and the camera depth where it takes over, m.
    far_slope: (f32, f32),
    /// The water map as uploaded (m per cell), for the CPU back end.
    metres: Vec<f32>,
}

/// The frame's shared resources the pass binds, and the device it builds on.
struct Bound {
    device: wgpu::Device,
    rain_params: wgpu::Buffer,
    frame_params: wgpu::Buffer,
    planes: [wgpu::TextureView; 3],
    canvas: wgpu::Texture,
    scene_depth: wgpu::Buffer,
    ground_mask: wgpu::Buffer,
    glow_grid: wgpu::TextureView,
    lights: wgpu::Buffer,
}

/// The water of one frame as the stage's uniforms and buffers hold it (what the CPU back end
/// shades from).
pub struct FrameWater<'a> {
    /// The map's placement, the water's optics and the live rings' count.
    pub params: PuddleParams,
    /// Water depth per cell, m (row-major, x fastest).
    pub depth_m: &'a [f32],
    /// The rings alive at the frame's time, the newest [`MAX_RINGS`].
    pub ripples: Vec<Ripple>,
}

/// What water on the ground needs.
struct Water {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    params: wgpu::Buffer,
    frame: wgpu::Texture,
    depth_m: wgpu::Buffer,
    ripples: wgpu::Buffer,
}

impl Puddles {
    /// The stage for the frame resources `r` of pictures (`picture`) or layers, idle until
    /// water is set; its pass on the adapter only with `r` (none on the CPU back end).
    pub fn new(device: &wgpu::Device, r: Option<&FrameResources>, picture: bool) -> Puddles {
        Puddles {
            bound: r.map(|r| Bound {
                device: device.clone(),
                rain_params: r.rain_params.clone(),
                frame_params: r.frame_params.clone(),
                planes: r.planes.clone(),
                canvas: r.canvas.texture().clone(),
                scene_depth: r.scene_depth.clone(),
                ground_mask: r.ground_mask.clone(),
                glow_grid: r.glow_grid.clone(),
                lights: r.lights.list.clone(),
            }),
            picture,
            base: None,
            job: None,
            rings: Vec::new(),
            far_slope: (0.0, 0.0),
            metres: Vec::new(),
        }
    }

    /// Sets the water map (m per cell of `depth`, world x, y on z = 0; [`shown::water_map`]) for
    /// the frames submitted from now on: a signed depth, negative where dry, so that its
    /// interpolated zero can fall between cells. Non-finite values count as dry.
    pub fn set_water(&mut self, queue: &wgpu::Queue, depth: &Field2) -> Result<()> {
        let cells = depth.nx * depth.ny;
        if cells == 0 || depth.values.len() != cells {
            return Err(Error::Unsupported(format!(
                "a water map of {}×{} cells with {} values",
                depth.nx,
                depth.ny,
                depth.values.len()
            )));
        }
        if !(depth.cell_m > 0.0 && depth.cell_m.is_finite() && depth.origin_m.is_finite()) {
            return Err(Error::Unsupported(format!(
                "a water map with cells of {} m at {}",
                depth.cell_m, depth.origin_m
            )));
        }
        // Into the last frame's array: a fresh one of a million cells is paged in anew each
        // frame.
        let mut metres = std::mem::take(&mut self.metres);
        metres.clear();
        metres.extend(depth.values.iter().map(|&d| {
            if d.is_finite() {
                d
            } else {
                -shown::EDGE_DEPTH_M
            }
        }));
        let bytes = 4 * cells as u64;
        if let Some(bound) = &self.bound
            && self.job.as_ref().is_none_or(|w| w.depth_m.size() != bytes)
        {
            self.job = Some(bound.build(self.picture, bytes));
        }
        if let Some(job) = &self.job {
            queue.write_buffer(&job.depth_m, 0, bytemuck::cast_slice(&metres));
        }
        self.base = Some(water_params(
            depth.origin_m.to_array(),
            depth.cell_m,
            [depth.nx as u32, depth.ny as u32],
        ));
        self.metres = metres;
        Ok(())
    }

    /// Sets the drops that landed on water, whose rings the frames submitted from now on show
    /// (those alive at each frame's time, the newest [`MAX_RINGS`]).
    pub fn set_ripples(&mut self, impacts: &[Impact]) {
        self.rings = impacts.iter().map(Ring::from_impact).collect();
    }

    /// Sets the RMS slope of the water rained on where single rings are finer than a pixel,
    /// shown as a blurred reflection from camera depth `resolve_depth_m` on (fully from twice
    /// that); 0: none.
    pub fn set_far_ripples(&mut self, slope_rms: f64, resolve_depth_m: f64) {
        self.far_slope = (slope_rms as f32, resolve_depth_m as f32);
    }

    /// The water of the frame of `rain` (uniforms, map and rings), or `None` before water is
    /// set (the stage does not run).
    pub fn frame_water(&self, rain: &RainParams) -> Option<FrameWater<'_>> {
        let base = self.base?;
        let t_s = rain.time_whole_s as f64 + rain.time_frac_s as f64;
        let ripples: Vec<Ripple> = live_rings(&self.rings, t_s)
            .iter()
            .filter_map(|ring| Ripple::new(ring, t_s))
            .collect();
        let params = PuddleParams {
            ring_count: ripples.len() as u32,
            far_slope_rms: self.far_slope.0,
            resolve_depth_m: self.far_slope.1,
            ..base
        };
        Some(FrameWater {
            params,
            depth_m: &self.metres,
            ripples,
        })
    }
}

impl Bound {
    /// The pipeline and buffers, for a water map of `depth_bytes` (of pictures with
    /// `picture`, else of layers).
    fn build(&self, picture: bool, depth_bytes: u64) -> Water {
        let device = &self.device;
        let frame = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("puddles_frame"),
            size: self.canvas.size(),
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: self.canvas.format(),
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let storage = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let depth_m = storage("water_depth", depth_bytes);
        let ripples = storage(
            "ripples",
            (MAX_RINGS * std::mem::size_of::<Ripple>()) as u64,
        );
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("puddle_params"),
            size: std::mem::size_of::<PuddleParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let entry = if picture { "main" } else { "layer" };
        let pipeline = super::compute_pipeline(device, Stage::Puddles, entry);
        let canvas = self.canvas.create_view(&Default::default());
        let bind = bind_group(
            device,
            Stage::Puddles.name(),
            &pipeline.get_bind_group_layout(0),
            &[
                buffer(&self.rain_params),
                buffer(&params),
                view(&frame.create_view(&Default::default())),
                view(&canvas),
                buffer(&self.scene_depth),
                buffer(&depth_m),
                buffer(&ripples),
                buffer(&self.lights),
                buffer(&self.frame_params),
                view(&self.planes[0]),
                view(&self.planes[1]),
                view(&self.planes[2]),
                buffer(&self.ground_mask),
                view(&self.glow_grid),
            ],
        );
        Water {
            pipeline,
            bind,
            params,
            frame,
            depth_m,
            ripples,
        }
    }
}

impl FrameStage for Puddles {
    fn name(&self) -> &'static str {
        Stage::Puddles.name()
    }

    fn runs(&self) -> bool {
        self.base.is_some()
    }

    fn prepare(&self, queue: &wgpu::Queue, rain: &RainParams) {
        let (Some(job), Some(water)) = (&self.job, self.frame_water(rain)) else {
            return;
        };
        if !water.ripples.is_empty() {
            queue.write_buffer(&job.ripples, 0, bytemuck::cast_slice(&water.ripples));
        }
        queue.write_buffer(&job.params, 0, bytemuck::bytes_of(&water.params));
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timestamps: Option<TimestampSlot<'_>>) {
        let (Some(job), Some(bound)) = (&self.job, &self.bound) else {
            return;
        };
        encoder.copy_texture_to_texture(
            bound.canvas.as_image_copy(),
            job.frame.as_image_copy(),
            bound.canvas.size(),
        );
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(self.name()),
            timestamp_writes: timestamps.map(TimestampSlot::compute),
        });
        pass.set_pipeline(&job.pipeline);
        pass.set_bind_group(0, &job.bind, &[]);
        let size = bound.canvas.size();
        pass.dispatch_workgroups(
            workgroups(size.width, PIXEL_WORKGROUP),
            workgroups(size.height, PIXEL_WORKGROUP),
            1,
        );
    }
}
