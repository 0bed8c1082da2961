//! The wet ground on the CPU back end (the `wet_ground` stage's work), fused into the plate's
//! decode: a row whose rays reach the ground takes the frame's linear colour L before the haze,
//! the haze's transmittance T and in-scatter S from the decode, and writes L·M + A where the ray
//! meets the ground (M = T·(1 + w·(k − 1)), A = (1 − T)·(S + G) + w·T·R·L_env(mirrored ray), G
//! the lamps' glow per unit of opacity the decode laid too;
//! docs/method.md §2.3, Lekner & Dorf's darkening k). Rows above the horizon, and pixels the ray
//! of which does not go down, keep the decode's bits. In f32 as the shader; the plain twin
//! [`crate::gpu::cpu::wet_ground`] is the reference (`tests/backend.rs`). [`Ground`] holds what
//! the ground's passes share (the rays, the depth map, the ground mask, the environment).

use glam::{DVec2, Vec2, Vec3};

use super::veil::GridPoint;
use crate::gpu::cpu::yuv_to_rgb::view_ray_at;
use crate::gpu::stages::yuv_to_rgb::{GLOW_CELL_PX, glow_grid_size};
use crate::gpu::types::{RainParams, WetParams};
use crate::lighting::sh::basis16_cartesian_f32;

/// π in f32, as the shaders' `PI`.
pub(super) const PI: f32 = std::f32::consts::PI;

/// What every pass over the ground shares for one frame: the view rays (affine in the coded
/// position), the camera, the scene's depth per displayed pixel, the ground mask on the glow's
/// grid and the environment's SH.
pub struct Ground<'a> {
    /// The view ray (unit camera depth) through coded position (x, y) is
    /// `origin + x · dx + y · dy`.
    origin: Vec3,
    pub(super) dx: Vec3,
    pub(super) dy: Vec3,
    /// The camera's position (world, m) and rows of `camera_from_world`.
    pub(super) camera: Vec3,
    pub(super) rows: [Vec3; 3],
    pub(super) coded_size: (usize, usize),
    depth: Option<&'a [f32]>,
    display_size: (usize, usize),
    /// display = m (coded − offset); coded = mᵀ display + offset.
    m: [f32; 4],
    offset: Vec2,
    pub(super) principal: Vec2,
    pub(super) focal: f32,
    /// The ground's weight at the glow's grid points, with the grid's width and height.
    mask: Option<(&'a [f32], usize, usize)>,
    /// The environment's 16 SH coefficients (RGB).
    pub(super) env: [Vec3; 16],
}

impl<'a> Ground<'a> {
    /// The ground of the uniforms `p` over a coded picture of `size`, with the scene's depth per
    /// displayed pixel (0 unknown) and the ground mask on the glow's grid, where given.
    pub fn new(
        p: &RainParams,
        size: (u32, u32),
        depth: Option<&'a [f32]>,
        mask: Option<&'a [f32]>,
    ) -> Ground<'a> {
        let ray = |x: f64, y: f64| view_ray_at(p, DVec2::new(x, y));
        let o = ray(0.0, 0.0);
        let (dx, dy) = (ray(1.0, 0.0) - o, ray(0.0, 1.0) - o);
        let v = |d: glam::DVec3| d.as_vec3();
        let display_size = (p.display_size_px[0] as usize, p.display_size_px[1] as usize);
        let (gw, gh) = glow_grid_size(size);
        let row = |r: [f32; 4]| Vec3::new(r[0], r[1], r[2]);
        Ground {
            origin: v(o),
            dx: v(dx),
            dy: v(dy),
            camera: Vec3::from_array(p.camera_pos_m),
            rows: [
                row(p.camera_from_world_0),
                row(p.camera_from_world_1),
                row(p.camera_from_world_2),
            ],
            coded_size: (size.0 as usize, size.1 as usize),
            depth: depth.filter(|d| {
                d.len() >= display_size.0 * display_size.1 && display_size.0 * display_size.1 > 0
            }),
            display_size,
            m: p.coded_from_display,
            offset: Vec2::from_array(p.coded_offset_px),
            principal: Vec2::from_array(p.principal_px),
            focal: p.focal_px,
            mask: mask
                .filter(|m| m.len() >= (gw * gh) as usize)
                .map(|m| (m, gw as usize, gh as usize)),
            env: std::array::from_fn(|i| Vec3::new(p.env_sh[i][0], p.env_sh[i][1], p.env_sh[i][2])),
        }
    }

    /// Coded position of display position `s` (coded = mᵀ display + offset).
    #[inline]
    pub(super) fn coded(&self, s: Vec2) -> Vec2 {
        let m = self.m;
        Vec2::new(m[0] * s.x + m[2] * s.y, m[1] * s.x + m[3] * s.y) + self.offset
    }

    /// The camera's height over the ground, m.
    pub(super) fn height_m(&self) -> f32 {
        self.camera.z
    }

    /// The view ray (unit camera depth) through the centre of coded pixel (`x`, `y`).
    #[inline]
    pub(super) fn ray(&self, x: usize, y: usize) -> Vec3 {
        self.ray_through(Vec2::new(x as f32 + 0.5, y as f32 + 0.5))
    }

    /// The view ray (unit camera depth) through coded position `at`.
    #[inline]
    pub(super) fn ray_through(&self, at: Vec2) -> Vec3 {
        self.origin + self.dx * at.x + self.dy * at.y
    }

    /// The pixels of row `y` whose ray goes down (`ray.z < 0`), as a range (the ray's z is
    /// affine along the row); empty where the camera is not above the ground.
    pub(super) fn downward(&self, y: usize) -> std::ops::Range<usize> {
        let w = self.coded_size.0;
        if self.height_m() <= 0.0 || w == 0 {
            return 0..0;
        }
        let (first, last) = (self.ray(0, y).z, self.ray(w - 1, y).z);
        match (first < 0.0, last < 0.0) {
            (true, true) => 0..w,
            (false, false) => 0..0,
            // The one crossing, found from the pixels' own values.
            (true, false) => 0..(0..w).find(|&x| self.ray(x, y).z >= 0.0).unwrap_or(w),
            (false, true) => (0..w).find(|&x| self.ray(x, y).z < 0.0).unwrap_or(w)..w,
        }
    }

    /// The scene's depth (camera z, m) at coded position `at`, looked up at its displayed
    /// pixel; 0 where unknown or without a map (`scene_depth_m` of common/depth.wgsl).
    #[inline]
    pub(super) fn scene_depth_m(&self, at: Vec2) -> f32 {
        let Some(map) = self.depth else { return 0.0 };
        let c = at - self.offset;
        let m = self.m;
        let (sx, sy) = (m[0] * c.x + m[1] * c.y, m[2] * c.x + m[3] * c.y);
        let px = (sx.max(0.0) as usize).min(self.display_size.0 - 1);
        let py = (sy.max(0.0) as usize).min(self.display_size.1 - 1);
        map[py * self.display_size.0 + px]
    }

    /// Whether a depth map is set.
    pub(super) fn has_depth(&self) -> bool {
        self.depth.is_some()
    }

    /// The ground's weight at coded pixel (`x`, `y`) given the scene's depth there: the mask
    /// bilinear between its grid points; 1 without a mask or where the depth is known
    /// (`ground_weight` of common/ground_mask.wgsl).
    #[inline]
    pub(super) fn weight(&self, x: usize, y: usize, scene_m: f32) -> f32 {
        let Some((mask, w, h)) = self.mask else {
            return 1.0;
        };
        if scene_m > 0.0 {
            return 1.0;
        }
        let u = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) / GLOW_CELL_PX as f32;
        let (gx, gy) = ((u.x as usize).min(w - 2), (u.y as usize).min(h - 2));
        let f = u - u.floor();
        let i = gy * w + gx;
        let top = mask[i] + (mask[i + 1] - mask[i]) * f.x;
        let bottom = mask[i + w] + (mask[i + w + 1] - mask[i + w]) * f.x;
        top + (bottom - top) * f.y
    }

    /// The environment's radiance from unit direction `dir`, clamped at 0.
    #[inline(always)]
    pub(super) fn sky(&self, dir: Vec3) -> Vec3 {
        let b = basis16_cartesian_f32(dir.x, dir.y, dir.z);
        let mut c = Vec3::ZERO;
        for (e, y) in self.env.iter().zip(b) {
            c += *e * y;
        }
        c.max(Vec3::ZERO)
    }

    /// The irradiance the environment sends onto the level ground (`irradiance_up` of
    /// common/water.wgsl: Â₀ = π, Â₁ = 2π/3, Â₂ = π/4 on the m = 0 functions).
    pub(super) fn irradiance_up(&self) -> Vec3 {
        self.env[0] * (PI * 0.282_094_8)
            + self.env[2] * ((2.0 * PI / 3.0) * 0.488_602_5)
            + self.env[6] * ((PI / 4.0) * 0.630_783_1)
    }
}

/// Unpolarised Fresnel reflectance of water of index `n` seen from the air at incidence cosine
/// `cos_i` (`water_reflectance` of common/water.wgsl).
#[inline]
pub(super) fn reflectance(n: f32, cos_i: f32) -> f32 {
    let ci = cos_i.clamp(0.0, 1.0);
    let ct = (1.0 - (1.0 - ci * ci) / (n * n)).max(0.0).sqrt();
    let rs = (ci - n * ct) / (ci + n * ct);
    let rp = (n * ci - ct) / (n * ci + ct);
    0.5 * (rs * rs + rp * rp)
}

/// `smoothstep` as WGSL defines it.
#[inline]
pub(super) fn smoothstep(lo: f32, hi: f32, x: f32) -> f32 {
    let t = ((x - lo) / (hi - lo)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// How much a pixel shows the ground at camera depth `ground_m` given the scene's depth there
/// (0 unknown: ground) (`ground_shown` of common/water.wgsl).
#[inline]
pub(super) fn ground_shown(scene_m: f32, ground_m: f32) -> f32 {
    if scene_m <= 0.0 {
        return 1.0;
    }
    smoothstep(0.8 * ground_m, 0.9 * ground_m, scene_m)
}

/// Lekner & Dorf's darkening of the ground of linear colour `scene` under a film, per channel,
/// seen at incidence cosine `cos_view` (the albedo π L / E from the ground's irradiance `e`).
#[inline]
pub(super) fn darkening(scene: Vec3, e: Vec3, optics: [f32; 3], cos_view: f32) -> Vec3 {
    let [n, outside, inside] = optics;
    let albedo = Vec3::select(
        e.cmpgt(Vec3::ZERO),
        (PI * scene / e).clamp(Vec3::ZERO, Vec3::ONE),
        Vec3::ZERO,
    );
    let f = (1.0 - reflectance(n, cos_view)) * (1.0 - outside) / (n * n);
    f / (Vec3::ONE - albedo * inside)
}

/// The wet ground of one frame.
pub struct WetGround<'a> {
    ground: &'a Ground<'a>,
    wetness: f32,
    reach_m: f32,
    /// Index, diffuse reflectance outside and inside the film.
    optics: [f32; 3],
    e_up: Vec3,
}

impl<'a> WetGround<'a> {
    /// The wet ground under `wet` over `ground`; `None` where no ray reaches the ground (the
    /// camera not above it).
    pub fn new(ground: &'a Ground<'a>, wet: &WetParams) -> Option<WetGround<'a>> {
        (ground.height_m() > 0.0).then(|| WetGround {
            ground,
            wetness: wet.wetness,
            reach_m: wet.reach_m,
            optics: [wet.water_index, wet.diffuse_external, wet.diffuse_internal],
            e_up: ground.irradiance_up(),
        })
    }

    /// Whether row `y` has a pixel whose ray meets the ground.
    pub fn touches(&self, y: usize) -> bool {
        !self.ground.downward(y).is_empty()
    }

    /// Wets row `y`: `plate` the frame's linear RGBA before the haze, `haze` the row's
    /// transmittance and the in-scatter and glow on the glow's grid columns (`None`: no haze),
    /// `out` the veiled row (RGBA), rewritten where the ray meets the ground.
    pub fn row(
        &self,
        y: usize,
        plate: &[f32],
        haze: Option<(&[f32], &[GridPoint])>,
        out: &mut [f32],
    ) {
        let g = self.ground;
        let h = g.height_m();
        let cell = GLOW_CELL_PX as usize;
        for x in g.downward(y) {
            let ray = g.ray(x, y);
            let (t, s, glow) = match haze {
                None => (1.0, Vec3::ZERO, Vec3::ZERO),
                Some((t, grid)) => {
                    let (a, b) = (grid[x / cell], grid[x / cell + 1]);
                    let f = ((x % cell) as f32 + 0.5) / cell as f32;
                    let at = |c: usize| a[c] + (b[c] - a[c]) * f;
                    let rgb = |c: usize| Vec3::new(at(c), at(c + 1), at(c + 2));
                    (t[x], rgb(0), rgb(3))
                }
            };
            let len = ray.length();
            let cos_view = -ray.z / len;
            let ground_z_m = h / -ray.z;
            let centre = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let scene_m = g.scene_depth_m(centre);
            let w = self.wetness
                * reach_fade(h / cos_view, self.reach_m)
                * ground_shown(scene_m, ground_z_m)
                * g.weight(x, y, scene_m);
            let l = Vec3::from_slice(&plate[4 * x..]);
            let px = &mut out[4 * x..][..3];
            if w == 0.0 {
                // L·T + (1 − T)·S + (1 − T)·G, as the haze lays it.
                for k in 0..3 {
                    px[k] = l[k] * t + (1.0 - t) * s[k] + (1.0 - t) * glow[k];
                }
                continue;
            }
            let d = ray / len;
            let k = darkening(l, self.e_up, self.optics, cos_view);
            let r = reflectance(self.optics[0], cos_view);
            let sky = g.sky(Vec3::new(d.x, d.y, -d.z));
            let m = Vec3::splat(t) + w * t * (k - Vec3::ONE);
            let a = (1.0 - t) * s + (1.0 - t) * glow + w * t * r * sky;
            for c in 0..3 {
                px[c] = l[c] * m[c] + a[c];
            }
        }
    }
}

/// 1 on ground nearer than half the reach, 0 beyond it (`reach_fade` of wet_ground.wgsl).
#[inline]
fn reach_fade(distance_m: f32, reach_m: f32) -> f32 {
    if reach_m <= 0.0 {
        return 1.0;
    }
    1.0 - smoothstep(0.5 * reach_m, reach_m, distance_m)
}
