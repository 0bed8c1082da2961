//! A frame on the CPU back end, whole: with a ground the splashes simulated on the adapter
//! while the CPU lays the plate with the wet ground fused in and shades the puddles, the drops
//! simulated on the CPU, then the splashes' streaks read back and drawn, the drops' drawn, and
//! the canvas packed. The canvas never goes to the adapter, a frame without splashes does not
//! touch it at all, and the frame is done when `submit` returns.

use super::Compositor;
use crate::gpu::host::GroundFrame;
use crate::gpu::stages::rain_splashes::RainSplashes;
use crate::gpu::stages::wet_ground::WetGround;
use crate::gpu::stages::{FrameStage, TimestampSlot, puddles::Puddles};
use crate::gpu::types::RainParams;
use crate::video::{Rendered, YuvFrame};
use crate::{Error, Result};

/// The stage of type `T` among `stages` that runs, with its timestamp slot.
fn running<T: FrameStage>(stages: &[Box<dyn FrameStage>]) -> Option<(usize, &T)> {
    stages.iter().enumerate().find_map(|(slot, s)| {
        let any = s.as_ref() as &dyn std::any::Any;
        any.downcast_ref::<T>()
            .filter(|s| s.runs())
            .map(|s| (slot, s))
    })
}

/// The splash stage among `stages`, where it runs.
pub(super) fn splash_stage(stages: &[Box<dyn FrameStage>]) -> Option<&RainSplashes> {
    running::<RainSplashes>(stages).map(|(_, s)| s)
}

impl Compositor {
    /// Whether frames are rendered on the CPU back end ([`Compositor::render_on_host`]): every
    /// picture frame there is, whatever its ground, water or splashes.
    pub(super) fn drawn_on_host(&self) -> bool {
        self.host_rain.is_some()
    }

    /// The frame rendered on the CPU back end (see the module's comment).
    pub(super) fn render_on_host(
        &mut self,
        frame: &YuvFrame,
        rain: &RainParams,
    ) -> Result<Rendered> {
        let splashing =
            running::<RainSplashes>(&self.stages).is_some() && self.host_splashes.is_some();
        if splashing {
            // The splashes' simulation reads the uniforms and the held lights, depth and masks.
            self.write_stale();
            let queue = &self.ctx.queue;
            queue.write_buffer(&self.rain_buffer, 0, bytemuck::bytes_of(rain));
        }
        let (Some(host), Some(drops)) = (&mut self.host, &mut self.host_rain) else {
            return Err(Error::Gpu("no CPU back end".into()));
        };
        let (device, queue) = (&self.ctx.device, &self.ctx.queue);
        let timestamps = |slot: usize| {
            self.timestamps.as_ref().map(|(set, resolve)| {
                let slot = slot as u32;
                (TimestampSlot { set, slot }, resolve)
            })
        };
        let stages = &self.stages;
        let splashes = running::<RainSplashes>(stages)
            .zip(self.host_splashes.as_ref())
            .map(|((slot, stage), back)| {
                let pending = back.submit(device, queue, stage.simulate(), timestamps(slot));
                (stage, back, pending)
            });
        let ground = GroundFrame {
            wet: running::<WetGround>(stages).and_then(|(_, s)| s.params_at(rain)),
            water: running::<Puddles>(stages).and_then(|(_, s)| s.frame_water(rain)),
        };
        let started = std::time::Instant::now();
        let (puddles_s, _) = host.decode_ground(frame, rain, &ground);
        self.gpu_times.yuv_to_rgb_s += started.elapsed().as_secs_f64() - puddles_s;
        self.gpu_times.puddles_s += puddles_s;
        let period_s = queue.get_timestamp_period() as f64 * 1e-9;
        if let Some((stage, back, pending)) = splashes {
            let (count, ticks) =
                back.receive(device, queue, stage.simulate(), pending, |list| {
                    let started = std::time::Instant::now();
                    let count = host.draw_splashes(rain, list);
                    (count.streaks, started.elapsed().as_secs_f64())
                })?;
            self.gpu_times.rain_splashes_s += count.1 + ticks.map_or(0.0, |t| t as f64 * period_s);
            self.gpu_times.splashes_drawn += count.0 as u64;
        }
        if self.rain_drops > 0 {
            let t = drops.draw(rain, |streaks, mattes, glints| {
                host.draw_streaks(rain, streaks, mattes, glints)
            });
            self.gpu_times.rain_simulate_s += t.simulate_s;
            self.gpu_times.rain_streaks_s += t.streaks_s;
            self.gpu_times.streaks_drawn += t.raster.streaks as u64;
        }
        let started = std::time::Instant::now();
        let planes = host.encode_canvas();
        self.gpu_times.rgb_to_yuv_s += started.elapsed().as_secs_f64();
        Ok(Rendered::Picture(YuvFrame {
            format: frame.format,
            color: frame.color,
            planes,
            pts: frame.pts,
            index: frame.index,
        }))
    }
}
