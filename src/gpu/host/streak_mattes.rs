//! The streak mattes' part of the CPU raster ([`super::streaks`]): what each drawn streak's
//! matte reads (its layers chosen once for the streak, as `gpu::cpu::rain_streaks::matte_layers`
//! picks them) and its runs blended as the twin does, the bilinear reads in lanes.
// Lane loops index several arrays by the lane: the form the vectoriser reads best.
#![allow(clippy::needless_range_loop)]

use super::streaks::{LANES, Prepared, Rain, Run, larger, smaller};
use crate::drops::MatteAtlas;
use crate::drops::atlas::{ATLAS_HEIGHT, ATLAS_WIDTH, HALF_WIDTH_RADII};
use crate::gpu::cpu::rain_streaks::matte_layers;
use crate::gpu::types::{GLINTS_PER_DROP, Streak};

/// What a streak's matte colour reads: its environment layer and its glints (layer, mirror
/// image, colour), strongest first.
#[derive(Default)]
pub(super) struct Matte {
    layer: usize,
    glints: Vec<(usize, bool, [f32; 3])>,
}

/// The matte of drawn streak `id`, `s` (its layers chosen once for the streak).
pub(super) fn matte_of(rain: &Rain, atlas: &MatteAtlas, id: usize, s: &Streak) -> Matte {
    let own = rain
        .glints
        .get(GLINTS_PER_DROP * id..)
        .map_or(&[][..], |g| &g[..g.len().min(GLINTS_PER_DROP)]);
    let (layer, glints) = matte_layers(atlas, rain.params.seed, id as u32, s.drop_info, own);
    Matte {
        layer,
        glints: glints
            .into_iter()
            .zip(own)
            .map(|((l, mirror), g)| (l, mirror, [g.colour[0], g.colour[1], g.colour[2]]))
            .collect(),
    }
}

/// Texels in one layer of the mattes.
const LAYER: usize = ATLAS_WIDTH * ATLAS_HEIGHT;

/// Blends streak `p` with its matte `m` over `run` as the twin does (the capsule's alpha, the
/// colour spread by the matte and the glints' mattes, sampled bilinearly), the alpha and light
/// of its `k`-th pixel times `shown(k, along)`; a pixel outside the quad, or with neither
/// alpha nor light, is left as it was. The layers are chosen once for the streak, and each
/// pixel is computed from its own coordinate in lanes (as [`capsule_run`]).
#[inline(always)]
pub(super) fn matte_run(
    p: &Prepared,
    m: &Matte,
    atlas: &MatteAtlas,
    run: &Run,
    px: &mut [f32],
    shown: impl Fn(usize, f32) -> f32,
) {
    let layer = |l: usize| <&[f32; LAYER]>::try_from(&atlas.texels[l * LAYER..][..LAYER]).ok();
    let Some(env) = layer(m.layer) else { return };
    let (r2, len) = (p.r * p.r, p.len);
    let [r0, r1] = p.radiance;
    let still = len < 1e-3;
    let footprint = p.len + 2.0 * p.r;
    let light_spread = p.alpha_scale * std::f32::consts::PI * p.r / footprint;
    let mut k0 = 0;
    while k0 < run.count {
        // Outside the quad a lane's alpha and light are 0 (`spread[l]` = 0): left as it was.
        let (mut alpha, mut along, mut spread) = ([0f32; LANES], [0f32; LANES], [0f32; LANES]);
        let (mut u, mut w, mut t) = ([0f32; LANES], [0f32; LANES], [0f32; LANES]);
        let u0 = (run.first + k0) as i32;
        for l in 0..LANES {
            let uf = (u0 + l as i32) as f32;
            let a = run.along + uf * run.da;
            let across = run.across + uf * run.dc;
            let h = larger(r2 - across * across, 0.0).sqrt();
            let swept =
                (smaller(larger(a + h, 0.0), len) - smaller(larger(a - h, 0.0), len)) * p.inv_len;
            let here = if a.abs() < h { 1.0 } else { 0.0 };
            let cover = if still { here } else { swept };
            alpha[l] = smaller(larger(cover * p.alpha_scale, 0.0), 1.0);
            t[l] = (a + p.ext) * p.inv_quad;
            u[l] = (a + p.r) / footprint;
            w[l] = -across / p.r;
            along[l] = a;
            spread[l] = across;
        }
        for l in 0..LANES {
            let (a, across) = (along[l], spread[l]);
            // `&`, not `&&`: no branch in a lane.
            let inside = (a >= -p.ext) & (a <= len + p.ext) & (across.abs() <= p.across_ext);
            alpha[l] = if inside { alpha[l] } else { 0.0 };
            spread[l] = if inside { light_spread } else { 0.0 };
        }
        let mut n = [0f32; LANES];
        sample_lanes(env, &u, &w, false, &mut n);
        let mut light = [[0f32; LANES]; 3];
        for l in 0..LANES {
            for k in 0..3 {
                light[k][l] = (r0[k] * (1.0 - t[l]) + r1[k] * t[l]) * n[l];
            }
        }
        for &(glint, mirror, colour) in &m.glints {
            let Some(texels) = layer(glint) else { continue };
            sample_lanes(texels, &u, &w, mirror, &mut n);
            for l in 0..LANES {
                for k in 0..3 {
                    light[k][l] += colour[k] * n[l];
                }
            }
        }
        for l in 0..LANES.min(run.count - k0) {
            let s = shown(k0 + l, along[l]);
            let a = alpha[l] * s;
            let lit = [0, 1, 2].map(|k| light[k][l] * spread[l] * s);
            if a <= 0.0 && lit.iter().all(|&c| c <= 0.0) {
                continue;
            }
            let keep = 1.0 - a;
            let px = &mut px[(k0 + l) * run.stride..][..4];
            for k in 0..3 {
                px[k] = lit[k] + px[k] * keep;
            }
            px[3] = a + px[3] * keep;
        }
        k0 += LANES;
    }
}

/// A matte layer at (`u` along, `w` across in radii; `mirror`: at −`w`) in lanes, bilinear
/// between texel centres, zero outside (`MatteAtlas::sample` in f32).
#[inline(always)]
fn sample_lanes(
    texels: &[f32; LAYER],
    u: &[f32; LANES],
    w: &[f32; LANES],
    mirror: bool,
    out: &mut [f32; LANES],
) {
    let at = |xi: i32, yi: i32| {
        let on = (xi >= 0) & (yi >= 0) & (xi < ATLAS_WIDTH as i32) & (yi < ATLAS_HEIGHT as i32);
        let k = ((yi * ATLAS_WIDTH as i32 + xi) as usize).min(LAYER - 1);
        let v = texels[k];
        if on { v } else { 0.0 }
    };
    for l in 0..LANES {
        let w = if mirror { -w[l] } else { w[l] };
        let x = (w / HALF_WIDTH_RADII as f32 + 1.0) * 0.5 * ATLAS_WIDTH as f32 - 0.5;
        let y = u[l] * ATLAS_HEIGHT as f32 - 0.5;
        let (xf, yf) = (x.floor(), y.floor());
        let (tx, ty) = (x - xf, y - yf);
        let (x0, y0) = (xf as i32, yf as i32);
        let top = at(x0, y0) * (1.0 - tx) + at(x0 + 1, y0) * tx;
        let bottom = at(x0, y0 + 1) * (1.0 - tx) + at(x0 + 1, y0 + 1) * tx;
        out[l] = top * (1.0 - ty) + bottom * ty;
    }
}
