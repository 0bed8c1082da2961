//! Straight edges of a frame: a small line-segment detector whose pieces, broken where lines
//! cross, are joined again into the long lines they belong to.
//!
//! Sobel gradients on the downscaled luma; region growing from the strongest edgels over
//! neighbours whose edge direction agrees within 22.5° (as in LSD, von Gioi et al. 2010); a
//! region's line is the principal axis of its gradient-weighted pixels. A paving's joints cross
//! every stone, and where two joints cross the gradient's direction is neither's, so each
//! joint breaks into pieces one stone long: short pieces whose directions are only good to a
//! degree or two, and the far stones give pieces too short to keep at all. Pieces that lie on
//! one line (directions within [`JOIN_DEG`], each end within [`JOIN_OFFSET_PX`] of the other's
//! line, the gap between them shorter than the longer piece) are joined, and the joined line
//! is fitted to all its pixels at once (the weighted moments add): a joint seen across ten
//! stones is one segment ten times as long, whose direction is ten times better than a piece's
//! (the error of a fitted direction falls as the inverse of the length). Window frames on a
//! floor and the posts of a railing join the same way.

use crate::scene::horizon::Luma;

/// A straight edge, in displayed-frame pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// One end, pixels.
    pub a: [f64; 2],
    /// The other end, pixels.
    pub b: [f64; 2],
}

impl Segment {
    /// Length, pixels.
    pub fn length(&self) -> f64 {
        (self.a[0] - self.b[0]).hypot(self.a[1] - self.b[1])
    }
}

/// Gradient magnitude below which a pixel is no edge (luma in [0, 1], Sobel over 8).
pub const MIN_GRAD: f32 = 0.012;

/// Shortest segment kept, work pixels (after joining).
pub const MIN_LEN_PX: f64 = 12.0;

/// Shortest piece considered for joining, work pixels.
pub const MIN_PIECE_PX: f64 = 6.0;

/// Largest angle between two pieces joined into one line, degrees.
pub const JOIN_DEG: f64 = 3.0;

/// Largest distance of a piece's ends from the line it joins, work pixels.
pub const JOIN_OFFSET_PX: f64 = 1.0;

/// Gradient-weighted moments of a set of pixels, and the extent of their line.
#[derive(Debug, Clone, Copy)]
struct Piece {
    s0: f64,
    sx: f64,
    sy: f64,
    sxx: f64,
    sxy: f64,
    syy: f64,
    /// Ends of the extent, work pixels (pixel centres).
    a: [f64; 2],
    b: [f64; 2],
    /// Whether this piece alone passes the thinness test (joined lines always do).
    thin: bool,
    /// Sum of the gradients (the edge's polarity: which side is brighter).
    g: [f64; 2],
}

impl Piece {
    /// Centroid and unit direction of the principal axis.
    fn line(&self) -> ([f64; 2], [f64; 2]) {
        let (mx, my) = (self.sx / self.s0, self.sy / self.s0);
        let cxx = self.sxx / self.s0 - mx * mx;
        let cxy = self.sxy / self.s0 - mx * my;
        let cyy = self.syy / self.s0 - my * my;
        let theta = 0.5 * (2.0 * cxy).atan2(cxx - cyy);
        ([mx, my], [theta.cos(), theta.sin()])
    }

    fn length(&self) -> f64 {
        (self.a[0] - self.b[0]).hypot(self.a[1] - self.b[1])
    }

    /// Whether `other` lies on this piece's line (see the module doc).
    fn joins(&self, other: &Piece) -> bool {
        if self.g[0] * other.g[0] + self.g[1] * other.g[1] <= 0.0 {
            return false;
        }
        let (c, u) = self.line();
        let (_, v) = other.line();
        let cos = (u[0] * v[0] + u[1] * v[1]).abs();
        if cos < JOIN_DEG.to_radians().cos() {
            return false;
        }
        let along = |p: [f64; 2]| (p[0] - c[0]) * u[0] + (p[1] - c[1]) * u[1];
        let across = |p: [f64; 2]| (-(p[0] - c[0]) * u[1] + (p[1] - c[1]) * u[0]).abs();
        if across(other.a) > JOIN_OFFSET_PX || across(other.b) > JOIN_OFFSET_PX {
            return false;
        }
        // And this piece's ends on the other's line (a short piece's direction is loose).
        let (c2, _) = other.line();
        let across2 = |p: [f64; 2]| (-(p[0] - c2[0]) * v[1] + (p[1] - c2[1]) * v[0]).abs();
        if across2(self.a) > 2.0 * JOIN_OFFSET_PX || across2(self.b) > 2.0 * JOIN_OFFSET_PX {
            return false;
        }
        let (s0, s1) = {
            let (p, q) = (along(self.a), along(self.b));
            (p.min(q), p.max(q))
        };
        let (o0, o1) = {
            let (p, q) = (along(other.a), along(other.b));
            (p.min(q), p.max(q))
        };
        let gap = (o0 - s1).max(s0 - o1);
        gap <= self.length().max(other.length())
    }

    /// This piece and `other` as one line: the moments add, the extent spans both.
    fn absorb(&mut self, other: &Piece) {
        self.s0 += other.s0;
        self.sx += other.sx;
        self.sy += other.sy;
        self.sxx += other.sxx;
        self.sxy += other.sxy;
        self.syy += other.syy;
        self.g[0] += other.g[0];
        self.g[1] += other.g[1];
        self.thin = true;
        let (c, u) = self.line();
        let along = |p: [f64; 2]| (p[0] - c[0]) * u[0] + (p[1] - c[1]) * u[1];
        let ts = [along(self.a), along(self.b), along(other.a), along(other.b)];
        let lo = ts.iter().copied().fold(f64::MAX, f64::min);
        let hi = ts.iter().copied().fold(f64::MIN, f64::max);
        self.a = [c[0] + lo * u[0], c[1] + lo * u[1]];
        self.b = [c[0] + hi * u[0], c[1] + hi * u[1]];
    }
}

/// Line segments of `luma` (see the module doc), in frame pixels, longest first, at most
/// `max_count`.
pub fn detect_segments(luma: &Luma, max_count: usize) -> Vec<Segment> {
    let grad = Gradient::new(luma);
    let mut pieces = regions(&grad);
    join(&mut pieces);
    let s = luma.scale as f64;
    let to_frame = |p: [f64; 2]| [(p[0] + 0.5) * s, (p[1] + 0.5) * s];
    let mut segs: Vec<Segment> = pieces
        .iter()
        .filter(|p| p.thin && p.length() + 1.0 >= MIN_LEN_PX)
        .map(|p| {
            let (a, b) = grad.refit(p.a, p.b, p.g).unwrap_or((p.a, p.b));
            Segment {
                a: to_frame(a),
                b: to_frame(b),
            }
        })
        .collect();
    segs.sort_by(|a, b| b.length().total_cmp(&a.length()));
    segs.truncate(max_count);
    segs
}

/// Joins pieces on one line, longest first, until none joins (see the module doc).
fn join(pieces: &mut Vec<Piece>) {
    pieces.sort_by(|a, b| b.length().total_cmp(&a.length()));
    let mut alive = vec![true; pieces.len()];
    for i in 0..pieces.len() {
        if !alive[i] {
            continue;
        }
        let mut line = pieces[i];
        loop {
            let mut grew = false;
            for j in i + 1..pieces.len() {
                if alive[j] && line.joins(&pieces[j]) {
                    line.absorb(&pieces[j]);
                    alive[j] = false;
                    grew = true;
                }
            }
            if !grew {
                break;
            }
        }
        pieces[i] = line;
    }
    let mut k = 0;
    pieces.retain(|_| {
        k += 1;
        alive[k - 1]
    });
}

/// Sobel gradients of a luma picture.
struct Gradient {
    w: usize,
    h: usize,
    gx: Vec<f32>,
    gy: Vec<f32>,
    mag: Vec<f32>,
    /// The gradient's direction, radians (mod 2π: the two sides of a thin dark line are two
    /// edges, of opposite polarity).
    ang: Vec<f32>,
}

impl Gradient {
    fn new(luma: &Luma) -> Gradient {
        let (w, h) = (luma.width, luma.height);
        let mut g = Gradient {
            w,
            h,
            gx: vec![0.0; w * h],
            gy: vec![0.0; w * h],
            mag: vec![0.0; w * h],
            ang: vec![0.0; w * h],
        };
        if w < 3 || h < 3 {
            return g;
        }
        let px = |x: usize, y: usize| luma.data[y * w + x];
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let gx = (px(x + 1, y - 1) + 2.0 * px(x + 1, y) + px(x + 1, y + 1))
                    - (px(x - 1, y - 1) + 2.0 * px(x - 1, y) + px(x - 1, y + 1));
                let gy = (px(x - 1, y + 1) + 2.0 * px(x, y + 1) + px(x + 1, y + 1))
                    - (px(x - 1, y - 1) + 2.0 * px(x, y - 1) + px(x + 1, y - 1));
                let (gx, gy) = (gx / 8.0, gy / 8.0);
                let i = y * w + x;
                g.gx[i] = gx;
                g.gy[i] = gy;
                g.mag[i] = gx.hypot(gy);
                g.ang[i] = gy.atan2(gx);
            }
        }
        g
    }

    /// The gradient's component along the unit `n`, bilinear at `p` (work pixels), where
    /// positive.
    fn across(&self, p: [f64; 2], n: [f64; 2]) -> f64 {
        let (x, y) = (p[0], p[1]);
        if x < 1.0 || y < 1.0 || x >= (self.w - 2) as f64 || y >= (self.h - 2) as f64 {
            return 0.0;
        }
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let at = |i: usize| (self.gx[i] as f64 * n[0] + self.gy[i] as f64 * n[1]).max(0.0);
        let i = y0 * self.w + x0;
        (1.0 - fy) * ((1.0 - fx) * at(i) + fx * at(i + 1))
            + fy * ((1.0 - fx) * at(i + self.w) + fx * at(i + self.w + 1))
    }

    /// The line from `a` to `b` fitted again to the edge's sub-pixel position across it (see
    /// the module doc): `None` where too little of it shows an edge.
    fn refit(&self, a: [f64; 2], b: [f64; 2], g: [f64; 2]) -> Option<([f64; 2], [f64; 2])> {
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        if len < 2.0 {
            return None;
        }
        let u = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
        // The normal on the edge's brighter side (its gradient's sense).
        let n = if g[1] * u[0] - g[0] * u[1] >= 0.0 {
            [-u[1], u[0]]
        } else {
            [u[1], -u[0]]
        };
        // (t along, s across, weight) of the edge's centroid at each step along.
        let mut pts: Vec<(f64, f64, f64)> = Vec::new();
        let steps = len.floor() as usize;
        for k in 0..=steps {
            let t = k as f64 * len / steps.max(1) as f64;
            let (mut sw, mut ss) = (0.0, 0.0);
            for j in -REFIT_HALF..=REFIT_HALF {
                let s = 0.5 * j as f64;
                let p = [a[0] + t * u[0] + s * n[0], a[1] + t * u[1] + s * n[1]];
                let g = self.across(p, n);
                sw += g;
                ss += g * s;
            }
            if sw > 2.0 * MIN_GRAD as f64 {
                pts.push((t, ss / sw, sw));
            }
        }
        if pts.len() < (0.5 * steps as f64) as usize || pts.len() < 4 {
            return None;
        }
        // s = c0 + c1 t by weighted least squares, twice dropping points off by over half a
        // pixel (a crossing joint, a corner).
        let (mut c0, mut c1) = (0.0, 0.0);
        for round in 0..3 {
            let (mut s0, mut st, mut ss, mut stt, mut sts) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for &(t, s, w) in &pts {
                if round > 0 && (s - c0 - c1 * t).abs() > REFIT_REJECT_PX {
                    continue;
                }
                s0 += w;
                st += w * t;
                ss += w * s;
                stt += w * t * t;
                sts += w * t * s;
            }
            let det = s0 * stt - st * st;
            if s0 <= 0.0 || det.abs() < 1e-12 {
                return None;
            }
            c1 = (s0 * sts - st * ss) / det;
            c0 = (ss - c1 * st) / s0;
        }
        let at = |t: f64| {
            let s = c0 + c1 * t;
            [a[0] + t * u[0] + s * n[0], a[1] + t * u[1] + s * n[1]]
        };
        Some((at(0.0), at(len)))
    }
}

/// Half-width of the profile across a line in its refit, half pixels.
const REFIT_HALF: i32 = 4;

/// Points of a refit farther than this from the line are dropped, work pixels.
const REFIT_REJECT_PX: f64 = 0.5;

/// The regions of agreeing edge direction, as pieces (see the module doc).
fn regions(grad: &Gradient) -> Vec<Piece> {
    let (w, h) = (grad.w, grad.h);
    if w < 3 || h < 3 {
        return Vec::new();
    }
    let (mag, ang) = (&grad.mag, &grad.ang);
    let tol = 22.5f32.to_radians();
    let mut order: Vec<u32> = (0..(w * h) as u32)
        .filter(|&i| mag[i as usize] > MIN_GRAD)
        .collect();
    order.sort_unstable_by(|&a, &b| mag[b as usize].total_cmp(&mag[a as usize]));
    let mut used = vec![false; w * h];
    let mut pieces = Vec::new();
    let mut region: Vec<u32> = Vec::new();
    let mut stack: Vec<u32> = Vec::new();
    let diff = |a: f32, b: f32| {
        let d = (a - b).rem_euclid(std::f32::consts::TAU);
        d.min(std::f32::consts::TAU - d)
    };
    for &seed in &order {
        if used[seed as usize] {
            continue;
        }
        region.clear();
        stack.clear();
        used[seed as usize] = true;
        stack.push(seed);
        let (mut c2, mut s2) = (0.0f32, 0.0f32);
        let mut mean;
        while let Some(i) = stack.pop() {
            region.push(i);
            let a = ang[i as usize];
            c2 += a.cos();
            s2 += a.sin();
            mean = s2.atan2(c2);
            let (x, y) = ((i as usize % w) as isize, (i as usize / w) as isize);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 1 || ny < 1 || nx >= w as isize - 1 || ny >= h as isize - 1 {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if !used[j] && mag[j] > MIN_GRAD && diff(ang[j], mean) < tol {
                        used[j] = true;
                        stack.push(j as u32);
                    }
                }
            }
        }
        if region.len() < 4 {
            continue;
        }
        let mut p = Piece {
            s0: 0.0,
            sx: 0.0,
            sy: 0.0,
            sxx: 0.0,
            sxy: 0.0,
            syy: 0.0,
            a: [0.0; 2],
            b: [0.0; 2],
            thin: false,
            g: [0.0; 2],
        };
        for &i in &region {
            let m = mag[i as usize] as f64;
            let (x, y) = ((i as usize % w) as f64, (i as usize / w) as f64);
            p.s0 += m;
            p.sx += m * x;
            p.sy += m * y;
            p.sxx += m * x * x;
            p.sxy += m * x * y;
            p.syy += m * y * y;
            p.g[0] += grad.gx[i as usize] as f64;
            p.g[1] += grad.gy[i as usize] as f64;
        }
        let (c, u) = p.line();
        let (mut lo, mut hi, mut wlo, mut whi) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &i in &region {
            let (dx, dy) = (
                (i as usize % w) as f64 - c[0],
                (i as usize / w) as f64 - c[1],
            );
            let along = dx * u[0] + dy * u[1];
            let across = -dx * u[1] + dy * u[0];
            lo = lo.min(along);
            hi = hi.max(along);
            wlo = wlo.min(across);
            whi = whi.max(across);
        }
        let (len, width) = (hi - lo + 1.0, whi - wlo + 1.0);
        // Thin pieces join; a piece may be a little wider than a fifth of its length (a short
        // Sobel edge is two or three pixels wide) only to join others.
        if len < MIN_PIECE_PX || width > (0.2 * len).max(3.0) {
            continue;
        }
        p.thin = len >= MIN_LEN_PX && width <= 0.2 * len;
        p.a = [c[0] + lo * u[0], c[1] + lo * u[1]];
        p.b = [c[0] + hi * u[0], c[1] + hi * u[1]];
        pieces.push(p);
    }
    pieces
}
