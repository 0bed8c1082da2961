//! Stage `rain_splashes`: with a ground, each drop of a column standing on the ground → the
//! streaks of its latest splash (`shaders/rain_splashes.wgsl`; CPU twin
//! [`crate::gpu::cpu::rain_splashes`]), then those streaks rasterised onto the canvas by the
//! `rain_streaks` pipeline, in drop order, before the drops' own streaks (splashes are on the
//! ground, behind the rain falling in front of them). Without a ground it does not run.
//!
//! Nearly every slot is empty (a splash lives a tenth of a second of its drop's seconds-long
//! fall), so the drawn streaks are first packed, in order, into a draw list whose length the
//! GPU writes as the instance count of an indirect draw: the rasteriser runs over the splashes
//! that show, not over every slot, and the canvas is the same bit for bit.

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

/// The compute half: landing drops → their splashes' streaks, `SPLASH_SLOTS` per drop, then
/// the draw list of those drawn.
pub struct SplashSimulate {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    /// The packing passes (`count_drawn`, `offset_blocks`, `pack_drawn`) and their bindings.
    pack: [(wgpu::ComputePipeline, wgpu::BindGroup); 3],
    /// The splashes' streaks, drop after drop (slot 0 the crown, then the droplets).
    pub splashes: wgpu::Buffer,
    /// The drawn streaks of `splashes`, in their order, packed to the front.
    pub drawn: wgpu::Buffer,
    /// `draw_indirect`'s arguments: a quad's vertices, as many instances as `drawn` holds.
    pub draw_args: wgpu::Buffer,
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
        let drawn = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("splash_draw_list"),
            size: splashes.size(),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let draw_args = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("splash_draw_args"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::INDIRECT
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let block_offsets = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("splash_block_offsets"),
            size: 4 * u64::from(workgroups(drops, WORKGROUP)),
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        // Each packing pass binds only what it uses (its layout is derived from its entry).
        let pack = [
            ("count_drawn", vec![(3, &splashes), (6, &block_offsets)]),
            ("offset_blocks", vec![(6, &block_offsets), (8, &draw_args)]),
            (
                "pack_drawn",
                vec![(3, &splashes), (6, &block_offsets), (7, &drawn)],
            ),
        ]
        .map(|(entry, buffers)| {
            let pipeline = super::compute_pipeline(device, Stage::RainSplashes, entry);
            let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
                .iter()
                .map(|&(binding, b)| wgpu::BindGroupEntry {
                    binding,
                    resource: buffer(b),
                })
                .collect();
            let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(entry),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &entries,
            });
            (pipeline, bind)
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
            pack,
            splashes,
            drawn,
            draw_args,
            drop_ids,
        }
    }

    /// Landing drops handled.
    pub fn drops(&self) -> u32 {
        self.drop_ids.len() as u32
    }

    /// Records the compute pass: the splashes, then their draw list.
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
        let blocks = workgroups(self.drops(), WORKGROUP);
        pass.dispatch_workgroups(blocks, 1, 1);
        // Each dispatch sees the storage written by the one before.
        for ((pipeline, bind), groups) in self.pack.iter().zip([blocks, 1, blocks]) {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind, &[]);
            pass.dispatch_workgroups(groups, 1, 1);
        }
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
            &simulate.drawn,
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
        self.draw.draw_indirect(
            encoder,
            timestamps.map(|t| wgpu::RenderPassTimestampWrites {
                query_set: t.set,
                beginning_of_pass_write_index: None,
                end_of_pass_write_index: Some(2 * t.slot + 1),
            }),
            &self.simulate.draw_args,
        );
    }
}
