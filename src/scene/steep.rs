//! The camera's pose in steep views down or up, from the vertical vanishing point near the
//! middle of the picture.
//!
//! Looking straight down (or up), the world's verticals — building corners, posts — converge
//! on the nadir (or zenith) inside or near the picture, and its position gives the up direction
//! in camera space directly: the unit ray through it, without any horizon. The search of
//! [`crate::scene::horizon`] stops at ±65° of tilt, where its tilt-and-roll grid and its priors
//! no longer tell the vertical vanishing point from the point straight ahead; this module reads
//! the steeper views.
//!
//! Candidates are the meeting points of pairs of the longest segments that lie within
//! [`STEEP_AXIS_DEG`] of the optical axis (tilt beyond 90° − that); each is scored by the
//! length of the segments whose lines pass within [`INLIER_DEG`] of it and which do not cross
//! it (a vertical edge below the camera is seen as a ray from the nadir, never through it).
//! The best is refined by least squares: the unit `d` minimising `Σ w (l·d)² / |m×d|²` over the
//! inliers (`l` an interpretation-plane normal, `m` the ray through the midpoint: the squared
//! sine of each segment's angle to the great circle through its midpoint and `d`), the
//! smallest eigenvector of a 3×3 matrix, reweighted and reclassified three times.
//!
//! **Evidence.** Paving seen from above has two families of parallel joints, and any two
//! joints meet somewhere; only structure standing up converges from many directions. The
//! reading's evidence is the number of *distinct lines* through the point (inliers whose
//! directions around it differ by more than [`DISTINCT_DEG`]) and their *spread* (the circle
//! around the point less its largest empty gap). A picture of a level street also has a point
//! where many lines converge (the street's own vanishing point straight ahead), with the same
//! evidence. A steep reading replaces the level search's where its own sky correlates with
//! elevation clearly better ([`SKY_MARGIN`]: looking up between facades, the sky is around the
//! zenith), and then its evidence sets its confidence; or where the level reading is unsure and
//! sees no sky above its horizon ([`LEVEL_SKY`]), and then it is not confident
//! ([`STEEP_CEILING`]): a pose to inspect, on which `auto` does not engage.
//!
//! **Views down.** They have no sky to choose with, and that absence is their evidence: a
//! steep reading looking down, with [`NO_SKY_MIN_LINES`] distinct lines, replaces an unsure level
//! reading confidently where that level reading is not its Manhattan alternative (its point
//! ahead is not the steep point) and no direction of the picture shows sky
//! ([`alternative_sky`]): every level reading of the point would be refused for the sky it
//! lacks above its horizon, and a view up would have the sky around the point. Seen straight
//! down from 30 m, a facade's window sides are too short for the working resolution, so an
//! unsure level reading without a steep one of enough lines gets a second, finer detection
//! pass ([`FINE_WIDTH`]) whose steep reading may replace it by this rule only.
//!
//! **The level search's misreadings.** The level search reads a steep view as its Manhattan
//! alternative (a level view tilted under [`STEEP_ALTERNATIVE_DEG`], its point ahead the nadir
//! or the zenith); [`sky_refusal`] refuses such a reading where the sky says it is the steep
//! view, and the steep reading of that point then replaces it.
//!
//! **Down or up.** The nadir and the zenith are the same point of the picture. The sky is
//! brighter than what stands under it, so the reading looks up when the brightness correlates
//! with elevation above [`ZENITH_SKY`] for the zenith, and down otherwise (drone shots straight
//! down are the common case).

use glam::{DMat3, DVec3};

use crate::scene::Camera;
use crate::scene::ground::{horizon_row_of_up, tilt_roll_from_up};
use crate::scene::horizon::HorizonEstimate;
use crate::scene::vanishing::{Edge, vertical_angle, within};

/// Largest angle between the vertical vanishing point and the optical axis, degrees: tilts
/// beyond 70° (the level search covers up to 65°; nearer level, a steep reading of a level
/// street's own vanishing point is its Manhattan alternative, which that search weighs).
pub const STEEP_AXIS_DEG: f64 = 20.0;

/// Inlier tolerance, degrees.
pub const INLIER_DEG: f64 = 1.0;

/// Lines through the point whose directions around it differ by less than this are one line
/// (the two silhouette edges of a post, a corner broken into pieces), degrees.
pub const DISTINCT_DEG: f64 = 1.5;

/// Segments paired for candidates (the longest).
pub const PAIRED_SEGMENTS: usize = 60;

/// The sky's correlation with elevation above which the reading looks up at the zenith.
pub const ZENITH_SKY: f64 = 0.2;

/// A steep reading.
#[derive(Debug, Clone)]
pub struct SteepReading {
    /// The ground's upward normal in camera space.
    pub up_cam: DVec3,
    /// Inlier segments.
    pub inliers: Vec<usize>,
    /// Distinct lines through the vanishing point.
    pub distinct_lines: usize,
    /// The circle around the point less its largest gap without inliers, radians.
    pub spread_rad: f64,
    /// Root-mean-square angle of the inliers to the point, degrees.
    pub rms_deg: f64,
}

impl SteepReading {
    /// The estimate of this reading, with `confidence` and the sky's correlation with
    /// elevation `steep_sky`, over the level reading `level` (whose evidence of the picture,
    /// its segments and sky shares, it keeps).
    pub fn estimate(
        &self,
        level: &HorizonEstimate,
        confidence: f64,
        steep_sky: f64,
        camera: &Camera,
    ) -> HorizonEstimate {
        let (t, r) = tilt_roll_from_up(self.up_cam);
        HorizonEstimate {
            up_cam: self.up_cam,
            tilt_deg: t.to_degrees(),
            roll_deg: r.to_degrees(),
            horizon_row: horizon_row_of_up(self.up_cam, camera),
            confidence,
            vertical_inliers: self.inliers.len(),
            horizontal_inliers: 0,
            horizon_inliers: 0,
            families: 0,
            fitted_inliers: self.inliers.len(),
            standing_len: 0.0,
            floating_len: 0.0,
            sky_correlation: steep_sky,
            steep_lines: self.distinct_lines,
            level_offset: 0.0,
            horizon_shift: camera.focal_px() * t.tan() / camera.height_px as f64,
            focal_scale_sq: None,
            ..*level
        }
    }
}

/// Whether the unit ray `d` lies on segment `e` between its ends.
fn crosses(e: &Edge, d: DVec3) -> bool {
    let [a, b] = e.ends;
    d.dot(e.m) > 0.0 && a.cross(d).dot(e.l) > 0.0 && d.cross(b).dot(e.l) > 0.0
}

fn inliers_of(edges: &[Edge], d: DVec3, tol_rad: f64) -> (Vec<usize>, f64) {
    let mut out = Vec::new();
    let mut w = 0.0;
    // Outside a tolerance a millionth wider, tested without a square root or an arcsine
    // ([`within`]), the angle cannot be within `tol_rad`: only the few segments inside it are
    // measured (the pairs' search runs this over every segment for each of its pairs).
    let wide = (tol_rad.sin() * (1.0 + 1e-6)).powi(2);
    for (i, e) in edges.iter().enumerate() {
        if within(e, d, wide) && vertical_angle(e, d) < tol_rad && !crosses(e, d) {
            out.push(i);
            w += e.w;
        }
    }
    (out, w)
}

/// [`inliers_of`] in its plain form, every segment's angle measured: the reference it is
/// tested against.
#[cfg(test)]
fn inliers_of_plain(edges: &[Edge], d: DVec3, tol_rad: f64) -> (Vec<usize>, f64) {
    let mut out = Vec::new();
    let mut w = 0.0;
    for (i, e) in edges.iter().enumerate() {
        if vertical_angle(e, d) < tol_rad && !crosses(e, d) {
            out.push(i);
            w += e.w;
        }
    }
    (out, w)
}

/// The unit `d` minimising the weighted `Σ (l·d)² / |m×d0|²` (see the module doc), by inverse
/// iteration from `d0`.
fn fit(edges: &[Edge], inliers: &[usize], d0: DVec3) -> DVec3 {
    let mut m = DMat3::ZERO;
    for &i in inliers {
        let e = &edges[i];
        let s2 = e.m.cross(d0).length_squared().max(1e-6);
        let l = e.l;
        m += DMat3::from_cols(l * l.x, l * l.y, l * l.z) * (e.w / s2);
    }
    let trace = m.x_axis.x + m.y_axis.y + m.z_axis.z;
    let a = m + DMat3::IDENTITY * (1e-9 * trace.max(1e-12));
    if a.determinant().abs() < 1e-300 {
        return d0;
    }
    let inv = a.inverse();
    let mut d = d0;
    for _ in 0..30 {
        d = (inv * d).normalize_or(d0);
    }
    if d.dot(d0) < 0.0 { -d } else { d }
}

/// The direction of each inlier's midpoint around `d`, radians in [0, 2π).
fn around(edges: &[Edge], inliers: &[usize], d: DVec3) -> Vec<f64> {
    let e1 = (DVec3::X - d * d.x).normalize_or(DVec3::Y);
    let e2 = d.cross(e1);
    inliers
        .iter()
        .map(|&i| {
            let m = edges[i].m;
            m.dot(e2).atan2(m.dot(e1)).rem_euclid(std::f64::consts::TAU)
        })
        .collect()
}

/// The steep reading of `edges`, if two segments meet within [`STEEP_AXIS_DEG`] of the optical
/// axis: its up direction looks down at the point unless `zenith_sky(d)` (the brightness's
/// correlation with elevation for up = `d`) exceeds [`ZENITH_SKY`].
pub fn read(edges: &[Edge], zenith_sky: impl Fn(DVec3) -> f64) -> Option<SteepReading> {
    let mut order: Vec<usize> = (0..edges.len()).collect();
    order.sort_by(|&a, &b| edges[b].w.total_cmp(&edges[a].w));
    order.truncate(PAIRED_SEGMENTS);
    let cos_axis = STEEP_AXIS_DEG.to_radians().cos();
    let tol = INLIER_DEG.to_radians();
    let mut best: Option<(f64, DVec3)> = None;
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            let Some(mut d) = edges[i].l.cross(edges[j].l).try_normalize() else {
                continue;
            };
            if d.z < 0.0 {
                d = -d;
            }
            if d.z < cos_axis || crosses(&edges[i], d) || crosses(&edges[j], d) {
                continue;
            }
            let (_, w) = inliers_of(edges, d, tol);
            if best.is_none_or(|b| w > b.0) {
                best = Some((w, d));
            }
        }
    }
    let (_, mut d) = best?;
    for tol_deg in [2.0, 1.5, INLIER_DEG, INLIER_DEG] {
        let (inl, _) = inliers_of(edges, d, tol_deg.to_radians());
        if inl.len() < 2 {
            return None;
        }
        d = fit(edges, &inl, d);
    }
    let (inliers, _) = inliers_of(edges, d, tol);
    if inliers.len() < 2 {
        return None;
    }
    let mut dirs = around(edges, &inliers, d);
    dirs.sort_by(f64::total_cmp);
    let (tau, pi) = (std::f64::consts::TAU, std::f64::consts::PI);
    let mut gap: f64 = tau - dirs[dirs.len() - 1] + dirs[0];
    for w in dirs.windows(2) {
        gap = gap.max(w[1] - w[0]);
    }
    // Lines: the directions modulo π (a line seen on both sides of the point is one line).
    let mut lines: Vec<f64> = dirs.iter().map(|a| a.rem_euclid(pi)).collect();
    lines.sort_by(f64::total_cmp);
    let step = DISTINCT_DEG.to_radians();
    let mut distinct = usize::from(pi - lines[lines.len() - 1] + lines[0] > step);
    for w in lines.windows(2) {
        distinct += usize::from(w[1] - w[0] > step);
    }
    let distinct = distinct.max(1);
    let ms: f64 = inliers
        .iter()
        .map(|&i| vertical_angle(&edges[i], d).powi(2))
        .sum::<f64>()
        / inliers.len() as f64;
    let up_cam = if zenith_sky(d) > ZENITH_SKY { d } else { -d };
    Some(SteepReading {
        up_cam,
        distinct_lines: distinct,
        spread_rad: tau - gap,
        rms_deg: ms.sqrt().to_degrees(),
        inliers,
    })
}

/// The level reading's sky correlation below which a steep reading is weighed (a level
/// street with a sky above its horizon is not read as a view straight down).
pub const LEVEL_SKY: f64 = 0.3;

/// Fewest distinct lines with which a steep reading's sky may overrule a level reading.
pub const SKY_MIN_LINES: usize = 6;

/// How much more a steep reading's sky must correlate with elevation than the level
/// reading's for it to overrule that reading (on synthetic level streets the steep partner's
/// sky exceeded the level reading's by at most 0.14; looking up between towers, by 0.3–0.5).
pub const SKY_MARGIN: f64 = 0.25;

/// Weights of the steep reading's confidence: `1 / (1 + exp(−z))`, `z = w₀ + w₁ min(lines,
/// 16) + w₂ spread/π`: set by hand so that three lines or
/// fewer stay below 0.25 (two paving joints always meet), four below 0.5 however spread, and
/// eight lines spread over a third of the circle pass 0.9; checked on random steep streets (`tests/ground_pose.rs`).
pub const STEEP_WEIGHTS: [f64; 3] = [-8.0, 1.2, 1.5];

/// The share of the evidence's odds a steep reading keeps: on synthetic level streets looking
/// up 11–19°, the street's own vanishing point reads as a view straight down with 16–19 distinct
/// lines (the evidence of a true steep view), so the evidence alone cannot make a steep reading
/// confident: unless the sky chose it, its confidence stays at most this, below
/// [`crate::scene::horizon::MIN_CONFIDENCE`].
pub const STEEP_CEILING: f64 = 0.5;

/// The confidence of a steep reading: the evidence's logistic, times [`STEEP_CEILING`] unless
/// the sky chose it over the level reading (`by_sky`: a sky around the zenith, which a level
/// street's own vanishing point does not have).
pub fn confidence(s: &SteepReading, by_sky: bool) -> f64 {
    let w = STEEP_WEIGHTS;
    let z =
        w[0] + w[1] * s.distinct_lines.min(16) as f64 + w[2] * s.spread_rad / std::f64::consts::PI;
    let ceiling = if by_sky { 1.0 } else { STEEP_CEILING };
    ceiling / (1.0 + (-z).exp())
}

/// A level reading tilted less than this, degrees, has a steep alternative: the same lines read
/// with the point ahead (where its level lines converge, within this angle of the optical
/// axis) as the nadir or the zenith of a view down or up at least 65° steep, whose verticals
/// converge there. The three directions of a box world are mutually orthogonal, so both
/// readings fit the same lens; only the sky tells them apart (see [`SKY_ABOVE_MIN`],
/// [`SKY_AHEAD_MAX`]).
pub const STEEP_ALTERNATIVE_DEG: f64 = 25.0;

/// A steep reading is the steep alternative of a level reading where its point lies within this
/// angle of the level reading's point ahead, degrees.
pub const ALTERNATIVE_MATCH_DEG: f64 = 3.0;

/// A level reading looking up needs at least this share of sky blocks in the quarter of the
/// picture highest above its horizon: a camera looking up along a street sees the sky over it
/// (0.15–0.75 on synthetic streets); a drone looking straight down at a city sees none
/// (0.01–0.22), and its nadir reads as the street's vanishing point of a level camera looking
/// up (the Manhattan alternative, see [`STEEP_ALTERNATIVE_DEG`]).
pub const SKY_ABOVE_MIN: f64 = 0.2;

/// A level reading looking down with a steep alternative is refused where at least this share
/// of the quarter of the picture around its point ahead is sky blocks: looking down a street,
/// the far street is around that point (at most 0.30 on synthetic streets); looking up
/// between facades, the sky surrounds the zenith (0.44–0.89).
pub const SKY_AHEAD_MAX: f64 = 0.4;

/// Why the sky refuses a level reading, if it does: looking up less than
/// [`STEEP_ALTERNATIVE_DEG`] with no sky above the horizon ([`SKY_ABOVE_MIN`]) or with a
/// sky no brighter than what lies under that horizon ([`SKY_OVER_GROUND`]), looking
/// down with the sky around its point ahead, where that point lies within that angle of the
/// optical axis ([`SKY_AHEAD_MAX`]), or looking down with its horizon above the picture and as
/// much sky in the picture's quarter nearest that horizon (the sky cannot lie below the
/// horizon; streets seen so measure at most 0.22 there, a view up between towers read that way
/// 0.77). Both say the picture is a steep view that the level search
/// read as its Manhattan alternative (a reading at tilt `t` has its alternative at
/// `±(90° − |t|)`: beyond the level search's range, which weighs the others by its priors).
pub fn sky_refusal(e: &HorizonEstimate) -> Option<&'static str> {
    if e.steep_lines > 0 {
        None
    } else if e.tilt_deg > 0.0
        && e.tilt_deg < STEEP_ALTERNATIVE_DEG
        && (e.sky_above < SKY_ABOVE_MIN || e.sky_over_ground < SKY_OVER_GROUND * e.sky_above)
    {
        Some("looking up with no sky above the horizon: a view straight down reads the same")
    } else if e.tilt_deg < 0.0
        && e.receding >= STEEP_ALTERNATIVE_DEG.to_radians().cos()
        && e.sky_ahead >= SKY_AHEAD_MAX
    {
        Some("the sky surrounds the point the level lines meet: a view up reads the same")
    } else if e.tilt_deg < 0.0
        && e.horizon_row.is_some_and(|r| r < 0.0)
        && e.sky_above >= SKY_AHEAD_MAX
    {
        Some("sky below a horizon above the picture: a view up reads the same")
    } else {
        None
    }
}

/// Whether a steep reading looks up with too little sky around its zenith to be a view up: a
/// camera looking up between facades sees the sky surround the point its verticals meet
/// (0.44–0.89 of the quarter of the picture around it, as [`SKY_AHEAD_MAX`] judges a level
/// reading looking down), while a level street's vanishing point, where its receding lines meet
/// as a view up's verticals would, has the far street around it (at most 0.30). Such a reading
/// replaces no level reading. `sky_share` is the share of sky blocks around a direction.
pub fn up_without_sky(s: &SteepReading, sky_share: impl Fn(DVec3) -> f64) -> bool {
    s.up_cam.z > 0.0 && sky_share(s.up_cam) < SKY_AHEAD_MAX
}

/// Why a level reading's horizon is unfounded, if it is: it crosses the picture, yet no
/// vertical stands across it and no edge runs along it. Families of parallel lines fix the
/// vanishing line of the plane they lie in, not that this plane is level: a flat roof, a
/// town's street grid or a paving seen steeply from above gives one as well. A horizon in
/// view is marked by what stands on the ground (verticals crossing it) or by the ground's far
/// edge (the sea's line, a far treeline); a reading with neither says nothing of gravity. With
/// the horizon off the picture nothing of it can be seen, and the ground's own texture and
/// lines decide (streets looking down steeply show no verticals).
pub fn unmarked_horizon(e: &HorizonEstimate) -> Option<&'static str> {
    (e.steep_lines == 0
        && e.vertical_inliers == 0
        && e.horizon_inliers == 0
        && e.horizon_row.is_some_and(|r| (0.0..=1.0).contains(&r)))
    .then_some("the horizon crosses the picture but no vertical stands on it and no edge marks it")
}

/// Width of the finer luma a second detection pass reads where the working luma shows no
/// steep reading with [`SKY_MIN_LINES`] distinct lines, pixels (about; twice
/// [`crate::scene::horizon::WORK_WIDTH`]). Seen straight down from 30 m, the sides of a
/// facade's windows (world verticals, short rays from the nadir) are 4 px long at the working
/// width, under the detector's shortest segment, and the building corners are seen end-on;
/// at twice the width the windows' sides are found, and they converge on the nadir.
pub const FINE_WIDTH: usize = 640;

/// A view down is confident, without a sky to choose it, where no direction of the picture
/// shows sky: the largest of the share of sky blocks in the quarter of the picture around the
/// point `d` (`sky_ahead`, as a level reading's
/// [`crate::scene::horizon::HorizonEstimate::sky_ahead`]) and the sky above the horizon of
/// each level alternative of it (`sky_above` of its up direction, the rule
/// [`sky_refusal`] applies: [`crate::scene::brightness::Brightness::sky_above`]; a level
/// camera looking at `d`, at [`ALTERNATIVE_ROLLS`] rolls around the circle). Each such level
/// reading looking up would be refused under [`SKY_ABOVE_MIN`] (the looser of the two sky
/// rules [`sky_refusal`] applies to such a reading: the stricter [`SKY_OVER_GROUND`] here
/// would let a level street without bright sky read as a view down); a camera looking up between
/// facades has the sky around `d`; a level street's own vanishing point has the sky above it;
/// looking straight down at a street over buildings (seen from 30 m), at most 0.16 of any
/// quarter is sky (flat roofs).
pub fn alternative_sky(
    d: DVec3,
    sky_ahead: impl Fn(DVec3) -> f64,
    sky_above: impl Fn(DVec3) -> f64,
) -> f64 {
    // The picture's up (−y in camera space) made normal to `d`, turned about `d`.
    let u0 = (DVec3::NEG_Y - d * -d.y).normalize_or(DVec3::NEG_Y);
    let u1 = d.cross(u0);
    (0..ALTERNATIVE_ROLLS)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / ALTERNATIVE_ROLLS as f64;
            // The level alternative looking at `d` with its picture's up along this roll: its
            // up direction is the roll's, made normal to `d`.
            sky_above(u0 * a.cos() + u1 * a.sin())
        })
        .fold(sky_ahead(d), f64::max)
}

/// Fewest distinct lines with which a view down replaces a level reading for the sky no
/// direction shows ([`alternative_sky`]): on a real oblique aerial view of a town (the horizon
/// above the picture, no sky), the finer pass finds chance meeting points of 6–8 lines (rms
/// 0.46–0.63°) near the middle; the synthetic street seen straight down from 30 m gives 11
/// (rms 0.36°). A thin margin, set between those two.
pub const NO_SKY_MIN_LINES: usize = 10;

/// Rolls of the level alternatives weighed by [`alternative_sky`], evenly around the circle.
pub const ALTERNATIVE_ROLLS: usize = 24;

/// Least share of a level reading's sky above (smooth blocks among the picture's brightest,
/// [`SKY_ABOVE_MIN`]) that must also be brighter than most of the picture below its horizon
/// ([`crate::scene::brightness::Brightness::sky_over_ground`]), where it looks up with a steep
/// alternative. The sky is brighter than what stands under it: on synthetic streets 0.80–1.0 of
/// it is, and 0.66 over a bright paving under a sky no brighter near the horizon. A view
/// straight down has no sky, and what its level reading takes for sky above the horizon (flat
/// roofs, the brightest smooth surfaces) is drawn from the same surfaces as what lies under
/// that horizon: of the blocks among the picture's brightest 30 %, about a third are brighter
/// than nine tenths of those surfaces. The threshold is the geometric mean of that third and
/// one.
pub const SKY_OVER_GROUND: f64 = 0.577_350_269_189_625_8;

#[cfg(test)]
mod tests {
    use super::*;

    /// [`inliers_of`] takes the segments [`inliers_of_plain`] takes, on random segments and
    /// points with the tolerance at each segment's own angle (a billionth either side), and
    /// at the tolerances the search uses.
    #[test]
    fn the_prefiltered_inliers_are_the_plain_ones() {
        let mut rng = crate::rng::SplitMix64(11);
        let mut unit = |spread: f64| {
            DVec3::new(
                spread * (rng.next_f64() - 0.5),
                spread * (rng.next_f64() - 0.5),
                1.0,
            )
            .normalize()
        };
        let edges: Vec<Edge> = (0..400)
            .map(|_| {
                let (a, b) = (unit(1.2), unit(1.2));
                Edge {
                    l: a.cross(b).normalize(),
                    m: (a + b).normalize(),
                    ends: [a, b],
                    cut: [false; 2],
                    w: (a - b).length(),
                }
            })
            .collect();
        let mut taken = 0;
        for _ in 0..200 {
            let d = unit(0.7);
            let mut tolerances: Vec<f64> = [2.0f64, 1.5, INLIER_DEG]
                .iter()
                .map(|t| t.to_radians())
                .collect();
            for e in edges.iter().take(40) {
                let a = vertical_angle(e, d);
                tolerances.extend([a * (1.0 - 1e-9), a * (1.0 + 1e-9)]);
            }
            for tol in tolerances.into_iter().filter(|t| *t > 0.0 && *t < 0.5) {
                let (fast, w) = inliers_of(&edges, d, tol);
                let (plain, w_plain) = inliers_of_plain(&edges, d, tol);
                assert_eq!(fast, plain);
                assert_eq!(w.to_bits(), w_plain.to_bits());
                taken += fast.len();
            }
        }
        assert!(taken > 1000, "{taken} inliers taken");
    }
}
