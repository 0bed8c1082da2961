// The haze's glow around compact lights: the lamps' light that the rain beyond the drawn drops
// scatters once toward the camera (forward scattering makes the halo real rain shows around
// every lamp at night). The haze's in_scatter (common/plate.wgsl) carries the extended light
// of the SH, whose four bands cannot hold a lamp; this adds the lights through the drop's exact
// transfer table, as the drawn drops show them.
//
// The glow is as smooth as the drop's forward lobe (half its peak 20° off the lamp), so it is
// integrated on a grid of rays every GLOW_CELL_PX coded pixels (entry point `glow_grid`, into
// `glow_grid`) and each pixel interpolates it bilinearly: a per-pixel integral over 16 lights
// cost 0.35 s per 720p frame on a CPU adapter, the grid 1/64 of it.
//
// Needs, declared by the stage that includes it: var<uniform> rain: RainParams; and those of
// common/lights.wgsl. Uses common/lights.wgsl; the grid is read back at each pixel by
// common/glow_grid.wgsl (the stages after yuv_to_rgb that rewrite a pixel add it too).

// Samples along the ray per light at a finite distance; a light at infinity is seen at one
// angle all along the ray and needs none.
const HAZE_GLOW_SAMPLES: u32 = 16u;

// The compact lights scattered once by the haze into unit view ray `v`. The haze spans s from
// rain.haze.x (the farthest drawn drop: the drawn drops carry the light before it, so nothing
// is counted twice) to rain.haze.y (the scene), with transmittance T = rain.haze.w =
// e^(−β (y − x)); a drop at s scatters L Ω(s) F(θ(s)) toward the camera, weighted
// β e^(−β (s − x)) ds. At infinity Ω and θ are constant: (1 − T) L Ω F(θ). A light at a finite
// distance is a point the ray passes at h: its Ω(s) ∝ 1/r² peaks there, so the samples are
// equiangular (uniform in the angle φ = atan((s − s₀)/h) seen from the light, where
// ds/r² = dφ/h), which integrates the peak exactly and leaves a slowly varying rest. β is the
// imaging extinction (rain::physics::imaging_extinction_per_m): the diffracted half of a drop's
// extinction stays in the beam, so what the beam loses is what the geometric optics scatter
// through F.
fn haze_glow_along(v: vec3<f32>) -> vec3<f32> {
    let opacity = 1.0 - rain.haze.w;
    let near_m = rain.haze.x;
    let far_m = max(rain.haze.y, near_m + 1e-6);
    let beta_per_m = -log(rain.haze.w) / (far_m - near_m);
    var c = vec3<f32>(0.0);
    for (var i = 0u; i < min(lights.count, MAX_LIGHTS); i++) {
        let l = lights.lights[i];
        if l.direction_distance.w <= 0.0 {
            c += opacity * light_term(l, v, v * near_m).colour;
            continue;
        }
        let light_m = l.direction_distance.xyz * l.direction_distance.w;
        let s0_m = dot(light_m, v);
        let h_m = max(length(light_m - s0_m * v), max(l.strength.w, 1e-4));
        let phi_a = atan((near_m - s0_m) / h_m);
        let dphi = (atan((far_m - s0_m) / h_m) - phi_a) / f32(HAZE_GLOW_SAMPLES);
        for (var k = 0u; k < HAZE_GLOW_SAMPLES; k++) {
            let phi = phi_a + (f32(k) + 0.5) * dphi;
            let s_m = s0_m + h_m * tan(phi);
            let cos_phi = cos(phi);
            let ds_m = h_m / (cos_phi * cos_phi) * dphi;
            let weight = beta_per_m * exp(-beta_per_m * (s_m - near_m)) * ds_m;
            c += weight * light_term(l, v, v * s_m).colour;
        }
    }
    return c;
}

// The glow along the ray through grid point `g`, at coded position GLOW_CELL_PX · g (pixel
// corners: pixel p's centre is p + ½).
fn glow_at_grid_point(g: vec2<u32>) -> vec3<f32> {
    return haze_glow_along(normalize(view_ray_at(vec2<f32>(g * GLOW_CELL_PX))));
}
