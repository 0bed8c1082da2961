// Stage rain_simulate: each drop once per frame — its closed-form state at the frame's time,
// the streak it draws over the exposure (projected, near-clipped, widened and defocused), the
// light it shows — written to `streaks[id]` for rain_streaks to rasterise. Evaluating this in
// the vertex stage would repeat it for each of a quad's four vertices.
//
// A drop of projected radius r moving from q0 to q1 (px) during the exposure covers a pixel for
// the fraction of the exposure its disc overlaps the pixel: Garg & Nayar's time-averaged streak
// (alpha = τ/T). Drops thinner than a pixel are widened to r_eff and their alpha scaled by
// (r/r_eff)², which keeps the integrated coverage; defocus widens them the same way. Streaks
// whose brightest pixel would change by less than half a code value of 8-bit video are marked
// invisible (len_px < 0): on CPU adapters raster work is most of the cost.
// With a ground (ground_clip), a streak ends where its drop lands on z = 0 during the exposure,
// and a drop that landed before it opened is not drawn: no streak reaches below the ground
// (but for its end disc, under a pixel wide for all but the nearest drops).
// Drops near the lens are large soft discs (the circle of confusion): they are drawn no wider
// than NEAR_FIELD_MAX_RADIUS of the picture height, their alpha still (r/r_drawn)², so the
// integrated coverage stays physical while the cost of the few such drops stays bounded.
// Colour: the drop's radiance for the view ray through each end of the streak, the dot product
// of the frame's environment SH with the drop's transfer function rotated to the ray (PRT,
// thesis §5.1.2; docs/method.md, "Lighting"), plus the compact lights through the exact
// transfer table (lights.wgsl), seen from the end's position; the ray changes by a few degrees
// at most along a streak.
// Includes: common/types.wgsl, common/rng.wgsl, common/drops.wgsl, common/sh.wgsl,
// common/camera.wgsl, common/lights.wgsl, common/streak.wgsl.

@group(0) @binding(0) var<uniform> rain: RainParams;
@group(0) @binding(1) var<storage, read> columns: array<Column>;
@group(0) @binding(2) var<storage, read_write> streaks: array<Streak>;
@group(0) @binding(3) var<uniform> lights: LightList;
@group(0) @binding(4) var<storage, read> rtf_table: array<vec4<f32>>;
// main_mattes only.
@group(0) @binding(5) var<storage, read_write> glints: array<Glint>;

// NEAR_FIELD_MAX_RADIUS (the largest drawn radius over the picture height) comes from
// rain::physics.

// What picks a drop's streak matte: its diameter and the camera's elevation over the plane
// normal to its fall (asin |view · fall|, 0 = seen side-on), for `view_cam` (camera axes, any
// length) the ray to the streak's middle.
fn drop_info(drop: DropState, view_cam: vec3<f32>) -> u32 {
    let view = rain.camera_from_world_0.xyz * view_cam.x + rain.camera_from_world_1.xyz * view_cam.y + rain.camera_from_world_2.xyz * view_cam.z;
    let fall = drop.vel_mps / max(length(drop.vel_mps), 1e-6);
    let elevation_deg = degrees(asin(min(abs(dot(normalize(view), fall)), 1.0)));
    return pack2x16unorm(vec2<f32>(drop.diameter_mm / 10.0, elevation_deg / 90.0));
}

fn streak_of(id: u32) -> Streak {
    let drop = drop_state(id);
    if !drop.falls { return hidden(); }
    let half = drop.vel_mps * (0.5 * rain.exposure_s);
    let w0 = drop.pos_m - half;
    var w1 = drop.pos_m + half;
    // Impact: at constant velocity over the exposure the drop meets the ground z = 0 at the
    // fraction w0.z / (w0.z − w1.z) of it; the streak ends there and covers each pixel for
    // that much less of the exposure (its alpha scales by the fraction, its length too).
    var exposed = 1.0;
    if rain.ground_clip != 0u && w1.z < 0.0 {
        if w0.z <= 0.0 { return hidden(); }
        exposed = w0.z / (w0.z - w1.z);
        w1 = mix(w0, w1, exposed);
    }
    // Near the lens the blur disc can fill the view: the drawn radius is capped (coverage is
    // kept by the alpha, the cost by the cap).
    var s = segment_streak(w0, w1, exposed, 0.5e-3 * drop.width_mm, 1.0, NEAR_FIELD_MAX_RADIUS * rain.display_size_px.y, 0.0);
    if s.len_px >= 0.0 { s.drop_info = drop_info(drop, to_camera(drop.pos_m)); }
    return s;
}

@compute @workgroup_size(SIMULATE_WORKGROUP)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= rain.drop_count { return; }
    streaks[id.x] = streak_of(id.x);
}

// With point-light mattes (--streaks mattes): the drop's GLINTS_PER_DROP strongest compact
// lights (by the sum of their rgb), at its mid-exposure position, leave the streak's smooth
// colour and are written as glints, strongest first (zero colour: none), for rain_streaks to
// draw each with its light's matte, its direction in the matte's frame. Weaker lights stay in
// the smooth colour. The lights were added to the colour at the streak's ends, the glints are
// taken at its middle: where they would exceed the mean colour they are scaled down to it, so
// the light is moved, never counted twice nor made negative.
@compute @workgroup_size(SIMULATE_WORKGROUP)
fn main_mattes(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= rain.drop_count { return; }
    var s = streak_of(id.x);
    var strongest: array<LightTerm, GLINTS_PER_DROP>;
    var dirs: array<vec3<f32>, GLINTS_PER_DROP>;
    // Per channel, the share of the glints' light the streak can give them.
    var share = vec3<f32>(0.0);
    if s.len_px >= 0.0 && lights.count > 0u {
        let drop = drop_state(id.x);
        let offset = drop.pos_m - rain.camera_pos_m.xyz;
        let v = normalize(offset);
        for (var i = 0u; i < min(lights.count, MAX_LIGHTS); i++) {
            // Insertion into the strongest so far; the weakest drops out.
            var t = light_term(lights.lights[i], v, offset);
            for (var k = 0u; k < GLINTS_PER_DROP; k++) {
                if dot(t.colour, vec3<f32>(1.0)) > dot(strongest[k].colour, vec3<f32>(1.0)) {
                    let weaker = strongest[k];
                    strongest[k] = t;
                    t = weaker;
                }
            }
        }
        // The matte's frame: z against the fall, y the view's horizontal part, x = y × z.
        let up = -drop.vel_mps / max(length(drop.vel_mps), 1e-6);
        var away = v - up * dot(v, up);
        away = select(vec3<f32>(0.0, 1.0, 0.0), normalize(away), length(away) > 1e-6);
        let right = cross(away, up);
        var sum = vec3<f32>(0.0);
        for (var k = 0u; k < GLINTS_PER_DROP; k++) {
            sum += strongest[k].colour;
            let w = strongest[k].omega;
            dirs[k] = vec3<f32>(dot(w, right), dot(w, away), dot(w, up));
        }
        // Per channel, the glints hold at most the streak's mean colour; what they hold leaves
        // the mean exactly: both ends lose it, or one end all it has and the other the rest.
        let both = s.radiance0.rgb + s.radiance1.rgb;
        let taken = min(sum, 0.5 * both);
        let left = max(both - 2.0 * taken, vec3<f32>(0.0));
        let end0 = clamp(s.radiance0.rgb - taken, vec3<f32>(0.0), left);
        s.radiance0 = vec4<f32>(end0, s.radiance0.w);
        s.radiance1 = vec4<f32>(left - end0, s.radiance1.w);
        share = select(taken / max(sum, vec3<f32>(1e-30)), vec3<f32>(1.0), sum <= taken);
    }
    streaks[id.x] = s;
    for (var k = 0u; k < GLINTS_PER_DROP; k++) {
        glints[GLINTS_PER_DROP * id.x + k] = Glint(vec4<f32>(strongest[k].colour * share, 0.0), vec4<f32>(dirs[k], 0.0));
    }
}
