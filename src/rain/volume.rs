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
//! 5. **Columns.** The stateless emitter fills the volume with prisms along the mean fall
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
//! GPU precision: displacements grow with time (v_t t reaches kilometres after minutes), so
//! wrap with care in `f32` — e.g. pass t modulo a long period split into high and low parts,
//! or reduce per-frame terms on the CPU in `f64`.

use glam::{DMat3, DVec2, DVec3};
use serde_json::{Value, json};

use super::physics::{DsdShape, RainModel, ThinLens, extinction_per_m, streak_alpha};
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
        }
    }
}

impl VolumeParams {
    /// Checks every field; the error names the option a user would type.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, value: f64, expected: &str| {
            Err(Error::Parameter {
                name,
                value: value.to_string(),
                expected: expected.to_string(),
            })
        };
        if !(self.exposure_s.is_finite() && self.exposure_s > 0.0 && self.exposure_s <= 1.0) {
            return bad("--exposure", self.exposure_s, "seconds in (0, 1]");
        }
        if !(self.alpha_min.is_finite() && self.alpha_min > 0.0 && self.alpha_min < 1.0) {
            return bad("--alpha-min", self.alpha_min, "an alpha in (0, 1)");
        }
        if !(self.near_m.is_finite() && self.near_m >= 0.01) {
            return bad("--near", self.near_m, "metres ≥ 0.01");
        }
        if !(self.far_max_m.is_finite() && self.far_max_m > self.near_m && self.far_max_m <= 1e4) {
            return bad(
                "--far",
                self.far_max_m,
                "metres beyond --near, at most 10000",
            );
        }
        if self.budget == 0 || self.budget > MAX_BUDGET {
            return bad("--max-drops", self.budget as f64, "from 1 to 2^30 drops");
        }
        if let Some(g) = self.ground_z_m
            && !g.is_finite()
        {
            return bad("--ground", g, "a finite height in metres");
        }
        if let Some(d) = self.reference_diameter_mm
            && !(d.is_finite() && d > 0.0)
        {
            return bad("--reference-diameter", d, "millimetres > 0");
        }
        if !(self.far_shrink_limit.is_finite() && (0.0..=1.0).contains(&self.far_shrink_limit)) {
            return bad(
                "--far-shrink",
                self.far_shrink_limit,
                "a fraction in [0, 1]",
            );
        }
        if !(16..=1 << 20).contains(&self.max_columns) {
            return bad(
                "--columns",
                self.max_columns as f64,
                "from 16 to 2^20 cells",
            );
        }
        Ok(())
    }
}

// ------------------------------------------------------------------------------------------
// The view volume as a convex polytope
// ------------------------------------------------------------------------------------------

/// A half-space n·p ≤ d (n unit).
#[derive(Debug, Clone, Copy)]
struct HalfSpace {
    n: DVec3,
    d: f64,
}

impl HalfSpace {
    fn new(n: DVec3, d: f64) -> HalfSpace {
        let l = n.length();
        HalfSpace { n: n / l, d: d / l }
    }
}

/// The frustum slab near ≤ depth ≤ far, clipped above the ground, as world half-spaces.
fn slab_half_spaces(
    camera: &Camera,
    near_m: f64,
    far_m: f64,
    ground: Option<f64>,
) -> Vec<HalfSpace> {
    let f = camera.focal_px();
    let a = 0.5 * camera.width_px as f64 / f;
    let b = 0.5 * camera.height_px as f64 / f;
    let r = camera.world_from_camera;
    let c = camera.position_m;
    let cam = [
        (DVec3::new(1.0, 0.0, -a), 0.0),
        (DVec3::new(-1.0, 0.0, -a), 0.0),
        (DVec3::new(0.0, 1.0, -b), 0.0),
        (DVec3::new(0.0, -1.0, -b), 0.0),
        (DVec3::new(0.0, 0.0, -1.0), -near_m),
        (DVec3::new(0.0, 0.0, 1.0), far_m),
    ];
    let mut hs: Vec<HalfSpace> = cam
        .iter()
        .map(|&(n, d)| {
            let nw = r * n;
            HalfSpace::new(nw, d + nw.dot(c))
        })
        .collect();
    if let Some(g) = ground {
        hs.push(HalfSpace::new(DVec3::NEG_Z, -g));
    }
    hs
}

/// Vertices of the bounded polytope ∩ half-spaces (every feasible intersection of three
/// planes). Empty when the polytope is empty or flat.
fn polytope_vertices(hs: &[HalfSpace]) -> Vec<DVec3> {
    let scale = hs.iter().fold(1.0f64, |m, h| m.max(h.d.abs()));
    let tol = 1e-9 * scale;
    let mut out = Vec::new();
    for i in 0..hs.len() {
        for j in i + 1..hs.len() {
            let nij = hs[i].n.cross(hs[j].n);
            for k in j + 1..hs.len() {
                let det = nij.dot(hs[k].n);
                if det.abs() < 1e-10 {
                    continue;
                }
                // Cramer: p = (d_i (n_j × n_k) + d_j (n_k × n_i) + d_k (n_i × n_j)) / det.
                let p = (hs[j].n.cross(hs[k].n) * hs[i].d
                    + hs[k].n.cross(hs[i].n) * hs[j].d
                    + nij * hs[k].d)
                    / det;
                if hs.iter().all(|h| h.n.dot(p) <= h.d + tol) {
                    out.push(p);
                }
            }
        }
    }
    out
}

/// Volume of the frustum slab between depths `near_m` and `far_m` (along the optical axis),
/// clipped above the ground, m³. Exact: each depth slice is the picture rectangle scaled by
/// depth, clipped by the ground line; its area is quadratic in depth between the depths where
/// the ground line passes a corner, and Simpson's rule is exact on each such piece. Without a
/// ground it is (4ab/3)(far³ − near³), a = tan(fov_x/2), b = tan(fov_y/2).
pub fn view_volume_m3(camera: &Camera, near_m: f64, far_m: f64, ground_z_m: Option<f64>) -> f64 {
    // Written so NaN depths also give an empty volume.
    if far_m.partial_cmp(&near_m) != Some(std::cmp::Ordering::Greater) {
        return 0.0;
    }
    let f = camera.focal_px();
    let a = 0.5 * camera.width_px as f64 / f;
    let b = 0.5 * camera.height_px as f64 / f;
    let Some(g) = ground_z_m else {
        return 4.0 * a * b / 3.0 * (far_m.powi(3) - near_m.powi(3));
    };
    // World height of camera point (x, y, s): c_z + r0 x + r1 y + r2 s.
    let m = camera.world_from_camera;
    let (r0, r1, r2) = (m.x_axis.z, m.y_axis.z, m.z_axis.z);
    let h = camera.position_m.z - g;
    let mut cuts = vec![near_m, far_m];
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            let k = sx * a * r0 + sy * b * r1 + r2;
            if k.abs() > 1e-14 {
                let s = -h / k;
                if s > near_m && s < far_m {
                    cuts.push(s);
                }
            }
        }
    }
    cuts.sort_by(f64::total_cmp);
    let area = |s: f64| clipped_rect_area(a * s, b * s, r0, r1, h + r2 * s);
    cuts.windows(2)
        .map(|w| (w[1] - w[0]) / 6.0 * (area(w[0]) + 4.0 * area(0.5 * (w[0] + w[1])) + area(w[1])))
        .sum()
}

/// Area of the rectangle |x| ≤ hx, |y| ≤ hy where r0 x + r1 y + c ≥ 0.
fn clipped_rect_area(hx: f64, hy: f64, r0: f64, r1: f64, c: f64) -> f64 {
    let rect = [
        DVec2::new(-hx, -hy),
        DVec2::new(hx, -hy),
        DVec2::new(hx, hy),
        DVec2::new(-hx, hy),
    ];
    let side = |p: DVec2| r0 * p.x + r1 * p.y + c;
    let mut poly: Vec<DVec2> = Vec::with_capacity(6);
    for i in 0..4 {
        let (p, q) = (rect[i], rect[(i + 1) % 4]);
        let (sp, sq) = (side(p), side(q));
        if sp >= 0.0 {
            poly.push(p);
        }
        if (sp >= 0.0) != (sq >= 0.0) {
            poly.push(p + (q - p) * (sp / (sp - sq)));
        }
    }
    let n = poly.len();
    if n < 3 {
        return 0.0;
    }
    0.5 * (0..n)
        .map(|i| poly[i].perp_dot(poly[(i + 1) % n]))
        .sum::<f64>()
        .abs()
}

// ------------------------------------------------------------------------------------------
// Columns
// ------------------------------------------------------------------------------------------

/// One emitter column: the prism over grid cell [u0, u0+du] × [v0, v0+dv] (sheared
/// coordinates, see [`ColumnGrid`]) between heights `z_lo_m` and `z_hi_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Column {
    /// Cell corner (u0, v0), m.
    pub cell_min_m: DVec2,
    /// Lowest world height of the column, m.
    pub z_lo_m: f64,
    /// Highest world height of the column, m.
    pub z_hi_m: f64,
    /// First drop id in this column (prefix sum of the counts before it).
    pub first_id: u64,
    /// Drops in this column.
    pub count: u32,
}

impl Column {
    /// The column's height, m (> 0).
    pub fn height_m(&self) -> f64 {
        self.z_hi_m - self.z_lo_m
    }
}

/// The emitter's columns. Sheared coordinates (u, v, z) map to the world as
/// x = u + slopeₓ z, y = v + slope_y z, so a drop falling at the mean velocity keeps its (u, v).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ColumnGrid {
    /// Horizontal drift per metre of height, k = −W̄/v_t (dimensionless).
    pub slope: DVec2,
    /// Cell size (du, dv), m.
    pub cell_size_m: DVec2,
    /// Columns with at least one drop, in id order.
    pub columns: Vec<Column>,
    /// Total drops (the next free id).
    pub total: u64,
    /// Total volume of all prisms, m³ (before dropping empty ones).
    pub volume_m3: f64,
    volumes: Vec<f64>,
}

impl ColumnGrid {
    /// Column prisms covering the frustum slab [near_m, far_m] (clipped at the ground), on a
    /// grid of at most about `max_columns` cells, without drops yet (see [`ColumnGrid::allot`]).
    pub fn build(
        camera: &Camera,
        near_m: f64,
        far_m: f64,
        ground_z_m: Option<f64>,
        slope: DVec2,
        max_columns: usize,
    ) -> ColumnGrid {
        let mut grid = ColumnGrid {
            slope,
            ..ColumnGrid::default()
        };
        if far_m.partial_cmp(&near_m) != Some(std::cmp::Ordering::Greater) || !slope.is_finite() {
            return grid;
        }
        let world = slab_half_spaces(camera, near_m, far_m, ground_z_m);
        let verts = polytope_vertices(&world);
        if verts.len() < 4 {
            return grid;
        }
        let to_uv = |p: DVec3| DVec2::new(p.x, p.y) - slope * p.z;
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for &p in &verts {
            lo = lo.min(to_uv(p));
            hi = hi.max(to_uv(p));
        }
        let ext = (hi - lo).max(DVec2::splat(1e-6));
        let m = max_columns.max(1) as f64;
        let nu = (m * ext.x / ext.y).sqrt().round().clamp(1.0, m);
        let nv = (m / nu).floor().max(1.0);
        let cell = DVec2::new(ext.x / nu, ext.y / nv);
        grid.cell_size_m = cell;
        // Shear the world half-spaces: n·(u + kx z, v + ky z, z) = (nx, ny, nx kx + ny ky + nz)·(u,v,z).
        let shear = DMat3::from_cols(DVec3::X, DVec3::Y, DVec3::new(slope.x, slope.y, 1.0));
        let sheared: Vec<HalfSpace> = world
            .iter()
            .map(|h| HalfSpace {
                n: shear.transpose() * h.n,
                d: h.d,
            })
            .map(|h| HalfSpace::new(h.n, h.d))
            .collect();
        for iu in 0..nu as usize {
            for iv in 0..nv as usize {
                let c0 = lo + cell * DVec2::new(iu as f64, iv as f64);
                let c1 = c0 + cell;
                let mut hs = sheared.clone();
                hs.extend([
                    HalfSpace::new(DVec3::X, c1.x),
                    HalfSpace::new(DVec3::NEG_X, -c0.x),
                    HalfSpace::new(DVec3::Y, c1.y),
                    HalfSpace::new(DVec3::NEG_Y, -c0.y),
                ]);
                let vs = polytope_vertices(&hs);
                if vs.is_empty() {
                    continue;
                }
                let z_lo = vs.iter().fold(f64::INFINITY, |m, p| m.min(p.z));
                let z_hi = vs.iter().fold(f64::NEG_INFINITY, |m, p| m.max(p.z));
                let vol = cell.x * cell.y * (z_hi - z_lo);
                if z_hi - z_lo > 1e-9 && vol.is_finite() && vol > 0.0 {
                    grid.columns.push(Column {
                        cell_min_m: c0,
                        z_lo_m: z_lo,
                        z_hi_m: z_hi,
                        first_id: 0,
                        count: 0,
                    });
                    grid.volumes.push(vol);
                }
            }
        }
        grid.volume_m3 = grid.volumes.iter().sum();
        grid
    }

    /// Shares `total` drops among the columns in proportion to their volumes (cumulative
    /// rounding: the counts sum to `total` and each column is within one drop of its share),
    /// then drops the columns left empty.
    pub fn allot(&mut self, total: u64) {
        let v = self.volume_m3;
        if v <= 0.0 || total == 0 {
            self.columns.clear();
            self.volumes.clear();
            self.total = 0;
            return;
        }
        let mut acc = 0.0;
        let mut prev = 0u64;
        for (c, vol) in self.columns.iter_mut().zip(&self.volumes) {
            acc += vol;
            let next = ((total as f64 * acc / v).round() as u64).min(total);
            c.first_id = prev;
            c.count = u32::try_from(next - prev).unwrap_or(u32::MAX);
            prev = next;
        }
        if let Some(last) = self.columns.last_mut() {
            last.count = u32::try_from(total - last.first_id).unwrap_or(u32::MAX);
        }
        let keep: Vec<bool> = self.columns.iter().map(|c| c.count > 0).collect();
        let mut it = keep.iter();
        self.columns.retain(|_| *it.next().unwrap_or(&false));
        let mut it = keep.iter();
        self.volumes.retain(|_| *it.next().unwrap_or(&false));
        self.total = total;
    }

    /// Volume of column `i`, m³.
    pub fn column_volume_m3(&self, i: usize) -> f64 {
        self.volumes.get(i).copied().unwrap_or(0.0)
    }

    /// The column holding drop `id` (binary search on the prefix sums); `None` past the end.
    pub fn column_of(&self, id: u64) -> Option<usize> {
        if id >= self.total {
            return None;
        }
        Some(
            self.columns
                .partition_point(|c| c.first_id <= id)
                .saturating_sub(1),
        )
    }

    /// The world point at fractions `uvw` ∈ [0, 1)³ of column `col` (u across, v across, w up).
    pub fn point_m(&self, col: &Column, uvw: [f64; 3]) -> DVec3 {
        let uv = col.cell_min_m + self.cell_size_m * DVec2::new(uvw[0], uvw[1]);
        let z = col.z_lo_m + uvw[2] * col.height_m();
        DVec3::new(uv.x + self.slope.x * z, uv.y + self.slope.y * z, z)
    }

    /// The world point of a drop born at fractions `uvw` of `col` after it moved by
    /// `displacement_m` (world), wrapped inside the column: the displacement is taken to
    /// sheared coordinates, added to the fractions and reduced modulo 1 on each axis. Wrapping
    /// preserves volume, so drops stay uniform in the column whatever their speeds.
    pub fn wrapped_point_m(&self, col: &Column, uvw: [f64; 3], displacement_m: DVec3) -> DVec3 {
        let d = displacement_m;
        let du = (d.x - self.slope.x * d.z) / self.cell_size_m.x;
        let dv = (d.y - self.slope.y * d.z) / self.cell_size_m.y;
        let dw = d.z / col.height_m();
        self.point_m(
            col,
            [
                (uvw[0] + du).rem_euclid(1.0),
                (uvw[1] + dv).rem_euclid(1.0),
                (uvw[2] + dw).rem_euclid(1.0),
            ],
        )
    }
}

/// The emitter's columns for the slab [near_m, far_m] (clipped at the ground), sheared by
/// `slope` (k = −W̄/v_t), on at most about `max_columns` cells, with `total_drops` shared by
/// volume: [`ColumnGrid::build`] then [`ColumnGrid::allot`].
pub fn columns(
    camera: &Camera,
    near_m: f64,
    far_m: f64,
    ground_z_m: Option<f64>,
    slope: DVec2,
    max_columns: usize,
    total_drops: u64,
) -> ColumnGrid {
    let mut grid = ColumnGrid::build(camera, near_m, far_m, ground_z_m, slope, max_columns);
    grid.allot(total_drops);
    grid
}

// ------------------------------------------------------------------------------------------
// The plan
// ------------------------------------------------------------------------------------------

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
    /// Simulated drops expected in the band (expected ÷ weight).
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
    /// Extinction coefficient of the haze beyond `far_m`, m⁻¹.
    pub extinction_per_m: f64,
    /// Counts per distance band.
    pub bands: Vec<Band>,
    /// The emitter's terminal-velocity table (32 entries over the size range).
    pub velocity_table: super::physics::VelocityTable,
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
        params.validate()?;
        if camera.width_px == 0
            || camera.height_px == 0
            || !(camera.fov_x_rad > 0.0 && camera.fov_x_rad < std::f64::consts::PI)
            || !camera.position_m.is_finite()
        {
            return Err(Error::Parameter {
                name: "--fov",
                value: format!("{}°", camera.fov_x_rad.to_degrees()),
                expected: "a field of view in (0°, 180°) and a non-empty picture".into(),
            });
        }
        let dsd = &model.dsd;
        let (d_lo, d_hi) = dsd.range_mm();
        let density = dsd.number_density_per_m3();
        let d_ref = params
            .reference_diameter_mm
            .unwrap_or_else(|| dsd.mass_weighted_diameter_mm())
            .clamp(d_lo, d_hi);
        let v_ref = model.fall.terminal_velocity_mps(d_ref);
        let slope = -wind.mean_mps / v_ref.max(0.1);
        let near = params.near_m;
        let far_visible = visible_far_m(camera, params, d_ref, v_ref, wind.mean_mps);
        let far0 = far_visible.clamp((near + MIN_SPAN_M).min(params.far_max_m), params.far_max_m);
        let ground = params.ground_z_m;
        let mut far = far0;
        let mut grid = ColumnGrid::default();
        let mut budget_binds = false;
        if density > 0.0 {
            grid = ColumnGrid::build(camera, near, far, ground, slope, params.max_columns);
            let budget = params.budget as f64;
            if density * grid.volume_m3 > budget {
                budget_binds = true;
                // Shrink far: bisection on the slab volume, scaled by the columns' overhang.
                let view0 = view_volume_m3(camera, near, far0, ground);
                let overhang = if view0 > 0.0 {
                    grid.volume_m3 / view0
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
                grid = ColumnGrid::build(camera, near, far, ground, slope, params.max_columns);
            }
        }
        let expected_cols = density * grid.volume_m3;
        let simulated = (expected_cols.round() as u64).min(params.budget);
        let weight = if simulated > 0 {
            expected_cols / simulated as f64
        } else {
            1.0
        };
        budget_binds |= weight > 1.0 + 1e-9 && simulated == params.budget;
        grid.allot(simulated);
        let view = view_volume_m3(camera, near, far, ground);
        let bands = band_edges(near, far)
            .windows(2)
            .map(|w| {
                let vol = view_volume_m3(camera, w[0], w[1], ground);
                Band {
                    near_m: w[0],
                    far_m: w[1],
                    volume_m3: vol,
                    expected: density * vol,
                    simulated: density * vol / weight,
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
            extinction_per_m: extinction_per_m(model.rate),
            bands,
            velocity_table: {
                let (lo, hi) = dsd.range_mm();
                model
                    .fall
                    .velocity_table(super::physics::VelocityTable::DEFAULT_LEN, lo, hi)
            },
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

// ------------------------------------------------------------------------------------------
// Hash and inspection
// ------------------------------------------------------------------------------------------

/// PCG hash of a `u32` (Jarzynski & Olano 2020, "Hash functions for GPU rendering"), the
/// per-drop random source; WGSL has the same `u32` wrapping arithmetic.
pub fn pcg_hash(x: u32) -> u32 {
    let state = x.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// Uniform in [0, 1) for drop `id`, random stream `stream` (0–2 position, 3 diameter, …) and
/// `seed`: 24 bits, exact in `f32`.
pub fn drop_uniform(seed: u32, id: u32, stream: u32) -> f64 {
    let h = pcg_hash(pcg_hash(pcg_hash(seed) ^ id) ^ stream.wrapping_mul(0x9E37_79B9));
    (h >> 8) as f64 * (1.0 / 16_777_216.0)
}

/// One drop of the CPU emitter at time `t_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampledDrop {
    /// Drop id.
    pub id: u64,
    /// Column index.
    pub column: usize,
    /// Diameter, mm.
    pub diameter_mm: f64,
    /// Velocity (world), m/s.
    pub velocity_mps: DVec3,
    /// Position (world), m.
    pub position_m: DVec3,
}

/// Uniform in [0, 1) for drop `id`, stream `stream`, in the `cycle`-th pass of the drop
/// through its column (a new lateral offset at each rebirth).
pub fn cycle_uniform(seed: u32, id: u32, cycle: u32, stream: u32) -> f64 {
    let h = pcg_hash(
        pcg_hash(pcg_hash(seed) ^ id) ^ stream.wrapping_mul(0x9E37_79B9) ^ pcg_hash(cycle),
    );
    (h >> 8) as f64 * (1.0 / 16_777_216.0)
}

/// The plain CPU reference of the stateless emitter (`shaders/common/drops.wgsl`): drop `id`
/// at time `t_s`. Diameter by inverse CDF of stream 3; vertical velocity the terminal velocity
/// from the emitter's 32-entry table; horizontal velocity the wind's steady-state response with
/// τ(D); position the column point of streams 0–2 moved by the displacement and wrapped modulo
/// the column, with a new lateral offset (streams 4, 5 of the pass number) each time the drop
/// wraps through the bottom.
pub fn sample_drop(
    volume: &RainVolume,
    model: &RainModel,
    wind: &Wind,
    seed: u32,
    id: u64,
    t_s: f64,
) -> Option<SampledDrop> {
    let ci = volume.grid.column_of(id)?;
    let col = &volume.grid.columns[ci];
    let id32 = id as u32;
    let u = |s| drop_uniform(seed, id32, s);
    let d = model.dsd.diameter_from_uniform_mm(u(3));
    let vt = volume.velocity_table.lookup_mps(d);
    let tau = vt / super::physics::G_MPS2;
    let vh = wind.drop_velocity_mps(t_s, tau);
    let dh = wind.drop_displacement_m(t_s, tau);
    let grid = &volume.grid;
    let dz = -vt * t_s;
    let w_total = u(2) + dz / col.height_m();
    let cycle = w_total.floor();
    let k = (cycle as i64 as i32) as u32;
    let du = (dh.x - grid.slope.x * dz) / grid.cell_size_m.x;
    let dv = (dh.y - grid.slope.y * dz) / grid.cell_size_m.y;
    let uvw = [
        (u(0) + du + cycle_uniform(seed, id32, k, 4)).rem_euclid(1.0),
        (u(1) + dv + cycle_uniform(seed, id32, k, 5)).rem_euclid(1.0),
        w_total - cycle,
    ];
    Some(SampledDrop {
        id,
        column: ci,
        diameter_mm: d,
        velocity_mps: DVec3::new(vh.x, vh.y, -vt),
        position_m: grid.point_m(col, uvw),
    })
}

/// `rain-composite inspect drops`: the plan, the distributions and `count` drops sampled from
/// the emitter at time `t_s` (ids spread evenly over all simulated drops), with the sampled
/// share of drops per distance band next to the planned share.
pub fn inspect_drops(
    camera: &Camera,
    model: &RainModel,
    wind: &Wind,
    params: &VolumeParams,
    count: usize,
    seed: u32,
    t_s: f64,
) -> Result<Value> {
    let volume = RainVolume::plan(camera, model, wind, params)?;
    let dsd = &model.dsd;
    let n = (count as u64).min(volume.simulated).min(1_000_000);
    let drops: Vec<SampledDrop> = (0..n)
        .filter_map(|i| {
            // i < n, so n > 0 here.
            let id = i * volume.simulated / n.max(1);
            sample_drop(&volume, model, wind, seed, id, t_s)
        })
        .collect();
    let depth = |p: DVec3| camera.camera_from_world_point(p).z;
    let in_view = |p: DVec3| {
        let q = camera.camera_from_world_point(p);
        q.z >= volume.near_m
            && q.z <= volume.far_m
            && camera.project_camera(q).is_some_and(|px| {
                px.x >= 0.0
                    && px.y >= 0.0
                    && px.x <= camera.width_px as f64
                    && px.y <= camera.height_px as f64
            })
            && params.ground_z_m.is_none_or(|g| p.z >= g)
    };
    let total_band: f64 = volume.bands.iter().map(|b| b.simulated).sum();
    let sim_cols = volume.simulated.max(1) as f64;
    let bands: Vec<Value> = volume
        .bands
        .iter()
        .map(|b| {
            let k = drops
                .iter()
                .filter(|d| in_view(d.position_m))
                .filter(|d| (b.near_m..b.far_m).contains(&depth(d.position_m)))
                .count();
            json!({
                "near_m": b.near_m,
                "far_m": b.far_m,
                "sampled": k,
                "sampled_fraction": k as f64 / drops.len().max(1) as f64,
                "planned_fraction": b.simulated / sim_cols,
            })
        })
        .collect();
    let mean = |f: &dyn Fn(&SampledDrop) -> f64| {
        drops.iter().map(f).sum::<f64>() / drops.len().max(1) as f64
    };
    let (lo, hi) = dsd.range_mm();
    let shape = match dsd.shape() {
        DsdShape::MarshallPalmer => json!({"kind": "marshall-palmer"}),
        DsdShape::Gamma { mu } => json!({"kind": "gamma", "mu": mu}),
    };
    let table = model.fall.velocity_table(32, lo, hi);
    let mean_d = if dsd.number_density_per_m3() > 0.0 {
        dsd.moment(1.0) / dsd.number_density_per_m3()
    } else {
        0.0
    };
    let w_t = wind.wind_velocity_mps(t_s);
    let drop_list: Vec<Value> = drops
        .iter()
        .map(|d| {
            json!({
                "id": d.id,
                "column": d.column,
                "diameter_mm": d.diameter_mm,
                "velocity_mps": [d.velocity_mps.x, d.velocity_mps.y, d.velocity_mps.z],
                "position_m": [d.position_m.x, d.position_m.y, d.position_m.z],
                "depth_m": depth(d.position_m),
                "in_view": in_view(d.position_m),
            })
        })
        .collect();
    Ok(json!({
        "rain": {
            "mm_per_h": model.rate.mm_per_h(),
            "class": model.rate.class().map(|c| c.name()),
        },
        "distribution": {
            "shape": shape,
            "n0": dsd.n0(),
            "lambda_per_mm": dsd.lambda_per_mm(),
            "d_min_mm": lo,
            "d_max_mm": hi,
            "number_density_per_m3": dsd.number_density_per_m3(),
            "mean_diameter_mm": mean_d,
            "mass_weighted_diameter_mm": dsd.mass_weighted_diameter_mm(),
            "liquid_water_g_per_m3": dsd.liquid_water_g_per_m3(),
        },
        "fall": {
            "altitude_m": model.fall.altitude_m(),
            "density_factor": model.fall.density_factor(),
            "velocity_table_d_range_mm": [table.d_min_mm, table.d_max_mm],
            "velocity_table_mps": table.v_mps,
        },
        "wind": {
            "mean_mps": [wind.mean_mps.x, wind.mean_mps.y],
            "gust_components": wind.gusts.len(),
            "at_t_mps": [w_t.x, w_t.y],
        },
        "volume": volume.to_json(),
        "sample": {
            "seed": seed,
            "time_s": t_s,
            "count": drops.len(),
            "in_view": drops.iter().filter(|d| in_view(d.position_m)).count(),
            "mean_diameter_mm": mean(&|d| d.diameter_mm),
            "mean_speed_mps": mean(&|d| d.velocity_mps.length()),
            "bands": bands,
            "total_planned_in_view": total_band,
            "drops": drop_list,
        },
    }))
}

#[cfg(test)]
mod tests {
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
