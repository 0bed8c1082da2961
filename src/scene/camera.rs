//! Pinhole camera: projection of world points to pixels and pixels to world rays.
//!
//! Camera space follows the image (OpenCV convention): +x right, +y down, +z forward (the
//! optical axis). `world_from_camera` maps camera-space directions into the z-up world frame.

use glam::{DMat3, DVec2, DVec3};

/// A pinhole camera with square pixels and the principal point at the picture's centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Picture width in pixels (the displayed picture, after rotation).
    pub width_px: u32,
    /// Picture height in pixels.
    pub height_px: u32,
    /// Horizontal field of view, radians, in (0, π).
    pub fov_x_rad: f64,
    /// Camera centre in the world, metres.
    pub position_m: DVec3,
    /// Rotation from camera space to the world frame.
    pub world_from_camera: DMat3,
}

impl Camera {
    /// A camera `height_m` above the ground, pitched up by `tilt_rad` (negative looks down) and
    /// rolled clockwise by `roll_rad` about its optical axis.
    pub fn new(
        width_px: u32,
        height_px: u32,
        fov_x_rad: f64,
        height_m: f64,
        tilt_rad: f64,
        roll_rad: f64,
    ) -> Camera {
        // Level camera: camera x → world +x, camera y (down) → world −z, camera z → world +y.
        let level = DMat3::from_cols(DVec3::X, DVec3::NEG_Z, DVec3::Y);
        let world_from_camera =
            DMat3::from_rotation_x(tilt_rad) * level * DMat3::from_rotation_z(roll_rad);
        Camera {
            width_px,
            height_px,
            fov_x_rad,
            position_m: DVec3::new(0.0, 0.0, height_m),
            world_from_camera,
        }
    }

    /// This camera panned right by `pan_rad` about the world's vertical through its centre
    /// (the identity for 0, so an unpanned camera keeps its exact rotation).
    pub fn panned(mut self, pan_rad: f64) -> Camera {
        if pan_rad != 0.0 {
            // Right is clockwise seen from above: a rotation by −pan about +z.
            self.world_from_camera = DMat3::from_rotation_z(-pan_rad) * self.world_from_camera;
        }
        self
    }

    /// Focal length in pixels: `f = (W/2) / tan(fov_x/2)`.
    pub fn focal_px(&self) -> f64 {
        0.5 * self.width_px as f64 / (0.5 * self.fov_x_rad).tan()
    }

    /// Vertical field of view, radians.
    pub fn fov_y_rad(&self) -> f64 {
        2.0 * (0.5 * self.height_px as f64 / self.focal_px()).atan()
    }

    /// The principal point (picture centre), pixels.
    pub fn principal_px(&self) -> DVec2 {
        DVec2::new(0.5 * self.width_px as f64, 0.5 * self.height_px as f64)
    }

    /// Camera-space point → pixel coordinates (pixel centres at half-integers). `None` behind
    /// the camera.
    pub fn project_camera(&self, p_cam: DVec3) -> Option<DVec2> {
        if p_cam.z <= 0.0 {
            return None;
        }
        let f = self.focal_px();
        Some(self.principal_px() + DVec2::new(p_cam.x, p_cam.y) * (f / p_cam.z))
    }

    /// World point → camera space.
    pub fn camera_from_world_point(&self, p_world: DVec3) -> DVec3 {
        self.world_from_camera.transpose() * (p_world - self.position_m)
    }

    /// World point → pixel coordinates; `None` behind the camera.
    pub fn project_world(&self, p_world: DVec3) -> Option<DVec2> {
        self.project_camera(self.camera_from_world_point(p_world))
    }

    /// [`Camera::project_world`] with the focal length and the rotation's transpose worked out
    /// once, for many points: the same pixel positions to the bit.
    pub fn projector(&self) -> impl Fn(DVec3) -> Option<DVec2> + use<> {
        let (camera_from_world, position_m) = (self.world_from_camera.transpose(), self.position_m);
        let (f, principal) = (self.focal_px(), self.principal_px());
        move |p_world| {
            let p_cam = camera_from_world * (p_world - position_m);
            (p_cam.z > 0.0).then(|| principal + DVec2::new(p_cam.x, p_cam.y) * (f / p_cam.z))
        }
    }

    /// Unit world direction of the ray through pixel position `px` (pixel centres at
    /// half-integers).
    pub fn ray_world(&self, px: DVec2) -> DVec3 {
        let d = (px - self.principal_px()) / self.focal_px();
        (self.world_from_camera * DVec3::new(d.x, d.y, 1.0)).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The projector projects as `project_world` does, to the bit, behind the camera too.
    #[test]
    fn the_projector_is_project_world() {
        let cam = Camera::new(640, 360, 1.2, 1.6, -0.3, 0.2).panned(0.7);
        let project = cam.projector();
        let mut state = 5u64;
        let mut next = || {
            state = crate::rng::splitmix64(state);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 40.0 - 20.0
        };
        let mut behind = 0;
        for _ in 0..2000 {
            let p = DVec3::new(next(), next(), 0.1 * next());
            let (a, b) = (project(p), cam.project_world(p));
            behind += a.is_none() as usize;
            assert_eq!(
                a.map(|q| q.to_array().map(f64::to_bits)),
                b.map(|q| q.to_array().map(f64::to_bits))
            );
        }
        assert!(behind > 100 && behind < 1900, "{behind} behind");
    }

    #[test]
    fn ray_and_projection_are_inverse() {
        let cam = Camera::new(640, 360, 1.2, 1.6, 0.3, -0.2);
        for &(x, y) in &[(0.5, 0.5), (320.0, 180.0), (639.5, 12.25), (100.0, 359.5)] {
            let px = DVec2::new(x, y);
            let p = cam.position_m + cam.ray_world(px) * 7.0;
            let back = cam.project_world(p).expect("in front");
            assert!((back - px).length() < 1e-9, "{back:?} vs {px:?}");
        }
    }

    #[test]
    fn level_camera_looks_along_y_with_z_up() {
        let cam = Camera::new(100, 100, 1.0, 2.0, 0.0, 0.0);
        let centre = cam.ray_world(cam.principal_px());
        assert!((centre - DVec3::Y).length() < 1e-12);
        // The top row of the picture looks upward.
        assert!(cam.ray_world(DVec2::new(50.0, 0.0)).z > 0.0);
        // Tilting up raises the optical axis.
        let up = Camera::new(100, 100, 1.0, 2.0, 0.5, 0.0);
        assert!(up.ray_world(up.principal_px()).z > 0.4);
    }
}
