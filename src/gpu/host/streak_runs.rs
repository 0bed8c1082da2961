//! Where a streak's runs lie in one of the CPU raster's tiles ([`super::streaks`]): the
//! pixels of each row (or column) its capsule or quad can reach, and the rows that can hold any,
//! found from the streak's own along and across forms so that no pixel depends on the tile.

use super::streaks::{Area, Prepared, larger, smaller};

/// The pixels x of a row where `value(x) = v0 + x · slope` lies in [lo, hi] (`inv` = 1 /
/// slope, 0 where the slope vanishes), as a range of reals (possibly empty).
#[inline(always)]
fn span(v0: f32, slope: f32, inv: f32, lo: f32, hi: f32) -> (f32, f32) {
    if inv == 0.0 {
        let inside = v0 >= lo - 1e-3 && v0 <= hi + 1e-3 && slope.abs() < 1e-6;
        return if inside {
            (f32::NEG_INFINITY, f32::INFINITY)
        } else {
            (f32::INFINITY, f32::NEG_INFINITY)
        };
    }
    let (a, b) = ((lo - v0) * inv, (hi - v0) * inv);
    if a < b { (a, b) } else { (b, a) }
}

/// 1 / `slope`, or 0 where it is too small to bound a row.
fn inverse(slope: f32) -> f32 {
    if slope.abs() < 1e-6 { 0.0 } else { 1.0 / slope }
}

/// The whole pixels in [lo, hi] (both ≥ 0 or the range empty), without libm's rounding.
#[inline(always)]
fn whole(lo: f32, hi: f32) -> Option<(usize, usize)> {
    if lo.is_nan() || hi.is_nan() || lo > hi || hi < 0.0 {
        return None;
    }
    let first = lo as usize + usize::from((lo as usize as f32) < lo);
    let last = hi as usize;
    (first <= last).then_some((first, last))
}

/// `p`'s runs over `area` (`capsule`: over its disc's path alone), whether they go along
/// the coded picture's columns, and the range of `v` its box covers there; `None` where the box
/// misses `area`.
#[inline(always)]
pub(super) fn runs_of(
    p: &Prepared,
    capsule: bool,
    area: &Area,
) -> Option<(Rows, bool, (usize, usize))> {
    let (ya, yb) = ((p.y0 as usize).max(area.y0), (p.y1 as usize).min(area.y1));
    let (xa, xb) = ((p.x0 as usize).max(area.x0), (p.x1 as usize).min(area.x1));
    if ya > yb || xa > xb {
        return None;
    }
    // A capsule covers nothing beyond its disc's path (coverage 0 leaves a pixel as it was);
    // a matte's colour reaches the whole quad.
    let (along_lo, along_hi, across_lim) = if capsule {
        (-p.r, p.len + p.r, p.r)
    } else {
        (-p.ext, p.len + p.ext, p.across_ext)
    };
    // Runs along coordinate `u` (x or y) at each `v`: `along = along_v + u · da`.
    let columns = p.along[2].abs() > p.along[1].abs();
    let (da, dc, va, vc) = if columns {
        (p.along[2], p.across[2], p.along[1], p.across[1])
    } else {
        (p.along[1], p.across[1], p.along[2], p.across[2])
    };
    let ((v0, v1), (u0, u1)) = if columns {
        ((xa, xb), (ya, yb))
    } else {
        ((ya, yb), (xa, xb))
    };
    let rows = Rows {
        along: [p.along[0], va, da],
        across: [p.across[0], vc, dc],
        inv: [inverse(da), inverse(dc)],
        lims: [along_lo, along_hi, across_lim],
        u: (u0, u1),
    };
    Some((rows, columns, (v0, v1)))
}

/// One streak's runs over a tile: at coordinate `u` (x or y) along a run and `v` across the
/// runs, along = `along[0] + v · along[1] + u · along[2]`, across likewise; `inv`: 1 / the
/// slopes in `u` ([`inverse`]), `lims`: along's bounds and across's half-width, `u`: the
/// tile's range of `u`.
pub(super) struct Rows {
    pub(super) along: [f32; 3],
    pub(super) across: [f32; 3],
    inv: [f32; 2],
    lims: [f32; 3],
    u: (usize, usize),
}

impl Rows {
    /// The run at `v`: along and across at `u` = 0, its first and last `u`, or `None`.
    #[inline(always)]
    pub(super) fn row(&self, v: usize) -> Option<(f32, f32, usize, usize)> {
        // Rounding between the bounds and the pixels' own values: the pixel decides.
        const PAD: f32 = 0.01;
        let [along_lo, along_hi, across_lim] = self.lims;
        let vf = v as f32;
        let along_v = self.along[0] + vf * self.along[1];
        let across_v = self.across[0] + vf * self.across[1];
        let (a0, a1) = span(along_v, self.along[2], self.inv[0], along_lo, along_hi);
        let (c0, c1) = span(
            across_v,
            self.across[2],
            self.inv[1],
            -across_lim,
            across_lim,
        );
        let lo = larger(larger(a0, c0) - PAD, self.u.0 as f32);
        let hi = smaller(smaller(a1, c1) + PAD, self.u.1 as f32);
        let (first, last) = whole(lo, hi)?;
        Some((along_v, across_v, first, last))
    }

    /// The rows within `v0..=v1` where [`Rows::row`] can find a run, or `None`: along and
    /// across each bound `v` over the tile's whole range of `u`. Generous by [`ROWS_SLACK`] of
    /// either value (more than `row`'s rounding and its pad), and a value that hardly changes
    /// with `v` bounds nothing, so a row left out has no run: the bound skips the empty rows
    /// of a steep streak's box and decides no pixel.
    #[inline(always)]
    pub(super) fn reached(&self, v0: usize, v1: usize) -> Option<(usize, usize)> {
        let (ua, ub) = (self.u.0 as f32, self.u.1 as f32);
        let (mut lo_v, mut hi_v) = (v0 as f32, v1 as f32);
        let [along_lo, along_hi, across_lim] = self.lims;
        for (w, lo, hi) in [
            (self.along, along_lo, along_hi),
            (self.across, -across_lim, across_lim),
        ] {
            let [w0, wv, wu] = w;
            if wv.abs() < 1e-6 {
                continue;
            }
            let slack = ROWS_SLACK + 0.01 * wu.abs();
            let (m_lo, m_hi) = (
                w0 + smaller(ua * wu, ub * wu),
                w0 + larger(ua * wu, ub * wu),
            );
            // Some m in [m_lo, m_hi] with lo − slack ≤ m + v · wv ≤ hi + slack.
            let (e0, e1) = ((lo - slack - m_hi) / wv, (hi + slack - m_lo) / wv);
            let (e0, e1) = if wv > 0.0 { (e0, e1) } else { (e1, e0) };
            // A NaN bound leaves the range as it was.
            lo_v = larger(e0, lo_v);
            hi_v = smaller(e1, hi_v);
        }
        let (first, last) = whole(lo_v, hi_v)?;
        let (first, last) = (first.max(v0), last.min(v1));
        (first <= last).then_some((first, last))
    }
}

/// How far beyond its bounds (px of along or across) [`Rows::reached`] looks: well over the
/// f32 rounding of values of a few thousand pixels (~10⁻³).
const ROWS_SLACK: f32 = 0.05;

#[cfg(test)]
mod tests {
    use super::{Area, Prepared, runs_of};
    use crate::gpu::host::streaks::{TILE_H, TILE_W};

    /// Every row [`super::Rows::reached`] leaves out has no run, for streaks of every
    /// direction, length and width, capsules and quads, on the tiles they cross (the plain
    /// form: every row of the streak's box tried); and it leaves out most empty rows.
    #[test]
    fn rows_left_out_hold_no_run() {
        let mut state = 3u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut empty, mut skipped) = (0usize, 0usize);
        for trial in 0..4000 {
            // Mostly down the picture, some at any angle, some exactly along an axis.
            let angle = match trial % 6 {
                0 => next() * std::f32::consts::TAU,
                1 => (trial % 4) as f32 * std::f32::consts::FRAC_PI_2,
                _ => (next() - 0.5) * 0.8,
            };
            let d = [angle.sin(), angle.cos()];
            let n = [-d[1], d[0]];
            let q = [100.0 + next() * 1700.0, 100.0 + next() * 900.0];
            let len = if trial % 7 == 0 {
                0.0
            } else {
                250.0 * next() * next()
            };
            let r = 0.3 + 8.0 * next() * next();
            let (ext, across_ext) = (r + 0.5, (r + 0.5).max(2.5 * r));
            let form = |u: [f32; 2]| [u[0] * (0.5 - q[0]) + u[1] * (0.5 - q[1]), u[0], u[1]];
            let ends = [q, [q[0] + d[0] * len, q[1] + d[1] * len]];
            let reach = ext.max(across_ext) + 1.0;
            let lo = |k: usize| (ends[0][k].min(ends[1][k]) - reach).floor().max(0.0) as u32;
            let hi = |k: usize| (ends[0][k].max(ends[1][k]) + reach).ceil() as u32;
            let p = Prepared {
                along: form(d),
                across: form(n),
                len,
                inv_len: if len >= 1e-3 { 1.0 / len } else { 0.0 },
                inv_quad: 1.0 / (len + 2.0 * ext),
                r,
                ext,
                across_ext,
                x0: lo(0),
                x1: hi(0),
                y0: lo(1),
                y1: hi(1),
                ..Prepared::default()
            };
            // A tile the streak crosses, or one beside it.
            let at = next();
            let point = [
                ends[0][0] + d[0] * len * at + n[0] * r * (next() * 4.0 - 2.0),
                ends[0][1] + d[1] * len * at + n[1] * r * (next() * 4.0 - 2.0),
            ];
            let (tx, ty) = (
                (point[0].max(0.0) as usize) / TILE_W,
                (point[1].max(0.0) as usize) / TILE_H,
            );
            let area = Area {
                x0: tx * TILE_W,
                x1: tx * TILE_W + TILE_W - 1,
                y0: ty * TILE_H,
                y1: ty * TILE_H + TILE_H - 1,
            };
            let Some((rows, _, (v0, v1))) = runs_of(&p, trial % 3 != 0, &area) else {
                continue;
            };
            let kept = rows.reached(v0, v1);
            for v in v0..=v1 {
                let inside = kept.is_some_and(|(a, b)| (a..=b).contains(&v));
                let run = rows.row(v);
                assert!(
                    inside || run.is_none(),
                    "trial {trial}: row {v} left out of {kept:?} has the run {run:?}"
                );
                empty += usize::from(run.is_none());
                skipped += usize::from(!inside);
            }
        }
        assert!(
            skipped * 2 > empty,
            "{skipped} of {empty} empty rows left out"
        );
    }
}
