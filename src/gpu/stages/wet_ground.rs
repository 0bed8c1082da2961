//! Stage `wet_ground`: the ground below the horizon darkens and gains a sheen as it wets
//! (`shaders/wet_ground.wgsl`; CPU twin [`crate::gpu::cpu::wet_ground`]). It reads the dry
//! scene from the decoded planes and writes the wet ground on the canvas (or, for the rain as
//! a layer, its premultiplied colour and alpha); pixels it does not touch (the horizon and
//! above) keep their value bit for bit. The wetness keeps to the ground mask
//! (`FrameResources::ground_mask`); the lamps' glow `yuv_to_rgb` put on the ground is read
//! back from its grid (`FrameResources::glow_grid`) and kept.

use super::{FrameResources, FrameStage, PIXEL_WORKGROUP, TimestampSlot, workgroups};
use crate::gpu::bind::{bind_group, buffer, view};
use crate::gpu::shaders::Stage;
use crate::gpu::types::{RainParams, WetParams};
use crate::lighting::wetness::{FilmOptics, Wetting};

/// The stage; it has work only where the job has a ground that gets wet.
pub struct WetGround {
    job: Option<Wet>,
}

/// What a wetting ground needs.
struct Wet {
    /// The pipeline, its bindings, its uniforms' buffer and the frame's size; `None` on the
    /// CPU back end, which reads the uniforms from [`WetGround::params_at`].
    pass: Option<(
        wgpu::ComputePipeline,
        wgpu::BindGroup,
        wgpu::Buffer,
        (u32, u32),
    )>,
    wetting: Wetting,
    optics: FilmOptics,
}

impl WetGround {
    /// Builds the pipeline and binds `r` for a ground wetting as `wetting`; nothing without one.
    /// With `layer`, the wet ground is written as the layer's premultiplied colour and alpha.
    /// Without `r` (the CPU back end draws it) no pipeline is built.
    pub fn new(
        device: &wgpu::Device,
        r: Option<&FrameResources>,
        wetting: Option<&Wetting>,
        layer: bool,
    ) -> WetGround {
        let job = wetting.filter(|w| w.ever_wet()).map(|wetting| {
            let pass = r.map(|r| {
                let params = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("wet_params"),
                    size: std::mem::size_of::<WetParams>() as u64,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                let entry = if layer { "layer" } else { "main" };
                let pipeline = super::compute_pipeline(device, Stage::WetGround, entry);
                let bind = bind_group(
                    device,
                    Stage::WetGround.name(),
                    &pipeline.get_bind_group_layout(0),
                    &[
                        buffer(&r.rain_params),
                        buffer(&params),
                        buffer(&r.frame_params),
                        view(&r.planes[0]),
                        view(&r.planes[1]),
                        view(&r.planes[2]),
                        view(&r.canvas),
                        buffer(&r.scene_depth),
                        buffer(&r.ground_mask),
                        buffer(&r.lights.list),
                        view(&r.glow_grid),
                    ],
                );
                (pipeline, bind, params, (r.frame.width, r.frame.height))
            });
            Wet {
                pass,
                wetting: wetting.clone(),
                optics: FilmOptics::water(),
            }
        });
        WetGround { job }
    }

    /// The uniforms of the frame of `rain`, or `None` where the ground never wets (the stage
    /// does not run; the CPU back end reads them here).
    pub fn params_at(&self, rain: &RainParams) -> Option<WetParams> {
        let job = self.job.as_ref()?;
        let t_s = rain.time_whole_s as f64 + rain.time_frac_s as f64;
        Some(WetParams::new(
            job.wetting.wetness_at(t_s),
            &job.optics,
            job.wetting.reach_m,
        ))
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
        let pass = self.job.as_ref().and_then(|j| j.pass.as_ref());
        if let (Some((_, _, buffer, _)), Some(params)) = (pass, self.params_at(rain)) {
            queue.write_buffer(buffer, 0, bytemuck::bytes_of(&params));
        }
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timestamps: Option<TimestampSlot<'_>>) {
        let Some((pipeline, bind, _, size)) = self.job.as_ref().and_then(|j| j.pass.as_ref())
        else {
            return;
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(self.name()),
            timestamp_writes: timestamps.map(TimestampSlot::compute),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.dispatch_workgroups(
            workgroups(size.0, PIXEL_WORKGROUP),
            workgroups(size.1, PIXEL_WORKGROUP),
            1,
        );
    }
}
