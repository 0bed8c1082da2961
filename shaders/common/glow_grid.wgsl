// The lamps' glow read back from its coarse grid (filled by yuv_to_rgb's `glow` entry point,
// common/glow.wgsl): every stage that writes a pixel of the veiled picture adds the glow G the
// plate had there, C = L·T + S + G, so the halo does not stop where a later stage (the wet
// ground, the water) rewrites the pixel.
//
// Needs, declared by the stage that includes it: var<uniform> rain: RainParams;
// var<uniform> lights: LightList (its count only); var glow_grid: texture_2d<f32> (rgba32float,
// one texel a grid point, read with textureLoad: a texture rather than a storage buffer keeps
// the puddles within the four storage buffers a stage that downlevel adapters offer).

// Whether there is a glow to draw.
fn haze_glows() -> bool {
    return rain.haze.w < 1.0 && lights.count > 0u;
}

// Grid points per row: one every GLOW_CELL_PX coded pixels, both ends included.
fn glow_grid_width() -> u32 {
    return (u32(rain.coded_size_px.x) + GLOW_CELL_PX - 1u) / GLOW_CELL_PX + 1u;
}

// The grid point `g`'s glow.
fn glow_at(g: vec2<u32>) -> vec4<f32> {
    return textureLoad(glow_grid, g, 0);
}

// The glow at coded pixel `p`, bilinear between the grid points around its centre, for a ray
// whose haze has transmittance `t`: the grid integrates the haze to the scene's depth, and a
// ray that meets the ground sooner glows by its share of that opacity (exact for lights at
// infinity, whose glow is proportional to the opacity).
fn haze_glow(p: vec2<u32>, t: f32) -> vec3<f32> {
    if !haze_glows() { return vec3<f32>(0.0); }
    let share = (1.0 - t) / (1.0 - rain.haze.w);
    let u = (vec2<f32>(p) + vec2<f32>(0.5)) / f32(GLOW_CELL_PX);
    let g = vec2<u32>(floor(u));
    let f = u - floor(u);
    let top = mix(glow_at(g).rgb, glow_at(g + vec2<u32>(1u, 0u)).rgb, f.x);
    let bottom = mix(glow_at(g + vec2<u32>(0u, 1u)).rgb, glow_at(g + vec2<u32>(1u, 1u)).rgb, f.x);
    return share * mix(top, bottom, f.y);
}
