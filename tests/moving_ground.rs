//! A camera that turns and zooms over a ground, through the binary: the water, the splashes,
//! the wet ground and the masks follow each frame's camera, and a preview, a chunk and a second
//! render each show what the whole render writes at a frame, bit for bit; a keyed tilt that
//! does not start where the ground puts the camera, and a keyed height, are refused with one
//! line.

use std::path::{Path, PathBuf};

use tempfile::TempDir;

#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::{framemd5, quick_clip, s};

#[path = "common/binary.rs"]
mod binary;
use binary::{bin, ok};

/// Rain over a given ground with puddles, the camera panning 30° and zooming in over the
/// clip's 2 s.
const PANNING: &[&str] = &[
    "--rain",
    "30",
    "--seed",
    "3",
    "--cpu",
    "--ground",
    "horizon=0.4",
    "--pre-rain",
    "240",
    "--puddles",
    "--puddle-particles",
    "1500",
    "--relief",
    "0.01",
    "--set",
    "camera.pan_deg=[[0,0],[2,30]]",
    "--set",
    "camera.fov_deg=[[0,60],[2,50]]",
];

fn render(dir: &Path, input: &Path, name: &str, look: &[&str], extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    ok(bin()
        .args([s(input), "-o", s(&out), "--codec", "ffv1"])
        .args(look)
        .args(extra));
    out
}

/// Frame `index` previewed with `look`, and the same frame of the render `full`, both as
/// 16-bit PNGs.
fn preview_and_frame(dir: &Path, input: &Path, full: &Path, look: &[&str], index: usize) {
    let preview = dir.join(format!("preview-{index}.png"));
    ok(bin()
        .args(["preview", s(input), "--frame", &index.to_string()])
        .args(["-o", s(&preview), "--bits", "16"])
        .args(look));
    let from_full = dir.join(format!("full-{index}.png"));
    ok(bin()
        .args(["preview", s(full), "--frame", &index.to_string()])
        .args(["-o", s(&from_full), "--bits", "16", "--rain", "0", "--cpu"]));
    assert!(
        std::fs::read(&preview).expect("png") == std::fs::read(&from_full).expect("png"),
        "{look:?}: the preview of frame {index} differs from the render's"
    );
}

#[test]
fn a_pan_over_puddles_previews_chunks_and_renders_again_the_same() {
    let dir = TempDir::new().expect("tmp");
    let d = dir.path();
    let input = quick_clip(d, "in.mp4", "160x120", 2.0);
    let whole = render(d, &input, "whole.mkv", PANNING, &[]);
    let frames = framemd5(&whole, "0:v", false);
    assert_eq!(frames.len(), 50);
    // The water is simulated again from the clip's start: the same, frame for frame.
    let again = render(d, &input, "again.mkv", PANNING, &[]);
    assert_eq!(framemd5(&again, "0:v", false), frames);
    // Chunks bring the water to their first frame and join into the whole.
    let mut joined = Vec::new();
    for (k, range) in ["0..23", "23.."].into_iter().enumerate() {
        let chunk = render(
            d,
            &input,
            &format!("c{k}.mkv"),
            PANNING,
            &["--frames", range],
        );
        joined.extend(framemd5(&chunk, "0:v", false));
    }
    assert_eq!(joined, frames);
    for index in [17, 41] {
        preview_and_frame(d, &input, &whole, PANNING, index);
    }
    // The camera turned: its frames are not the still camera's.
    let still: Vec<&str> = PANNING
        .iter()
        .copied()
        .filter(|a| !a.starts_with("camera.") && *a != "--set")
        .collect();
    let held = render(d, &input, "still.mkv", &still, &["--frames", "40..42"]);
    assert_ne!(framemd5(&held, "0:v", false), frames[40..42]);
}

/// A pose file (a pan with shake in tilt and roll, its first frame level) beside a ground:
/// turned to start at the ground's pose, rendered, previewed as rendered.
#[test]
fn a_pose_file_beside_a_ground_previews_as_it_renders() {
    let dir = TempDir::new().expect("tmp");
    let d = dir.path();
    let input = quick_clip(d, "in.mp4", "160x120", 2.0);
    let frames: Vec<serde_json::Value> = (0..50)
        .map(|i| {
            let t = i as f64 / 25.0;
            serde_json::json!({
                "t": t,
                "pan_deg": -12.0 * t,
                "tilt_deg": 0.4 * (6.0 * t).sin(),
                "roll_deg": 0.3 * (4.0 * t).sin(),
                "fov_deg": 60.0,
            })
        })
        .collect();
    let poses = d.join("poses.json");
    std::fs::write(&poses, serde_json::json!({ "frames": frames }).to_string()).expect("write");
    let mut look: Vec<&str> = PANNING[..PANNING.len() - 4].to_vec();
    look.extend(["--camera-motion", s(&poses)]);
    let whole = render(d, &input, "whole.mkv", &look, &["--frames", "0..31"]);
    preview_and_frame(d, &input, &whole, &look, 30);
}

#[test]
fn a_moving_ground_camera_is_refused_where_it_cannot_be_drawn() {
    let dir = TempDir::new().expect("tmp");
    let d = dir.path();
    let input = quick_clip(d, "in.mp4", "96x64", 0.2);
    let refused = |extra: &[&str], names: &str| {
        let png = d.join("refused.png");
        let out = bin()
            .args(["preview", s(&input), "--at", "0.1", "-o", s(&png), "--cpu"])
            .args(["--ground", "horizon=0.4"])
            .args(extra)
            .output()
            .expect("run");
        let e = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{extra:?} was not refused");
        assert!(e.contains(names), "{extra:?}: {e}");
        assert_eq!(e.trim().lines().count(), 1, "{e}");
        assert!(!png.exists());
    };
    // A tilt keyed from level, where the ground's horizon puts the camera at another tilt.
    refused(&["--set", "camera.tilt_deg=[[0,0],[0.2,3]]"], "--tilt");
    // A crane: the camera moves, the ground would not stay where it is drawn.
    refused(
        &["--set", "camera.height_m=[[0,1.6],[0.2,3]]"],
        "--camera-height",
    );
}
