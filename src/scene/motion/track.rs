//! Feature tracks between two frames: Shi–Tomasi corners (the smaller eigenvalue of the
//! gradients' structure tensor, Shi & Tomasi 1994), one per cell of a grid so they spread over
//! the picture, followed into the next frame by pyramidal Lucas–Kanade (Bouguet 2001: the
//! reference patch's gradients and their 2×2 normal matrix once per level, Newton steps on the
//! frame's bilinear samples, coarse to fine).

use glam::DVec2;

/// A greyscale picture, row-major, values about [0, 1].
#[derive(Debug, Clone)]
pub struct Image {
    /// Width, samples.
    pub width: usize,
    /// Height, samples.
    pub height: usize,
    /// The samples.
    pub data: Vec<f32>,
}

impl Image {
    /// The sample at integer `(x, y)`, clamped to the picture.
    fn at(&self, x: isize, y: isize) -> f32 {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.data[y * self.width + x]
    }

    /// Bilinear sample at `(x, y)` (sample i's centre at x = i), clamped at the edges.
    pub fn bilinear(&self, x: f64, y: f64) -> f64 {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (i, j) = (x0 as isize, y0 as isize);
        let a = self.at(i, j) as f64;
        let b = self.at(i + 1, j) as f64;
        let c = self.at(i, j + 1) as f64;
        let d = self.at(i + 1, j + 1) as f64;
        (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy
    }

    /// Half the size: each sample the mean of a 2×2 block (an odd last row or column dropped).
    fn half(&self) -> Image {
        let (w, h) = (self.width / 2, self.height / 2);
        let mut data = Vec::with_capacity(w * h);
        for y in 0..h {
            let (r0, r1) = (2 * y * self.width, (2 * y + 1) * self.width);
            for x in 0..w {
                let s = self.data[r0 + 2 * x]
                    + self.data[r0 + 2 * x + 1]
                    + self.data[r1 + 2 * x]
                    + self.data[r1 + 2 * x + 1];
                data.push(0.25 * s);
            }
        }
        Image {
            width: w,
            height: h,
            data,
        }
    }
}

/// Levels of the pyramid: at 640 samples wide the coarsest is 80, so a frame-to-frame shift of
/// up to about `HALF_WINDOW · 2³` ≈ 50 samples is followed.
pub const LEVELS: usize = 4;

/// Half the side of the tracked patch, samples (a 13×13 patch).
pub const HALF_WINDOW: isize = 6;

/// A picture and its halvings, finest first.
#[derive(Debug, Clone)]
pub struct Pyramid {
    /// Level 0 is the picture itself.
    pub levels: Vec<Image>,
}

impl Pyramid {
    /// The pyramid of `image`, [`LEVELS`] deep (fewer where it gets too small to track in).
    pub fn new(image: Image) -> Pyramid {
        let mut levels = vec![image];
        while levels.len() < LEVELS {
            let last = &levels[levels.len() - 1];
            if last.width < 4 * HALF_WINDOW as usize || last.height < 4 * HALF_WINDOW as usize {
                break;
            }
            levels.push(last.half());
        }
        Pyramid { levels }
    }
}

/// Smallest eigenvalue of the structure tensor summed over a corner's patch (gradients in
/// luma per sample) that counts as a corner: below it the patch is flat or a plain edge, whose
/// position along the edge is noise.
pub const MIN_CORNERNESS: f64 = 2e-3;

/// Central-difference gradient of `img` at integer `(x, y)`.
fn gradient(img: &Image, x: isize, y: isize) -> DVec2 {
    DVec2::new(
        0.5 * (img.at(x + 1, y) - img.at(x - 1, y)) as f64,
        0.5 * (img.at(x, y + 1) - img.at(x, y - 1)) as f64,
    )
}

/// The smaller eigenvalue of the structure tensor of the `(2r+1)²` patch around `(x, y)`.
pub fn cornerness(img: &Image, x: isize, y: isize, r: isize) -> f64 {
    let (mut gxx, mut gxy, mut gyy) = (0.0, 0.0, 0.0);
    for v in y - r..=y + r {
        for u in x - r..=x + r {
            let g = gradient(img, u, v);
            gxx += g.x * g.x;
            gxy += g.x * g.y;
            gyy += g.y * g.y;
        }
    }
    let half_trace = 0.5 * (gxx + gyy);
    let det = gxx * gyy - gxy * gxy;
    half_trace - (half_trace * half_trace - det).max(0.0).sqrt()
}

/// Corners of `img`: in each cell of a `cells.0 × cells.1` grid, the sample of largest
/// [`cornerness`] (tested every `step` samples) if it passes [`MIN_CORNERNESS`], away from the
/// border by more than the tracked patch.
pub fn corners(img: &Image, cells: (usize, usize), step: usize) -> Vec<DVec2> {
    let margin = 2 * HALF_WINDOW as usize + 2;
    if img.width <= 2 * margin || img.height <= 2 * margin {
        return Vec::new();
    }
    let (iw, ih) = (img.width - 2 * margin, img.height - 2 * margin);
    let step = step.max(1);
    let mut out = Vec::new();
    for cy in 0..cells.1 {
        for cx in 0..cells.0 {
            let (x0, x1) = (margin + cx * iw / cells.0, margin + (cx + 1) * iw / cells.0);
            let (y0, y1) = (margin + cy * ih / cells.1, margin + (cy + 1) * ih / cells.1);
            let mut best = (MIN_CORNERNESS, None);
            for y in (y0..y1).step_by(step) {
                for x in (x0..x1).step_by(step) {
                    let c = cornerness(img, x as isize, y as isize, 3);
                    if c > best.0 {
                        best = (c, Some(DVec2::new(x as f64, y as f64)));
                    }
                }
            }
            out.extend(best.1);
        }
    }
    out
}

/// Newton steps per level, and the step below which a level is done, samples.
const ITERATIONS: usize = 12;
const CONVERGED: f64 = 0.005;

/// The position in `next` of the patch around `p` in `reference` (level-0 samples), starting
/// from the guess `guess`: pyramidal Lucas–Kanade. `None` where the patch leaves the picture or
/// its normal matrix is singular (a flat or edge-only patch).
pub fn follow(reference: &Pyramid, next: &Pyramid, p: DVec2, guess: DVec2) -> Option<DVec2> {
    let levels = reference.levels.len().min(next.levels.len());
    let top = levels - 1;
    // The displacement at the coarsest level, carried down and refined at each.
    let mut d = (guess - p) / (1u32 << top) as f64;
    let n = (2 * HALF_WINDOW + 1) as usize;
    let mut patch = vec![0.0f64; n * n];
    let mut grads = vec![DVec2::ZERO; n * n];
    for level in (0..levels).rev() {
        let (a, b) = (&reference.levels[level], &next.levels[level]);
        let scale = (1u32 << level) as f64;
        let q = p / scale;
        // The reference patch and its gradients, bilinear at the (sub-sample) corner position.
        let (mut gxx, mut gxy, mut gyy) = (0.0, 0.0, 0.0);
        for (k, (v, u)) in (-HALF_WINDOW..=HALF_WINDOW)
            .flat_map(|v| (-HALF_WINDOW..=HALF_WINDOW).map(move |u| (v, u)))
            .enumerate()
        {
            let (x, y) = (q.x + u as f64, q.y + v as f64);
            patch[k] = a.bilinear(x, y);
            let g = DVec2::new(
                0.5 * (a.bilinear(x + 1.0, y) - a.bilinear(x - 1.0, y)),
                0.5 * (a.bilinear(x, y + 1.0) - a.bilinear(x, y - 1.0)),
            );
            grads[k] = g;
            gxx += g.x * g.x;
            gxy += g.x * g.y;
            gyy += g.y * g.y;
        }
        let det = gxx * gyy - gxy * gxy;
        if det <= 1e-12 * (gxx + gyy).powi(2).max(1e-30) || gxx + gyy <= 0.0 {
            return None;
        }
        for _ in 0..ITERATIONS {
            let (mut bx, mut by) = (0.0, 0.0);
            let c = q + d;
            for (k, (v, u)) in (-HALF_WINDOW..=HALF_WINDOW)
                .flat_map(|v| (-HALF_WINDOW..=HALF_WINDOW).map(move |u| (v, u)))
                .enumerate()
            {
                let e = patch[k] - b.bilinear(c.x + u as f64, c.y + v as f64);
                bx += e * grads[k].x;
                by += e * grads[k].y;
            }
            let step = DVec2::new(gyy * bx - gxy * by, gxx * by - gxy * bx) / det;
            d += step;
            if step.length() < CONVERGED {
                break;
            }
        }
        if level > 0 {
            d *= 2.0;
        }
    }
    let out = p + d;
    let r = HALF_WINDOW as f64;
    let fine = &next.levels[0];
    let inside = out.x >= r
        && out.y >= r
        && out.x <= fine.width as f64 - 1.0 - r
        && out.y <= fine.height as f64 - 1.0 - r;
    (inside && out.is_finite()).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth blob picture, shifted by `shift`.
    fn blobs(w: usize, h: usize, shift: DVec2) -> Image {
        let centres = [(40.0, 30.0), (90.0, 70.0), (150.0, 40.0), (120.0, 100.0)];
        let data = (0..w * h)
            .map(|i| {
                let p = DVec2::new((i % w) as f64, (i / w) as f64) - shift;
                centres
                    .iter()
                    .map(|&(x, y)| {
                        let d2 = (p - DVec2::new(x, y)).length_squared();
                        (-d2 / 18.0).exp()
                    })
                    .sum::<f64>() as f32
            })
            .collect();
        Image {
            width: w,
            height: h,
            data,
        }
    }

    /// Lucas–Kanade finds a known sub-sample shift of a smooth picture, from a guess far off.
    #[test]
    fn follows_a_known_shift() {
        let shift = DVec2::new(13.37, -4.21);
        let a = Pyramid::new(blobs(200, 140, DVec2::ZERO));
        let b = Pyramid::new(blobs(200, 140, shift));
        let p = DVec2::new(90.0, 70.0);
        let q = follow(&a, &b, p, p).expect("tracked");
        assert!((q - p - shift).length() < 0.02, "{q} vs {}", p + shift);
    }

    /// A flat picture has no corners and no track.
    #[test]
    fn a_flat_picture_has_no_corners() {
        let flat = Image {
            width: 120,
            height: 80,
            data: vec![0.5; 120 * 80],
        };
        assert!(corners(&flat, (8, 4), 1).is_empty());
        let p = Pyramid::new(flat);
        assert!(follow(&p, &p, DVec2::new(60.0, 40.0), DVec2::new(60.0, 40.0)).is_none());
    }
}
