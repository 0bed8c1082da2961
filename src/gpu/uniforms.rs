//! The uniforms builder: the shot's rain plan ([`crate::shot::RainPlan`], planned on the CPU)
//! and the frame's light, packed into the uniforms and column buffer the stages read
//! (`shaders/common/types.wgsl`), with the display↔coded mapping.
//!
//! The per-drop algorithm lives in the WGSL; its plain CPU reference is
//! [`sample_drop`](crate::rain::volume::sample_drop), which `tests/gpu.rs` holds the GPU to.
//! Everything time-dependent that needs `f64` (gust phases, the mean wind's travel modulo a
//! cell) is computed here per frame in [`RainSetup::params_at`], so the shader never takes the
//! cosine of a large argument in `f32`; the time itself arrives split into whole seconds and a
//! fraction (see `rain::volume::drop`, "Long clips").

use glam::DVec2;

use super::types::{Column, GUSTS, LightList, RainParams};
use crate::keyframes::MAX_KEYS;
use crate::lighting::FrameLight;
use crate::rain::physics::{G_MPS2, ThinLens};
use crate::rain::volume::drop::inv_height_q;
use crate::rain::volume::{SplitTime, mean_travel_cells, near_clip_m};
use crate::scene::Camera;
use crate::shot::RainPlan;

/// A shot's rain plan packed for the GPU: the uniforms (without the per-frame fields) and the
/// columns. It reads as its plan (`setup.volume`, `setup.wind`…) through `Deref`.
#[derive(Debug, Clone)]
pub struct RainSetup {
    /// The plan packed here.
    pub plan: RainPlan,
    /// Uniforms; the time-dependent fields are filled by [`RainSetup::params_at`].
    pub params: RainParams,
    /// Columns in drop-id order (at least one, possibly empty, so the buffer binds).
    pub columns: Vec<Column>,
}

impl std::ops::Deref for RainSetup {
    type Target = RainPlan;
    fn deref(&self) -> &RainPlan {
        &self.plan
    }
}

/// Maps display pixels to coded pixels for a display rotation of `rotation_deg`, in `f32` for
/// the uniforms ([`crate::video::frame::coded_from_display`]).
/// Returns (column-major 2×2 matrix, offset).
pub fn coded_from_display(rotation_deg: i32, coded_w: f32, coded_h: f32) -> ([f32; 4], [f32; 2]) {
    let (m, o) =
        crate::video::frame::coded_from_display(rotation_deg, coded_w as f64, coded_h as f64);
    (m.map(|v| v as f32), o.map(|v| v as f32))
}

impl RainSetup {
    /// The uniforms and columns of `plan`.
    pub fn pack(plan: RainPlan) -> RainSetup {
        let camera = &plan.first_camera;
        let (volume, model, wind) = (&plan.volume, &plan.model, &plan.wind);
        let grid = &volume.grid;
        let mut columns: Vec<Column> = grid
            .columns
            .iter()
            .map(|c| Column {
                cell_min_m: [c.cell_min_m.x as f32, c.cell_min_m.y as f32],
                z_lo_m: c.z_lo_m as f32,
                height_m: c.height_m() as f32,
                first_drop: c.first_id as u32,
                drop_count: c.count,
                inv_height_q: inv_height_q(c.height_m()),
                size_keep_q: c.size_keep_q,
            })
            .collect();
        if columns.is_empty() {
            columns.push(bytemuck::Zeroable::zeroed());
        }
        let (d_min, d_max) = model.dsd.range_mm();
        let mut gust_amp = [[0.0, 0.0, 1.0, 0.0]; GUSTS];
        for (a, g) in gust_amp.iter_mut().zip(&wind.gusts) {
            *a = [
                g.amplitude_mps.x as f32,
                g.amplitude_mps.y as f32,
                g.omega_radps as f32,
                0.0,
            ];
        }
        let (lens_blur_k_px_m, inv_focus_per_m) = lens_uniforms(camera, plan.lens);
        let (w, h) = plan.coded_size_px;
        let (m, off) = coded_from_display(plan.rotation_deg, w as f32, h as f32);
        // A keyed mean wind starts where its curve does; a plain one is the wind's mean.
        let start_mps = match wind.mean_keys {
            Some(_) => wind.mean_at(0.0),
            None => wind.mean_mps,
        };
        let mut params = RainParams {
            camera_pos_m: [0.0; 3],
            focal_px: 0.0,
            camera_from_world_0: [0.0; 4],
            camera_from_world_1: [0.0; 4],
            camera_from_world_2: [0.0; 4],
            principal_px: camera.principal_px().as_vec2().to_array(),
            display_size_px: [camera.width_px as f32, camera.height_px as f32],
            coded_from_display: m,
            coded_offset_px: off,
            coded_size_px: [w as f32, h as f32],
            column_slope: grid.slope.as_vec2().to_array(),
            cell_size_m: grid
                .cell_size_m
                .max(DVec2::splat(1e-6))
                .as_vec2()
                .to_array(),
            wind_mean_mps: [wind.mean_mps.x as f32, wind.mean_mps.y as f32],
            mean_travel_cells: [0.0; 2],
            haze: [0.0, 0.0, 0.0, 1.0],
            env_sh: [[0.0; 4]; 16],
            drop_zonal: [[0.0; 4]; 3],
            gust_amp,
            gust_phase: [[1.0, 0.0, 1.0, 0.0]; GUSTS],
            time_whole_s: 0,
            time_frac_s: 0.0,
            exposure_s: plan.exposure_s as f32,
            seed: plan.seed,
            drop_count: plan.drop_count(),
            column_count: columns.len() as u32,
            opacity: plan.opacity as f32,
            near_clip_m: near_clip_m(plan.near_m) as f32,
            drop_weight: volume.weight as f32,
            d_min_mm: d_min as f32,
            d_max_mm: d_max as f32,
            lambda_per_mm: model.dsd.lambda_per_mm() as f32,
            diameter_scale: volume.motion.diameter_scale as f32,
            lens_blur_k_px_m,
            inv_focus_per_m,
            gravity_mps2: G_MPS2 as f32,
            drift_q: volume.motion.drift_q,
            ground_clip: plan.ground as u32,
            _pad: 0,
            wind_slope_mps2: [0.0; 2],
            wind_start_mps: [start_mps.x as f32, start_mps.y as f32],
            wind_kink_count: 0,
            rate_key_count: 0,
            _pad_keys: [0; 2],
            wind_kinks: [[0.0; 4]; MAX_KEYS],
            rate_keys: [[0.0; 4]; MAX_KEYS],
            speed_q: volume.motion.speed_q,
        };
        set_camera(&mut params, camera);
        RainSetup {
            plan,
            params,
            columns,
        }
    }

    /// The uniforms at time `t_s`, the drops lit by `light` with transfer coefficients
    /// `drop_zonal` (see [`crate::lighting::LightEstimator`]).
    pub fn params_at(&self, t_s: f64, light: &FrameLight, drop_zonal: [[f32; 4]; 3]) -> RainParams {
        let mut p = self.motion_at(t_s);
        p.env_sh = light.env.to_gpu_array();
        p.drop_zonal = drop_zonal;
        // The far drops of the haze scatter the same light as the drawn ones; the haze spans
        // the farthest drawn drop to the scene (where its compact lights' glow is integrated),
        // or to the ground where a ray meets it sooner (its extinction per metre, z).
        let alpha = self.haze_at(t_s);
        let span_m = self.scene_depth_m - self.volume.far_m;
        let beta_per_m = if alpha > 0.0 && span_m > 0.0 {
            -(-alpha).ln_1p() / span_m
        } else {
            0.0
        };
        p.haze = [
            self.volume.far_m as f32,
            self.scene_depth_m as f32,
            beta_per_m as f32,
            1.0 - alpha as f32,
        ];
        p
    }

    /// The uniforms and the compact lights at time `t_s`, the drops lit by `light` with
    /// transfer coefficients `drop_zonal`: everything the frame's stages read.
    pub fn frame_uniforms(
        &self,
        t_s: f64,
        light: &FrameLight,
        drop_zonal: [[f32; 4]; 3],
    ) -> (RainParams, LightList) {
        (
            self.params_at(t_s, light, drop_zonal),
            LightList::new(&light.lights),
        )
    }

    /// The uniforms at time `t_s`, unlit: the drops' motion only. The time is split into whole
    /// seconds and a fraction; gust phases and the mean wind's travel (modulo a cell) are
    /// computed in `f64` here, so the shader never takes the cosine of a large argument in
    /// `f32` nor loses a drop's phase as t grows.
    pub fn motion_at(&self, t_s: f64) -> RainParams {
        let mut p = self.params;
        let t = SplitTime::new(t_s);
        p.time_whole_s = t.whole_s;
        p.time_frac_s = t.frac_s as f32;
        let travel = mean_travel_cells(&self.wind, &self.volume.grid, t);
        p.mean_travel_cells = [travel.x as f32, travel.y as f32];
        let t_s = t.seconds();
        self.keyed_at(&mut p, t_s);
        for (ph, g) in p.gust_phase.iter_mut().zip(&self.wind.gusts) {
            let x = g.omega_radps * t_s + g.phase_rad;
            *ph = [
                x.cos() as f32,
                x.sin() as f32,
                g.phase_rad.cos() as f32,
                g.phase_rad.sin() as f32,
            ];
        }
        p
    }

    /// The keyed settings' fields of `p` at `t_s`: the mean wind, its slope and its changes so
    /// far; the rate's keys relative to now (f32 stays exact in the drops' ages however long
    /// the clip); opacity and lens.
    fn keyed_at(&self, p: &mut RainParams, t_s: f64) {
        let f2 = |v: DVec2| [v.x as f32, v.y as f32];
        if self.wind.mean_keys.is_some() {
            p.wind_mean_mps = f2(self.wind.mean_at(t_s));
            p.wind_slope_mps2 = f2(self.wind.mean_slope_at(t_s));
            let kinks = self.wind.mean_kinks_before(t_s);
            p.wind_kink_count = kinks.len() as u32;
            for (slot, (dt, db)) in p.wind_kinks.iter_mut().zip(kinks) {
                *slot = [dt as f32, db.x as f32, db.y as f32, 0.0];
            }
        }
        if let Some(k) = &self.model.rate_keys {
            p.rate_key_count = k.keys().len() as u32;
            for (slot, &(tk, r)) in p.rate_keys.iter_mut().zip(k.keys()) {
                *slot = [(tk - t_s) as f32, r as f32, 0.0, 0.0];
            }
        }
        if let Some(k) = &self.keys.opacity {
            p.opacity = k.at(t_s) as f32;
        }
        if self.keys_move_lens() {
            let camera = self.camera_at(t_s);
            if self.keys.moves_camera() {
                set_camera(p, &camera);
            }
            (p.lens_blur_k_px_m, p.inv_focus_per_m) = lens_uniforms(&camera, self.lens_at(t_s));
        }
    }

    /// With `ground` true, streaks end where their drops land on the ground z = 0 (see
    /// [`RainPlan::with_ground`]).
    pub fn with_ground(mut self, ground: bool) -> RainSetup {
        self.plan.ground = ground;
        self.params.ground_clip = ground as u32;
        self
    }

    /// Streaks drawn with `mattes` (`None`: the capsule).
    pub fn with_mattes(
        mut self,
        mattes: Option<std::sync::Arc<crate::drops::MatteAtlas>>,
    ) -> RainSetup {
        self.plan.mattes = mattes;
        self
    }

    /// The ground z = 0 wets as `wetting` says (`None`: a dry ground, or none).
    pub fn with_wetting(mut self, wetting: Option<crate::lighting::wetness::Wetting>) -> RainSetup {
        self.plan = self.plan.with_wetting(wetting);
        self
    }

    /// With `depth` true, the compositor holds a depth map of the displayed picture and hides
    /// drops behind the scene (`Compositor::set_scene_depth`).
    pub fn with_scene_depth(mut self, depth: bool) -> RainSetup {
        self.plan.scene_depth = depth;
        self
    }

    /// Drops drawn per frame.
    pub fn drop_count(&self) -> u32 {
        self.params.drop_count
    }
}

/// The camera's fields of `p`: its centre, focal length and rotation.
pub(crate) fn set_camera(p: &mut RainParams, camera: &Camera) {
    let r = camera.world_from_camera.transpose();
    let row = |k: usize| {
        let v = r.row(k);
        [v.x as f32, v.y as f32, v.z as f32, 0.0]
    };
    let c = camera.position_m;
    p.camera_pos_m = [c.x as f32, c.y as f32, c.z as f32];
    p.focal_px = camera.focal_px() as f32;
    p.camera_from_world_0 = row(0);
    p.camera_from_world_1 = row(1);
    p.camera_from_world_2 = row(2);
}

/// The defocus uniforms of `lens` (`None`: a pinhole): k of the circle of confusion's diameter
/// k·|1/focus − 1/z| px, and 1/focus.
fn lens_uniforms(camera: &Camera, lens: Option<ThinLens>) -> (f32, f32) {
    lens.map_or((0.0, 0.0), |l| {
        // Read k off the lens at half the focus distance.
        let z = 0.5 * l.focus_m;
        (
            (l.coc_diameter_px(camera, z) / (1.0 / l.focus_m - 1.0 / z).abs()) as f32,
            (1.0 / l.focus_m) as f32,
        )
    })
}
