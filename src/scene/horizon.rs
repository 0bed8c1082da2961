//! The ground's horizon (so the camera's tilt and roll) estimated from the frames.
//!
//! # Method
//!
//! Man-made and natural scenes are full of straight edges that are either **vertical**
//! (posts, walls, door frames) or **horizontal** (kerbs, paving joints, roof lines, a sea
//! horizon). Seen through a pinhole camera of known field of view, each image segment
//! defines an *interpretation plane* through the camera centre, with unit normal `l` on the
//! Gaussian sphere. With `n` the ground's upward normal in camera space (the camera's tilt and
//! roll, see [`crate::scene::ground`]):
//!
//! - a vertical edge's plane contains `n`: `l · n = 0` (all verticals meet at the vertical
//!   vanishing point `n`);
//! - parallel horizontal edges share a vanishing point `d` on the horizon (`d · n = 0`), and
//!   for each edge `d = l × n` up to sign: a family shows as a peak of the edges' azimuths
//!   along the horizon;
//! - the horizon itself (a sea or a flat far skyline) is an edge with `l = ±n`.
//!
//! The estimate is the `n` with the most support from the three kinds of evidence, found by
//! an exhaustive search over tilt ∈ [−65°, 65°] × roll ∈ [−60°, 60°] (3° steps, then two finer
//! levels around the three best cells), so it has no random start and is a pure function of
//! the frame. A segment's discrepancy to a vertical vanishing point is measured as the angle
//! between it and the great circle through its midpoint and `n` (not as a distance to the
//! point, which would favour far-away points), with a Gaussian kernel of 2.5°, 1° then 0.4°.
//! In a world of right angles the vertical and a horizontal vanishing point look alike to these
//! tests (the "Manhattan" ambiguity: a camera looking up 25° at buildings reads as well as one
//! looking down 65°). The tie is broken by four priors multiplying the support (weights
//! [`TEXTURE_PRIOR`], [`BRIGHTNESS_PRIOR`], [`TILT_PRIOR`], [`ROLL_PRIOR`]): the ground is
//! where the texture is (`1 − w/2 + w g`, `g` the fraction of the edges' length below the
//! candidate horizon);
//! the sky is brighter than what stands under it (`1 + w ρ`, `ρ` the correlation of 32 columns
//! of block means of the luma with the blocks' elevation `r · n` above the candidate horizon,
//! which is defined even when the horizon is out of the picture); and a camera is more often
//! near level than steep (`1 − w (tilt/90°)²`; the two readings of a Manhattan picture have
//! tilts `t` and about `±(90° − |t|)`, so this favours the truth whenever |t| < 45°) and more
//! often level than rolled (`1 − w (roll/90°)²`). The priors only choose between readings
//! (the coarse cells and the refined starts); each start is refined on the edges alone, so
//! they do not pull a fit towards level.
//!
//! Segments come from a small line-segment detector on a downscaled luma (the frame's Y plane,
//! box-averaged to about 320 pixels wide): Sobel gradients; region growing from the strongest
//! edgels over neighbours whose edge direction agrees within 22.5° (as in LSD, von Gioi et al.
//! 2010); a region is kept as a segment when its principal axis is at least 12 pixels long and
//! it is thin (width under a fifth of the length). At most the 400 longest segments are used.
//!
//! The chosen reading is then refined by least squares on its own inliers
//! ([`vanishing::refine`]: the vertical vanishing point and up to four fitted horizontal ones),
//! which the kernel counts above only bracket to a few tenths of a degree.
//!
//! # Confidence
//!
//! `confidence` is a probability: that the horizon is within 2 % of the picture's height and
//! the roll within 1°. It is a logistic model ([`calibrated_confidence`]) of the estimate's
//! evidence — the ambiguity, the number of fitted inliers, the vertical inliers, the sky's
//! correlation with elevation, how far off the picture the horizon lies, the share of rising
//! vertical length whose foot floats, the kernel support — fitted on synthetic streets at random
//! poses and checked for calibration on others (`tests/ground_pose.rs`). A reading that leaves
//! strong vertical structure floating above its horizon with nothing standing through it
//! ([`floats`]: a guardrail or a fence rail taken for the horizon) has confidence 0, and so has
//! one whose verticals and receding level lines disagree on the horizon under the assumed
//! field of view ([`lens_mismatch`]: the lens is not the picture's), and so has one the sky
//! says is a steep view ([`STEEP_ALTERNATIVE_DEG`]: where level lines meet near the optical
//! axis, the same lines read, under the same lens, as a view straight down or up with that
//! point as the nadir or the sky): a level reading looking up with no sky above its horizon
//! ([`SKY_ABOVE_MIN`]) or none brighter than the ground under it ([`steep::SKY_OVER_GROUND`]),
//! or looking down with the sky around the point its level lines meet
//! ([`SKY_AHEAD_MAX`]) or below a horizon above the picture; so has a horizon in view that no
//! vertical crosses and no edge marks ([`steep::unmarked_horizon`]). Below
//! [`MIN_CONFIDENCE`] the ground falls back to `none` with a warning.
//!
//! # Over time
//!
//! [`GroundTracker`] combines the per-frame estimates of a window of past frames after the
//! last scene cut in the window (a cut: the mean absolute change of a 16×9 thumbnail of the
//! luma above 0.12) with [`aggregate`]: the mode of their up directions, with the mean
//! confidence of the readings that agree with it — a pure function of the window's frames, so a
//! preview of frame *t* that feeds the same window gets the same answer as the render.

use glam::DVec3;

use crate::scene::Camera;
use crate::scene::brightness::Brightness;
use crate::scene::ground::{horizon_row_of_up, tilt_roll_from_up};
pub use crate::scene::lens::{
    LENS_SHIFT_MIN, LEVEL_OFFSET_MAX, lens_hint, lens_mismatch, read_lens,
};
pub use crate::scene::segments::{Segment, detect_segments};
use crate::scene::steep;
pub use crate::scene::steep::{
    ALTERNATIVE_MATCH_DEG, SKY_ABOVE_MIN, SKY_AHEAD_MAX, STEEP_ALTERNATIVE_DEG, sky_refusal,
};
pub use crate::scene::tracker::{CUT_THRESHOLD, GroundTracker};
use crate::scene::vanishing::{self, Edge};
use crate::video::YuvFrame;
use crate::video::frame::coded_pixel;

/// Below this confidence `auto` falls back to no ground: on the synthetic streets about one
/// estimate in twenty above it is off by more than 2 % of the height or 1° of roll.
pub const MIN_CONFIDENCE: f64 = 0.9;

/// Width of the luma the segments are detected on, pixels (about; an integer factor of the
/// frame's width).
pub const WORK_WIDTH: usize = 320;

/// A greyscale picture in [0, 1], row-major, `scale` frame pixels per sample.
#[derive(Debug, Clone)]
pub struct Luma {
    /// Width, samples.
    pub width: usize,
    /// Height, samples.
    pub height: usize,
    /// Values in [0, 1].
    pub data: Vec<f32>,
    /// Displayed-frame pixels per sample (the box size).
    pub scale: usize,
}

impl Luma {
    /// The Y plane of `frame` as displayed (after `rotation_deg`), box-averaged down to about
    /// `target_width` samples wide.
    pub fn from_frame(frame: &YuvFrame, rotation_deg: i32, target_width: usize) -> Luma {
        let (cw, ch) = (frame.format.width, frame.format.height);
        let (dw, dh) = if rotation_deg.rem_euclid(180) == 90 {
            (ch, cw)
        } else {
            (cw, ch)
        };
        let scale = (dw as usize).div_ceil(target_width.max(1)).max(1);
        let (w, h) = ((dw as usize / scale).max(1), (dh as usize / scale).max(1));
        let max = ((1u32 << frame.format.bit_depth) - 1) as f32;
        let norm = 1.0 / (max * (scale * scale) as f32);
        let mut data = vec![0.0f32; w * h];
        for (j, row) in data.chunks_mut(w).enumerate() {
            for (i, out) in row.iter_mut().enumerate() {
                let mut sum = 0u32;
                for y in j * scale..((j + 1) * scale).min(dh as usize) {
                    for x in i * scale..((i + 1) * scale).min(dw as usize) {
                        let (cx, cy) = coded_pixel(rotation_deg, cw, ch, x as u32, y as u32);
                        sum += frame.sample(0, cx, cy) as u32;
                    }
                }
                *out = sum as f32 * norm;
            }
        }
        Luma {
            width: w,
            height: h,
            data,
            scale,
        }
    }

    /// A 16×9 thumbnail (means over blocks), for scene-cut detection.
    pub fn thumbnail(&self) -> [f32; 144] {
        let mut sum = [0.0f32; 144];
        let mut count = [0u32; 144];
        for y in 0..self.height {
            let by = (y * 9 / self.height).min(8);
            for x in 0..self.width {
                let b = by * 16 + (x * 16 / self.width).min(15);
                sum[b] += self.data[y * self.width + x];
                count[b] += 1;
            }
        }
        std::array::from_fn(|i| sum[i] / count[i].max(1) as f32)
    }
}

/// One frame's estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HorizonEstimate {
    /// The ground's upward normal in camera space.
    pub up_cam: DVec3,
    /// Pitch up, degrees (as `--tilt`).
    pub tilt_deg: f64,
    /// Roll clockwise, degrees (as `--roll`).
    pub roll_deg: f64,
    /// Where the horizon crosses the vertical centre line, fraction of the height from the
    /// top; `None` when it does not.
    pub horizon_row: Option<f64>,
    /// The probability that the horizon is within 2 % of the height and the roll within 1°
    /// (see [`calibrated_confidence`]).
    pub confidence: f64,
    /// Evidence: the kernel support, `(1 − exp(−S/0.5)) · (1 − exp(−max(0, k − 2)/3))`.
    pub support: f64,
    /// The score of the best other reading (at least [`DISTINCT_READING_DEG`] away) over the
    /// chosen one's, priors included: near 1, the picture reads two ways and the choice may be
    /// a guess (an input of the confidence model).
    pub ambiguity: f64,
    /// Evidence: segments found.
    pub segments: usize,
    /// Evidence: segments through the vertical vanishing point.
    pub vertical_inliers: usize,
    /// Evidence: segments in the two strongest horizontal vanishing points.
    pub horizontal_inliers: usize,
    /// Evidence: segments along the horizon itself.
    pub horizon_inliers: usize,
    /// Evidence: families of horizontal edges in the least-squares fit.
    pub families: usize,
    /// Evidence: inliers of the least-squares fit (a horizon edge counts 4).
    pub fitted_inliers: usize,
    /// Evidence: length (frame diagonals) of vertical edges rising above the horizon from a
    /// foot below it (see [`vanishing::standing_check`]).
    pub standing_len: f64,
    /// Evidence: length of vertical edges rising above the horizon from a foot above it.
    pub floating_len: f64,
    /// Evidence: correlation of brightness with elevation above the horizon (the sky).
    pub sky_correlation: f64,
    /// Evidence: the share of sky blocks (smooth and bright, see [`Brightness::sky_above`]) in
    /// the quarter of the picture highest above the horizon; 1 where not measured. See
    /// [`SKY_ABOVE_MIN`].
    pub sky_above: f64,
    /// Evidence: the same share counting only blocks brighter than most of the picture below
    /// the horizon ([`Brightness::sky_over_ground`]); see [`steep::SKY_OVER_GROUND`].
    pub sky_over_ground: f64,
    /// Evidence: the share of sky blocks in the quarter of the picture around the point ahead
    /// where the level lines converge nearest the optical axis; 0 where not measured. See
    /// [`SKY_AHEAD_MAX`].
    pub sky_ahead: f64,
    /// Distinct lines through the vertical vanishing point of a steep reading (see
    /// [`steep`]); 0 for a reading of the level search.
    pub steep_lines: usize,
    /// Evidence: how near the optical axis the fitted horizontal families converge: the
    /// largest `|cos|` of the angle between a family's vanishing point and the axis (0 without
    /// families). See [`RECEDING_MIN_COS`].
    pub receding: f64,
    /// Evidence: how far the horizontal families converge off the horizon the verticals alone
    /// predict, picture heights, positive above (see [`vanishing::level_offset`]; 0 where it
    /// is not measured). See [`lens_mismatch`].
    pub level_offset: f64,
    /// How far the horizon lies from the principal point along the picture's up, picture
    /// heights (`f tan(tilt) / height`; see [`lens_mismatch`]).
    pub horizon_shift: f64,
    /// Evidence: `(f/f_a)²`, the focal length under which the horizontal families lie on the
    /// verticals' horizon over the one assumed (see [`vanishing::LevelCheck`]), where
    /// measured.
    pub focal_scale_sq: Option<f64>,
    /// Where the given field of view is refused for its lens ([`lens_mismatch`]): the
    /// horizontal field of view the frames show, degrees, if one reads them consistently (see
    /// [`read_lens`]). The estimate itself stays refused.
    pub lens_fov_deg: Option<f64>,
}

struct Score {
    total: f64,
    vertical: usize,
    horizontal: usize,
    horizon: usize,
}

fn score(edges: &[Edge], n: DVec3, sigma: f64, hist: &mut Vec<(f64, f64, u32)>) -> Score {
    let bins = (std::f64::consts::PI / sigma).ceil() as usize;
    hist.clear();
    hist.resize(bins, (0.0, 0.0, 0));
    let e1 = (DVec3::X - n * n.x).normalize_or(DVec3::Z);
    let e2 = n.cross(e1);
    let cut = 3.0 * sigma;
    let inv2s2 = 0.5 / (sigma * sigma);
    let (mut v_sum, mut v_max, mut l_sum, mut below, mut all) = (0.0, 0.0f64, 0.0, 0.0, 0.0);
    let (mut nv, mut nl) = (0, 0);
    for e in edges {
        all += e.w;
        if e.m.dot(n) < 0.0 {
            below += e.w;
        }
        let ln = e.l.dot(n);
        let mxn = e.m.cross(n).length().max(1e-9);
        let alpha = (ln.abs() / mxn).min(1.0).asin();
        if alpha < cut {
            let v = e.w * (-alpha * alpha * inv2s2).exp();
            v_sum += v;
            v_max = v_max.max(v);
            if alpha < 2.0 * sigma {
                nv += 1;
            }
            continue;
        }
        let lxn = e.l.cross(n);
        let s = lxn.length();
        let beta = s.min(1.0).asin();
        if beta < cut {
            l_sum += e.w * (-beta * beta * inv2s2).exp();
            nl += 1;
            continue;
        }
        let d = lxn / s;
        let phi = d.dot(e2).atan2(d.dot(e1)).rem_euclid(std::f64::consts::PI);
        let b = ((phi / sigma) as usize).min(bins - 1);
        let cell = &mut hist[b];
        cell.0 += e.w;
        cell.1 = cell.1.max(e.w);
        cell.2 += 1;
    }
    // The two strongest families: a window of three bins, less its longest segment (one
    // segment alone is no vanishing point).
    let mut h_sum = 0.0;
    let mut nh = 0;
    let mut taken: Vec<usize> = Vec::new();
    for _ in 0..2 {
        let mut best = (0.0, 0usize, 0u32);
        for b in 0..bins {
            if taken.iter().any(|&t| {
                let d = b.abs_diff(t);
                d.min(bins - d) <= 3
            }) {
                continue;
            }
            let (mut s, mut m, mut c) = (0.0, 0.0f64, 0);
            for k in [bins - 1, 0, 1] {
                let cell = hist[(b + k) % bins];
                s += cell.0;
                m = m.max(cell.1);
                c += cell.2;
            }
            if c >= 2 && s - m > best.0 {
                best = (s - m, b, c);
            }
        }
        if best.0 > 0.0 {
            h_sum += best.0;
            nh += best.2 as usize;
            taken.push(best.1);
        }
    }
    let g = if all > 0.0 { below / all } else { 0.5 };
    Score {
        total: (v_sum - v_max + h_sum + 1.5 * l_sum)
            * (1.0 - 0.5 * TEXTURE_PRIOR + TEXTURE_PRIOR * g),
        vertical: nv,
        horizontal: nh,
        horizon: nl,
    }
}

/// Estimates the horizon of one picture seen through `camera`'s intrinsics (its own tilt and
/// roll are ignored) from its segments alone (no brightness prior: see [`estimate`]).
pub fn estimate_from_segments(segments: &[Segment], camera: &Camera) -> HorizonEstimate {
    read_lens(camera, |cam| estimate_with(segments, None, cam, &|| None))
}

/// The picture's segments as great-circle edges through `camera`'s intrinsics, weighted by
/// length over the diagonal; an end within 1 % of the width of the border is marked cut (it
/// may be where the picture cuts the line, not where the line ends).
pub fn edges(segments: &[Segment], camera: &Camera) -> Vec<Edge> {
    let f = camera.focal_px();
    let c = camera.principal_px();
    let (wpx, hpx) = (camera.width_px as f64, camera.height_px as f64);
    let diag = wpx.hypot(hpx);
    let ray = |p: [f64; 2]| DVec3::new((p[0] - c.x) / f, (p[1] - c.y) / f, 1.0);
    let border = 0.01 * wpx;
    let cut =
        |p: [f64; 2]| p[0] < border || p[1] < border || p[0] > wpx - border || p[1] > hpx - border;
    segments
        .iter()
        .filter_map(|s| {
            let (a, b) = (ray(s.a), ray(s.b));
            Some(Edge {
                l: a.cross(b).try_normalize()?,
                m: (a + b).normalize(),
                ends: [a.normalize(), b.normalize()],
                cut: [cut(s.a), cut(s.b)],
                w: s.length() / diag,
            })
        })
        .collect()
}

fn estimate_with<'a>(
    segments: &[Segment],
    brightness: Option<&Brightness>,
    camera: &Camera,
    fine: &dyn Fn() -> Option<&'a [Segment]>,
) -> HorizonEstimate {
    let f = camera.focal_px();
    let edges = edges(segments, camera);
    let mut hist = Vec::new();
    let eval = |t: f64, r: f64, sigma: f64, hist: &mut Vec<_>| {
        score(
            &edges,
            crate::scene::ground::up_from_tilt_roll(t.to_radians(), r.to_radians()),
            sigma.to_radians(),
            hist,
        )
    };
    // The priors choose between readings (the coarse cells, the refined starts); they do not
    // bias the fit within one (a start is refined on the edges alone).
    let prior = |t: f64, r: f64| {
        let n = crate::scene::ground::up_from_tilt_roll(t.to_radians(), r.to_radians());
        let c = brightness.map_or(0.0, |b| b.correlation(n));
        (1.0 + BRIGHTNESS_PRIOR * c)
            * (1.0 - TILT_PRIOR * (t / 90.0).powi(2))
            * (1.0 - ROLL_PRIOR * (r / 90.0).powi(2))
    };
    // Coarse: the whole range.
    let mut coarse: Vec<(f64, f64, f64)> = Vec::new();
    let mut t = -MAX_TILT_DEG;
    while t <= MAX_TILT_DEG {
        let mut r = -MAX_ROLL_DEG;
        while r <= MAX_ROLL_DEG {
            coarse.push((
                eval(t, r, COARSE_SIGMA_DEG, &mut hist).total * prior(t, r),
                t,
                r,
            ));
            r += COARSE_STEP_DEG;
        }
        t += COARSE_STEP_DEG;
    }
    coarse.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut starts: Vec<(f64, f64)> = Vec::new();
    for &(_, t, r) in &coarse {
        if starts
            .iter()
            .all(|&(t0, r0)| (t - t0).abs() > 6.0 || (r - r0).abs() > 6.0)
        {
            starts.push((t, r));
        }
        if starts.len() == STARTS {
            break;
        }
    }
    // Hypotheses from the edges themselves: the vertical vanishing point where two of the
    // longest edges meet. A wide kernel lets a wrong reading gather the ridges of several
    // families of long lines and outscore the true one in the coarse grid; a pair of
    // verticals puts the true one among the starts.
    let mut order: Vec<usize> = (0..edges.len()).collect();
    order.sort_by(|&a, &b| edges[b].w.total_cmp(&edges[a].w));
    order.truncate(PAIRED_EDGES);
    let mut paired: Vec<(f64, f64, f64)> = Vec::new();
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            let Some(mut n) = edges[i].l.cross(edges[j].l).try_normalize() else {
                continue;
            };
            if n.y > 0.0 {
                n = -n;
            }
            let (t, r) = tilt_roll_from_up(n);
            let (t, r) = (t.to_degrees(), r.to_degrees());
            if t.abs() > MAX_TILT_DEG || r.abs() > MAX_ROLL_DEG {
                continue;
            }
            paired.push((eval(t, r, 1.0, &mut hist).total * prior(t, r), t, r));
        }
    }
    paired.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut extra = 0;
    for &(_, t, r) in &paired {
        if extra == PAIRED_STARTS {
            break;
        }
        if starts
            .iter()
            .all(|&(t0, r0)| (t - t0).abs() > 1.0 || (r - r0).abs() > 1.0)
        {
            starts.push((t, r));
            extra += 1;
        }
    }
    let refine = |(t0, r0): (f64, f64), half: f64, step: f64, sigma: f64, hist: &mut Vec<_>| {
        let mut best = (f64::MIN, t0, r0);
        let k = (half / step).round() as i32;
        for i in -k..=k {
            for j in -k..=k {
                let (t, r) = (t0 + i as f64 * step, r0 + j as f64 * step);
                if t.abs() > MAX_TILT_DEG || r.abs() > MAX_ROLL_DEG {
                    continue;
                }
                let s = eval(t, r, sigma, hist).total;
                if s > best.0 {
                    best = (s, t, r);
                }
            }
        }
        best
    };
    let readings: Vec<(f64, f64, f64)> = starts
        .into_iter()
        .map(|s| {
            let b = refine(s, 3.0, 0.5, 1.0, &mut hist);
            (b.0 * prior(b.1, b.2), b.1, b.2)
        })
        .collect();
    let best = readings
        .iter()
        .copied()
        .fold((f64::MIN, 0.0, 0.0), |a, b| if b.0 > a.0 { b } else { a });
    let ambiguity = ambiguity(&readings, best);
    let (_, t, r) = refine((best.1, best.2), 0.6, 0.1, 0.4, &mut hist);
    let fin = eval(t, r, 0.4, &mut hist);
    // The fit's inliers depend on where it starts: refit from its own result until it stays
    // put (a start half a degree off can keep a neighbouring line of a family out).
    let (mut up_cam, mut inliers) = vanishing::refine(
        &edges,
        crate::scene::ground::up_from_tilt_roll(t.to_radians(), r.to_radians()),
    );
    for _ in 0..3 {
        let (n, inl) = vanishing::refine(&edges, up_cam);
        let moved = n.angle_between(up_cam);
        (up_cam, inliers) = (n, inl);
        if moved < 0.01f64.to_radians() {
            break;
        }
    }
    let (t, r) = tilt_roll_from_up(up_cam);
    let (t, r) = (t.to_degrees(), r.to_degrees());
    let (standing, floating) = vanishing::standing_check(&edges, &inliers.vertical, up_cam);
    // The point ahead: the fitted family of level lines converging nearest the optical axis.
    let ahead = inliers
        .families
        .iter()
        .map(|fam| vanishing::family_point(&edges, fam, up_cam))
        .map(|p| if p.z < 0.0 { -p } else { p })
        .max_by(|a, b| a.z.total_cmp(&b.z));
    let k = fin.vertical + fin.horizontal + 4 * fin.horizon;
    let support =
        (1.0 - (-fin.total / 0.5).exp()) * (1.0 - (-((k as f64 - 2.0).max(0.0)) / 3.0).exp());
    let mut est = HorizonEstimate {
        up_cam,
        tilt_deg: t,
        roll_deg: r,
        horizon_row: horizon_row_of_up(up_cam, camera),
        confidence: 0.0,
        support: support.clamp(0.0, 1.0),
        ambiguity,
        segments: edges.len(),
        vertical_inliers: fin.vertical,
        horizontal_inliers: fin.horizontal,
        horizon_inliers: fin.horizon,
        families: inliers.families.len(),
        fitted_inliers: inliers.count(),
        standing_len: standing,
        floating_len: floating,
        sky_correlation: brightness.map_or(0.0, |b| b.correlation(up_cam)),
        sky_above: brightness.map_or(1.0, |b| b.sky_above(up_cam)),
        sky_over_ground: brightness.map_or(1.0, |b| b.sky_over_ground(up_cam)),
        sky_ahead: 0.0,
        steep_lines: 0,
        receding: ahead.map_or(0.0, |p| p.z.abs()),
        level_offset: 0.0,
        horizon_shift: f * t.to_radians().tan() / camera.height_px as f64,
        focal_scale_sq: None,
        lens_fov_deg: None,
    };
    // The lens check matters only where a wrong focal length moves the horizon (see
    // [`LENS_SHIFT_MIN`]); it regroups the level lines afresh, the costliest step after the
    // search, so it is skipped elsewhere.
    if est.horizon_shift.abs() >= LENS_SHIFT_MIN
        && let Some(c) = vanishing::level_offset(&edges, &inliers, up_cam)
    {
        est.level_offset = c.offset_rad * f / camera.height_px as f64;
        est.focal_scale_sq = c.focal_scale_sq;
    }
    if let (Some(b), Some(p)) = (brightness, ahead) {
        est.sky_ahead = b.sky_share(p);
    }
    let sky = |n: DVec3| brightness.map_or(0.0, |b| b.correlation(n));
    est.confidence = calibrated_confidence(&est);
    let sky_refused = sky_refusal(&est).is_some();
    // A steep reading (see [`steep`]) replaces an unsure level one where the level reading
    // sees no sky (a picture of a level street has a point where many lines converge too), or
    // where its own sky is clearly brighter: looking up between facades, the sky is around
    // the zenith, and the level reading (the Manhattan alternative) is then a guess; or,
    // looking down, where no direction shows sky (see the steep module's "Views down").
    // A level reading refused for its lens keeps its refusal (the user's remedy is a field of
    // view, and a steep reading of a level street is a guess).
    let steep = if lens_mismatch(&est) {
        None
    } else {
        steep::read(&edges, sky)
    };
    // An unsure level reading with no steep reading of enough lines: the finer pass (see
    // [`steep::FINE_WIDTH`]) reads the short verticals of a view straight down; its reading
    // replaces the level one only where no direction shows sky (`no_sky` below).
    let fine_steep = if est.confidence < MIN_CONFIDENCE
        && steep
            .as_ref()
            .is_none_or(|s| s.distinct_lines < steep::SKY_MIN_LINES)
    {
        fine().and_then(|fine| steep::read(&crate::scene::horizon::edges(fine, camera), sky))
    } else {
        None
    };
    let (level, mut posed) = (est, est);
    let readings = steep.map(|s| (s, false)).into_iter();
    for (s, fine_pass) in readings.chain(fine_steep.map(|s| (s, true))) {
        let est = level;
        let steep_sky = sky(s.up_cam);
        let sky_says_steep = !fine_pass
            && s.distinct_lines >= steep::SKY_MIN_LINES
            && steep_sky > est.sky_correlation + steep::SKY_MARGIN;
        // The level reading's point ahead at the steep point: the same lines read two ways.
        let matches =
            ahead.is_some_and(|p| s.up_cam.dot(p).abs() > ALTERNATIVE_MATCH_DEG.to_radians().cos());
        // An unsure level reading that is not the steep reading's alternative, and a view down
        // with no sky in any direction (see [`steep::alternative_sky`]).
        let no_sky = est.confidence < MIN_CONFIDENCE
            && !matches
            && s.distinct_lines >= steep::NO_SKY_MIN_LINES
            && s.up_cam.z < 0.0
            && brightness.is_some_and(|b| {
                steep::alternative_sky(-s.up_cam, |n| b.sky_share(n), |u| b.sky_above(u))
                    < SKY_ABOVE_MIN
            });
        let unsure = !fine_pass
            && est.confidence < MIN_CONFIDENCE
            && (sky_refused || est.sky_correlation < steep::LEVEL_SKY);
        // A level reading refused for its steep alternative is replaced by that alternative
        // only: the steep point is its point ahead, the nadir where it looked up (no sky above),
        // the zenith where it looked down (the sky around the point).
        let alternative = !sky_refused
            || ahead.is_some_and(|p| {
                let c = s.up_cam.dot(p);
                c.abs() > ALTERNATIVE_MATCH_DEG.to_radians().cos()
                    && (c < 0.0) == (est.tilt_deg > 0.0)
            });
        let confidence = steep::confidence(&s, sky_says_steep || no_sky);
        let up_without_sky =
            brightness.is_some_and(|b| steep::up_without_sky(&s, |n| b.sky_share(n)));
        if !up_without_sky
            && (sky_says_steep || no_sky || (unsure && alternative && confidence > est.confidence))
        {
            posed = s.estimate(&est, confidence, steep_sky, camera);
        }
    }
    posed
}

/// Number of inputs of the confidence model.
pub const CONFIDENCE_INPUTS: usize = 8;

/// The inputs of the confidence model of an estimate: 1, the ambiguity, ln(1 + fitted
/// inliers), the vertical inliers (saturating at 10), the sky's correlation, how far the
/// horizon is from the picture's middle (heights, at most 2), the share of rising vertical
/// length that floats, and the kernel support.
pub fn confidence_inputs(e: &HorizonEstimate) -> [f64; CONFIDENCE_INPUTS] {
    let off = e.horizon_row.map_or(2.0, |r| (r - 0.5).abs().min(2.0));
    [
        1.0,
        e.ambiguity,
        (e.fitted_inliers as f64 + 1.0).ln(),
        e.vertical_inliers.min(10) as f64 / 10.0,
        e.sky_correlation,
        off,
        e.floating_len / (e.standing_len + e.floating_len + 0.05),
        e.support,
    ]
}

/// Weights of the confidence model, `confidence = 1 / (1 + exp(−w · x))` with `x` the
/// [`confidence_inputs`]: a logistic regression of "horizon within 2 % of the height and roll
/// within 1°" on synthetic streets at random poses (`tests/ground_pose.rs` refits them), so
/// that the confidence is the probability of being right on such shots.
pub const CONFIDENCE_WEIGHTS: [f64; CONFIDENCE_INPUTS] =
    [2.382, -0.041, 1.234, -1.594, -3.897, -3.609, 0.990, 1.881];

/// A vertical structure of at least this length (frame diagonals) rising above the horizon
/// with its foot above it, and under [`STANDING_SHARE`] of that length standing on the ground,
/// vetoes a reading: the horizon is too low (a rail taken for it).
pub const FLOATING_MIN_LEN: f64 = 0.08;

/// See [`FLOATING_MIN_LEN`].
pub const STANDING_SHARE: f64 = 0.15;

/// Whether the estimate leaves strong vertical structure floating above its horizon with
/// nothing standing through it (see [`vanishing::standing_check`]).
pub fn floats(e: &HorizonEstimate) -> bool {
    e.floating_len >= FLOATING_MIN_LEN && e.standing_len < STANDING_SHARE * e.floating_len
}

/// A level reading whose families of horizontal edges all converge farther than this from
/// the optical axis (`cos` of the angle; about 80°), with no edge along its horizon, sees no
/// ground receding and has confidence 0: a paving seen straight down reads, edge for edge, as
/// a tiled wall seen level (one family of its joints taken for verticals, the other for
/// frontal horizontals), and nothing in the edges tells the two apart.
pub const RECEDING_MIN_COS: f64 = 0.17;

/// Why a reading has confidence 0 regardless of its evidence, if it does.
pub fn refusal(e: &HorizonEstimate) -> Option<&'static str> {
    if e.segments == 0 {
        Some("no straight edges")
    } else if floats(e) {
        Some("vertical structure floats above the horizon (a rail taken for it)")
    } else if e.receding < RECEDING_MIN_COS && e.horizon_inliers == 0 {
        Some("no ground receding (no horizontal lines converge ahead)")
    } else if lens_mismatch(e) {
        Some(
            "the verticals and the receding level lines disagree on the horizon: the field of \
             view is not the lens's (try another --fov)",
        )
    } else {
        sky_refusal(e).or_else(|| steep::unmarked_horizon(e))
    }
}

/// The calibrated confidence of an estimate (see [`CONFIDENCE_WEIGHTS`]); 0 where there is a
/// [`refusal`]: without segments, where the reading [`floats`], where it sees no receding
/// ground ([`RECEDING_MIN_COS`]), where the assumed lens is not the picture's
/// ([`lens_mismatch`]), or where the sky says the picture is its steep alternative
/// ([`STEEP_ALTERNATIVE_DEG`]).
pub fn calibrated_confidence(e: &HorizonEstimate) -> f64 {
    if refusal(e).is_some() {
        return 0.0;
    }
    let x = confidence_inputs(e);
    let z: f64 = x.iter().zip(CONFIDENCE_WEIGHTS).map(|(x, w)| x * w).sum();
    1.0 / (1.0 + (-z).exp())
}

/// Readings within this angle of each other agree, degrees.
pub const AGREE_DEG: f64 = 2.0;

/// Combines per-frame readings of one shot through `camera`: the mode (the reading with the
/// most confidence within [`AGREE_DEG`] of it), refined as the confidence-weighted mean up
/// direction of the readings that agree with it. The confidence is the mean over all readings
/// of the confidence of those that agree (a steady estimate keeps its own; a misread frame
/// takes its share away). `None` without readings.
pub fn aggregate(readings: &[HorizonEstimate], camera: &Camera) -> Option<HorizonEstimate> {
    let first = readings.first()?;
    let cos_agree = AGREE_DEG.to_radians().cos();
    let agree_weight = |n: DVec3| {
        readings
            .iter()
            .filter(|e| e.up_cam.dot(n) >= cos_agree)
            .map(|e| e.confidence)
            .sum::<f64>()
    };
    let mode = readings
        .iter()
        .map(|e| (agree_weight(e.up_cam), e))
        .fold((f64::MIN, first), |a, b| if b.0 > a.0 { b } else { a })
        .1;
    if agree_weight(mode.up_cam) <= 0.0 {
        return Some(HorizonEstimate {
            confidence: 0.0,
            ..*first
        });
    }
    let sum: DVec3 = readings
        .iter()
        .filter(|e| e.up_cam.dot(mode.up_cam) >= cos_agree)
        .map(|e| e.up_cam * e.confidence)
        .sum();
    let up_cam = sum.normalize_or(mode.up_cam);
    let (t, r) = tilt_roll_from_up(up_cam);
    Some(HorizonEstimate {
        up_cam,
        tilt_deg: t.to_degrees(),
        roll_deg: r.to_degrees(),
        horizon_row: horizon_row_of_up(up_cam, camera),
        confidence: agree_weight(up_cam) / readings.len() as f64,
        ..*mode
    })
}

/// Readings whose up directions differ by more than this are distinct, degrees (the Manhattan
/// alternative of a reading lies tens of degrees away; refinement noise within a few).
pub const DISTINCT_READING_DEG: f64 = 10.0;

/// The best distinct reading's score over `best`'s, 0 when there is none.
fn ambiguity(readings: &[(f64, f64, f64)], best: (f64, f64, f64)) -> f64 {
    let up =
        |t: f64, r: f64| crate::scene::ground::up_from_tilt_roll(t.to_radians(), r.to_radians());
    let n = up(best.1, best.2);
    let cos_min = DISTINCT_READING_DEG.to_radians().cos();
    readings
        .iter()
        .filter(|(_, t, r)| up(*t, *r).dot(n) < cos_min)
        .map(|(s, _, _)| s / best.0)
        .fold(0.0, f64::max)
        .clamp(0.0, 1.0)
}

/// Weight of the texture prior: the support is scaled by `1 − w/2 + w g`, `g` the fraction of
/// the edges' length below the candidate horizon (the ground is where the texture is). Kept
/// weak: looking up, all the edges are above the true horizon.
pub const TEXTURE_PRIOR: f64 = 0.15;

/// Weight of the brightness prior: the support is scaled by `1 + w ρ`, `ρ` the correlation of
/// the picture's block brightness with elevation above the candidate horizon (daylight skies
/// are brighter than what stands under them).
pub const BRIGHTNESS_PRIOR: f64 = 0.5;

/// Weight of the tilt prior: the support is scaled by `1 − w (tilt/90°)²` (most footage is
/// shot within 45° of level, and of the two Manhattan readings of a picture, the vertical and a
/// horizontal vanishing point swapped, the one nearer level is the likelier).
pub const TILT_PRIOR: f64 = 0.3;

/// Weight of the roll prior: the support is scaled by `1 − w (roll/90°)²` (footage is mostly
/// shot near level; it keeps a steep reading at a large roll from beating a moderate one).
pub const ROLL_PRIOR: f64 = 0.6;

/// Largest |tilt| `auto` considers, degrees: beyond it the optical axis is within 25° of the
/// vertical and, in a picture of right angles, the vertical vanishing point cannot be told
/// from the point straight ahead (any two families of image-parallel lines fit it).
pub const MAX_TILT_DEG: f64 = 65.0;

/// Largest |roll| `auto` considers, degrees (beyond, up and sideways trade places).
pub const MAX_ROLL_DEG: f64 = 60.0;

/// Most segments used per frame.
pub const MAX_SEGMENTS: usize = 400;

/// Estimates the horizon of one luma picture through `camera`'s intrinsics.
pub fn estimate(luma: &Luma, camera: &Camera) -> HorizonEstimate {
    estimate_finer(luma, || None, camera)
}

/// [`estimate`], with `fine()` the same picture at [`steep::FINE_WIDTH`] for the steep
/// reading's second pass, made only where that pass is needed.
pub fn estimate_finer(
    luma: &Luma,
    fine: impl Fn() -> Option<Luma>,
    camera: &Camera,
) -> HorizonEstimate {
    let segments = detect_segments(luma, MAX_SEGMENTS);
    let fine_segments = std::cell::OnceCell::new();
    let fine = || {
        fine_segments
            .get_or_init(|| fine().map(|l| detect_segments(&l, MAX_SEGMENTS)))
            .as_deref()
    };
    read_lens(camera, |cam| {
        estimate_with(&segments, Brightness::new(luma, cam).as_ref(), cam, &fine)
    })
}

/// The camera's tilt and roll from one decoded frame (displayed after `rotation_deg`) seen
/// through `camera`'s intrinsics (its own tilt and roll are ignored): [`estimate`] on the
/// frame's luma at [`WORK_WIDTH`].
pub fn estimate_frame(frame: &YuvFrame, rotation_deg: i32, camera: &Camera) -> HorizonEstimate {
    estimate_finer(
        &Luma::from_frame(frame, rotation_deg, WORK_WIDTH),
        || Some(Luma::from_frame(frame, rotation_deg, steep::FINE_WIDTH)),
        camera,
    )
}

/// Step of the coarse search over tilt and roll, degrees.
pub const COARSE_STEP_DEG: f64 = 2.0;

/// Kernel width of the coarse search, degrees: wide enough that a cell's support reaches the
/// reading within it (at most a degree away), narrow enough that a wrong reading does not
/// gather the ridges of several families of long, well-fitted lines (at 2.5° it did).
pub const COARSE_SIGMA_DEG: f64 = 1.5;

/// Distinct coarse cells refined into readings.
pub const STARTS: usize = 5;

/// The longest edges paired for hypotheses of the vertical vanishing point.
pub const PAIRED_EDGES: usize = 40;

/// Hypotheses from pairs of edges refined into readings (besides the coarse cells).
pub const PAIRED_STARTS: usize = 2;
