// Where the ground is (scene::ground_mask): the share of a pixel below the horizon that the
// ground plane explains, so the wet ground and the puddles keep off what stands on it. The
// mask's weights, in [0, 1], lie on the glow's grid (a point every GLOW_CELL_PX coded pixels,
// both ends included) in `ground_mask`, made from the frame on the CPU; ones when the mask is
// off, a one-element buffer reads as no mask.
//
// Needs, declared by the stage that includes it: var<uniform> rain: RainParams;
// var<storage, read> ground_mask: array<f32>; and those of common/depth.wgsl. Uses
// common/depth.wgsl.

// The ground's weight at coded pixel `p`, bilinear between the grid points around its
// centre; 1 where the depth map knows the pixel (its depth decides, ground_shown) or there is
// no mask.
fn ground_weight(p: vec2<u32>) -> f32 {
    let size = vec2<u32>(rain.coded_size_px);
    let w = (size.x + GLOW_CELL_PX - 1u) / GLOW_CELL_PX + 1u;
    let h = (size.y + GLOW_CELL_PX - 1u) / GLOW_CELL_PX + 1u;
    if arrayLength(&ground_mask) < w * h { return 1.0; }
    let centre = vec2<f32>(p) + vec2<f32>(0.5);
    if scene_depth_m(centre) > 0.0 { return 1.0; }
    let u = centre / f32(GLOW_CELL_PX);
    let g = min(vec2<u32>(floor(u)), vec2<u32>(w - 2u, h - 2u));
    let f = u - floor(u);
    let i = g.y * w + g.x;
    let top = mix(ground_mask[i], ground_mask[i + 1u], f.x);
    let bottom = mix(ground_mask[i + w], ground_mask[i + w + 1u], f.x);
    return mix(top, bottom, f.y);
}
