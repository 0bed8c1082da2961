//! Stage `rain_streaks`: the streaks rasterised onto the canvas, one quad per drop in drop
//! order, premultiplied, hidden behind the scene where a depth map is given
//! (`shaders/rain_streaks.wgsl`; CPU twin [`crate::gpu::cpu::rain_streaks`]).

use super::{FrameResources, FrameStage, TimestampSlot};
use crate::gpu::bind::{bind_group, buffer};
use crate::gpu::shaders::Stage;

/// The canvas format the streaks blend into.
pub const CANVAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The stage, drawing into one canvas.
pub struct RainStreaks {
    pipeline: wgpu::RenderPipeline,
    bind: wgpu::BindGroup,
    canvas: wgpu::TextureView,
    drops: u32,
}

impl RainStreaks {
    /// Builds the pipeline and binds `r`.
    pub fn new(device: &wgpu::Device, r: &FrameResources) -> RainStreaks {
        RainStreaks::with_streaks(device, r, &r.streaks, r.drop_count)
    }

    /// The rasteriser over `count` streaks of another buffer (the splashes').
    pub fn with_streaks(
        device: &wgpu::Device,
        r: &FrameResources,
        streaks: &wgpu::Buffer,
        count: u32,
    ) -> RainStreaks {
        let module = Stage::RainStreaks.module(device);
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(Stage::RainStreaks.name()),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: CANVAS_FORMAT,
                    blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let bind = bind_group(
            device,
            Stage::RainStreaks.name(),
            &pipeline.get_bind_group_layout(0),
            &[
                buffer(&r.rain_params),
                buffer(streaks),
                buffer(&r.scene_depth),
            ],
        );
        RainStreaks {
            pipeline,
            bind,
            canvas: r.canvas.clone(),
            drops: count,
        }
    }
}

impl FrameStage for RainStreaks {
    fn name(&self) -> &'static str {
        Stage::RainStreaks.name()
    }

    fn runs(&self) -> bool {
        self.drops > 0
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timestamps: Option<TimestampSlot<'_>>) {
        self.draw(encoder, timestamps.map(TimestampSlot::render));
    }
}

impl RainStreaks {
    /// Records the draw, with `timestamp_writes` when given.
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(self.name()),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &self.canvas,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.draw(0..6, 0..self.drops);
    }
}
