//! Only the sizes that show: per column, the smallest drop diameter whose streak can change a
//! pixel by the renderer's own cull, so the emitter samples Marshall–Palmer truncated below it
//! and simulates only that share of the column's drops (docs/method.md §3.7, "Sizes").
//!
//! The renderer draws a drop only when its streak's peak alpha reaches [`MIN_PEAK_ALPHA`]:
//!
//! peak = g · (r/r_eff)² · min(1, 2 r_eff/ℓ),  r_eff = min(max(√(r² + b²), 0.7 px), cap)
//!
//! ([`streak_peak_alpha`]; `segment_streak` in `shaders/common/streak.wgsl`), with r = D′f/2z
//! the drawn radius (D′ = D × drop scale × the Beard & Chuang width factor), b the defocus blur
//! radius at depth z, ℓ the streak's image length and g = opacity × drop weight (the landing
//! fraction only lowers it). The peak grows with r and falls with b and ℓ, so an upper bound of
//! r and lower bounds of b and ℓ over everything a drop of the column may do bound its peak:
//!
//! - **r**: the column's nearest depth (its prism's corners, less the half exposure's travel
//!   and never nearer than the near clip), D′ at the top of the diameter step;
//! - **b**: the least blur over each of 8 depth steps spanning the column (0 where the focus
//!   lies in the step, 0 everywhere with a keyed lens);
//! - **ℓ**: a point at depth z moving at V has image speed (f/z)|V_xy − n V_z| ≥ (f/z)|V_⊥|
//!   (V_⊥ the part of V across the view ray: the gnomonic projection stretches every
//!   direction by at least f/z). A drop falls at v_t(D) (its speed at the bottom of the step,
//!   less the fixed-point table's 0.01 m/s) and drifts horizontally at most w_max (the largest
//!   mean wind plus every gust amplitude), so |V_⊥| ≥ v_t cos e − w_max, e the steepest view
//!   elevation onto the column, and ℓ ≥ T f |V_⊥| / z over the exposure T (the streak shortened
//!   by a landing keeps the bound, its alpha falls with it; a column the near plane may clip
//!   gets ℓ ≥ 0).
//!
//! The smallest diameter whose bound reaches 0.95 × [`MIN_PEAK_ALPHA`] (a margin for the
//! GPU's `f32`) is the column's cut; every drop below it would be culled anyway. Columns that
//! stand on the ground also keep every drop whose splash crown could be drawn (it splashes, and
//! its largest crown is at least the 1 px the splash stage draws), since a crown spreads a
//! small drop's water over a short, bright footprint. A moving camera takes the extremes over
//! its poses (each turned by up to half the planning step).

use glam::{DVec2, DVec3};

use super::VolumeParams;
use super::columns::{Column, ColumnGrid};
use super::drop::{SIZE_KEEP_ALL, SIZE_KEEP_BITS};
use super::impacts::GROUND_TOLERANCE_M;
use crate::rain::physics::splash::{CROWN_S, crown_radius_m, splashes};
use crate::rain::physics::{
    MIN_PEAK_ALPHA, NEAR_FIELD_MAX_RADIUS, RainModel, ThinLens, streak_peak_alpha,
    streak_width_factor,
};
use crate::rain::wind::Wind;
use crate::scene::Camera;

/// Diameter steps of the search over the truncation range.
const DIAMETER_STEPS: usize = 240;
/// Depth steps of a column's range.
const DEPTH_STEPS: usize = 8;
/// The bound must reach this fraction of the cull (room for `f32` on the GPU).
const CULL_MARGIN: f64 = 0.95;
/// How far the fixed-point speed table may fall below Gunn & Kinzer, m/s (it is within 0.004).
const SPEED_SLACK_MPS: f64 = 0.01;

/// The nearest depth the renderer draws (its near clip plane), m, for a plan's `near_m`.
pub fn near_clip_m(near_m: f64) -> f64 {
    (0.5 * near_m).max(0.02)
}

/// The column's share to keep for a cut at `cut_mm`: 1 − F(cut) in 2⁻²⁴, rounded up.
pub fn keep_q(model: &RainModel, cut_mm: f64) -> u32 {
    let s = 1.0 - model.dsd.cdf(cut_mm);
    ((s * (1u64 << SIZE_KEEP_BITS) as f64).ceil().max(0.0) as u64).min(SIZE_KEEP_ALL as u64) as u32
}

/// The smallest diameter a column keeping `keep_q` simulates, mm: F⁻¹(1 − S).
pub fn cut_mm(model: &RainModel, keep_q: u32) -> f64 {
    let s = keep_q.min(SIZE_KEEP_ALL) as f64 / (1u64 << SIZE_KEEP_BITS) as f64;
    model.dsd.diameter_from_uniform_mm(1.0 - s)
}

/// What bounds a drop's streak in the picture, for every pose of the shot.
#[derive(Debug, Clone)]
pub struct SizeBound<'a> {
    poses: &'a [Camera],
    /// Largest turn between a planned pose and the frames between them, rad.
    turn_rad: f64,
    model: &'a RainModel,
    focal_px: f64,
    max_radius_px: f64,
    near_clip_m: f64,
    exposure_s: f64,
    diameter_scale: f64,
    speed_scale: f64,
    wind_max_mps: f64,
    /// The defocus: (1/focus, the least k of blur radius = k |1/focus − 1/z| over the poses);
    /// `None`: no blur is counted on.
    blur: Option<(f64, f64)>,
}

impl<'a> SizeBound<'a> {
    /// The bound for `poses` (a still camera: one) at most `turn_rad` from the frames between
    /// them, the rain `model` and `wind`, under `params`.
    pub fn new(
        poses: &'a [Camera],
        turn_rad: f64,
        model: &'a RainModel,
        wind: &Wind,
        params: &VolumeParams,
    ) -> SizeBound<'a> {
        let focal_px = poses.iter().map(Camera::focal_px).fold(0.0, f64::max);
        let height = poses.iter().map(|c| c.height_px).max().unwrap_or(0) as f64;
        let mean = params
            .wind_max_mps
            .unwrap_or(0.0)
            .max(wind.mean_mps.length());
        let gusts: f64 = wind.gusts.iter().map(|g| g.amplitude_mps.length()).sum();
        let blur = params.lens.filter(|_| !params.lens_keyed).map(|l| {
            (
                1.0 / l.focus_m,
                poses
                    .iter()
                    .map(|c| blur_k_px_m(&l, c))
                    .fold(f64::INFINITY, f64::min),
            )
        });
        SizeBound {
            poses,
            turn_rad,
            model,
            focal_px,
            max_radius_px: NEAR_FIELD_MAX_RADIUS * height,
            near_clip_m: near_clip_m(params.near_m),
            exposure_s: params.exposure_s,
            diameter_scale: params.diameter_scale,
            speed_scale: params.fall_speed_scale,
            wind_max_mps: mean + gusts,
            blur,
        }
    }

    /// Fall speed of diameter `d_mm` as drawn, m/s.
    fn speed_mps(&self, d_mm: f64) -> f64 {
        self.model.fall.terminal_velocity_mps(d_mm) * self.speed_scale
    }

    /// The least blur radius over depths [z0, z1], px.
    fn blur_min_px(&self, z0: f64, z1: f64) -> f64 {
        let Some((inv_focus, k)) = self.blur else {
            return 0.0;
        };
        let (a, b) = (1.0 / z1 - inv_focus, 1.0 / z0 - inv_focus);
        if a <= 0.0 && b >= 0.0 {
            0.0
        } else {
            k * a.abs().min(b.abs())
        }
    }

    /// The smallest diameter, mm, that a drop of `col` (in `grid`) needs for its streak — or,
    /// on the ground, its splash — to pass the cull when its alpha is multiplied by `gain`
    /// (opacity × drop weight); the distribution's largest where none can.
    pub fn cut_mm(&self, grid: &ColumnGrid, col: &Column, gain: f64) -> f64 {
        let (d_lo, d_hi) = self.model.dsd.range_mm();
        let step = (d_hi - d_lo) / DIAMETER_STEPS as f64;
        let g = self.geometry(grid, col);
        let f = self.focal_px;
        let t = self.exposure_s;
        let threshold = CULL_MARGIN * MIN_PEAK_ALPHA;
        let (za, zb) = (g.depth_m[0], g.depth_m[1]);
        let ratio = (zb / za).powf(1.0 / DEPTH_STEPS as f64);
        let visible = |a: f64, b: f64| {
            let radius_m = 0.5e-3 * b * self.diameter_scale * streak_width_factor(b);
            let v = (self.speed_mps(a) - SPEED_SLACK_MPS).max(0.0);
            let across = if g.near_clipped {
                0.0
            } else {
                (v * g.cos_elevation - self.wind_max_mps).max(0.0)
            };
            (0..DEPTH_STEPS).any(|k| {
                let z0 = za * ratio.powi(k as i32);
                let z1 = (z0 * ratio).min(zb).max(z0);
                let r = radius_m * f / z0;
                let len = t * f * across / z1;
                let blur = self.blur_min_px(z0, z1);
                gain * streak_peak_alpha(r, blur, len, self.max_radius_px) >= threshold
            })
        };
        let landing = col.z_lo_m.abs() < GROUND_TOLERANCE_M;
        let ground_z = (g.depth_m[0] - 0.05).max(self.near_clip_m);
        let crown = |b: f64| {
            let v = self.speed_mps(b) + SPEED_SLACK_MPS;
            splashes(b, v)
                && 2.0 * crown_radius_m(b, v, CROWN_S) * self.diameter_scale * f / ground_z >= 1.0
        };
        (0..DIAMETER_STEPS)
            .map(|i| (d_lo + i as f64 * step, d_lo + (i + 1) as f64 * step))
            .find(|&(a, b)| visible(a, b) || (landing && crown(b)))
            .map_or(d_hi, |(a, _)| a)
    }

    /// The column's depths and view elevations over every pose, widened as the module notes
    /// say.
    fn geometry(&self, grid: &ColumnGrid, col: &Column) -> ColumnView {
        let v_max = self.speed_mps(self.model.dsd.range_mm().1) + SPEED_SLACK_MPS;
        let margin = 0.5 * self.exposure_s * v_max.hypot(self.wind_max_mps);
        let corners: Vec<DVec3> = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
            .into_iter()
            .flat_map(|(u, v)| [(u, v, col.z_lo_m), (u, v, col.z_hi_m)])
            .map(|(u, v, z)| {
                let uv = col.cell_min_m + grid.cell_size_m * DVec2::new(u, v);
                DVec3::new(uv.x + grid.slope.x * z, uv.y + grid.slope.y * z, z)
            })
            .collect();
        let (sin_t, cos_t) = self.turn_rad.sin_cos();
        let (mut z_min, mut z_max, mut cos_e) = (f64::INFINITY, f64::NEG_INFINITY, 1.0f64);
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for p in &corners {
            lo = lo.min(p.truncate());
            hi = hi.max(p.truncate());
        }
        for cam in self.poses {
            for &p in &corners {
                let depth = cam.camera_from_world_point(p).z;
                let rho = (p - cam.position_m).length();
                z_min = z_min.min(depth * cos_t - rho * sin_t);
                z_max = z_max.max(depth + rho * sin_t);
            }
            // The steepest ray onto the column (its footprint's box and heights, widened by
            // the travel): cos e ≥ h/√(h² + Δz²).
            let c = cam.position_m;
            let gap = (lo - c.truncate()).max(c.truncate() - hi).max(DVec2::ZERO);
            let h = (gap.length() - margin).max(0.0);
            let dz = (col.z_lo_m - c.z).abs().max((col.z_hi_m - c.z).abs()) + margin;
            cos_e = cos_e.min(if h > 0.0 { h / h.hypot(dz) } else { 0.0 });
        }
        let near_clipped = z_min - margin < self.near_clip_m;
        let za = (z_min - margin).max(self.near_clip_m);
        ColumnView {
            depth_m: [za, (z_max + margin).max(za * 1.0001)],
            cos_elevation: cos_e,
            near_clipped,
        }
    }
}

/// What the bound reads of one column.
struct ColumnView {
    /// Depths a streak's ends can take, m.
    depth_m: [f64; 2],
    /// Least cosine of the view elevation onto it.
    cos_elevation: f64,
    /// Whether the near plane may clip a streak (its length is then not bounded).
    near_clipped: bool,
}

/// k of the blur radius k |1/focus − 1/z| px of `lens` on `camera` (as the uniforms pack it).
fn blur_k_px_m(lens: &ThinLens, camera: &Camera) -> f64 {
    let z = 0.5 * lens.focus_m;
    lens.defocus_radius_px(camera, z) / (1.0 / lens.focus_m - 1.0 / z).abs()
}
