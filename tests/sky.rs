//! The open sky keeps its own radiance: on synthetic frames whose sky boundary is known (a blue
//! gradient over a skyline of textured buildings and a textured ground), the mask found in
//! the frame matches the true sky (IoU ≥ 0.9 on randomised scenes); a bright textured wall
//! reaching the top edge is not taken as sky; the haze leaves the sky within a code while the
//! ground veils by its distance as without a mask; the GPU stage matches its CPU twin with a
//! mask; the mask over time is a smooth, pure function of the frames in its window.
//! Set `RAIN_COMPOSITE_REQUIRE_GPU=1` to turn a missing adapter into a failure.

use rain_composite::config::{CameraConfig, RainConfig};
use rain_composite::gpu::cpu::{rgb_to_yuv, yuv_to_rgb};
use rain_composite::gpu::stages::yuv_to_rgb::GLOW_CELL_PX;
use rain_composite::gpu::types::RainParams;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::lighting::{EnvironmentSh, FrameLight};
use rain_composite::rng::splitmix64;
use rain_composite::scene::DepthMap;
use rain_composite::scene::sky::{SkyGrid, SkyTracker, TopEdge, detect};
use rain_composite::video::YuvFrame;

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/render.rs"]
mod render;
use render::{render_with, water_tables};

#[path = "common/pictures.rs"]
mod pictures;
use pictures::{interior, plane_codes};

const W: u32 = 320;
const H: u32 = 180;

/// A deterministic uniform number in [0, 1) from `seed` and `k`.
fn uniform(seed: u64, k: u64) -> f64 {
    (splitmix64(seed.wrapping_mul(0x9e37_79b9).wrapping_add(k)) >> 11) as f64 / (1u64 << 53) as f64
}

/// A scene in R'G'B' (0–1) with its true sky.
struct Scene {
    rgb: Vec<[f64; 3]>,
    sky: Vec<bool>,
}

/// A blue sky's gradient at row `y`, pale toward the horizon, with a faint dither.
fn sky_colour(y: u32, seed: u64, x: u32) -> [f64; 3] {
    let f = y as f64 / H as f64;
    let dither = (uniform(seed, 7 * (y as u64 * 4096 + x as u64)) - 0.5) / 255.0;
    [0.32 + 0.4 * f, 0.52 + 0.28 * f, 0.86 + 0.06 * f].map(|v| v + dither)
}

/// A façade's texture: `base` with dark windows every 12 × 14 px and a 2-code grain.
fn facade(base: [f64; 3], x: u32, y: u32, seed: u64) -> [f64; 3] {
    let grain = (uniform(seed, 3 * (y as u64 * 4096 + x as u64)) - 0.5) * 8.0 / 255.0;
    let window = (x % 12) >= 4 && (x % 12) < 10 && (y % 14) >= 4 && (y % 14) < 12;
    let k = if window { 0.35 } else { 1.0 };
    base.map(|v| v * k + grain)
}

/// Asphalt or paving: grey with a coarse random texture.
fn ground(x: u32, y: u32, seed: u64) -> [f64; 3] {
    let v = 0.3 + (uniform(seed, 5 * (y as u64 * 4096 + x as u64)) - 0.5) * 0.16;
    [v, v, v * 1.02]
}

/// A skyline of buildings `seed` draws, roofs between rows `roof_range` (fractions of the
/// height), in front of the ground from row `horizon_row` down.
fn skyline(seed: u64, roof_range: (f64, f64), horizon_row: u32) -> Scene {
    let mut roofs = vec![horizon_row; W as usize];
    let mut bases = vec![[0.0; 3]; W as usize];
    let mut x = 0u32;
    let mut k = 0u64;
    while x < W {
        let width = 24 + (uniform(seed, 100 + k) * 50.0) as u32;
        let gap = uniform(seed, 200 + k) < 0.2;
        let roof =
            H as f64 * (roof_range.0 + (roof_range.1 - roof_range.0) * uniform(seed, 300 + k));
        let grey = 0.35 + 0.4 * uniform(seed, 400 + k);
        let base = [grey * 1.05, grey, grey * 0.9];
        for c in x..(x + width).min(W) {
            if !gap {
                roofs[c as usize] = (roof as u32).min(horizon_row);
            }
            bases[c as usize] = base;
        }
        x += width;
        k += 1;
    }
    let mut rgb = Vec::with_capacity((W * H) as usize);
    let mut sky = Vec::with_capacity((W * H) as usize);
    for y in 0..H {
        for x in 0..W {
            let roof = roofs[x as usize];
            let (c, s) = if y < roof {
                (sky_colour(y, seed, x), true)
            } else if y < horizon_row {
                (facade(bases[x as usize], x, y, seed), false)
            } else {
                (ground(x, y, seed), false)
            };
            rgb.push(c);
            sky.push(s);
        }
    }
    Scene { rgb, sky }
}

/// The scene as an 8-bit 4:2:0 BT.709 limited-range frame.
fn frame(scene: &Scene) -> YuvFrame {
    pictures::bt709_420_from_rgb(W, H, &scene.rgb)
}

/// The mask's weight at each pixel, as the haze reads it.
fn weights_px(grid: &SkyGrid, mask: &[f32]) -> Vec<f32> {
    (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|(x, y)| grid.weight_at(mask, x, y))
        .collect()
}

fn grid() -> SkyGrid {
    SkyGrid::new(GLOW_CELL_PX, (W, H))
}

/// Intersection over union of the pixels weighted ≥ ½ and the true sky.
fn iou(weights: &[f32], truth: &[bool]) -> f64 {
    let (mut both, mut either) = (0usize, 0usize);
    for (w, t) in weights.iter().zip(truth) {
        let m = *w >= 0.5;
        both += usize::from(m && *t);
        either += usize::from(m || *t);
    }
    both as f64 / either.max(1) as f64
}

#[test]
fn the_mask_follows_the_true_sky_boundary() {
    for seed in 1..=6u64 {
        let horizon = (H as f64 * (0.6 + 0.2 * uniform(seed, 1))) as u32;
        let scene = skyline(seed, (0.2, 0.55), horizon);
        let mask = detect(&frame(&scene), grid(), TopEdge::Top, None);
        let score = iou(&weights_px(&grid(), &mask), &scene.sky);
        let sky_share = scene.sky.iter().filter(|&&s| s).count() as f64 / scene.sky.len() as f64;
        eprintln!(
            "scene {seed}: sky {:.0} % of the frame, IoU {score:.3}",
            100.0 * sky_share
        );
        assert!(score >= 0.9, "scene {seed}: IoU {score:.3}");
    }
}

/// The scene turned a quarter for display (stored with its top on the left): the same mask.
#[test]
fn the_top_edge_follows_the_rotation() {
    assert_eq!(TopEdge::of_rotation(0, (W, H)), TopEdge::Top);
    assert_eq!(TopEdge::of_rotation(180, (W, H)), TopEdge::Bottom);
    let (a, b) = (
        TopEdge::of_rotation(90, (H, W)),
        TopEdge::of_rotation(270, (H, W)),
    );
    assert!(
        [a, b].contains(&TopEdge::Left) && [a, b].contains(&TopEdge::Right),
        "{a:?}, {b:?}"
    );
    // Seeded from the wrong edge (the ground's), nothing is sky.
    let scene = skyline(3, (0.2, 0.5), 130);
    let mask = detect(&frame(&scene), grid(), TopEdge::Bottom, None);
    assert!(
        mask.iter().all(|&w| w < 0.5),
        "sky found from the ground's edge"
    );
}

/// The render's uniforms say which stored edge is shown at the top as the rotation does: the
/// display's "up" through `coded_from_display` (display = M · coded, so up is Mᵀ (0, −1)).
#[test]
fn the_uniforms_and_the_rotation_agree_on_the_top_edge() {
    for rotation in [0, 90, 180, 270] {
        let coded = if rotation % 180 == 0 { (W, H) } else { (H, W) };
        let camera = CameraConfig::default().camera(W, H);
        let setup = rain_composite::shot::rain::plan(
            &camera,
            &CameraConfig::default(),
            &RainConfig {
                rate_mm_per_h: 0.0,
                ..RainConfig::default()
            },
            0.01,
            rotation,
            coded,
        )
        .map(RainSetup::pack)
        .expect("rain");
        let m = setup.params.coded_from_display;
        let from_uniforms = TopEdge::from_up([-f64::from(m[2]), -f64::from(m[3])]);
        assert_eq!(
            from_uniforms,
            TopEdge::of_rotation(rotation, coded),
            "rotation {rotation}"
        );
    }
}

/// A bright façade of white panels and windows fills the right two thirds up to the top edge
/// (as a facade seen from below in the sun): at most 1 % of its pixels are taken as sky, while
/// the blue sky beside it is.
#[test]
fn a_bright_textured_wall_at_the_top_is_not_sky() {
    for (seed, panel) in [(1u64, 24u32), (2, 40), (3, 56)] {
        let wall_from = W / 3;
        let mut rgb = Vec::new();
        let mut truth_sky = Vec::new();
        let mut wall = Vec::new();
        for y in 0..H {
            for x in 0..W {
                let (c, s, on_wall) = if y >= H * 4 / 5 {
                    (ground(x, y, seed), false, false)
                } else if x < wall_from {
                    (sky_colour(y, seed, x), true, false)
                } else {
                    let (u, v) = ((x - wall_from) % panel, y % panel);
                    let groove = u < 3 || v < 3;
                    let window = u > panel / 2 && v > panel / 3 && v < panel - 4 && seed != 2;
                    let grain =
                        (uniform(seed, 11 * (y as u64 * 4096 + x as u64)) - 0.5) * 3.0 / 255.0;
                    let c = if groove {
                        [0.45, 0.43, 0.4]
                    } else if window {
                        [0.2, 0.22, 0.25]
                    } else {
                        [0.9, 0.88, 0.84]
                    };
                    (c.map(|v| v + grain), false, true)
                };
                rgb.push(c);
                truth_sky.push(s);
                wall.push(on_wall);
            }
        }
        let scene = Scene {
            rgb,
            sky: truth_sky,
        };
        let w = weights_px(&grid(), &detect(&frame(&scene), grid(), TopEdge::Top, None));
        let on_wall = wall.iter().filter(|&&b| b).count();
        let wall_sky = w
            .iter()
            .zip(&wall)
            .filter(|(v, b)| **b && **v >= 0.5)
            .count();
        let share = wall_sky as f64 / on_wall as f64;
        let sky_found = w
            .iter()
            .zip(&scene.sky)
            .filter(|(v, s)| **s && **v >= 0.5)
            .count() as f64
            / scene.sky.iter().filter(|&&s| s).count() as f64;
        eprintln!(
            "panels of {panel} px: {:.2} % of the wall taken as sky, {:.0} % of the sky found",
            100.0 * share,
            100.0 * sky_found
        );
        assert!(share <= 0.01, "panels of {panel} px: {share}");
        assert!(
            sky_found >= 0.8,
            "panels of {panel} px: sky found {sky_found}"
        );
    }
}

/// A level camera 1.6 m above a given ground, a uniform grey environment, haze from 3 to 50 m
/// at β = 0.02/m (the setting of the haze's veil test).
fn ground_params() -> (RainSetup, RainParams) {
    let config = CameraConfig {
        height_m: 1.6,
        ..CameraConfig::default()
    };
    let camera = config.camera(W, H);
    let setup = rain_composite::shot::rain::plan(
        &camera,
        &config,
        &RainConfig {
            rate_mm_per_h: 0.0,
            ..RainConfig::default()
        },
        1.0 / 50.0,
        0,
        (W, H),
    )
    .map(RainSetup::pack)
    .expect("setup")
    .with_ground(true);
    let mut env = EnvironmentSh::zeros(4);
    env.coeffs[0] = [0.8, 0.8, 0.8];
    let mut p = setup.params_at(
        0.0,
        &FrameLight {
            env,
            lights: Vec::new(),
        },
        [[1.0, 0.4, 0.2, 0.1]; 3],
    );
    p.haze = [3.0, 50.0, 0.02, (-0.02f32 * 47.0).exp()];
    (setup, p)
}

/// The grid points whose ray goes down to the given ground (as the render's feed marks them).
fn below_horizon(p: &RainParams) -> Vec<bool> {
    let g = grid();
    (0..g.len())
        .map(|k| yuv_to_rgb::view_ray_at(p, g.point_px(k)).z < 0.0)
        .collect()
}

/// On the sky the haze changes the picture by at most one code; on the ground it veils as
/// without a mask (the distance to the ground, Koschmieder), and visibly so.
#[test]
fn the_sky_keeps_its_radiance_and_the_ground_still_veils() {
    let (_, p) = ground_params();
    // The level camera's horizon is the picture's middle row.
    let scene = skyline(9, (0.15, 0.42), H / 2);
    let f = frame(&scene);
    let mask = detect(&f, grid(), TopEdge::Top, Some(&below_horizon(&p)));
    let color = f.color;
    let codes = |c: &[[f64; 3]]| rgb_to_yuv::rgb_to_yuv(c, f.format, &color)[0].clone();
    let clear = {
        let mut q = p;
        q.haze[3] = 1.0;
        codes(&yuv_to_rgb::yuv_to_rgb(&f, &q))
    };
    let with_sky = codes(&yuv_to_rgb::yuv_to_rgb_in_scene(
        &f,
        &p,
        None,
        None,
        Some(&mask),
    ));
    let without = codes(&yuv_to_rgb::yuv_to_rgb(&f, &p));
    let inside = interior(&scene.sky, (W, H), 12);
    let (mut sky_worst, mut sky_n, mut ground_n, mut ground_veiled) = (0u16, 0, 0, 0);
    for i in 0..(W * H) as usize {
        let y = i as u32 / W;
        if scene.sky[i] && inside[i] {
            sky_worst = sky_worst.max(with_sky[i].abs_diff(clear[i]));
            sky_n += 1;
        }
        if y > H / 2 + 1 {
            assert_eq!(with_sky[i], without[i], "ground pixel {i}");
            ground_n += 1;
            ground_veiled += usize::from(with_sky[i].abs_diff(clear[i]) >= 2);
        }
    }
    eprintln!(
        "sky: worst {sky_worst} codes over {sky_n} px; ground: {ground_veiled} of {ground_n} px \
         veiled by 2 codes or more; without the mask the sky moves by {} codes",
        (0..(W * H) as usize)
            .filter(|&i| scene.sky[i] && inside[i])
            .map(|i| without[i].abs_diff(clear[i]))
            .max()
            .unwrap_or(0)
    );
    assert!(sky_n > 1000, "{sky_n} sky pixels tested");
    assert!(sky_worst <= 1, "the sky moved by {sky_worst} codes");
    assert!(
        ground_veiled * 5 >= ground_n,
        "{ground_veiled} of {ground_n}"
    );
}

/// The GPU stage with a mask (and a depth map over part of the sky, which wins) against the
/// CPU twin: within one code.
#[test]
fn the_gpu_stage_matches_its_twin_with_a_mask() {
    let Some(ctx) = gpu() else { return };
    let (setup, p) = ground_params();
    let setup = setup.with_scene_depth(true);
    let scene = skyline(4, (0.15, 0.42), H / 2);
    let f = frame(&scene);
    let mask = detect(&f, grid(), TopEdge::Top, Some(&below_horizon(&p)));
    assert!(mask.iter().any(|&w| w > 0.5), "no sky to test");
    // A depth map that knows a box in the sky (20 m) and nothing else.
    let values: Vec<f32> = (0..W * H)
        .map(|i| {
            let (x, y) = (i % W, i / W);
            if (40..120).contains(&x) && (4..40).contains(&y) {
                20.0
            } else {
                0.0
            }
        })
        .collect();
    let map = DepthMap::from_values(W as usize, H as usize, &values, 1.0).expect("depth");
    let out = render_with(&ctx, &f, &setup, &p, |comp| {
        comp.set_transfer_table(&water_tables(256));
        comp.set_scene_depth(&map).expect("depth");
        comp.set_sky_mask(&mask).expect("sky");
    });
    let canvas = yuv_to_rgb::yuv_to_rgb_in_scene(&f, &p, None, Some(&map), Some(&mask));
    let twin = rgb_to_yuv::rgb_to_yuv(&canvas, f.format, &f.color);
    let gpu_luma = plane_codes(&out, 0);
    let worst = gpu_luma
        .iter()
        .zip(&twin[0])
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap_or(0);
    assert!(worst <= 1, "GPU vs twin: {worst} codes off");
    // The box the depth map knows is veiled; the sky beside it is not.
    let clear = {
        let mut q = p;
        q.haze[3] = 1.0;
        rgb_to_yuv::rgb_to_yuv(&yuv_to_rgb::yuv_to_rgb(&f, &q), f.format, &f.color)[0].clone()
    };
    let at = |x: u32, y: u32| (y * W + x) as usize;
    let (in_box, beside) = (at(80, 20), at(160, 10));
    assert!(scene.sky[in_box] && scene.sky[beside]);
    assert!(
        gpu_luma[in_box].abs_diff(clear[in_box]) >= 2,
        "the box is not veiled"
    );
    assert!(
        gpu_luma[beside].abs_diff(clear[beside]) <= 1,
        "the sky is veiled"
    );
    // A mask of another size is refused.
    let mut comp = rain_composite::gpu::Compositor::new(ctx.clone(), f.format, &f.color, &setup)
        .expect("compositor");
    assert!(comp.set_sky_mask(&mask[1..]).is_err());
}

/// A region whose detection flips every frame is held near its mean (the veil does not pump),
/// and the mask at a frame is a function of the frames in the window alone.
#[test]
fn the_mask_over_time_is_smooth_and_depends_on_its_window_alone() {
    let fps = 25.0;
    let masks = |k: usize| vec![1.0f32, (k % 2) as f32, if k < 40 { 0.0 } else { 1.0 }];
    let mut tracker = SkyTracker::new(0.25);
    let mut seen = Vec::new();
    for k in 0..100 {
        seen.push(tracker.update(masks(k), k as f64 / fps, false).to_vec());
    }
    for k in 30..100 {
        assert!((seen[k][0] - 1.0).abs() < 1e-5, "frame {k}: {}", seen[k][0]);
        assert!((seen[k][1] - 0.5).abs() < 0.1, "frame {k}: {}", seen[k][1]);
        assert!(
            (seen[k][2] - seen[k - 1][2]).abs() < 0.2,
            "frame {k}: a jump"
        );
    }
    assert!(seen[99][2] > 0.99, "the region never came: {}", seen[99][2]);
    // Started one window before frame 80, the tracker agrees with the one that saw it all.
    let mut late = SkyTracker::new(0.25);
    let from = 80 - (late.window_s() * fps).ceil() as usize - 1;
    let mut last = Vec::new();
    for k in from..=80 {
        last = late.update(masks(k), k as f64 / fps, false).to_vec();
    }
    assert_eq!(last, seen[80]);
    // A cut restarts it.
    assert_eq!(tracker.update(vec![0.0; 3], 4.0, true), &[0.0; 3]);
}
