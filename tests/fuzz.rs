//! Seeded mutation fuzzing of the two parsers that read untrusted bytes: the JSON configuration
//! and the video reader (y4m, the format pipes carry). Every mutated input must give `Ok` or a
//! clean `Err`, never a panic, and a configuration that validates must plan its rain.
//!
//! CI runs a bounded number of cases; a longer run:
//! `RAIN_COMPOSITE_FUZZ_CASES=200000 cargo test --release --test fuzz -- --nocapture`.

use std::panic::{AssertUnwindSafe, catch_unwind};

use rain_composite::config::RenderConfig;
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
    let _ = rain_composite::gpu::uniforms::build(
        &camera,
        &config.camera,
        &config.rain,
        exposure,
        0,
        (64, 48),
    );
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
