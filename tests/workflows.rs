//! Editing workflows through the `rain-composite` binary: presets and overrides, shell
//! integration, and chunked renders that join into the whole. GPU work runs on whatever adapter
//! the machine has (lavapipe in CI).

use std::path::Path;
use std::process::Command;

use tempfile::TempDir;

#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::s;

#[path = "common/binary.rs"]
mod binary;
use binary::{bin, ok};

fn fails(cmd: &mut Command) -> String {
    let out = cmd.output().expect("spawn");
    assert!(!out.status.success(), "{cmd:?} should fail");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn preset_names() -> Vec<String> {
    let out = ok(bin().args(["config", "--list"]));
    String::from_utf8(out.stdout)
        .expect("utf-8")
        .lines()
        .map(|l| l.split_whitespace().next().expect("a name").to_string())
        .collect()
}

/// The presets the product promises are listed, one line each with a description, and each
/// renders a frame with rain in it.
#[test]
fn every_preset_renders() {
    let names = preset_names();
    for promised in [
        "drizzle",
        "steady",
        "downpour",
        "windy-storm",
        "night-street",
        "backlit",
        "passing-shower",
    ] {
        assert!(names.iter().any(|n| n == promised), "{promised}: {names:?}");
    }
    let dir = TempDir::new().expect("tempdir");
    let input = fixtures::quick_clip(dir.path(), "in.mp4", "160x120", 0.4);
    let frame = |name: &str, extra: &[&str]| {
        let png = dir.path().join(format!("{name}.png"));
        ok(bin()
            .args(["preview", s(&input), "--frame", "5", "-y", "-o", s(&png)])
            .args(["--config", name])
            .args(extra));
        std::fs::read(&png).expect("png")
    };
    for name in &names {
        let dry = frame(name, &["--set", "rain.rate_mm_per_h=0"]);
        assert_ne!(frame(name, &[]), dry, "{name} shows no rain");
    }
}

/// `config --print` writes what `--config FILE` reads back, with the overrides and flags in
/// their order of precedence: preset < --set < flag.
#[test]
fn config_print_round_trips_with_precedence() {
    let dir = TempDir::new().expect("tempdir");
    let print = |args: &[&str]| {
        let out = ok(bin().args(["config", "--print"]).args(args));
        String::from_utf8(out.stdout).expect("utf-8")
    };
    let text = print(&[
        "--config",
        "windy-storm",
        "--set",
        "rain.rate_mm_per_h=12",
        "--set",
        "rain.seed=9",
        "--seed",
        "4",
    ]);
    let v: serde_json::Value = serde_json::from_str(&text).expect("json");
    assert_eq!(v["rain"]["rate_mm_per_h"], 12.0, "--set over the preset");
    assert_eq!(v["rain"]["seed"], 4, "the flag over --set");
    assert_eq!(
        v["rain"]["wind_mps"][0], 11.5,
        "the preset over the default"
    );
    let file = dir.path().join("effective.json");
    std::fs::write(&file, &text).expect("write");
    assert_eq!(print(&["--config", s(&file)]), text);
}

/// Keyframes given with `--set` show in `config --print` as keys, read back unchanged through
/// `--config FILE`; a setting that cannot change over a shot is refused in one line naming it.
#[test]
fn keyed_settings_print_and_read_back() {
    let dir = TempDir::new().expect("tempdir");
    let print = |args: &[&str]| {
        let out = ok(bin().args(["config", "--print"]).args(args));
        String::from_utf8(out.stdout).expect("utf-8")
    };
    let text = print(&[
        "--set",
        "rain.rate_mm_per_h=[[0,0],[4,30]]",
        "--set",
        "rain.wind_mps=[[1,[0,0]],[3,[6,-1]]]",
    ]);
    let v: serde_json::Value = serde_json::from_str(&text).expect("json");
    assert_eq!(
        v["rain"]["rate_mm_per_h"],
        serde_json::json!([[0.0, 0.0], [4.0, 30.0]])
    );
    assert_eq!(
        v["rain"]["wind_mps"][1],
        serde_json::json!([3.0, [6.0, -1.0]])
    );
    let file = dir.path().join("keyed.json");
    std::fs::write(&file, &text).expect("write");
    assert_eq!(print(&["--config", s(&file)]), text);
    // A flag replaces the keys with its constant.
    let flat = print(&["--config", s(&file), "--rain", "7"]);
    let v: serde_json::Value = serde_json::from_str(&flat).expect("json");
    assert_eq!(v["rain"]["rate_mm_per_h"], 7.0);
    for (set, says) in [
        (
            "rain.drop_scale=[[0,1],[2,2]]",
            "rain.drop_scale cannot change over a shot",
        ),
        (
            "rain.rate_mm_per_h=[[2,0],[1,30]]",
            "times in increasing order",
        ),
        ("rain.rate_mm_per_h=[[0,0],[4,900]]", "(keyed, at 4 s)"),
    ] {
        let e = fails(bin().args(["config", "--print", "--set", set]));
        assert!(
            e.starts_with("error: ") && e.contains(says) && e.lines().count() == 1,
            "{set}: {e}"
        );
    }
}

/// Unknown keys, wrong types and out-of-range values are refused naming the key and value,
/// with the keys or range allowed.
#[test]
fn bad_overrides_are_refused_by_name() {
    for (set, says) in [
        ("rain.rate=5", "rate_mm_per_h"),
        ("camera.fov_deg=wide", "f64"),
        ("rain.rate_mm_per_h=900", "[0, 500]"),
        ("camera.fov_deg=200", "(1, 170)"),
        ("light.n_max=0", "1 to 64"),
    ] {
        let e = fails(bin().args(["config", "--print", "--set", set]));
        assert!(
            e.starts_with("error: ")
                && e.contains(set)
                && e.contains(says)
                && e.lines().count() == 1,
            "{set}: {e}"
        );
    }
}

/// The shipped manual page is the one the CLI definition generates today.
#[test]
fn the_manual_page_is_up_to_date() {
    let out = ok(bin().arg("man"));
    let shipped = include_str!("../docs/rain-composite.1");
    assert!(
        String::from_utf8_lossy(&out.stdout) == shipped,
        "docs/rain-composite.1 is out of date: run `cargo run --release -- man > docs/rain-composite.1`"
    );
}

/// Each shell's completion script offers the flags, and bash's is valid bash.
#[test]
fn completions_offer_the_flags() {
    for shell in ["bash", "zsh", "fish"] {
        let out = ok(bin().args(["completions", shell]));
        let script = String::from_utf8(out.stdout).expect("utf-8");
        for flag in ["config", "set", "rain", "wind"] {
            assert!(script.contains(flag), "{shell} lacks --{flag}");
        }
        if shell == "bash" {
            let check = Command::new("bash")
                .args(["-n", "-c", &script])
                .output()
                .expect("bash");
            assert!(
                check.status.success(),
                "{}",
                String::from_utf8_lossy(&check.stderr)
            );
        }
    }
}

/// `ffmpeg -f framemd5` lines of one stream's packets, copied: stream, dts, pts, duration,
/// size and hash.
fn packet_md5(path: &Path, map: &str) -> Vec<String> {
    let out = Command::new("ffmpeg")
        .args(["-hide_banner", "-nostdin", "-v", "error", "-i", s(path)])
        .args(["-map", map, "-c", "copy", "-f", "framemd5", "-"])
        .output()
        .expect("ffmpeg");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .expect("utf-8")
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(str::to_string)
        .collect()
}

/// Three chunks, cut by index and by time (the last one far enough in that it starts from a
/// seek), joined with `ffmpeg -f concat -c copy` by the shipped joiner, are the single render
/// packet for packet: the same bytes at the same timestamps, video and audio.
#[test]
fn chunks_join_into_the_single_render() {
    let dir = TempDir::new().expect("tempdir");
    let input = fixtures::clip_with_audio(
        dir.path(),
        "in.mp4",
        6.0,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
        &["-c:a", "aac", "-shortest"],
    );
    // With the rain keyed to start and grow, which chunks must follow as the whole does.
    let render = |name: &str, range: &[&str]| {
        let out = dir.path().join(name);
        ok(bin()
            .args([s(&input), "-o", s(&out), "--codec", "ffv1"])
            .args(["--set", "rain.rate_mm_per_h=[[0.5,0],[4,40]]"])
            .args(range));
        out
    };
    let whole = render("whole.mkv", &[]);
    let chunks = [
        render("c0.mkv", &["--frames", "0..50"]),
        render("c1.mkv", &["--from", "2", "--to", "4.4"]),
        render("c2.mkv", &["--frames", "110.."]),
    ];
    // Named relative to the current folder, the output in another one: the list ffmpeg reads
    // lies beside the output, and is removed after the join.
    std::fs::create_dir(dir.path().join("out")).expect("mkdir");
    let joined = dir.path().join("out/joined.mkv");
    let join = concat!(env!("CARGO_MANIFEST_DIR"), "/tools/farm/join.py");
    ok(Command::new("python3")
        .current_dir(dir.path())
        .args([join, "out/joined.mkv"])
        .args(chunks.iter().map(|c| c.file_name().expect("a file name"))));
    assert_eq!(fixtures::files_in(&dir.path().join("out")), ["joined.mkv"]);
    for map in ["0:v", "0:a"] {
        let (a, b) = (packet_md5(&whole, map), packet_md5(&joined, map));
        assert!(a.len() > 100, "{map}: {} packets", a.len());
        assert_eq!(a, b, "{map} differs");
    }
    // An empty or missing range is refused, and leaves no file behind.
    let none = dir.path().join("none.mkv");
    for range in [["--frames", "400.."], ["--frames", "9..9"]] {
        let e = fails(bin().args([s(&input), "-o", s(&none)]).args(range));
        assert!(e.contains("error:") && !none.exists(), "{e}");
    }
}

/// The Python with Dask that `.ci/install-deps` sets up (or `RAIN_COMPOSITE_FARM_PYTHON`).
fn farm_python() -> String {
    let python = std::env::var("RAIN_COMPOSITE_FARM_PYTHON").unwrap_or_else(|_| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/target/farm-venv/bin/python").to_string()
    });
    assert!(
        Path::new(&python).exists(),
        "{python} is missing: run .ci/install-deps (it installs Dask into target/farm-venv)"
    );
    python
}

/// The Dask job on a local single-node cluster (two worker processes, four chunks) writes the
/// single render, packet for packet, with a preset passed through to every chunk.
#[test]
fn the_dask_job_renders_the_single_render() {
    let dir = TempDir::new().expect("tempdir");
    let input = fixtures::clip_with_audio(
        dir.path(),
        "in.mp4",
        3.0,
        &["-c:v", "libx264", "-pix_fmt", "yuv420p"],
        &["-c:a", "aac", "-shortest"],
    );
    let whole = dir.path().join("whole.mkv");
    ok(bin()
        .args([s(&input), "-o", s(&whole), "--codec", "ffv1"])
        .args(["--config", "steady"]));
    let farmed = dir.path().join("farmed.mkv");
    let job = concat!(env!("CARGO_MANIFEST_DIR"), "/tools/farm/dask_render.py");
    ok(Command::new(farm_python())
        .args([
            job,
            s(&input),
            s(&farmed),
            "--chunk-frames",
            "20",
            "--workers",
            "2",
        ])
        .args(["--binary", env!("CARGO_BIN_EXE_rain-composite")])
        .args(["--work-dir", s(dir.path()), "--", "--config", "steady"])
        .env("XDG_RUNTIME_DIR", std::env::temp_dir()));
    for map in ["0:v", "0:a"] {
        assert_eq!(
            packet_md5(&whole, map),
            packet_md5(&farmed, map),
            "{map} differs"
        );
    }
}
