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

/// Half the side of the patch [`corners`] scores, samples.
pub const CORNER_RADIUS: usize = 3;

/// [`cornerness`] with radius [`CORNER_RADIUS`] at every sample at least `CORNER_RADIUS + 1`
/// from the border (0 elsewhere): the gradients' products once per sample, summed over the
/// patch by a running box sum along rows then columns, so the cost is a few passes over the
/// picture instead of a patch per sample.
pub fn cornerness_map(img: &Image) -> Vec<f64> {
    let (w, h) = (img.width, img.height);
    let r = CORNER_RADIUS;
    let mut out = vec![0.0; w * h];
    if w < 2 * r + 3 || h < 2 * r + 3 {
        return out;
    }
    // Gradient products at every sample (central differences, clamped as `gradient` is).
    let mut products = vec![[0.0f64; 3]; w * h];
    for y in 0..h {
        for x in 0..w {
            let g = gradient(img, x as isize, y as isize);
            products[y * w + x] = [g.x * g.x, g.x * g.y, g.y * g.y];
        }
    }
    // Sums over 2r + 1 samples along each row, centred (valid where the window fits).
    let mut rows = vec![[0.0f64; 3]; w * h];
    for y in 0..h {
        let line = &products[y * w..(y + 1) * w];
        let mut acc = [0.0f64; 3];
        for p in &line[..2 * r + 1] {
            (0..3).for_each(|k| acc[k] += p[k]);
        }
        for x in r..w - r {
            rows[y * w + x] = acc;
            if x + r + 1 < w {
                (0..3).for_each(|k| acc[k] += line[x + r + 1][k] - line[x - r][k]);
            }
        }
    }
    // Then along each column, and the smaller eigenvalue.
    for x in r..w - r {
        let mut acc = [0.0f64; 3];
        for y in 0..2 * r + 1 {
            (0..3).for_each(|k| acc[k] += rows[y * w + x][k]);
        }
        for y in r..h - r {
            let [gxx, gxy, gyy] = acc;
            let half_trace = 0.5 * (gxx + gyy);
            let det = gxx * gyy - gxy * gxy;
            out[y * w + x] = half_trace - (half_trace * half_trace - det).max(0.0).sqrt();
            if y + r + 1 < h {
                (0..3).for_each(|k| {
                    acc[k] += rows[(y + r + 1) * w + x][k] - rows[(y - r) * w + x][k]
                });
            }
        }
    }
    out
}

/// Corners of `img`: in each cell of a `cells.0 × cells.1` grid, the sample of largest
/// [`cornerness`] (tested every `step` samples) if it passes [`MIN_CORNERNESS`], away from the
/// border by more than the tracked patch.
pub fn corners(img: &Image, cells: (usize, usize), step: usize) -> Vec<DVec2> {
    let margin = 2 * HALF_WINDOW as usize + 2;
    if img.width <= 2 * margin || img.height <= 2 * margin {
        return Vec::new();
    }
    let map = cornerness_map(img);
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
                    let c = map[y * img.width + x];
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
const ITERATIONS: usize = 10;
const CONVERGED: f64 = 0.01;

/// The position in `next` of the patch around `p` in `reference` (level-0 samples), starting
/// from the guess `guess`: pyramidal Lucas–Kanade. `None` where the patch leaves the picture or
/// its normal matrix is singular (a flat or edge-only patch).
pub fn follow(reference: &Pyramid, next: &Pyramid, p: DVec2, guess: DVec2) -> Option<DVec2> {
    let levels = reference.levels.len().min(next.levels.len());
    let top = levels - 1;
    // The displacement at the coarsest level, carried down and refined at each.
    let mut d = (guess - p) / (1u32 << top) as f64;
    let n = (2 * HALF_WINDOW + 1) as usize;
    // The patch with a border of one sample, for its central differences.
    let m = n + 2;
    let mut ring = vec![0.0f64; m * m];
    let mut patch = vec![0.0f64; n * n];
    let mut grads = vec![DVec2::ZERO; n * n];
    for level in (0..levels).rev() {
        let (a, b) = (&reference.levels[level], &next.levels[level]);
        let scale = (1u32 << level) as f64;
        let q = p / scale;
        // The reference patch and its gradients, bilinear at the (sub-sample) corner position.
        for (k, v) in ring.iter_mut().enumerate() {
            let (u, w) = ((k % m) as f64 - 1.0, (k / m) as f64 - 1.0);
            *v = a.bilinear(q.x + u - HALF_WINDOW as f64, q.y + w - HALF_WINDOW as f64);
        }
        let (mut gxx, mut gxy, mut gyy) = (0.0, 0.0, 0.0);
        for k in 0..n * n {
            let c = (k / n + 1) * m + k % n + 1;
            patch[k] = ring[c];
            let g = DVec2::new(
                0.5 * (ring[c + 1] - ring[c - 1]),
                0.5 * (ring[c + m] - ring[c - m]),
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

    /// The running-sum cornerness map equals the patch-by-patch reference.
    #[test]
    fn the_cornerness_map_is_the_plain_sum() {
        let img = blobs(90, 60, DVec2::new(0.3, -0.7));
        let map = cornerness_map(&img);
        let r = CORNER_RADIUS as isize;
        for y in r..60 - r {
            for x in r..90 - r {
                let want = cornerness(&img, x, y, r);
                let got = map[y as usize * 90 + x as usize];
                assert!(
                    (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
                    "{x},{y}: {got} vs {want}"
                );
            }
        }
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
