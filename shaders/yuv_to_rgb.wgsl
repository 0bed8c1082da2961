// Stage yuv_to_rgb: decoded planes (integer code values) → linear RGB on the f16 canvas, with
// the frame's own matrix, range and transfer. Chroma is taken from the co-sited sample
// (nearest): rgb_to_yuv box-averages it back, so a frame without rain returns unchanged.
// The rain too far to draw drop by drop veils the background here, before the streaks are drawn
// over it: background · T + in-scatter + the lamps' glow (T = 1, in-scatter and glow = 0
// without rain: exact identity; common/plate.wgsl, common/glow.wgsl); on the open sky T goes
// to 1 for the background and the in-scatter, the glow staying (common/sky.wgsl).
// Includes: common/types.wgsl, common/color.wgsl, common/sh.wgsl, common/camera.wgsl,
// common/lights.wgsl, common/depth.wgsl, common/plate.wgsl, common/glow.wgsl, common/glow_grid.wgsl,
// common/sky.wgsl.

@group(0) @binding(0) var<uniform> frame: FrameParams;
@group(0) @binding(1) var plane_y: texture_2d<u32>;
@group(0) @binding(2) var plane_cb: texture_2d<u32>;
@group(0) @binding(3) var plane_cr: texture_2d<u32>;
@group(0) @binding(4) var canvas: texture_storage_2d<rgba16float, write>;
@group(0) @binding(5) var<uniform> rain: RainParams;
@group(0) @binding(6) var<uniform> lights: LightList;
@group(0) @binding(7) var<storage, read> rtf_table: array<vec4<f32>>;
@group(0) @binding(8) var glow_out: texture_storage_2d<rgba32float, write>;
@group(0) @binding(9) var<storage, read> scene_depth: array<f32>;
@group(0) @binding(10) var<storage, read> sky_mask: array<f32>;
// The grid `glow` wrote (the same texture as `glow_out`), read back by `main` and `layer`.
@group(0) @binding(11) var glow_grid: texture_2d<f32>;

// The lamps' glow on its coarse grid (common/glow.wgsl), before `main` or `layer` reads it.
@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn glow(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = glow_grid_width();
    let h = (u32(rain.coded_size_px.y) + GLOW_CELL_PX - 1u) / GLOW_CELL_PX + 1u;
    if id.x >= w || id.y >= h || !haze_glows() { return; }
    textureStore(glow_out, id.xy, vec4<f32>(glow_at_grid_point(id.xy), 0.0));
}

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.width || id.y >= frame.height { return; }
    let t = haze_transmittance(id.xy);
    let veil = veil_transmittance(id.xy, t);
    textureStore(canvas, id.xy, vec4<f32>(plate_linear(id.xy) * veil + in_scatter(id.xy, veil) + haze_glow(id.xy, t), 1.0));
}

// The rain layer's starting canvas: the haze alone, premultiplied over nothing (colour
// (1 − T) · L plus the glow, alpha 1 − T with the sky's T), so that this over the frame is
// what `main` writes.
@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn layer(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.width || id.y >= frame.height { return; }
    let t = haze_transmittance(id.xy);
    let veil = veil_transmittance(id.xy, t);
    textureStore(canvas, id.xy, vec4<f32>(in_scatter(id.xy, veil) + haze_glow(id.xy, t), 1.0 - veil));
}
