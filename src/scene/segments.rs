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

/// A piece's line: its centroid and the unit direction of its principal axis, work pixels.
type Line = ([f64; 2], [f64; 2]);

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
    fn line(&self) -> Line {
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
    #[cfg(test)]
    fn joins(&self, other: &Piece) -> bool {
        self.joins_lines(self.line(), other, other.line())
    }

    /// [`Piece::joins`] with both pieces' lines ([`Piece::line`]) given.
    fn joins_lines(&self, mine: Line, other: &Piece, theirs: Line) -> bool {
        if self.g[0] * other.g[0] + self.g[1] * other.g[1] <= 0.0 {
            return false;
        }
        let (c, u) = mine;
        let (c2, v) = theirs;
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

    /// This piece and `other` as one line: the moments add, the extent spans both. Returns
    /// the joined piece's line.
    fn absorb(&mut self, other: &Piece) -> Line {
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
        (c, u)
    }
}

/// Line segments of `luma` (see the module doc), in frame pixels, longest first, at most
/// `max_count`.
pub fn detect_segments(luma: &Luma, max_count: usize) -> Vec<Segment> {
    detect_with(luma, max_count, regions, join)
}

/// [`detect_segments`] with the regions grown by `regions` and the pieces joined by `join`.
fn detect_with(
    luma: &Luma,
    max_count: usize,
    regions: fn(&Gradient) -> Vec<Piece>,
    join: fn(&mut Vec<Piece>),
) -> Vec<Segment> {
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

/// Joins pieces on one line, longest first, until none joins (see the module doc). The same
/// tests on the same values as [`join_plain`], in the same order, less two costs: each
/// piece's line (an arctangent, a sine and a cosine) is computed once, and the growing line's
/// once per piece it takes in; and only pieces whose direction lies within [`JOIN_DEG`] (and
/// a margin) of the growing line's are tested, found in bins of direction (the pairs' loop
/// was most of a 640-pixel picture's detection, and all but a few per cent of its pairs fail
/// on their directions).
fn join(pieces: &mut Vec<Piece>) {
    pieces.sort_by(|a, b| b.length().total_cmp(&a.length()));
    let lines: Vec<Line> = pieces.iter().map(Piece::line).collect();
    let bins = DirectionBins::new(&lines);
    let mut alive = vec![true; pieces.len()];
    let mut candidates = Vec::new();
    for i in 0..pieces.len() {
        if !alive[i] {
            continue;
        }
        let mut line = pieces[i];
        let mut own = lines[i];
        loop {
            let mut grew = false;
            bins.near(own.1, i + 1, &mut candidates);
            let mut k = 0;
            while let Some(&j) = candidates.get(k) {
                k += 1;
                if alive[j] && line.joins_lines(own, &pieces[j], lines[j]) {
                    own = line.absorb(&pieces[j]);
                    alive[j] = false;
                    grew = true;
                    // The line turned: the pieces after this one near its new direction.
                    bins.near(own.1, j + 1, &mut candidates);
                    k = 0;
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

/// Bins of direction for [`join`]: the pieces (their indices, ascending) whose lines' angle
/// modulo π falls in each degree.
struct DirectionBins {
    bins: Vec<Vec<usize>>,
}

impl DirectionBins {
    fn new(lines: &[Line]) -> DirectionBins {
        let mut bins = vec![Vec::new(); 180];
        for (i, (_, u)) in lines.iter().enumerate() {
            bins[Self::bin(*u)].push(i);
        }
        DirectionBins { bins }
    }

    /// The bin of the unit direction `u`.
    fn bin(u: [f64; 2]) -> usize {
        let deg = u[1].atan2(u[0]).to_degrees().rem_euclid(180.0);
        (deg as usize).min(179)
    }

    /// Into `out`, ascending: the pieces from `from` on whose direction is within
    /// [`JOIN_DEG`] of `u` (modulo π), and some within a degree more (every piece
    /// [`Piece::joins_lines`] could take in: its cosine test holds only within that angle,
    /// and the bins' edges are good to far better than a degree).
    fn near(&self, u: [f64; 2], from: usize, out: &mut Vec<usize>) {
        out.clear();
        let reach = JOIN_DEG as isize + 1;
        let b = Self::bin(u) as isize;
        for d in -reach..=reach {
            let list = &self.bins[(b + d).rem_euclid(180) as usize];
            out.extend_from_slice(&list[list.partition_point(|&j| j < from)..]);
        }
        out.sort_unstable();
    }
}

/// [`join`] in its plain form, both lines recomputed for every pair: the reference it is
/// tested against.
#[cfg(test)]
fn join_plain(pieces: &mut Vec<Piece>) {
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
                // Only edgels' directions are read (see [`regions`]).
                if g.mag[i] > MIN_GRAD {
                    g.ang[i] = gy.atan2(gx);
                }
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

/// [`regions`] in its plain form: each pixel's direction from its gradient where read, every
/// neighbour tested against the picture's border and the region's mean direction recomputed
/// for every pixel taken; the reference it is tested against.
#[cfg(test)]
fn regions_plain(grad: &Gradient) -> Vec<Piece> {
    let (w, h) = (grad.w, grad.h);
    if w < 3 || h < 3 {
        return Vec::new();
    }
    let mag = &grad.mag;
    let ang = |i: usize| grad.gy[i].atan2(grad.gx[i]);
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
            let a = ang(i as usize);
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
                    if !used[j] && mag[j] > MIN_GRAD && diff(ang(j), mean) < tol {
                        used[j] = true;
                        stack.push(j as u32);
                    }
                }
            }
        }
        if let Some(p) = piece(grad, &region) {
            pieces.push(p);
        }
    }
    pieces
}

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
    // Edgels not yet in a region. Border pixels have no gradient, so they are never open,
    // and an open pixel's eight neighbours all lie in the picture.
    let mut open: Vec<bool> = mag.iter().map(|&m| m > MIN_GRAD).collect();
    let mut pieces = Vec::new();
    let mut region: Vec<u32> = Vec::new();
    let mut stack: Vec<u32> = Vec::new();
    let diff = |a: f32, b: f32| {
        let d = (a - b).rem_euclid(std::f32::consts::TAU);
        d.min(std::f32::consts::TAU - d)
    };
    // The eight neighbours, row by row (the order they join the stack in).
    let wi = w as isize;
    let neighbours = [-wi - 1, -wi, -wi + 1, -1, 1, wi - 1, wi, wi + 1];
    for &seed in &order {
        if !open[seed as usize] {
            continue;
        }
        region.clear();
        stack.clear();
        open[seed as usize] = false;
        stack.push(seed);
        let (mut c2, mut s2) = (0.0f32, 0.0f32);
        while let Some(i) = stack.pop() {
            region.push(i);
            let a = ang[i as usize];
            c2 += a.cos();
            s2 += a.sin();
            // The region's mean direction, computed only where a neighbour is open (most of
            // a thin edge's neighbours are not).
            let mut mean = None;
            for d in neighbours {
                let j = (i as isize + d) as usize;
                if open[j] && diff(ang[j], *mean.get_or_insert_with(|| s2.atan2(c2))) < tol {
                    open[j] = false;
                    stack.push(j as u32);
                }
            }
        }
        if let Some(p) = piece(grad, &region) {
            pieces.push(p);
        }
    }
    pieces
}

/// The piece of a region of pixels: its gradient-weighted moments and the extent of its line;
/// `None` where it is too short or too wide to be part of a line.
fn piece(grad: &Gradient, region: &[u32]) -> Option<Piece> {
    if region.len() < 4 {
        return None;
    }
    let (w, mag) = (grad.w, &grad.mag);
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
    for &i in region {
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
    for &i in region {
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
        return None;
    }
    p.thin = len >= MIN_LEN_PX && width <= 0.2 * len;
    p.a = [c[0] + lo * u[0], c[1] + lo * u[1]];
    p.b = [c[0] + hi * u[0], c[1] + hi * u[1]];
    Some(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The street sample's frames at the working width and at twice it (the finer pass), and
    /// a paving of stones whose joints cross every stone: [`regions`] grows the pieces of
    /// [`regions_plain`] and [`join`] joins them as [`join_plain`] does, bit for bit, where
    /// tens to hundreds of pieces join.
    #[test]
    fn the_fast_detection_finds_the_plain_ones_segments() {
        let mut pictures = Vec::new();
        let mut source = crate::video::Source::open("samples/street.mp4").expect("sample");
        for at_s in [0.2, 1.4, 2.6] {
            let frame = source.seek_to_time(at_s).expect("frame");
            for width in [320, 640] {
                pictures.push(Luma::from_frame(&frame, 0, width));
            }
        }
        // Stones of 23 × 17 pixels seen square-on, a joint one pixel wide and a little
        // darker each row, turned 7° so that no joint is a pixel row.
        let (w, h) = (400, 300);
        let (sin, cos) = 7f64.to_radians().sin_cos();
        let data = (0..w * h)
            .map(|k| {
                let (x, y) = ((k % w) as f64, (k / w) as f64);
                let (u, v) = (x * cos + y * sin, y * cos - x * sin + 400.0);
                let joint = u.rem_euclid(23.0) < 1.0 || v.rem_euclid(17.0) < 1.0;
                if joint { 0.2 + 0.001 * y as f32 } else { 0.6 }
            })
            .collect();
        pictures.push(Luma {
            width: w,
            height: h,
            data,
            scale: 1,
        });
        let moments = |p: &Vec<Piece>| {
            p.iter()
                .flat_map(|p| {
                    [
                        p.s0, p.sx, p.sy, p.sxx, p.sxy, p.syy, p.a[0], p.a[1], p.b[0], p.b[1],
                    ]
                    .map(f64::to_bits)
                })
                .collect::<Vec<_>>()
        };
        for luma in &pictures {
            let grad = Gradient::new(luma);
            let pieces = regions(&grad).len();
            let (mut fast, mut plain) = (regions(&grad), regions_plain(&grad));
            assert_eq!(moments(&fast), moments(&plain));
            join(&mut fast);
            join_plain(&mut plain);
            assert!(
                pieces >= fast.len() + 10,
                "{pieces} pieces joined into {}",
                fast.len()
            );
            let bits = |s: Vec<Segment>| {
                s.iter()
                    .flat_map(|s| [s.a[0], s.a[1], s.b[0], s.b[1]].map(f64::to_bits))
                    .collect::<Vec<_>>()
            };
            assert_eq!(
                bits(detect_with(luma, usize::MAX, regions, join)),
                bits(detect_with(luma, usize::MAX, regions_plain, join_plain))
            );
            assert_eq!(moments(&fast), moments(&plain));
        }
    }
}
