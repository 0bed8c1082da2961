//! Stage `rain_simulate`: each drop once per frame → its streak and light
//! (`shaders/rain_simulate.wgsl`; CPU twin [`crate::gpu::cpu::rain_simulate`]).

use super::{FrameResources, FrameStage, TimestampSlot, workgroups};
use crate::gpu::bind::{bind_group, buffer};
use crate::gpu::lights::DirectLightBuffers;
use crate::gpu::shaders::Stage;

/// Drops per workgroup (`SIMULATE_WORKGROUP` in the WGSL).
pub const WORKGROUP: u32 = 64;

/// The stage, bound to its buffers.
pub struct RainSimulate {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    drops: u32,
}

impl RainSimulate {
    /// Builds the pipeline and binds `r`.
    pub fn new(device: &wgpu::Device, r: &FrameResources) -> RainSimulate {
        RainSimulate::with_buffers(
            device,
            &r.rain_params,
            &r.columns,
            &r.streaks,
            &r.lights,
            r.glints.as_ref(),
            r.drop_count,
        )
    }

    /// The stage over explicit buffers (the probes use their own).
    pub fn with_buffers(
        device: &wgpu::Device,
        rain_params: &wgpu::Buffer,
        columns: &wgpu::Buffer,
        streaks: &wgpu::Buffer,
        lights: &DirectLightBuffers,
        glints: Option<&wgpu::Buffer>,
        drops: u32,
    ) -> RainSimulate {
        // With glints, the strongest lights of each drop leave the streak's colour for them.
        let entry = if glints.is_some() {
            "main_mattes"
        } else {
            "main"
        };
        let pipeline = super::compute_pipeline(device, Stage::RainSimulate, entry);
        let mut buffers = vec![
            buffer(rain_params),
            buffer(columns),
            buffer(streaks),
            buffer(&lights.list),
            buffer(&lights.table),
        ];
        buffers.extend(glints.map(buffer));
        let bind = bind_group(
            device,
            Stage::RainSimulate.name(),
            &pipeline.get_bind_group_layout(0),
            &buffers,
        );
        RainSimulate {
            pipeline,
            bind,
            drops,
        }
    }

    /// Records the pass for `drops` drops (at most the count it was built for).
    pub fn record_drops(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamps: Option<TimestampSlot<'_>>,
        drops: u32,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(self.name()),
            timestamp_writes: timestamps.map(TimestampSlot::compute),
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.dispatch_workgroups(workgroups(drops.min(self.drops), WORKGROUP), 1, 1);
    }
}

impl FrameStage for RainSimulate {
    fn name(&self) -> &'static str {
        Stage::RainSimulate.name()
    }

    fn runs(&self) -> bool {
        self.drops > 0
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timestamps: Option<TimestampSlot<'_>>) {
        self.record_drops(encoder, timestamps, self.drops);
    }
}
