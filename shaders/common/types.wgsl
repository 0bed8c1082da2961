// Structs shared by the stages. Each has one Rust twin in src/gpu/types.rs (same name, same
// field order); tests/shaders.rs checks sizes and offsets with naga.

// One frame's layout and colour interpretation (see src/video/color.rs).
struct FrameParams {
    width: u32,              // luma width, coded orientation
    height: u32,
    chroma_shift_x: u32,     // log2 subsampling
    chroma_shift_y: u32,
    y_offset: f32,           // code of black
    y_scale: f32,            // code span black..white
    c_offset: f32,           // code of zero chroma
    c_scale: f32,            // code span of chroma −½..½
    max_code: f32,
    transfer: u32,           // Transfer::gpu_id
    kr: f32,
    kb: f32,
    bytes_per_sample: u32,   // 1 or 2
    y_row_words: u32,        // u32 words per row of the packed output planes
    c_row_words: u32,
    cb_offset_words: u32,    // plane starts in the packed output buffer
    cr_offset_words: u32,
    chroma_width: u32,
    chroma_height: u32,
    _pad: u32,
}

// The camera, the rain volume and the look of the streaks, for one frame.
struct RainParams {
    camera_pos_m: vec3<f32>,
    focal_px: f32,
    camera_from_world_0: vec4<f32>,  // rows of camera_from_world (w unused)
    camera_from_world_1: vec4<f32>,
    camera_from_world_2: vec4<f32>,
    principal_px: vec2<f32>,         // display picture centre
    display_size_px: vec2<f32>,
    coded_from_display: vec4<f32>,   // 2×2 matrix, column-major (display rotation)
    coded_offset_px: vec2<f32>,
    coded_size_px: vec2<f32>,
    column_slope: vec2<f32>,         // sheared columns: x = u + slope.x·z, y = v + slope.y·z
    cell_size_m: vec2<f32>,
    wind_mean_mps: vec2<f32>,
    mean_travel_cells: vec2<f32>,    // mean wind · t / cell size, modulo 1 (computed in f64)
    haze: vec4<f32>,                 // rain beyond the drawn drops: x its start, y its end (m), z extinction (1/m), w transmittance to y; it scatters env_sh and the lights
    env_sh: array<vec4<f32>, SH_COEFFS>,    // the frame's environment, 4 SH bands, rgb per coefficient
    drop_zonal: array<vec4<f32>, 3>, // the drop's RTF zonal coefficients z0..z3 per channel R, G, B
    gust_amp: array<vec4<f32>, GUSTS>,   // per gust component: ax, ay (m/s), ω (rad/s), unused
    gust_phase: array<vec4<f32>, GUSTS>, // cos(ωt+φ), sin(ωt+φ), cos φ, sin φ (computed in f64)
    time_whole_s: u32,               // t = whole + frac (see drops.wgsl: long clips)
    time_frac_s: f32,
    exposure_s: f32,
    seed: u32,
    drop_count: u32,
    column_count: u32,
    opacity: f32,                    // alpha multiplier (1 = physical coverage)
    near_clip_m: f32,
    drop_weight: f32,                // > 1 where the particle budget binds
    d_min_mm: f32,                   // truncated exponential size distribution
    d_max_mm: f32,
    lambda_per_mm: f32,
    diameter_scale: f32,             // drawn diameter = sampled diameter × this
    lens_blur_k_px_m: f32,           // defocus diameter px = k·|1/focus − 1/z|; 0 = pinhole
    inv_focus_per_m: f32,
    gravity_mps2: f32,
    drift_q: vec2<i32>,              // the columns' drift per metre fallen, 2^-DRIFT_BITS cells/m
    ground_clip: u32,                // 1: streaks end where drops land on the ground z = 0
    _pad: u32,
    wind_slope_mps2: vec2<f32>,      // keyed wind: the mean wind's slope now (0 when steady)
    wind_start_mps: vec2<f32>,       // keyed wind: the mean wind at t = 0
    wind_kink_count: u32,            // entries of wind_kinks
    rate_key_count: u32,             // entries of rate_keys; 0: the rate is constant, every drop falls
    _pad_keys: vec2<u32>,
    wind_kinks: array<vec4<f32>, MAX_KEYS>,  // the slope's changes so far: t − t_j (s), Δb_j (m/s²)
    rate_keys: array<vec4<f32>, MAX_KEYS>,   // the keyed rate: t_k − t (s), rate (mm/h)
    speed_q: array<vec4<u32>, SPEED_TABLE_LEN / 4u>,  // fall speed at size quantile i/(N−1), 2^-SPEED_BITS m/s
}

// A column of the rain volume: a sheared prism over cell [u0, u0+du] × [v0, v0+dv] between
// heights z_lo and z_lo + height.
struct Column {
    cell_min_m: vec2<f32>,
    z_lo_m: f32,
    height_m: f32,
    first_drop: u32,
    drop_count: u32,
    inv_height_q: u32,      // 1 / height_m, 2^-INV_HEIGHT_BITS m^-1 (the fall rate's grid)
    size_keep_q: u32,       // share of the sizes it simulates, 1 - F(D_cut), 2^-24 (drops.wgsl: size_bits)
}

// One drop's streak for the frame (rain_simulate → rain_streaks), in the displayed picture.
struct Streak {
    q0_px: vec2<f32>,       // start of the centre's path
    dir: vec2<f32>,         // unit direction of motion
    len_px: f32,            // path length; < 0: not drawn
    r_eff_px: f32,          // drawn radius (sub-pixel drops widened, defocus included)
    alpha_scale: f32,       // coverage multiplier
    drop_info: u32,         // pack2x16unorm(diameter mm / 10, view elevation / 90°): the matte bins
    radiance0: vec4<f32>,   // drop radiance seen at q0 (rgb); w: the drop's depth there (camera z, m)
    radiance1: vec4<f32>,   // and at the end of the path
}

// One compact light for the direct term (src/lighting/sources.rs, LightSource).
struct DirectLight {
    direction_distance: vec4<f32>,  // xyz: unit camera → light, world; w: distance m, 0 = infinity
    strength: vec4<f32>,            // rgb: radiance × solid angle at the camera; w: closest a drop may be, m
}

// Light `l` seen from the point `from_camera_m` (world axes, metres from the camera): xyz the
// unit direction point → light, w the factor (d/|light − point|)² on its solid angle, the
// distance clamped at the closest a drop may be; 1 for a light at infinity
// (DirectLight::seen_from).
fn light_seen_from(l: DirectLight, from_camera_m: vec3<f32>) -> vec4<f32> {
    let d = l.direction_distance.w;
    if d <= 0.0 { return vec4<f32>(l.direction_distance.xyz, 1.0); }
    let to_light = l.direction_distance.xyz * d - from_camera_m;
    let r = length(to_light);
    let omega = select(l.direction_distance.xyz, to_light / r, r > 0.0);
    let q = d / max(r, l.strength.w);
    return vec4<f32>(omega, q * q);
}

// The frame's compact lights (the brightest MAX_LIGHTS) and the size of the RTF table.
struct LightList {
    count: u32,
    table_bins: u32,                // θ bins of rtf_table over [0, π]
    _pad: vec2<u32>,
    lights: array<DirectLight, MAX_LIGHTS>,
}

// The wet ground's look for one frame (src/scene/wetness.rs; stage wet_ground).
struct WetParams {
    wetness: f32,           // share of the ground under a water film, [0, 1]
    water_index: f32,       // refractive index of the film
    diffuse_external: f32,  // the film's reflectance for diffuse light from the air
    diffuse_internal: f32,  // and for diffuse light inside it (total internal reflection included)
    reach_m: f32,           // how far the ground reaches: wetness fades from reach/2 to reach (0: no limit)
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

// The brightest compact light of a drop, drawn with its point-light matte (--streaks mattes).
struct Glint {
    colour: vec4<f32>,      // rgb: its radiance on the drop, L·Ω·F(θ) (taken out of the Streak's); 0: none
    light_dir: vec4<f32>,   // xyz: drop → light in the streak's frame: x image right, y away from the camera, z against the fall
}

// The streak mattes' bins (src/drops/atlas.rs, MatteAtlas; stage rain_streaks, --streaks mattes).
struct MatteParams {
    counts: vec4<u32>,              // size bins, view bins, phases, 0
    sizes_mm: array<vec4<f32>, 2>,  // bin diameters, mm (MAX_MATTE_BINS = 8)
    views_deg: array<vec4<f32>, 2>, // bin camera elevations, degrees
    lights: array<vec4<f32>, MAX_MATTE_LIGHTS>, // xyz: the point-light mattes' directions, the Glint frame
    light_count: vec4<u32>,         // x: point-light directions (0: none), y: first light layer
    reach: vec4<f32>,               // x: how far across a streak the matte reaches, radii; yz: 1 / the matte texture's size
}

// The puddles' water map and look for one frame (src/gpu/stages/puddles.rs; stage puddles).
struct PuddleParams {
    origin_m: vec2<f32>,    // corner of the water map's cell (0, 0) on the ground, world x, y
    cell_m: f32,            // its cell edge
    edge_depth_m: f32,      // water covers the ground smoothly from depth 0 to this
    cells: vec2<u32>,       // cells along x, y (row-major, x fastest)
    ring_count: u32,        // live entries of `ripples`
    far_slope_rms: f32,     // RMS slope of the water rained on, where single rings are finer than a pixel
    water_index: f32,
    diffuse_external: f32,  // Lekner & Dorf's diffuse reflectances (see WetParams)
    diffuse_internal: f32,
    light_lobe: f32,        // concentration κ of a compact light's mirror image (rad⁻²)
    resolve_depth_m: f32,   // camera depth where single rings become finer than a pixel
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

// One ripple ring at the frame's time (src/fluid/ripples.rs, RingState): a Gaussian wave packet
// in the distance r from its centre, η = a·exp(−(r − R)²/(2s²))·cos(k r − φ).
struct Ripple {
    centre_m: vec2<f32>,    // point of impact, world x, y
    radius_m: f32,          // R: the envelope's peak
    width_m: f32,           // s
    amplitude_m: f32,       // a
    wavenumber: f32,        // k, rad/m
    phase: f32,             // φ = ω t modulo 2π
    _pad: f32,
}
