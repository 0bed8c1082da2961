// Stage rain_streaks: every drop drawn as a camera-facing streak into the linear canvas.
//
// A drop of projected radius r moving from q0 to q1 (px) during the exposure covers a pixel for
// the fraction of the exposure its disc overlaps the pixel: Garg & Nayar's time-averaged
// streak (alpha = τ/T). The fragment evaluates that fraction exactly for a disc on a segment;
// drops thinner than a pixel are widened to r_eff and their alpha scaled by (r/r_eff)², which
// keeps the integrated coverage (sub-pixel coverage folded into alpha). Premultiplied output;
// the pipeline blends src + dst·(1 − αsrc).
// Colour: a streak shows the drop's radiance for its view ray, the dot product
// of the frame's environment SH with the drop's transfer function rotated to the ray (PRT,
// SPEC §3–5; common/sh.wgsl).
// Includes: common/types.wgsl, common/rng.wgsl, common/drops.wgsl, common/sh.wgsl.

@group(0) @binding(0) var<uniform> rain: RainParams;
@group(0) @binding(1) var<storage, read> columns: array<Column>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    // x: px along the streak from q0, y: px across it.
    @location(0) local_px: vec2<f32>,
    // x: streak length px, y: r_eff px, z: alpha scale.
    @location(1) @interpolate(flat) shape: vec3<f32>,
    // Drop radiance (PRT) for the view ray through this vertex, linear RGB.
    @location(2) radiance: vec3<f32>,
}

const MIN_RADIUS_PX: f32 = 0.7;
const AA_MARGIN_PX: f32 = 0.5;
// Streaks whose brightest pixel would change by less than half a code value of 8-bit video are
// not drawn: they are invisible, and on CPU adapters raster work is most of the cost.
const MIN_PEAK_ALPHA: f32 = 0.5 / 255.0;

fn culled() -> VsOut {
    return VsOut(vec4<f32>(2.0, 2.0, 2.0, 1.0), vec2<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
}

fn to_camera(p_world: vec3<f32>) -> vec3<f32> {
    let d = p_world - rain.camera_pos_m.xyz;
    return vec3<f32>(dot(rain.camera_from_world_0.xyz, d), dot(rain.camera_from_world_1.xyz, d), dot(rain.camera_from_world_2.xyz, d));
}

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) id: u32) -> VsOut {
    let drop = drop_state(id);
    let half = drop.vel_mps * (0.5 * rain.exposure_s);
    var c0 = to_camera(drop.pos_m - half);
    var c1 = to_camera(drop.pos_m + half);
    let near = rain.near_clip_m;
    if c0.z < near && c1.z < near { return culled(); }
    // Clip the segment to the near plane.
    if c0.z < near { c0 = mix(c0, c1, (near - c0.z) / (c1.z - c0.z)); }
    if c1.z < near { c1 = mix(c1, c0, (near - c1.z) / (c0.z - c1.z)); }
    let f = rain.camera_pos_m.w;
    let q0 = rain.principal_px + f * c0.xy / c0.z;
    let q1 = rain.principal_px + f * c1.xy / c1.z;
    let z = min(c0.z, c1.z);
    let r = 0.5e-3 * drop.width_mm * f / z;
    // Defocus: the thin lens spreads the drop over its circle of confusion (Garg & Nayar,
    // "When does a camera see rain?"); coverage is conserved, so alpha falls as r²/r_eff².
    let blur_radius = 0.5 * rain.lens_blur_k_px_m * abs(rain.inv_focus_per_m - 1.0 / z);
    let r_eff = max(sqrt(r * r + blur_radius * blur_radius), MIN_RADIUS_PX);
    // A drop this close fills the view: it is a blur on the lens, not a streak.
    if r_eff > 0.1 * rain.display_size_px.y { return culled(); }
    let seg = q1 - q0;
    let len = length(seg);
    var dir = vec2<f32>(0.0, 1.0);
    if len > 1e-4 { dir = seg / len; }
    let nrm = vec2<f32>(-dir.y, dir.x);
    let alpha_scale = (r * r) / (r_eff * r_eff) * rain.opacity * rain.drop_weight;
    // Peak coverage on the streak's axis: the disc's chord over the path length.
    let peak = alpha_scale * min(1.0, 2.0 * r_eff / max(len, 1e-3));
    if peak < MIN_PEAK_ALPHA { return culled(); }
    let ext = r_eff + AA_MARGIN_PX;
    let lo = min(q0, q1) - vec2<f32>(ext);
    let hi = max(q0, q1) + vec2<f32>(ext);
    if hi.x < 0.0 || hi.y < 0.0 || lo.x > rain.display_size_px.x || lo.y > rain.display_size_px.y {
        return culled();
    }
    // Two triangles: corners (along ∈ {start, end}) × (across ∈ {−, +}).
    let corner = array<vec2<f32>, 6>(
        vec2<f32>(0.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(0.0, 1.0),
        vec2<f32>(0.0, 1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
    )[vertex];
    let along = mix(-ext, len + ext, corner.x);
    let across = corner.y * ext;
    let p_display = q0 + dir * along + nrm * across;
    let m = rain.coded_from_display;
    let p_coded = vec2<f32>(m.x * p_display.x + m.z * p_display.y, m.y * p_display.x + m.w * p_display.y)
        + rain.coded_offset_px;
    let clip = vec2<f32>(2.0 * p_coded.x / rain.coded_size_px.x - 1.0, 1.0 - 2.0 * p_coded.y / rain.coded_size_px.y);
    // The view ray changes by a few degrees at most along a streak, far below what 4 SH bands
    // resolve: the drop's radiance is evaluated per vertex and interpolated.
    let d = (p_display - rain.principal_px) / f;
    let ray = rain.camera_from_world_0.xyz * d.x + rain.camera_from_world_1.xyz * d.y + rain.camera_from_world_2.xyz;
    let radiance = max(prt_colour(rain.env_sh, rain.drop_zonal[0], rain.drop_zonal[1], rain.drop_zonal[2], ray), vec3<f32>(0.0));
    return VsOut(vec4<f32>(clip, 0.0, 1.0), vec2<f32>(along, across), vec3<f32>(len, r_eff, alpha_scale), radiance);
}

// Fraction of the exposure during which a disc of radius r, moving uniformly from 0 to len
// along x, covers the point (along, across).
fn coverage(along: f32, across: f32, len: f32, r: f32) -> f32 {
    let h2 = r * r - across * across;
    if h2 <= 0.0 { return 0.0; }
    let h = sqrt(h2);
    if len < 1e-3 {
        return select(0.0, 1.0, abs(along) < h);
    }
    let overlap = clamp(along + h, 0.0, len) - clamp(along - h, 0.0, len);
    return overlap / len;
}

@fragment
fn fs_main(v: VsOut) -> @location(0) vec4<f32> {
    let a = clamp(coverage(v.local_px.x, v.local_px.y, v.shape.x, v.shape.y) * v.shape.z, 0.0, 1.0);
    if a <= 0.0 { discard; }
    return vec4<f32>(v.radiance * a, a);
}
