//! Seeded mutation fuzzing of the parsers that read untrusted bytes: the JSON configuration,
//! the video reader (y4m, the format pipes carry), the puddles' checkpoints, depth maps and
//! `--set` overrides. Every mutated input must give `Ok` or a clean `Err`, never a panic, and a
//! configuration that validates must plan its rain.
//!
//! CI runs a bounded number of cases; a longer run:
//! `RAIN_COMPOSITE_FUZZ_CASES=200000 cargo test --release --test fuzz -- --nocapture`.

use std::panic::{AssertUnwindSafe, catch_unwind};

use rain_composite::config::RenderConfig;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::rng::SplitMix64;
use rain_composite::video::{Source, SourceItem};

fn cases(default: usize) -> usize {
    std::env::var("RAIN_COMPOSITE_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn pick(rng: &mut SplitMix64, n: usize) -> usize {
    (rng.next_u64() % n.max(1) as u64) as usize
}

/// Tokens that stress a JSON number or structure parser and our range checks.
const TOKENS: &[&str] = &[
    "0",
    "-0",
    "1e308",
    "-1e308",
    "1e-320",
    "NaN",
    "Infinity",
    "null",
    "true",
    "\"x\"",
    "[]",
    "{}",
    "[",
    "{",
    "}",
    "]",
    ",",
    ":",
    "4294967296",
    "-1",
    "18446744073709551616",
    "1.5",
    "\"rain\"",
    "\"camera\"",
    "\"light\"",
    "\u{feff}",
    "\\u0000",
    "\"",
];

/// One mutation of `input`: a byte flipped, a range deleted or duplicated, or a token inserted.
fn mutate(rng: &mut SplitMix64, input: &[u8]) -> Vec<u8> {
    let mut v = input.to_vec();
    for _ in 0..1 + pick(rng, 4) {
        let at = pick(rng, v.len() + 1);
        match pick(rng, 4) {
            0 if !v.is_empty() => {
                let i = at.min(v.len() - 1);
                v[i] ^= 1 << pick(rng, 8);
            }
            1 if !v.is_empty() => {
                let end = (at + 1 + pick(rng, 16)).min(v.len());
                v.drain(at.min(end)..end);
            }
            2 if !v.is_empty() => {
                let end = (at + 1 + pick(rng, 16)).min(v.len());
                let piece = v[at.min(end)..end].to_vec();
                v.splice(at.min(end)..at.min(end), piece);
            }
            _ => {
                let t = TOKENS[pick(rng, TOKENS.len())].as_bytes();
                v.splice(at..at, t.iter().copied());
            }
        }
    }
    v
}

/// A value-level mutation: one number of the configuration replaced by an extreme, a boundary
/// or a random value (reaches the range checks and the planner far more often than bytes).
fn mutate_value(rng: &mut SplitMix64, text: &str) -> String {
    let mut v: serde_json::Value = serde_json::from_str(text).expect("seed parses");
    let mut leaves = Vec::new();
    collect_numbers(&v, String::new(), &mut leaves);
    for _ in 0..1 + pick(rng, 3) {
        let path = &leaves[pick(rng, leaves.len())];
        let x = match pick(rng, 6) {
            0 => 0.0,
            1 => -1.0,
            2 => 1e9,
            3 => (rng.next_f64() - 0.5) * 2e4,
            4 => rng.next_f64() * 10.0,
            _ => f64::from(u32::MAX),
        };
        if let Some(slot) = v.pointer_mut(path) {
            *slot = serde_json::json!(x);
        }
    }
    v.to_string()
}

fn collect_numbers(v: &serde_json::Value, at: String, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                collect_numbers(x, format!("{at}/{k}"), out);
            }
        }
        serde_json::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                collect_numbers(x, format!("{at}/{i}"), out);
            }
        }
        serde_json::Value::Number(_) => out.push(at),
        _ => {}
    }
}

fn seeds_config() -> Vec<String> {
    let mut seeds: Vec<String> = ["default", "city", "storm"]
        .iter()
        .map(|p| {
            let path = format!("{}/samples/presets/{p}.json", env!("CARGO_MANIFEST_DIR"));
            std::fs::read_to_string(path).expect("preset")
        })
        .collect();
    seeds.push(serde_json::to_string(&RenderConfig::default()).expect("json"));
    seeds
}

/// Parses, validates and (when valid) plans the rain of a mutated configuration.
fn exercise_config(text: &str) {
    let Ok(config) = RenderConfig::from_json(text) else {
        return;
    };
    if config.validate().is_err() {
        return;
    }
    let camera = config.camera.camera(64, 48);
    let Ok(exposure) = rain_composite::rain::physics::exposure_s(config.camera.shutter_deg, 25.0)
    else {
        return;
    };
    let _ = rain_composite::shot::rain::plan(
        &camera,
        &config.camera,
        &config.rain,
        exposure,
        0,
        (64, 48),
    )
    .map(RainSetup::pack);
}

#[test]
fn mutated_configurations_never_panic() {
    let seeds = seeds_config();
    let mut rng = SplitMix64(0x5eed_c0f1);
    let (mut parsed, mut planned) = (0, 0);
    for case in 0..cases(3000) {
        let seed = &seeds[case % seeds.len()];
        let text = if case % 2 == 0 {
            mutate_value(&mut rng, seed)
        } else {
            String::from_utf8_lossy(&mutate(&mut rng, seed.as_bytes())).into_owned()
        };
        if let Ok(c) = RenderConfig::from_json(&text) {
            parsed += 1;
            planned += usize::from(c.validate().is_ok());
        }
        let r = catch_unwind(AssertUnwindSafe(|| exercise_config(&text)));
        assert!(r.is_ok(), "case {case} panicked on config:\n{text}");
    }
    // The mutations must reach the validation and the planner, not stop at the JSON syntax.
    assert!(
        parsed > 1000 && planned > 150,
        "only {parsed} mutated configs parsed, {planned} valid"
    );
}

/// A valid YUV4MPEG2 stream: `frames` frames of `w`×`h` 4:2:0.
fn y4m(w: usize, h: usize, frames: usize) -> Vec<u8> {
    let mut v = format!("YUV4MPEG2 W{w} H{h} F25:1 Ip A1:1 C420jpeg\n").into_bytes();
    for f in 0..frames {
        v.extend_from_slice(b"FRAME\n");
        v.extend((0..w * h).map(|i| (i * 7 + f * 13) as u8));
        v.extend(std::iter::repeat_n(128u8, 2 * (w / 2) * (h / 2)));
    }
    v
}

/// Opens a mutated stream from a file and reads it to the end; errors are fine.
fn exercise_video(path: &std::path::Path) -> usize {
    let Ok(mut source) = Source::open(path.to_str().expect("utf-8")) else {
        return 0;
    };
    let mut frames = 0;
    while let Ok(Some(item)) = source.next_item() {
        if let SourceItem::Frame(f) = item {
            assert_eq!(f.planes.len(), 3);
            frames += 1;
        }
        if frames > 1000 {
            break;
        }
    }
    frames
}

#[test]
fn mutated_y4m_streams_never_panic() {
    let dir = tempfile::tempdir().expect("tmp");
    let mut rng = SplitMix64(0xf00d_0d4e);
    let seeds = [y4m(16, 16, 3), y4m(17, 9, 2), y4m(2, 2, 4)];
    let mut decoded = 0;
    for case in 0..cases(400) {
        let seed = &seeds[case % seeds.len()];
        // Mutate the header more often than the pixels: that is where the parsing is.
        let bytes = if case % 3 == 0 {
            mutate(&mut rng, seed)
        } else {
            let head = seed.iter().position(|&b| b == b'\n').unwrap_or(0) + 1;
            let mut v = mutate(&mut rng, &seed[..head]);
            v.extend_from_slice(&seed[head..]);
            v
        };
        let path = dir.path().join(format!("case{case}.y4m"));
        std::fs::write(&path, &bytes).expect("write");
        let r = catch_unwind(AssertUnwindSafe(|| exercise_video(&path)));
        match r {
            Ok(n) => decoded += usize::from(n > 0),
            Err(_) => panic!(
                "case {case} panicked on y4m header {:?}",
                String::from_utf8_lossy(&bytes[..bytes.len().min(80)])
            ),
        }
        std::fs::remove_file(&path).expect("rm");
    }
    assert!(
        decoded > 10,
        "only {decoded} mutated streams decoded at all"
    );
}

/// FNV-1a, 64 bits: the hash a checkpoint ends in, so a mutated file can be made to pass it
/// and reach the state's reader.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Kept water that is damaged — whether its hash then matches or not — is passed over or
/// read, never a panic, and water read from it goes on running.
#[test]
fn mutated_checkpoints_never_panic() {
    use rain_composite::fluid::puddles::checkpoint::fingerprint;
    use rain_composite::fluid::puddles::{Checkpoints, PuddleSettings, PuddleSim};
    let mut config = RenderConfig::default();
    config.ground.mode = "horizon=0.1".parse().expect("mode");
    config.camera.fov_deg = 90.0;
    config.ground.pre_rain_min = 60.0;
    let camera = config.camera(96, 64).expect("camera");
    let settings = PuddleSettings {
        max_distance_m: 2.0,
        particle_spacing_m: 0.03,
        max_particles: 400,
        ..PuddleSettings::default()
    };
    let build = || {
        PuddleSim::new(&config, &camera, None, 25.0, &settings)
            .expect("valid")
            .expect("ground in view")
    };
    let dir = tempfile::tempdir().expect("tmp");
    let kept = Checkpoints {
        dir: dir.path().to_path_buf(),
        every_frames: 1,
    };
    let print = fingerprint(&config, &camera, 25.0, &settings);
    kept.save(&print, 0, &build()).expect("kept");
    let file = kept.path(&print, 0);
    let sound = std::fs::read(&file).expect("file");
    let mut rng = SplitMix64(0xc4ec_4901);
    let mut read = 0;
    for case in 0..cases(300) {
        let mut bytes = mutate(&mut rng, &sound[..sound.len() - 8]);
        // Half the cases carry a hash that matches: the reader of the state itself is fuzzed.
        let hash = if case % 2 == 0 {
            fnv1a(&bytes)
        } else {
            rng.next_u64()
        };
        bytes.extend(hash.to_le_bytes());
        std::fs::write(&file, &bytes).expect("write");
        let r = catch_unwind(AssertUnwindSafe(|| {
            if let Some((_, sim)) = kept.latest(&print, 0) {
                let mut sim = sim.with_fixed_parts_of(build());
                let _ = sim.advance_to(0.08, &[]);
                return true;
            }
            false
        }));
        match r {
            Ok(used) => read += usize::from(used),
            Err(_) => panic!("case {case} panicked on a mutated checkpoint"),
        }
    }
    // Mutations that keep the state readable must reach the solver, not stop at the hash.
    assert!(read > 0, "no mutated checkpoint was read");
}

/// A damaged depth map is an error, never a panic.
#[test]
fn mutated_depth_maps_never_panic() {
    use rain_composite::scene::DepthMap;
    let dir = tempfile::tempdir().expect("tmp");
    let seed_path = dir.path().join("seed.png");
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(23, 17, |x, y| {
        image::Luma([(x * 300 + y * 7) as u16])
    })
    .save(&seed_path)
    .expect("png");
    let seed = std::fs::read(&seed_path).expect("read");
    let mut rng = SplitMix64(0xdeb7_4a95);
    let mut loaded = 0;
    for case in 0..cases(1000) {
        let bytes = mutate(&mut rng, &seed);
        let path = dir.path().join("case.png");
        std::fs::write(&path, &bytes).expect("write");
        let r = catch_unwind(AssertUnwindSafe(|| {
            DepthMap::load_png(&path, 1.0).map(|m| m.resampled(40, 30).known_fraction())
        }));
        match r {
            Ok(result) => loaded += usize::from(result.is_ok()),
            Err(_) => panic!("case {case} panicked on a mutated depth map"),
        }
    }
    assert!(loaded > 10, "only {loaded} mutated maps loaded");
}

/// `--set` overrides mutated in their keys and values are applied or refused, never a panic.
#[test]
fn mutated_overrides_never_panic() {
    let seeds = [
        "rain.rate_mm_per_h=12.5",
        "camera.fov_deg=[[0,60],[2,40]]",
        "ground.mode=horizon=0.45",
        "light.lights=[]",
        "rain.wind_mps=[1.5,-0.5]",
    ];
    let mut rng = SplitMix64(0x0e77_1de5);
    let base = RenderConfig::default();
    for case in 0..cases(3000) {
        let set = String::from_utf8_lossy(&mutate(&mut rng, seeds[case % seeds.len()].as_bytes()))
            .into_owned();
        let r = catch_unwind(AssertUnwindSafe(|| {
            if let Ok(c) = rain_composite::preset::with_overrides(&base, std::slice::from_ref(&set))
            {
                let _ = c.validate();
            }
        }));
        assert!(r.is_ok(), "case {case} panicked on --set {set:?}");
    }
}
