//! Runs the `rain_probe` stage: drop states computed on the GPU, read back. Used by the
//! GPU-against-CPU-twin tests and by `inspect drops`. [`probe_streaks`] does the same for the
//! `rain_simulate` stage (streak geometry and light).

use glam::Vec3;
use wgpu::util::DeviceExt;

use super::GpuContext;
use super::lights::DirectLightBuffers;
use super::shaders::Stage;
use super::types::{LightList, RainParams, Streak};
use crate::lighting::RtfTable;
use crate::rain::emitter::RainSetup;
use crate::{Error, Result};

/// One drop as the GPU computed it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpuDrop {
    /// Position, world metres.
    pub pos_m: Vec3,
    /// Velocity, m/s.
    pub vel_mps: Vec3,
    /// Drawn diameter, mm.
    pub diameter_mm: f32,
    /// Drawn horizontal diameter (the streak's width), mm.
    pub width_mm: f32,
}

/// States of the first `count` drops of `setup` at `time_s`, as the GPU computes them.
pub fn probe_drops(
    ctx: &GpuContext,
    setup: &RainSetup,
    time_s: f32,
    count: u32,
) -> Result<Vec<GpuDrop>> {
    let device = &ctx.device;
    let mut params = setup.motion_at(time_s as f64);
    params.drop_count = count.min(setup.params.drop_count);
    let n = params.drop_count.max(1) as u64;
    let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("rain_params"),
        contents: bytemuck::bytes_of(&params),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let columns = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("rain_columns"),
        contents: bytemuck::cast_slice(&setup.columns),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = n * 32;
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe_out"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let read = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe_read"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let module = Stage::RainProbe.module(device);
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(Stage::RainProbe.name()),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("rain_probe"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: columns.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: out.as_entire_binding(),
            },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups((n as u32).div_ceil(64), 1, 1);
    }
    encoder.copy_buffer_to_buffer(&out, 0, &read, 0, size);
    let (tx, rx) = std::sync::mpsc::channel();
    encoder.map_buffer_on_submit(&read, wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    let submission = ctx.queue.submit([encoder.finish()]);
    device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(submission),
            timeout: None,
        })
        .map_err(|e| Error::Gpu(e.to_string()))?;
    rx.recv()
        .map_err(|_| Error::Gpu("probe readback dropped".into()))?
        .map_err(|e| Error::Gpu(e.to_string()))?;
    let view = read
        .get_mapped_range(..)
        .map_err(|e| Error::Gpu(e.to_string()))?;
    let floats: &[f32] = bytemuck::cast_slice(&view);
    let states = floats
        .chunks_exact(8)
        .take(params.drop_count as usize)
        .map(|c| GpuDrop {
            pos_m: Vec3::new(c[0], c[1], c[2]),
            vel_mps: Vec3::new(c[4], c[5], c[6]),
            diameter_mm: c[3],
            width_mm: c[7],
        })
        .collect();
    drop(view);
    read.unmap();
    Ok(states)
}

/// The streaks `rain_simulate` writes for the first `params.drop_count` drops of `setup` under
/// the uniforms `params`, lit also by `lights` through `tables`.
pub fn probe_streaks(
    ctx: &GpuContext,
    setup: &RainSetup,
    params: &RainParams,
    lights: &LightList,
    tables: &[RtfTable; 3],
) -> Result<Vec<Streak>> {
    SimulateProbe::new(ctx, setup, params.drop_count, tables).run(ctx, params, lights)
}

/// The `rain_simulate` stage set up once for repeated runs (tests and timing).
pub struct SimulateProbe {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    uniform: wgpu::Buffer,
    direct: DirectLightBuffers,
    out: wgpu::Buffer,
    capacity: u32,
}

impl SimulateProbe {
    /// The stage for up to `capacity` drops of `setup`, with the transfer table `tables`.
    pub fn new(
        ctx: &GpuContext,
        setup: &RainSetup,
        capacity: u32,
        tables: &[RtfTable; 3],
    ) -> SimulateProbe {
        let device = &ctx.device;
        let capacity = capacity.max(1);
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain_params"),
            size: std::mem::size_of::<RainParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let columns = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rain_columns"),
            contents: bytemuck::cast_slice(&setup.columns),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let direct = DirectLightBuffers::new(device);
        direct.upload_table(&ctx.queue, tables);
        let out = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain_streaks"),
            size: capacity as u64 * std::mem::size_of::<Streak>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let module = Stage::RainSimulate.module(device);
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(Stage::RainSimulate.name()),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("rain_simulate"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                entry(0, &uniform),
                entry(1, &columns),
                entry(2, &out),
                entry(3, &direct.list),
                entry(4, &direct.table),
            ],
        });
        SimulateProbe {
            pipeline,
            bind,
            uniform,
            direct,
            out,
            capacity,
        }
    }

    /// Runs the stage for `params.drop_count` drops (at most the capacity) and reads the
    /// streaks back.
    pub fn run(
        &self,
        ctx: &GpuContext,
        params: &RainParams,
        lights: &LightList,
    ) -> Result<Vec<Streak>> {
        let mut params = *params;
        params.drop_count = params.drop_count.min(self.capacity);
        ctx.queue
            .write_buffer(&self.uniform, 0, bytemuck::bytes_of(&params));
        self.direct.upload_lights(&ctx.queue, lights);
        let size = params.drop_count.max(1) as u64 * std::mem::size_of::<Streak>() as u64;
        let bytes = run_and_read(
            ctx,
            &self.pipeline,
            &self.bind,
            params.drop_count.max(1),
            &self.out,
            size,
        )?;
        Ok(bytemuck::pod_collect_to_vec::<u8, Streak>(&bytes)
            .into_iter()
            .take(params.drop_count as usize)
            .collect())
    }
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// Dispatches one thread per item (workgroups of 64) and reads `out` back.
fn run_and_read(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    bind: &wgpu::BindGroup,
    items: u32,
    out: &wgpu::Buffer,
    size: u64,
) -> Result<Vec<u8>> {
    let device = &ctx.device;
    let read = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe_read"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.dispatch_workgroups(items.div_ceil(64), 1, 1);
    }
    encoder.copy_buffer_to_buffer(out, 0, &read, 0, size);
    let (tx, rx) = std::sync::mpsc::channel();
    encoder.map_buffer_on_submit(&read, wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    let submission = ctx.queue.submit([encoder.finish()]);
    device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(submission),
            timeout: None,
        })
        .map_err(|e| Error::Gpu(e.to_string()))?;
    rx.recv()
        .map_err(|_| Error::Gpu("probe readback dropped".into()))?
        .map_err(|e| Error::Gpu(e.to_string()))?;
    let bytes = read
        .get_mapped_range(..)
        .map_err(|e| Error::Gpu(e.to_string()))?
        .to_vec();
    read.unmap();
    Ok(bytes)
}
