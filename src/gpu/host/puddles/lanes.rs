//! The puddles' cover eight pixels of a row at a time: [`Puddles::cover`]'s operations lane by
//! lane, its branches as selects, the map's 4×4 cells around each ground point read once (by AVX2
//! gathers in the AVX2 build) for the range, its widening and Catmull-Rom; the same bits as the
//! plain routine, which stays the reference (and serves the lanes whose cells leave the map, and
//! the rows whose footprints are longer than a probe). Most of the water's shading is this cover,
//! made for every downward pixel of a block that may see water.

use glam::Vec2;

use super::super::lanes::{LANES, gather};
use super::super::wet_ground::smoothstep;
use super::{PROBE_CELLS, Puddles, catmull_rom, catmull_rom_slope, rim_cover_spread};

impl Puddles<'_> {
    /// [`Puddles::cover`] of the pixels (`x` + l, `y`), l < [`LANES`], all of whose rays go
    /// down; `avx2`: the cells read by AVX2 gathers (only inside a build with AVX2 enabled).
    #[inline(always)]
    pub(super) fn cover_lanes(&self, x: usize, y: usize, avx2: bool) -> [f32; LANES] {
        let g = self.ground;
        let p = &self.water.params;
        let (nx, ny) = (p.cells[0] as usize, p.cells[1] as usize);
        // The ground point's place on the map and its change per pixel (`cover`).
        let (mut fx, mut fy, mut ix, mut iy) = ([0f32; LANES], [0f32; LANES], [0f32; 8], [0f32; 8]);
        let mut per = [[0f32; LANES]; 4];
        for l in 0..LANES {
            let ray = g.ray_through(Vec2::new((x + l) as u32 as f32 + 0.5, y as f32 + 0.5));
            let ground_z_m = g.height_m() / -ray.z;
            let ground = g.camera + ground_z_m * ray;
            let per_px = |r: glam::Vec3| ground_z_m * (r - ray * (r.z / ray.z));
            let (dx, dy) = (per_px(g.dx), per_px(g.dy));
            [per[0][l], per[1][l], per[2][l], per[3][l]] = [dx.x, dx.y, dy.x, dy.y];
            let u = (Vec2::new(ground.x, ground.y) - Vec2::from_array(p.origin_m)) / p.cell_m
                - Vec2::splat(0.5);
            let i0 = u.floor();
            let f = u - i0;
            (fx[l], fy[l], ix[l], iy[l]) = (f.x, f.y, i0.x, i0.y);
        }
        // A footprint longer than a probe along an axis (far ground): its cover is the mean
        // over its pieces, the plain routine's.
        let reach = PROBE_CELLS * p.cell_m;
        if (0..LANES).any(|l| {
            let (a, b) = (
                Vec2::new(per[0][l], per[1][l]),
                Vec2::new(per[2][l], per[3][l]),
            );
            a.length_squared().max(b.length_squared()) > reach * reach
        }) {
            // A loop, not `array::from_fn`: that stays a function of its own, built without
            // the AVX2 build's features (its `floor` a call to libm), and the pieces' probes
            // are most of the far rows' time.
            let mut cover = [0f32; LANES];
            for (l, c) in cover.iter_mut().enumerate() {
                *c = self.cover(x + l, y);
            }
            return cover;
        }
        // Lanes whose 4×4 cells all lie on the map (`water_cover`'s `inside`, in floats: NaN
        // and the far side fail); the others are read at cell 0 and made by the plain routine.
        let (mut inside, mut all) = ([false; LANES], true);
        let mut at = [0u32; LANES];
        for l in 0..LANES {
            inside[l] = ix[l] >= 1.0
                && iy[l] >= 1.0
                && ix[l] + 3.0 <= nx as f32
                && iy[l] + 3.0 <= ny as f32;
            all &= inside[l];
            if inside[l] {
                at[l] = (iy[l] as u32 - 1) * nx as u32 + ix[l] as u32 - 1;
            }
        }
        // Where every lane's cells lie on the map and no cell of their 4×4 windows is wet,
        // every cover is 0 (the plain routine's range is then at most 0), without the reads.
        if all {
            let (lo_x, hi_x) = (
                ix.iter().fold(f32::MAX, |a, &b| a.min(b)),
                ix.iter().fold(0f32, |a, &b| a.max(b)),
            );
            let (lo_y, hi_y) = (
                iy.iter().fold(f32::MAX, |a, &b| a.min(b)),
                iy.iter().fold(0f32, |a, &b| a.max(b)),
            );
            let cols = (lo_x as usize - 1, hi_x as usize + 2);
            if !self.wet.any(cols, (lo_y as usize - 1, hi_y as usize + 2)) {
                return [0.0; LANES];
            }
        }
        let map = self.water.depth_m;
        // cells[4 b + a]: cell (i0 + a, j0 + b) of each lane.
        let mut cells = [[0f32; LANES]; 16];
        for b in 0..4 {
            let mut row = at;
            for r in &mut row {
                *r += (b * nx) as u32;
            }
            for a in 0..4 {
                cells[4 * b + a] = gather(map, row, a, avx2);
            }
        }
        let edge = p.edge_depth_m;
        let cell = |a: usize, b: usize, l: usize| cells[4 * b + a][l];
        // The four nearest cells' range, widened toward the twelve around them where the
        // footprint passes their square (loops kept short, each one vectorised).
        let (mut lo, mut hi) = ([0f32; LANES], [0f32; LANES]);
        let (mut reach_x, mut reach_y) = ([[1f32; LANES]; 4], [[1f32; LANES]; 4]);
        let mut widen = [false; LANES];
        for l in 0..LANES {
            let near = [cell(1, 1, l), cell(2, 1, l), cell(1, 2, l), cell(2, 2, l)];
            lo[l] = near[0].min(near[1]).min(near[2].min(near[3]));
            hi[l] = near[0].max(near[1]).max(near[2].max(near[3]));
            let (d0, d1) = (
                Vec2::new(per[0][l], per[1][l]),
                Vec2::new(per[2][l], per[3][l]),
            );
            let f = Vec2::new(fx[l], fy[l]);
            let half = (d0.abs() + d1.abs()) * (0.5 / p.cell_m);
            let (before, after) = (
                (half - f).clamp(Vec2::ZERO, Vec2::ONE),
                (f + half - Vec2::ONE).clamp(Vec2::ZERO, Vec2::ONE),
            );
            (reach_x[0][l], reach_x[3][l]) = (before.x, after.x);
            (reach_y[0][l], reach_y[3][l]) = (before.y, after.y);
            widen[l] = before.max(after).max_element() > 0.0;
        }
        let (mut down, mut up) = ([0f32; LANES], [0f32; LANES]);
        for (b, ry) in reach_y.iter().enumerate() {
            for (a, rx) in reach_x.iter().enumerate() {
                for l in 0..LANES {
                    let (v, r) = (cell(a, b, l), rx[l] * ry[l]);
                    down[l] = down[l].max(r * (lo[l] - v).max(0.0));
                    up[l] = up[l].max(r * (v - hi[l]).max(0.0));
                }
            }
        }
        for l in 0..LANES {
            if widen[l] {
                (lo[l], hi[l]) = (lo[l] - down[l], hi[l] + up[l]);
            }
        }
        // Catmull-Rom's depth and its change per pixel, and the rim's cover.
        let mut out = [0f32; LANES];
        for l in 0..LANES {
            let (wx, wy) = (catmull_rom(fx[l]), catmull_rom(fy[l]));
            let sx = catmull_rom_slope(fx[l]);
            let row = |w: &[f32; 4], b: usize| {
                w[0] * cell(0, b, l)
                    + w[1] * cell(1, b, l)
                    + w[2] * cell(2, b, l)
                    + w[3] * cell(3, b, l)
            };
            let rows = [row(&wx, 0), row(&wx, 1), row(&wx, 2), row(&wx, 3)];
            let dot =
                |w: [f32; 4], v: [f32; 4]| w[0] * v[0] + w[1] * v[1] + w[2] * v[2] + w[3] * v[3];
            let sum = dot(wy, rows);
            let along_x = dot(wy, [row(&sx, 0), row(&sx, 1), row(&sx, 2), row(&sx, 3)]);
            let along_y = dot(catmull_rom_slope(fy[l]), rows);
            let grad = Vec2::new(along_x, along_y) / p.cell_m;
            let (d0, d1) = (
                Vec2::new(per[0][l], per[1][l]),
                Vec2::new(per[2][l], per[3][l]),
            );
            let width = Vec2::new(grad.dot(d0), grad.dot(d1)).length();
            let rim = rim_cover_selected(sum, lo[l], hi[l], width, edge);
            out[l] = if hi[l] <= 0.0 {
                0.0
            } else if lo[l] >= edge {
                1.0
            } else {
                rim
            };
        }
        if !all {
            for l in 0..LANES {
                if !inside[l] {
                    out[l] = self.cover(x + l, y);
                }
            }
        }
        out
    }
}

/// [`super::rim_cover`] with both of its ways made and one picked (the same bits: neither
/// way has a side effect, and a lane's unused way may divide by zero harmlessly).
#[inline(always)]
fn rim_cover_selected(depth: f32, lo: f32, hi: f32, width: f32, edge: f32) -> f32 {
    let narrow = smoothstep(0.0, edge, depth.max(lo).min(hi));
    let wide = rim_cover_spread(depth, lo, hi, width, edge);
    if width <= 1e-3 * edge { narrow } else { wide }
}

#[cfg(test)]
mod tests {
    use bytemuck::Zeroable;

    use super::super::super::wet_ground::Ground;
    use super::*;
    use crate::gpu::stages::puddles::{FrameWater, water_params};
    use crate::gpu::types::{LightList, RainParams};

    /// A camera 1.6 m over the ground, pitched down by `pitch` rad, the picture turned by
    /// `turned` (coded = displayed turned a quarter), 160 × 96 coded pixels.
    fn camera(pitch: f32, turned: bool) -> RainParams {
        let mut p = RainParams::zeroed();
        let (w, h) = if turned { (96.0, 160.0) } else { (160.0, 96.0) };
        p.camera_pos_m = [0.3, -1.0, 1.6];
        p.focal_px = 120.0;
        let (s, c) = pitch.sin_cos();
        p.camera_from_world_0 = [1.0, 0.0, 0.0, 0.0];
        p.camera_from_world_1 = [0.0, -s, -c, 0.0];
        p.camera_from_world_2 = [0.0, c, -s, 0.0];
        p.principal_px = [0.5 * w, 0.5 * h];
        p.display_size_px = [w, h];
        // display = m (coded − offset): a quarter turn maps coded (x, y) to (y, 159 − x).
        (p.coded_from_display, p.coded_offset_px) = if turned {
            ([0.0, -1.0, 1.0, 0.0], [160.0, 0.0])
        } else {
            ([1.0, 0.0, 0.0, 1.0], [0.0, 0.0])
        };
        p
    }

    /// Pools over a map of `cell_m` cells that ends inside the picture's ground: dry cells,
    /// films under the rim's depth and deep water.
    /// `sparse`: single wet cells, about one in 300, on dry ground instead.
    fn pools(cell_m: f32, sparse: bool) -> (Vec<f32>, [u32; 2], [f32; 2]) {
        let (nx, ny) = ((6.0 / cell_m) as usize, (9.0 / cell_m) as usize);
        let depth = (0..nx * ny)
            .map(|k| {
                let (x, y) = ((k % nx) as f32 * cell_m, (k / nx) as f32 * cell_m);
                if sparse {
                    let h = (k as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 40;
                    return if h.is_multiple_of(300) { 0.004 } else { 0.0 };
                }
                (0.02 * (2.1 * x).sin() * (1.7 * y).cos() - 0.003).max(0.0)
            })
            .collect();
        (depth, [nx as u32, ny as u32], [-2.5, -0.5])
    }

    /// Each lane block's covers are the plain routine's, value for value, over map cells
    /// finer and coarser than a pixel's footprint, a map that ends in the picture, a turned
    /// picture, and single wet cells on dry ground (where the dry blocks are passed over);
    /// with and without the AVX2 gathers.
    #[test]
    fn cover_lanes_are_the_plain_cover() {
        let lights = LightList::new(&[]);
        let avx2 = super::super::has_avx2();
        let (mut compared, mut rims, mut off_map) = (0, 0, 0);
        for (pitch, turned, cell_m, sparse) in [
            (0.35, false, 0.02, false),
            (0.35, false, 0.25, false),
            (0.6, true, 0.05, false),
            (0.2, false, 0.1, false),
            (0.35, false, 0.02, true),
            (0.6, true, 0.05, true),
        ] {
            let p = camera(pitch, turned);
            let size = (p.display_size_px[0] as u32, p.display_size_px[1] as u32);
            let size = if turned { (size.1, size.0) } else { size };
            let ground = Ground::new(&p, size, None, None);
            let (depth, cells, origin_m) = pools(cell_m, sparse);
            let water = FrameWater {
                params: water_params(origin_m, cell_m, cells),
                depth_m: &depth,
                ripples: Vec::new(),
            };
            let puddles = Puddles::new(&ground, &water, &lights).expect("a ground");
            for y in 0..size.1 as usize {
                let down = ground.downward(y);
                let mut x = down.start;
                while x + LANES <= down.end {
                    for gathers in [false, avx2] {
                        let lanes = puddles.cover_lanes(x, y, gathers);
                        for (l, &c) in lanes.iter().enumerate() {
                            let plain = puddles.cover(x + l, y);
                            assert!(
                                c == plain || (c.is_nan() && plain.is_nan()),
                                "pixel ({}, {y}), cells {cell_m} m: {c} against {plain}",
                                x + l
                            );
                            compared += 1;
                            rims += usize::from(c > 0.0 && c < 1.0);
                        }
                    }
                    let (g, pm) = (&ground, &water.params);
                    for l in 0..LANES {
                        let ray = g.ray(x + l, y);
                        let at = g.camera + (g.height_m() / -ray.z) * ray;
                        let u = (Vec2::new(at.x, at.y) - Vec2::from(pm.origin_m)) / pm.cell_m;
                        off_map +=
                            usize::from(u.x < 1.5 || u.y < 1.5 || u.x > cells[0] as f32 - 3.0);
                    }
                    x += 3;
                }
            }
        }
        assert!(
            compared > 50_000 && rims > 2_000 && off_map > 1_000,
            "{compared} {rims} {off_map}"
        );
    }
}
