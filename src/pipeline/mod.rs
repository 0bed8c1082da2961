//! One render job from input to output, single-frame preview, and the [`Renderer`] both run on.
//!
//! Laid out along a frame's journey:
//! - [`job`]: the job — decode thread → the renderer → encode thread, bounded channels between.
//! - [`chunk`]: which frames a job renders, and the cut of frames and audio at its bounds.
//! - [`preview`]: one frame, exactly as the job writes it.
//! - [`ground`]: `--ground auto`'s pre-pass, resolved into the configuration before the shot
//!   is planned.
//! - [`motion`]: the camera's motion (`camera_motion`), estimated in a pre-pass or read from a
//!   pose file, resolved into pose keys after the ground; [`pose_cache`] keeps an estimate
//!   beside the water's checkpoints.
//! - [`renderer`]: the frame renderer every front end uses; it drives the compositor with
//!   one feed per input a frame needs: `light_feed`, `water_feed`, `depth_feed`, `sky_feed` and
//!   `ground_mask_feed` (the last two one `mask_feed` around their own detectors, their windows
//!   in `view_window`).
//!
//! The rain at a frame is a pure function of the frame's time `t = (pts − start) · time_base`
//! and of that frame alone, so [`preview()`] renders exactly what [`render`] writes at the same
//! frame.

pub mod chunk;
mod depth_feed;
pub mod ground;
pub mod ground_mask_feed;
pub mod job;
mod light_feed;
mod mask_feed;
pub mod motion;
pub mod pose_cache;
pub mod preview;
pub mod renderer;
mod sky_feed;
mod view_window;
mod water_feed;

pub use chunk::FrameRange;
pub use job::{Job, Progress, StageTimes, Summary, render};
pub use preview::{FrameSelector, preview};
pub use renderer::Renderer;
