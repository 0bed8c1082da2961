//! The ground mask feed: each frame's ground ([`crate::scene::ground_mask`]) under the given
//! ground's horizon, averaged over the frames shortly before it, handed to the compositor so
//! that wetness and puddles keep to it.

use glam::{DVec2, DVec3};

use super::mask_feed::{MaskDetector, MaskFeed};
use crate::Result;
use crate::gpu::Compositor;
use crate::gpu::cpu::puddles::project;
use crate::gpu::cpu::yuv_to_rgb::view_ray_at;
use crate::gpu::types::RainParams;
use crate::scene::ground_mask::{GroundMaskMode, PointView, detect};
use crate::scene::sky::{SkyGrid, TopEdge};
use crate::shot::Shot;
use crate::video::YuvFrame;

/// The ground of a shot's frames, on the glow's grid; nothing where `ground.mask` is off.
pub(super) type GroundMaskFeed = MaskFeed<Ground>;

/// The ground's detector.
pub(super) struct Ground;

impl MaskDetector for Ground {
    fn wanted(shot: &Shot) -> bool {
        shot.config.ground.mask == GroundMaskMode::Auto
    }

    /// `None` where there is no ground.
    fn detect(frame: &YuvFrame, grid: SkyGrid, top: TopEdge, p: &RainParams) -> Option<Vec<f32>> {
        if p.ground_clip == 0 || p.camera_pos_m[2] <= 0.0 {
            return None;
        }
        Some(detect(frame, grid, top, &point_views(p, grid)))
    }

    fn set(compositor: &mut Compositor, mask: &[f32]) -> Result<()> {
        compositor.set_ground_mask(mask)
    }
}

/// What the camera of `p` says about each point of `grid`: whether its ray meets the ground,
/// the image of the world's up direction there, and where its ray reflected in the ground
/// lands in the picture.
pub fn point_views(p: &RainParams, grid: SkyGrid) -> Vec<PointView> {
    // World up in the camera's frame: the rows' z (world = Σ row_k · q_k, orthonormal).
    let up = [
        f64::from(p.camera_from_world_0[2]),
        f64::from(p.camera_from_world_1[2]),
        f64::from(p.camera_from_world_2[2]),
    ];
    let m = p.coded_from_display.map(f64::from);
    let (f, c) = (
        f64::from(p.focal_px),
        DVec2::new(f64::from(p.principal_px[0]), f64::from(p.principal_px[1])),
    );
    let row = |r: [f32; 4]| DVec3::new(f64::from(r[0]), f64::from(r[1]), f64::from(r[2]));
    (0..grid.len())
        .map(|k| {
            let at = grid.point_px(k);
            let ray = view_ray_at(p, at);
            // The displayed position's normalised coordinates d: the camera-space ray (d, 1).
            let o = at
                - DVec2::new(
                    f64::from(p.coded_offset_px[0]),
                    f64::from(p.coded_offset_px[1]),
                );
            let shown = DVec2::new(m[0] * o.x + m[1] * o.y, m[2] * o.x + m[3] * o.y);
            let d = (shown - c) / f;
            // d(display)/dε of the point moved by ε along world up: f · (up.xy − d · up.z).
            let s = DVec2::new(up[0] - d.x * up[2], up[1] - d.y * up[2]);
            // Coded = Mᵀ display.
            let coded = [m[0] * s.x + m[2] * s.y, m[1] * s.x + m[3] * s.y];
            // The ray reflected in the ground, in the camera's frame (rows of camera_from_world).
            let mirrored = DVec3::new(ray.x, ray.y, -ray.z);
            let q = DVec3::new(
                row(p.camera_from_world_0).dot(mirrored),
                row(p.camera_from_world_1).dot(mirrored),
                row(p.camera_from_world_2).dot(mirrored),
            );
            let below_horizon = ray.z < 0.0;
            PointView {
                below_horizon,
                up_px: coded.map(|v| v as f32),
                mirror_px: (below_horizon && q.z > 1e-9)
                    .then(|| project(p, q).to_array().map(|v| v as f32)),
                sin_depression: if below_horizon {
                    (-ray.z / ray.length()) as f32
                } else {
                    0.0
                },
            }
        })
        .collect()
}
