// The stateless drop (thesis eq. 5.1–5.3, with rebirth): a drop's state at time t is a closed
// form of (seed, drop id, t). Each drop belongs to a column of the rain volume and travels
// along the column's fall axis, re-entering at the top (with a new lateral position) whenever
// it leaves at the bottom, so the volume stays uniformly filled and any frame can be rendered
// without the ones before it. CPU twin: src/rain/emitter.rs (`drop_state`).
//
// Needs, declared by the stage that includes it:
//   var<uniform> rain: RainParams;  var<storage, read> columns: array<Column>;

struct DropState {
    pos_m: vec3<f32>,
    vel_mps: vec3<f32>,
    diameter_mm: f32,
}

// Per-drop constants use this cycle key; per-cycle values use the cycle number.
const DROP_CONSTANT_KEY: u32 = 0xffffffffu;

fn terminal_speed_mps(d_mm: f32) -> f32 {
    let x = clamp(d_mm / rain.speed_table_step_mm, 0.0, 30.999);
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

fn drop_state(id: u32, t_s: f32) -> DropState {
    let col = columns[column_of(id)];
    let d_mm = diameter_from_unit(rand_key(rain.seed, id, DROP_CONSTANT_KEY, 0u));
    let vel = vec3<f32>(rain.wind_mps.xy, -terminal_speed_mps(d_mm));
    let axis = rain.fall_axis.xyz;
    let w = max(dot(vel, axis), 1e-3);
    let len = max(col.s_len_m, 1e-3);
    let travel = rand_key(rain.seed, id, DROP_CONSTANT_KEY, 1u) * len + w * t_s;
    let cycle = floor(travel / len);
    let s_in = travel - cycle * len;
    let k = bitcast<u32>(i32(cycle));
    let lateral = col.lateral_min_m
        + col.lateral_size_m * vec2<f32>(rand_key(rain.seed, id, k, 2u), rand_key(rain.seed, id, k, 3u));
    let since_birth_s = s_in / w;
    let drift = vel - w * axis;
    let pos = rain.volume_origin_m.xyz + lateral.x * rain.lateral_e1.xyz + lateral.y * rain.lateral_e2.xyz
        + (col.s_lo_m + s_in) * axis + drift * since_birth_s;
    return DropState(pos, vel, d_mm);
}
