//! The sky feed: each frame's open sky ([`crate::scene::sky`]), averaged over the frames
//! shortly before it, handed to the compositor as the haze's sky mask.

use glam::DVec2;

use super::view_window::Window;
use crate::Result;
use crate::gpu::Compositor;
use crate::gpu::cpu::yuv_to_rgb::view_ray_at;
use crate::gpu::stages::yuv_to_rgb::GLOW_CELL_PX;
use crate::gpu::types::RainParams;
use crate::scene::sky::{SkyGrid, SkyMode, TopEdge, detect};
use crate::shot::Shot;
use crate::video::YuvFrame;

/// The open sky of a shot's frames, on the glow's grid; nothing where `ground.sky` is off.
pub(super) struct SkyFeed {
    tracker: Option<Window>,
    grid: SkyGrid,
}

impl SkyFeed {
    /// The feed of `shot`: smoothed like the light (`light.smoothing_s`).
    pub(super) fn new(shot: &Shot) -> SkyFeed {
        let config = &shot.config;
        let f = shot.footage.format;
        let grid = SkyGrid::new(GLOW_CELL_PX, (f.width, f.height));
        SkyFeed {
            tracker: (config.ground.sky == SkyMode::Auto).then(|| Window::new(shot, grid)),
            grid,
        }
    }

    /// How far back frames change the mask of a frame, seconds.
    pub(super) fn window_s(&self) -> f64 {
        self.tracker.as_ref().map_or(0.0, Window::window_s)
    }

    /// The mask of `frame` shown at `t_s` under the uniforms `p` (`cut`: the light saw a scene
    /// cut); `None` where the sky is not looked for or there is no haze to lift.
    pub(super) fn observe(
        &mut self,
        frame: &YuvFrame,
        p: &RainParams,
        t_s: f64,
        cut: bool,
    ) -> Option<&[f32]> {
        let tracker = self.tracker.as_mut()?;
        if p.haze[3] >= 1.0 {
            return None;
        }
        let grid = self.grid;
        let m = p.coded_from_display;
        // Display "up" (0, −1) in coded pixels: display = M coded, M orthogonal.
        let top = TopEdge::from_up([-f64::from(m[2]), -f64::from(m[3])]);
        // Below the horizon of a given ground: the ray goes down to it.
        let below: Option<Vec<bool>> = (p.ground_clip != 0 && p.camera_pos_m[2] > 0.0).then(|| {
            let cell = f64::from(grid.cell_px);
            (0..grid.len())
                .map(|k| {
                    let at = DVec2::new((k % grid.width) as f64, (k / grid.width) as f64) * cell;
                    view_ray_at(p, at).z < 0.0
                })
                .collect()
        });
        let mask = detect(frame, grid, top, below.as_deref());
        Some(tracker.update(mask, p, t_s, cut))
    }

    /// Sets the mask of `frame` on `compositor` (see [`observe`](Self::observe)).
    pub(super) fn feed(
        &mut self,
        compositor: &mut Compositor,
        frame: &YuvFrame,
        p: &RainParams,
        t_s: f64,
        cut: bool,
    ) -> Result<()> {
        match self.observe(frame, p, t_s, cut) {
            Some(mask) => compositor.set_sky_mask(mask),
            None => Ok(()),
        }
    }
}
