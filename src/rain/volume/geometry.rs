//! The view volume as a convex polytope: the frustum slab between two depths, clipped at the
//! ground, its vertices and its volume.

use glam::{DVec2, DVec3};

use crate::scene::Camera;

/// A half-space n·p ≤ d (n unit).
#[derive(Debug, Clone, Copy)]
pub(super) struct HalfSpace {
    pub(super) n: DVec3,
    pub(super) d: f64,
}

impl HalfSpace {
    pub(super) fn new(n: DVec3, d: f64) -> HalfSpace {
        let l = n.length();
        HalfSpace { n: n / l, d: d / l }
    }
}

/// The frustum slab near ≤ depth ≤ far, clipped above the ground, as world half-spaces.
pub(super) fn slab_half_spaces(
    camera: &Camera,
    near_m: f64,
    far_m: f64,
    ground: Option<f64>,
) -> Vec<HalfSpace> {
    let f = camera.focal_px();
    let a = 0.5 * camera.width_px as f64 / f;
    let b = 0.5 * camera.height_px as f64 / f;
    let r = camera.world_from_camera;
    let c = camera.position_m;
    let cam = [
        (DVec3::new(1.0, 0.0, -a), 0.0),
        (DVec3::new(-1.0, 0.0, -a), 0.0),
        (DVec3::new(0.0, 1.0, -b), 0.0),
        (DVec3::new(0.0, -1.0, -b), 0.0),
        (DVec3::new(0.0, 0.0, -1.0), -near_m),
        (DVec3::new(0.0, 0.0, 1.0), far_m),
    ];
    let mut hs: Vec<HalfSpace> = cam
        .iter()
        .map(|&(n, d)| {
            let nw = r * n;
            HalfSpace::new(nw, d + nw.dot(c))
        })
        .collect();
    if let Some(g) = ground {
        hs.push(HalfSpace::new(DVec3::NEG_Z, -g));
    }
    hs
}

/// `camera` seen with focal length `f_px` (≤ its own: a wider view) and widened on every side
/// so that any ray of that view turned by up to `turn_rad` stays inside: a ray at angle θ from
/// the axis turned by ε lies at most θ + ε from it, so each image-plane half extent grows by
/// tan(θc + ε) − tan(θc), θc the corner's angle (the largest θ).
pub(crate) fn widened(camera: &Camera, f_px: f64, turn_rad: f64) -> Camera {
    let f = f_px.min(camera.focal_px());
    let (a, b) = (
        0.5 * camera.width_px as f64 / f,
        0.5 * camera.height_px as f64 / f,
    );
    let corner = a.hypot(b).atan();
    let grow = if corner + turn_rad < 1.5 {
        (corner + turn_rad).tan() - corner.tan()
    } else {
        1.0
    };
    let (w, h) = (2.0 * (a + grow) * f, 2.0 * (b + grow) * f);
    Camera {
        width_px: w.ceil() as u32,
        height_px: h.ceil() as u32,
        fov_x_rad: 2.0 * (0.5 * w.ceil() / f).atan(),
        ..*camera
    }
}

/// Vertices of the bounded polytope ∩ half-spaces (every feasible intersection of three
/// planes). Empty when the polytope is empty or flat.
pub(super) fn polytope_vertices(hs: &[HalfSpace]) -> Vec<DVec3> {
    let scale = hs.iter().fold(1.0f64, |m, h| m.max(h.d.abs()));
    let tol = 1e-9 * scale;
    let mut out = Vec::new();
    for i in 0..hs.len() {
        for j in i + 1..hs.len() {
            let nij = hs[i].n.cross(hs[j].n);
            for k in j + 1..hs.len() {
                let det = nij.dot(hs[k].n);
                if det.abs() < 1e-10 {
                    continue;
                }
                // Cramer: p = (d_i (n_j × n_k) + d_j (n_k × n_i) + d_k (n_i × n_j)) / det.
                let p = (hs[j].n.cross(hs[k].n) * hs[i].d
                    + hs[k].n.cross(hs[i].n) * hs[j].d
                    + nij * hs[k].d)
                    / det;
                if hs.iter().all(|h| h.n.dot(p) <= h.d + tol) {
                    out.push(p);
                }
            }
        }
    }
    out
}

/// Volume of the frustum slab between depths `near_m` and `far_m` (along the optical axis),
/// clipped above the ground, m³. Exact: each depth slice is the picture rectangle scaled by
/// depth, clipped by the ground line; its area is quadratic in depth between the depths where
/// the ground line passes a corner, and Simpson's rule is exact on each such piece. Without a
/// ground it is (4ab/3)(far³ − near³), a = tan(fov_x/2), b = tan(fov_y/2).
pub fn view_volume_m3(camera: &Camera, near_m: f64, far_m: f64, ground_z_m: Option<f64>) -> f64 {
    // Written so NaN depths also give an empty volume.
    if far_m.partial_cmp(&near_m) != Some(std::cmp::Ordering::Greater) {
        return 0.0;
    }
    let f = camera.focal_px();
    let a = 0.5 * camera.width_px as f64 / f;
    let b = 0.5 * camera.height_px as f64 / f;
    let Some(g) = ground_z_m else {
        return 4.0 * a * b / 3.0 * (far_m.powi(3) - near_m.powi(3));
    };
    // World height of camera point (x, y, s): c_z + r0 x + r1 y + r2 s.
    let m = camera.world_from_camera;
    let (r0, r1, r2) = (m.x_axis.z, m.y_axis.z, m.z_axis.z);
    let h = camera.position_m.z - g;
    let mut cuts = vec![near_m, far_m];
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            let k = sx * a * r0 + sy * b * r1 + r2;
            if k.abs() > 1e-14 {
                let s = -h / k;
                if s > near_m && s < far_m {
                    cuts.push(s);
                }
            }
        }
    }
    cuts.sort_by(f64::total_cmp);
    let area = |s: f64| clipped_rect_area(a * s, b * s, r0, r1, h + r2 * s);
    cuts.windows(2)
        .map(|w| (w[1] - w[0]) / 6.0 * (area(w[0]) + 4.0 * area(0.5 * (w[0] + w[1])) + area(w[1])))
        .sum()
}

/// Area of the rectangle |x| ≤ hx, |y| ≤ hy where r0 x + r1 y + c ≥ 0.
pub(super) fn clipped_rect_area(hx: f64, hy: f64, r0: f64, r1: f64, c: f64) -> f64 {
    let rect = [
        DVec2::new(-hx, -hy),
        DVec2::new(hx, -hy),
        DVec2::new(hx, hy),
        DVec2::new(-hx, hy),
    ];
    let side = |p: DVec2| r0 * p.x + r1 * p.y + c;
    let mut poly: Vec<DVec2> = Vec::with_capacity(6);
    for i in 0..4 {
        let (p, q) = (rect[i], rect[(i + 1) % 4]);
        let (sp, sq) = (side(p), side(q));
        if sp >= 0.0 {
            poly.push(p);
        }
        if (sp >= 0.0) != (sq >= 0.0) {
            poly.push(p + (q - p) * (sp / (sp - sq)));
        }
    }
    let n = poly.len();
    if n < 3 {
        return 0.0;
    }
    0.5 * (0..n)
        .map(|i| poly[i].perp_dot(poly[(i + 1) % n]))
        .sum::<f64>()
        .abs()
}
