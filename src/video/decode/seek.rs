//! Seeking for previews: [`Source::seek_to_time`] and [`Source::frame_at_index`].
//!
//! How it works: the demuxer seeks to the keyframe at or before the target and the decoder
//! runs forward to the first frame at or after it; if the demuxer landed after the target (its
//! index can be coarse, or by decode time), it backs off further. The frame's index is what a
//! full decode would give it: arithmetic at a constant rate, counted from the packet
//! timestamps (demux only, no decoding) at a variable one.

use ffmpeg_next::{self as ff, Rational, Rescale};

use super::{Source, SourceItem};
use crate::video::YuvFrame;
use crate::{Error, Result};

/// Packets after which a timestamp scan without decode timestamps trusts its order.
const REORDER_WINDOW: u32 = 16;

impl Source {
    /// Seeks to the keyframe before `t_s` (seconds after the first frame, see
    /// [`VideoInfo::start_pts`](crate::video::VideoInfo::start_pts)), decodes forward and returns the first frame whose time is
    /// ≥ `t_s`: the same pixels, pts and index a full decode gives there. Afterwards
    /// [`Source::next_item`] continues after that frame (other streams' packets from the
    /// keyframe on). Errors when `t_s` lies beyond the last frame, and on stdin.
    pub fn seek_to_time(&mut self, t_s: f64) -> Result<YuvFrame> {
        if !t_s.is_finite() || t_s < 0.0 {
            return Err(Error::Parameter {
                name: "job.at",
                value: t_s.to_string(),
                expected: "a time ≥ 0 in seconds".into(),
            });
        }
        let spt = f64::from(self.tb);
        // The first tick at or after t (a tiny epsilon absorbs decimal input like 0.1 s).
        let target = self.info().start_pts + (t_s / spt - 1e-6).ceil() as i64;
        let path = self.path.clone();
        let beyond = || Error::OutOfRange(format!("{t_s} s is beyond the last frame of '{path}'"));
        if self.info().variable_frame_rate {
            // Count the frames before the target from the packet timestamps (demux only).
            let (before, Some(pts)) = self.scan_to_pts(target)? else {
                return Err(beyond());
            };
            let frame = self.seek_to_pts(pts)?;
            return Ok(self.renumber(frame, before));
        }
        let frame = self.seek_to_pts(target).map_err(|e| match e {
            Error::OutOfRange(_) => beyond(),
            e => e,
        })?;
        let index = self.cfr_index(frame.pts);
        Ok(self.renumber(frame, index))
    }

    /// Seeks to frame `n` (0-based, in presentation order) and returns it; see
    /// [`Source::seek_to_time`].
    pub fn frame_at_index(&mut self, n: u64) -> Result<YuvFrame> {
        let path = self.path.clone();
        let out_of_range = || Error::OutOfRange(format!("'{path}' has no frame {n}"));
        if let Some(count) = self.info().frame_count
            && n >= count
        {
            return Err(out_of_range());
        }
        let info = self.info();
        let (start, vfr) = (info.start_pts, info.variable_frame_rate);
        if !vfr {
            // Constant rate: the first frame at or after (n − ½) frame periods.
            let (num, den) = info.nominal_fps();
            let spt = f64::from(self.tb);
            let t = (n as f64 - 0.5).max(0.0) * den as f64 / num as f64;
            let target = start + (t / spt - 1e-6).ceil() as i64;
            let frame = self.seek_to_pts(target).map_err(|e| match e {
                Error::OutOfRange(_) => out_of_range(),
                e => e,
            })?;
            if self.cfr_index(frame.pts) == n {
                return Ok(self.renumber(frame, n));
            }
            log::warn!("frame timestamps are not evenly spaced; counting frames from the start");
        }
        let pts = self.scan_pts_of_index(n)?.ok_or_else(out_of_range)?;
        let frame = self.seek_to_pts(pts)?;
        Ok(self.renumber(frame, n))
    }

    /// Seeks and decodes forward to the first frame with pts ≥ `target`, backing off further
    /// when the demuxer landed after the target (its keyframe index is coarse for some
    /// formats).
    fn seek_to_pts(&mut self, target: i64) -> Result<YuvFrame> {
        if !self.seekable {
            return Err(Error::Unsupported(
                "seeking needs a file; a pipe can only be read from the start".into(),
            ));
        }
        let start = self.info().start_pts;
        let us = Rational::new(1, ff::ffi::AV_TIME_BASE);
        let mut backoff_s = 0i64;
        loop {
            let mut ts = target.rescale(self.tb, us) - backoff_s * 1_000_000;
            let from_start = ts <= start.rescale(self.tb, us);
            if from_start {
                ts = start.rescale(self.tb, us);
            }
            self.seek_raw(ts)?;
            let mut first_seen = None;
            loop {
                let Some(frame) = self.next_frame()? else {
                    return Err(Error::OutOfRange(format!("pts {target} is beyond the end")));
                };
                let first = *first_seen.get_or_insert(frame.pts);
                if frame.pts >= target {
                    if first > target && !from_start {
                        break; // landed after the target: seek further back
                    }
                    return Ok(frame);
                }
            }
            backoff_s = if backoff_s == 0 { 1 } else { backoff_s * 4 };
        }
    }

    /// Positions the demuxer at the keyframe at or before `ts_us` and resets the decoder.
    fn seek_raw(&mut self, ts_us: i64) -> Result<()> {
        // The keyframe at or before the time; failing that (no keyframe before it, e.g. a
        // rounding hair before the first one), the nearest: the caller checks where it landed.
        self.sought = true;
        if let Err(e) = self.input.seek(ts_us, ..ts_us) {
            log::debug!("seek to {ts_us} µs backwards failed ({e}); seeking to the nearest");
            self.input
                .seek(ts_us, ..)
                .map_err(Error::ffmpeg(format!("seeking in '{}'", self.path)))?;
        }
        self.decoder.flush();
        self.pending.clear();
        self.ready.clear();
        // A seek starts the clocks afresh (within a joined recording it lands in one segment).
        self.clocks.clear();
        self.input_done = false;
        self.decoder_done = false;
        self.bad_packets_in_a_row = 0;
        Ok(())
    }

    /// The next decoded frame, skipping (dropping) packets of other streams; `None` at the end.
    /// For reading ahead to a frame (preview, inspection), not for a render that copies audio.
    pub fn next_frame(&mut self) -> Result<Option<YuvFrame>> {
        while let Some(item) = self.next_item()? {
            if let SourceItem::Frame(f) = item {
                return Ok(Some(f));
            }
        }
        Ok(None)
    }

    /// Gives `frame` its full-decode index and renumbers the frames already decoded after it.
    fn renumber(&mut self, mut frame: YuvFrame, index: u64) -> YuvFrame {
        frame.index = index;
        let mut next = index + 1;
        for item in &mut self.ready {
            if let SourceItem::Frame(f) = item {
                f.index = next;
                next += 1;
            }
        }
        self.next_index = next;
        self.last_pts = Some(frame.pts);
        frame
    }

    fn cfr_index(&self, pts: i64) -> u64 {
        let info = self.info();
        let (num, den) = info.nominal_fps();
        let t = (pts - info.start_pts) as f64 * f64::from(self.tb);
        (t * num as f64 / den as f64).round().max(0.0) as u64
    }

    /// Counts the frames before `target` and finds the first frame at or after it, from the
    /// packet timestamps (presentation order = sorted pts).
    fn scan_to_pts(&mut self, target: i64) -> Result<(u64, Option<i64>)> {
        let all = self.scan_video_pts(|sorted, dts| {
            let at = sorted.partition_point(|&p| p < target);
            at < sorted.len() && dts > sorted[at]
        })?;
        let at = all.partition_point(|&p| p < target);
        Ok((at as u64, all.get(at).copied()))
    }

    /// pts of frame `n` by counting packets from the start.
    fn scan_pts_of_index(&mut self, n: u64) -> Result<Option<i64>> {
        let n = n as usize;
        let all = self.scan_video_pts(|sorted, dts| sorted.len() > n && dts > sorted[n])?;
        Ok(all.get(n).copied())
    }

    /// Reads video packet timestamps from the first frame on until `done(sorted, dts)`; returns
    /// the sorted presentation timestamps (packets before the first frame, such as those an
    /// edit list discards, are left out).
    fn scan_video_pts(&mut self, done: impl Fn(&[i64], i64) -> bool) -> Result<Vec<i64>> {
        let start = self.info().start_pts;
        let us = Rational::new(1, ff::ffi::AV_TIME_BASE);
        self.seek_raw(start.rescale(self.tb, us))?;
        let mut sorted: Vec<i64> = Vec::new();
        // Without decode timestamps (Matroska often has none) a packet's pts says nothing
        // certain about later packets, so the condition must hold for a reordering window.
        let mut settled = 0;
        while let Some(p) = self.read_packet()? {
            if p.stream() != self.video || crate::video::ffi::packet_discarded(&p) {
                continue;
            }
            let Some(pts) = p.pts().or(p.dts()) else {
                continue;
            };
            if pts >= start {
                let at = sorted.partition_point(|&x| x < pts);
                sorted.insert(at, pts);
            }
            match p.dts() {
                Some(dts) if done(&sorted, dts) => break,
                Some(_) => {}
                None => {
                    settled = if done(&sorted, pts) { settled + 1 } else { 0 };
                    if settled > REORDER_WINDOW {
                        break;
                    }
                }
            }
        }
        Ok(sorted)
    }
}
