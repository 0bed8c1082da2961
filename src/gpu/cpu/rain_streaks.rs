//! The CPU twin of the `rain_streaks` stage: each streak's quad rasterised over the canvas in
//! drop order, the exact time-averaged coverage of [`coverage`] at each pixel centre, the
//! radiance interpolated along the quad as the vertex stage does, blended premultiplied
//! (src + dst·(1 − α)); with a depth map of the displayed picture, each pixel's alpha (and
//! light) times the drop's [`visibility`] in front of the scene there. With streak mattes, the
//! colour is spread by the drop's matte as the stage's `fs_mattes` does; the alpha is unchanged.

use std::f64::consts::PI;

use glam::{DVec2, DVec3};

pub use super::rain_simulate::coverage;
use crate::drops::MatteAtlas;
use crate::drops::atlas::HALF_WIDTH_RADII;
use crate::gpu::types::{GLINTS_PER_DROP, Glint, RainParams, Streak};
use crate::rain::volume::drop_uniform;

/// The random stream of a drop's oscillation phase (`MATTE_PHASE_STREAM` in the WGSL).
pub const MATTE_PHASE_STREAM: u32 = 6;

/// The matte layers of drop `id` with `drop_info` and `glints` (its glints, strongest first,
/// as `rain_simulate`'s `main_mattes` writes them; the stage's `vs_mattes`): the nearest size
/// and view bins and a phase random per drop and fixed in time; for each glint up to the first
/// without light, the point-light matte of the nearest direction, and whether it is the mirror
/// image.
pub fn matte_layers(
    atlas: &MatteAtlas,
    seed: u32,
    id: u32,
    drop_info: u32,
    glints: &[Glint],
) -> (usize, Vec<(usize, bool)>) {
    let unorm = |bits: u32| (bits & 0xffff) as f64 / 65535.0;
    let nearest = |values: &[f64], x: f64| {
        (1..values.len()).fold(0, |best, k| {
            if ((values[k] as f32) - x as f32).abs() < ((values[best] as f32) - x as f32).abs() {
                k
            } else {
                best
            }
        })
    };
    let size = nearest(&atlas.sizes_mm, unorm(drop_info) * 10.0);
    let view = nearest(&atlas.views_deg, unorm(drop_info >> 16) * 90.0);
    let phases = atlas.phases;
    let phase =
        ((drop_uniform(seed, id, MATTE_PHASE_STREAM) * phases as f64) as usize).min(phases - 1);
    let bin = size * atlas.views_deg.len() + view;
    // No point-light mattes, no glints drawn.
    let glints = if atlas.lights.is_empty() {
        &[][..]
    } else {
        &glints[..glints.len().min(GLINTS_PER_DROP)]
    };
    let lit = |g: &&Glint| g.colour[..3].iter().any(|&c| c > 0.0);
    let glint_layers = glints
        .iter()
        .take_while(lit)
        .map(|g| {
            let [x, y, z, _] = g.light_dir.map(f64::from);
            let mirror = x < 0.0;
            let d = DVec3::new(x.abs(), y, z);
            let light = (1..atlas.lights.len()).fold(0, |best, k| {
                if atlas.lights[k].dot(d) > atlas.lights[best].dot(d) {
                    k
                } else {
                    best
                }
            });
            let layer = atlas.light_layer0() + (bin * atlas.lights.len() + light) * phases + phase;
            (layer, mirror)
        })
        .collect();
    (bin * phases + phase, glint_layers)
}

/// Half a pixel of margin around each quad (`AA_MARGIN_PX` in the WGSL).
pub const AA_MARGIN_PX: f64 = 0.5;

/// Depth over which a drop passing behind the scene fades out, metres (`OCCLUSION_SOFTNESS_M`
/// in the WGSL): a few centimetres, so depth edges are soft and a drop touching a surface does
/// not flicker.
pub const OCCLUSION_SOFTNESS_M: f64 = 0.05;

/// How much of a drop at depth `drop_m` shows in front of a scene at depth `scene_m` (both
/// camera z, metres): a smoothstep over [`OCCLUSION_SOFTNESS_M`] centred on the surface; 1
/// where the scene's depth is unknown (`None`).
pub fn visibility(scene_m: Option<f64>, drop_m: f64) -> f64 {
    let Some(scene_m) = scene_m else { return 1.0 };
    let x = ((scene_m - drop_m) / OCCLUSION_SOFTNESS_M + 0.5).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// The drop's depth (camera z, m) `along` px down a streak of `len_px` whose ends lie at
/// `depth_m`: 1/z is affine in the picture along a projected segment.
pub fn drop_depth_m(along: f64, len_px: f64, depth_m: [f64; 2]) -> f64 {
    let t = if len_px >= 1e-3 {
        (along / len_px).clamp(0.0, 1.0)
    } else {
        0.0
    };
    1.0 / ((1.0 - t) / depth_m[0] + t / depth_m[1])
}

/// Blends `streaks` over `canvas` (linear RGB, row-major, the coded picture of
/// `p.coded_size_px`), with `p`'s display rotation.
pub fn rain_streaks(canvas: &mut [[f64; 3]], p: &RainParams, streaks: &[Streak]) {
    rain_streaks_with(canvas, p, streaks, None, &[], None)
}

/// [`rain_streaks`] behind the scene of `depth` (metres per displayed pixel, the size of
/// `p.display_size_px`; `None` = unknown).
pub fn rain_streaks_occluded(
    canvas: &mut [[f64; 3]],
    p: &RainParams,
    streaks: &[Streak],
    depth: Option<&crate::scene::DepthMap>,
) {
    rain_streaks_with(canvas, p, streaks, None, &[], depth)
}

/// [`rain_streaks`], the colours spread by `mattes` where given, with each drop's glints
/// (`rain_simulate`'s `main_mattes`: [`GLINTS_PER_DROP`] per drop, drop `id`'s from
/// `GLINTS_PER_DROP · id`; `glints` may end early: no more), behind the scene of `depth` where
/// given.
pub fn rain_streaks_with(
    canvas: &mut [[f64; 3]],
    p: &RainParams,
    streaks: &[Streak],
    mattes: Option<&MatteAtlas>,
    glints: &[Glint],
    depth: Option<&crate::scene::DepthMap>,
) {
    let (w, h) = (p.coded_size_px[0] as u32, p.coded_size_px[1] as u32);
    let m = p.coded_from_display.map(|v| v as f64);
    let off = DVec2::new(p.coded_offset_px[0] as f64, p.coded_offset_px[1] as f64);
    // The rotation is orthogonal: display = mᵀ (coded − offset).
    let to_display = |c: DVec2| {
        let d = c - off;
        DVec2::new(m[0] * d.x + m[1] * d.y, m[2] * d.x + m[3] * d.y)
    };
    for (id, s) in streaks.iter().enumerate().filter(|(_, s)| s.len_px >= 0.0) {
        let own = glints
            .get(GLINTS_PER_DROP * id..)
            .map_or(&[][..], |g| &g[..g.len().min(GLINTS_PER_DROP)]);
        let layers = mattes.map(|m| (m, matte_layers(m, p.seed, id as u32, s.drop_info, own)));
        let q0 = DVec2::new(s.q0_px[0] as f64, s.q0_px[1] as f64);
        let dir = DVec2::new(s.dir[0] as f64, s.dir[1] as f64);
        let (len, r) = (s.len_px as f64, s.r_eff_px as f64);
        let ext = r + AA_MARGIN_PX;
        // The matte's width (the stage's `quad` in `vs_mattes` reaches only as far as the
        // mattes' light, `MatteAtlas::reach_radii`: the same pixels change).
        let across_ext = match mattes {
            None => ext,
            Some(_) => ext.max(HALF_WIDTH_RADII * r),
        };
        for y in 0..h {
            for x in 0..w {
                let d = to_display(DVec2::new(x as f64 + 0.5, y as f64 + 0.5)) - q0;
                let along = d.dot(dir);
                let across = d.x * -dir.y + d.y * dir.x;
                if along < -ext || along > len + ext || across.abs() > across_ext {
                    continue;
                }
                let shown = match depth {
                    None => 1.0,
                    Some(map) => {
                        let at = to_display(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
                        let (px, py) = (at.x.floor() as usize, at.y.floor() as usize);
                        let scene = map
                            .at(px.min(map.width - 1), py.min(map.height - 1))
                            .map(f64::from);
                        let ends = [s.radiance0[3] as f64, s.radiance1[3] as f64];
                        visibility(scene, drop_depth_m(along, len, ends))
                    }
                };
                let a = (coverage(along, across, len, r) * s.alpha_scale as f64).clamp(0.0, 1.0)
                    * shown;
                let t = (along + ext) / (len + 2.0 * ext);
                let rad: [f64; 3] = std::array::from_fn(|k| {
                    s.radiance0[k] as f64 * (1.0 - t) + s.radiance1[k] as f64 * t
                });
                // The premultiplied colour: radiance × alpha, or the mattes' spread of the same
                // light (∫∫ N du dw = 1 over the footprint, πr² the capsule's coverage).
                let light: [f64; 3] = match &layers {
                    None => rad.map(|c| c * a),
                    Some((atlas, (env, glint_layers))) => {
                        let footprint = len + 2.0 * r;
                        let spread = s.alpha_scale as f64 * PI * r / footprint;
                        let (u, w) = ((along + r) / footprint, -across / r);
                        let n = atlas.sample(*env, u, w);
                        let glint_n: Vec<f64> = glint_layers
                            .iter()
                            .map(|&(l, mirror)| atlas.sample(l, u, if mirror { -w } else { w }))
                            .collect();
                        std::array::from_fn(|k| {
                            let g: f64 = own
                                .iter()
                                .zip(&glint_n)
                                .map(|(g, n)| g.colour[k] as f64 * n)
                                .sum();
                            (rad[k] * n + g) * spread * shown
                        })
                    }
                };
                if a <= 0.0 && light.iter().all(|&c| c <= 0.0) {
                    continue;
                }
                let px = &mut canvas[(y * w + x) as usize];
                for (c, l) in px.iter_mut().zip(light) {
                    *c = l + *c * (1.0 - a);
                }
            }
        }
    }
}
