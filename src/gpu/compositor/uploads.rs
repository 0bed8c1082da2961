//! The per-frame inputs of the GPU stages (the compact lights, the scene's depth, the sky and
//! ground masks) on the CPU back end: held until a frame needs a GPU stage and written just
//! before it, so a frame drawn wholly on the CPU leaves the adapter alone (a queued write with
//! no submission after it would pile up in the queue frame after frame).

use super::Compositor;
use crate::gpu::types::LightList;

/// What changed since the adapter's buffers were last written (the CPU back end).
#[derive(Default)]
pub(super) struct Stale {
    pub lights: Option<LightList>,
    /// The scene's depth: the CPU back end's copy is the one to write.
    pub depth: bool,
    /// The sky mask: likewise.
    pub sky: bool,
    pub ground: Option<Vec<f32>>,
}

impl Compositor {
    /// Whether the GPU's per-frame inputs wait for a frame with GPU stages (the CPU back end).
    pub(super) fn defers_uploads(&self) -> bool {
        self.host.is_some()
    }

    /// Writes the inputs held back since the last frame with GPU stages.
    pub(super) fn write_stale(&mut self) {
        let stale = std::mem::take(&mut self.stale);
        let queue = &self.ctx.queue;
        if let Some(lights) = &stale.lights {
            self.direct_lights.upload_lights(queue, lights);
        }
        if let Some(ground) = &stale.ground {
            queue.write_buffer(&self.ground_mask, 0, bytemuck::cast_slice(ground));
        }
        let Some(host) = &self.host else { return };
        if let Some(depth) = host.scene_depth().filter(|_| stale.depth) {
            queue.write_buffer(&self.scene_depth, 0, bytemuck::cast_slice(depth));
        }
        if let Some(sky) = host.sky_mask().filter(|_| stale.sky) {
            queue.write_buffer(&self.sky_mask, 0, bytemuck::cast_slice(sky));
        }
    }
}
