// water.wgsl — a water surface seen from the air, and the environment it mirrors: shared by
// the wet ground and the puddles. GPU twin of src/scene/wetness.rs (reflectance, ground_shown)
// and src/gpu/cpu/wet_ground.rs (radiance, irradiance). Needs common/sh.wgsl.

const PI: f32 = 3.14159265358979;

// How much the pixel shows the ground at camera depth `ground_m`, given the scene's depth there
// (0: unknown, taken for ground): none where the scene is nearer than 80 % of the ground's
// depth, all from 90 % (depth maps are rarely better than that).
fn ground_shown(scene_m: f32, ground_m: f32) -> f32 {
    if scene_m <= 0.0 { return 1.0; }
    return smoothstep(0.8 * ground_m, 0.9 * ground_m, scene_m);
}

// Unpolarised Fresnel reflectance of a surface of index n seen from the air at incidence
// cosine cos_i (finite at grazing, where it reaches 1).
fn water_reflectance(n: f32, cos_i: f32) -> f32 {
    let ci = clamp(cos_i, 0.0, 1.0);
    let ct = sqrt(max(1.0 - (1.0 - ci * ci) / (n * n), 0.0));
    let rs = (ci - n * ct) / (ci + n * ct);
    let rp = (n * ci - ct) / (n * ci + ct);
    return 0.5 * (rs * rs + rp * rp);
}

// The environment's radiance from direction dir (written out term by term: a loop indexing
// the arrays at run time is several times slower on CPU adapters).
fn sh_radiance(env: array<vec4<f32>, 16>, dir: vec3<f32>) -> vec3<f32> {
    let y = sh_basis16(dir);
    return env[0].rgb * y[0] + env[1].rgb * y[1] + env[2].rgb * y[2] + env[3].rgb * y[3]
        + env[4].rgb * y[4] + env[5].rgb * y[5] + env[6].rgb * y[6] + env[7].rgb * y[7]
        + env[8].rgb * y[8] + env[9].rgb * y[9] + env[10].rgb * y[10] + env[11].rgb * y[11]
        + env[12].rgb * y[12] + env[13].rgb * y[13] + env[14].rgb * y[14] + env[15].rgb * y[15];
}

// Irradiance on the level ground: the clamped cosine about +z convolved with the environment
// (Ramamoorthi & Hanrahan 2001: Â₀ = π, Â₁ = 2π/3, Â₂ = π/4, Â₃ = 0), where only the m = 0
// functions are non-zero: Y₀₀ = 0.28209, Y₁₀(+z) = 0.48860, Y₂₀(+z) = 0.63078.
fn irradiance_up(env: array<vec4<f32>, 16>) -> vec3<f32> {
    return PI * 0.28209479177387814 * env[0].rgb
        + (2.0 * PI / 3.0) * 0.4886025119029199 * env[2].rgb
        + (PI / 4.0) * 0.6307831305050401 * env[6].rgb;
}
