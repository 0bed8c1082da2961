//! Stage `rgb_to_yuv`: the canvas → packed code values, luma then chroma
//! (`shaders/rgb_to_yuv.wgsl`; CPU twin [`crate::gpu::cpu::rgb_to_yuv`]).

use super::{FrameResources, FrameStage, PIXEL_WORKGROUP, TimestampSlot, workgroups};
use crate::gpu::bind::{bind_group, buffer, view};
use crate::gpu::shaders::Stage;

/// The stage: two entry points, one pass.
pub struct RgbToYuv {
    luma: (wgpu::ComputePipeline, wgpu::BindGroup, [u32; 2]),
    chroma: (wgpu::ComputePipeline, wgpu::BindGroup, [u32; 2]),
}

impl RgbToYuv {
    /// Builds the pipelines and binds `r`.
    pub fn new(device: &wgpu::Device, r: &FrameResources) -> RgbToYuv {
        let entry = |name: &str, words: u32, rows: u32| {
            let pipeline = super::compute_pipeline(device, Stage::RgbToYuv, name);
            let bind = bind_group(
                device,
                Stage::RgbToYuv.name(),
                &pipeline.get_bind_group_layout(0),
                &[
                    buffer(&r.frame_params),
                    view(&r.canvas),
                    buffer(&r.out_words),
                ],
            );
            (pipeline, bind, [words, rows])
        };
        let f = &r.frame;
        RgbToYuv {
            luma: entry("luma", f.y_row_words, f.height),
            chroma: entry("chroma", f.c_row_words, f.chroma_height),
        }
    }
}

impl FrameStage for RgbToYuv {
    fn name(&self) -> &'static str {
        Stage::RgbToYuv.name()
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timestamps: Option<TimestampSlot<'_>>) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(self.name()),
            timestamp_writes: timestamps.map(TimestampSlot::compute),
        });
        for (pipeline, bind, [w, h]) in [&self.luma, &self.chroma] {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind, &[]);
            pass.dispatch_workgroups(
                workgroups(*w, PIXEL_WORKGROUP),
                workgroups(*h, PIXEL_WORKGROUP),
                1,
            );
        }
    }
}
