//! The CPU twin of `shaders/common/drops.wgsl`: the stateless drop, a closed form of
//! (seed, drop id, t).
//!
//! ## Long clips
//! A drop's position is a phase (how many column heights it has fallen, how many cells it has
//! drifted) that grows linearly with t, and only its fraction matters. In `f32` a product
//! rate·t loses its fraction as t grows (at t = 1 h the step of t alone is 0.24 ms), so the
//! phase is computed in fixed point instead: each drop's rates are integers on a grid shared
//! by the CPU and the GPU ([`DropMotion`]: fall speed by size quantile, 2⁻¹⁰ m/s; column
//! height⁻¹, 2⁻²² m⁻¹; the columns' drift per metre fallen, 2⁻¹⁶ cells/m), and t arrives split
//! into whole seconds (`u32`) and a fraction ([`SplitTime`]). rate·whole is then exact integer
//! arithmetic (wrapping, or 64-bit for the fall's pass count) and only rate·fraction is a float
//! product, whose size does not grow with t. The mean wind's travel (a CPU `f64` quantity)
//! reaches the GPU already reduced modulo one cell. A drop at t = 10 h is then placed as
//! precisely as at t = 10 s.

use glam::{DVec2, DVec3};

use super::rainfall::Rainfall;
use super::{ColumnGrid, RainVolume};
use crate::rain::physics::{G_MPS2, RainModel, streak_width_factor};
use crate::rain::wind::Wind;

/// Octaves of 1 − u the fall-speed table spans (u a 24-bit size quantile).
pub const SPEED_OCTAVES: u32 = 24;
/// log₂ of the table's steps per octave.
pub const SPEED_STEPS_LOG2: u32 = 4;
/// Entries of the fall-speed-by-quantile table ([`DropMotion::speed_q`]): one per step of
/// each octave and the end, padded to whole `vec4`s.
pub const SPEED_TABLE_LEN: usize =
    (((SPEED_OCTAVES << SPEED_STEPS_LOG2) + 1).div_ceil(4) * 4) as usize;
/// Fixed-point bits of a fall speed (units of 2⁻¹⁰ m/s ≈ 1 mm/s).
pub const SPEED_BITS: u32 = 10;
/// Fixed-point bits of a column's inverse height (units of 2⁻²² m⁻¹).
pub const INV_HEIGHT_BITS: u32 = 22;
/// Fixed-point bits of a fall rate in column heights per second (units of 2⁻²⁰ s⁻¹).
pub const FALL_RATE_BITS: u32 = 20;
/// Fixed-point bits of the columns' drift per metre fallen (units of 2⁻¹⁶ cells/m).
pub const DRIFT_BITS: u32 = 16;
/// Bits of the drift phase: a fall speed times a drift rate (units of 2⁻²⁶ cells).
pub const DRIFT_PHASE_BITS: u32 = SPEED_BITS + DRIFT_BITS;
/// Shortest column height the fall rate resolves, m (shorter columns fall at its rate).
pub const MIN_COLUMN_HEIGHT_M: f64 = 1.0 / 256.0;

/// A time split into whole seconds and a fraction, the way it reaches the GPU.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplitTime {
    /// Whole seconds (t ≥ 0; clamped to `u32`).
    pub whole_s: u32,
    /// The rest, in [0, 1).
    pub frac_s: f64,
}

impl SplitTime {
    /// Splits `t_s` (negative times clamp to 0).
    pub fn new(t_s: f64) -> SplitTime {
        let t = t_s.max(0.0);
        let whole = t.floor().min(u32::MAX as f64);
        SplitTime {
            whole_s: whole as u32,
            frac_s: (t - whole).clamp(0.0, 1.0),
        }
    }

    /// The time as one number (for the `f64` quantities the CPU computes per frame).
    pub fn seconds(self) -> f64 {
        self.whole_s as f64 + self.frac_s
    }
}

/// The drops' motion on the fixed-point grid the CPU and the GPU share.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DropMotion {
    /// Fall speed at the table's size quantiles (see [`DropMotion::fall_speed_q`]), 2⁻¹⁰ m/s,
    /// the fall speed scale applied.
    pub speed_q: [u32; SPEED_TABLE_LEN],
    /// The columns' drift in cells per metre fallen, (slope / cell size), 2⁻¹⁶ cells/m.
    pub drift_q: [i32; 2],
    /// Drawn diameter over the physical one.
    pub diameter_scale: f64,
}

impl DropMotion {
    /// The motion of `model`'s drops in the columns of `grid`, with fall speeds times
    /// `fall_speed_scale` and drawn diameters times `diameter_scale`.
    pub fn new(
        model: &RainModel,
        grid: &ColumnGrid,
        fall_speed_scale: f64,
        diameter_scale: f64,
    ) -> DropMotion {
        let last = (SPEED_OCTAVES << SPEED_STEPS_LOG2) as usize;
        let steps = (1u32 << SPEED_STEPS_LOG2) as f64;
        let speed_q = std::array::from_fn(|j| {
            // Node j: 1 − u = 2^e (1 + k/steps) / 2²⁴, e = j / steps, k = j mod steps.
            let j = j.min(last);
            let (e, k) = (
                (j >> SPEED_STEPS_LOG2) as i32,
                (j % (1 << SPEED_STEPS_LOG2)) as f64,
            );
            let r = 2f64.powi(e) * (1.0 + k / steps);
            let u = (1.0 - (r + 1.0) / (1u32 << 24) as f64).clamp(0.0, 1.0);
            let d = model.dsd.diameter_from_uniform_mm(u);
            let v = model.fall.terminal_velocity_mps(d) * fall_speed_scale;
            (v * (1u32 << SPEED_BITS) as f64)
                .round()
                .clamp(0.0, (1u32 << 20) as f64) as u32
        });
        let drift = |k: f64, cell: f64| {
            let r = k / cell.max(1e-6) * (1u32 << DRIFT_BITS) as f64;
            r.round().clamp(-(1i64 << 30) as f64, (1i64 << 30) as f64) as i32
        };
        DropMotion {
            speed_q,
            drift_q: [
                drift(grid.slope.x, grid.cell_size_m.x),
                drift(grid.slope.y, grid.cell_size_m.y),
            ],
            diameter_scale,
        }
    }

    /// Fall speed (2⁻¹⁰ m/s) of a drop whose size quantile has the 24 bits `quantile`: the
    /// table interpolated in integers, so CPU and GPU agree to the bit. The table steps
    /// evenly through each octave of 1 − u: the size distribution's tail, where the diameter
    /// climbs fastest with u, is resolved as finely as its bulk (for an exponential
    /// distribution the diameter is linear in log(1 − u)).
    pub fn fall_speed_q(&self, quantile: u32) -> u32 {
        let r = (0x00FF_FFFF - (quantile & 0x00FF_FFFF)).max(1);
        let e = 31 - r.leading_zeros();
        let f12 = if e >= 12 {
            (r >> (e - 12)) & 0xFFF
        } else {
            (r << (12 - e)) & 0xFFF
        };
        let j = ((e << SPEED_STEPS_LOG2) + (f12 >> (12 - SPEED_STEPS_LOG2))) as usize;
        let g = (f12 & ((1 << (12 - SPEED_STEPS_LOG2)) - 1)) as i32;
        let a = self.speed_q[j] as i32;
        let b = self.speed_q[(j + 1).min(SPEED_TABLE_LEN - 1)] as i32;
        (a + (((b - a) * g) >> (12 - SPEED_STEPS_LOG2))) as u32
    }
}

/// A column's inverse height on the fixed-point grid (2⁻²² m⁻¹).
pub fn inv_height_q(height_m: f64) -> u32 {
    ((1u64 << INV_HEIGHT_BITS) as f64 / height_m.max(MIN_COLUMN_HEIGHT_M))
        .round()
        .min(u32::MAX as f64) as u32
}

/// Column heights per second (2⁻²⁰ s⁻¹) of a drop falling at `speed_q` in a column of inverse
/// height `inv_height_q`, saturating.
pub fn fall_rate_q(speed_q: u32, inv_height_q: u32) -> u32 {
    let p =
        (speed_q as u64 * inv_height_q as u64) >> (SPEED_BITS + INV_HEIGHT_BITS - FALL_RATE_BITS);
    p.min(u32::MAX as u64) as u32
}

/// The fall phase rate·t of a drop: (whole passes, wrapping; the fraction of the whole-second
/// part, in [0, 1)); the fraction-second part, rate·frac, is left to the caller's float.
pub fn fall_phase(rate_q: u32, whole_s: u32) -> (u32, f64) {
    let p = rate_q as u64 * whole_s as u64;
    let mask = (1u64 << FALL_RATE_BITS) - 1;
    (
        (p >> FALL_RATE_BITS) as u32,
        (p & mask) as f64 / (1u64 << FALL_RATE_BITS) as f64,
    )
}

/// The drift phase (cells) of a drop falling at `speed_q` in columns drifting `drift_q`
/// cells per metre, after `t`, modulo 1 for the whole seconds.
pub fn drift_phase(speed_q: u32, drift_q: i32, t: SplitTime) -> f64 {
    let rate = (speed_q as i32).wrapping_mul(drift_q) as u32;
    let mask = (1u32 << DRIFT_PHASE_BITS) - 1;
    let whole = (rate.wrapping_mul(t.whole_s) & mask) as f64 / (1u32 << DRIFT_PHASE_BITS) as f64;
    let rate_f = speed_q as f64 * drift_q as f64 / (1u64 << DRIFT_PHASE_BITS) as f64;
    whole + rate_f * t.frac_s
}

/// The 24 random bits of drop `id`'s stream `stream` ([`drop_uniform`] is them over 2²⁴).
pub fn drop_bits(seed: u32, id: u32, stream: u32) -> u32 {
    pcg_hash(pcg_hash(pcg_hash(seed) ^ id) ^ stream.wrapping_mul(0x9E37_79B9)) >> 8
}

/// PCG hash of a `u32` (Jarzynski & Olano 2020, "Hash functions for GPU rendering"), the
/// per-drop random source; WGSL has the same `u32` wrapping arithmetic.
pub const fn pcg_hash(x: u32) -> u32 {
    let state = x.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// Bits of a column's size share ([`Column::size_keep_q`](super::Column)): the survival
/// 1 − F(D_cut) of the sizes it simulates, in units of 2⁻²⁴.
pub const SIZE_KEEP_BITS: u32 = 24;
/// The share of a column that simulates every size.
pub const SIZE_KEEP_ALL: u32 = 1 << SIZE_KEEP_BITS;

/// The 24-bit size quantile of drop `id` in a column that keeps the share `keep_q` (2⁻²⁴) of
/// the size distribution's top: its uniform bits q (stream 3) mapped onto the top, so that
/// 1 − u' = (1 − u)·S with S = keep_q/2²⁴ and u' is uniform on [1 − S, 1). The diameter
/// D(u') is then drawn from the distribution truncated below D_cut = F⁻¹(1 − S), and the fall
/// speed table is read at u' too. Integer arithmetic (a 48-bit product), so the GPU's twin in
/// `drops.wgsl` (`size_bits`) agrees to the bit; `keep_q` = 2²⁴ gives q itself.
pub fn size_bits(seed: u32, id: u32, keep_q: u32) -> u32 {
    let r = 0x00FF_FFFF - drop_bits(seed, id, 3);
    let kept = (r as u64 * keep_q.min(SIZE_KEEP_ALL) as u64) >> SIZE_KEEP_BITS;
    0x00FF_FFFF - kept as u32
}

/// Uniform in [0, 1) for drop `id`, random stream `stream` (0–2 position, 3 diameter, …) and
/// `seed`: 24 bits, exact in `f32`.
pub fn drop_uniform(seed: u32, id: u32, stream: u32) -> f64 {
    drop_bits(seed, id, stream) as f64 * (1.0 / 16_777_216.0)
}

/// One drop of the CPU emitter at time `t_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampledDrop {
    /// Drop id.
    pub id: u64,
    /// Column index.
    pub column: usize,
    /// Diameter, mm.
    pub diameter_mm: f64,
    /// Drawn diameter (the diameter × the drop scale), mm.
    pub drawn_mm: f64,
    /// Drawn horizontal diameter, the streak's width, mm.
    pub width_mm: f64,
    /// Velocity (world), m/s.
    pub velocity_mps: DVec3,
    /// Position (world), m.
    pub position_m: DVec3,
    /// Its pass through its column (a new one at each rebirth; counts down, modulo 2³²).
    pub pass: u32,
    /// When this pass began at the column's top, s.
    pub born_s: f64,
}

/// Uniform in [0, 1) for drop `id`, stream `stream`, in the `cycle`-th pass of the drop
/// through its column (a new lateral offset at each rebirth).
pub fn cycle_uniform(seed: u32, id: u32, cycle: u32, stream: u32) -> f64 {
    let h = pcg_hash(
        pcg_hash(pcg_hash(seed) ^ id) ^ stream.wrapping_mul(0x9E37_79B9) ^ pcg_hash(cycle),
    );
    (h >> 8) as f64 * (1.0 / 16_777_216.0)
}

/// The plain CPU reference of the stateless emitter (`shaders/common/drops.wgsl`): drop `id`
/// at time `t_s` (`None` outside the columns, or where a keyed rate leaves this pass out).
/// Diameter by inverse CDF of stream 3, truncated below the column's smallest visible size
/// ([`size_bits`]); vertical velocity the fall speed of its size quantile
/// ([`DropMotion::fall_speed_q`]); horizontal velocity the wind's
/// steady-state response with τ = v_t/g; position the column point of streams 0–2 moved by
/// the fall and the drift (fixed-point phases, see the module notes) and the wind, wrapped
/// modulo the column, with a new lateral offset (streams 4, 5 of the pass number) each time
/// the drop wraps through the bottom.
pub fn sample_drop(rain: Rainfall, id: u64, t_s: f64) -> Option<SampledDrop> {
    let Rainfall {
        volume,
        model,
        wind,
        seed,
    } = rain;
    let ci = volume.grid.column_of(id)?;
    let col = &volume.grid.columns[ci];
    let grid = &volume.grid;
    let motion = &volume.motion;
    let id32 = id as u32;
    let u = |s| drop_uniform(seed, id32, s);
    let t = SplitTime::new(t_s);
    let q = size_bits(seed, id32, col.size_keep_q);
    let d = model
        .dsd
        .diameter_from_uniform_mm(q as f64 * (1.0 / 16_777_216.0));
    let speed_q = motion.fall_speed_q(q);
    let vt = speed_q as f64 / (1u32 << SPEED_BITS) as f64;
    let tau = vt / G_MPS2;
    let vh = wind.drop_velocity_mps(t.seconds(), tau);
    // Fall: w = w0 − rate·t, in column heights.
    let rate_q = fall_rate_q(speed_q, inv_height_q(col.height_m()));
    let (passes, whole_frac) = fall_phase(rate_q, t.whole_s);
    let x = u(2) - whole_frac - rate_q as f64 / (1u32 << FALL_RATE_BITS) as f64 * t.frac_s;
    let c = x.floor();
    let k = (c as i64 as i32 as u32).wrapping_sub(passes);
    let rate = rate_q as f64 / (1u32 << FALL_RATE_BITS) as f64;
    let born_s = t.seconds() - (1.0 - (x - c)) / rate;
    if !falls(model, seed, id32, k, born_s, d) {
        return None;
    }
    let [u_frac, v_frac] = lateral_fractions(seed, id32, drift_cells(volume, wind, speed_q, t), k);
    let uvw = [u_frac, v_frac, x - c];
    let drawn = d * motion.diameter_scale;
    Some(SampledDrop {
        id,
        column: ci,
        diameter_mm: d,
        drawn_mm: drawn,
        width_mm: drawn * streak_width_factor(d),
        velocity_mps: DVec3::new(vh.x, vh.y, -vt),
        position_m: grid.point_m(col, uvw),
        pass: k,
        born_s,
    })
}

/// Random stream of the decision whether a drop falls in a pass (keyed rate).
pub const RATE_STREAM: u32 = 6;

/// Whether drop `id32` falls in its pass `pass` through its column, born (at the column's
/// top, outside the view) at `birth_s`. With a keyed rate the emitter holds the peak rate's
/// drops, and each pass falls with the probability [`RainModel::keeps`] of the rate at its
/// birth: decided once per pass, so a drop never appears or vanishes mid-air, and stateless,
/// so preview, chunks and render agree.
pub fn falls(model: &RainModel, seed: u32, id32: u32, pass: u32, birth_s: f64, d_mm: f64) -> bool {
    let Some(keys) = &model.rate_keys else {
        return true;
    };
    cycle_uniform(seed, id32, pass, RATE_STREAM) < model.keeps(keys.at(birth_s), d_mm)
}

/// The drift (cells, only its fraction matters) of a drop falling at `speed_q` at `t`: the
/// columns' shear as it falls, the mean wind (with the drop's lag where it changes) and the
/// gusts.
pub fn drift_cells(volume: &RainVolume, wind: &Wind, speed_q: u32, t: SplitTime) -> DVec2 {
    let grid = &volume.grid;
    let drift_q = volume.motion.drift_q;
    let tau = speed_q as f64 / (1u32 << SPEED_BITS) as f64 / G_MPS2;
    let travel = mean_travel_cells(wind, grid, t);
    let gust = (wind.gust_displacement_m(t.seconds(), tau) + wind.mean_lag(t.seconds(), tau).1)
        / grid.cell_size_m.max(DVec2::splat(1e-6));
    DVec2::new(
        drift_phase(speed_q, drift_q[0], t) + travel.x + gust.x,
        drift_phase(speed_q, drift_q[1], t) + travel.y + gust.y,
    )
}

/// Where across its cell drop `id32` is after drifting `drift` cells, in its pass `pass`: the
/// fractions (u, v) of the cell; each pass adds its own lateral offset (streams 4, 5).
pub fn lateral_fractions(seed: u32, id32: u32, drift: DVec2, pass: u32) -> [f64; 2] {
    [
        (drop_uniform(seed, id32, 0)
            + drift.x.rem_euclid(1.0)
            + cycle_uniform(seed, id32, pass, 4))
        .rem_euclid(1.0),
        (drop_uniform(seed, id32, 1)
            + drift.y.rem_euclid(1.0)
            + cycle_uniform(seed, id32, pass, 5))
        .rem_euclid(1.0),
    ]
}

/// The mean wind's travel at `t` in cells of `grid`, modulo one cell (computed in `f64`: what
/// the GPU receives per frame).
pub fn mean_travel_cells(wind: &Wind, grid: &ColumnGrid, t: SplitTime) -> DVec2 {
    let cells = wind.mean_travel_m(t.seconds()) / grid.cell_size_m.max(DVec2::splat(1e-6));
    DVec2::new(cells.x.rem_euclid(1.0), cells.y.rem_euclid(1.0))
}
