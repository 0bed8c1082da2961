//! The look at the defaults on footage nobody tuned for: the samples (a daylight facade with
//! white surfaces, a bright hazy sky, an overcast street, a night skyline, the sun in shot) and
//! a night street with a lamp made here. Rendered losslessly through the CLI and compared with
//! the input luma, frame by frame:
//!
//! - the frame-mean change at 10 mm/h stays within 6 code values (no fog), and at most 0.5 % of
//!   the pixels change by 40 codes or more (no glowing surfaces), except with the sun or a lamp
//!   in shot, where the glow of the rain toward it is physical: there the change must be a glow
//!   around the light, not a veil;
//! - the frame-mean change does not pump: its standard deviation over the frames of a steady
//!   shot is at most 1 code;
//! - at 20 mm/h the rain is seen: the high-pass (the frame minus its 7×7 mean) changes by 3
//!   codes or more on at least 0.5 % of the pixels.

#[path = "common/fixtures.rs"]
mod fixtures;
#[path = "common/gpu.rs"]
mod shared_gpu;

#[path = "common/binary.rs"]
mod binary;
use binary::{bin, ok};

use std::path::{Path, PathBuf};

use fixtures::ffmpeg;

fn sample(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("samples")
        .join(name)
}

/// The luma planes of the first `frames` frames of `path` (8-bit, full picture).
fn luma(path: &Path, frames: usize) -> (usize, usize, Vec<Vec<f64>>) {
    let probe = fixtures::stream(path, "v:0");
    let (w, h) = (
        probe["width"].as_u64().unwrap() as usize,
        probe["height"].as_u64().unwrap() as usize,
    );
    let planes = fixtures::luma_frames(path)
        .chunks_exact(w * h)
        .take(frames)
        .map(|p| p.iter().map(|&v| f64::from(v)).collect())
        .collect();
    (w, h, planes)
}

/// The frame minus its 7×7 box mean (edges clamped).
fn high_pass(p: &[f64], w: usize, h: usize) -> Vec<f64> {
    // Integral image, then box sums.
    let mut sum = vec![0.0; (w + 1) * (h + 1)];
    for y in 0..h {
        for x in 0..w {
            sum[(y + 1) * (w + 1) + x + 1] =
                p[y * w + x] + sum[y * (w + 1) + x + 1] + sum[(y + 1) * (w + 1) + x]
                    - sum[y * (w + 1) + x];
        }
    }
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let (x0, x1) = (x.saturating_sub(3), (x + 4).min(w));
            let (y0, y1) = (y.saturating_sub(3), (y + 4).min(h));
            let s = sum[y1 * (w + 1) + x1] - sum[y0 * (w + 1) + x1] - sum[y1 * (w + 1) + x0]
                + sum[y0 * (w + 1) + x0];
            out.push(p[y * w + x] - s / ((x1 - x0) * (y1 - y0)) as f64);
        }
    }
    out
}

/// What the rain did to a clip.
#[derive(Debug)]
struct Look {
    /// Mean over frames of the frame-mean luma change, code values.
    mean_change: f64,
    /// Standard deviation over frames of the frame-mean change.
    pumping: f64,
    /// Share of pixels changed by 40 codes or more.
    big_share: f64,
    /// Share of pixels whose high-pass changed by 3 codes or more.
    detail_share: f64,
    /// Mean change within a tenth of the width of the input's brightest pixel over the mean
    /// change farther than half the width from it: a glow around a light source is high, a
    /// veil over the whole frame near 1.
    glow_contrast: f64,
}

fn look(input: &Path, output: &Path, frames: usize) -> Look {
    let (w, h, a) = luma(input, frames);
    let (w2, h2, b) = luma(output, frames);
    assert_eq!((w, h), (w2, h2));
    let n = a.len().min(b.len());
    assert!(n >= frames.min(10), "{n} frames");
    let brightest = (0..w * h)
        .max_by(|&i, &j| a[0][i].total_cmp(&a[0][j]))
        .unwrap();
    let dist = |i: usize| {
        let (dx, dy) = (
            (i % w) as f64 - (brightest % w) as f64,
            (i / w) as f64 - (brightest / w) as f64,
        );
        dx.hypot(dy) / w as f64
    };
    let (mut near, mut near_n, mut far, mut far_n) = (0.0, 0usize, 0.0, 0usize);
    let (mut means, mut big, mut detail) = (Vec::new(), 0usize, 0usize);
    for (fa, fb) in a.iter().zip(&b).take(n) {
        let d: Vec<f64> = fa.iter().zip(fb).map(|(x, y)| y - x).collect();
        means.push(d.iter().sum::<f64>() / d.len() as f64);
        for (i, v) in d.iter().enumerate() {
            match dist(i) {
                r if r <= 0.1 => (near, near_n) = (near + v, near_n + 1),
                r if r >= 0.5 => (far, far_n) = (far + v, far_n + 1),
                _ => {}
            }
        }
        big += d.iter().filter(|v| v.abs() >= 40.0).count();
        let (ha, hb) = (high_pass(fa, w, h), high_pass(fb, w, h));
        detail += ha
            .iter()
            .zip(&hb)
            .filter(|(x, y)| (*y - *x).abs() >= 3.0)
            .count();
    }
    let mean = means.iter().sum::<f64>() / n as f64;
    let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / n as f64;
    let px = (n * w * h) as f64;
    Look {
        mean_change: mean,
        pumping: var.sqrt(),
        big_share: big as f64 / px,
        detail_share: detail as f64 / px,
        glow_contrast: (near / near_n.max(1) as f64) / (far / far_n.max(1) as f64).max(1e-3),
    }
}

/// Renders `frames` frames of `input` losslessly at `rate_mm_per_h` with `args`.
fn render(input: &Path, out: &Path, rate_mm_per_h: f64, frames: usize, args: &[&str]) {
    ok(bin()
        .arg(input)
        .arg("-o")
        .arg(out)
        .args([
            "--codec",
            "ffv1",
            "-y",
            "--rain",
            &rate_mm_per_h.to_string(),
        ])
        .args(["--frames", &format!("0..{frames}")])
        .args(args));
}

/// A night street with a lamp: road 0.03 and sky 0.01 (linear), a lamp of radius 4 px above the
/// road, 2 s at 25 fps, 320×180 (as a camera exposed for the road would show it).
fn night_lamp(dir: &Path) -> PathBuf {
    let (w, h) = (320u32, 180u32);
    let srgb = |v: f64| {
        let s = if v <= 0.003_130_8 {
            12.92 * v
        } else {
            1.055 * v.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0).round() as u8
    };
    let img = image::RgbImage::from_fn(w, h, |x, y| {
        let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
        let v = if (fx - 200.0).hypot(fy - 50.0) <= 4.0 {
            1.0
        } else if fy > 0.5 * h as f64 {
            0.03
        } else {
            0.01
        };
        image::Rgb([srgb(v); 3])
    });
    let png = dir.join("night.png");
    img.save(&png).unwrap();
    let clip = dir.join("night.mp4");
    ffmpeg(&[
        "-loop",
        "1",
        "-framerate",
        "25",
        "-i",
        png.to_str().unwrap(),
        "-t",
        "2",
        "-c:v",
        "libx264",
        "-crf",
        "16",
        "-pix_fmt",
        "yuv420p",
        "-colorspace",
        "bt709",
        "-color_primaries",
        "bt709",
        "-color_trc",
        "iec61966-2-1",
        clip.to_str().unwrap(),
    ]);
    clip
}

const FRAMES: usize = 25;

/// Each clip at the defaults (10 mm/h) and at 20 mm/h; `light` where the sun or a lamp is in
/// shot: there the rain toward it glows (forward scattering), which lifts the frame's mean and
/// the pixels near it by more than the limits, so the check is that the change is a glow
/// around the light, at least twice as strong near it as half a frame away, not a veil.
#[test]
fn rain_looks_like_rain_on_footage_nobody_tuned_for() {
    if shared_gpu::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let night = night_lamp(dir.path());
    let clips: Vec<(&str, PathBuf, Vec<&str>, bool)> = vec![
        // (name, clip, arguments, a light in shot)
        ("daylight", sample("daylight.mp4"), vec![], false),
        ("aerial", sample("aerial.mp4"), vec![], false),
        ("street", sample("street.mp4"), vec![], false),
        ("city", sample("city.mp4"), vec![], false),
        ("sunset", sample("sunset.mp4"), vec!["--tilt", "11.3"], true),
        ("night lamp", night, vec![], true),
    ];
    let mut failures = Vec::new();
    for (name, input, args, light) in &clips {
        let out = dir.path().join(format!("{}.mkv", name.replace(' ', "_")));
        render(input, &out, 10.0, FRAMES, args);
        let at10 = look(input, &out, FRAMES);
        render(input, &out, 20.0, FRAMES, args);
        let at20 = look(input, &out, FRAMES);
        eprintln!("{name}: 10 mm/h {at10:?}; 20 mm/h {at20:?}");
        if *light {
            if at10.glow_contrast < 2.0 {
                failures.push(format!(
                    "{name}: a veil, not a glow: {:.2} times the change near the light",
                    at10.glow_contrast
                ));
            }
        } else if at10.mean_change.abs() > 6.0 {
            failures.push(format!("{name}: mean change {:.2} codes", at10.mean_change));
        }
        if !light && at10.big_share > 0.005 {
            failures.push(format!(
                "{name}: {:.2} % of pixels changed by 40 codes or more",
                100.0 * at10.big_share
            ));
        }
        if at10.pumping > 1.0 {
            failures.push(format!(
                "{name}: the mean pumps by {:.2} codes",
                at10.pumping
            ));
        }
        if at20.detail_share < 0.005 {
            failures.push(format!(
                "{name}: at 20 mm/h only {:.2} % of the high-pass changed",
                100.0 * at20.detail_share
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
