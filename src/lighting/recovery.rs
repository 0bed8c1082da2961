//! Scene-referred light from a display-referred frame: the highlights that clipping removed.
//!
//! A frame stores the sky, the sun, lamps and lit windows at its code-value ceiling, when the
//! scene holds tens to millions of times more; those are exactly the light a drop shows
//! (`notes/light.md`). This module finds what was clipped and puts an estimate of it back.
//!
//! ## How it works
//!
//! 1. **Clip statistics** ([`BlockStats`]): beside the mean of each thumbnail block (the
//!    environment's input), the fraction of samples whose channel sits at the frame's own ceiling
//!    (within [`CLIP_TOLERANCE_CODES`] code values, per channel), so clipping is seen before the
//!    block average smears it.
//! 2. **Regions**: connected components (8-neighbour) of blocks holding clipped samples, with
//!    their clipped solid angle `Ω_clip = Σ f_b Ω_b` through the pinhole model and the level of
//!    the unclipped ring around them.
//! 3. **Classes**: a region whose clipped solid angle is at most [`COMPACT_MAX_SR`] (a disc of
//!    ≈ 9°), or at most [`EMITTER_MAX_SR`] (≈ 20°) with an unclipped ring darker than
//!    [`EMITTER_RING_CONTRAST`] × the clip level, is a *compact source* (sun, lamp, window, a
//!    softbox against a dark studio); any other is *extended* (bright sky, a sunlit wall, which
//!    fade into surroundings near the clip level).
//! 4. **Compact sources: an exposure-anchored illuminance prior.** The camera's exposure puts
//!    a mid-grey surface near the frame's median luminance `L_med`, so the illuminance on the
//!    scene's typical surfaces is `E = π L_med / a` (grey-world albedo `a` = 0.18, Lambert). The
//!    compact sources deliver, at the camera, an illuminance of the same order: the sun gives
//!    ≈ 10× the sky's diffuse light at high elevation and ≈ 1× near the horizon; a street lamp
//!    lights the road about as much as it lights a camera at a similar distance. Their total
//!    `Σ L Ω` is set to [`SOURCE_ILLUMINANCE_RATIO`] (3, the geometric middle of 1–10) times
//!    `E`, shared in proportion to their clipped solid angles (a source's bloom grows with its
//!    flux); each source's radiance is that flux over its clipped solid angle, never below the
//!    clip level, and at most [`MAX_GAIN`] times it. Because the prior is on flux (`L Ω`) rather
//!    than radiance, it does not depend on the picture's resolution or on how far the bloom
//!    spread the clipped area. The [`MAX_RECOVERED_LIGHTS`] largest become [`LightSource`]s;
//!    every compact region's blocks are replaced in the environment by the ring's level, and
//!    the smaller ones add their flux to the nearest light: a compact source's light stays in
//!    its direction, where the environment's fill outside the view would copy a window at the
//!    picture's edge over the sphere behind and beside the camera and multiply its flux many
//!    times (on a night skyline, 0.16 sr of recovered windows became ≈ 3.5 over the sphere and
//!    veiled the whole frame). Clipped samples keep their measured colour (a sodium lamp
//!    clipped in red and green stays yellow), scaled by the gain.
//!
//!    **More compact regions than lights: a field of emitters.** Lit windows and signs on a
//!    night skyline are not the scene's key light (they light little of what the camera sees),
//!    so the flux prior does not hold for them: each gets the typical luminance of a lit window,
//!    [`EMITTER_OVER_MEAN_AT_NIGHT`] times the frame's median luminance.
//! 5. **Extended regions: the CIE standard overcast sky**, `L(z) ∝ (1 + 2 cos z)/3` with `z`
//!    the zenith angle, fitted to the unclipped ring of the region and extrapolated into its
//!    clipped blocks (never below the clip level; a region with no ring stays at the clip
//!    level). Sky gradients are gentle (3:1 from zenith to horizon), so this restores at most a
//!    few times the clip level, which is what an unclipped sky next to the region allows.
//!    Both estimates are luminances; the clipped samples keep their measured colour, scaled to
//!    reach them.
//! 6. `highlight_gain` replaces steps 4–5 by a fixed factor: every clipped sample becomes `G ×`
//!    its own value, compact regions still becoming lights.
//!
//! A frame without clipped samples comes back unchanged (the same thumbnail, no lights).
//!
//! ## Hard frames (all tested; every output finite)
//!
//! - **All white**: one region with no unclipped ring: nothing to extrapolate from, so it stays
//!   at the clip level (the light of the frame as it is), no lights.
//! - **All black**: nothing clipped. A lamp in an otherwise black frame gets its flux from
//!   [`MIN_MEDIAN_LUMINANCE`], small and finite.
//! - **One huge clipped region**: extended; the sky model raises it at most to 3× its ring.
//! - **A lamp at the picture's edge**: still compact, in the direction of its visible part.
//! - **PQ / HLG**: only samples at the code-value ceiling are clipped; values above diffuse
//!   white below it are real light and pass unchanged; a stream tagged PQ or HLG is HDR input
//!   (`HdrInput::Auto`) and trusts even the ceiling, unless the user says `off`.
//! - **Flicker**: see [`LightTracker`](super::tracker::LightTracker): a lamp switching every other
//!   frame is a steady lamp at its mean flux.
//!
//! ## Limits
//!
//! The frame holds no measure of a compact source's flux once it clips (a real lens's glow
//! around it would, but its spread function is unknown and compression flattens it), so the
//! flux is a prior, right to within a few stops when the exposure sits on a grey-world scene and
//! the sources are the scene's main light. Light from outside the view (a sun above the frame,
//! a lamp behind the camera) is not recovered: the frame does not show it.
//! [`LightTracker`](super::tracker::LightTracker) smooths the sources over a window of past frames (a pure function of that
//! window, like [`ShSmoother`](super::envmap::ShSmoother)), so `preview` sees what the render sees.

use glam::{DVec2, DVec3};

use super::sources::LightSource;
use crate::scene::Camera;

/// Samples within this many code values of the ceiling count as clipped (compression and
/// chroma rounding keep clipped areas a code value or two below it).
pub const CLIP_TOLERANCE_CODES: f64 = 3.0;
/// Largest clipped solid angle of a compact source, steradians (a disc of ≈ 9°).
pub const COMPACT_MAX_SR: f64 = 0.02;
/// Largest clipped solid angle of a compact source standing out against darker surroundings,
/// steradians (a disc of ≈ 20°).
pub const EMITTER_MAX_SR: f64 = 0.1;
/// Surroundings at most this fraction of the clip level make a clipped region an emitter.
pub const EMITTER_RING_CONTRAST: f64 = 0.25;
/// Most compact regions turned into light sources per frame; smaller ones add their flux to
/// the nearest of them.
pub const MAX_RECOVERED_LIGHTS: usize = 16;
/// Illuminance of all compact sources at the camera over the illuminance on typical surfaces.
pub const SOURCE_ILLUMINANCE_RATIO: f64 = 3.0;
/// Luminance of a lit window or sign over the scene's typical luminance at night (the frame's
/// median, where the exposure puts it): office windows and shop fronts are 30–300 cd/m²
/// (interiors at 300–500 lx seen through glass; guidance on illuminated signs keeps them to a
/// few hundred cd/m² in dark surroundings), while exposure tables put a distant view of lit
/// buildings at EV 2–3, a mean of 0.5–1 cd/m² (L = 12.5 · 2^EV / ISO 100); the ratios span
/// 30–600, whose geometric middle is ≈ 130.
pub const EMITTER_OVER_MEAN_AT_NIGHT: f64 = 130.0;
/// Grey-world albedo that the exposure maps to the frame's median luminance.
pub const GREY_ALBEDO: f64 = 0.18;
/// Largest recovered radiance over the clip level (the sun over a mid-grey exposure is ~10⁶).
pub const MAX_GAIN: f64 = 1e6;
/// Floor of the frame's median luminance used by the prior (a black frame has no exposure
/// anchor; this keeps a lamp in it finite and small), frame units.
pub const MIN_MEDIAN_LUMINANCE: f64 = 1e-3;

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Where a frame's channels clip, in its linear units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClipLevel {
    /// A sample at or above this (per channel) is clipped.
    pub threshold: [f64; 3],
    /// The value of the ceiling itself (per channel).
    pub level: [f64; 3],
}

impl ClipLevel {
    /// The ceiling of a frame with transfer `eotf` (encoded [0, 1] → linear) and `codes_per_unit`
    /// code values from black to white.
    pub fn from_eotf(eotf: impl Fn(f64) -> f64, codes_per_unit: f64) -> ClipLevel {
        let t = eotf(1.0 - CLIP_TOLERANCE_CODES / codes_per_unit.max(CLIP_TOLERANCE_CODES + 1.0));
        let l = eotf(1.0);
        ClipLevel {
            threshold: [t; 3],
            level: [l; 3],
        }
    }
}

/// The thumbnail the environment is projected from, with its clipping per block.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockStats {
    /// Blocks per row.
    pub width: usize,
    /// Blocks per column.
    pub height: usize,
    /// Side of a block, frame pixels.
    pub block_px: usize,
    /// Frame size, pixels (the displayed picture).
    pub frame_px: (usize, usize),
    /// Mean linear RGB per block (each sample clamped to [0, 10³]).
    pub mean: Vec<[f32; 3]>,
    /// Fraction of the block's samples with at least one channel clipped.
    pub clipped: Vec<f32>,
    /// Mean linear RGB of those samples (zero where there are none): the colour the recovered
    /// light keeps.
    pub clipped_colour: Vec<[f32; 3]>,
    /// The frame's ceiling.
    pub clip: ClipLevel,
}

impl BlockStats {
    /// Statistics of a `frame_w × frame_h` picture read through `sample(x, y)` (linear RGB of
    /// displayed pixel (x, y)) in `block_px` blocks, with `samples_per_block` samples per block
    /// side spread evenly (`None`: every pixel).
    pub fn build(
        frame_px: (usize, usize),
        block_px: usize,
        samples_per_block: Option<usize>,
        clip: ClipLevel,
        sample: impl Fn(usize, usize) -> [f64; 3],
    ) -> BlockStats {
        let (dw, dh) = frame_px;
        let block = block_px.max(1);
        let (sw, sh) = (dw.div_ceil(block), dh.div_ceil(block));
        let mut mean = Vec::with_capacity(sw * sh);
        let mut clipped = Vec::with_capacity(sw * sh);
        let mut clipped_colour = Vec::with_capacity(sw * sh);
        for by in 0..sh {
            for bx in 0..sw {
                let (x0, y0) = (bx * block, by * block);
                let (x1, y1) = ((x0 + block).min(dw), (y0 + block).min(dh));
                let spb = samples_per_block.unwrap_or(block);
                let n = spb.min(x1 - x0).max(1);
                let m = spb.min(y1 - y0).max(1);
                let mut acc = [0.0f64; 3];
                let mut clip_acc = [0.0f64; 3];
                let mut clip_n = 0usize;
                for j in 0..m {
                    for i in 0..n {
                        // Sample centres spread evenly over the block.
                        let x = x0 + ((2 * i + 1) * (x1 - x0)) / (2 * n);
                        let y = y0 + ((2 * j + 1) * (y1 - y0)) / (2 * m);
                        let rgb = sample(x, y);
                        let mut any = false;
                        for k in 0..3 {
                            acc[k] += rgb[k].clamp(0.0, 1e3);
                            any |= rgb[k] >= clip.threshold[k];
                        }
                        if any {
                            clip_n += 1;
                            (0..3).for_each(|k| clip_acc[k] += rgb[k].clamp(0.0, 1e3));
                        }
                    }
                }
                let count = (n * m) as f64;
                mean.push(acc.map(|v| (v / count) as f32));
                clipped.push((clip_n as f64 / count) as f32);
                clipped_colour.push(clip_acc.map(|v| (v / clip_n.max(1) as f64) as f32));
            }
        }
        BlockStats {
            width: sw,
            height: sh,
            block_px: block,
            frame_px,
            mean,
            clipped,
            clipped_colour,
            clip,
        }
    }

    /// True when any sample of the frame is clipped.
    pub fn any_clipped(&self) -> bool {
        self.clipped.iter().any(|f| *f > 0.0)
    }

    fn clipped_fraction(&self, b: usize) -> f64 {
        f64::from(self.clipped[b])
    }
}

/// How recovery treats clipped samples.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RecoverySettings {
    /// A fixed factor on every clipped sample (its value, i.e. the clip level) instead of the
    /// estimate.
    pub highlight_gain: Option<f64>,
}

/// The class of a clipped region.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RegionKind {
    /// Small solid angle: becomes a light source.
    Compact,
    /// Large solid angle: stays in the environment, extrapolated by the sky model.
    Extended,
}

/// One connected clipped region and what recovery made of it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Region {
    /// Compact or extended.
    pub kind: RegionKind,
    /// Blocks in the region.
    pub blocks: usize,
    /// Clipped solid angle `Σ f_b Ω_b`, steradians.
    pub clipped_solid_angle_sr: f64,
    /// Centroid of the clipped area, frame pixels.
    pub centre_px: [f64; 2],
    /// Direction of that centroid, world frame.
    pub direction_world: [f64; 3],
    /// True when the region touches the picture's border (partly outside the frame).
    pub touches_edge: bool,
    /// True when the region became a light source (compact regions beyond the
    /// [`MAX_RECOVERED_LIGHTS`] largest add their flux to the nearest one).
    pub light: bool,
    /// Recovered radiance of the clipped samples over the clip level (1 = nothing added).
    pub gain: f64,
}

/// What recovery returns for one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Recovered {
    /// Compact sources (frame units), brightest first.
    pub lights: Vec<LightSource>,
    /// The thumbnail of the extended remainder: compact sources replaced by their
    /// surroundings, extended regions extrapolated.
    pub remainder: Vec<[f32; 3]>,
    /// The clipped regions found.
    pub regions: Vec<Region>,
}

/// Geometry of the blocks through the camera.
struct BlockGeometry {
    dir: Vec<DVec3>,
    centre_px: Vec<DVec2>,
    solid_angle_sr: Vec<f64>,
}

fn block_geometry(stats: &BlockStats, camera: &Camera) -> BlockGeometry {
    let f = camera.focal_px();
    let c = camera.principal_px();
    let (dw, dh) = stats.frame_px;
    let b = stats.block_px;
    let mut g = BlockGeometry {
        dir: Vec::with_capacity(stats.mean.len()),
        centre_px: Vec::with_capacity(stats.mean.len()),
        solid_angle_sr: Vec::with_capacity(stats.mean.len()),
    };
    for by in 0..stats.height {
        for bx in 0..stats.width {
            let (x0, y0) = ((bx * b) as f64, (by * b) as f64);
            let (x1, y1) = (((bx + 1) * b).min(dw) as f64, ((by + 1) * b).min(dh) as f64);
            let p = DVec2::new(0.5 * (x0 + x1), 0.5 * (y0 + y1));
            let r2 = (p - c).length_squared();
            let cos_a = f / (f * f + r2).sqrt();
            g.dir.push(camera.ray_world(p));
            g.centre_px.push(p);
            // Pinhole: dΩ = dA cos³α / f².
            g.solid_angle_sr
                .push((x1 - x0) * (y1 - y0) * cos_a.powi(3) / (f * f));
        }
    }
    g
}

/// Connected components (8-neighbour) of the blocks where `mask` is true, in scan order.
fn components(w: usize, h: usize, mask: &[bool]) -> Vec<Vec<usize>> {
    let mut label = vec![usize::MAX; w * h];
    let mut out = Vec::new();
    for start in 0..w * h {
        if !mask[start] || label[start] != usize::MAX {
            continue;
        }
        let id = out.len();
        let mut comp = vec![start];
        label[start] = id;
        let mut i = 0;
        while i < comp.len() {
            let b = comp[i];
            i += 1;
            let (x, y) = ((b % w) as isize, (b / w) as isize);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                        continue;
                    }
                    let n = ny as usize * w + nx as usize;
                    if mask[n] && label[n] == usize::MAX {
                        label[n] = id;
                        comp.push(n);
                    }
                }
            }
        }
        comp.sort_unstable();
        out.push(comp);
    }
    out
}

/// CIE standard overcast sky, relative: `(1 + 2 cos z)/3`, `cos z` = the direction's z.
fn overcast(dir: DVec3) -> f64 {
    (1.0 + 2.0 * dir.z.max(0.0)) / 3.0
}

/// Recovers the clipped light of one frame (module doc). `stats` must come from a frame seen
/// through `camera`.
pub fn recover(stats: &BlockStats, camera: &Camera, settings: &RecoverySettings) -> Recovered {
    let mut remainder = stats.mean.clone();
    if !stats.any_clipped() {
        return Recovered {
            lights: Vec::new(),
            remainder,
            regions: Vec::new(),
        };
    }
    let (w, h) = (stats.width, stats.height);
    let geo = block_geometry(stats, camera);
    let lum: Vec<f64> = stats
        .mean
        .iter()
        .map(|m| luminance(m.map(f64::from)))
        .collect();
    let mask: Vec<bool> = (0..w * h)
        .map(|b| stats.clipped_fraction(b) > 0.0)
        .collect();
    let clip_lum = luminance(stats.clip.level).max(1e-12);
    // The exposure anchor: the frame's median luminance.
    let mut sorted = lum.clone();
    sorted.sort_by(f64::total_cmp);
    let l_med = sorted[sorted.len() / 2].max(MIN_MEDIAN_LUMINANCE);
    let e_frame = std::f64::consts::PI * l_med / GREY_ALBEDO;

    struct Comp {
        blocks: Vec<usize>,
        omega_clip: f64,
        centre: DVec2,
        dir: DVec3,
        ring: Vec<usize>,
        ring_mean: Option<[f64; 3]>,
        compact: bool,
        touches_edge: bool,
    }
    let comps: Vec<Comp> = components(w, h, &mask)
        .into_iter()
        .map(|blocks| {
            let mut omega_clip = 0.0;
            let mut omega_all = 0.0;
            let mut dir = DVec3::ZERO;
            let mut centre = DVec2::ZERO;
            let mut touches_edge = false;
            for &b in &blocks {
                let f = stats.clipped_fraction(b);
                omega_clip += f * geo.solid_angle_sr[b];
                omega_all += geo.solid_angle_sr[b];
                dir += f * geo.solid_angle_sr[b] * geo.dir[b];
                centre += f * geo.solid_angle_sr[b] * geo.centre_px[b];
                let (x, y) = (b % w, b / w);
                touches_edge |= x == 0 || y == 0 || x + 1 == w || y + 1 == h;
            }
            let dir = dir.normalize_or(geo.dir[blocks[0]]);
            let centre = centre / omega_clip.max(1e-300);
            // The unclipped ring: blocks within three equivalent radii of the centroid (at
            // least two blocks' width), outside the region.
            let r_eq = (omega_all / std::f64::consts::PI).sqrt();
            let block_rad = geo.solid_angle_sr[blocks[0]].sqrt();
            let cos_ring = (3.0 * r_eq).max(2.5 * block_rad).min(1.5).cos();
            let ring: Vec<usize> = (0..w * h)
                .filter(|&b| !mask[b] && geo.dir[b].dot(dir) >= cos_ring)
                .collect();
            let ring_mean = (!ring.is_empty()).then(|| {
                let mut acc = [0.0f64; 3];
                for &b in &ring {
                    (0..3).for_each(|k| acc[k] += f64::from(stats.mean[b][k]));
                }
                acc.map(|v| v / ring.len() as f64)
            });
            // An emitter: small, or moderately large but standing out against darker
            // surroundings (a luminaire, a window at night); a bright sky or a sunlit wall
            // fades into surroundings near the clip level instead.
            let dark_ring =
                ring_mean.is_some_and(|m| luminance(m) <= EMITTER_RING_CONTRAST * clip_lum);
            let compact =
                omega_clip <= COMPACT_MAX_SR || (omega_clip <= EMITTER_MAX_SR && dark_ring);
            Comp {
                blocks,
                omega_clip,
                centre,
                dir,
                ring,
                ring_mean,
                compact,
                touches_edge,
            }
        })
        .collect();

    let total_compact_omega: f64 = comps
        .iter()
        .filter(|c| c.compact)
        .map(|c| c.omega_clip)
        .sum();
    // The largest compact regions (largest flux under the prior) become lights.
    let mut order: Vec<usize> = (0..comps.len()).filter(|&i| comps[i].compact).collect();
    order.sort_by(|&a, &b| {
        comps[b]
            .omega_clip
            .total_cmp(&comps[a].omega_clip)
            .then(a.cmp(&b))
    });
    let mut as_light = vec![false; comps.len()];
    for &i in order.iter().take(MAX_RECOVERED_LIGHTS) {
        as_light[i] = true;
    }
    // More emitters than lights: a field of windows and signs that light little of the scene,
    // not its key light; each gets the typical luminance of one (see
    // EMITTER_OVER_MEAN_AT_NIGHT) rather than a share of the key light's flux.
    let emitter_field = order.len() > MAX_RECOVERED_LIGHTS;
    let mut lights = Vec::new();
    // Compact regions that did not become lights: (direction, flux).
    let mut leftovers: Vec<(DVec3, [f64; 3])> = Vec::new();
    let mut regions = Vec::new();
    for (ci, c) in comps.iter().enumerate() {
        let (compact, ring_mean) = (c.compact, c.ring_mean);
        let light = as_light[ci];
        // Radiance of a clipped sample over the clip level, per block.
        let gain_of = |b: usize| -> f64 {
            if let Some(g) = settings.highlight_gain {
                return g;
            }
            if compact && emitter_field {
                (EMITTER_OVER_MEAN_AT_NIGHT * l_med / clip_lum).clamp(1.0, MAX_GAIN)
            } else if compact {
                let flux = SOURCE_ILLUMINANCE_RATIO * e_frame * c.omega_clip
                    / total_compact_omega.max(1e-300);
                (flux / c.omega_clip.max(1e-300) / clip_lum).clamp(1.0, MAX_GAIN)
            } else {
                // Overcast gradient fitted to the ring (mean of L/g over its blocks).
                let fit: Vec<f64> = c
                    .ring
                    .iter()
                    .filter(|&&r| geo.dir[r].z > 0.0)
                    .map(|&r| lum[r] / overcast(geo.dir[r]))
                    .collect();
                if fit.is_empty() {
                    return 1.0;
                }
                let lz = fit.iter().sum::<f64>() / fit.len() as f64;
                (lz * overcast(geo.dir[b]) / clip_lum).clamp(1.0, MAX_GAIN)
            }
        };
        let mut gain_sum = 0.0;
        let mut flux = [0.0f64; 3];
        let surround = ring_mean.unwrap_or([0.0; 3]);
        for &b in &c.blocks {
            // The estimates are luminances: the gain on the clipped samples' own colour that
            // reaches it (a coloured clip has less luminance than the white level).
            let colour_lum = luminance(stats.clipped_colour[b].map(f64::from));
            let g = match settings.highlight_gain {
                Some(g) => g,
                None => {
                    let to_lum = (clip_lum / colour_lum.max(0.25 * clip_lum)).max(1.0);
                    (gain_of(b) * to_lum).min(MAX_GAIN)
                }
            };
            gain_sum += g;
            // The clipped samples keep their colour, scaled by the gain.
            let m: [f64; 3] = std::array::from_fn(|k| {
                f64::from(stats.mean[b][k])
                    + f64::from(stats.clipped[b])
                        * (g - 1.0)
                        * f64::from(stats.clipped_colour[b][k])
            });
            if compact {
                for k in 0..3 {
                    flux[k] += (m[k] - surround[k]).max(0.0) * geo.solid_angle_sr[b];
                }
                remainder[b] = surround.map(|v| v as f32);
            } else {
                remainder[b] = m.map(|v| v as f32);
            }
        }
        let gain = gain_sum / c.blocks.len() as f64;
        if compact && !light {
            leftovers.push((c.dir, flux));
        } else if light && c.omega_clip > 0.0 && flux.iter().any(|v| *v > 0.0) {
            lights.push(LightSource {
                direction_world: c.dir,
                solid_angle_sr: c.omega_clip,
                radiance_rgb: flux.map(|v| v / c.omega_clip),
                distance_m: None,
            });
        }
        regions.push(Region {
            kind: if compact {
                RegionKind::Compact
            } else {
                RegionKind::Extended
            },
            blocks: c.blocks.len(),
            clipped_solid_angle_sr: c.omega_clip,
            centre_px: c.centre.to_array(),
            direction_world: c.dir.to_array(),
            touches_edge: c.touches_edge,
            light,
            gain,
        });
    }
    // A compact source's light must stay where it is: in the environment, the frame's fill
    // outside the view would copy a window at the picture's edge over the sphere behind and
    // beside the camera and multiply its flux many times. So the small ones join the nearest
    // light, flux conserved (on a skyline, a window beside its neighbour).
    for (dir, flux) in leftovers {
        let nearest = lights.iter_mut().max_by(|a, b| {
            a.direction_world
                .dot(dir)
                .total_cmp(&b.direction_world.dot(dir))
        });
        if let Some(l) = nearest {
            for (r, f) in l.radiance_rgb.iter_mut().zip(flux) {
                *r += f / l.solid_angle_sr;
            }
        }
    }
    lights.sort_by(|a, b| {
        luminance(b.radiance_times_solid_angle())
            .total_cmp(&luminance(a.radiance_times_solid_angle()))
    });
    Recovered {
        lights,
        remainder,
        regions,
    }
}
