// sh.wgsl — real spherical harmonics (4 bands, 16 coefficients) and the raindrop PRT colour.
//
// GPU twin of src/lighting/sh.rs (`basis16_cartesian`) and src/lighting/prt.rs (`prt_colour`);
// keep them in sync. Conventions: world z up; index i = l(l+1)+m; real SH WITHOUT the
// Condon–Shortley phase (every Cartesian constant positive: Y_1,-1 = +0.4886 y).
// Only functions and consts: this file is concatenated before other shader files.
//
// Layouts (as uploaded by EnvironmentSh::to_gpu_array and RtfSh::to_gpu_array):
//   env:     array<vec4<f32>, 16>, env[i] = (r, g, b, 0) coefficient i of the environment.
//   zonal_r: vec4<f32> = (z_0, z_1, z_2, z_3) of the red channel's RTF about the view ray,
//            likewise zonal_g, zonal_b (raw z_l; the sqrt(4π/(2l+1)) factor is applied here).
//   view_dir: eye → drop (normalised here).

// sqrt(4π/(2l+1)) for l = 0..3: the zonal-harmonic rotation factor.
const SH_ZONAL_FACTOR: vec4<f32> = vec4<f32>(3.5449077018110318, 2.0466534158929770, 1.5853309190424044, 1.3398491713435027);

// The 16 basis functions at a unit direction (Cartesian forms of thesis eq. 4.14).
fn sh_basis16(dir: vec3<f32>) -> array<f32, 16> {
    let x = dir.x;
    let y = dir.y;
    let z = dir.z;
    var b: array<f32, 16>;
    b[0] = 0.28209479177387814;
    b[1] = 0.4886025119029199 * y;
    b[2] = 0.4886025119029199 * z;
    b[3] = 0.4886025119029199 * x;
    b[4] = 1.0925484305920792 * x * y;
    b[5] = 1.0925484305920792 * y * z;
    b[6] = 0.31539156525252005 * (3.0 * z * z - 1.0);
    b[7] = 1.0925484305920792 * x * z;
    b[8] = 0.5462742152960396 * (x * x - y * y);
    b[9] = 0.5900435899266435 * y * (3.0 * x * x - y * y);
    b[10] = 2.890611442640554 * x * y * z;
    b[11] = 0.4570457994644658 * y * (5.0 * z * z - 1.0);
    b[12] = 0.3731763325901154 * z * (5.0 * z * z - 3.0);
    b[13] = 0.4570457994644658 * x * (5.0 * z * z - 1.0);
    b[14] = 1.445305721320277 * z * (x * x - y * y);
    b[15] = 0.5900435899266435 * x * (x * x - 3.0 * y * y);
    return b;
}

// Drop radiance for a view ray: Σ_lm L_lm · sqrt(4π/(2l+1)) z_l Y_lm(v), per channel.
fn prt_colour(
    env: array<vec4<f32>, 16>,
    zonal_r: vec4<f32>,
    zonal_g: vec4<f32>,
    zonal_b: vec4<f32>,
    view_dir: vec3<f32>,
) -> vec3<f32> {
    let y = sh_basis16(normalize(view_dir));
    // Per band l: the RTF's coefficient factor per channel.
    var t: array<vec3<f32>, 4>;
    for (var l = 0u; l < 4u; l++) {
        t[l] = vec3<f32>(zonal_r[l], zonal_g[l], zonal_b[l]) * SH_ZONAL_FACTOR[l];
    }
    var c = env[0].rgb * t[0] * y[0];
    c += (env[1].rgb * y[1] + env[2].rgb * y[2] + env[3].rgb * y[3]) * t[1];
    c += (env[4].rgb * y[4] + env[5].rgb * y[5] + env[6].rgb * y[6] + env[7].rgb * y[7]
        + env[8].rgb * y[8]) * t[2];
    c += (env[9].rgb * y[9] + env[10].rgb * y[10] + env[11].rgb * y[11] + env[12].rgb * y[12]
        + env[13].rgb * y[13] + env[14].rgb * y[14] + env[15].rgb * y[15]) * t[3];
    return c;
}
