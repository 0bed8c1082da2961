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
//! 2. **Regions and kinds**: connected components (8-neighbour) of blocks holding clipped
//!    samples, with their clipped solid angle `Ω_clip = Σ f_b Ω_b` through the pinhole model and
//!    the level of the unclipped ring around them. A region is a **surface** unless the evidence
//!    says emitter:
//!    - a **lamp** is compact (at most [`EMITTER_MAX_SR`]) and stands in a dark place: its ring
//!      is darker than [`EMITTER_RING_CONTRAST`] × the clip level, and, unless the whole frame
//!      is dark (a median below [`NIGHT_MEDIAN_OVER_CLIP`] of white), it is above the horizon
//!      with a ring darker than [`DARK_SURROUND_OVER_MEDIAN`] × the frame's median (a white roof
//!      on asphalt in daylight has the scene's typical luminance around it, a lamp does not);
//!      more lamps than [`MAX_RECOVERED_LIGHTS`] are a field of lit **windows**;
//!    - unless lamps light a night scene, the **sun** is in the largest clipped region above the
//!      horizon, when that holds at least [`SUN_MIN_SR`] (its glare clips several degrees), at
//!      least [`SUN_MIN_FILL`] of its blocks (the glare clips solidly, a facade of lit windows
//!      does not), its surroundings are no brighter than [`SUN_SURROUND_OVER_MEDIAN`] × the
//!      median, and its core clips every channel ([`SUN_CORE_MIN_CHANNEL_RATIO`]: a wall lit by
//!      a warm lamp clips red only) or, where the camera renders the clipped sun in a colour,
//!      its surroundings fall off toward it all around like the sun's aureole
//!      ([`SUN_MIN_AUREOLE`]);
//!    - any other region above the horizon larger than [`COMPACT_MAX_SR`] is **sky**.
//! 3. **Radiance.** The exposure anchors it: the camera puts a mid-grey surface near the frame's
//!    median luminance `L_med`, so the illuminance on the scene's typical surfaces is
//!    `E = π L_med / a` (grey-world albedo `a` = [`GREY_ALBEDO`], Lambert).
//!    - A **surface** reflects at most the light that falls on it: never more than
//!      [`SURFACE_BOUND_OVER_MEDIAN`] × `L_med` (snow in full sun against shade; ≈ 10× the
//!      frame's white in daylight exposed for mid-grey, less the darker the frame), and its
//!      clipped samples are taken at the mean of the histogram's bright tail above the clip,
//!      [`SURFACE_OVER_CLIP`] × the clip level, less where the region only grazes the clip.
//!    - **Sky**: the CIE standard overcast sky, `L(z) ∝ (1 + 2 cos z)/3` with `z` the zenith
//!      angle, fitted to the unclipped ring and extrapolated into the clipped blocks, at least
//!      the surface estimate and at most its bound.
//!    - The **sun** region is sky, and the key light's flux `Φ = k E` (`k` =
//!      [`KEY_LIGHT_ILLUMINANCE_RATIO`]) becomes a light source at its core (the blocks farthest
//!      from the unclipped surroundings), in the colour of the clipped samples there: the
//!      region is no longer flattened to white, and its flux does not depend on how far the
//!      glare spread.
//!    - **Lamps** at night share the key light's flux in proportion to their clipped solid
//!      angles (a source's bloom grows with its flux); in daylight they are not the key light
//!      and each gets the luminance of a lit window (below). Each becomes a light source, and
//!      its blocks are replaced in the environment by the ring's level: the environment's fill
//!      outside the view would copy a lamp at the picture's edge over the sphere behind and
//!      beside the camera and multiply its flux many times. The [`MAX_RECOVERED_LIGHTS`] largest become lights; the
//!      smaller ones add their flux to the nearest.
//!    - **Windows** are not the scene's key light (they light little of what the camera sees):
//!      each gets the typical luminance of a lit window, [`EMITTER_OVER_MEAN_AT_NIGHT`] times
//!      the frame's median.
//!
//!    Clipped samples keep their measured colour (a sodium lamp clipped in red and green stays
//!    yellow), scaled to reach the estimated luminance.
//! 4. `highlight_gain` replaces step 3 by a fixed factor: every clipped sample becomes `G ×` its
//!    own value, lamps still becoming lights.
//!
//! A frame without clipped samples comes back unchanged (the same thumbnail, no lights).
//!
//! ## Hard frames (all tested; every output finite)
//!
//! - **All white**: one region with no unclipped ring: nothing to extrapolate from, so it stays
//!   at the clip level (the light of the frame as it is), no lights.
//! - **All black**: nothing clipped. A lamp in an otherwise black frame gets its flux from
//!   [`MIN_MEDIAN_LUMINANCE`], small and finite.
//! - **One huge clipped region**: sky, or surface below the horizon; never above the surface
//!   bound unless it holds the sun, whose flux is bounded by the exposure.
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
use rayon::prelude::*;

use super::block_grid::{components, distance_to_unclipped};
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
/// Illuminance the key light (the sun, or the lamps together) gives at the camera over the
/// illuminance on the surfaces the exposure is set for. A camera facing the sun receives its
/// direct beam at normal incidence, a typical surface at about 60° plus the sky's fill: of the
/// same order. 1 is the middle of the range the panoramas of `tests/data` span (region table in
/// `docs/method.md`); 3 over-brightens the sun's region by ≈ 1.6 stops there.
pub const KEY_LIGHT_ILLUMINANCE_RATIO: f64 = 1.0;
/// Luminance of a typical clipped lit surface over the clip level. Surfaces lit by the same
/// light fill the bright end of a frame's histogram with a tail that falls roughly as a power
/// law of exponent α ≈ 2–3; the mean of such a tail above a threshold is α/(α − 1) = 1.5–2
/// times the threshold, whatever the exposure. Scaled toward the clip level by the region's
/// clipped fraction (a region only grazing the clip lies just above it) and by its whiteness (a
/// sample clipped in one channel only has its other channels well below the clip).
pub const SURFACE_OVER_CLIP: f64 = 2.0;
/// The most a clipped surface may be over the frame's median: the whitest surfaces (fresh
/// snow, albedo 0.9) over grey, ≈ 5, times sun plus sky over the typical light, ≤ 11.
pub const SURFACE_BOUND_OVER_MEDIAN: f64 = 55.0;
/// Surroundings of a lamp are at most this fraction of the frame's median luminance: an
/// emitter stands in a place darker than the scene's typical surfaces (a white roof on asphalt
/// in daylight does not: its surroundings are the scene's typical luminance).
pub const DARK_SURROUND_OVER_MEDIAN: f64 = 0.25;
/// Surroundings of the sun's region are at most this multiple of the frame's median: the
/// glare and the bright sky next to the sun are clipped with it, so what is left unclipped
/// around it is the sky and the scene farther off, darker than the glare's edge; a bright
/// surface against a brighter sky (a facade, a cloud bank) has more light around it.
pub const SUN_SURROUND_OVER_MEDIAN: f64 = 2.0;
/// Least share of its blocks' solid angle that the sun's region has clipped: the sun's glare
/// clips solidly (0.8–1 on the panoramas of `tests/data`); a facade of lit windows or a field of
/// glints clips a lattice of small patches that 1° blocks join into one sparse region.
pub const SUN_MIN_FILL: f64 = 0.6;
/// Least ratio of the weakest to the strongest channel of the clipped samples at the core of
/// the sun's region. The sun is 10⁵–10⁶ times a mid-grey exposure and even low in the sky
/// keeps a few per cent of that in its weakest channel (Rayleigh optical depth ≈ 0.2 at 450 nm,
/// 0.05 at 650 nm), so its core clips every channel (0.75–1 on the views of `tests/data`); a
/// wall lit by a warm lamp, a few times white, clips red only (0.19–0.28 there). A camera may
/// render the clipped sun in a colour of its own (`samples/sunset.mp4`: (255, 240, 0), 0.12); then
/// the aureole decides ([`SUN_MIN_AUREOLE`]).
pub const SUN_CORE_MIN_CHANNEL_RATIO: f64 = 0.5;
/// Least alignment of the unclipped surroundings' luminance gradient with the direction to the
/// core that makes a region with a coloured core the sun's: its aureole falls off radially all
/// around it (`samples/sunset.mp4` 0.54–0.56 over its frames, `studio`'s lamps 0.31–0.61),
/// where a lamp-lit wall (0.31 and −0.29) or a sunlit facade (0.08–0.11) has structure around it.
pub const SUN_MIN_AUREOLE: f64 = 0.45;
/// A frame whose median luminance is at most this fraction of its white is a night (or dark
/// interior) scene, exposed well under mid-grey: its clipped compact regions against dark
/// surroundings are lamps whatever the median.
pub const NIGHT_MEDIAN_OVER_CLIP: f64 = 0.05;
/// Smallest clipped solid angle of a region holding the sun, steradians (a disc of ≈ 6.5°):
/// the sun is 10⁵–10⁶ times a mid-grey exposure, so a lens's glare clips several degrees
/// around it; a smaller clipped patch in the sky is a cloud's edge or a surface.
pub const SUN_MIN_SR: f64 = 0.05;
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

/// A block's mean, clipped share and clipped colour.
type BlockSums = ([f32; 3], f32, [f32; 3]);

impl BlockStats {
    /// Statistics of a `frame_w × frame_h` picture read through `sample(x, y)` (linear RGB of
    /// displayed pixel (x, y)) in `block_px` blocks, with `samples_per_block` samples per block
    /// side spread evenly (`None`: every pixel).
    pub fn build(
        frame_px: (usize, usize),
        block_px: usize,
        samples_per_block: Option<usize>,
        clip: ClipLevel,
        sample: impl Fn(usize, usize) -> [f64; 3] + Sync,
    ) -> BlockStats {
        let (dw, dh) = frame_px;
        let block = block_px.max(1);
        let (sw, sh) = (dw.div_ceil(block), dh.div_ceil(block));
        // Each block on its own (rows of blocks over rayon's threads): the same sums in the
        // same order whatever the threads.
        let rows: Vec<Vec<BlockSums>> = (0..sh)
            .into_par_iter()
            .map(|by| {
                (0..sw)
                    .map(|bx| {
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
                        (
                            acc.map(|v| (v / count) as f32),
                            (clip_n as f64 / count) as f32,
                            clip_acc.map(|v| (v / clip_n.max(1) as f64) as f32),
                        )
                    })
                    .collect()
            })
            .collect();
        let blocks = rows.into_iter().flatten();
        let (mut mean, mut clipped, mut clipped_colour) = (
            Vec::with_capacity(sw * sh),
            Vec::with_capacity(sw * sh),
            Vec::with_capacity(sw * sh),
        );
        for (m, c, cc) in blocks {
            mean.push(m);
            clipped.push(c);
            clipped_colour.push(cc);
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

/// What a clipped region is taken to be.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RegionKind {
    /// A lit surface (a sunlit wall, a white roof, snow, a cloud's edge): a few times the clip
    /// level at most, kept in the environment.
    Surface,
    /// A large clipped region above the horizon: the overcast gradient of its surroundings,
    /// kept in the environment.
    Sky,
    /// The sky region that holds the sun: the sky, plus the key light's flux as a light
    /// source at its core.
    Sun,
    /// A compact emitter against dark surroundings (a lamp, a softbox): a light source sharing
    /// the key light's flux.
    Lamp,
    /// One of more emitters than lights (lit windows and signs of a night skyline): a light
    /// source at the luminance of a lit window.
    Window,
}

/// One connected clipped region and what recovery made of it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Region {
    /// What the region is taken to be.
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
    /// True when the region became a light source: the sun, and the [`MAX_RECOVERED_LIGHTS`]
    /// largest lamps or windows (the others add their flux to the nearest one).
    pub light: bool,
    /// Recovered radiance of the clipped samples over the clip level (1 = nothing added).
    pub gain: f64,
    /// Recovered mean radiance of the region's clipped samples, linear RGB, frame units.
    pub radiance_rgb: [f64; 3],
    /// Mean luminance of the unclipped surroundings, frame units (0 with none).
    pub surround_luminance: f64,
}

/// What recovery returns for one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Recovered {
    /// The sun and lamps (frame units), brightest first.
    pub lights: Vec<LightSource>,
    /// The thumbnail of the extended remainder: lamps and windows replaced by their
    /// surroundings, surfaces and sky (the sun's included) at their recovered radiance.
    pub remainder: Vec<[f32; 3]>,
    /// The clipped regions found.
    pub regions: Vec<Region>,
    /// Per block: the 1-based index of its region in `regions`, 0 where nothing is clipped.
    pub block_region: Vec<u32>,
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

/// CIE standard overcast sky, relative: `(1 + 2 cos z)/3`, `cos z` = the direction's z.
fn overcast(dir: DVec3) -> f64 {
    (1.0 + 2.0 * dir.z.max(0.0)) / 3.0
}

/// One clipped region while it is being classified.
struct Candidate {
    blocks: Vec<usize>,
    /// Clipped solid angle `Σ f_b Ω_b`, and that of the blocks whole.
    omega_clip: f64,
    omega_blocks: f64,
    centre: DVec2,
    dir: DVec3,
    /// Direction and clipped colour (solid-angle weighted sum) of the core: the blocks
    /// farthest from the unclipped surroundings.
    core_dir: DVec3,
    core_colour: [f64; 3],
    /// How straight the ring's luminance rises toward the core ([`aureole`]).
    aureole: f64,
    ring: Vec<usize>,
    ring_mean: Option<[f64; 3]>,
    touches_edge: bool,
}

impl Candidate {
    fn ring_luminance(&self) -> f64 {
        self.ring_mean.map_or(0.0, luminance)
    }

    /// The core's weakest channel over its strongest (1 where every channel clips).
    fn core_channel_ratio(&self) -> f64 {
        let max = self.core_colour.into_iter().fold(0.0, f64::max);
        let min = self.core_colour.into_iter().fold(f64::INFINITY, f64::min);
        if max > 0.0 { min / max } else { 0.0 }
    }
}

/// Recovers the clipped light of one frame (module doc). `stats` must come from a frame seen
/// through `camera`.
pub fn recover(stats: &BlockStats, camera: &Camera, settings: &RecoverySettings) -> Recovered {
    let mut remainder = stats.mean.clone();
    if !stats.any_clipped() {
        return Recovered {
            lights: Vec::new(),
            block_region: vec![0; remainder.len()],
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
    let anchor = Anchor::of(stats, &lum);
    let Anchor {
        clip_lum,
        l_med,
        key_flux,
        surface_bound,
        surface_typical,
    } = anchor;
    let dist = distance_to_unclipped(w, h, &mask);
    let cands = candidates(stats, &geo, &mask, &dist);
    let kinds = Kinds::of(&cands, &anchor, settings);

    let mut lights = Vec::new();
    // Lamps that did not become lights: (direction, flux).
    let mut leftovers: Vec<(DVec3, [f64; 3])> = Vec::new();
    let mut regions = Vec::new();
    let mut block_region = vec![0u32; w * h];
    for (ci, c) in cands.iter().enumerate() {
        let kind = kinds.kind[ci];
        let emitter = matches!(kind, RegionKind::Lamp | RegionKind::Window);
        // Step 3: the luminance of a clipped sample, per block.
        // The overcast sky's zenith luminance fitted to the ring above the horizon.
        let fit: Vec<f64> = c
            .ring
            .iter()
            .filter(|&&r| geo.dir[r].z > 0.0)
            .map(|&r| lum[r] / overcast(geo.dir[r]))
            .collect();
        let sky_zenith = (!fit.is_empty()).then(|| fit.iter().sum::<f64>() / fit.len() as f64);
        let fill = (c.omega_clip / c.omega_blocks.max(1e-300)).clamp(0.0, 1.0);
        let target_lum = |b: usize| -> f64 {
            match kind {
                RegionKind::Window => EMITTER_OVER_MEAN_AT_NIGHT * l_med,
                RegionKind::Lamp if !kinds.lamps_are_key => EMITTER_OVER_MEAN_AT_NIGHT * l_med,
                // The key light's flux shared in proportion to Ω: the same radiance for all.
                RegionKind::Lamp => key_flux / kinds.total_lamp_omega.max(1e-300),
                RegionKind::Sky | RegionKind::Sun => {
                    let fit = sky_zenith.map_or(clip_lum, |lz| lz * overcast(geo.dir[b]));
                    fit.max(clip_lum + (surface_typical - clip_lum) * fill)
                        .min(surface_bound)
                }
                RegionKind::Surface => clip_lum + (surface_typical - clip_lum) * fill,
            }
            .min(if c.ring_mean.is_some() {
                f64::INFINITY
            } else {
                // Nothing unclipped around it: no evidence of anything above the clip.
                clip_lum
            })
        };
        let mut gain_sum = 0.0;
        let mut rad_acc = [0.0f64; 3];
        let mut rad_w = 0.0;
        let mut flux = [0.0f64; 3];
        let surround = c.ring_mean.unwrap_or([0.0; 3]);
        for &b in &c.blocks {
            // The estimates are luminances: the gain on the clipped samples' own colour that
            // reaches it (a coloured clip has less luminance than the white level).
            let colour_lum = luminance(stats.clipped_colour[b].map(f64::from));
            let g = match settings.highlight_gain {
                Some(g) => g,
                None => {
                    let white = (colour_lum / clip_lum).clamp(0.25, 1.0);
                    let g = target_lum(b) / clip_lum;
                    if kind == RegionKind::Surface {
                        // A sample clipped in one channel only lies near the clip: its other
                        // channels are well below it.
                        1.0 + (g - 1.0).max(0.0) * white
                    } else {
                        (g / white).clamp(1.0, MAX_GAIN)
                    }
                }
            };
            gain_sum += g;
            block_region[b] = regions.len() as u32 + 1;
            let fw = stats.clipped_fraction(b) * geo.solid_angle_sr[b];
            rad_w += fw;
            (0..3).for_each(|k| rad_acc[k] += fw * g * f64::from(stats.clipped_colour[b][k]));
            // The clipped samples keep their colour, scaled by the gain.
            let m: [f64; 3] = std::array::from_fn(|k| {
                f64::from(stats.mean[b][k])
                    + stats.clipped_fraction(b) * (g - 1.0) * f64::from(stats.clipped_colour[b][k])
            });
            if emitter {
                for k in 0..3 {
                    flux[k] += (m[k] - surround[k]).max(0.0) * geo.solid_angle_sr[b];
                }
                remainder[b] = surround.map(|v| v as f32);
            } else {
                remainder[b] = m.map(|v| v as f32);
            }
        }
        let mut radiance_rgb = rad_acc.map(|v| v / rad_w.max(1e-300));
        if kind == RegionKind::Sun {
            let (light, sun_rgb) = sun_light(c, key_flux);
            lights.push(light);
            for k in 0..3 {
                radiance_rgb[k] += sun_rgb[k] / c.omega_clip.max(1e-300);
            }
        }
        if emitter && !kinds.as_light[ci] {
            leftovers.push((c.dir, flux));
        } else if emitter && c.omega_clip > 0.0 && flux.iter().any(|v| *v > 0.0) {
            lights.push(LightSource {
                direction_world: c.dir,
                solid_angle_sr: c.omega_clip,
                radiance_rgb: flux.map(|v| v / c.omega_clip),
                distance_m: None,
            });
        }
        regions.push(Region {
            kind,
            blocks: c.blocks.len(),
            clipped_solid_angle_sr: c.omega_clip,
            centre_px: c.centre.to_array(),
            direction_world: c.dir.to_array(),
            touches_edge: c.touches_edge,
            light: kinds.as_light[ci] || kind == RegionKind::Sun,
            gain: gain_sum / c.blocks.len() as f64,
            radiance_rgb,
            surround_luminance: c.ring_luminance(),
        });
    }
    merge_into_nearest(&mut lights, leftovers);
    lights.sort_by(|a, b| {
        luminance(b.radiance_times_solid_angle())
            .total_cmp(&luminance(a.radiance_times_solid_angle()))
    });
    Recovered {
        lights,
        remainder,
        regions,
        block_region,
    }
}

/// The sun's light at the core of region `c`, in the colour of the core's clipped samples,
/// carrying the key light's flux; and that flux per colour.
fn sun_light(c: &Candidate, key_flux: f64) -> (LightSource, [f64; 3]) {
    let colour_lum = luminance(c.core_colour).max(1e-300);
    let solid_angle_sr = c.omega_clip.min(COMPACT_MAX_SR);
    let sun_rgb = c.core_colour.map(|v| key_flux * v / colour_lum);
    let light = LightSource {
        direction_world: c.core_dir,
        solid_angle_sr,
        radiance_rgb: sun_rgb.map(|v| v / solid_angle_sr),
        distance_m: None,
    };
    (light, sun_rgb)
}

/// Emitters that did not become lights (`leftovers`: direction, flux) join the nearest light,
/// flux conserved.
fn merge_into_nearest(lights: &mut [LightSource], leftovers: Vec<(DVec3, [f64; 3])>) {
    // A lamp's light must stay where it is: in the environment, the frame's fill outside the
    // view would copy a window at the picture's edge over the sphere behind and beside the
    // camera and multiply its flux many times. So the small ones join the nearest light, flux
    // conserved (on a skyline, a window beside its neighbour).
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
}

/// What the frame's exposure says about its clipped light: the clip level's luminance, the
/// frame's median, the key light's flux, and what a clipped surface is taken to be and the
/// most it may be (module doc, step 3).
#[derive(Debug, Clone, Copy)]
struct Anchor {
    clip_lum: f64,
    l_med: f64,
    key_flux: f64,
    surface_bound: f64,
    surface_typical: f64,
}

impl Anchor {
    /// The anchor of a frame whose blocks have luminance `lum`: its median, and the
    /// illuminance on the surfaces the exposure is set for.
    fn of(stats: &BlockStats, lum: &[f64]) -> Anchor {
        let clip_lum = luminance(stats.clip.level).max(1e-12);
        let mut sorted = lum.to_vec();
        sorted.sort_by(f64::total_cmp);
        let l_med = sorted[sorted.len() / 2].max(MIN_MEDIAN_LUMINANCE);
        let e_frame = std::f64::consts::PI * l_med / GREY_ALBEDO;
        let surface_bound = (SURFACE_BOUND_OVER_MEDIAN * l_med).max(clip_lum);
        Anchor {
            clip_lum,
            l_med,
            key_flux: KEY_LIGHT_ILLUMINANCE_RATIO * e_frame,
            surface_bound,
            surface_typical: (SURFACE_OVER_CLIP * clip_lum).min(surface_bound),
        }
    }

    /// A frame exposed for the dark: its median far below the clip level.
    fn night(&self) -> bool {
        self.l_med <= NIGHT_MEDIAN_OVER_CLIP * self.clip_lum
    }
}

/// Step 1: the clipped regions (connected clipped blocks), each with its solid angle,
/// direction, core (the blocks farthest from the unclipped surroundings, `dist`) and unclipped
/// ring.
fn candidates(
    stats: &BlockStats,
    geo: &BlockGeometry,
    mask: &[bool],
    dist: &[u32],
) -> Vec<Candidate> {
    let (w, h) = (stats.width, stats.height);
    components(w, h, mask)
        .into_iter()
        .map(|blocks| {
            let mut omega_clip = 0.0;
            let mut omega_blocks = 0.0;
            let mut dir = DVec3::ZERO;
            let mut centre = DVec2::ZERO;
            let mut touches_edge = false;
            for &b in &blocks {
                let f = stats.clipped_fraction(b);
                omega_clip += f * geo.solid_angle_sr[b];
                omega_blocks += geo.solid_angle_sr[b];
                dir += f * geo.solid_angle_sr[b] * geo.dir[b];
                centre += f * geo.solid_angle_sr[b] * geo.centre_px[b];
                let (x, y) = (b % w, b / w);
                touches_edge |= x == 0 || y == 0 || x + 1 == w || y + 1 == h;
            }
            let dir = dir.normalize_or(geo.dir[blocks[0]]);
            let centre = centre / omega_clip.max(1e-300);
            let d_max = blocks.iter().map(|&b| dist[b]).max().unwrap_or(0);
            let (mut core_dir, mut core_px, mut core_w) = (DVec3::ZERO, DVec2::ZERO, 0.0);
            let mut core_colour = [0.0f64; 3];
            for &b in blocks.iter().filter(|&&b| dist[b] + 1 >= d_max) {
                let wgt = stats.clipped_fraction(b) * geo.solid_angle_sr[b];
                core_dir += wgt * geo.dir[b];
                core_px += wgt * geo.centre_px[b];
                core_w += wgt;
                (0..3).for_each(|k| core_colour[k] += wgt * f64::from(stats.clipped_colour[b][k]));
            }
            let core_px = core_px / f64::max(core_w, 1e-300);
            // The unclipped ring: blocks within three equivalent radii of the centroid (at
            // least two blocks' width), outside the region.
            let r_eq = (omega_blocks / std::f64::consts::PI).sqrt();
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
            Candidate {
                aureole: aureole(stats, geo, mask, &ring, core_px),
                blocks,
                omega_clip,
                omega_blocks,
                centre,
                dir,
                core_dir: core_dir.normalize_or(dir),
                core_colour,
                ring,
                ring_mean,
                touches_edge,
            }
        })
        .collect()
}

/// How straight the unclipped `ring`'s luminance rises toward `core_px`: `Σ ĝ·u / Σ |ĝ|` over
/// its blocks, `ĝ` the relative luminance gradient (central differences between unclipped
/// blocks), `u` the unit vector toward the core. 1 is a radial falloff all around (the sun's
/// aureole, `L ∝ θ^−k`), 0 texture with no preferred direction.
fn aureole(
    stats: &BlockStats,
    geo: &BlockGeometry,
    mask: &[bool],
    ring: &[usize],
    core_px: DVec2,
) -> f64 {
    let (w, h) = (stats.width, stats.height);
    let lum = |b: usize| luminance(stats.mean[b].map(f64::from));
    // The luminance difference across block b along (dx, dy), where both neighbours are unclipped.
    let diff = |b: usize, dx: usize, dy: usize| {
        let (x, y) = (b % w, b / w);
        (x >= dx && y >= dy && x + dx < w && y + dy < h)
            .then(|| (b - dy * w - dx, b + dy * w + dx))
            .filter(|&(a, c)| !mask[a] && !mask[c])
            .map(|(a, c)| 0.5 * (lum(c) - lum(a)))
    };
    let (mut along, mut total) = (0.0, 0.0);
    for &b in ring {
        if let (Some(gx), Some(gy)) = (diff(b, 1, 0), diff(b, 0, 1)) {
            let g = DVec2::new(gx, gy) / lum(b).max(1e-12);
            along += g.dot((core_px - geo.centre_px[b]).normalize_or_zero());
            total += g.length();
        }
    }
    if total > 0.0 { along / total } else { 0.0 }
}

/// Step 2: what each region is, and which emitters become lights.
struct Kinds {
    kind: Vec<RegionKind>,
    /// Whether a region's flux becomes a light of its own.
    as_light: Vec<bool>,
    /// Lamps carry the key light (a night frame with lamps).
    lamps_are_key: bool,
    /// Clipped solid angle of all lamps, sr.
    total_lamp_omega: f64,
}

impl Kinds {
    fn of(cands: &[Candidate], anchor: &Anchor, settings: &RecoverySettings) -> Kinds {
        let Anchor {
            clip_lum, l_med, ..
        } = *anchor;
        // Step 2: the kinds. Lamps and windows: compact, above the horizon, against surroundings
        // dark both next to the clip level and next to the scene's typical luminance.
        let night = anchor.night();
        let is_lamp = |c: &Candidate| {
            let ring = c.ring_luminance();
            c.omega_clip <= EMITTER_MAX_SR
                && ring <= EMITTER_RING_CONTRAST * clip_lum
                && (night || (c.dir.z > 0.0 && ring <= DARK_SURROUND_OVER_MEDIAN * l_med))
        };
        let mut lamps: Vec<usize> = (0..cands.len()).filter(|&i| is_lamp(&cands[i])).collect();
        lamps.sort_by(|&a, &b| {
            cands[b]
                .omega_clip
                .total_cmp(&cands[a].omega_clip)
                .then(a.cmp(&b))
        });
        let mut is_lamp = vec![false; cands.len()];
        lamps.iter().for_each(|&i| is_lamp[i] = true);
        // More emitters than lights: a field of windows and signs.
        let emitter_field = lamps.len() > MAX_RECOVERED_LIGHTS;
        // Lamps are the key light only at night; in daylight the sun and sky are, and a lamp or a
        // lit window shows the luminance of one.
        let lamps_are_key = night && !lamps.is_empty();
        // The sun, where no lamp is the key light: the largest clipped region above the horizon,
        // if it is as large and as solidly clipped as the sun's glare.
        let sun = if !lamps_are_key && settings.highlight_gain.is_none() {
            (0..cands.len())
                .filter(|&i| {
                    let c = &cands[i];
                    c.dir.z > 0.0
                        && !is_lamp[i]
                        && c.omega_clip >= SUN_MIN_SR
                        && c.omega_clip >= SUN_MIN_FILL * c.omega_blocks
                        && c.ring_luminance() <= SUN_SURROUND_OVER_MEDIAN * l_med
                        && (c.core_channel_ratio() >= SUN_CORE_MIN_CHANNEL_RATIO
                            || c.aureole >= SUN_MIN_AUREOLE)
                })
                .max_by(|&a, &b| cands[a].omega_clip.total_cmp(&cands[b].omega_clip))
        } else {
            None
        };
        let kind_of = |i: usize| -> RegionKind {
            if is_lamp[i] {
                if emitter_field {
                    RegionKind::Window
                } else {
                    RegionKind::Lamp
                }
            } else if sun == Some(i) {
                RegionKind::Sun
            } else if cands[i].dir.z > 0.0 && cands[i].omega_clip > COMPACT_MAX_SR {
                RegionKind::Sky
            } else {
                RegionKind::Surface
            }
        };
        let mut as_light = vec![false; cands.len()];
        for &i in lamps.iter().take(MAX_RECOVERED_LIGHTS) {
            as_light[i] = true;
        }
        Kinds {
            kind: (0..cands.len()).map(kind_of).collect(),
            as_light,
            lamps_are_key,
            total_lamp_omega: lamps.iter().map(|&i| cands[i].omega_clip).sum(),
        }
    }
}
