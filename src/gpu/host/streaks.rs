//! The streaks rasterised on the CPU (the `rain_streaks` stage's work, for the CPU back end):
//! each drawn streak is binned to the 64 × 32 px tiles its quad's box reaches, in drop order;
//! rayon's threads take bands of tiles, and each tile with streaks goes to f32 once, blends its
//! streaks in drop order (premultiplied, `src + dst·(1 − α)`, as the stage's blend state) row by
//! row over the span of each row the quad covers, and goes back to f16. Tiles no streak reaches
//! are not read or written, and a pixel no streak covers keeps its bits (f16 → f32 → f16 is
//! exact). The plain twin [`crate::gpu::cpu::rain_streaks`] is the reference
//! (`tests/backend.rs`); every pixel is computed from its own coordinates, so the result does
//! not depend on the tiles or the threads.

use half::f16;
use half::slice::HalfFloatSliceExt;
use rayon::prelude::*;

use crate::drops::MatteAtlas;
use crate::drops::atlas::{ATLAS_HEIGHT, ATLAS_WIDTH, HALF_WIDTH_RADII};
use crate::gpu::cpu::rain_streaks::{AA_MARGIN_PX, OCCLUSION_SOFTNESS_M, matte_layers};
use crate::gpu::types::{GLINTS_PER_DROP, Glint, RainParams, Streak};

/// A tile's width and height, px: a tile's f32 pixels (32 KiB) stay in the first-level cache
/// while its streaks blend.
pub const TILE_W: usize = 64;
/// See [`TILE_W`].
pub const TILE_H: usize = 32;

/// What a streak's matte colour reads: its environment layer and its glints (layer, mirror
/// image, colour), strongest first.
struct Matte {
    layer: usize,
    glints: Vec<(usize, bool, [f32; 3])>,
}

/// One drawn streak in the raster's terms (f32).
struct Prepared {
    q0: [f32; 2],
    dir: [f32; 2],
    len: f32,
    r: f32,
    /// The quad's half-extent along (beyond each end) and across.
    ext: f32,
    across_ext: f32,
    alpha_scale: f32,
    radiance: [[f32; 3]; 2],
    /// The drop's depth at the path's ends (camera z, m).
    depth_m: [f32; 2],
    /// Coded pixels the quad's box reaches (inclusive), clamped to the picture.
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
    matte: Option<Matte>,
}

/// The display rotation: display = mᵀ (coded − offset) for pixel centres.
#[derive(Clone, Copy)]
struct Rotation {
    m: [f32; 4],
    offset: [f32; 2],
}

impl Rotation {
    fn new(p: &RainParams) -> Rotation {
        Rotation {
            m: p.coded_from_display,
            offset: p.coded_offset_px,
        }
    }

    /// Display coordinates of coded point (x, y).
    #[inline]
    fn display(&self, x: f32, y: f32) -> [f32; 2] {
        let (dx, dy) = (x - self.offset[0], y - self.offset[1]);
        [
            self.m[0] * dx + self.m[1] * dy,
            self.m[2] * dx + self.m[3] * dy,
        ]
    }

    /// Coded coordinates of display point (x, y).
    fn coded(&self, x: f32, y: f32) -> [f32; 2] {
        [
            self.m[0] * x + self.m[2] * y + self.offset[0],
            self.m[1] * x + self.m[3] * y + self.offset[1],
        ]
    }
}

/// Streaks drawn and tiles touched by one raster.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RasterCount {
    /// Streaks with a quad on the picture.
    pub streaks: usize,
    /// Tiles at least one quad's box reaches.
    pub tiles: usize,
}

/// The rain's inputs besides the streaks: the uniforms, the mattes and glints where streaks
/// are drawn with mattes, and the scene's depth per displayed pixel (metres, 0 unknown).
pub struct Rain<'a> {
    /// The frame's uniforms.
    pub params: &'a RainParams,
    /// The streak mattes (`None`: capsules).
    pub mattes: Option<&'a MatteAtlas>,
    /// [`GLINTS_PER_DROP`] per drop, as `rain_simulate`'s `main_mattes` writes them (may be
    /// empty: no glints).
    pub glints: &'a [Glint],
    /// The scene's depth per displayed pixel, row-major, metres (0: unknown).
    pub depth: Option<&'a [f32]>,
}

/// Blends `streaks` (one per drop, `len_px < 0`: not drawn) over `canvas` (RGBA f16, row-major,
/// the coded picture of `rain.params.coded_size_px`, `width` texels a row).
pub fn rasterise(canvas: &mut [f16], width: usize, rain: &Rain, streaks: &[Streak]) -> RasterCount {
    let height = canvas.len() / (4 * width.max(1));
    let rot = Rotation::new(rain.params);
    let prepared: Vec<Prepared> = streaks
        .par_iter()
        .enumerate()
        .filter_map(|(id, s)| prepare(rain, &rot, id, s, width, height))
        .collect();
    let tiles_x = width.div_ceil(TILE_W);
    let tiles_y = height.div_ceil(TILE_H);
    // Counting sort by tile, drop order kept within each tile.
    let mut start = vec![0u32; tiles_x * tiles_y + 1];
    let tile_span = |p: &Prepared| {
        (
            p.x0 / TILE_W..=p.x1 / TILE_W,
            p.y0 / TILE_H..=p.y1 / TILE_H,
        )
    };
    for p in &prepared {
        let (xs, ys) = tile_span(p);
        for ty in ys {
            for tx in xs.clone() {
                start[ty * tiles_x + tx + 1] += 1;
            }
        }
    }
    for k in 1..start.len() {
        start[k] += start[k - 1];
    }
    let mut fill = start.clone();
    let mut binned = vec![0u32; start[start.len() - 1] as usize];
    for (i, p) in prepared.iter().enumerate() {
        let (xs, ys) = tile_span(p);
        for ty in ys {
            for tx in xs.clone() {
                let at = &mut fill[ty * tiles_x + tx];
                binned[*at as usize] = i as u32;
                *at += 1;
            }
        }
    }
    let count = RasterCount {
        streaks: prepared.len(),
        tiles: start.windows(2).filter(|w| w[1] > w[0]).count(),
    };
    canvas
        .par_chunks_mut(4 * width * TILE_H)
        .enumerate()
        .for_each(|(ty, band)| {
            let rows = band.len() / (4 * width);
            let mut tile = vec![0f32; 4 * TILE_W * TILE_H];
            for tx in 0..tiles_x {
                let k = ty * tiles_x + tx;
                let list = &binned[start[k] as usize..start[k + 1] as usize];
                if list.is_empty() {
                    continue;
                }
                let (x0, cols) = (tx * TILE_W, TILE_W.min(width - tx * TILE_W));
                for r in 0..rows {
                    band[4 * (r * width + x0)..][..4 * cols]
                        .convert_to_f32_slice(&mut tile[4 * r * TILE_W..][..4 * cols]);
                }
                let area = Area {
                    x0,
                    x1: x0 + cols - 1,
                    y0: ty * TILE_H,
                    y1: ty * TILE_H + rows - 1,
                };
                for &i in list {
                    draw(rain, &rot, &prepared[i as usize], &area, &mut tile);
                }
                for r in 0..rows {
                    band[4 * (r * width + x0)..][..4 * cols]
                        .convert_from_f32_slice(&tile[4 * r * TILE_W..][..4 * cols]);
                }
            }
        });
    count
}

/// A tile's coded pixels (inclusive).
struct Area {
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
}

/// Streak `id` in the raster's terms, or `None` where it is not drawn or its quad misses the
/// picture.
fn prepare(
    rain: &Rain,
    rot: &Rotation,
    id: usize,
    s: &Streak,
    width: usize,
    height: usize,
) -> Option<Prepared> {
    if !(s.len_px >= 0.0) {
        return None;
    }
    let (len, r) = (s.len_px, s.r_eff_px);
    let ext = r + AA_MARGIN_PX as f32;
    let across_ext = match rain.mattes {
        None => ext,
        Some(_) => ext.max(HALF_WIDTH_RADII as f32 * r),
    };
    // The quad's corners, display → coded; its box, a pixel wider for rounding.
    let (q0, d) = (s.q0_px, s.dir);
    let n = [-d[1], d[0]];
    let mut lo = [f32::INFINITY; 2];
    let mut hi = [f32::NEG_INFINITY; 2];
    for along in [-ext, len + ext] {
        for across in [-across_ext, across_ext] {
            let c = rot.coded(
                q0[0] + d[0] * along + n[0] * across,
                q0[1] + d[1] * along + n[1] * across,
            );
            for k in 0..2 {
                lo[k] = lo[k].min(c[k]);
                hi[k] = hi[k].max(c[k]);
            }
        }
    }
    if !(hi[0] >= 0.0 && hi[1] >= 0.0 && lo[0] <= width as f32 && lo[1] <= height as f32) {
        return None;
    }
    let clamp = |v: f32, n: usize| (v.max(0.0) as usize).min(n - 1);
    let matte = rain.mattes.map(|atlas| {
        let own = rain
            .glints
            .get(GLINTS_PER_DROP * id..)
            .map_or(&[][..], |g| &g[..g.len().min(GLINTS_PER_DROP)]);
        let (layer, glints) = matte_layers(atlas, rain.params.seed, id as u32, s.drop_info, own);
        Matte {
            layer,
            glints: glints
                .into_iter()
                .zip(own)
                .map(|((l, mirror), g)| (l, mirror, [g.colour[0], g.colour[1], g.colour[2]]))
                .collect(),
        }
    });
    Some(Prepared {
        q0,
        dir: d,
        len,
        r,
        ext,
        across_ext,
        alpha_scale: s.alpha_scale,
        radiance: [
            [s.radiance0[0], s.radiance0[1], s.radiance0[2]],
            [s.radiance1[0], s.radiance1[1], s.radiance1[2]],
        ],
        depth_m: [s.radiance0[3], s.radiance1[3]],
        x0: clamp((lo[0] - 1.0).floor(), width),
        x1: clamp((hi[0] + 1.0).ceil(), width),
        y0: clamp((lo[1] - 1.0).floor(), height),
        y1: clamp((hi[1] + 1.0).ceil(), height),
        matte,
    })
}

/// The pixel centres `x + 0.5` of a row where `value(x) = v0 + x · slope` lies in [lo, hi],
/// as a range of x (possibly empty), a pixel wider on each side for rounding.
fn span(v0: f32, slope: f32, lo: f32, hi: f32) -> (f32, f32) {
    if slope.abs() < 1e-6 {
        return if v0 >= lo - 1e-3 && v0 <= hi + 1e-3 {
            (f32::NEG_INFINITY, f32::INFINITY)
        } else {
            (f32::INFINITY, f32::NEG_INFINITY)
        };
    }
    let (a, b) = ((lo - v0) / slope, (hi - v0) / slope);
    (a.min(b) - 1.0, a.max(b) + 1.0)
}

/// Blends streak `p` over the part of `tile` (f32 RGBA, [`TILE_W`] texels a row) in `area`.
fn draw(rain: &Rain, rot: &Rotation, p: &Prepared, area: &Area, tile: &mut [f32]) {
    let (ya, yb) = (p.y0.max(area.y0), p.y1.min(area.y1));
    let (xa, xb) = (p.x0.max(area.x0), p.x1.min(area.x1));
    if ya > yb || xa > xb {
        return;
    }
    // Along a row, a step in coded x moves the display point by (m0, m2).
    let step = [rot.m[0], rot.m[2]];
    let slope_along = step[0] * p.dir[0] + step[1] * p.dir[1];
    let slope_across = -step[0] * p.dir[1] + step[1] * p.dir[0];
    for y in ya..=yb {
        let yc = y as f32 + 0.5;
        // The row's display point at coded x = 0.5, relative to q0.
        let at = rot.display(0.5, yc);
        let (dx, dy) = (at[0] - p.q0[0], at[1] - p.q0[1]);
        let along0 = dx * p.dir[0] + dy * p.dir[1];
        let across0 = -dx * p.dir[1] + dy * p.dir[0];
        let (a0, a1) = span(along0, slope_along, -p.ext, p.len + p.ext);
        let (c0, c1) = span(across0, slope_across, -p.across_ext, p.across_ext);
        let (lo, hi) = (a0.max(c0).max(xa as f32), a1.min(c1).min(xb as f32));
        if lo > hi {
            continue;
        }
        let row = (y - area.y0) * TILE_W;
        for x in lo.ceil() as usize..=hi.floor() as usize {
            pixel(rain, rot, p, x, yc, &mut tile[4 * (row + x - area.x0)..][..4]);
        }
    }
}

/// Blends streak `p` over coded pixel (x, `yc` − 0.5), as the twin does.
#[inline]
fn pixel(rain: &Rain, rot: &Rotation, p: &Prepared, x: usize, yc: f32, px: &mut [f32]) {
    let at = rot.display(x as f32 + 0.5, yc);
    let (dx, dy) = (at[0] - p.q0[0], at[1] - p.q0[1]);
    let along = dx * p.dir[0] + dy * p.dir[1];
    let across = -dx * p.dir[1] + dy * p.dir[0];
    if along < -p.ext || along > p.len + p.ext || across.abs() > p.across_ext {
        return;
    }
    let shown = match rain.depth {
        None => 1.0,
        Some(map) => visibility(rain.params, map, at, along, p),
    };
    let a = (coverage(along, across, p.len, p.r) * p.alpha_scale).clamp(0.0, 1.0) * shown;
    let t = (along + p.ext) / (p.len + 2.0 * p.ext);
    let [r0, r1] = p.radiance;
    let rad = [0, 1, 2].map(|k| r0[k] * (1.0 - t) + r1[k] * t);
    let light = match (&p.matte, rain.mattes) {
        (Some(m), Some(atlas)) => {
            let footprint = p.len + 2.0 * p.r;
            let spread = p.alpha_scale * std::f32::consts::PI * p.r / footprint;
            let (u, w) = ((along + p.r) / footprint, -across / p.r);
            let n = sample(atlas, m.layer, u, w);
            let mut light = rad.map(|c| c * n);
            for &(layer, mirror, colour) in &m.glints {
                let g = sample(atlas, layer, u, if mirror { -w } else { w });
                for k in 0..3 {
                    light[k] += colour[k] * g;
                }
            }
            light.map(|c| c * spread * shown)
        }
        _ => {
            if a <= 0.0 {
                return;
            }
            rad.map(|c| c * a)
        }
    };
    if a <= 0.0 && light.iter().all(|&c| c <= 0.0) {
        return;
    }
    let keep = 1.0 - a;
    for k in 0..3 {
        px[k] = light[k] + px[k] * keep;
    }
    px[3] = a + px[3] * keep;
}

/// The fraction of the exposure a disc of radius `r` moving from 0 to `len` along x covers the
/// point (`along`, `across`) (the twin's `coverage`).
#[inline]
fn coverage(along: f32, across: f32, len: f32, r: f32) -> f32 {
    let h2 = r * r - across * across;
    if h2 <= 0.0 {
        return 0.0;
    }
    let h = h2.sqrt();
    if len < 1e-3 {
        return if along.abs() < h { 1.0 } else { 0.0 };
    }
    ((along + h).clamp(0.0, len) - (along - h).clamp(0.0, len)) / len
}

/// How much of the drop shows at display point `at`, `along` px down its path, in front of
/// the scene's depth there (the twin's `visibility` of `drop_depth_m`).
fn visibility(params: &RainParams, map: &[f32], at: [f32; 2], along: f32, p: &Prepared) -> f32 {
    let (w, h) = (
        params.display_size_px[0] as usize,
        params.display_size_px[1] as usize,
    );
    if map.len() < w * h || w == 0 || h == 0 {
        return 1.0;
    }
    let px = (at[0].floor().max(0.0) as usize).min(w - 1);
    let py = (at[1].floor().max(0.0) as usize).min(h - 1);
    let scene = map[py * w + px];
    if scene <= 0.0 {
        return 1.0;
    }
    let t = if p.len >= 1e-3 {
        (along / p.len).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let drop = 1.0 / ((1.0 - t) / p.depth_m[0] + t / p.depth_m[1]);
    let x = ((scene - drop) / OCCLUSION_SOFTNESS_M as f32 + 0.5).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// The matte `layer` at (u along, w across in radii), bilinear between texel centres, zero
/// outside (`MatteAtlas::sample` in f32).
#[inline]
fn sample(atlas: &MatteAtlas, layer: usize, u: f32, w: f32) -> f32 {
    let texels = &atlas.texels[layer * ATLAS_WIDTH * ATLAS_HEIGHT..][..ATLAS_WIDTH * ATLAS_HEIGHT];
    let x = (w / HALF_WIDTH_RADII as f32 + 1.0) * 0.5 * ATLAS_WIDTH as f32 - 0.5;
    let y = u * ATLAS_HEIGHT as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (tx, ty) = (x - x0, y - y0);
    let at = |xi: f32, yi: f32| {
        if xi < 0.0 || yi < 0.0 || xi >= ATLAS_WIDTH as f32 || yi >= ATLAS_HEIGHT as f32 {
            0.0
        } else {
            texels[yi as usize * ATLAS_WIDTH + xi as usize]
        }
    };
    let top = at(x0, y0) * (1.0 - tx) + at(x0 + 1.0, y0) * tx;
    let bottom = at(x0, y0 + 1.0) * (1.0 - tx) + at(x0 + 1.0, y0 + 1.0) * tx;
    top * (1.0 - ty) + bottom * ty
}
