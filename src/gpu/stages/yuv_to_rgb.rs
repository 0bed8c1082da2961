//! Stage `yuv_to_rgb`: decoded planes → the linear canvas, with the haze; for the rain as a
//! layer, the haze alone over a transparent canvas (`shaders/yuv_to_rgb.wgsl`; CPU twin
//! [`crate::gpu::cpu::yuv_to_rgb`]). The lamps' glow in the haze is integrated first on a
//! coarse grid of rays (entry point `glow`), which each pixel interpolates.

use super::{FrameResources, FrameStage, PIXEL_WORKGROUP, TimestampSlot, workgroups};
use crate::gpu::bind::{buffer, view};
use crate::gpu::shaders::Stage;

/// Coded pixels between the rays the haze's glow is integrated along (`GLOW_CELL_PX` in the
/// WGSL): the drop's forward lobe changes over degrees, 8 px is 0.7° at 720p and 60°.
pub const GLOW_CELL_PX: u32 = 8;

/// Grid points of the glow for a coded picture of `size` pixels: one every [`GLOW_CELL_PX`],
/// both ends included.
pub fn glow_grid_size(size: (u32, u32)) -> (u32, u32) {
    (
        size.0.div_ceil(GLOW_CELL_PX) + 1,
        size.1.div_ceil(GLOW_CELL_PX) + 1,
    )
}

/// The stage, bound to one compositor's resources.
pub struct YuvToRgb {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    glow: wgpu::ComputePipeline,
    glow_bind: wgpu::BindGroup,
    size: (u32, u32),
}

/// The glow's grid pipeline, bound to `r` (the grid is `r.glow_grid`).
fn glow_pass(
    device: &wgpu::Device,
    r: &FrameResources,
) -> (wgpu::ComputePipeline, wgpu::BindGroup) {
    let pipeline = super::compute_pipeline(device, Stage::YuvToRgb, "glow");
    let entries = [
        (5, buffer(&r.rain_params)),
        (6, buffer(&r.lights.list)),
        (7, buffer(&r.lights.table)),
        (8, view(&r.glow_grid)),
    ]
    .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("glow_grid"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    (pipeline, bind)
}

impl YuvToRgb {
    /// Builds the pipeline and binds `r`.
    pub fn new(device: &wgpu::Device, r: &FrameResources) -> YuvToRgb {
        YuvToRgb::with_entry(device, r, "main")
    }

    /// The layer's start: the haze alone over a transparent canvas (entry point `layer`, which
    /// reads no planes, so its inferred layout holds bindings 0, 4, 5, 6, 9, 10 and 11 only).
    pub fn layer(device: &wgpu::Device, r: &FrameResources) -> YuvToRgb {
        YuvToRgb::with_entry(device, r, "layer")
    }

    /// The stage with entry point `entry`, bound to what that entry point reads (the planes
    /// only for `main`; the drop tables only the glow's pass reads).
    fn with_entry(device: &wgpu::Device, r: &FrameResources, entry: &str) -> YuvToRgb {
        let (glow, glow_bind) = glow_pass(device, r);
        let pipeline = super::compute_pipeline(device, Stage::YuvToRgb, entry);
        let planes = [
            (1, view(&r.planes[0])),
            (2, view(&r.planes[1])),
            (3, view(&r.planes[2])),
        ];
        let entries: Vec<wgpu::BindGroupEntry> = [
            (0, buffer(&r.frame_params)),
            (4, view(&r.canvas)),
            (5, buffer(&r.rain_params)),
            (6, buffer(&r.lights.list)),
            (9, buffer(&r.scene_depth)),
            (10, buffer(&r.sky_mask)),
            (11, view(&r.glow_grid)),
        ]
        .into_iter()
        .chain(planes.into_iter().filter(|_| entry == "main"))
        .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource })
        .collect();
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(Stage::YuvToRgb.name()),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        YuvToRgb {
            pipeline,
            bind,
            glow,
            glow_bind,
            size: (r.frame.width, r.frame.height),
        }
    }
}

impl FrameStage for YuvToRgb {
    fn name(&self) -> &'static str {
        Stage::YuvToRgb.name()
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timestamps: Option<TimestampSlot<'_>>) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(self.name()),
            timestamp_writes: timestamps.map(TimestampSlot::compute),
        });
        // The glow's grid first (each dispatch sees the previous one's writes).
        let (gw, gh) = glow_grid_size(self.size);
        pass.set_pipeline(&self.glow);
        pass.set_bind_group(0, &self.glow_bind, &[]);
        pass.dispatch_workgroups(
            workgroups(gw, PIXEL_WORKGROUP),
            workgroups(gh, PIXEL_WORKGROUP),
            1,
        );
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.dispatch_workgroups(
            workgroups(self.size.0, PIXEL_WORKGROUP),
            workgroups(self.size.1, PIXEL_WORKGROUP),
            1,
        );
    }
}
