//! The puddles' cover eight at a time: [`Puddles::probe_cover`]'s operations lane by lane, its
//! branches as selects, the map's 4×4 cells around each probe read once (by AVX2 gathers in the
//! AVX2 build) for the range, its widening and Catmull-Rom; the same bits as the plain routines
//! ([`Puddles::cover`], [`Puddles::probe_cover`]), which stay the reference (and serve the lanes
//! whose cells leave the map). A row's pixels whose footprints are one probe each go eight at a
//! time; the far rows' pixels, whose footprints are cut into pieces, queue their pieces' probes
//! and are summed in the plain order once eight are made; probes whose 4×4 cells are all dry or
//! all deep are settled without the reading. Most of the water's shading is this cover, made for
//! every downward pixel of a block that may see water.

use glam::Vec2;

use super::super::lanes::{LANES, gather};
use super::super::wet_ground::smoothstep;
use super::{Puddles, catmull_rom, catmull_rom_slope, rim_cover_spread};

impl Puddles<'_> {
    /// The covers of the pixels `x`.. of row `y` into `out` (one per pixel, all of whose rays
    /// go down), each [`Puddles::cover`]'s value: eight pixels at a time through
    /// [`Puddles::probe_lanes`] where all their footprints are one probe each; elsewhere (the
    /// far rows, whose footprints are cut into pieces, and a span's last pixels) each pixel's
    /// probes over wet cells are queued and made eight at a time, and each cover summed in
    /// [`Puddles::pieces`]' order (a probe over dry cells adds 0: left out).
    #[inline(always)]
    pub(super) fn cover_span(&self, x: usize, y: usize, out: &mut [f32], avx2: bool) {
        let mut queue = Queue::default();
        let mut k = 0;
        while k + LANES <= out.len() {
            let (xy, per) = self.footprint_lanes(x + k, y);
            let one = (0..LANES).fold(true, |a, l| a & self.one_probe(lane_per(&per, l)));
            if one {
                out[k..][..LANES].copy_from_slice(&self.probe_lanes(xy, per, avx2));
            } else {
                for (l, (&ax, &ay)) in xy[0].iter().zip(&xy[1]).enumerate() {
                    let at = Vec2::new(ax, ay);
                    self.queue_cover(k + l, at, lane_per(&per, l), &mut queue, out, avx2);
                }
            }
            k += LANES;
        }
        for k in k..out.len() {
            let (at, per_px) = self.footprint(x + k, y);
            self.queue_cover(k, at, per_px, &mut queue, out, avx2);
        }
        queue.flush(self, out, avx2);
    }

    /// Queues the probes of the cover of `out[k]`, a pixel whose ground point is `xy` and moves
    /// by `per_px` ([`Puddles::water_cover`]'s); a probe whose cells settle it
    /// ([`Puddles::probe_settled`]) is not made: 0 adds nothing, 1 adds its weight (in its turn).
    #[inline(always)]
    fn queue_cover(
        &self,
        k: usize,
        xy: Vec2,
        per_px: [Vec2; 2],
        queue: &mut Queue,
        out: &mut [f32],
        avx2: bool,
    ) {
        if self.one_probe(per_px) {
            match self.probe_settled(xy) {
                Some(cover) => out[k] = cover,
                None => queue.push(self, (k, None), Some((xy, per_px)), out, avx2),
            }
            return;
        }
        out[k] = 0.0;
        if let Some(pieces) = self.pieces(xy, per_px) {
            for i in 0..pieces.len(0) {
                for j in 0..pieces.len(1) {
                    let Some((weight, at, per)) = pieces.piece(i, j) else {
                        continue;
                    };
                    match self.probe_settled(at) {
                        Some(cover) if cover <= 0.0 => {}
                        Some(_) => queue.push(self, (k, Some(weight)), None, out, avx2),
                        None => queue.push(self, (k, Some(weight)), Some((at, per)), out, avx2),
                    }
                }
            }
        }
    }

    /// [`Puddles::footprint`] of the pixels (`x` + l, `y`), l < [`LANES`]: the ground points'
    /// x and y, and their changes per pixel (x and y of the change along x, then along y).
    #[inline(always)]
    fn footprint_lanes(&self, x: usize, y: usize) -> (Lanes2, Lanes4) {
        let (mut xy, mut per) = ([[0f32; LANES]; 2], [[0f32; LANES]; 4]);
        for l in 0..LANES {
            let (at, [dx, dy]) = self.footprint(x + l, y);
            [xy[0][l], xy[1][l]] = [at.x, at.y];
            [per[0][l], per[1][l], per[2][l], per[3][l]] = [dx.x, dx.y, dy.x, dy.y];
        }
        (xy, per)
    }

    /// [`Puddles::probe_cover`] of eight probes, at ground points `xy` (x, then y), moving by
    /// `per` (as [`Puddles::footprint_lanes`] lays it out); `avx2`: the cells read by AVX2
    /// gathers (only inside a build with AVX2 enabled). The same bits as the plain probe.
    #[inline(always)]
    fn probe_lanes(&self, xy: Lanes2, per: Lanes4, avx2: bool) -> [f32; LANES] {
        let p = &self.water.params;
        let (nx, ny) = (p.cells[0] as usize, p.cells[1] as usize);
        // The probe's place on the map (`probe_cover`'s `u`).
        let (mut fx, mut fy, mut ix, mut iy) = ([0f32; LANES], [0f32; LANES], [0f32; 8], [0f32; 8]);
        for l in 0..LANES {
            let u = (Vec2::new(xy[0][l], xy[1][l]) - Vec2::from_array(p.origin_m)) / p.cell_m
                - Vec2::splat(0.5);
            let i0 = u.floor();
            let f = u - i0;
            (fx[l], fy[l], ix[l], iy[l]) = (f.x, f.y, i0.x, i0.y);
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
                    out[l] = self.probe_cover(Vec2::new(xy[0][l], xy[1][l]), lane_per(&per, l));
                }
            }
        }
        out
    }
}

/// Eight lanes of two values (x, y).
type Lanes2 = [[f32; LANES]; 2];
/// Eight lanes of a pixel's two changes per pixel (x and y of each).
type Lanes4 = [[f32; LANES]; 4];

/// Lane `l`'s changes per pixel.
#[inline(always)]
fn lane_per(per: &Lanes4, l: usize) -> [Vec2; 2] {
    [
        Vec2::new(per[0][l], per[1][l]),
        Vec2::new(per[2][l], per[3][l]),
    ]
}

/// Steps of the covers waiting for their probes, each for the cover `out[k]`: with weight
/// `None`, the probe is the cover; `Some(weight)`, weight × probe is added to it; the probe is
/// lane `l` of the next eight made, or 1 (a probe its cells settle). Applied in the order they
/// were queued, once eight probes wait or the steps are full.
struct Queue {
    xy: Lanes2,
    per: Lanes4,
    lanes: usize,
    steps: [(usize, Option<f32>, Option<usize>); STEPS],
    len: usize,
}

/// Steps a [`Queue`] holds at most.
const STEPS: usize = 64;

impl Default for Queue {
    fn default() -> Queue {
        Queue {
            xy: [[0.0; LANES]; 2],
            per: [[0.0; LANES]; 4],
            lanes: 0,
            steps: [(0, None, None); STEPS],
            len: 0,
        }
    }
}

impl Queue {
    /// Queues a step for `to` (`out[k]`, weight), its probe at a ground point moving by its
    /// change per pixel, or 1 where `probe` is `None`; applies the steps once full.
    #[inline(always)]
    fn push(
        &mut self,
        puddles: &Puddles,
        (k, weight): (usize, Option<f32>),
        probe: Option<(Vec2, [Vec2; 2])>,
        out: &mut [f32],
        avx2: bool,
    ) {
        let mut lane = None;
        if let Some((xy, per_px)) = probe {
            let l = self.lanes;
            [self.xy[0][l], self.xy[1][l]] = [xy.x, xy.y];
            [self.per[0][l], self.per[1][l]] = [per_px[0].x, per_px[0].y];
            [self.per[2][l], self.per[3][l]] = [per_px[1].x, per_px[1].y];
            self.lanes += 1;
            lane = Some(l);
        }
        self.steps[self.len] = (k, weight, lane);
        self.len += 1;
        if self.lanes == LANES || self.len == STEPS {
            self.flush(puddles, out, avx2);
        }
    }

    /// Makes the queued probes (the empty lanes repeat the first, their values unused) and
    /// applies the steps in order.
    #[inline(always)]
    fn flush(&mut self, puddles: &Puddles, out: &mut [f32], avx2: bool) {
        let mut probes = [1f32; LANES];
        if self.lanes > 0 {
            for l in self.lanes..LANES {
                for v in self.xy.iter_mut().chain(self.per.iter_mut()) {
                    v[l] = v[0];
                }
            }
            probes = puddles.probe_lanes(self.xy, self.per, avx2);
        }
        for &(k, weight, lane) in &self.steps[..self.len] {
            let probe = lane.map_or(1.0, |l| probes[l]);
            match weight {
                None => out[k] = probe,
                Some(w) => out[k] += w * probe,
            }
        }
        (self.lanes, self.len) = (0, 0);
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

    /// What a test map holds.
    #[derive(Clone, Copy, PartialEq)]
    enum Map {
        /// Pools: dry cells, films under the rim's depth and deep water.
        Pools,
        /// Single wet cells, about one in 300, on dry ground.
        Sparse,
        /// Squares of deep water (0.5 m) and of exactly the rim's depth, with dry and shallow
        /// squares among them.
        Steps,
    }

    /// The `map` over cells of `cell_m` that ends inside the picture's ground: the depths, the
    /// cells along x and y and the map's origin.
    fn pools(cell_m: f32, map: Map) -> (Vec<f32>, [u32; 2], [f32; 2]) {
        let (nx, ny) = ((6.0 / cell_m) as usize, (9.0 / cell_m) as usize);
        let edge_m = water_params([0.0; 2], cell_m, [1, 1]).edge_depth_m;
        let depth = (0..nx * ny)
            .map(|k| {
                let (x, y) = ((k % nx) as f32 * cell_m, (k / nx) as f32 * cell_m);
                match map {
                    Map::Sparse => {
                        let h = (k as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 40;
                        if h.is_multiple_of(300) { 0.004 } else { 0.0 }
                    }
                    Map::Pools => (0.02 * (2.1 * x).sin() * (1.7 * y).cos() - 0.003).max(0.0),
                    Map::Steps => {
                        let (i, j) = ((k % nx) / 3, (k / nx) / 2);
                        [0.5, edge_m, 0.5, 0.0, 0.5, 0.3 * edge_m][(i + 2 * j) % 6]
                    }
                }
            })
            .collect();
        (depth, [nx as u32, ny as u32], [-2.5, -0.5])
    }

    /// A row span's covers are the plain routine's, value for value, over map cells finer
    /// and coarser than a pixel's footprint, far rows whose footprints are cut into pieces, a
    /// map that ends in the picture, a turned picture, single wet cells on dry ground (where
    /// the dry blocks are passed over), and deep water beside cells at exactly the rim's depth
    /// (where a probe's widened range falls a rounding below the rim: not settled as deep);
    /// with and without the AVX2 gathers, spans of every length from each pixel.
    #[test]
    fn cover_span_is_the_plain_cover() {
        let lights = LightList::new(&[]);
        let avx2 = super::super::has_avx2();
        let (mut compared, mut rims, mut off_map, mut pieces, mut deep) = (0, 0, 0, 0, 0);
        for (pitch, turned, cell_m, map) in [
            (0.35, false, 0.02, Map::Pools),
            (0.35, false, 0.25, Map::Pools),
            (0.6, true, 0.05, Map::Pools),
            (0.2, false, 0.1, Map::Pools),
            (0.12, false, 0.02, Map::Pools),
            (0.35, false, 0.02, Map::Sparse),
            (0.6, true, 0.05, Map::Sparse),
            (0.12, false, 0.02, Map::Steps),
            (0.35, false, 0.05, Map::Steps),
        ] {
            let p = camera(pitch, turned);
            let size = (p.display_size_px[0] as u32, p.display_size_px[1] as u32);
            let size = if turned { (size.1, size.0) } else { size };
            let ground = Ground::new(&p, size, None, None);
            let (depth, cells, origin_m) = pools(cell_m, map);
            let water = FrameWater {
                params: water_params(origin_m, cell_m, cells),
                depth_m: &depth,
                ripples: Vec::new(),
            };
            let puddles = Puddles::new(&ground, &water, &lights).expect("a ground");
            for y in 0..size.1 as usize {
                let down = ground.downward(y);
                let plain: Vec<f32> = down.clone().map(|x| puddles.cover(x, y)).collect();
                for x in down.clone() {
                    let (at, per_px) = puddles.footprint(x, y);
                    pieces += usize::from(!puddles.one_probe(per_px));
                    deep += usize::from(puddles.probe_settled(at) == Some(1.0));
                    let pm = &water.params;
                    let u = (at - Vec2::from(pm.origin_m)) / pm.cell_m;
                    off_map += usize::from(u.x < 1.5 || u.y < 1.5 || u.x > cells[0] as f32 - 3.0);
                }
                // Spans of each length from each start (a few starts per row).
                let n = down.len();
                for start in (0..n).step_by(5) {
                    for len in [n - start, 1, 7, 8, 9, 17]
                        .into_iter()
                        .filter(|&l| start + l <= n)
                    {
                        for gathers in [false, avx2] {
                            let mut span = vec![f32::NAN; len];
                            puddles.cover_span(down.start + start, y, &mut span, gathers);
                            for (k, (&c, &plain)) in span.iter().zip(&plain[start..]).enumerate() {
                                assert!(
                                    c.to_bits() == plain.to_bits()
                                        || (c.is_nan() && plain.is_nan()),
                                    "pixel ({}, {y}), cells {cell_m} m: {c} against {plain}",
                                    down.start + start + k
                                );
                                compared += 1;
                                rims += usize::from(c > 0.0 && c < 1.0);
                            }
                        }
                    }
                }
            }
        }
        assert!(
            compared > 200_000 && rims > 5_000 && off_map > 1_000 && pieces > 2_000 && deep > 2_000,
            "{compared} {rims} {off_map} {pieces} {deep}"
        );
    }
}
