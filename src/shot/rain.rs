//! The rain plan of a shot, on the CPU: the volume of drops planned for the camera (or every
//! pose of a keyed camera), the rain's model and wind, and what each frame reads from the keyed
//! settings. `gpu::uniforms` packs it for the stages; nothing here knows the GPU.

use glam::DVec2;

use crate::config::{CameraConfig, RainConfig, RenderConfig};
use crate::keyframes::Keyframes;
use crate::rain::physics::{DsdShape, RainModel, RainRate, ThinLens, haze_alpha};
use crate::rain::volume::{RainVolume, VolumeParams};
use crate::rain::wind::Wind;
use crate::scene::Camera;
use crate::{Error, Result};

/// The drops of a shot: where they are planned, how they fall, what the keyed settings do to
/// them over the shot, and what the picture around them is (ground, depth map, mattes).
#[derive(Debug, Clone)]
pub struct RainPlan {
    /// The plan: distances, counts, weights, bands.
    pub volume: RainVolume,
    /// Rain rate, sizes and fall speeds.
    pub model: RainModel,
    /// The wind.
    pub wind: Wind,
    /// The seed every drop's randomness derives from.
    pub seed: u32,
    /// Opacity of the rain between the farthest drawn drop and the scene (0 without haze).
    pub haze_alpha: f64,
    /// How the ground wets, where a ground is given and rain has fallen on it.
    pub wetting: Option<crate::lighting::wetness::Wetting>,
    /// Whether streaks end where their drops land on the ground z = 0 (a ground is given).
    pub ground: bool,
    /// Whether drops are hidden behind the scene's depth map (set per frame on the
    /// compositor); false leaves the render as without one.
    pub scene_depth: bool,
    /// The streak mattes (`--streaks mattes`); `None` draws the capsule.
    pub mattes: Option<std::sync::Arc<crate::drops::MatteAtlas>>,
    /// How the GPU draws the capsule streaks (`gpu_raster`).
    pub gpu_raster: crate::config::GpuRaster,
    /// The settings that change over the shot, read per frame (the rate's and the wind's
    /// curves also live in `model` and `wind`, which the drops follow).
    pub keys: Keyframes,
    /// The camera at the shot's start (the first pose a keyed camera takes).
    pub first_camera: Camera,
    /// The lens the volume was planned for (`None`: a pinhole).
    pub lens: Option<ThinLens>,
    /// Exposure time, s.
    pub exposure_s: f64,
    /// The rain's opacity (before keys).
    pub opacity: f64,
    /// Nearest drawn drop, m.
    pub near_m: f64,
    /// Display rotation of the video, degrees.
    pub rotation_deg: i32,
    /// The coded picture's size, pixels.
    pub coded_size_px: (u32, u32),
    /// What a keyed focus or aperture needs per frame: the camera and its lens settings.
    lens_camera: (Camera, CameraConfig),
    /// Distance of the filmed scene, m (the haze ends there).
    pub scene_depth_m: f64,
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
        opacity_max: rain.opacity,
        ..VolumeParams::default()
    })
}

/// Plans the rain of a shot seen by `camera` (the displayed picture) of a coded picture of
/// `coded_size_px`.
pub fn plan(
    camera: &Camera,
    camera_config: &CameraConfig,
    rain: &RainConfig,
    exposure_s: f64,
    rotation_deg: i32,
    coded_size_px: (u32, u32),
) -> Result<RainPlan> {
    let path = CameraPath {
        cameras: std::slice::from_ref(camera),
        step_rad: 0.0,
    };
    plan_on(
        path,
        camera_config,
        rain,
        &Keyframes::default(),
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
pub const PATH_STEP_DEG: f64 = 1.0;

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

/// [`plan`] for the camera path `path`: the volume is planned for all its poses, the shot
/// starts at the first; the sizes it simulates are those that can show under any of `keys`'
/// opacities, winds and lenses.
fn plan_on(
    path: CameraPath,
    camera_config: &CameraConfig,
    rain: &RainConfig,
    keys: &Keyframes,
    exposure_s: f64,
    rotation_deg: i32,
    coded_size_px: (u32, u32),
) -> Result<RainPlan> {
    let camera = &path.cameras[0];
    let model = RainModel::new(
        RainRate::from_mm_per_h(rain.rate_mm_per_h)?,
        DsdShape::MarshallPalmer,
        rain.altitude_m,
    )?;
    let wind = Wind::new(DVec2::from(rain.wind_mps), rain.gust_mps, rain.seed as u64)?;
    let mut params = plan_params(camera_config, rain, exposure_s)?;
    if let Some(k) = &keys.opacity {
        params.opacity_max = params.opacity_max.max(k.max());
    }
    if let Some(k) = &keys.wind_mps {
        let top = k.keys().iter().map(|k| k.1.length()).fold(0.0, f64::max);
        params.wind_max_mps = Some(top);
    }
    params.lens_keyed = keys.focus_m.is_some() || keys.f_number.is_some();
    let lens = params.lens;
    let volume = RainVolume::plan_moving(path.cameras, path.step_rad, &model, &wind, &params)?;
    // Rain between the farthest drawn drop and the scene veils it (Weber et al. extinction).
    let haze_alpha = if rain.scene_depth_m > volume.far_m {
        haze_alpha(model.rate, volume.far_m, rain.scene_depth_m)
    } else {
        0.0
    };
    Ok(RainPlan {
        volume,
        model,
        wind,
        seed: rain.seed,
        haze_alpha,
        wetting: None,
        ground: false,
        scene_depth: false,
        mattes: None,
        gpu_raster: crate::config::GpuRaster::Fragments,
        keys: Keyframes::default(),
        first_camera: *camera,
        lens,
        exposure_s,
        opacity: rain.opacity,
        near_m: rain.near_m,
        rotation_deg,
        coded_size_px,
        lens_camera: (*camera, *camera_config),
        scene_depth_m: rain.scene_depth_m,
    })
}

/// [`plan`] for a configuration whose settings may change over the shot (`keys`): the rain
/// is planned for the peak rate, and for the focus and aperture (at any key) that see rain
/// farthest, so every frame's drops are among the planned ones; the drops then follow the
/// keyed rate and wind, and each frame reads its opacity and lens.
pub fn plan_keyed(
    camera: &Camera,
    camera_config: &CameraConfig,
    rain: &RainConfig,
    keys: &Keyframes,
    exposure_s: f64,
    rotation_deg: i32,
    coded_size_px: (u32, u32),
) -> Result<RainPlan> {
    let plain = || {
        plan(
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
        let mut at = RenderConfig {
            camera: *camera_config,
            rain: *rain,
            ..Default::default()
        };
        at.apply_keys_at(keys, t);
        at.rain.rate_mm_per_h = keys
            .rate_mm_per_h
            .as_ref()
            .map_or(rain.rate_mm_per_h, |k| k.max());
        if let Some(w) = &keys.wind_mps {
            // The columns lean with the wind the drops see on average over the keys.
            let k = w.keys();
            at.rain.wind_mps = (k.iter().map(|k| k.1).sum::<DVec2>() / k.len() as f64).to_array();
        }
        let plan = plan_on(
            path,
            &at.camera,
            &at.rain,
            keys,
            exposure_s,
            rotation_deg,
            coded_size_px,
        )?;
        if planned
            .as_ref()
            .is_none_or(|p: &RainPlan| plan.volume.far_m > p.volume.far_m)
        {
            planned = Some(plan);
        }
    }
    let Some(mut plan) = planned else {
        return plain();
    };
    if let Some(k) = &keys.rate_mm_per_h {
        plan.model = plan.model.with_rate_keys(k);
    }
    if let Some(k) = &keys.wind_mps {
        plan.wind = plan.wind.clone().with_mean_keys(k);
    }
    plan.keys = keys.clone();
    plan.lens_camera = (*camera, *camera_config);
    Ok(plan)
}

/// Most turn and zoom between the camera poses the water's ground is laid out for, degrees
/// ([`CameraTrack::poses`]): the views between two of them overlap theirs by far.
pub const GROUND_VIEW_STEP_DEG: f64 = 1.0;

/// The camera of each frame of a shot: [`RainPlan::camera_at`] without the rain.
#[derive(Debug, Clone)]
pub struct CameraTrack {
    first: Camera,
    config: CameraConfig,
    /// The pose keys, where they move the camera.
    keys: Option<Keyframes>,
}

impl CameraTrack {
    /// The camera of the frame shown at `t_s`.
    pub fn at(&self, t_s: f64) -> Camera {
        match &self.keys {
            Some(keys) => camera_at(
                &self.config,
                keys,
                self.first.width_px,
                self.first.height_px,
                t_s,
            ),
            None => self.first,
        }
    }

    /// The camera at the shot's start.
    pub fn first(&self) -> Camera {
        self.first
    }

    /// The cameras over the shot no further apart than `step_deg` of turn and zoom along the
    /// keys' path ([`Keyframes::camera_samples_s`]), the first at t = 0; the one camera of a
    /// still shot.
    pub fn poses(&self, step_deg: f64) -> Vec<Camera> {
        match &self.keys {
            Some(keys) => keys
                .camera_samples_s(step_deg)
                .into_iter()
                .map(|t| self.at(t))
                .collect(),
            None => vec![self.first],
        }
    }
}

/// The camera of `config` with `keys` applied at `t_s`, for a `width_px`×`height_px` picture.
fn camera_at(
    config: &CameraConfig,
    keys: &Keyframes,
    width_px: u32,
    height_px: u32,
    t_s: f64,
) -> Camera {
    let mut at = RenderConfig {
        camera: *config,
        ..Default::default()
    };
    at.apply_keys_at(keys, t_s);
    at.camera.camera(width_px, height_px)
}

impl RainPlan {
    /// The haze's opacity at `t_s`: [`RainPlan::haze_alpha`] (the peak's) scaled to the keyed
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

    /// The cameras of the shot's frames, apart from the rain (what the water on the ground
    /// needs of them).
    pub fn camera_track(&self) -> CameraTrack {
        CameraTrack {
            first: self.lens_camera.0,
            config: self.lens_camera.1,
            keys: self.keys.moves_camera().then(|| Keyframes {
                pan_deg: self.keys.pan_deg.clone(),
                tilt_deg: self.keys.tilt_deg.clone(),
                roll_deg: self.keys.roll_deg.clone(),
                height_m: self.keys.height_m.clone(),
                fov_deg: self.keys.fov_deg.clone(),
                ..Keyframes::default()
            }),
        }
    }

    /// Whether a keyed pose, zoom, focus or aperture changes the camera or its lens over the
    /// shot.
    pub fn keys_move_lens(&self) -> bool {
        self.keys.moves_camera() || self.keys.focus_m.is_some() || self.keys.f_number.is_some()
    }

    /// The lens at `t_s` with a keyed focus or aperture applied (`None`: a pinhole). Keyed
    /// values are validated in range, so a lens with an f-number exists.
    pub fn lens_at(&self, t_s: f64) -> Option<ThinLens> {
        let mut lens = self.lens_camera.1;
        if let Some(k) = &self.keys.focus_m {
            lens.focus_m = k.at(t_s);
        }
        if let Some(k) = &self.keys.f_number {
            lens.f_number = k.at(t_s);
        }
        (lens.f_number > 0.0)
            .then(|| ThinLens::new(lens.sensor_width_mm, lens.f_number, lens.focus_m).ok())
            .flatten()
    }

    /// With `ground` true, streaks end where their drops land on the ground z = 0 the volume
    /// stands on (a ground is given); false leaves the render as without a ground.
    pub fn with_ground(mut self, ground: bool) -> RainPlan {
        self.ground = ground;
        self
    }

    /// Streaks drawn with `mattes` (`None`: the capsule).
    pub fn with_mattes(mut self, mattes: Option<std::sync::Arc<crate::drops::MatteAtlas>>) -> Self {
        self.mattes = mattes;
        self
    }

    /// The capsule streaks drawn on the GPU by `raster`.
    pub fn with_gpu_raster(mut self, raster: crate::config::GpuRaster) -> Self {
        self.gpu_raster = raster;
        self
    }

    /// The ground z = 0 wets as `wetting` says (`None`: a dry ground, or none).
    pub fn with_wetting(mut self, wetting: Option<crate::lighting::wetness::Wetting>) -> RainPlan {
        self.wetting = wetting.filter(|w| w.ever_wet());
        self
    }

    /// With `depth` true, the compositor holds a depth map of the displayed picture and hides
    /// drops behind the scene.
    pub fn with_scene_depth(mut self, depth: bool) -> RainPlan {
        self.scene_depth = depth;
        self
    }

    /// The rain its drops see: volume, model, wind and seed.
    pub fn rainfall(&self) -> crate::rain::volume::Rainfall<'_> {
        crate::rain::volume::Rainfall::new(&self.volume, &self.model, &self.wind, self.seed)
    }

    /// Drops drawn per frame.
    pub fn drop_count(&self) -> u32 {
        self.volume.simulated.min(u32::MAX as u64) as u32
    }

    /// The plan in one line, for `-v`.
    pub fn summary(&self) -> String {
        self.volume.summary()
    }
}
