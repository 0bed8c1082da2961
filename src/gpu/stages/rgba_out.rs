//! Stage `rgba_out`: the layer's canvas → packed 16-bit R'G'B'A, premultiplied, straight or
//! the matte, or the canvas as half floats for a scene-linear layer (`shaders/rgba_out.wgsl`;
//! CPU twin [`crate::gpu::cpu::rgba_out`]).

use super::{FrameResources, FrameStage, PIXEL_WORKGROUP, TimestampSlot, workgroups};
use crate::gpu::bind::{bind_group, buffer, view};
use crate::gpu::shaders::Stage;
use crate::video::layer::{AlphaMode, Layer};

/// Words per pixel in the output buffer (four 16-bit samples).
pub const WORDS_PER_PIXEL: u32 = 2;

/// The stage, one entry point chosen by the layer.
pub struct RgbaOut {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    size: (u32, u32),
}

impl RgbaOut {
    /// Builds the pipeline of `layer`'s entry point and binds `r`.
    pub fn new(device: &wgpu::Device, r: &FrameResources, layer: Layer) -> RgbaOut {
        RgbaOut::with_buffers(
            device,
            &r.frame_params,
            (r.frame.width, r.frame.height),
            &r.canvas,
            &r.out_words,
            layer,
        )
    }

    /// The stage over explicit resources (the twin test uploads its own canvas): the
    /// `FrameParams` uniform of a `size` picture, an `Rgba16Float` canvas, and an output
    /// buffer of [`WORDS_PER_PIXEL`] words a pixel.
    pub fn with_buffers(
        device: &wgpu::Device,
        frame_params: &wgpu::Buffer,
        size: (u32, u32),
        canvas: &wgpu::TextureView,
        out_words: &wgpu::Buffer,
        layer: Layer,
    ) -> RgbaOut {
        let entry = match layer {
            Layer::Alpha(AlphaMode::Straight) => "straight",
            Layer::Matte => "matte",
            Layer::SceneLinear => "linear",
            Layer::Alpha(AlphaMode::Premultiplied) | Layer::OverBlack => "premultiplied",
        };
        let pipeline = super::compute_pipeline(device, Stage::RgbaOut, entry);
        let bind = bind_group(
            device,
            Stage::RgbaOut.name(),
            &pipeline.get_bind_group_layout(0),
            &[buffer(frame_params), view(canvas), buffer(out_words)],
        );
        RgbaOut {
            pipeline,
            bind,
            size,
        }
    }
}

impl FrameStage for RgbaOut {
    fn name(&self) -> &'static str {
        Stage::RgbaOut.name()
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
