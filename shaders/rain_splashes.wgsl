// Stage rain_splashes: each drop of a column standing on the ground, once per frame — its latest
// impact before the exposure closes, and if it splashed and the splash still lives, the crown and
// the secondary droplets at their places over the exposure, written as SPLASH_SLOTS streaks
// (slot 0 the crown, then the droplets) for the rain_streaks rasteriser. The model is
// src/rain/physics/splash.rs (docs/method.md, "Splashes"); the CPU twin src/gpu/cpu/rain_splashes.rs.
//
// Impact: the drop's height fraction w falls at `rate` column heights per second, so it landed
// (1 − w)/rate ago, in the pass before this one, or lands w/rate from now, in this pass; where, is
// its lateral position in that pass moved back along its horizontal drift (exact in steady wind;
// with gusts the drift of the frame's time stands for the last fraction of a second).
// Each droplet flies a ballistic arc; over the exposure it draws the chord of the part of its
// flight that lies in the exposure, its alpha scaled by that part (as a landing streak's is).
// The crown is drawn as the drop's own water spread over a capsule of the crown's radius and
// height (coverage conserved). Droplets thinner than a pixel at their distance are skipped.
// Lit exactly like the drops: PRT of the environment with the drop's zonal RTF plus the compact
// lights.
// Includes: common/types.wgsl, common/rng.wgsl, common/drops.wgsl, common/sh.wgsl,
// common/camera.wgsl, common/lights.wgsl, common/streak.wgsl.

@group(0) @binding(0) var<uniform> rain: RainParams;
@group(0) @binding(1) var<storage, read> columns: array<Column>;
// The columns standing on the ground: (column index, index of its first drop among them).
@group(0) @binding(2) var<storage, read> landing: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read_write> splashes: array<Streak>;
@group(0) @binding(4) var<uniform> lights: LightList;
@group(0) @binding(5) var<storage, read> rtf_table: array<vec4<f32>>;

const PI: f32 = 3.14159265;

fn crown_radius_m(d_m: f32, speed_mps: f32, tau_s: f32) -> f32 {
    return sqrt(0.25 * d_m * d_m + d_m * speed_mps * max(tau_s, 0.0));
}

fn crown_height_m(d_m: f32, speed_mps: f32, tau_s: f32) -> f32 {
    if tau_s < 0.0 || tau_s > SPLASH_CROWN_S { return 0.0; }
    return (crown_radius_m(d_m, speed_mps, tau_s) - 0.5 * d_m) * sin(PI * tau_s / SPLASH_CROWN_S);
}

@compute @workgroup_size(SIMULATE_WORKGROUP)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let g = gid.x;
    if g >= arrayLength(&splashes) / SPLASH_SLOTS { return; }
    let base = g * SPLASH_SLOTS;
    for (var s = 0u; s < SPLASH_SLOTS; s++) { splashes[base + s] = hidden(); }
    // The drop: the g-th of the landing columns' drops.
    var lo = 0u;
    var hi = arrayLength(&landing);
    loop {
        if hi - lo <= 1u { break; }
        let mid = (lo + hi) / 2u;
        if landing[mid].y <= g { lo = mid; } else { hi = mid; }
    }
    let id = columns[landing[lo].x].first_drop + (g - landing[lo].y);
    if rain.ground_clip == 0u || id >= rain.drop_count { return; }
    let ph = drop_phase(id);
    if ph.rate <= 0.0 { return; }
    let w = ph.x - floor(ph.x);
    let half = 0.5 * rain.exposure_s;
    // Seconds since its latest impact before the exposure closes (< 0: later in the exposure).
    var since = (1.0 - w) / ph.rate;
    var pass_index = ph.pass_index + 1u;
    if w / ph.rate <= half {
        since = -w / ph.rate;
        pass_index = ph.pass_index;
    }
    // An impact before the clip's start did not happen; nor one of a pass a keyed rate leaves
    // out (born one column height before it landed).
    if f32(rain.time_whole_s) + rain.time_frac_s < since { return; }
    if !falls(id, pass_index, since + 1.0 / ph.rate, ph.d_mm) { return; }
    let d_m = ph.d_mm * 1e-3;
    let v = ph.vt;
    let k = SPLASH_K_COEFFICIENT * pow(d_m, 1.2) * v * v;
    if k <= SPLASH_THRESHOLD_K { return; }
    // Over before the exposure opened: the crown stage, then the longest flight (the fastest,
    // steepest launch from the crown's top, below its final radius).
    let w_max = v * SPLASH_SPEED_MAX * sin(radians(SPLASH_ELEVATION_MAX_DEG));
    let z_max = crown_radius_m(d_m, v, SPLASH_CROWN_S);
    let lifetime = SPLASH_CROWN_S + (w_max + sqrt(w_max * w_max + 2.0 * rain.gravity_mps2 * z_max)) / rain.gravity_mps2;
    if since - half >= lifetime { return; }
    let drift_cells_ps = (ph.vh + rain.column_slope * ph.vt) / rain.cell_size_m;
    let uv = lateral_fractions(id, ph.duv - drift_cells_ps * since, pass_index);
    let hit = vec3<f32>(ph.col.cell_min_m + rain.cell_size_m * uv, 0.0);
    let scale = rain.diameter_scale;
    // The exposure in seconds after the impact.
    let a = since - half;
    let b = since + half;
    // Crown: the drop's water over a capsule of the crown's radius and height.
    let c_lo = max(a, 0.0);
    let c_hi = min(b, SPLASH_CROWN_S);
    if c_hi > c_lo {
        let tau = 0.5 * (c_lo + c_hi);
        let r = crown_radius_m(d_m, v, tau);
        let h = crown_height_m(d_m, v, tau);
        let cover = PI * 0.25 * d_m * d_m / (2.0 * r * h + PI * r * r);
        splashes[base] = segment_streak(hit, hit + vec3<f32>(0.0, 0.0, h), (c_hi - c_lo) / rain.exposure_s, r * scale, cover, 3.0e38, 1.0);
    }
    // Secondary droplets.
    let ratio = SPLASH_THRESHOLD_K / k;
    let count = SPLASH_EJECTED_FRACTION_MAX * (1.0 - ratio) / (pow(SPLASH_DROPLET_RATIO, 3.0) * pow(ratio, 0.75));
    let drawn = clamp(u32(ceil(count)), 1u, SPLASH_MAX_DROPLETS);
    let droplet_m = SPLASH_DROPLET_RATIO * d_m * pow(ratio, 0.25);
    let weight = count / f32(drawn);
    for (var j = 0u; j < drawn; j++) {
        let stream = SPLASH_STREAM + 4u * j;
        let u0 = cycle_uniform(rain.seed, id, pass_index, stream);
        let u1 = cycle_uniform(rain.seed, id, pass_index, stream + 1u);
        let u2 = cycle_uniform(rain.seed, id, pass_index, stream + 2u);
        let u3 = cycle_uniform(rain.seed, id, pass_index, stream + 3u);
        let azimuth = 2.0 * PI * (f32(j) + u0) / f32(drawn);
        let elevation = radians(mix(SPLASH_ELEVATION_MIN_DEG, SPLASH_ELEVATION_MAX_DEG, u1));
        let speed = v * mix(SPLASH_SPEED_MIN, SPLASH_SPEED_MAX, u2);
        let launch_s = SPLASH_CROWN_S * u3;
        let out = vec3<f32>(cos(azimuth), sin(azimuth), 0.0);
        let p0 = out * crown_radius_m(d_m, v, launch_s) + vec3<f32>(0.0, 0.0, crown_height_m(d_m, v, launch_s));
        let vel = (out * cos(elevation) + vec3<f32>(0.0, 0.0, sin(elevation))) * speed;
        let flight_s = (vel.z + sqrt(vel.z * vel.z + 2.0 * rain.gravity_mps2 * p0.z)) / rain.gravity_mps2;
        let t_lo = max(a, launch_s);
        let t_hi = min(b, launch_s + flight_s);
        if t_hi <= t_lo { continue; }
        let s0 = t_lo - launch_s;
        let s1 = t_hi - launch_s;
        let g_half = vec3<f32>(0.0, 0.0, 0.5 * rain.gravity_mps2);
        let w0 = hit + p0 + vel * s0 - g_half * (s0 * s0);
        let w1 = hit + p0 + vel * s1 - g_half * (s1 * s1);
        splashes[base + 1u + j] = segment_streak(w0, w1, (t_hi - t_lo) / rain.exposure_s, 0.5 * droplet_m * scale, weight, 3.0e38, 1.0);
    }
}

// The draw list: the streaks drawn (not hidden), in slot order, packed to the front of `drawn`
// with their count in `draw_args`, so the rasteriser runs over them only (nearly every slot is
// empty: a splash lives a tenth of a second of its drop's seconds-long fall). Three dispatches
// after main: the drawn streaks per block of SIMULATE_WORKGROUP drops, the blocks' offsets (one
// invocation, in block order), then each block's streaks copied to its offset in order. The
// draw order, and so the blended canvas, is exactly that of drawing every slot.
@group(0) @binding(6) var<storage, read_write> block_offsets: array<u32>;
@group(0) @binding(7) var<storage, read_write> drawn: array<Streak>;
// draw_indirect's arguments: vertex count, instance count, first vertex, first instance.
@group(0) @binding(8) var<storage, read_write> draw_args: array<u32, 4>;

var<workgroup> drawn_in_block: array<u32, SIMULATE_WORKGROUP>;

// Streaks of the g-th landing drop that the rasteriser draws (rain_streaks skips len_px < 0).
fn drawn_slots(g: u32) -> u32 {
    var n = 0u;
    if g < arrayLength(&splashes) / SPLASH_SLOTS {
        for (var s = 0u; s < SPLASH_SLOTS; s++) {
            if !(splashes[g * SPLASH_SLOTS + s].len_px < 0.0) { n++; }
        }
    }
    return n;
}

@compute @workgroup_size(SIMULATE_WORKGROUP)
fn count_drawn(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    drawn_in_block[lid.x] = drawn_slots(gid.x);
    workgroupBarrier();
    if lid.x == 0u {
        var total = 0u;
        for (var i = 0u; i < SIMULATE_WORKGROUP; i++) { total += drawn_in_block[i]; }
        block_offsets[wid.x] = total;
    }
}

@compute @workgroup_size(1)
fn offset_blocks() {
    var offset = 0u;
    for (var b = 0u; b < arrayLength(&block_offsets); b++) {
        let n = block_offsets[b];
        block_offsets[b] = offset;
        offset += n;
    }
    draw_args = array<u32, 4>(QUAD_VERTICES, offset, 0u, 0u);
}

@compute @workgroup_size(SIMULATE_WORKGROUP)
fn pack_drawn(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    drawn_in_block[lid.x] = drawn_slots(gid.x);
    workgroupBarrier();
    var out = block_offsets[wid.x];
    for (var i = 0u; i < lid.x; i++) { out += drawn_in_block[i]; }
    let g = gid.x;
    if g >= arrayLength(&splashes) / SPLASH_SLOTS { return; }
    for (var s = 0u; s < SPLASH_SLOTS; s++) {
        let streak = splashes[g * SPLASH_SLOTS + s];
        if !(streak.len_px < 0.0) {
            drawn[out] = streak;
            out++;
        }
    }
}
