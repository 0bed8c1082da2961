// Stage yuv_to_rgb: decoded planes (integer code values) → linear RGB on the f16 canvas, with
// the frame's own matrix, range and transfer. Chroma is taken from the co-sited sample
// (nearest): rgb_to_yuv box-averages it back, so a frame without rain returns unchanged.
// The rain too far to draw drop by drop veils the background here, before the streaks are drawn
// over it: background · T + in-scatter (T = 1 and in-scatter = 0 without rain: exact identity).
// The in-scatter along a pixel's ray is what a drop on that ray shows (the PRT colour of the
// frame's environment, compact lights left to the drawn drops) times the haze's opacity, so the
// veil follows the light of the scene across the picture.
// Includes: common/types.wgsl, common/color.wgsl, common/sh.wgsl, common/camera.wgsl.

@group(0) @binding(0) var<uniform> frame: FrameParams;
@group(0) @binding(1) var plane_y: texture_2d<u32>;
@group(0) @binding(2) var plane_cb: texture_2d<u32>;
@group(0) @binding(3) var plane_cr: texture_2d<u32>;
@group(0) @binding(4) var canvas: texture_storage_2d<rgba16float, write>;
@group(0) @binding(5) var<uniform> rain: RainParams;

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.width || id.y >= frame.height { return; }
    let c = vec2<u32>(id.x >> frame.chroma_shift_x, id.y >> frame.chroma_shift_y);
    let code = vec3<f32>(
        f32(textureLoad(plane_y, id.xy, 0).x),
        f32(textureLoad(plane_cb, c, 0).x),
        f32(textureLoad(plane_cr, c, 0).x),
    );
    let ycc = vec3<f32>(
        (code.x - frame.y_offset) / frame.y_scale,
        (code.y - frame.c_offset) / frame.c_scale,
        (code.z - frame.c_offset) / frame.c_scale,
    );
    let linear = to_linear(frame.transfer, ycbcr_to_rgb(frame.kr, frame.kb, ycc));
    textureStore(canvas, id.xy, vec4<f32>(linear * rain.haze.w + in_scatter(id.xy), 1.0));
}

// The rain layer's starting canvas: the haze alone, premultiplied over nothing (colour
// (1 − T) · L, alpha 1 − T), so that this over the frame is what `main` writes.
@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn layer(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.width || id.y >= frame.height { return; }
    textureStore(canvas, id.xy, vec4<f32>(in_scatter(id.xy), 1.0 - rain.haze.w));
}

// The haze's in-scatter at pixel `p`, already weighted by its opacity 1 − T.
fn in_scatter(p: vec2<u32>) -> vec3<f32> {
    if rain.haze.w >= 1.0 { return vec3<f32>(0.0); }
    return (1.0 - rain.haze.w) * max(prt_colour(rain.env_sh, rain.drop_zonal[0], rain.drop_zonal[1], rain.drop_zonal[2], view_ray(p)), vec3<f32>(0.0));
}
