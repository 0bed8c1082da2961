//! How many of a lossless render's visible streak pixels each encoder setting keeps, and at
//! what size: the table behind the default `--encoder-params` (docs/measurements.md, "Streaks
//! through the encoder"; the reasoning in docs/guide/encoding.md).
//!
//! `cargo bench --bench streak_encoding` (about ten minutes on two CPU cores). Each scene is
//! rendered twice losslessly (FFV1), with rain and with `--rain 0`, both with `--scene-depth 0`
//! (the haze would otherwise count as streaks); each setting then encodes the lossless rain
//! render with the ffmpeg CLI (the same libx264/libx265 the program links, with the same
//! options), and the last row is the program's own default output, rendered again.

use std::path::{Path, PathBuf};
use std::process::Command;

#[path = "../tests/common/fixtures.rs"]
mod fixtures;
use fixtures::{VISIBLE_STREAK_CODES, ffmpeg, luma_frames, streaks_kept};

/// A clip to rain on: a sample, optionally cropped, and the look flags.
struct Scene {
    name: &'static str,
    sample: &'static str,
    crop: Option<&'static str>,
    secs: &'static str,
    look: &'static [&'static str],
}

const SCENES: [Scene; 3] = [
    Scene {
        name: "street, downpour (daylight, 640×360)",
        sample: "street.mp4",
        crop: None,
        secs: "4",
        look: &["--config", "downpour"],
    },
    Scene {
        name: "city, city preset (night sky, 720×404)",
        sample: "city.mp4",
        crop: None,
        secs: "4",
        look: &["--config", "city"],
    },
    Scene {
        name: "city's lit buildings, 320×180, 30 mm/h (the test's scene)",
        sample: "city.mp4",
        crop: Some("crop=320:180:400:224"),
        secs: "2",
        look: &["--rain", "30"],
    },
];

/// (label, ffmpeg video encoder arguments).
const SETTINGS: [(&str, &str); 15] = [
    (
        "x264 CRF 18 medium (the encoder's defaults)",
        "-c:v libx264 -crf 18 -preset medium",
    ),
    ("CRF 16", "-c:v libx264 -crf 16 -preset medium"),
    ("CRF 14", "-c:v libx264 -crf 14 -preset medium"),
    (
        "CRF 18, tune=grain",
        "-c:v libx264 -crf 18 -preset medium -tune grain",
    ),
    (
        "CRF 16, tune=grain",
        "-c:v libx264 -crf 16 -preset medium -tune grain",
    ),
    (
        "CRF 18, psy-rd=1.0:0.25",
        "-c:v libx264 -crf 18 -preset medium -x264-params psy-rd=1.0,0.25",
    ),
    (
        "CRF 18, aq-mode=3",
        "-c:v libx264 -crf 18 -preset medium -x264-params aq-mode=3",
    ),
    (
        "CRF 18, deblock=-2:-2",
        "-c:v libx264 -crf 18 -preset medium -x264-params deblock=-2,-2",
    ),
    (
        "CRF 18, mbtree=0",
        "-c:v libx264 -crf 18 -preset medium -x264-params mbtree=0",
    ),
    (
        "CRF 18, bframes=0",
        "-c:v libx264 -crf 18 -preset medium -x264-params bframes=0",
    ),
    (
        "CRF 18, bframes=0:qcomp=0.8",
        "-c:v libx264 -crf 18 -preset medium -x264-params bframes=0:qcomp=0.8",
    ),
    (
        "CRF 17, bframes=0",
        "-c:v libx264 -crf 17 -preset medium -x264-params bframes=0",
    ),
    (
        "CRF 18, tune=grain, bframes=0",
        "-c:v libx264 -crf 18 -preset medium -tune grain -x264-params bframes=0",
    ),
    (
        "x265 CRF 18 medium",
        "-c:v libx265 -crf 18 -preset medium -x265-params log-level=error",
    ),
    (
        "x265 CRF 18, bframes=0:qcomp=0.8",
        "-c:v libx265 -crf 18 -preset medium -x265-params log-level=error:bframes=0:qcomp=0.8",
    ),
];

fn render(input: &Path, output: &Path, args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_rain-composite"))
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .arg(input)
        .arg("-o")
        .arg(output)
        .args(["-y", "-q", "--scene-depth", "0"])
        .args(args)
        .output()
        .expect("run rain-composite");
    assert!(
        out.status.success(),
        "render {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

fn main() {
    // `cargo bench --bench streak_encoding [-- N…]`: scenes N… only (1-based), else all.
    let chosen: Vec<usize> = std::env::args().filter_map(|a| a.parse().ok()).collect();
    let scenes: Vec<&Scene> = SCENES
        .iter()
        .enumerate()
        .filter(|(i, _)| chosen.is_empty() || chosen.contains(&(i + 1)))
        .map(|(_, s)| s)
        .collect();
    let dir = tempfile::TempDir::new().expect("temporary directory");
    let samples = Path::new(env!("CARGO_MANIFEST_DIR")).join("samples");
    // results[setting][scene] = (kept %, bytes); visible[scene] = % of the frame.
    let mut results = vec![Vec::new(); SETTINGS.len() + 1];
    let mut visible_pc = Vec::new();
    for (i, scene) in scenes.iter().enumerate() {
        let clip = dir.path().join(format!("clip{i}.mkv"));
        let sample = samples.join(scene.sample);
        let mut args = vec!["-i", s(&sample), "-t", scene.secs];
        if let Some(crop) = scene.crop {
            args.extend(["-vf", crop]);
        }
        args.extend(["-c:v", "ffv1", s(&clip)]);
        ffmpeg(&args);
        let (rain, dry) = (dir.path().join("rain.mkv"), dir.path().join("dry.mkv"));
        let mut look = scene.look.to_vec();
        look.extend(["--codec", "ffv1"]);
        render(&clip, &rain, &look);
        match look.iter().position(|a| *a == "--rain") {
            Some(k) => look[k + 1] = "0",
            None => look.extend(["--rain", "0"]),
        }
        render(&clip, &dry, &look);
        let (rain_y, dry_y) = (luma_frames(&rain), luma_frames(&dry));
        let measure = |encoded: &Path| {
            let (visible, kept) =
                streaks_kept(&rain_y, &dry_y, &luma_frames(encoded), VISIBLE_STREAK_CODES);
            let bytes = std::fs::metadata(encoded).expect("output").len();
            (100.0 * kept as f64 / visible.max(1) as f64, bytes, visible)
        };
        for (k, (label, codec)) in SETTINGS.iter().enumerate() {
            let out: PathBuf = dir.path().join(format!("enc{k}.mkv"));
            let mut args = vec!["-i", s(&rain)];
            args.extend(codec.split(' '));
            args.push(s(&out));
            ffmpeg(&args);
            let (kept, bytes, visible) = measure(&out);
            if k == 0 {
                visible_pc.push(100.0 * visible as f64 / rain_y.len() as f64);
            }
            eprintln!("{}: {label}: {kept:.1} % kept, {bytes} bytes", scene.name);
            results[k].push((kept, bytes));
        }
        let ours = dir.path().join("ours.mkv");
        render(&clip, &ours, scene.look);
        let (kept, bytes, _) = measure(&ours);
        eprintln!(
            "{}: rain-composite's default: {kept:.1} % kept, {bytes} bytes",
            scene.name
        );
        results[SETTINGS.len()].push((kept, bytes));
    }

    print!("| setting |");
    for (scene, v) in scenes.iter().zip(&visible_pc) {
        print!(" {} ({v:.2} % visible): kept | size |", scene.name);
    }
    println!();
    println!("|---|{}", "---|---|".repeat(scenes.len()));
    let labels = SETTINGS
        .iter()
        .map(|(l, _)| *l)
        .chain(["rain-composite's default output"]);
    for (label, row) in labels.zip(&results) {
        print!("| {label} |");
        for (j, (kept, bytes)) in row.iter().enumerate() {
            let base = results[0][j].1 as f64;
            print!(" {kept:.1} % | {:.2}× |", *bytes as f64 / base);
        }
        println!();
    }
}
