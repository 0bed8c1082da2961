// The frame as the scene behind the rain: a pixel's linear colour decoded from the planes (the
// frame's own matrix, range and transfer; chroma from the co-sited sample, which rgb_to_yuv
// box-averages back), and the haze that veils it.
//
// Needs, declared by the stage that includes it: var<uniform> frame: FrameParams;
// plane_y, plane_cb, plane_cr: texture_2d<u32>; var<uniform> rain: RainParams; and those of
// common/depth.wgsl. Uses common/color.wgsl, common/sh.wgsl, common/camera.wgsl and
// common/depth.wgsl.

// The frame's linear RGB at coded pixel `p`.
fn plate_linear(p: vec2<u32>) -> vec3<f32> {
    let c = vec2<u32>(p.x >> frame.chroma_shift_x, p.y >> frame.chroma_shift_y);
    let code = vec3<f32>(
        f32(textureLoad(plane_y, p, 0).x),
        f32(textureLoad(plane_cb, c, 0).x),
        f32(textureLoad(plane_cr, c, 0).x),
    );
    let ycc = vec3<f32>(
        (code.x - frame.y_offset) / frame.y_scale,
        (code.y - frame.c_offset) / frame.c_scale,
        (code.z - frame.c_offset) / frame.c_scale,
    );
    return to_linear(frame.transfer, ycbcr_to_rgb(frame.kr, frame.kb, ycc));
}

// The haze's transmittance along the ray of coded pixel `p` (Koschmieder): e^(−β s) over the
// rain from the farthest drawn drop (rain.haze.x) to what the ray meets, s along the ray: the
// depth map's scene where it knows it; else, where a ground is given and the ray goes down to
// it, the ground plane z = 0 (the near road clear, the far road veiled); else the scene's
// depth (rain.haze.y), whose transmittance is rain.haze.w.
fn haze_transmittance(p: vec2<u32>) -> f32 {
    if rain.haze.w >= 1.0 { return 1.0; }
    let ray = view_ray(p);
    // `ray` has unit camera depth: a camera z of z metres lies z · |ray| along it.
    let mapped_m = scene_depth_m(vec2<f32>(p) + vec2<f32>(0.5)) * length(ray);
    if mapped_m > 0.0 { return exp(-rain.haze.z * max(mapped_m - rain.haze.x, 0.0)); }
    let d = normalize(ray);
    let h = rain.camera_pos_m.z;
    if rain.ground_clip == 0u || d.z >= 0.0 || h <= 0.0 { return rain.haze.w; }
    let ground_m = h / -d.z;
    if ground_m >= rain.haze.y { return rain.haze.w; }
    return exp(-rain.haze.z * max(ground_m - rain.haze.x, 0.0));
}

// The haze's in-scatter at pixel `p`, already weighted by its opacity 1 − T: what a drop on
// the pixel's ray shows (the PRT colour of the frame's environment; compact lights are left to
// the drawn drops) times the haze's opacity, so the veil follows the light across the picture.
fn in_scatter(p: vec2<u32>, t: f32) -> vec3<f32> {
    if t >= 1.0 { return vec3<f32>(0.0); }
    return (1.0 - t) * max(prt_colour(rain.env_sh, rain.drop_zonal[0], rain.drop_zonal[1], rain.drop_zonal[2], view_ray(p)), vec3<f32>(0.0));
}
