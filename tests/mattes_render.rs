//! Streaks drawn with the mattes (`--streaks mattes`): the default stays the capsule, a matte
//! moves a streak's light along it without changing how much there is, and the GPU stage
//! matches its CPU twin. Set `RAIN_COMPOSITE_REQUIRE_GPU=1` to turn a missing adapter into a
//! failure.

use std::path::Path;
use std::sync::{Arc, OnceLock};

use rain_composite::config::{CameraConfig, RainConfig, RenderConfig, StreakStyle};
use rain_composite::drops::MatteAtlas;
use rain_composite::gpu::cpu::rain_simulate::{light_term, take_glints};
use rain_composite::gpu::cpu::rain_streaks::{matte_layers, rain_streaks_with};
use rain_composite::gpu::cpu::{rgb_to_yuv, yuv_to_rgb};
use rain_composite::gpu::lights::TABLE_BINS;
use rain_composite::gpu::probe::{probe_drops_with, probe_streaks, probe_streaks_and_glints};
use rain_composite::gpu::types::{
    DirectLight, GLINTS_PER_DROP, Glint, LightList, RainParams, Streak,
};
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::lighting::rtf::RtfTable;
use rain_composite::scene::Camera;
use rain_composite::video::{Chroma, ColorParams, FrameFormat, YuvFrame};

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/render.rs"]
mod render;
use render::{BLUISH_SKY, render_with, water_tables};

#[path = "common/pictures.rs"]
mod pictures;
use pictures::codes;

/// The shipped database's mattes at 1/60 s.
fn atlas() -> Arc<MatteAtlas> {
    static ATLAS: OnceLock<Arc<MatteAtlas>> = OnceLock::new();
    ATLAS
        .get_or_init(|| {
            let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("drops");
            Arc::new(MatteAtlas::load(&dir, 1.0 / 60.0).expect("drops/"))
        })
        .clone()
}

/// pack2x16unorm of (diameter mm / 10, view elevation / 90°), as `rain_simulate` writes it.
fn drop_info(diameter_mm: f64, view_deg: f64) -> u32 {
    let q = |x: f64| (x.clamp(0.0, 1.0) * 65535.0).round() as u32;
    q(diameter_mm / 10.0) | (q(view_deg / 90.0) << 16)
}

/// A vertical streak from (x, 8) `len_px` long, of radius `r_px`, radiance 1.
fn streak(x: f32, len_px: f32, r_px: f32, info: u32) -> Streak {
    Streak {
        q0_px: [x, 8.0],
        dir: [0.0, 1.0],
        len_px,
        r_eff_px: r_px,
        alpha_scale: 0.2,
        drop_info: info,
        radiance0: [1.0; 4],
        radiance1: [1.0; 4],
    }
}

fn plain_params(w: u32, h: u32, seed: u32) -> RainParams {
    let mut p: RainParams = bytemuck::Zeroable::zeroed();
    p.coded_size_px = [w as f32, h as f32];
    p.coded_from_display = [1.0, 0.0, 0.0, 1.0];
    p.seed = seed;
    p
}

#[test]
fn the_capsule_is_the_default() {
    let c = RenderConfig::default();
    assert_eq!(c.rain.streaks, StreakStyle::Simple);
    assert_eq!(c.streak_db, None);
}

/// Over a black canvas, each streak's summed colour with its matte equals the capsule's
/// (πr²·α, the Garg–Nayar coverage) within a few per cent, for every size and view bin; and
/// the matte does move the light: the brightness along the streak is not the capsule's flat
/// profile.
#[test]
fn a_matte_moves_a_streaks_light_without_changing_its_total() {
    let atlas = atlas();
    let (w, h) = (24u32, 140u32);
    let p = plain_params(w, h, 7);
    for &d in &atlas.sizes_mm {
        for &view in &atlas.views_deg {
            for (len, r) in [(120.0f32, 2.5f32), (60.0, 1.2), (8.0, 3.0)] {
                // Averaged over sub-pixel positions the pixel sums of either are the integrals.
                let offsets = 8;
                let (mut a, mut b) = (0.0, 0.0);
                let (mut simple, mut matte) = (Vec::new(), Vec::new());
                for k in 0..offsets {
                    let f = k as f32 / offsets as f32;
                    let mut s = [streak(12.0 + f, len, r, drop_info(d, view))];
                    s[0].q0_px[1] += (3 * k % offsets) as f32 / offsets as f32;
                    simple = vec![[0.0; 3]; (w * h) as usize];
                    matte = simple.clone();
                    rain_streaks_with(&mut simple, &p, &s, None, &[], None);
                    rain_streaks_with(&mut matte, &p, &s, Some(&atlas), &[], None);
                    let total = |c: &[[f64; 3]]| c.iter().map(|px| px[1]).sum::<f64>();
                    a += total(&simple) / offsets as f64;
                    b += total(&matte) / offsets as f64;
                }
                let coverage = std::f64::consts::PI * (r * r) as f64 * 0.2;
                let what = format!("{d} mm, view {view}°, {len}×{r} px");
                eprintln!(
                    "{what}: capsule / πr²α {:.4}, matte / capsule {:.4}",
                    a / coverage,
                    b / a
                );
                assert!(
                    (a / coverage - 1.0).abs() < 0.02,
                    "{what}: capsule {a} vs πr²α {coverage}"
                );
                assert!(
                    (b / a - 1.0).abs() < 0.01,
                    "{what}: matte {b} vs capsule {a}"
                );
                if len > 100.0 {
                    // Row sums along the streak's middle: the capsule's are flat.
                    let rows = |c: &[[f64; 3]]| -> Vec<f64> {
                        (20..120)
                            .map(|y| (0..w).map(|x| c[(y * w + x) as usize][1]).sum())
                            .collect()
                    };
                    let spread = |v: &[f64]| {
                        let mean = v.iter().sum::<f64>() / v.len() as f64;
                        (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
                            / mean
                    };
                    let (flat, rippled) = (spread(&rows(&simple)), spread(&rows(&matte)));
                    eprintln!("{what}: rows vary by {flat:.4} (capsule), {rippled:.4} (matte)");
                    assert!(flat < 0.001, "{what}: capsule rows vary by {flat}");
                    assert!(rippled > 0.005, "{what}: matte rows vary by {rippled}");
                }
            }
        }
    }
}

/// Brightness along the middle of a vertical streak: the sum of each row over the streak.
fn row_profile(canvas: &[[f64; 3]], w: u32, rows: std::ops::Range<u32>) -> Vec<f64> {
    rows.map(|y| (0..w).map(|x| canvas[(y * w + x) as usize][1]).sum())
        .collect()
}

/// Standard deviation over mean.
fn ripple(v: &[f64]) -> f64 {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt() / mean
}

/// The lag (of `lags`) at which the mean-removed profile best matches itself.
fn period(v: &[f64], lags: std::ops::Range<usize>) -> usize {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let d: Vec<f64> = v.iter().map(|x| x - mean).collect();
    let corr = |lag: usize| {
        let n = d.len() - lag;
        (0..n).map(|i| d[i] * d[i + lag]).sum::<f64>() / n as f64
    };
    lags.max_by(|&a, &b| corr(a).total_cmp(&corr(b)))
        .unwrap_or(0)
}

/// A streak lit by a lamp beside it is a string of beads at the drop's oscillation period
/// (fall speed over the (2,0) frequency, here len / (f·T) px); its glint keeps the light the
/// lamp gave the capsule; and a lamp on the other side gives the mirror image.
#[test]
fn a_lamp_beside_a_streak_strings_it_with_beads() {
    let atlas = atlas();
    let (w, h) = (24u32, 230u32);
    let p = plain_params(w, h, 11);
    let (d_mm, len) = (1.0, 200.0f32);
    let mut s = streak(12.0, len, 3.0, drop_info(d_mm, 0.0));
    s.radiance0 = [0.05; 4];
    s.radiance1 = [0.05; 4];
    // A lamp level with the drop, to the image right of it, 5° towards the camera.
    let lamp = |x: f32| Glint {
        colour: [2.0, 2.0, 2.0, 0.0],
        light_dir: [
            x * 85f32.to_radians().sin(),
            -(85f32.to_radians().cos()),
            0.0,
            0.0,
        ],
    };
    let draw_at = |s: Streak, glint: Option<Glint>| {
        let mut canvas = vec![[0.0; 3]; (w * h) as usize];
        let glints: Vec<Glint> = glint.into_iter().collect();
        rain_streaks_with(&mut canvas, &p, &[s], Some(&atlas), &glints, None);
        canvas
    };
    let draw = |glint: Option<Glint>| draw_at(s, glint);
    let (right, left, none) = (draw(Some(lamp(1.0))), draw(Some(lamp(-1.0))), draw(None));
    let total = |c: &[[f64; 3]]| c.iter().map(|px| px[1]).sum::<f64>();
    // The capsule of the same drop would hold (0.05 + 2)·πr²·α; averaged over sub-pixel
    // positions the pixel sums are the integrals.
    let capsule = 2.05 * std::f64::consts::PI * 9.0 * 0.2;
    let offsets = 8;
    let held = (0..offsets)
        .map(|k| {
            let mut moved = s;
            moved.q0_px[0] += k as f32 / offsets as f32;
            moved.q0_px[1] += (3 * k % offsets) as f32 / offsets as f32;
            total(&draw_at(moved, Some(lamp(1.0))))
        })
        .sum::<f64>()
        / offsets as f64;
    eprintln!("lamp: total {:.4} of the capsule's", held / capsule);
    assert!((held / capsule - 1.0).abs() < 0.03);
    let rows = 30..190;
    let (lit, dim) = (
        row_profile(&right, w, rows.clone()),
        row_profile(&none, w, rows),
    );
    eprintln!(
        "ripple: {:.3} lit, {:.3} without the lamp",
        ripple(&lit),
        ripple(&dim)
    );
    assert!(ripple(&lit) > 5.0 * ripple(&dim), "beads");
    let f20_hz = atlas_frequency_hz(d_mm);
    let expected = len as f64 / (f20_hz / 60.0);
    let found = period(&lit, 8..80);
    eprintln!("bead period {found} px, (2,0) period {expected:.1} px");
    assert!(
        (found as f64 / expected - 1.0).abs() < 0.15
            || (2.0 * found as f64 / expected - 1.0).abs() < 0.15,
        "period {found} px vs {expected:.1} px"
    );
    // Mirror: column x of one is column 23 − x of the other: compare the weight centres.
    let centre = |c: &[[f64; 3]]| {
        let (mut m, mut t) = (0.0, 0.0);
        for (i, px) in c.iter().enumerate() {
            m += px[1] * ((i as u32 % w) as f64 + 0.5);
            t += px[1];
        }
        m / t
    };
    eprintln!(
        "centres: {:.3} right, {:.3} left",
        centre(&right),
        centre(&left)
    );
    assert!(centre(&right) > 12.05 && centre(&left) < 11.95);
    assert!((centre(&right) + centre(&left) - 24.0).abs() < 1e-6);
}

/// The (2,0) Rayleigh frequency the database lists for a drop of `d_mm`.
fn atlas_frequency_hz(d_mm: f64) -> f64 {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("drops");
    let index = rain_composite::drops::database::load_index(&dir).expect("index");
    index
        .mattes
        .iter()
        .find(|m| m.diameter_mm == d_mm)
        .map(|m| m.mode_frequencies_hz[0])
        .expect("size")
}

/// The phase is random per drop (all phases turn up), fixed by seed and drop id, and the size
/// and view pick the nearest bins.
#[test]
fn each_drop_keeps_its_matte() {
    let atlas = atlas();
    let info = drop_info(2.1, 25.0);
    let layers: Vec<usize> = (0..400)
        .map(|id| matte_layers(&atlas, 3, id, info, &[]).0)
        .collect();
    let again: Vec<usize> = (0..400)
        .map(|id| matte_layers(&atlas, 3, id, info, &[]).0)
        .collect();
    assert_eq!(layers, again);
    let (size, view) = (1, 1); // 2 mm, 30°
    let first = (size * atlas.views_deg.len() + view) * atlas.phases;
    for k in 0..atlas.phases {
        let n = layers.iter().filter(|&&l| l == first + k).count();
        assert!(n > 400 / atlas.phases / 2, "phase {k}: {n} of 400 drops");
    }
    assert_eq!(
        layers
            .iter()
            .filter(|&&l| l < first || l >= first + atlas.phases)
            .count(),
        0
    );
    let other_seed: Vec<usize> = (0..400)
        .map(|id| matte_layers(&atlas, 4, id, info, &[]).0)
        .collect();
    assert_ne!(layers, other_seed);
}

fn setup_for(format: FrameFormat) -> RainSetup {
    let camera = Camera::new(format.width, format.height, 1.0, 1.6, 0.05, 0.0);
    let rain = RainConfig {
        rate_mm_per_h: 60.0,
        opacity: 4.0,
        near_m: 0.3,
        far_m: 5.0,
        max_drops: 3000,
        ..RainConfig::default()
    };
    rain_composite::shot::rain::plan(
        &camera,
        &CameraConfig::default(),
        &rain,
        1.0 / 50.0,
        0,
        (format.width, format.height),
    )
    .map(RainSetup::pack)
    .expect("rain")
}

/// The uniforms at 1.7 s under a bluish sky brighter overhead.
fn lit(setup: &RainSetup) -> RainParams {
    render::lit(setup, 1.7, &BLUISH_SKY, None)
}

/// The GPU's `fs_mattes` against the CPU twin, on the GPU's own streaks.
#[test]
fn mattes_on_the_gpu_match_the_cpu_twin() {
    let Some(ctx) = gpu() else { return };
    let format = FrameFormat {
        width: 64,
        height: 48,
        chroma: Chroma::Cs444,
        bit_depth: 10,
    };
    let color = ColorParams::bt709(10);
    let frame = YuvFrame::filled(format, color, [200, 512, 512]);
    let tables = water_tables(256);
    let render = |setup: &RainSetup| {
        codes(&render_with(&ctx, &frame, setup, &lit(setup), |comp| {
            comp.set_transfer_table(&tables)
        }))
    };
    let simple = setup_for(format);
    let matted = setup_for(format).with_mattes(Some(atlas()));
    let params = lit(&matted);
    let streaks =
        probe_streaks(&ctx, &matted, &params, &LightList::new(&[]), &tables).expect("streaks");
    let drawn = streaks.iter().filter(|s| s.len_px >= 0.0).count();
    assert!(drawn > 20, "{drawn} streaks");
    let mut canvas = yuv_to_rgb::yuv_to_rgb(&frame, &params);
    rain_streaks_with(&mut canvas, &params, &streaks, Some(&atlas()), &[], None);
    let cpu = rgb_to_yuv::rgb_to_yuv(&canvas, format, &color);
    let gpu = render(&matted);
    let (mut worst, mut off, mut n) = (0u16, 0usize, 0usize);
    for (g, c) in gpu.iter().zip(&cpu) {
        for (a, b) in g.iter().zip(c) {
            worst = worst.max(a.abs_diff(*b));
            off += (a.abs_diff(*b) > 2) as usize;
            n += 1;
        }
    }
    eprintln!("{drawn} streaks, worst {worst} codes, {off} of {n} samples > 2 codes");
    // f16 canvas and per-draw blending on the GPU against f64 on the CPU (10-bit codes).
    assert!(worst <= 8, "{worst} codes off");
    assert!((off as f64) < 0.02 * n as f64, "{off} of {n} samples off");
    assert_ne!(render(&simple), gpu, "the mattes show");
}

/// A lamp in shot: the GPU's glints and their mattes match the CPU twin, and the glints are
/// the streaks' light near the lamp (within 15°: beaded, as the twin test shows a glint
/// makes them) and a small share of it far from the lamp (smooth).
#[test]
fn a_lamp_in_shot_glints_in_the_streaks_near_it() {
    let Some(ctx) = gpu() else { return };
    let format = FrameFormat {
        width: 96,
        height: 64,
        chroma: Chroma::Cs444,
        bit_depth: 10,
    };
    let color = ColorParams::bt709(10);
    let frame = YuvFrame::filled(format, color, [150, 512, 512]);
    let tables = water_tables(256);
    let setup = setup_for(format).with_mattes(Some(atlas()));
    let params = lit(&setup);
    // The lamp: in front of the camera, a little right of and above the centre.
    let row = |k: usize| match k {
        0 => params.camera_from_world_0,
        1 => params.camera_from_world_1,
        _ => params.camera_from_world_2,
    };
    let cam = [0.15f32, -0.1, 1.0];
    let mut world = [0.0f32; 3];
    for (k, c) in cam.iter().enumerate() {
        for (i, w) in world.iter_mut().enumerate() {
            *w += row(k)[i] * c;
        }
    }
    let n = world.iter().map(|v| v * v).sum::<f32>().sqrt();
    let mut lights = LightList::new(&[]);
    lights.count = 1;
    // A street lamp 2 m away, among the drops.
    lights.lights[0].direction_distance = [world[0] / n, world[1] / n, world[2] / n, 2.0];
    lights.lights[0].strength = [3.0, 2.5, 2.0, 0.05];
    let lamp_px = [
        params.principal_px[0] + params.focal_px * cam[0],
        params.principal_px[1] + params.focal_px * cam[1],
    ];
    let (streaks, glints) =
        probe_streaks_and_glints(&ctx, &setup, &params, &lights, &tables).expect("probe");
    let (mut near, mut far) = (Vec::new(), Vec::new());
    let per_drop = glints.chunks(GLINTS_PER_DROP);
    for (s, g) in streaks
        .iter()
        .zip(per_drop)
        .filter(|(s, _)| s.len_px >= 0.0)
    {
        let mid = [
            s.q0_px[0] + s.dir[0] * s.len_px / 2.0,
            s.q0_px[1] + s.dir[1] * s.len_px / 2.0,
        ];
        let off = ((mid[0] - lamp_px[0]).powi(2) + (mid[1] - lamp_px[1]).powi(2)).sqrt();
        let angle_deg = (off / params.focal_px).atan().to_degrees();
        let glint: f32 = g.iter().flat_map(|g| &g.colour[..3]).sum();
        let smooth: f32 = (0..3)
            .map(|k| 0.5 * (s.radiance0[k] + s.radiance1[k]))
            .sum();
        let share = glint / (glint + smooth).max(1e-12);
        if angle_deg < 15.0 {
            near.push(share);
        } else if angle_deg > 30.0 {
            far.push(share);
        }
    }
    let median = |v: &mut Vec<f32>| {
        v.sort_by(f32::total_cmp);
        v[v.len() / 2]
    };
    assert!(
        near.len() > 10 && far.len() > 10,
        "{} near, {} far",
        near.len(),
        far.len()
    );
    let (near_share, far_share) = (median(&mut near), median(&mut far));
    eprintln!(
        "glint share of the light: {near_share:.3} within 15° of the lamp ({} streaks), {far_share:.3} beyond 30° ({})",
        near.len(),
        far.len()
    );
    assert!(
        near_share > 0.5,
        "near the lamp the glint is most of the light"
    );
    assert!(far_share < 0.5 * near_share, "far from it, less");

    // The frame: GPU against the twin with the same glints.
    let gpu = codes(&render_with(&ctx, &frame, &setup, &params, |comp| {
        comp.set_transfer_table(&tables);
        comp.set_lights(&lights);
    }));
    let mut canvas = yuv_to_rgb::yuv_to_rgb_lit(&frame, &params, &lights, &tables);
    rain_streaks_with(
        &mut canvas,
        &params,
        &streaks,
        Some(&atlas()),
        &glints,
        None,
    );
    let cpu = rgb_to_yuv::rgb_to_yuv(&canvas, format, &color);
    let (mut worst, mut off, mut total) = (0u16, 0usize, 0usize);
    for (g, c) in gpu.iter().zip(&cpu) {
        for (a, b) in g.iter().zip(c) {
            worst = worst.max(a.abs_diff(*b));
            off += (a.abs_diff(*b) > 2) as usize;
            total += 1;
        }
    }
    eprintln!("with a lamp: worst {worst} codes, {off} of {total} samples > 2 codes");
    assert!(worst <= 8 && (off as f64) < 0.02 * total as f64);
}

/// A compact light seen in direction `cam` (camera axes: x right, y down, z forward),
/// `distance_m` away (0: at infinity), of radiance × solid angle `strength`.
fn lamp(params: &RainParams, cam: [f32; 3], distance_m: f32, strength: [f32; 3]) -> DirectLight {
    let rows = [
        params.camera_from_world_0,
        params.camera_from_world_1,
        params.camera_from_world_2,
    ];
    let mut world = [0.0f32; 3];
    for (row, c) in rows.iter().zip(cam) {
        for (w, r) in world.iter_mut().zip(row) {
            *w += r * c;
        }
    }
    let n = world.iter().map(|v| v * v).sum::<f32>().sqrt();
    DirectLight {
        direction_distance: [world[0] / n, world[1] / n, world[2] / n, distance_m],
        strength: [strength[0], strength[1], strength[2], 0.05],
    }
}

/// Where the lamp seen in direction `cam` appears in the picture, px.
fn lamp_px(params: &RainParams, cam: [f32; 3]) -> [f32; 2] {
    [
        params.principal_px[0] + params.focal_px * cam[0] / cam[2],
        params.principal_px[1] + params.focal_px * cam[1] / cam[2],
    ]
}

/// Degrees between the middle of streak `s` and the picture point `at`, seen from the camera.
fn degrees_from(params: &RainParams, s: &Streak, at: [f32; 2]) -> f32 {
    let ray = |p: [f32; 2]| {
        let v = [
            (p[0] - params.principal_px[0]) / params.focal_px,
            (p[1] - params.principal_px[1]) / params.focal_px,
            1.0,
        ];
        let n = v.iter().map(|x| x * x).sum::<f32>().sqrt();
        v.map(|x| x / n)
    };
    let mid = [
        s.q0_px[0] + s.dir[0] * s.len_px / 2.0,
        s.q0_px[1] + s.dir[1] * s.len_px / 2.0,
    ];
    let (a, b) = (ray(mid), ray(at));
    let cos: f32 = (0..3).map(|k| a[k] * b[k]).sum();
    cos.clamp(-1.0, 1.0).acos().to_degrees()
}

/// The light list of `lamps`.
fn light_list(lamps: &[DirectLight]) -> LightList {
    let mut list = LightList::new(&[]);
    list.count = lamps.len() as u32;
    list.lights[..lamps.len()].copy_from_slice(lamps);
    list
}

/// Three lamps in shot, at different distances and strengths, one at infinity: `main_mattes`'
/// glints and the streaks it leaves match the twin `take_glints` applied to the plain
/// streaks of `main`, drop by drop; and the light is moved exactly once: per channel the
/// glints plus the mean of the streak's ends are the plain streak's mean (to f32 rounding),
/// nothing negative. The frame drawn with them matches the twin's.
#[test]
fn glints_on_the_gpu_match_the_cpu_twin_and_move_the_light_once() {
    let Some(ctx) = gpu() else { return };
    let format = FrameFormat {
        width: 96,
        height: 64,
        chroma: Chroma::Cs444,
        bit_depth: 10,
    };
    // At the GPU's own resolution, so the twin interpolates what it reads.
    let tables = water_tables(TABLE_BINS);
    let setup = setup_for(format).with_mattes(Some(atlas()));
    let params = lit(&setup);
    let lights = light_list(&[
        lamp(&params, [0.3, -0.2, 1.0], 2.0, [3.0, 2.5, 2.0]),
        lamp(&params, [-0.35, -0.1, 1.0], 4.0, [1.0, 1.0, 1.5]),
        lamp(&params, [0.0, -0.6, 1.0], 0.0, [0.4, 0.4, 0.4]),
    ]);
    let plain = probe_streaks(&ctx, &setup, &params, &lights, &tables).expect("streaks");
    let (split, glints) =
        probe_streaks_and_glints(&ctx, &setup, &params, &lights, &tables).expect("glints");
    let drops = probe_drops_with(&ctx, &setup, &params, params.drop_count).expect("drops");
    let v3 = |v: glam::Vec3| glam::DVec3::new(v.x as f64, v.y as f64, v.z as f64);
    let (mut drawn, mut lit_drops, mut glint_count) = (0, 0, 0);
    let (mut worst_twin, mut worst_once) = (0.0f64, 0.0f64);
    for (id, ((p, s), d)) in plain.iter().zip(&split).zip(&drops).enumerate() {
        let ours = &glints[GLINTS_PER_DROP * id..GLINTS_PER_DROP * (id + 1)];
        if p.len_px < 0.0 {
            assert!(ours.iter().all(|g| g.colour == [0.0; 4]));
            continue;
        }
        drawn += 1;
        let mut twin = *p;
        let theirs = take_glints(
            &params,
            &lights,
            &tables,
            v3(d.pos_m),
            v3(d.vel_mps),
            &mut twin,
        );
        // The scale of the drop's light: differences are judged against it.
        let scale = (0..3)
            .map(|k| (p.radiance0[k] + p.radiance1[k]) as f64)
            .sum::<f64>()
            .max(1e-6);
        let n = ours.iter().filter(|g| g.colour[..3] != [0.0; 3]).count();
        lit_drops += (n > 0) as usize;
        glint_count += n;
        for (g, t) in ours.iter().zip(&theirs) {
            for k in 0..3 {
                let off = (g.colour[k] - t.colour[k]).abs() as f64 / scale;
                worst_twin = worst_twin.max(off);
                if t.colour[k] > 1e-3 * scale as f32 {
                    let dir_off = (0..3)
                        .map(|i| (g.light_dir[i] - t.light_dir[i]).abs())
                        .fold(0.0f32, f32::max);
                    assert!(dir_off < 1e-3, "drop {id}: direction off by {dir_off}");
                }
            }
        }
        for k in 0..3 {
            let ends = |s: &Streak| (s.radiance0[k] + s.radiance1[k]) as f64;
            worst_twin = worst_twin.max((ends(s) - ends(&twin)).abs() / scale);
            assert!(s.radiance0[k] >= 0.0 && s.radiance1[k] >= 0.0, "drop {id}");
            assert!(ours.iter().all(|g| g.colour[k] >= 0.0), "drop {id}");
            let glint: f64 = ours.iter().map(|g| g.colour[k] as f64).sum();
            let once = (0.5 * ends(s) + glint - 0.5 * ends(p)).abs() / scale;
            worst_once = worst_once.max(once);
        }
    }
    eprintln!(
        "{drawn} streaks, {lit_drops} with glints ({glint_count} glints); GPU vs twin {worst_twin:.2e}, \
         light moved once to {worst_once:.2e} of each streak's light"
    );
    assert!(
        drawn > 50 && lit_drops > drawn / 2,
        "{lit_drops} of {drawn}"
    );
    assert!(
        glint_count > 2 * lit_drops,
        "most lit drops glint for more than one lamp"
    );
    // f32 on the GPU against f64 on the CPU.
    assert!(worst_twin < 1e-3, "GPU vs twin {worst_twin}");
    assert!(worst_once < 1e-5, "light not conserved: {worst_once}");

    // The frame: every glint drawn with its matte, GPU against the twin.
    let color = ColorParams::bt709(10);
    let frame = YuvFrame::filled(format, color, [150, 512, 512]);
    let gpu = codes(&render_with(&ctx, &frame, &setup, &params, |comp| {
        comp.set_transfer_table(&tables);
        comp.set_lights(&lights);
    }));
    let mut canvas = yuv_to_rgb::yuv_to_rgb_lit(&frame, &params, &lights, &tables);
    rain_streaks_with(&mut canvas, &params, &split, Some(&atlas()), &glints, None);
    let cpu = rgb_to_yuv::rgb_to_yuv(&canvas, format, &color);
    let (mut worst, mut off, mut total) = (0u16, 0usize, 0usize);
    for (g, c) in gpu.iter().zip(&cpu) {
        for (a, b) in g.iter().zip(c) {
            worst = worst.max(a.abs_diff(*b));
            off += (a.abs_diff(*b) > 2) as usize;
            total += 1;
        }
    }
    eprintln!("three lamps: worst {worst} codes, {off} of {total} samples > 2 codes");
    assert!(worst <= 8 && (off as f64) < 0.02 * total as f64);
}

/// The light of `lamp` (the drop at `offset_m` from the camera seen along unit `v`) the glints
/// hold: the glint whose direction matches the lamp's, over the lamp's own light term.
fn lamp_share(
    glints: &[Glint],
    lamp: &DirectLight,
    tables: &[RtfTable; 3],
    v: glam::DVec3,
    offset_m: glam::DVec3,
    vel_mps: glam::DVec3,
) -> f64 {
    let (colour, omega) = light_term(lamp, tables, v, offset_m);
    // ω in the matte's frame (as `take_glints` writes it).
    let up = -vel_mps.normalize();
    let away = (v - up * v.dot(up)).normalize();
    let right = away.cross(up);
    let want = [omega.dot(right), omega.dot(away), omega.dot(up)];
    let total: f64 = colour.iter().sum();
    glints
        .iter()
        .filter(|g| (0..3).all(|i| (g.light_dir[i] as f64 - want[i]).abs() < 1e-3))
        .map(|g| g.colour[..3].iter().map(|&c| c as f64).sum::<f64>())
        .sum::<f64>()
        / total.max(1e-12)
}

/// A street at night: a dim sky, so lamps light the rain.
fn night(setup: &RainSetup) -> RainParams {
    render::lit(
        setup,
        1.7,
        &[(0, [0.05, 0.05, 0.07]), (2, [0.01, 0.01, 0.02])],
        None,
    )
}

/// Two lamps a metre away in different places at night, one ten times the other: streaks
/// near each are strings of beads. The strong lamp is the brightest light of some drops near
/// the weak one, where the single-glint path left the weak lamp's light smooth; here each
/// lamp's glint holds its light in the streaks within 15° of it, and a dozen streaks each lamp
/// lights (half their light or more), drawn large alone by the twin that the GPU is held to,
/// ripple along their length several times more than with their glints folded back into the
/// smooth colour, while holding the light of the plain streak's capsule within 3 % (the
/// matte's bilinear sampling, averaged over sub-pixel positions, as for the matte alone).
#[test]
fn two_lamps_each_bead_the_streaks_near_them() {
    let Some(ctx) = gpu() else { return };
    let format = FrameFormat {
        width: 128,
        height: 96,
        chroma: Chroma::Cs444,
        bit_depth: 10,
    };
    // At the GPU's own resolution, so the twin interpolates what it reads.
    let tables = water_tables(TABLE_BINS);
    let atlas = atlas();
    let setup = setup_for(format).with_mattes(Some(atlas.clone()));
    let params = night(&setup);
    let (strong_cam, weak_cam) = ([0.3f32, -0.15, 1.0], [-0.3f32, 0.1, 1.0]);
    let lamps = [
        lamp(&params, strong_cam, 1.0, [8.0, 7.0, 6.0]),
        lamp(&params, weak_cam, 1.0, [0.8, 0.7, 0.6]),
    ];
    let lights = light_list(&lamps);
    let plain = probe_streaks(&ctx, &setup, &params, &lights, &tables).expect("streaks");
    let (split, glints) =
        probe_streaks_and_glints(&ctx, &setup, &params, &lights, &tables).expect("glints");
    let drops = probe_drops_with(&ctx, &setup, &params, params.drop_count).expect("drops");
    let [x, y, z] = params.camera_pos_m.map(f64::from);
    let cam = glam::DVec3::new(x, y, z);
    let v3 = |v: glam::Vec3| glam::DVec3::new(v.x as f64, v.y as f64, v.z as f64);
    for (which, (lamp_cam, lamp)) in [(strong_cam, &lamps[0]), (weak_cam, &lamps[1])]
        .into_iter()
        .enumerate()
    {
        let at = lamp_px(&params, lamp_cam);
        let (mut shares, mut ratios, mut held) = (Vec::new(), Vec::new(), Vec::new());
        let mut outshone = 0;
        for (id, ((p, s), d)) in plain.iter().zip(&split).zip(&drops).enumerate() {
            if s.len_px < 0.0 || degrees_from(&params, s, at) > 15.0 {
                continue;
            }
            let own = &glints[GLINTS_PER_DROP * id..GLINTS_PER_DROP * (id + 1)];
            let offset = v3(d.pos_m) - cam;
            let v = offset.normalize();
            let terms = lamps.map(|l| light_term(&l, &tables, v, offset).0.iter().sum::<f64>());
            if terms[which] < terms[1 - which] {
                outshone += 1;
            }
            shares.push(lamp_share(own, lamp, &tables, v, offset, v3(d.vel_mps)));
            // Streaks this lamp lights (half their light or more), a dozen of them, are drawn.
            let mean: f64 = (0..3)
                .map(|k| 0.5 * (p.radiance0[k] + p.radiance1[k]) as f64)
                .sum();
            if terms[which] < 0.5 * mean || held.len() >= 12 {
                continue;
            }
            // Drawn alone, vertical, 200 px long and 3 px wide: the same light and layers.
            let big = |s: &Streak, k: usize| {
                let mut b = *s;
                b.q0_px = [12.0 + k as f32 / 8.0, 8.0 + (3 * k % 8) as f32 / 8.0];
                b.dir = [0.0, 1.0];
                b.len_px = 200.0;
                b.r_eff_px = 3.0;
                b.alpha_scale = 0.2;
                b
            };
            let (w, h) = (24u32, 230u32);
            let canvas_p = plain_params(w, h, params.seed);
            let draw = |s: Streak, mattes: Option<&MatteAtlas>, with: &[Glint]| {
                let mut drops = vec![hidden_streak(); id + 1];
                drops[id] = s;
                let mut all: Vec<Glint> = vec![bytemuck::Zeroable::zeroed(); GLINTS_PER_DROP * id];
                all.extend_from_slice(with);
                let mut canvas = vec![[0.0; 3]; (w * h) as usize];
                rain_streaks_with(&mut canvas, &canvas_p, &drops, mattes, &all, None);
                canvas
            };
            let (beaded, folded) = (
                draw(big(s, 0), Some(&atlas), own),
                draw(big(p, 0), Some(&atlas), &[]),
            );
            let rows = 30..190;
            ratios.push(
                ripple(&row_profile(&beaded, w, rows.clone()))
                    / ripple(&row_profile(&folded, w, rows)),
            );
            let total = |c: &[[f64; 3]]| c.iter().map(|px| px[1]).sum::<f64>();
            let (mut a, mut b) = (0.0, 0.0);
            for k in 0..8 {
                a += total(&draw(big(s, k), Some(&atlas), own));
                b += total(&draw(big(p, k), None, &[]));
            }
            held.push(a / b);
        }
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let n = shares.len();
        if n == 0 {
            panic!("no streak near lamp {which}");
        }
        let worst_held = held.iter().map(|h| (h - 1.0).abs()).fold(0.0, f64::max);
        assert!(
            ratios.len() >= 6,
            "{} streaks lit by lamp {which}",
            ratios.len()
        );
        let (share, ratio) = (median(&mut shares), median(&mut ratios));
        eprintln!(
            "lamp {which}: {n} streaks within 15°, {outshone} of them brighter in the other lamp; \
             median share of its light in its glint {share:.3}, ripple {ratio:.1}× the smooth \
             streak's, light held to {worst_held:.4}"
        );
        assert!(n > 10, "{n} streaks near lamp {which}");
        assert!(
            share > 0.95,
            "lamp {which}: its glint holds {share} of its light"
        );
        assert!(
            ratio > 3.0,
            "lamp {which}: ripple only {ratio}× the smooth streak's"
        );
        assert!(worst_held < 0.03, "lamp {which}: light off by {worst_held}");
        if which == 1 {
            // Where the single-glint path left the weak lamp's light smooth.
            assert!(
                outshone > n / 10,
                "the strong lamp outshines the weak one in {outshone} of {n}"
            );
        }
    }
}

/// A streak that is not drawn.
fn hidden_streak() -> Streak {
    let mut s = streak(0.0, 0.0, 0.0, 0);
    s.len_px = -1.0;
    s
}

/// Report (`--ignored --nocapture`): how much of the drops' direct light the glints leave in
/// the smooth colour, for 1 to 4 glints per drop and 2 to 16 lamps among the drops (street
/// lamps 2 to 8 m away about the view, a few times apart in strength): over all the drops,
/// the light beyond the strongest K over all the direct light, and the share of drops for which
/// it is more than a tenth of their own.
#[test]
#[ignore]
fn report_the_light_the_glints_leave_out() {
    let Some(ctx) = gpu() else { return };
    let format = FrameFormat {
        width: 160,
        height: 120,
        chroma: Chroma::Cs444,
        bit_depth: 10,
    };
    // At the GPU's own resolution, so the twin interpolates what it reads.
    let tables = water_tables(TABLE_BINS);
    let setup = setup_for(format);
    let params = lit(&setup);
    let drops = probe_drops_with(&ctx, &setup, &params, params.drop_count).expect("drops");
    let [x, y, z] = params.camera_pos_m.map(f64::from);
    let cam = glam::DVec3::new(x, y, z);
    // Deterministic lamp placements: a low-discrepancy spread over the view and behind it.
    let lamps = |n: usize| -> Vec<DirectLight> {
        (0..n)
            .map(|i| {
                let a = (i as f32 * 0.618_034).fract();
                let b = (i as f32 * 0.754_878).fract();
                let strength = 1.0 + 3.0 * (i as f32 * 0.569_84).fract();
                lamp(
                    &params,
                    [
                        2.0 * a - 1.0,
                        -0.2 - 0.6 * b,
                        if i % 3 == 2 { -0.5 } else { 1.0 },
                    ],
                    2.0 + 6.0 * b,
                    [strength, 0.9 * strength, 0.7 * strength],
                )
            })
            .collect()
    };
    println!("| lamps | K = 1 | K = 2 | K = 3 | K = 4 | drops > 10 % left, K = 4 |");
    println!("|---|---|---|---|---|---|");
    for n in [2, 3, 4, 6, 8, 16] {
        let lamps = lamps(n);
        let (mut left, mut all, mut many, mut count) = ([0.0f64; 4], 0.0f64, 0usize, 0usize);
        for d in &drops {
            let p = glam::DVec3::new(d.pos_m.x as f64, d.pos_m.y as f64, d.pos_m.z as f64);
            let offset = p - cam;
            let v = offset.normalize();
            let mut terms: Vec<f64> = lamps
                .iter()
                .map(|l| light_term(l, &tables, v, offset).0.iter().sum())
                .collect();
            terms.sort_by(|a, b| b.total_cmp(a));
            let total: f64 = terms.iter().sum();
            all += total;
            count += 1;
            for (k, l) in left.iter_mut().enumerate() {
                *l += terms.iter().skip(k + 1).sum::<f64>();
            }
            many += (terms.iter().skip(4).sum::<f64>() > 0.1 * total) as usize;
        }
        let pct = |x: f64| 100.0 * x / all.max(1e-30);
        println!(
            "| {n} | {:.1} % | {:.1} % | {:.1} % | {:.1} % | {:.1} % |",
            pct(left[0]),
            pct(left[1]),
            pct(left[2]),
            pct(left[3]),
            100.0 * many as f64 / count.max(1) as f64
        );
    }
}

/// The mattes' reach, by brute force over every layer of the shipped set: each layer's read is
/// zero (to rounding) from the reach outwards on both sides (the stage's quads end there), and some layer's
/// light reaches nearly that far.
#[test]
fn no_matte_holds_light_beyond_its_reach() {
    let atlas = atlas();
    let reach = atlas.reach_radii();
    assert!((1.0..=1.5).contains(&reach), "reach {reach} radii");
    let (mut beyond, mut inside) = (0.0f64, 0.0f64);
    for layer in 0..atlas.layers() {
        for j in 0..=512 {
            let u = j as f64 / 512.0;
            for k in 0..=20 {
                let w = reach + (1.5 - reach) * k as f64 / 20.0;
                beyond = beyond
                    .max(atlas.sample(layer, u, w))
                    .max(atlas.sample(layer, u, -w));
            }
            let w = reach - 0.02;
            inside = inside
                .max(atlas.sample(layer, u, w))
                .max(atlas.sample(layer, u, -w));
        }
    }
    // Zero but for the rounding of the grid position (N is of order 1).
    assert!(beyond < 1e-12, "light {beyond} beyond {reach} radii");
    assert!(inside > 0.0, "no light just inside {reach} radii");
}
