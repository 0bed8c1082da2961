// Stage rain_streaks: the streaks of rain_simulate rasterised into the linear canvas, one quad
// per drop in drop order (so blending is deterministic), premultiplied; the pipeline blends
// src + dst·(1 − αsrc). The fragment evaluates exactly the fraction of the exposure during which
// the drop's disc covers the pixel.
// Occlusion: scene_depth holds the scene's depth (camera z, m) per displayed pixel, row-major,
// 0 where unknown. A drop fades out as it passes behind the scene, over OCCLUSION_SOFTNESS_M of
// depth centred on the surface; where the depth is unknown nothing hides it (the ground, when
// one is given, already ends each streak where its drop lands). Without a depth map the buffer
// holds one element and the alpha is multiplied by exactly 1.
// With --streaks mattes (vs_mattes, fs_mattes) the colour is spread along the streak by the
// drop's environment matte (src/drops/atlas.rs): its size and view bins from `drop_info`, its
// oscillation phase random per drop and fixed in time; and each of the drop's glints (its
// GLINTS_PER_DROP strongest compact lights, from rain_simulate's main_mattes) by that light's
// point-light matte. The alpha stays the coverage above.
// Includes: common/types.wgsl, common/rng.wgsl, common/depth.wgsl.

@group(0) @binding(0) var<uniform> rain: RainParams;
@group(0) @binding(1) var<storage, read> streaks: array<Streak>;
@group(0) @binding(2) var<storage, read> scene_depth: array<f32>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    // x: px along the streak from q0, y: px across it.
    @location(0) local_px: vec2<f32>,
    // x: streak length px, y: r_eff px, z: alpha scale.
    @location(1) @interpolate(flat) shape: vec3<f32>,
    // Drop radiance for the view ray here, linear RGB.
    @location(2) radiance: vec3<f32>,
    // The drop's depth (camera z, m) at the start and end of its path.
    @location(3) @interpolate(flat) depth_m: vec2<f32>,
    // The streak's matte layer (mattes only).
    @location(4) @interpolate(flat) layer: u32,
    // The glints' matte layers, strongest first (MATTE_NONE: none), MATTE_MIRROR set where the
    // matte is the mirror image; their colours are read where drawn. Few varyings: on CPU
    // adapters each costs set-up per triangle, and the quads are many and small.
    @location(5) @interpolate(flat) glint_layers: vec4<u32>,
    @location(6) @interpolate(flat) id: u32,
}

@group(0) @binding(3) var<uniform> mattes: MatteParams;
// MATTE_WIDTH × MATTE_HEIGHT normalised texels per layer (MatteAtlas::texels).
@group(0) @binding(4) var<storage, read> matte_texels: array<f32>;
@group(0) @binding(5) var<storage, read> glints: array<Glint>;

// Half a matte layer's width in drop radii (HALF_WIDTH_RADII in src/drops/atlas.rs).
const MATTE_HALF_WIDTH_RADII: f32 = 1.5;
// The random stream of a drop's oscillation phase (streams 0–5 place and size it).
const MATTE_PHASE_STREAM: u32 = 6u;
const MATTE_PI: f32 = 3.14159265358979;
const MATTE_NONE: u32 = 0xffffffffu;
// The bit of a glint's layer that marks its matte's mirror image.
const MATTE_MIRROR: u32 = 0x80000000u;

const AA_MARGIN_PX: f32 = 0.5;
// Depth over which a drop passing behind the scene fades out, m: a few centimetres, so depth
// edges are soft and a drop does not flicker on a surface it touches.
const OCCLUSION_SOFTNESS_M: f32 = 0.05;

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) id: u32) -> VsOut {
    return quad(vertex, id, 0.0);
}

// Corner `vertex` of the quad of streak `id`, at least `half_width_radii` drop radii wide on
// each side.
fn quad(vertex: u32, id: u32, half_width_radii: f32) -> VsOut {
    let s = streaks[id];
    if s.len_px < 0.0 {
        return VsOut(vec4<f32>(2.0, 2.0, 2.0, 1.0), vec2<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec2<f32>(1.0), 0u, vec4<u32>(MATTE_NONE), id);
    }
    // Two triangles: corners (along ∈ {start, end}) × (across ∈ {−, +}).
    let corner = array<vec2<f32>, 6>(
        vec2<f32>(0.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(0.0, 1.0),
        vec2<f32>(0.0, 1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
    )[vertex];
    let ext = s.r_eff_px + AA_MARGIN_PX;
    let along = mix(-ext, s.len_px + ext, corner.x);
    let across = corner.y * max(ext, half_width_radii * s.r_eff_px);
    let nrm = vec2<f32>(-s.dir.y, s.dir.x);
    let p_display = s.q0_px + s.dir * along + nrm * across;
    let m = rain.coded_from_display;
    let p_coded = vec2<f32>(m.x * p_display.x + m.z * p_display.y, m.y * p_display.x + m.w * p_display.y)
        + rain.coded_offset_px;
    let clip = vec2<f32>(2.0 * p_coded.x / rain.coded_size_px.x - 1.0, 1.0 - 2.0 * p_coded.y / rain.coded_size_px.y);
    let t = clamp(along / max(s.len_px, 1e-3), 0.0, 1.0);
    let radiance = mix(s.radiance0.rgb, s.radiance1.rgb, t);
    return VsOut(vec4<f32>(clip, 0.0, 1.0), vec2<f32>(along, across), vec3<f32>(s.len_px, s.r_eff_px, s.alpha_scale), radiance,
        vec2<f32>(s.radiance0.w, s.radiance1.w), 0u, vec4<u32>(MATTE_NONE), id);
}

// The index of the bin of `values` (the first `count`) nearest to `x`.
fn nearest_bin(values: array<vec4<f32>, 2>, count: u32, x: f32) -> u32 {
    var best = 0u;
    for (var k = 1u; k < count; k++) {
        if abs(values[k / 4u][k % 4u] - x) < abs(values[best / 4u][best % 4u] - x) { best = k; }
    }
    return best;
}

@vertex
fn vs_mattes(@builtin(vertex_index) vertex: u32, @builtin(instance_index) id: u32) -> VsOut {
    var out = quad(vertex, id, MATTE_HALF_WIDTH_RADII);
    let info = unpack2x16unorm(streaks[id].drop_info);
    let size = nearest_bin(mattes.sizes_mm, mattes.counts.x, info.x * 10.0);
    let view = nearest_bin(mattes.views_deg, mattes.counts.y, info.y * 90.0);
    let phases = mattes.counts.z;
    let phase = min(u32(drop_uniform(rain.seed, id, MATTE_PHASE_STREAM) * f32(phases)), phases - 1u);
    out.layer = (size * mattes.counts.y + view) * phases + phase;
    for (var k = 0u; k < GLINTS_PER_DROP && mattes.light_count.x > 0u; k++) {
        let g = glints[GLINTS_PER_DROP * id + k];
        // Strongest first: the first without light ends them.
        if all(g.colour.rgb <= vec3<f32>(0.0)) { break; }
        // Lights left of the view use the mirror image of those to its right.
        var dir = g.light_dir.xyz;
        let mirror = dir.x < 0.0;
        dir.x = abs(dir.x);
        var light = 0u;
        for (var j = 1u; j < mattes.light_count.x; j++) {
            if dot(mattes.lights[j].xyz, dir) > dot(mattes.lights[light].xyz, dir) { light = j; }
        }
        out.glint_layers[k] = mattes.light_count.y + ((size * mattes.counts.y + view) * mattes.light_count.x + light) * phases + phase
            | select(0u, MATTE_MIRROR, mirror);
    }
    return out;
}

// The matte texel (i, j) of `layer`, zero outside the layer.
fn matte_texel(layer: u32, i: i32, j: i32) -> f32 {
    if i < 0 || j < 0 || i >= i32(MATTE_WIDTH) || j >= i32(MATTE_HEIGHT) { return 0.0; }
    return matte_texels[(layer * MATTE_HEIGHT + u32(j)) * MATTE_WIDTH + u32(i)];
}

// N of `layer` at (u along the footprint, w across in radii), bilinear between texel centres
// (twin of MatteAtlas::sample).
fn matte_at(layer: u32, u: f32, w: f32) -> f32 {
    let x = (w / MATTE_HALF_WIDTH_RADII + 1.0) * 0.5 * f32(MATTE_WIDTH) - 0.5;
    let y = u * f32(MATTE_HEIGHT) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let t = vec2<f32>(x - x0, y - y0);
    let i = i32(x0);
    let j = i32(y0);
    let top = mix(matte_texel(layer, i, j), matte_texel(layer, i + 1, j), t.x);
    let bottom = mix(matte_texel(layer, i, j + 1), matte_texel(layer, i + 1, j + 1), t.x);
    return mix(top, bottom, t.y);
}

// The light of glint `index` at (u, w) of the footprint, drawn with its point-light matte
// (`bits`: the layer, MATTE_MIRROR for the mirror image); nothing for MATTE_NONE (the same for
// the whole quad).
fn glint_light(bits: u32, index: u32, u: f32, w: f32) -> vec3<f32> {
    if bits == MATTE_NONE { return vec3<f32>(0.0); }
    let layer = bits & ~MATTE_MIRROR;
    return glints[index].colour.rgb * matte_at(layer, u, select(w, -w, layer != bits));
}

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

@fragment
fn fs_main(v: VsOut) -> @location(0) vec4<f32> {
    let drop_m = drop_depth_m(v.local_px.x, v.shape.x, v.depth_m);
    let a = clamp(coverage(v.local_px.x, v.local_px.y, v.shape.x, v.shape.y) * v.shape.z, 0.0, 1.0)
        * visibility(scene_depth_m(v.clip.xy), drop_m);
    if a <= 0.0 { discard; }
    return vec4<f32>(v.radiance * a, a);
}

// The streak's light spread by its matte: N integrates to 1 over the footprint (len + 2r) × 2r
// in (u, w) units, the capsule's coverage to πr², so radiance × alpha_scale × N × πr/(len + 2r)
// holds the capsule's light, moved along the streak.
@fragment
fn fs_mattes(v: VsOut) -> @location(0) vec4<f32> {
    let shown = visibility(scene_depth_m(v.clip.xy), drop_depth_m(v.local_px.x, v.shape.x, v.depth_m));
    let a = clamp(coverage(v.local_px.x, v.local_px.y, v.shape.x, v.shape.y) * v.shape.z, 0.0, 1.0) * shown;
    let r = v.shape.y;
    let footprint = v.shape.x + 2.0 * r;
    // The oscillating drop reaches a little beyond the mean disc: light without coverage.
    // The matte's (u, w): w grows to the image right of a streak falling down the picture,
    // −local_px.y.
    let u = (v.local_px.x + r) / footprint;
    let w = -v.local_px.y / r;
    var light = v.radiance * matte_at(v.layer, u, w);
    // Written out: a vector indexed per fragment spills to memory on CPU adapters.
    let first = GLINTS_PER_DROP * v.id;
    light += glint_light(v.glint_layers.x, first, u, w) + glint_light(v.glint_layers.y, first + 1u, u, w)
        + glint_light(v.glint_layers.z, first + 2u, u, w) + glint_light(v.glint_layers.w, first + 3u, u, w);
    if a <= 0.0 && all(light <= vec3<f32>(0.0)) { discard; }
    return vec4<f32>(light * (shown * v.shape.z * MATTE_PI * r / footprint), a);
}
