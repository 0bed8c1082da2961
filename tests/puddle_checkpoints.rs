//! The puddles' checkpoints: the water kept in a file and read back goes on exactly as the
//! water that was never stopped; chunks that start from kept water join into the whole render
//! frame for frame; water kept under other settings, or a damaged file, is never used.

use glam::DVec3;
use rain_composite::config::RenderConfig;
use rain_composite::fluid::puddles::checkpoint::fingerprint;
use rain_composite::fluid::puddles::{Checkpoints, PuddleSettings, PuddleSim};
use rain_composite::rain::volume::Impact;
use rain_composite::rng::SplitMix64;
use rain_composite::scene::Camera;
use std::path::Path;
use std::process::Command;
use tempfile::TempDir;

#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::s;

#[path = "common/binary.rs"]
mod binary;
use binary::{bin, ok};

const FPS: f64 = 25.0;

#[path = "common/puddle_street.rs"]
mod puddle_street;

/// A street seen from 1.6 m with a 90° lens, four hours of 20 mm/h before the clip.
fn street() -> (RenderConfig, Camera) {
    puddle_street::street(20.0, 240.0, 0.006)
}

fn settings() -> PuddleSettings {
    PuddleSettings {
        max_distance_m: 3.0,
        particle_spacing_m: 0.015,
        max_particles: 6_000,
        ..PuddleSettings::default()
    }
}

/// 400 drops of 2 mm landing during frame `frame`, spread over the ground the camera sees.
fn rain_of_frame(frame: u64) -> Vec<Impact> {
    let mut rng = SplitMix64(frame);
    (0..400)
        .map(|k| Impact {
            id: k,
            pass: frame as u32,
            time_s: (frame as f64 - rng.next_f64()) / FPS,
            position_m: DVec3::new(rng.next_f64() * 4.0 - 2.0, 0.2 + rng.next_f64() * 2.8, 0.0),
            diameter_mm: 2.0,
            velocity_mps: DVec3::new(0.0, 0.0, -6.5),
        })
        .collect()
}

fn run(sim: &mut PuddleSim, frames: std::ops::RangeInclusive<u64>) {
    for f in frames {
        sim.advance_to(f as f64 / FPS, &rain_of_frame(f))
            .expect("step");
    }
}

#[test]
fn kept_water_goes_on_as_the_water_that_never_stopped() {
    let (config, camera) = street();
    let s = settings();
    let build = || {
        PuddleSim::new(&config, &camera, None, FPS, &s)
            .expect("valid")
            .expect("ground in view")
    };
    let dir = TempDir::new().expect("tmp");
    let kept = Checkpoints {
        dir: dir.path().join("water"),
        every_frames: 4,
    };
    let print = fingerprint(&config, &camera, FPS, &s);

    let mut straight = build();
    run(&mut straight, 1..=8);
    assert!(straight.ledger().rain_drops > 0);
    kept.save(&print, 8, &straight).expect("kept");

    // Read back at a later frame: the latest file at or before it, with the parts the file
    // leaves out taken from water built anew.
    let (at, restored) = kept.latest(&print, 11).expect("a checkpoint");
    assert_eq!(at, 8);
    let mut restored = restored.with_fixed_parts_of(build());
    assert_eq!(restored.time_s(), straight.time_s());
    run(&mut straight, 9..=14);
    run(&mut restored, 9..=14);
    assert!(
        straight.steps() > 14,
        "the solver ran: {}",
        straight.steps()
    );
    assert_eq!(
        restored.flow().sph.state_digest(),
        straight.flow().sph.state_digest()
    );
    assert_eq!(restored.water_depth(), straight.water_depth());
    assert_eq!(restored.shown_depth(), straight.shown_depth());
    assert_eq!(restored.wetness(), straight.wetness());
    assert_eq!(restored.ledger(), straight.ledger());

    // Nothing before the first kept frame; nothing under other settings.
    assert!(kept.latest(&print, 7).is_none());
    let (mut wetter, _) = street();
    wetter.rain.rate_mm_per_h = 21.0;
    let other = fingerprint(&wetter, &camera, FPS, &s);
    assert_ne!(other, print);
    assert!(kept.latest(&other, 11).is_none());

    // A damaged file (cut short) or one renamed to another frame is passed over, not used.
    let file = kept.path(&print, 8);
    let bytes = std::fs::read(&file).expect("file");
    std::fs::write(&file, &bytes[..bytes.len() / 2]).expect("cut");
    assert!(kept.latest(&print, 11).is_none());
    std::fs::write(kept.path(&print, 4), &bytes).expect("renamed");
    assert!(kept.latest(&print, 11).is_none());
}

/// What the water of a render started from, as its `-v` log says.
fn start_of_water(log: &str) -> &str {
    let line = log
        .lines()
        .find(|l| l.contains("puddles:") && l.contains("water brought to"))
        .unwrap_or_else(|| panic!("no puddles line in {log}"));
    line.find(" s from ").map_or(line, |i| &line[i + 3..])
}

#[test]
fn chunks_from_kept_water_join_into_the_whole_render() {
    let dir = TempDir::new().expect("tmp");
    let input = dir.path().join("in.mp4");
    fixtures::ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "testsrc2=size=160x120:rate=25",
        "-t",
        "3",
        "-c:v",
        "libx264",
        "-g",
        "10",
        "-pix_fmt",
        "yuv420p",
        s(&input),
    ]);
    let water = dir.path().join("water");
    let render_from = |kept: &Path, name: &str, rain: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let log = ok(bin()
            .args([s(&input), "-o", s(&out), "--codec", "ffv1", "-v"])
            .args(["--rain", rain, "--seed", "3", "--cpu"])
            .args(["--ground", "horizon=0.4", "--pre-rain", "240", "--puddles"])
            .args(["--puddle-particles", "1500", "--relief", "0.01"])
            .args(["--checkpoints", s(kept)])
            .args(extra));
        (out, String::from_utf8_lossy(&log.stderr).into_owned())
    };
    let render = |name: &str, rain: &str, extra: &[&str]| render_from(&water, name, rain, extra);
    let (whole, log) = render("whole.mkv", "30", &["--checkpoint-every", "10"]);
    assert!(
        start_of_water(&log).starts_with("from the clip's start"),
        "{log}"
    );
    let kept = std::fs::read_dir(&water).expect("kept water").count();
    assert_eq!(kept, 8, "frames 0, 10, … 70 of 75");

    let mut joined = Vec::new();
    for (range, from) in [("0..25", 0), ("25..52", 20), ("52..", 50)] {
        let (chunk, log) = render(&format!("c{from}.mkv"), "30", &["--frames", range]);
        assert!(
            start_of_water(&log).starts_with(&format!("from the checkpoint of frame {from} ")),
            "{range}: {log}"
        );
        joined.extend(fixtures::framemd5(&chunk, "0:v", false));
    }
    assert_eq!(joined, fixtures::framemd5(&whole, "0:v", false));

    // A farm's simulation pass: `inspect puddles` keeps the water a render would keep, and a
    // chunk started from it is the whole render's chunk (the pass needs no `--puddles`: what
    // is shown does not change the water).
    let pass = dir.path().join("pass");
    ok(bin()
        .args([
            "inspect",
            "puddles",
            s(&input),
            "--at",
            "3",
            "--checkpoint-every",
            "25",
        ])
        .args(["--checkpoints", s(&pass), "--rain", "30", "--seed", "3"])
        .args(["--ground", "horizon=0.4", "--pre-rain", "240"])
        .args(["--puddle-particles", "1500", "--relief", "0.01"]));
    assert_eq!(
        std::fs::read_dir(&pass).expect("kept").count(),
        4,
        "frames 0, 25, 50, 75"
    );
    let (out, log) = render_from(&pass, "late.mkv", "30", &["--frames", "52.."]);
    assert!(
        start_of_water(&log).starts_with("from the checkpoint of frame 50 "),
        "{log}"
    );
    assert_eq!(
        fixtures::framemd5(&out, "0:v", false),
        fixtures::framemd5(&whole, "0:v", false)[52..]
    );

    // Other settings make other water: the kept files are not theirs.
    let (_, log) = render("wetter.mkv", "31", &["--frames", "52.."]);
    assert!(
        start_of_water(&log).starts_with("from the clip's start"),
        "{log}"
    );
    assert!(log.contains("simulated with other settings"), "{log}");
}

/// A kept file is checked whole before it is used: flipped bits in its body, a FIFO or a link
/// to a device named like one are passed over (at once, whatever their size), and a damaged
/// file is replaced when the water is kept again.
#[test]
fn damaged_or_strange_checkpoints_are_passed_over_and_replaced() {
    let (config, camera) = street();
    let s = settings();
    let mut sim = PuddleSim::new(&config, &camera, None, FPS, &s)
        .expect("valid")
        .expect("ground in view");
    run(&mut sim, 1..=4);
    let dir = TempDir::new().expect("tmp");
    let kept = Checkpoints {
        dir: dir.path().join("water"),
        every_frames: 4,
    };
    let print = fingerprint(&config, &camera, FPS, &s);
    kept.save(&print, 4, &sim).expect("kept");
    let file = kept.path(&print, 4);
    let sound = std::fs::read(&file).expect("file");
    assert!(kept.latest(&print, 4).is_some());

    // Bits flipped in the middle of the state: the floats would still parse.
    let mut flipped = sound.clone();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 0x55;
    std::fs::write(&file, &flipped).expect("write");
    assert!(kept.latest(&print, 4).is_none(), "a damaged file was used");
    // Kept again: the damaged file is replaced by the sound one.
    kept.save(&print, 4, &sim).expect("kept");
    assert_eq!(std::fs::read(&file).expect("file"), sound);

    let started = std::time::Instant::now();
    std::fs::remove_file(&file).expect("rm");
    assert!(
        Command::new("mkfifo")
            .arg(&file)
            .status()
            .expect("mkfifo")
            .success()
    );
    assert!(kept.latest(&print, 4).is_none(), "a FIFO");
    std::fs::remove_file(&file).expect("rm");
    std::os::unix::fs::symlink("/dev/zero", &file).expect("symlink");
    assert!(kept.latest(&print, 4).is_none(), "a device");
    assert!(started.elapsed().as_secs() < 5, "{:?}", started.elapsed());

    // A folder that is a file is named as such (not "File exists").
    let not_a_folder = Checkpoints {
        dir: dir
            .path()
            .join("water")
            .join(file.file_name().expect("name")),
        every_frames: 4,
    };
    let e = not_a_folder
        .save(&print, 4, &sim)
        .expect_err("a file as the folder")
        .to_string();
    assert!(e.contains("is not a folder"), "{e}");
}

/// The settings of the picture alone — whether the puddles are shown, the streaks, the light —
/// do not change the water, so they do not change its fingerprint: the simulation pass of
/// `inspect puddles` (without `--puddles`) serves a render's chunks.
#[test]
fn the_fingerprint_holds_what_the_water_depends_on_only() {
    let (config, camera) = street();
    let s = settings();
    let print = fingerprint(&config, &camera, FPS, &s);
    let mut shown = config.clone();
    shown.ground.puddles = true;
    shown.rain.streaks = rain_composite::config::StreakStyle::Mattes;
    shown.light.smoothing_s = 2.0;
    shown.streak_db = Some("elsewhere".into());
    assert_eq!(fingerprint(&shown, &camera, FPS, &s), print);
    let mut wetter = config.clone();
    wetter.rain.rate_mm_per_h += 1.0;
    assert_ne!(fingerprint(&wetter, &camera, FPS, &s), print);
    let mut bumpier = config;
    bumpier.ground.relief_seed += 1;
    assert_ne!(fingerprint(&bumpier, &camera, FPS, &s), print);
}
