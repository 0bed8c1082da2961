//! The per-frame horizon estimates smoothed over a window of past frames, reset at scene cuts.
//!
//! The window's readings are combined by [`crate::scene::horizon::aggregate`] after the last cut
//! in the window (a cut: the mean absolute change of a 16×9 thumbnail of the luma above
//! [`CUT_THRESHOLD`]), so a preview of frame *t* that feeds the same window gets the same answer
//! as the render.

use std::collections::VecDeque;

use crate::scene::Camera;
use crate::scene::horizon::{HorizonEstimate, Luma, aggregate};

/// Smoothing of the per-frame estimates over a window of past frames, reset at cuts (see the
/// module doc).
#[derive(Debug, Clone)]
pub struct GroundTracker {
    window: usize,
    frames: VecDeque<(HorizonEstimate, [f32; 144])>,
}

/// Mean absolute thumbnail change above which two consecutive frames are a cut.
pub const CUT_THRESHOLD: f32 = 0.12;

/// Whether two consecutive frames' luma thumbnails ([`Luma::thumbnail`]) differ by a cut.
pub fn is_cut(prev: &[f32; 144], thumb: &[f32; 144]) -> bool {
    let change = prev
        .iter()
        .zip(thumb)
        .map(|(a, b)| (a - b).abs())
        .sum::<f32>()
        / 144.0;
    change > CUT_THRESHOLD
}

impl GroundTracker {
    /// A tracker averaging over the last `window` frames (1 = no smoothing).
    pub fn new(window: usize) -> GroundTracker {
        GroundTracker {
            window: window.max(1),
            frames: VecDeque::new(),
        }
    }

    /// Adds a frame's estimate and returns the smoothed one.
    pub fn update(
        &mut self,
        est: HorizonEstimate,
        luma: &Luma,
        camera: &Camera,
    ) -> HorizonEstimate {
        let thumb = luma.thumbnail();
        if self
            .frames
            .back()
            .is_some_and(|(_, prev)| is_cut(prev, &thumb))
        {
            self.frames.clear();
        }
        self.frames.push_back((est, thumb));
        while self.frames.len() > self.window {
            self.frames.pop_front();
        }
        let readings: Vec<HorizonEstimate> = self.frames.iter().map(|f| f.0).collect();
        aggregate(&readings, camera).unwrap_or(est)
    }
}
