//! The splashes on the CPU back end: the `rain_splashes` stage's compute half runs on the
//! adapter (one invocation per landing drop, no canvas) while the CPU lays the plate; its draw
//! list (the drawn splash streaks, packed in slot order) is read back, its length first and then
//! only the streaks it holds, and drawn on the CPU as capsules before the drops' streaks
//! ([`super::streaks`]), as the stage draws them before `rain_streaks`.

use std::sync::mpsc;

use crate::gpu::stages::TimestampSlot;
use crate::gpu::stages::rain_splashes::SplashSimulate;
use crate::gpu::types::Streak;
use crate::{Error, Result};

/// The readbacks of one frame's splashes: the draw list's arguments (and the pass's two
/// timestamps), then its streaks.
pub struct HostSplashes {
    args: wgpu::Buffer,
    list: wgpu::Buffer,
}

/// The splashes submitted, their draw list's length mapped when they are done.
pub struct Pending {
    submission: wgpu::SubmissionIndex,
    mapped: mpsc::Receiver<std::result::Result<(), wgpu::BufferAsyncError>>,
    timed: bool,
}

impl HostSplashes {
    /// The readbacks for the splashes of `simulate`.
    pub fn new(device: &wgpu::Device, simulate: &SplashSimulate) -> HostSplashes {
        let buffer = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        HostSplashes {
            args: buffer("splash_args_readback", 32),
            list: buffer("splash_readback", simulate.drawn.size()),
        }
    }

    /// Submits `simulate` for the frame whose uniforms are already written, timed in slot
    /// `timestamps` (with the buffer its two queries resolve into) where given.
    pub fn submit(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        simulate: &SplashSimulate,
        timestamps: Option<(TimestampSlot<'_>, &wgpu::Buffer)>,
    ) -> Pending {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("rain_splashes"),
        });
        simulate.record(
            &mut encoder,
            timestamps.map(|(t, _)| wgpu::ComputePassTimestampWrites {
                query_set: t.set,
                beginning_of_pass_write_index: Some(2 * t.slot),
                end_of_pass_write_index: Some(2 * t.slot + 1),
            }),
        );
        encoder.copy_buffer_to_buffer(&simulate.draw_args, 0, &self.args, 0, 16);
        if let Some((slot, resolve)) = timestamps {
            let first = 2 * slot.slot;
            encoder.resolve_query_set(slot.set, first..first + 2, resolve, 0);
            encoder.copy_buffer_to_buffer(resolve, 0, &self.args, 16, 16);
        }
        let (tx, rx) = mpsc::channel();
        encoder.map_buffer_on_submit(&self.args, wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        Pending {
            submission: queue.submit([encoder.finish()]),
            mapped: rx,
            timed: timestamps.is_some(),
        }
    }

    /// Waits for `pending`, reads back the streaks its draw list holds and hands them to
    /// `draw`; returns what `draw` returns and the splash pass's GPU time in ticks, where it
    /// was timed.
    pub fn receive<T>(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        simulate: &SplashSimulate,
        pending: Pending,
        draw: impl FnOnce(&[Streak]) -> T,
    ) -> Result<(T, Option<u64>)> {
        wait(device, pending.submission, pending.mapped, "the splashes")?;
        let (count, span) = {
            let view = self
                .args
                .get_mapped_range(..)
                .map_err(|e| Error::Gpu(format!("readback: {e}")))?;
            let word =
                |k: usize| u32::from_le_bytes(view[4 * k..4 * k + 4].try_into().unwrap_or([0; 4]));
            let tick = |k: usize| {
                u64::from_le_bytes(view[16 + 8 * k..24 + 8 * k].try_into().unwrap_or([0; 8]))
            };
            (
                word(1) as u64,
                pending.timed.then(|| tick(1).saturating_sub(tick(0))),
            )
        };
        self.args.unmap();
        let bytes = (count * std::mem::size_of::<Streak>() as u64).min(self.list.size());
        if bytes == 0 {
            return Ok((draw(&[]), span));
        }
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("splash_readback"),
        });
        encoder.copy_buffer_to_buffer(&simulate.drawn, 0, &self.list, 0, bytes);
        let (tx, rx) = mpsc::channel();
        encoder.map_buffer_on_submit(&self.list, wgpu::MapMode::Read, ..bytes, move |r| {
            let _ = tx.send(r);
        });
        let submission = queue.submit([encoder.finish()]);
        wait(device, submission, rx, "the splash list")?;
        let result = {
            let view = self
                .list
                .get_mapped_range(..bytes)
                .map_err(|e| Error::Gpu(format!("readback: {e}")))?;
            // Mapped memory is aligned for any `Pod`; copied where it is not.
            let streaks: std::borrow::Cow<[Streak]> = bytemuck::try_cast_slice(&view)
                .map_or_else(|_| bytemuck::pod_collect_to_vec(&view).into(), Into::into);
            draw(&streaks)
        };
        self.list.unmap();
        Ok((result, span))
    }
}

/// Waits for `submission` and its mapping.
fn wait(
    device: &wgpu::Device,
    submission: wgpu::SubmissionIndex,
    mapped: mpsc::Receiver<std::result::Result<(), wgpu::BufferAsyncError>>,
    what: &str,
) -> Result<()> {
    device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(submission),
            timeout: None,
        })
        .map_err(|e| Error::Gpu(format!("waiting for {what}: {e}")))?;
    mapped
        .recv()
        .map_err(|_| Error::Gpu("readback callback dropped".into()))?
        .map_err(|e| Error::Gpu(format!("readback of {what}: {e}")))
}
