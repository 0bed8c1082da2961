//! Stage `streak_tiles`: the capsule streaks drawn onto the canvas by compute
//! (`shaders/streak_tiles.wgsl`, `--gpu-raster compute`), the picture of
//! [`super::rain_streaks::RainStreaks`] without mattes. On GPUs built for compute only a few of
//! the cores run the rasteriser, and the quad-per-drop draw costs per drop (about 8 ns a drop on
//! an H200 at 1080p whatever the picture's size); binned into tiles, the drops are drawn by
//! every core.
//!
//! Four dispatches in one pass: per streak the tiles its quad meets are counted, the counts
//! summed into each tile's first entry, the streaks listed per tile (in any order), then each
//! tile sorts its list into drop order and blends it pixel by pixel. Sorting makes the picture
//! independent of the order the atomics listed the streaks in: the same every run.

use wgpu::util::DeviceExt;

use super::rain_streaks::StreakInputs;
use super::{FrameResources, FrameStage, PIXEL_WORKGROUP, TimestampSlot, workgroups};
use crate::gpu::shaders::Stage;
use crate::gpu::types::TileParams;

/// Threads of the prefix sum's one workgroup (`TILE_SCAN_WORKGROUP` in the WGSL).
pub const SCAN_WORKGROUP: u32 = 256;
/// The longest list a tile sorts in workgroup memory (`STREAK_SORT_LOCAL`, 8 KiB of it); longer
/// lists are sorted where they lie.
pub const SORT_LOCAL: u32 = 2048;
/// Streak records a tile stages in workgroup memory at a time (`STREAK_BATCH`, 4 KiB of it).
pub const BATCH: u32 = 64;
/// List entries per streak the lists are sized for: a streak of up to a few tiles' length meets
/// at most a handful. Tiles whose lists would run past the end read every streak instead (the
/// same picture, slower).
pub const ENTRIES_PER_STREAK: u64 = 8;
/// Most workgroups of the per-streak dispatches (each thread takes every so many streaks).
const MAX_GROUPS: u32 = 65_535;

/// The stage, drawing one streak buffer into one canvas.
pub struct StreakTiles {
    count: wgpu::ComputePipeline,
    offsets: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
    blend: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    canvas: wgpu::Texture,
    picture: wgpu::Texture,
    params: TileParams,
}

impl StreakTiles {
    /// The stage for the frame's streaks in `r`.
    pub fn new(device: &wgpu::Device, r: &FrameResources) -> StreakTiles {
        let inputs = StreakInputs {
            rain_params: &r.rain_params,
            streaks: &r.streaks,
            count: r.drop_count,
            scene_depth: &r.scene_depth,
            canvas: r.canvas.texture(),
        };
        StreakTiles::with_inputs(device, &inputs, None)
    }

    /// The stage over `inputs`, its lists holding `capacity` entries in all (`None`:
    /// [`ENTRIES_PER_STREAK`] per streak, within the device's largest storage binding).
    pub fn with_inputs(
        device: &wgpu::Device,
        inputs: &StreakInputs<'_>,
        capacity: Option<u32>,
    ) -> StreakTiles {
        let size = inputs.canvas.size();
        let tiles_xy = [
            workgroups(size.width, PIXEL_WORKGROUP),
            workgroups(size.height, PIXEL_WORKGROUP),
        ];
        let tile_count = u64::from(tiles_xy[0]) * u64::from(tiles_xy[1]);
        let limits = device.limits();
        let most = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size)
            / 4;
        let capacity = capacity
            .map(u64::from)
            .unwrap_or(u64::from(inputs.count) * ENTRIES_PER_STREAK)
            .clamp(1, most.min(u64::from(u32::MAX)));
        let params = TileParams {
            tiles_xy,
            streak_count: inputs.count,
            capacity: capacity as u32,
        };
        let storage = |label, words: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 4 * words,
                usage: wgpu::BufferUsages::STORAGE,
                // Created zeroed: the counts start at zero, and blend leaves them so.
                mapped_at_creation: false,
            })
        };
        let tile_data = storage("streak_tile_data", 2 * tile_count);
        let tile_list = storage("streak_tile_list", capacity);
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("tile_params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let picture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("streak_tiles_picture"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: inputs.canvas.format(),
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let layout = bind_group_layout(device);
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(Stage::StreakTiles.name()),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = Stage::StreakTiles.module(device);
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(Stage::StreakTiles.name()),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let picture_view = picture.create_view(&Default::default());
        let canvas_view = inputs.canvas.create_view(&Default::default());
        let resources = [
            inputs.rain_params.as_entire_binding(),
            uniform.as_entire_binding(),
            inputs.streaks.as_entire_binding(),
            inputs.scene_depth.as_entire_binding(),
            tile_data.as_entire_binding(),
            tile_list.as_entire_binding(),
            wgpu::BindingResource::TextureView(&picture_view),
            wgpu::BindingResource::TextureView(&canvas_view),
        ];
        let bind =
            crate::gpu::bind::bind_group(device, Stage::StreakTiles.name(), &layout, &resources);
        StreakTiles {
            count: pipeline("count"),
            offsets: pipeline("offsets"),
            scatter: pipeline("scatter"),
            blend: pipeline("blend"),
            bind,
            canvas: inputs.canvas.clone(),
            picture,
            params,
        }
    }

    /// Entries the tiles' lists hold in all.
    pub fn capacity(&self) -> u32 {
        self.params.capacity
    }
}

/// The stage's one layout, shared by its four entry points (bindings as in the WGSL).
fn bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty,
        count: None,
    };
    let uniform = wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Uniform,
        has_dynamic_offset: false,
        min_binding_size: None,
    };
    let storage = |read_only| wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Storage { read_only },
        has_dynamic_offset: false,
        min_binding_size: None,
    };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(Stage::StreakTiles.name()),
        entries: &[
            entry(0, uniform),
            entry(1, uniform),
            entry(2, storage(true)),
            entry(3, storage(true)),
            entry(4, storage(false)),
            entry(5, storage(false)),
            entry(
                6,
                wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
            ),
            entry(
                7,
                wgpu::BindingType::StorageTexture {
                    access: wgpu::StorageTextureAccess::WriteOnly,
                    format: super::rain_streaks::CANVAS_FORMAT,
                    view_dimension: wgpu::TextureViewDimension::D2,
                },
            ),
        ],
    })
}

impl FrameStage for StreakTiles {
    fn name(&self) -> &'static str {
        Stage::StreakTiles.name()
    }

    fn runs(&self) -> bool {
        self.params.streak_count > 0
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timestamps: Option<TimestampSlot<'_>>) {
        encoder.copy_texture_to_texture(
            self.canvas.as_image_copy(),
            self.picture.as_image_copy(),
            self.canvas.size(),
        );
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(self.name()),
            timestamp_writes: timestamps.map(TimestampSlot::compute),
        });
        pass.set_bind_group(0, &self.bind, &[]);
        let per_streak =
            workgroups(self.params.streak_count, super::rain_simulate::WORKGROUP).min(MAX_GROUPS);
        pass.set_pipeline(&self.count);
        pass.dispatch_workgroups(per_streak, 1, 1);
        pass.set_pipeline(&self.offsets);
        pass.dispatch_workgroups(1, 1, 1);
        pass.set_pipeline(&self.scatter);
        pass.dispatch_workgroups(per_streak, 1, 1);
        pass.set_pipeline(&self.blend);
        pass.dispatch_workgroups(self.params.tiles_xy[0], self.params.tiles_xy[1], 1);
    }
}
