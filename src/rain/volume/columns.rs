//! The emitter's columns: sheared prisms covering the view slab, with the drops shared among
//! them by volume.

use glam::{DMat3, DVec2, DVec3};

use super::drop::{SIZE_KEEP_ALL, SIZE_KEEP_BITS};
use super::geometry::{HalfSpace, polytope_vertices, slab_half_spaces};
use crate::scene::Camera;

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
    /// Share of the size distribution the column simulates, 2⁻²⁴ ([`super::drop::size_bits`]):
    /// 1 − F(D_cut), D_cut the smallest diameter whose streak (or splash) can show in it
    /// ([`super::visible`]); [`SIZE_KEEP_ALL`] simulates every size.
    pub size_keep_q: u32,
}

impl Column {
    /// The share of the size distribution the column simulates, S = 1 − F(D_cut).
    pub fn size_share(&self) -> f64 {
        self.size_keep_q.min(SIZE_KEEP_ALL) as f64 / (1u64 << SIZE_KEEP_BITS) as f64
    }

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
        let cameras = std::slice::from_ref(camera);
        ColumnGrid::build_envelope(cameras, near_m, far_m, ground_z_m, slope, max_columns)
    }

    /// Column prisms covering every camera's frustum slab (a moving camera sampled over the
    /// shot): the grid spans the union of their footprints and each cell's prism spans the
    /// union of the z ranges the cameras see in it. One camera gives [`ColumnGrid::build`].
    pub fn build_envelope(
        cameras: &[Camera],
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
        let slabs: Vec<Vec<HalfSpace>> = cameras
            .iter()
            .map(|c| slab_half_spaces(c, near_m, far_m, ground_z_m))
            .filter(|w| polytope_vertices(w).len() >= 4)
            .collect();
        if slabs.is_empty() {
            return grid;
        }
        let to_uv = |p: DVec3| DVec2::new(p.x, p.y) - slope * p.z;
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for p in slabs.iter().flat_map(|w| polytope_vertices(w)) {
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
        let sheared: Vec<Vec<HalfSpace>> = slabs
            .iter()
            .map(|world| {
                world
                    .iter()
                    .map(|h| HalfSpace {
                        n: shear.transpose() * h.n,
                        d: h.d,
                    })
                    .map(|h| HalfSpace::new(h.n, h.d))
                    .collect()
            })
            .collect();
        for iu in 0..nu as usize {
            for iv in 0..nv as usize {
                let c0 = lo + cell * DVec2::new(iu as f64, iv as f64);
                let c1 = c0 + cell;
                let walls = [
                    HalfSpace::new(DVec3::X, c1.x),
                    HalfSpace::new(DVec3::NEG_X, -c0.x),
                    HalfSpace::new(DVec3::Y, c1.y),
                    HalfSpace::new(DVec3::NEG_Y, -c0.y),
                ];
                let (mut z_lo, mut z_hi) = (f64::INFINITY, f64::NEG_INFINITY);
                for slab in &sheared {
                    let mut hs = slab.clone();
                    hs.extend(walls);
                    for p in polytope_vertices(&hs) {
                        z_lo = z_lo.min(p.z);
                        z_hi = z_hi.max(p.z);
                    }
                }
                let vol = cell.x * cell.y * (z_hi - z_lo);
                if z_hi - z_lo > 1e-9 && vol.is_finite() && vol > 0.0 {
                    grid.columns.push(Column {
                        cell_min_m: c0,
                        z_lo_m: z_lo,
                        z_hi_m: z_hi,
                        first_id: 0,
                        count: 0,
                        size_keep_q: SIZE_KEEP_ALL,
                    });
                    grid.volumes.push(vol);
                }
            }
        }
        grid.volume_m3 = grid.volumes.iter().sum();
        grid
    }

    /// The volume the columns simulate, m³: each column's volume times its size share (drops
    /// per m³ of every size × this = the drops to simulate).
    pub fn simulated_volume_m3(&self) -> f64 {
        self.columns
            .iter()
            .zip(&self.volumes)
            .map(|(c, v)| v * c.size_share())
            .sum()
    }

    /// Shares `total` drops among the columns in proportion to their volumes times their size
    /// shares (cumulative rounding: the counts sum to `total` and each column is within one drop
    /// of its share), then drops the columns left empty.
    pub fn allot(&mut self, total: u64) {
        let v = self.simulated_volume_m3();
        if v <= 0.0 || total == 0 {
            self.columns.clear();
            self.volumes.clear();
            self.total = 0;
            return;
        }
        let mut acc = 0.0;
        let mut prev = 0u64;
        for (c, vol) in self.columns.iter_mut().zip(&self.volumes) {
            acc += vol * c.size_share();
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
