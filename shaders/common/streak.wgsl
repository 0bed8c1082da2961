// A world segment of water → the streak it draws over the exposure: near-clipped, projected,
// widened to at least MIN_RADIUS_PX and by the lens's defocus, its alpha scaled so coverage is
// conserved (Garg & Nayar's time fraction), and hidden where it could not change a pixel. One
// function for the drops (rain_simulate) and the splash droplets (rain_splashes).
// Needs common/camera.wgsl (to_camera) and common/lights.wgsl (drop_radiance).

// MIN_RADIUS_PX and MIN_PEAK_ALPHA come from rain::physics (gpu::shaders::constants): the rain
// plan bounds the sizes it simulates by the same cull (rain::volume::visible).

// A streak that is not drawn (rain_streaks skips len_px < 0).
fn hidden() -> Streak {
    return Streak(vec2<f32>(0.0), vec2<f32>(0.0, 1.0), -1.0, 0.0, 0.0, 0u, vec4<f32>(0.0), vec4<f32>(0.0));
}

// The streak of water of radius `radius_m` moving from w0 to w1 (world) while in view for
// `exposed` of the exposure, its coverage times `weight`; drawn no wider than `max_radius_px`,
// and not at all when thinner than `min_width_px` at its distance (before any widening).
fn segment_streak(w0: vec3<f32>, w1: vec3<f32>, exposed: f32, radius_m: f32, weight: f32, max_radius_px: f32, min_width_px: f32) -> Streak {
    var c0 = to_camera(w0);
    var c1 = to_camera(w1);
    let near = rain.near_clip_m;
    if c0.z < near && c1.z < near { return hidden(); }
    // Clip the segment to the near plane.
    if c0.z < near { c0 = mix(c0, c1, (near - c0.z) / (c1.z - c0.z)); }
    if c1.z < near { c1 = mix(c1, c0, (near - c1.z) / (c0.z - c1.z)); }
    let f = rain.focal_px;
    let z = min(c0.z, c1.z);
    let r = radius_m * f / z;
    if 2.0 * r < min_width_px { return hidden(); }
    let q0 = rain.principal_px + f * c0.xy / c0.z;
    let q1 = rain.principal_px + f * c1.xy / c1.z;
    // Defocus: the thin lens spreads the drop over its circle of confusion (Garg & Nayar,
    // "When does a camera see rain?"); coverage is conserved, so alpha falls as r²/r_eff².
    let blur_radius = 0.5 * rain.lens_blur_k_px_m * abs(rain.inv_focus_per_m - 1.0 / z);
    let r_eff = min(max(sqrt(r * r + blur_radius * blur_radius), MIN_RADIUS_PX), max_radius_px);
    let seg = q1 - q0;
    let len = length(seg);
    var dir = vec2<f32>(0.0, 1.0);
    if len > 1e-4 { dir = seg / len; }
    let alpha_scale = (r * r) / (r_eff * r_eff) * rain.opacity * rain.drop_weight * exposed * weight;
    // Peak coverage on the streak's axis: the disc's chord over the path length.
    let peak = alpha_scale * min(1.0, 2.0 * r_eff / max(len, 1e-3));
    if peak < MIN_PEAK_ALPHA { return hidden(); }
    let ext = r_eff + 1.0;
    let lo = min(q0, q1) - vec2<f32>(ext);
    let hi = max(q0, q1) + vec2<f32>(ext);
    if hi.x < 0.0 || hi.y < 0.0 || lo.x > rain.display_size_px.x || lo.y > rain.display_size_px.y {
        return hidden();
    }
    return Streak(q0, dir, len, r_eff, alpha_scale, 0u, drop_radiance(c0), drop_radiance(c1));
}
