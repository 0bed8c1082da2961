// Stage rain_streaks: the streaks of rain_simulate rasterised into the linear canvas, one quad
// per drop in drop order (so blending is deterministic), premultiplied; the pipeline blends
// src + dst·(1 − αsrc). The fragment evaluates exactly the fraction of the exposure during which
// the drop's disc covers the pixel.
// Occlusion: scene_depth holds the scene's depth (camera z, m) per displayed pixel, row-major,
// 0 where unknown. A drop fades out as it passes behind the scene, over OCCLUSION_SOFTNESS_M of
// depth centred on the surface; where the depth is unknown nothing hides it (the ground, when
// one is given, already ends each streak where its drop lands). Without a depth map the buffer
// holds one element and the alpha is multiplied by exactly 1.
// Includes: common/types.wgsl, common/depth.wgsl.

@group(0) @binding(0) var<uniform> rain: RainParams;
@group(0) @binding(1) var<storage, read> streaks: array<Streak>;
@group(0) @binding(2) var<storage, read> scene_depth: array<f32>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    // x: px along the streak from q0, y: px across it.
    @location(0) local_px: vec2<f32>,
    // x: streak length px, y: r_eff px, z: alpha scale.
    @location(1) @interpolate(flat) shape: vec3<f32>,
    // Drop radiance for the view ray here, linear RGB.
    @location(2) radiance: vec3<f32>,
    // The drop's depth (camera z, m) at the start and end of its path.
    @location(3) @interpolate(flat) depth_m: vec2<f32>,
}

const AA_MARGIN_PX: f32 = 0.5;
// Depth over which a drop passing behind the scene fades out, m: a few centimetres, so depth
// edges are soft and a drop does not flicker on a surface it touches.
const OCCLUSION_SOFTNESS_M: f32 = 0.05;

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) id: u32) -> VsOut {
    let s = streaks[id];
    if s.len_px < 0.0 {
        return VsOut(vec4<f32>(2.0, 2.0, 2.0, 1.0), vec2<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec2<f32>(1.0));
    }
    // Two triangles: corners (along ∈ {start, end}) × (across ∈ {−, +}).
    let corner = array<vec2<f32>, 6>(
        vec2<f32>(0.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(0.0, 1.0),
        vec2<f32>(0.0, 1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
    )[vertex];
    let ext = s.r_eff_px + AA_MARGIN_PX;
    let along = mix(-ext, s.len_px + ext, corner.x);
    let across = corner.y * ext;
    let nrm = vec2<f32>(-s.dir.y, s.dir.x);
    let p_display = s.q0_px + s.dir * along + nrm * across;
    let m = rain.coded_from_display;
    let p_coded = vec2<f32>(m.x * p_display.x + m.z * p_display.y, m.y * p_display.x + m.w * p_display.y)
        + rain.coded_offset_px;
    let clip = vec2<f32>(2.0 * p_coded.x / rain.coded_size_px.x - 1.0, 1.0 - 2.0 * p_coded.y / rain.coded_size_px.y);
    let t = clamp(along / max(s.len_px, 1e-3), 0.0, 1.0);
    let radiance = mix(s.radiance0.rgb, s.radiance1.rgb, t);
    return VsOut(vec4<f32>(clip, 0.0, 1.0), vec2<f32>(along, across), vec3<f32>(s.len_px, s.r_eff_px, s.alpha_scale), radiance,
        vec2<f32>(s.radiance0.w, s.radiance1.w));
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

// The drop's depth `along` px down its path: 1/z is affine in the picture along a projected
// segment, so it is interpolated, not z.
fn drop_depth_m(along: f32, len: f32, depth_m: vec2<f32>) -> f32 {
    let t = select(0.0, clamp(along / len, 0.0, 1.0), len >= 1e-3);
    return 1.0 / mix(1.0 / depth_m.x, 1.0 / depth_m.y, t);
}

// How much of a drop at depth `drop_m` shows in front of a scene at `scene_m` (0: unknown).
fn visibility(scene_m: f32, drop_m: f32) -> f32 {
    if scene_m <= 0.0 { return 1.0; }
    return smoothstep(-0.5 * OCCLUSION_SOFTNESS_M, 0.5 * OCCLUSION_SOFTNESS_M, scene_m - drop_m);
}

@fragment
fn fs_main(v: VsOut) -> @location(0) vec4<f32> {
    let drop_m = drop_depth_m(v.local_px.x, v.shape.x, v.depth_m);
    let a = clamp(coverage(v.local_px.x, v.local_px.y, v.shape.x, v.shape.y) * v.shape.z, 0.0, 1.0)
        * visibility(scene_depth_m(v.clip.xy), drop_m);
    if a <= 0.0 { discard; }
    return vec4<f32>(v.radiance * a, a);
}
