//! Encode and mux: the [`Sink`] takes rendered frames and the other streams' packets and writes
//! the output file (or stdout) with the input's timing, colour tags, rotation and metadata.
//!
//! How it works: [`Sink::create`] plans every input stream ([`plan_streams`]: render, copy,
//! AAC fallback or drop), opens the video encoder with the input stream's time base (so each
//! frame's pts passes through unchanged, CFR or VFR), adds the copied streams, and writes the
//! header, all into a hidden temporary file beside the output. [`Sink::finish`] flushes and
//! renames it onto the output; dropping an unfinished sink deletes it, so a failed or
//! interrupted job never leaves a half-written output. A PNG or OpenEXR sequence is written into a
//! hidden temporary directory whose files are moved beside the output pattern at the end.
//!
//! One file a step: `options` (what to write), `streams` (the container and the fate of each
//! input stream), `video_out` and `pixel` (the video encoder and the layout it takes),
//! `header` (the container's tags and header), `exr` (OpenEXR sequences, written without
//! FFmpeg), `temp` (the temporary output until it is published) and `sink` (the [`Sink`]
//! tying them together).

mod exr;
mod header;
mod options;
mod pixel;
mod sink;
mod streams;
mod temp;
mod video_out;

use ffmpeg_next::{self as ff, Rational};

pub use exr::{Chromaticities, chromaticities};
pub use options::{AudioMode, EncodeOptions, STREAK_PARAMS, VideoCodec, X26X_PRESETS};
pub use sink::Sink;
pub use streams::{output_format, plan_streams};

/// The muxer y4m output goes through.
const Y4M: &str = "yuv4mpegpipe";

/// The image2 muxer's name (PNG sequences).
const IMAGE2: &str = "image2";

/// The MP4 family's muxers: the containers that store a display rotation and take `movflags`.
const MP4_FAMILY: [&str; 8] = ["mp4", "mov", "ipod", "ismv", "3gp", "3g2", "psp", "f4v"];

/// The time base of output stream `index` (1/1 if there is none).
fn stream_tb(octx: &ff::format::context::Output, index: usize) -> Rational {
    octx.stream(index)
        .map_or(Rational::new(1, 1), |s| s.time_base())
}

/// `pairs` as an FFmpeg dictionary, without the keys in `skip`.
fn dictionary(pairs: &[(String, String)], skip: &[&str]) -> ff::Dictionary<'static> {
    let mut d = ff::Dictionary::new();
    for (k, v) in pairs {
        if !skip.contains(&k.as_str()) {
            d.set(k, v);
        }
    }
    d
}
