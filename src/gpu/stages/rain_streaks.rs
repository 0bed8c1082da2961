//! Stage `rain_streaks`: the streaks rasterised onto the canvas, one quad per drop in drop
//! order, premultiplied, hidden behind the scene where a depth map is given
//! (`shaders/rain_streaks.wgsl`; CPU twin [`crate::gpu::cpu::rain_streaks`]). With streak
//! mattes, a second pair of entry points spreads each streak's colour by its matte; without,
//! the pipeline is the capsule's alone.

use wgpu::util::DeviceExt;

use super::{FrameResources, FrameStage, TimestampSlot};
use crate::drops::MatteAtlas;
use crate::gpu::bind::{bind_group, buffer};
use crate::gpu::shaders::Stage;
use bytemuck::Zeroable;

use crate::gpu::types::{Glint, MatteParams};

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
    /// Builds the pipeline and binds `r`; with `mattes`, uploads them and draws with them.
    pub fn new(
        device: &wgpu::Device,
        r: &FrameResources,
        mattes: Option<&MatteAtlas>,
    ) -> RainStreaks {
        RainStreaks::with_streaks(device, r, &r.streaks, r.drop_count, mattes)
    }

    /// The rasteriser over `count` streaks of another buffer (the splashes', drawn as capsules
    /// with `mattes` None).
    pub fn with_streaks(
        device: &wgpu::Device,
        r: &FrameResources,
        streaks: &wgpu::Buffer,
        count: u32,
        mattes: Option<&MatteAtlas>,
    ) -> RainStreaks {
        let module = Stage::RainStreaks.module(device);
        let (vs, fs) = match mattes {
            None => ("vs_main", "fs_main"),
            Some(_) => ("vs_mattes", "fs_mattes"),
        };
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(Stage::RainStreaks.name()),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some(vs),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some(fs),
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
        let layout = pipeline.get_bind_group_layout(0);
        let bind = match mattes {
            None => bind_group(
                device,
                Stage::RainStreaks.name(),
                &layout,
                &[
                    buffer(&r.rain_params),
                    buffer(streaks),
                    buffer(&r.scene_depth),
                ],
            ),
            Some(atlas) => {
                let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("matte_params"),
                    contents: bytemuck::bytes_of(&MatteParams::new(atlas)),
                    usage: wgpu::BufferUsages::UNIFORM,
                });
                // Without point-light mattes no streak has a glint: one zero glint for all.
                let placeholder = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("no_glints"),
                    contents: bytemuck::bytes_of(&Glint::zeroed()),
                    usage: wgpu::BufferUsages::STORAGE,
                });
                let texels = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("matte_texels"),
                    contents: bytemuck::cast_slice(&atlas.texels),
                    usage: wgpu::BufferUsages::STORAGE,
                });
                bind_group(
                    device,
                    Stage::RainStreaks.name(),
                    &layout,
                    &[
                        buffer(&r.rain_params),
                        buffer(streaks),
                        buffer(&r.scene_depth),
                        buffer(&params),
                        buffer(&texels),
                        buffer(r.glints.as_ref().unwrap_or(&placeholder)),
                    ],
                )
            }
        };
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
        self.begin(encoder, timestamp_writes)
            .draw(0..6, 0..self.drops);
    }

    /// Records the draw of the first streaks, as many as the instance count in `args`
    /// (`draw_indirect`'s arguments, written on the GPU).
    pub fn draw_indirect(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
        args: &wgpu::Buffer,
    ) {
        self.begin(encoder, timestamp_writes).draw_indirect(args, 0);
    }

    /// The render pass onto the canvas, the pipeline and bindings set.
    fn begin<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) -> wgpu::RenderPass<'e> {
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
        pass
    }
}
