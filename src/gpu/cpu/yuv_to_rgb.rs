//! The CPU twin of the `yuv_to_rgb` stage: decoded code values → linear RGB, chroma taken
//! from the co-sited sample, through [`crate::video::ColorParams::code_to_linear`]; then the
//! haze: `background · T + (1 − T) · in-scatter`, the in-scatter the PRT colour of the
//! environment (`RainParams::env_sh`, what the drawn drops show too) for the pixel's view ray
//! ([`crate::lighting::prt::prt_colour_f64`]).

use glam::{DVec2, DVec3};

use crate::gpu::types::RainParams;
use crate::lighting::prt::{RtfSh, prt_colour_f64};
use crate::video::YuvFrame;

/// The world direction of the view ray through the centre of coded pixel (`x`, `y`) under the
/// uniforms `p` (back to display pixels, then the pinhole).
pub fn view_ray(p: &RainParams, x: u32, y: u32) -> DVec3 {
    let m = p.coded_from_display.map(f64::from);
    let c = DVec2::new(x as f64 + 0.5, y as f64 + 0.5)
        - DVec2::new(p.coded_offset_px[0] as f64, p.coded_offset_px[1] as f64);
    // The rotation is orthogonal: display = mᵀ (coded − offset).
    let q = DVec2::new(m[0] * c.x + m[1] * c.y, m[2] * c.x + m[3] * c.y);
    let d =
        (q - DVec2::new(p.principal_px[0] as f64, p.principal_px[1] as f64)) / p.focal_px as f64;
    let row = |r: [f32; 4]| DVec3::new(r[0] as f64, r[1] as f64, r[2] as f64);
    row(p.camera_from_world_0) * d.x + row(p.camera_from_world_1) * d.y + row(p.camera_from_world_2)
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

/// The linear canvas of `frame` (coded orientation, row-major RGB) veiled by the haze of `p`.
pub fn yuv_to_rgb(frame: &YuvFrame, p: &RainParams) -> Vec<[f64; 3]> {
    let f = frame.format;
    let (sx, sy) = f.chroma.shift();
    let transmittance = p.haze[3] as f64;
    let (haze_env, drop) = environment_and_drop(p);
    let mut out = Vec::with_capacity((f.width * f.height) as usize);
    for y in 0..f.height {
        for x in 0..f.width {
            let code = [
                frame.sample(0, x, y) as f64,
                frame.sample(1, x >> sx, y >> sy) as f64,
                frame.sample(2, x >> sx, y >> sy) as f64,
            ];
            let rgb = frame.color.code_to_linear(code);
            let in_scatter = if transmittance < 1.0 {
                prt_colour_f64(&haze_env, &drop, view_ray(p, x, y))
                    .map(|v| (1.0 - transmittance) * v.max(0.0))
            } else {
                [0.0; 3]
            };
            out.push(std::array::from_fn(|k| {
                rgb[k] * transmittance + in_scatter[k]
            }));
        }
    }
    out
}
