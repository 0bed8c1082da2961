//! End to end through the `rain-composite` binary on small clips made with the ffmpeg CLI.
//! GPU work runs on whatever adapter the machine has (lavapipe in CI).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use tempfile::TempDir;

#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::{
    VISIBLE_STREAK_CODES, color_tags, ffmpeg, frame_times, framemd5, luma_frames, psnr, quick_clip,
    s, streaks_kept,
};

#[path = "common/binary.rs"]
mod binary;
use binary::{bin, ok};

fn ffprobe(path: &Path, args: &[&str]) -> String {
    let out = Command::new("ffprobe")
        .args(["-v", "error"])
        .args(args)
        .arg(path)
        .output()
        .expect("ffprobe");
    assert!(out.status.success());
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn p(dir: &TempDir, name: &str) -> PathBuf {
    dir.path().join(name)
}

/// A testsrc2 clip: `size`, `secs` long at 25 fps, extra encoder args.
fn clip(path: &Path, size: &str, secs: f64, extra: &[&str]) {
    let src = format!("testsrc2=size={size}:rate=25:duration={secs}");
    let mut args = vec!["-f", "lavfi", "-i", &src];
    args.extend_from_slice(extra);
    args.push(s(path));
    ffmpeg(&args);
}

/// A clip lit like a street under an overcast sky: a bright band at the top (the sky the
/// drops refract) over a dark scene. In a uniform picture drops are invisible, as real ones
/// are in uniform light.
fn sky_clip(path: &Path, size: &str, secs: f64, extra: &[&str]) {
    let (w, h) = size.split_once('x').expect("WxH");
    let src = format!(
        "nullsrc=s={w}x{h}:r=25:d={secs},format=yuv420p,geq=lum='if(lt(Y,{}),235,40)':cb=128:cr=128",
        h.parse::<u32>().expect("h") / 4
    );
    let mut args = vec!["-f", "lavfi", "-i", &src];
    args.extend_from_slice(extra);
    args.push(s(path));
    ffmpeg(&args);
}

#[test]
fn without_rain_the_output_matches_a_plain_transcode() {
    let dir = TempDir::new().expect("tmp");
    let cases: [(&str, &[&str]); 4] = [
        (
            "bt709",
            &[
                "-pix_fmt",
                "yuv420p",
                "-color_range",
                "tv",
                "-colorspace",
                "bt709",
                "-color_primaries",
                "bt709",
                "-color_trc",
                "bt709",
            ],
        ),
        (
            "bt601",
            &[
                "-pix_fmt",
                "yuv420p",
                "-color_range",
                "tv",
                "-colorspace",
                "smpte170m",
                "-color_primaries",
                "smpte170m",
                "-color_trc",
                "smpte170m",
            ],
        ),
        (
            "full",
            &[
                "-pix_fmt",
                "yuvj420p",
                "-color_range",
                "pc",
                "-colorspace",
                "bt709",
                "-color_primaries",
                "bt709",
                "-color_trc",
                "bt709",
            ],
        ),
        (
            "10bit",
            &[
                "-pix_fmt",
                "yuv420p10le",
                "-color_range",
                "tv",
                "-colorspace",
                "bt709",
                "-color_primaries",
                "bt709",
                "-color_trc",
                "bt709",
            ],
        ),
    ];
    for (name, tags) in cases {
        let input = p(&dir, &format!("{name}.mkv"));
        let mut args = vec!["-c:v", "libx264", "-crf", "10"];
        args.extend_from_slice(tags);
        clip(&input, "160x120", 1.0, &args);
        let out = p(&dir, &format!("{name}-out.mp4"));
        ok(bin().args([s(&input), "-o", s(&out), "--rain", "0", "--cpu"]));
        let reference = p(&dir, &format!("{name}-ref.mp4"));
        ffmpeg(&[
            "-i",
            s(&input),
            "-c:v",
            "libx264",
            "-crf",
            "18",
            "-x264-params",
            rain_composite::video::STREAK_PARAMS,
            s(&reference),
        ]);
        let db = psnr(&out, &reference);
        assert!(db >= 50.0, "{name}: PSNR {db} dB");
        assert_eq!(color_tags(&out), color_tags(&input), "{name}: colour tags");
    }
}

#[test]
fn every_frame_keeps_its_timestamp_constant_and_variable_rate() {
    let dir = TempDir::new().expect("tmp");
    let cfr = p(&dir, "cfr.mp4");
    clip(
        &cfr,
        "96x64",
        1.0,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
    );
    // Variable rate: a 0.5 s gap after frame 10.
    let vfr = p(&dir, "vfr.mkv");
    clip(
        &vfr,
        "96x64",
        1.0,
        &[
            "-vf",
            "setpts='if(gt(N,10),PTS+0.5/TB,PTS)'",
            "-fps_mode",
            "passthrough",
            "-c:v",
            "libx264",
            "-pix_fmt",
            "yuv420p",
        ],
    );
    for input in [cfr, vfr] {
        let out = input.with_extension("out.mkv");
        ok(bin().args([s(&input), "-o", s(&out), "--cpu"]));
        let (a, b) = (frame_times(&input), frame_times(&out));
        assert_eq!(a.len(), 25, "{input:?}");
        assert_eq!(a, b, "{input:?}");
    }
}

#[test]
fn audio_is_copied_bit_for_bit() {
    let dir = TempDir::new().expect("tmp");
    let input = p(&dir, "av.mp4");
    ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "testsrc2=size=96x64:rate=25:duration=1",
        "-f",
        "lavfi",
        "-i",
        "sine=frequency=440:duration=1",
        "-c:v",
        "libx264",
        "-pix_fmt",
        "yuv420p",
        "-c:a",
        "aac",
        "-shortest",
        s(&input),
    ]);
    let out = p(&dir, "av-out.mp4");
    ok(bin().args([s(&input), "-o", s(&out), "--cpu"]));
    let (a, b) = (framemd5(&input, "0:a", true), framemd5(&out, "0:a", true));
    assert!(!a.is_empty());
    assert_eq!(a, b);
}

/// Gray frames of `path` as the viewer sees them (ffmpeg applies the display rotation).
fn gray_frames(path: &Path) -> (usize, usize, Vec<Vec<f64>>) {
    let dims = ffprobe(
        path,
        &[
            "-select_streams",
            "v:0",
            "-show_entries",
            "stream=width,height:stream_side_data=rotation",
            "-of",
            "default=nw=1",
        ],
    );
    let get = |k: &str| {
        dims.lines()
            .find_map(|l| l.strip_prefix(k))
            .map(|v| v.trim().parse::<i64>().expect("int"))
    };
    let (w, h) = (
        get("width=").expect("w") as usize,
        get("height=").expect("h") as usize,
    );
    let rotated = get("rotation=").is_some_and(|r| r.rem_euclid(180) == 90);
    let (w, h) = if rotated { (h, w) } else { (w, h) };
    let o = Command::new("ffmpeg")
        .args([
            "-v",
            "error",
            "-i",
            s(path),
            "-f",
            "rawvideo",
            "-pix_fmt",
            "gray",
            "-",
        ])
        .output()
        .expect("ffmpeg");
    let frames = o
        .stdout
        .chunks_exact(w * h)
        .map(|f| f.iter().map(|&v| v as f64).collect())
        .collect();
    (w, h, frames)
}

#[test]
fn rain_falls_down_the_displayed_picture_of_a_rotated_clip() {
    let dir = TempDir::new().expect("tmp");
    let input = p(&dir, "rot.mp4");
    // A 160×96 picture shown rotated by 90°: the viewer sees 96×160.
    let plain = p(&dir, "plain.mp4");
    sky_clip(
        &plain,
        "160x96",
        0.4,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
    );
    // FFmpeg 5.1 writes the display matrix from the `rotate` tag on a stream copy.
    ffmpeg(&[
        "-i",
        s(&plain),
        "-c",
        "copy",
        "-metadata:s:v:0",
        "rotate=90",
        s(&input),
    ]);
    let rainy = p(&dir, "rainy.mp4");
    let dry = p(&dir, "dry.mp4");
    let look = ["--opacity", "30", "--cpu", "--crf", "0"];
    ok(bin()
        .args([s(&input), "-o", s(&rainy), "--rain", "60"])
        .args(look));
    ok(bin()
        .args([s(&input), "-o", s(&dry), "--rain", "0"])
        .args(look));
    let (w, h, wet) = gray_frames(&rainy);
    let (_, _, base) = gray_frames(&dry);
    assert!(h > w, "the displayed picture is portrait ({w}×{h})");
    let layer = |i: usize| {
        wet[i]
            .iter()
            .zip(&base[i])
            .map(|(a, b)| a - b)
            .collect::<Vec<f64>>()
    };
    let l0 = layer(3);
    // Streaks are vertical in the displayed picture: intensity varies across x more than y.
    let (mut gx2, mut gy2) = (0.0, 0.0);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            gx2 += (l0[y * w + x + 1] - l0[y * w + x - 1]).powi(2);
            gy2 += (l0[(y + 1) * w + x] - l0[(y - 1) * w + x]).powi(2);
        }
    }
    assert!(
        gx2 > 2.0 * gy2,
        "streaks not vertical: gx² {gx2}, gy² {gy2}"
    );
    // And the pattern moves down between consecutive frames. Near drops cross 20–30 rows a
    // frame here, so the search spans 45; the layer's static part (the haze, fixed on the
    // picture) is removed first, and the correlations of all consecutive pairs are summed.
    let n = wet.len().min(base.len());
    let layers: Vec<Vec<f64>> = (0..n).map(layer).collect();
    let mean: Vec<f64> = (0..w * h)
        .map(|i| layers.iter().map(|l| l[i]).sum::<f64>() / n as f64)
        .collect();
    let moving: Vec<Vec<f64>> = layers
        .iter()
        .map(|l| l.iter().zip(&mean).map(|(a, m)| a - m).collect())
        .collect();
    let reach = 45i64;
    let score = |dy: i64| -> f64 {
        let mut sum = 0.0;
        for pair in moving.windows(2) {
            for y in reach..h as i64 - reach {
                for x in 0..w {
                    sum += pair[0][y as usize * w + x] * pair[1][(y + dy) as usize * w + x];
                }
            }
        }
        sum
    };
    let best = (-reach..=reach)
        .max_by(|a, b| score(*a).total_cmp(&score(*b)))
        .expect("shift");
    assert!(best > 0, "rain moves by {best} rows between frames");
}

/// The default H.264 output keeps at least 60 % of the streak pixels a lossless render shows
/// (brighter than the render without rain by `VISIBLE_STREAK_CODES` or more; kept: still
/// brighter by half as much), and more than the encoder's own defaults keep (B-frames smooth
/// faint streaks away): the night skyline sample under its preset (30 mm/h, tilted up), 1 s.
#[test]
fn the_default_encoding_keeps_the_streaks() {
    let dir = TempDir::new().expect("tmp");
    let input = p(&dir, "in.mkv");
    let sample = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/city.mp4");
    ffmpeg(&["-i", sample, "-t", "1", "-c:v", "ffv1", s(&input)]);
    let render = |name: &str, args: &[&str]| {
        let out = p(&dir, name);
        ok(bin()
            .args([s(&input), "-o", s(&out), "--scene-depth", "0", "--cpu"])
            .args(args));
        luma_frames(&out)
    };
    let rain = render("rain.mkv", &["--config", "city", "--codec", "ffv1"]);
    let dry = render("dry.mkv", &["--rain", "0", "--codec", "ffv1"]);
    let share = |encoded: &[u8]| {
        let (visible, kept) = streaks_kept(&rain, &dry, encoded, VISIBLE_STREAK_CODES);
        assert!(
            visible > rain.len() / 1000,
            "only {visible} visible streak pixels"
        );
        kept as f64 / visible as f64
    };
    let ours = share(&render("out.mp4", &["--config", "city"]));
    let theirs = share(&render(
        "own.mp4",
        &["--config", "city", "--encoder-params", "none"],
    ));
    eprintln!("streak pixels kept: {ours:.3} (the encoder's own defaults {theirs:.3})");
    assert!(
        ours >= 0.6,
        "the default encoding keeps {:.1} % of the visible streak pixels",
        100.0 * ours
    );
    assert!(ours > theirs, "{ours} vs the encoder's own {theirs}");
}

#[test]
fn rain_is_visible_varies_in_time_and_follows_the_seed() {
    let dir = TempDir::new().expect("tmp");
    let input = p(&dir, "in.mp4");
    sky_clip(
        &input,
        "128x96",
        0.3,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
    );
    let render = |name: &str, seed: &str, rain: &str| {
        let out = p(&dir, name);
        ok(bin().args([
            s(&input),
            "-o",
            s(&out),
            "--rain",
            rain,
            "--opacity",
            "20",
            "--seed",
            seed,
            "--cpu",
            "--codec",
            "ffv1",
        ]));
        gray_frames(&out).2
    };
    let a = render("a.mkv", "5", "40");
    let b = render("b.mkv", "5", "40");
    let c = render("c.mkv", "6", "40");
    let dry = render("dry.mkv", "5", "0");
    assert!(a == b, "same seed, same rain");
    assert!(a != c, "another seed, other rain");
    assert!(a[1] != a[2], "consecutive frames differ");
    // Over the dark part of the picture (below the sky band) drops show the brighter
    // surroundings they refract.
    let dark = 32 * 128..;
    let pairs = || a[1][dark.clone()].iter().zip(&dry[1][dark.clone()]);
    let brighter = pairs().filter(|(w, d)| w > d).count();
    let darker = pairs().filter(|(w, d)| w < d).count();
    assert!(
        brighter > 30 && darker == 0,
        "{brighter} brighter, {darker} darker pixels"
    );
}

#[test]
fn odd_tiny_and_4k_sizes_work() {
    let dir = TempDir::new().expect("tmp");
    for (size, secs) in [("321x241", 0.2), ("16x16", 0.2), ("3840x2160", 0.08)] {
        let input = p(&dir, &format!("{size}.mkv"));
        // testsrc2 rounds odd sizes to even: scale to the exact size.
        let scale = format!("scale={}", size.replace('x', ":"));
        clip(
            &input,
            "320x240",
            secs,
            &["-vf", &scale, "-c:v", "ffv1", "-pix_fmt", "yuv420p"],
        );
        // The default codec (H.264), which cannot subsample odd sizes.
        let out = p(&dir, &format!("{size}-out.mp4"));
        ok(bin().args([s(&input), "-o", s(&out), "--cpu"]));
        assert_eq!(frame_times(&input), frame_times(&out), "{size}");
        let dims = ffprobe(
            &out,
            &[
                "-select_streams",
                "v:0",
                "-show_entries",
                "stream=width,height",
                "-of",
                "csv=p=0:s=x",
            ],
        );
        assert_eq!(dims.trim(), size);
    }
}

#[test]
fn preview_is_the_frame_the_full_render_writes() {
    let dir = TempDir::new().expect("tmp");
    let input = p(&dir, "in.mp4");
    clip(
        &input,
        "160x120",
        2.0,
        &["-c:v", "libx264", "-g", "10", "-pix_fmt", "yuv420p"],
    );
    // A depth map of another size than the picture: a near box in its middle.
    let depth = p(&dir, "depth.png");
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(40, 30, |x, y| {
        image::Luma([if (10..30).contains(&x) && (8..22).contains(&y) {
            1500
        } else {
            0
        }])
    })
    .save(&depth)
    .expect("png");
    let plain = vec!["--rain", "30", "--opacity", "10", "--seed", "3", "--cpu"];
    let mut grounded = plain.clone();
    grounded.extend(["--ground", "auto", "--depth", s(&depth)]);
    let mut keyed = plain.clone();
    keyed.extend([
        "--ground",
        "horizon=0.6",
        "--set",
        "rain.rate_mm_per_h=[[0,0],[1,60],[1.5,5]]",
        "--set",
        "rain.wind_mps=[[0,[0,0]],[1,[8,0]]]",
        "--set",
        "camera.focus_m=[[0,1],[2,10]]",
    ]);
    keyed.retain(|a| *a != "--rain" && *a != "30");
    // A moving camera: a pan with a tilt and a zoom.
    let mut moving = plain.clone();
    moving.extend([
        "--set",
        "camera.pan_deg=[[0,0],[2,40]]",
        "--set",
        "camera.tilt_deg=[[0.5,0],[2,-8]]",
        "--set",
        "camera.fov_deg=[[0,60],[2,45]]",
    ]);
    check_preview_against_render(&dir, &input, "moving", &moving);
    check_preview_against_render(&dir, &input, "plain", &plain);
    check_preview_against_render(&dir, &input, "grounded", &grounded);
    check_preview_against_render(&dir, &input, "keyed", &keyed);
}

/// Puddles are stateful: a preview (and a chunk) fast-forwards the water from the clip's start,
/// and shows the frame a whole render writes there; the water changes the ground; puddles need
/// a given ground.
#[test]
fn puddles_preview_is_the_frame_the_full_render_writes() {
    let dir = TempDir::new().expect("tmp");
    let input = p(&dir, "in.mp4");
    clip(
        &input,
        "160x120",
        2.0,
        &["-c:v", "libx264", "-g", "10", "-pix_fmt", "yuv420p"],
    );
    let dry = vec![
        "--rain",
        "30",
        "--seed",
        "3",
        "--cpu",
        "--ground",
        "horizon=0.4",
        "--pre-rain",
        "240",
    ];
    let mut wet = dry.clone();
    wet.extend([
        "--puddles",
        "--puddle-particles",
        "1500",
        "--relief",
        "0.01",
    ]);
    check_preview_against_render(&dir, &input, "puddles", &wet);
    let still = |look: &[&str], name: &str| {
        let png = p(&dir, name);
        ok(bin()
            .args([
                "preview",
                s(&input),
                "--at",
                "1.2s",
                "-o",
                s(&png),
                "--bits",
                "16",
            ])
            .args(look));
        std::fs::read(&png).expect("png")
    };
    assert_ne!(
        still(&wet, "wet.png"),
        still(&dry, "dry.png"),
        "puddles show"
    );
    // Puddles lie on a given ground: without one, one error line and no file.
    let refused = p(&dir, "refused.mov");
    let out = bin()
        .args([s(&input), "-o", s(&refused), "--puddles"])
        .output()
        .expect("run");
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && e.contains("--puddles"), "{e}");
    assert!(!refused.exists());
}

/// Frames 30 (`--at 1.2s`) and 17 (`--frame 17`) previewed with `look` equal those frames of
/// the full render with `look`.
fn check_preview_against_render(dir: &TempDir, input: &Path, tag: &str, look: &[&str]) {
    let full = p(dir, &format!("{tag}-full.mkv"));
    ok(bin()
        .args([s(input), "-o", s(&full), "--codec", "ffv1"])
        .args(look));
    for (flag, value, index) in [("--at", "1.2s", 30), ("--frame", "17", 17)] {
        let preview = p(dir, &format!("{tag}-preview-{index}.png"));
        ok(bin()
            .args([
                "preview",
                s(input),
                flag,
                value,
                "-o",
                s(&preview),
                "--bits",
                "16",
            ])
            .args(look));
        // The full render's frame through the same still conversion (no rain added).
        let from_full = p(dir, &format!("{tag}-full-{index}.png"));
        ok(bin().args([
            "preview",
            s(&full),
            "--frame",
            &index.to_string(),
            "-o",
            s(&from_full),
            "--bits",
            "16",
            "--rain",
            "0",
            "--cpu",
        ]));
        let (a, b) = (
            std::fs::read(&preview).expect("png"),
            std::fs::read(&from_full).expect("png"),
        );
        assert!(
            a == b,
            "{look:?} {flag} {value}: preview differs from frame {index} of the render"
        );
    }
}

#[test]
fn works_inside_a_pipe() {
    let dir = TempDir::new().expect("tmp");
    let input = p(&dir, "in.mp4");
    clip(
        &input,
        "96x64",
        0.6,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
    );
    let mut src = Command::new("ffmpeg")
        .args(["-v", "error", "-i", s(&input), "-f", "yuv4mpegpipe", "-"])
        .stdout(Stdio::piped())
        .spawn()
        .expect("ffmpeg");
    let mut rain = bin()
        .args(["-", "-o", "-", "--cpu"])
        .stdin(src.stdout.take().expect("stdout"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("rain-composite");
    let sink = Command::new("ffmpeg")
        .args(["-v", "error", "-i", "-", "-f", "framemd5", "-"])
        .stdin(rain.stdout.take().expect("stdout"))
        .output()
        .expect("ffmpeg");
    assert!(src.wait().expect("wait").success());
    let status = rain.wait_with_output().expect("wait");
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let frames = String::from_utf8_lossy(&sink.stdout)
        .lines()
        .filter(|l| !l.starts_with('#'))
        .count();
    assert_eq!(frames, 15);
}

/// Runs a command that must fail; returns its stderr.
fn fails(cmd: &mut Command) -> String {
    let out = cmd.output().expect("spawn");
    assert!(!out.status.success(), "{cmd:?} should fail");
    assert_eq!(
        out.status.code(),
        Some(1),
        "{cmd:?}: exit code (not a panic)"
    );
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        err.lines().filter(|l| l.starts_with("error")).count(),
        1,
        "one error line: {err}"
    );
    err
}

fn only_files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn user_mistakes_and_bad_files_give_one_clear_line_and_no_output() {
    let dir = TempDir::new().expect("tmp");
    let good = p(&dir, "good.mp4");
    clip(
        &good,
        "96x64",
        1.0,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
    );
    let out = p(&dir, "out.mp4");

    let err = fails(bin().args([s(&p(&dir, "missing.mp4")), "-o", s(&out)]));
    assert!(err.contains("missing.mp4"), "{err}");

    let text = p(&dir, "notes.mp4");
    std::fs::write(&text, "this is not a video\n".repeat(50)).expect("write");
    fails(bin().args([s(&text), "-o", s(&out), "--cpu"]));

    let bytes = std::fs::read(&good).expect("read");
    let truncated = p(&dir, "truncated.mp4");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).expect("write");
    fails(bin().args([s(&truncated), "-o", s(&out), "--cpu"]));

    let err = fails(bin().args([s(&good), "-o", s(&p(&dir, "no/such/dir/out.mp4")), "--cpu"]));
    assert!(err.contains("out.mp4"), "{err}");

    let err = fails(bin().args([s(&good), "-o", s(&out), "--fov", "500", "--cpu"]));
    assert!(err.contains("--fov"), "{err}");
    let err = fails(bin().args([s(&good), "-o", s(&out), "--rain", "buckets", "--cpu"]));
    assert!(err.contains("--rain"), "{err}");
    let err = fails(bin().args([s(&good), "-o", s(&out), "--encoder-params", "bframes"]));
    assert!(err.contains("--encoder-params"), "{err}");

    assert_eq!(
        only_files(dir.path()),
        ["good.mp4", "notes.mp4", "truncated.mp4"],
        "no output or temporary file left"
    );

    std::fs::write(&out, b"precious").expect("write");
    let err = fails(bin().args([s(&good), "-o", s(&out), "--cpu"]));
    assert!(err.contains("-y"), "{err}");
    assert_eq!(std::fs::read(&out).expect("read"), b"precious");
}

fn json_of(cmd: &mut Command) -> serde_json::Value {
    let out = ok(cmd);
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

#[test]
fn inspect_prints_the_models_as_json() {
    // RTF: energy per order plus the truncated tail is all the light that hits the drop.
    let rtf = json_of(bin().args([
        "inspect", "rtf", "--rho", "1.333", "--nmax", "9", "--bins", "256", "--json",
    ]));
    let ch = &rtf["channels"][0];
    let sum: f64 = ch["energy_per_order"]
        .as_array()
        .expect("array")
        .iter()
        .map(|v| v.as_f64().expect("f64"))
        .sum();
    let tail = ch["tail_energy"].as_f64().expect("tail");
    assert!((sum + tail - 1.0).abs() < 1e-9, "{sum} + {tail}");
    // Descartes' primary bow: cos²γ = (ρ²−1)/3, deviation 2(γ−β)+(π−2β), seen at 180° − D.
    let rho: f64 = 1.333;
    let g = ((rho * rho - 1.0) / 3.0).sqrt().acos();
    let b = (g.sin() / rho).asin();
    let bow_deg = 180.0 - (2.0 * (g - b) + std::f64::consts::PI - 2.0 * b).to_degrees();
    let caustic = ch["caustic_scattering_angle_deg"]["3"]
        .as_f64()
        .expect("order 3");
    // The report measures θ from the forward direction: the bow is at 180° − (its radius).
    assert!(
        (180.0 - caustic - bow_deg).abs() < 0.01,
        "{caustic} vs bow {bow_deg}"
    );

    let drops = json_of(bin().args([
        "inspect", "drops", "--rain", "10", "--count", "50", "--size", "640x360", "--json",
    ]));
    assert_eq!(drops["sample"]["drops"].as_array().map(Vec::len), Some(50));

    let dir = TempDir::new().expect("tmp");
    let plot = p(&dir, "sh.png");
    let sh = json_of(bin().args([
        "inspect",
        "sh",
        "tests/data/courtyard_128x64.png",
        "--bands",
        "3",
        "--plot",
        s(&plot),
    ]));
    assert_eq!(sh["coeffs"].as_array().map(Vec::len), Some(9));
    assert!(plot.exists());
    let sph = json_of(bin().args([
        "inspect", "sph", "--scene", "column", "--steps", "20", "--json",
    ]));
    assert!(sph.is_object());
    let err = fails(bin().args(["inspect", "rtf", "--rho", "0.5"]));
    assert!(err.contains("rho"), "{err}");
}

#[test]
fn ctrl_c_stops_cleanly_and_leaves_no_output() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "long.mp4", "320x240", 30.0);
    let out = p(&dir, "out.mp4");
    let mut child = bin()
        .args([s(&input), "-o", s(&out), "--cpu", "--progress", "json"])
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    // Wait until frames are flowing (a progress line), then interrupt.
    let mut stderr = std::io::BufReader::new(child.stderr.take().expect("stderr"));
    let mut line = String::new();
    std::io::BufRead::read_line(&mut stderr, &mut line).expect("progress line");
    let progress: serde_json::Value = serde_json::from_str(&line).expect("JSON progress");
    assert!(progress["frames_done"].as_u64().is_some_and(|n| n >= 1));
    let pid = child.id().to_string();
    assert!(
        Command::new("kill")
            .args(["-INT", &pid])
            .status()
            .expect("kill")
            .success()
    );
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut stderr, &mut rest).expect("stderr");
    assert!(rest.contains("error: interrupted"), "{rest}");
    let status = child.wait().expect("wait");
    assert_eq!(status.code(), Some(1));
    assert_eq!(
        only_files(dir.path()),
        ["long.mp4"],
        "no output or temporary file left"
    );
}

#[test]
fn a_truncated_stream_is_an_error_even_when_its_start_decodes() {
    let dir = TempDir::new().expect("tmp");
    let input = p(&dir, "in.mp4");
    clip(
        &input,
        "160x120",
        2.0,
        &[
            "-c:v",
            "libx264",
            "-pix_fmt",
            "yuv420p",
            "-movflags",
            "+faststart",
        ],
    );
    let bytes = std::fs::read(&input).expect("read");
    let cut = p(&dir, "cut.mp4");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).expect("write");
    std::fs::remove_file(&input).expect("rm");
    let err = fails(bin().args([s(&cut), "-o", s(&p(&dir, "out.mp4")), "--cpu"]));
    assert!(err.contains("ends early"), "{err}");
    assert_eq!(
        only_files(dir.path()),
        ["cut.mp4"],
        "no output or temporary file left"
    );
}

/// A report's plot is checked before the report's work: a name that is not PNG, a directory or
/// a missing folder is one error line, and an existing file of that name is left as it was; a
/// plot that is written replaces the old file whole and leaves nothing beside it.
#[test]
fn inspect_plots_are_checked_first_and_never_destroy_a_file() {
    let dir = TempDir::new().expect("tmp");
    let input = p(&dir, "in.mp4");
    clip(&input, "96x64", 0.5, &[]);
    let keep = p(&dir, "plot.jpg");
    std::fs::write(&keep, "keep").expect("write");
    let image = "tests/data/courtyard_128x64.png";
    let puddles = [
        "inspect",
        "puddles",
        s(&input),
        "--at",
        "0.4",
        "--ground",
        "horizon=0.4",
    ];
    let reports: [&[&str]; 6] = [
        &["inspect", "rtf", "--bins", "64"],
        &["inspect", "sh", image],
        &["inspect", "light", image],
        &["inspect", "ground", s(&input)],
        &puddles,
        &["inspect", "drops"],
    ];
    let sub = p(&dir, "sub");
    std::fs::create_dir(&sub).expect("mkdir");
    let missing = p(&dir, "no/such/plot.png");
    let new = p(&dir, "new.jpg");
    let started = std::time::Instant::now();
    for report in reports {
        let flag = if report[1] == "drops" {
            "--mattes"
        } else {
            "--plot"
        };
        for (plot, says) in [
            (keep.as_path(), ".png"),
            (new.as_path(), ".png"),
            (sub.as_path(), "directory"),
            (missing.as_path(), "does not exist"),
        ] {
            let err = fails(bin().args(report).args([flag, s(plot)]));
            assert!(err.contains(says), "{report:?} {plot:?}: {err}");
        }
    }
    // Refused before the work: no simulation, no decoding.
    assert!(started.elapsed().as_secs() < 60, "{:?}", started.elapsed());
    assert_eq!(std::fs::read(&keep).expect("read"), b"keep");
    assert_eq!(only_files(dir.path()), ["in.mp4", "plot.jpg", "sub"]);

    let plot = p(&dir, "rtf.png");
    std::fs::write(&plot, "old").expect("write");
    ok(bin().args(["inspect", "rtf", "--bins", "64", "--plot", s(&plot)]));
    assert_eq!(&std::fs::read(&plot).expect("read")[..4], b"\x89PNG");
    assert_eq!(
        only_files(dir.path()),
        ["in.mp4", "plot.jpg", "rtf.png", "sub"]
    );
}
