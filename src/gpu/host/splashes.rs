//! The splashes of a frame simulated on the CPU (the `rain_splashes` stage's compute half, for
//! the CPU back end): each drop of a column standing on the ground → the streaks of its latest
//! splash, lit, and only those that can be drawn, packed in the order the stage's draw list
//! holds them (drop after drop in the landing columns' order, the crown before the droplets),
//! for [`super::streaks`] to draw before the drops' own streaks. Nothing goes to the adapter.
//!
//! ## How it works
//! The WGSL's arithmetic in `f32`, step for step, with the drop's fall and drift from the same
//! helpers as [`super::simulate`] (so the diameter's CDF complement is `f64` there as here).
//! The drop's impact time and size are found first, and a drop whose splash is over (or never
//! was) leaves before its drift and place are formed. A splash's crown and droplets become
//! streaks (`segment_streak`), the droplets skipped as a whole where none can be a pixel wide
//! wherever it flies (a bound with wide margins: no bit changes), and the streaks are lit in
//! blocks of [`LANES`] across their ends by [`super::drop_light`]. rayon's threads take chunks
//! of [`CHUNK`] landing drops, each chunk writing its own list, and the lists are joined in
//! chunk order: neither the threads nor the chunks change a bit. The plain twin
//! ([`crate::gpu::cpu::rain_splashes`], `f64`, from the splash model) is the reference
//! (`tests/splashes.rs`).

use rayon::prelude::*;

use super::drop_light::{LightTable, Lit, light_ends};
use super::simulate::{
    HIDDEN, LANES, diameter_mm, drift_cells, fall, falls, fract, lag, mix, pcg_hash,
    size_and_speed, stream_key, to_camera, unit,
};
use crate::gpu::stages::rain_splashes::landing_list;
use crate::gpu::types::{Column, GUSTS, LightList, RainParams, Streak};
use crate::gpu::uniforms::RainSetup;
use crate::lighting::RtfTable;
use crate::rain::physics::splash::{
    CROWN_S, DROPLET_RATIO, EJECTED_FRACTION_MAX, LAUNCH_ELEVATION_DEG, LAUNCH_SPEED, MAX_DROPLETS,
    SPLASH_SLOTS, SPLASH_STREAM, SPLASH_THRESHOLD_K, splash_k_coefficient,
};
use crate::rain::physics::{MIN_PEAK_ALPHA, MIN_RADIUS_PX};
use crate::rain::volume::drop::{SPEED_BITS, SPEED_TABLE_LEN};

/// Landing drops per rayon task.
pub const CHUNK: usize = 1024;

/// The splash model's constants as the WGSL has them (`gpu::shaders`: `f32` of the `f64`).
const CROWN: f32 = CROWN_S as f32;
const THRESHOLD_K: f32 = SPLASH_THRESHOLD_K as f32;
const EJECTED: f32 = EJECTED_FRACTION_MAX as f32;
const DROPLET: f32 = DROPLET_RATIO as f32;
const SPEED: [f32; 2] = [LAUNCH_SPEED[0] as f32, LAUNCH_SPEED[1] as f32];
const ELEVATION_DEG: [f32; 2] = [
    LAUNCH_ELEVATION_DEG[0] as f32,
    LAUNCH_ELEVATION_DEG[1] as f32,
];
/// The WGSL's `PI`.
const PI: f32 = std::f32::consts::PI;
/// No cap on a splash streak's width (the WGSL's 3.0e38).
const UNCAPPED_PX: f32 = 3.0e38;

/// The splashes of a rain on the CPU: its landing drops, the lights they are lit by and the
/// last frame's list (kept to reuse its memory).
pub struct HostSplashes {
    /// The columns standing on the ground.
    columns: Vec<Column>,
    /// The landing drops in the stage's order: (drop id, index into `columns`).
    drops: Vec<[u32; 2]>,
    lights: LightList,
    table: Option<LightTable>,
    drawn: Vec<Streak>,
}

impl HostSplashes {
    /// The splashes of `rain`: `None` without a ground or without a column standing on it.
    /// Every landing drop is handled (the GPU stage holds as many as one storage binding does).
    pub fn new(rain: &RainSetup) -> Option<HostSplashes> {
        if rain.params.ground_clip == 0 {
            return None;
        }
        let (list, _) = landing_list(rain, u64::from(u32::MAX));
        let columns: Vec<Column> = list
            .iter()
            .map(|&[ci, _]| rain.columns[ci as usize])
            .collect();
        let drops: Vec<[u32; 2]> = columns
            .iter()
            .enumerate()
            .flat_map(|(k, c)| {
                (c.first_drop..c.first_drop + c.drop_count).map(move |id| [id, k as u32])
            })
            .collect();
        (!drops.is_empty()).then(|| HostSplashes {
            columns,
            drops,
            lights: LightList::new(&[]),
            table: None,
            drawn: Vec::new(),
        })
    }

    /// The landing drops, in the stage's order (the g-th has its slots at g·`SPLASH_SLOTS`).
    pub fn drop_ids(&self) -> Vec<u32> {
        self.drops.iter().map(|d| d[0]).collect()
    }

    /// The compact lights of the frames from now on.
    pub fn set_lights(&mut self, lights: &LightList) {
        self.lights = *lights;
    }

    /// The drop's transfer table the lights are seen through; until it is set they add
    /// nothing (as on the GPU).
    pub fn set_transfer_table(&mut self, tables: &[RtfTable; 3]) {
        self.table = Some(LightTable::new(&crate::gpu::lights::table_texels(tables)));
    }

    /// The frame's splash streaks under `p` that can be drawn, in the stage's draw-list order.
    pub fn simulate(&mut self, p: &RainParams) -> &[Streak] {
        let lists = self.chunks(p, true);
        self.drawn.clear();
        for (streaks, _) in lists {
            self.drawn.extend_from_slice(&streaks);
        }
        &self.drawn
    }

    /// Every slot of every landing drop, as the stage's `splashes` buffer holds them
    /// (`SPLASH_SLOTS` per drop, hidden where nothing is drawn).
    pub fn slots(&self, p: &RainParams) -> Vec<Streak> {
        self.slots_culled(p, true)
    }

    /// [`slots`](Self::slots) with every droplet's streak formed, none skipped for being
    /// thinner than a pixel as a whole splash: the reference the cull is held to.
    pub fn slots_uncut(&self, p: &RainParams) -> Vec<Streak> {
        self.slots_culled(p, false)
    }

    fn slots_culled(&self, p: &RainParams, cull: bool) -> Vec<Streak> {
        let mut out = vec![HIDDEN; self.drops.len() * SPLASH_SLOTS as usize];
        for (streaks, at) in self.chunks(p, cull) {
            for (s, &i) in streaks.iter().zip(&at) {
                out[i as usize] = *s;
            }
        }
        out
    }

    /// Each chunk's drawn streaks and their slots' indices, in chunk order.
    fn chunks(&self, p: &RainParams, cull: bool) -> Vec<(Vec<Streak>, Vec<u32>)> {
        let frame = Frame::new(p, &self.lights, self.table.as_ref(), cull);
        self.drops
            .par_chunks(CHUNK)
            .enumerate()
            .map(|(k, drops)| {
                let mut list = List::default();
                for (i, &[id, c]) in drops.iter().enumerate() {
                    let g = (k * CHUNK + i) as u32;
                    splash(&frame, id, &self.columns[c as usize], g, &mut list);
                }
                list.light(&frame);
                (list.streaks, list.at)
            })
            .collect()
    }
}

/// The frame's constants, formed once.
struct Frame<'a> {
    p: &'a RainParams,
    seed_hash: u32,
    /// 1 − exp(−Λ (D_max − D_min)): the truncated size distribution's mass.
    tail: f64,
    speed_q: [i32; SPEED_TABLE_LEN],
    k_coefficient: f32,
    /// sin of the steepest launch, and the droplet's diameter ratio cubed.
    sin_elevation_max: f32,
    droplet_cubed: f32,
    lit: Lit<'a>,
    /// Whether a splash's droplets are skipped where every one is thinner than a pixel.
    cull: bool,
}

impl<'a> Frame<'a> {
    fn new(
        p: &'a RainParams,
        lights: &LightList,
        table: Option<&'a LightTable>,
        cull: bool,
    ) -> Frame<'a> {
        Frame {
            p,
            seed_hash: pcg_hash(p.seed),
            tail: 1.0 - (-p.lambda_per_mm as f64 * (p.d_max_mm - p.d_min_mm) as f64).exp(),
            speed_q: p.speed_q.map(|v| v as i32),
            k_coefficient: splash_k_coefficient() as f32,
            sin_elevation_max: ELEVATION_DEG[1].to_radians().sin(),
            droplet_cubed: DROPLET.powf(3.0),
            lit: Lit::new(lights, table),
            cull,
        }
    }
}

/// A chunk's streaks: those lit, then up to [`LANES`] waiting for their light (with their
/// ends in the camera's frame), and each one's slot index (g · `SPLASH_SLOTS` + slot).
#[derive(Default)]
struct List {
    streaks: Vec<Streak>,
    at: Vec<u32>,
    waiting: usize,
    ends: [[[f32; LANES]; 3]; 2],
}

impl List {
    fn push(&mut self, f: &Frame, at: u32, streak: Streak, ends: [[f32; 3]; 2]) {
        for (lanes, end) in self.ends.iter_mut().zip(ends) {
            for (lane, x) in lanes.iter_mut().zip(end) {
                lane[self.waiting] = x;
            }
        }
        self.streaks.push(streak);
        self.at.push(at);
        self.waiting += 1;
        if self.waiting == LANES {
            self.light(f);
        }
    }

    /// Lights the waiting streaks at both ends (WGSL `drop_radiance`).
    fn light(&mut self, f: &Frame) {
        let n = self.waiting;
        if n == 0 {
            return;
        }
        let lanes: [u8; LANES] = std::array::from_fn(|l| l as u8);
        let radiance = light_ends(f.p, &f.lit, &self.ends, &lanes[..n]);
        let first = self.streaks.len() - n;
        for (k, s) in self.streaks[first..].iter_mut().enumerate() {
            let end = |e: usize| {
                let c = radiance[e * n + k];
                [c[0], c[1], c[2], self.ends[e][2][k]]
            };
            s.radiance0 = end(0);
            s.radiance1 = end(1);
        }
        self.waiting = 0;
    }
}

/// WGSL `crown_radius_m`: the crown's radius `tau_s` after the impact.
#[inline(always)]
fn crown_radius_m(d_m: f32, speed_mps: f32, tau_s: f32) -> f32 {
    (0.25 * d_m * d_m + d_m * speed_mps * tau_s.max(0.0)).sqrt()
}

/// WGSL `crown_height_m`: the crown's height `tau_s` after the impact.
#[inline(always)]
fn crown_height_m(d_m: f32, speed_mps: f32, tau_s: f32) -> f32 {
    if !(0.0..=CROWN).contains(&tau_s) {
        return 0.0;
    }
    (crown_radius_m(d_m, speed_mps, tau_s) - 0.5 * d_m) * (PI * tau_s / CROWN).sin()
}

/// `a + b` per axis.
#[inline(always)]
fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// Landing drop `id` (the g-th, in `col`): the streaks of its latest splash into `list`
/// (WGSL `main`).
fn splash(f: &Frame, id: u32, col: &Column, g: u32, list: &mut List) {
    let p = f.p;
    if p.ground_clip == 0 || id >= p.drop_count {
        return;
    }
    // The fall first (drop_phase): when the drop last met the ground.
    let base = pcg_hash(f.seed_hash ^ id);
    let (q_unit, speed_q) = size_and_speed(&f.speed_q, base, col.size_keep_q.min(1 << 24));
    let (x, pass, rate) = fall(p, base, speed_q, col.inv_height_q);
    if rate <= 0.0 {
        return;
    }
    let w = x - x.floor();
    let half = 0.5 * p.exposure_s;
    // Seconds since its latest impact before the exposure closes (< 0: later in the exposure).
    let (since, pass) = if w / rate <= half {
        (-w / rate, pass)
    } else {
        ((1.0 - w) / rate, pass.wrapping_add(1))
    };
    // An impact before the clip's start did not happen; nor one of a pass a keyed rate leaves
    // out (born one column height before it landed).
    if (p.time_whole_s as f32 + p.time_frac_s) < since {
        return;
    }
    let d_mm = diameter_mm(p, f.tail, q_unit);
    if p.rate_key_count > 0 && !falls(p, f.seed_hash, id, pass, since + 1.0 / rate, d_mm) {
        return;
    }
    let d_m = d_mm * 1e-3;
    let v = speed_q as f32 * (1.0 / (1u32 << SPEED_BITS) as f32);
    let k = f.k_coefficient * d_m.powf(1.2) * v * v;
    if k <= THRESHOLD_K {
        return;
    }
    // Over before the exposure opened: the crown stage, then the longest flight.
    let gravity = p.gravity_mps2;
    let w_max = v * SPEED[1] * f.sin_elevation_max;
    let z_max = crown_radius_m(d_m, v, CROWN);
    let lifetime = CROWN + (w_max + (w_max * w_max + 2.0 * gravity * z_max).sqrt()) / gravity;
    if since - half >= lifetime {
        return;
    }
    // Where: the drift at the frame's time moved back along the drift rate (drop_phase's
    // gusts and wind lag, then lateral_fractions).
    let tau = v / gravity;
    let mut vh = p.wind_mean_mps;
    let mut gust = [0f32; 2];
    for k in 0..GUSTS {
        let (a, ph) = (p.gust_amp[k], p.gust_phase[k]);
        let wt = a[2] * tau;
        let den = 1.0 + wt * wt;
        let along = (ph[0] + wt * ph[1]) / den;
        vh[0] += a[0] * along;
        vh[1] += a[1] * along;
        let shift = ((ph[1] - wt * ph[0]) / den - (ph[3] - wt * ph[2]) / den) / a[2];
        gust[0] += a[0] * shift;
        gust[1] += a[1] * shift;
    }
    if p.wind_kink_count > 0 {
        let (vel, disp) = lag(p, tau);
        for a in 0..2 {
            vh[a] += vel[a];
            gust[a] += disp[a];
        }
    }
    let cycle = pcg_hash(pass);
    let hit: [f32; 3] = {
        let mut uv = [0f32; 2];
        for a in 0..2 {
            let per_s = (vh[a] + p.column_slope[a] * v) / p.cell_size_m[a];
            let duv = drift_cells(p, speed_q, gust[a], a) - per_s * since;
            let own = unit(pcg_hash(base ^ stream_key(a as u32)) >> 8);
            let cyc = unit(pcg_hash(base ^ stream_key(4 + a as u32) ^ cycle) >> 8);
            uv[a] = col.cell_min_m[a] + p.cell_size_m[a] * fract(own + fract(duv) + cyc);
        }
        [uv[0], uv[1], 0.0]
    };
    let scale = p.diameter_scale;
    let at = g * SPLASH_SLOTS;
    // The exposure in seconds after the impact.
    let (a, b) = (since - half, since + half);
    // Crown: the drop's water over a capsule of the crown's radius and height.
    let (c_lo, c_hi) = (a.max(0.0), b.min(CROWN));
    if c_hi > c_lo {
        let tau = 0.5 * (c_lo + c_hi);
        let r = crown_radius_m(d_m, v, tau);
        let h = crown_height_m(d_m, v, tau);
        let cover = PI * 0.25 * d_m * d_m / (2.0 * r * h + PI * r * r);
        let top = add(hit, [0.0, 0.0, h]);
        let exposed = (c_hi - c_lo) / p.exposure_s;
        if let Some((s, ends)) = segment_streak(p, hit, top, exposed, r * scale, cover) {
            list.push(f, at, s, ends);
        }
    }
    // Secondary droplets.
    let ratio = THRESHOLD_K / k;
    let count = EJECTED * (1.0 - ratio) / (f.droplet_cubed * ratio.powf(0.75));
    let drawn = (count.ceil() as u32).clamp(1, MAX_DROPLETS);
    let droplet_m = DROPLET * d_m * ratio.powf(0.25);
    let weight = count / drawn as f32;
    let radius_m = 0.5 * droplet_m * scale;
    // The longest a droplet can have flown when the exposure closes.
    let flown_s = (lifetime - CROWN).min(b).max(0.0);
    if f.cull && thinner_than_a_pixel(p, hit, radius_m, reach_m(v, z_max, flown_s, gravity)) {
        return;
    }
    let pass_hash = pcg_hash(pass);
    let uniform = |stream: u32| unit(pcg_hash(base ^ stream_key(stream) ^ pass_hash) >> 8);
    for j in 0..drawn {
        let stream = SPLASH_STREAM + 4 * j;
        let u: [f32; 4] = std::array::from_fn(|s| uniform(stream + s as u32));
        let azimuth = 2.0 * PI * (j as f32 + u[0]) / drawn as f32;
        let elevation = mix(ELEVATION_DEG[0], ELEVATION_DEG[1], u[1]).to_radians();
        let speed = v * mix(SPEED[0], SPEED[1], u[2]);
        let launch_s = CROWN * u[3];
        let out = [azimuth.cos(), azimuth.sin(), 0.0];
        let radius = crown_radius_m(d_m, v, launch_s);
        let height = crown_height_m(d_m, v, launch_s);
        let p0 = [out[0] * radius, out[1] * radius, out[2] * radius + height];
        let (cos_e, sin_e) = (elevation.cos(), elevation.sin());
        let vel = [
            out[0] * cos_e * speed,
            out[1] * cos_e * speed,
            (out[2] * cos_e + sin_e) * speed,
        ];
        let flight_s = (vel[2] + (vel[2] * vel[2] + 2.0 * gravity * p0[2]).sqrt()) / gravity;
        let (t_lo, t_hi) = (a.max(launch_s), b.min(launch_s + flight_s));
        if t_hi <= t_lo {
            continue;
        }
        let g_half = [0.0, 0.0, 0.5 * gravity];
        let at_time = |s: f32| -> [f32; 3] {
            let start = add(hit, p0);
            std::array::from_fn(|i| start[i] + vel[i] * s - g_half[i] * (s * s))
        };
        let (w0, w1) = (at_time(t_lo - launch_s), at_time(t_hi - launch_s));
        let exposed = (t_hi - t_lo) / p.exposure_s;
        if let Some((s, ends)) = segment_streak(p, w0, w1, exposed, radius_m, weight) {
            list.push(f, at + 1 + j, s, ends);
        }
    }
}

/// How far from its impact, m, a droplet of a splash can be after flying `flown_s`: the crown's
/// final radius `z_max` (which bounds where it is launched and how high) plus the distance at
/// the fastest launch speed across, plus the crown and the highest arc up; with a margin for
/// the f32 arithmetic of the flight.
fn reach_m(v: f32, z_max: f32, flown_s: f32, gravity: f32) -> f64 {
    let w = v as f64 * LAUNCH_SPEED[1];
    let (z_max, flown_s) = (z_max as f64, flown_s as f64);
    let across = z_max + w * flown_s;
    let up = z_max + w * w / (2.0 * gravity as f64);
    1.01 * (across + up) + 1e-3
}

/// Whether a streak of radius `radius_m` with both ends within `reach_m` of `hit` is
/// everywhere thinner than a pixel, so that `segment_streak` hides it: its nearer end is no
/// nearer the camera than the hit's depth less the reach, nor than the near plane it is
/// clipped to. With margins far wider than the f32 rounding of the streak's own test, so the
/// cull changes no bit (`tests/splashes.rs` holds it to the uncut run).
fn thinner_than_a_pixel(p: &RainParams, hit: [f32; 3], radius_m: f32, reach_m: f64) -> bool {
    let z_hit = to_camera(p, hit)[2] as f64;
    let z = (z_hit - reach_m).max(p.near_clip_m as f64) * (1.0 - 1e-4);
    2.0 * radius_m as f64 * p.focal_px as f64 / z < 1.0 - 1e-4
}

/// The streak of water of radius `radius_m` moving from `w0` to `w1` (world) while in view for
/// `exposed` of the exposure, its coverage times `weight`, uncapped in width and not drawn when
/// thinner than a pixel at its distance (WGSL `segment_streak` for the splashes), without its
/// light; with its ends in the camera's frame. `None` where the WGSL returns `hidden()`.
#[inline(always)]
fn segment_streak(
    p: &RainParams,
    w0: [f32; 3],
    w1: [f32; 3],
    exposed: f32,
    radius_m: f32,
    weight: f32,
) -> Option<(Streak, [[f32; 3]; 2])> {
    let (mut c0, mut c1) = (to_camera(p, w0), to_camera(p, w1));
    let near = p.near_clip_m;
    if c0[2] < near && c1[2] < near {
        return None;
    }
    // Clip the segment to the near plane, the start first.
    if c0[2] < near {
        let t = (near - c0[2]) / (c1[2] - c0[2]);
        c0 = std::array::from_fn(|a| mix(c0[a], c1[a], t));
    }
    if c1[2] < near {
        let t = (near - c1[2]) / (c0[2] - c1[2]);
        c1 = std::array::from_fn(|a| mix(c1[a], c0[a], t));
    }
    let fpx = p.focal_px;
    let z = c0[2].min(c1[2]);
    let r = radius_m * fpx / z;
    if 2.0 * r < 1.0 {
        return None;
    }
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
        .min(UNCAPPED_PX);
    let seg = [q1[0] - q0[0], q1[1] - q0[1]];
    let len = (seg[0] * seg[0] + seg[1] * seg[1]).sqrt();
    let dir = if len > 1e-4 {
        [seg[0] / len, seg[1] / len]
    } else {
        [0.0, 1.0]
    };
    let alpha = r * r / (r_eff * r_eff) * p.opacity * p.drop_weight * exposed * weight;
    let peak = alpha * (2.0 * r_eff / len.max(1e-3)).min(1.0);
    if peak < MIN_PEAK_ALPHA as f32 {
        return None;
    }
    let ext = r_eff + 1.0;
    if q0[0].max(q1[0]) + ext < 0.0
        || q0[1].max(q1[1]) + ext < 0.0
        || q0[0].min(q1[0]) - ext > p.display_size_px[0]
        || q0[1].min(q1[1]) - ext > p.display_size_px[1]
    {
        return None;
    }
    let streak = Streak {
        q0_px: q0,
        dir,
        len_px: len,
        r_eff_px: r_eff,
        alpha_scale: alpha,
        drop_info: 0,
        ..HIDDEN
    };
    Some((streak, [c0, c1]))
}
