//! The CPU twin of the `wet_ground` stage: on every pixel whose view ray meets the ground
//! z = 0 in front of the camera, the scene radiance under the haze is darkened by the water
//! film (Lekner & Dorf, [`FilmOptics::darkening`]) and gains the film's Fresnel reflection of the
//! environment in the mirrored direction, both weighted by the wetness (docs/method.md §2.3).

use std::f64::consts::PI;

use glam::DVec3;

use super::yuv_to_rgb::view_ray;
use crate::gpu::types::{RainParams, WetParams};
use crate::lighting::prt::{RtfSh, prt_colour_f64};
use crate::lighting::sh::{band_of, eval_basis};
use crate::scene::wetness::{FilmOptics, ground_shown, reach_fade, reflectance};

/// The environment of `p` as f64 coefficients.
fn environment(p: &RainParams) -> Vec<[f64; 3]> {
    p.env_sh
        .iter()
        .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
        .collect()
}

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

/// Wets the ground on `canvas` (linear RGB, coded orientation, row-major, `width` wide) under
/// the uniforms `p` and `wet`.
///
/// With `depth` (metres of camera z per displayed pixel, `NaN` unknown), a pixel whose scene is
/// nearer than the ground along its ray stays dry ([`ground_shown`]).
pub fn wet_ground(
    canvas: &mut [[f64; 3]],
    width: u32,
    p: &RainParams,
    wet: &WetParams,
    depth: Option<&crate::scene::DepthMap>,
) {
    let env = environment(p);
    let drop = RtfSh {
        bands: 4,
        zonal: (0..4)
            .map(|l| std::array::from_fn(|c| p.drop_zonal[c][l] as f64))
            .collect(),
    };
    let optics = FilmOptics {
        index: wet.water_index as f64,
        diffuse_external: wet.diffuse_external as f64,
        diffuse_internal: wet.diffuse_internal as f64,
    };
    let w = wet.wetness as f64;
    let transmittance = p.haze[3] as f64;
    let e_up = irradiance(&env, DVec3::Z);
    for (i, pixel) in canvas.iter_mut().enumerate() {
        let (x, y) = (i as u32 % width, i as u32 / width);
        let ray = view_ray(p, x, y);
        let d = ray.normalize();
        if d.z >= 0.0 || p.camera_pos_m[2] <= 0.0 {
            continue;
        }
        let in_scatter = if transmittance < 1.0 {
            prt_colour_f64(&env, &drop, ray).map(|v| (1.0 - transmittance) * v.max(0.0))
        } else {
            [0.0; 3]
        };
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
        let shown = ground_shown(scene_m, ground_z_m);
        let r = reflectance(optics.index, cos_view);
        let sky = radiance(&env, DVec3::new(d.x, d.y, -d.z));
        for k in 0..3 {
            let scene = (pixel[k] - in_scatter[k]).max(0.0) / transmittance.max(1e-6);
            // The pixel is the dry albedo times the light: a = π L / E.
            let albedo = if e_up[k] > 0.0 {
                (PI * scene / e_up[k]).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let change = (optics.darkening(albedo, cos_view) - 1.0) * scene + r * sky[k].max(0.0);
            pixel[k] +=
                w * reach_fade(distance_m, wet.reach_m as f64) * shown * transmittance * change;
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
