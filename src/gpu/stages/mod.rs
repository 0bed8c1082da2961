//! One object per GPU stage: each file owns its pipeline, bind-group layout and bind group,
//! workgroup size and uniforms, and records its own pass; the compositor only puts them in
//! order, and a stage's timestamp slot is its place in that order.
//!
//! Adding a stage: a WGSL file (declaring its `// Includes:`), its [`Stage`] name, a file here
//! implementing [`FrameStage`], and one line in `Compositor::new`'s stage list.

pub mod puddles;
pub mod rain_probe;
pub mod rain_simulate;
pub mod rain_splashes;
pub mod rain_streaks;
pub mod rgb_to_yuv;
pub mod rgba_out;
pub mod streak_tiles;
pub mod wet_ground;
pub mod yuv_to_rgb;

use super::lights::DirectLightBuffers;
use super::shaders::Stage;
use super::types::{FrameParams, RainParams};

/// Workgroup side of the per-pixel stages (`PIXEL_WORKGROUP` in the WGSL).
pub const PIXEL_WORKGROUP: u32 = 16;

/// The buffers and views the frame's stages share, made once by the compositor.
pub struct FrameResources {
    /// The frame's layout and colour (`FrameParams` uniform), and its value.
    pub frame_params: wgpu::Buffer,
    /// Its value, for dispatch sizes.
    pub frame: FrameParams,
    /// The decoded planes Y, Cb, Cr.
    pub planes: [wgpu::TextureView; 3],
    /// The linear canvas (`Rgba16Float`).
    pub canvas: wgpu::TextureView,
    /// The `RainParams` uniform, rewritten every frame.
    pub rain_params: wgpu::Buffer,
    /// The rain volume's columns.
    pub columns: wgpu::Buffer,
    /// One `Streak` per drop (`rain_simulate` → `rain_streaks`).
    pub streaks: wgpu::Buffer,
    /// `GLINTS_PER_DROP` `Glint`s per drop where the streak mattes have point lights (`rain_simulate`'s
    /// `main_mattes` → `rain_streaks`); `None` otherwise.
    pub glints: Option<wgpu::Buffer>,
    /// The streak mattes' texture ([`rain_streaks::matte_texture`]) where the job draws them.
    pub matte_atlas: Option<wgpu::TextureView>,
    /// Drops per frame.
    pub drop_count: u32,
    /// The scene's depth per displayed pixel, metres (0 = unknown), for `rain_streaks`; one
    /// element when the job has no depth map.
    pub scene_depth: wgpu::Buffer,
    /// The lamps' glow at its grid points (an `Rgba32Float` texel each), written by
    /// `yuv_to_rgb`'s `glow` entry point and read back at each pixel by it, `wet_ground` and
    /// `puddles`: a texture, so no stage reads more than four storage buffers.
    pub glow_grid: wgpu::TextureView,
    /// The open sky's weight at the glow's grid points, for `yuv_to_rgb` (zeros: no sky).
    pub sky_mask: wgpu::Buffer,
    /// The ground's weight at the glow's grid points, for `wet_ground` and `puddles` (ones:
    /// everything below the horizon).
    pub ground_mask: wgpu::Buffer,
    /// The direct light term's inputs.
    pub lights: DirectLightBuffers,
    /// The packed output planes (`rgb_to_yuv` → readback), or the packed layer (`rgba_out`).
    pub out_words: wgpu::Buffer,
}

/// Where a stage writes its begin and end timestamps: queries 2·slot and 2·slot + 1.
#[derive(Clone, Copy)]
pub struct TimestampSlot<'a> {
    /// The compositor's query set.
    pub set: &'a wgpu::QuerySet,
    /// The stage's place in the frame.
    pub slot: u32,
}

impl<'a> TimestampSlot<'a> {
    /// For a compute pass.
    pub fn compute(self) -> wgpu::ComputePassTimestampWrites<'a> {
        wgpu::ComputePassTimestampWrites {
            query_set: self.set,
            beginning_of_pass_write_index: Some(2 * self.slot),
            end_of_pass_write_index: Some(2 * self.slot + 1),
        }
    }

    /// For a render pass.
    pub fn render(self) -> wgpu::RenderPassTimestampWrites<'a> {
        wgpu::RenderPassTimestampWrites {
            query_set: self.set,
            beginning_of_pass_write_index: Some(2 * self.slot),
            end_of_pass_write_index: Some(2 * self.slot + 1),
        }
    }
}

/// One stage of a frame (`Any`, so the compositor can reach a stage's own setters; `Send`, so a
/// `Renderer` may move to the thread a host renders on).
pub trait FrameStage: std::any::Any + Send {
    /// The stage's name (its WGSL file, pipeline label and timing key).
    fn name(&self) -> &'static str;
    /// Whether the stage has work this job (a rain stage without drops has none).
    fn runs(&self) -> bool {
        true
    }
    /// Writes the stage's own uniforms for the frame of `rain`, before its pass is recorded
    /// (most stages read `RainParams` alone and have none).
    fn prepare(&self, _queue: &wgpu::Queue, _rain: &RainParams) {}
    /// Records the stage's pass, timed in `timestamps` when given.
    fn record(&self, encoder: &mut wgpu::CommandEncoder, timestamps: Option<TimestampSlot<'_>>);
}

/// The compute pipeline of `stage`'s entry point `entry`, its bind-group layout inferred from
/// the WGSL.
pub fn compute_pipeline(device: &wgpu::Device, stage: Stage, entry: &str) -> wgpu::ComputePipeline {
    let module = stage.module(device);
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(stage.name()),
        layout: None,
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// Workgroups covering `n` items in groups of `size` (at least one).
pub fn workgroups(n: u32, size: u32) -> u32 {
    n.div_ceil(size).max(1)
}
