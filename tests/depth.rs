//! Depth-map occlusion: a near box in front of a far scene hides the rain behind it and not the
//! rain in front of it, pixel for pixel; holes (zero, NaN) hide nothing; a map of another size
//! is resampled; the GPU matches its CPU twin; depth maps are read from a PNG, a directory and
//! a video; without a map nothing changes.
//! Set `RAIN_COMPOSITE_REQUIRE_GPU=1` to turn a missing adapter into a failure.

use std::path::Path;
use std::sync::Arc;

use glam::{DVec2, DVec3};
use rain_composite::config::{CameraConfig, RainConfig};
use rain_composite::gpu::GpuContext;
use rain_composite::gpu::cpu::{rain_streaks, rgb_to_yuv, yuv_to_rgb};
use rain_composite::gpu::probe::probe_streaks;
use rain_composite::gpu::types::{LightList, RainParams};
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::scene::depth::DepthSource;
use rain_composite::scene::{Camera, DepthMap};
use rain_composite::video::{Chroma, ColorParams, FrameFormat, YuvFrame};
use tempfile::TempDir;

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/fixtures.rs"]
mod fixtures;

#[path = "common/binary.rs"]
mod binary;
use binary::bin;

#[path = "common/render.rs"]
mod render;
use render::{lit, render_with, water_tables};

#[path = "common/pictures.rs"]
mod pictures;
use pictures::plane_codes;

const W: u32 = 160;
const H: u32 = 96;
/// The near box's picture, [x0, x1) × [y0, y1), and its depth.
const BOX: [u32; 4] = [48, 112, 24, 72];
const BOX_M: f32 = 2.5;
/// The scene around the box.
const FAR_M: f32 = 100.0;

fn format(rotation_deg: i32) -> FrameFormat {
    let (w, h) = if rotation_deg.rem_euclid(180) == 90 {
        (H, W)
    } else {
        (W, H)
    };
    FrameFormat {
        width: w,
        height: h,
        chroma: Chroma::Cs444,
        bit_depth: 8,
    }
}

/// The luma code of [`picture`].
const GREY: u16 = 90;

/// A flat grey picture (coded orientation); the rain is lit by a brighter environment.
fn picture(f: FrameFormat) -> YuvFrame {
    YuvFrame::filled(f, ColorParams::bt709(8), [GREY, 128, 128])
}

/// Heavy rain of large drops between `near_m` and `far_m`, on a displayed `W`×`H` picture.
fn rain(near_m: f64, far_m: f64, rotation_deg: i32) -> RainSetup {
    let f = format(rotation_deg);
    let camera = Camera::new(W, H, 1.0, 1.6, 0.05, 0.0);
    let rain = RainConfig {
        rate_mm_per_h: 80.0,
        opacity: 15.0,
        drop_scale: 2.0,
        near_m,
        far_m,
        max_drops: 20_000,
        // No haze: a pixel without drops keeps its code.
        scene_depth_m: 0.0,
        ..RainConfig::default()
    };
    rain_composite::shot::rain::plan(
        &camera,
        &CameraConfig::default(),
        &rain,
        1.0 / 50.0,
        rotation_deg,
        (f.width, f.height),
    )
    .map(RainSetup::pack)
    .expect("rain")
    .with_scene_depth(true)
}

/// The uniforms at 0.7 s under a brighter environment than [`picture`].
fn params(setup: &RainSetup) -> RainParams {
    lit(setup, 0.7, &[(0, [2.0, 2.0, 2.2])], None)
}

/// The luma codes of `frame` rendered with `setup` at `p` behind `depth` (none: as without a
/// map).
fn luma_behind(
    ctx: &Arc<GpuContext>,
    frame: &YuvFrame,
    setup: &RainSetup,
    p: &RainParams,
    depth: Option<&DepthMap>,
) -> Vec<u16> {
    let tables = water_tables(256);
    let out = render_with(ctx, frame, setup, p, |comp| {
        comp.set_transfer_table(&tables);
        if let Some(d) = depth {
            comp.set_scene_depth(d).expect("depth");
        }
    });
    plane_codes(&out, 0)
}

/// The luma codes of the frame rendered with `setup` behind `depth` (none: as without a map).
fn render(ctx: &Arc<GpuContext>, setup: &RainSetup, depth: Option<&DepthMap>) -> Vec<u16> {
    luma_behind(ctx, &picture(format(0)), setup, &params(setup), depth)
}

/// A `w`×`h` depth map of the scene: the box (its picture scaled to the map) at [`BOX_M`] in
/// front of a scene at [`FAR_M`], with `hole` (map pixels) unknown: its left half 0, its right
/// half NaN.
fn box_map(w: usize, h: usize, hole: Option<[u32; 4]>) -> DepthMap {
    let (sx, sy) = (w as f64 / W as f64, h as f64 / H as f64);
    let b = [
        (BOX[0] as f64 * sx) as usize,
        (BOX[1] as f64 * sx) as usize,
        (BOX[2] as f64 * sy) as usize,
        (BOX[3] as f64 * sy) as usize,
    ];
    let mut v = vec![FAR_M; w * h];
    for y in b[2]..b[3] {
        for x in b[0]..b[1] {
            v[y * w + x] = BOX_M;
        }
    }
    if let Some([x0, x1, y0, y1]) = hole {
        for y in y0 as usize..y1 as usize {
            for x in x0..x1 {
                v[y * w + x as usize] = if x < (x0 + x1) / 2 { 0.0 } else { f32::NAN };
            }
        }
    }
    DepthMap::from_values(w, h, &v, 1.0).expect("map")
}

fn inside(x: u32, y: u32, r: [u32; 4], margin: i64) -> bool {
    let (x, y) = (x as i64, y as i64);
    x >= r[0] as i64 + margin
        && x < r[1] as i64 - margin
        && y >= r[2] as i64 + margin
        && y < r[3] as i64 - margin
}

/// Pixels where `a` and `b` differ, among those `keep` selects.
fn differing(a: &[u16], b: &[u16], keep: impl Fn(u32, u32) -> bool) -> usize {
    (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .filter(|&(x, y)| keep(x, y))
        .filter(|&(x, y)| a[(y * W + x) as usize] != b[(y * W + x) as usize])
        .count()
}

/// Rain 3.5–8 m away lies behind the box at 2.5 m (even at the picture's corners, where a
/// drop's camera z is its distance × cos 35°): every pixel of the box is as without rain, every
/// pixel around it as without the map. Rain 0.3–2 m away lies in front of it: the map changes
/// nothing.
#[test]
fn a_near_box_hides_the_rain_behind_it_and_not_in_front() {
    let Some(ctx) = gpu() else { return };
    // Without haze, a frame without rain comes back unchanged.
    let rainless = vec![GREY; (W * H) as usize];
    let map = box_map(W as usize, H as usize, None);
    let in_box = |x, y| inside(x, y, BOX, 0);

    let behind = rain(3.5, 8.0, 0);
    let plain = render(&ctx, &behind, None);
    let occluded = render(&ctx, &behind, Some(&map));
    let raining = differing(&plain, &rainless, in_box);
    eprintln!("rain behind: {raining} box pixels wet without the map");
    assert!(
        raining > 200,
        "the test needs rain behind the box: {raining}"
    );
    assert_eq!(
        differing(&occluded, &rainless, in_box),
        0,
        "rain shows on the box"
    );
    assert_eq!(
        differing(&occluded, &plain, |x, y| !in_box(x, y)),
        0,
        "the far scene hid rain in front of it"
    );

    let front = rain(0.3, 2.0, 0);
    let plain = render(&ctx, &front, None);
    let raining = differing(&plain, &rainless, in_box);
    eprintln!("rain in front: {raining} box pixels wet");
    assert!(
        raining > 200,
        "the test needs rain in front of the box: {raining}"
    );
    assert!(
        plain == render(&ctx, &front, Some(&map)),
        "rain in front was hidden"
    );
}

/// Unknown depth (0 or NaN) hides nothing; a map of another size is resampled to the picture,
/// so the box's interior still hides the rain behind it and the far scene hides nothing.
#[test]
fn holes_hide_nothing_and_a_map_of_another_size_is_resampled() {
    let Some(ctx) = gpu() else { return };
    let setup = rain(3.5, 8.0, 0);
    let plain = render(&ctx, &setup, None);
    let rainless = vec![GREY; (W * H) as usize];

    let hole = [64, 96, 36, 60];
    let holed = render(
        &ctx,
        &setup,
        Some(&box_map(W as usize, H as usize, Some(hole))),
    );
    let in_hole = |x, y| inside(x, y, hole, 0);
    let wet = differing(&plain, &rainless, in_hole);
    assert!(wet > 50, "the test needs rain in the hole: {wet}");
    assert_eq!(differing(&holed, &plain, in_hole), 0, "a hole hid rain");
    let in_box_not_hole = |x, y| inside(x, y, BOX, 0) && !in_hole(x, y);
    assert_eq!(differing(&holed, &rainless, in_box_not_hole), 0);

    // A quarter-size map: bilinear resampling blends depths within 4 px of the box's edges.
    for (w, h) in [
        (W as usize / 4, H as usize / 4),
        (2 * W as usize, 2 * H as usize),
    ] {
        let small = render(&ctx, &setup, Some(&box_map(w, h, None)));
        assert_eq!(
            differing(&small, &rainless, |x, y| inside(x, y, BOX, 4)),
            0,
            "{w}×{h}: rain shows on the box"
        );
        assert_eq!(
            differing(&small, &plain, |x, y| !inside(x, y, BOX, -4)),
            0,
            "{w}×{h}: the far scene hid rain"
        );
    }
}

/// A depth ramp, 1 m at the left to 8 m at the right, with a hole (unknown) across rows
/// 20–29.
fn ramp() -> DepthMap {
    let ramp: Vec<f32> = (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|(x, y)| {
            if (20..30).contains(&y) {
                f32::NAN
            } else {
                1.0 + 7.0 * x as f32 / W as f32
            }
        })
        .collect();
    DepthMap::from_values(W as usize, H as usize, &ramp, 1.0).expect("map")
}

/// The GPU frame behind a depth ramp (1 m at the left to 8 m at the right, with a hole) against
/// the CPU twins (`yuv_to_rgb` → `rain_streaks_occluded` of the GPU's own streaks →
/// `rgb_to_yuv`), on a picture displayed turned 90° so the depth is looked up through the
/// display rotation; and the map must have hidden part of the rain.
#[test]
fn occlusion_matches_the_cpu_twin() {
    let Some(ctx) = gpu() else { return };
    let rotation = 90;
    let setup = rain(0.3, 8.0, rotation);
    let p = params(&setup);
    let map = ramp();
    let f = format(rotation);
    let frame = picture(f);
    let tables = water_tables(256);
    let gpu_frame = |depth: Option<&DepthMap>| luma_behind(&ctx, &frame, &setup, &p, depth);
    let gpu = gpu_frame(Some(&map));
    let streaks = probe_streaks(&ctx, &setup, &p, &LightList::new(&[]), &tables).expect("probe");
    let mut canvas = yuv_to_rgb::yuv_to_rgb(&frame, &p);
    rain_streaks::rain_streaks_occluded(&mut canvas, &p, &streaks, Some(&map));
    let cpu = rgb_to_yuv::rgb_to_yuv(&canvas, f, &frame.color);
    let worst = gpu
        .iter()
        .zip(&cpu[0])
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap_or(0);
    let hidden = gpu
        .iter()
        .zip(gpu_frame(None))
        .filter(|(a, b)| *a != b)
        .count();
    eprintln!("GPU vs twin: worst {worst} codes; {hidden} pixels changed by the map");
    assert!(worst <= 1, "{worst} codes off");
    assert!(
        hidden > 100,
        "the ramp hid too little rain to compare: {hidden}"
    );
}

/// The haze ends where each pixel's ray meets the scene of the depth map (Koschmieder): the
/// GPU frame without drops against the twin on the ramp turned 90°, and the twin against the
/// closed form e^(−β (z |ray| − near)) at pixels the map knows, the constant veil in its hole.
#[test]
fn veil_by_the_depth_map_matches_the_cpu_twin() {
    let Some(ctx) = gpu() else { return };
    let rotation = 90;
    let setup = rain(0.3, 8.0, rotation);
    let mut p = params(&setup);
    p.drop_count = 0;
    let (near_m, far_m, beta) = (0.5f32, 30.0f32, 0.2f32);
    p.haze = [near_m, far_m, beta, (-beta * (far_m - near_m)).exp()];
    let map = ramp();
    let f = format(rotation);
    let frame = picture(f);
    let out = render_with(&ctx, &frame, &setup, &p, |comp| {
        comp.set_transfer_table(&water_tables(256));
        comp.set_scene_depth(&map).expect("depth");
    });
    let canvas = yuv_to_rgb::yuv_to_rgb_with_depth(&frame, &p, Some(&map));
    let cpu = rgb_to_yuv::rgb_to_yuv(&canvas, f, &frame.color);
    let mut worst = 0;
    for y in 0..f.height {
        for x in 0..f.width {
            worst = worst.max(
                out.sample(0, x, y)
                    .abs_diff(cpu[0][(y * f.width + x) as usize]),
            );
        }
    }
    assert!(worst <= 1, "GPU vs twin: {worst} codes off");
    // The twin against the closed form.
    let (mut known, mut hole) = (0, 0);
    for y in 0..f.height {
        for x in 0..f.width {
            let t = yuv_to_rgb::haze_transmittance(&p, Some(&map), x, y);
            let ray = yuv_to_rgb::view_ray(&p, x, y);
            let at = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            match yuv_to_rgb::scene_depth_at(&p, &map, at) {
                Some(z) => {
                    let s = z * ray.length();
                    let want = (-(beta as f64) * (s - near_m as f64).max(0.0)).exp();
                    assert!((t - want).abs() < 1e-6, "({x}, {y}): {t} vs {want}");
                    known += 1;
                }
                None => {
                    assert_eq!(t, p.haze[3] as f64);
                    hole += 1;
                }
            }
        }
    }
    assert!(known > 0 && hole > 0, "{known} known, {hole} in the hole");
}

/// Along a projected segment 1/z is affine in the picture: the twin's drop depth at a point
/// of the streak equals the depth of the 3-D point that projects there.
#[test]
fn drop_depth_along_a_streak_is_perspective_correct() {
    let camera = Camera::new(W, H, 1.0, 1.6, 0.05, 0.0);
    let to_px = |c: DVec3| DVec2::new(c.x, c.y) / c.z * 140.0;
    let (a, b) = (DVec3::new(-0.4, -0.3, 0.8), DVec3::new(0.5, 0.9, 6.0));
    let (qa, qb) = (to_px(a), to_px(b));
    let len = (qb - qa).length();
    for i in 0..=10 {
        let s = i as f64 / 10.0;
        let p = a.lerp(b, s);
        let along = (to_px(p) - qa).length();
        let got = rain_streaks::drop_depth_m(along, len, [a.z, b.z]);
        assert!((got - p.z).abs() < 1e-9 * p.z, "s {s}: {got} vs {}", p.z);
    }
    let _ = camera;
}

/// The fade: unknown depth shows all, a drop 3 cm behind the surface nothing, 3 cm in front
/// all, on the surface half.
#[test]
fn visibility_fades_over_a_few_centimetres() {
    use rain_streaks::visibility;
    assert_eq!(visibility(None, 50.0), 1.0);
    assert_eq!(visibility(Some(4.0), 4.03), 0.0);
    assert_eq!(visibility(Some(4.0), 3.97), 1.0);
    assert!((visibility(Some(4.0), 4.0) - 0.5).abs() < 1e-12);
    assert!(visibility(Some(4.0), 4.01) < visibility(Some(4.0), 3.99));
}

fn write_png(path: &Path, w: u32, h: u32, mm: impl Fn(u32, u32) -> u16) {
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(w, h, |x, y| {
        image::Luma([mm(x, y)])
    });
    img.save(path).expect("png");
}

/// A PNG serves every frame; a directory gives one map per frame in name order; a 16-bit grey
/// video gives its codes as millimetres; `--depth-scale` multiplies them; a zero is a hole.
#[test]
fn depth_is_read_from_a_png_a_directory_and_a_video() {
    let dir = TempDir::new().expect("tmp");
    let mm = |i: u32| {
        move |x: u32, y: u32| {
            if x == 0 {
                0
            } else {
                (1000 * (i + 1) + 7 * x + y) as u16
            }
        }
    };
    let frames = dir.path().join("frames");
    std::fs::create_dir(&frames).expect("dir");
    // Names out of creation order: the order is by name.
    for i in [2u32, 0, 1] {
        write_png(&frames.join(format!("d{i:03}.png")), 16, 8, mm(i));
    }
    let check = |map: &DepthMap, i: u32, scale: f64| {
        assert_eq!((map.width, map.height), (16, 8));
        assert_eq!(map.at(0, 3), None, "zero is unknown");
        let want = (1000 * (i + 1) + 7 * 5 + 3) as f64 * scale / 1000.0;
        let got = map.at(5, 3).expect("known") as f64;
        assert!((got - want).abs() < 1e-5 * want, "map {i}: {got} vs {want}");
    };
    let mut d = DepthSource::open(&frames, 2.0).expect("dir");
    assert_eq!(d.frame_count(), Some(3));
    for i in [0, 1, 2, 1] {
        check(&d.at(i as u64).expect("map"), i, 2.0);
    }
    assert!(d.at(3).is_err(), "a frame beyond the maps");

    let mut still = DepthSource::open(&frames.join("d001.png"), 1.0).expect("png");
    for i in [0, 5, 99] {
        check(&still.at(i).expect("map"), 1, 1.0);
    }

    let video = dir.path().join("depth.mkv");
    fixtures::ffmpeg(&[
        "-framerate",
        "25",
        "-i",
        frames.join("d%03d.png").to_str().expect("utf-8"),
        "-c:v",
        "ffv1",
        "-pix_fmt",
        "gray16le",
        video.to_str().expect("utf-8"),
    ]);
    let mut v = DepthSource::open(&video, 1.0).expect("video");
    for i in [0, 1, 2, 0] {
        check(&v.at(i as u64).expect("map"), i, 1.0);
    }

    assert!(DepthSource::open(&frames, 0.0).is_err(), "scale 0");
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).expect("dir");
    assert!(DepthSource::open(&empty, 1.0).is_err(), "no maps");
}

/// The command line: a missing depth map is one `error:` line and no output; a map that is
/// all holes renders exactly as without `--depth`; a near wall hides rain.
#[test]
fn the_cli_takes_a_depth_map() {
    let dir = TempDir::new().expect("tmp");
    let input = fixtures::sky_over_ground(dir.path(), "in.mkv", (160, 96), 30, 0.08);
    let holes = dir.path().join("holes.png");
    write_png(&holes, 40, 24, |_, _| 0);
    let wall = dir.path().join("wall.png");
    write_png(&wall, 160, 96, |_, _| 200);
    let render = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let o = bin()
            .arg(&input)
            .arg("-o")
            .arg(&out)
            .args([
                "--rain",
                "60",
                "--opacity",
                "20",
                "--drop-scale",
                "3",
                "--cpu",
            ])
            .args(["--codec", "ffv1"])
            .args(extra)
            .output()
            .expect("spawn");
        (o, out)
    };
    let (o, out) = render("missing.mkv", &["--depth", "nowhere.png"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert_eq!(
        err.lines().filter(|l| l.starts_with("error:")).count(),
        1,
        "{err}"
    );
    assert!(err.contains("nowhere.png"), "{err}");
    assert!(!out.exists(), "an output for a failed job");

    let md5 = |o: std::process::Output, out: &Path| {
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        fixtures::framemd5(out, "0:v:0", true)
    };
    let (o, out) = render("plain.mkv", &[]);
    let plain = md5(o, &out);
    let (o, out) = render("holes.mkv", &["--depth", holes.to_str().expect("utf-8")]);
    assert!(plain == md5(o, &out), "a map of holes changed the render");
    // A wall 0.2 m from the lens, nearer than almost every drop.
    let (o, out) = render("wall.mkv", &["--depth", wall.to_str().expect("utf-8")]);
    assert!(plain != md5(o, &out), "a near wall hid nothing");
}

/// Runs the binary; returns whether it succeeded and its stderr.
fn run_bin(args: &[&str]) -> (bool, String) {
    let o = bin().args(args).output().expect("spawn");
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Only the documented format is depth: an 8-bit or colour PNG, an 8-bit or colour video (the
/// clip itself) would be read on a scale no one means, so each is one error line naming the
/// format wanted.
#[test]
fn depth_in_another_format_is_refused() {
    let dir = TempDir::new().expect("tmp");
    let input = fixtures::sky_over_ground(dir.path(), "in.mkv", (64, 48), 20, 0.12);
    let grey8 = dir.path().join("grey8.png");
    image::GrayImage::from_pixel(64, 48, image::Luma([200]))
        .save(&grey8)
        .expect("png");
    let rgb16 = dir.path().join("rgb16.png");
    image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_pixel(64, 48, image::Rgb([900; 3]))
        .save(&rgb16)
        .expect("png");
    let grey8_video = dir.path().join("grey8.mkv");
    fixtures::ffmpeg(&[
        "-i",
        grey8.to_str().expect("utf-8"),
        "-c:v",
        "ffv1",
        "-pix_fmt",
        "gray",
        grey8_video.to_str().expect("utf-8"),
    ]);
    let png = dir.path().join("p.png");
    for depth in [&grey8, &rgb16, &grey8_video, &input] {
        let (ok, err) = run_bin(&[
            "preview",
            input.to_str().expect("utf-8"),
            "--frame",
            "0",
            "-o",
            png.to_str().expect("utf-8"),
            "--depth",
            depth.to_str().expect("utf-8"),
        ]);
        assert!(!ok, "{depth:?} was taken for depth");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.starts_with("error:") && err.contains("16-bit greyscale"),
            "{err}"
        );
    }
    assert!(!png.exists());
}

/// With puddles, a map of holes knows nothing, so the water lies on the plane as without a
/// map; a map that shows no ground within reach (a wall near or far) gives no puddles, with a
/// warning, as a camera that sees no ground does.
#[test]
fn puddles_over_a_map_of_holes_or_of_a_wall() {
    let dir = TempDir::new().expect("tmp");
    let input = fixtures::sky_over_ground(dir.path(), "in.mkv", (96, 64), 24, 0.12);
    let preview = |name: &str, depth: Option<&Path>| {
        let out = dir.path().join(name);
        let mut args = vec![
            "preview",
            input.to_str().expect("utf-8"),
            "--frame",
            "2",
            "-o",
            out.to_str().expect("utf-8"),
            "--ground",
            "horizon=0.5",
            "--puddles",
            "--puddle-particles",
            "500",
            "--pre-rain",
            "5",
            "--cpu",
        ];
        if let Some(d) = depth {
            args.extend(["--depth", d.to_str().expect("utf-8")]);
        }
        let (ok, err) = run_bin(&args);
        assert!(ok, "{name}: {err}");
        (std::fs::read(&out).expect("png"), err)
    };
    let (plain, _) = preview("plain.png", None);
    let holes = dir.path().join("holes-map.png");
    write_png(&holes, 48, 32, |_, _| 0);
    let (with_holes, err) = preview("with-holes.png", Some(&holes));
    assert!(
        with_holes == plain,
        "a map of holes changed the water: {err}"
    );
    for mm in [500, 3_000, 51_400] {
        let wall = dir.path().join(format!("wall{mm}.png"));
        write_png(&wall, 48, 32, |_, _| mm);
        let (_, err) = preview(&format!("wall{mm}.out.png"), Some(&wall));
        assert!(err.contains("no puddles"), "{mm} mm: {err}");
        assert!(!err.contains("error"), "{mm} mm: {err}");
    }
}

/// A configuration names its depth map relative to itself: it travels with its maps, and is
/// read the same from any folder.
#[test]
fn a_configuration_names_its_depth_map_relative_to_itself() {
    let dir = TempDir::new().expect("tmp");
    let input = fixtures::sky_over_ground(dir.path(), "in.mkv", (64, 48), 20, 0.12);
    let shot = dir.path().join("shot");
    std::fs::create_dir(&shot).expect("dir");
    write_png(&shot.join("depth.png"), 64, 48, |_, _| 3000);
    let config = shot.join("look.json");
    std::fs::write(&config, r#"{"ground": {"depth": "depth.png"}}"#).expect("write");
    let (ok, err) = run_bin(&[
        "preview",
        input.to_str().expect("utf-8"),
        "--frame",
        "0",
        "-o",
        "-",
        "--config",
        config.to_str().expect("utf-8"),
    ]);
    assert!(ok, "{err}");
}
