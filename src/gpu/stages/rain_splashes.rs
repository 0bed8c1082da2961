//! Stage `rain_splashes`: with a ground, each drop of a column standing on the ground → the
//! streaks of its latest splash (`shaders/rain_splashes.wgsl`; CPU twin
//! [`crate::gpu::cpu::rain_splashes`]), then those streaks rasterised onto the canvas by the
//! `rain_streaks` pipeline, in drop order, before the drops' own streaks (splashes are on the
//! ground, behind the rain falling in front of them). Without a ground it does not run.

use wgpu::util::DeviceExt;

use super::rain_streaks::RainStreaks;
use super::{FrameResources, FrameStage, TimestampSlot, workgroups};
use crate::gpu::bind::{bind_group, buffer};
use crate::gpu::lights::DirectLightBuffers;
use crate::gpu::shaders::Stage;
use crate::gpu::types::Streak;
use crate::gpu::uniforms::RainSetup;
use crate::rain::physics::splash::SPLASH_SLOTS;
use crate::rain::volume::landing_columns;

/// Drops per workgroup (`SIMULATE_WORKGROUP` in the WGSL).
pub const WORKGROUP: u32 = super::rain_simulate::WORKGROUP;

/// The columns standing on the ground as the stage reads them: (column index, index of the
/// column's first drop among the landing drops), and the number of landing drops, at most
/// `max_drops`.
pub fn landing_list(rain: &RainSetup, max_drops: u64) -> (Vec<[u32; 2]>, u32) {
    let mut list = Vec::new();
    let mut total = 0u64;
    for ci in landing_columns(&rain.volume) {
        let count = rain.volume.grid.columns[ci].count as u64;
        if total + count > max_drops {
            break;
        }
        list.push([ci as u32, total as u32]);
        total += count;
    }
    (list, total as u32)
}

/// The compute half: landing drops → their splashes' streaks, `SPLASH_SLOTS` per drop.
pub struct SplashSimulate {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    /// The splashes' streaks, drop after drop (slot 0 the crown, then the droplets).
    pub splashes: wgpu::Buffer,
    /// The landing drops, in order (the g-th has its streaks at g·`SPLASH_SLOTS`).
    pub drop_ids: Vec<u32>,
}

impl SplashSimulate {
    /// The pipeline and buffers for the landing drops of `rain` (none without a ground), with
    /// the uniforms `rain_params`, the columns `columns` and the compact lights `lights`.
    pub fn new(
        device: &wgpu::Device,
        rain_params: &wgpu::Buffer,
        columns: &wgpu::Buffer,
        lights: &DirectLightBuffers,
        rain: &RainSetup,
    ) -> SplashSimulate {
        let limits = device.limits();
        let bytes = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let per_drop = SPLASH_SLOTS as u64 * std::mem::size_of::<Streak>() as u64;
        let by_dispatch =
            u64::from(limits.max_compute_workgroups_per_dimension) * u64::from(WORKGROUP);
        let (list, drops) = if rain.params.ground_clip != 0 {
            landing_list(rain, (bytes / per_drop).min(by_dispatch))
        } else {
            (Vec::new(), 0)
        };
        let drop_ids = list
            .iter()
            .flat_map(|&[ci, _]| {
                let c = &rain.columns[ci as usize];
                c.first_drop..c.first_drop + c.drop_count
            })
            .take(drops as usize)
            .collect();
        let landing = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("splash_landing"),
            contents: bytemuck::cast_slice(if list.is_empty() { &[[0u32; 2]] } else { &list }),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let splashes = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("splash_streaks"),
            size: per_drop * drops.max(1) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let pipeline = super::compute_pipeline(device, Stage::RainSplashes, "main");
        let bind = bind_group(
            device,
            Stage::RainSplashes.name(),
            &pipeline.get_bind_group_layout(0),
            &[
                buffer(rain_params),
                buffer(columns),
                buffer(&landing),
                buffer(&splashes),
                buffer(&lights.list),
                buffer(&lights.table),
            ],
        );
        SplashSimulate {
            pipeline,
            bind,
            splashes,
            drop_ids,
        }
    }

    /// Landing drops handled.
    pub fn drops(&self) -> u32 {
        self.drop_ids.len() as u32
    }

    /// Records the compute pass.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(Stage::RainSplashes.name()),
            timestamp_writes,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.dispatch_workgroups(workgroups(self.drops(), WORKGROUP), 1, 1);
    }
}

/// The stage: the splashes' streaks, then their draw.
pub struct RainSplashes {
    simulate: SplashSimulate,
    draw: RainStreaks,
}

impl RainSplashes {
    /// Builds the pipelines and buffers for the landing drops of `rain` and binds `r`.
    pub fn new(device: &wgpu::Device, r: &FrameResources, rain: &RainSetup) -> RainSplashes {
        let simulate = SplashSimulate::new(device, &r.rain_params, &r.columns, &r.lights, rain);
        let draw = RainStreaks::with_streaks(
            device,
            r,
            &simulate.splashes,
            simulate.drops() * SPLASH_SLOTS,
            None,
        );
        RainSplashes { simulate, draw }
    }
}

impl FrameStage for RainSplashes {
    fn name(&self) -> &'static str {
        Stage::RainSplashes.name()
    }

    fn runs(&self) -> bool {
        self.simulate.drops() > 0
    }

    /// Timed from the compute pass's start to the draw's end.
    fn record(&self, encoder: &mut wgpu::CommandEncoder, timestamps: Option<TimestampSlot<'_>>) {
        self.simulate.record(
            encoder,
            timestamps.map(|t| wgpu::ComputePassTimestampWrites {
                query_set: t.set,
                beginning_of_pass_write_index: Some(2 * t.slot),
                end_of_pass_write_index: None,
            }),
        );
        self.draw.draw(
            encoder,
            timestamps.map(|t| wgpu::RenderPassTimestampWrites {
                query_set: t.set,
                beginning_of_pass_write_index: None,
                end_of_pass_write_index: Some(2 * t.slot + 1),
            }),
        );
    }
}
