// The stateless drop (thesis eq. 5.1–5.3, with rebirth): a drop's state at time t is a closed
// form of (seed, drop id, t); the CPU reference is `rain::volume::sample_drop`, whose module
// notes explain the fixed-point phases that keep long clips exact.
//
// Each drop lives in a column of the rain volume (sheared along the mean fall direction, see
// src/rain/volume.rs). It is born at fractions (u0, v0, w0) of its column, moves with its
// steady-state velocity (terminal speed of its diameter, Gunn & Kinzer; horizontal: the wind's
// gusts low-passed by the drop's relaxation time τ = v_t/g), and its fractional position wraps
// modulo 1 on each axis. Wrapping preserves volume, so the column stays uniformly filled; each
// time the drop wraps through the bottom it is reborn with a new lateral offset.
//
// A keyed rate thins the drops per pass (falls); a keyed wind adds each drop's lag (wind_lag).
// A column simulates only the sizes that can show in it (size_bits; rain::volume::visible).
//
// Needs, declared by the stage that includes it:
//   var<uniform> rain: RainParams;  var<storage, read> columns: array<Column>;

struct DropState {
    pos_m: vec3<f32>,
    vel_mps: vec3<f32>,
    diameter_mm: f32,   // drawn equivalent diameter (× diameter_scale)
    width_mm: f32,      // drawn horizontal diameter: the streak's width
    falls: bool,        // false: a keyed rate leaves this pass of the drop out (not drawn)
}

// The keyed rate, mm/h, `s` seconds from the frame's time: linear between keys, held outside
// (keyframes::Curve::at).
fn rate_at(s: f32) -> f32 {
    let n = rain.rate_key_count;
    if s <= rain.rate_keys[0].x { return rain.rate_keys[0].y; }
    for (var i = 1u; i < n; i++) {
        let k1 = rain.rate_keys[i];
        if s < k1.x {
            let k0 = rain.rate_keys[i - 1u];
            return mix(k0.y, k1.y, (s - k0.x) / (k1.x - k0.x));
        }
    }
    return rain.rate_keys[n - 1u].y;
}

// Whether drop `id` falls in its pass `pass_index`, born `age_s` ago at its column's top: with
// a keyed rate the columns hold the peak rate's drops, and a pass falls with probability
// N(D; R)/N(D; R_peak) = exp(−(Λ(R) − Λ_peak) D) of the rate at its birth (Marshall–Palmer),
// decided once per pass (rain::volume::drop::falls).
fn falls(id: u32, pass_index: u32, age_s: f32, d_mm: f32) -> bool {
    if rain.rate_key_count == 0u { return true; }
    let r = rate_at(-age_s);
    if r <= 0.0 { return false; }
    let excess = max(MP_LAMBDA_COEFF * pow(r, -MP_LAMBDA_EXPONENT) - rain.lambda_per_mm, 0.0);
    return cycle_uniform(rain.seed, id, pass_index, RATE_STREAM) < exp(-excess * d_mm);
}

// How far a drop with time constant `tau` lags a keyed mean wind: velocity and displacement to
// add to the mean wind's (exact for piecewise-linear wind, rain::wind::Wind::mean_lag).
struct WindLag {
    vel_mps: vec2<f32>,
    disp_m: vec2<f32>,
}

fn wind_lag(tau: f32) -> WindLag {
    var lag = WindLag(-tau * rain.wind_slope_mps2, -tau * (rain.wind_mean_mps - rain.wind_start_mps));
    for (var j = 0u; j < rain.wind_kink_count; j++) {
        let k = rain.wind_kinks[j];
        let e = exp(-k.x / tau);
        lag.vel_mps += k.yz * (tau * e);
        lag.disp_m += k.yz * (tau * tau * (1.0 - e));
    }
    return lag;
}

// Horizontal over equivalent diameter, r^(−1/3), of an oblate drop with Beard & Chuang's (1987)
// axis ratio r(D) (twin of rain::physics::streak_width_factor).
fn streak_width_factor(d_mm: f32) -> f32 {
    let d = clamp(d_mm, 0.0, 7.0);
    let r = min(1.0048 + d * (5.7e-4 + d * (-2.628e-2 + d * (3.682e-3 + d * -1.677e-4))), 1.0);
    return pow(r, -1.0 / 3.0);
}

// Fall speed, 2^-SPEED_BITS m/s, of the drop whose size quantile has the 24 bits `q`: the
// table (even steps through each octave of 1 − u) interpolated in integers, bit-identical to
// rain::volume::DropMotion::fall_speed_q.
fn fall_speed_q(q: u32) -> u32 {
    let r = max(0xFFFFFFu - (q & 0xFFFFFFu), 1u);
    let e = firstLeadingBit(r);
    var f12 = (r << (12u - min(e, 12u))) & 0xFFFu;
    if e >= 12u { f12 = (r >> (e - 12u)) & 0xFFFu; }
    let j = (e << SPEED_STEPS_LOG2) + (f12 >> (12u - SPEED_STEPS_LOG2));
    let g = i32(f12 & ((1u << (12u - SPEED_STEPS_LOG2)) - 1u));
    let k = min(j + 1u, SPEED_TABLE_LEN - 1u);
    let a = i32(rain.speed_q[j / 4u][j % 4u]);
    let b = i32(rain.speed_q[k / 4u][k % 4u]);
    return u32(a + (((b - a) * g) >> (12u - SPEED_STEPS_LOG2)));
}

// The 64-bit product a·b as (low, high) words.
fn mul_wide(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xFFFFu;
    let a1 = a >> 16u;
    let b0 = b & 0xFFFFu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let mid = (p00 >> 16u) + (p01 & 0xFFFFu) + (p10 & 0xFFFFu);
    let lo = (p00 & 0xFFFFu) | (mid << 16u);
    let hi = a1 * b1 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
    return vec2<u32>(lo, hi);
}

// Column heights per second, 2^-FALL_RATE_BITS s^-1, saturating (rain::volume::fall_rate_q).
fn fall_rate_q(speed_q: u32, inv_height_q: u32) -> u32 {
    let p = mul_wide(speed_q, inv_height_q);
    let shift = SPEED_BITS + INV_HEIGHT_BITS - FALL_RATE_BITS;
    if (p.y >> shift) != 0u { return 0xFFFFFFFFu; }
    return (p.x >> shift) | (p.y << (32u - shift));
}

// Truncated exponential (Marshall–Palmer) diameter by inverse CDF.
fn diameter_from_unit(u: f32) -> f32 {
    let span = rain.d_max_mm - rain.d_min_mm;
    let tail = 1.0 - exp(-rain.lambda_per_mm * span);
    return rain.d_min_mm - log(1.0 - u * tail) / rain.lambda_per_mm;
}

// The 24-bit size quantile of drop `id` in a column keeping the share `keep_q` (2^-24) of the
// sizes' top: 1 − u' = (1 − u)·keep, so the diameter is drawn from the distribution truncated
// below the column's smallest visible size (rain::volume::drop::size_bits, bit-identical).
fn size_bits(seed: u32, id: u32, keep_q: u32) -> u32 {
    let r = 0xFFFFFFu - drop_bits(seed, id, 3u);
    let p = mul_wide(r, min(keep_q, 1u << 24u));
    return 0xFFFFFFu - ((p.x >> 24u) | (p.y << 8u));
}

// The column holding drop `id`: the last one whose first_drop ≤ id.
fn column_of(id: u32) -> u32 {
    var lo = 0u;
    var hi = rain.column_count;
    loop {
        if hi - lo <= 1u { break; }
        let mid = (lo + hi) / 2u;
        if columns[mid].first_drop <= id { lo = mid; } else { hi = mid; }
    }
    return lo;
}

// A drop's fall and drift at the frame's time, before its position is wrapped into its column
// (drop_state; the splashes find the drop's impacts from it).
struct DropPhase {
    col: Column,
    d_mm: f32,
    speed_q: u32,
    vt: f32,
    vh: vec2<f32>,
    x: f32,           // height in column heights, unwrapped: w = x − floor(x)
    pass_index: u32,  // the pass through the column, ⌊x⌋ − passes of the whole seconds
    rate: f32,        // column heights per second
    duv: vec2<f32>,   // drift in cells, before the pass's own offset
}

fn drop_phase(id: u32) -> DropPhase {
    let col = columns[column_of(id)];
    let seed = rain.seed;
    let q = size_bits(seed, id, col.size_keep_q);
    let d_mm = diameter_from_unit(f32(q) * (1.0 / 16777216.0));
    let speed_q = fall_speed_q(q);
    let vt = f32(speed_q) * (1.0 / f32(1u << SPEED_BITS));
    let wt_per_omega = vt / rain.gravity_mps2;  // τ
    // Steady-state response to the gusts (src/rain/wind.rs): velocity and displacement.
    var vh = rain.wind_mean_mps;
    var gust = vec2<f32>(0.0);
    for (var k = 0u; k < GUSTS; k++) {
        let a = rain.gust_amp[k];
        let p = rain.gust_phase[k];
        let wt = a.z * wt_per_omega;
        let den = 1.0 + wt * wt;
        vh += a.xy * ((p.x + wt * p.y) / den);
        let s1 = (p.y - wt * p.x) / den;
        let s0 = (p.w - wt * p.z) / den;
        gust += a.xy * ((s1 - s0) / a.z);
    }
    if rain.wind_kink_count > 0u {
        let lag = wind_lag(wt_per_omega);
        vh += lag.vel_mps;
        gust += lag.disp_m;
    }
    let frac_s = rain.time_frac_s;
    // Fall, in column heights: w = w0 − rate·t, the whole seconds in exact integers.
    let rate_q = fall_rate_q(speed_q, col.inv_height_q);
    let p = mul_wide(rate_q, rain.time_whole_s);
    let passes = (p.x >> FALL_RATE_BITS) | (p.y << (32u - FALL_RATE_BITS));
    let whole_frac = f32(p.x & ((1u << FALL_RATE_BITS) - 1u)) * (1.0 / f32(1u << FALL_RATE_BITS));
    let rate = f32(rate_q) * (1.0 / f32(1u << FALL_RATE_BITS));
    let x = drop_uniform(seed, id, 2u) - whole_frac - rate * frac_s;
    let c = floor(x);
    let k = bitcast<u32>(i32(c)) - passes;
    // Drift in cells: the columns' shear as the drop falls (exact for the whole seconds), the
    // mean wind (reduced modulo a cell on the CPU), the gusts.
    let drift = vec2<u32>(bitcast<u32>(i32(speed_q) * rain.drift_q.x), bitcast<u32>(i32(speed_q) * rain.drift_q.y));
    let mask = (1u << DRIFT_PHASE_BITS) - 1u;
    let unit = 1.0 / f32(1u << DRIFT_PHASE_BITS);
    let drift_whole = vec2<f32>(vec2<u32>(drift.x * rain.time_whole_s, drift.y * rain.time_whole_s) & vec2<u32>(mask)) * unit;
    let drift_rate = f32(speed_q) * vec2<f32>(rain.drift_q) * unit;
    let duv = drift_whole + drift_rate * frac_s + rain.mean_travel_cells + gust / rain.cell_size_m;
    return DropPhase(col, d_mm, speed_q, vt, vh, x, k, rate, duv);
}

// The fractions (u, v) of its cell where a drop with drift `duv` (cells) is in pass `pass_index`.
fn lateral_fractions(id: u32, duv: vec2<f32>, pass_index: u32) -> vec2<f32> {
    let seed = rain.seed;
    let u = fract(drop_uniform(seed, id, 0u) + fract(duv.x) + cycle_uniform(seed, id, pass_index, 4u));
    let v = fract(drop_uniform(seed, id, 1u) + fract(duv.y) + cycle_uniform(seed, id, pass_index, 5u));
    return vec2<f32>(u, v);
}

fn drop_state(id: u32) -> DropState {
    let ph = drop_phase(id);
    let col = ph.col;
    let w = ph.x - floor(ph.x);
    let uv = col.cell_min_m + rain.cell_size_m * lateral_fractions(id, ph.duv, ph.pass_index);
    let z = col.z_lo_m + w * col.height_m;
    let pos = vec3<f32>(uv + rain.column_slope * z, z);
    let drawn_mm = ph.d_mm * rain.diameter_scale;
    let born = falls(id, ph.pass_index, (1.0 - w) / ph.rate, ph.d_mm);
    return DropState(pos, vec3<f32>(ph.vh, -ph.vt), drawn_mm, drawn_mm * streak_width_factor(ph.d_mm), born);
}
