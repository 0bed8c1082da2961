//! A mask feed: a detector's mask of each frame on the glow's grid, averaged over the frames
//! shortly before it ([`super::view_window`]), handed to the compositor; the sky feed and the
//! ground mask feed are this feed around their own detectors.

use super::view_window::Window;
use crate::Result;
use crate::gpu::Compositor;
use crate::gpu::stages::yuv_to_rgb::GLOW_CELL_PX;
use crate::gpu::types::RainParams;
use crate::scene::sky::{SkyGrid, TopEdge};
use crate::shot::Shot;
use crate::video::YuvFrame;

/// What a mask feed detects in one frame, and where the compositor takes it.
pub(super) trait MaskDetector {
    /// Whether `shot` asks for the mask at all (its mode is `auto`).
    fn wanted(shot: &Shot) -> bool;

    /// The mask of `frame` over `grid` under the uniforms `p`, the picture's top edge being
    /// `top`; `None` where this frame needs none.
    fn detect(frame: &YuvFrame, grid: SkyGrid, top: TopEdge, p: &RainParams) -> Option<Vec<f32>>;

    /// Hands a frame's smoothed mask to `compositor`.
    fn set(compositor: &mut Compositor, mask: &[f32]) -> Result<()>;
}

/// A mask of a shot's frames on the glow's grid; nothing where the detector is not wanted.
pub(super) struct MaskFeed<D> {
    tracker: Option<Window>,
    grid: SkyGrid,
    detector: std::marker::PhantomData<D>,
}

impl<D: MaskDetector> MaskFeed<D> {
    /// The feed of `shot`: smoothed like the light (`light.smoothing_s`).
    pub(super) fn new(shot: &Shot) -> MaskFeed<D> {
        let f = shot.footage.format;
        let grid = SkyGrid::new(GLOW_CELL_PX, (f.width, f.height));
        MaskFeed {
            tracker: D::wanted(shot).then(|| Window::new(shot, grid)),
            grid,
            detector: std::marker::PhantomData,
        }
    }

    /// How far back frames change the mask of a frame, seconds.
    pub(super) fn window_s(&self) -> f64 {
        self.tracker.as_ref().map_or(0.0, Window::window_s)
    }

    /// The mask of `frame` shown at `t_s` under the uniforms `p` (`cut`: the light saw a scene
    /// cut); `None` where it is not looked for or the frame needs none.
    pub(super) fn observe(
        &mut self,
        frame: &YuvFrame,
        p: &RainParams,
        t_s: f64,
        cut: bool,
    ) -> Option<&[f32]> {
        let tracker = self.tracker.as_mut()?;
        let m = p.coded_from_display;
        // Display "up" (0, −1) in coded pixels: display = M coded, M orthogonal.
        let top = TopEdge::from_up([-f64::from(m[2]), -f64::from(m[3])]);
        let mask = D::detect(frame, self.grid, top, p)?;
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
            Some(mask) => D::set(compositor, mask),
            None => Ok(()),
        }
    }
}
