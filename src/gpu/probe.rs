//! Runs the `rain_probe` stage: drop states computed on the GPU, read back. Used by the
//! GPU-against-CPU-twin tests and by `inspect drops`. [`probe_streaks`] does the same for the
//! `rain_simulate` stage (streak geometry and light).

use glam::Vec3;
use wgpu::util::DeviceExt;

use super::GpuContext;
use super::lights::DirectLightBuffers;
use super::stages::rain_probe::{BYTES_PER_DROP, RainProbe};
use super::stages::rain_simulate::RainSimulate;
use super::types::{GLINTS_PER_DROP, Glint, LightList, RainParams, Streak};
use super::uniforms::RainSetup;
use crate::lighting::RtfTable;
use crate::{Error, Result};

/// One drop as the GPU computed it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpuDrop {
    /// Position, world metres.
    pub pos_m: Vec3,
    /// Velocity, m/s.
    pub vel_mps: Vec3,
    /// Drawn diameter, mm; −1 for a drop a keyed rate leaves out of its current pass.
    pub diameter_mm: f32,
    /// Drawn horizontal diameter (the streak's width), mm.
    pub width_mm: f32,
}

/// States of the first `count` drops of `setup` at `time_s`, as the GPU computes them.
pub fn probe_drops(
    ctx: &GpuContext,
    setup: &RainSetup,
    time_s: f64,
    count: u32,
) -> Result<Vec<GpuDrop>> {
    probe_drops_with(ctx, setup, &setup.motion_at(time_s), count)
}

/// States of the first `count` drops of `setup` under the uniforms `params`.
pub fn probe_drops_with(
    ctx: &GpuContext,
    setup: &RainSetup,
    params: &RainParams,
    count: u32,
) -> Result<Vec<GpuDrop>> {
    let device = &ctx.device;
    let mut params = *params;
    params.drop_count = count.min(setup.params.drop_count);
    let n = params.drop_count.max(1) as u64;
    let uniform = params_buffer(device, &params);
    let columns = columns_buffer(device, setup);
    let size = n * BYTES_PER_DROP;
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe_out"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let stage = RainProbe::new(device, &uniform, &columns, &out);
    let bytes = run_and_read(
        ctx,
        |encoder| stage.record(encoder, None, n as u32),
        &out,
        size,
    )?;
    let floats: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes);
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

/// Each drop's streak and glints from `rain_simulate`'s `main_mattes` (its
/// [`GLINTS_PER_DROP`] strongest compact lights taken out of the streak for their point-light
/// mattes, `GLINTS_PER_DROP` per drop), for `params.drop_count` drops.
pub fn probe_streaks_and_glints(
    ctx: &GpuContext,
    setup: &RainSetup,
    params: &RainParams,
    lights: &LightList,
    tables: &[RtfTable; 3],
) -> Result<(Vec<Streak>, Vec<Glint>)> {
    let device = &ctx.device;
    let drops = params.drop_count.max(1);
    let uniform = params_buffer(device, params);
    let columns = columns_buffer(device, setup);
    let direct = lit_by(ctx, lights, tables);
    let out = |label, size: usize| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: drops as u64 * size as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    };
    let streaks = out("rain_streaks", std::mem::size_of::<Streak>());
    let glints = out("glints", GLINTS_PER_DROP * std::mem::size_of::<Glint>());
    let stage = RainSimulate::with_buffers(
        device,
        &uniform,
        &columns,
        &streaks,
        &direct,
        Some(&glints),
        drops,
    );
    let read = |buffer: &wgpu::Buffer, size: usize| {
        run_and_read(
            ctx,
            |encoder| stage.record_drops(encoder, None, drops),
            buffer,
            drops as u64 * size as u64,
        )
    };
    let s = read(&streaks, std::mem::size_of::<Streak>())?;
    let g = read(&glints, GLINTS_PER_DROP * std::mem::size_of::<Glint>())?;
    let n = params.drop_count as usize;
    Ok((
        bytemuck::pod_collect_to_vec::<u8, Streak>(&s)
            .into_iter()
            .take(n)
            .collect(),
        bytemuck::pod_collect_to_vec::<u8, Glint>(&g)
            .into_iter()
            .take(GLINTS_PER_DROP * n)
            .collect(),
    ))
}

/// The `rain_simulate` stage set up once for repeated runs (tests and timing).
pub struct SimulateProbe {
    stage: RainSimulate,
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
        let columns = columns_buffer(device, setup);
        let direct = DirectLightBuffers::new(device);
        direct.upload_table(&ctx.queue, tables);
        let out = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain_streaks"),
            size: capacity as u64 * std::mem::size_of::<Streak>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let stage =
            RainSimulate::with_buffers(device, &uniform, &columns, &out, &direct, None, capacity);
        SimulateProbe {
            stage,
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
        let drops = params.drop_count.max(1);
        let bytes = run_and_read(
            ctx,
            |encoder| self.stage.record_drops(encoder, None, drops),
            &self.out,
            size,
        )?;
        Ok(bytemuck::pod_collect_to_vec::<u8, Streak>(&bytes)
            .into_iter()
            .take(params.drop_count as usize)
            .collect())
    }
}

/// Records a stage with `record`, runs it and reads `out` back.
fn run_and_read(
    ctx: &GpuContext,
    record: impl FnOnce(&mut wgpu::CommandEncoder),
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
    record(&mut encoder);
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

/// The splash streaks `rain_splashes` writes under the uniforms `params` for the landing drops
/// of `setup` (with its ground), lit also by `lights` through `tables`: the landing drops' ids
/// and `SPLASH_SLOTS` streaks per drop.
pub fn probe_splashes(
    ctx: &GpuContext,
    setup: &RainSetup,
    params: &RainParams,
    lights: &LightList,
    tables: &[RtfTable; 3],
) -> Result<(Vec<u32>, Vec<Streak>)> {
    let (stage, _inputs) = splash_stage(ctx, setup, params, lights, tables);
    let size = stage.splashes.size();
    let bytes = run_and_read(
        ctx,
        |encoder| stage.record(encoder, None),
        &stage.splashes,
        size,
    )?;
    let streaks = bytemuck::pod_collect_to_vec::<u8, Streak>(&bytes);
    Ok((stage.drop_ids, streaks))
}

/// The draw list `rain_splashes` packs from the slots [`probe_splashes`] reads: the streaks the
/// rasteriser draws, in order, as many as the instance count of its indirect draw.
pub fn probe_splash_draw_list(
    ctx: &GpuContext,
    setup: &RainSetup,
    params: &RainParams,
    lights: &LightList,
    tables: &[RtfTable; 3],
) -> Result<Vec<Streak>> {
    let (stage, _inputs) = splash_stage(ctx, setup, params, lights, tables);
    let args = run_and_read(ctx, |e| stage.record(e, None), &stage.draw_args, 16)?;
    let instances = u32::from_le_bytes([args[4], args[5], args[6], args[7]]) as u64;
    if instances == 0 {
        return Ok(Vec::new());
    }
    let size = instances * std::mem::size_of::<Streak>() as u64;
    let bytes = run_and_read(ctx, |e| stage.record(e, None), &stage.drawn, size)?;
    Ok(bytemuck::pod_collect_to_vec::<u8, Streak>(&bytes))
}

/// The splash stage for `setup` under `params`, and the inputs it binds.
fn splash_stage(
    ctx: &GpuContext,
    setup: &RainSetup,
    params: &RainParams,
    lights: &LightList,
    tables: &[RtfTable; 3],
) -> (
    super::stages::rain_splashes::SplashSimulate,
    (wgpu::Buffer, wgpu::Buffer, DirectLightBuffers),
) {
    use super::stages::rain_splashes::SplashSimulate;
    let device = &ctx.device;
    let uniform = params_buffer(device, params);
    let columns = columns_buffer(device, setup);
    let direct = lit_by(ctx, lights, tables);
    let stage = SplashSimulate::new(device, &uniform, &columns, &direct, setup);
    (stage, (uniform, columns, direct))
}

/// The `RainParams` uniform holding `params`.
fn params_buffer(device: &wgpu::Device, params: &RainParams) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("rain_params"),
        contents: bytemuck::bytes_of(params),
        usage: wgpu::BufferUsages::UNIFORM,
    })
}

/// The rain volume's columns of `setup`.
fn columns_buffer(device: &wgpu::Device, setup: &RainSetup) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("rain_columns"),
        contents: bytemuck::cast_slice(&setup.columns),
        usage: wgpu::BufferUsages::STORAGE,
    })
}

/// The direct light term's inputs: the transfer `tables` and the compact `lights`.
fn lit_by(ctx: &GpuContext, lights: &LightList, tables: &[RtfTable; 3]) -> DirectLightBuffers {
    let direct = DirectLightBuffers::new(&ctx.device);
    direct.upload_table(&ctx.queue, tables);
    direct.upload_lights(&ctx.queue, lights);
    direct
}
