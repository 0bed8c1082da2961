//! A frame on the CPU back end, whole: with a ground the splashes simulated, the drops
//! simulated, then the plate laid with the wet ground fused in, the puddles shaded, the
//! splashes and the drops drawn and the canvas packed, all on the CPU. Without water the
//! frame goes band by band (`HostColour::render_bands`: each band laid, drawn and packed in
//! the cache). The frame never touches the adapter and is done when `submit` returns. Where
//! nothing but the rain changes the picture, only the tiles it reaches are decoded and
//! packed; the others' codes are copied.

use super::Compositor;
use crate::gpu::host::{FrameRain, GroundFrame};
use crate::gpu::stages::FrameStage;
use crate::gpu::stages::{puddles::Puddles, wet_ground::WetGround};
use crate::gpu::types::{RainParams, Streak};
use crate::video::{Rendered, YuvFrame};
use crate::{Error, Result};

/// The stage of type `T` among `stages` that runs.
fn running<T: FrameStage>(stages: &[Box<dyn FrameStage>]) -> Option<&T> {
    stages.iter().find_map(|s| {
        let any = s.as_ref() as &dyn std::any::Any;
        any.downcast_ref::<T>().filter(|s| s.runs())
    })
}

impl Compositor {
    /// Whether frames are rendered on the CPU back end ([`Compositor::render_on_host`]): every
    /// picture frame there is, whatever its ground, water or splashes.
    pub(super) fn drawn_on_host(&self) -> bool {
        self.host_rain.is_some()
    }

    /// Whether the CPU back end lets the tiles nothing changes pass through, their codes
    /// copied (the default), or decodes and encodes every tile.
    pub fn set_pass_through(&mut self, on: bool) {
        if let Some(host) = &mut self.host {
            host.set_pass_through(on);
        }
    }

    /// The frame rendered on the CPU back end (see the module's comment).
    pub(super) fn render_on_host(
        &mut self,
        frame: &YuvFrame,
        rain: &RainParams,
    ) -> Result<Rendered> {
        let (Some(host), Some(drops)) = (&mut self.host, &mut self.host_rain) else {
            return Err(Error::Gpu("no CPU back end".into()));
        };
        let stages = &self.stages;
        let ground = GroundFrame {
            wet: running::<WetGround>(stages).and_then(|s| s.params_at(rain)),
            water: running::<Puddles>(stages).and_then(|s| s.frame_water(rain)),
        };
        let t = &mut self.gpu_times;
        let splashing = self.host_splashes.is_some();
        let started = std::time::Instant::now();
        let splashes: &[Streak] = match &mut self.host_splashes {
            Some(splashes) => splashes.simulate(rain),
            None => &[],
        };
        t.rain_splashes_s += started.elapsed().as_secs_f64();
        let started = std::time::Instant::now();
        let (streaks, mattes, glints, _) = if self.rain_drops > 0 {
            drops.simulate_for_draw(rain)
        } else {
            (&[][..], None, &[][..], 0)
        };
        t.rain_simulate_s += started.elapsed().as_secs_f64();
        let drawn = FrameRain {
            splashes,
            streaks,
            mattes,
            glints,
        };
        let planes = if let Some(f) = host.render_bands(frame, rain, &ground, &drawn) {
            t.yuv_to_rgb_s += f.decode_s;
            t.rain_splashes_s += f.splashes_s;
            t.rain_streaks_s += f.streaks_s;
            t.rgb_to_yuv_s += f.encode_s;
            t.splashes_drawn += f.splashes.streaks as u64;
            t.streaks_drawn += f.streaks.streaks as u64;
            f.planes
        } else {
            let started = std::time::Instant::now();
            let (puddles_s, _) = host.lay_plate(frame, rain, &ground);
            t.yuv_to_rgb_s += started.elapsed().as_secs_f64() - puddles_s;
            t.puddles_s += puddles_s;
            if splashing {
                let started = std::time::Instant::now();
                let count = host.draw_splashes(frame, rain, splashes);
                // The plate laid inside a draw is the decode's work, not the rain's.
                let laying_s = host.take_laying_s();
                t.yuv_to_rgb_s += laying_s;
                t.rain_splashes_s += started.elapsed().as_secs_f64() - laying_s;
                t.splashes_drawn += count.streaks as u64;
            }
            if self.rain_drops > 0 {
                let started = std::time::Instant::now();
                let count = host.draw_streaks(frame, rain, streaks, mattes, glints);
                let laying_s = host.take_laying_s();
                t.yuv_to_rgb_s += laying_s;
                t.rain_streaks_s += started.elapsed().as_secs_f64() - laying_s;
                t.streaks_drawn += count.streaks as u64;
            }
            let started = std::time::Instant::now();
            let planes = host.encode_canvas(frame);
            t.rgb_to_yuv_s += started.elapsed().as_secs_f64();
            planes
        };
        let (converted, tiles) = host.tiles_converted();
        t.tiles_converted += converted as u64;
        t.tiles += tiles as u64;
        Ok(Rendered::Picture(YuvFrame {
            format: frame.format,
            color: frame.color,
            planes,
            pts: frame.pts,
            index: frame.index,
        }))
    }
}
