//! The scene around the camera: the pinhole camera model, the ground, depth maps and the sky.
//!
//! World frame: right-handed, **z up**, metres. With zero tilt and roll the camera stands at
//! `(0, 0, height_m)` looking along +y, with +x to the right of the picture. This is the frame the
//! environment map, the spherical harmonics and the rain all share.
pub mod brightness;
pub mod camera;
pub mod depth;
pub mod ground;
pub mod ground_mask;
pub mod horizon;
pub mod lens;
pub mod motion;
pub mod segments;
pub mod sky;
pub mod steep;
pub mod tracker;
pub mod vanishing;
pub mod water;
pub mod working_picture;

pub use camera::{Camera, Projector};
pub use depth::DepthMap;
pub use ground::{GroundMode, GroundPlane, GroundPose};
