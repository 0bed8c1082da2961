//! Single-frame preview: exactly the frame the full render writes at a time.

use std::sync::atomic::{AtomicBool, Ordering};

use super::renderer::Renderer;
use crate::config::RenderConfig;
use crate::fluid::puddles::checkpoint::Checkpoints;
use crate::gpu::AdapterRequest;
use crate::shot::{Footage, frame_time_s};
use crate::video::{Source, VideoInfo, YuvFrame};
use crate::{Error, Result};

/// Which frame to preview.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FrameSelector {
    /// The first frame at or after this time, seconds from the stream's start.
    At(f64),
    /// The frame with this zero-based index.
    Index(u64),
}

/// Renders one frame exactly as [`render`] would; returns it with the stream's description.
/// The puddles' water starts from the latest of `checkpoints` at or before the frame, if any.
///
/// The light of a frame depends on the frames shortly before it (temporal smoothing), so
/// those are decoded and fed first, exactly as the full render sees them.
pub fn preview(
    input: &str,
    at: FrameSelector,
    render: &RenderConfig,
    adapter: &AdapterRequest,
    checkpoints: Option<&Checkpoints>,
    cancel: &'static AtomicBool,
) -> Result<(YuvFrame, VideoInfo)> {
    render.validate()?;
    let check = || {
        if cancel.load(Ordering::Relaxed) {
            Err(Error::Interrupted)
        } else {
            Ok(())
        }
    };
    let mut source = Source::open(input)?;
    let info = source.info().clone();
    let render = &super::ground::resolve(render, input)?;
    let render =
        &super::motion::resolve_kept(render, input, cancel, checkpoints.map(|c| c.dir.as_path()))?;
    let target = match at {
        FrameSelector::At(t) => source.seek_to_time(t)?,
        FrameSelector::Index(n) => source.frame_at_index(n)?,
    };
    let mut rain = Renderer::new(render, &Footage::of(&info), adapter)?;
    if let Some(c) = checkpoints {
        rain = rain.with_checkpoints(c.clone());
    }
    rain = rain.with_cancel(cancel);
    let t_target = frame_time_s(&info, &target);
    // The water's fast-forward beside the light window's frames.
    rain.begin_water(target.index, t_target)?;
    let window = rain.light_window_s();
    if window > 0.0 {
        let from = (t_target - window).max(0.0);
        let mut frame = source.seek_to_time(from)?;
        while frame.pts < target.pts {
            check()?;
            let t = frame_time_s(&info, &frame);
            if t > t_target - window {
                rain.observe(&frame, t);
            }
            frame = source
                .next_frame()?
                .ok_or_else(|| Error::OutOfRange("the clip ended before the frame".into()))?;
        }
    }
    check()?;
    let out = rain.render(&target, t_target)?;
    check()?;
    Ok((out, info))
}
