//! The rain as a layer, end to end through the binary: the layer over the original frame, with
//! the over operation in linear light (written here from its definition, not from the
//! renderer), gives back the normal render; the matte is the layer's alpha; the black variant
//! is the layer over black; outputs that cannot hold the layer are refused before any work.

use std::path::Path;
use std::process::{Command, Output};

use rain_composite::gpu::cpu::rgb_to_yuv::rgb_to_yuv;
use rain_composite::video::YuvFrame;
use rain_composite::video::color::eotf_signed;
use tempfile::TempDir;

#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::{decoded_frames, files_in, lossless_clip, stream};

#[path = "common/binary.rs"]
mod binary;
use binary::bin;

/// Heavy rain, so that many pixels are covered; the haze is on by default, so every pixel has
/// some alpha too.
/// The colour bars' clipped light stays at the clip level (`--highlight-gain 1`): recovered, they
/// would be lamps hundreds of times white whose glow in the haze is brighter than white, which
/// a premultiplied layer cannot hold (its colour would exceed its alpha).
const RAIN: [&str; 6] = ["--rain", "60", "--seed", "7", "--highlight-gain", "1"];

fn render(input: &Path, output: &Path, extra: &[&str]) -> Output {
    bin()
        .arg(input)
        .arg("-o")
        .arg(output)
        .args(RAIN)
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

/// A layer's R'G'B'A samples, 16 bits, frame by frame, whatever it was written as.
fn layer_samples(path: &Path, w: u32, h: u32) -> Vec<Vec<u16>> {
    let out = Command::new("ffmpeg")
        .args(["-v", "error", "-i"])
        .arg(path)
        .args(["-f", "rawvideo", "-pix_fmt", "rgba64le", "-"])
        .output()
        .expect("ffmpeg");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let per_frame = (w * h * 8) as usize;
    assert_eq!(out.stdout.len() % per_frame, 0);
    out.stdout
        .chunks_exact(per_frame)
        .map(|f| {
            f.chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]))
                .collect()
        })
        .collect()
}

/// A PNG sequence's samples in file order (the `image` crate, independently of FFmpeg).
fn png_samples(dir: &Path, prefix: &str) -> Vec<Vec<u16>> {
    files_in(dir)
        .iter()
        .filter(|n| n.starts_with(prefix) && n.ends_with(".png"))
        .map(|n| {
            image::open(dir.join(n))
                .expect("png")
                .into_rgba16()
                .into_raw()
        })
        .collect()
}

/// `layer` over `frame` in linear light — `premultiplied + background · (1 − α)`, colour
/// decoded with the video's transfer (`straight`: times α first) — then coded as the render
/// codes its canvas.
fn over(frame: &YuvFrame, layer: &[u16], straight: bool) -> [Vec<u16>; 3] {
    let f = frame.format;
    let (sx, sy) = f.chroma.shift();
    let color = frame.color;
    let canvas: Vec<[f64; 3]> = (0..f.height)
        .flat_map(|y| (0..f.width).map(move |x| (x, y)))
        .map(|(x, y)| {
            let code = [
                frame.sample(0, x, y) as f64,
                frame.sample(1, x >> sx, y >> sy) as f64,
                frame.sample(2, x >> sx, y >> sy) as f64,
            ];
            let background = color.code_to_linear(code);
            let p = &layer[4 * (y * f.width + x) as usize..][..4];
            let alpha = p[3] as f64 / 65535.0;
            std::array::from_fn(|k| {
                let c = eotf_signed(color.transfer, p[k] as f64 / 65535.0);
                let premultiplied = if straight { c * alpha } else { c };
                premultiplied + background[k] * (1.0 - alpha)
            })
        })
        .collect();
    rgb_to_yuv(&canvas, f, &color)
}

/// The largest code difference between `expected` planes and `frame`'s, and how many samples
/// differ at all; samples that draw on a pixel where `skip` is true are left out.
fn max_diff(expected: &[Vec<u16>; 3], frame: &YuvFrame, skip: &[bool]) -> (u16, usize) {
    let mut worst = 0;
    let mut differ = 0;
    let f = frame.format;
    for (i, plane) in expected.iter().enumerate() {
        let (w, _) = f.plane_size(i);
        let (sx, sy) = if i == 0 { (0, 0) } else { f.chroma.shift() };
        for (n, &e) in plane.iter().enumerate() {
            let (x, y) = (n as u32 % w, n as u32 / w);
            let skipped = (y << sy..((y + 1) << sy).min(f.height)).any(|py| {
                (x << sx..((x + 1) << sx).min(f.width)).any(|px| skip[(py * f.width + px) as usize])
            });
            if skipped {
                continue;
            }
            let got = frame.sample(i, x, y);
            let d = got.abs_diff(e);
            worst = worst.max(d);
            differ += usize::from(d > 0);
        }
    }
    (worst, differ)
}

/// The pixels of a premultiplied `layer` whose colour exceeds their alpha (light added beyond
/// what covers the background, e.g. a drop brighter than the frame's white): straight colour
/// = premultiplied / α is then above 1, which no straight R'G'B'A sample holds.
fn superluminous(layer: &[u16], frame: &YuvFrame) -> Vec<bool> {
    layer
        .chunks_exact(4)
        .map(|p| {
            let alpha = p[3] as f64 / 65535.0;
            p[..3]
                .iter()
                .any(|&c| eotf_signed(frame.color.transfer, c as f64 / 65535.0) > alpha)
        })
        .collect()
}

/// The pixels of a premultiplied `layer` whose colour reached the format's largest code: light
/// beyond the frame's white that the render keeps until its own final clip (a saturated colour
/// under water, its channels darkened unequally, plus the water's reflection) but an integer
/// layer cannot hold.
fn saturated(layer: &[u16]) -> Vec<bool> {
    layer
        .chunks_exact(4)
        .map(|p| p[..3].contains(&u16::MAX))
        .collect()
}

/// Pixels of `layer` whose alpha is above 1 %, of all.
fn covered_fraction(layer: &[u16]) -> f64 {
    let n = layer.len() / 4;
    layer.chunks_exact(4).filter(|p| p[3] > 655).count() as f64 / n as f64
}

/// Renders `pix_fmt` with `look` normally and as layers; each layer over the original must be
/// the normal render. Returns the premultiplied layers.
fn round_trip(pix_fmt: &str, look: &[&str]) -> Vec<Vec<u16>> {
    let dir = TempDir::new().unwrap();
    let input = lossless_clip(dir.path(), "96x64", pix_fmt, "bt709");
    let with = |args: &[&'static str]| -> Vec<&str> { args.iter().chain(look).copied().collect() };
    let normal = dir.path().join("normal.mkv");
    render_ok(&input, &normal, &with(&["--codec", "ffv1"]));
    let premult_mkv = dir.path().join("premult.mkv");
    render_ok(&input, &premult_mkv, &with(&["--layer-only"]));
    let straight_png = dir.path().join("straight_%05d.png");
    render_ok(
        &input,
        &straight_png,
        &with(&["--layer-only=alpha", "--alpha", "straight"]),
    );
    let premult_png = dir.path().join("premult_%05d.png");
    render_ok(&input, &premult_png, &with(&["--layer-only"]));

    let originals = decoded_frames(&input);
    let rendered = decoded_frames(&normal);
    let (w, h) = (originals[0].format.width, originals[0].format.height);
    let layers = [
        (
            "premultiplied FFV1",
            layer_samples(&premult_mkv, w, h),
            false,
        ),
        (
            "premultiplied PNG",
            png_samples(dir.path(), "premult_"),
            false,
        ),
        ("straight PNG", png_samples(dir.path(), "straight_"), true),
    ];
    for (name, layer, straight) in &layers {
        assert_eq!(layer.len(), originals.len(), "{name}: frame count");
        for (((frame, out), l), premultiplied) in
            originals.iter().zip(&rendered).zip(layer).zip(&layers[0].1)
        {
            let skip = if *straight {
                superluminous(premultiplied, frame)
            } else {
                saturated(premultiplied)
            };
            let skipped = skip.iter().filter(|&&s| s).count();
            assert!(
                skipped * 4 < skip.len(),
                "{name}: {skipped} of {} pixels superluminous",
                skip.len()
            );
            assert!(
                covered_fraction(l) > 0.01,
                "{name}: the test needs rain ({:.3} covered)",
                covered_fraction(l)
            );
            let (worst, differ) = max_diff(&over(frame, l, *straight), out, &skip);
            // The canvas is f16 (11 bits of mantissa): near white a value carries 2^-11, about
            // half a code at 10 bits. The render blends each streak over the plate, the layer
            // over black and `over` here in f64, so where several streaks overlap the two
            // roundings part by up to two 10-bit codes; an 8-bit code is four times coarser.
            let tolerance = if frame.format.bit_depth > 8 { 2 } else { 1 };
            assert!(
                worst <= tolerance,
                "{pix_fmt} {name}, frame {}: off by {worst} code values ({differ} samples \
                 differ; {skipped} superluminous pixels left out)",
                frame.index
            );
        }
    }
    // The PNG (read by `image`) and the FFV1 layer (read by FFmpeg) hold the same samples.
    assert_eq!(layers[0].1, layers[1].1);
    layers.into_iter().next().map(|l| l.1).unwrap_or_default()
}

#[test]
fn layer_over_the_original_is_the_render_8_bit() {
    round_trip("yuv420p", &[]);
}

#[test]
fn layer_over_the_original_is_the_render_10_bit() {
    round_trip("yuv422p10le", &[]);
}

/// Puddles are in the layer too: the water over the wet ground, its reflection of the picture
/// (rain included), and the layer over the original is the render, 8-bit.
#[test]
fn the_layer_carries_the_puddles() {
    let puddles = [
        "--ground",
        "horizon=0.3",
        "--pre-rain",
        "600",
        "--puddles",
        "--puddle-particles",
        "1500",
        "--relief",
        "0.01",
    ];
    round_trip("yuv420p", &puddles);
}

/// A wet ground is in the layer: its darkening as alpha, its tint and sheen as colour, and the
/// layer over the original is still the render, 8- and 10-bit.
#[test]
fn the_layer_carries_the_wet_ground() {
    // The mask would keep testsrc2's bars dry: this checks the layer, not where the ground is.
    let ground = [
        "--ground",
        "horizon=0.3",
        "--pre-rain",
        "30",
        "--ground-mask",
        "off",
    ];
    for pix_fmt in ["yuv420p", "yuv422p10le"] {
        let layers = round_trip(pix_fmt, &ground);
        // 96×64: rows from 0.3 of the height down show the ground; all of it is wet.
        let (w, top) = (96usize, 24usize);
        for layer in &layers {
            let wet = layer[4 * w * top..]
                .chunks(4)
                .filter(|px| px[3] > 1000)
                .count();
            let ground_px = layer.len() / 4 - w * top;
            assert!(
                wet * 10 > ground_px * 9,
                "{pix_fmt}: {wet} of {ground_px} wet"
            );
        }
    }
}

#[test]
fn matte_is_the_alpha_and_black_is_the_layer_over_black() {
    let dir = TempDir::new().unwrap();
    let input = lossless_clip(dir.path(), "96x64", "yuv420p10le", "bt709");
    let layer_path = dir.path().join("layer.mkv");
    render_ok(&input, &layer_path, &["--layer-only"]);
    let matte_path = dir.path().join("matte.mkv");
    render_ok(&input, &matte_path, &["--matte"]);
    let black_path = dir.path().join("black.mkv");
    render_ok(
        &input,
        &black_path,
        &["--layer-only=black", "--codec", "ffv1"],
    );

    let originals = decoded_frames(&input);
    let (w, h) = (originals[0].format.width, originals[0].format.height);
    let layer = layer_samples(&layer_path, w, h);
    let matte = layer_samples(&matte_path, w, h);
    assert_eq!(stream(&matte_path, "v:0")["pix_fmt"], "gray16le");
    for (l, m) in layer.iter().zip(&matte) {
        for (lp, mp) in l.chunks_exact(4).zip(m.chunks_exact(4)) {
            assert_eq!(
                [mp[0], mp[1], mp[2]],
                [lp[3]; 3],
                "matte grey = layer alpha"
            );
        }
    }

    // Over black: a black frame of the same layout as background.
    let black = decoded_frames(&black_path);
    assert_eq!(black.len(), originals.len());
    for ((frame, l), out) in originals.iter().zip(&layer).zip(&black) {
        let mut dark = frame.clone();
        let s = frame.color.range_scale();
        for (i, plane) in dark.planes.iter_mut().enumerate() {
            let code = if i == 0 { s.y_offset } else { s.c_offset } as u16;
            for px in plane.data.chunks_exact_mut(2) {
                px.copy_from_slice(&code.to_le_bytes());
            }
        }
        let (worst, differ) = max_diff(&over(&dark, l, false), out, &vec![false; l.len() / 4]);
        assert!(
            worst <= 1,
            "black: off by {worst} ({differ} samples differ)"
        );
    }
}

#[test]
fn prores_layer_has_alpha_and_says_premultiplied() {
    let dir = TempDir::new().unwrap();
    let input = lossless_clip(dir.path(), "96x64", "yuv420p", "bt709");
    let out = dir.path().join("layer.mov");
    render_ok(&input, &out, &["--layer-only"]);
    let v = stream(&out, "v:0");
    assert_eq!(v["codec_name"], "prores");
    assert_eq!(v["profile"], "4444");
    assert!(
        v["pix_fmt"].as_str().unwrap().starts_with("yuva444p"),
        "{v}"
    );
    let tags = fixtures::ffprobe(&out, &["-show_format"]);
    assert_eq!(tags["format"]["tags"]["alpha_mode"], "premultiplied");
    // Its alpha is ProRes's lossless alpha at 10 bits: within half a 10-bit step of FFV1's.
    let lossless = dir.path().join("layer.mkv");
    render_ok(&input, &lossless, &["--layer-only"]);
    let (w, h) = (96, 64);
    let a = layer_samples(&out, w, h);
    let b = layer_samples(&lossless, w, h);
    for (fa, fb) in a.iter().zip(&b) {
        for (pa, pb) in fa.chunks_exact(4).zip(fb.chunks_exact(4)) {
            assert!(pa[3].abs_diff(pb[3]) <= 65, "alpha {} vs {}", pa[3], pb[3]);
        }
    }
}

#[test]
fn outputs_that_cannot_hold_the_layer_are_refused_before_any_work() {
    let dir = TempDir::new().unwrap();
    let input = lossless_clip(dir.path(), "96x64", "yuv420p", "bt709");
    let cases: [(&str, &[&str], &str); 11] = [
        ("out.mp4", &["--layer-only"], "cannot hold"),
        ("out.mp4", &["--matte"], "cannot hold"),
        (
            "out.mkv",
            &["--layer-only", "--codec", "prores"],
            "cannot hold",
        ),
        ("single.png", &["--layer-only"], "frame number pattern"),
        ("plain_%05d.png", &[], "image sequences are written for"),
        // FFmpeg cuts a number wider than 19 digits: every image would get the same name.
        ("wide_%020d.png", &["--layer-only"], "at most 19 digits"),
        // Flags the layer would ignore.
        (
            "l.mkv",
            &["--layer-only", "--codec", "h264"],
            "--codec h264",
        ),
        ("m.mkv", &["--matte", "--codec", "h264"], "--codec h264"),
        (
            "b.mkv",
            &["--layer-only=black", "--alpha", "straight"],
            "--alpha",
        ),
        ("wide_%025d.png", &["--matte"], "at most 19 digits"),
        ("wide_%0100d.png", &["--layer-only"], "at most 19 digits"),
    ];
    for (name, flags, says) in cases {
        let out = render(&input, &dir.path().join(name), flags);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{name} {flags:?} was accepted");
        assert_eq!(err.lines().count(), 1, "one line: {err}");
        assert!(
            err.starts_with("error:") && err.contains(says),
            "{name}: {err}"
        );
    }
    // Flags that make no sense together are refused by the parser.
    for flags in [&["--alpha", "straight"][..], &["--matte", "--layer-only"]] {
        let out = render(&input, &dir.path().join("x.mkv"), flags);
        assert!(!out.status.success(), "{flags:?} was accepted");
    }
    let left: Vec<String> = files_in(dir.path())
        .into_iter()
        .filter(|n| !n.starts_with("in_"))
        .collect();
    assert!(left.is_empty(), "nothing written: {left:?}");
}

/// An `f32` exactly representable as a normal `f16` (at most 11 significant bits), as its bits.
fn f16_bits(v: f32) -> u16 {
    if v == 0.0 {
        return 0;
    }
    let b = v.to_bits();
    let exponent = ((b >> 23) & 0xff) as i32 - 127 + 15;
    assert!(
        (1..31).contains(&exponent) && b & 0x1fff == 0,
        "{v} is no normal f16"
    );
    (((b >> 16) & 0x8000) | ((exponent as u32) << 10) | ((b >> 13) & 0x3ff)) as u16
}

/// The GPU stage `rgba_out` against its CPU twin, every mode, on a canvas of exact `f16`
/// values: dark and bright colour, α from 0 to 1, colour above α (superluminous) and above 1
/// (which the scene-linear layer keeps bit for bit).
#[test]
fn rgba_out_matches_its_cpu_twin() {
    use rain_composite::gpu::cpu::rgba_out::rgba_out;
    use rain_composite::gpu::stages::{FrameStage, rgba_out::RgbaOut};
    use rain_composite::gpu::types::FrameParams;
    use rain_composite::gpu::{AdapterRequest, GpuContext};
    use rain_composite::video::{AlphaMode, ColorParams, FrameFormat, Layer, Transfer};
    use wgpu::util::DeviceExt;

    let ctx = match GpuContext::new(&AdapterRequest::default()) {
        Ok(c) => c,
        Err(e) => {
            assert!(
                std::env::var_os("RAIN_COMPOSITE_REQUIRE_GPU").is_none(),
                "no GPU adapter: {e}"
            );
            return;
        }
    };
    let (w, h) = (37u32, 11u32);
    let canvas: Vec<[f64; 4]> = (0..w * h)
        .map(|i| {
            let a = f64::from(i % 33) / 32.0;
            let level = f64::from((i * 7) % 41) / 32.0; // up to 1.25: some above α and above 1
            [level * a, level * a * 0.5, f64::from(i % 5) / 1024.0, a]
        })
        .collect();
    let texels: Vec<u16> = canvas
        .iter()
        .flat_map(|p| p.map(|v| f16_bits(v as f32)))
        .collect();
    let device = &ctx.device;
    let texture = device.create_texture_with_data(
        &ctx.queue,
        &wgpu::TextureDescriptor {
            label: Some("canvas"),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba16Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        bytemuck::cast_slice(&texels),
    );
    let view = texture.create_view(&Default::default());
    let bytes = u64::from(w * h) * 8;
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("out"),
        size: bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let read = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read"),
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let format = FrameFormat {
        width: w,
        height: h,
        chroma: rain_composite::video::Chroma::Cs444,
        bit_depth: 10,
    };
    for transfer in [Transfer::Bt709, Transfer::Srgb] {
        let color = ColorParams {
            transfer,
            ..ColorParams::bt709(10)
        };
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("frame_params"),
            contents: bytemuck::bytes_of(&FrameParams::new(&format, &color)),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        for layer in [
            Layer::Alpha(AlphaMode::Premultiplied),
            Layer::Alpha(AlphaMode::Straight),
            Layer::Matte,
            Layer::SceneLinear,
        ] {
            let stage = RgbaOut::with_buffers(device, &params, (w, h), &view, &out, layer);
            let mut encoder = device.create_command_encoder(&Default::default());
            stage.record(&mut encoder, None);
            encoder.copy_buffer_to_buffer(&out, 0, &read, 0, bytes);
            ctx.queue.submit([encoder.finish()]);
            read.slice(..)
                .map_async(wgpu::MapMode::Read, |r| r.expect("map"));
            device
                .poll(wgpu::PollType::Wait {
                    submission_index: None,
                    timeout: None,
                })
                .expect("poll");
            let gpu: Vec<u16> =
                bytemuck::pod_collect_to_vec(&read.slice(..).get_mapped_range().expect("mapped"));
            read.unmap();
            let cpu = rgba_out(&canvas, transfer, layer);
            if layer == Layer::SceneLinear {
                // The canvas's half floats, unchanged, bit for bit.
                assert_eq!(gpu, cpu, "{transfer:?} {layer:?}");
                assert_eq!(cpu, texels, "{transfer:?} {layer:?}: the canvas itself");
                continue;
            }
            // f32 against f64 transfer: a rounding may land on the other side of a half.
            let worst = gpu.iter().zip(&cpu).map(|(g, c)| g.abs_diff(*c)).max();
            assert!(worst <= Some(1), "{transfer:?} {layer:?}: off by {worst:?}");
            assert!(gpu.iter().zip(&cpu).filter(|(g, c)| g != c).count() * 100 < gpu.len());
        }
    }
}

/// The widest frame-number pattern FFmpeg formats whole still names each image apart; images
/// are numbered by source frame, so a chunk writes its own images and never a neighbour's.
#[test]
fn a_sequence_pattern_of_19_digits_names_every_frame() {
    let dir = TempDir::new().unwrap();
    let input = lossless_clip(dir.path(), "96x64", "yuv420p", "bt709");
    let seq = dir.path().join("seq");
    std::fs::create_dir(&seq).unwrap();
    render_ok(
        &input,
        &seq.join("g_%019d.png"),
        &["--layer-only", "--frames", "0..3"],
    );
    assert_eq!(
        files_in(&seq),
        (1..=3)
            .map(|i| format!("g_{i:019}.png"))
            .collect::<Vec<_>>()
    );
    let chunks = dir.path().join("chunks");
    std::fs::create_dir(&chunks).unwrap();
    let pattern = chunks.join("c_%05d.png");
    render_ok(&input, &pattern, &["--layer-only", "--frames", "2..3"]);
    assert_eq!(files_in(&chunks), ["c_00003.png"]);
    let last = std::fs::read(chunks.join("c_00003.png")).unwrap();
    render_ok(
        &input,
        &pattern,
        &["--layer-only", "--frames", "0..2", "-y"],
    );
    assert_eq!(
        files_in(&chunks),
        ["c_00001.png", "c_00002.png", "c_00003.png"]
    );
    assert_eq!(std::fs::read(chunks.join("c_00003.png")).unwrap(), last);
}
