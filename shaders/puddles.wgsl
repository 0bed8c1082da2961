// Stage puddles: standing water on the ground, shaded into the picture (docs/method.md,
// "Puddles: shading"; CPU twin src/gpu/cpu/puddles.rs). A pixel whose view ray meets the ground
// z = 0 at P takes the water depth there from the map (Catmull-Rom, C¹; the water covers the
// ground smoothly as the depth rises from 0 to edge_depth_m). The map is signed, negative where
// dry (src/fluid/puddles/shown.rs), so the rim, its interpolated zero, falls between cells and
// turns smoothly across them; the cover is the share of the pixel's footprint under water (an
// antialiased rim, water_cover). The water's normal is the flat normal tilted by the slopes of the ripple rings; its surface shows C' = C + c·T·((k − 1)·L + R·L_r):
// the ground under it darkened by Lekner & Dorf's k (as the wet ground), plus the exact
// unpolarised Fresnel reflectance R of the rippled surface times the radiance L_r along the
// mirrored ray. L_r is the frame itself where the mirrored ray's image lies in it: with a depth
// map the ray is marched in screen space until it passes behind the filmed scene; without one
// (or where it passes nothing) it is the picture towards its direction (content at a distance,
// exact for the sky). Where the image leaves the frame L_r is the SH environment plus the
// compact lights, blended over the last EDGE_PX pixels.
// The ground under the water is the frame's own (decoded from the planes, common/plate.wgsl),
// not the canvas, which already holds the wet ground's film: the water replaces the film where
// it covers the ground, C' = C + cover·(L·T + S + G + T·((k − 1)·L + R·L_r) − C) (G the
// lamps' glow, common/glow_grid.wgsl, as yuv_to_rgb added it), instead of
// darkening it twice. Without a depth map, the water keeps to the ground found in the frame
// (common/ground_mask.wgsl).
// Includes: common/types.wgsl, common/color.wgsl, common/sh.wgsl, common/camera.wgsl,
// common/depth.wgsl, common/water.wgsl, common/plate.wgsl, common/ground_mask.wgsl,
// common/glow_grid.wgsl.

@group(0) @binding(0) var<uniform> rain: RainParams;
@group(0) @binding(1) var<uniform> puddle: PuddleParams;
@group(0) @binding(2) var picture: texture_2d<f32>;
@group(0) @binding(3) var canvas: texture_storage_2d<rgba16float, write>;
@group(0) @binding(4) var<storage, read> scene_depth: array<f32>;
@group(0) @binding(5) var<storage, read> water_depth_m: array<f32>;
@group(0) @binding(6) var<storage, read> ripples: array<Ripple>;
@group(0) @binding(7) var<uniform> lights: LightList;
@group(0) @binding(8) var<uniform> frame: FrameParams;
@group(0) @binding(9) var plane_y: texture_2d<u32>;
@group(0) @binding(10) var plane_cb: texture_2d<u32>;
@group(0) @binding(11) var plane_cr: texture_2d<u32>;
@group(0) @binding(12) var<storage, read> ground_mask: array<f32>;
@group(0) @binding(13) var glow_grid: texture_2d<f32>;

// The reflection fades from the frame to the environment over this many pixels at its border.
const EDGE_PX: f32 = 8.0;
// The screen-space march along the mirrored ray's image: a step every MARCH_STRIDE_PX, at most
// MARCH_MAX_STEPS, up to MARCH_FARTHEST of the way to the vanishing point, then halvings of the
// step that passed behind the scene.
const MARCH_STRIDE_PX: f32 = 2.0;
const MARCH_MAX_STEPS: u32 = 64u;
const MARCH_FARTHEST: f32 = 0.999;
const MARCH_HALVINGS: u32 = 6u;
// A ray counts as behind the scene's surface only to this fraction of its depth (no farther:
// it passed behind a thin object).
const MARCH_THICKNESS: f32 = 0.25;

// The rings that can reach the workgroup's pixels, one bit per ring in ring order (so every
// pixel sums them in the same order whichever thread found them).
var<workgroup> tile_rings: array<atomic<u32>, RING_WORDS>;

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(workgroup_id) tile: vec3<u32>, @builtin(local_invocation_index) thread: u32) {
    cull_rings(tile.xy, thread);
    shade(id.xy, false);
}

// For the rain as a layer: the canvas holds the layer so far (premultiplied colour C_l, alpha
// α_l, over the frame L); the water is written as the layer that, over L, gives the picture
// (1 − a)·(C_l + (1 − α_l)·L) + a·(L·M + A), a the water's cover, M = T·k its factor on L
// per channel, A the haze and the reflection: α = 1 − min F with F = (1 − a)(1 − α_l) + a·M,
// colour (1 − a)·C_l + a·A + L·(F − min F) ≥ 0 (as the wet ground does, §5.2).
@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn layer(@builtin(global_invocation_id) id: vec3<u32>, @builtin(workgroup_id) tile: vec3<u32>, @builtin(local_invocation_index) thread: u32) {
    cull_rings(tile.xy, thread);
    shade(id.xy, true);
}

// Marks in tile_rings the rings whose annulus R ± 4s meets the ground under the workgroup's
// pixel centres (the bounding box of its four corner pixels' ground points; every ring where a
// corner pixel looks at or above the horizon).
fn cull_rings(tile: vec2<u32>, thread: u32) {
    if thread < RING_WORDS { atomicStore(&tile_rings[thread], 0u); }
    workgroupBarrier();
    let h = rain.camera_pos_m.z;
    let last = min(tile * PIXEL_WORKGROUP + vec2<u32>(PIXEL_WORKGROUP - 1u), textureDimensions(picture) - vec2<u32>(1u));
    var bounded = h > 0.0;
    var lo = vec2<f32>(3.4e38);
    var hi = vec2<f32>(-3.4e38);
    for (var k = 0u; k < 4u; k++) {
        let corner = select(tile * PIXEL_WORKGROUP, last, vec2<bool>((k & 1u) == 1u, (k & 2u) == 2u));
        let ray = view_ray(corner);
        if ray.z >= 0.0 { bounded = false; }
        let g = rain.camera_pos_m.xy + (h / -ray.z) * ray.xy;
        lo = min(lo, g);
        hi = max(hi, g);
    }
    for (var i = thread; i < puddle.ring_count; i += PIXEL_WORKGROUP * PIXEL_WORKGROUP) {
        let ring = ripples[i];
        let nearest = distance(clamp(ring.centre_m, lo, hi), ring.centre_m);
        let farthest = length(max(abs(lo - ring.centre_m), abs(hi - ring.centre_m)));
        let reach = 4.0 * ring.width_m;
        if !bounded || (nearest <= ring.radius_m + reach && farthest >= ring.radius_m - reach) {
            atomicOr(&tile_rings[i / 32u], 1u << (i % 32u));
        }
    }
    workgroupBarrier();
}

fn shade(id: vec2<u32>, layer: bool) {
    let size = textureDimensions(picture);
    if id.x >= size.x || id.y >= size.y { return; }
    let ray = view_ray(id);
    let d = normalize(ray);
    let h = rain.camera_pos_m.z;
    if d.z >= 0.0 || h <= 0.0 { return; }
    // The ray has unit camera depth: it meets the ground at camera depth h / −ray.z.
    let ground_z_m = h / -ray.z;
    let p = rain.camera_pos_m + ground_z_m * ray;
    let cover = water_cover(p.xy, ground_per_px(ray, ground_z_m));
    if cover <= 0.0 { return; }
    let shown = ground_shown(scene_depth_m(vec2<f32>(id) + vec2<f32>(0.5)), ground_z_m) * ground_weight(id);
    if shown <= 0.0 { return; }
    let c = picture_at(vec2<i32>(id));
    let t = haze_transmittance(id);
    let scene = plate_linear(id);
    let e = irradiance_up(rain.env_sh);
    let albedo = select(vec3<f32>(0.0), clamp(PI * scene / e, vec3<f32>(0.0), vec3<f32>(1.0)), e > vec3<f32>(0.0));
    let n_w = puddle.water_index;
    let k = (1.0 - water_reflectance(n_w, -d.z)) * (1.0 - puddle.diffuse_external) / (n_w * n_w * (1.0 - albedo * puddle.diffuse_internal));
    let slope = ripple_slope(p.xy);
    let normal = normalize(vec3<f32>(-slope, 1.0));
    let cos_i = max(-dot(d, normal), 0.0);
    let mirrored = d + 2.0 * cos_i * normal;
    let r = water_reflectance(n_w, cos_i);
    let a = cover * shown;
    let seen = rough_reflected(p, d, slope, mirrored, ground_z_m);
    if layer {
        let held = textureLoad(picture, id, 0);
        let m = t * k;
        let added = in_scatter(id, t) + haze_glow(id, t) + t * r * seen;
        let f = (1.0 - a) * (1.0 - held.a) + a * m;
        let kept = clamp(min(f.x, min(f.y, f.z)), 0.0, 1.0);
        textureStore(canvas, id, vec4<f32>((1.0 - a) * held.rgb + a * added + scene * (f - kept), 1.0 - kept));
        return;
    }
    let change = (k - 1.0) * scene + r * seen;
    let water = scene * t + in_scatter(id, t) + haze_glow(id, t) + t * change;
    // Rounded to the nearest f16 here, as the CPU back end's canvas is: the store's own
    // conversion rounds toward zero on some adapters (Mesa's lavapipe), a step darker where
    // a sliver of water (a cover of a few thousandths at a rim) changes the texel by less
    // (quantizeToF16 is defined within f16's range only).
    let out = clamp(c + a * (water - c), vec3<f32>(-65504.0), vec3<f32>(65504.0));
    textureStore(canvas, id, vec4<f32>(quantizeToF16(out), 1.0));
}

// The reflection along `mirrored` off the surface of slope `slope`, blurred where the
// rain's rings are finer than a pixel (beyond camera depth resolve_depth_m, fully from twice
// that): the mean of the reflections off the slope moved by ±σ along x and along y, four
// slopes of variance σ²/2 per axis like an isotropic slope distribution of mean square σ²
// (src/fluid/ripples.rs, rain_slope_variance).
fn rough_reflected(p: vec3<f32>, d: vec3<f32>, slope: vec2<f32>, mirrored: vec3<f32>, depth_m: f32) -> vec3<f32> {
    if puddle.far_slope_rms <= 0.0 { return reflected(p, mirrored); }
    let s = puddle.resolve_depth_m;
    let sigma = puddle.far_slope_rms * smoothstep(s, 2.0 * s, depth_m);
    if sigma <= 0.0 { return reflected(p, mirrored); }
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < 4u; i++) {
        let axis = select(vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 0.0), i < 2u);
        let tilt = select(-sigma, sigma, (i & 1u) == 0u) * axis;
        let n = normalize(vec3<f32>(-(slope + tilt), 1.0));
        let c = max(-dot(d, n), 0.0);
        sum += reflected(p, d + 2.0 * c * n);
    }
    return 0.25 * sum;
}

// A probe of water_cover spans at most this many cells along each axis of the footprint (the
// twin's PROBE_CELLS), and an axis has at most this many whole probes (MAX_PROBES).
const PROBE_CELLS: f32 = 2.0;
const MAX_PROBES: f32 = 15.0;

// The water's cover at ground point `xy` for a pixel whose ground point moves by `per_px`: the
// share of the pixel's footprint under water. A footprint longer than PROBE_CELLS along an axis
// (far ground at a grazing angle) is cut into a centre piece, whole pieces out from it and two
// shorter pieces at its ends (growing from 0 with the footprint: no jump where one is added),
// and the cover is the mean of probe_cover over the pieces by their area (the twin's
// water_cover, in its order); one piece where it is not.
fn water_cover(xy: vec2<f32>, per_px: mat2x2<f32>) -> f32 {
    let share_a = max(PROBE_CELLS * puddle.cell_m / length(per_px[0]), 1.0 / MAX_PROBES);
    let share_b = max(PROBE_CELLS * puddle.cell_m / length(per_px[1]), 1.0 / MAX_PROBES);
    if share_a >= 1.0 && share_b >= 1.0 { return probe_cover(xy, per_px); }
    let ka = select(floor((1.0 / share_a - 1.0) / 2.0), 0.0, share_a >= 1.0);
    let kb = select(floor((1.0 / share_b - 1.0) / 2.0), 0.0, share_b >= 1.0);
    let na = select(2 * i32(ka) + 3, 1, share_a >= 1.0);
    let nb = select(2 * i32(kb) + 3, 1, share_b >= 1.0);
    var cover = 0.0;
    for (var i = 0; i < na; i++) {
        let pa = footprint_piece(share_a, ka, i);
        if pa.y <= 0.0 { continue; }
        for (var j = 0; j < nb; j++) {
            let pb = footprint_piece(share_b, kb, j);
            if pb.y <= 0.0 { continue; }
            let at = xy + pa.x * per_px[0] + pb.x * per_px[1];
            cover += pa.y * pb.y * probe_cover(at, mat2x2<f32>(pa.y * per_px[0], pb.y * per_px[1]));
        }
    }
    return cover;
}

// Piece `m` of an axis cut into pieces of `share` (k whole pieces each side of the centre's):
// (its centre's offset from the footprint's, its length), shares of the axis; the centre
// first, then the whole pieces out and back, then the two ends (the twin's footprint_pieces).
fn footprint_piece(share: f32, k: f32, m: i32) -> vec2<f32> {
    if share >= 1.0 { return vec2<f32>(0.0, 1.0); }
    if m == 0 { return vec2<f32>(0.0, share); }
    let whole = 2 * i32(k);
    if m <= whole {
        let s = f32((m + 1) / 2) * share;
        return vec2<f32>(select(-s, s, m % 2 == 1), share);
    }
    let end = 0.5 * (1.0 - (2.0 * k + 1.0) * share);
    let out = (k + 0.5) * share + 0.5 * end;
    return vec2<f32>(select(-out, out, m == whole + 1), end);
}

// One probe's cover at ground point `xy`, the share of its footprint under water: the
// mean of smoothstep(0, edge_depth_m, depth) over a box of one pixel's width across the rim
// (rim_cover), the depth (m, signed: negative where dry) read by Catmull-Rom over the 4×4
// cells around it (0 off the map) and clamped to the four nearest cells' range, widened toward
// the twelve around them where the pixel's footprint passes their square. C¹, so the
// rim turns smoothly across the cells' edges (a bilinear reading's zero kinks there); exact on
// planes and quadratics; the clamp keeps its overshoot from making water or dry ground that
// none of the cells the footprint reaches holds, and settles the cover from the four nearest
// alone where the footprint stays in their square and all are dry or all deeper than the rim
// (the same value, without the other twelve reads). The
// depth's change per pixel is the reading's own derivative (Catmull-Rom's) along the ground
// point's change per pixel `per_px` (columns: per pixel along x, along y). Each row along x,
// then the rows along y (the twin's water_depth).
fn probe_cover(xy: vec2<f32>, per_px: mat2x2<f32>) -> f32 {
    let u = (xy - puddle.origin_m) / puddle.cell_m - vec2<f32>(0.5);
    let c = vec2<i32>(floor(u));
    let f = u - floor(u);
    let a = map_cell(c);
    let b = map_cell(c + vec2<i32>(1, 0));
    let d = map_cell(c + vec2<i32>(0, 1));
    let e = map_cell(c + vec2<i32>(1, 1));
    var lo = min(min(a, b), min(d, e));
    var hi = max(max(a, b), max(d, e));
    // Widened toward the twelve cells around the four by how far the footprint passes their
    // square toward each (the twin's footprint_range).
    let half = 0.5 * (abs(per_px[0]) + abs(per_px[1])) / puddle.cell_m;
    let before = clamp(half - f, vec2<f32>(0.0), vec2<f32>(1.0));
    let after = clamp(f + half - vec2<f32>(1.0), vec2<f32>(0.0), vec2<f32>(1.0));
    let leaves = max(max(before.x, before.y), max(after.x, after.y)) > 0.0;
    if !leaves {
        if hi <= 0.0 { return 0.0; }
        if lo >= puddle.edge_depth_m { return 1.0; }
    }
    let r0 = map_row(c + vec2<i32>(-1, -1));
    let r1 = vec4<f32>(map_cell(c + vec2<i32>(-1, 0)), a, b, map_cell(c + vec2<i32>(2, 0)));
    let r2 = vec4<f32>(map_cell(c + vec2<i32>(-1, 1)), d, e, map_cell(c + vec2<i32>(2, 1)));
    let r3 = map_row(c + vec2<i32>(-1, 2));
    if leaves {
        let reach_x = vec4<f32>(before.x, 1.0, 1.0, after.x);
        let reach_y = vec4<f32>(before.y, 1.0, 1.0, after.y);
        let w = mat4x4<f32>(reach_y.x * reach_x, reach_y.y * reach_x, reach_y.z * reach_x, reach_y.w * reach_x);
        let cells = mat4x4<f32>(r0, r1, r2, r3);
        var down = 0.0;
        var up = 0.0;
        for (var j = 0; j < 4; j++) {
            let below = w[j] * max(vec4<f32>(lo) - cells[j], vec4<f32>(0.0));
            let above = w[j] * max(cells[j] - vec4<f32>(hi), vec4<f32>(0.0));
            down = max(down, max(max(below.x, below.y), max(below.z, below.w)));
            up = max(up, max(max(above.x, above.y), max(above.z, above.w)));
        }
        lo -= down;
        hi += up;
        if hi <= 0.0 { return 0.0; }
        if lo >= puddle.edge_depth_m { return 1.0; }
    }
    let wx = catmull_rom(f.x);
    let dx = catmull_rom_slope(f.x);
    let rows = vec4<f32>(dot(wx, r0), dot(wx, r1), dot(wx, r2), dot(wx, r3));
    let sum = dot(catmull_rom(f.y), rows);
    let along_x = dot(catmull_rom(f.y), vec4<f32>(dot(dx, r0), dot(dx, r1), dot(dx, r2), dot(dx, r3)));
    let along_y = dot(catmull_rom_slope(f.y), rows);
    // The depth's gradient on the ground (m per m), then its change per pixel.
    let grad = vec2<f32>(along_x, along_y) / puddle.cell_m;
    let width = length(vec2<f32>(dot(grad, per_px[0]), dot(grad, per_px[1])));
    return rim_cover(sum, lo, hi, width, puddle.edge_depth_m);
}

// The mean of smoothstep(0, edge, clamp(s, lo, hi)) for s spread evenly over depth ± width/2
// (the depth's run across one pixel): the clamped parts at their ends' cover, the rest the
// ramp's integral. A box whose variance is the pixel's for any direction of the rim (|∇D|²/12);
// the plain smoothstep where the pixel spans under a thousandth of the ramp. Exactly 0 where
// hi <= 0 and 1 where lo >= edge (the callers' shortcut).
fn rim_cover(depth: f32, lo: f32, hi: f32, width: f32, edge: f32) -> f32 {
    if width <= 1e-3 * edge { return smoothstep(0.0, edge, clamp(depth, lo, hi)); }
    let x0 = depth - 0.5 * width;
    let x1 = depth + 0.5 * width;
    let below = max(min(x1, lo) - x0, 0.0) * smoothstep(0.0, edge, lo);
    let above = max(x1 - max(x0, hi), 0.0) * smoothstep(0.0, edge, hi);
    let a = clamp(x0, lo, hi);
    let b = clamp(x1, lo, hi);
    let ramp = max(b - max(a, edge), 0.0) + ramp_area(clamp(b, 0.0, edge), edge) - ramp_area(clamp(a, 0.0, edge), edge);
    return clamp((below + ramp + above) / width, 0.0, 1.0);
}

// ∫₀ˢ smoothstep(0, edge, x) dx for 0 <= s <= edge: edge·(t³ − t⁴/2), t = s/edge.
fn ramp_area(s: f32, edge: f32) -> f32 {
    let t = s / edge;
    return edge * t * t * t * (1.0 - 0.5 * t);
}

// The ground point's change per pixel along x and along y (m, columns) for the view ray `ray`
// (unit camera depth, meeting the ground at camera depth `ground_z_m`): the ray is affine in the
// pixel, r' per pixel, and the point h·r/(−r_z) moves by (h/(−r_z))·(r' − r·r'_z/r_z).
fn ground_per_px(ray: vec3<f32>, ground_z_m: f32) -> mat2x2<f32> {
    let m = rain.coded_from_display;
    let along_x = (rain.camera_from_world_0.xyz * m.x + rain.camera_from_world_1.xyz * m.z) / rain.focal_px;
    let along_y = (rain.camera_from_world_0.xyz * m.y + rain.camera_from_world_1.xyz * m.w) / rain.focal_px;
    let gx = ground_z_m * (along_x - ray * (along_x.z / ray.z));
    let gy = ground_z_m * (along_y - ray * (along_y.z / ray.z));
    return mat2x2<f32>(gx.xy, gy.xy);
}

// The Catmull-Rom weights of the four cells around a point at fraction `t` of the way from the
// second to the third.
fn catmull_rom(t: f32) -> vec4<f32> {
    let t2 = t * t;
    let t3 = t2 * t;
    return 0.5 * vec4<f32>(-t3 + 2.0 * t2 - t, 3.0 * t3 - 5.0 * t2 + 2.0, -3.0 * t3 + 4.0 * t2 + t, t3 - t2);
}

// The derivative of catmull_rom's weights by `t`.
fn catmull_rom_slope(t: f32) -> vec4<f32> {
    let t2 = t * t;
    return 0.5 * vec4<f32>(-3.0 * t2 + 4.0 * t - 1.0, 9.0 * t2 - 10.0 * t, -9.0 * t2 + 8.0 * t + 1.0, 3.0 * t2 - 2.0 * t);
}

// The map's four cells from `c` along x (0 off the map).
fn map_row(c: vec2<i32>) -> vec4<f32> {
    return vec4<f32>(map_cell(c), map_cell(c + vec2<i32>(1, 0)), map_cell(c + vec2<i32>(2, 0)), map_cell(c + vec2<i32>(3, 0)));
}

fn map_cell(c: vec2<i32>) -> f32 {
    let n = vec2<i32>(puddle.cells);
    if any(c < vec2<i32>(0)) || any(c >= n) { return 0.0; }
    return water_depth_m[c.y * n.x + c.x];
}

// The gradient of the water's height at `xy`: the radial slope dη/dr along r̂ of every ring
// the workgroup kept.
fn ripple_slope(xy: vec2<f32>) -> vec2<f32> {
    var g = vec2<f32>(0.0);
    for (var word = 0u; word < RING_WORDS; word++) {
        var bits = atomicLoad(&tile_rings[word]);
        while bits != 0u {
            let i = 32u * word + firstTrailingBit(bits);
            bits &= bits - 1u;
            let ring = ripples[i];
            let off = xy - ring.centre_m;
            let r = length(off);
            let u = r - ring.radius_m;
            if abs(u) > 4.0 * ring.width_m || r < 1e-6 { continue; }
            let s2 = ring.width_m * ring.width_m;
            let envelope = exp(-0.5 * u * u / s2);
            let carrier = ring.wavenumber * r - ring.phase;
            let dr = ring.amplitude_m * envelope * (-u / s2 * cos(carrier) - ring.wavenumber * sin(carrier));
            g += dr * off / r;
        }
    }
    return g;
}

// Coded pixel position (px, continuous) of camera-space point `q` (q.z > 0).
fn project(q: vec3<f32>) -> vec2<f32> {
    let s = rain.principal_px + rain.focal_px * q.xy / q.z;
    let m = rain.coded_from_display;
    return vec2<f32>(m.x * s.x + m.z * s.y, m.y * s.x + m.w * s.y) + rain.coded_offset_px;
}

// The radiance the water at ground point `p` mirrors along unit direction `dir`.
fn reflected(p: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    // Without a hit: the picture towards the direction itself (its vanishing point).
    var q = camera_dir(dir);
    let hit = march(p, dir);
    if hit.w > 0.0 {
        q = hit.xyz;
    }
    if q.z <= 1e-6 { return environment(p, dir); }
    let at = project(q);
    let size = vec2<f32>(textureDimensions(picture));
    let inside = min(min(at.x, at.y), min(size.x - at.x, size.y - at.y));
    let w = smoothstep(0.0, EDGE_PX, inside);
    if w <= 0.0 { return environment(p, dir); }
    if w >= 1.0 { return sample_frame(at); }
    return mix(environment(p, dir), sample_frame(at), w);
}

// Where the mirrored ray from `p` along `dir` first passes behind the filmed scene (camera
// space, w = 1), or w = 0: no depth map, or nothing met in the frame. The ray's image runs from
// p's pixel to its vanishing point; it is walked in even steps along that image (a point at
// share λ of the way lies at distance s = λ·z_p / ((1 − λ)·dir_z) along the ray, dir_z its
// camera depth per metre), so no step skips an object's edge by more than MARCH_STRIDE_PX.
fn march(p: vec3<f32>, dir: vec3<f32>) -> vec4<f32> {
    let size = vec2<u32>(rain.display_size_px);
    if arrayLength(&scene_depth) < size.x * size.y { return vec4<f32>(0.0); }
    let q_p = to_camera(p);
    let q_dir = camera_dir(dir);
    if q_dir.z <= 1e-6 { return vec4<f32>(0.0); }
    let image_px = length(project(q_dir) - project(q_p));
    let steps = u32(clamp(ceil(image_px / MARCH_STRIDE_PX), 1.0, f32(MARCH_MAX_STEPS)));
    var before = 0.0;
    for (var i = 1u; i <= steps; i++) {
        let share = MARCH_FARTHEST * f32(i) / f32(steps);
        let q = q_p + march_distance(q_p.z, q_dir.z, share) * q_dir;
        if !in_frame(project(q)) { return vec4<f32>(0.0); }
        if behind(q) {
            var lo = before;
            var hi = share;
            for (var j = 0u; j < MARCH_HALVINGS; j++) {
                let mid = 0.5 * (lo + hi);
                if behind(q_p + march_distance(q_p.z, q_dir.z, mid) * q_dir) { hi = mid; } else { lo = mid; }
            }
            return vec4<f32>(q_p + march_distance(q_p.z, q_dir.z, hi) * q_dir, 1.0);
        }
        before = share;
    }
    return vec4<f32>(0.0);
}

// Distance along the ray at share `share` of its image (see march).
fn march_distance(z_p: f32, dir_z: f32, share: f32) -> f32 {
    return share * z_p / ((1.0 - share) * dir_z);
}

// World direction `dir` in the camera's frame.
fn camera_dir(dir: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(rain.camera_from_world_0.xyz, dir), dot(rain.camera_from_world_1.xyz, dir), dot(rain.camera_from_world_2.xyz, dir));
}

fn in_frame(at: vec2<f32>) -> bool {
    let size = vec2<f32>(textureDimensions(picture));
    return all(at >= vec2<f32>(0.0)) && all(at < size);
}

// Whether camera-space point `q` lies behind the scene's surface at its pixel (but not far),
// where that surface stands on the ground: nearer than the ground plane along the pixel's ray
// (the 90 % of ground_shown), or above the horizon. The mirrored ray runs above the plane, so
// the plane itself is never met (its depths, quantised per pixel, would otherwise be).
fn behind(q: vec3<f32>) -> bool {
    if q.z <= 0.0 { return false; }
    let at = project(q);
    let z = scene_depth_m(at);
    if z <= 0.0 || q.z < z || q.z > z * (1.0 + MARCH_THICKNESS) { return false; }
    let ray = view_ray(vec2<u32>(max(floor(at), vec2<f32>(0.0))));
    return ray.z >= 0.0 || z < 0.9 * rain.camera_pos_m.z / -ray.z;
}

// The picture before the water at coded pixel `i`: the canvas, which for the rain as a layer
// holds the layer (α < 1), laid over the frame itself. A picture's canvas has α = 1: no decode.
fn picture_at(i: vec2<i32>) -> vec3<f32> {
    let v = textureLoad(picture, i, 0);
    if v.a >= 1.0 { return v.rgb; }
    return v.rgb + (1.0 - v.a) * plate_linear(vec2<u32>(i));
}

// The frame at coded position `at` (px), bilinear between pixel centres, clamped at the border.
fn sample_frame(at: vec2<f32>) -> vec3<f32> {
    let hi = vec2<i32>(textureDimensions(picture)) - vec2<i32>(1);
    let u = at - vec2<f32>(0.5);
    let i0 = vec2<i32>(floor(u));
    let f = u - floor(u);
    let a = picture_at(clamp(i0, vec2<i32>(0), hi));
    let b = picture_at(clamp(i0 + vec2<i32>(1, 0), vec2<i32>(0), hi));
    let c = picture_at(clamp(i0 + vec2<i32>(0, 1), vec2<i32>(0), hi));
    let e = picture_at(clamp(i0 + vec2<i32>(1, 1), vec2<i32>(0), hi));
    return mix(mix(a, b, f.x), mix(c, e, f.x), f.y);
}

// What lies along `dir` from ground point `p` outside the frame: the SH environment, and each
// compact light as a normalised lobe about its direction from `p` (von Mises–Fisher of
// concentration light_lobe: the water's roughness), radiance × solid angle spread over it.
fn environment(p: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    var c = max(sh_radiance(rain.env_sh, dir), vec3<f32>(0.0));
    let kappa = puddle.light_lobe;
    let from_camera = p - rain.camera_pos_m;
    for (var i = 0u; i < min(lights.count, MAX_LIGHTS); i++) {
        let l = lights.lights[i];
        let seen = light_seen_from(l, from_camera);
        let lobe = kappa / (2.0 * PI) * exp(kappa * (dot(seen.xyz, dir) - 1.0));
        c += l.strength.rgb * seen.w * lobe;
    }
    return c;
}
