//! Every numeric option at its minimum and maximum (accepted, rendered) and one step outside
//! (refused with one `error:` line naming the option), at two picture sizes, on whatever
//! adapter the machine has: no run may panic (exit 101) or hang.

use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::time::Duration;

#[path = "common/fixtures.rs"]
mod fixtures;

/// `(flag, minimum, maximum, one step below, one step above)`: the documented ranges.
/// Open bounds use the nearest value inside; `None` where no value lies outside.
type Bounds = (
    &'static str,
    &'static str,
    &'static str,
    Option<&'static str>,
    Option<&'static str>,
);

const OPTIONS: &[Bounds] = &[
    ("--rain", "0", "500", Some("-0.01"), Some("500.01")),
    ("--drop-scale", "0.001", "10", Some("0"), Some("10.01")),
    (
        "--fall-speed-scale",
        "0.001",
        "10",
        Some("0"),
        Some("10.01"),
    ),
    (
        "--wind",
        "-60,0",
        "42.4,42.4",
        Some("-60.1,0"),
        Some("42.5,42.5"),
    ),
    ("--opacity", "0", "100", Some("-0.01"), Some("100.01")),
    ("--seed", "0", "4294967295", Some("-1"), Some("4294967296")),
    ("--fov", "1.01", "169.9", Some("1"), Some("170")),
    (
        "--camera-height",
        "0",
        "1000",
        Some("-0.01"),
        Some("1000.01"),
    ),
    ("--tilt", "-90", "90", Some("-90.01"), Some("90.01")),
    ("--roll", "-180", "180", Some("-180.01"), Some("180.01")),
    ("--shutter", "0.01", "360", Some("0"), Some("360.01")),
    ("--near", "0.05", "199", Some("0.04"), Some("200")),
    ("--far", "0.31", "10000", Some("0.3"), Some("10000.1")),
    ("--max-drops", "1", "20000000", Some("0"), Some("20000001")),
    ("--gust", "0", "60", Some("-0.01"), Some("60.01")),
    ("--altitude", "-500", "9000", Some("-500.1"), Some("9000.1")),
    ("--focus", "0.051", "1e9", Some("0.05"), Some("inf")),
    ("--f-number", "0", "64", Some("-0.01"), Some("64.01")),
    ("--sensor-width", "1.01", "100", Some("1"), Some("100.01")),
    (
        "--scene-depth",
        "0",
        "100000",
        Some("-0.01"),
        Some("100000.1"),
    ),
    ("--light-smoothing", "0", "10", Some("-0.01"), Some("10.01")),
    ("--crf", "0", "51", Some("-1"), Some("52")),
];

struct Case {
    size: &'static str,
    flag: &'static str,
    value: &'static str,
    valid: bool,
}

fn run_case(input: &Path, c: &Case) -> Result<(), String> {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_rain-composite"));
    cmd.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    // --crf belongs to the render, the rest also to preview: render one short clip for it.
    if c.flag == "--crf" {
        cmd.args([input.to_str().expect("utf-8"), "-o", "-", "--format", "nut"]);
    } else {
        cmd.args([
            "preview",
            input.to_str().expect("utf-8"),
            "--frame",
            "1",
            "-o",
            "-",
        ]);
    }
    let arg = format!("{}={}", c.flag, c.value);
    cmd.arg(&arg).stdout(Stdio::null()).stderr(Stdio::piped());
    let mut child = cmd.spawn().map_err(|e| e.to_string())?;
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().map_err(|e| e.to_string())? {
            break s;
        }
        if start.elapsed() > Duration::from_secs(240) {
            let _ = child.kill();
            return Err(format!("{} {arg}: still running after 240 s", c.size));
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().expect("stderr"), &mut err)
        .map_err(|e| e.to_string())?;
    let what = format!("{} {arg} (exit {:?}): {err}", c.size, status.code());
    if err.contains("panicked") || status.code() == Some(101) {
        return Err(format!("panic: {what}"));
    }
    if c.valid {
        if !status.success() {
            return Err(format!("refused a value in range: {what}"));
        }
    } else {
        let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
        // clap refuses what does not parse (a negative u32, say), our checks the rest.
        let names_it =
            lines.len() == 1 && (lines[0].contains(c.flag) || lines[0].contains(&c.flag[2..]));
        if status.code() == Some(0) || !names_it {
            return Err(format!("accepted or unclear: {what}"));
        }
    }
    Ok(())
}

#[test]
fn every_numeric_option_at_and_beyond_its_bounds() {
    let dir = tempfile::tempdir().expect("tmp");
    let sizes = [("96x64", "small.mp4"), ("640x360", "large.mp4")];
    for (size, name) in sizes {
        fixtures::quick_clip(dir.path(), name, size, 0.16);
    }
    let mut cases = Vec::new();
    for (size, _) in sizes {
        for &(flag, min, max, below, above) in OPTIONS {
            cases.push(Case {
                size,
                flag,
                value: min,
                valid: true,
            });
            cases.push(Case {
                size,
                flag,
                value: max,
                valid: true,
            });
            for v in [below, above].into_iter().flatten() {
                cases.push(Case {
                    size,
                    flag,
                    value: v,
                    valid: false,
                });
            }
        }
    }
    let queue = Mutex::new(cases);
    let failures = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..2 {
            scope.spawn(|| {
                loop {
                    let Some(c) = queue.lock().expect("queue").pop() else {
                        break;
                    };
                    let input = dir.path().join(if c.size == "96x64" {
                        "small.mp4"
                    } else {
                        "large.mp4"
                    });
                    if let Err(e) = run_case(&input, &c) {
                        failures.lock().expect("failures").push(e);
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().expect("failures");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
