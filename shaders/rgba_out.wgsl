// Stage rgba_out: the rain layer's canvas (linear light, premultiplied, alpha = coverage) →
// 16-bit full-range code values R'G'B'A packed two to a word, two words a pixel, in the
// coded orientation. Colour is encoded with the frame's own transfer, so the layer shares
// the video's primaries and transfer; alpha is linear. Entry points: `premultiplied` writes
// the transfer of the premultiplied linear colour (premultiplication in linear light),
// `straight` the transfer of colour / alpha, `matte` the coverage alone as opaque grey, and
// `linear` the canvas itself as half floats (an OpenEXR layer: scene-linear, premultiplied,
// nothing clipped, so the light above white that the haze's glow adds is kept).
// Includes: common/types.wgsl, common/color.wgsl.

@group(0) @binding(0) var<uniform> frame: FrameParams;
@group(0) @binding(1) var canvas: texture_2d<f32>;
@group(0) @binding(2) var<storage, read_write> out_words: array<u32>;

fn code16(v: f32) -> u32 {
    return u32(round(clamp(v, 0.0, 1.0) * 65535.0));
}

fn store(p: vec2<u32>, rgba: vec4<f32>) {
    let i = 2u * (p.y * frame.width + p.x);
    out_words[i] = code16(rgba.r) | (code16(rgba.g) << 16u);
    out_words[i + 1u] = code16(rgba.b) | (code16(rgba.a) << 16u);
}

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn premultiplied(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.width || id.y >= frame.height { return; }
    let c = textureLoad(canvas, id.xy, 0);
    store(id.xy, vec4<f32>(from_linear(frame.transfer, c.rgb), c.a));
}

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn straight(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.width || id.y >= frame.height { return; }
    let c = textureLoad(canvas, id.xy, 0);
    var colour = vec3<f32>(0.0);
    if c.a > 0.0 {
        colour = from_linear(frame.transfer, c.rgb / c.a);
    }
    store(id.xy, vec4<f32>(colour, c.a));
}

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn matte(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.width || id.y >= frame.height { return; }
    let a = textureLoad(canvas, id.xy, 0).a;
    store(id.xy, vec4<f32>(a, a, a, 1.0));
}

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn linear(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.width || id.y >= frame.height { return; }
    // The canvas is Rgba16Float: each texel widens to f32 exactly and packs back exactly.
    let c = textureLoad(canvas, id.xy, 0);
    let i = 2u * (id.y * frame.width + id.x);
    out_words[i] = pack2x16float(c.rg);
    out_words[i + 1u] = pack2x16float(c.ba);
}
