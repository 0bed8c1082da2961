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
// Includes: common/types.wgsl, common/rng.wgsl, common/depth.wgsl, common/capsule.wgsl.

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
    // Mattes only. The point in the matte's texel grid (x across, y along, texel centres at
    // +0.5): affine over the quad, so interpolated rather than derived per fragment.
    @location(4) matte_px: vec2<f32>,
    // The first texel of the streak's matte layer in the texture's coordinates, the layers of
    // its glints (MATTE_NONE: none), MATTE_MIRROR set where the matte is the mirror image, and
    // how many it has; their colours are read where drawn. Few varyings: on CPU adapters each
    // costs set-up per triangle, and the quads are many and small.
    @location(5) @interpolate(flat) tile_uv: vec2<f32>,
    @location(6) @interpolate(flat) glint_layers: vec4<u32>,
    @location(7) @interpolate(flat) glint_count: u32,
    @location(8) @interpolate(flat) id: u32,
}

@group(0) @binding(3) var<uniform> mattes: MatteParams;
// The matte layers as tiles of one filterable texture (src/gpu/stages/rain_streaks.rs,
// matte_texture): layer l at tile (l mod MATTE_TILES_ACROSS, l div MATTE_TILES_ACROSS), each
// MATTE_WIDTH × MATTE_HEIGHT texels framed by one texel of zeros, read bilinearly by the
// sampler.
@group(0) @binding(4) var matte_atlas: texture_2d<f32>;
@group(0) @binding(5) var<storage, read> glints: array<Glint>;
@group(0) @binding(6) var matte_sampler: sampler;

// Half a matte layer's width in drop radii (HALF_WIDTH_RADII in src/drops/atlas.rs).
const MATTE_HALF_WIDTH_RADII: f32 = 1.5;
// The random stream of a drop's oscillation phase (streams 0–5 place and size it).
const MATTE_PHASE_STREAM: u32 = 6u;
const MATTE_PI: f32 = 3.14159265358979;
const MATTE_NONE: u32 = 0xffffffffu;
// The bit of a glint's layer that marks its matte's mirror image.
const MATTE_MIRROR: u32 = 0x80000000u;


@vertex
fn vs_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) id: u32) -> VsOut {
    return quad(vertex, id, 0.0);
}

// Corner `vertex` of the quad of streak `id` (a triangle strip of four), at least
// `half_width_radii` drop radii wide on each side.
fn quad(vertex: u32, id: u32, half_width_radii: f32) -> VsOut {
    let s = streaks[id];
    if s.len_px < 0.0 {
        return VsOut(vec4<f32>(2.0, 2.0, 2.0, 1.0), vec2<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec2<f32>(1.0), vec2<f32>(0.0), vec2<f32>(0.0), vec4<u32>(MATTE_NONE), 0u, id);
    }
    // Corners (along ∈ {start, end}) × (across ∈ {−, +}), in strip order.
    let corner = array<vec2<f32>, 4>(
        vec2<f32>(0.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 1.0),
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
        vec2<f32>(s.radiance0.w, s.radiance1.w), vec2<f32>(0.0), vec2<f32>(0.0), vec4<u32>(MATTE_NONE), 0u, id);
}

// The index of the bin of `bins` (the first `count` of its eight) nearest to `x`, the lower on
// a tie: compares on two vectors, where an array indexed per vertex spills to memory on CPU
// adapters.
fn nearest_bin(bins: array<vec4<f32>, 2>, count: u32, x: f32) -> u32 {
    let unused = vec4<f32>(3.0e38);
    let lo = select(abs(bins[0] - x), unused, vec4<u32>(0u, 1u, 2u, 3u) >= vec4<u32>(count));
    let hi = select(abs(bins[1] - x), unused, vec4<u32>(4u, 5u, 6u, 7u) >= vec4<u32>(count));
    var best = 0u;
    var d = lo.x;
    best = select(best, 1u, lo.y < d); d = min(d, lo.y);
    best = select(best, 2u, lo.z < d); d = min(d, lo.z);
    best = select(best, 3u, lo.w < d); d = min(d, lo.w);
    best = select(best, 4u, hi.x < d); d = min(d, hi.x);
    best = select(best, 5u, hi.y < d); d = min(d, hi.y);
    best = select(best, 6u, hi.z < d); d = min(d, hi.z);
    best = select(best, 7u, hi.w < d);
    return best;
}

@vertex
fn vs_mattes(@builtin(vertex_index) vertex: u32, @builtin(instance_index) id: u32) -> VsOut {
    // As wide as the mattes reach (beyond, their light is zero).
    var out = quad(vertex, id, mattes.reach.x);
    let r = out.shape.y;
    // The matte's (u, w): u from the disc's tail at shutter open to its head at close, w
    // across in radii, growing to the image right of a streak falling down the picture
    // (−local_px.y); in texels as MatteAtlas::sample takes them.
    let u = (out.local_px.x + r) / (out.shape.x + 2.0 * r);
    let w = -out.local_px.y / r;
    out.matte_px = vec2<f32>((w / MATTE_HALF_WIDTH_RADII + 1.0) * 0.5 * f32(MATTE_WIDTH), u * f32(MATTE_HEIGHT));
    let info = unpack2x16unorm(streaks[id].drop_info);
    let size = nearest_bin(mattes.sizes_mm, mattes.counts.x, info.x * 10.0);
    let view = nearest_bin(mattes.views_deg, mattes.counts.y, info.y * 90.0);
    let phases = mattes.counts.z;
    let phase = min(u32(drop_uniform(rain.seed, id, MATTE_PHASE_STREAM) * f32(phases)), phases - 1u);
    out.tile_uv = tile_uv((size * mattes.counts.y + view) * phases + phase);
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
        out.glint_count = k + 1u;
    }
    return out;
}

// The first texel of `layer`'s tile in the texture's coordinates (0 to 1).
fn tile_uv(layer: u32) -> vec2<f32> {
    let tile = vec2<u32>(layer % MATTE_TILES_ACROSS, layer / MATTE_TILES_ACROSS);
    return vec2<f32>(tile * vec2<u32>(MATTE_WIDTH + 2u, MATTE_HEIGHT + 2u) + 1u) * mattes.reach.yz;
}

// N of the layer whose tile starts at `tile_uv`, at `px` of its texel grid, bilinear between
// texel centres and zero outside the layer (twin of MatteAtlas::sample): the sampler's
// bilinear read, the point clamped to the frame's texel centres, where the read is exactly
// zero.
fn matte_at(tile_uv: vec2<f32>, px: vec2<f32>) -> f32 {
    let inside = clamp(px, vec2<f32>(-0.5), vec2<f32>(f32(MATTE_WIDTH) + 0.5, f32(MATTE_HEIGHT) + 0.5));
    return textureSampleLevel(matte_atlas, matte_sampler, tile_uv + inside * mattes.reach.yz, 0.0).r;
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
    let cover = clamp(coverage(v.local_px.x, v.local_px.y, v.shape.x, v.shape.y) * v.shape.z, 0.0, 1.0);
    // The oscillating drop reaches a little beyond the mean disc: light without coverage, as
    // far as the mattes reach (their frame of zeros, mirrored or not, is the same).
    let off_matte = any(v.matte_px <= vec2<f32>(-0.5)) || any(v.matte_px >= vec2<f32>(f32(MATTE_WIDTH) + 0.5, f32(MATTE_HEIGHT) + 0.5));
    if cover <= 0.0 && off_matte { discard; }
    let shown = visibility(scene_depth_m(v.clip.xy), drop_depth_m(v.local_px.x, v.shape.x, v.depth_m));
    let a = cover * shown;
    let r = v.shape.y;
    let footprint = v.shape.x + 2.0 * r;
    var light = v.radiance * matte_at(v.tile_uv, v.matte_px);
    // A loop to the drop's count, the same for the whole quad: where it has no glints, none
    // is read. The layer picked by selects: a vector indexed per fragment spills to memory on
    // CPU adapters.
    let first = GLINTS_PER_DROP * v.id;
    for (var k = 0u; k < v.glint_count; k++) {
        let bits = select(select(select(v.glint_layers.x, v.glint_layers.y, k == 1u), v.glint_layers.z, k == 2u), v.glint_layers.w, k == 3u);
        let layer = bits & ~MATTE_MIRROR;
        let px = select(v.matte_px, vec2<f32>(f32(MATTE_WIDTH) - v.matte_px.x, v.matte_px.y), layer != bits);
        light += glints[first + k].colour.rgb * matte_at(tile_uv(layer), px);
    }
    if a <= 0.0 && all(light <= vec3<f32>(0.0)) { discard; }
    return vec4<f32>(light * (shown * v.shape.z * MATTE_PI * r / footprint), a);
}
