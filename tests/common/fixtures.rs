//! Test fixtures made with the ffmpeg CLI (small generated clips in a temporary directory), the
//! ffprobe/ffmpeg measurements the tests compare against, and a logger that records warnings.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;

/// `p` as a command-line argument (the tests' paths are UTF-8).
pub fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Runs `ffmpeg -y -v error <args>` and panics with its stderr on failure.
pub fn ffmpeg(args: &[&str]) {
    let out = Command::new("ffmpeg")
        .args(["-hide_banner", "-nostdin", "-y", "-v", "error"])
        .args(args)
        .output()
        .expect("the ffmpeg CLI is installed");
    assert!(
        out.status.success(),
        "ffmpeg {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Runs ffmpeg and returns its stderr (for filters that report there, such as psnr).
pub fn ffmpeg_stderr(args: &[&str]) -> String {
    let out = Command::new("ffmpeg")
        .args(["-hide_banner", "-nostdin", "-y"])
        .args(args)
        .output()
        .expect("the ffmpeg CLI is installed");
    assert!(
        out.status.success(),
        "ffmpeg {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// `ffprobe -of json <args> <path>` parsed.
pub fn ffprobe(path: &Path, args: &[&str]) -> serde_json::Value {
    let out = Command::new("ffprobe")
        .args(["-v", "error", "-of", "json"])
        .args(args)
        .arg(path)
        .output()
        .expect("ffprobe is installed");
    assert!(
        out.status.success(),
        "ffprobe {args:?} {} failed: {}",
        path.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("ffprobe prints JSON")
}

/// The first stream of a kind (`"v"`, `"a"`) as ffprobe describes it.
pub fn stream(path: &Path, kind: &str) -> serde_json::Value {
    let v = ffprobe(path, &["-show_streams", "-select_streams", kind]);
    v["streams"][0].clone()
}

/// The four colour tags of the video stream as ffprobe prints them.
pub fn color_tags(path: &Path) -> [String; 4] {
    let s = stream(path, "v:0");
    [
        "color_space",
        "color_range",
        "color_primaries",
        "color_transfer",
    ]
    .map(|k| s[k].as_str().unwrap_or("unknown").to_owned())
}

/// Per-frame MD5s of the decoded frames of one stream (`"0:v:0"`, `"0:a:0"`), in order, with
/// `copy` taking packets instead of decoded frames.
pub fn framemd5(path: &Path, map: &str, copy: bool) -> Vec<String> {
    let mut args = vec!["-hide_banner", "-nostdin", "-v", "error", "-i"];
    let p = path.to_str().expect("utf-8 path");
    args.push(p);
    args.extend(["-map", map]);
    if copy {
        args.extend(["-c", "copy"]);
    }
    args.extend(["-f", "framemd5", "-"]);
    let out = Command::new("ffmpeg").args(&args).output().expect("ffmpeg");
    assert!(
        out.status.success(),
        "framemd5 of {} failed: {}",
        path.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| l.rsplit(',').next().map(|h| h.trim().to_owned()))
        .collect()
}

/// Presentation times of every video frame (ffprobe, seconds).
pub fn frame_times(path: &Path) -> Vec<f64> {
    let v = ffprobe(
        path,
        &["-select_streams", "v:0", "-show_entries", "frame=pts_time"],
    );
    v["frames"]
        .as_array()
        .expect("frames")
        .iter()
        .map(|f| {
            f["pts_time"]
                .as_str()
                .expect("pts_time")
                .parse()
                .expect("number")
        })
        .collect()
}

/// Average PSNR (dB) of `a` against `b`; infinite when identical.
pub fn psnr(a: &Path, b: &Path) -> f64 {
    let err = ffmpeg_stderr(&[
        "-i",
        a.to_str().unwrap(),
        "-i",
        b.to_str().unwrap(),
        "-lavfi",
        "psnr",
        "-f",
        "null",
        "-",
    ]);
    let avg = err
        .split("average:")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .unwrap_or_else(|| panic!("no PSNR in {err}"));
    if avg == "inf" {
        f64::INFINITY
    } else {
        avg.parse().expect("PSNR number")
    }
}

/// A generated clip: `testsrc2` of the given size, rate and duration, encoded with `vcodec`
/// arguments (`["-c:v", "libx264", "-pix_fmt", "yuv420p"]`) into `name` inside `dir`.
pub fn clip(dir: &Path, name: &str, size: &str, rate: u32, secs: f64, vargs: &[&str]) -> PathBuf {
    let path = dir.join(name);
    let src = format!("testsrc2=s={size}:r={rate}:d={secs}");
    let mut args = vec!["-f", "lavfi", "-i", &src];
    args.extend_from_slice(vargs);
    args.push(path.to_str().unwrap());
    ffmpeg(&args);
    path
}

/// A `testsrc2` clip of `size` and `pix_fmt` at 25 fps for 0.12 s, tagged with `primaries`
/// (BT.709 matrix and transfer, limited range), losslessly coded (FFV1) so the decoded source
/// is exact.
pub fn lossless_clip(dir: &Path, size: &str, pix_fmt: &str, primaries: &str) -> PathBuf {
    clip(
        dir,
        &format!("in_{size}_{pix_fmt}_{primaries}.mkv"),
        size,
        25,
        0.12,
        &[
            "-c:v",
            "ffv1",
            "-pix_fmt",
            pix_fmt,
            "-color_primaries",
            primaries,
            "-color_trc",
            "bt709",
            "-colorspace",
            "bt709",
            "-color_range",
            "tv",
        ],
    )
}

/// Every frame of `path`, decoded by the library.
pub fn decoded_frames(path: &Path) -> Vec<rain_composite::video::YuvFrame> {
    let mut source =
        rain_composite::video::Source::open(path.to_str().expect("utf-8 path")).expect("open");
    let mut out = Vec::new();
    while let Some(f) = source.next_frame().expect("decode") {
        out.push(f);
    }
    out
}

/// A quickly encoded H.264 4:2:0 `testsrc2` clip at 25 fps (for tests about anything but the
/// encoding).
pub fn quick_clip(dir: &Path, name: &str, size: &str, secs: f64) -> PathBuf {
    clip(
        dir,
        name,
        size,
        25,
        secs,
        &[
            "-c:v",
            "libx264",
            "-preset",
            "ultrafast",
            "-pix_fmt",
            "yuv420p",
        ],
    )
}

/// A clip with a sine-wave audio track: `vargs` for the video, `aargs` for the audio (and any
/// extra output options).
pub fn clip_with_audio(
    dir: &Path,
    name: &str,
    secs: f64,
    vargs: &[&str],
    aargs: &[&str],
) -> PathBuf {
    let path = dir.join(name);
    let v = format!("testsrc2=s=160x120:r=25:d={secs}");
    let a = format!("sine=frequency=440:sample_rate=48000:duration={secs}");
    let mut args = vec!["-f", "lavfi", "-i", &v, "-f", "lavfi", "-i", &a];
    args.extend_from_slice(vargs);
    args.extend_from_slice(aargs);
    args.push(path.to_str().unwrap());
    ffmpeg(&args);
    path
}

static LOG: Mutex<Vec<(std::thread::ThreadId, log::Level, String)>> = Mutex::new(Vec::new());

struct Recorder;

impl log::Log for Recorder {
    fn enabled(&self, m: &log::Metadata) -> bool {
        m.level() <= log::Level::Warn
    }

    fn log(&self, r: &log::Record) {
        if self.enabled(r.metadata()) {
            let msg = r.args().to_string();
            eprintln!("[{}] {msg}", r.level());
            LOG.lock()
                .unwrap()
                .push((std::thread::current().id(), r.level(), msg));
        }
    }

    fn flush(&self) {}
}

/// Installs the recording logger (idempotent).
pub fn init_logger() {
    static R: Recorder = Recorder;
    if log::set_logger(&R).is_ok() {
        log::set_max_level(log::LevelFilter::Warn);
    }
}

/// Warnings logged so far by the calling thread.
pub fn my_warnings() -> Vec<String> {
    let me = std::thread::current().id();
    LOG.lock()
        .unwrap()
        .iter()
        .filter(|(t, _, _)| *t == me)
        .map(|(_, _, m)| m.clone())
        .collect()
}

/// Files in `dir` (names), sorted.
pub fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A lossless (FFV1) clip `name` in `dir`, `w`×`h` at 25 fps for `secs`: a bright sky above row
/// `sky_rows`, a dark ground below — a picture where rain shows and a ground is easy to place.
pub fn sky_over_ground(
    dir: &Path,
    name: &str,
    (w, h): (u32, u32),
    sky_rows: u32,
    secs: f64,
) -> PathBuf {
    let path = dir.join(name);
    let src = format!(
        "nullsrc=s={w}x{h}:r=25:d={secs},format=yuv420p,geq=lum='if(lt(Y,{sky_rows}),235,40)':cb=128:cr=128"
    );
    ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        &src,
        "-c:v",
        "ffv1",
        path.to_str().unwrap(),
    ]);
    path
}

/// How much brighter than the same render without rain (8-bit luma codes) a pixel of a lossless
/// render must be to count as a visible streak pixel: about the smallest step a thin line
/// shows against mid grey (1.6 % of the range); daylight streaks rarely reach 8 codes.
pub const VISIBLE_STREAK_CODES: i16 = 4;

/// The 8-bit luma of every frame of `path` (the ffmpeg CLI's decode), frame after frame.
pub fn luma_frames(path: &Path) -> Vec<u8> {
    let out = Command::new("ffmpeg")
        .args(["-hide_banner", "-nostdin", "-v", "error", "-i"])
        .arg(path)
        .args(["-f", "rawvideo", "-pix_fmt", "gray", "-"])
        .output()
        .expect("the ffmpeg CLI is installed");
    assert!(
        out.status.success(),
        "decoding {}: {}",
        path.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

/// The streak pixels an encoding keeps, as (visible, kept), from the luma of three renders of
/// the same frames: `rain` and `dry` (no rain) written losslessly, and `encoded` (the rain
/// through the encoder under test). A visible streak pixel is one where `rain` is at least
/// `threshold` codes above `dry`; it is kept where `encoded` is still above `dry` by at least
/// half that difference. Both sets are defined by the lossless renders alone, so every
/// encoder is measured against the same pixels.
pub fn streaks_kept(rain: &[u8], dry: &[u8], encoded: &[u8], threshold: i16) -> (usize, usize) {
    assert_eq!(rain.len(), dry.len(), "the renders differ in size");
    assert_eq!(rain.len(), encoded.len(), "the encoding differs in size");
    let (mut visible, mut kept) = (0, 0);
    for ((&r, &d), &e) in rain.iter().zip(dry).zip(encoded) {
        let streak = i16::from(r) - i16::from(d);
        if streak >= threshold {
            visible += 1;
            if 2 * (i16::from(e) - i16::from(d)) >= streak {
                kept += 1;
            }
        }
    }
    (visible, kept)
}
