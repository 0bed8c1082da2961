//! Which frames a job renders: the frame range, and the cut of frames and copied packets
//! (audio) at its bounds so chunks joined with `ffmpeg -f concat -c copy` equal the full render.

use crate::video::{CopiedPacket, VideoInfo, YuvFrame};
use crate::{Error, Result};

/// Which frames of the shot a job renders. A chunk holds exactly the frames, and the packets
/// of the copied streams (audio), that a full render writes between its bounds, with the same
/// timestamps, so chunks joined with `ffmpeg -f concat -c copy` are the full render.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum FrameRange {
    /// The whole shot.
    #[default]
    All,
    /// Frames whose zero-based index (presentation order) is in `[start, end)`; no end: to
    /// the last frame.
    Indices {
        /// First frame rendered.
        start: u64,
        /// First frame not rendered.
        end: Option<u64>,
    },
    /// Frames whose time (seconds from the first frame) is in `[from_s, to_s)`.
    Times {
        /// Earliest time rendered.
        from_s: f64,
        /// First time not rendered.
        to_s: Option<f64>,
    },
}

impl std::fmt::Display for FrameRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let end = |e: Option<String>| e.unwrap_or_default();
        match *self {
            FrameRange::All => write!(f, "all frames"),
            FrameRange::Indices { start, end: e } => {
                write!(f, "frames {start}..{}", end(e.map(|e| e.to_string())))
            }
            FrameRange::Times { from_s, to_s } => match to_s {
                Some(to_s) => write!(f, "times {from_s} s..{to_s} s"),
                None => write!(f, "times from {from_s} s on"),
            },
        }
    }
}

impl FrameRange {
    /// Where a frame of index `index` shown at `t_s` lies: before the range, in it, or after.
    pub(super) fn place(&self, index: u64, t_s: f64) -> std::cmp::Ordering {
        use std::cmp::Ordering::*;
        let (start, end) = match *self {
            FrameRange::All => return Equal,
            FrameRange::Indices { start, end } => (index < start, end.is_some_and(|e| index >= e)),
            FrameRange::Times { from_s, to_s } => (t_s < from_s, to_s.is_some_and(|e| t_s >= e)),
        };
        match (start, end) {
            (true, _) => Less,
            (false, true) => Greater,
            _ => Equal,
        }
    }

    /// About when the range starts, seconds from the first frame (where to start decoding).
    pub(super) fn start_s(&self, info: &VideoInfo) -> f64 {
        match *self {
            FrameRange::All => 0.0,
            FrameRange::Indices { start, .. } => {
                let (num, den) = info.nominal_fps();
                start as f64 * den as f64 / num.max(1) as f64
            }
            FrameRange::Times { from_s, .. } => from_s,
        }
    }

    /// Rejects an empty or reversed range.
    pub fn validate(&self) -> Result<()> {
        let empty = match *self {
            FrameRange::All => false,
            FrameRange::Indices { start, end } => end.is_some_and(|e| e <= start),
            FrameRange::Times { from_s, to_s } => {
                !(from_s.is_finite() && from_s >= 0.0)
                    || to_s.is_some_and(|e| !e.is_finite() || e <= from_s)
            }
        };
        if empty {
            return Err(Error::Parameter {
                name: "job.frames",
                value: self.to_string(),
                expected: "a range that starts at or after 0 and ends after it starts".into(),
            });
        }
        Ok(())
    }
}

/// How far apart in time a container may store the packets of its streams (audio against
/// video), seconds. A chunk decodes this much before its first frame and reads this much past
/// its last, so every audio packet inside its bounds is seen.
pub(super) const INTERLEAVE_SLACK_S: f64 = 2.0;

/// Whether the packet time `a` (pts, time base) is before `b`, exactly.
fn earlier((pa, (na, da)): (i64, (i32, i32)), (pb, (nb, db)): (i64, (i32, i32))) -> bool {
    // pa·na/da < pb·nb/db with positive denominators, in integers.
    let wide = |x: i64, y: i32, z: i32| i128::from(x) * i128::from(y) * i128::from(z);
    wide(pa, na, db) < wide(pb, nb, da)
}

/// What to do with a frame, for [`ChunkCut`].
pub(super) enum Cut {
    /// Before the chunk: feed the light only.
    Before,
    /// In the chunk: render it, after writing these held packets.
    In(Vec<CopiedPacket>),
    /// After the chunk, while packets of its time may still come: skip it, writing these
    /// held packets.
    After(Vec<CopiedPacket>),
    /// Far enough past the chunk: stop reading.
    Done,
}

/// Cuts a job's frames and copied packets to its [`FrameRange`]. The bounds are the
/// timestamps of the chunk's first frame and of the first frame after it (none at the ends of
/// the shot); a packet belongs to the chunk whose bounds hold its pts, so chunks split the
/// audio exactly where they split the video, every packet going to one chunk. Packets arrive
/// before the frames of their time are decoded, so a packet is held until a frame at or after
/// it settles which side of a bound it lies on.
pub(super) struct ChunkCut {
    range: FrameRange,
    video_tb: (i32, i32),
    /// Packets whose side of a bound is not known yet, in demux order.
    held: Vec<CopiedPacket>,
    /// Whether the chunk's first frame was seen.
    pub(super) started: bool,
    lower: Option<i64>,
    /// The latest frame of the chunk: a packet before it is before the upper bound.
    latest: Option<i64>,
    upper: Option<(i64, f64)>,
}

impl ChunkCut {
    pub(super) fn new(range: FrameRange, info: &VideoInfo) -> ChunkCut {
        ChunkCut {
            range,
            video_tb: info.time_base,
            held: Vec::new(),
            started: false,
            lower: None,
            latest: None,
            upper: None,
        }
    }

    /// What to do with `frame`, shown at `t_s`; [`Cut::In`] carries the held packets it settles.
    pub(super) fn frame(&mut self, frame: &YuvFrame, t_s: f64) -> Cut {
        use std::cmp::Ordering::*;
        match self.range.place(frame.index, t_s) {
            Less => Cut::Before,
            Equal => {
                if !self.started {
                    self.started = true;
                    self.lower = (frame.index > 0).then_some(frame.pts);
                }
                self.latest = Some(frame.pts);
                Cut::In(self.release())
            }
            Greater => {
                if self.upper.is_none() {
                    self.upper = Some((frame.pts, t_s));
                    let settled = self.release();
                    self.held.clear();
                    return Cut::After(settled);
                }
                match self.upper {
                    Some((_, upper_s)) if t_s >= upper_s + INTERLEAVE_SLACK_S => Cut::Done,
                    _ => Cut::After(Vec::new()),
                }
            }
        }
    }

    /// The packet, when it is known to belong to the chunk; held while that is open.
    pub(super) fn packet(&mut self, p: CopiedPacket) -> Option<CopiedPacket> {
        if self.range == FrameRange::All {
            return Some(p);
        }
        match self.side(&p) {
            Some(true) => Some(p),
            Some(false) => None,
            None => {
                self.held.push(p);
                None
            }
        }
    }

    /// The held packets of the shot's end (no frame after the chunk came).
    pub(super) fn finish(&mut self) -> Vec<CopiedPacket> {
        let held = std::mem::take(&mut self.held);
        match self.started {
            true => held
                .into_iter()
                .filter(|p| self.side(p) != Some(false))
                .collect(),
            false => Vec::new(),
        }
    }

    /// The held packets now known to belong to the chunk (those known not to are dropped).
    fn release(&mut self) -> Vec<CopiedPacket> {
        let held = std::mem::take(&mut self.held);
        let mut out = Vec::new();
        for p in held {
            match self.side(&p) {
                Some(true) => out.push(p),
                Some(false) => {}
                None => self.held.push(p),
            }
        }
        out
    }

    /// Whether `p` lies within the bounds; `None` while that is not known yet.
    fn side(&self, p: &CopiedPacket) -> Option<bool> {
        if !self.started {
            return None;
        }
        let Some(pts) = p.packet.pts() else {
            return Some(self.upper.is_none());
        };
        let at = (pts, (p.time_base.numerator(), p.time_base.denominator()));
        if self.lower.is_some_and(|l| earlier(at, (l, self.video_tb))) {
            return Some(false);
        }
        match (self.upper, self.latest) {
            (Some((u, _)), _) => Some(earlier(at, (u, self.video_tb))),
            (None, Some(l)) if earlier(at, (l, self.video_tb)) => Some(true),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Times in different time bases compare exactly: equal instants are not earlier either
    /// way, and one tick apart is.
    #[test]
    fn packet_times_compare_exactly_across_time_bases() {
        for k in [1i64, 7, 3_600, 86_399] {
            let audio = (48_000 * k, (1, 48_000));
            let video = (12_800 * k, (1, 12_800));
            assert!(!earlier(audio, video) && !earlier(video, audio), "{k} s");
            assert!(
                earlier((48_000 * k - 1, (1, 48_000)), video),
                "{k} s less a tick"
            );
            assert!(
                earlier(video, (48_000 * k + 1, (1, 48_000))),
                "{k} s and a tick"
            );
        }
        // NTSC: frame 30 000 at 1001/30000 s is exactly 1001 s.
        assert!(!earlier(
            (30_000, (1001, 30_000)),
            (1001 * 90_000, (1, 90_000))
        ));
    }

    /// A range places a frame by index or by time, half-open, the end left open when absent.
    #[test]
    fn ranges_are_half_open() {
        use std::cmp::Ordering::*;
        let by_index = FrameRange::Indices {
            start: 10,
            end: Some(20),
        };
        let places: Vec<_> = [9, 10, 19, 20].map(|i| by_index.place(i, 0.0)).into();
        assert_eq!(places, [Less, Equal, Equal, Greater]);
        let by_time = FrameRange::Times {
            from_s: 1.0,
            to_s: None,
        };
        assert_eq!(by_time.place(0, 0.96), Less);
        assert_eq!(by_time.place(0, 1.0), Equal);
        assert_eq!(by_time.place(0, 1e6), Equal);
        for empty in [
            FrameRange::Indices {
                start: 5,
                end: Some(5),
            },
            FrameRange::Times {
                from_s: 2.0,
                to_s: Some(1.0),
            },
        ] {
            assert!(empty.validate().is_err(), "{empty}");
        }
    }
}
