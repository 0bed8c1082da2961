//! Decode → (frames unchanged) → encode round trips on clips generated with the ffmpeg CLI:
//! pixels, colour tags, timestamps, audio, rotation, pipes, seeking and error handling.

#[path = "common/fixtures.rs"]
mod fixtures;

use std::path::Path;

use fixtures::*;
use rain_composite::Error;
use rain_composite::video::{
    AudioMode, Chroma, EncodeOptions, Matrix, Sink, Source, SourceItem, StreamAction, VideoCodec,
    VideoInfo, YuvFrame, probe,
};
use tempfile::TempDir;

/// Source → Sink with every frame and packet passed through unchanged.
fn transcode(input: &Path, output: &Path, opts: &EncodeOptions) -> VideoInfo {
    let mut src = Source::open(s(input)).expect("open input");
    let info = src.info().clone();
    let mut sink = Sink::create(s(output), &info, opts).expect("create output");
    while let Some(item) = src.next_item().expect("read input") {
        match item {
            SourceItem::Frame(f) => sink.write_frame(&f).expect("write frame"),
            SourceItem::Packet(p) => sink.write_packet(p).expect("write packet"),
        }
    }
    sink.finish().expect("finish output");
    info
}

fn ffv1() -> EncodeOptions {
    EncodeOptions {
        codec: VideoCodec::Ffv1,
        ..Default::default()
    }
}

/// Decoding and re-encoding losslessly gives back the input's decoded frames bit for bit, with
/// the same colour tags.
fn assert_identity(input: &Path, dir: &Path) -> VideoInfo {
    let out = dir.join("identity.mkv");
    let info = transcode(input, &out, &ffv1());
    let a = framemd5(input, "0:v:0", false);
    let b = framemd5(&out, "0:v:0", false);
    assert!(!a.is_empty());
    assert_eq!(a, b, "decoded frames differ");
    assert_eq!(color_tags(input), color_tags(&out), "colour tags differ");
    info
}

const TAGS_709: [&str; 8] = [
    "-colorspace",
    "bt709",
    "-color_primaries",
    "bt709",
    "-color_trc",
    "bt709",
    "-color_range",
    "tv",
];

#[test]
fn identity_bt709_limited() {
    let dir = TempDir::new().unwrap();
    let mut args = vec!["-c:v", "libx264", "-pix_fmt", "yuv420p"];
    args.extend(TAGS_709);
    let input = clip(dir.path(), "in.mp4", "160x120", 25, 1.0, &args);
    let info = assert_identity(&input, dir.path());
    assert_eq!(info.color.matrix, Matrix::Bt709);
    assert!(!info.color.full_range);
    assert_eq!(color_tags(&input)[0], "bt709");
}

#[test]
fn identity_bt601_limited() {
    let dir = TempDir::new().unwrap();
    let args = [
        "-c:v",
        "libx264",
        "-pix_fmt",
        "yuv420p",
        "-colorspace",
        "smpte170m",
        "-color_primaries",
        "smpte170m",
        "-color_trc",
        "smpte170m",
        "-color_range",
        "tv",
    ];
    let input = clip(dir.path(), "in.mp4", "160x120", 25, 1.0, &args);
    let info = assert_identity(&input, dir.path());
    assert_eq!(info.color.matrix, Matrix::Bt601);
}

#[test]
fn identity_bt709_full_range_yuvj() {
    let dir = TempDir::new().unwrap();
    let args = [
        "-c:v",
        "libx264",
        "-pix_fmt",
        "yuvj420p",
        "-colorspace",
        "bt709",
        "-color_primaries",
        "bt709",
        "-color_trc",
        "bt709",
    ];
    let input = clip(dir.path(), "in.mp4", "160x120", 25, 1.0, &args);
    let info = assert_identity(&input, dir.path());
    assert_eq!(info.pixel_format, "yuvj420p");
    assert!(info.color.full_range, "yuvj420p is full range");
    assert_eq!(color_tags(&input)[1], "pc");
}

#[test]
fn identity_10bit_420() {
    let dir = TempDir::new().unwrap();
    let mut args = vec!["-c:v", "libx264", "-pix_fmt", "yuv420p10le"];
    args.extend(TAGS_709);
    let input = clip(dir.path(), "in.mkv", "160x120", 25, 1.0, &args);
    let info = assert_identity(&input, dir.path());
    assert_eq!(
        (info.format.chroma, info.format.bit_depth),
        (Chroma::Cs420, 10)
    );
}

#[test]
fn identity_10bit_422() {
    let dir = TempDir::new().unwrap();
    let mut args = vec!["-c:v", "libx264", "-pix_fmt", "yuv422p10le"];
    args.extend(TAGS_709);
    let input = clip(dir.path(), "in.mkv", "160x120", 25, 1.0, &args);
    let info = assert_identity(&input, dir.path());
    assert_eq!(
        (info.format.chroma, info.format.bit_depth),
        (Chroma::Cs422, 10)
    );
}

#[test]
fn identity_444() {
    let dir = TempDir::new().unwrap();
    let mut args = vec!["-c:v", "libx264", "-pix_fmt", "yuv444p"];
    args.extend(TAGS_709);
    let input = clip(dir.path(), "in.mp4", "160x120", 25, 1.0, &args);
    let info = assert_identity(&input, dir.path());
    assert_eq!(
        (info.format.chroma, info.format.bit_depth),
        (Chroma::Cs444, 8)
    );
}

#[test]
fn identity_12bit_444() {
    let dir = TempDir::new().unwrap();
    let mut args = vec!["-c:v", "ffv1", "-pix_fmt", "yuv444p12le"];
    args.extend(TAGS_709);
    let input = clip(dir.path(), "in.mkv", "160x120", 25, 0.4, &args);
    let info = assert_identity(&input, dir.path());
    assert_eq!(
        (info.format.chroma, info.format.bit_depth),
        (Chroma::Cs444, 12)
    );
}

#[test]
fn x264_output_matches_the_ffmpeg_cli() {
    let dir = TempDir::new().unwrap();
    let mut args = vec!["-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "10"];
    args.extend(TAGS_709);
    let input = clip(dir.path(), "in.mp4", "160x120", 25, 1.0, &args);
    let ours = dir.path().join("ours.mp4");
    transcode(&input, &ours, &EncodeOptions::default());
    let reference = dir.path().join("ref.mp4");
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
    let db = psnr(&ours, &reference);
    assert!(db >= 50.0, "PSNR {db} dB");
    assert_eq!(color_tags(&input), color_tags(&ours));
    assert_eq!(stream(&ours, "v:0")["codec_name"], "h264");

    // Without our options: x264's own defaults at the same CRF and preset.
    let plain = EncodeOptions {
        encoder_params: String::new(),
        ..EncodeOptions::default()
    };
    let (ours, reference) = (
        dir.path().join("plain.mp4"),
        dir.path().join("plain-ref.mp4"),
    );
    transcode(&input, &ours, &plain);
    ffmpeg(&[
        "-i",
        s(&input),
        "-c:v",
        "libx264",
        "-crf",
        "18",
        s(&reference),
    ]);
    let db = psnr(&ours, &reference);
    assert!(db >= 50.0, "without our options: PSNR {db} dB");
}

#[test]
fn constant_rate_frames_and_timestamps_are_kept() {
    let dir = TempDir::new().unwrap();
    let input = clip(
        dir.path(),
        "in.mp4",
        "160x120",
        30,
        1.0,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
    );
    let out = dir.path().join("out.mp4");
    let info = transcode(&input, &out, &EncodeOptions::default());
    assert!(!info.variable_frame_rate);
    assert_eq!(info.frame_count, Some(30));
    assert_eq!(frame_times(&input), frame_times(&out));
    let duration = |p: &Path| -> f64 {
        ffprobe(p, &["-show_format"])["format"]["duration"]
            .as_str()
            .unwrap()
            .parse()
            .unwrap()
    };
    assert!((duration(&input) - duration(&out)).abs() < 1e-6);
}

#[test]
fn variable_rate_frames_and_timestamps_are_kept() {
    let dir = TempDir::new().unwrap();
    // 10 frames, a 0.48 s gap, 15 more frames. (The expression is in ticks of testsrc2's 1/25
    // time base: `(N+12)/25/TB` would round 29 down to 28 and repeat a timestamp.)
    let input = clip(
        dir.path(),
        "in.mkv",
        "160x120",
        25,
        1.0,
        &[
            "-vf",
            "setpts='if(lt(N,10),N,N+12)'",
            "-fps_mode",
            "passthrough",
            "-c:v",
            "libx264",
            "-pix_fmt",
            "yuv420p",
        ],
    );
    let out = dir.path().join("out.mp4");
    let info = transcode(&input, &out, &EncodeOptions::default());
    assert!(info.variable_frame_rate);
    let (a, b) = (frame_times(&input), frame_times(&out));
    assert_eq!(a.len(), 25);
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 1e-9, "{a:?} vs {b:?}");
    }
}

#[test]
fn aac_audio_is_copied_bit_exactly() {
    let dir = TempDir::new().unwrap();
    let input = clip_with_audio(
        dir.path(),
        "in.mp4",
        1.0,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
        &["-c:a", "aac"],
    );
    let out = dir.path().join("out.mp4");
    transcode(&input, &out, &EncodeOptions::default());
    let a = framemd5(&input, "0:a:0", true);
    assert!(a.len() > 10);
    assert_eq!(a, framemd5(&out, "0:a:0", true));
}

#[test]
fn opus_audio_is_copied_bit_exactly() {
    let dir = TempDir::new().unwrap();
    let input = clip_with_audio(
        dir.path(),
        "in.mkv",
        1.0,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
        &["-c:a", "libopus"],
    );
    let out = dir.path().join("out.mkv");
    transcode(&input, &out, &EncodeOptions::default());
    let a = framemd5(&input, "0:a:0", true);
    assert!(a.len() > 10);
    assert_eq!(a, framemd5(&out, "0:a:0", true));
    assert_eq!(stream(&out, "a:0")["codec_name"], "opus");
}

#[test]
fn pcm_into_mp4_falls_back_to_aac_with_a_warning() {
    init_logger();
    let dir = TempDir::new().unwrap();
    let input = clip_with_audio(
        dir.path(),
        "in.mov",
        1.0,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
        &["-c:a", "pcm_s16le"],
    );
    let report = probe(s(&input), Some("mp4")).unwrap();
    assert_eq!(
        report.video.streams[1].action,
        Some(StreamAction::TranscodeAac)
    );
    let out = dir.path().join("out.mp4");
    transcode(&input, &out, &EncodeOptions::default());
    let a = stream(&out, "a:0");
    assert_eq!(a["codec_name"], "aac");
    assert_eq!(a["sample_rate"], "48000");
    let dur: f64 = a["duration"].as_str().unwrap().parse().unwrap();
    assert!((dur - 1.0).abs() < 0.05, "audio lasts {dur} s");
    assert!(
        my_warnings()
            .iter()
            .any(|w| w.contains("AAC") && w.contains("pcm_s16le")),
        "{:?}",
        my_warnings()
    );
    // In Matroska the PCM is copied as it is.
    let mkv = dir.path().join("out.mkv");
    transcode(&input, &mkv, &EncodeOptions::default());
    assert_eq!(
        framemd5(&input, "0:a:0", true),
        framemd5(&mkv, "0:a:0", true)
    );
}

#[test]
fn audio_start_offset_stays_in_sync() {
    let dir = TempDir::new().unwrap();
    let input = dir.path().join("in.mp4");
    ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "testsrc2=s=160x120:r=25:d=1.5",
        "-itsoffset",
        "0.5",
        "-f",
        "lavfi",
        "-i",
        "sine=sample_rate=48000:duration=1",
        "-c:v",
        "libx264",
        "-pix_fmt",
        "yuv420p",
        "-c:a",
        "aac",
        s(&input),
    ]);
    let start = |p: &Path, k: &str| -> f64 {
        stream(p, k)["start_time"]
            .as_str()
            .unwrap()
            .parse()
            .unwrap()
    };
    let offset_in = start(&input, "a:0") - start(&input, "v:0");
    assert!(offset_in > 0.4, "fixture offset {offset_in}");
    for (name, opts) in [
        ("out.mp4", EncodeOptions::default()),
        ("out.mkv", EncodeOptions::default()),
    ] {
        let out = dir.path().join(name);
        transcode(&input, &out, &opts);
        let offset_out = start(&out, "a:0") - start(&out, "v:0");
        assert!(
            (offset_out - offset_in).abs() <= 1024.0 / 48000.0,
            "{name}: {offset_in} → {offset_out}"
        );
    }
}

#[test]
fn display_rotation_is_kept() {
    let dir = TempDir::new().unwrap();
    let plain = clip(
        dir.path(),
        "plain.mp4",
        "160x120",
        25,
        0.4,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
    );
    let input = dir.path().join("in.mp4");
    ffmpeg(&[
        "-i",
        s(&plain),
        "-c",
        "copy",
        "-metadata:s:v:0",
        "rotate=90",
        s(&input),
    ]);
    let rotation = |p: &Path| -> i64 {
        let v = stream(p, "v:0");
        v["side_data_list"]
            .as_array()
            .and_then(|l| l.iter().find_map(|sd| sd["rotation"].as_i64()))
            .unwrap_or(0)
    };
    let r_in = rotation(&input);
    assert_ne!(r_in, 0, "fixture has a rotation");
    let out = dir.path().join("out.mp4");
    let info = transcode(&input, &out, &EncodeOptions::default());
    assert_eq!(info.rotation_deg as i64, r_in.rem_euclid(360));
    assert_eq!(rotation(&out), r_in);
    // Frames stay in coded orientation.
    assert_eq!((info.format.width, info.format.height), (160, 120));
}

#[test]
fn odd_tiny_and_4k_sizes_work() {
    let dir = TempDir::new().unwrap();
    let odd = clip(
        dir.path(),
        "odd.mkv",
        "320x240",
        25,
        0.2,
        &[
            "-vf",
            "scale=321:241",
            "-c:v",
            "ffv1",
            "-pix_fmt",
            "yuv420p",
        ],
    );
    let info = assert_identity(&odd, dir.path());
    assert_eq!((info.format.width, info.format.height), (321, 241));

    let tiny = clip(
        dir.path(),
        "tiny.mp4",
        "16x16",
        25,
        0.4,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
    );
    let out = dir.path().join("tiny_out.mp4");
    transcode(&tiny, &out, &EncodeOptions::default());
    assert_eq!(frame_times(&out).len(), 10);
    assert!(psnr(&out, &tiny) > 30.0);

    let big = quick_clip(dir.path(), "big.mp4", "3840x2160", 0.08);
    let out = dir.path().join("big_out.mkv");
    transcode(&big, &out, &ffv1());
    assert_eq!(
        framemd5(&big, "0:v:0", false),
        framemd5(&out, "0:v:0", false)
    );
    assert_eq!(framemd5(&out, "0:v:0", false).len(), 2);
}

#[test]
fn odd_sizes_in_h264_keep_their_size_with_full_chroma() {
    let dir = TempDir::new().unwrap();
    let odd = clip(
        dir.path(),
        "odd.mkv",
        "320x240",
        25,
        0.2,
        &[
            "-vf",
            "scale=321:241",
            "-c:v",
            "ffv1",
            "-pix_fmt",
            "yuv420p",
        ],
    );
    let out = dir.path().join("out.mp4");
    transcode(&odd, &out, &EncodeOptions::default());
    let v = stream(&out, "v");
    assert_eq!(
        (v["width"].as_u64(), v["height"].as_u64()),
        (Some(321), Some(241))
    );
    assert_eq!(v["pix_fmt"].as_str(), Some("yuv444p"));
    // The same picture: chroma repeated, not resampled away.
    assert!(psnr(&out, &odd) > 40.0);
}

#[test]
fn y4m_output_to_a_file() {
    let dir = TempDir::new().unwrap();
    let mut args = vec!["-c:v", "libx264", "-pix_fmt", "yuv420p10le"];
    args.extend(TAGS_709);
    let input = clip(dir.path(), "in.mkv", "160x120", 25, 0.6, &args);
    let out = dir.path().join("out.y4m");
    let opts = EncodeOptions {
        container: Some("yuv4mpegpipe".into()),
        ..Default::default()
    };
    transcode(&input, &out, &opts);
    let v = stream(&out, "v:0");
    assert_eq!(v["pix_fmt"], "yuv420p10le");
    assert_eq!(v["r_frame_rate"], "25/1");
    assert_eq!(
        framemd5(&input, "0:v:0", false),
        framemd5(&out, "0:v:0", false)
    );
}

/// The child half of `stdin_to_stdout_pipes`: reads stdin, writes stdout (y4m, or the
/// container named by `RAIN_PIPE_FORMAT`).
#[test]
#[ignore = "run by stdin_to_stdout_pipes as a child process"]
fn pipe_child() {
    if std::env::var_os("RAIN_PIPE_CHILD").is_none() {
        return;
    }
    let mut src = Source::open("-").expect("open stdin");
    assert!(!src.is_seekable());
    assert!(src.seek_to_time(0.1).is_err());
    let info = src.info().clone();
    let opts = EncodeOptions {
        container: std::env::var("RAIN_PIPE_FORMAT").ok(),
        codec: VideoCodec::Ffv1,
        ..Default::default()
    };
    let mut sink = Sink::create("-", &info, &opts).expect("stdout");
    assert!(sink.temp_path().is_none());
    while let Some(item) = src.next_item().expect("read") {
        match item {
            SourceItem::Frame(f) => sink.write_frame(&f).expect("write"),
            SourceItem::Packet(p) => sink.write_packet(p).expect("packet"),
        }
    }
    sink.finish().expect("finish");
}

/// Runs `pipe_child` with `input` on stdin; returns what it wrote to stdout.
fn through_pipe(input: &Path, format: Option<&str>, magic: &[u8]) -> Vec<u8> {
    let mut cmd = std::process::Command::new(std::env::current_exe().unwrap());
    cmd.args([
        "--exact",
        "pipe_child",
        "--ignored",
        "--test-threads=1",
        "-q",
    ])
    .env("RAIN_PIPE_CHILD", "1")
    .stdin(std::fs::File::open(input).unwrap());
    if let Some(f) = format {
        cmd.env("RAIN_PIPE_FORMAT", f);
    }
    let child = cmd.output().unwrap();
    assert!(
        child.status.success(),
        "{}",
        String::from_utf8_lossy(&child.stderr)
    );
    // The test harness prints "running 1 test" before and ".\ntest result: …" after the
    // stream; cut those off.
    let out = child.stdout;
    let start = out
        .windows(magic.len())
        .position(|w| w == magic)
        .expect("the stream's header on stdout");
    let tail: &[u8] = b".\ntest result:";
    let end = out
        .windows(tail.len())
        .rposition(|w| w == tail)
        .expect("the harness summary");
    out[start..end].to_vec()
}

#[test]
fn stdin_to_stdout_pipes() {
    let dir = TempDir::new().unwrap();
    // A NUT stream with audio on stdin.
    let input = clip_with_audio(
        dir.path(),
        "in.nut",
        0.6,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
        &["-c:a", "pcm_s16le"],
    );
    // y4m (video only) by default.
    let y4m = dir.path().join("piped.y4m");
    std::fs::write(&y4m, through_pipe(&input, None, b"YUV4MPEG2")).unwrap();
    assert_eq!(
        framemd5(&input, "0:v:0", false),
        framemd5(&y4m, "0:v:0", false)
    );
    // Matroska carries the audio too, without seeking.
    let mkv = dir.path().join("piped.mkv");
    std::fs::write(
        &mkv,
        through_pipe(&input, Some("matroska"), &[0x1a, 0x45, 0xdf, 0xa3]),
    )
    .unwrap();
    assert_eq!(
        framemd5(&input, "0:v:0", false),
        framemd5(&mkv, "0:v:0", false)
    );
    assert_eq!(
        framemd5(&input, "0:a:0", true),
        framemd5(&mkv, "0:a:0", true)
    );
}

#[test]
fn nut_output_to_a_file_carries_audio() {
    let dir = TempDir::new().unwrap();
    let input = clip_with_audio(
        dir.path(),
        "in.mkv",
        0.6,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
        &["-c:a", "pcm_s16le"],
    );
    let out = dir.path().join("out.bin");
    let opts = EncodeOptions {
        container: Some("nut".into()),
        codec: VideoCodec::Ffv1,
        ..Default::default()
    };
    transcode(&input, &out, &opts);
    assert_eq!(
        framemd5(&input, "0:v:0", false),
        framemd5(&out, "0:v:0", false)
    );
    assert_eq!(
        framemd5(&input, "0:a:0", true),
        framemd5(&out, "0:a:0", true)
    );
    // Audio can be left out.
    let silent = dir.path().join("silent.mkv");
    let opts = EncodeOptions {
        audio: AudioMode::None,
        ..Default::default()
    };
    transcode(&input, &silent, &opts);
    assert!(stream(&silent, "a").is_null());
}

#[test]
fn prores_and_hevc_outputs() {
    init_logger();
    let dir = TempDir::new().unwrap();
    let mut args = vec!["-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "10"];
    args.extend(TAGS_709);
    let input = clip(dir.path(), "in.mp4", "160x120", 25, 0.4, &args);
    // ProRes has no 4:2:0: 4:2:2 10-bit, with a warning saying so.
    let prores = dir.path().join("out.mov");
    let opts = EncodeOptions {
        codec: VideoCodec::ProRes,
        ..Default::default()
    };
    transcode(&input, &prores, &opts);
    let v = stream(&prores, "v:0");
    assert_eq!(v["codec_name"], "prores");
    assert_eq!(v["pix_fmt"], "yuv422p10le");
    assert!(my_warnings().iter().any(|w| w.contains("yuv422p10le")));
    assert!(psnr(&prores, &input) > 40.0);
    assert_eq!(color_tags(&input), color_tags(&prores));

    let hevc = dir.path().join("out.mkv");
    let opts = EncodeOptions {
        codec: VideoCodec::Hevc,
        preset: "ultrafast".into(),
        ..Default::default()
    };
    transcode(&input, &hevc, &opts);
    let v = stream(&hevc, "v:0");
    assert_eq!(v["codec_name"], "hevc");
    assert!(psnr(&hevc, &input) > 35.0);
    assert_eq!(color_tags(&input), color_tags(&hevc));
    assert_eq!(frame_times(&hevc), frame_times(&input));
}

#[test]
fn metadata_subtitles_and_faststart() {
    init_logger();
    let dir = TempDir::new().unwrap();
    let srt = dir.path().join("subs.srt");
    std::fs::write(&srt, "1\n00:00:00,000 --> 00:00:00,500\nRain.\n").unwrap();
    let input = dir.path().join("in.mkv");
    ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "testsrc2=s=160x120:r=25:d=1",
        "-i",
        s(&srt),
        "-map",
        "0",
        "-map",
        "1",
        "-c:v",
        "libx264",
        "-pix_fmt",
        "yuv420p",
        "-c:s",
        "srt",
        "-metadata",
        "title=Wet street",
        "-metadata:s:s:0",
        "language=fra",
        s(&input),
    ]);
    // Matroska keeps the SubRip track, with its language.
    let mkv = dir.path().join("out.mkv");
    transcode(&input, &mkv, &EncodeOptions::default());
    let sub = stream(&mkv, "s:0");
    assert_eq!(sub["codec_name"], "subrip");
    assert_eq!(sub["tags"]["language"], "fra");
    let fmt = ffprobe(&mkv, &["-show_format"]);
    assert_eq!(fmt["format"]["tags"]["title"], "Wet street");
    // MP4 cannot hold SubRip: dropped with a warning; the index is written up front.
    let mp4 = dir.path().join("out.mp4");
    transcode(&input, &mp4, &EncodeOptions::default());
    assert!(stream(&mp4, "s").is_null());
    assert!(my_warnings().iter().any(|w| w.contains("subrip")));
    let bytes = std::fs::read(&mp4).unwrap();
    let at = |tag: &[u8]| bytes.windows(4).position(|w| w == tag).unwrap();
    assert!(at(b"moov") < at(b"mdat"), "+faststart puts the index first");
    let fmt = ffprobe(&mp4, &["-show_format"]);
    assert_eq!(fmt["format"]["tags"]["title"], "Wet street");
}

#[test]
fn damaged_frames_are_warned_about_and_decoding_goes_on() {
    init_logger();
    let dir = TempDir::new().unwrap();
    let input = clip(
        dir.path(),
        "in.ts",
        "160x120",
        25,
        2.0,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p", "-g", "25"],
    );
    let mut bytes = std::fs::read(&input).unwrap();
    let n = bytes.len();
    for b in &mut bytes[n / 2..n / 2 + 3000] {
        *b = b.wrapping_mul(7).wrapping_add(13);
    }
    let damaged = dir.path().join("damaged.ts");
    std::fs::write(&damaged, &bytes).unwrap();
    let out = dir.path().join("out.mkv");
    transcode(&damaged, &out, &ffv1());
    let frames = frame_times(&out).len();
    assert!((40..=50).contains(&frames), "{frames} frames");
    let warnings = my_warnings();
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("damaged") && w.contains("frame")),
        "{warnings:?}"
    );
}

#[test]
fn missing_input_is_an_open_error() {
    let err = Source::open("/nonexistent/clip.mp4").err().unwrap();
    assert!(matches!(err, Error::InputOpen { .. }), "{err}");
}

#[test]
fn a_text_file_is_not_a_video() {
    let dir = TempDir::new().unwrap();
    let p = dir.path().join("notes.mp4");
    std::fs::write(&p, "These are notes, not a video.\n".repeat(50)).unwrap();
    let err = Source::open(s(&p)).err().unwrap();
    assert!(matches!(err, Error::InputOpen { .. }), "{err}");
    assert!(err.to_string().contains("not a video"), "{err}");
    // Sound alone is not video either.
    let audio = dir.path().join("tone.m4a");
    ffmpeg(&["-f", "lavfi", "-i", "sine=duration=0.2", s(&audio)]);
    let err = Source::open(s(&audio)).err().unwrap();
    assert!(matches!(err, Error::NoVideo(_)), "{err}");
}

#[test]
fn a_truncated_mp4_is_corrupt_input() {
    let dir = TempDir::new().unwrap();
    let input = clip(
        dir.path(),
        "in.mp4",
        "160x120",
        25,
        2.0,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
    );
    // The index (moov) is at the end: half a file has none.
    let bytes = std::fs::read(&input).unwrap();
    let cut = dir.path().join("cut.mp4");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let err = Source::open(s(&cut)).err().unwrap();
    assert!(matches!(err, Error::CorruptInput(_)), "{err}");

    // With the index up front the first half decodes, then the missing data is an error
    // (not a silently shorter output), naming where it stopped.
    let fast = dir.path().join("fast.mp4");
    ffmpeg(&[
        "-i",
        s(&input),
        "-c",
        "copy",
        "-movflags",
        "+faststart",
        s(&fast),
    ]);
    let bytes = std::fs::read(&fast).unwrap();
    let cut = dir.path().join("fastcut.mp4");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let mut src = Source::open(s(&cut)).unwrap();
    let mut frames = 0;
    let err = loop {
        match src.next_item() {
            Ok(Some(item)) => frames += matches!(item, SourceItem::Frame(_)) as u32,
            Ok(None) => panic!("a truncated input must not end cleanly"),
            Err(e) => break e,
        }
    };
    assert!(frames > 5 && frames < 50, "{frames} frames");
    assert!(matches!(err, Error::CorruptInput(_)), "{err}");
    assert!(err.to_string().contains("ends early"), "{err}");
}

#[test]
fn existing_output_needs_overwrite() {
    let dir = TempDir::new().unwrap();
    let input = clip(
        dir.path(),
        "in.mp4",
        "160x120",
        25,
        0.2,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
    );
    let out = dir.path().join("out.mp4");
    std::fs::write(&out, b"keep me").unwrap();
    let src = Source::open(s(&input)).unwrap();
    let err = Sink::create(s(&out), src.info(), &EncodeOptions::default())
        .err()
        .unwrap();
    assert!(matches!(err, Error::OutputExists(_)), "{err}");
    assert_eq!(std::fs::read(&out).unwrap(), b"keep me");
    assert_eq!(files_in(dir.path()), vec!["in.mp4", "out.mp4"]);
    // With overwrite it is replaced.
    let opts = EncodeOptions {
        overwrite: true,
        ..Default::default()
    };
    transcode(&input, &out, &opts);
    assert_eq!(frame_times(&out).len(), 5);
    assert_eq!(files_in(dir.path()), vec!["in.mp4", "out.mp4"]);
}

#[test]
fn unwritable_output_is_an_output_error() {
    let dir = TempDir::new().unwrap();
    let input = clip(
        dir.path(),
        "in.mp4",
        "160x120",
        25,
        0.2,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
    );
    // A "directory" that is a file cannot hold anything (works as root too).
    let blocker = dir.path().join("blocker");
    std::fs::write(&blocker, b"").unwrap();
    let src = Source::open(s(&input)).unwrap();
    let err = Sink::create(
        s(&blocker.join("out.mp4")),
        src.info(),
        &EncodeOptions::default(),
    )
    .err()
    .unwrap();
    assert!(matches!(err, Error::OutputWrite { .. }), "{err}");
    assert_eq!(files_in(dir.path()), vec!["blocker", "in.mp4"]);
}

#[test]
fn an_unfinished_sink_leaves_nothing_behind() {
    let dir = TempDir::new().unwrap();
    let input = clip(
        dir.path(),
        "in.mp4",
        "160x120",
        25,
        0.4,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
    );
    let out = dir.path().join("out.mp4");
    let mut src = Source::open(s(&input)).unwrap();
    let mut sink = Sink::create(s(&out), src.info(), &EncodeOptions::default()).unwrap();
    let temp = sink.temp_path().unwrap().to_owned();
    assert!(temp.exists());
    assert!(temp.file_name().unwrap().to_string_lossy().starts_with('.'));
    assert_eq!(temp.extension().unwrap(), "mp4");
    for _ in 0..3 {
        if let Some(SourceItem::Frame(f)) = src.next_item().unwrap() {
            sink.write_frame(&f).unwrap();
        }
    }
    drop(sink);
    assert_eq!(files_in(dir.path()), vec!["in.mp4"]);
}

/// Every frame of a full decode.
fn decode_all(path: &Path) -> Vec<YuvFrame> {
    let mut src = Source::open(s(path)).unwrap();
    let mut v = Vec::new();
    while let Some(item) = src.next_item().unwrap() {
        if let SourceItem::Frame(f) = item {
            v.push(f);
        }
    }
    v
}

fn check_seeks(path: &Path, times: &[f64], indices: &[u64]) {
    let all = decode_all(path);
    for (i, f) in all.iter().enumerate() {
        assert_eq!(f.index, i as u64);
    }
    let mut src = Source::open(s(path)).unwrap();
    let info = src.info().clone();
    let spt = info.seconds_per_tick();
    for &t in times {
        let got = src.seek_to_time(t).unwrap();
        let want = all
            .iter()
            .find(|f| (f.pts - info.start_pts) as f64 * spt >= t - 1e-9)
            .unwrap();
        assert_eq!((got.pts, got.index), (want.pts, want.index), "at {t} s");
        assert!(got == *want, "pixels differ at {t} s");
        // Decoding continues after it.
        if let Some(SourceItem::Frame(next)) = std::iter::from_fn(|| src.next_item().unwrap())
            .find(|i| matches!(i, SourceItem::Frame(_)))
            && let Some(w) = all.get(want.index as usize + 1)
        {
            assert_eq!((next.pts, next.index), (w.pts, w.index));
        }
    }
    for &n in indices {
        let got = src.frame_at_index(n).unwrap();
        assert!(got == all[n as usize], "frame {n}");
    }
    let last = all.last().unwrap();
    let beyond = (last.pts - info.start_pts) as f64 * spt + 0.5;
    assert!(matches!(
        src.seek_to_time(beyond),
        Err(Error::OutOfRange(_))
    ));
    assert!(matches!(
        src.frame_at_index(all.len() as u64),
        Err(Error::OutOfRange(_))
    ));
}

const GOP10: [&str; 12] = [
    "-c:v",
    "libx264",
    "-pix_fmt",
    "yuv420p",
    "-g",
    "10",
    "-keyint_min",
    "10",
    "-sc_threshold",
    "0",
    "-bf",
    "2",
];

#[test]
fn seeking_matches_a_full_decode() {
    let dir = TempDir::new().unwrap();
    let input = clip(dir.path(), "in.mp4", "160x120", 25, 2.0, &GOP10);
    check_seeks(
        &input,
        &[0.0, 0.01, 0.39, 0.4, 0.41, 0.8, 1.23, 1.96],
        &[0, 9, 10, 11, 23, 49, 30],
    );
}

#[test]
fn seeking_a_variable_rate_clip_matches_a_full_decode() {
    let dir = TempDir::new().unwrap();
    let mut args = vec![
        "-vf",
        "setpts='if(lt(N,15),N,N+20)'",
        "-fps_mode",
        "passthrough",
    ];
    args.extend(GOP10);
    let input = clip(dir.path(), "in.mkv", "160x120", 25, 1.2, &args);
    check_seeks(&input, &[0.3, 0.7, 1.0, 1.5], &[0, 14, 15, 16, 29]);
}

/// A clip in `pix_fmt` made from the same source as a yuv420p/yuv420p10le reference.
fn layout_pair(dir: &Path, pix: &str, reference: &str) -> (Vec<YuvFrame>, Vec<YuvFrame>) {
    let src = clip(
        dir,
        &format!("src_{pix}.nut"),
        "64x48",
        25,
        0.12,
        &["-c:v", "rawvideo", "-pix_fmt", reference],
    );
    let conv = dir.join(format!("{pix}.nut"));
    ffmpeg(&["-i", s(&src), "-c:v", "rawvideo", "-pix_fmt", pix, s(&conv)]);
    (decode_all(&src), decode_all(&conv))
}

#[test]
fn packed_and_semi_planar_layouts_are_rearranged_without_changing_samples() {
    let dir = TempDir::new().unwrap();
    // (P010 has no container for raw samples; the converter's unit tests cover it.)
    for (pix, reference) in [
        ("nv12", "yuv420p"),
        ("nv21", "yuv420p"),
        ("yuyv422", "yuv422p"),
        ("uyvy422", "yuv422p"),
    ] {
        let (a, b) = layout_pair(dir.path(), pix, reference);
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.format, y.format, "{pix}");
            assert!(x.planes == y.planes, "{pix} samples differ");
        }
    }
    // Grey: luma kept as it is (FFmpeg's grey is full range), chroma neutral.
    let (_, b) = layout_pair(dir.path(), "gray", "yuv420p");
    let gray = std::process::Command::new("ffmpeg")
        .args(["-v", "error", "-i", s(&dir.path().join("gray.nut"))])
        .args(["-frames:v", "1", "-f", "rawvideo", "-"])
        .output()
        .unwrap()
        .stdout;
    assert!(b[0].planes[0].data == gray, "grey luma changed");
    assert!(b[0].color.full_range);
    assert!(b[0].planes[1].data.iter().all(|&c| c == 128));
}

#[test]
fn rgb_sources_become_full_range_bt709() {
    let dir = TempDir::new().unwrap();
    let path = dir.path().join("red.nut");
    ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "color=c=0xC03010:s=32x32:d=0.12",
        "-c:v",
        "rawvideo",
        "-pix_fmt",
        "rgb24",
        s(&path),
    ]);
    let src = Source::open(s(&path)).unwrap();
    let info = src.info().clone();
    assert_eq!(
        (info.format.chroma, info.format.bit_depth),
        (Chroma::Cs444, 8)
    );
    assert_eq!(info.color.matrix, Matrix::Bt709);
    assert!(info.color.full_range);
    let f = decode_all(&path).remove(0);
    let code = [0, 1, 2].map(|i| f.sample(i, 5, 5) as f64);
    let linear = info.color.code_to_linear(code);
    // The RGB the file holds (lavfi's colour source rounds through YUV on the way).
    let rgb = std::process::Command::new("ffmpeg")
        .args([
            "-v",
            "error",
            "-i",
            s(&path),
            "-frames:v",
            "1",
            "-f",
            "rawvideo",
            "-",
        ])
        .output()
        .unwrap()
        .stdout;
    for (k, &v) in rgb[..3].iter().enumerate() {
        let encoded = rain_composite::video::color::oetf_signed(info.color.transfer, linear[k]);
        assert!(
            (encoded - v as f64 / 255.0).abs() < 1.0 / 255.0,
            "channel {k}: {encoded} for {v}"
        );
    }
}

#[test]
fn probe_reports_streams_and_plans() {
    let dir = TempDir::new().unwrap();
    let input = clip_with_audio(
        dir.path(),
        "in.mkv",
        0.4,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
        &["-c:a", "libopus"],
    );
    let r = probe(s(&input), Some("out.mp4")).unwrap();
    assert_eq!(r.output_container.as_deref(), Some("mp4"));
    assert_eq!(r.video.streams.len(), 2);
    assert_eq!(r.video.streams[0].action, Some(StreamAction::Render));
    assert_eq!(r.video.streams[1].action, Some(StreamAction::Copy));
    let json = serde_json::to_value(&r).unwrap();
    assert_eq!(json["video"]["format"]["width"], 160);
    assert_eq!(json["video"]["tags"]["range"], "unknown");
    assert_eq!(json["video"]["streams"][1]["codec"], "opus");
    let text = r.to_string();
    assert!(text.contains("opus") && text.contains("→ copy"), "{text}");
    let r = probe(s(&input), Some("y4m")).unwrap();
    assert!(matches!(
        r.video.streams[1].action,
        Some(StreamAction::Drop(_))
    ));
}

#[test]
fn source_and_sink_are_send() {
    fn send<T: Send>() {}
    fn sync<T: Sync>() {}
    send::<Source>();
    send::<Sink>();
    send::<SourceItem>();
    sync::<VideoInfo>();
}
