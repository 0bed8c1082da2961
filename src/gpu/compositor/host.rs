//! A frame on the CPU back end, whole: the plate laid with the wet ground fused in, the
//! puddles shaded, then with a ground the splashes simulated and drawn, the drops simulated and
//! drawn, and the canvas packed, all on the CPU. The frame never touches the adapter and is
//! done when `submit` returns. Where nothing but the rain changes the picture, only the tiles
//! it reaches are decoded and packed; the others' codes are copied.

use super::Compositor;
use crate::gpu::host::GroundFrame;
use crate::gpu::stages::FrameStage;
use crate::gpu::stages::{puddles::Puddles, wet_ground::WetGround};
use crate::gpu::types::RainParams;
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
        let started = std::time::Instant::now();
        let (puddles_s, _) = host.lay_plate(frame, rain, &ground);
        self.gpu_times.yuv_to_rgb_s += started.elapsed().as_secs_f64() - puddles_s;
        self.gpu_times.puddles_s += puddles_s;
        if let Some(splashes) = &mut self.host_splashes {
            let started = std::time::Instant::now();
            let list = splashes.simulate(rain);
            let count = host.draw_splashes(frame, rain, list);
            // The plate laid inside a draw is the decode's work, not the rain's.
            let laying_s = host.take_laying_s();
            self.gpu_times.yuv_to_rgb_s += laying_s;
            self.gpu_times.rain_splashes_s += started.elapsed().as_secs_f64() - laying_s;
            self.gpu_times.splashes_drawn += count.streaks as u64;
        }
        if self.rain_drops > 0 {
            let t = drops.draw(rain, |streaks, mattes, glints| {
                host.draw_streaks(frame, rain, streaks, mattes, glints)
            });
            self.gpu_times.rain_simulate_s += t.simulate_s;
            let laying_s = host.take_laying_s();
            self.gpu_times.yuv_to_rgb_s += laying_s;
            self.gpu_times.rain_streaks_s += t.streaks_s - laying_s;
            self.gpu_times.streaks_drawn += t.raster.streaks as u64;
        }
        let started = std::time::Instant::now();
        let planes = host.encode_canvas(frame);
        self.gpu_times.rgb_to_yuv_s += started.elapsed().as_secs_f64();
        let (converted, tiles) = host.tiles_converted();
        self.gpu_times.tiles_converted += converted as u64;
        self.gpu_times.tiles += tiles as u64;
        Ok(Rendered::Picture(YuvFrame {
            format: frame.format,
            color: frame.color,
            planes,
            pts: frame.pts,
            index: frame.index,
        }))
    }
}
