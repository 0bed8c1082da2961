//! The light of the drops simulated on the CPU ([`super::simulate`]): the environment through
//! the drop's PRT and the compact lights through its transfer table at both ends of each
//! drawable streak, and with point-light mattes the drop's glints (the WGSL's `drop_radiance`
//! and `main_mattes`, in `f32`).
//!
//! ## How it works
//! The ends of a block's drawable streaks are packed side by side; the SH basis and each light
//! are evaluated across them in loops the compiler vectorises. The scattering angle comes from
//! a polynomial `atan` (Cephes' `atanf` after reduction to [0, 1], within 2 × 10⁻⁷ rad, where
//! the table's bins are 3 × 10⁻³ rad wide), and the table is read by an index masked into a
//! power-of-two array, so the reads need no bounds checks and become gathers. The lights are
//! summed in the list's order, the environment before them, as the WGSL does.

// Lane loops index several arrays by the lane: the form the vectoriser reads best.
#![allow(clippy::needless_range_loop)]

use super::simulate::{LANES, NO_GLINT};
use crate::gpu::lights::TABLE_BINS;
use crate::gpu::types::{GLINTS_PER_DROP, Glint, LightList, MAX_LIGHTS, RainParams, Streak};
use crate::lighting::sh::basis16_cartesian_f32;

/// The transfer table as the light loop reads it: one array per channel, [`TABLE_LEN`]
/// entries (the bins, then the last bin repeated), so a masked index never leaves it.
const TABLE_LEN: usize = (TABLE_BINS + 1).next_power_of_two();

/// The drop's transfer table per channel (F, sr⁻¹, over θ bins of π / [`TABLE_BINS`]), as the
/// GPU's `rtf_table` holds it (`gpu::lights::table_texels`).
#[derive(Clone)]
pub struct LightTable {
    channels: Box<[[f32; TABLE_LEN]; 3]>,
}

impl LightTable {
    /// The table of `texels` ([`TABLE_BINS`] × (F_R, F_G, F_B, 0)).
    pub fn new(texels: &[[f32; 4]]) -> LightTable {
        let mut channels = Box::new([[0f32; TABLE_LEN]; 3]);
        for (c, channel) in channels.iter_mut().enumerate() {
            for (m, v) in channel.iter_mut().enumerate() {
                *v = texels[m.min(texels.len().saturating_sub(1))][c];
            }
        }
        LightTable { channels }
    }
}

/// One compact light (WGSL `DirectLight`).
#[derive(Clone, Copy)]
struct Light {
    dir: [f32; 3],
    distance_m: f32,
    strength: [f32; 3],
    closest_m: f32,
}

/// The frame's compact lights and the table they are seen through.
pub(super) struct Lit<'a> {
    lights: Vec<Light>,
    table: Option<&'a LightTable>,
    bins: f32,
    last_bin: u32,
}

impl<'a> Lit<'a> {
    /// `list`'s lights through `table` (`None`: they add nothing, as the GPU's zero table).
    pub(super) fn new(list: &LightList, table: Option<&'a LightTable>) -> Lit<'a> {
        let count = (list.count as usize).min(MAX_LIGHTS);
        let bins = (list.table_bins as usize).clamp(1, TABLE_BINS);
        Lit {
            lights: list.lights[..count]
                .iter()
                .map(|l| {
                    let [x, y, z, d] = l.direction_distance;
                    let [r, g, b, closest] = l.strength;
                    Light {
                        dir: [x, y, z],
                        distance_m: d,
                        strength: [r, g, b],
                        closest_m: closest,
                    }
                })
                .collect(),
            table,
            bins: bins as f32,
            last_bin: bins as u32 - 1,
        }
    }
}

/// WGSL `mix`: `a (1 − t) + b t`.
#[inline(always)]
fn mix(a: f32, b: f32, t: f32) -> f32 {
    a * (1.0 - t) + b * t
}

/// Camera point → world offset from the camera (WGSL `world_offset`).
#[inline(always)]
pub(super) fn world_offset(p: &RainParams, c: [f32; 3]) -> [f32; 3] {
    let (r0, r1, r2) = (
        &p.camera_from_world_0,
        &p.camera_from_world_1,
        &p.camera_from_world_2,
    );
    std::array::from_fn(|a| r0[a] * c[0] + r1[a] * c[1] + r2[a] * c[2])
}

/// sqrt(4π/(2l+1)) for l = 0..3 (common/sh.wgsl).
const SH_ZONAL_FACTOR: [f32; 4] = [3.544_907_7, 2.046_653_4, 1.585_330_9, 1.339_849_2];

/// atan2(y, x) for y ≥ 0, in [0, π]: Cephes' `atanf` on min/max (within 2 × 10⁻⁷ rad), no
/// branches.
#[inline(always)]
fn atan2_upper(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let ax = x.abs();
    let (lo, hi) = (ax.min(y), ax.max(y));
    let a = lo / hi.max(f32::MIN_POSITIVE);
    // Below tan(π/8) the series directly; above, about π/4.
    let big = a > 0.414_213_57;
    let t = select(big, (a - 1.0) / (a + 1.0), a);
    let z = t * t;
    let poly =
        (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * t
            + t;
    let r = select(big, FRAC_PI_4 + poly, poly);
    let r = select(y > ax, FRAC_PI_2 - r, r);
    select(x < 0.0, PI - r, r)
}

/// `a` where `c`, else `b`; both already evaluated, so the compiler emits a blend, not a
/// branch, and the loop around it vectorises.
#[inline(always)]
fn select(c: bool, a: f32, b: f32) -> f32 {
    if c { a } else { b }
}

/// The radiance at both ends of the block's drawn streaks `visible` (lanes): the environment
/// through the drop's PRT plus the compact lights, clamped at 0 (WGSL `drop_radiance`).
/// Entry `e · m + k` is end e of the k-th drawn streak (`m` of them): only those are lit.
#[inline(always)]
pub(super) fn light_ends(
    p: &RainParams,
    f: &Lit,
    ends: &[[[f32; LANES]; 3]; 2],
    visible: &[u8],
) -> [[f32; 3]; 2 * LANES] {
    let m = visible.len();
    // The ends' world offsets from the camera and unit view rays, packed: e · m + k.
    let mut o = [[0f32; 2 * LANES]; 3];
    let mut v = [[0f32; 2 * LANES]; 3];
    for e in 0..2 {
        for (k, &l) in visible.iter().enumerate() {
            let l = l as usize;
            let c = [ends[e][0][l], ends[e][1][l], ends[e][2][l]];
            let w = world_offset(p, c);
            for a in 0..3 {
                o[a][e * m + k] = w[a];
            }
        }
    }
    let ends = 2 * m;
    for i in 0..ends {
        let len = (o[0][i] * o[0][i] + o[1][i] * o[1][i] + o[2][i] * o[2][i]).sqrt();
        for a in 0..3 {
            v[a][i] = o[a][i] / len;
        }
    }
    // The environment: Σ L_lm sqrt(4π/(2l+1)) z_l Y_lm(v) per channel (sh.wgsl).
    let mut out = [[0f32; 3]; 2 * LANES];
    let env = &p.env_sh;
    let t: [[f32; 4]; 3] =
        std::array::from_fn(|c| std::array::from_fn(|l| p.drop_zonal[c][l] * SH_ZONAL_FACTOR[l]));
    let mut sum = [[0f32; 2 * LANES]; 3];
    for i in 0..ends {
        let y = basis16_cartesian_f32(v[0][i], v[1][i], v[2][i]);
        for c in 0..3 {
            let e = |k: usize| env[k][c] * y[k];
            let mut s = env[0][c] * t[c][0] * y[0];
            s += (e(1) + e(2) + e(3)) * t[c][1];
            s += (e(4) + e(5) + e(6) + e(7) + e(8)) * t[c][2];
            s += (e(9) + e(10) + e(11) + e(12) + e(13) + e(14) + e(15)) * t[c][3];
            sum[c][i] = s;
        }
    }
    for i in 0..ends {
        for c in 0..3 {
            out[i][c] = sum[c][i];
        }
    }
    // The compact lights through the transfer table, in the list's order.
    if let (Some(table), false) = (f.table, f.lights.is_empty()) {
        let mut direct = [[0f32; 2 * LANES]; 3];
        for light in &f.lights {
            let mut scale = [0f32; 2 * LANES];
            let mut bin = [0u32; 2 * LANES];
            let mut frac = [0f32; 2 * LANES];
            // Three loops, each simple enough for the vectoriser (one loop of all three is
            // left scalar): the light's direction and solid angle, the angle, the bin.
            let mut omega = [[0f32; 2 * LANES]; 3];
            for i in 0..ends {
                let (w, s) = seen_from(light, [o[0][i], o[1][i], o[2][i]]);
                omega[0][i] = w[0];
                omega[1][i] = w[1];
                omega[2][i] = w[2];
                scale[i] = s;
            }
            let mut angle = [0f32; 2 * LANES];
            for i in 0..ends {
                let w = [omega[0][i], omega[1][i], omega[2][i]];
                angle[i] = theta(w, [v[0][i], v[1][i], v[2][i]]);
            }
            for i in 0..ends {
                let (b, t) = table_at(f, angle[i]);
                bin[i] = b;
                frac[i] = t;
            }
            for c in 0..3 {
                let ch = &table.channels[c];
                let strength = light.strength[c];
                for i in 0..ends {
                    let b = bin[i] as usize & (TABLE_LEN - 1);
                    let lo = ch[b];
                    let hi = ch[(b + 1) & (TABLE_LEN - 1)];
                    direct[c][i] += strength * scale[i] * mix(lo, hi, frac[i]);
                }
            }
        }
        for i in 0..ends {
            for c in 0..3 {
                out[i][c] += direct[c][i];
            }
        }
    }
    for c in &mut out[..ends] {
        *c = c.map(|x| x.max(0.0));
    }
    out
}

/// Light `l` seen from the point `from` (world axes, metres from the camera): the unit
/// direction towards it and the factor on its solid angle (WGSL `light_seen_from`).
#[inline(always)]
fn seen_from(l: &Light, from: [f32; 3]) -> ([f32; 3], f32) {
    let d = l.distance_m;
    let to = [
        l.dir[0] * d - from[0],
        l.dir[1] * d - from[1],
        l.dir[2] * d - from[2],
    ];
    let r = (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
    let finite = d > 0.0;
    // `&`, not `&&`: no branch in the vectorised loop.
    let moved = finite & (r > 0.0);
    let omega = std::array::from_fn(|a| select(moved, to[a] / r, l.dir[a]));
    let q = d / r.max(l.closest_m);
    (omega, select(finite, q * q, 1.0))
}

/// The scattering angle between ω and the view ray v: atan2(|ω × v|, ω · v).
#[inline(always)]
fn theta(w: [f32; 3], v: [f32; 3]) -> f32 {
    let cross = [
        w[1] * v[2] - w[2] * v[1],
        w[2] * v[0] - w[0] * v[2],
        w[0] * v[1] - w[1] * v[0],
    ];
    let sin = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
    atan2_upper(sin, w[0] * v[0] + w[1] * v[1] + w[2] * v[2])
}

/// The table's bin below θ and the fraction towards the next, clamped at the ends as the
/// WGSL's `rtf_at` (a fraction of 0 at either end).
#[inline(always)]
fn table_at(f: &Lit, theta: f32) -> (u32, f32) {
    // 2²³: adding it rounds an f32 in [0, 2²²) to an integer, whose bits it then holds.
    const MAGIC: f32 = 8_388_608.0;
    let u = theta / std::f32::consts::PI * f.bins - 0.5;
    let last = f.last_bin as f32;
    let clamped = u.max(0.0).min(last);
    let nearest = (clamped + MAGIC) - MAGIC;
    let floor = nearest - select(nearest > clamped, 1.0, 0.0);
    let inside = (u > 0.0) & (floor < last);
    (
        (floor + MAGIC).to_bits() - MAGIC.to_bits(),
        select(inside, u - floor, 0.0),
    )
}

/// The glints of the drawn drop at `pos` moving at `vel` (the stage's `main_mattes`): its
/// [`GLINTS_PER_DROP`] strongest lights at mid-exposure, strongest first, taken out of
/// `streak`'s colour.
pub(super) fn take_glints(
    p: &RainParams,
    f: &Lit,
    pos: [f32; 3],
    vel: [f32; 3],
    streak: &mut Streak,
    glints: &mut [Glint; GLINTS_PER_DROP],
) {
    *glints = [NO_GLINT; GLINTS_PER_DROP];
    if f.lights.is_empty() {
        return;
    }
    let offset = [
        pos[0] - p.camera_pos_m[0],
        pos[1] - p.camera_pos_m[1],
        pos[2] - p.camera_pos_m[2],
    ];
    let norm = |a: [f32; 3]| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let len = norm(offset);
    let v = offset.map(|x| x / len);
    let mut strongest = [([0f32; 3], [0f32; 3]); GLINTS_PER_DROP];
    let total = |c: &[f32; 3]| c[0] + c[1] + c[2];
    // Without a table every light gives nothing (as the GPU's zero table).
    if let Some(table) = f.table {
        for light in &f.lights {
            let (omega, scale) = seen_from(light, offset);
            let (b, t) = table_at(f, theta(omega, v));
            let b = b as usize & (TABLE_LEN - 1);
            let mut term: ([f32; 3], [f32; 3]) = (
                std::array::from_fn(|c| {
                    let ch = &table.channels[c];
                    light.strength[c] * scale * mix(ch[b], ch[(b + 1) & (TABLE_LEN - 1)], t)
                }),
                omega,
            );
            for k in 0..GLINTS_PER_DROP {
                if total(&term.0) > total(&strongest[k].0) {
                    std::mem::swap(&mut strongest[k], &mut term);
                }
            }
        }
    }
    // The matte's frame: z against the fall, y the view's horizontal part, x = y × z.
    let speed = norm(vel).max(1e-6);
    let up = vel.map(|x| -x / speed);
    let along = dot(v, up);
    let away = [
        v[0] - up[0] * along,
        v[1] - up[1] * along,
        v[2] - up[2] * along,
    ];
    let away_len = norm(away);
    let away = if away_len > 1e-6 {
        away.map(|x| x / away_len)
    } else {
        [0.0, 1.0, 0.0]
    };
    let right = [
        away[1] * up[2] - away[2] * up[1],
        away[2] * up[0] - away[0] * up[2],
        away[0] * up[1] - away[1] * up[0],
    ];
    let mut sum = [0f32; 3];
    for (colour, _) in &strongest {
        for c in 0..3 {
            sum[c] += colour[c];
        }
    }
    let mut share = [0f32; 3];
    for c in 0..3 {
        let (r0, r1) = (streak.radiance0[c], streak.radiance1[c]);
        let both = r0 + r1;
        let taken = sum[c].min(0.5 * both);
        let left = (both - 2.0 * taken).max(0.0);
        let end0 = (r0 - taken).max(0.0).min(left);
        streak.radiance0[c] = end0;
        streak.radiance1[c] = left - end0;
        share[c] = if sum[c] <= taken {
            1.0
        } else {
            taken / sum[c].max(1e-30)
        };
    }
    for (g, (colour, w)) in glints.iter_mut().zip(&strongest) {
        g.colour = [
            colour[0] * share[0],
            colour[1] * share[1],
            colour[2] * share[2],
            0.0,
        ];
        g.light_dir = [dot(*w, right), dot(*w, away), dot(*w, up), 0.0];
    }
}
