// lights.wgsl — the direct light term: compact sources through the drop's exact transfer
// function (the RTF table), beside the SH environment that keeps only the extended light.
//
// GPU twin of src/lighting/sources.rs (`direct_colour`); keep them in sync. Convention: θ is
// the angle between ω (from the drop toward the light) and the view ray v (eye → drop); θ = 0
// is straight through the drop, the primary bow is near θ = 138°. A light of radiance L and
// solid angle Ω adds L·Ω·F(θ); a light at distance d from the camera is seen from the drop,
// its Ω scaled by (d/|light − drop|)², the distance clamped where Ω would exceed a hemisphere.
//
// Needs, declared by the stage that includes it:
//   var<uniform> lights: LightList;  var<storage, read> rtf_table: array<vec4<f32>>;
// rtf_table[m].rgb = F (sr⁻¹) per channel over θ bin [mΔ, (m+1)Δ), Δ = π / lights.table_bins.

const LIGHTS_PI: f32 = 3.14159265358979;

// F per channel at scattering angle θ, linear between bin centres, clamped at the ends (twin of
// RtfTable::interpolated).
fn rtf_at(theta: f32) -> vec3<f32> {
    let n = lights.table_bins;
    let u = theta / LIGHTS_PI * f32(n) - 0.5;
    if u <= 0.0 { return rtf_table[0].rgb; }
    let m = u32(floor(u));
    if m + 1u >= n { return rtf_table[n - 1u].rgb; }
    return mix(rtf_table[m].rgb, rtf_table[m + 1u].rgb, u - f32(m));
}

// One light's share of direct_light, and ω (unit, drop → light, world).
struct LightTerm {
    colour: vec3<f32>,
    omega: vec3<f32>,
}

// The radiance light `l` gives a drop at `drop_from_camera_m` seen along unit `v`.
fn light_term(l: DirectLight, v: vec3<f32>, drop_from_camera_m: vec3<f32>) -> LightTerm {
    let seen = light_seen_from(l, drop_from_camera_m);
    let omega = seen.xyz;
    let scale = seen.w;
    // atan2(|ω×v|, ω·v): accurate near 0 and π, unlike acos.
    let theta = atan2(length(cross(omega, v)), dot(omega, v));
    return LightTerm(l.strength.rgb * scale * rtf_at(theta), omega);
}

// Radiance the compact lights give a drop at `drop_from_camera_m` (world axes, metres from the
// camera) seen along `view` (eye → drop, any length).
fn direct_light(view: vec3<f32>, drop_from_camera_m: vec3<f32>) -> vec3<f32> {
    let v = normalize(view);
    var c = vec3<f32>(0.0);
    for (var i = 0u; i < min(lights.count, MAX_LIGHTS); i++) {
        c += light_term(lights.lights[i], v, drop_from_camera_m).colour;
    }
    return c;
}

// Drop radiance at camera-space point `p_cam` (a drop's or a splash droplet's): the environment
// through the drop's transfer function (PRT, sh.wgsl) plus the compact lights; w: the point's
// depth (camera z, m), which rain_streaks compares with the scene's depth map.
fn drop_radiance(p_cam: vec3<f32>) -> vec4<f32> {
    let offset = world_offset(p_cam);
    let c = prt_colour(rain.env_sh, rain.drop_zonal[0], rain.drop_zonal[1], rain.drop_zonal[2], offset)
        + direct_light(offset, offset);
    return vec4<f32>(max(c, vec3<f32>(0.0)), p_cam.z);
}
