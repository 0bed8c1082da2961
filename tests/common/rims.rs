//! Where a puddle's rim is drawn against where it truly is: the crossings of a cover image
//! with ½ and their distances on the ground from a known rim.
#![allow(dead_code)]

use glam::DVec2;
use rain_composite::scene::Camera;

/// The rim as drawn: where the water's cover of each pixel of `camera`'s picture (`cover`,
/// row-major) crosses ½, along rows where it changes faster across than down and along
/// columns otherwise, linearly between pixel centres; each crossing's distance on the ground
/// from the true rim, m, positive outside. `rim(p)` gives, at ground point p, how far above
/// the ground the water's level lies beyond the height that covers half (smoothstep's ½) and
/// the size of that height's gradient: their ratio is the distance to first order.
pub fn rim_offsets_m(
    camera: &Camera,
    cover: &[f64],
    rim: impl Fn(DVec2) -> (f64, f64),
) -> Vec<f64> {
    rim_crossings(camera, cover, rim)
        .into_iter()
        .map(|c| c.1)
        .collect()
}

/// [`rim_offsets_m`] with each crossing's ground point: (point, offset).
pub fn rim_crossings(
    camera: &Camera,
    cover: &[f64],
    rim: impl Fn(DVec2) -> (f64, f64),
) -> Vec<(DVec2, f64)> {
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    let at = |x: usize, y: usize| cover[y * w + x];
    let mut out = Vec::new();
    let mut crossing = |x: f64, y: f64| {
        let ray = camera.ray_world(DVec2::new(x, y));
        if ray.z >= -1e-6 {
            return;
        }
        let p = (camera.position_m + ray * (camera.position_m.z / -ray.z)).truncate();
        let (above, slope) = rim(p);
        out.push((p, -above / slope));
    };
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let (a, right, down) = (at(x, y), at(x + 1, y), at(x, y + 1));
            let gx = (at(x + 1, y) - at(x - 1, y)).abs();
            let gy = (at(x, y + 1) - at(x, y - 1)).abs();
            if (a - 0.5) * (right - 0.5) < 0.0 && gx >= gy {
                crossing(x as f64 + 0.5 + (0.5 - a) / (right - a), y as f64 + 0.5);
            }
            if (a - 0.5) * (down - 0.5) < 0.0 && gy > gx {
                crossing(x as f64 + 0.5, y as f64 + 0.5 + (0.5 - a) / (down - a));
            }
        }
    }
    out
}

/// Mean, RMS, standard deviation about the mean, and largest size of `v`.
pub fn spread(v: &[f64]) -> (f64, f64, f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let rms = (v.iter().map(|d| d * d).sum::<f64>() / n).sqrt();
    let sd = (v.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n).sqrt();
    (mean, rms, sd, v.iter().fold(0.0f64, |a, d| a.max(d.abs())))
}

/// How rough a rim around `centre` is on the scale of `scale_m`: the RMS of each crossing's
/// offset less the mean offset of the crossings within `scale_m` of it along the rim (by
/// angle about `centre` times the rim's mean distance from it). A staircase of cells of
/// `scale_m`/3 shows here; a rim drawn smooth but a little off its true place does not.
pub fn roughness_m(crossings: &[(DVec2, f64)], centre: DVec2, scale_m: f64) -> f64 {
    let radius = crossings
        .iter()
        .map(|c| (c.0 - centre).length())
        .sum::<f64>()
        / crossings.len() as f64;
    let at: Vec<(f64, f64)> = crossings
        .iter()
        .map(|c| {
            let d = c.0 - centre;
            (d.y.atan2(d.x) * radius, c.1)
        })
        .collect();
    let turn = std::f64::consts::TAU * radius;
    let sum: f64 = at
        .iter()
        .map(|&(s, d)| {
            let near: Vec<f64> = at
                .iter()
                .filter(|&&(t, _)| {
                    let gap = (t - s).rem_euclid(turn);
                    gap.min(turn - gap) <= scale_m
                })
                .map(|n| n.1)
                .collect();
            let mean = near.iter().sum::<f64>() / near.len() as f64;
            (d - mean).powi(2)
        })
        .sum();
    (sum / at.len() as f64).sqrt()
}

/// Points of the contour `field = 0` on `lines` rays (ray k from `line(k).0` along
/// `line(k).1`): on each, its first crossing for t in [`t0`, `t1`], found in 400 steps and
/// then by bisection to the bit. `None` where a ray crosses nowhere.
pub fn contour_points(
    field: impl Fn(DVec2) -> f64,
    lines: usize,
    line: impl Fn(usize) -> (DVec2, DVec2),
    (t0, t1): (f64, f64),
) -> Option<Vec<DVec2>> {
    (0..lines)
        .map(|k| {
            let (base, dir) = line(k);
            let g = |t: f64| field(base + t * dir);
            let steps = 400;
            let mut before = t0;
            for s in 1..=steps {
                let t = t0 + (t1 - t0) * s as f64 / steps as f64;
                if g(before) * g(t) <= 0.0 {
                    let (mut lo, mut hi) = (before, t);
                    for _ in 0..60 {
                        let mid = 0.5 * (lo + hi);
                        if g(lo) * g(mid) <= 0.0 {
                            hi = mid;
                        } else {
                            lo = mid;
                        }
                    }
                    return Some(base + 0.5 * (lo + hi) * dir);
                }
                before = t;
            }
            None
        })
        .collect()
}

/// The turns of a polyline (`closed`: its last point joins its first), rad, positive to the
/// left: the angle from each segment to the next.
pub fn turns(points: &[DVec2], closed: bool) -> Vec<f64> {
    let n = points.len();
    let count = if closed { n } else { n.saturating_sub(2) };
    (0..count)
        .map(|k| {
            let (a, b, c) = (points[k], points[(k + 1) % n], points[(k + 2) % n]);
            let (u, v) = (b - a, c - b);
            u.perp_dot(v).atan2(u.dot(v))
        })
        .collect()
}
