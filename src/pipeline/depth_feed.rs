//! The depth feed: the scene's depth (`--depth`), a still for every frame or a map per frame,
//! handed to the compositor as the frames come.

use crate::config::RenderConfig;
use crate::gpu::Compositor;
use crate::scene::depth::DepthSource;
use crate::{Error, Result};

/// The scene's depth of a shot, and whether the compositor holds it yet.
pub(super) struct DepthFeed {
    pub(super) source: Option<DepthSource>,
    fed: bool,
}

impl DepthFeed {
    /// The depth `config` names, opened and checked before any frame is decoded: a directory or
    /// video with fewer maps than the clip's `frames` is refused here.
    pub(super) fn open(config: &RenderConfig, frames: Option<u64>) -> Result<DepthFeed> {
        let Some(path) = &config.ground.depth else {
            return Ok(DepthFeed {
                source: None,
                fed: false,
            });
        };
        let depth = DepthSource::open(path, config.ground.depth_scale)?;
        if let (Some(maps), Some(frames)) = (depth.frame_count(), frames)
            && maps < frames
        {
            return Err(Error::Parameter {
                name: "ground.depth",
                value: path.display().to_string(),
                expected: format!("a depth map per frame: {maps} maps for {frames} frames"),
            });
        }
        Ok(DepthFeed {
            source: Some(depth),
            fed: false,
        })
    }

    /// Sets the depth of frame `index` on `compositor`: a still once, a map per frame otherwise.
    pub(super) fn feed(&mut self, compositor: &mut Compositor, index: u64) -> Result<()> {
        let first = !self.fed;
        self.fed = true;
        match &mut self.source {
            Some(DepthSource::Still(map)) if first => compositor.set_scene_depth(map),
            Some(DepthSource::Still(_)) | None => Ok(()),
            Some(d) => compositor.set_scene_depth(d.at(index)?.as_ref()),
        }
    }
}
