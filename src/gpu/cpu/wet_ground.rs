//! The CPU twin of the `wet_ground` stage: on every pixel whose view ray meets the ground
//! z = 0 in front of the camera, the scene radiance under the haze is darkened by the water
//! film (Lekner & Dorf, [`FilmOptics::darkening`]) and gains the film's Fresnel reflection of the
//! environment in the mirrored direction, both weighted by the wetness (docs/method.md §2.3)
//! and, without a depth map, by the ground mask ([`ground_weight`]). The haze's in-scatter and
//! the lamps' glow that yuv_to_rgb put on the pixel stay on it.

use std::f64::consts::PI;

use glam::DVec3;

use super::yuv_to_rgb::view_ray;
use crate::gpu::types::{RainParams, WetParams};
use crate::lighting::prt::prt_colour_f64;
use crate::lighting::sh::{band_of, eval_basis};
use crate::lighting::wetness::{FilmOptics, ground_shown, reach_fade, reflectance};
use crate::video::YuvFrame;

/// Radiance of the environment `env` (SH coefficients) from direction `dir`.
pub fn radiance(env: &[[f64; 3]], dir: DVec3) -> [f64; 3] {
    let mut y = vec![0.0; env.len()];
    eval_basis(dir.normalize(), band_of(env.len() - 1) + 1, &mut y);
    std::array::from_fn(|k| env.iter().zip(&y).map(|(c, b)| c[k] * b).sum())
}

/// Irradiance the environment `env` sends onto a surface of normal `normal`: its convolution
/// with the clamped cosine, whose SH coefficients per band are Â₀ = π, Â₁ = 2π/3, Â₂ = π/4,
/// Â₃ = 0 (odd bands above 1 vanish).
pub fn irradiance(env: &[[f64; 3]], normal: DVec3) -> [f64; 3] {
    let a_hat = [PI, 2.0 * PI / 3.0, PI / 4.0, 0.0];
    let mut y = vec![0.0; env.len()];
    eval_basis(normal.normalize(), band_of(env.len() - 1) + 1, &mut y);
    std::array::from_fn(|k| {
        env.iter()
            .zip(&y)
            .enumerate()
            .map(|(i, (c, b))| a_hat[band_of(i)] * c[k] * b)
            .sum()
    })
}

/// The wet ground of `frame` at each coded pixel (row-major) under the uniforms `p` and `wet`,
/// as (L, M, A): the frame's linear colour L, the factor M on it and the light A added (the
/// haze's in-scatter, the lamps' glow and the film's reflection), so the wet picture is L·M + A;
/// `None` where the pixel's ray does not meet the ground.
///
/// With `depth` (metres of camera z per displayed pixel, `NaN` unknown), a pixel whose scene is
/// nearer than the ground along its ray stays dry ([`ground_shown`]).
pub fn wet_terms(
    frame: &YuvFrame,
    p: &RainParams,
    wet: &WetParams,
    depth: Option<&crate::scene::DepthMap>,
) -> Vec<Option<[[f64; 3]; 3]>> {
    wet_terms_masked(frame, p, wet, depth, None, None)
}

/// The ground's weight at coded pixel (`x`, `y`) (twin of `ground_weight` in
/// common/ground_mask.wgsl): the mask `mask` (weights at the glow's grid points of the coded
/// picture) bilinear at the pixel's centre; 1 without a mask or where the depth map knows the
/// pixel (its depth decides).
pub fn ground_weight(
    p: &RainParams,
    depth: Option<&crate::scene::DepthMap>,
    mask: Option<&[f32]>,
    x: u32,
    y: u32,
) -> f64 {
    let size = (p.coded_size_px[0] as u32, p.coded_size_px[1] as u32);
    let grid = crate::scene::sky::SkyGrid::new(crate::gpu::stages::yuv_to_rgb::GLOW_CELL_PX, size);
    let Some(mask) = mask.filter(|m| m.len() == grid.len()) else {
        return 1.0;
    };
    let centre = glam::DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
    if depth.is_some_and(|map| super::yuv_to_rgb::scene_depth_at(p, map, centre).is_some()) {
        return 1.0;
    }
    f64::from(grid.weight_at(mask, x, y))
}

/// [`wet_terms`] with the ground mask `mask` (weights at the glow's grid points; `None`: all
/// ground) and the lamps' glow `glow` (per coded pixel, at the scene's opacity, as
/// [`super::yuv_to_rgb::haze_glow`] gives it; `None`: no lamps), which the pixel keeps at its
/// ray's share of the opacity as yuv_to_rgb laid it.
pub fn wet_terms_masked(
    frame: &YuvFrame,
    p: &RainParams,
    wet: &WetParams,
    depth: Option<&crate::scene::DepthMap>,
    mask: Option<&[f32]>,
    glow: Option<&[[f64; 3]]>,
) -> Vec<Option<[[f64; 3]; 3]>> {
    let plate = super::yuv_to_rgb::plate(frame, p);
    let width = frame.format.width;
    let (env, drop) = super::yuv_to_rgb::environment_and_drop(p);
    let optics = FilmOptics {
        index: wet.water_index as f64,
        diffuse_external: wet.diffuse_external as f64,
        diffuse_internal: wet.diffuse_internal as f64,
    };
    let e_up = irradiance(&env, DVec3::Z);
    plate
        .iter()
        .enumerate()
        .map(|(i, &scene)| {
            let (x, y) = (i as u32 % width, i as u32 / width);
            let ray = view_ray(p, x, y);
            let d = ray.normalize();
            if d.z >= 0.0 || p.camera_pos_m[2] <= 0.0 {
                return None;
            }
            let transmittance = super::yuv_to_rgb::haze_transmittance(p, depth, x, y);
            let in_scatter = if transmittance < 1.0 {
                prt_colour_f64(&env, &drop, ray).map(|v| (1.0 - transmittance) * v.max(0.0))
            } else {
                [0.0; 3]
            };
            let share = (1.0 - transmittance) / (1.0 - p.haze[3] as f64).max(1e-300);
            let glow_px = glow.map_or([0.0; 3], |g| g[i].map(|v| v * share));
            let cos_view = -d.z;
            let distance_m = p.camera_pos_m[2] as f64 / cos_view;
            // `ray` has unit camera depth: the ground lies at camera depth h / −ray.z.
            let ground_z_m = p.camera_pos_m[2] as f64 / -ray.z;
            let scene_m = depth.and_then(|map| {
                let shown = display_pixel(p, x, y);
                map.at(
                    (shown.0.max(0.0) as usize).min(map.width - 1),
                    (shown.1.max(0.0) as usize).min(map.height - 1),
                )
                .map(f64::from)
            });
            let w = wet.wetness as f64
                * reach_fade(distance_m, wet.reach_m as f64)
                * ground_shown(scene_m, ground_z_m)
                * ground_weight(p, depth, mask, x, y);
            let r = reflectance(optics.index, cos_view);
            let sky = radiance(&env, DVec3::new(d.x, d.y, -d.z));
            let (mut m, mut a) = ([0.0; 3], [0.0; 3]);
            for k in 0..3 {
                // The pixel is the dry albedo times the light: a = π L / E.
                let albedo = if e_up[k] > 0.0 {
                    (PI * scene[k] / e_up[k]).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let darkening = optics.darkening(albedo, cos_view);
                m[k] = transmittance * (1.0 + w * (darkening - 1.0));
                a[k] = in_scatter[k] + glow_px[k] + w * transmittance * r * sky[k].max(0.0);
            }
            Some([scene, m, a])
        })
        .collect()
}

/// Wets the ground on `canvas` (the linear picture of `frame` with its haze, coded
/// orientation, row-major): L·M + A where the ground shows ([`wet_terms`]).
pub fn wet_ground(
    canvas: &mut [[f64; 3]],
    frame: &YuvFrame,
    p: &RainParams,
    wet: &WetParams,
    depth: Option<&crate::scene::DepthMap>,
) {
    wet_ground_masked(canvas, frame, p, wet, depth, None);
}

/// [`wet_ground`] with the ground mask `mask` (see [`wet_terms_masked`]).
pub fn wet_ground_masked(
    canvas: &mut [[f64; 3]],
    frame: &YuvFrame,
    p: &RainParams,
    wet: &WetParams,
    depth: Option<&crate::scene::DepthMap>,
    mask: Option<&[f32]>,
) {
    wet_ground_lit(canvas, frame, p, wet, depth, mask, None);
}

/// [`wet_ground_masked`] with the lamps' glow `glow` (see [`wet_terms_masked`]): over a canvas
/// from [`super::yuv_to_rgb::yuv_to_rgb_in_scene`] with the same lamps.
pub fn wet_ground_lit(
    canvas: &mut [[f64; 3]],
    frame: &YuvFrame,
    p: &RainParams,
    wet: &WetParams,
    depth: Option<&crate::scene::DepthMap>,
    mask: Option<&[f32]>,
    glow: Option<&[[f64; 3]]>,
) {
    for (pixel, terms) in canvas
        .iter_mut()
        .zip(wet_terms_masked(frame, p, wet, depth, mask, glow))
    {
        if let Some([l, m, a]) = terms {
            *pixel = std::array::from_fn(|k| l[k] * m[k] + a[k]);
        }
    }
}

/// The wet ground on a layer (premultiplied linear RGBA, starting as the haze alone): over
/// the frame it gives back L·M + A exactly, with α = 1 − min(M) and colour L·(M − min M) + A;
/// `glow` the lamps' (see [`wet_terms_masked`]).
pub fn wet_ground_layer(
    layer: &mut [[f64; 4]],
    frame: &YuvFrame,
    p: &RainParams,
    wet: &WetParams,
    depth: Option<&crate::scene::DepthMap>,
    glow: Option<&[[f64; 3]]>,
) {
    for (pixel, terms) in layer
        .iter_mut()
        .zip(wet_terms_masked(frame, p, wet, depth, None, glow))
    {
        if let Some([l, m, a]) = terms {
            let kept = m[0].min(m[1]).min(m[2]).clamp(0.0, 1.0);
            *pixel = [
                l[0] * (m[0] - kept) + a[0],
                l[1] * (m[1] - kept) + a[1],
                l[2] * (m[2] - kept) + a[2],
                1.0 - kept,
            ];
        }
    }
}

/// The displayed position (px) of the centre of coded pixel (x, y): display = mᵀ (coded −
/// offset), the rotation being orthogonal.
fn display_pixel(p: &RainParams, x: u32, y: u32) -> (f64, f64) {
    let m = p.coded_from_display.map(f64::from);
    let dx = x as f64 + 0.5 - p.coded_offset_px[0] as f64;
    let dy = y as f64 + 0.5 - p.coded_offset_px[1] as f64;
    (m[0] * dx + m[1] * dy, m[2] * dx + m[3] * dy)
}
