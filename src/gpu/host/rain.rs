//! The rain of a frame on the CPU back end: the drops are simulated on the adapter
//! (`rain_simulate`, one invocation per drop) while the CPU lays the plate, their streaks (and
//! glints) copied into a mapped buffer and read back, then rasterised on the CPU
//! ([`super::streaks`]); the canvas never goes to the adapter.

use std::sync::Arc;
use std::sync::mpsc;

use crate::drops::MatteAtlas;
use crate::gpu::stages::{FrameStage, TimestampSlot};
use crate::gpu::types::{GLINTS_PER_DROP, Glint, RainParams, Streak};
use crate::{Error, Result};

/// The readback of one frame's streaks: the buffers it copies from and the one it maps.
pub struct HostRain {
    streaks: wgpu::Buffer,
    glints: Option<wgpu::Buffer>,
    /// Streaks, then glints, then the simulation's two timestamps.
    readback: wgpu::Buffer,
    streak_bytes: u64,
    glint_bytes: u64,
    mattes: Option<Arc<MatteAtlas>>,
}

/// A simulation submitted, its readback mapped when it is done.
pub struct Pending {
    submission: wgpu::SubmissionIndex,
    mapped: mpsc::Receiver<std::result::Result<(), wgpu::BufferAsyncError>>,
    timed: bool,
}

impl HostRain {
    /// The readback of `streaks` (and `glints`, where the streak mattes have point lights), for
    /// streaks drawn with `mattes` (`None`: capsules).
    pub fn new(
        device: &wgpu::Device,
        streaks: &wgpu::Buffer,
        glints: Option<&wgpu::Buffer>,
        mattes: Option<Arc<MatteAtlas>>,
    ) -> HostRain {
        let (streak_bytes, glint_bytes) = (streaks.size(), glints.map_or(0, wgpu::Buffer::size));
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("streak_readback"),
            size: streak_bytes + glint_bytes + 16,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        HostRain {
            streaks: streaks.clone(),
            glints: glints.cloned(),
            readback,
            streak_bytes,
            glint_bytes,
            mattes,
        }
    }

    /// The mattes the streaks are drawn with.
    pub fn mattes(&self) -> Option<&MatteAtlas> {
        self.mattes.as_deref()
    }

    /// Submits `simulate` for the frame of `rain` and the copy of its streaks, timed in slot
    /// `timestamps` (with the buffer its two queries resolve into) where given.
    pub fn submit(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        simulate: &dyn FrameStage,
        rain: &RainParams,
        timestamps: Option<(TimestampSlot<'_>, &wgpu::Buffer)>,
    ) -> Pending {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("rain_simulate"),
        });
        simulate.prepare(queue, rain);
        simulate.record(&mut encoder, timestamps.map(|(slot, _)| slot));
        encoder.copy_buffer_to_buffer(&self.streaks, 0, &self.readback, 0, self.streak_bytes);
        if let Some(glints) = &self.glints {
            encoder.copy_buffer_to_buffer(
                glints,
                0,
                &self.readback,
                self.streak_bytes,
                self.glint_bytes,
            );
        }
        if let Some((slot, resolve)) = timestamps {
            let first = 2 * slot.slot;
            encoder.resolve_query_set(slot.set, first..first + 2, resolve, 0);
            encoder.copy_buffer_to_buffer(
                resolve,
                0,
                &self.readback,
                self.streak_bytes + self.glint_bytes,
                16,
            );
        }
        let (tx, rx) = mpsc::channel();
        encoder.map_buffer_on_submit(&self.readback, wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        Pending {
            submission: queue.submit([encoder.finish()]),
            mapped: rx,
            timed: timestamps.is_some(),
        }
    }

    /// Waits for `pending` and hands `draw` the streaks and glints it read back; returns what
    /// `draw` returns and the simulation's GPU time in ticks, where it was timed.
    pub fn receive<T>(
        &self,
        device: &wgpu::Device,
        pending: Pending,
        draw: impl FnOnce(&[Streak], &[Glint]) -> T,
    ) -> Result<(T, Option<u64>)> {
        device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(pending.submission),
                timeout: None,
            })
            .map_err(|e| Error::Gpu(format!("waiting for the drops: {e}")))?;
        pending
            .mapped
            .recv()
            .map_err(|_| Error::Gpu("readback callback dropped".into()))?
            .map_err(|e| Error::Gpu(format!("readback of the drops: {e}")))?;
        let result = {
            let view = self
                .readback
                .get_mapped_range(..)
                .map_err(|e| Error::Gpu(format!("readback: {e}")))?;
            let (s, rest) = view.split_at(self.streak_bytes as usize);
            let (g, ticks) = rest.split_at(self.glint_bytes as usize);
            // Mapped memory is aligned for any `Pod`; copied where it is not.
            let streaks: std::borrow::Cow<[Streak]> = bytemuck::try_cast_slice(s)
                .map_or_else(|_| bytemuck::pod_collect_to_vec(s).into(), Into::into);
            let glints: std::borrow::Cow<[Glint]> = bytemuck::try_cast_slice(g)
                .map_or_else(|_| bytemuck::pod_collect_to_vec(g).into(), Into::into);
            debug_assert!(glints.is_empty() || glints.len() == GLINTS_PER_DROP * streaks.len());
            let word =
                |k: usize| u64::from_le_bytes(ticks[8 * k..8 * k + 8].try_into().unwrap_or([0; 8]));
            let span = pending.timed.then(|| word(1).saturating_sub(word(0)));
            (draw(&streaks, &glints), span)
        };
        self.readback.unmap();
        Ok(result)
    }
}
