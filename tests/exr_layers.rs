//! The rain as an OpenEXR layer, end to end through the binary, read back by readers that share
//! no code with the writer (FFmpeg's EXR decoder for the pixels, OpenImageIO for the header and
//! the pixels again): the scene-linear layer over the linearised plate, re-encoded with the
//! input's transfer, is the normal render at the defaults, the recovered lamps' glow above white
//! included, where a 16-bit layer clips it; the header carries the input's primaries; images are
//! numbered by source frame; a bad output fails on one line and leaves nothing.
//!
//! OpenImageIO is Debian's `python3-openimageio` (with `python3-numpy`), run by Debian's own
//! `/usr/bin/python3` (`.ci/install-deps` installs both).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use rain_composite::gpu::cpu::rgb_to_yuv::rgb_to_yuv;
use rain_composite::video::YuvFrame;
use rain_composite::video::color::eotf_signed;
use tempfile::TempDir;

#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::{decoded_frames, files_in, lossless_clip};

#[path = "common/binary.rs"]
mod binary;
use binary::bin;

/// Debian's Python, where `python3-openimageio` installs (a `python3` earlier on the `PATH`,
/// such as a pyenv shim, does not see it).
const PYTHON: &str = "/usr/bin/python3";

/// BT.709's primaries and D65 as CIE xy (ITU-R BT.709-6, table 1, items 1.3 and 1.4), in
/// OpenEXR's order: red, green, blue, white.
const BT709_XY: [f32; 8] = [0.640, 0.330, 0.300, 0.600, 0.150, 0.060, 0.3127, 0.3290];

/// BT.2020's (ITU-R BT.2020-2, table 3).
const BT2020_XY: [f32; 8] = [0.708, 0.292, 0.170, 0.797, 0.131, 0.046, 0.3127, 0.3290];

/// SMPTE 170M's (SMPTE ST 170:2004, §3.3).
const SMPTE170M_XY: [f32; 8] = [0.630, 0.340, 0.310, 0.595, 0.155, 0.070, 0.3127, 0.3290];

fn render(input: &Path, output: &Path, extra: &[&str]) -> Output {
    bin()
        .arg(input)
        .arg("-o")
        .arg(output)
        .args(extra)
        .arg("-q")
        .output()
        .expect("spawn")
}

fn render_ok(input: &Path, output: &Path, extra: &[&str]) {
    let out = render(input, output, extra);
    assert!(
        out.status.success(),
        "render to {} failed:\n{}",
        output.display(),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The images of a sequence in `dir` whose names start with `prefix`, in name order.
fn images(dir: &Path, prefix: &str, ext: &str) -> Vec<PathBuf> {
    files_in(dir)
        .into_iter()
        .filter(|n| n.starts_with(prefix) && n.ends_with(ext))
        .map(|n| dir.join(n))
        .collect()
}

/// An EXR's pixels as FFmpeg's EXR decoder reads them: R, G, B, A per pixel, 32-bit floats.
fn ffmpeg_exr(path: &Path) -> Vec<[f32; 4]> {
    let out = Command::new("ffmpeg")
        .args(["-v", "error", "-i"])
        .arg(path)
        .args(["-f", "rawvideo", "-pix_fmt", "gbrapf32le", "-"])
        .output()
        .expect("ffmpeg");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let floats: Vec<f32> = out
        .stdout
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    // Planar G, B, R, A.
    let n = floats.len() / 4;
    (0..n)
        .map(|i| {
            [
                floats[2 * n + i],
                floats[i],
                floats[n + i],
                floats[3 * n + i],
            ]
        })
        .collect()
}

/// What OpenImageIO (OpenEXR's own library underneath) reads in an EXR.
struct OiioRead {
    /// The pixels' storage type (`"half"`).
    format: String,
    channels: Vec<String>,
    /// The `chromaticities` attribute, if any.
    chromaticities: Option<Vec<f32>>,
    /// R, G, B, A per pixel.
    pixels: Vec<[f32; 4]>,
}

fn oiio_exr(path: &Path) -> OiioRead {
    const SCRIPT: &str = r#"
import json, sys
import OpenImageIO as oiio
i = oiio.ImageInput.open(sys.argv[1])
s = i.spec()
c = s.getattribute("chromaticities")
px = i.read_image(oiio.FLOAT)
print(json.dumps({
    "format": str(s.format),
    "channels": list(s.channelnames),
    "chromaticities": None if c is None else list(c),
    "pixels": px.reshape(-1).tolist(),
}))
"#;
    let out = Command::new(PYTHON)
        .args(["-c", SCRIPT])
        .arg(path)
        .output()
        .expect("Debian's python3 (install with .ci/install-deps)");
    assert!(
        out.status.success(),
        "OpenImageIO could not read {}: {} (python3-openimageio and python3-numpy are \
         installed by .ci/install-deps)",
        path.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    let floats = |v: &serde_json::Value| -> Vec<f32> {
        v.as_array()
            .expect("array")
            .iter()
            .map(|x| x.as_f64().expect("number") as f32)
            .collect()
    };
    OiioRead {
        format: v["format"].as_str().unwrap_or_default().to_owned(),
        channels: v["channels"]
            .as_array()
            .expect("channels")
            .iter()
            .map(|c| c.as_str().unwrap_or_default().to_owned())
            .collect(),
        chromaticities: (!v["chromaticities"].is_null()).then(|| floats(&v["chromaticities"])),
        pixels: floats(&v["pixels"])
            .chunks_exact(4)
            .map(|p| [p[0], p[1], p[2], p[3]])
            .collect(),
    }
}

/// A 16-bit PNG layer's samples (the `image` crate).
fn png_layer(path: &Path) -> Vec<u16> {
    image::open(path).expect("png").into_rgba16().into_raw()
}

/// `frame`'s pixels as the plate: linear RGB through the frame's own matrix, range and
/// transfer, chroma from the co-sited sample (as the render decodes it).
fn plate(frame: &YuvFrame) -> Vec<[f64; 3]> {
    let f = frame.format;
    let (sx, sy) = f.chroma.shift();
    (0..f.height)
        .flat_map(|y| (0..f.width).map(move |x| (x, y)))
        .map(|(x, y)| {
            frame.color.code_to_linear([
                f64::from(frame.sample(0, x, y)),
                f64::from(frame.sample(1, x >> sx, y >> sy)),
                f64::from(frame.sample(2, x >> sx, y >> sy)),
            ])
        })
        .collect()
}

/// `layer + (1 − α) · plate` in linear light (`layer` premultiplied linear RGBA), coded as the
/// render codes its canvas.
fn over(frame: &YuvFrame, layer: &[[f64; 4]]) -> [Vec<u16>; 3] {
    let canvas: Vec<[f64; 3]> = plate(frame)
        .iter()
        .zip(layer)
        .map(|(bg, l)| std::array::from_fn(|k| l[k] + bg[k] * (1.0 - l[3])))
        .collect();
    rgb_to_yuv(&canvas, frame.format, &frame.color)
}

/// A 16-bit premultiplied PNG layer as linear RGBA (colour decoded with the video's transfer).
fn png_linear(frame: &YuvFrame, samples: &[u16]) -> Vec<[f64; 4]> {
    samples
        .chunks_exact(4)
        .map(|p| {
            let c = |v: u16| eotf_signed(frame.color.transfer, f64::from(v) / 65535.0);
            [c(p[0]), c(p[1]), c(p[2]), f64::from(p[3]) / 65535.0]
        })
        .collect()
}

/// How far a composite's code values are from the render's.
#[derive(Debug, Default, Clone, Copy)]
struct Agreement {
    samples: usize,
    exact: usize,
    within_one: usize,
    worst: u16,
    squared_error: f64,
    /// Largest code value.
    peak: f64,
}

impl Agreement {
    fn add(&mut self, expected: &[Vec<u16>; 3], frame: &YuvFrame) {
        let f = frame.format;
        self.peak = f64::from((1u32 << f.bit_depth) - 1);
        for (i, plane) in expected.iter().enumerate() {
            let (w, _) = f.plane_size(i);
            for (n, &e) in plane.iter().enumerate() {
                let got = frame.sample(i, n as u32 % w, n as u32 / w);
                let d = got.abs_diff(e);
                self.samples += 1;
                self.exact += usize::from(d == 0);
                self.within_one += usize::from(d <= 1);
                self.worst = self.worst.max(d);
                self.squared_error += f64::from(d) * f64::from(d);
            }
        }
    }

    /// PSNR over every sample of the three planes (infinite when equal).
    fn psnr_db(&self) -> f64 {
        let mse = self.squared_error / self.samples as f64;
        10.0 * (self.peak * self.peak / mse).log10()
    }

    fn report(&self) -> String {
        let pct = |n: usize| 100.0 * n as f64 / self.samples as f64;
        format!(
            "{:.3} % exact, {:.4} % within one code, worst {}, PSNR {:.1} dB ({} samples)",
            pct(self.exact),
            pct(self.within_one),
            self.worst,
            self.psnr_db(),
            self.samples
        )
    }
}

/// The normal render and the EXR and 16-bit PNG layers of `input` with `look`, each layer laid
/// over the plate: how close each comes to the render, and the EXR layers as FFmpeg read them.
fn compare(input: &Path, dir: &Path, look: &[&str]) -> (Agreement, Agreement, Vec<Vec<[f32; 4]>>) {
    let normal = dir.join("normal.mkv");
    let with =
        |extra: &[&'static str]| -> Vec<&str> { extra.iter().chain(look).copied().collect() };
    render_ok(input, &normal, &with(&["--codec", "ffv1"]));
    render_ok(input, &dir.join("rain_%05d.exr"), &with(&["--layer-only"]));
    render_ok(input, &dir.join("rain_%05d.png"), &with(&["--layer-only"]));
    let originals = decoded_frames(input);
    let rendered = decoded_frames(&normal);
    let exrs = images(dir, "rain_", ".exr");
    let pngs = images(dir, "rain_", ".png");
    assert_eq!(exrs.len(), originals.len(), "one EXR a frame");
    assert_eq!(pngs.len(), originals.len(), "one PNG a frame");
    let (mut exr_fit, mut png_fit) = (Agreement::default(), Agreement::default());
    let mut layers = Vec::new();
    for (((frame, out), exr), png) in originals.iter().zip(&rendered).zip(&exrs).zip(&pngs) {
        let layer = ffmpeg_exr(exr);
        let linear: Vec<[f64; 4]> = layer.iter().map(|p| p.map(f64::from)).collect();
        exr_fit.add(&over(frame, &linear), out);
        png_fit.add(&over(frame, &png_linear(frame, &png_layer(png))), out);
        layers.push(layer);
    }
    (exr_fit, png_fit, layers)
}

/// At the defaults with a lamp in view ([`LAMP`]): the EXR layer over the
/// plate is the render within one code value, where the 16-bit layer misses the glow above
/// white; the glow is there as values above 1; OpenImageIO reads the same half-float R, G, B, A
/// as FFmpeg, and BT.709 chromaticities.
///
/// 8-bit, every sample is within one code. 10-bit, a few samples of bright streaks over the
/// glow (5 of 1.4 million) are two codes off: the same samples with the 16-bit layer, so the
/// render's own arithmetic (its canvas is half floats too), not the layer's format.
/// A lamp just above the view's centre, 10⁵ times the frame's white (a street lamp at night is
/// 10³–10⁵): its glow in the haze is brighter than white, which a 16-bit layer cannot hold.
/// (testsrc2's colour bars clip one or two channels, so they are surfaces, not a sun.)
const LAMP: &str = "0,5,100000,100000,100000";

#[test]
fn exr_layer_over_the_plate_is_the_render_glow_included() {
    for (pix_fmt, within_one) in [("yuv420p", 1.0), ("yuv422p10le", 0.99999)] {
        let dir = TempDir::new().unwrap();
        let input = lossless_clip(dir.path(), "640x360", pix_fmt, "bt709");
        let (exr, png, layers) = compare(&input, dir.path(), &["--light", LAMP, "--sky", "off"]);
        eprintln!("{pix_fmt} EXR layer over the plate: {}", exr.report());
        eprintln!(
            "{pix_fmt} 16-bit PNG layer over the plate: {}",
            png.report()
        );
        assert!(
            exr.within_one as f64 >= within_one * exr.samples as f64 && exr.worst <= 2,
            "{pix_fmt}: {}",
            exr.report()
        );
        assert!(
            png.worst > exr.worst && png.within_one < exr.within_one,
            "{pix_fmt}: the test needs light above white, which the 16-bit layer clips \
             (PNG: {}; EXR: {})",
            png.report(),
            exr.report()
        );
        let bright = layers
            .iter()
            .flatten()
            .filter(|p| p[..3].iter().any(|&c| c > 1.0))
            .count();
        assert!(bright > 0, "{pix_fmt}: no colour above 1.0 in the layer");
        let covered = layers.iter().flatten().filter(|p| p[3] > 0.0).count();
        assert_eq!(
            covered,
            layers.iter().map(Vec::len).sum::<usize>(),
            "{pix_fmt}: the haze veils every pixel (no open sky), so every pixel has alpha"
        );

        let first = images(dir.path(), "rain_", ".exr").remove(0);
        let read = oiio_exr(&first);
        assert_eq!(read.format, "half");
        assert_eq!(read.channels, ["R", "G", "B", "A"]);
        assert_eq!(read.chromaticities.as_deref(), Some(&BT709_XY[..]));
        assert_eq!(
            read.pixels, layers[0],
            "OpenImageIO and FFmpeg read the same pixels"
        );
    }
}

/// Heavy rain thickens the haze, and the glow of a lamp in view ([`LAMP`]) passes
/// white over much of the picture: the 16-bit layer clips it far from the render, the EXR layer
/// over the plate stays within one code value.
#[test]
fn exr_layer_keeps_a_glow_far_above_white() {
    let dir = TempDir::new().unwrap();
    let input = lossless_clip(dir.path(), "320x240", "yuv420p", "bt709");
    let (exr, png, layers) = compare(
        &input,
        dir.path(),
        &["--rain", "60", "--seed", "7", "--light", LAMP],
    );
    eprintln!("60 mm/h, EXR layer over the plate: {}", exr.report());
    eprintln!("60 mm/h, 16-bit PNG layer over the plate: {}", png.report());
    assert_eq!(exr.within_one, exr.samples, "{}", exr.report());
    assert!(png.psnr_db() < 45.0, "{}", png.report());
    let pixels: usize = layers.iter().map(Vec::len).sum();
    let above = layers
        .iter()
        .flatten()
        .filter(|p| p[..3].iter().any(|&c| c > 1.0))
        .count();
    assert!(above * 10 > pixels, "{above} of {pixels} pixels above 1.0");
}

/// The wet ground is in the EXR layer too (its darkening as alpha, its tint and sheen as
/// colour): over the plate it is the render.
#[test]
fn exr_layer_carries_the_wet_ground() {
    let dir = TempDir::new().unwrap();
    let input = lossless_clip(dir.path(), "96x64", "yuv420p", "bt709");
    let ground = ["--ground", "horizon=0.3", "--pre-rain", "30"];
    let (exr, png, _) = compare(&input, dir.path(), &ground);
    eprintln!("wet ground, EXR layer over the plate: {}", exr.report());
    eprintln!(
        "wet ground, 16-bit PNG layer over the plate: {}",
        png.report()
    );
    assert_eq!(exr.within_one, exr.samples, "{}", exr.report());
}

/// The header's chromaticities are the input's primaries; untagged primaries are BT.709's.
#[test]
fn exr_header_holds_the_inputs_primaries() {
    let dir = TempDir::new().unwrap();
    for (primaries, expected) in [
        ("bt2020", BT2020_XY),
        ("smpte170m", SMPTE170M_XY),
        ("unknown", BT709_XY),
    ] {
        let input = lossless_clip(dir.path(), "96x64", "yuv420p", primaries);
        let prefix = format!("p_{primaries}_");
        render_ok(
            &input,
            &dir.path().join(format!("{prefix}%03d.exr")),
            &["--layer-only", "--frames", "0..1"],
        );
        let read = oiio_exr(&dir.path().join(format!("{prefix}001.exr")));
        assert_eq!(
            read.chromaticities.as_deref(),
            Some(&expected[..]),
            "{primaries}"
        );
    }
}

/// Images are numbered by source frame, as PNG sequences are (frame N is image N + 1): the
/// chunks of a shot write their own images of one sequence.
#[test]
fn exr_images_are_numbered_by_source_frame() {
    let dir = TempDir::new().unwrap();
    let input = lossless_clip(dir.path(), "96x64", "yuv420p", "bt709");
    let seq = dir.path().join("seq");
    std::fs::create_dir(&seq).unwrap();
    let pattern = seq.join("c_%04d.exr");
    render_ok(&input, &pattern, &["--layer-only", "--frames", "1..3"]);
    assert_eq!(files_in(&seq), ["c_0002.exr", "c_0003.exr"]);
    render_ok(&input, &pattern, &["--layer-only", "--frames", "0..1"]);
    assert_eq!(files_in(&seq), ["c_0001.exr", "c_0002.exr", "c_0003.exr"]);
}

/// Outputs an EXR sequence cannot be: each refused on one line, with a non-zero exit, and
/// nothing left behind (no image, no hidden directory).
#[test]
fn bad_exr_outputs_fail_cleanly() {
    let dir = TempDir::new().unwrap();
    let input = lossless_clip(dir.path(), "96x64", "yuv420p", "bt709");
    let out_dir = dir.path().join("out");
    std::fs::create_dir(&out_dir).unwrap();
    // A folder that is a file: no image can be written in it, not even by root.
    let not_a_dir = out_dir.join("plain-file");
    std::fs::write(&not_a_dir, b"x").unwrap();
    let existing = out_dir.join("e_00001.exr");
    std::fs::write(&existing, b"kept").unwrap();
    let cases: [(PathBuf, &[&str], &str); 9] = [
        (
            out_dir.join("rain.exr"),
            &["--layer-only"],
            "frame number pattern, e.g. out_%05d.exr",
        ),
        (
            not_a_dir.join("rain_%05d.exr"),
            &["--layer-only"],
            "does not exist",
        ),
        (
            out_dir.join("missing/rain_%05d.exr"),
            &["--layer-only"],
            "does not exist",
        ),
        (
            out_dir.join("wide_%020d.exr"),
            &["--layer-only"],
            "at most 19 digits",
        ),
        (
            out_dir.join("e_%05d.exr"),
            &["--layer-only"],
            "already exists",
        ),
        (
            out_dir.join("s_%05d.exr"),
            &["--layer-only", "--alpha", "straight"],
            "--alpha",
        ),
        (
            out_dir.join("m_%05d.exr"),
            &["--matte"],
            "OpenEXR sequence holds the layer",
        ),
        (
            out_dir.join("c_%05d.exr"),
            &["--layer-only", "--codec", "ffv1"],
            "leave --codec out",
        ),
        (
            out_dir.join("v_%05d.exr"),
            &[],
            "image sequences are written for --layer-only",
        ),
    ];
    for (output, flags, says) in cases {
        let out = render(&input, &output, flags);
        let err = String::from_utf8_lossy(&out.stderr);
        let name = output.display();
        assert!(!out.status.success(), "{name} {flags:?} was accepted");
        assert_eq!(err.lines().count(), 1, "{name}: one line: {err}");
        assert!(
            err.starts_with("error:") && err.contains(says),
            "{name}: {err}"
        );
    }
    assert_eq!(files_in(&out_dir), ["e_00001.exr", "plain-file"]);
    assert_eq!(std::fs::read(&existing).unwrap(), b"kept");
}

/// The numbers of `docs/measurements.md` ("Rain as a layer"): the 16-bit PNG and the EXR layer
/// over the plate against the render. `RAIN_COMPOSITE_MEASURE_CLIP` names a sample clip
/// (`city`, the default) or `testsrc2:WxH`; `RAIN_COMPOSITE_MEASURE_FROM` the start in seconds
/// (0), `RAIN_COMPOSITE_MEASURE_FRAMES` the frames (10), `RAIN_COMPOSITE_MEASURE_ARGS` the
/// render's flags (none: the defaults).
/// `cargo test --release --test exr_layers -- --ignored --nocapture`
#[test]
#[ignore = "a measurement: seconds a frame on lavapipe"]
fn measure_layers() {
    let var = |name: &str, default: &str| std::env::var(name).unwrap_or_else(|_| default.into());
    let name = var("RAIN_COMPOSITE_MEASURE_CLIP", "city");
    let from = var("RAIN_COMPOSITE_MEASURE_FROM", "0");
    let count = var("RAIN_COMPOSITE_MEASURE_FRAMES", "10");
    let args = var("RAIN_COMPOSITE_MEASURE_ARGS", "");
    let look: Vec<&str> = args.split_whitespace().collect();
    let dir = TempDir::new().unwrap();
    let input = match name.strip_prefix("testsrc2:") {
        Some(size) => lossless_clip(dir.path(), size, "yuv420p", "bt709"),
        None => {
            let clip = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("samples/{name}.mp4"));
            let input = dir.path().join("clip.mkv");
            // The frames losslessly (tags kept): the plate is exactly what the render decodes.
            fixtures::ffmpeg(&[
                "-ss",
                &from,
                "-i",
                fixtures::s(&clip),
                "-frames:v",
                &count,
                "-an",
                "-c:v",
                "ffv1",
                fixtures::s(&input),
            ]);
            input
        }
    };
    let (exr, png, layers) = compare(&input, dir.path(), &look);
    let brightest = layers
        .iter()
        .flatten()
        .flat_map(|p| p[..3].iter().copied())
        .fold(0f32, f32::max);
    let above_white = layers
        .iter()
        .flatten()
        .filter(|p| p[..3].iter().any(|&c| c > 1.0))
        .count();
    let pixels: usize = layers.iter().map(Vec::len).sum();
    let what = format!("{name} from {from} s, {} frames, '{args}'", layers.len());
    println!("{what}, 16-bit PNG layer over the plate: {}", png.report());
    println!("{what}, EXR layer over the plate: {}", exr.report());
    println!("brightest EXR colour {brightest}; {above_white} of {pixels} pixels above 1.0");
}
