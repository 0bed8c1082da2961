//! Stage `wet_ground`: the ground below the horizon darkens and gains a sheen as it wets
//! (`shaders/wet_ground.wgsl`; CPU twin [`crate::gpu::cpu::wet_ground`]). The canvas is copied
//! first, so the pass reads the dry picture and writes the wet one; pixels it does not touch
//! (the horizon and above) keep their value bit for bit.

use super::{FrameResources, FrameStage, PIXEL_WORKGROUP, TimestampSlot, workgroups};
use crate::gpu::bind::{bind_group, buffer, view};
use crate::gpu::shaders::Stage;
use crate::gpu::types::{RainParams, WetParams};
use crate::scene::wetness::{FilmOptics, Wetting};

/// The stage; it has work only where the job has a ground that gets wet.
pub struct WetGround {
    job: Option<Wet>,
}

/// What a wetting ground needs.
struct Wet {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    params: wgpu::Buffer,
    canvas: wgpu::Texture,
    dry: wgpu::Texture,
    wetting: Wetting,
    optics: FilmOptics,
}

impl WetGround {
    /// Builds the pipeline and binds `r` for a ground wetting as `wetting`; nothing without one.
    pub fn new(device: &wgpu::Device, r: &FrameResources, wetting: Option<&Wetting>) -> WetGround {
        let job = wetting.filter(|w| w.ever_wet()).map(|wetting| {
            let canvas = r.canvas.texture().clone();
            let dry = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("dry_canvas"),
                size: canvas.size(),
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: canvas.format(),
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            let params = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("wet_params"),
                size: std::mem::size_of::<WetParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let pipeline = super::compute_pipeline(device, Stage::WetGround, "main");
            let bind = bind_group(
                device,
                Stage::WetGround.name(),
                &pipeline.get_bind_group_layout(0),
                &[
                    buffer(&r.rain_params),
                    buffer(&params),
                    view(&dry.create_view(&Default::default())),
                    view(&r.canvas),
                    buffer(&r.scene_depth),
                ],
            );
            Wet {
                pipeline,
                bind,
                params,
                canvas,
                dry,
                wetting: wetting.clone(),
                optics: FilmOptics::water(),
            }
        });
        WetGround { job }
    }
}

impl FrameStage for WetGround {
    fn name(&self) -> &'static str {
        Stage::WetGround.name()
    }

    fn runs(&self) -> bool {
        self.job.is_some()
    }

    fn prepare(&self, queue: &wgpu::Queue, rain: &RainParams) {
        if let Some(job) = &self.job {
            let t_s = rain.time_whole_s as f64 + rain.time_frac_s as f64;
            let params = WetParams::new(
                job.wetting.wetness_at(t_s),
                &job.optics,
                job.wetting.reach_m,
            );
            queue.write_buffer(&job.params, 0, bytemuck::bytes_of(&params));
        }
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timestamps: Option<TimestampSlot<'_>>) {
        let Some(job) = &self.job else { return };
        encoder.copy_texture_to_texture(
            job.canvas.as_image_copy(),
            job.dry.as_image_copy(),
            job.canvas.size(),
        );
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(self.name()),
            timestamp_writes: timestamps.map(TimestampSlot::compute),
        });
        pass.set_pipeline(&job.pipeline);
        pass.set_bind_group(0, &job.bind, &[]);
        let size = job.canvas.size();
        pass.dispatch_workgroups(
            workgroups(size.width, PIXEL_WORKGROUP),
            workgroups(size.height, PIXEL_WORKGROUP),
            1,
        );
    }
}
