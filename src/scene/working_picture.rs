//! The picture the ground mask is found in: a frame larger than [`WORKING_PX`] on its longer
//! side reduced to it by a box filter, so the mask's thresholds in pixels hold for what the
//! frame shows whatever its resolution.

use rayon::prelude::*;

use crate::video::YuvFrame;

/// Row `y` of plane `i` of `frame` as codes into `out` (`n` samples).
pub(super) fn plane_row(frame: &YuvFrame, i: usize, y: usize, n: usize, out: &mut Vec<i64>) {
    let p = &frame.planes[i];
    let row = &p.data[y * p.stride..];
    out.clear();
    if frame.format.bytes_per_sample() == 1 {
        out.extend(row[..n].iter().map(|&v| i64::from(v)));
    } else {
        out.extend(
            row[..2 * n]
                .chunks_exact(2)
                .map(|b| i64::from(u16::from_le_bytes([b[0], b[1]]))),
        );
    }
}

/// The longer side, pixels, of the picture the mask is found in: its thresholds (steps and
/// texture between neighbouring pixels, blocks of a cell, bridges of so many cells) hold for
/// what a picture of this size shows of a scene, so a larger frame is first reduced to it.
pub const WORKING_PX: u32 = 640;

/// The size of the picture the mask of a `size` frame is found in: the frame's own up to
/// [`WORKING_PX`] on its longer side, else reduced to it, its aspect kept.
pub fn working_size(size: (u32, u32)) -> (u32, u32) {
    let long = size.0.max(size.1);
    if long <= WORKING_PX {
        return size;
    }
    let scale = f64::from(WORKING_PX) / f64::from(long);
    let side = |n: u32| ((f64::from(n) * scale).round() as u32).max(2);
    (side(size.0), side(size.1))
}

/// Plane `i` of `frame` reduced to `to` samples by a box filter: each source sample counts
/// once, toward the reduced sample its centre falls in (a 3 × 3 box from 1920 × 1080 to
/// 640 × 360), the mean rounded.
fn reduce_plane(frame: &YuvFrame, i: usize, to: (u32, u32)) -> Vec<u16> {
    let (w, h) = frame.format.plane_size(i);
    let (w, h, tw, th) = (w as usize, h as usize, to.0 as usize, to.1 as usize);
    let column: Vec<usize> = (0..w).map(|x| ((2 * x + 1) * tw) / (2 * w)).collect();
    // The first source row whose centre falls in reduced row r: (2y + 1) · th ≥ 2 · r · h.
    let first_row = |r: usize| (2 * r * h).saturating_sub(th).div_ceil(2 * th);
    let mut out = vec![0u16; tw * th];
    out.par_chunks_mut(tw).enumerate().for_each(|(r, out)| {
        let (lo, hi) = (first_row(r).min(h), first_row(r + 1).min(h));
        // The band's rows summed per column (a loop that vectorises), then the columns into
        // their reduced samples.
        let (mut columns, mut row) = (vec![0i64; w], Vec::new());
        for y in lo..hi {
            plane_row(frame, i, y, w, &mut row);
            for (c, v) in columns.iter_mut().zip(&row) {
                *c += v;
            }
        }
        let (mut sum, mut count) = (vec![0i64; tw], vec![0i64; tw]);
        for (x, v) in columns.iter().enumerate() {
            sum[column[x]] += v;
            count[column[x]] += 1;
        }
        let rows = (hi - lo) as i64;
        for ((o, s), c) in out.iter_mut().zip(&sum).zip(&count) {
            let n = c * rows;
            *o = if n == 0 { 0 } else { ((s + n / 2) / n) as u16 };
        }
    });
    out
}

/// `frame` reduced to `to` pixels (its chroma, bit depth and colour kept), by
/// [`reduce_plane`].
pub(super) fn reduce(frame: &YuvFrame, to: (u32, u32)) -> YuvFrame {
    let format = crate::video::frame::FrameFormat {
        width: to.0,
        height: to.1,
        ..frame.format
    };
    let mut small = YuvFrame::filled(format, frame.color, [0, 0, 0]);
    for i in 0..3 {
        let samples = reduce_plane(frame, i, format.plane_size(i));
        small.planes[i].data = if format.bytes_per_sample() == 1 {
            samples.iter().map(|&v| v as u8).collect()
        } else {
            samples.iter().flat_map(|v| v.to_le_bytes()).collect()
        };
    }
    small
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::video::ColorParams;
    use crate::video::frame::{Chroma, FrameFormat};

    /// The reduction's samples are the rounded means of the source samples whose centres fall
    /// in each reduced sample (a brute-force search over the source per reduced sample), for
    /// whole and fractional ratios, 8 and 10 bits, 4:2:0 and 4:4:4; and the working size keeps
    /// the aspect and leaves a 640 px picture alone.
    #[test]
    fn the_reduction_is_the_box_mean() {
        for (size, to, bit_depth, chroma) in [
            ((60u32, 34u32), (20u32, 11u32), 8u8, Chroma::Cs420),
            ((45, 31), (16, 11), 10, Chroma::Cs444),
            ((37, 23), (13, 9), 8, Chroma::Cs420),
        ] {
            let format = FrameFormat {
                width: size.0,
                height: size.1,
                chroma,
                bit_depth,
            };
            let mut f = YuvFrame::filled(format, ColorParams::bt709(bit_depth), [16, 128, 128]);
            let max = (1u64 << bit_depth) - 1;
            for (i, plane) in f.planes.iter_mut().enumerate() {
                let n = plane.data.len() / format.bytes_per_sample();
                let v = |k: usize| crate::rng::splitmix64((i * 1_000_003 + k) as u64) % (max + 1);
                plane.data = if bit_depth > 8 {
                    (0..n).flat_map(|k| (v(k) as u16).to_le_bytes()).collect()
                } else {
                    (0..n).map(|k| v(k) as u8).collect()
                };
            }
            let small = reduce(&f, to);
            let reduced = small.format;
            for i in 0..3 {
                let (w, h) = format.plane_size(i);
                let (tw, th) = reduced.plane_size(i);
                for ty in 0..th {
                    for tx in 0..tw {
                        // Source samples whose centre (x + ½) · tw / w lies in [tx, tx + 1).
                        let inside = |x: u32, n: u32, t: u32, at: u32| {
                            let c = (f64::from(x) + 0.5) * f64::from(t) / f64::from(n);
                            c >= f64::from(at) && c < f64::from(at + 1)
                        };
                        let (mut sum, mut count) = (0u64, 0u64);
                        for y in (0..h).filter(|&y| inside(y, h, th, ty)) {
                            for x in (0..w).filter(|&x| inside(x, w, tw, tx)) {
                                sum += u64::from(f.sample(i, x, y));
                                count += 1;
                            }
                        }
                        assert!(count > 0, "{size:?} plane {i} at {tx}, {ty}");
                        let mean = (sum as f64 / count as f64).round();
                        let got = f64::from(small.sample(i, tx, ty));
                        assert!(
                            (got - mean).abs() <= 0.5,
                            "{size:?} → {to:?} plane {i} at {tx}, {ty}: {got} against {mean}"
                        );
                    }
                }
            }
        }
        assert_eq!(working_size((1920, 1080)), (640, 360));
        assert_eq!(working_size((1080, 1920)), (360, 640));
        assert_eq!(working_size((1440, 1080)), (640, 480));
        assert_eq!(working_size((640, 360)), (640, 360));
        assert_eq!(working_size((320, 180)), (320, 180));
    }
}
