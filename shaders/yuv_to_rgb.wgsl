// Stage yuv_to_rgb: decoded planes (integer code values) → linear RGB on the f16 canvas, with
// the frame's own matrix, range and transfer. Chroma is taken from the co-sited sample
// (nearest): rgb_to_yuv box-averages it back, so a frame without rain returns unchanged.
// The rain too far to draw drop by drop veils the background here, before the streaks are drawn
// over it: background · T + in-scatter (T = 1 and in-scatter = 0 without rain: exact identity).
// Includes: common/types.wgsl, common/color.wgsl.

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
    textureStore(canvas, id.xy, vec4<f32>(linear * rain.haze.w + rain.haze.rgb, 1.0));
}
