//! The drops of a frame simulated on the CPU (the `rain_simulate` stage's work, for the CPU back
//! end): each drop's state at the frame's time, its streak and, for the streaks that can be
//! drawn, the light at both ends (and with point-light mattes its glints), written as the
//! stage writes them, one record per drop in drop order, for [`super::streaks`] to draw.
//!
//! ## How it works
//! The WGSL's arithmetic in `f32`, step for step (the fixed-point phases of long clips
//! included, `rain::volume::drop`), laid out for the compiler's vectoriser: blocks of
//! [`LANES`] drops, each step one loop over the block's lanes with the lane's values in arrays
//! (structure of arrays), no early exits; `ln`, `pow` and `asin` (scalar library calls) have
//! loops of their own. Only the block's streaks that can be drawn go on to the light
//! ([`super::drop_light`], vectorised across their ends). rayon's threads take chunks of
//! [`CHUNK`] drops, and a chunk walks the columns instead of searching them; on x86-64 with
//! AVX2 the same code is compiled a second time for 8 lanes a vector and picked at run time.
//! Neither the chunks, the threads nor the instruction set change a bit of the result: every
//! drop is computed from its own id with the same operations in the same order (Rust never
//! fuses a multiply and an add), and the lights are summed in the list's order. The plain
//! twin ([`crate::gpu::cpu::rain_simulate`] with `rain::volume::sample_drop` and the
//! lighting's `f64` references) is the reference (`tests/backend.rs`).

// Lane loops index several arrays by the lane: the form the vectoriser reads best.
#![allow(clippy::needless_range_loop)]

use rayon::prelude::*;

pub use super::drop_light::LightTable;
use super::drop_light::{Lit, light_ends, take_glints, world_offset};
use crate::gpu::types::{Column, GLINTS_PER_DROP, GUSTS, Glint, LightList, RainParams, Streak};
use crate::rain::physics::{
    MIN_PEAK_ALPHA, MIN_RADIUS_PX, MP_LAMBDA_COEFF, MP_LAMBDA_EXPONENT, NEAR_FIELD_MAX_RADIUS,
};
use crate::rain::volume::RATE_STREAM;
use crate::rain::volume::drop::{
    DRIFT_PHASE_BITS, FALL_RATE_BITS, INV_HEIGHT_BITS, SPEED_BITS, SPEED_STEPS_LOG2,
    SPEED_TABLE_LEN,
};

/// Drops evaluated side by side: every step is a loop over this many lanes.
pub const LANES: usize = 32;
/// Drops per rayon task (whole blocks): 36 tasks for the default rain of a 1080p frame.
pub const CHUNK: usize = 64 * LANES;

/// A streak that is not drawn (the WGSL's `hidden()`).
pub const HIDDEN: Streak = Streak {
    q0_px: [0.0, 0.0],
    dir: [0.0, 1.0],
    len_px: -1.0,
    r_eff_px: 0.0,
    alpha_scale: 0.0,
    drop_info: 0,
    radiance0: [0.0; 4],
    radiance1: [0.0; 4],
};

pub(super) const NO_GLINT: Glint = Glint {
    colour: [0.0; 4],
    light_dir: [0.0; 4],
};

/// What one frame's simulation needs besides the uniforms.
pub struct Drops<'a> {
    /// The rain volume's columns (`RainSetup::columns`).
    pub columns: &'a [Column],
    /// The frame's compact lights.
    pub lights: &'a LightList,
    /// The drop's transfer table; `None`: the lights add nothing (as before the GPU's table is
    /// set).
    pub table: Option<&'a LightTable>,
    /// Whether glints are written (point-light mattes: the stage's `main_mattes`).
    pub glints: bool,
}

/// The frame's drops under `p`: one streak per drop into `streaks` (resized to
/// `p.drop_count`) and, where `drops.glints`, [`GLINTS_PER_DROP`] glints per drop into
/// `glints` (else emptied). Returns how many streaks can be drawn.
pub fn simulate(
    p: &RainParams,
    drops: &Drops,
    streaks: &mut Vec<Streak>,
    glints: &mut Vec<Glint>,
) -> usize {
    simulate_on(p, drops, streaks, glints, true)
}

/// [`simulate`] without the AVX2 build: the same bits (`tests/backend.rs` holds them equal).
pub fn simulate_baseline(
    p: &RainParams,
    drops: &Drops,
    streaks: &mut Vec<Streak>,
    glints: &mut Vec<Glint>,
) -> usize {
    simulate_on(p, drops, streaks, glints, false)
}

fn simulate_on(
    p: &RainParams,
    drops: &Drops,
    streaks: &mut Vec<Streak>,
    glints: &mut Vec<Glint>,
    avx2: bool,
) -> usize {
    let n = if drops.columns.is_empty() {
        0
    } else {
        p.drop_count as usize
    };
    // Every record is written below (drawn or HIDDEN): the last frame's are not cleared first.
    streaks.resize(n, HIDDEN);
    if drops.glints {
        glints.resize(GLINTS_PER_DROP * n, NO_GLINT);
    } else {
        glints.clear();
    }
    if n == 0 {
        return 0;
    }
    let frame = Frame::new(p, drops, avx2);
    if drops.glints {
        streaks
            .par_chunks_mut(CHUNK)
            .zip(glints.par_chunks_mut(GLINTS_PER_DROP * CHUNK))
            .enumerate()
            .map(|(k, (s, g))| run_chunk(&frame, k * CHUNK, s, g))
            .sum()
    } else {
        streaks
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(|(k, s)| run_chunk(&frame, k * CHUNK, s, &mut []))
            .sum()
    }
}

/// Whether the CPU runs AVX2.
fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// The frame's constants, formed once.
struct Frame<'a> {
    p: &'a RainParams,
    columns: &'a [Column],
    seed_hash: u32,
    /// 1 − exp(−Λ (D_max − D_min)): the truncated size distribution's mass.
    tail: f64,
    speed_q: [i32; SPEED_TABLE_LEN],
    max_radius_px: f32,
    /// The frame's compact lights and their table.
    lit: Lit<'a>,
    glints: bool,
    /// Whether the steps' AVX2 builds run (asked for, and the CPU has AVX2).
    avx2: bool,
}

impl<'a> Frame<'a> {
    fn new(p: &'a RainParams, drops: &Drops<'a>, avx2: bool) -> Frame<'a> {
        Frame {
            p,
            columns: drops.columns,
            seed_hash: pcg_hash(p.seed),
            tail: 1.0 - (-p.lambda_per_mm as f64 * (p.d_max_mm - p.d_min_mm) as f64).exp(),
            speed_q: p.speed_q.map(|v| v as i32),
            max_radius_px: NEAR_FIELD_MAX_RADIUS as f32 * p.display_size_px[1],
            lit: Lit::new(drops.lights, drops.table),
            glints: drops.glints,
            avx2: avx2 && has_avx2(),
        }
    }
}

/// Defines `$name(avx2, args…)`: `$inner(args…)`, compiled a second time for AVX2 (8 lanes a
/// vector, gathers, shifts by lane) and run that way where `avx2` (the CPU has it). Each step
/// is a function of its own so the vectoriser sees its loops whole.
macro_rules! with_avx2 {
    ($(fn $name:ident = $inner:ident($($arg:ident: $ty:ty),*) -> $ret:ty;)*) => {$(
        #[inline(never)]
        fn $name(avx2: bool, $($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            if avx2 {
                #[target_feature(enable = "avx2")]
                fn fast($($arg: $ty),*) -> $ret {
                    $inner($($arg),*)
                }
                // SAFETY: `avx2` is set only where the CPU has AVX2 (`Frame::new`).
                return unsafe { fast($($arg),*) };
            }
            #[cfg(not(target_arch = "x86_64"))]
            let _ = avx2;
            $inner($($arg),*)
        }
    )*};
}

with_avx2! {
    fn states_on = states(f: &Frame, id0: u32, cols: &[u32; LANES]) -> States;
    fn shapes_on = shapes(f: &Frame, s: &States) -> Shapes;
    fn views_on = view_cosines(p: &RainParams, s: &States) -> [f32; LANES];
    fn info_on = drop_info(s: &States, cosines: &[f32; LANES], visible: &[u8]) -> [u32; LANES];
    fn light_on = light_ends(
        p: &RainParams,
        lit: &Lit,
        ends: &[[[f32; LANES]; 3]; 2],
        visible: &[u8]
    ) -> [[f32; 3]; 2 * LANES];
}

/// The drops `first..first + streaks.len()`; returns how many can be drawn.
fn run_chunk(f: &Frame, first: usize, streaks: &mut [Streak], glints: &mut [Glint]) -> usize {
    chunk(f, first, streaks, glints)
}

#[inline(always)]
fn chunk(f: &Frame, first: usize, streaks: &mut [Streak], glints: &mut [Glint]) -> usize {
    let columns = f.columns;
    // The column of the chunk's first drop: the last whose first drop is at or before it.
    let mut col = columns
        .partition_point(|c| c.first_drop as usize <= first)
        .saturating_sub(1);
    let mut drawn = 0;
    for (b, out) in streaks.chunks_mut(LANES).enumerate() {
        let id0 = first + b * LANES;
        let mut cols = [0u32; LANES];
        for (l, c) in cols.iter_mut().enumerate().take(out.len()) {
            while col + 1 < columns.len() && columns[col + 1].first_drop as usize <= id0 + l {
                col += 1;
            }
            *c = col as u32;
        }
        let last = cols[out.len() - 1];
        for c in &mut cols[out.len()..] {
            *c = last;
        }
        let g = if f.glints {
            &mut glints[GLINTS_PER_DROP * b * LANES..][..GLINTS_PER_DROP * out.len()]
        } else {
            &mut []
        };
        drawn += block(f, id0 as u32, &cols, out, g);
    }
    drawn
}

/// The drops' states in a block (WGSL `DropState`).
struct States {
    pos: [[f32; LANES]; 3],
    vel: [[f32; LANES]; 3],
    diameter_mm: [f32; LANES],
    width_mm: [f32; LANES],
    falls: [bool; LANES],
}

/// The block's streaks before their light (WGSL `segment_streak`).
struct Shapes {
    q0: [[f32; LANES]; 2],
    dir: [[f32; LANES]; 2],
    len: [f32; LANES],
    r_eff: [f32; LANES],
    alpha: [f32; LANES],
    ends: [[[f32; LANES]; 3]; 2],
    drawn: [bool; LANES],
}

/// Drops `id0..id0 + out.len()` (in columns `cols`, lanes past the end repeat the last):
/// their streaks into `out`, glints into `glints` where on; returns how many can be drawn.
#[inline(always)]
fn block(
    f: &Frame,
    id0: u32,
    cols: &[u32; LANES],
    out: &mut [Streak],
    glints: &mut [Glint],
) -> usize {
    let s = states_on(f.avx2, f, id0, cols);
    let sh = shapes_on(f.avx2, f, &s);
    let mut visible = [0u8; LANES];
    let mut n = 0;
    for l in 0..out.len() {
        if sh.drawn[l] {
            visible[n] = l as u8;
            n += 1;
        } else {
            out[l] = HIDDEN;
            if f.glints {
                glints[GLINTS_PER_DROP * l..][..GLINTS_PER_DROP].fill(NO_GLINT);
            }
        }
    }
    if n == 0 {
        return 0;
    }
    let visible = &visible[..n];
    let radiance = light_on(f.avx2, f.p, &f.lit, &sh.ends, visible);
    let info = info_on(f.avx2, &s, &views_on(f.avx2, f.p, &s), visible);
    for (k, &l) in visible.iter().enumerate() {
        let l = l as usize;
        let end = |e: usize| {
            let c = radiance[e * n + k];
            [c[0], c[1], c[2], sh.ends[e][2][l]]
        };
        out[l] = Streak {
            q0_px: [sh.q0[0][l], sh.q0[1][l]],
            dir: [sh.dir[0][l], sh.dir[1][l]],
            len_px: sh.len[l],
            r_eff_px: sh.r_eff[l],
            alpha_scale: sh.alpha[l],
            drop_info: info[k],
            radiance0: end(0),
            radiance1: end(1),
        };
        if f.glints {
            let pos = [s.pos[0][l], s.pos[1][l], s.pos[2][l]];
            let vel = [s.vel[0][l], s.vel[1][l], s.vel[2][l]];
            let g: &mut [Glint; GLINTS_PER_DROP] = (&mut glints[GLINTS_PER_DROP * l..]
                [..GLINTS_PER_DROP])
                .try_into()
                .expect("glints per drop");
            take_glints(f.p, &f.lit, pos, vel, &mut out[l], g);
        }
    }
    n
}

/// PCG integer hash (common/rng.wgsl).
#[inline(always)]
pub(super) fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// `stream · 0x9E3779B9`, the stream's key in the drop's hash.
#[inline(always)]
pub(super) fn stream_key(stream: u32) -> u32 {
    stream.wrapping_mul(0x9E37_79B9)
}

/// 24 random bits → [0, 1).
#[inline(always)]
pub(super) fn unit(bits: u32) -> f32 {
    bits as f32 * (1.0 / 16_777_216.0)
}

#[inline(always)]
pub(super) fn fract(x: f32) -> f32 {
    x - x.floor()
}

/// `a` where `c`, else `b`; both already formed, so the loop gets a blend, not a branch.
#[inline(always)]
fn select(c: bool, a: f32, b: f32) -> f32 {
    if c { a } else { b }
}

/// WGSL `mix`: `a (1 − t) + b t`.
#[inline(always)]
pub(super) fn mix(a: f32, b: f32, t: f32) -> f32 {
    a * (1.0 - t) + b * t
}

/// The drops' states at the frame's time (WGSL `drop_state`, common/drops.wgsl).
#[inline(always)]
fn states(f: &Frame, id0: u32, cols: &[u32; LANES]) -> States {
    let p = f.p;
    let mut base = [0u32; LANES];
    let mut keep = [0u32; LANES];
    let mut inv_height = [0u32; LANES];
    let mut cell = [[0f32; LANES]; 2];
    let mut z_lo = [0f32; LANES];
    let mut height = [0f32; LANES];
    // The columns' fields gathered first, so the loops below index nothing but their lanes.
    for l in 0..LANES {
        let c = &f.columns[cols[l] as usize];
        keep[l] = c.size_keep_q.min(1 << 24);
        inv_height[l] = c.inv_height_q;
        cell[0][l] = c.cell_min_m[0];
        cell[1][l] = c.cell_min_m[1];
        z_lo[l] = c.z_lo_m;
        height[l] = c.height_m;
    }
    for l in 0..LANES {
        base[l] = pcg_hash(f.seed_hash ^ id0.wrapping_add(l as u32));
    }
    // The size quantile (size_bits), the fall speed of its table entry (fall_speed_q).
    let mut q_unit = [0f64; LANES];
    let mut speed = [0u32; LANES];
    for l in 0..LANES {
        (q_unit[l], speed[l]) = size_and_speed(&f.speed_q, base[l], keep[l]);
    }
    // Library calls: the diameter by inverse CDF, the width of the oblate drop. The CDF's
    // complement in f64: for the largest drops 1 − u·tail is a few 10⁻⁶, where f32 (as the
    // WGSL has it) would lose a few per cent of it and ~0.01 mm of the diameter.
    let mut d_mm = [0f32; LANES];
    let mut width_factor = [0f32; LANES];
    for l in 0..LANES {
        let d = diameter_mm(p, f.tail, q_unit[l]);
        d_mm[l] = d;
        let x = d.clamp(0.0, 7.0);
        let ratio =
            (1.0048 + x * (5.7e-4 + x * (-2.628e-2 + x * (3.682e-3 + x * -1.677e-4)))).min(1.0);
        width_factor[l] = ratio.powf(-1.0 / 3.0);
    }
    // Velocity and drift: the gusts' steady-state response (drop_phase).
    let mut vh = [[p.wind_mean_mps[0]; LANES], [p.wind_mean_mps[1]; LANES]];
    let mut gust = [[0f32; LANES]; 2];
    let mut vt = [0f32; LANES];
    let mut tau = [0f32; LANES];
    for l in 0..LANES {
        vt[l] = speed[l] as f32 * (1.0 / (1u32 << SPEED_BITS) as f32);
        tau[l] = vt[l] / p.gravity_mps2;
    }
    for k in 0..GUSTS {
        let a = p.gust_amp[k];
        let ph = p.gust_phase[k];
        for l in 0..LANES {
            let wt = a[2] * tau[l];
            let den = 1.0 + wt * wt;
            let along = (ph[0] + wt * ph[1]) / den;
            vh[0][l] += a[0] * along;
            vh[1][l] += a[1] * along;
            let s1 = (ph[1] - wt * ph[0]) / den;
            let s0 = (ph[3] - wt * ph[2]) / den;
            let shift = (s1 - s0) / a[2];
            gust[0][l] += a[0] * shift;
            gust[1][l] += a[1] * shift;
        }
    }
    if p.wind_kink_count > 0 {
        wind_lag(p, &tau, &mut vh, &mut gust);
    }
    // The fall in column heights, the whole seconds in exact integers.
    let mut x = [0f32; LANES];
    let mut pass = [0u32; LANES];
    let mut rate = [0f32; LANES];
    for l in 0..LANES {
        (x[l], pass[l], rate[l]) = fall(p, base[l], speed[l], inv_height[l]);
    }
    // Drift in cells and the pass's own lateral offset (lateral_fractions), the position.
    let mut pos = [[0f32; LANES]; 3];
    let mut w = [0f32; LANES];
    for l in 0..LANES {
        let cycle = pcg_hash(pass[l]);
        let mut uv = [0f32; 2];
        for a in 0..2 {
            let duv = drift_cells(p, speed[l], gust[a][l], a);
            let own = unit(pcg_hash(base[l] ^ stream_key(a as u32)) >> 8);
            let cyc = unit(pcg_hash(base[l] ^ stream_key(4 + a as u32) ^ cycle) >> 8);
            let frac = fract(own + fract(duv) + cyc);
            uv[a] = cell[a][l] + p.cell_size_m[a] * frac;
        }
        w[l] = fract(x[l]);
        let z = z_lo[l] + w[l] * height[l];
        pos[0][l] = uv[0] + p.column_slope[0] * z;
        pos[1][l] = uv[1] + p.column_slope[1] * z;
        pos[2][l] = z;
    }
    let mut s = States {
        pos,
        vel: [vh[0], vh[1], vt.map(|v| -v)],
        diameter_mm: d_mm.map(|d| d * p.diameter_scale),
        width_mm: [0.0; LANES],
        falls: [true; LANES],
    };
    for l in 0..LANES {
        s.width_mm[l] = s.diameter_mm[l] * width_factor[l];
    }
    if p.rate_key_count > 0 {
        for l in 0..LANES {
            let id = id0.wrapping_add(l as u32);
            s.falls[l] = falls(p, f.seed_hash, id, pass[l], (1.0 - w[l]) / rate[l], d_mm[l]);
        }
    }
    s
}

/// How far the drops (time constants `tau`) lag a keyed mean wind (WGSL `wind_lag`), added
/// to their velocity `vh` and displacement `gust`.
fn wind_lag(
    p: &RainParams,
    tau: &[f32; LANES],
    vh: &mut [[f32; LANES]; 2],
    gust: &mut [[f32; LANES]; 2],
) {
    for l in 0..LANES {
        let (vel, disp) = lag(p, tau[l]);
        for a in 0..2 {
            vh[a][l] += vel[a];
            gust[a][l] += disp[a];
        }
    }
}

/// The velocity and displacement a drop with time constant `t` lags a keyed mean wind by
/// (WGSL `wind_lag`).
#[inline(always)]
pub(super) fn lag(p: &RainParams, t: f32) -> ([f32; 2], [f32; 2]) {
    let mut vel = [-t * p.wind_slope_mps2[0], -t * p.wind_slope_mps2[1]];
    let mut disp = [
        -t * (p.wind_mean_mps[0] - p.wind_start_mps[0]),
        -t * (p.wind_mean_mps[1] - p.wind_start_mps[1]),
    ];
    for k in &p.wind_kinks[..(p.wind_kink_count as usize).min(p.wind_kinks.len())] {
        let e = (-k[0] / t).exp();
        for a in 0..2 {
            vel[a] += k[1 + a] * (t * e);
            disp[a] += k[1 + a] * (t * t * (1.0 - e));
        }
    }
    (vel, disp)
}

/// The size quantile of the drop whose hash is `base` in a column keeping `keep` (2⁻²⁴) of
/// the sizes, as a unit (WGSL `size_bits`), and its fall speed, 2^-SPEED_BITS m/s, from the
/// frame's table `speed_q` (`fall_speed_q`).
#[inline(always)]
pub(super) fn size_and_speed(speed_q: &[i32; SPEED_TABLE_LEN], base: u32, keep: u32) -> (f64, u32) {
    let r = 0xFF_FFFF - (pcg_hash(base ^ stream_key(3)) >> 8);
    let q = 0xFF_FFFF - ((r as u64 * keep as u64) >> 24) as u32;
    let q_unit = q as f64 * (1.0 / 16_777_216.0);
    let r = (0xFF_FFFF - q).max(1);
    // ⌊log₂ r⌋ from the exponent of r as f32 (exact below 2²⁴).
    let e = ((r as f32).to_bits() >> 23) - 127;
    let f12 = if e >= 12 {
        (r >> (e - 12)) & 0xFFF
    } else {
        (r << (12 - e)) & 0xFFF
    };
    let j = (e << SPEED_STEPS_LOG2) + (f12 >> (12 - SPEED_STEPS_LOG2));
    let g = (f12 & ((1 << (12 - SPEED_STEPS_LOG2)) - 1)) as i32;
    let k = (j + 1).min(SPEED_TABLE_LEN as u32 - 1);
    let a = speed_q[(j as usize).min(SPEED_TABLE_LEN - 1)];
    let b = speed_q[k as usize];
    (
        q_unit,
        (a + (((b - a) * g) >> (12 - SPEED_STEPS_LOG2))) as u32,
    )
}

/// The diameter, mm, at the size quantile `q_unit` by inverse CDF (WGSL
/// `diameter_from_unit`), `tail` the truncated distribution's mass; the CDF's complement in
/// f64 (see [`states`]).
#[inline(always)]
pub(super) fn diameter_mm(p: &RainParams, tail: f64, q_unit: f64) -> f32 {
    (p.d_min_mm as f64 - (1.0 - q_unit * tail).ln() / p.lambda_per_mm as f64) as f32
}

/// The fall of the drop whose hash is `base`, falling at `speed` (2^-SPEED_BITS m/s) in a
/// column of inverse height `inv_height` (2^-INV_HEIGHT_BITS m⁻¹), at the frame's time: its
/// height in column heights before wrapping, its pass and its rate in column heights per
/// second, the whole seconds in exact integers (WGSL `drop_phase`).
#[inline(always)]
pub(super) fn fall(p: &RainParams, base: u32, speed: u32, inv_height: u32) -> (f32, u32, f32) {
    let shift = SPEED_BITS + INV_HEIGHT_BITS - FALL_RATE_BITS;
    let prod = speed as u64 * inv_height as u64;
    let rate_q = if prod >> (32 + shift) != 0 {
        u32::MAX
    } else {
        (prod >> shift) as u32
    };
    let whole = rate_q as u64 * p.time_whole_s as u64;
    let passes = (whole >> FALL_RATE_BITS) as u32;
    let whole_frac = (whole as u32 & ((1 << FALL_RATE_BITS) - 1)) as f32
        * (1.0 / (1u32 << FALL_RATE_BITS) as f32);
    let rate = rate_q as f32 * (1.0 / (1u32 << FALL_RATE_BITS) as f32);
    let u2 = unit(pcg_hash(base ^ stream_key(2)) >> 8);
    let x = u2 - whole_frac - rate * p.time_frac_s;
    (x, (x.floor() as i32 as u32).wrapping_sub(passes), rate)
}

/// The drift in cells along axis `a` of a drop falling at `speed` (2^-SPEED_BITS m/s) with
/// the gusts' displacement `gust_m`, before its pass's own offset: the columns' shear (exact
/// for the whole seconds), the mean wind, the gusts (WGSL `drop_phase`'s `duv`).
#[inline(always)]
pub(super) fn drift_cells(p: &RainParams, speed: u32, gust_m: f32, a: usize) -> f32 {
    let mask = (1u32 << DRIFT_PHASE_BITS) - 1;
    let drift_unit = 1.0 / (1u32 << DRIFT_PHASE_BITS) as f32;
    let drift = (speed as i32).wrapping_mul(p.drift_q[a]) as u32;
    let whole = (drift.wrapping_mul(p.time_whole_s) & mask) as f32 * drift_unit;
    let per_s = speed as f32 * p.drift_q[a] as f32 * drift_unit;
    whole + per_s * p.time_frac_s + p.mean_travel_cells[a] + gust_m / p.cell_size_m[a]
}

/// The keyed rate `s` seconds from the frame's time (WGSL `rate_at`).
fn rate_at(p: &RainParams, s: f32) -> f32 {
    let keys = &p.rate_keys[..(p.rate_key_count as usize).clamp(1, p.rate_keys.len())];
    if s <= keys[0][0] {
        return keys[0][1];
    }
    for pair in keys.windows(2) {
        let (k0, k1) = (pair[0], pair[1]);
        if s < k1[0] {
            return mix(k0[1], k1[1], (s - k0[0]) / (k1[0] - k0[0]));
        }
    }
    keys[keys.len() - 1][1]
}

/// Whether drop `id` falls in its pass `pass`, born `age_s` ago (WGSL `falls`).
pub(super) fn falls(
    p: &RainParams,
    seed_hash: u32,
    id: u32,
    pass: u32,
    age_s: f32,
    d_mm: f32,
) -> bool {
    let r = rate_at(p, -age_s);
    if r <= 0.0 {
        return false;
    }
    let excess =
        (MP_LAMBDA_COEFF as f32 * r.powf(-(MP_LAMBDA_EXPONENT as f32)) - p.lambda_per_mm).max(0.0);
    let h = pcg_hash(pcg_hash(seed_hash ^ id) ^ stream_key(RATE_STREAM) ^ pcg_hash(pass));
    unit(h >> 8) < (-excess * d_mm).exp()
}

/// World point → camera frame (WGSL `to_camera`).
#[inline(always)]
pub(super) fn to_camera(p: &RainParams, w: [f32; 3]) -> [f32; 3] {
    let d = [
        w[0] - p.camera_pos_m[0],
        w[1] - p.camera_pos_m[1],
        w[2] - p.camera_pos_m[2],
    ];
    let row = |r: &[f32; 4]| r[0] * d[0] + r[1] * d[1] + r[2] * d[2];
    [
        row(&p.camera_from_world_0),
        row(&p.camera_from_world_1),
        row(&p.camera_from_world_2),
    ]
}

/// The drops' streaks over the exposure (WGSL `streak_of` and `segment_streak`), without the
/// light.
#[inline(always)]
fn shapes(f: &Frame, s: &States) -> Shapes {
    let p = f.p;
    let mut sh = Shapes {
        q0: [[0.0; LANES]; 2],
        dir: [[0.0; LANES]; 2],
        len: [0.0; LANES],
        r_eff: [0.0; LANES],
        alpha: [0.0; LANES],
        ends: [[[0.0; LANES]; 3]; 2],
        drawn: [false; LANES],
    };
    let half_t = 0.5 * p.exposure_s;
    let near = p.near_clip_m;
    let fpx = p.focal_px;
    for l in 0..LANES {
        let pos = [s.pos[0][l], s.pos[1][l], s.pos[2][l]];
        let half = [
            s.vel[0][l] * half_t,
            s.vel[1][l] * half_t,
            s.vel[2][l] * half_t,
        ];
        let w0 = [pos[0] - half[0], pos[1] - half[1], pos[2] - half[2]];
        let w1 = [pos[0] + half[0], pos[1] + half[1], pos[2] + half[2]];
        // Impact on the ground during the exposure: the streak ends there.
        // `&` and `|`, not `&&` and `||`: no branches in the vectorised loop.
        let lands = (p.ground_clip != 0) & (w1[2] < 0.0);
        let landed = lands & (w0[2] <= 0.0);
        // Both sides formed, one picked: blends, not branches.
        let exposed = select(lands, w0[2] / (w0[2] - w1[2]), 1.0);
        let w1: [f32; 3] =
            std::array::from_fn(|a| select(lands, mix(w0[a], w1[a], exposed), w1[a]));
        let (c0, c1) = (to_camera(p, w0), to_camera(p, w1));
        let behind = (c0[2] < near) & (c1[2] < near);
        // Clipped to the near plane, the start first (the WGSL's order).
        let t0 = (near - c0[2]) / (c1[2] - c0[2]);
        let c0: [f32; 3] =
            std::array::from_fn(|a| select(c0[2] < near, mix(c0[a], c1[a], t0), c0[a]));
        let t1 = (near - c1[2]) / (c0[2] - c1[2]);
        let c1: [f32; 3] =
            std::array::from_fn(|a| select(c1[2] < near, mix(c1[a], c0[a], t1), c1[a]));
        let z = c0[2].min(c1[2]);
        let r = 0.5e-3 * s.width_mm[l] * fpx / z;
        let q0 = [
            p.principal_px[0] + fpx * c0[0] / c0[2],
            p.principal_px[1] + fpx * c0[1] / c0[2],
        ];
        let q1 = [
            p.principal_px[0] + fpx * c1[0] / c1[2],
            p.principal_px[1] + fpx * c1[1] / c1[2],
        ];
        let blur = 0.5 * p.lens_blur_k_px_m * (p.inv_focus_per_m - 1.0 / z).abs();
        let r_eff = (r * r + blur * blur)
            .sqrt()
            .max(MIN_RADIUS_PX as f32)
            .min(f.max_radius_px);
        let seg = [q1[0] - q0[0], q1[1] - q0[1]];
        let len = (seg[0] * seg[0] + seg[1] * seg[1]).sqrt();
        let long = len > 1e-4;
        let dir = [
            select(long, seg[0] / len, 0.0),
            select(long, seg[1] / len, 1.0),
        ];
        let alpha = r * r / (r_eff * r_eff) * p.opacity * p.drop_weight * exposed;
        let peak = alpha * (2.0 * r_eff / len.max(1e-3)).min(1.0);
        let ext = r_eff + 1.0;
        let off = (q0[0].max(q1[0]) + ext < 0.0)
            | (q0[1].max(q1[1]) + ext < 0.0)
            | (q0[0].min(q1[0]) - ext > p.display_size_px[0])
            | (q0[1].min(q1[1]) - ext > p.display_size_px[1]);
        sh.drawn[l] = s.falls[l] & !landed & !behind & (peak >= MIN_PEAK_ALPHA as f32) & !off;
        sh.q0[0][l] = q0[0];
        sh.q0[1][l] = q0[1];
        sh.dir[0][l] = dir[0];
        sh.dir[1][l] = dir[1];
        sh.len[l] = len;
        sh.r_eff[l] = r_eff;
        sh.alpha[l] = alpha;
        for a in 0..3 {
            sh.ends[0][a][l] = c0[a];
            sh.ends[1][a][l] = c1[a];
        }
    }
    sh
}

/// |cos| of the angle between each lane's view ray and its fall, at most 1 (WGSL
/// `drop_info`'s `abs(dot(view, fall))`), for every lane: the lanes side by side.
#[inline(always)]
fn view_cosines(p: &RainParams, s: &States) -> [f32; LANES] {
    let mut out = [0f32; LANES];
    for l in 0..LANES {
        let pos = [s.pos[0][l], s.pos[1][l], s.pos[2][l]];
        let view = world_offset(p, to_camera(p, pos));
        let vel = [s.vel[0][l], s.vel[1][l], s.vel[2][l]];
        let speed = (vel[0] * vel[0] + vel[1] * vel[1] + vel[2] * vel[2])
            .sqrt()
            .max(1e-6);
        let len = (view[0] * view[0] + view[1] * view[1] + view[2] * view[2]).sqrt();
        let dot = (view[0] / len) * (vel[0] / speed)
            + (view[1] / len) * (vel[1] / speed)
            + (view[2] / len) * (vel[2] / speed);
        out[l] = dot.abs().min(1.0);
    }
    out
}

/// The matte's bins of each drawn drop (WGSL `drop_info`): pack2x16unorm(diameter / 10 mm,
/// elevation of the view over the plane normal to the fall / 90°), `cosines` from
/// [`view_cosines`].
#[inline(always)]
fn drop_info(s: &States, cosines: &[f32; LANES], visible: &[u8]) -> [u32; LANES] {
    // The library's `asin` one drawn drop at a time, the packing in lanes.
    let (mut size, mut view) = ([0f32; LANES], [0f32; LANES]);
    for (k, &l) in visible.iter().enumerate() {
        let l = l as usize;
        size[k] = s.diameter_mm[l] / 10.0;
        view[k] = cosines[l].asin().to_degrees() / 90.0;
    }
    let mut info = [0u32; LANES];
    for k in 0..LANES {
        info[k] = unorm16(size[k]) | unorm16(view[k]) << 16;
    }
    info
}

/// `x` in [0, 1] to 16 bits, rounded half away from zero as `f32::round` (NaN: 0), without its
/// library call: below 2¹⁶ a value less its whole part is exact.
#[inline(always)]
fn unorm16(x: f32) -> u32 {
    let y = x.clamp(0.0, 1.0) * 65535.0;
    // Within i32 (NaN: 0): the conversion the lanes have.
    let whole = y as i32;
    (whole + i32::from(y - whole as f32 >= 0.5)) as u32
}

#[cfg(test)]
mod tests {
    use super::unorm16;

    /// The rounding without the library call is `f32::round`'s: at every half-way point
    /// between two codes and the values a few steps either side, across the unit by a stride
    /// through the bit patterns, and outside it (NaN included).
    #[test]
    fn unorm16_rounds_as_the_library() {
        let library = |x: f32| (x.clamp(0.0, 1.0) * 65535.0).round() as u32;
        let mut xs = vec![f32::NAN, -1.0, -0.0, 0.0, 1.0, 2.0, f32::INFINITY];
        for k in 0..65535u32 {
            let half = (k as f32 + 0.5) / 65535.0;
            for d in -3i32..=3 {
                xs.push(f32::from_bits(half.to_bits().wrapping_add_signed(d)));
            }
        }
        xs.extend((0..1.0f32.to_bits()).step_by(97).map(f32::from_bits));
        let mut halves = 0;
        for x in xs {
            let y = x.clamp(0.0, 1.0) * 65535.0;
            halves += usize::from(y.fract() == 0.5);
            assert_eq!(unorm16(x), library(x), "{x:e}");
        }
        assert!(halves > 1000, "{halves} values exactly half-way");
    }
}
