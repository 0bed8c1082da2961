// The scene's depth map (`--depth`), for the stages that bind it as `scene_depth`: camera z in
// metres per displayed pixel, row-major, 0 where unknown; a one-element buffer when there is
// no map.

// The scene's depth at coded position `coded_px` (px), looked up at its displayed pixel, display = mᵀ (coded − offset); 0 (unknown)
// without a map.
fn scene_depth_m(coded_px: vec2<f32>) -> f32 {
    let size = vec2<u32>(rain.display_size_px);
    if arrayLength(&scene_depth) < size.x * size.y { return 0.0; }
    let d = coded_px - rain.coded_offset_px;
    let m = rain.coded_from_display;
    let p = vec2<f32>(m.x * d.x + m.y * d.y, m.z * d.x + m.w * d.y);
    let px = min(vec2<u32>(max(floor(p), vec2<f32>(0.0))), size - 1u);
    return scene_depth[px.y * size.x + px.x];
}
