//! Only the drops the shot needs: the camera's rain volume, its drop budget and the emitter's
//! column geometry.
//!
//! How it works:
//! 1. **Near.** Drops closer than `near_m` (default 0.3 m) are not simulated: at 0.3 m a 2 mm
//!    drop at 6.5 m/s draws a streak ~700 px long and 11 px wide at 1080p in 1/50 s — a smear
//!    across the frame — and real lenses have hoods and minimum focus distances there. The
//!    slab holds only ~20 drops at 10 mm/h, so skipping it costs little realism.
//! 2. **Far.** A drop of image diameter d = D f/z px whose streak is ℓ = v T f/z px long
//!    leaves a mean alpha α = (π/4) d²/(w (ℓ + w)), w = max(√(d² + b²), 1) with b the defocus
//!    blur ([`streak_alpha`]). Once d < 1 px, α ≈ (π/4) D² f/(v T z) falls as 1/z. The far
//!    distance is where α of a *reference drop* — the mass-weighted mean diameter Dm (≈ 4/Λ),
//!    the size that carries the rain's water and its visible streaks — drops below
//!    `alpha_min` (default 1/255: less than one 8-bit code value even at full contrast).
//!    Rain beyond it is drawn as haze ([`haze_alpha`](super::physics::haze_alpha)).
//! 3. **Count.** Drops in the view = number density × volume of the frustum slab between
//!    near and far (clipped at the ground, if known), reported per distance band (edges at
//!    1, 2, 4, 8… m).
//! 4. **Budget.** When the count exceeds the particle budget, the far distance shrinks first
//!    (down to `near + far_shrink_limit·(far − near)`): the farthest drops are the faintest
//!    and the haze already stands for them. If that is not enough, the emitter simulates
//!    `budget` drops, each with weight = expected/simulated applied to its alpha, so the mean
//!    coverage (Σ alpha) stays right; weighting alone would make faint far rain sparse and
//!    blotchy, so it is the last resort.
//! 5. **Sizes.** Marshall–Palmer sizes are independent of distance, but a far drop must be
//!    large to show: each column simulates only the diameters whose streak can pass the
//!    renderer's cull there ([`visible`]), sampled from the distribution truncated below that
//!    cut, and holds that share S of the drops of every size. The drawn drops are statistically
//!    the same, for a fraction of the work (at 10 mm/h, 1080p, a third of the drops).
//! 6. **Columns.** The stateless emitter fills the volume with prisms along the mean fall
//!    direction (vertical in still air, sheared along the wind): x = u + kₓ z, y = v + k_y z
//!    with k = −W̄/v_t(Dm). A horizontal grid of cells in (u, v) covers the slab's footprint;
//!    each cell's prism spans [z_lo, z_hi], the exact z range of its intersection with the
//!    slab (vertex enumeration of the convex polytope). Drops are shared among columns by
//!    volume, with a prefix sum of counts so a drop id finds its column by binary search. A
//!    drop's position is wrapped inside its own prism (measure-preserving), so the density is
//!    uniform whatever its diameter, speed or gust displacement.
//!
//! Trade-off: a drop whose velocity differs from the columns' axis (another diameter, a gust)
//! drifts sideways and, at its cell's edge, reappears on the opposite side: a jump of one cell
//! (0.08–0.12 m with the default 4096 cells, comparable to the 0.1–0.4 m a drop falls per frame
//! at 25 fps, so individual drops are not trackable anyway). Fewer, larger cells jump less
//! often but overhang the slab more (1080p, 10 mm/h, still air: 64 cells overhang 34 %, 1024
//! cells 9 %, 4096 cells 4 %); planning takes ~10 ms at 4096 cells.
//!
//! GPU precision: displacements grow with time (v_t t reaches kilometres after minutes), so the
//! drop's phases are computed on a fixed-point grid with t split into whole seconds and a
//! fraction ([`drop`](mod@drop), "Long clips").
//!
//! Files: this one plans (near, far, count, budget, bands); [`geometry`] is the view volume as
//! a polytope; [`columns`](mod@columns) the emitter's prisms; [`drop`](mod@drop) the stateless drop (the CPU twin of
//! `shaders/common/drops.wgsl`); [`inspect`] the `inspect drops` report.

pub mod columns;
pub mod drop;
pub mod geometry;
pub mod ground_rain;
pub mod impacts;
pub mod inspect;
pub mod rainfall;
pub mod visible;

pub use columns::{Column, ColumnGrid, columns};
pub use drop::{
    DropMotion, RATE_STREAM, SampledDrop, SplitTime, cycle_uniform, drop_bits, drop_uniform,
    fall_rate_q, falls, inv_height_q, mean_travel_cells, pcg_hash, sample_drop,
};
pub use geometry::view_volume_m3;
pub use ground_rain::{GroundRain, GroundRect, Landing, StreamSlots};
pub use impacts::{Impact, impacts_between, landing_columns, latest_impact};
pub use inspect::inspect_drops;
pub use rainfall::Rainfall;
pub use visible::{SizeBound, near_clip_m};

use glam::{DVec2, DVec3};
use serde_json::{Value, json};

use super::physics::{RainModel, ThinLens, extinction_per_m, streak_alpha};
use super::wind::Wind;
use crate::scene::Camera;
use crate::{Error, Result};

/// Depth span always kept, m, so a shot that asked for rain gets some even when the reference
/// drop is invisible everywhere (e.g. heavy defocus).
const MIN_SPAN_M: f64 = 1.0;
/// Largest accepted particle budget (drop ids are `u32` on the GPU).
pub const MAX_BUDGET: u64 = 1 << 30;

/// What the planner needs besides the camera, the rain and the wind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VolumeParams {
    /// Exposure time, s ([`exposure_s`](super::physics::exposure_s)).
    pub exposure_s: f64,
    /// Streak alpha below which a drop is not worth drawing (default 1/255).
    pub alpha_min: f64,
    /// Nearest simulated depth, m (default 0.3).
    pub near_m: f64,
    /// Largest far distance, m (default 200).
    pub far_max_m: f64,
    /// Most drops to simulate (default 2²⁰).
    pub budget: u64,
    /// Ground height, m (world z); drops below it are not simulated. `None`: no ground.
    /// Default `Some(0.0)`: the camera model stands `height_m` above the ground.
    pub ground_z_m: Option<f64>,
    /// Depth of field; `None` is a pinhole (everything sharp).
    pub lens: Option<ThinLens>,
    /// Diameter that sets the far distance, mm; `None`: the mass-weighted mean diameter.
    pub reference_diameter_mm: Option<f64>,
    /// How far the budget may pull in the far distance, as a fraction of far − near kept
    /// (default 0.5).
    pub far_shrink_limit: f64,
    /// Largest number of grid cells for the columns (default 4096).
    pub max_columns: usize,
    /// Drawn diameter over the physical one (`--drop-scale`, default 1).
    pub diameter_scale: f64,
    /// Fall speed over the terminal velocity (`--fall-speed-scale`, default 1).
    pub fall_speed_scale: f64,
    /// Simulate only the sizes whose streak can show (default true; see [`visible`]); false
    /// samples every size everywhere, as before the size cut.
    pub visible_sizes: bool,
    /// Largest opacity over the shot (alpha multiplier; default 1): the size cut's gain.
    pub opacity_max: f64,
    /// Largest mean wind speed over the shot where it is keyed, m/s (`None`: the plan's wind).
    pub wind_max_mps: Option<f64>,
    /// Whether the focus or aperture change over the shot: the size cut then counts on no
    /// defocus blur.
    pub lens_keyed: bool,
}

impl Default for VolumeParams {
    fn default() -> VolumeParams {
        VolumeParams {
            exposure_s: 0.02,
            alpha_min: 1.0 / 255.0,
            near_m: 0.3,
            far_max_m: 200.0,
            budget: 1 << 20,
            ground_z_m: Some(0.0),
            lens: None,
            reference_diameter_mm: None,
            far_shrink_limit: 0.5,
            max_columns: 4096,
            diameter_scale: 1.0,
            fall_speed_scale: 1.0,
            visible_sizes: true,
            opacity_max: 1.0,
            wind_max_mps: None,
            lens_keyed: false,
        }
    }
}

impl VolumeParams {
    /// Checks every field; the error names the setting of the configuration it comes from, or
    /// the field (`volume.alpha_min`).
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, value: f64, expected: &str| {
            Err(Error::Parameter {
                name,
                value: value.to_string(),
                expected: expected.to_string(),
            })
        };
        if !(self.exposure_s.is_finite() && self.exposure_s > 0.0 && self.exposure_s <= 1.0) {
            return bad("volume.exposure_s", self.exposure_s, "seconds in (0, 1]");
        }
        if !(self.alpha_min.is_finite() && self.alpha_min > 0.0 && self.alpha_min < 1.0) {
            return bad("volume.alpha_min", self.alpha_min, "an alpha in (0, 1)");
        }
        if !(self.near_m.is_finite() && self.near_m >= 0.01) {
            return bad("rain.near_m", self.near_m, "metres ≥ 0.01");
        }
        if !(self.far_max_m.is_finite() && self.far_max_m > self.near_m && self.far_max_m <= 1e4) {
            return bad(
                "rain.far_m",
                self.far_max_m,
                "metres beyond rain.near_m, at most 10000",
            );
        }
        if !(self.diameter_scale.is_finite() && self.diameter_scale > 0.0) {
            return bad("rain.drop_scale", self.diameter_scale, "a factor > 0");
        }
        if !(self.fall_speed_scale.is_finite() && self.fall_speed_scale > 0.0) {
            return bad(
                "rain.fall_speed_scale",
                self.fall_speed_scale,
                "a factor > 0",
            );
        }
        if !(self.opacity_max.is_finite() && self.opacity_max >= 0.0) {
            return bad("rain.opacity", self.opacity_max, "a factor ≥ 0");
        }
        if let Some(w) = self.wind_max_mps
            && !(w.is_finite() && w >= 0.0)
        {
            return bad("rain.wind_mps", w, "a finite wind speed");
        }
        if self.budget == 0 || self.budget > MAX_BUDGET {
            return bad("rain.max_drops", self.budget as f64, "from 1 to 2^30 drops");
        }
        if let Some(g) = self.ground_z_m
            && !g.is_finite()
        {
            return bad("volume.ground_z_m", g, "a finite height in metres");
        }
        if let Some(d) = self.reference_diameter_mm
            && !(d.is_finite() && d > 0.0)
        {
            return bad("volume.reference_diameter_mm", d, "millimetres > 0");
        }
        if !(self.far_shrink_limit.is_finite() && (0.0..=1.0).contains(&self.far_shrink_limit)) {
            return bad(
                "volume.far_shrink_limit",
                self.far_shrink_limit,
                "a fraction in [0, 1]",
            );
        }
        if !(16..=1 << 20).contains(&self.max_columns) {
            return bad(
                "volume.max_columns",
                self.max_columns as f64,
                "from 16 to 2^20 cells",
            );
        }
        Ok(())
    }
}

/// A distance band of the view volume.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Band {
    /// Nearest depth, m.
    pub near_m: f64,
    /// Farthest depth, m.
    pub far_m: f64,
    /// Volume of the slab, m³.
    pub volume_m3: f64,
    /// Real drops expected in the band (density × volume).
    pub expected: f64,
    /// Simulated drops expected in the band: expected × the columns' mean size share there
    /// (spread by depth, so approximate with the size cut) ÷ weight.
    pub simulated: f64,
}

/// Everything the emitter and `-v` logging need about the rain in one shot.
#[derive(Debug, Clone, PartialEq)]
pub struct RainVolume {
    /// Rain rate, mm/h.
    pub rate_mm_per_h: f64,
    /// Drops per m³ in the truncated size range.
    pub number_density_per_m3: f64,
    /// Diameter that set the far distance, mm.
    pub reference_diameter_mm: f64,
    /// Its terminal velocity, m/s (the columns' fall speed).
    pub reference_speed_mps: f64,
    /// Nearest simulated depth, m.
    pub near_m: f64,
    /// Farthest simulated depth, m (after the budget).
    pub far_m: f64,
    /// Where the reference drop's alpha falls below the threshold, m (before the budget).
    pub far_visible_m: f64,
    /// Volume of the view slab [near, far], m³.
    pub view_volume_m3: f64,
    /// Real drops expected in the view slab.
    pub expected_in_view: f64,
    /// Drops the emitter simulates (in the columns, which overhang the slab a little).
    pub simulated: u64,
    /// Alpha weight of each simulated drop (expected in the columns ÷ simulated; ≥ 1 when
    /// the budget binds, ≈ 1 otherwise).
    pub weight: f64,
    /// Whether the budget pulled in the far distance or raised the weight.
    pub budget_binds: bool,
    /// Drops of every size the columns hold (density × their volume): what the emitter would
    /// simulate without the size cut, before the budget.
    pub all_sizes_in_columns: f64,
    /// Extinction coefficient of the haze beyond `far_m`, m⁻¹.
    pub extinction_per_m: f64,
    /// Counts per distance band.
    pub bands: Vec<Band>,
    /// The drops' motion on the fixed-point grid the GPU shares (fall speeds by size
    /// quantile, the columns' drift, the drop scale).
    pub motion: DropMotion,
    /// The emitter's columns.
    pub grid: ColumnGrid,
}

impl RainVolume {
    /// Plans the rain volume of one shot.
    pub fn plan(
        camera: &Camera,
        model: &RainModel,
        wind: &Wind,
        params: &VolumeParams,
    ) -> Result<RainVolume> {
        RainVolume::plan_moving(std::slice::from_ref(camera), 0.0, model, wind, params)
    }

    /// Plans the rain volume of a shot filmed by a moving camera, sampled at `path` (the
    /// first at t = 0) with at most `step_rad` of turn between neighbouring samples: the far
    /// distance is the farthest any sample sees rain, and the columns cover the envelope of
    /// the frusta — each sample's, widened by half a step's turn and to its neighbours' widest
    /// field of view, so the poses between samples are inside it too. The view volume and its
    /// bands are those of the first camera; the drops per m³ are the same as for a still one.
    pub fn plan_moving(
        path: &[Camera],
        step_rad: f64,
        model: &RainModel,
        wind: &Wind,
        params: &VolumeParams,
    ) -> Result<RainVolume> {
        params.validate()?;
        let Some(camera) = path.first() else {
            return Err(Error::Parameter {
                name: "camera",
                value: "no pose".into(),
                expected: "at least one camera pose".into(),
            });
        };
        for camera in path {
            if camera.width_px == 0
                || camera.height_px == 0
                || !(camera.fov_x_rad > 0.0 && camera.fov_x_rad < std::f64::consts::PI)
                || !camera.position_m.is_finite()
            {
                return Err(Error::Parameter {
                    name: "camera.fov_deg",
                    value: format!("{}°", camera.fov_x_rad.to_degrees()),
                    expected: "a field of view in (0°, 180°) and a non-empty picture".into(),
                });
            }
        }
        let envelope: Vec<Camera> = if path.len() == 1 {
            path.to_vec()
        } else {
            (0..path.len())
                .map(|i| {
                    let near = &path[i.saturating_sub(1)..(i + 2).min(path.len())];
                    let f_px = near
                        .iter()
                        .map(Camera::focal_px)
                        .fold(f64::INFINITY, f64::min);
                    geometry::widened(&path[i], f_px, 0.5 * step_rad)
                })
                .collect()
        };
        let dsd = &model.dsd;
        let (d_lo, d_hi) = dsd.range_mm();
        let density = dsd.number_density_per_m3();
        let d_ref = params
            .reference_diameter_mm
            .unwrap_or_else(|| dsd.mass_weighted_diameter_mm())
            .clamp(d_lo, d_hi);
        let v_ref = model.fall.terminal_velocity_mps(d_ref);
        // The reference drop as drawn: the scales change how wide and how fast it streaks, so
        // how far it stays visible, and the fall direction the columns follow.
        let (d_drawn, v_drawn) = (
            d_ref * params.diameter_scale,
            v_ref * params.fall_speed_scale,
        );
        let slope = -wind.mean_mps / v_drawn.max(0.1);
        let near = params.near_m;
        let far_visible = path
            .iter()
            .map(|c| visible_far_m(c, params, d_drawn, v_drawn, wind.mean_mps))
            .fold(f64::NEG_INFINITY, f64::max);
        let far0 = far_visible.clamp((near + MIN_SPAN_M).min(params.far_max_m), params.far_max_m);
        let ground = params.ground_z_m;
        let mut far = far0;
        let mut grid = ColumnGrid::default();
        let mut budget_binds = false;
        let bound = SizeBound::new(path, 0.5 * step_rad, model, wind, params);
        // Each column simulates only the sizes that can show in it (see `visible`).
        let cut = |grid: &mut ColumnGrid, gain: f64| {
            if !params.visible_sizes {
                return;
            }
            let keeps: Vec<u32> = grid
                .columns
                .iter()
                .map(|c| visible::keep_q(model, bound.cut_mm(grid, c, gain)))
                .collect();
            for (c, k) in grid.columns.iter_mut().zip(keeps) {
                c.size_keep_q = k;
            }
        };
        let gain = params.opacity_max;
        if density > 0.0 {
            grid =
                ColumnGrid::build_envelope(&envelope, near, far, ground, slope, params.max_columns);
            cut(&mut grid, gain);
            let budget = params.budget as f64;
            if density * grid.simulated_volume_m3() > budget {
                budget_binds = true;
                // Shrink far: bisection on the slab volume, scaled by the columns' overhang
                // and the share of sizes they simulate.
                let view0 = view_volume_m3(camera, near, far0, ground);
                let overhang = if view0 > 0.0 {
                    grid.simulated_volume_m3() / view0
                } else {
                    1.0
                };
                let count = |f: f64| density * overhang * view_volume_m3(camera, near, f, ground);
                let floor = near + params.far_shrink_limit * (far0 - near);
                far = if count(floor) >= budget {
                    floor
                } else {
                    let (mut lo, mut hi) = (floor, far0);
                    for _ in 0..60 {
                        let mid = 0.5 * (lo + hi);
                        if count(mid) > budget {
                            hi = mid;
                        } else {
                            lo = mid;
                        }
                    }
                    lo
                };
                grid = ColumnGrid::build_envelope(
                    &envelope,
                    near,
                    far,
                    ground,
                    slope,
                    params.max_columns,
                );
                cut(&mut grid, gain);
            }
        }
        let all_sizes = density * grid.volume_m3;
        let mut expected_cols = density * grid.simulated_volume_m3();
        let simulated = (expected_cols.round() as u64).min(params.budget);
        let mut weight = if simulated > 0 {
            expected_cols / simulated as f64
        } else {
            1.0
        };
        if weight > 1.0 + 1e-9 {
            // Weighted drops are brighter: cut again for their gain (the weight this gives is
            // a little larger still; the margin of the cull covers the difference).
            cut(&mut grid, gain * weight);
            expected_cols = density * grid.simulated_volume_m3();
            weight = expected_cols / simulated as f64;
        }
        budget_binds |= weight > 1.0 + 1e-9 && simulated == params.budget;
        grid.allot(simulated);
        let view = view_volume_m3(camera, near, far, ground);
        let edges = band_edges(near, far);
        let shares = band_shares(camera, &grid, &edges);
        let bands = edges
            .windows(2)
            .zip(shares)
            .map(|(w, share)| {
                let vol = view_volume_m3(camera, w[0], w[1], ground);
                Band {
                    near_m: w[0],
                    far_m: w[1],
                    volume_m3: vol,
                    expected: density * vol,
                    simulated: density * vol * share / weight,
                }
            })
            .collect();
        Ok(RainVolume {
            rate_mm_per_h: model.rate.mm_per_h(),
            number_density_per_m3: density,
            reference_diameter_mm: d_ref,
            reference_speed_mps: v_ref,
            near_m: near,
            far_m: far,
            far_visible_m: far_visible,
            view_volume_m3: view,
            expected_in_view: density * view,
            simulated,
            weight,
            budget_binds,
            all_sizes_in_columns: all_sizes,
            extinction_per_m: extinction_per_m(model.rate),
            bands,
            motion: DropMotion::new(model, &grid, params.fall_speed_scale, params.diameter_scale),
            grid,
        })
    }

    /// One line for `-v` logging.
    pub fn summary(&self) -> String {
        format!(
            "rain {:.3} mm/h: {:.0} drops/m³, reference drop {:.2} mm at {:.2} m/s; view {:.2}–{:.2} m \
             (visible to {:.2} m), {:.1} m³ → {:.0} drops expected; simulating {} (weight {:.3}{}) \
             in {} columns; haze β = {:.3} km⁻¹",
            self.rate_mm_per_h,
            self.number_density_per_m3,
            self.reference_diameter_mm,
            self.reference_speed_mps,
            self.near_m,
            self.far_m,
            self.far_visible_m,
            self.view_volume_m3,
            self.expected_in_view,
            self.simulated,
            self.weight,
            if self.budget_binds {
                ", budget binds"
            } else {
                ""
            },
            self.grid.columns.len(),
            self.extinction_per_m * 1e3,
        )
    }

    /// The plan as JSON (without the column list, which can be long).
    pub fn to_json(&self) -> Value {
        let bands: Vec<Value> = self
            .bands
            .iter()
            .map(|b| {
                json!({
                    "near_m": b.near_m,
                    "far_m": b.far_m,
                    "volume_m3": b.volume_m3,
                    "expected": b.expected,
                    "simulated": b.simulated,
                })
            })
            .collect();
        json!({
            "rate_mm_per_h": self.rate_mm_per_h,
            "number_density_per_m3": self.number_density_per_m3,
            "reference_diameter_mm": self.reference_diameter_mm,
            "reference_speed_mps": self.reference_speed_mps,
            "near_m": self.near_m,
            "far_m": self.far_m,
            "far_visible_m": self.far_visible_m,
            "view_volume_m3": self.view_volume_m3,
            "expected_in_view": self.expected_in_view,
            "column_volume_m3": self.grid.volume_m3,
            "simulated": self.simulated,
            "all_sizes_in_columns": self.all_sizes_in_columns,
            "weight": self.weight,
            "budget_binds": self.budget_binds,
            "extinction_per_km": self.extinction_per_m * 1e3,
            "columns": self.grid.columns.len(),
            "cell_size_m": [self.grid.cell_size_m.x, self.grid.cell_size_m.y],
            "column_slope": [self.grid.slope.x, self.grid.slope.y],
            "bands": bands,
        })
    }
}

/// The mean size share of the columns in each band of `edges` (depths of `camera`), weighted
/// by volume: each column's volume is spread over its depth range [nearest, farthest corner]
/// in proportion to the overlap (1 where no column reaches a band).
fn band_shares(camera: &Camera, grid: &ColumnGrid, edges: &[f64]) -> Vec<f64> {
    let n = edges.len().saturating_sub(1);
    let (mut kept, mut all) = (vec![0.0; n], vec![0.0; n]);
    for (i, c) in grid.columns.iter().enumerate() {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (u, v, z) in [0.0, 1.0]
            .into_iter()
            .flat_map(|u| [(u, 0.0), (u, 1.0)])
            .flat_map(|(u, v)| [(u, v, 0.0), (u, v, 1.0)])
        {
            let d = camera.camera_from_world_point(grid.point_m(c, [u, v, z])).z;
            lo = lo.min(d);
            hi = hi.max(d);
        }
        let span = (hi - lo).max(1e-9);
        let vol = grid.column_volume_m3(i);
        for ((k, a), w) in kept.iter_mut().zip(all.iter_mut()).zip(edges.windows(2)) {
            let part = vol * (hi.min(w[1]) - lo.max(w[0])).max(0.0) / span;
            *k += part * c.size_share();
            *a += part;
        }
    }
    kept.iter()
        .zip(&all)
        .map(|(k, a)| if *a > 0.0 { k / a } else { 1.0 })
        .collect()
}

/// Band edges: near, 1, 2, 4, 8 … m, far.
fn band_edges(near_m: f64, far_m: f64) -> Vec<f64> {
    let mut e = vec![near_m];
    let mut x = 1.0;
    while x < far_m {
        if x > near_m {
            e.push(x);
        }
        x *= 2.0;
    }
    if far_m > near_m {
        e.push(far_m);
    }
    e
}

/// Farthest depth at which the reference drop's streak alpha reaches `alpha_min`.
///
/// The image speed of a point at depth z is (f/z)|v_xy − v_z n| in camera coordinates, n the
/// point's normalised image position; it is averaged over a 3 × 3 grid of the picture so a
/// camera looking up into the rain (streaks radial, short at the centre) is handled too.
fn visible_far_m(
    camera: &Camera,
    params: &VolumeParams,
    d_mm: f64,
    v_mps: f64,
    wind: DVec2,
) -> f64 {
    let f = camera.focal_px();
    let a = 0.5 * camera.width_px as f64 / f;
    let b = 0.5 * camera.height_px as f64 / f;
    let v = camera.world_from_camera.transpose() * DVec3::new(wind.x, wind.y, -v_mps);
    let mut v_eff = 0.0;
    for i in [-1.0, 0.0, 1.0] {
        for j in [-1.0, 0.0, 1.0] {
            let n = DVec2::new(i * 2.0 / 3.0 * a, j * 2.0 / 3.0 * b);
            v_eff += (DVec2::new(v.x, v.y) - v.z * n).length() / 9.0;
        }
    }
    let alpha = |z: f64| {
        let d = d_mm * 1e-3 * f / z;
        let l = v_eff * params.exposure_s * f / z;
        let blur = params
            .lens
            .map_or(0.0, |lens| lens.coc_diameter_px(camera, z));
        streak_alpha(d, l, blur)
    };
    let (near, far) = (params.near_m, params.far_max_m);
    let n = 512;
    let z_at = |i: usize| near * (far / near).powf(i as f64 / n as f64);
    let Some(last) = (0..=n).rev().find(|&i| alpha(z_at(i)) >= params.alpha_min) else {
        return near;
    };
    if last == n {
        return far;
    }
    let (mut lo, mut hi) = (z_at(last), z_at(last + 1));
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if alpha(mid) >= params.alpha_min {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

#[cfg(test)]
mod tests {
    use super::geometry::*;
    use super::*;

    #[test]
    fn clipped_area_limits() {
        assert!((clipped_rect_area(1.0, 2.0, 0.0, 1.0, 10.0) - 8.0).abs() < 1e-12);
        assert_eq!(clipped_rect_area(1.0, 2.0, 0.0, 1.0, -10.0), 0.0);
        // Half the rectangle above y = 0.
        assert!((clipped_rect_area(1.0, 2.0, 0.0, 1.0, 0.0) - 4.0).abs() < 1e-12);
        // Diagonal cut of a square through its centre.
        assert!((clipped_rect_area(1.0, 1.0, 1.0, 1.0, 0.0) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn vertices_of_a_cube() {
        let hs: Vec<HalfSpace> = [DVec3::X, DVec3::Y, DVec3::Z]
            .iter()
            .flat_map(|&n| [HalfSpace::new(n, 1.0), HalfSpace::new(-n, 1.0)])
            .collect();
        assert_eq!(polytope_vertices(&hs).len(), 8);
    }

    #[test]
    fn ground_clipped_volume_matches_monte_carlo() {
        let cam = Camera::new(1920, 1080, 60f64.to_radians(), 1.6, -0.2, 0.1);
        let v = view_volume_m3(&cam, 0.3, 12.0, Some(0.0));
        // Uniform points in the unclipped slab (by depth³ and picture position), keep z ≥ 0.
        let full = view_volume_m3(&cam, 0.3, 12.0, None);
        let n = 200_000u32;
        let mut kept = 0;
        for i in 0..n {
            let (a, b, c) = (
                drop_uniform(1, i, 0),
                drop_uniform(1, i, 1),
                drop_uniform(1, i, 2),
            );
            let s = (0.3f64.powi(3) + c * (12f64.powi(3) - 0.3f64.powi(3))).cbrt();
            let px = DVec2::new(a * 1920.0, b * 1080.0);
            let ray = cam.ray_world(px);
            let axis = cam.world_from_camera * DVec3::Z;
            let p = cam.position_m + ray * (s / ray.dot(axis));
            if p.z >= 0.0 {
                kept += 1;
            }
        }
        let mc = full * kept as f64 / n as f64;
        assert!((v / mc - 1.0).abs() < 0.01, "{v} vs {mc}");
    }
}
