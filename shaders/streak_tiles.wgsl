// Stage streak_tiles: the capsule streaks of rain_simulate drawn onto the canvas by compute, the
// picture of rain_streaks' fs_main (--gpu-raster compute). Where only a few of a GPU's cores
// run the rasteriser, a quad per drop costs per drop whatever its size; here every core works.
// The canvas is cut into tiles of PIXEL_WORKGROUP² coded pixels:
//   count:   per streak, the tiles its quad (rain_streaks' vs_main) meets, counted per tile;
//   offsets: an exclusive prefix sum of the counts, each tile's first entry in tile_list;
//   scatter: per streak, its index into the list of every tile it meets (in any order);
//   blend:   per tile, its list sorted ascending (drop order, as the draw blends), then each
//            pixel sums the streaks in that order, src + dst·(1 − αsrc) as the blend unit does,
//            rounded to f16 after each as the Rgba16Float canvas is.
// `picture` is a copy of the canvas before the pass (a storage texture of Rgba16Float cannot be
// read and written in one pass). Where the lists outgrow tile_list, the tiles past its end
// read every streak in order instead: slower, the same picture.
// Includes: common/types.wgsl, common/depth.wgsl, common/capsule.wgsl.

// The tile grid (`gpu::types::TileParams`).
struct TileParams {
    tiles_xy: vec2<u32>,   // tiles across and down
    streak_count: u32,     // streaks drawn (the first of `streaks`)
    capacity: u32,         // entries tile_list holds
}

@group(0) @binding(0) var<uniform> rain: RainParams;
@group(0) @binding(1) var<uniform> tiles: TileParams;
@group(0) @binding(2) var<storage, read> streaks: array<Streak>;
@group(0) @binding(3) var<storage, read> scene_depth: array<f32>;
// Per tile t (row-major): its count of streaks at t, its first entry in tile_list at T + t
// (T tiles). The counts are zero before count: blend clears its tile's after reading it.
@group(0) @binding(4) var<storage, read_write> tile_data: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> tile_list: array<u32>;
@group(0) @binding(6) var picture: texture_2d<f32>;
@group(0) @binding(7) var canvas: texture_storage_2d<rgba16float, write>;

const NO_STREAK: u32 = 0xffffffffu;

// A streak's quad in coded pixels: its centre, unit axes along and across the streak, and half
// its extent along each.
struct Quad {
    centre: vec2<f32>,
    along: vec2<f32>,
    across: vec2<f32>,
    half_px: vec2<f32>,
}

// The coded picture's point at displayed point `p` (rain_streaks' vs_main: coded = M p + offset).
fn coded_from_display(p: vec2<f32>) -> vec2<f32> {
    let m = rain.coded_from_display;
    return vec2<f32>(m.x * p.x + m.z * p.y, m.y * p.x + m.w * p.y);
}

// The quad rain_streaks draws for `s` (vs_main: `ext` beyond the path at either end and across).
fn streak_quad(s: Streak) -> Quad {
    let ext = s.r_eff_px + AA_MARGIN_PX;
    let nrm = vec2<f32>(-s.dir.y, s.dir.x);
    let centre = coded_from_display(s.q0_px + s.dir * (0.5 * s.len_px)) + rain.coded_offset_px;
    return Quad(centre, coded_from_display(s.dir), coded_from_display(nrm), vec2<f32>(0.5 * s.len_px + ext, ext));
}

// Whether quad `q` meets tile `tile` (the separating axes of the two boxes; the tile's own axes
// are those of quad_tiles' bounds): every pixel centre of the tile that the quad covers is in
// such a tile.
fn quad_meets_tile(q: Quad, tile: vec2<u32>) -> bool {
    let half_tile = 0.5 * f32(PIXEL_WORKGROUP);
    let d = (vec2<f32>(tile) + 0.5) * f32(PIXEL_WORKGROUP) - q.centre;
    let reach_along = half_tile * (abs(q.along.x) + abs(q.along.y));
    let reach_across = half_tile * (abs(q.across.x) + abs(q.across.y));
    return abs(dot(d, q.along)) <= q.half_px.x + reach_along && abs(dot(d, q.across)) <= q.half_px.y + reach_across;
}

// The first and last tile (x, y, x, y) of the quad's bounding box within the grid; empty (last
// < first) where it misses the picture.
fn quad_tiles(q: Quad) -> vec4<i32> {
    let reach = abs(q.along) * q.half_px.x + abs(q.across) * q.half_px.y;
    let grid = vec2<f32>(tiles.tiles_xy);
    let lo = clamp(floor((q.centre - reach) / f32(PIXEL_WORKGROUP)), vec2<f32>(-1.0), grid);
    let hi = clamp(floor((q.centre + reach) / f32(PIXEL_WORKGROUP)), vec2<f32>(-1.0), grid);
    // Integer clamps too: a NaN converts to any integer.
    let last = vec2<i32>(tiles.tiles_xy) - 1;
    return vec4<i32>(max(vec2<i32>(lo), vec2<i32>(0)), min(vec2<i32>(hi), last));
}

// Streak `i` counted in (scatter false) or listed in (true) every tile its quad meets.
fn bin_streak(i: u32, scatter: bool) {
    let s = streaks[i];
    if !(s.len_px >= 0.0) { return; }
    let q = streak_quad(s);
    let r = quad_tiles(q);
    let tile_count = tiles.tiles_xy.x * tiles.tiles_xy.y;
    for (var y = r.y; y <= r.w; y++) {
        for (var x = r.x; x <= r.z; x++) {
            if !quad_meets_tile(q, vec2<u32>(u32(x), u32(y))) { continue; }
            let t = u32(y) * tiles.tiles_xy.x + u32(x);
            if scatter {
                let slot = atomicLoad(&tile_data[tile_count + t]) + atomicAdd(&tile_data[t], 1u);
                if slot < tiles.capacity { tile_list[slot] = i; }
            } else {
                atomicAdd(&tile_data[t], 1u);
            }
        }
    }
}

@compute @workgroup_size(SIMULATE_WORKGROUP)
fn count(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    for (var i = id.x; i < tiles.streak_count; i += groups.x * SIMULATE_WORKGROUP) {
        bin_streak(i, false);
    }
}

@compute @workgroup_size(SIMULATE_WORKGROUP)
fn scatter(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    for (var i = id.x; i < tiles.streak_count; i += groups.x * SIMULATE_WORKGROUP) {
        bin_streak(i, true);
    }
}

// a + b, saturating at the largest u32 (a tile past it is never listed).
fn add_saturating(a: u32, b: u32) -> u32 {
    return select(a + b, NO_STREAK, a > NO_STREAK - b);
}

var<workgroup> scan_sums: array<u32, TILE_SCAN_WORKGROUP>;

// One workgroup: each thread a run of consecutive tiles, their sums scanned across threads.
// Leaves each tile's first entry at T + t and its count zero for scatter to count again.
@compute @workgroup_size(TILE_SCAN_WORKGROUP)
fn offsets(@builtin(local_invocation_index) thread: u32) {
    let n = tiles.tiles_xy.x * tiles.tiles_xy.y;
    let per = (n + TILE_SCAN_WORKGROUP - 1u) / TILE_SCAN_WORKGROUP;
    let first = min(thread * per, n);
    let end = min(first + per, n);
    var sum = 0u;
    for (var t = first; t < end; t++) {
        sum = add_saturating(sum, atomicLoad(&tile_data[t]));
    }
    scan_sums[thread] = sum;
    workgroupBarrier();
    // Hillis–Steele inclusive scan.
    for (var d = 1u; d < TILE_SCAN_WORKGROUP; d *= 2u) {
        var before = 0u;
        if thread >= d { before = scan_sums[thread - d]; }
        workgroupBarrier();
        scan_sums[thread] = add_saturating(scan_sums[thread], before);
        workgroupBarrier();
    }
    // The exclusive sum: the inclusive one less this thread's own (exact unless saturated,
    // where every later tile is past the list's end anyway).
    var offset = select(scan_sums[thread] - sum, NO_STREAK, scan_sums[thread] == NO_STREAK);
    for (var t = first; t < end; t++) {
        let c = atomicLoad(&tile_data[t]);
        atomicStore(&tile_data[n + t], offset);
        atomicStore(&tile_data[t], 0u);
        offset = add_saturating(offset, c);
    }
}

// Streak indices of a tile's list sorted in workgroup memory (lists of up to STREAK_SORT_LOCAL),
// the records of the streaks being blended, and the tile's (count, first entry).
var<workgroup> sort_keys: array<u32, STREAK_SORT_LOCAL>;
var<workgroup> staged: array<Streak, STREAK_BATCH>;
var<workgroup> tile_head: vec2<u32>;

// Comparator `i` of the bitonic network's step (k, j) as (lower, upper) index: j = k/2 compares
// a block of k with its mirror image, the smaller j halves; every comparator puts the smaller
// key at the lower index, so keys past the list's end may be taken as +∞ and left unread.
fn comparator(i: u32, k: u32, j: u32) -> vec2<u32> {
    let lo = (i / j) * 2u * j + i % j;
    return vec2<u32>(lo, select(lo + j, lo ^ (k - 1u), 2u * j == k));
}

// The smallest power of two at least n (n ≤ 2³¹).
fn pow2_at_least(n: u32) -> u32 {
    return select(1u << (32u - countLeadingZeros(n - 1u)), 1u, n <= 1u);
}

// Entries [first, first + n) of tile_list into sort_keys, sorted ascending (n ≤ STREAK_SORT_LOCAL).
fn sort_in_workgroup(n: u32, first: u32, thread: u32) {
    let size = pow2_at_least(n);
    for (var i = thread; i < size; i += PIXEL_WORKGROUP * PIXEL_WORKGROUP) {
        var key = NO_STREAK;
        if i < n { key = tile_list[first + i]; }
        sort_keys[i] = key;
    }
    workgroupBarrier();
    for (var k = 2u; k <= size; k *= 2u) {
        for (var j = k / 2u; j > 0u; j /= 2u) {
            for (var i = thread; i < size / 2u; i += PIXEL_WORKGROUP * PIXEL_WORKGROUP) {
                let c = comparator(i, k, j);
                let a = sort_keys[c.x];
                let b = sort_keys[c.y];
                if b < a {
                    sort_keys[c.x] = b;
                    sort_keys[c.y] = a;
                }
            }
            workgroupBarrier();
        }
    }
}

// Entries [first, first + n) of tile_list sorted ascending where they lie (longer lists): only
// this workgroup touches them, so storage barriers order its steps.
fn sort_in_place(n: u32, first: u32, thread: u32) {
    let size = pow2_at_least(n);
    for (var k = 2u; k <= size; k *= 2u) {
        for (var j = k / 2u; j > 0u; j /= 2u) {
            for (var i = thread; i < size / 2u; i += PIXEL_WORKGROUP * PIXEL_WORKGROUP) {
                let c = comparator(i, k, j);
                if c.y < n {
                    let a = tile_list[first + c.x];
                    let b = tile_list[first + c.y];
                    if b < a {
                        tile_list[first + c.x] = b;
                        tile_list[first + c.y] = a;
                    }
                }
            }
            storageBarrier();
        }
    }
}

// `dst` with streak `s` blended over it at displayed point `p` (a pixel centre) where the scene
// lies `scene_m` deep: fs_main's colour and alpha, the radiance interpolated over the quad as
// its vertices carry it (radiance0 at −ext along, radiance1 at len + ext), rounded to f16 as
// the canvas stores each blend.
fn blend_streak(dst: vec4<f32>, s: Streak, p: vec2<f32>, scene_m: f32) -> vec4<f32> {
    if !(s.len_px >= 0.0) { return dst; }
    let d = p - s.q0_px;
    let along = dot(d, s.dir);
    let across = s.dir.x * d.y - s.dir.y * d.x;
    let cover = coverage(along, across, s.len_px, s.r_eff_px);
    if cover <= 0.0 { return dst; }
    let a = clamp(cover * s.alpha_scale, 0.0, 1.0)
        * visibility(scene_m, drop_depth_m(along, s.len_px, vec2<f32>(s.radiance0.w, s.radiance1.w)));
    if a <= 0.0 { return dst; }
    let ext = s.r_eff_px + AA_MARGIN_PX;
    let radiance = mix(s.radiance0.rgb, s.radiance1.rgb, (along + ext) / (s.len_px + 2.0 * ext));
    let src = quantizeToF16(vec4<f32>(radiance * a, a));
    return quantizeToF16(src + dst * (1.0 - src.a));
}

@compute @workgroup_size(PIXEL_WORKGROUP, PIXEL_WORKGROUP)
fn blend(@builtin(workgroup_id) tile: vec3<u32>, @builtin(local_invocation_id) local: vec3<u32>, @builtin(local_invocation_index) thread: u32) {
    let tile_count = tiles.tiles_xy.x * tiles.tiles_xy.y;
    let t = tile.y * tiles.tiles_xy.x + tile.x;
    if thread == 0u {
        tile_head = vec2<u32>(atomicLoad(&tile_data[t]), atomicLoad(&tile_data[tile_count + t]));
        // Zero for the next frame's count.
        atomicStore(&tile_data[t], 0u);
    }
    let head = workgroupUniformLoad(&tile_head);
    let first = head.y;
    // The whole list was scattered: it lies before the end of tile_list.
    let listed = first <= tiles.capacity && head.x <= tiles.capacity - first;
    let in_workgroup = listed && head.x <= STREAK_SORT_LOCAL;
    if in_workgroup {
        sort_in_workgroup(head.x, first, thread);
    } else if listed {
        sort_in_place(head.x, first, thread);
    }
    // Unlisted: every streak in order, those missing the tile skipped.
    let n = select(tiles.streak_count, head.x, listed);
    if n == 0u { return; }

    let px = tile.xy * PIXEL_WORKGROUP + local.xy;
    let inside = all(px < textureDimensions(picture));
    var colour = vec4<f32>(0.0);
    if inside { colour = textureLoad(picture, px, 0); }
    let centre = vec2<f32>(px) + 0.5;
    let scene_m = scene_depth_m(centre);
    // Display point of the centre: M is a rotation, its inverse Mᵀ (common/depth.wgsl).
    let d = centre - rain.coded_offset_px;
    let m = rain.coded_from_display;
    let p = vec2<f32>(m.x * d.x + m.y * d.y, m.z * d.x + m.w * d.y);
    for (var base = 0u; base < n; base += STREAK_BATCH) {
        workgroupBarrier();
        if thread < STREAK_BATCH && base + thread < n {
            let k = base + thread;
            var id = k;
            if in_workgroup {
                id = sort_keys[k];
            } else if listed {
                id = tile_list[first + k];
            }
            var s = streaks[min(id, tiles.streak_count - 1u)];
            if !listed && !(s.len_px >= 0.0 && quad_meets_tile(streak_quad(s), tile.xy)) {
                s.len_px = -1.0;
            }
            staged[thread] = s;
        }
        workgroupBarrier();
        let batch = min(STREAK_BATCH, n - base);
        for (var j = 0u; j < batch; j++) {
            colour = blend_streak(colour, staged[j], p, scene_m);
        }
    }
    if inside { textureStore(canvas, px, colour); }
}
