//! The terrain: a height field z = H(x, y) on a regular grid, triangulated regularly (thesis
//! §5.2, Figure 5.6).
//!
//! How it works: vertex (i, j) sits at `origin + (i, j)·spacing` with height `heights[j·nx + i]`.
//! Each grid cell is split along its (i, j)–(i+1, j+1) diagonal; a query finds the triangle
//! holding (x, y) and interpolates height and vertex normals with its barycentric coordinates,
//! which is what the terrain collision of §5.3.1 needs. Vertex normals come from central
//! differences. Outside the grid the border heights extend outward.
//!
//! A height field can come from a DEM ([`HeightField::new`], [`HeightField::from_fn`]), from the
//! estimated ground plane of a shot ([`HeightField::from_ground_plane`]) or from a depth map
//! seen through the shot's camera ([`HeightField::from_depth_map`]).

use crate::scene::Camera;
use crate::{Error, Result};
use glam::{DVec2, DVec3, Vec2, Vec3};

/// Height and interpolated unit normal of the terrain at one (x, y).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TerrainSample {
    /// Terrain height, m.
    pub height_m: f32,
    /// Barycentric interpolation of the vertex normals, normalised (z > 0).
    pub normal: Vec3,
}

/// A regular-grid height field (DEM), z up, metres.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HeightField {
    nx: usize,
    ny: usize,
    origin_m: Vec2,
    spacing_m: f32,
    heights_m: Vec<f32>,
    normals: Vec<Vec3>,
}

impl HeightField {
    /// A height field from `nx × ny` vertex heights (row-major, x fastest).
    pub fn new(
        nx: usize,
        ny: usize,
        origin_m: Vec2,
        spacing_m: f32,
        heights_m: Vec<f32>,
    ) -> Result<HeightField> {
        if nx < 2 || ny < 2 || nx.saturating_mul(ny) > 1 << 26 {
            return Err(Error::Parameter {
                name: "terrain.size",
                value: format!("{nx}×{ny}"),
                expected: "at least 2×2 and at most 2²⁶ vertices".into(),
            });
        }
        if heights_m.len() != nx * ny {
            return Err(Error::Parameter {
                name: "terrain.heights_m",
                value: format!("{} values", heights_m.len()),
                expected: format!("{} values ({nx}×{ny})", nx * ny),
            });
        }
        if !(spacing_m.is_finite() && spacing_m > 0.0 && origin_m.is_finite()) {
            return Err(Error::Parameter {
                name: "terrain.spacing_m",
                value: format!("{spacing_m} at origin {origin_m}"),
                expected: "a finite spacing > 0 and a finite origin".into(),
            });
        }
        if let Some(bad) = heights_m.iter().find(|h| !h.is_finite()) {
            return Err(Error::Parameter {
                name: "terrain.heights_m",
                value: bad.to_string(),
                expected: "finite heights".into(),
            });
        }
        let mut field = HeightField {
            nx,
            ny,
            origin_m,
            spacing_m,
            heights_m,
            normals: Vec::new(),
        };
        // Row by row: no division per vertex to find its row and column.
        let mut normals = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            normals.extend((0..nx).map(|i| field.vertex_normal(i, j)));
        }
        field.normals = normals;
        Ok(field)
    }

    /// A height field sampling `height_m(x, y)` at the vertices.
    pub fn from_fn(
        nx: usize,
        ny: usize,
        origin_m: Vec2,
        spacing_m: f32,
        height_m: impl Fn(f32, f32) -> f32,
    ) -> Result<HeightField> {
        let heights = (0..nx.saturating_mul(ny).min(1 << 26))
            .map(|k| {
                let x = origin_m.x + (k % nx) as f32 * spacing_m;
                let y = origin_m.y + (k / nx) as f32 * spacing_m;
                height_m(x, y)
            })
            .collect();
        HeightField::new(nx, ny, origin_m, spacing_m, heights)
    }

    /// A flat terrain at height `z_m`.
    pub fn flat(nx: usize, ny: usize, origin_m: Vec2, spacing_m: f32, z_m: f32) -> Result<Self> {
        HeightField::from_fn(nx, ny, origin_m, spacing_m, |_, _| z_m)
    }

    /// The plane through `point_m` with normal `normal` (an estimated ground plane), sampled on
    /// the grid. The plane must not be steeper than 80° (normal.z ≥ cos 80°).
    pub fn from_ground_plane(
        normal: Vec3,
        point_m: Vec3,
        nx: usize,
        ny: usize,
        origin_m: Vec2,
        spacing_m: f32,
    ) -> Result<HeightField> {
        let n = normal.normalize_or_zero();
        let steep = n.z.is_nan() || n.z < 80f32.to_radians().cos();
        if steep || !point_m.is_finite() {
            return Err(Error::Parameter {
                name: "terrain.ground_plane",
                value: format!("normal {normal}, point {point_m}"),
                expected: "a finite point and an upward normal at most 80° from vertical".into(),
            });
        }
        let d = n.dot(point_m);
        HeightField::from_fn(nx, ny, origin_m, spacing_m, |x, y| {
            (d - n.x * x - n.y * y) / n.z
        })
    }

    /// A height field from a depth map seen through `camera`: `depth_m[v·W + u]` is the camera-
    /// space z (distance along the optical axis) of pixel (u, v), 0 or non-finite where unknown.
    /// Each pixel's world point is binned to its nearest vertex (mean z); vertices without a
    /// sample take the mean of their sampled neighbours, repeatedly, until all are filled.
    /// `None` when no known pixel lands on the grid (a wall, or a map of holes): the map
    /// shows none of this ground.
    pub fn from_depth_map(
        camera: &Camera,
        depth_m: &[f32],
        nx: usize,
        ny: usize,
        origin_m: Vec2,
        spacing_m: f32,
    ) -> Result<Option<HeightField>> {
        let (w, h) = (camera.width_px as usize, camera.height_px as usize);
        if depth_m.len() != w * h {
            return Err(Error::Parameter {
                name: "terrain.depth_map",
                value: format!("{} values", depth_m.len()),
                expected: format!("{} values ({w}×{h}, the camera's picture)", w * h),
            });
        }
        // Validate the grid first (cheap) so the binning below can index freely.
        HeightField::flat(nx, ny, origin_m, spacing_m, 0.0)?;
        let mut sum = vec![0.0f64; nx * ny];
        let mut count = vec![0u32; nx * ny];
        let f = camera.focal_px();
        let c = camera.principal_px();
        for (k, &z) in depth_m.iter().enumerate() {
            if !(z.is_finite() && z > 0.0) {
                continue;
            }
            let px = DVec2::new((k % w) as f64 + 0.5, (k / w) as f64 + 0.5);
            let d = (px - c) / f * z as f64;
            let p = camera.world_from_camera * DVec3::new(d.x, d.y, z as f64) + camera.position_m;
            let gi = ((p.x - origin_m.x as f64) / spacing_m as f64).round();
            let gj = ((p.y - origin_m.y as f64) / spacing_m as f64).round();
            if gi < 0.0 || gj < 0.0 || gi >= nx as f64 || gj >= ny as f64 {
                continue;
            }
            let v = gj as usize * nx + gi as usize;
            sum[v] += p.z;
            count[v] += 1;
        }
        if count.iter().all(|&n| n == 0) {
            return Ok(None);
        }
        let mut heights: Vec<Option<f64>> = sum
            .iter()
            .zip(&count)
            .map(|(&s, &n)| (n > 0).then(|| s / n as f64))
            .collect();
        // Hole filling by repeated neighbour averaging (Jacobi sweeps, deterministic).
        while heights.iter().any(Option::is_none) {
            let prev = heights.clone();
            for j in 0..ny {
                for i in 0..nx {
                    if prev[j * nx + i].is_some() {
                        continue;
                    }
                    let (mut s, mut n) = (0.0, 0);
                    for (di, dj) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                        let (a, b) = (i as i64 + di, j as i64 + dj);
                        if a >= 0 && b >= 0 && (a as usize) < nx && (b as usize) < ny {
                            if let Some(z) = prev[b as usize * nx + a as usize] {
                                s += z;
                                n += 1;
                            }
                        }
                    }
                    if n > 0 {
                        heights[j * nx + i] = Some(s / n as f64);
                    }
                }
            }
        }
        let heights = heights
            .into_iter()
            .map(|z| z.unwrap_or(0.0) as f32)
            .collect();
        HeightField::new(nx, ny, origin_m, spacing_m, heights).map(Some)
    }

    /// Vertices along x.
    pub fn nx(&self) -> usize {
        self.nx
    }

    /// Vertices along y.
    pub fn ny(&self) -> usize {
        self.ny
    }

    /// Position of vertex (0, 0), m.
    pub fn origin_m(&self) -> Vec2 {
        self.origin_m
    }

    /// Vertex spacing, m.
    pub fn spacing_m(&self) -> f32 {
        self.spacing_m
    }

    /// The far corner (vertex (nx−1, ny−1)), m.
    pub fn max_m(&self) -> Vec2 {
        self.origin_m + Vec2::new((self.nx - 1) as f32, (self.ny - 1) as f32) * self.spacing_m
    }

    /// Vertex heights, m (row-major, x fastest).
    pub fn heights_m(&self) -> &[f32] {
        &self.heights_m
    }

    /// Lowest and highest vertex heights, m.
    pub fn height_range_m(&self) -> (f32, f32) {
        self.heights_m
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &z| {
                (lo.min(z), hi.max(z))
            })
    }

    fn h(&self, i: usize, j: usize) -> f32 {
        self.heights_m[j * self.nx + i]
    }

    fn vertex_normal(&self, i: usize, j: usize) -> Vec3 {
        let (i0, i1) = (i.saturating_sub(1), (i + 1).min(self.nx - 1));
        let (j0, j1) = (j.saturating_sub(1), (j + 1).min(self.ny - 1));
        let dzdx = (self.h(i1, j) - self.h(i0, j)) / ((i1 - i0) as f32 * self.spacing_m);
        let dzdy = (self.h(i, j1) - self.h(i, j0)) / ((j1 - j0) as f32 * self.spacing_m);
        Vec3::new(-dzdx, -dzdy, 1.0).normalize()
    }

    /// Height and barycentrically interpolated normal at (x, y) (thesis §5.3.1 collision).
    #[inline]
    pub fn sample(&self, x_m: f32, y_m: f32) -> TerrainSample {
        let gx = ((x_m - self.origin_m.x) / self.spacing_m).clamp(0.0, (self.nx - 1) as f32);
        let gy = ((y_m - self.origin_m.y) / self.spacing_m).clamp(0.0, (self.ny - 1) as f32);
        let i = (gx as usize).min(self.nx - 2);
        let j = (gy as usize).min(self.ny - 2);
        let (u, v) = (gx - i as f32, gy - j as f32);
        let k00 = j * self.nx + i;
        let k11 = k00 + self.nx + 1;
        // Lower triangle (i,j),(i+1,j),(i+1,j+1) when u ≥ v, else (i,j),(i,j+1),(i+1,j+1).
        let (w00, wmid, w11, kmid) = if u >= v {
            (1.0 - u, u - v, v, k00 + 1)
        } else {
            (1.0 - v, v - u, u, k00 + self.nx)
        };
        let height_m =
            w00 * self.heights_m[k00] + wmid * self.heights_m[kmid] + w11 * self.heights_m[k11];
        let normal =
            (self.normals[k00] * w00 + self.normals[kmid] * wmid + self.normals[k11] * w11)
                .normalize_or(Vec3::Z);
        TerrainSample { height_m, normal }
    }

    /// Terrain height at (x, y), m.
    #[inline]
    pub fn height_at_m(&self, x_m: f32, y_m: f32) -> f32 {
        self.sample(x_m, y_m).height_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planes_are_reproduced_exactly() {
        let n = Vec3::new(0.1, -0.2, 1.0).normalize();
        let t = HeightField::from_ground_plane(n, Vec3::new(0.0, 0.0, 0.5), 9, 7, Vec2::ZERO, 0.25)
            .expect("plane");
        for &(x, y) in &[(0.3, 0.7), (1.9, 1.4), (0.0, 0.0), (1.13, 0.61)] {
            let s = t.sample(x, y);
            let z = 0.5 - (n.x * x + n.y * y) / n.z;
            assert!((s.height_m - z).abs() < 1e-5);
            assert!((s.normal - n).length() < 1e-5);
        }
    }

    #[test]
    fn depth_map_of_a_flat_floor_is_flat() {
        let cam = Camera::new(64, 48, 1.2, 1.5, -0.6, 0.0);
        // Depth of the ground z = 0 along each pixel's ray, converted to camera-space z.
        let mut depth = vec![0.0f32; 64 * 48];
        for v in 0..48 {
            for u in 0..64 {
                let ray = cam.ray_world(DVec2::new(u as f64 + 0.5, v as f64 + 0.5));
                if ray.z < -1e-3 {
                    let t = cam.position_m.z / -ray.z;
                    let p_cam = cam.camera_from_world_point(cam.position_m + ray * t);
                    depth[v * 64 + u] = p_cam.z as f32;
                }
            }
        }
        let t = HeightField::from_depth_map(&cam, &depth, 11, 11, Vec2::new(-1.0, 1.0), 0.2)
            .expect("depth map")
            .expect("ground in the map");
        let (lo, hi) = t.height_range_m();
        assert!(lo.abs() < 1e-4 && hi.abs() < 1e-4, "{lo} {hi}");
    }

    #[test]
    fn bad_inputs_are_errors() {
        assert!(HeightField::new(1, 5, Vec2::ZERO, 1.0, vec![0.0; 5]).is_err());
        assert!(HeightField::new(2, 2, Vec2::ZERO, 1.0, vec![0.0, f32::NAN, 0.0, 0.0]).is_err());
        assert!(HeightField::new(2, 2, Vec2::ZERO, 0.0, vec![0.0; 4]).is_err());
        assert!(
            HeightField::from_ground_plane(Vec3::X, Vec3::ZERO, 3, 3, Vec2::ZERO, 1.0).is_err()
        );
    }
}
