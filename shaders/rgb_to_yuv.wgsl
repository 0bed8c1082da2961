// Stage rgb_to_yuv: the linear canvas → code values packed into u32 words, one buffer holding
// the Y, Cb and Cr planes back to back (rows padded to whole words), ready to copy out.
// Chroma is the box average of the block's per-pixel chroma (the inverse of the co-sited
// upsampling in yuv_to_rgb). Entry points `luma` and `chroma` each write one word per thread.
// Includes: common/types.wgsl, common/color.wgsl.

@group(0) @binding(0) var<uniform> frame: FrameParams;
@group(0) @binding(1) var canvas: texture_2d<f32>;
@group(0) @binding(2) var<storage, read_write> out_words: array<u32>;

fn encoded_ycc(p: vec2<u32>) -> vec3<f32> {
    let linear = textureLoad(canvas, p, 0).rgb;
    return rgb_to_ycbcr(frame.kr, frame.kb, from_linear(frame.transfer, linear));
}

fn to_code(v: f32, scale: f32, offset: f32) -> u32 {
    return u32(clamp(round(v * scale + offset), 0.0, frame.max_code));
}

fn samples_per_word() -> u32 {
    return 4u / frame.bytes_per_sample;
}

fn pack(word: u32, j: u32, code: u32) -> u32 {
    return word | (code << (j * 8u * frame.bytes_per_sample));
}

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn luma(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.y_row_words || id.y >= frame.height { return; }
    let n = samples_per_word();
    var word = 0u;
    for (var j = 0u; j < n; j++) {
        let x = id.x * n + j;
        if x < frame.width {
            word = pack(word, j, to_code(encoded_ycc(vec2<u32>(x, id.y)).x, frame.y_scale, frame.y_offset));
        }
    }
    out_words[id.y * frame.y_row_words + id.x] = word;
}

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn chroma(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.c_row_words || id.y >= frame.chroma_height { return; }
    let n = samples_per_word();
    var cb_word = 0u;
    var cr_word = 0u;
    for (var j = 0u; j < n; j++) {
        let cx = id.x * n + j;
        if cx < frame.chroma_width {
            let x0 = cx << frame.chroma_shift_x;
            let y0 = id.y << frame.chroma_shift_y;
            let x1 = min(x0 + (1u << frame.chroma_shift_x), frame.width);
            let y1 = min(y0 + (1u << frame.chroma_shift_y), frame.height);
            var sum = vec2<f32>(0.0);
            for (var y = y0; y < y1; y++) {
                for (var x = x0; x < x1; x++) {
                    sum += encoded_ycc(vec2<u32>(x, y)).yz;
                }
            }
            let c = sum / f32((x1 - x0) * (y1 - y0));
            cb_word = pack(cb_word, j, to_code(c.x, frame.c_scale, frame.c_offset));
            cr_word = pack(cr_word, j, to_code(c.y, frame.c_scale, frame.c_offset));
        }
    }
    let i = id.y * frame.c_row_words + id.x;
    out_words[frame.cb_offset_words + i] = cb_word;
    out_words[frame.cr_offset_words + i] = cr_word;
}
