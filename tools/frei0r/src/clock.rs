//! The host's clock → the shot's time.
//!
//! Hosts pass each frame's time as a `double`, each in its own way: FFmpeg's `frei0r` filter in
//! milliseconds of the stream (`pts · time_base · 1000`, libavfilter/vf_frei0r.c), MLT in
//! seconds from the effect's start on the clip (`position / fps`), GStreamer in seconds of the
//! buffer's timestamp (and `GST_CLOCK_TIME_NONE / GST_SECOND`, about 1.8e10, for a buffer
//! without one). The rain is a pure function of the shot's time, so the map is a pure function
//! of the host's time; only a time that is not one falls back to counting frames.

use std::sync::OnceLock;

use crate::params::Params;

/// Largest |shot time| taken as a time, seconds (11.6 days): beyond it, or not finite, the
/// host sent no time.
pub const MAX_SHOT_S: f64 = 1e6;

/// Seconds per unit of the host's clock: 1/1000 in FFmpeg's programs (recognised by name),
/// 1 elsewhere. `time_scale` covers a host counting milliseconds under another name.
pub fn host_unit_s() -> f64 {
    static UNIT: OnceLock<f64> = OnceLock::new();
    *UNIT.get_or_init(|| {
        let exe = std::env::current_exe().ok();
        let name = exe
            .as_deref()
            .and_then(|p| p.file_stem())
            .and_then(|n| n.to_str())
            .unwrap_or("");
        if counts_milliseconds(name) { 1e-3 } else { 1.0 }
    })
}

/// Whether a program of this name runs libavfilter's `frei0r` filter, whose clock is in
/// milliseconds.
pub fn counts_milliseconds(program: &str) -> bool {
    matches!(program, "ffmpeg" | "ffplay")
}

/// One instance's clock: the last good time, for the fallback.
#[derive(Debug, Default)]
pub struct Clock {
    last_s: Option<f64>,
}

/// A shot time, and whether it came from the fallback.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShotTime {
    /// Seconds of the shot.
    pub t_s: f64,
    /// The host's time was not a time: this one is the last good time plus a frame.
    pub fallback: bool,
}

impl Clock {
    /// The shot time of a frame the host stamps `host`, in units of `unit_s` seconds.
    pub fn shot_time(&mut self, host: f64, unit_s: f64, params: &Params) -> ShotTime {
        let t = params.time_offset_s() + params.time_scale() * unit_s * host;
        if t.is_finite() && (0.0..=MAX_SHOT_S).contains(&t) {
            self.last_s = Some(t);
            return ShotTime {
                t_s: t,
                fallback: false,
            };
        }
        let t = self.last_s.map_or(params.time_offset_s(), |last| {
            last + 1.0 / params.fps().max(1.0)
        });
        self.last_s = Some(t);
        ShotTime {
            t_s: t,
            fallback: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::index;

    #[test]
    fn hosts_clocks_map_to_the_same_shot_time() {
        let p = Params::default();
        let mut c = Clock::default();
        // FFmpeg: 1.04 s as milliseconds; MLT and GStreamer: seconds.
        assert!((c.shot_time(1040.0, 1e-3, &p).t_s - 1.04).abs() < 1e-12);
        assert_eq!(c.shot_time(1.04, 1.0, &p).t_s, 1.04);
        assert!(counts_milliseconds("ffmpeg") && !counts_milliseconds("melt"));
    }

    #[test]
    fn scale_and_offset_apply_in_that_order() {
        let mut p = Params::default();
        p.numbers[index::TIME_SCALE] = 0.25; // 1000^-0.5
        p.numbers[index::TIME_OFFSET] = 1.0 / 3600.0; // 1 s
        let t = Clock::default().shot_time(10.0, 1.0, &p).t_s;
        assert!((t - (1.0 + 10.0 / 1000f64.sqrt())).abs() < 1e-9, "{t}");
    }

    #[test]
    fn a_time_that_is_not_one_counts_frames_from_the_last_good_one() {
        let p = Params::default();
        let mut c = Clock::default();
        let none = c.shot_time(f64::NAN, 1.0, &p);
        assert_eq!(
            none,
            ShotTime {
                t_s: 0.0,
                fallback: true
            }
        );
        assert_eq!(c.shot_time(2.0, 1.0, &p).t_s, 2.0);
        // GStreamer's "no timestamp", in seconds.
        let t = c.shot_time(u64::MAX as f64 / 1e9, 1.0, &p);
        assert!(t.fallback && (t.t_s - 2.04).abs() < 1e-12, "{t:?}");
        assert!(c.shot_time(-5.0, 1.0, &p).fallback);
        assert!(c.shot_time(f64::INFINITY, 1.0, &p).fallback);
    }
}
