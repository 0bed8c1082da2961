//! The haze as the CPU back end lays it over the plate: `plate · T' + (1 − T') · S + (1 − T) · L`,
//! with the transmittance T per pixel (it has the depth map's and the horizon's edges), T' the
//! same toward 1 on the open sky (`common/sky.wgsl`), S the SH in-scatter and L the lamps' glow
//! per unit of opacity; S, L and the sky's weight lie on the glow's coarse grid (every
//! [`GLOW_CELL_PX`] pixels) interpolated bilinearly, as the GPU already does for the glow and the
//! sky: S and L are as smooth as the drop's transfer (the SH's four bands; the forward lobe).
//!
//! S is `Σ L_lm sqrt(4π/(2l+1)) z_l Y_lm(v)` (the PRT, thesis §5.1.2): the basis `Y_lm(v)` at
//! the grid's rays changes only when the camera moves, the light's weights every frame. So
//! [`GridRays`] keeps the basis in `f32` from frame to frame and a frame costs one weighted
//! sum of 16 functions per grid point, in lanes; [`grid_reference`] is the plain `f64` form.

// Lane loops index several arrays by the lane: the form the vectoriser reads best.
#![allow(clippy::needless_range_loop)]

use glam::DVec2;
use rayon::prelude::*;

use super::lanes::LANES;
use crate::gpu::cpu::yuv_to_rgb::{environment_and_drop, haze_glow_along, view_ray_at};
use crate::gpu::stages::yuv_to_rgb::{GLOW_CELL_PX, glow_grid_size};
use crate::gpu::types::{LightList, RainParams, SH_COEFFS};
use crate::lighting::RtfTable;
use crate::lighting::prt::{prt_colour_f64, zonal_factor};
use crate::lighting::sh::{band_of, basis16_cartesian_f32};

/// What the haze adds at a grid point: S (RGB), L (RGB) and the sky's weight.
pub type GridPoint = [f32; 7];

/// The haze of one frame over a coded picture.
pub struct Veil<'a> {
    /// S, L and the sky's weight at the grid points (coded position `GLOW_CELL_PX · (i, j)`),
    /// row-major.
    grid: Vec<GridPoint>,
    grid_width: usize,
    along: Along<'a>,
}

/// What a pixel's ray meets, which sets its transmittance.
enum Along<'a> {
    /// No depth map and no ground: the scene's depth for every ray.
    Scene(f32),
    /// Per ray: the depth map's scene where it knows it, else the ground, else the scene.
    Rays(Rays<'a>),
}

/// The per-ray transmittance's constants (`haze_transmittance` in common/plate.wgsl).
struct Rays<'a> {
    /// The view ray (unit camera depth) is `dx · (x + ½) + dy · (y + ½) + origin`.
    dx: [f32; 3],
    dy: [f32; 3],
    origin: [f32; 3],
    near_m: f32,
    far_m: f32,
    beta_per_m: f32,
    scene_t: f32,
    /// The camera's height over the ground, where the ground clips the haze.
    ground_h_m: Option<f32>,
    depth: Option<Depth<'a>>,
}

/// The depth map at the displayed pixels: display = m (coded − offset).
struct Depth<'a> {
    metres: &'a [f32],
    size: (usize, usize),
    m: [f32; 4],
    offset: [f32; 2],
}

impl<'a> Veil<'a> {
    /// The veil of the uniforms `p` over a coded picture of `size`, the lamps' glow with `lit`
    /// (lights and the drop's transfer tables), the depth map `depth` (per displayed pixel,
    /// 0 unknown) and the open sky's weight at the grid points `sky`, the in-scatter through
    /// the basis kept in `rays` (made anew where the camera moved); `None` where there is no
    /// haze (then the plate is the canvas, bit for bit).
    pub fn new(
        p: &RainParams,
        lit: Option<(&LightList, &[RtfTable; 3])>,
        depth: Option<&'a [f32]>,
        sky: Option<&[f32]>,
        size: (u32, u32),
        rays: &mut GridRays,
    ) -> Option<Veil<'a>> {
        if p.haze[3] >= 1.0 {
            return None;
        }
        let (gw, gh) = glow_grid_size(size);
        let n = (gw * gh) as usize;
        rays.update(p, size);
        let weights = prt_weights(p);
        let mut grid = vec![[0f32; 7]; n];
        for (b, block) in rays.basis.iter().enumerate() {
            let scatter = weighted_sum(&weights, block);
            for (l, point) in grid[b * LANES..].iter_mut().take(LANES).enumerate() {
                *point = [
                    scatter[0][l],
                    scatter[1][l],
                    scatter[2][l],
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                ];
            }
        }
        // The lamps' glow: a few sums a light per grid point, in f64 as the twin (only where a
        // lamp is lit).
        if let Some(glow) = glow_grid(p, lit, size) {
            for (point, g) in grid.iter_mut().zip(glow) {
                point[3..6].copy_from_slice(&g);
            }
        }
        if let Some(w) = sky.filter(|w| w.len() == n) {
            for (point, w) in grid.iter_mut().zip(w) {
                point[6] = *w;
            }
        }
        Some(Veil {
            grid,
            grid_width: gw as usize,
            along: along(p, depth),
        })
    }

    /// S, L and the sky's weight along row `y`, interpolated between grid rows: the row the
    /// pixels of `y` interpolate along x (`out` holds one entry per grid column).
    pub fn grid_row(&self, y: u32, out: &mut Vec<GridPoint>) {
        let u = (y as f32 + 0.5) / GLOW_CELL_PX as f32;
        let (j, f) = (u as usize, u.fract());
        let w = self.grid_width;
        let (top, bottom) = (&self.grid[j * w..][..w], &self.grid[(j + 1) * w..][..w]);
        out.clear();
        out.extend(
            top.iter()
                .zip(bottom)
                .map(|(a, b)| std::array::from_fn(|c| a[c] + (b[c] - a[c]) * f)),
        );
    }

    /// The transmittance of each pixel of row `y` into `out` (`out.len()` pixels), and into
    /// `finite` whether the pixel's distance is known finite (the depth map knows it, or a given
    /// ground lies below its ray): there the sky's mask does not apply.
    #[inline(always)]
    pub fn transmittance_row(&self, y: u32, out: &mut [f32], finite: &mut [bool]) {
        finite.fill(false);
        match &self.along {
            Along::Scene(t) => out.fill(*t),
            Along::Rays(r) => r.row(y, out, finite),
        }
    }
}

/// The grid of [`Veil::new`] in plain `f64` (the PRT through the recurrences of
/// [`crate::lighting::sh::eval_basis`] at each grid point's ray, the glow as there): the
/// reference its `f32` in-scatter is tested against.
pub fn grid_reference(
    p: &RainParams,
    lit: Option<(&LightList, &[RtfTable; 3])>,
    sky: Option<&[f32]>,
    size: (u32, u32),
) -> Vec<GridPoint> {
    let (gw, gh) = glow_grid_size(size);
    let (env, drop) = environment_and_drop(p);
    let glows = lit.filter(|(l, _)| l.count > 0);
    let cell = f64::from(GLOW_CELL_PX);
    let per_opacity = 1.0 / (1.0 - f64::from(p.haze[3]));
    let sky = sky.filter(|w| w.len() == (gw * gh) as usize);
    (0..gw * gh)
        .into_par_iter()
        .map(|k| {
            let at = DVec2::new(f64::from(k % gw) * cell, f64::from(k / gw) * cell);
            let v = view_ray_at(p, at).normalize();
            let scatter = prt_colour_f64(&env, &drop, v).map(|c| c.max(0.0));
            let glow = glows.map_or([0.0; 3], |(l, t)| haze_glow_along(p, l, t, v));
            let weight = sky.map_or(0.0, |w| w[k as usize]);
            std::array::from_fn(|c| match c {
                0..3 => scatter[c] as f32,
                3..6 => (glow[c - 3] * per_opacity) as f32,
                _ => weight,
            })
        })
        .collect()
}

/// The lamps' glow per unit of opacity at the grid points, as [`grid_reference`] computes it;
/// `None` where no lamp is lit.
fn glow_grid(
    p: &RainParams,
    lit: Option<(&LightList, &[RtfTable; 3])>,
    size: (u32, u32),
) -> Option<Vec<[f32; 3]>> {
    let (lights, tables) = lit.filter(|(l, _)| l.count > 0)?;
    let (gw, gh) = glow_grid_size(size);
    let cell = f64::from(GLOW_CELL_PX);
    let per_opacity = 1.0 / (1.0 - f64::from(p.haze[3]));
    Some(
        (0..gw * gh)
            .into_par_iter()
            .map(|k| {
                let at = DVec2::new(f64::from(k % gw) * cell, f64::from(k / gw) * cell);
                let v = view_ray_at(p, at).normalize();
                haze_glow_along(p, lights, tables, v).map(|g| (g * per_opacity) as f32)
            })
            .collect(),
    )
}

/// The SH basis at the grid's rays (`f32`), kept while what sets the rays stays.
#[derive(Default)]
pub struct GridRays {
    /// What the rays were made from ([`ray_key`]).
    key: Option<RayKey>,
    /// The 16 functions at the grid points, [`LANES`] points a block: `basis[b][i][l]` is
    /// function i at grid point `LANES · b + l` (row-major; the last block padded with the last point).
    basis: Vec<[[f32; LANES]; SH_COEFFS]>,
}

/// The bits of everything a grid point's ray depends on: the pinhole, the camera's rotation,
/// the coded picture's orientation and offset, and the grid's size.
type RayKey = [u32; 23];

fn ray_key(p: &RainParams, size: (u32, u32)) -> RayKey {
    let (gw, gh) = glow_grid_size(size);
    let mut key = [0u32; 23];
    let floats = std::iter::once(p.focal_px)
        .chain(p.camera_from_world_0)
        .chain(p.camera_from_world_1)
        .chain(p.camera_from_world_2)
        .chain(p.principal_px)
        .chain(p.coded_from_display)
        .chain(p.coded_offset_px);
    for (k, v) in key.iter_mut().zip(floats) {
        *k = v.to_bits();
    }
    key[21] = gw;
    key[22] = gh;
    key
}

impl GridRays {
    /// Makes the basis anew where the rays of `p` over a picture of `size` are not those kept.
    fn update(&mut self, p: &RainParams, size: (u32, u32)) {
        let key = ray_key(p, size);
        if self.key == Some(key) {
            return;
        }
        let (gw, gh) = glow_grid_size(size);
        let n = (gw * gh) as usize;
        // The ray is affine in the coded position: its value at the origin and its steps (f64,
        // then one rounding to f32).
        let ray = |x: f64, y: f64| view_ray_at(p, DVec2::new(x, y));
        let o = ray(0.0, 0.0);
        let cell = f64::from(GLOW_CELL_PX);
        let (dx, dy) = ((ray(cell, 0.0) - o), (ray(0.0, cell) - o));
        let (o, dx, dy) = (o.as_vec3(), dx.as_vec3(), dy.as_vec3());
        self.basis.clear();
        self.basis.extend((0..n.div_ceil(LANES)).map(|b| {
            let mut v = [[0f32; LANES]; 3];
            for l in 0..LANES {
                let k = (b * LANES + l).min(n - 1) as u32;
                let (i, j) = ((k % gw) as f32, (k / gw) as f32);
                let r = o + dx * i + dy * j;
                let inv = 1.0 / r.length();
                (v[0][l], v[1][l], v[2][l]) = (r.x * inv, r.y * inv, r.z * inv);
            }
            let mut block = [[0f32; LANES]; SH_COEFFS];
            for l in 0..LANES {
                let y = basis16_cartesian_f32(v[0][l], v[1][l], v[2][l]);
                for i in 0..SH_COEFFS {
                    block[i][l] = y[i];
                }
            }
            block
        }));
        self.key = Some(key);
    }
}

/// The in-scatter's weights `L_lm sqrt(4π/(2l+1)) z_l` per function and channel, from the
/// uniforms' environment and drop (each rounded once from `f64`).
fn prt_weights(p: &RainParams) -> [[f32; 3]; SH_COEFFS] {
    let (env, drop) = environment_and_drop(p);
    std::array::from_fn(|i| {
        let l = band_of(i);
        let f = zonal_factor(l);
        std::array::from_fn(|c| (env[i][c] * f * drop.zonal[l][c]) as f32)
    })
}

/// `max(Σ_i w_i Y_i, 0)` per channel over a block of grid points, the functions in order.
#[inline]
fn weighted_sum(w: &[[f32; 3]; SH_COEFFS], block: &[[f32; LANES]; SH_COEFFS]) -> [[f32; LANES]; 3] {
    let mut acc = [[0f32; LANES]; 3];
    for i in 0..SH_COEFFS {
        for c in 0..3 {
            for l in 0..LANES {
                acc[c][l] += w[i][c] * block[i][l];
            }
        }
    }
    for c in 0..3 {
        for l in 0..LANES {
            acc[c][l] = acc[c][l].max(0.0);
        }
    }
    acc
}

/// What the rays of `p` meet.
fn along<'a>(p: &RainParams, depth: Option<&'a [f32]>) -> Along<'a> {
    let h = p.camera_pos_m[2];
    let ground_h_m = (p.ground_clip != 0 && h > 0.0).then_some(h);
    let size = (p.display_size_px[0] as usize, p.display_size_px[1] as usize);
    let depth = depth
        .filter(|d| d.len() >= size.0 * size.1 && size.0 * size.1 > 0)
        .map(|metres| Depth {
            metres,
            size,
            m: p.coded_from_display,
            offset: p.coded_offset_px,
        });
    if ground_h_m.is_none() && depth.is_none() {
        return Along::Scene(p.haze[3]);
    }
    // The ray is affine in the coded position: its value at the origin and its steps.
    let ray = |x: f64, y: f64| view_ray_at(p, DVec2::new(x, y));
    let o = ray(0.0, 0.0);
    let (dx, dy) = (ray(1.0, 0.0) - o, ray(0.0, 1.0) - o);
    let f = |v: glam::DVec3| [v.x as f32, v.y as f32, v.z as f32];
    Along::Rays(Rays {
        dx: f(dx),
        dy: f(dy),
        origin: f(o),
        near_m: p.haze[0],
        far_m: p.haze[1],
        beta_per_m: p.haze[2],
        scene_t: p.haze[3],
        ground_h_m,
        depth,
    })
}

impl Rays<'_> {
    /// The transmittance along the rays of row `y`: first where each ray ends (the depth
    /// map, the ground, or the scene), then `exp(−β · max(d − near, 0))` over the row in lanes.
    #[inline(always)]
    fn row(&self, y: u32, out: &mut [f32], known: &mut [bool]) {
        let yc = y as f32 + 0.5;
        let base: [f32; 3] = std::array::from_fn(|k| self.origin[k] + self.dy[k] * yc);
        let h = self.ground_h_m.unwrap_or(0.0);
        for (x, (t, known)) in out.iter_mut().zip(known.iter_mut()).enumerate() {
            let xc = x as f32 + 0.5;
            let r: [f32; 3] = std::array::from_fn(|k| base[k] + self.dx[k] * xc);
            let len = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
            let mapped = self.depth.as_ref().map_or(0.0, |d| d.at(xc, yc));
            let below = self.ground_h_m.is_some() && r[2] < 0.0;
            *known = mapped > 0.0 || below;
            // The distance along the ray (unit camera depth: a camera z of z metres lies
            // z · |ray| along it); NaN where the scene's own transmittance holds.
            *t = if mapped > 0.0 {
                mapped * len
            } else if below && h * len < -r[2] * self.far_m {
                h * len / -r[2]
            } else {
                f32::NAN
            };
        }
        for t in out.iter_mut() {
            let along_m = *t;
            let v = exp_nonpositive(-self.beta_per_m * (along_m - self.near_m).max(0.0));
            *t = if along_m.is_nan() { self.scene_t } else { v };
        }
    }
}

/// e^x for x ≤ 0 (x > 0 reads as 0, NaN as −87) within 2 ulp, without a library call so that a
/// row of them vectorises: x = n ln 2 + r with |r| ≤ ln 2 / 2, e^r by its Taylor polynomial to
/// r⁷ (the next term is below 2⁻²⁶), times 2ⁿ. Below −87 (e^x < 2⁻¹²⁵) it gives 2⁻¹²⁶·e^r's
/// floor, about 1e-38: no transmittance a canvas can show.
#[inline(always)]
fn exp_nonpositive(x: f32) -> f32 {
    const LN2_HI: f32 = 0.693_145_75;
    const LN2_LO: f32 = 1.428_606_8e-6;
    // 1.5 · 2²³: adding it rounds to an integer (ties to even) in its low bits.
    const ROUND: f32 = 12_582_912.0;
    // Not `clamp`, which keeps NaN: NaN goes to −87 here.
    #[allow(clippy::manual_clamp)]
    let x = x.max(-87.0).min(0.0);
    let n = (x * std::f32::consts::LOG2_E + ROUND) - ROUND;
    let r = (x - n * LN2_HI) - n * LN2_LO;
    let p = 1.0
        + r * (1.0
            + r * (0.5
                + r * (1.0 / 6.0
                    + r * (1.0 / 24.0 + r * (1.0 / 120.0 + r * (1.0 / 720.0 + r / 5040.0))))));
    // SAFETY: n is an integer in [−126, 0] (x is in [−87, 0]), so it converts exactly.
    let n = unsafe { n.to_int_unchecked::<i32>() };
    // 2ⁿ from its exponent bits.
    p * f32::from_bits(((n + 127) as u32) << 23)
}

impl Depth<'_> {
    /// The depth at coded position (`x`, `y`), 0 where unknown.
    #[inline(always)]
    fn at(&self, x: f32, y: f32) -> f32 {
        let (cx, cy) = (x - self.offset[0], y - self.offset[1]);
        let m = self.m;
        let (sx, sy) = (m[0] * cx + m[1] * cy, m[2] * cx + m[3] * cy);
        let px = (sx.max(0.0) as usize).min(self.size.0 - 1);
        let py = (sy.max(0.0) as usize).min(self.size.1 - 1);
        self.metres[py * self.size.0 + px]
    }
}

#[cfg(test)]
mod tests {
    use glam::DMat3;

    use super::{GridRays, Veil, grid_reference};
    use crate::gpu::types::RainParams;
    use crate::gpu::uniforms::coded_from_display;
    use crate::rng::SplitMix64;

    /// Uniforms of a `size` picture shown turned by `rotation_deg`, the camera turned by
    /// `yaw`, `pitch` (radians), an environment and a drop of scattered coefficients.
    fn params(size: (u32, u32), rotation_deg: i32, yaw: f64, pitch: f64, seed: u64) -> RainParams {
        let mut rng = SplitMix64(seed);
        let mut p: RainParams = bytemuck::Zeroable::zeroed();
        let world_from_camera = DMat3::from_rotation_z(yaw) * DMat3::from_rotation_x(pitch);
        let r = world_from_camera.transpose();
        let row = |k: usize| {
            let v = r.row(k);
            [v.x as f32, v.y as f32, v.z as f32, 0.0]
        };
        p.camera_from_world_0 = row(0);
        p.camera_from_world_1 = row(1);
        p.camera_from_world_2 = row(2);
        let (w, h) = (size.0 as f32, size.1 as f32);
        let shown = if rotation_deg % 180 == 0 {
            (w, h)
        } else {
            (h, w)
        };
        p.focal_px = 0.9 * shown.0;
        p.principal_px = [shown.0 / 2.0, shown.1 / 2.0];
        (p.coded_from_display, p.coded_offset_px) = coded_from_display(rotation_deg, w, h);
        p.haze = [2.0, 60.0, 0.05, 0.4];
        for c in p.env_sh.iter_mut() {
            *c = std::array::from_fn(|_| (2.0 * rng.next_f64() - 1.0) as f32);
        }
        p.env_sh[0] = [1.5, 1.7, 2.1, 0.0];
        for (c, z) in p.drop_zonal.iter_mut().enumerate() {
            *z = [0.5, 0.3 + 0.02 * c as f32, 0.2, 0.1];
        }
        p
    }

    /// The in-scatter of the f32 grid (the basis kept in lanes, the weights per frame)
    /// against the plain f64 grid: within 10⁻⁵ of the in-scatter's scale (the veil's budget
    /// against the per-pixel twin is 7 × 10⁻⁴), over turned pictures, tilted cameras and an
    /// odd size; the glow and the sky's weight exactly. A camera that moves makes the basis
    /// anew, one that does not keeps it.
    #[test]
    fn the_f32_grid_is_the_f64_grid() {
        let mut rays = GridRays::default();
        let mut worst = 0f64;
        for (k, &(size, rotation, yaw, pitch)) in [
            ((1920, 1080), 0, 0.3, -0.2),
            ((1920, 1080), 0, 0.3, 0.9),
            ((1080, 1920), 90, -1.2, -1.1),
            ((317, 203), 270, 2.0, 0.4),
            ((317, 203), 180, 2.0, -1.5),
        ]
        .iter()
        .enumerate()
        {
            for seed in 0..2 {
                let p = params(size, rotation, yaw, pitch, 7 * k as u64 + seed);
                let (gw, gh) = crate::gpu::stages::yuv_to_rgb::glow_grid_size(size);
                let sky: Vec<f32> = (0..gw * gh).map(|i| (i % 7) as f32 / 6.0).collect();
                let plain = grid_reference(&p, None, Some(&sky), size);
                let veil = Veil::new(&p, None, None, Some(&sky), size, &mut rays).expect("haze");
                assert_eq!(veil.grid.len(), plain.len());
                let scale = plain
                    .iter()
                    .flat_map(|g| g[..3].iter())
                    .fold(0f32, |m, v| m.max(v.abs()));
                assert!(scale > 0.5, "{scale}");
                for (a, b) in veil.grid.iter().zip(&plain) {
                    for c in 0..3 {
                        let off = f64::from((a[c] - b[c]).abs() / scale);
                        worst = worst.max(off);
                        assert!(off <= 1e-5, "{size:?} {rotation}°: {a:?} against {b:?}");
                    }
                    assert_eq!(a[3..], b[3..], "{size:?} {rotation}°");
                }
                // The same camera again, another light: the basis kept gives the same grid as
                // one made anew.
                let mut q = p;
                q.env_sh[3][1] += 0.25;
                let kept = Veil::new(&q, None, None, None, size, &mut rays).expect("haze");
                let fresh = Veil::new(&q, None, None, None, size, &mut GridRays::default());
                assert_eq!(kept.grid, fresh.expect("haze").grid);
            }
        }
        eprintln!("worst {worst:.2e} of the in-scatter's scale");
    }

    /// The row's exponential against the library's, over the transmittances a haze can have.
    #[test]
    fn exp_nonpositive_is_within_two_ulp() {
        let mut worst = 0f64;
        for k in 0..=200_000 {
            let x = -87.0 * k as f32 / 200_000.0;
            let (ours, libm) = (super::exp_nonpositive(x), x.exp());
            let ulp = f64::from(libm) * f64::from(f32::EPSILON);
            worst = worst.max((f64::from(ours) - f64::from(libm)).abs() / ulp);
        }
        assert!(worst <= 2.0, "{worst} ulp");
        assert_eq!(super::exp_nonpositive(0.0), 1.0);
        assert!(super::exp_nonpositive(-200.0) < 1e-37);
    }
}
