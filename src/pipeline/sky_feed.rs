//! The sky feed: each frame's open sky ([`crate::scene::sky`]), averaged over the frames
//! shortly before it, handed to the compositor as the haze's sky mask.

use super::mask_feed::{MaskDetector, MaskFeed};
use crate::Result;
use crate::gpu::Compositor;
use crate::gpu::cpu::yuv_to_rgb::view_ray_at;
use crate::gpu::types::RainParams;
use crate::scene::sky::{SkyGrid, SkyMode, TopEdge, detect};
use crate::shot::Shot;
use crate::video::YuvFrame;

/// The open sky of a shot's frames, on the glow's grid; nothing where `ground.sky` is off.
pub(super) type SkyFeed = MaskFeed<Sky>;

/// The open sky's detector.
pub(super) struct Sky;

impl MaskDetector for Sky {
    fn wanted(shot: &Shot) -> bool {
        shot.config.ground.sky == SkyMode::Auto
    }

    /// `None` where there is no haze to lift.
    fn detect(frame: &YuvFrame, grid: SkyGrid, top: TopEdge, p: &RainParams) -> Option<Vec<f32>> {
        if p.haze[3] >= 1.0 {
            return None;
        }
        // Below the horizon of a given ground: the ray goes down to it.
        let below: Option<Vec<bool>> = (p.ground_clip != 0 && p.camera_pos_m[2] > 0.0).then(|| {
            (0..grid.len())
                .map(|k| view_ray_at(p, grid.point_px(k)).z < 0.0)
                .collect()
        });
        Some(detect(frame, grid, top, below.as_deref()))
    }

    fn set(compositor: &mut Compositor, mask: &[f32]) -> Result<()> {
        compositor.set_sky_mask(mask)
    }
}
