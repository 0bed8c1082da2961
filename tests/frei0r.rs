//! The frei0r plug-in (tools/frei0r) inside its three hosts: FFmpeg's `frei0r` filter, MLT's
//! `melt` (a project as Kdenlive writes one, and the command line) and GStreamer's
//! `frei0r-filter-rain-composite`. The plug-in is built here (`cargo build --release -p
//! rain-composite-frei0r`) and installed as `rain_composite` in a folder named by
//! `FREI0R_PATH`.
//!
//! Checked: every host renders every frame, rain changes them, the same input renders the same
//! frames bit for bit in every host; a frame without rain drawn and the alpha pass through
//! unchanged; each host's clock reaches the same shot time; frames in any order and on several
//! instances give the same pictures; the default frame matches `rain-composite preview` on the
//! same 8-bit RGB file to within the preview's own quantisation; what the plug-in refuses passes
//! the frames through with one message.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

use tempfile::TempDir;

#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::{clip, s};

#[path = "common/binary.rs"]
mod binary;
use binary::bin;

#[path = "common/gpu.rs"]
mod gpu;

/// The frames of these tests: small, so each host's run takes about a second.
const W: usize = 192;
const H: usize = 108;
const FRAME: usize = W * H * 4;
const FPS: u32 = 25;

/// The folder holding the freshly built plug-in as `rain_composite.<so>`, the name hosts know
/// it by.
fn plugin_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let out = Command::new(env!("CARGO"))
            .args(["build", "--release", "-p", "rain-composite-frei0r"])
            .arg("--message-format=json-render-diagnostics")
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .expect("cargo runs");
        assert!(
            out.status.success(),
            "building the plug-in failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let built = String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .filter(|m| m["reason"] == "compiler-artifact")
            .filter(|m| m["target"]["name"] == "rain_composite_frei0r")
            .flat_map(|m| m["filenames"].as_array().cloned().unwrap_or_default())
            .filter_map(|f| f.as_str().map(PathBuf::from))
            .find(|f| f.to_string_lossy().ends_with(std::env::consts::DLL_SUFFIX))
            .expect("cargo names the plug-in's shared library");
        // Beside the build, replaced at every run (a temporary folder would outlive the test).
        let dir = built.parent().expect("a folder").join("frei0r-hosts");
        std::fs::create_dir_all(&dir).unwrap();
        let installed = dir.join(format!("rain_composite{}", std::env::consts::DLL_SUFFIX));
        std::fs::copy(&built, &installed).expect("copy the plug-in");
        dir
    })
}

/// `program` run with the plug-in installed, a runtime directory for the GPU drivers, and a
/// GStreamer registry of its own (so a stale one cannot hide the element).
fn host(program: &str, work: &Path) -> Command {
    let mut c = Command::new(program);
    c.env("FREI0R_PATH", plugin_dir())
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .env("GST_REGISTRY", work.join("gst-registry.bin"))
        .env_remove("RAIN_COMPOSITE_FREI0R_TRACE")
        .current_dir(work);
    c
}

/// Runs `cmd`, failing the test with its stderr unless it succeeds.
fn ok(cmd: &mut Command) -> Output {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{cmd:?} does not run ({e}): install it with .ci/install-deps"));
    assert!(
        out.status.success(),
        "{cmd:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Runs melt, one at a time, rendering every frame (`real_time=-1` unless given), within two
/// minutes; returns its stderr. Several melt processes with a frei0r filter at once sometimes
/// render nothing or never finish (MLT 7.12, with a stock frei0r filter as with this one), so
/// the tests never start two.
fn melt(cmd: &mut Command) -> String {
    static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|p| p.into_inner());
    if !cmd
        .get_args()
        .any(|a| a.to_string_lossy().starts_with("real_time="))
    {
        cmd.arg("real_time=-1");
    }
    let log = tempfile::NamedTempFile::new().unwrap();
    let mut child = cmd
        .stdout(std::process::Stdio::null())
        .stderr(log.reopen().unwrap())
        .spawn()
        .unwrap_or_else(|e| panic!("melt does not run ({e}): install it with .ci/install-deps"));
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(120);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if std::time::Instant::now() > deadline {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("{cmd:?} did not finish in two minutes");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    let stderr = std::fs::read_to_string(log.path()).unwrap();
    assert!(status.success(), "{cmd:?} failed:\n{stderr}");
    stderr
}

/// `n` frames of RGBA: colour bars, a bright sky band (where rain shows), and an alpha ramp,
/// the same picture in every frame so that only the rain tells frames apart.
fn rgba_frames(n: usize) -> Vec<u8> {
    (0..n).flat_map(|_| picture(1.0)).collect()
}

/// `n` frames whose light changes from frame to frame (the picture dims and brightens), so a
/// frame's light estimated from the frames before it would tell the order they came in.
fn changing_frames(n: usize) -> Vec<u8> {
    (0..n)
        .flat_map(|i| picture(0.8 + 0.2 * (i as f64 * 0.3).cos()))
        .collect()
}

/// The picture of [`rgba_frames`] with its colours times `level`.
fn picture(level: f64) -> Vec<u8> {
    let mut frame = vec![0u8; FRAME];
    for y in 0..H {
        for x in 0..W {
            let at = (y * W + x) * 4;
            let px = if y < H / 3 {
                [235, 240, 250]
            } else {
                let bar = x * 7 / W;
                let on = |bit: usize| if (bar + 1) & bit != 0 { 190 } else { 30 };
                [on(4), on(2), on(1)]
            };
            let px = px.map(|v| (f64::from(v) * level).round() as u8);
            frame[at..at + 3].copy_from_slice(&px);
            frame[at + 3] = (x * 255 / (W - 1)) as u8;
        }
    }
    frame
}

/// Writes `frames` as a raw RGBA file in `dir`.
fn raw_input(dir: &Path, frames: &[u8]) -> PathBuf {
    let path = dir.join("in.rgba");
    std::fs::write(&path, frames).unwrap();
    path
}

/// FFmpeg's `frei0r` filter over raw RGBA at 25 fps: the frames it writes, raw RGBA, and its
/// stderr.
fn ffmpeg_rain(work: &Path, input: &Path, params: &str, trace: bool) -> (Vec<u8>, String) {
    let size = format!("{W}x{H}");
    let filter = format!("frei0r=filter_name=rain_composite:filter_params={params}");
    let mut cmd = host("ffmpeg", work);
    cmd.args(["-hide_banner", "-nostdin", "-v", "error", "-f", "rawvideo"])
        .args([
            "-pix_fmt",
            "rgba",
            "-s",
            &size,
            "-r",
            &FPS.to_string(),
            "-i",
        ])
        .arg(input)
        .args(["-vf", &filter, "-f", "rawvideo", "-pix_fmt", "rgba", "-"]);
    if trace {
        cmd.env("RAIN_COMPOSITE_FREI0R_TRACE", "1");
    }
    let out = ok(&mut cmd);
    (
        out.stdout,
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The shot times the plug-in traced, in call order.
fn traced_times(stderr: &str) -> Vec<f64> {
    stderr
        .lines()
        .filter_map(|l| l.split("-> shot time ").nth(1))
        .filter_map(|t| t.trim_end_matches(" s").parse().ok())
        .collect()
}

/// Pixels whose colour differs between two RGBA frames.
fn changed(a: &[u8], b: &[u8]) -> usize {
    a.chunks_exact(4)
        .zip(b.chunks_exact(4))
        .filter(|(p, q)| p[..3] != q[..3])
        .count()
}

/// FFmpeg renders every frame; rain changes each of them, the alpha stays; the same run again
/// gives the same bytes; two frames a second apart (of a still picture) differ; FFmpeg's clock
/// (milliseconds) becomes the frame's time in seconds.
#[test]
fn ffmpeg_renders_every_frame_repeatably() {
    if gpu::gpu().is_none() {
        return;
    }
    let work = TempDir::new().unwrap();
    let n = 30;
    let frames = rgba_frames(n);
    let input = raw_input(work.path(), &frames);
    let (wet, stderr) = ffmpeg_rain(work.path(), &input, "0.3", true);
    assert_eq!(wet.len(), frames.len(), "one output frame per input frame");
    for (i, (w, d)) in wet.chunks(FRAME).zip(frames.chunks(FRAME)).enumerate() {
        assert!(changed(w, d) > W * H / 50, "frame {i} has rain");
        let alpha = |f: &[u8]| f.iter().skip(3).step_by(4).copied().collect::<Vec<u8>>();
        assert_eq!(alpha(w), alpha(d), "frame {i}'s alpha passes through");
    }
    let (again, _) = ffmpeg_rain(work.path(), &input, "0.3", false);
    assert!(again == wet, "the same input renders the same frames");
    let second = |f: usize| &wet[f * FRAME..(f + 1) * FRAME];
    assert!(changed(second(0), second(FPS as usize)) > W * H / 50);
    // 40 ms steps in FFmpeg's milliseconds are 0.04 s steps of the shot.
    let times = traced_times(&stderr);
    assert_eq!(times.len(), n, "{stderr}");
    for (i, t) in times.iter().enumerate() {
        assert!(
            (t - i as f64 / FPS as f64).abs() < 1e-9,
            "frame {i} at {t} s"
        );
    }
}

/// Without rain nothing is drawn, and the frames come back bit for bit, alpha included; so do
/// frames the plug-in refuses to render (puddles), with one message saying why.
#[test]
fn frames_without_rain_come_back_unchanged() {
    if gpu::gpu().is_none() {
        return;
    }
    let work = TempDir::new().unwrap();
    let frames = rgba_frames(5);
    let input = raw_input(work.path(), &frames);
    let (dry, _) = ffmpeg_rain(work.path(), &input, "0", false);
    assert!(dry == frames, "a frame with no rain drawn is unchanged");
    let puddles = work.path().join("puddles.json");
    std::fs::write(
        &puddles,
        r#"{"ground": {"mode": "horizon=0.4", "puddles": true}}"#,
    )
    .unwrap();
    let params = format!("0.3|0.5|0.5|0|{}", s(&puddles));
    let (refused, stderr) = ffmpeg_rain(work.path(), &input, &params, false);
    assert!(refused == frames, "refused frames pass through");
    let said: Vec<&str> = stderr.lines().filter(|l| l.contains("puddles")).collect();
    assert_eq!(said.len(), 1, "one message, not one per frame: {stderr}");
}

/// With the defaults, the frame at t is `rain-composite preview --at t` of the same 8-bit RGB
/// file, with the light estimated per frame as the plug-in does (`light.smoothing_s=0`), to
/// within the preview's quantisation. The preview reads the RGB file as 8-bit Y'CbCr and
/// writes its frame as 8-bit Y'CbCr again, each costing up to 0.5 + 1.856 · 0.5 = 1.43 codes
/// of R'G'B' (blue, the largest matrix coefficient), so even dry it is up to 1.43 codes off the
/// file; the plug-in works in 16 bits and rounds once. The bound is the two quantisations,
/// 2.86 codes; measured on this clip: 2.71 at most, 0.52 on average (dry: 1.38).
#[test]
fn default_frames_match_the_preview() {
    if gpu::gpu().is_none() {
        return;
    }
    let work = TempDir::new().unwrap();
    let dir = work.path();
    let src = clip(
        dir,
        "bars.mkv",
        "320x180",
        FPS,
        1.2,
        &["-pix_fmt", "rgb24", "-c:v", "ffv1"],
    );
    // Samples as 16-bit codes: the 8-bit ones times 257 (swscale's rgb24 → rgb48 is not exact,
    // so 8-bit pictures are read as rgb24), the preview's 16-bit PNG as it is.
    let rgb = |path: &Path, vf: Option<&str>, bits16: bool| -> Vec<u16> {
        let mut cmd = host("ffmpeg", dir);
        cmd.args(["-v", "error", "-i"]).arg(path);
        if let Some(vf) = vf {
            cmd.args(["-vf", vf]);
        }
        let fmt = if bits16 { "rgb48le" } else { "rgb24" };
        let out = ok(cmd.args(["-f", "rawvideo", "-pix_fmt", fmt, "-"])).stdout;
        if bits16 {
            out.chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]))
                .collect()
        } else {
            out.iter().map(|&v| u16::from(v) * 257).collect()
        }
    };
    let wet = rgb(&src, Some("frei0r=filter_name=rain_composite"), false);
    let file = rgb(&src, None, false);
    let frame_len = 320 * 180 * 3;
    let (mut worst, mut sum, mut count, mut dry_worst) = (0f64, 0f64, 0usize, 0f64);
    for n in [0usize, 12, 25] {
        let t = format!("{}", n as f64 / FPS as f64);
        let preview = |extra: &[&str], name: &str| -> Vec<u16> {
            let png = dir.join(name);
            let mut cmd = bin();
            cmd.arg("preview")
                .arg(&src)
                .args(["--at", &t, "--bits", "16", "-y"]);
            binary::ok(cmd.args(extra).arg("-o").arg(&png));
            rgb(&png, None, true)
        };
        let wet_preview = preview(&["--set", "light.smoothing_s=0"], "wet.png");
        let dry_preview = preview(&["--rain", "0"], "dry.png");
        let ours = &wet[n * frame_len..(n + 1) * frame_len];
        let file = &file[n * frame_len..(n + 1) * frame_len];
        assert!(
            ours.iter().zip(file).filter(|(a, b)| a != b).count() > frame_len / 50,
            "frame {n} has rain"
        );
        for ((&a, &p), (&f, &d)) in ours
            .iter()
            .zip(&wet_preview)
            .zip(file.iter().zip(&dry_preview))
        {
            let diff = (f64::from(a) - f64::from(p)).abs() / 257.0;
            worst = worst.max(diff);
            sum += diff;
            count += 1;
            dry_worst = dry_worst.max((f64::from(f) - f64::from(d)).abs() / 257.0);
        }
    }
    let mean = sum / count as f64;
    eprintln!(
        "plug-in vs preview: at most {worst:.2} codes, {mean:.3} on average; dry preview vs the file: at most {dry_worst:.2}"
    );
    assert!(
        dry_worst <= 1.5,
        "the preview's own quantisation: {dry_worst}"
    );
    assert!(worst <= 3.0 + 1e-9, "at most 3 codes apart: {worst}");
    assert!(mean <= 0.6, "0.47 codes apart on average: {mean}");
}

/// The MLT project `frames` of raw RGBA on a 25 fps profile of the test size, with the
/// filter's `properties`, rendered by melt to raw RGBA.
fn melt_raw(work: &Path, project: &Path, extra: &[&str], trace: bool) -> (Vec<u8>, String) {
    let out = work.join(format!(
        "melt-{}.rgba",
        project.file_stem().unwrap().to_string_lossy()
    ));
    let mut cmd = host("melt", work);
    cmd.arg("-silent").arg(project).arg("-consumer");
    cmd.arg(format!("avformat:{}", s(&out)));
    cmd.args(["f=rawvideo", "vcodec=rawvideo", "pix_fmt=rgba", "an=1"]);
    cmd.args(extra);
    if trace {
        cmd.env("RAIN_COMPOSITE_FREI0R_TRACE", "1");
    }
    let log = melt(&mut cmd);
    (std::fs::read(&out).unwrap(), log)
}

/// An FFV1 RGBA clip of `frames` for MLT to read.
fn rgba_clip(dir: &Path, frames: &[u8]) -> PathBuf {
    let input = raw_input(dir, frames);
    let path = dir.join("clip.mkv");
    let size = format!("{W}x{H}");
    ok(host("ffmpeg", dir)
        .args([
            "-v", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgba", "-s", &size,
        ])
        .args(["-r", "25", "-i"])
        .arg(input)
        .args(["-c:v", "ffv1", "-pix_fmt", "rgba"])
        .arg(&path));
    path
}

fn profile() -> String {
    format!(
        r#"<profile description="{W}x{H} 25 fps" width="{W}" height="{H}" progressive="1" sample_aspect_num="1" sample_aspect_den="1" display_aspect_num="16" display_aspect_den="9" frame_rate_num="25" frame_rate_den="1" colorspace="709"/>"#
    )
}

/// melt renders a project as Kdenlive writes one (the effect inside the timeline clip's entry,
/// its parameters by name) and the command line; both change the frames, and melt's frames
/// with rain are FFmpeg's for the frames melt hands the plug-in (melt without rain), bit for
/// bit. MLT's clock: seconds of the clip's source position.
#[test]
fn melt_renders_a_kdenlive_project_and_the_command_line() {
    if gpu::gpu().is_none() {
        return;
    }
    let work = TempDir::new().unwrap();
    let dir = work.path();
    let clip = rgba_clip(dir, &rgba_frames(25));
    let project = |name: &str, rate: &str| -> PathBuf {
        let xml = format!(
            r#"<?xml version="1.0" encoding="utf-8"?>
<mlt LC_NUMERIC="C" version="7.12.0" producer="main_bin" root="{root}">
  {profile}
  <producer id="producer0" in="00:00:00.000" out="00:00:00.960">
    <property name="length">25</property>
    <property name="eof">pause</property>
    <property name="resource">clip.mkv</property>
    <property name="mlt_service">avformat</property>
    <property name="kdenlive:id">2</property>
  </producer>
  <playlist id="playlist0">
    <property name="kdenlive:track_name">V1</property>
    <entry producer="producer0" in="00:00:00.200" out="00:00:00.560">
      <property name="kdenlive:id">2</property>
      <filter id="filter0">
        <property name="mlt_service">frei0r.rain_composite</property>
        <property name="kdenlive_id">frei0r.rain_composite</property>
        <property name="rain_rate">{rate}</property>
        <property name="wind">0.55</property>
        <property name="kdenlive:collapsed">0</property>
      </filter>
    </entry>
  </playlist>
  <tractor id="tractor0" in="00:00:00.000" out="00:00:00.360">
    <track producer="playlist0"/>
  </tractor>
</mlt>
"#,
            root = s(dir),
            profile = profile(),
        );
        let path = dir.join(name);
        std::fs::write(&path, xml).unwrap();
        path
    };
    let (wet, log) = melt_raw(dir, &project("wet.mlt", "0.3"), &[], true);
    let (dry, _) = melt_raw(dir, &project("dry.mlt", "0"), &[], false);
    assert_eq!(wet.len(), 10 * FRAME, "the clip's 10 frames");
    assert_eq!(dry.len(), wet.len());
    for (i, (w, d)) in wet.chunks(FRAME).zip(dry.chunks(FRAME)).enumerate() {
        assert!(changed(w, d) > W * H / 50, "frame {i} has rain");
    }
    let times = traced_times(&log);
    assert!(
        (times[0] - 0.2).abs() < 1e-9 && (times[9] - 0.56).abs() < 1e-9,
        "the clip's source seconds, from its in point at 0.2 s: {times:?}"
    );
    // FFmpeg on the frames melt handed over, at the same times (from 0.2 s: time_offset).
    let input = raw_input(dir, &dry);
    let offset = 0.2 / 3600.0;
    let params = format!("0.3|0.55|0.5|0|default|0.5|0.5|0.5/0.5|n|simple|{offset}");
    let (ffmpeg_wet, _) = ffmpeg_rain(dir, &input, &params, false);
    assert!(ffmpeg_wet == wet, "melt's frames are FFmpeg's, bit for bit");

    // The command line, with the profile given as a file (melt 7.12 crashes on a profile
    // without a description).
    let prof = dir.join("profile");
    std::fs::write(
        &prof,
        format!(
            "description=test\nwidth={W}\nheight={H}\nframe_rate_num=25\nframe_rate_den=1\nprogressive=1\n\
             sample_aspect_num=1\nsample_aspect_den=1\ndisplay_aspect_num=16\n\
             display_aspect_den=9\ncolorspace=709\n"
        ),
    )
    .unwrap();
    let out = dir.join("cli.rgba");
    melt(
        host("melt", dir)
            .args(["-silent", "-profile"])
            .arg(&prof)
            .arg(&clip)
            .args(["-filter", "frei0r.rain_composite", "rain_rate=0.3"])
            .arg("-consumer")
            .arg(format!("avformat:{}", s(&out)))
            .args(["f=rawvideo", "vcodec=rawvideo", "pix_fmt=rgba", "an=1"]),
    );
    let cli = std::fs::read(&out).unwrap();
    assert_eq!(cli.len(), 25 * FRAME, "every frame of the clip");
    assert!(changed(&cli[..FRAME], &rgba_frames(1)) > W * H / 50);
}

/// MLT hands one instance frames out of order (a playlist playing the clip's second part
/// first) and splits frames between instances (`real_time=-2`: two render threads, each with
/// its own instance): every frame is the same picture as in order on one instance, though the
/// light changes from frame to frame.
#[test]
fn melt_frames_out_of_order_and_in_parallel_are_the_same() {
    if gpu::gpu().is_none() {
        return;
    }
    let work = TempDir::new().unwrap();
    let dir = work.path();
    rgba_clip(dir, &changing_frames(25));
    // The effect on the producer: it sees the clip's own positions, whatever the playlist.
    let project = |name: &str, entries: &[(u32, u32)]| -> PathBuf {
        let entries: String = entries
            .iter()
            .map(|(a, b)| format!(r#"    <entry producer="clip" in="{a}" out="{b}"/>"#) + "\n")
            .collect();
        let xml = format!(
            r#"<?xml version="1.0" encoding="utf-8"?>
<mlt LC_NUMERIC="C" version="7.12.0" root="{root}">
  {profile}
  <producer id="clip" in="0" out="24">
    <property name="resource">clip.mkv</property>
    <property name="mlt_service">avformat</property>
    <filter id="rain">
      <property name="mlt_service">frei0r.rain_composite</property>
      <property name="rain_rate">0.3</property>
    </filter>
  </producer>
  <playlist id="playlist0">
{entries}  </playlist>
  <tractor id="tractor0">
    <track producer="playlist0"/>
  </tractor>
</mlt>
"#,
            root = s(dir),
            profile = profile(),
        );
        let path = dir.join(name);
        std::fs::write(&path, xml).unwrap();
        path
    };
    let (in_order, _) = melt_raw(dir, &project("in-order.mlt", &[(0, 19)]), &[], false);
    let (shuffled, log) = melt_raw(
        dir,
        &project("shuffled.mlt", &[(10, 19), (0, 9)]),
        &[],
        true,
    );
    let (parallel, plog) = melt_raw(
        dir,
        &project("parallel.mlt", &[(0, 19)]),
        &["real_time=-2"],
        true,
    );
    assert_eq!(in_order.len(), 20 * FRAME);
    let times = traced_times(&log);
    assert!(
        times.first() == Some(&0.4) && times.contains(&0.0),
        "the instance saw 0.4 s first, then 0 s: {times:?}\nmelt said:\n{log}"
    );
    assert!(
        shuffled[..10 * FRAME] == in_order[10 * FRAME..],
        "frames 10–19 rendered first are those rendered in order"
    );
    assert!(
        shuffled[10 * FRAME..] == in_order[..10 * FRAME],
        "frames 0–9 rendered after 10–19 are those rendered in order"
    );
    let instances = plog.lines().filter(|l| l.contains("drops a frame")).count();
    assert!(instances >= 2, "two render threads, two instances:\n{plog}");
    assert!(parallel == in_order, "frames split between instances");
}

/// GStreamer's element renders every frame, and the same frames as FFmpeg bit for bit: its
/// clock (the buffer's seconds) reaches the same shot times as FFmpeg's milliseconds.
#[test]
fn gstreamer_renders_the_frames_ffmpeg_does() {
    if gpu::gpu().is_none() {
        return;
    }
    let work = TempDir::new().unwrap();
    let dir = work.path();
    let frames = rgba_frames(10);
    let input = raw_input(dir, &frames);
    let out = dir.join("gst.rgba");
    let mut cmd = host("gst-launch-1.0", dir);
    cmd.args(["-q", "filesrc"])
        .arg(format!("location={}", s(&input)))
        .args([
            "!",
            "rawvideoparse",
            &format!("width={W}"),
            &format!("height={H}"),
        ])
        .args(["format=rgba", "framerate=25/1", "!"])
        .args([
            "frei0r-filter-rain-composite",
            "rain-rate=0.3",
            "wind=0.6",
            "!",
        ])
        .arg("filesink")
        .arg(format!("location={}", s(&out)))
        .env("RAIN_COMPOSITE_FREI0R_TRACE", "1");
    let log = ok(&mut cmd);
    let gst = std::fs::read(&out).unwrap();
    assert_eq!(gst.len(), frames.len(), "every frame");
    let (ffmpeg, _) = ffmpeg_rain(dir, &input, "0.3|0.6", false);
    assert!(
        changed(&gst[..FRAME], &frames[..FRAME]) > W * H / 50,
        "rain"
    );
    assert!(
        gst == ffmpeg,
        "GStreamer's frames are FFmpeg's, bit for bit"
    );
    let times = traced_times(&String::from_utf8_lossy(&log.stderr));
    assert_eq!(times.len(), 10);
    assert!((times[9] - 0.36).abs() < 1e-9, "stream seconds: {times:?}");
}
