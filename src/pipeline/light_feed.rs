//! The light feed: each frame's light, estimated from the frame (and the frames shortly
//! before it), as the GPU's uniforms and compact lights.

use crate::Result;
use crate::gpu::Compositor;
use crate::gpu::types::{LightList, RainParams};
use crate::gpu::uniforms::RainSetup;
use crate::lighting::{EnvironmentSh, FrameLight, LightEstimator};
use crate::shot::Shot;
use crate::video::YuvFrame;

/// Feeds each frame's light to the GPU: from a [`LightEstimator`] where anything shows light,
/// none where nothing would (no drops, no haze).
pub(super) struct LightFeed {
    estimator: Option<LightEstimator>,
    drop_zonal: [[f32; 4]; 3],
}

impl LightFeed {
    pub(super) fn new(shot: &Shot) -> Result<LightFeed> {
        let rain = &shot.rain;
        let needed = rain.drop_count() > 0 || rain.haze_alpha > 0.0 || rain.wetting.is_some();
        let estimator = if needed {
            Some(LightEstimator::new(
                &shot.camera,
                shot.footage.rotation_deg,
                &shot.config.light,
            )?)
        } else {
            None
        };
        let drop_zonal = estimator
            .as_ref()
            .map_or([[0.0; 4]; 3], |l| l.drop_zonal_gpu());
        Ok(LightFeed {
            estimator,
            drop_zonal,
        })
    }

    /// How far back frames affect the light, when there is light to compute.
    pub(super) fn window_secs(&self) -> Option<f64> {
        self.estimator
            .as_ref()
            .map(|l| l.window_secs())
            .filter(|&w| w > 0.0)
    }

    /// Clipping judged at `bits` bits (see `LightEstimator::set_source_bits`).
    pub(super) fn set_source_bits(&mut self, bits: u8) {
        if let Some(l) = &mut self.estimator {
            l.set_source_bits(bits);
        }
    }

    /// Whether the last frame's light started a new scene.
    pub(super) fn last_was_cut(&self) -> bool {
        self.estimator.as_ref().is_some_and(|l| l.last_was_cut())
    }

    /// The drop's transfer table for the direct light term, once per job.
    pub(super) fn upload_table(&self, compositor: &mut Compositor) {
        if let Some(l) = &self.estimator {
            compositor.set_transfer_table(l.transfer_tables());
        }
    }

    /// The GPU uniforms of `frame`, shown at `t_s`: the rain's and the compact lights'.
    pub(super) fn params(
        &mut self,
        rain: &RainSetup,
        frame: &YuvFrame,
        t_s: f64,
    ) -> (RainParams, LightList) {
        let light = match &mut self.estimator {
            Some(l) => {
                if rain.keys.moves_camera()
                    && let Err(e) = l.set_camera(&rain.camera_at(t_s))
                {
                    // Unreachable for validated keys (every field of view in range).
                    log::warn!("light at {t_s:.3} s seen through the first camera: {e}");
                }
                l.update(frame, t_s)
            }
            None => FrameLight {
                env: EnvironmentSh::zeros(4),
                lights: Vec::new(),
            },
        };
        rain.frame_uniforms(t_s, &light, self.drop_zonal)
    }
}
