// Stage wet_ground: the ground wets (docs/method.md §2.3; CPU twin src/gpu/cpu/wet_ground.rs).
// Only pixels whose view ray meets the ground z = 0 in front of the camera change (d.z < 0):
// nothing at or above the horizon is written. The canvas already carries the haze
// (C = L·T + S), so the scene radiance L is taken back out, wetted, and the change veiled again:
// C' = C + w·T·((k − 1)·L + R(μ)·L_env(mirrored ray)), with k Lekner & Dorf's darkening of a
// film over a surface of albedo a = π·L / E (E the irradiance the frame's environment SH sends
// onto the level ground) and R the exact unpolarised Fresnel reflectance of water. The mirror
// image comes from four SH bands: a blurred sky, as on a rough wet road, not a sharp mirror.
// With a depth map, a pixel whose scene is nearer than the ground along its ray (a car, a wall)
// shows something standing on the ground, not the ground: it stays dry.
// Includes: common/types.wgsl, common/sh.wgsl, common/camera.wgsl, common/depth.wgsl,
// common/water.wgsl.

@group(0) @binding(0) var<uniform> rain: RainParams;
@group(0) @binding(1) var<uniform> wet: WetParams;
@group(0) @binding(2) var dry: texture_2d<f32>;
@group(0) @binding(3) var canvas: texture_storage_2d<rgba16float, write>;
@group(0) @binding(4) var<storage, read> scene_depth: array<f32>;

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(dry);
    if id.x >= size.x || id.y >= size.y { return; }
    let ray = view_ray(id.xy);
    let d = normalize(ray);
    if d.z >= 0.0 || rain.camera_pos_m.z <= 0.0 { return; }
    let c = textureLoad(dry, id.xy, 0).rgb;
    let t = rain.haze.w;
    var in_scatter = vec3<f32>(0.0);
    if t < 1.0 {
        in_scatter = (1.0 - t) * max(prt_colour(rain.env_sh, rain.drop_zonal[0], rain.drop_zonal[1], rain.drop_zonal[2], ray), vec3<f32>(0.0));
    }
    let scene = max(c - in_scatter, vec3<f32>(0.0)) / max(t, 1e-6);
    let e = irradiance_up(rain.env_sh);
    let albedo = select(vec3<f32>(0.0), clamp(PI * scene / e, vec3<f32>(0.0), vec3<f32>(1.0)), e > vec3<f32>(0.0));
    let cos_view = -d.z;
    let n = wet.water_index;
    let r = water_reflectance(n, cos_view);
    let k = (1.0 - r) * (1.0 - wet.diffuse_external) / (n * n * (1.0 - albedo * wet.diffuse_internal));
    let sky = max(sh_radiance(rain.env_sh, vec3<f32>(d.x, d.y, -d.z)), vec3<f32>(0.0));
    let change = (k - 1.0) * scene + r * sky;
    // The ray has unit camera depth: it meets the ground at camera depth h / −ray.z.
    let ground_z_m = rain.camera_pos_m.z / -ray.z;
    let shown = ground_shown(scene_depth_m(vec2<f32>(id.xy) + vec2<f32>(0.5)), ground_z_m);
    let wetness = wet.wetness * reach_fade(rain.camera_pos_m.z / cos_view, wet.reach_m) * shown;
    textureStore(canvas, id.xy, vec4<f32>(c + wetness * t * change, 1.0));
}

// 1 on ground nearer than half the reach, 0 beyond it: a ray that meets the plane farther than
// the filmed scene has met the scene first (a facade, the far shore), not the ground.
fn reach_fade(distance_m: f32, reach_m: f32) -> f32 {
    if reach_m <= 0.0 { return 1.0; }
    return 1.0 - smoothstep(0.5 * reach_m, reach_m, distance_m);
}
