//! Stage `yuv_to_rgb`: decoded planes → the linear canvas, with the haze; for the rain as a
//! layer, the haze alone over a transparent canvas (`shaders/yuv_to_rgb.wgsl`; CPU twin
//! [`crate::gpu::cpu::yuv_to_rgb`]).

use super::{FrameResources, FrameStage, PIXEL_WORKGROUP, TimestampSlot, workgroups};
use crate::gpu::bind::{bind_group, buffer, view};
use crate::gpu::shaders::Stage;

/// The stage, bound to one compositor's resources.
pub struct YuvToRgb {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    size: (u32, u32),
}

impl YuvToRgb {
    /// Builds the pipeline and binds `r`.
    pub fn new(device: &wgpu::Device, r: &FrameResources) -> YuvToRgb {
        let pipeline = super::compute_pipeline(device, Stage::YuvToRgb, "main");
        let layout = pipeline.get_bind_group_layout(0);
        let bind = bind_group(
            device,
            Stage::YuvToRgb.name(),
            &layout,
            &[
                buffer(&r.frame_params),
                view(&r.planes[0]),
                view(&r.planes[1]),
                view(&r.planes[2]),
                view(&r.canvas),
                buffer(&r.rain_params),
                buffer(&r.lights.list),
                buffer(&r.lights.table),
            ],
        );
        YuvToRgb {
            pipeline,
            bind,
            size: (r.frame.width, r.frame.height),
        }
    }

    /// The layer's start: the haze alone over a transparent canvas (entry point `layer`, which
    /// reads no planes, so its inferred layout holds bindings 0 and 4 to 7 only).
    pub fn layer(device: &wgpu::Device, r: &FrameResources) -> YuvToRgb {
        let pipeline = super::compute_pipeline(device, Stage::YuvToRgb, "layer");
        let entries = [
            (0, buffer(&r.frame_params)),
            (4, view(&r.canvas)),
            (5, buffer(&r.rain_params)),
            (6, buffer(&r.lights.list)),
            (7, buffer(&r.lights.table)),
        ]
        .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(Stage::YuvToRgb.name()),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        YuvToRgb {
            pipeline,
            bind,
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
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.dispatch_workgroups(
            workgroups(self.size.0, PIXEL_WORKGROUP),
            workgroups(self.size.1, PIXEL_WORKGROUP),
            1,
        );
    }
}
