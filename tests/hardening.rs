//! Hostile but fair use of the binary: every failure is one `error:` line and exit status 1,
//! never a panic (101), never a destroyed input and never a file left behind; a successful
//! run is quiet on stderr.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use tempfile::TempDir;

#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::{ffmpeg, files_in, frame_times, quick_clip, s};

#[path = "common/binary.rs"]
mod binary;
use binary::bin;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `cmd`, killing it after `limit` (a hang is a failure, not a stuck test run).
fn run_within(cmd: &mut Command, limit: Duration) -> Output {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let start = Instant::now();
    while child.try_wait().expect("wait").is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().expect("output");
            panic!("{cmd:?} still running after {limit:?}: {}", stderr(&out));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().expect("output")
}

fn run(cmd: &mut Command) -> Output {
    run_within(cmd, Duration::from_secs(300))
}

/// The run failed cleanly: status 1 and a single `error:` line. Returns that line.
fn fails(cmd: &mut Command) -> String {
    let out = run(cmd);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{cmd:?}: {err}");
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 1, "one error line expected: {err}");
    assert!(!err.contains("panicked"), "{err}");
    errors[0].to_owned()
}

fn succeeds(cmd: &mut Command) -> Output {
    let out = run(cmd);
    assert!(out.status.success(), "{cmd:?}: {}", stderr(&out));
    out
}

#[test]
fn a_drop_budget_beyond_the_gpu_is_lowered_with_a_warning_not_a_panic() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "in.mp4", "64x64", 0.2);
    let png = dir.path().join("m.png");
    let out = succeeds(bin().args([
        "preview",
        s(&input),
        "--frame",
        "0",
        "-o",
        s(&png),
        "--rain",
        "500",
        "--max-drops",
        "20000000",
        "--fov",
        "169",
        "--camera-height",
        "1000",
        "--near",
        "0.05",
    ]));
    assert!(png.exists());
    let err = stderr(&out);
    // lavapipe's largest storage binding (128 MiB) holds about 2 M drops; a GPU that holds 20 M
    // needs no warning.
    if err.contains("--max-drops") {
        assert!(err.contains("more than this GPU holds"), "{err}");
    }
}

#[test]
fn the_input_is_never_the_output() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "a.mp4", "64x64", 0.2);
    let before = std::fs::read(&input).expect("read");
    let hard = dir.path().join("hard.mp4");
    std::fs::hard_link(&input, &hard).expect("link");
    let soft = dir.path().join("soft.mp4");
    std::os::unix::fs::symlink(&input, &soft).expect("symlink");
    for out in [&input, &hard, &soft] {
        let e = fails(bin().args([s(&input), "-o", s(out), "-y", "--rain", "0"]));
        assert!(e.contains("is the input"), "{e}");
        let e = fails(bin().args(["preview", s(&soft), "--frame", "0", "-o", s(out), "-y"]));
        assert!(e.contains("PNG") || e.contains("is the input"), "{e}");
    }
    assert_eq!(std::fs::read(&input).expect("read"), before);
    assert_eq!(files_in(dir.path()), ["a.mp4", "hard.mp4", "soft.mp4"]);
}

#[test]
fn a_config_is_read_from_regular_files_of_bounded_size_only() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "in.mp4", "64x64", 0.2);
    let fifo = dir.path().join("fifo.json");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .expect("mkfifo")
            .success()
    );
    let big = dir.path().join("big.json");
    std::fs::write(&big, vec![b' '; 5 << 20]).expect("write");
    for (config, says) in [
        (Path::new("/dev/zero"), "not a regular file"),
        (fifo.as_path(), "not a regular file"),
        (big.as_path(), "MiB"),
        (dir.path(), "not a regular file"),
    ] {
        let out = run_within(
            bin().args([
                "preview",
                s(&input),
                "--frame",
                "0",
                "-o",
                s(&dir.path().join("p.png")),
                "--config",
                s(config),
            ]),
            Duration::from_secs(20),
        );
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(err.contains("--config") && err.contains(says), "{err}");
    }
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, r#"{"rain": {"rate_mm_per_h": "lots"}}"#).expect("write");
    let e = fails(bin().args([s(&input), "-o", "o.mp4", "--config", s(&bad)]));
    assert!(e.contains("rate_mm_per_h") || e.contains("line 1"), "{e}");
}

#[test]
fn joined_transport_streams_keep_time_running() {
    let dir = TempDir::new().expect("tmp");
    let ts = dir.path().join("a.ts");
    ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "testsrc2=s=96x64:r=25:d=1",
        "-f",
        "lavfi",
        "-i",
        "sine=r=48000:d=1",
        "-c:v",
        "libx264",
        "-preset",
        "ultrafast",
        "-c:a",
        "aac",
        "-f",
        "mpegts",
        s(&ts),
    ]);
    let part = std::fs::read(&ts).expect("read");
    let joined = dir.path().join("joined.ts");
    std::fs::write(&joined, [part.clone(), part].concat()).expect("write");
    let out_path = dir.path().join("out.mkv");
    let out = succeeds(bin().args([s(&joined), "-o", s(&out_path), "--rain", "0"]));
    assert!(
        stderr(&out).contains("timestamps go back"),
        "{}",
        stderr(&out)
    );
    let t = frame_times(&out_path);
    assert_eq!(t.len(), 50);
    for w in t.windows(2) {
        let step = w[1] - w[0];
        assert!((step - 0.04).abs() < 0.002, "frames {step} s apart: {t:?}");
    }
}

#[test]
fn preview_outputs_are_checked_first_and_never_left_half_written() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "in.mp4", "64x64", 0.2);
    let sub = dir.path().join("sub");
    std::fs::create_dir(&sub).expect("mkdir");
    let e = fails(bin().args(["preview", s(&input), "--frame", "0", "-o", s(&sub), "-y"]));
    assert!(e.contains("PNG") || e.contains("directory"), "{e}");
    let e = fails(bin().args(["preview", s(&input), "--frame", "0", "-o", "p.jpg"]));
    assert!(e.contains(".png"), "{e}");
    let e = fails(bin().args([
        "preview",
        s(&input),
        "--frame",
        "0",
        "-o",
        s(&dir.path().join("missing/p.png")),
    ]));
    assert!(e.contains("does not exist"), "{e}");
    // A directory named like a PNG: refused before any work.
    let trap = dir.path().join("trap.png");
    std::fs::create_dir(&trap).expect("mkdir");
    let e = fails(bin().args(["preview", s(&input), "--frame", "0", "-o", s(&trap), "-y"]));
    assert!(e.contains("directory"), "{e}");
    assert_eq!(files_in(dir.path()), ["in.mp4", "sub", "trap.png"]);
    assert!(files_in(&sub).is_empty());
    // `-o -` is stdout, as for the render.
    let out = succeeds(bin().args(["preview", s(&input), "--frame", "0", "-o", "-"]));
    assert_eq!(&out.stdout[..8], b"\x89PNG\r\n\x1a\n");
    assert!(!Path::new("-").exists());
}

#[test]
fn preview_stops_on_interrupt_and_leaves_nothing() {
    let dir = TempDir::new().expect("tmp");
    // Enough frames before the target that feeding the light's smoothing window takes a while.
    let input = quick_clip(dir.path(), "in.mp4", "1280x720", 10.0);
    let png = dir.path().join("p.png");
    let child = bin()
        .args([
            "preview",
            s(&input),
            "--at",
            "9.9",
            "-o",
            s(&png),
            "--light-smoothing",
            "2.4",
            "--cpu",
        ])
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    std::thread::sleep(Duration::from_millis(700));
    let pid = child.id().to_string();
    let _ = Command::new("kill").args(["-INT", &pid]).status();
    let out = child.wait_with_output().expect("wait");
    let err = stderr(&out);
    if out.status.success() {
        // This machine finished before the signal: nothing to check but the output.
        assert!(png.exists());
        return;
    }
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("interrupted"), "{err}");
    assert_eq!(files_in(dir.path()), ["in.mp4"]);
}

#[test]
fn output_names_at_the_file_system_limit_work() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "in.mp4", "64x64", 0.2);
    let name = format!("{}.mp4", "r".repeat(251));
    let out = dir.path().join(&name);
    succeeds(bin().args([s(&input), "-o", s(&out), "--rain", "0"]));
    assert_eq!(files_in(dir.path()), ["in.mp4".to_string(), name]);
    let png = dir.path().join(format!("{}.png", "p".repeat(251)));
    succeeds(bin().args(["preview", s(&input), "--frame", "0", "-o", s(&png)]));
    assert!(png.exists());
}

#[test]
fn a_directory_as_output_is_refused_before_the_render() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "in.mp4", "64x64", 0.2);
    let started = Instant::now();
    let e = fails(bin().args([s(&input), "-o", s(dir.path()), "-y"]));
    assert!(e.contains("directory"), "{e}");
    let e = fails(bin().args([s(&input), "-o", s(&dir.path().join("no/such/out.mp4"))]));
    assert!(e.contains("does not exist"), "{e}");
    assert!(started.elapsed() < Duration::from_secs(60));
    assert_eq!(files_in(dir.path()), ["in.mp4"]);
}

#[test]
fn messages_name_the_option_and_the_cause() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "in.mp4", "64x64", 0.2);
    let out = dir.path().join("o.mp4");
    let o = s(&out);
    let i = s(&input);
    for (args, says) in [
        (vec![i, "-o", o, "--preset", "nonsense"], "--preset"),
        (vec![i, "-o", o, "--preset", ""], "--preset"),
        (vec![i, "-o", o, "--max-drops", "0"], "--rain 0"),
        (vec![i, "-o", o, "--fov", "-5"], "--fov"),
        (vec![i, "-o", o, "--near", "-1"], "--near"),
        (vec![i, "-o", o, "--shutter", "0"], "--shutter"),
    ] {
        let e = fails(bin().args(&args));
        assert!(e.contains(says), "{args:?}: {e}");
        assert!(
            !e.contains("-- -"),
            "clap's tip is wrong for our options: {e}"
        );
        assert!(!e.contains("Invalid argument: Invalid argument"), "{e}");
    }
    // Negative values need no `=`.
    succeeds(bin().args([
        "preview", i, "--frame", "0", "-o", "-", "--tilt", "-5", "--roll", "-3",
    ]));
    // A full disk names the cause, not "the encoder stopped".
    for format in ["y4m", "nut"] {
        let out = bin()
            .args([i, "-o", "-", "--rain", "0", "--format", format])
            .stdout(std::fs::File::create("/dev/full").expect("/dev/full"))
            .output()
            .expect("spawn");
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(err.contains("no space left"), "{format}: {err}");
    }
    // An animation container cannot hold the video codec: said before anything is written.
    let e = fails(bin().args([i, "-o", s(&dir.path().join("o.gif"))]));
    assert!(e.contains("cannot hold"), "{e}");
    // An exposure longer than a second (a 0.5 fps clip at 360°) names --shutter.
    let slow = dir.path().join("slow.mp4");
    ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "testsrc2=s=64x64:r=1/2:d=4",
        "-c:v",
        "libx264",
        "-preset",
        "ultrafast",
        "-pix_fmt",
        "yuv420p",
        s(&slow),
    ]);
    let e = fails(bin().args([
        "preview",
        s(&slow),
        "--frame",
        "0",
        "-o",
        "-",
        "--shutter",
        "360",
    ]));
    assert!(e.contains("--shutter") && e.contains("at most"), "{e}");
    std::fs::remove_file(&slow).expect("rm");
    // A header FFmpeg cannot read is not "Device or resource busy" alone.
    let y4m = dir.path().join("bad.y4m");
    std::fs::write(&y4m, b"YUV4MPEG2 W99999 H99999 F25:1 C420jpeg\nFRAME\nxxxx").expect("write");
    let e = fails(bin().args([s(&y4m), "-o", o]));
    assert!(e.contains("cannot read its header"), "{e}");
    assert_eq!(files_in(dir.path()), ["bad.y4m", "in.mp4"]);
}

#[test]
fn a_successful_run_is_quiet_even_without_a_display_environment() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "in.mp4", "64x64", 0.2);
    let out = succeeds(
        bin()
            .env_remove("XDG_RUNTIME_DIR")
            .env_remove("WAYLAND_DISPLAY")
            .args(["preview", s(&input), "--frame", "0", "-o", "-"]),
    );
    assert_eq!(stderr(&out), "", "nothing on stderr on success");
    let out = succeeds(bin().env_remove("XDG_RUNTIME_DIR").args([
        s(&input),
        "-o",
        s(&dir.path().join("o.mp4")),
    ]));
    assert_eq!(stderr(&out), "", "nothing on stderr on success");
}

#[test]
fn inspect_drops_prints_the_plan_the_render_uses() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "in.mp4", "320x180", 0.2);
    // A fast lens focused close: defocus changes how far drops stay visible.
    let look = ["--f-number", "1.4", "--focus", "1", "--rain", "20"];
    let out = succeeds(
        bin()
            .args([
                "inspect", "drops", "--size", "320x180", "--fps", "25", "--count", "3",
            ])
            .args(look),
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let plan = &v["volume"];
    let out = succeeds(
        bin()
            .args(["preview", s(&input), "--frame", "0", "-o", "-", "-v"])
            .args(look),
    );
    let log = stderr(&out);
    let expected = format!(
        "view {:.2}–{:.2} m",
        plan["near_m"].as_f64().expect("near"),
        plan["far_m"].as_f64().expect("far")
    );
    assert!(log.contains(&expected), "{expected} not in: {log}");
    let simulated = format!("simulating {} ", plan["simulated"].as_u64().expect("count"));
    assert!(log.contains(&simulated), "{simulated} not in: {log}");
    // And the lens matters: without it the plan differs.
    let out = succeeds(
        bin()
            .args([
                "inspect", "drops", "--size", "320x180", "--fps", "25", "--count", "3",
            ])
            .args(["--f-number", "0", "--rain", "20"]),
    );
    let pinhole: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_ne!(pinhole["volume"]["far_m"], plan["far_m"]);
}

/// Starts `cmd`, sends `signal` after `after`, and returns its output and how long it took to
/// stop; `None` when it had already finished (a machine faster than the test expects).
fn stop_with(cmd: &mut Command, signal: &str, after: Duration) -> Option<(Output, Duration)> {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    std::thread::sleep(after);
    if child.try_wait().expect("wait").is_some() {
        return None;
    }
    let sent = Instant::now();
    let pid = child.id().to_string();
    let _ = Command::new("kill")
        .args([&format!("-{signal}"), &pid])
        .status();
    while child.try_wait().expect("wait").is_none() {
        if sent.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            let out = child.wait_with_output().expect("output");
            panic!("{cmd:?} ignored {signal}: {}", stderr(&out));
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let took = sent.elapsed();
    Some((child.wait_with_output().expect("output"), took))
}

/// Every long piece of work — the water's simulation pass, its fast-forward before a preview
/// or a chunk, the streak database's ray tracing — stops within a second of INT, TERM or HUP,
/// says so in one line and leaves no file behind.
#[test]
fn long_work_stops_on_int_term_and_hup_and_leaves_nothing() {
    let dir = TempDir::new().expect("tmp");
    let input = fixtures::sky_over_ground(dir.path(), "in.mkv", (160, 96), 30, 3.0);
    let water = [
        "--ground",
        "horizon=0.3",
        "--pre-rain",
        "60",
        "--puddle-particles",
        "10000",
    ];
    let out = dir.path().join("out.mkv");
    let png = dir.path().join("p.png");
    let db = dir.path().join("db");
    let cases: [(&str, Vec<&str>); 5] = [
        ("TERM", vec!["inspect", "puddles", s(&input), "--at", "2.9"]),
        (
            "TERM",
            vec!["inspect", "sph", "--scene", "basin", "--steps", "100000"],
        ),
        (
            "HUP",
            vec![
                "preview",
                s(&input),
                "--at",
                "2.9",
                "--puddles",
                "-o",
                s(&png),
            ],
        ),
        (
            "INT",
            vec![s(&input), "--frames", "70..72", "--puddles", "-o", s(&out)],
        ),
        (
            "INT",
            vec![
                "drops",
                "generate",
                "-o",
                s(&db),
                "--sizes",
                "4",
                "--views",
                "0",
                "--phases",
                "1",
                "--pixels-per-diameter",
                "32",
                "--samples",
                "4",
            ],
        ),
    ];
    let mut stopped = 0;
    for (signal, args) in cases {
        let extra: &[&str] = if args[0] == "drops" || args[1] == "sph" {
            &[]
        } else {
            &water
        };
        let Some((o, took)) = stop_with(
            bin().args(&args).args(extra),
            signal,
            Duration::from_millis(2500),
        ) else {
            // It finished before the signal (the water starts settled, so a short clip's
            // render can): what it wrote is a whole output, not a leftover.
            for finished in [&out, &png] {
                let _ = std::fs::remove_file(finished);
            }
            continue;
        };
        let err = stderr(&o);
        if o.status.code() == Some(0) {
            // The signal came as the work was ending (it finished within the stop's bound): what
            // it wrote must then be whole.
            assert!(took < Duration::from_secs(2), "{args:?}: {took:?}");
            if args.contains(&s(&out)) {
                assert_eq!(frame_times(&out).len(), 2, "{args:?}");
            } else if args.contains(&s(&png)) {
                image::open(&png).expect("a whole picture");
            }
            for finished in [&out, &png] {
                let _ = std::fs::remove_file(finished);
            }
            continue;
        }
        stopped += 1;
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains("error: interrupted"), "{args:?}: {err}");
        assert!(
            took < Duration::from_secs(2),
            "{args:?}: {took:?} after {signal}"
        );
        let left: Vec<String> = files_in(dir.path())
            .into_iter()
            .filter(|n| n != "in.mkv" && !(n == "db" && files_in(&db).is_empty()))
            .collect();
        assert!(left.is_empty(), "{args:?} left {left:?}");
    }
    // The streak at 32 pixels a diameter takes minutes on any machine.
    assert!(stopped > 0);
}

/// A depth map that is not a regular file (a FIFO would block the read forever, a device never
/// ends) is refused at once.
#[test]
fn a_depth_map_is_read_from_regular_files_only() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "in.mp4", "64x64", 0.2);
    for name in ["fifo.png", "fifo.mkv"] {
        let fifo = dir.path().join(name);
        assert!(
            Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .expect("mkfifo")
                .success()
        );
        let zero = dir.path().join(format!("zero-{name}"));
        std::os::unix::fs::symlink("/dev/zero", &zero).expect("symlink");
        for depth in [&fifo, &zero] {
            let out = run_within(
                bin().args([
                    "preview",
                    s(&input),
                    "--frame",
                    "0",
                    "-o",
                    s(&dir.path().join("p.png")),
                    "--depth",
                    s(depth),
                ]),
                Duration::from_secs(20),
            );
            let err = stderr(&out);
            assert_eq!(out.status.code(), Some(1), "{err}");
            assert!(err.contains("not a regular file"), "{err}");
        }
    }
    assert!(!dir.path().join("p.png").exists());
}

/// Each message says what is wrong with what the user typed: the time asked for, not the one
/// a seek started from; a range that is open at the end; a count that does not fit; a conflict,
/// not a range; a number too large for JSON; an error of a setting no key changes, without a
/// key's time; the flag's own name; the format a file is not; a BOM-marked configuration read.
#[test]
fn messages_say_what_is_wrong_with_what_was_typed() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "in.mp4", "64x64", 0.5);
    let out = dir.path().join("o.mkv");
    let (i, o) = (s(&input), s(&out));
    let keyed = "rain.rate_mm_per_h=[[0,10],[1,20]]";
    let cases: [(Vec<&str>, &str, &str); 14] = [
        (vec![i, "-o", o, "--from", "5"], "5 s is beyond", ""),
        (vec![i, "-o", o, "--from", "1:2:3:4"], "invalid time", ""),
        (
            vec![i, "-o", o, "--from", "0.49"],
            "from 0.49 s on",
            " s.. s",
        ),
        (
            vec![i, "-o", o, "--frames", "0..=18446744073709551615"],
            "invalid --frames",
            "0..0",
        ),
        (
            vec![
                i,
                "-o",
                o,
                "--ground",
                "horizon=0.5",
                "--set",
                "camera.tilt_deg=5",
            ],
            "conflicts with --ground horizon=0.5",
            "out of range",
        ),
        (
            vec![i, "-o", o, "--set", "rain.rate_mm_per_h=1e999"],
            "not a finite number",
            "string",
        ),
        (
            vec![i, "-o", o, "--set", keyed, "--fov", "200"],
            "--fov = 200: degrees",
            "keyed",
        ),
        (
            vec![i, "-o", o, "--set", "rain.rate_mm_per_h=[[0,10],[1,2000]]"],
            "2000 (keyed, at 1 s) is out of range",
            "conflicts",
        ),
        (
            vec![
                "inspect",
                "sh",
                "tests/data/courtyard_128x64.png",
                "--bands",
                "30",
            ],
            "--bands",
            "",
        ),
        (vec!["inspect", "light", i], "not a PNG image", "extension"),
        (vec!["inspect", "rtf", "--bins", "1"], "--bins", ""),
        (vec!["inspect", "rtf", "--nmax", "100000"], "--nmax", ""),
        (
            vec!["inspect", "sph", "--scene", "column", "--steps", "1000000"],
            "--steps",
            "",
        ),
        (
            vec![i, "-o", o, "--streaks", "mattes", "--streak-db", "MISSING"],
            "no such folder",
            "",
        ),
    ];
    for (args, says, not) in cases {
        let e = fails(bin().args(&args));
        assert!(e.contains(says), "{args:?}: {e}");
        assert!(not.is_empty() || !e.contains(not), "{args:?}: {e}");
    }
    let e = fails(bin().args([i, "--layer-only", "-o", "-"]));
    assert!(!e.contains("--codec libx264"), "no --codec was given: {e}");
    let bom = dir.path().join("bom.json");
    std::fs::write(&bom, "\u{feff}{\"rain\": {\"rate_mm_per_h\": 5}}").expect("write");
    succeeds(bin().args(["preview", i, "--frame", "0", "-o", "-", "--config", s(&bom)]));
    assert_eq!(files_in(dir.path()), ["bom.json", "in.mp4"]);
}

/// CRC-32 (PNG's), for a hand-made header.
fn crc32(bytes: &[u8]) -> u32 {
    !bytes.iter().fold(!0u32, |c, &b| {
        (0..8).fold(c ^ b as u32, |c, _| {
            if c & 1 == 1 {
                0xedb8_8320 ^ (c >> 1)
            } else {
                c >> 1
            }
        })
    })
}

/// A PNG whose header claims a picture of 100 000² pixels (a few dozen bytes on disk) is
/// refused from its header, as a depth map and as an image for `inspect`, not decoded.
#[test]
fn a_huge_picture_is_refused_from_its_header() {
    let dir = TempDir::new().expect("tmp");
    let input = quick_clip(dir.path(), "in.mp4", "64x64", 0.2);
    let chunk = |kind: &[u8], data: &[u8]| {
        let mut c = (data.len() as u32).to_be_bytes().to_vec();
        let body = [kind, data].concat();
        c.extend(&body);
        c.extend(crc32(&body).to_be_bytes());
        c
    };
    let mut ihdr = 100_000u32.to_be_bytes().repeat(2);
    ihdr.extend([16, 0, 0, 0, 0]);
    let png = [
        b"\x89PNG\r\n\x1a\n".to_vec(),
        chunk(b"IHDR", &ihdr),
        chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]),
        chunk(b"IEND", &[]),
    ]
    .concat();
    let huge = dir.path().join("huge.png");
    std::fs::write(&huge, png).expect("write");
    let started = Instant::now();
    let e = fails(bin().args([
        "preview",
        s(&input),
        "--frame",
        "0",
        "-o",
        "-",
        "--depth",
        s(&huge),
    ]));
    assert!(
        e.contains("too large") || e.contains("pixels a side"),
        "{e}"
    );
    let e = fails(bin().args(["inspect", "sh", s(&huge)]));
    assert!(e.contains("too large"), "{e}");
    assert!(started.elapsed() < Duration::from_secs(20));
}
