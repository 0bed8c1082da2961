//! The CPU back end of the colour passes (`gpu::host`) against the plain `f64` twins
//! (`gpu::cpu::yuv_to_rgb` → `gpu::cpu::rgb_to_yuv`) on 8-bit limited, full-range and 10-bit
//! pictures, with the haze to the scene, to the ground and to a depth map, and with a lamp's
//! glow; its determinism; the identity of a frame with nothing drawn; the wet ground and the
//! puddles against their twins; and the two back ends' renders, previews and frames against
//! each other, with a ground, splashes, mattes and puddles.
//! Set `RAIN_COMPOSITE_REQUIRE_GPU=1` to turn a missing adapter into a failure.

use std::path::Path;
use std::sync::{Arc, OnceLock};

use glam::{DVec3, Vec2};
use rain_composite::config::{CameraConfig, RainConfig};
use rain_composite::drops::MatteAtlas;
use rain_composite::fluid::Field2;
use rain_composite::gpu::cpu::puddles::{Water, puddles_lit};
use rain_composite::gpu::cpu::wet_ground::wet_ground_lit;
use rain_composite::gpu::cpu::{rain_streaks, rgb_to_yuv, yuv_to_rgb};
use rain_composite::gpu::host::rain::HostRain;
use rain_composite::gpu::host::{FrameRain, GroundFrame, HostColour};
use rain_composite::gpu::stages::puddles::{FrameWater, water_params};
use rain_composite::gpu::types::{
    GLINTS_PER_DROP, Glint, LightList, PuddleParams, RainParams, Ripple, Streak, WetParams,
};
use rain_composite::gpu::uniforms::{RainSetup, coded_from_display};
use rain_composite::gpu::{Backend, Compositor};
use rain_composite::lighting::RtfTable;
use rain_composite::lighting::wetness::{FilmOptics, RainHistory, SurfaceStore, Wetting};
use rain_composite::rain::volume::impacts::Impact;
use rain_composite::scene::{Camera, DepthMap};
use rain_composite::video::{Chroma, ColorParams, FrameFormat, Matrix, Transfer, YuvFrame};
use tempfile::TempDir;

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/render.rs"]
mod render;
use render::{BLUISH_SKY, water_tables};

#[path = "common/pictures.rs"]
mod pictures;
use pictures::{codes, scatter};

#[path = "common/fixtures.rs"]
mod fixtures;
use fixtures::s;

#[path = "common/binary.rs"]
mod binary;
use binary::{bin, ok};

const W: u32 = 96;
const H: u32 = 64;

/// The pictures: 8-bit BT.709 limited range 4:2:0, 8-bit full-range BT.601 sRGB 4:2:2 and
/// 10-bit BT.2020 limited 4:2:0 (odd-sized, so the last chroma blocks are partial).
fn formats() -> Vec<(&'static str, FrameFormat, ColorParams)> {
    let format = |width, height, chroma, bit_depth| FrameFormat {
        width,
        height,
        chroma,
        bit_depth,
    };
    vec![
        (
            "8-bit BT.709 limited",
            format(W, H, Chroma::Cs420, 8),
            ColorParams::bt709(8),
        ),
        (
            "8-bit full range",
            format(W, H, Chroma::Cs422, 8),
            ColorParams {
                matrix: Matrix::Bt601,
                full_range: true,
                transfer: Transfer::Srgb,
                bit_depth: 8,
            },
        ),
        (
            "10-bit",
            format(W - 1, H - 1, Chroma::Cs420, 10),
            ColorParams {
                matrix: Matrix::Bt2020Ncl,
                full_range: false,
                transfer: Transfer::Bt709,
                bit_depth: 10,
            },
        ),
    ]
}

/// Scattered, mildly saturated code values over the whole range.
fn picture(format: FrameFormat, color: ColorParams) -> YuvFrame {
    let max = (1u32 << format.bit_depth) - 1;
    let mid = (max + 1) as f64 / 2.0;
    pictures::picture(format, color, |i, x, y| {
        let v = scatter(i, x, y) % (max + 1);
        if i > 0 {
            (mid + (v as f64 - mid) * 0.4).round() as u16
        } else {
            v as u16
        }
    })
}

fn camera(format: FrameFormat) -> Camera {
    Camera::new(format.width, format.height, 1.0, 1.6, 0.1, 0.0)
}

/// No drops over `format`'s picture.
fn dry(format: FrameFormat) -> RainSetup {
    let rain = RainConfig {
        rate_mm_per_h: 0.0,
        ..RainConfig::default()
    };
    planned(&camera(format), &rain, format)
}

/// `rain` seen by `camera` over `format`'s upright picture at a 1/50 s exposure.
fn planned(camera: &Camera, rain: &RainConfig, format: FrameFormat) -> RainSetup {
    rain_composite::shot::rain::plan(
        camera,
        &CameraConfig::default(),
        rain,
        1.0 / 50.0,
        0,
        (format.width, format.height),
    )
    .map(RainSetup::pack)
    .expect("rain")
}

/// How the haze is laid: none, to the scene, to the ground, to a depth map, with lamps; with
/// an open sky's mask over the ground, the depth map and the lamps.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Haze {
    None,
    Scene,
    Ground,
    DepthMap,
    Lamps,
    Sky,
}

const HAZES: [Haze; 6] = [
    Haze::None,
    Haze::Scene,
    Haze::Ground,
    Haze::DepthMap,
    Haze::Lamps,
    Haze::Sky,
];

/// The uniforms of `haze` under a bluish sky brighter to one side: the haze from 2 m,
/// β = 0.05/m, the scene at 60 m.
fn params(setup: &RainSetup, haze: Haze) -> RainParams {
    let mut p = render::lit(setup, 0.0, &BLUISH_SKY, None);
    p.env_sh[3] = [0.4, 0.3, 0.2, 0.0];
    p.haze = match haze {
        Haze::None => [0.0, 0.0, 0.0, 1.0],
        _ => [2.0, 60.0, 0.05, (-0.05f32 * 58.0).exp()],
    };
    p.ground_clip = u32::from(matches!(haze, Haze::Ground | Haze::Sky));
    p
}

/// A sky mask on the glow's grid of `format`'s picture: weights from 0 to 1 across it, whole
/// in the upper left, none in a band.
fn sky_mask(format: FrameFormat) -> Vec<f32> {
    let (gw, gh) =
        rain_composite::gpu::stages::yuv_to_rgb::glow_grid_size((format.width, format.height));
    (0..gw * gh)
        .map(|k| {
            let (i, j) = (k % gw, k / gw);
            if j == gh / 2 {
                0.0
            } else {
                (1.0 - (i + j) as f32 / (gw + gh) as f32 * 1.5).clamp(0.0, 1.0)
            }
        })
        .collect()
}

/// A depth map with a near box, a far band and holes (unknown depth).
fn depth_map(format: FrameFormat) -> DepthMap {
    let (w, h) = (format.width as usize, format.height as usize);
    let values: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if (20..50).contains(&x) && (10..40).contains(&y) {
                4.0
            } else if y > h * 2 / 3 {
                25.0
            } else {
                0.0
            }
        })
        .collect();
    DepthMap::from_values(w, h, &values, 1.0).expect("depth")
}

/// The two lamps of the glow test, over `format`'s picture.
fn lamps(format: FrameFormat) -> LightList {
    LightList::new(&render::lamps(&camera(format)))
}

/// The depth map as the compositor hands it over: metres per displayed pixel, 0 unknown.
fn metres(map: &DepthMap) -> Vec<f32> {
    map.depth_m
        .iter()
        .map(|&d| if d.is_finite() && d > 0.0 { d } else { 0.0 })
        .collect()
}

/// The code planes of `frame` under `haze`: the CPU back end's and the twins'.
fn both(frame: &YuvFrame, haze: Haze, tables: &[RtfTable; 3]) -> ([Vec<u16>; 3], [Vec<u16>; 3]) {
    let f = frame.format;
    let p = params(&dry(f), haze);
    let mut host = HostColour::new(f, &frame.color);
    let map = depth_map(f);
    let list = lamps(f);
    let canvas = match haze {
        Haze::DepthMap => {
            host.set_scene_depth(metres(&map));
            yuv_to_rgb::yuv_to_rgb_with_depth(frame, &p, Some(&map))
        }
        Haze::Lamps => {
            host.set_transfer_table(tables);
            host.set_lights(&list);
            yuv_to_rgb::yuv_to_rgb_lit(frame, &p, &list, tables)
        }
        Haze::Sky => {
            let mask = sky_mask(f);
            host.set_scene_depth(metres(&map));
            host.set_transfer_table(tables);
            host.set_lights(&list);
            host.set_sky_mask(mask.clone());
            let lit = Some((&list, tables));
            yuv_to_rgb::yuv_to_rgb_in_scene(frame, &p, lit, Some(&map), Some(&mask))
        }
        _ => yuv_to_rgb::yuv_to_rgb(frame, &p),
    };
    let twin = rgb_to_yuv::rgb_to_yuv(&canvas, f, &frame.color);
    let texels: Vec<u16> = host.decode(frame, &p).iter().map(|v| v.to_bits()).collect();
    let planes = host.encode(&texels, f.width as usize);
    (codes(&with_planes(frame, planes)), twin)
}

/// `frame` with `planes` in place of its own.
fn with_planes(frame: &YuvFrame, planes: [rain_composite::video::Plane; 3]) -> YuvFrame {
    YuvFrame {
        format: frame.format,
        color: frame.color,
        planes,
        pts: frame.pts,
        index: frame.index,
    }
}

/// Largest code difference and the share of samples more than one code off.
fn compare(a: &[Vec<u16>; 3], b: &[Vec<u16>; 3]) -> (u16, f64) {
    let (mut worst, mut off, mut n) = (0u16, 0usize, 0usize);
    for (x, y) in a.iter().zip(b) {
        assert_eq!(x.len(), y.len());
        for (u, v) in x.iter().zip(y) {
            let d = u.abs_diff(*v);
            worst = worst.max(d);
            off += usize::from(d > 1);
            n += 1;
        }
    }
    (worst, off as f64 / n as f64)
}

/// The CPU back end is within one code of the twins on 99.9 % of the samples, for every
/// picture and every haze; without haze it is the frame itself.
#[test]
fn cpu_back_end_matches_the_twins() {
    let tables = water_tables(1024);
    for (name, format, color) in formats() {
        let frame = picture(format, color);
        for haze in HAZES {
            let (host, twin) = both(&frame, haze, &tables);
            let (worst, share) = compare(&host, &twin);
            eprintln!(
                "{name}, haze {haze:?}: worst {worst} codes, {:.4} % over one",
                100.0 * share
            );
            assert!(share <= 1e-3, "{name}, haze {haze:?}: {share}");
            assert!(worst <= 2, "{name}, haze {haze:?}: {worst} codes off");
            if haze == Haze::None {
                assert_eq!(host, codes(&frame), "{name}: not the frame itself");
            }
        }
        // The haze does change the picture (the cases above test something).
        let (hazy, _) = both(&frame, Haze::Lamps, &tables);
        assert_ne!(hazy, codes(&frame), "{name}");
    }
}

/// The veil on the coarse grid (the SH in-scatter and the glow interpolated bilinearly between
/// rays 8 px apart) against the twins' per-pixel in-scatter, on the linear canvas: within the
/// f16 canvas's own step (2⁻¹¹ relative) and a small absolute floor for the dark pixels.
#[test]
fn the_veil_on_its_grid_is_close_to_per_pixel() {
    let tables = water_tables(1024);
    let (_, format, color) = formats().remove(0);
    let frame = picture(format, color);
    for haze in [Haze::Scene, Haze::Ground, Haze::Lamps] {
        let p = params(&dry(format), haze);
        let mut host = HostColour::new(format, &color);
        let list = lamps(format);
        let twin = if haze == Haze::Lamps {
            host.set_transfer_table(&tables);
            host.set_lights(&list);
            yuv_to_rgb::yuv_to_rgb_lit(&frame, &p, &list, &tables)
        } else {
            yuv_to_rgb::yuv_to_rgb(&frame, &p)
        };
        let canvas = host.decode(&frame, &p);
        let worst = twin
            .iter()
            .zip(canvas.chunks_exact(4))
            .flat_map(|(t, c)| (0..3).map(move |k| (t[k], c[k].to_f64())))
            .map(|(t, c)| (c - t).abs() / t.abs().max(0.01))
            .fold(0.0, f64::max);
        eprintln!("haze {haze:?}: worst error {worst:.2e} of the linear value");
        assert!(worst < 1.5e-3, "haze {haze:?}: {worst}");
    }
}

/// Two runs of the CPU back end give the same bits (the bands are independent of the threads).
#[test]
fn cpu_back_end_is_deterministic() {
    let tables = water_tables(1024);
    let (_, format, color) = formats().remove(2);
    let frame = picture(format, color);
    for haze in [Haze::Ground, Haze::Lamps] {
        let runs: Vec<_> = (0..2).map(|_| both(&frame, haze, &tables).0).collect();
        assert_eq!(runs[0], runs[1], "{haze:?}");
    }
}

/// Through the compositor on the CPU back end (the canvas never on the adapter): a frame with
/// nothing drawn and no haze comes back bit for bit, the haze as the twins lay it, twice alike.
#[test]
fn compositor_on_the_cpu_back_end() {
    let Some(ctx) = gpu() else { return };
    let tables = water_tables(1024);
    for (name, format, color) in formats() {
        let frame = picture(format, color);
        let setup = dry(format);
        for haze in [Haze::None, Haze::Ground, Haze::Lamps] {
            let p = params(&setup, haze);
            let mut comp =
                Compositor::with_backend(ctx.clone(), format, &color, &setup, None, Backend::Cpu)
                    .expect("compositor");
            assert_eq!(comp.backend(), Backend::Cpu);
            comp.set_transfer_table(&tables);
            if haze == Haze::Lamps {
                comp.set_lights(&lamps(format));
            }
            let out: Vec<_> = (0..2)
                .map(|_| codes(&comp.render_one(&frame, &p).expect("render")))
                .collect();
            assert_eq!(out[0], out[1], "{name}, {haze:?}: two runs differ");
            if haze == Haze::None {
                assert_eq!(out[0], codes(&frame), "{name}: a dry frame changed");
            } else {
                let (_, twin) = both(&frame, haze, &tables);
                let (worst, share) = compare(&out[0], &twin);
                assert!(share <= 1e-3 && worst <= 2, "{name}, {haze:?}: {worst}");
            }
        }
    }
}

/// Decoded frames of `video` (8-bit 4:2:0), as raw planes one after the other.
fn raw_frames(video: &Path, dir: &Path, tag: &str) -> Vec<u8> {
    let raw = dir.join(format!("{tag}.yuv"));
    fixtures::ffmpeg(&[
        "-i",
        s(video),
        "-f",
        "rawvideo",
        "-pix_fmt",
        "yuv420p",
        s(&raw),
    ]);
    std::fs::read(&raw).expect("raw")
}

/// Within one code on 99.9 % of the samples, and never more than `worst`.
fn agree(a: &[u8], b: &[u8], worst: u8, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    assert!(!a.is_empty(), "{what}");
    let off = a.iter().zip(b).filter(|(x, y)| x.abs_diff(**y) > 1).count();
    let max = a.iter().zip(b).map(|(x, y)| x.abs_diff(*y)).max();
    eprintln!(
        "{what}: {off} of {} samples more than one code apart, worst {max:?}",
        a.len()
    );
    assert!(off as f64 <= 1e-3 * a.len() as f64, "{what}: {off} samples");
    assert!(max <= Some(worst), "{what}: {max:?}");
}

/// The night skyline sample rendered with its preset (haze, lamps) on each back end, losslessly:
/// the two agree within a code on 99.9 % of the samples.
#[test]
fn cpu_and_gpu_renders_of_the_city_agree() {
    if gpu().is_none() {
        return;
    }
    let dir = TempDir::new().expect("tmp");
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("samples/city.mp4");
    let frames: Vec<Vec<u8>> = ["gpu", "cpu"]
        .iter()
        .map(|backend| {
            let out = dir.path().join(format!("{backend}.mkv"));
            ok(bin().args([
                s(&sample),
                "-o",
                s(&out),
                "--config",
                "city",
                "--codec",
                "ffv1",
                "--frames",
                "0..4",
                "--backend",
                backend,
            ]));
            raw_frames(&out, dir.path(), backend)
        })
        .collect();
    agree(&frames[0], &frames[1], 4, "city, --backend gpu vs cpu");
}

/// A preview is the frame the full render writes, on either back end (with haze over a ground
/// and rain drawn).
#[test]
fn preview_is_the_render_on_both_back_ends() {
    if gpu().is_none() {
        return;
    }
    let dir = TempDir::new().expect("tmp");
    let input = fixtures::quick_clip(dir.path(), "in.mp4", "160x120", 1.0);
    for backend in ["gpu", "cpu"] {
        let look = [
            "--rain",
            "40",
            "--seed",
            "5",
            "--ground",
            "horizon=0.4",
            "--backend",
            backend,
        ];
        let full = dir.path().join(format!("{backend}.mkv"));
        ok(bin()
            .args([
                s(&input),
                "-o",
                s(&full),
                "--codec",
                "ffv1",
                "--frames",
                "0..12",
            ])
            .args(look));
        assert_preview_is_the_render(dir.path(), &input, &full, "9", &look, backend);
    }
}

/// The look of the program-level splash tests: heavy rain of drops three times their size over
/// a street seen from 1.6 m through a 90° lens tilted down (the horizon 10 % from the top).
const SPLASHING: [&str; 12] = [
    "--rain",
    "50",
    "--drop-scale",
    "3",
    "--near",
    "0.3",
    "--far",
    "6",
    "--fov",
    "90",
    "--ground",
    "horizon=0.1",
];

/// [`SPLASHING`] as a configuration, seeded `seed`.
fn splashing(seed: u32) -> rain_composite::config::RenderConfig {
    let mut c = render::looking_down();
    c.rain.rate_mm_per_h = 50.0;
    c.rain.drop_scale = 3.0;
    c.rain.near_m = 0.3;
    c.rain.far_m = 6.0;
    c.rain.seed = seed;
    c
}

/// On the CPU back end with splashes drawn: one seed renders the same frames twice, another
/// seed other frames.
#[test]
fn splashes_on_the_cpu_back_end_are_seeded() {
    use rain_composite::Renderer;
    use rain_composite::gpu::{AdapterRequest, Backend};
    use rain_composite::shot::Footage;
    use rain_composite::video::{Chroma, ColorParams, FrameFormat, YuvFrame};
    if gpu().is_none() {
        return;
    }
    let format = FrameFormat {
        width: 160,
        height: 120,
        chroma: Chroma::Cs420,
        bit_depth: 8,
    };
    let footage = Footage::picture(format, ColorParams::bt709(8), 25.0);
    let mut frame = YuvFrame::filled(format, footage.color, [60, 128, 128]);
    frame.planes[0].data[..160 * 30].fill(220);
    let cpu = AdapterRequest {
        backend: Backend::Cpu,
        ..AdapterRequest::default()
    };
    let render = |seed| {
        let mut r = Renderer::new(&splashing(seed), &footage, &cpu).expect("renderer");
        assert_eq!(r.backend(), Backend::Cpu);
        let frames: Vec<Vec<u8>> = (0..10)
            .map(|k| {
                let f = r.render(&frame, k as f64 / 25.0).expect("frame");
                f.planes.iter().flat_map(|p| p.data.clone()).collect()
            })
            .collect();
        (frames, r.gpu_times().splashes_drawn)
    };
    let (a, drawn) = render(5);
    let (b, _) = render(5);
    let (other, _) = render(6);
    eprintln!("{drawn} splash streaks drawn over 10 frames");
    assert!(drawn > 50, "{drawn} splash streaks drawn");
    assert!(a == b, "one seed, two renders differ");
    assert!(a != other, "the seed changes nothing");
}

/// With splashes on the CPU back end, a preview is the frame the full render writes (the look
/// of [`splashes_on_the_cpu_back_end_are_seeded`], which draws splashes).
#[test]
fn preview_with_splashes_is_the_render_on_the_cpu_back_end() {
    if gpu().is_none() {
        return;
    }
    let dir = TempDir::new().expect("tmp");
    let input = fixtures::quick_clip(dir.path(), "in.mp4", "160x120", 1.0);
    let full = dir.path().join("splashes.mkv");
    let look: Vec<&str> = SPLASHING
        .iter()
        .copied()
        .chain(["--seed", "5", "--backend", "cpu"])
        .collect();
    ok(bin()
        .args([
            s(&input),
            "-o",
            s(&full),
            "--codec",
            "ffv1",
            "--frames",
            "0..10",
        ])
        .args(&look));
    assert_preview_is_the_render(dir.path(), &input, &full, "8", &look, "cpu");
}

/// The 16-bit preview of `input`'s frame `frame` under `look` (which names `backend`) is the
/// frame of the render `rendered` taken through the same still conversion (no rain, no haze
/// added), byte for byte.
fn assert_preview_is_the_render(
    dir: &Path,
    input: &Path,
    rendered: &Path,
    frame: &str,
    look: &[&str],
    backend: &str,
) {
    let preview = dir.join(format!("{backend}-preview.png"));
    ok(bin()
        .args(["preview", s(input), "--frame", frame, "-o", s(&preview)])
        .args(["--bits", "16"])
        .args(look));
    let from_full = dir.join(format!("{backend}-full.png"));
    ok(bin().args([
        "preview",
        s(rendered),
        "--frame",
        frame,
        "-o",
        s(&from_full),
        "--bits",
        "16",
        "--rain",
        "0",
        "--backend",
        backend,
    ]));
    assert!(
        std::fs::read(&preview).expect("png") == std::fs::read(&from_full).expect("png"),
        "--backend {backend}: the preview differs from the render's frame ({})",
        look.join(" ")
    );
}

// The streaks drawn on the CPU (`gpu::host::streaks`) against the plain twin
// (`gpu::cpu::rain_streaks`), and through the compositor against the GPU's raster.

/// A picture a few tiles wide and high (tiles are 64 × 32), odd in neither dimension's tiles.
const RW: u32 = 150;
const RH: u32 = 100;

/// A small deterministic stream of uniforms in [0, 1).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// `n` streaks over a `w × h` display: every direction (mostly down the picture), lengths from
/// none to long, radii from thin to wide, faint to opaque, a tenth hidden, some off the
/// picture; each with up to four glints.
fn random_streaks(n: usize, w: f32, h: f32, seed: u64) -> (Vec<Streak>, Vec<Glint>) {
    let mut r = Lcg(seed);
    let mut streaks = Vec::new();
    let mut glints = Vec::new();
    for k in 0..n {
        let angle = (r.next() - 0.5) * if k % 7 == 0 { 6.3 } else { 1.2 };
        let len = match k % 9 {
            0 => 0.0,
            1 => 5e-4,
            _ => 60.0 * r.next() * r.next(),
        };
        let radius = if k % 23 == 0 {
            6.0 + 6.0 * r.next()
        } else {
            0.5 + 2.5 * r.next() * r.next()
        };
        let depth = [1.0 + 20.0 * r.next(), 1.0 + 20.0 * r.next()];
        let rad = |r: &mut Lcg| [r.next() * 2.0, r.next() * 2.0, r.next() * 2.0];
        let (c0, c1) = (rad(&mut r), rad(&mut r));
        streaks.push(Streak {
            q0_px: [(r.next() * 1.3 - 0.15) * w, (r.next() * 1.3 - 0.25) * h],
            dir: [angle.sin(), angle.cos()],
            len_px: if k % 10 == 3 { -1.0 } else { len },
            r_eff_px: radius,
            alpha_scale: 0.02 + 1.2 * r.next() * r.next(),
            drop_info: (r.next() * 65535.0) as u32 | ((r.next() * 65535.0) as u32) << 16,
            radiance0: [c0[0], c0[1], c0[2], depth[0]],
            radiance1: [c1[0], c1[1], c1[2], depth[1]],
        });
        let lit = (r.next() * 5.0) as usize;
        for g in 0..GLINTS_PER_DROP {
            let (a, b) = (r.next() * std::f32::consts::TAU, r.next() * 2.0 - 1.0);
            let s = (1.0 - b * b).sqrt();
            let c = if g < lit { r.next() } else { 0.0 };
            glints.push(Glint {
                colour: [c, 0.8 * c, 0.6 * c, 0.0],
                light_dir: [s * a.cos(), s * a.sin(), b, 0.0],
            });
        }
    }
    (streaks, glints)
}

/// The shipped streak database's mattes at 1/50 s.
fn atlas() -> Arc<MatteAtlas> {
    static ATLAS: OnceLock<Arc<MatteAtlas>> = OnceLock::new();
    ATLAS
        .get_or_init(|| {
            let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("drops");
            Arc::new(MatteAtlas::load(&dir, 1.0 / 50.0).expect("drops/"))
        })
        .clone()
}

/// How the streaks are drawn in [`raster_pair`].
#[derive(Clone, Copy, Debug, PartialEq)]
enum Draw {
    Capsules,
    /// Behind the scene of [`depth_map`].
    Occluded,
    Mattes,
    /// Mattes with their glints.
    Glints,
    /// Capsules on a picture shown turned by 90°.
    Rotated,
}

const DRAWS: [Draw; 5] = [
    Draw::Capsules,
    Draw::Occluded,
    Draw::Mattes,
    Draw::Glints,
    Draw::Rotated,
];

/// The uniforms of the raster tests for `draw` over `format`'s coded picture.
fn raster_params(format: FrameFormat, draw: Draw) -> RainParams {
    let mut p = params(&dry(format), Haze::Scene);
    if draw == Draw::Rotated {
        let (m, off) = coded_from_display(90, format.width as f32, format.height as f32);
        p.coded_from_display = m;
        p.coded_offset_px = off;
        p.display_size_px = [format.height as f32, format.width as f32];
    }
    p
}

/// The hazed canvas of `frame` with `streaks` drawn on the CPU back end (f16 bits), and the
/// twin's canvas from the same plate, rounded to f16 bits.
fn raster_pair(
    frame: &YuvFrame,
    draw: Draw,
    streaks: &[Streak],
    glints: &[Glint],
) -> (Vec<u16>, Vec<u16>, Vec<u16>) {
    let f = frame.format;
    let p = raster_params(f, draw);
    let mut host = HostColour::new(f, &frame.color);
    let map = depth_map(f);
    if draw == Draw::Occluded {
        host.set_scene_depth(metres(&map));
    }
    let plate: Vec<u16> = host.decode(frame, &p).iter().map(|v| v.to_bits()).collect();
    let mut canvas: Vec<[f64; 3]> = plate
        .chunks_exact(4)
        .map(|px| std::array::from_fn(|k| half::f16::from_bits(px[k]).to_f64()))
        .collect();
    let atlas = atlas();
    let mattes = matches!(draw, Draw::Mattes | Draw::Glints).then_some(&*atlas);
    let glints = if draw == Draw::Glints { glints } else { &[] };
    let depth = (draw == Draw::Occluded).then_some(&map);
    rain_streaks::rain_streaks_with(&mut canvas, &p, streaks, mattes, glints, depth);
    let count = host.draw_streaks(frame, &p, streaks, mattes, glints);
    assert!(
        count.streaks > 0 && count.tiles > 0,
        "{draw:?}: nothing drawn"
    );
    let ours: Vec<u16> = host.canvas().iter().map(|v| v.to_bits()).collect();
    let twin = canvas
        .iter()
        .zip(plate.chunks_exact(4))
        .flat_map(|(c, px)| {
            let rgb = c.map(|v| half::f16::from_f64(v).to_bits());
            [rgb[0], rgb[1], rgb[2], px[3]]
        })
        .collect();
    (plate, ours, twin)
}

/// The code planes of a canvas (f16 bits) through the CPU back end's encoder.
fn encoded(frame: &YuvFrame, canvas: &[u16]) -> [Vec<u16>; 3] {
    let host = HostColour::new(frame.format, &frame.color);
    codes(&with_planes(
        frame,
        host.encode(canvas, frame.format.width as usize),
    ))
}

/// The streaks drawn in tiles on the CPU are the twin's within one code on 99.9 % of the
/// samples, for capsules, capsules behind a depth map, mattes with and without glints and a
/// turned picture; where the twin leaves a pixel as it was, so do the tiles, bit for bit.
#[test]
fn streak_raster_matches_the_twin() {
    for (name, format, color) in formats() {
        let format = FrameFormat {
            width: RW - (W - format.width),
            height: RH - (H - format.height),
            ..format
        };
        let frame = picture(format, color);
        for draw in DRAWS {
            let p = raster_params(format, draw);
            let [dw, dh] = p.display_size_px;
            let (streaks, glints) = random_streaks(400, dw, dh, 7);
            let (plate, ours, twin) = raster_pair(&frame, draw, &streaks, &glints);
            let (worst, share) = compare(&encoded(&frame, &ours), &encoded(&frame, &twin));
            // Pixels the twin left untouched: the same bits (the twin's f64 round trip of
            // an f16 is exact).
            let mut kept = 0;
            for (i, ((o, t), p)) in ours.iter().zip(&twin).zip(&plate).enumerate() {
                if t == p {
                    assert_eq!(o, p, "{name}, {draw:?}: sample {i} changed");
                    kept += 1;
                }
            }
            let drawn = plate.len() - kept;
            eprintln!(
                "{name}, {draw:?}: {drawn} of {} samples drawn; worst {worst} codes, {:.4} % over one",
                plate.len(),
                100.0 * share
            );
            assert!(drawn > plate.len() / 10, "{name}, {draw:?}: {drawn}");
            assert!(share <= 1e-3, "{name}, {draw:?}: {share}");
            assert!(worst <= 2, "{name}, {draw:?}: {worst} codes off");
        }
    }
}

/// The raster gives the same bits twice, and on one thread as on many (every pixel is computed
/// from its own coordinates; each tile blends its streaks in drop order).
#[test]
fn streak_raster_is_deterministic() {
    let (_, format, color) = formats().remove(0);
    let format = FrameFormat {
        width: RW,
        height: RH,
        ..format
    };
    let frame = picture(format, color);
    let (streaks, glints) = random_streaks(400, RW as f32, RH as f32, 11);
    for draw in [Draw::Capsules, Draw::Glints] {
        let run = || raster_pair(&frame, draw, &streaks, &glints).1;
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool")
            .install(run);
        assert_eq!(run(), run(), "{draw:?}");
        assert_eq!(run(), one, "{draw:?}: one thread differs");
    }
}

/// The raster's AVX2 build (eight lanes a vector, F16C for the tiles) gives the baseline
/// build's bits for every way of drawing, wide streaks that cross many tiles included, and the
/// same bits twice; on an odd width (the last tile's rows end between two vectors).
#[test]
fn streak_raster_avx2_build_matches_the_baseline() {
    use rain_composite::gpu::host::streaks::{Rain, Raster, rasterise, rasterise_baseline};
    let (_, format, color) = formats().remove(2);
    let format = FrameFormat {
        width: 2 * RW - 1,
        height: RH,
        ..format
    };
    let frame = picture(format, color);
    let atlas = atlas();
    let map = depth_map(format);
    let depth = metres(&map);
    for draw in DRAWS {
        let p = raster_params(format, draw);
        let [dw, dh] = p.display_size_px;
        let (mut streaks, glints) = random_streaks(600, dw, dh, 13);
        for s in streaks.iter_mut().step_by(31) {
            s.r_eff_px *= 6.0;
            s.len_px *= 3.0;
        }
        let rain = Rain {
            params: &p,
            mattes: matches!(draw, Draw::Mattes | Draw::Glints).then_some(&*atlas),
            glints: if draw == Draw::Glints { &glints } else { &[] },
            depth: (draw == Draw::Occluded).then_some(&depth[..]),
        };
        let mut host = HostColour::new(format, &frame.color);
        let plate = host.decode(&frame, &p).to_vec();
        let width = format.width as usize;
        let run = |raster: fn(&mut [half::f16], usize, &Rain, &[Streak]) -> _| {
            let mut canvas = plate.clone();
            let count = raster(&mut canvas, width, &rain, &streaks);
            (
                canvas.iter().map(|v| v.to_bits()).collect::<Vec<u16>>(),
                count,
            )
        };
        let (fast, count) = run(rasterise);
        let (base, base_count) = run(rasterise_baseline);
        // A raster's buffers kept from a frame with more streaks, elsewhere, change no bit.
        let mut kept = Raster::default();
        let (more, _) = random_streaks(900, dw, dh, 17);
        let rain_more = Rain {
            glints: &[],
            ..rain
        };
        kept.draw(&mut plate.clone(), width, &rain_more, &more);
        let mut canvas = plate.clone();
        assert_eq!(kept.draw(&mut canvas, width, &rain, &streaks), count);
        assert!(
            canvas.iter().map(|v| v.to_bits()).eq(fast.iter().copied()),
            "{draw:?}: a kept raster differs"
        );
        assert!(
            count.streaks > 300 && count.tiles > 8,
            "{draw:?}: {count:?}"
        );
        assert_eq!(count, base_count, "{draw:?}");
        let changed = fast
            .iter()
            .zip(&plate)
            .filter(|(f, p)| **f != p.to_bits())
            .count();
        assert!(changed > fast.len() / 10, "{draw:?}: {changed} changed");
        assert!(fast == base, "{draw:?}: the AVX2 build differs");
        assert!(
            run(rasterise).0 == fast,
            "{draw:?}: not the same bits twice"
        );
    }
}

/// The decode's, the puddles' and the encode's AVX2 builds (eight lanes a vector, gathers from
/// the tables, F16C for the canvas and the puddles' reads of the picture) give the baseline
/// builds' bits: for every picture (odd sizes, 4:2:2, 10-bit) under every haze, and with the
/// wet ground fused into the decode and the puddles, upright and turned.
#[test]
fn colour_passes_avx2_build_matches_the_baseline() {
    let tables = water_tables(1024);
    let bits = |c: &[half::f16]| c.iter().map(|v| v.to_bits()).collect::<Vec<u16>>();
    for (name, format, color) in formats() {
        let frame = picture(format, color);
        let map = depth_map(format);
        let list = lamps(format);
        for haze in HAZES {
            let p = params(&dry(format), haze);
            let run = |make: fn(FrameFormat, &ColorParams) -> HostColour| {
                let mut host = make(format, &color);
                host.set_transfer_table(&tables);
                host.set_lights(&list);
                if matches!(haze, Haze::DepthMap | Haze::Sky) {
                    host.set_scene_depth(metres(&map));
                }
                if haze == Haze::Sky {
                    host.set_sky_mask(sky_mask(format));
                }
                let canvas = bits(host.decode(&frame, &p));
                let planes = codes(&with_planes(&frame, host.encode_canvas(&frame)));
                (canvas, planes)
            };
            let (fast, base) = (run(HostColour::new), run(HostColour::baseline));
            assert!(fast.0 == base.0, "{name}, {haze:?}: the decodes differ");
            assert!(fast.1 == base.1, "{name}, {haze:?}: the encodes differ");
        }
        for (on, rotation_deg) in GROUNDS.into_iter().flat_map(|on| [(on, 0), (on, 90)]) {
            let turned = |make| ground_case_turned(&frame, on, &tables, 1, rotation_deg, make);
            let (fast, base) = (turned(HostColour::new), turned(HostColour::baseline));
            assert!(fast.wet_pixels > 0 || on == OnGround::Wet, "{name}, {on:?}");
            assert!(
                fast.host_plate == base.host_plate,
                "{name}, {on:?}: plates differ"
            );
            assert!(fast.host == base.host, "{name}, {on:?}: the ground differs");
            assert!(
                fast.host != vec![fast.host_plate.clone()],
                "{name}, {on:?}: no change"
            );
        }
    }
}

/// Rain on but nothing drawn (every streak hidden or off the picture): the canvas keeps its
/// bits, no tile is touched, and without haze the frame comes back as it was.
#[test]
fn nothing_drawn_leaves_the_canvas_untouched() {
    for (name, format, color) in formats() {
        let frame = picture(format, color);
        let p = params(&dry(format), Haze::None);
        let (mut streaks, glints) = random_streaks(200, W as f32, H as f32, 3);
        for (k, s) in streaks.iter_mut().enumerate() {
            if k % 2 == 0 {
                s.len_px = -1.0;
            } else {
                s.q0_px = [-50.0 - s.r_eff_px - s.len_px, 20.0];
                s.dir = [0.0, 1.0];
            }
        }
        let mut host = HostColour::new(format, &color);
        let plate: Vec<u16> = host
            .decode(&frame, &p)
            .iter()
            .map(|v| v.to_bits())
            .collect();
        let count = host.draw_streaks(&frame, &p, &streaks, Some(&atlas()), &glints);
        assert_eq!(count.streaks, 0, "{name}");
        assert_eq!(count.tiles, 0, "{name}");
        let after: Vec<u16> = host.canvas().iter().map(|v| v.to_bits()).collect();
        assert_eq!(after, plate, "{name}");
        assert_eq!(
            codes(&with_planes(&frame, host.encode_canvas(&frame))),
            codes(&frame),
            "{name}: the frame changed"
        );
    }
}

/// Samples of `a` that differ from `b`'s (the planes the same sizes).
fn differing(a: &[Vec<u16>; 3], b: &[Vec<u16>; 3]) -> usize {
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            assert_eq!(x.len(), y.len());
            x.iter().zip(y).filter(|(u, v)| u != v).count()
        })
        .sum()
}

/// `frame` under `p` with `ground`, the splashes and `rain`'s streaks, through the stages one
/// after another (the plate laid, each draw, the canvas packed) and band by band
/// (`render_bands`), on two hosts `make` sets up alike: the two code planes and what each
/// draw drew.
fn staged_and_banded(
    frame: &YuvFrame,
    p: &RainParams,
    ground: &GroundFrame,
    rain: &FrameRain,
    make: &dyn Fn() -> HostColour,
) -> ([Vec<u16>; 3], [Vec<u16>; 3]) {
    let mut staged = make();
    staged.lay_plate(frame, p, ground);
    let splashed = staged.draw_splashes(frame, p, rain.splashes);
    let drawn = staged.draw_streaks(frame, p, rain.streaks, rain.mattes, rain.glints);
    let want = codes(&with_planes(frame, staged.encode_canvas(frame)));
    let banded = make()
        .render_bands(frame, p, ground, rain)
        .expect("a frame that does not pass through goes band by band");
    assert_eq!(banded.splashes, splashed, "splashes drawn");
    assert_eq!(banded.streaks, drawn, "streaks drawn");
    assert!(drawn.streaks > 0 && splashed.streaks > 0, "nothing drawn");
    (codes(&with_planes(frame, banded.planes)), want)
}

/// A frame laid, drawn on and packed band by band is the stages one after another to the bit
/// (several bands, the last cut short, odd sizes, 4:2:0 and 4:2:2, 8 and 10 bits): for
/// capsules, capsules behind a depth map, mattes with and without glints and a turned
/// picture, the splashes drawn first, under haze and over a wet ground; without haze the
/// frame is left to pass through unless pass-through is off, and then it is the stages too.
#[test]
fn banded_frame_is_the_stages_to_the_bit() {
    for (name, format, color) in formats() {
        let format = FrameFormat {
            width: 200 - (W - format.width),
            height: 100 - (H - format.height),
            ..format
        };
        let frame = picture(format, color);
        let map = depth_map(format);
        let atlas = atlas();
        for draw in DRAWS {
            let p = raster_params(format, draw);
            let [dw, dh] = p.display_size_px;
            let (streaks, glints) = random_streaks(600, dw, dh, 11);
            let (splashes, _) = random_streaks(150, dw, dh, 12);
            let rain = FrameRain {
                splashes: &splashes,
                streaks: &streaks,
                mattes: matches!(draw, Draw::Mattes | Draw::Glints).then_some(&*atlas),
                glints: if draw == Draw::Glints { &glints } else { &[] },
            };
            let make = || {
                let mut host = HostColour::new(format, &color);
                if draw == Draw::Occluded {
                    host.set_scene_depth(metres(&map));
                }
                host
            };
            let (banded, staged) =
                staged_and_banded(&frame, &p, &GroundFrame::default(), &rain, &make);
            assert_eq!(differing(&banded, &staged), 0, "{name}, {draw:?}");
        }
        let (streaks, _) = random_streaks(600, format.width as f32, format.height as f32, 13);
        let (splashes, _) = random_streaks(150, format.width as f32, format.height as f32, 14);
        let rain = FrameRain {
            splashes: &splashes,
            streaks: &streaks,
            mattes: None,
            glints: &[],
        };
        // A wet ground, fused into the decode.
        let setup = rain_composite::shot::rain::plan(
            &ground_camera(format),
            &CameraConfig::default(),
            &RainConfig {
                rate_mm_per_h: 0.0,
                ..RainConfig::default()
            },
            1.0 / 50.0,
            0,
            (format.width, format.height),
        )
        .map(RainSetup::pack)
        .expect("rain")
        .with_ground(true);
        let p = params(&setup, Haze::Ground);
        let wet = GroundFrame {
            wet: Some(WetParams::new(
                wetting().wetness_at(0.0),
                &FilmOptics::water(),
                40.0,
            )),
            water: None,
        };
        let make = || HostColour::new(format, &color);
        let (banded, staged) = staged_and_banded(&frame, &p, &wet, &rain, &make);
        assert_eq!(differing(&banded, &staged), 0, "{name}, wet ground");
        let (_, dry_ground) = staged_and_banded(&frame, &p, &GroundFrame::default(), &rain, &make);
        assert!(
            differing(&staged, &dry_ground) > 0,
            "{name}: the wet ground changed nothing"
        );
        // No haze: the untouched tiles pass through, unless that is turned off.
        let p = params(&dry(format), Haze::None);
        let mut host = HostColour::new(format, &color);
        assert!(
            host.render_bands(&frame, &p, &GroundFrame::default(), &rain)
                .is_none(),
            "{name}: no haze, yet not passed through"
        );
        let make = || {
            let mut host = HostColour::new(format, &color);
            host.set_pass_through(false);
            host
        };
        let (banded, staged) = staged_and_banded(&frame, &p, &GroundFrame::default(), &rain, &make);
        assert_eq!(
            differing(&banded, &staged),
            0,
            "{name}, no haze, all tiles converted"
        );
    }
}

/// Rain through the compositor: the CPU back end, which simulates the drops and draws their
/// streaks on the CPU, agrees with the GPU's `rain_simulate` and raster within one code on
/// 99.9 % of the samples, for capsules and for mattes with glints, and draws something.
#[test]
fn compositor_rain_on_both_back_ends_agrees() {
    let Some(ctx) = gpu() else { return };
    let tables = water_tables(1024);
    let (name, format, color) = formats().remove(0);
    let format = FrameFormat {
        width: RW,
        height: RH,
        ..format
    };
    let frame = picture(format, color);
    let camera = camera(format);
    let rain = RainConfig {
        rate_mm_per_h: 60.0,
        ..RainConfig::default()
    };
    for mattes in [false, true] {
        let setup = planned(&camera, &rain, format).with_mattes(mattes.then(atlas));
        let mut p = params(&setup, Haze::Scene);
        p.time_frac_s = 0.4;
        let render = |backend| {
            let mut comp =
                Compositor::with_backend(ctx.clone(), format, &color, &setup, None, backend)
                    .expect("compositor");
            comp.set_transfer_table(&tables);
            comp.set_lights(&lamps(format));
            let out = codes(&comp.render_one(&frame, &p).expect("render"));
            (out, comp.gpu_times().streaks_drawn)
        };
        let ((cpu, drawn), (gpu, _)) = (render(Backend::Cpu), render(Backend::Gpu));
        let (worst, share) = compare(&cpu, &gpu);
        let dry_cpu = {
            let dry = dry(format);
            let mut comp =
                Compositor::with_backend(ctx.clone(), format, &color, &dry, None, Backend::Cpu)
                    .expect("compositor");
            codes(
                &comp
                    .render_one(&frame, &params(&dry, Haze::Scene))
                    .expect("render"),
            )
        };
        eprintln!(
            "{name}, mattes {mattes}: {drawn} streaks drawn; worst {worst} codes, {:.4} % over one",
            100.0 * share
        );
        assert!(drawn > 50, "mattes {mattes}: {drawn} streaks");
        assert_ne!(cpu, dry_cpu, "mattes {mattes}: no rain shows");
        assert!(
            share <= 1e-3 && worst <= 2,
            "mattes {mattes}: {worst}, {share}"
        );
    }
}

/// A depth map of holes (unknown everywhere) draws the streaks bit for bit as no map does.
#[test]
fn unknown_depth_draws_as_no_map() {
    let (_, format, color) = formats().remove(0);
    let format = FrameFormat {
        width: RW,
        height: RH,
        ..format
    };
    let frame = picture(format, color);
    let p = raster_params(format, Draw::Capsules);
    let (streaks, _) = random_streaks(400, RW as f32, RH as f32, 5);
    let draw = |holes: bool| {
        let mut host = HostColour::new(format, &color);
        if holes {
            host.set_scene_depth(vec![0.0; (RW * RH) as usize]);
        }
        host.decode(&frame, &p);
        host.draw_streaks(&frame, &p, &streaks, None, &[]);
        host.canvas()
            .iter()
            .map(|v| v.to_bits())
            .collect::<Vec<u16>>()
    };
    assert_eq!(draw(true), draw(false));
}

// The ground's passes on the CPU back end (`gpu::host::wet_ground`, `gpu::host::puddles`, the
// splashes' draw list drawn by `gpu::host::streaks`) against the twins
// (`gpu::cpu::wet_ground::wet_ground_lit`, `gpu::cpu::puddles::puddles_lit`, the lamps' glow
// kept on the ground), and through
// the compositor against the GPU's stages.

/// A camera 1.6 m over the ground looking down by 0.2 rad: about two thirds of the picture is
/// ground.
fn ground_camera(format: FrameFormat) -> Camera {
    Camera::new(format.width, format.height, 1.0, 1.6, -0.2, 0.0)
}

/// The ground wetting: ten minutes of 10 mm/h up to the clip's start.
fn wetting() -> Wetting {
    Wetting {
        store: SurfaceStore::default(),
        history: RainHistory::new(vec![(-600.0, 10.0), (0.0, 0.0)]).expect("history"),
        reach_m: 40.0,
    }
}

/// Patchy water in front of the camera: cells of 0.25 m from dry through the rim's film to
/// 3 cm deep.
fn pools() -> Field2 {
    let (nx, ny) = (64, 120);
    let values = (0..nx * ny)
        .map(|k| {
            let (i, j) = ((k % nx) as f32, (k / nx) as f32);
            (0.03 * (0.31 * i).sin() * (0.23 * j).cos() - 0.004).max(0.0)
        })
        .collect();
    Field2 {
        nx,
        ny,
        origin_m: Vec2::new(-8.0, 0.0),
        cell_m: 0.25,
        values,
    }
}

/// Rings on the water near the camera, at a frame's time.
fn rings() -> Vec<Ripple> {
    (0..40)
        .map(|k| {
            let k = k as f32;
            Ripple {
                centre_m: [-3.0 + 0.17 * k, 3.0 + 0.29 * k],
                radius_m: 0.05 + 0.01 * k,
                width_m: 0.02,
                amplitude_m: 1.5e-3,
                wavenumber: 90.0,
                phase: 0.37 * k,
                _pad: 0.0,
            }
        })
        .collect()
}

/// The water's uniforms for `water` with `rings` live rings and the far water's slope `far`.
fn pool_params(water: &Field2, rings: usize, far: Option<(f32, f32)>) -> PuddleParams {
    let (far_slope_rms, resolve_depth_m) = far.unwrap_or((0.0, 0.0));
    PuddleParams {
        ring_count: rings as u32,
        far_slope_rms,
        resolve_depth_m,
        ..water_params(
            water.origin_m.to_array(),
            water.cell_m,
            [water.nx as u32, water.ny as u32],
        )
    }
}

/// What lies on the ground in a case of [`GROUNDS`].
#[derive(Clone, Copy, Debug, PartialEq)]
enum OnGround {
    /// The wet ground alone, under the haze.
    Wet,
    /// Water without a film around it, no haze, no mask.
    Pools,
    /// The wet ground, water with rings and the far water's roughness, the ground mask, lamps.
    Masked,
    /// The wet ground and water with rings, a depth map (the march), lamps, the haze.
    DepthMap,
}

const GROUNDS: [OnGround; 4] = [
    OnGround::Wet,
    OnGround::Pools,
    OnGround::Masked,
    OnGround::DepthMap,
];

/// A ground mask on the glow's grid of `format`'s picture: ground on the left, none in a
/// band on the right, weights between.
fn ground_mask(format: FrameFormat) -> Vec<f32> {
    let (gw, gh) =
        rain_composite::gpu::stages::yuv_to_rgb::glow_grid_size((format.width, format.height));
    (0..gw * gh)
        .map(|k| (1.4 - 1.6 * (k % gw) as f32 / gw as f32).clamp(0.0, 1.0))
        .collect()
}

/// The linear canvases of `frame` with `on` the ground: the twins' (f64) before and after the
/// ground's passes, and the CPU back end's bits (plate alone, then with the ground's passes),
/// the latter run `runs` times.
struct GroundCase {
    twin_before: Vec<[f64; 3]>,
    twin: Vec<[f64; 3]>,
    host_plate: Vec<u16>,
    host: Vec<Vec<u16>>,
    wet_pixels: usize,
}

fn ground_case(frame: &YuvFrame, on: OnGround, tables: &[RtfTable; 3], runs: usize) -> GroundCase {
    ground_case_turned(frame, on, tables, runs, 0, HostColour::new)
}

/// [`ground_case`] for a picture stored turned by `rotation_deg` (the frame is the coded one).
fn ground_case_turned(
    frame: &YuvFrame,
    on: OnGround,
    tables: &[RtfTable; 3],
    runs: usize,
    rotation_deg: i32,
    make: fn(FrameFormat, &ColorParams) -> HostColour,
) -> GroundCase {
    let f = frame.format;
    // The displayed picture, and the camera that films it.
    let shown = if rotation_deg % 180 == 0 {
        f
    } else {
        FrameFormat {
            width: f.height,
            height: f.width,
            ..f
        }
    };
    let setup = rain_composite::shot::rain::plan(
        &ground_camera(shown),
        &CameraConfig::default(),
        &RainConfig {
            rate_mm_per_h: 0.0,
            ..RainConfig::default()
        },
        1.0 / 50.0,
        rotation_deg,
        (f.width, f.height),
    )
    .map(RainSetup::pack)
    .expect("rain")
    .with_ground(true);
    let mut p = params(&setup, Haze::Ground);
    if on == OnGround::Pools {
        p.haze = [0.0, 0.0, 0.0, 1.0];
    }
    let map = (on == OnGround::DepthMap).then(|| depth_map(shown));
    let mask = (on == OnGround::Masked).then(|| ground_mask(f));
    let list = if matches!(on, OnGround::Masked | OnGround::DepthMap) {
        LightList::new(&render::lamps(&ground_camera(shown)))
    } else {
        LightList::new(&[])
    };
    let wet = (on != OnGround::Pools)
        .then(|| WetParams::new(wetting().wetness_at(0.0), &FilmOptics::water(), 40.0));
    let water = pools();
    let ripples = rings();
    let live = if matches!(on, OnGround::Masked | OnGround::DepthMap) {
        ripples.len()
    } else {
        0
    };
    let far = (on == OnGround::Masked).then_some((0.06, 6.0));
    let pool = (on != OnGround::Wet).then(|| pool_params(&water, live, far));
    // The twins.
    let lit = Some((&list, tables));
    let twin_before = yuv_to_rgb::yuv_to_rgb_in_scene(frame, &p, lit, map.as_ref(), None);
    // The lamps' glow the ground's passes keep (none without lamps or haze).
    let glow = (list.count > 0 && p.haze[3] < 1.0)
        .then(|| yuv_to_rgb::haze_glow(&p, &list, tables, (f.width, f.height)));
    let mut twin = twin_before.clone();
    if let Some(w) = &wet {
        let (map, mask) = (map.as_ref(), mask.as_deref());
        wet_ground_lit(&mut twin, frame, &p, w, map, mask, glow.as_deref());
    }
    if let Some(params) = &pool {
        let pond = Water {
            params,
            depth_m: &water.values,
            ripples: &ripples,
            lights: &list,
        };
        let (map, mask) = (map.as_ref(), mask.as_deref());
        puddles_lit(&mut twin, frame, &p, &pond, map, mask, glow.as_deref());
    }
    // The CPU back end.
    let mut host = make(f, &frame.color);
    host.set_transfer_table(tables);
    host.set_lights(&list);
    if let Some(map) = &map {
        host.set_scene_depth(metres(map));
    }
    if let Some(mask) = &mask {
        host.set_ground_mask(mask.clone());
    }
    let bits = |c: &[half::f16]| c.iter().map(|v| v.to_bits()).collect::<Vec<u16>>();
    let host_plate = bits(host.decode(frame, &p));
    let mut wet_pixels = 0;
    let host_runs = (0..runs)
        .map(|_| {
            let ground = GroundFrame {
                wet,
                water: pool.map(|params| FrameWater {
                    params,
                    depth_m: &water.values,
                    ripples: ripples.clone(),
                }),
            };
            wet_pixels = host.decode_ground(frame, &p, &ground).1;
            bits(host.canvas())
        })
        .collect();
    GroundCase {
        twin_before,
        twin,
        host_plate,
        host: host_runs,
        wet_pixels,
    }
}

/// The wet ground and the puddles on the CPU back end are within one code of the twins on
/// 99.9 % of the samples, for every picture and every case; the pixels the twins leave alone
/// keep the plate's bits; the cases do change the picture.
#[test]
fn ground_passes_match_the_twins() {
    let tables = water_tables(1024);
    for (name, format, color) in formats() {
        let frame = picture(format, color);
        for on in GROUNDS {
            let case = ground_case(&frame, on, &tables, 1);
            let host = &case.host[0];
            let host_codes = encoded(&frame, host);
            let twin = rgb_to_yuv::rgb_to_yuv(&case.twin, format, &color);
            let (worst, share) = compare(&host_codes, &twin);
            let changed = case
                .twin
                .iter()
                .zip(&case.twin_before)
                .filter(|(a, b)| a != b)
                .count();
            eprintln!(
                "{name}, {on:?}: {changed} pixels changed by the twins, {} under water; worst {worst} codes, {:.4} % over one",
                case.wet_pixels,
                100.0 * share
            );
            assert!(share <= 1e-3, "{name}, {on:?}: {share}");
            assert!(worst <= 2, "{name}, {on:?}: {worst} codes off");
            assert!(
                changed > (format.width * format.height / 10) as usize,
                "{name}, {on:?}: {changed} pixels changed"
            );
            if on != OnGround::Wet {
                assert!(case.wet_pixels > 100, "{name}, {on:?}: no water shows");
            }
            for (i, (a, b)) in case.twin.iter().zip(&case.twin_before).enumerate() {
                if a == b {
                    assert_eq!(
                        host[4 * i..4 * i + 4],
                        case.host_plate[4 * i..4 * i + 4],
                        "{name}, {on:?}: pixel {i} left alone by the twins changed"
                    );
                }
            }
        }
    }
}

/// On a picture stored turned a quarter (coded ≠ displayed), the ground's passes are still
/// within one code of the twins on 99.9 % of the samples, and the water shows.
#[test]
fn ground_passes_on_a_turned_picture() {
    let tables = water_tables(1024);
    let (name, format, color) = formats().remove(0);
    let frame = picture(format, color);
    for on in [OnGround::Masked, OnGround::DepthMap] {
        let case = ground_case_turned(&frame, on, &tables, 1, 90, HostColour::new);
        let host_codes = encoded(&frame, &case.host[0]);
        let twin = rgb_to_yuv::rgb_to_yuv(&case.twin, format, &color);
        let (worst, share) = compare(&host_codes, &twin);
        eprintln!(
            "{name} turned, {on:?}: {} under water; worst {worst} codes, {:.4} % over one",
            case.wet_pixels,
            100.0 * share
        );
        assert!(case.wet_pixels > 100, "{on:?}: no water shows");
        assert!(share <= 1e-3 && worst <= 2, "{on:?}: {worst}, {share}");
    }
}

/// The ground's passes give the same bits twice and on one thread.
#[test]
fn ground_passes_are_deterministic() {
    let tables = water_tables(1024);
    let (_, format, color) = formats().remove(2);
    let frame = picture(format, color);
    for on in [OnGround::Masked, OnGround::DepthMap] {
        let case = ground_case(&frame, on, &tables, 2);
        assert_eq!(case.host[0], case.host[1], "{on:?}");
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool")
            .install(|| ground_case(&frame, on, &tables, 1));
        assert_eq!(case.host[0], one.host[0], "{on:?}: one thread differs");
    }
}

/// A camera looking down at a wet ground two seconds into rain of `rate_mm_per_h`, drops
/// from 0.3 to 6 m drawn three times their size, streak mattes on and the haze reaching the
/// ground: the scene both compositor ground tests draw.
fn wet_ground_scene(rate_mm_per_h: f64) -> (Camera, RainSetup, RainParams) {
    let rain = RainConfig {
        rate_mm_per_h,
        near_m: 0.3,
        far_m: 6.0,
        drop_scale: 3.0,
        ..RainConfig::default()
    };
    let (camera, setup) =
        render::rain_seen_by(&render::looking_down(), (RW, RH), &rain, 1.0 / 50.0, true);
    let setup = setup
        .with_wetting(Some(wetting()))
        .with_scene_depth(true)
        .with_mattes(Some(atlas()));
    let mut p = params(&setup, Haze::Ground);
    p.time_whole_s = 2;
    (camera, setup, p)
}

/// Rain over a wet ground with puddles, rings, splashes, streak mattes with glints, a depth
/// map and a ground mask, through the compositor: the CPU back end (the canvas never on the
/// adapter) agrees with the GPU's stages within one code on 99.9 % of the samples, on 8-bit
/// BT.709, full-range and 10-bit pictures, and the ground, the water and the rain show.
#[test]
fn compositor_ground_on_both_back_ends_agrees() {
    let Some(ctx) = gpu() else { return };
    let tables = water_tables(1024);
    for (k, (name, format, color)) in formats().into_iter().enumerate() {
        let format = FrameFormat {
            width: RW,
            height: RH,
            ..format
        };
        let frame = picture(format, color);
        // Drops near the camera landing on the ground below it: splashes. Lighter rain on
        // the other pictures: where many wide streaks overlap a pixel the two rasters part by
        // more than a 10-bit code even without a ground (the adapter's canvas is rounded to
        // f16 after each streak, the CPU's tile once).
        let (camera, setup, mut p) = wet_ground_scene(if k == 0 { 10.0 } else { 2.0 });
        p.time_frac_s = 0.4;
        let water = pools();
        let impacts: Vec<Impact> = (0..60)
            .map(|k| Impact {
                id: k,
                pass: 0,
                time_s: 2.4 - 0.01 * k as f64,
                position_m: DVec3::new(-3.0 + 0.1 * k as f64, 3.0 + 0.2 * k as f64, 0.0),
                diameter_mm: 2.0,
                velocity_mps: DVec3::new(0.0, 0.0, -6.5),
            })
            .collect();
        let map = depth_map(format);
        let render = |backend, wet: bool| {
            let mut comp =
                Compositor::with_backend(ctx.clone(), format, &color, &setup, None, backend)
                    .expect("compositor");
            comp.set_transfer_table(&tables);
            comp.set_lights(&LightList::new(&render::lamps(&camera)));
            comp.set_scene_depth(&map).expect("depth");
            comp.set_ground_mask(&ground_mask(format)).expect("mask");
            if wet {
                comp.set_water(&water_map(&water)).expect("water");
                comp.set_ripples(&impacts).expect("rings");
                comp.set_far_ripples(0.05, 8.0).expect("far");
            }
            let out = codes(&comp.render_one(&frame, &p).expect("render"));
            let t = comp.gpu_times();
            (out, (t.streaks_drawn, t.splashes_drawn))
        };
        let (cpu, (drawn, splashes)) = render(Backend::Cpu, true);
        let (gpu, _) = render(Backend::Gpu, true);
        let (dry_cpu, _) = render(Backend::Cpu, false);
        let (worst, share) = compare(&cpu, &gpu);
        let (_, water_share) = compare(&cpu, &dry_cpu);
        eprintln!(
            "{name}: {drawn} streaks and {splashes} splash streaks drawn; water changes {:.2} % of the samples; CPU vs GPU worst {worst} codes, {:.4} % over one",
            100.0 * water_share,
            100.0 * share
        );
        assert!(drawn > 50, "{name}: {drawn} streaks");
        assert!(splashes > 0, "{name}: no splash drawn");
        assert!(water_share > 0.01, "{name}: the water does not show");
        assert!(share <= 1e-3, "{name}: {worst}, {share}");
    }
}

/// On the CPU back end a compositor allocates nothing on the adapter (no planes, canvas,
/// readback ring, masks, streak or matte buffers), with a wet ground, puddles, rings, streak
/// mattes, a depth map and both masks set and a frame of rain drawn: the allocator report of a
/// device of its own lists the same allocations after as before. The GPU back end's compositor
/// on that device does show in it (its canvas at least), so the report sees what it should.
#[test]
fn cpu_back_end_allocates_nothing_on_the_adapter() {
    use rain_composite::gpu::{AdapterRequest, GpuContext};
    if gpu().is_none() {
        return;
    }
    let ctx = Arc::new(GpuContext::new(&AdapterRequest::default()).expect("adapter"));
    let report = || {
        let r = ctx.device.generate_allocator_report();
        let r = r.expect("the adapter's allocator report (Vulkan keeps one)");
        let mut names: Vec<String> = r.allocations.into_iter().map(|a| a.name).collect();
        names.sort();
        (names, r.total_allocated_bytes)
    };
    let (_, format, color) = formats().remove(0);
    let format = FrameFormat {
        width: RW,
        height: RH,
        ..format
    };
    let frame = picture(format, color);
    let (camera, setup, p) = wet_ground_scene(RainConfig::default().rate_mm_per_h);
    let render = |backend| {
        let mut comp = Compositor::with_backend(ctx.clone(), format, &color, &setup, None, backend)
            .expect("compositor");
        comp.set_transfer_table(&water_tables(1024));
        comp.set_lights(&LightList::new(&render::lamps(&camera)));
        comp.set_scene_depth(&depth_map(format)).expect("depth");
        comp.set_sky_mask(&sky_mask(format)).expect("sky");
        comp.set_ground_mask(&ground_mask(format)).expect("ground");
        comp.set_water(&pools()).expect("water");
        comp.render_one(&frame, &p).expect("render");
        (comp.gpu_times().streaks_drawn, comp)
    };
    let (before, before_bytes) = report();
    let (drawn, cpu) = render(Backend::Cpu);
    assert_eq!(cpu.backend(), Backend::Cpu);
    assert!(drawn > 0, "no rain drawn");
    let (after, after_bytes) = report();
    let new: Vec<_> = after.iter().filter(|n| !before.contains(n)).collect();
    assert_eq!(
        (after.len(), after_bytes),
        (before.len(), before_bytes),
        "the CPU back end allocated on the adapter: {new:?}"
    );
    let (_, gpu) = render(Backend::Gpu);
    assert_eq!(gpu.backend(), Backend::Gpu);
    let (with_gpu, gpu_bytes) = report();
    let canvas_bytes = u64::from(RW * RH) * 8;
    assert!(
        with_gpu.iter().any(|n| n == "canvas") && gpu_bytes >= after_bytes + canvas_bytes,
        "the GPU back end's compositor is not in the report: {after_bytes} → {gpu_bytes} bytes"
    );
}

/// The water map as the compositor takes it.
fn water_map(water: &Field2) -> Field2 {
    Field2 {
        nx: water.nx,
        ny: water.ny,
        origin_m: water.origin_m,
        cell_m: water.cell_m,
        values: water.values.clone(),
    }
}

/// With puddles on a given ground, on either back end: a render is the same twice with the
/// same seed, another seed changes it, and a preview is the frame the render writes.
#[test]
fn puddles_are_seeded_and_previewed_alike_on_both_back_ends() {
    if gpu().is_none() {
        return;
    }
    let dir = TempDir::new().expect("tmp");
    let input = fixtures::quick_clip(dir.path(), "in.mp4", "160x120", 1.0);
    for backend in ["gpu", "cpu"] {
        let look = |seed: &'static str| {
            [
                "--rain",
                "40",
                "--seed",
                seed,
                "--ground",
                "horizon=0.4",
                "--pre-rain",
                "240",
                "--puddles",
                "--puddle-particles",
                "1500",
                "--relief",
                "0.01",
                "--backend",
                backend,
            ]
        };
        let render = |seed, tag: &str| {
            let out = dir.path().join(format!("{backend}-{tag}.mkv"));
            ok(bin()
                .args([
                    s(&input),
                    "-o",
                    s(&out),
                    "--codec",
                    "ffv1",
                    "--frames",
                    "0..10",
                ])
                .args(look(seed)));
            raw_frames(&out, dir.path(), &format!("{backend}-{tag}"))
        };
        let (a, b, other) = (render("5", "a"), render("5", "b"), render("6", "c"));
        assert!(a == b, "--backend {backend}: one seed, two renders differ");
        assert!(a != other, "--backend {backend}: the seed changes nothing");
        let rendered = dir.path().join(format!("{backend}-a.mkv"));
        assert_preview_is_the_render(dir.path(), &input, &rendered, "8", &look("5"), backend);
    }
}

// The drops simulated on the CPU (`gpu::host::simulate`) against the plain twin
// (`gpu::cpu::rain_simulate::streak_of` and `take_glints` on `rain::volume::sample_drop`, the
// light from `lighting::prt_colour` and `lighting::direct_colour`), all in f64.

/// One random shot for the drops' tests.
struct Shot {
    setup: RainSetup,
    params: RainParams,
    env: rain_composite::lighting::EnvironmentSh,
    sources: Vec<rain_composite::lighting::LightSource>,
    list: LightList,
    rtf: rain_composite::lighting::RtfSh,
    camera: Camera,
    t_s: f64,
}

/// Shot `k` over a `w × h` picture: a random lens, pose, rate, wind and gusts, time (up to an
/// hour in), with a ground on odd shots, a sun and a near lamp, mattes with glints on shots
/// 2 and 3 (mod 4).
fn shot(k: u64, w: u32, h: u32) -> Shot {
    use glam::DVec3;
    use rain_composite::lighting::prt::channel_optics;
    use rain_composite::lighting::rtf::{ChannelIndices, Polarisation, WATER_RHO_RGB};
    use rain_composite::lighting::{EnvironmentSh, FrameLight, LightSource, RtfSh};
    let mut r = Lcg(1000 + k);
    let fov = 0.5 + 1.2 * r.next() as f64;
    let camera = Camera::new(
        w,
        h,
        fov,
        0.5 + 3.0 * r.next() as f64,
        0.4 * (r.next() as f64 - 0.6),
        0.2 * (r.next() as f64 - 0.5),
    );
    let lens = CameraConfig {
        fov_deg: fov.to_degrees(),
        f_number: [0.0, 2.8, 8.0][k as usize % 3],
        focus_m: 1.0 + 10.0 * r.next() as f64,
        ..CameraConfig::default()
    };
    let rain = RainConfig {
        rate_mm_per_h: 2.0 + 40.0 * r.next() as f64,
        wind_mps: [8.0 * (r.next() as f64 - 0.5), 6.0 * (r.next() as f64 - 0.5)],
        gust_mps: 3.0 * r.next() as f64,
        seed: k as u32 * 7 + 1,
        ..RainConfig::default()
    };
    let setup = rain_composite::shot::rain::plan(&camera, &lens, &rain, 1.0 / 50.0, 0, (w, h))
        .map(RainSetup::pack)
        .expect("rain")
        .with_mattes((k % 4 >= 2).then(atlas));
    let optics =
        channel_optics(ChannelIndices(WATER_RHO_RGB), 5, Polarisation::default()).expect("optics");
    let rtf = RtfSh::from_optics(&optics, 4).expect("rtf");
    let mut env = EnvironmentSh::zeros(4);
    env.coeffs[0] = [0.8, 0.9, 1.0];
    env.coeffs[2] = [0.3, 0.35, 0.5];
    env.coeffs[5] = [0.1 * r.next(), -0.05, 0.02];
    let sources = vec![
        LightSource {
            direction_world: DVec3::new(0.3, -0.8, 0.5).normalize(),
            solid_angle_sr: 6.8e-5,
            radiance_rgb: [2e4, 1.9e4, 1.7e4],
            distance_m: None,
        },
        LightSource {
            direction_world: camera.ray_world(glam::DVec2::new(0.3 * w as f64, 0.4 * h as f64)),
            solid_angle_sr: 2e-3,
            radiance_rgb: [3000.0, 2500.0, 1500.0],
            distance_m: Some(3.0 + 5.0 * r.next() as f64),
        },
    ];
    let t_s = [0.3, 2.7, 3600.25, 41.9][k as usize % 4] + r.next() as f64;
    let zonal = rtf.to_gpu_array();
    let light = FrameLight {
        env: env.clone(),
        lights: sources.clone(),
    };
    let mut params = setup.params_at(t_s, &light, zonal);
    params.ground_clip = (k % 2) as u32;
    Shot {
        list: LightList::new(&sources),
        setup,
        params,
        env,
        sources,
        rtf,
        camera,
        t_s,
    }
}

/// The shot's drops on the CPU back end: streaks, glints (empty without point-light mattes)
/// and how many can be drawn.
fn simulated(s: &Shot, tables: &[RtfTable; 3]) -> (Vec<Streak>, Vec<Glint>, usize) {
    let mut rain = HostRain::new(&s.setup.columns, s.setup.mattes.clone());
    rain.set_transfer_table(tables);
    rain.set_lights(&s.list);
    let (streaks, glints, drawable) = rain.simulate(&s.params);
    (streaks.to_vec(), glints.to_vec(), drawable)
}

/// The shot's drops from the twin, in f64: one streak per drop (hidden: `len_px < 0`) and
/// its glints where the shot has point-light mattes.
fn twin_drops(s: &Shot, tables: &[RtfTable; 3]) -> (Vec<Streak>, Vec<Glint>) {
    use rain_composite::gpu::cpu::rain_simulate::{streak_of, take_glints};
    use rain_composite::lighting::{direct_colour, prt_colour};
    use rain_composite::rain::volume::sample_drop;
    let glints_on = s
        .setup
        .mattes
        .as_ref()
        .is_some_and(|m| !m.lights.is_empty());
    let hidden = Streak {
        len_px: -1.0,
        dir: [0.0, 1.0],
        ..bytemuck::Zeroable::zeroed()
    };
    let mut streaks = Vec::new();
    let mut glints = Vec::new();
    for id in 0..s.params.drop_count as u64 {
        let mut out = hidden;
        let mut g = [Glint {
            colour: [0.0; 4],
            light_dir: [0.0; 4],
        }; GLINTS_PER_DROP];
        let drop = sample_drop(s.setup.rainfall(), id, s.t_s);
        let shape = drop.as_ref().and_then(|d| {
            streak_of(&s.params, d.position_m, d.velocity_mps, d.width_mm).map(|sh| (d, sh))
        });
        if let Some((d, sh)) = shape {
            let end = |k: usize| {
                let offset = s.camera.world_from_camera * sh.ends_camera_m[k];
                let env = prt_colour(&s.env, &s.rtf, offset);
                let direct = direct_colour(&s.sources, tables, Some(offset), offset);
                let c: [f64; 3] = std::array::from_fn(|c| (env[c] + direct[c]).max(0.0));
                [
                    c[0] as f32,
                    c[1] as f32,
                    c[2] as f32,
                    sh.ends_camera_m[k].z as f32,
                ]
            };
            let view = (d.position_m - s.camera.position_m).normalize();
            let fall = d.velocity_mps.normalize();
            let elevation = view.dot(fall).abs().min(1.0).asin().to_degrees();
            let unorm = |x: f64| (x.clamp(0.0, 1.0) * 65535.0).round() as u32;
            out = Streak {
                q0_px: sh.q0_px.as_vec2().to_array(),
                dir: sh.dir.as_vec2().to_array(),
                len_px: sh.len_px as f32,
                r_eff_px: sh.r_eff_px as f32,
                alpha_scale: sh.alpha_scale as f32,
                drop_info: unorm(d.drawn_mm / 10.0) | unorm(elevation / 90.0) << 16,
                radiance0: end(0),
                radiance1: end(1),
            };
            if glints_on {
                g = take_glints(
                    &s.params,
                    &s.list,
                    tables,
                    d.position_m,
                    d.velocity_mps,
                    &mut out,
                );
            }
        }
        streaks.push(out);
        if glints_on {
            glints.extend(g);
        }
    }
    (streaks, glints)
}

/// The drops simulated on the CPU match the twin's records on random shots (lenses, poses,
/// rates, winds, gusts, an hour into the clip, with and without a ground, lit by the
/// environment, a sun and a near lamp, with glints): the same streaks drawn but for drops a
/// hair from the cull or from their column's end (f32 against f64); where both draw, positions
/// within 0.01 px, the rest of the geometry within 10⁻³, the light within 2 × 10⁻³ (2 % on the few ends on a bow's caustic, where the
/// transfer table steps), the matte's bins within 0.1 % and the glints' light within 10⁻³.
#[test]
fn simulated_drops_match_the_twin() {
    let tables = water_tables(1024);
    let (mut total_drawn, mut total_compared) = (0, 0);
    for k in 0..12 {
        let s = shot(k, 960, 540);
        let (ours, our_glints, drawable) = simulated(&s, &tables);
        let (twin, twin_glints) = twin_drops(&s, &tables);
        assert_eq!(ours.len(), twin.len());
        assert_eq!(
            drawable,
            ours.iter().filter(|s| s.len_px >= 0.0).count(),
            "shot {k}: the count"
        );
        let (mut drawn, mut mismatched, mut steep, mut compared) = (0, 0, 0, 0);
        for (id, (o, t)) in ours.iter().zip(&twin).enumerate() {
            if (o.len_px >= 0.0) != (t.len_px >= 0.0) {
                mismatched += 1;
                continue;
            }
            if o.len_px < 0.0 {
                assert_eq!(*o, rain_composite::gpu::host::simulate::HIDDEN);
                continue;
            }
            // A drop at its column's end may wrap on one side only.
            if (o.q0_px[1] - t.q0_px[1]).abs() > 1.0 + 1e-3 * t.q0_px[1].abs() {
                mismatched += 1;
                continue;
            }
            drawn += 1;
            let close = |a: f32, b: f32, tol: f32| (a - b).abs() <= tol * (1.0 + b.abs());
            let what = format!("shot {k}, drop {id}: {o:?} against {t:?}");
            // Positions to a hundredth of a pixel (f32 sums of terms the picture's size).
            let px = |a: f32, b: f32| (a - b).abs() <= 0.01 + 1e-4 * b.abs();
            assert!(
                px(o.q0_px[0], t.q0_px[0]) && px(o.q0_px[1], t.q0_px[1]),
                "{what}"
            );
            assert!(px(o.len_px, t.len_px), "{what}");
            assert!(close(o.r_eff_px, t.r_eff_px, 1e-3), "{what}");
            assert!(close(o.alpha_scale, t.alpha_scale, 2e-3), "{what}");
            assert!(
                close(o.dir[0], t.dir[0], 1e-3) && close(o.dir[1], t.dir[1], 1e-3),
                "{what}"
            );
            let bins = |i: u32| [i & 0xFFFF, i >> 16];
            let (ob, tb) = (bins(o.drop_info), bins(t.drop_info));
            assert!(ob[0].abs_diff(tb[0]) <= 2, "{what}: size bin");
            assert!(ob[1].abs_diff(tb[1]) <= 66, "{what}: view bin");
            // The streak's light before any glints left it: what its errors scale with.
            let glint_sum = |c: usize| -> f32 {
                twin_glints[(4 * id).min(twin_glints.len())..][..twin_glints.len().min(4)]
                    .iter()
                    .map(|g| g.colour[c])
                    .sum()
            };
            let light = |c: usize| t.radiance0[c] + t.radiance1[c] + glint_sum(c);
            for (a, b) in [(o.radiance0, t.radiance0), (o.radiance1, t.radiance1)] {
                assert!(close(a[3], b[3], 1e-3), "{what}: depth");
                for c in 0..3 {
                    let (err, scale) = ((a[c] - b[c]).abs(), b[c].max(light(c)));
                    if err > 2e-3 * scale + 1e-4 {
                        steep += 1;
                        assert!(err <= 2e-2 * scale + 1e-4, "{what}: channel {c}");
                    }
                    compared += 1;
                }
            }
            if !twin_glints.is_empty() {
                for g in 0..GLINTS_PER_DROP {
                    let (a, b) = (our_glints[4 * id + g], twin_glints[4 * id + g]);
                    for c in 0..3 {
                        assert!(
                            (a.colour[c] - b.colour[c]).abs() <= 2e-2 * light(c) + 1e-4,
                            "{what}: glint {g}: {a:?} against {b:?}"
                        );
                        assert!(
                            (a.light_dir[c] - b.light_dir[c]).abs() <= 1e-3 || b.colour[c] == 0.0,
                            "{what}: glint {g} direction: {a:?} against {b:?}"
                        );
                    }
                }
            }
        }
        eprintln!(
            "shot {k}: {} drops, {drawn} drawn alike, {mismatched} drawn on one side only, \
             {steep} of {compared} radiances beyond 2e-3",
            ours.len()
        );
        assert!(drawn > 20, "shot {k}: {drawn} drawn");
        assert!(
            mismatched * 200 <= drawn + 400,
            "shot {k}: {mismatched} mismatches"
        );
        assert!(steep * 200 <= compared, "shot {k}: {steep} of {compared}");
        total_drawn += drawn;
        total_compared += compared;
    }
    assert!(total_drawn > 20_000, "{total_drawn} drawn");
    assert!(total_compared >= 6 * total_drawn);
}

/// The frames drawn from the CPU's drops and from the twin's agree within one code on 99.9 %
/// of the samples, with a ground, behind a depth map and with mattes and glints.
#[test]
fn frames_from_simulated_drops_match_the_twin() {
    let tables = water_tables(1024);
    let (_, format, color) = formats().remove(0);
    let format = FrameFormat {
        width: 320,
        height: 180,
        ..format
    };
    let frame = picture(format, color);
    for k in 0..4 {
        let s = shot(k, format.width, format.height);
        let (ours, our_glints, _) = simulated(&s, &tables);
        let (twin, twin_glints) = twin_drops(&s, &tables);
        let map = depth_map(format);
        let draw = |streaks: &[Streak], glints: &[Glint]| {
            let mut host = HostColour::new(format, &color);
            if k % 2 == 1 {
                host.set_scene_depth(metres(&map));
            }
            host.decode(&frame, &s.params);
            host.draw_streaks(
                &frame,
                &s.params,
                streaks,
                s.setup.mattes.as_deref(),
                glints,
            );
            codes(&with_planes(&frame, host.encode_canvas(&frame)))
        };
        let (a, b) = (draw(&ours, &our_glints), draw(&twin, &twin_glints));
        let (worst, share) = compare(&a, &b);
        let changed = a
            .iter()
            .zip(&codes(&frame))
            .map(|(x, y)| x.iter().zip(y).filter(|(u, v)| u != v).count())
            .sum::<usize>();
        eprintln!(
            "shot {k}: {changed} samples changed by the rain; worst {worst} codes, {:.4} % over one",
            100.0 * share
        );
        assert!(changed > 1000, "shot {k}: the rain hardly shows");
        assert!(share <= 1e-3, "shot {k}: {share}");
    }
}

/// The drops on the CPU are the same bits twice, on one thread as on many, and with or
/// without the AVX2 build; another seed gives other drops.
#[test]
fn simulated_drops_are_deterministic() {
    use rain_composite::gpu::host::simulate::{Drops, LightTable, simulate_baseline};
    let tables = water_tables(1024);
    let s = shot(2, 320, 180);
    let run = || simulated(&s, &tables);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool")
        .install(run);
    let (a, b) = (run(), run());
    assert_eq!(a.0, b.0);
    assert_eq!(a.1, b.1);
    assert_eq!(a.0, one.0, "one thread differs");
    assert_eq!(a.1, one.1, "one thread differs");
    assert!(a.2 > 100 && !a.1.is_empty());
    let table = LightTable::new(&rain_composite::gpu::lights::table_texels(&tables));
    let drops = Drops {
        columns: &s.setup.columns,
        lights: &s.list,
        table: Some(&table),
        glints: true,
    };
    let (mut streaks, mut glints) = (Vec::new(), Vec::new());
    simulate_baseline(&s.params, &drops, &mut streaks, &mut glints);
    assert_eq!(streaks, a.0, "the baseline build differs");
    assert_eq!(glints, a.1, "the baseline build differs");
    let mut other = shot(2, 320, 180);
    other.params.seed += 1;
    // Records kept from another frame (other drops drawn, other glints) are all rewritten.
    let mut kept = HostRain::new(&s.setup.columns, s.setup.mattes.clone());
    kept.set_transfer_table(&tables);
    kept.set_lights(&s.list);
    kept.simulate(&other.params);
    let (streaks, glints, drawable) = kept.simulate(&s.params);
    assert_eq!(streaks, &a.0[..], "records kept from another frame differ");
    assert_eq!(glints, &a.1[..], "glints kept from another frame differ");
    assert_eq!(drawable, a.2);
    assert_ne!(
        simulated(&other, &tables).0,
        a.0,
        "the seed changes nothing"
    );
}

/// Rain whose every streak is culled (opacity far below a code's worth): the simulation finds
/// nothing to draw, the raster touches no tile and the frame comes back bit for bit.
#[test]
fn simulated_rain_with_nothing_drawn_leaves_the_frame() {
    let tables = water_tables(1024);
    for (name, format, color) in formats() {
        let frame = picture(format, color);
        let mut s = shot(1, format.width, format.height);
        s.params.opacity = 1e-7;
        s.params.haze = [0.0, 0.0, 0.0, 1.0];
        let (streaks, glints, drawable) = simulated(&s, &tables);
        assert_eq!(drawable, 0, "{name}");
        assert!(streaks.len() > 100, "{name}: {} drops", streaks.len());
        let mut host = HostColour::new(format, &color);
        host.decode(&frame, &s.params);
        let count = host.draw_streaks(&frame, &s.params, &streaks, None, &glints);
        assert_eq!(count.tiles, 0, "{name}");
        assert_eq!(
            codes(&with_planes(&frame, host.encode_canvas(&frame))),
            codes(&frame),
            "{name}: the frame changed"
        );
    }
}

/// A picture of `format` whose chroma spans every code (far out of gamut in places), 10-bit
/// samples with stray high bits here and there, rows padded.
fn wild_picture(format: FrameFormat, color: ColorParams) -> YuvFrame {
    let max = (1u32 << format.bit_depth) - 1;
    pictures::padded_picture(format, color, 5, |i, x, y| {
        let v = scatter(i, x, y);
        if format.bit_depth > 8 && v.is_multiple_of(97) {
            (v % (max + 1)) as u16 | 0x8000
        } else {
            (v % (max + 1)) as u16
        }
    })
}

/// `codes` of `frame`'s planes with each sample clamped to its depth's largest code (as the
/// decode reads them).
fn clamped(frame: &YuvFrame) -> [Vec<u16>; 3] {
    let max = ((1u32 << frame.format.bit_depth) - 1) as u16;
    codes(frame).map(|p| p.into_iter().map(|c| c.min(max)).collect())
}

/// Whether every sample of tile (`tx`, `ty`) of `format` is the same in `a` and `b`.
fn tile_equal(format: FrameFormat, a: &[Vec<u16>; 3], b: &[Vec<u16>; 3], tx: u32, ty: u32) -> bool {
    use rain_composite::gpu::host::streaks::{TILE_H, TILE_W};
    (0..3).all(|i| {
        let (w, h) = format.plane_size(i);
        let (sx, sy) = if i == 0 {
            (0, 0)
        } else {
            format.chroma.shift()
        };
        let (tw, th) = (TILE_W as u32 >> sx, TILE_H as u32 >> sy);
        (ty * th..((ty + 1) * th).min(h)).all(|y| {
            (tx * tw..((tx + 1) * tw).min(w))
                .all(|x| a[i][(y * w + x) as usize] == b[i][(y * w + x) as usize])
        })
    })
}

/// Rain drawn on some tiles only, no haze, no ground: every tile comes out either as the full
/// decode → draw → encode gives it or as the frame came in, bit for bit; tiles far from every
/// streak and splash come out as they came in; the whole frame is the full path's; and only
/// the tiles reached were converted.
#[test]
fn untouched_tiles_pass_through_bit_for_bit() {
    use rain_composite::gpu::host::streaks::{TILE_H, TILE_W};
    for (name, format, color) in formats() {
        // Five tiles across (the last partial on the odd picture), seven down.
        let format = FrameFormat {
            width: format.width + 221,
            height: format.height + 141,
            ..format
        };
        let p = params(&dry(format), Haze::None);
        // Within 100 px of the left edge (q0 within 130 px, 60 px long, 36 px across with the
        // mattes' widest reach): nothing reaches x = 256.
        let (streaks, glints) = random_streaks(300, 100.0, format.height as f32, 5);
        let splashes: Vec<Streak> = random_streaks(20, 100.0, format.height as f32, 9)
            .0
            .into_iter()
            .map(|s| Streak {
                q0_px: [s.q0_px[0], format.height as f32 - 20.0],
                ..s
            })
            .collect();
        let (tiles_x, tiles_y) = (
            format.width.div_ceil(TILE_W as u32),
            format.height.div_ceil(TILE_H as u32),
        );
        for (kind, frame) in [
            ("mild", picture(format, color)),
            ("wild", wild_picture(format, color)),
        ] {
            let render = |pass: bool| {
                let mut host = HostColour::new(format, &color);
                host.set_pass_through(pass);
                host.lay_plate(&frame, &p, &GroundFrame::default());
                host.draw_splashes(&frame, &p, &splashes);
                let count = host.draw_streaks(&frame, &p, &streaks, Some(&atlas()), &glints);
                assert!(count.tiles > 0, "{name}: nothing drawn");
                let out = codes(&with_planes(&frame, host.encode_canvas(&frame)));
                (out, host.tiles_converted())
            };
            let ((ours, (converted, all)), (full, (full_converted, _))) =
                (render(true), render(false));
            assert_eq!(all as u32, tiles_x * tiles_y, "{name}");
            assert_eq!(
                full_converted, all,
                "{name}: the full path converts every tile"
            );
            assert!(
                converted > 0 && converted < all,
                "{name}, {kind}: {converted} of {all} tiles converted"
            );
            let input = clamped(&frame);
            for ty in 0..tiles_y {
                for tx in 0..tiles_x {
                    let passed = tile_equal(format, &ours, &input, tx, ty);
                    assert!(
                        passed || tile_equal(format, &ours, &full, tx, ty),
                        "{name}, {kind}: tile ({tx}, {ty}) is neither the input nor the full path"
                    );
                    if tx * TILE_W as u32 >= 256 {
                        assert!(passed, "{name}, {kind}: tile ({tx}, {ty}) changed");
                    }
                }
            }
            assert_eq!(
                ours, full,
                "{name}, {kind}: the pass-through changed a sample"
            );
        }
    }
}

/// Rain off through the compositor on the CPU back end: the frame comes back bit for bit (its
/// stray high bits cleared, as the decode reads it), as the full path gives it, and no tile is
/// decoded or encoded; with haze every tile is.
#[test]
fn rain_off_converts_no_tile() {
    let Some(ctx) = gpu() else { return };
    for (name, format, color) in formats() {
        let setup = dry(format);
        for haze in [Haze::None, Haze::Scene] {
            let mut comp =
                Compositor::with_backend(ctx.clone(), format, &color, &setup, None, Backend::Cpu)
                    .expect("compositor");
            let frame = wild_picture(format, color);
            let out = codes(
                &comp
                    .render_one(&frame, &params(&setup, haze))
                    .expect("render"),
            );
            let t = comp.gpu_times();
            assert!(t.tiles > 0, "{name}");
            if haze == Haze::None {
                assert_eq!(t.tiles_converted, 0, "{name}");
                assert_eq!(out, clamped(&frame), "{name}: a dry frame changed");
                // The full path gives the same codes: the skip changes no sample.
                comp.set_pass_through(false);
                let full = codes(
                    &comp
                        .render_one(&frame, &params(&setup, haze))
                        .expect("render"),
                );
                assert_eq!(full, out, "{name}: the pass-through changed a sample");
                assert_eq!(comp.gpu_times().tiles_converted, t.tiles, "{name}");
            } else {
                assert_eq!(
                    t.tiles_converted, t.tiles,
                    "{name}: the haze reaches every tile"
                );
            }
        }
    }
}

/// Light rain through the compositor on the CPU back end: the frame with the tiles nothing
/// reaches passed through is the frame converted whole, bit for bit, and fewer tiles are
/// converted.
#[test]
fn compositor_rain_passes_untouched_tiles_through() {
    let Some(ctx) = gpu() else { return };
    let (name, format, color) = formats().remove(2);
    let format = FrameFormat {
        width: 317,
        height: 203,
        ..format
    };
    let frame = picture(format, color);
    let rain = RainConfig {
        rate_mm_per_h: 0.5,
        ..RainConfig::default()
    };
    let setup = planned(&camera(format), &rain, format).with_mattes(Some(atlas()));
    let mut p = params(&setup, Haze::None);
    p.time_frac_s = 0.4;
    let render = |pass: bool| {
        let mut comp =
            Compositor::with_backend(ctx.clone(), format, &color, &setup, None, Backend::Cpu)
                .expect("compositor");
        comp.set_pass_through(pass);
        let out = codes(&comp.render_one(&frame, &p).expect("render"));
        (out, comp.gpu_times())
    };
    let ((ours, t), (full, t_full)) = (render(true), render(false));
    eprintln!(
        "{name}: {} streaks drawn, {} of {} tiles converted",
        t.streaks_drawn, t.tiles_converted, t.tiles
    );
    assert!(t.streaks_drawn > 0, "{name}: no rain drawn");
    assert_ne!(ours, codes(&frame), "{name}: no rain shows");
    assert_eq!(ours, full, "{name}: the pass-through changed a sample");
    assert_eq!(t_full.tiles_converted, t_full.tiles, "{name}");
    assert!(t.tiles_converted < t.tiles, "{name}: every tile converted");
}
