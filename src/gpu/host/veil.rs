//! The haze as the CPU back end lays it over the plate: `plate · T' + (1 − T') · S + (1 − T) · L`,
//! with the transmittance T per pixel (it has the depth map's and the horizon's edges), T' the
//! same toward 1 on the open sky (`common/sky.wgsl`), S the SH in-scatter and L the lamps' glow
//! per unit of opacity; S, L and the sky's weight lie on the glow's coarse grid (every
//! [`GLOW_CELL_PX`] pixels) interpolated bilinearly, as the GPU already does for the glow and the
//! sky: S and L are as smooth as the drop's transfer (the SH's four bands; the forward lobe).

use glam::DVec2;
use rayon::prelude::*;

use crate::gpu::cpu::yuv_to_rgb::{environment_and_drop, haze_glow_along, view_ray_at};
use crate::gpu::stages::yuv_to_rgb::{GLOW_CELL_PX, glow_grid_size};
use crate::gpu::types::{LightList, RainParams};
use crate::lighting::RtfTable;
use crate::lighting::prt::prt_colour_f64;

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
    /// 0 unknown) and the open sky's weight at the grid points `sky`; `None` where there is no
    /// haze (then the plate is the canvas, bit for bit).
    pub fn new(
        p: &RainParams,
        lit: Option<(&LightList, &[RtfTable; 3])>,
        depth: Option<&'a [f32]>,
        sky: Option<&[f32]>,
        size: (u32, u32),
    ) -> Option<Veil<'a>> {
        let scene_t = p.haze[3];
        if scene_t >= 1.0 {
            return None;
        }
        let (gw, gh) = glow_grid_size(size);
        let (env, drop) = environment_and_drop(p);
        let glows = lit.filter(|(l, _)| l.count > 0);
        let cell = f64::from(GLOW_CELL_PX);
        let per_opacity = 1.0 / (1.0 - f64::from(scene_t));
        let sky = sky.filter(|w| w.len() == (gw * gh) as usize);
        let grid = (0..gw * gh)
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
            .collect();
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
