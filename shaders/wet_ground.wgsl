// Stage wet_ground: the ground wets (docs/method.md §2.3; CPU twin src/gpu/cpu/wet_ground.rs).
// Only pixels whose view ray meets the ground z = 0 in front of the camera change (d.z < 0):
// nothing at or above the horizon is written. The scene radiance L is the frame's own, decoded
// from the planes (common/plate.wgsl); yuv_to_rgb veiled it with the haze and the lamps' glow
// (C = L·T + S + G), so the wet ground is C' = L·T + S + G + w·T·((k − 1)·L + R(μ)·L_env(mirrored
// ray)) = L·M + A, with k
// Lekner & Dorf's darkening of a film over a surface of albedo a = π·L / E (E the irradiance
// the frame's environment SH sends onto the level ground) and R the exact unpolarised Fresnel
// reflectance of water. The mirror image comes from four SH bands: a blurred sky, as on a rough
// wet road, not a sharp mirror. With a depth map, a pixel whose scene is nearer than the ground
// along its ray (a car, a wall) shows something standing on the ground, not the ground: it
// stays dry; without one, the wetness keeps to the ground found in the frame
// (common/ground_mask.wgsl).
// For the rain as a layer (entry point `layer`) the same C' is written as a premultiplied
// colour and alpha laid over the original frame: with α = 1 − min(M) over the channels, the
// colour L·(M − min(M)) + A ≥ 0 gives back L·M + A over L exactly. The darkening is per channel
// (the ground's albedo tints it), so the layer is exact over the frame it was made from.
// Includes: common/types.wgsl, common/color.wgsl, common/sh.wgsl, common/camera.wgsl,
// common/depth.wgsl, common/plate.wgsl, common/water.wgsl, common/ground_mask.wgsl,
// common/glow_grid.wgsl.

@group(0) @binding(0) var<uniform> rain: RainParams;
@group(0) @binding(1) var<uniform> wet: WetParams;
@group(0) @binding(2) var<uniform> frame: FrameParams;
@group(0) @binding(3) var plane_y: texture_2d<u32>;
@group(0) @binding(4) var plane_cb: texture_2d<u32>;
@group(0) @binding(5) var plane_cr: texture_2d<u32>;
@group(0) @binding(6) var canvas: texture_storage_2d<rgba16float, write>;
@group(0) @binding(7) var<storage, read> scene_depth: array<f32>;
@group(0) @binding(8) var<storage, read> ground_mask: array<f32>;
@group(0) @binding(9) var<uniform> lights: LightList;
@group(0) @binding(10) var glow_grid: texture_2d<f32>;

// The wet ground at pixel `p` as L·M + A: the frame's linear colour L, the factor M on it and
// the light A added (the haze's in-scatter and the lamps' glow, as yuv_to_rgb wrote them with
// the same T, and the film's reflection); `ground` false where the pixel's
// ray does not meet the ground (nothing to write).
struct Wet {
    ground: bool,
    l: vec3<f32>,
    m: vec3<f32>,
    a: vec3<f32>,
}

fn wet_at(p: vec2<u32>) -> Wet {
    let ray = view_ray(p);
    let d = normalize(ray);
    if d.z >= 0.0 || rain.camera_pos_m.z <= 0.0 { return Wet(false, vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0)); }
    let scene = plate_linear(p);
    let t = haze_transmittance(p);
    let e = irradiance_up(rain.env_sh);
    let albedo = select(vec3<f32>(0.0), clamp(PI * scene / e, vec3<f32>(0.0), vec3<f32>(1.0)), e > vec3<f32>(0.0));
    let cos_view = -d.z;
    let n = wet.water_index;
    let r = water_reflectance(n, cos_view);
    let k = (1.0 - r) * (1.0 - wet.diffuse_external) / (n * n * (1.0 - albedo * wet.diffuse_internal));
    let sky = max(sh_radiance(rain.env_sh, vec3<f32>(d.x, d.y, -d.z)), vec3<f32>(0.0));
    // The ray has unit camera depth: it meets the ground at camera depth h / −ray.z.
    let ground_z_m = rain.camera_pos_m.z / -ray.z;
    let shown = ground_shown(scene_depth_m(vec2<f32>(p) + vec2<f32>(0.5)), ground_z_m);
    let w = wet.wetness * reach_fade(rain.camera_pos_m.z / cos_view, wet.reach_m) * shown * ground_weight(p);
    return Wet(true, scene, t + w * t * (k - 1.0), in_scatter(p, t) + haze_glow(p, t) + w * t * r * sky);
}

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.width || id.y >= frame.height { return; }
    let g = wet_at(id.xy);
    if !g.ground { return; }
    textureStore(canvas, id.xy, vec4<f32>(g.l * g.m + g.a, 1.0));
}

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn layer(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.width || id.y >= frame.height { return; }
    let g = wet_at(id.xy);
    if !g.ground { return; }
    let kept = clamp(min(g.m.x, min(g.m.y, g.m.z)), 0.0, 1.0);
    textureStore(canvas, id.xy, vec4<f32>(g.l * (g.m - kept) + g.a, 1.0 - kept));
}

// 1 on ground nearer than half the reach, 0 beyond it: a ray that meets the plane farther than
// the filmed scene has met the scene first (a facade, the far shore), not the ground.
fn reach_fade(distance_m: f32, reach_m: f32) -> f32 {
    if reach_m <= 0.0 { return 1.0; }
    return 1.0 - smoothstep(0.5 * reach_m, reach_m, distance_m);
}
