// The stateless drop (thesis eq. 5.1–5.3, with rebirth): a drop's state at time t is a closed
// form of (seed, drop id, t); the CPU reference is `rain::volume::sample_drop`.
//
// Each drop lives in a column of the rain volume (sheared along the mean fall direction, see
// src/rain/volume.rs). It is born at fractions (u0, v0, w0) of its column, moves with its
// steady-state velocity (terminal speed of its diameter, Gunn & Kinzer; horizontal: the wind's
// gusts low-passed by the drop's relaxation time τ = v_t/g), and its fractional position wraps
// modulo 1 on each axis. Wrapping preserves volume, so the column stays uniformly filled; each
// time the drop wraps through the bottom it is reborn with a new lateral offset.
//
// Needs, declared by the stage that includes it:
//   var<uniform> rain: RainParams;  var<storage, read> columns: array<Column>;

struct DropState {
    pos_m: vec3<f32>,
    vel_mps: vec3<f32>,
    diameter_mm: f32,   // drawn equivalent diameter (× diameter_scale)
    width_mm: f32,      // drawn horizontal diameter: the streak's width
}

// Horizontal over equivalent diameter, r^(−1/3), of an oblate drop with Beard & Chuang's (1987)
// axis ratio r(D) (twin of rain::physics::streak_width_factor).
fn streak_width_factor(d_mm: f32) -> f32 {
    let d = clamp(d_mm, 0.0, 7.0);
    let r = min(1.0048 + d * (5.7e-4 + d * (-2.628e-2 + d * (3.682e-3 + d * -1.677e-4))), 1.0);
    return pow(r, -1.0 / 3.0);
}

fn terminal_speed_mps(d_mm: f32) -> f32 {
    let x = clamp((d_mm - rain.d_min_mm) / rain.speed_table_step_mm, 0.0, 30.999);
    let i = u32(floor(x));
    let f = x - f32(i);
    let a = rain.speed_table[i / 4u][i % 4u];
    let b = rain.speed_table[(i + 1u) / 4u][(i + 1u) % 4u];
    return mix(a, b, f);
}

// Truncated exponential (Marshall–Palmer) diameter by inverse CDF.
fn diameter_from_unit(u: f32) -> f32 {
    let span = rain.d_max_mm - rain.d_min_mm;
    let tail = 1.0 - exp(-rain.lambda_per_mm * span);
    return rain.d_min_mm - log(1.0 - u * tail) / rain.lambda_per_mm;
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

fn drop_state(id: u32) -> DropState {
    let col = columns[column_of(id)];
    let seed = rain.seed;
    let d_mm = diameter_from_unit(drop_uniform(seed, id, 3u));
    let vt = terminal_speed_mps(d_mm);
    let wt_per_omega = vt / rain.gravity_mps2;  // τ
    // Steady-state response to the gusts (src/rain/wind.rs): velocity and displacement.
    var vh = rain.wind_mean_mps.xy;
    var disp = rain.wind_mean_mps.zw;
    for (var k = 0u; k < 8u; k++) {
        let a = rain.gust_amp[k];
        let p = rain.gust_phase[k];
        let wt = a.z * wt_per_omega;
        let den = 1.0 + wt * wt;
        vh += a.xy * ((p.x + wt * p.y) / den);
        let s1 = (p.y - wt * p.x) / den;
        let s0 = (p.w - wt * p.z) / den;
        disp += a.xy * ((s1 - s0) / a.z);
    }
    let dz = -vt * rain.time_s;
    // Displacement in sheared column coordinates, in cells.
    let du = (disp.x - rain.column_slope.x * dz) / rain.cell_size_m.x;
    let dv = (disp.y - rain.column_slope.y * dz) / rain.cell_size_m.y;
    let w_total = drop_uniform(seed, id, 2u) + dz / col.height_m;
    let cycle = floor(w_total);
    let k = bitcast<u32>(i32(cycle));
    let u = fract(drop_uniform(seed, id, 0u) + fract(du) + cycle_uniform(seed, id, k, 4u));
    let v = fract(drop_uniform(seed, id, 1u) + fract(dv) + cycle_uniform(seed, id, k, 5u));
    let w = w_total - cycle;
    let uv = col.cell_min_m + rain.cell_size_m * vec2<f32>(u, v);
    let z = col.z_lo_m + w * col.height_m;
    let pos = vec3<f32>(uv + rain.column_slope * z, z);
    let drawn_mm = d_mm * rain.diameter_scale;
    return DropState(pos, vec3<f32>(vh, -vt), drawn_mm, drawn_mm * streak_width_factor(d_mm));
}
