//! The CPU twin of the `yuv_to_rgb` stage: decoded code values → linear RGB, chroma taken
//! from the co-sited sample, through [`crate::video::ColorParams::code_to_linear`]; then the
//! haze: `background · T + (1 − T) · in-scatter`, the in-scatter the PRT colour of the
//! environment (`RainParams::env_sh`, what the drawn drops show too) for the pixel's view ray
//! ([`crate::lighting::prt::prt_colour_f64`]), plus the compact lights' glow ([`haze_glow`]).
//! On the open sky ([`sky_weight`]) the background and the in-scatter see T toward 1, the
//! glow keeping the ray's T (twin of common/sky.wgsl).

use glam::{DVec2, DVec3};

use super::rain_simulate::light_term;
use crate::gpu::stages::yuv_to_rgb::{GLOW_CELL_PX, glow_grid_size};
use crate::gpu::types::{LightList, RainParams};
use crate::lighting::RtfTable;
use crate::lighting::prt::{RtfSh, prt_colour_f64};
use crate::scene::DepthMap;
use crate::video::YuvFrame;

/// Samples along the ray per light at a finite distance (`HAZE_GLOW_SAMPLES` in
/// common/glow.wgsl).
pub const HAZE_GLOW_SAMPLES: usize = 16;

/// The world direction of the view ray through the centre of coded pixel (`x`, `y`) under the
/// uniforms `p` (back to display pixels, then the pinhole).
pub fn view_ray(p: &RainParams, x: u32, y: u32) -> DVec3 {
    view_ray_at(p, DVec2::new(x as f64 + 0.5, y as f64 + 0.5))
}

/// The world direction of the view ray through continuous coded position `at_px` (pixel
/// (x, y) spans x to x + 1).
pub fn view_ray_at(p: &RainParams, at_px: DVec2) -> DVec3 {
    let m = p.coded_from_display.map(f64::from);
    let c = at_px - DVec2::new(p.coded_offset_px[0] as f64, p.coded_offset_px[1] as f64);
    // The rotation is orthogonal: display = mᵀ (coded − offset).
    let q = DVec2::new(m[0] * c.x + m[1] * c.y, m[2] * c.x + m[3] * c.y);
    let d =
        (q - DVec2::new(p.principal_px[0] as f64, p.principal_px[1] as f64)) / p.focal_px as f64;
    let row = |r: [f32; 4]| DVec3::new(r[0] as f64, r[1] as f64, r[2] as f64);
    row(p.camera_from_world_0) * d.x + row(p.camera_from_world_1) * d.y + row(p.camera_from_world_2)
}

/// The haze's transmittance along the ray of coded pixel (`x`, `y`) (twin of
/// `haze_transmittance` in common/plate.wgsl): Koschmieder's `e^(−β s)` over the rain from the
/// farthest drawn drop to what the ray meets: the scene of the depth map `depth` where it knows
/// it, else the ground plane where a ground is given and the ray meets it before the scene's
/// depth, else `p.haze[3]`, the transmittance to the scene's depth.
pub fn haze_transmittance(p: &RainParams, depth: Option<&DepthMap>, x: u32, y: u32) -> f64 {
    let t = p.haze[3] as f64;
    if t >= 1.0 {
        return 1.0;
    }
    let (near_m, beta_per_m) = (p.haze[0] as f64, p.haze[2] as f64);
    let ray = view_ray(p, x, y);
    let mapped =
        depth.and_then(|map| scene_depth_at(p, map, DVec2::new(x as f64 + 0.5, y as f64 + 0.5)));
    if let Some(z_m) = mapped {
        // `ray` has unit camera depth: a camera z of z metres lies z · |ray| along it.
        return (-beta_per_m * (z_m * ray.length() - near_m).max(0.0)).exp();
    }
    let d = ray.normalize();
    let h = p.camera_pos_m[2] as f64;
    if p.ground_clip == 0 || d.z >= 0.0 || h <= 0.0 {
        return t;
    }
    let ground_m = h / -d.z;
    if ground_m >= p.haze[1] as f64 {
        return t;
    }
    (-beta_per_m * (ground_m - near_m).max(0.0)).exp()
}

/// The scene's depth (camera z, metres) of `map` at coded position `coded_px`, looked up at its
/// displayed pixel; `None` where the map does not know it (twin of `scene_depth_m` in
/// common/depth.wgsl).
pub fn scene_depth_at(p: &RainParams, map: &DepthMap, coded_px: DVec2) -> Option<f64> {
    let m = p.coded_from_display.map(f64::from);
    let c = coded_px - DVec2::new(p.coded_offset_px[0] as f64, p.coded_offset_px[1] as f64);
    let shown = DVec2::new(m[0] * c.x + m[1] * c.y, m[2] * c.x + m[3] * c.y);
    let x = (shown.x.max(0.0) as usize).min(map.width - 1);
    let y = (shown.y.max(0.0) as usize).min(map.height - 1);
    map.at(x, y).map(f64::from).filter(|d| *d > 0.0)
}

/// The open sky's weight at coded pixel (`x`, `y`) (twin of `sky_weight` in common/sky.wgsl):
/// the mask `sky` (weights at the glow's grid points of a coded picture of `size`) bilinear at
/// the pixel's centre; 0 where the pixel's distance is known finite (the depth map `depth`
/// knows it, or a given ground lies below its ray) or the mask is not the grid's size.
pub fn sky_weight(
    p: &RainParams,
    depth: Option<&DepthMap>,
    sky: &[f32],
    size: (u32, u32),
    x: u32,
    y: u32,
) -> f64 {
    let (gw, gh) = glow_grid_size(size);
    let centre = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
    if sky.len() < (gw * gh) as usize
        || depth.is_some_and(|map| scene_depth_at(p, map, centre).is_some())
        || (p.ground_clip != 0 && p.camera_pos_m[2] > 0.0 && view_ray(p, x, y).z < 0.0)
    {
        return 0.0;
    }
    let u = centre / GLOW_CELL_PX as f64;
    let (g, f) = (u.floor(), u - u.floor());
    let i = g.y as usize * gw as usize + g.x as usize;
    let at = |k: usize| f64::from(sky[k]);
    let top = at(i) + (at(i + 1) - at(i)) * f.x;
    let bottom = at(i + gw as usize) + (at(i + gw as usize + 1) - at(i + gw as usize)) * f.x;
    top + (bottom - top) * f.y
}

/// The frame's environment (SH coefficients, `f64`) and the drop's zonal transfer, from the
/// uniforms `p`: what the haze, the wet ground and the water are lit with.
pub fn environment_and_drop(p: &RainParams) -> (Vec<[f64; 3]>, RtfSh) {
    let env = p
        .env_sh
        .iter()
        .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
        .collect();
    let drop = RtfSh {
        bands: 4,
        zonal: (0..4)
            .map(|l| std::array::from_fn(|c| p.drop_zonal[c][l] as f64))
            .collect(),
    };
    (env, drop)
}

/// The frame's own linear colour (coded orientation, row-major), without the haze: the scene
/// the wet ground and the water lie on.
pub fn plate(frame: &YuvFrame, p: &RainParams) -> Vec<[f64; 3]> {
    let mut clear = *p;
    clear.haze[3] = 1.0;
    yuv_to_rgb(frame, &clear)
}

/// The compact lights scattered once by the haze of `p` into unit view ray `v`, weighted by the
/// haze's opacity: the halo around a lamp. Twin of `haze_glow_along` in common/glow.wgsl, which
/// says how: the haze spans `p.haze[0]` to `p.haze[1]` metres with transmittance `p.haze[3]`; a
/// light at infinity adds (1 − T) L Ω F(θ), one at a finite distance the integral of
/// β e^(−β (s − s_near)) L Ω(s) F(θ(s)) ds, sampled equiangularly about it (β the imaging
/// extinction: what the beam loses is what the geometric optics scatter,
/// [`crate::rain::physics::imaging_extinction_per_m`]).
pub fn haze_glow_along(
    p: &RainParams,
    lights: &LightList,
    tables: &[RtfTable; 3],
    v: DVec3,
) -> [f64; 3] {
    let t = p.haze[3] as f64;
    let count = (lights.count as usize).min(lights.lights.len());
    if t >= 1.0 || count == 0 {
        return [0.0; 3];
    }
    let opacity = 1.0 - t;
    let near_m = p.haze[0] as f64;
    let far_m = (p.haze[1] as f64).max(near_m + 1e-6);
    let beta_per_m = -t.ln() / (far_m - near_m);
    let mut c = [0.0; 3];
    let mut add = |w: f64, term: [f64; 3]| (0..3).for_each(|k| c[k] += w * term[k]);
    for l in &lights.lights[..count] {
        let [lx, ly, lz, d] = l.direction_distance.map(f64::from);
        if d <= 0.0 {
            add(opacity, light_term(l, tables, v, v * near_m).0);
            continue;
        }
        let light_m = DVec3::new(lx, ly, lz) * d;
        let s0_m = light_m.dot(v);
        let h_m = (light_m - s0_m * v)
            .length()
            .max((l.strength[3] as f64).max(1e-4));
        let phi_a = ((near_m - s0_m) / h_m).atan();
        let dphi = (((far_m - s0_m) / h_m).atan() - phi_a) / HAZE_GLOW_SAMPLES as f64;
        for k in 0..HAZE_GLOW_SAMPLES {
            let phi = phi_a + (k as f64 + 0.5) * dphi;
            let s_m = s0_m + h_m * phi.tan();
            let ds_m = h_m / phi.cos().powi(2) * dphi;
            let weight = beta_per_m * (-beta_per_m * (s_m - near_m)).exp() * ds_m;
            add(weight, light_term(l, tables, v, v * s_m).0);
        }
    }
    c
}

/// The glow of a coded picture of `size` pixels, row-major: integrated along the rays of the
/// grid points every [`GLOW_CELL_PX`] pixels (corner positions), then bilinear at each pixel's
/// centre (twin of the `glow` entry point and `haze_glow` in common/glow.wgsl).
pub fn haze_glow(
    p: &RainParams,
    lights: &LightList,
    tables: &[RtfTable; 3],
    size: (u32, u32),
) -> Vec<[f64; 3]> {
    let (gw, gh) = glow_grid_size(size);
    let cell = GLOW_CELL_PX as f64;
    let grid: Vec<[f64; 3]> = (0..gh)
        .flat_map(|j| (0..gw).map(move |i| (i, j)))
        .map(|(i, j)| {
            let at = DVec2::new(i as f64 * cell, j as f64 * cell);
            haze_glow_along(p, lights, tables, view_ray_at(p, at).normalize())
        })
        .collect();
    let gw = gw as usize;
    (0..size.1)
        .flat_map(|y| (0..size.0).map(move |x| (x, y)))
        .map(|(x, y)| {
            let u = DVec2::new(x as f64 + 0.5, y as f64 + 0.5) / cell;
            let (g, f) = (u.floor(), u - u.floor());
            let i = g.y as usize * gw + g.x as usize;
            std::array::from_fn(|k| {
                let top = grid[i][k] + (grid[i + 1][k] - grid[i][k]) * f.x;
                let bottom = grid[i + gw][k] + (grid[i + gw + 1][k] - grid[i + gw][k]) * f.x;
                top + (bottom - top) * f.y
            })
        })
        .collect()
}

/// The linear canvas of `frame` (coded orientation, row-major RGB) veiled by the haze of `p`.
pub fn yuv_to_rgb(frame: &YuvFrame, p: &RainParams) -> Vec<[f64; 3]> {
    canvas(frame, p, None, None, None)
}

/// [`yuv_to_rgb`] with the scene's depth map: the haze of each pixel the map knows ends at its
/// scene.
pub fn yuv_to_rgb_with_depth(
    frame: &YuvFrame,
    p: &RainParams,
    depth: Option<&DepthMap>,
) -> Vec<[f64; 3]> {
    canvas(frame, p, None, depth, None)
}

/// [`yuv_to_rgb`] with the compact lights' glow in the haze (`lights` and the transfer tables
/// as the GPU stage binds them).
pub fn yuv_to_rgb_lit(
    frame: &YuvFrame,
    p: &RainParams,
    lights: &LightList,
    tables: &[RtfTable; 3],
) -> Vec<[f64; 3]> {
    canvas(frame, p, Some((lights, tables)), None, None)
}

/// [`yuv_to_rgb`] with all the haze knows: the lamps (`lit`: lights and transfer tables), the
/// scene's depth map and the open sky's weights at the glow's grid points (`sky`).
pub fn yuv_to_rgb_in_scene(
    frame: &YuvFrame,
    p: &RainParams,
    lit: Option<(&LightList, &[RtfTable; 3])>,
    depth: Option<&DepthMap>,
    sky: Option<&[f32]>,
) -> Vec<[f64; 3]> {
    canvas(frame, p, lit, depth, sky)
}

fn canvas(
    frame: &YuvFrame,
    p: &RainParams,
    lit: Option<(&LightList, &[RtfTable; 3])>,
    depth: Option<&DepthMap>,
    sky: Option<&[f32]>,
) -> Vec<[f64; 3]> {
    let f = frame.format;
    let (sx, sy) = f.chroma.shift();
    let (haze_env, drop) = environment_and_drop(p);
    let glow = lit.map(|(l, t)| haze_glow(p, l, t, (f.width, f.height)));
    let mut out = Vec::with_capacity((f.width * f.height) as usize);
    for y in 0..f.height {
        for x in 0..f.width {
            let code = [
                frame.sample(0, x, y) as f64,
                frame.sample(1, x >> sx, y >> sy) as f64,
                frame.sample(2, x >> sx, y >> sy) as f64,
            ];
            let rgb = frame.color.code_to_linear(code);
            let transmittance = haze_transmittance(p, depth, x, y);
            let veil = sky.map_or(transmittance, |w| {
                let weight = sky_weight(p, depth, w, (f.width, f.height), x, y);
                transmittance + (1.0 - transmittance) * weight
            });
            let in_scatter = if veil < 1.0 {
                prt_colour_f64(&haze_env, &drop, view_ray(p, x, y))
                    .map(|v| (1.0 - veil) * v.max(0.0))
            } else {
                [0.0; 3]
            };
            // The grid's glow is the haze's to the scene's depth; a ray meeting the ground
            // sooner glows by its share of that opacity.
            let share = (1.0 - transmittance) / (1.0 - p.haze[3] as f64).max(1e-300);
            let glow_px = glow.as_ref().map_or([0.0; 3], |g| {
                g[(y * f.width + x) as usize].map(|v| v * share)
            });
            out.push(std::array::from_fn(|k| {
                rgb[k] * veil + in_scatter[k] + glow_px[k]
            }));
        }
    }
    out
}
