//! Stage `rain_streaks`: the streaks rasterised onto the canvas, one quad per drop in drop
//! order, premultiplied, hidden behind the scene where a depth map is given
//! (`shaders/rain_streaks.wgsl`; CPU twin [`crate::gpu::cpu::rain_streaks`]). With streak
//! mattes, a second pair of entry points spreads each streak's colour by its matte; without,
//! the pipeline is the capsule's alone.

use wgpu::util::DeviceExt;

use super::{FrameResources, FrameStage, TimestampSlot};
use crate::drops::MatteAtlas;
use crate::drops::atlas::{ATLAS_HEIGHT, ATLAS_WIDTH};
use crate::gpu::bind::{bind_group, buffer, view};
use crate::gpu::shaders::Stage;
use bytemuck::Zeroable;

use crate::gpu::types::{Glint, MatteParams};

/// The canvas format the streaks blend into.
pub const CANVAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Matte layers side by side in a row of the atlas texture (`MATTE_TILES_ACROSS` in the WGSL).
pub const MATTE_TILES_ACROSS: usize = 64;

/// Vertices of a streak's quad, a triangle strip.
pub const QUAD_VERTICES: u32 = 4;

/// The matte layers as one `R16Float` texture for the sampler's bilinear read: layer `l` at
/// tile (`l mod` [`MATTE_TILES_ACROSS`], `l div` it), each layer framed by one texel of zeros,
/// so a read clamped to the frame's texel centres is zero outside the layer as
/// [`MatteAtlas::sample`] is. Half floats hold N to 2⁻¹¹ of itself, far below a code value of
/// the light it spreads; the filtering hardware does the four reads and weights that a storage
/// buffer read costs in the shader.
pub fn matte_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    atlas: &MatteAtlas,
) -> crate::Result<wgpu::TextureView> {
    let (tile_w, tile_h) = (ATLAS_WIDTH + 2, ATLAS_HEIGHT + 2);
    let (width, height) = matte_texture_size(atlas);
    let max = device.limits().max_texture_dimension_2d as usize;
    if height > max {
        return Err(crate::Error::Unsupported(format!(
            "{} streak mattes need a {width}×{height} texture; this GPU's largest is {max} px",
            atlas.layers()
        )));
    }
    let mut texels = vec![half::f16::ZERO; width * height];
    for (l, layer) in atlas
        .texels
        .chunks_exact(ATLAS_WIDTH * ATLAS_HEIGHT)
        .enumerate()
    {
        let (x0, y0) = (
            (l % MATTE_TILES_ACROSS) * tile_w + 1,
            (l / MATTE_TILES_ACROSS) * tile_h + 1,
        );
        for (j, row) in layer.chunks_exact(ATLAS_WIDTH).enumerate() {
            let at = (y0 + j) * width + x0;
            for (t, &n) in texels[at..at + ATLAS_WIDTH].iter_mut().zip(row) {
                *t = half::f16::from_f32(n);
            }
        }
    }
    let texture = device.create_texture_with_data(
        queue,
        &wgpu::TextureDescriptor {
            label: Some("matte_atlas"),
            size: wgpu::Extent3d {
                width: width as u32,
                height: height as u32,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R16Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        bytemuck::cast_slice(&texels),
    );
    Ok(texture.create_view(&Default::default()))
}

/// The width and height in texels of [`matte_texture`] for `atlas`.
pub fn matte_texture_size(atlas: &MatteAtlas) -> (usize, usize) {
    let layers = atlas.layers().max(1);
    (
        MATTE_TILES_ACROSS * (ATLAS_WIDTH + 2),
        layers.div_ceil(MATTE_TILES_ACROSS) * (ATLAS_HEIGHT + 2),
    )
}

/// The stage, drawing into one canvas.
pub struct RainStreaks {
    pipeline: wgpu::RenderPipeline,
    bind: wgpu::BindGroup,
    canvas: wgpu::TextureView,
    drops: u32,
}

impl RainStreaks {
    /// Builds the pipeline and binds `r`; with `mattes` (their texture in `r`), draws with them.
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
        let pipeline = pipeline(device, mattes.is_some());
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
                let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
                    label: Some("matte_sampler"),
                    mag_filter: wgpu::FilterMode::Linear,
                    min_filter: wgpu::FilterMode::Linear,
                    ..Default::default()
                });
                let texture = r
                    .matte_atlas
                    .as_ref()
                    .expect("the frame's resources hold the mattes' texture");
                bind_group(
                    device,
                    Stage::RainStreaks.name(),
                    &layout,
                    &[
                        buffer(&r.rain_params),
                        buffer(streaks),
                        buffer(&r.scene_depth),
                        buffer(&params),
                        view(texture),
                        buffer(r.glints.as_ref().unwrap_or(&placeholder)),
                        wgpu::BindingResource::Sampler(&sampler),
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

/// The draw's pipeline: the capsule's, or with `mattes` the mattes'.
fn pipeline(device: &wgpu::Device, mattes: bool) -> wgpu::RenderPipeline {
    let module = Stage::RainStreaks.module(device);
    let (vs, fs) = match mattes {
        false => ("vs_main", "fs_main"),
        true => ("vs_mattes", "fs_mattes"),
    };
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(Stage::RainStreaks.name()),
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some(vs),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleStrip,
            ..Default::default()
        },
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
    })
}

/// The buffers and the canvas a streak rasteriser binds (for a draw outside a compositor's
/// frame, as the tests and benches make).
pub struct StreakInputs<'a> {
    /// The `RainParams` uniform.
    pub rain_params: &'a wgpu::Buffer,
    /// The streaks (`Streak`s), at least `count` of them.
    pub streaks: &'a wgpu::Buffer,
    /// Streaks drawn: the first of `streaks`.
    pub count: u32,
    /// The scene's depth per displayed pixel (one element: none).
    pub scene_depth: &'a wgpu::Buffer,
    /// The `Rgba16Float` canvas.
    pub canvas: &'a wgpu::Texture,
}

impl RainStreaks {
    /// The capsules' draw of `inputs`.
    pub fn capsules(device: &wgpu::Device, inputs: &StreakInputs<'_>) -> RainStreaks {
        let pipeline = pipeline(device, false);
        let bind = bind_group(
            device,
            Stage::RainStreaks.name(),
            &pipeline.get_bind_group_layout(0),
            &[
                buffer(inputs.rain_params),
                buffer(inputs.streaks),
                buffer(inputs.scene_depth),
            ],
        );
        RainStreaks {
            pipeline,
            bind,
            canvas: inputs.canvas.create_view(&Default::default()),
            drops: inputs.count,
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
            .draw(0..QUAD_VERTICES, 0..self.drops);
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
