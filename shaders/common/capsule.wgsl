// The capsule streak's coverage and occlusion at a point, shared by rain_streaks (fs_main, a
// fragment per covered pixel) and streak_tiles (the same sum by compute), so both draw the
// same picture.

// Half a pixel beyond the drawn radius: the quad's margin around the capsule, every pixel whose
// centre the disc reaches inside it.
const AA_MARGIN_PX: f32 = 0.5;
// Depth over which a drop passing behind the scene fades out, m: a few centimetres, so depth
// edges are soft and a drop does not flicker on a surface it touches.
const OCCLUSION_SOFTNESS_M: f32 = 0.05;

// Fraction of the exposure during which a disc of radius r, moving uniformly from 0 to len
// along x, covers the point (along, across).
fn coverage(along: f32, across: f32, len: f32, r: f32) -> f32 {
    let h2 = r * r - across * across;
    if h2 <= 0.0 { return 0.0; }
    let h = sqrt(h2);
    if len < 1e-3 {
        return select(0.0, 1.0, abs(along) < h);
    }
    let overlap = clamp(along + h, 0.0, len) - clamp(along - h, 0.0, len);
    return overlap / len;
}

// The drop's depth `along` px down its path: 1/z is affine in the picture along a projected
// segment, so it is interpolated, not z.
fn drop_depth_m(along: f32, len: f32, depth_m: vec2<f32>) -> f32 {
    let t = select(0.0, clamp(along / len, 0.0, 1.0), len >= 1e-3);
    return 1.0 / mix(1.0 / depth_m.x, 1.0 / depth_m.y, t);
}

// How much of a drop at depth `drop_m` shows in front of a scene at `scene_m` (0: unknown).
fn visibility(scene_m: f32, drop_m: f32) -> f32 {
    if scene_m <= 0.0 { return 1.0; }
    return smoothstep(-0.5 * OCCLUSION_SOFTNESS_M, 0.5 * OCCLUSION_SOFTNESS_M, scene_m - drop_m);
}
