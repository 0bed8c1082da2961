//! A mask over the glow's grid averaged over the frames shortly before, in the world's
//! directions rather than on the picture: for a camera that turns or zooms, each earlier
//! frame's mask is read where it saw the ray of each point of the current frame.
//!
//! The sky and the ground stay where they are in the world while the camera turns, so a
//! point's ray, not its place on the picture, is what an earlier frame saw of it: a pan of a few
//! pixels a frame averaged on the picture would smear the horizon over the whole window. An
//! earlier frame that did not see a ray (it lay outside that frame's picture or behind it)
//! leaves that point out, so the weights are normalised per point. As with
//! [`crate::scene::sky::SkyTracker`] (the same weights, `e^(−Δt/τ)` over 4 τ), a cut starts
//! afresh, and the mask of a frame depends only on the frames of its window: a preview that
//! observes the window before its frame sees what a whole render shows there.

use std::collections::VecDeque;

use glam::{DMat3, DVec2, DVec3};

use crate::gpu::types::RainParams;
use crate::scene::sky::{SkyGrid, SkyTracker};

/// What a frame's uniforms say about where its picture looks: enough to find the grid point
/// that saw a world direction.
#[derive(Debug, Clone, Copy)]
struct View {
    /// Rows: camera from world.
    camera_from_world: DMat3,
    focal_px: f64,
    principal_px: DVec2,
    /// Display from coded, row-major; orthogonal.
    m: [f64; 4],
    coded_offset_px: DVec2,
}

impl View {
    fn of(p: &RainParams) -> View {
        let row = |r: [f32; 4]| DVec3::new(r[0] as f64, r[1] as f64, r[2] as f64);
        View {
            camera_from_world: DMat3::from_cols(
                row(p.camera_from_world_0),
                row(p.camera_from_world_1),
                row(p.camera_from_world_2),
            )
            .transpose(),
            focal_px: p.focal_px as f64,
            principal_px: DVec2::new(p.principal_px[0] as f64, p.principal_px[1] as f64),
            m: p.coded_from_display.map(f64::from),
            coded_offset_px: DVec2::new(p.coded_offset_px[0] as f64, p.coded_offset_px[1] as f64),
        }
    }

    /// The world direction of the ray through continuous coded position `at_px`
    /// ([`crate::gpu::cpu::yuv_to_rgb::view_ray_at`]).
    fn ray(&self, at_px: DVec2) -> DVec3 {
        let m = self.m;
        let c = at_px - self.coded_offset_px;
        let q = DVec2::new(m[0] * c.x + m[1] * c.y, m[2] * c.x + m[3] * c.y);
        let d = (q - self.principal_px) / self.focal_px;
        self.camera_from_world.transpose() * DVec3::new(d.x, d.y, 1.0)
    }

    /// The coded position that sees world direction `dir`, `None` behind the camera.
    fn coded_of(&self, dir: DVec3) -> Option<DVec2> {
        let c = self.camera_from_world * dir;
        if c.z <= 1e-9 {
            return None;
        }
        let q = self.principal_px + self.focal_px * DVec2::new(c.x, c.y) / c.z;
        let m = self.m;
        // Coded = mᵀ display + offset (m orthogonal).
        Some(DVec2::new(m[0] * q.x + m[2] * q.y, m[1] * q.x + m[3] * q.y) + self.coded_offset_px)
    }
}

/// A mask averaged over its window in the world's directions (see the module doc).
pub(super) struct RayWindow {
    settle_s: f64,
    grid: SkyGrid,
    window: VecDeque<(f64, Vec<f32>, View)>,
    out: Vec<f32>,
}

impl RayWindow {
    /// A window with time constant `settle_s` (0: the frame's own mask) over `grid`.
    pub(super) fn new(settle_s: f64, grid: SkyGrid) -> RayWindow {
        RayWindow {
            settle_s: settle_s.max(0.0),
            grid,
            window: VecDeque::new(),
            out: Vec::new(),
        }
    }

    /// How far back a frame's mask still counts, seconds.
    pub(super) fn window_s(&self) -> f64 {
        4.0 * self.settle_s
    }

    /// Takes `detected`, the mask of the frame shown at `t_s` through the uniforms `p`
    /// (increasing; `cut`: it starts a new scene), and returns the mask to use for it.
    pub(super) fn update(
        &mut self,
        detected: Vec<f32>,
        p: &RainParams,
        t_s: f64,
        cut: bool,
    ) -> &[f32] {
        let size = detected.len();
        if cut
            || self
                .window
                .back()
                .is_some_and(|(t, w, _)| *t >= t_s || w.len() != size)
        {
            self.window.clear();
        }
        self.window.push_back((t_s, detected, View::of(p)));
        let horizon = t_s - self.window_s();
        while self.window.len() > 1 && self.window.front().is_some_and(|(t, _, _)| *t <= horizon) {
            self.window.pop_front();
        }
        let (_, own, now) = self.window.back().expect("pushed");
        let mut sum: Vec<f64> = own.iter().map(|&m| f64::from(m)).collect();
        let mut total = vec![1.0f64; size];
        let grid = self.grid;
        if self.settle_s > 0.0 && size == grid.len() {
            let cell = f64::from(grid.cell_px);
            let rays: Vec<DVec3> = (0..size).map(|k| now.ray(grid.point_px(k))).collect();
            for (t, mask, view) in self.window.iter().rev().skip(1) {
                let weight = (-(t_s - t) / self.settle_s).exp();
                for (k, ray) in rays.iter().enumerate() {
                    if let Some(v) = view
                        .coded_of(*ray)
                        .and_then(|at| sample(mask, grid, at / cell))
                    {
                        sum[k] += weight * v;
                        total[k] += weight;
                    }
                }
            }
        }
        self.out.clear();
        self.out
            .extend(sum.iter().zip(&total).map(|(s, w)| (s / w) as f32));
        &self.out
    }
}

/// `mask` bilinear at grid coordinates `g` (point (i, j) at (i, j)); `None` outside the grid.
fn sample(mask: &[f32], grid: SkyGrid, g: DVec2) -> Option<f64> {
    let (wx, wy) = ((grid.width - 1) as f64, (grid.height - 1) as f64);
    if !(g.x >= 0.0 && g.y >= 0.0 && g.x <= wx && g.y <= wy) {
        return None;
    }
    let (i, j) = (
        (g.x.floor() as usize).min(grid.width.saturating_sub(2)),
        (g.y.floor() as usize).min(grid.height.saturating_sub(2)),
    );
    let (fx, fy) = (g.x - i as f64, g.y - j as f64);
    let at = |i: usize, j: usize| {
        f64::from(mask[j.min(grid.height - 1) * grid.width + i.min(grid.width - 1)])
    };
    let top = at(i, j) + (at(i + 1, j) - at(i, j)) * fx;
    let bottom = at(i, j + 1) + (at(i + 1, j + 1) - at(i, j + 1)) * fx;
    Some(top + (bottom - top) * fy)
}

/// A feed's window: on the picture for a still camera, in the world's directions for one that
/// turns or zooms.
pub(super) enum Window {
    /// [`SkyTracker`]: the camera does not move.
    Picture(SkyTracker),
    /// [`RayWindow`]: pose keys (typed or estimated) move it.
    Rays(RayWindow),
}

impl Window {
    /// The window of `shot`'s masks over `grid`, smoothed like the light
    /// (`light.smoothing_s`).
    pub(super) fn new(shot: &crate::shot::Shot, grid: SkyGrid) -> Window {
        let settle_s = shot.config.light.smoothing_s;
        if shot.rain.keys.moves_camera() {
            Window::Rays(RayWindow::new(settle_s, grid))
        } else {
            Window::Picture(SkyTracker::new(settle_s))
        }
    }

    /// How far back a frame's mask still counts, seconds.
    pub(super) fn window_s(&self) -> f64 {
        match self {
            Window::Picture(t) => t.window_s(),
            Window::Rays(t) => t.window_s(),
        }
    }

    /// The mask to use for the frame shown at `t_s` through `p`, given its own `detected`.
    pub(super) fn update(
        &mut self,
        detected: Vec<f32>,
        p: &RainParams,
        t_s: f64,
        cut: bool,
    ) -> &[f32] {
        match self {
            Window::Picture(t) => t.update(detected, t_s, cut),
            Window::Rays(t) => t.update(detected, p, t_s, cut),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Camera;

    fn params_of(camera: &Camera) -> RainParams {
        let mut p = bytemuck::Zeroable::zeroed();
        let p: &mut RainParams = &mut p;
        crate::gpu::uniforms::set_camera(p, camera);
        let c = camera.principal_px();
        p.principal_px = [c.x as f32, c.y as f32];
        p.coded_from_display = [1.0, 0.0, 0.0, 1.0];
        *p
    }

    /// A mask fixed in the world (1 where the ray points up) seen by a panning, tilting and
    /// zooming camera: the window's average is the mask of the frame's own rays, so the
    /// horizon is not smeared, while averaging on the picture would be.
    #[test]
    fn a_world_fixed_mask_stays_sharp_under_a_pan() {
        let (w, h) = (320u32, 180u32);
        let grid = SkyGrid::new(8, (w, h));
        let mut window = RayWindow::new(0.25, grid);
        let soft = |d: DVec3| (0.5 + 6.0 * d.normalize().z).clamp(0.0, 1.0) as f32;
        let mut on_picture = SkyTracker::new(0.25);
        let (mut worst, mut worst_on_picture): (f32, f32) = (0.0, 0.0);
        for i in 0..30 {
            let t = i as f64 / 25.0;
            let cam = Camera::new(w, h, (60.0 - 10.0 * t).to_radians(), 1.6, 0.2 * t, 0.05)
                .panned(0.6 * t);
            let p = params_of(&cam);
            let view = View::of(&p);
            let mask: Vec<f32> = (0..grid.len())
                .map(|k| soft(view.ray(grid.point_px(k))))
                .collect();
            let out = window.update(mask.clone(), &p, t, false).to_vec();
            let plain = on_picture.update(mask.clone(), t, false).to_vec();
            for ((a, b), c) in out.iter().zip(&mask).zip(&plain) {
                worst = worst.max((a - b).abs());
                worst_on_picture = worst_on_picture.max((c - b).abs());
            }
            // The ray of a grid point is the camera's own.
            let at = DVec2::new(40.0, 24.0);
            let d = view.ray(at).normalize();
            let seen = cam.ray_world(at).normalize();
            assert!((d - seen).length() < 1e-6);
            // And back, to the uniforms' f32 rounding.
            let back = view.coded_of(d).expect("in front");
            assert!((back - at).length() < 1e-3, "{back} vs {at}");
        }
        // The rays' average is the frame's own mask but for the bilinear reading of the ramp
        // at its clamped ends (0.024); the picture's lags the turn by about 0.3.
        assert!(worst < 0.05, "{worst}");
        assert!(worst_on_picture > 0.2, "{worst_on_picture}");
    }
}
