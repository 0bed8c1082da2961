//! `inspect camera`: the camera's motion over a clip as the render's pre-pass estimates it —
//! every frame's pan, tilt, roll and field of view (the pose file `camera_motion` reads) and
//! each shot's confidence and largest turn.

use std::sync::atomic::AtomicBool;

use serde_json::{Value, json};

use crate::Result;
use crate::config::{CameraConfig, RenderConfig};

/// The report of `input` whose first frame is seen through `camera` (its field of view, tilt
/// and roll): `{"frames": [{"t", "pan_deg", "tilt_deg", "roll_deg", "fov_deg", "confidence"}],
/// "shots": [...]}`, a pose file as it stands.
pub fn report(input: &str, camera: &CameraConfig) -> Result<Value> {
    let config = RenderConfig {
        camera: *camera,
        ..RenderConfig::default()
    };
    let estimate = crate::pipeline::motion::estimate_clip(input, &config, &AtomicBool::new(false))?;
    Ok(json!({
        "frames": estimate.track.frames,
        "shots": estimate.shots,
    }))
}
