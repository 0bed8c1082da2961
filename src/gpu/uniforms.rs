//! The uniforms builder: the rain volume planned for the shot (`rain::volume`, CPU physics
//! only) and the frame's light, packed into the uniforms and column buffer the stages read
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
use crate::config::{CameraConfig, RainConfig};
use crate::keyframes::{Keyframes, MAX_KEYS};
use crate::lighting::FrameLight;
use crate::rain::physics::{DsdShape, G_MPS2, RainModel, RainRate, ThinLens, haze_alpha};
use crate::rain::volume::drop::inv_height_q;
use crate::rain::volume::{RainVolume, SplitTime, VolumeParams, mean_travel_cells};
use crate::rain::wind::Wind;
use crate::scene::Camera;
use crate::{Error, Result};

/// The drops of a shot: the plan, and uniforms (without the per-frame fields) and columns
/// ready for the GPU.
#[derive(Debug, Clone)]
pub struct RainSetup {
    /// Uniforms; the time-dependent fields are filled by [`RainSetup::params_at`].
    pub params: RainParams,
    /// Columns in drop-id order (at least one, possibly empty, so the buffer binds).
    pub columns: Vec<Column>,
    /// The plan: distances, counts, weights, bands.
    pub volume: RainVolume,
    /// Rain rate, sizes and fall speeds.
    pub model: RainModel,
    /// The wind.
    pub wind: Wind,
    /// Opacity of the rain between the farthest drawn drop and the scene (0 without haze).
    pub haze_alpha: f64,
    /// How the ground wets, where a ground is given and rain has fallen on it.
    pub wetting: Option<crate::scene::wetness::Wetting>,
    /// Whether drops are hidden behind the scene's depth map (set per frame with
    /// `Compositor::set_scene_depth`); false leaves the render as without one.
    pub scene_depth: bool,
    /// The streak mattes (`--streaks mattes`); `None` draws the capsule.
    pub mattes: Option<std::sync::Arc<crate::drops::MatteAtlas>>,
    /// The settings that change over the shot, read per frame (the rate's and the wind's
    /// curves also live in `model` and `wind`, which the drops follow).
    pub keys: Keyframes,
    /// What a keyed focus or aperture needs per frame: the camera and its lens settings.
    lens_camera: (Camera, CameraConfig),
    /// Distance of the filmed scene, m (the haze ends there).
    scene_depth_m: f64,
}

/// Maps display pixels to coded pixels for a display rotation of `rotation_deg`, in `f32` for
/// the uniforms ([`crate::video::frame::coded_from_display`]).
/// Returns (column-major 2×2 matrix, offset).
pub fn coded_from_display(rotation_deg: i32, coded_w: f32, coded_h: f32) -> ([f32; 4], [f32; 2]) {
    let (m, o) =
        crate::video::frame::coded_from_display(rotation_deg, coded_w as f64, coded_h as f64);
    (m.map(|v| v as f32), o.map(|v| v as f32))
}

/// What the volume plan needs from the configuration: the one place that turns the camera and
/// rain settings into [`VolumeParams`], so `inspect drops` prints the plan the render uses.
pub fn plan_params(
    camera_config: &CameraConfig,
    rain: &RainConfig,
    exposure_s: f64,
) -> Result<VolumeParams> {
    let lens = if camera_config.f_number > 0.0 {
        Some(ThinLens::new(
            camera_config.sensor_width_mm,
            camera_config.f_number,
            camera_config.focus_m,
        )?)
    } else {
        None
    };
    Ok(VolumeParams {
        exposure_s,
        near_m: rain.near_m,
        far_max_m: rain.far_m,
        budget: rain.max_drops.max(1) as u64,
        lens,
        ground_z_m: Some(0.0),
        diameter_scale: rain.drop_scale,
        fall_speed_scale: rain.fall_speed_scale,
        ..VolumeParams::default()
    })
}

/// Plans the rain of a shot seen by `camera` (the displayed picture) and prepares the GPU
/// inputs for a coded picture of `coded_size_px`.
pub fn build(
    camera: &Camera,
    camera_config: &CameraConfig,
    rain: &RainConfig,
    exposure_s: f64,
    rotation_deg: i32,
    coded_size_px: (u32, u32),
) -> Result<RainSetup> {
    let path = CameraPath {
        cameras: std::slice::from_ref(camera),
        step_rad: 0.0,
    };
    build_on(
        path,
        camera_config,
        rain,
        exposure_s,
        rotation_deg,
        coded_size_px,
    )
}

/// A moving camera sampled over the shot (the first at t = 0), at most `step_rad` of turn
/// between samples.
#[derive(Clone, Copy)]
struct CameraPath<'a> {
    cameras: &'a [Camera],
    step_rad: f64,
}

/// Most turn between the camera poses a moving camera's rain volume is planned for, degrees
/// (the frusta between are covered by widening each by half of it).
const PATH_STEP_DEG: f64 = 1.0;

/// Most poses planned between the keys: each costs milliseconds, so a camera that turns far
/// is planned at a coarser step (wider frusta) rather than for minutes.
pub const MAX_PATH_POSES: usize = 360;

/// Coarsest step the planning takes, degrees: a camera that turns further than
/// [`MAX_PATH_POSES`] of these over the shot is refused (its frusta would be too wide).
pub const MAX_PATH_STEP_DEG: f64 = 10.0;

/// The step a moving camera's path is planned at: [`PATH_STEP_DEG`], coarser where that would
/// take more than [`MAX_PATH_POSES`] poses (with a warning).
fn path_step_deg(keys: &Keyframes) -> Result<f64> {
    let poses = keys.camera_samples_s(PATH_STEP_DEG).len();
    if poses <= MAX_PATH_POSES {
        return Ok(PATH_STEP_DEG);
    }
    let step = PATH_STEP_DEG * poses as f64 / MAX_PATH_POSES as f64;
    if step > MAX_PATH_STEP_DEG {
        return Err(Error::Parameter {
            name: "camera keys",
            value: format!("a turn of about {} degrees over the shot", poses - 1),
            expected: format!(
                "at most {:.0} degrees of pan, tilt and roll in all",
                MAX_PATH_STEP_DEG * MAX_PATH_POSES as f64
            ),
        });
    }
    log::warn!(
        "moving camera: the camera turns about {} degrees over the shot; the rain volume is \
         planned every {step:.1} degrees (at most {MAX_PATH_POSES} poses), with wider columns",
        poses - 1
    );
    Ok(step)
}

/// [`build`] for the camera path `path`: the volume is planned for all its poses, the
/// uniforms hold the first.
fn build_on(
    path: CameraPath,
    camera_config: &CameraConfig,
    rain: &RainConfig,
    exposure_s: f64,
    rotation_deg: i32,
    coded_size_px: (u32, u32),
) -> Result<RainSetup> {
    let camera = &path.cameras[0];
    let model = RainModel::new(
        RainRate::from_mm_per_h(rain.rate_mm_per_h)?,
        DsdShape::MarshallPalmer,
        rain.altitude_m,
    )?;
    let wind = Wind::new(DVec2::from(rain.wind_mps), rain.gust_mps, rain.seed as u64)?;
    let plan = plan_params(camera_config, rain, exposure_s)?;
    let lens = plan.lens;
    let volume = RainVolume::plan_moving(path.cameras, path.step_rad, &model, &wind, &plan)?;
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
            _pad: 0,
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
    let (lens_blur_k_px_m, inv_focus_per_m) = lens_uniforms(camera, lens);
    let (m, off) = coded_from_display(rotation_deg, coded_size_px.0 as f32, coded_size_px.1 as f32);
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
        coded_size_px: [coded_size_px.0 as f32, coded_size_px.1 as f32],
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
        exposure_s: exposure_s as f32,
        seed: rain.seed,
        drop_count: volume.simulated.min(u32::MAX as u64) as u32,
        column_count: columns.len() as u32,
        opacity: rain.opacity as f32,
        near_clip_m: (0.5 * rain.near_m).max(0.02) as f32,
        drop_weight: volume.weight as f32,
        d_min_mm: d_min as f32,
        d_max_mm: d_max as f32,
        lambda_per_mm: model.dsd.lambda_per_mm() as f32,
        diameter_scale: volume.motion.diameter_scale as f32,
        lens_blur_k_px_m,
        inv_focus_per_m,
        gravity_mps2: G_MPS2 as f32,
        drift_q: volume.motion.drift_q,
        ground_clip: 0,
        _pad: 0,
        wind_slope_mps2: [0.0; 2],
        wind_start_mps: [wind.mean_mps.x as f32, wind.mean_mps.y as f32],
        wind_kink_count: 0,
        rate_key_count: 0,
        _pad_keys: [0; 2],
        wind_kinks: [[0.0; 4]; MAX_KEYS],
        rate_keys: [[0.0; 4]; MAX_KEYS],
        speed_q: volume.motion.speed_q,
    };
    set_camera(&mut params, camera);
    // Rain between the farthest drawn drop and the scene veils it (Weber et al. extinction).
    let haze_alpha = if rain.scene_depth_m > volume.far_m {
        haze_alpha(model.rate, volume.far_m, rain.scene_depth_m)
    } else {
        0.0
    };
    Ok(RainSetup {
        params,
        columns,
        volume,
        model,
        wind,
        haze_alpha,
        wetting: None,
        scene_depth: false,
        mattes: None,
        keys: Keyframes::default(),
        lens_camera: (*camera, *camera_config),
        scene_depth_m: rain.scene_depth_m,
    })
}

/// The camera's fields of `p`: its centre, focal length and rotation.
fn set_camera(p: &mut RainParams, camera: &Camera) {
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

/// [`build`] for a configuration whose settings may change over the shot (`keys`): the rain
/// is planned for the peak rate, and for the focus and aperture (at any key) that see rain
/// farthest, so every frame's drops are among the planned ones; the drops then follow the
/// keyed rate and wind, and each frame reads its opacity and lens ([`RainSetup::motion_at`]).
pub fn build_keyed(
    camera: &Camera,
    camera_config: &CameraConfig,
    rain: &RainConfig,
    keys: &Keyframes,
    exposure_s: f64,
    rotation_deg: i32,
    coded_size_px: (u32, u32),
) -> Result<RainSetup> {
    let plain = || {
        build(
            camera,
            camera_config,
            rain,
            exposure_s,
            rotation_deg,
            coded_size_px,
        )
    };
    if keys.is_empty() {
        return plain();
    }
    // Of the keyed settings only the lens moves the far distance (the rate is planned at its
    // peak, the columns lean with the keys' mean wind): one plan per lens key, else one.
    let mut lens_times: Vec<f64> = [&keys.focus_m, &keys.f_number]
        .into_iter()
        .flatten()
        .flat_map(|c| c.keys().iter().map(|k| k.0))
        .collect();
    lens_times.sort_by(f64::total_cmp);
    lens_times.dedup();
    if lens_times.is_empty() {
        lens_times.push(0.0);
    }
    // A moving camera: the volume covers the frusta of the poses over the shot.
    let step_deg = if keys.moves_camera() {
        path_step_deg(keys)?
    } else {
        PATH_STEP_DEG
    };
    let cameras: Vec<Camera> = if keys.moves_camera() {
        let (w, h) = (camera.width_px, camera.height_px);
        keys.camera_samples_s(step_deg)
            .into_iter()
            .map(|t| camera_at(camera_config, keys, w, h, t))
            .collect()
    } else {
        vec![*camera]
    };
    let path = CameraPath {
        cameras: &cameras,
        step_rad: step_deg.to_radians(),
    };
    if cameras.len() > 1 {
        log::info!(
            "moving camera: rain volume planned for {} poses over the shot",
            cameras.len()
        );
    }
    let mut planned = None;
    for t in lens_times {
        let mut at = crate::config::RenderConfig {
            camera: *camera_config,
            rain: *rain,
            ..Default::default()
        };
        keys.apply_at(&mut at, t);
        at.rain.rate_mm_per_h = keys
            .rate_mm_per_h
            .as_ref()
            .map_or(rain.rate_mm_per_h, |k| k.max());
        if let Some(w) = &keys.wind_mps {
            // The columns lean with the wind the drops see on average over the keys.
            let k = w.keys();
            at.rain.wind_mps = (k.iter().map(|k| k.1).sum::<DVec2>() / k.len() as f64).to_array();
        }
        let setup = build_on(
            path,
            &at.camera,
            &at.rain,
            exposure_s,
            rotation_deg,
            coded_size_px,
        )?;
        if planned
            .as_ref()
            .is_none_or(|p: &RainSetup| setup.volume.far_m > p.volume.far_m)
        {
            planned = Some(setup);
        }
    }
    let Some(mut setup) = planned else {
        return plain();
    };
    if let Some(k) = &keys.rate_mm_per_h {
        setup.model = setup.model.with_rate_keys(k);
    }
    if let Some(k) = &keys.wind_mps {
        setup.wind = setup.wind.clone().with_mean_keys(k);
        let w0 = setup.wind.mean_at(0.0);
        setup.params.wind_start_mps = [w0.x as f32, w0.y as f32];
    }
    setup.keys = keys.clone();
    setup.lens_camera = (*camera, *camera_config);
    Ok(setup)
}

/// The camera of `config` with `keys` applied at `t_s`, for a `width_px`×`height_px` picture.
fn camera_at(
    config: &CameraConfig,
    keys: &Keyframes,
    width_px: u32,
    height_px: u32,
    t_s: f64,
) -> Camera {
    let mut at = crate::config::RenderConfig {
        camera: *config,
        ..Default::default()
    };
    keys.apply_at(&mut at, t_s);
    at.camera.camera(width_px, height_px)
}

impl RainSetup {
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

    /// The haze's opacity at `t_s`: [`RainSetup::haze_alpha`] (the peak's) scaled to the keyed
    /// rate then.
    pub fn haze_at(&self, t_s: f64) -> f64 {
        match &self.model.rate_keys {
            Some(k) if self.haze_alpha > 0.0 => RainRate::from_mm_per_h(k.at(t_s))
                .map_or(0.0, |r| {
                    haze_alpha(r, self.volume.far_m, self.scene_depth_m)
                }),
            _ => self.haze_alpha,
        }
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
        let moving = self.keys.moves_camera();
        if moving || self.keys.focus_m.is_some() || self.keys.f_number.is_some() {
            let (mut camera, mut lens) = self.lens_camera;
            if moving {
                camera = self.camera_at(t_s);
                set_camera(p, &camera);
            }
            if let Some(k) = &self.keys.focus_m {
                lens.focus_m = k.at(t_s);
            }
            if let Some(k) = &self.keys.f_number {
                lens.f_number = k.at(t_s);
            }
            // Validated: keyed values are in range, so the lens exists.
            let thin = (lens.f_number > 0.0)
                .then(|| ThinLens::new(lens.sensor_width_mm, lens.f_number, lens.focus_m).ok())
                .flatten();
            (p.lens_blur_k_px_m, p.inv_focus_per_m) = lens_uniforms(&camera, thin);
        }
    }

    /// The camera of the frame shown at `t_s` (the displayed picture): the shot's camera, or
    /// for a keyed pose or zoom, the camera at that time.
    pub fn camera_at(&self, t_s: f64) -> Camera {
        let (camera, config) = &self.lens_camera;
        if self.keys.moves_camera() {
            camera_at(config, &self.keys, camera.width_px, camera.height_px, t_s)
        } else {
            *camera
        }
    }

    /// With `ground` true, streaks end where their drops land on the ground z = 0 the volume
    /// stands on (a ground is given); false leaves the render as without a ground.
    pub fn with_ground(mut self, ground: bool) -> RainSetup {
        self.params.ground_clip = ground as u32;
        self
    }

    /// Streaks drawn with `mattes` (`None`: the capsule).
    pub fn with_mattes(
        mut self,
        mattes: Option<std::sync::Arc<crate::drops::MatteAtlas>>,
    ) -> RainSetup {
        self.mattes = mattes;
        self
    }

    /// The ground z = 0 wets as `wetting` says (`None`: a dry ground, or none).
    pub fn with_wetting(mut self, wetting: Option<crate::scene::wetness::Wetting>) -> RainSetup {
        self.wetting = wetting.filter(|w| w.ever_wet());
        self
    }

    /// With `depth` true, the compositor holds a depth map of the displayed picture and hides
    /// drops behind the scene (`Compositor::set_scene_depth`).
    pub fn with_scene_depth(mut self, depth: bool) -> RainSetup {
        self.scene_depth = depth;
        self
    }

    /// Drops drawn per frame.
    pub fn drop_count(&self) -> u32 {
        self.params.drop_count
    }

    /// The plan in one line, for `-v`.
    pub fn summary(&self) -> String {
        self.volume.summary()
    }
}
