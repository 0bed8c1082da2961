// The open sky (scene::sky): where the scene is infinitely far, so the haze leaves the frame
// its own radiance, the sky already being the air-light at infinity (Koschmieder's limit). The
// mask's weights, in [0, 1], lie on the glow's grid (a point every GLOW_CELL_PX coded pixels,
// both ends included) in `sky_mask`, made from the frame on the CPU; a one-element buffer when
// the sky is not detected.
//
// Needs, declared by the stage that includes it: var<uniform> rain: RainParams;
// var<storage, read> sky_mask: array<f32>; and those of common/depth.wgsl. Uses
// common/glow.wgsl (the grid's width), common/camera.wgsl and common/depth.wgsl.

// The sky's weight at coded pixel `p`, bilinear between the grid points around its centre; 0
// where the pixel's distance is known finite (the depth map knows it, or a given ground lies
// below its ray) or there is no mask.
fn sky_weight(p: vec2<u32>) -> f32 {
    let w = glow_grid_width();
    let h = (u32(rain.coded_size_px.y) + GLOW_CELL_PX - 1u) / GLOW_CELL_PX + 1u;
    if arrayLength(&sky_mask) < w * h { return 0.0; }
    let centre = vec2<f32>(p) + vec2<f32>(0.5);
    if scene_depth_m(centre) > 0.0 { return 0.0; }
    if rain.ground_clip != 0u && rain.camera_pos_m.z > 0.0 && view_ray(p).z < 0.0 { return 0.0; }
    let u = centre / f32(GLOW_CELL_PX);
    let g = vec2<u32>(floor(u));
    let f = u - floor(u);
    let i = g.y * w + g.x;
    let top = mix(sky_mask[i], sky_mask[i + 1u], f.x);
    let bottom = mix(sky_mask[i + w], sky_mask[i + w + 1u], f.x);
    return mix(top, bottom, f.y);
}

// The veil's transmittance at coded pixel `p`, whose ray's haze has transmittance `t`
// (common/plate.wgsl): toward 1 on the sky, where the plate is its own air-light. The lamps'
// glow keeps `t`: the sky's radiance holds none of it.
fn veil_transmittance(p: vec2<u32>, t: f32) -> f32 {
    return t + (1.0 - t) * sky_weight(p);
}
