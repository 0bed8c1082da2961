//! Stage `rain_probe`: drop states written to a buffer, the GPU side of the drop twin test and
//! of `inspect` (`shaders/rain_probe.wgsl`; CPU twin [`crate::rain::volume::sample_drop`]).

use super::{TimestampSlot, workgroups};
use crate::gpu::bind::{bind_group, buffer};
use crate::gpu::shaders::Stage;

/// Bytes per drop in the output: (pos, diameter), (velocity, width) as two `vec4<f32>`.
pub const BYTES_PER_DROP: u64 = 32;

/// The stage over explicit buffers.
pub struct RainProbe {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
}

impl RainProbe {
    /// Binds the uniforms, columns and output buffer.
    pub fn new(
        device: &wgpu::Device,
        rain_params: &wgpu::Buffer,
        columns: &wgpu::Buffer,
        out: &wgpu::Buffer,
    ) -> RainProbe {
        let pipeline = super::compute_pipeline(device, Stage::RainProbe, "main");
        let bind = bind_group(
            device,
            Stage::RainProbe.name(),
            &pipeline.get_bind_group_layout(0),
            &[buffer(rain_params), buffer(columns), buffer(out)],
        );
        RainProbe { pipeline, bind }
    }

    /// Records the pass for `drops` drops.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamps: Option<TimestampSlot<'_>>,
        drops: u32,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(Stage::RainProbe.name()),
            timestamp_writes: timestamps.map(TimestampSlot::compute),
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.dispatch_workgroups(workgroups(drops, super::rain_simulate::WORKGROUP), 1, 1);
    }
}
