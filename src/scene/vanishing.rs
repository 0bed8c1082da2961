//! The up direction refined by least squares on the segments that support a reading, and the
//! check that nothing standing floats above the horizon.
//!
//! The search of [`crate::scene::horizon`] scores a candidate up direction `n` by kernel
//! counts, which pick the reading but not its last tenth of a degree: a family of horizontal
//! edges is a histogram peak, not a fitted vanishing point. Here the reading's inliers are
//! fixed (vertical edges within [`INLIER_DEG`] of the great circle through `n`, edges along the
//! horizon, and up to [`MAX_FAMILIES`] families of horizontal edges sharing a vanishing point)
//! and `n` minimises
//!
//! ```text
//! J(n) = Σ_vertical w sin²α + Σ_horizon w |l × n|² + Σ_families λ_min(Pₙᵀ M_k Pₙ)
//! ```
//!
//! with `α` the angle between a vertical edge and the great circle through its midpoint and `n`,
//! `M_k = Σ w l lᵀ` over a family's interpretation-plane normals and `Pₙ` a basis of the plane
//! normal to `n`: the smallest eigenvalue is the family's residual at its best vanishing point
//! on the horizon of `n` (Kosecka & Zhang 2002 fit vanishing points the same way, as the
//! direction most orthogonal to the family's normals). The minimum is found by nested grid
//! search in tilt and roll, classified again at the result and fitted once more.
//!
//! **Floating verticals.** A thing standing on the ground has its foot below the horizon
//! (the camera is above the ground), so a vertical edge whose lower end shows, inside the
//! picture, clearly above the horizon is either high on a wall (a window frame) or the
//! horizon is too low: a fence rail or a guardrail taken for the horizon leaves the poles and
//! trees beyond it floating. [`standing_check`] weighs the vertical edges rising above the
//! horizon: those whose foot is below it (or cut by the picture's border) against those whose
//! foot floats.

use glam::DVec3;

use crate::scene::ground::{tilt_roll_from_up, up_from_tilt_roll};

/// A segment on the Gaussian sphere.
#[derive(Debug, Clone, Copy)]
pub struct Edge {
    /// Interpretation-plane normal (unit).
    pub l: DVec3,
    /// Unit ray through the midpoint.
    pub m: DVec3,
    /// Unit rays through the two ends.
    pub ends: [DVec3; 2],
    /// Whether each end lies on the picture's border (the segment may go on beyond it).
    pub cut: [bool; 2],
    /// Length in frame diagonals.
    pub w: f64,
}

/// Inlier tolerance of the least-squares fit, degrees.
pub const INLIER_DEG: f64 = 1.0;

/// Most families of horizontal edges fitted (a street has the kerbs', the paving's two and the
/// cross streets').
pub const MAX_FAMILIES: usize = 4;

/// The share of the inlier tolerance an edge along the horizon must meet: short level edges
/// far away lie near the horizon without being on it, and pull a fit that takes them for it.
pub const HORIZON_TOL_SHARE: f64 = 0.3;

/// Fewest edges a family of horizontal edges has (two lines always meet somewhere).
pub const MIN_FAMILY: usize = 3;

/// The angle between a segment and the great circle through its midpoint and `n`, radians.
pub fn vertical_angle(e: &Edge, n: DVec3) -> f64 {
    let mxn = e.m.cross(n).length().max(1e-9);
    (e.l.dot(n).abs() / mxn).min(1.0).asin()
}

/// Whether segment `e` lies within the angle whose squared sine is `sin2_tol` of the great
/// circle through its midpoint and `n`: `vertical_angle(e, n) < tol` without the square root
/// and the arcsine (the same comparison squared), for the inner loops.
pub fn within(e: &Edge, n: DVec3, sin2_tol: f64) -> bool {
    let ln = e.l.dot(n);
    ln * ln < sin2_tol * e.m.cross(n).length_squared().max(1e-18)
}

/// The angle between a segment's interpretation plane and the horizon of `n`, radians.
pub fn horizon_angle(e: &Edge, n: DVec3) -> f64 {
    e.l.cross(n).length().min(1.0).asin()
}

/// Azimuth along the horizon of `n` of the vanishing point a segment would have if horizontal,
/// radians in [0, π).
pub fn azimuth(e: &Edge, n: DVec3) -> Option<f64> {
    let d = e.l.cross(n).try_normalize()?;
    let (e1, e2) = horizon_basis(n);
    Some(d.dot(e2).atan2(d.dot(e1)).rem_euclid(std::f64::consts::PI))
}

fn horizon_basis(n: DVec3) -> (DVec3, DVec3) {
    let e1 = (DVec3::X - n * n.x).normalize_or(DVec3::Z);
    (e1, n.cross(e1))
}

/// The inliers of a reading.
#[derive(Debug, Clone, Default)]
pub struct Inliers {
    /// Vertical edges.
    pub vertical: Vec<usize>,
    /// Edges along the horizon.
    pub horizon: Vec<usize>,
    /// Families of horizontal edges sharing a vanishing point (each of at least 2).
    pub families: Vec<Vec<usize>>,
}

impl Inliers {
    /// Number of independent inlier segments (a horizon edge counts 4, as in the confidence).
    pub fn count(&self) -> usize {
        self.vertical.len()
            + 4 * self.horizon.len()
            + self.families.iter().map(Vec::len).sum::<usize>()
    }
}

/// Classifies `edges` at `n` with tolerance `tol_rad`.
pub fn classify(edges: &[Edge], n: DVec3, tol_rad: f64) -> Inliers {
    let mut out = Inliers::default();
    let mut rest: Vec<(f64, usize)> = Vec::new();
    for (i, e) in edges.iter().enumerate() {
        if vertical_angle(e, n) < tol_rad {
            out.vertical.push(i);
        } else if horizon_angle(e, n) < HORIZON_TOL_SHARE * tol_rad {
            out.horizon.push(i);
        } else if let Some(phi) = azimuth(e, n) {
            rest.push((phi, i));
        }
    }
    // Families: the heaviest window of ±tol along the horizon's azimuth, greedily.
    let pi = std::f64::consts::PI;
    let mut taken = vec![false; rest.len()];
    for _ in 0..MAX_FAMILIES {
        let mut best: (f64, Vec<usize>) = (0.0, Vec::new());
        for &(phi0, _) in &rest {
            let mut sum = 0.0;
            let mut members = Vec::new();
            for (k, &(phi, i)) in rest.iter().enumerate() {
                let d = (phi - phi0).rem_euclid(pi);
                if !taken[k] && d.min(pi - d) < tol_rad {
                    sum += edges[i].w;
                    members.push(k);
                }
            }
            if members.len() >= MIN_FAMILY && sum > best.0 {
                best = (sum, members);
            }
        }
        if best.1.is_empty() {
            break;
        }
        for &k in &best.1 {
            taken[k] = true;
        }
        out.families
            .push(best.1.iter().map(|&k| rest[k].1).collect());
    }
    out
}

/// The vanishing point of a family of horizontal edges on the horizon of `n`: the unit
/// direction normal to `n` most orthogonal to the family's plane normals (the smallest
/// eigenvector of the 2×2 problem in [`residual`]).
pub fn family_point(edges: &[Edge], family: &[usize], n: DVec3) -> DVec3 {
    let (e1, e2) = horizon_basis(n);
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for &i in family {
        let (p, q) = (edges[i].l.dot(e1), edges[i].l.dot(e2));
        a += edges[i].w * p * p;
        b += edges[i].w * p * q;
        c += edges[i].w * q * q;
    }
    // The eigenvector of the smaller eigenvalue of [[a, b], [b, c]].
    let lambda = 0.5 * (a + c) - (0.25 * (a - c) * (a - c) + b * b).sqrt();
    let (x, y) = if b.abs() > 1e-15 {
        (b, lambda - a)
    } else if a <= c {
        (1.0, 0.0)
    } else {
        (0.0, 1.0)
    };
    (e1 * x + e2 * y).normalize_or(e1)
}

/// `J(n)` of the module doc for fixed inliers.
pub fn residual(edges: &[Edge], inliers: &Inliers, n: DVec3) -> f64 {
    let mut j = 0.0;
    for &i in &inliers.vertical {
        let a = vertical_angle(&edges[i], n).sin();
        j += edges[i].w * a * a;
    }
    for &i in &inliers.horizon {
        j += edges[i].w * edges[i].l.cross(n).length_squared();
    }
    let (e1, e2) = horizon_basis(n);
    for fam in &inliers.families {
        let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
        for &i in fam {
            let (p, q) = (edges[i].l.dot(e1), edges[i].l.dot(e2));
            a += edges[i].w * p * p;
            b += edges[i].w * p * q;
            c += edges[i].w * q * q;
        }
        // Smallest eigenvalue of [[a, b], [b, c]].
        j += 0.5 * (a + c) - (0.25 * (a - c) * (a - c) + b * b).sqrt();
    }
    j
}

/// The least-squares up direction near `n0` (see the module doc), with its inliers.
pub fn refine(edges: &[Edge], n0: DVec3) -> (DVec3, Inliers) {
    let mut n = n0;
    // Wide inliers first (the start may be a degree off), then narrower ones.
    for (tol_deg, first) in [
        (2.5, (2.0f64, 0.25f64)),
        (1.5, (0.6, 0.1)),
        (INLIER_DEG, (0.3, 0.05)),
    ] {
        let inliers = classify(edges, n, f64::to_radians(tol_deg));
        let (t0, r0) = tilt_roll_from_up(n);
        let (mut t, mut r) = (t0.to_degrees(), r0.to_degrees());
        for (half, step) in [
            first,
            (first.1 * 1.2, first.1 / 5.0),
            (first.1 / 4.0, first.1 / 20.0),
        ] {
            let k = (half / step).round() as i32;
            let mut best = (f64::MAX, t, r);
            for i in -k..=k {
                for j in -k..=k {
                    let (tt, rr) = (t + i as f64 * step, r + j as f64 * step);
                    let cand = up_from_tilt_roll(tt.to_radians(), rr.to_radians());
                    let v = residual(edges, &inliers, cand);
                    if v < best.0 {
                        best = (v, tt, rr);
                    }
                }
            }
            (t, r) = (best.1, best.2);
        }
        n = up_from_tilt_roll(t.to_radians(), r.to_radians());
    }
    let inliers = classify(edges, n, INLIER_DEG.to_radians());
    (n, inliers)
}

/// Below this elevation a vertical edge's foot stands on the ground, radians of elevation
/// above the horizon (the tolerance of a right reading).
pub const FOOT_MARGIN_DEG: f64 = 1.0;

/// The vertical edges rising above the horizon of `n`: length (frame diagonals) of those whose
/// foot is at or below the horizon or cut by the picture's border, and of those whose foot
/// floats above it (see the module doc).
pub fn standing_check(edges: &[Edge], vertical: &[usize], n: DVec3) -> (f64, f64) {
    let margin = FOOT_MARGIN_DEG.to_radians().sin();
    let (mut standing, mut floating) = (0.0, 0.0);
    for &i in vertical {
        let e = &edges[i];
        let el = [e.ends[0].dot(n), e.ends[1].dot(n)];
        let (lo, hi) = if el[0] < el[1] { (0, 1) } else { (1, 0) };
        if el[hi] < margin {
            continue;
        }
        if el[lo] < margin || e.cut[lo] {
            standing += e.w;
        } else {
            floating += e.w;
        }
    }
    (standing, floating)
}

/// The unit direction most orthogonal to the plane normals of `members` (the smallest
/// eigenvector of `Σ w l lᵀ`, by inverse iteration from `start`): the free vanishing point of
/// a set of edges, on no assumed horizon.
pub fn free_point(edges: &[Edge], members: &[usize], start: DVec3) -> DVec3 {
    let mut m = glam::DMat3::ZERO;
    for &i in members {
        let l = edges[i].l;
        m += glam::DMat3::from_cols(l * l.x, l * l.y, l * l.z) * edges[i].w;
    }
    let trace = m.x_axis.x + m.y_axis.y + m.z_axis.z;
    let shifted = m + glam::DMat3::IDENTITY * (1e-9 * trace + 1e-15);
    if shifted.determinant().abs() < 1e-300 {
        return start;
    }
    let inv = shifted.inverse();
    let mut x = start;
    for _ in 0..8 {
        x = (inv * x).normalize_or(x);
    }
    if x.dot(start) < 0.0 { -x } else { x }
}

/// Fewest vertical inliers for [`level_offset`]: below, the verticals alone do not pose the
/// camera and the fit rests on the families, consistent with them by construction.
pub const LEVEL_CHECK_MIN_VERTICALS: usize = 4;

/// Longest non-vertical edges paired for the level families' vanishing points in
/// [`level_offset`].
pub const LEVEL_PAIRED_EDGES: usize = 40;

/// Farthest a family's vanishing point may lie off the predicted horizon and still count as
/// level in [`level_offset`], degrees.
pub const LEVEL_MAX_ELEVATION_DEG: f64 = 10.0;

/// Nearest a level family's vanishing point comes to the optical axis in [`level_offset`]
/// (`cos` of the angle; about 73°): a family converging far aside is nearly parallel in the
/// picture and its point's elevation is poorly determined (a paving's families 80–84° aside
/// read 2.4–2.9° off the horizon of an exact lens).
pub const LEVEL_MIN_COS: f64 = 0.3;

/// Least length of a second level family in [`level_offset`], a share of the first's.
pub const LEVEL_SECOND_SHARE: f64 = 0.5;

/// Most level families [`level_offset`] finds.
pub const LEVEL_FAMILIES: usize = 2;

/// How far the families of receding level edges converge off the horizon the verticals alone
/// predict: the weighted mean signed elevation (radians, positive above) of their vanishing
/// points over the horizon of the verticals' own vanishing point. The families are found
/// afresh, not at the fitted `n`: a fit whose tilt is wrong groups, along its own horizon, the edges that happen to meet there, and misses
/// the true families, which converge off it. A family is the point where two of the
/// [`LEVEL_PAIRED_EDGES`] longest non-vertical edges meet with the most edge length through it
/// (within [`INLIER_DEG`], at least [`MIN_FAMILY`] edges, within [`LEVEL_MIN_COS`] of the
/// optical axis), greedily, up to [`LEVEL_FAMILIES`], a second one at least
/// [`LEVEL_SECOND_SHARE`] as long as the first; weights: length times the square of how much
/// the family recedes (the cosine of its point's angle to the axis).
///
/// Under the right focal length a vertical vanishing point `v` and the horizon are pole and
/// polar (`(p − c)·(v − c) = −f²` for every point `p` of the horizon), so the level families'
/// points lie on it; under a wrong one the verticals' convergence is read as the wrong tilt and
/// the families sit off its horizon, all on one side. `None` with fewer than
/// [`LEVEL_CHECK_MIN_VERTICALS`] verticals or no family.
///
/// The same families give the lens ([`LevelCheck::focal_scale_sq`]): with `P` and `V` the
/// families' and the verticals' vanishing points in the picture through the assumed focal
/// length `f_a` (`x/z`, `y/z` of their rays), `(f/f_a)² = −P·V`, the weighted mean over the
/// families.
pub fn level_offset(edges: &[Edge], inliers: &Inliers, n: DVec3) -> Option<LevelCheck> {
    if inliers.vertical.len() < LEVEL_CHECK_MIN_VERTICALS {
        return None;
    }
    let nv = free_point(edges, &inliers.vertical, n);
    let tol = INLIER_DEG.to_radians();
    let sin2_tol = tol.sin().powi(2);
    let mut free: Vec<usize> = (0..edges.len())
        .filter(|&i| vertical_angle(&edges[i], nv) >= tol)
        .collect();
    let (mut sum, mut weight, mut heaviest) = (0.0, 0.0, 0.0f64);
    let mut polar = 0.0;
    for _ in 0..LEVEL_FAMILIES {
        let mut order = free.clone();
        order.sort_by(|&a, &b| edges[b].w.total_cmp(&edges[a].w));
        order.truncate(LEVEL_PAIRED_EDGES);
        let mut best: (f64, DVec3, Vec<usize>) = (0.0, DVec3::Z, Vec::new());
        for (k, &i) in order.iter().enumerate() {
            for &j in &order[k + 1..] {
                let Some(mut p) = edges[i].l.cross(edges[j].l).try_normalize() else {
                    continue;
                };
                if p.z < 0.0 {
                    p = -p;
                }
                if p.z < LEVEL_MIN_COS {
                    continue;
                }
                let (mut count, mut w) = (0, 0.0);
                for &m in &free {
                    if within(&edges[m], p, sin2_tol) {
                        count += 1;
                        w += edges[m].w;
                    }
                }
                if count >= MIN_FAMILY && w > best.0 {
                    best = (w, p, Vec::new());
                }
            }
        }
        if best.0 > 0.0 {
            best.2 = free
                .iter()
                .copied()
                .filter(|&m| within(&edges[m], best.1, sin2_tol))
                .collect();
        }
        // A second family counts where it is at least half as strong as the first: a few
        // edges meeting by chance make a weak one.
        if best.2.is_empty() || best.0 < LEVEL_SECOND_SHARE * heaviest {
            break;
        }
        heaviest = heaviest.max(best.0);
        let mut d = free_point(edges, &best.2, best.1);
        if d.z < 0.0 {
            d = -d;
        }
        // A point farther than this off the predicted horizon is no level family (a lens a
        // few tens of degrees off moves the horizon a few degrees): stairs, roofs, or verticals
        // beyond the inlier tolerance.
        let elevation = d.dot(nv).clamp(-1.0, 1.0).asin();
        if elevation.abs() < LEVEL_MAX_ELEVATION_DEG.to_radians() {
            sum += best.0 * d.z * d.z * elevation;
            weight += best.0 * d.z * d.z;
            polar += best.0 * d.z * d.z * (d.x * nv.x + d.y * nv.y) / (d.z * nv.z);
        }
        free.retain(|i| !best.2.contains(i));
    }
    (weight > 1e-12).then(|| LevelCheck {
        offset_rad: sum / weight,
        focal_scale_sq: (nv.z.abs() > 1e-9).then(|| -polar / weight),
    })
}

/// What [`level_offset`] measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelCheck {
    /// The families' weighted mean elevation over the verticals' horizon, radians.
    pub offset_rad: f64,
    /// `(f/f_a)²` of the focal length `f` under which the families lie on the verticals'
    /// horizon, over the assumed `f_a`; `None` where the verticals' vanishing point lies on
    /// the picture's plane (a level camera: every focal length fits). Not positive: no lens
    /// centred on the picture explains both (a picture cropped off its centre).
    pub focal_scale_sq: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`within`] makes the same decisions as comparing [`vertical_angle`] (its plain
    /// reference) on random segments and points, near the tolerance included.
    #[test]
    fn within_is_the_angle_comparison() {
        let mut rng = crate::rng::SplitMix64(5);
        let mut unit = || {
            DVec3::new(
                rng.next_f64() - 0.5,
                rng.next_f64() - 0.5,
                0.2 + rng.next_f64(),
            )
            .normalize()
        };
        let mut disagreements = 0;
        for _ in 0..20_000 {
            let (a, b, n) = (unit(), unit(), unit());
            let e = Edge {
                l: a.cross(b).normalize(),
                m: (a + b).normalize(),
                ends: [a, b],
                cut: [false; 2],
                w: 1.0,
            };
            // Tolerances around the segment's own angle, so that both sides are tested.
            let angle = vertical_angle(&e, n);
            for tol in [
                0.5 * angle,
                angle * (1.0 - 1e-9),
                angle * (1.0 + 1e-9),
                2.0 * angle,
            ] {
                if tol <= 0.0 || tol >= 1.5 {
                    continue;
                }
                let plain = vertical_angle(&e, n) < tol;
                disagreements += usize::from(within(&e, n, tol.sin().powi(2)) != plain);
            }
        }
        assert_eq!(disagreements, 0);
    }
}
