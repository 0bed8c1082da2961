//! The wet ground: the water store against a numerical integration of its equation, the
//! film's optics against Fresnel's equations written here in angle form, and the GPU stage
//! against its CPU twin, against the model's closed form on a uniform picture, and against the
//! dry render above the horizon (bit for bit) for tilted, rolled and rotated cameras.
//! Set `RAIN_COMPOSITE_REQUIRE_GPU=1` to turn a missing adapter into a failure.

use glam::DVec2;
use rain_composite::config::{CameraConfig, GroundConfig, RainConfig};
use rain_composite::gpu::cpu::{rgb_to_yuv, wet_ground, yuv_to_rgb};
use rain_composite::gpu::types::WetParams;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::gpu::{Compositor, GpuContext};
use rain_composite::lighting::wetness::{
    FilmOptics, RainHistory, SurfaceStore, WATER_INDEX, Wetting, water_reflectance,
};
use rain_composite::scene::{Camera, DepthMap, GroundMode};
use rain_composite::video::YuvFrame;

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/render.rs"]
mod render;
use render::{dry_ground, lit, render, render_with};

#[path = "common/pictures.rs"]
mod pictures;
use pictures::{codes, picture_444, scatter};

/// Fresnel's unpolarised reflectance in angle form, air → water (independent of the cosine
/// form the crate uses).
fn fresnel_angles(theta_i: f64) -> f64 {
    if theta_i < 1e-9 {
        let r = (WATER_INDEX - 1.0) / (WATER_INDEX + 1.0);
        return r * r;
    }
    let theta_t = (theta_i.sin() / WATER_INDEX).asin();
    let rs = (theta_i - theta_t).sin() / (theta_i + theta_t).sin();
    let rp = (theta_i - theta_t).tan() / (theta_i + theta_t).tan();
    0.5 * (rs * rs + rp * rp)
}

#[test]
fn water_reflects_two_percent_head_on_and_everything_at_grazing() {
    let normal = ((WATER_INDEX - 1.0) / (WATER_INDEX + 1.0)).powi(2);
    assert!((water_reflectance(1.0) - normal).abs() < 1e-12);
    assert!((normal - 0.0204).abs() < 1e-3);
    assert!(water_reflectance(1e-4) > 0.999);
    let mut last = 0.0;
    for i in 0..=100 {
        let theta = (i as f64 / 100.0) * 89.9f64.to_radians();
        let r = water_reflectance(theta.cos());
        assert!((r - fresnel_angles(theta)).abs() < 1e-9, "θ = {theta}");
        assert!(r >= last, "grows towards grazing");
        last = r;
    }
}

#[test]
fn the_films_diffuse_reflectances_obey_reciprocity() {
    let film = FilmOptics::water();
    // R̄ₑ by the midpoint rule in θ, from the angle form.
    let n = 200_000;
    let external: f64 = (0..n)
        .map(|i| {
            let theta = (i as f64 + 0.5) / n as f64 * std::f64::consts::FRAC_PI_2;
            fresnel_angles(theta) * 2.0 * theta.sin() * theta.cos()
        })
        .sum::<f64>()
        * std::f64::consts::FRAC_PI_2
        / n as f64;
    assert!((film.diffuse_external - external).abs() < 1e-6, "{film:?}");
    assert!((external - 0.066).abs() < 0.003, "{external}");
    // What leaves the film diffusely from inside is what enters it from outside over n²
    // (étendue): 1 − R̄ᵢ = (1 − R̄ₑ)/n².
    let internal = 1.0 - (1.0 - external) / (WATER_INDEX * WATER_INDEX);
    assert!((film.diffuse_internal - internal).abs() < 1e-6, "{film:?}");
}

/// dS/dt = P(1 − S/C) − S/τ integrated by RK4 in small steps over `history` (piecewise
/// constant rates) to `t_s`.
fn store_by_steps(store: &SurfaceStore, history: &[(f64, f64)], t_s: f64) -> f64 {
    let mut s = 0.0;
    for (i, &(start, rate_mm_per_h)) in history.iter().enumerate() {
        let end = history.get(i + 1).map_or(t_s, |next| next.0.min(t_s));
        let p = rate_mm_per_h / 3600.0;
        let f = |s: f64| p * (1.0 - s / store.capacity_mm) - s / store.drying_s;
        let mut t = start;
        while t < end {
            let h = 0.25f64.min(end - t);
            let k1 = f(s);
            let k2 = f(s + 0.5 * h * k1);
            let k3 = f(s + 0.5 * h * k2);
            let k4 = f(s + h * k3);
            s += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            t += h;
        }
    }
    s
}

#[test]
fn the_store_follows_its_equation_through_a_rate_history() {
    let store = SurfaceStore::default();
    // Drizzle, a downpour, a dry spell.
    let segments = vec![(-1200.0, 1.0), (-300.0, 40.0), (60.0, 0.0)];
    let history = RainHistory::new(segments.clone()).expect("history");
    for t in [-1000.0, -300.0, -100.0, 0.0, 60.0, 600.0, 3000.0] {
        let closed = history.store_mm(&store, t);
        let steps = store_by_steps(&store, &segments, t);
        assert!(
            (closed - steps).abs() < 1e-9,
            "t = {t}: {closed} vs {steps}"
        );
    }
    assert!(RainHistory::new(vec![(0.0, 1.0), (-1.0, 2.0)]).is_err());
    assert!(RainHistory::new(vec![(0.0, -1.0)]).is_err());
}

#[test]
fn wetness_grows_with_the_rain_before_the_clip_and_dries_after() {
    let wet = |rate: f64, pre_min: f64| Wetting {
        store: SurfaceStore::default(),
        history: RainHistory::constant(rate, 60.0 * pre_min),
        reach_m: 0.0,
    };
    assert_eq!(wet(10.0, 0.0).wetness_at(0.0), 0.0);
    let mut last = 0.0;
    for pre in [1.0, 2.0, 5.0, 10.0, 30.0] {
        let w = wet(10.0, pre).wetness_at(0.0);
        assert!(w > last && w < 1.0, "{pre} min: {w}");
        last = w;
    }
    // Thirty minutes of 10 mm/h: at the steady state
    // P/(P + C/τ) = 10/(10 + 0.5 mm / 0.5 h) = 10/11.
    assert!((last - 10.0 / 11.0).abs() < 1e-3, "{last}");
    assert!(wet(1.0, 10.0).wetness_at(0.0) < wet(10.0, 10.0).wetness_at(0.0));
    // Rain stops at t = 0: the store decays with the drying time, e^(−t/τ).
    let stops = Wetting {
        store: SurfaceStore::default(),
        history: RainHistory::new(vec![(-600.0, 10.0), (0.0, 0.0)]).expect("history"),
        reach_m: 0.0,
    };
    let w0 = stops.wetness_at(0.0);
    let tau = SurfaceStore::default().drying_s;
    for t in [60.0, 600.0, tau] {
        let expected = w0 * (-t / tau).exp();
        assert!((stops.wetness_at(t) - expected).abs() < 1e-12);
    }
    // Without a ground, or without any rain, nothing wets.
    let ground = |mode: GroundMode, pre_rain_min| GroundConfig {
        mode,
        pre_rain_min,
        ..GroundConfig::default()
    };
    let horizon: GroundMode = "horizon=0.6".parse().expect("mode");
    assert!(
        ground(GroundMode::None, 10.0)
            .wetting(None, 10.0, 50.0)
            .is_none()
    );
    assert!(ground(horizon, 0.0).wetting(None, 0.0, 50.0).is_none());
    assert!(ground(horizon, 10.0).wetting(None, 0.0, 50.0).is_none());
    assert!(ground(horizon, 10.0).wetting(None, 1.0, 50.0).is_some());
    assert!(ground(horizon, 0.0).wetting(None, 10.0, 50.0).is_some());
}

/// A 4:4:4 10-bit BT.709 picture: a texture, or one grey (`flat`).
fn picture(width: u32, height: u32, flat: Option<u16>) -> YuvFrame {
    let hash = |i: usize, x: u32, y: u32| scatter(i, x, y) % 1024;
    picture_444(
        width,
        height,
        |x, y| match flat {
            Some(code) => code,
            None => (100 + hash(0, x, y) * 3 / 4) as u16,
        },
        |x, y, i| match flat {
            Some(_) => 512,
            None => (512 + (hash(i, x, y) as i32 - 512) as u32 / 4) as u16,
        },
    )
}

/// No rain drawn, the ground z = 0 under a camera 1.6 m up; wet as `wetting`.
fn setup(camera: &Camera, rotation_deg: i32, wetting: Option<Wetting>) -> RainSetup {
    dry_ground(camera, rotation_deg).with_wetting(wetting)
}

/// It rained at 10 mm/h for ten minutes and stops at the clip's start.
fn drying() -> Wetting {
    Wetting {
        store: SurfaceStore::default(),
        history: RainHistory::new(vec![(-600.0, 10.0), (0.0, 0.0)]).expect("history"),
        reach_m: 0.0,
    }
}

/// A sky brighter overhead and warmer to one side.
const SKY: [(usize, [f32; 3]); 3] = [
    (0, [1.6, 1.8, 2.2]),
    (2, [0.5, 0.6, 0.8]),
    (3, [0.3, 0.2, 0.1]),
];

#[test]
fn the_stage_matches_its_cpu_twin() {
    let Some(ctx) = gpu() else { return };
    for (rotation, tilt_deg, roll_deg) in [(0, -8.0, 0.0), (90, 5.0, -12.0)] {
        let camera = Camera::new(
            48,
            32,
            1.0,
            1.6,
            f64::to_radians(tilt_deg),
            f64::to_radians(roll_deg),
        );
        // A ground reaching 30 m: the fade (from 15 m) is held to the twin too.
        let reach_m = 30.0;
        let wetting = Wetting {
            reach_m,
            ..drying()
        };
        let s = setup(&camera, rotation, Some(wetting));
        let p = lit(&s, 120.0, &SKY, Some(0.9));
        let frame = picture(
            s.params.coded_size_px[0] as u32,
            s.params.coded_size_px[1] as u32,
            None,
        );
        let gpu = codes(&render(&ctx, &frame, &s, &p));
        let wetness = drying().wetness_at(120.0);
        let mut canvas = yuv_to_rgb::yuv_to_rgb(&frame, &p);
        wet_ground::wet_ground(
            &mut canvas,
            &frame,
            &p,
            &WetParams::new(wetness, &FilmOptics::water(), reach_m),
            None,
        );
        let cpu = rgb_to_yuv::rgb_to_yuv(&canvas, frame.format, &frame.color);
        let dry = codes(&render(&ctx, &frame, &setup(&camera, rotation, None), &p));
        let (mut worst, mut changed) = (0, 0);
        for plane in 0..3 {
            for ((g, c), d) in gpu[plane].iter().zip(&cpu[plane]).zip(&dry[plane]) {
                worst = worst.max(g.abs_diff(*c));
                changed += (g != d) as usize;
            }
        }
        eprintln!("rotation {rotation}: w = {wetness:.3}, worst {worst} codes, {changed} changed");
        // f16 canvas on the GPU against f64 on the CPU.
        assert!(worst <= 2, "{worst} codes off");
        assert!(changed > 200, "the ground wets: {changed} samples changed");
    }
}

#[test]
fn nothing_changes_at_or_above_the_horizon() {
    let Some(ctx) = gpu() else { return };
    for (rotation, tilt_deg, roll_deg) in [(0, 0.0, 0.0), (0, 10.0, 25.0), (270, -15.0, -30.0)] {
        let camera = Camera::new(
            64,
            40,
            1.1,
            1.6,
            f64::to_radians(tilt_deg),
            f64::to_radians(roll_deg),
        );
        let wet = setup(&camera, rotation, Some(drying()));
        let p = lit(&wet, 0.0, &SKY, Some(1.0));
        let (w, h) = (
            wet.params.coded_size_px[0] as u32,
            wet.params.coded_size_px[1] as u32,
        );
        let frame = picture(w, h, None);
        let after = codes(&render(&ctx, &frame, &wet, &p));
        let before = codes(&render(&ctx, &frame, &setup(&camera, rotation, None), &p));
        let (mut sky, mut ground_changed, mut ground) = (0, 0, 0);
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let d = yuv_to_rgb::view_ray(&p, x, y);
                let same = (0..3).all(|k| after[k][i] == before[k][i]);
                // (a margin for the GPU's f32 rays at the horizon itself)
                if d.z >= 1e-5 * d.length() {
                    sky += 1;
                    assert!(same, "pixel ({x}, {y}) at or above the horizon changed");
                } else if d.z < 0.0 {
                    ground += 1;
                    ground_changed += !same as usize;
                }
            }
        }
        eprintln!(
            "rotation {rotation}, tilt {tilt_deg}, roll {roll_deg}: {sky} sky pixels, {ground_changed}/{ground} ground pixels changed"
        );
        assert!(sky > 100 && ground > 100);
        assert!(ground_changed as f64 > 0.9 * ground as f64);
    }
}

#[test]
fn a_grey_ground_darkens_as_the_closed_form_says() {
    let Some(ctx) = gpu() else { return };
    // The ground unbounded, then reaching 8 m: the wetting fades out from 4 to 8 m.
    for reach_m in [0.0, 8.0] {
        grey_ground_closed_form(&ctx, reach_m);
    }
}

fn grey_ground_closed_form(ctx: &std::sync::Arc<GpuContext>, reach_m: f64) {
    let camera = Camera::new(40, 60, 1.2, 1.6, f64::to_radians(-20.0), 0.0);
    let wetting = Wetting {
        reach_m,
        ..drying()
    };
    let t = 300.0;
    let s = setup(&camera, 0, Some(wetting.clone()));
    // A uniform sky of radiance 2: irradiance 2π on the ground, and the mirror image is 2.
    let sky = 2.0;
    let y00 = 0.5 / std::f64::consts::PI.sqrt();
    let c0 = (sky / y00) as f32;
    let p = lit(&s, t, &[(0, [c0, c0, c0])], Some(1.0));
    let frame = picture(40, 60, Some(400));
    let gpu = codes(&render(ctx, &frame, &s, &p));
    let dry = frame.color.code_to_linear([400.0, 512.0, 512.0])[1];
    let albedo = std::f64::consts::PI * dry / (std::f64::consts::PI * sky);
    let w = wetting.wetness_at(t);
    // Lekner & Dorf with this file's own Fresnel and diffuse reflectances.
    let n2 = WATER_INDEX * WATER_INDEX;
    let m = 20_000;
    let r_ext: f64 = (0..m)
        .map(|i| {
            let theta = (i as f64 + 0.5) / m as f64 * std::f64::consts::FRAC_PI_2;
            fresnel_angles(theta) * (2.0 * theta).sin()
        })
        .sum::<f64>()
        * std::f64::consts::FRAC_PI_2
        / m as f64;
    let r_int = 1.0 - (1.0 - r_ext) / n2;
    let mut expected = Vec::new();
    let mut ratios = Vec::new();
    for y in 0..60 {
        for x in 0..40 {
            let d = camera.ray_world(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
            let v = if d.z < 0.0 {
                let r = fresnel_angles((-d.z).acos());
                let k = (1.0 - r) * (1.0 - r_ext) / (n2 * (1.0 - albedo * r_int));
                // The camera is 1.6 m up: the ray meets the ground 1.6/cos(view) away.
                let distance_m = 1.6 / (-d.z / d.length());
                let fade = if reach_m <= 0.0 || distance_m <= 0.5 * reach_m {
                    1.0
                } else if distance_m >= reach_m {
                    0.0
                } else {
                    let x = 2.0 * distance_m / reach_m - 1.0;
                    1.0 - x * x * (3.0 - 2.0 * x)
                };
                let w = w * fade;
                ratios.push(1.0 + w * (k - 1.0));
                dry * (1.0 + w * (k - 1.0)) + w * r * sky
            } else {
                dry
            };
            expected.push([v; 3]);
        }
    }
    let cpu = rgb_to_yuv::rgb_to_yuv(&expected, frame.format, &frame.color);
    let worst = (0..3)
        .flat_map(|k| gpu[k].iter().zip(&cpu[k]).map(|(a, b)| a.abs_diff(*b)))
        .max()
        .unwrap_or(0);
    let (lo, hi) = ratios
        .iter()
        .fold((f64::MAX, f64::MIN), |(lo, hi), &r| (lo.min(r), hi.max(r)));
    eprintln!(
        "reach {reach_m} m: albedo {albedo:.3}, w {w:.3}: diffuse ratio {lo:.3}..{hi:.3}, worst {worst} codes"
    );
    assert!(worst <= 2, "{worst} codes off");
    assert!(lo < 0.8, "the near wet ground is darker: {lo}");
    if reach_m > 0.0 {
        assert!(hi > 0.999, "beyond the reach the ground stays dry: {hi}");
    } else {
        assert!(hi < 0.8, "the wet ground is darker: {hi}");
    }
}

#[test]
fn without_a_ground_the_frame_is_bit_identical() {
    let Some(ctx) = gpu() else { return };
    let camera = Camera::new(32, 24, 1.0, 1.6, f64::to_radians(-10.0), 0.0);
    let none = GroundConfig {
        mode: GroundMode::None,
        pre_rain_min: 30.0,
        ..GroundConfig::default()
    };
    let rain = RainConfig::default();
    let plain = rain_composite::shot::rain::plan(
        &camera,
        &CameraConfig::default(),
        &rain,
        0.01,
        0,
        (32, 24),
    )
    .map(RainSetup::pack)
    .expect("rain");
    let with_none = plain
        .clone()
        .with_ground(none.is_given())
        .with_wetting(none.wetting(None, rain.rate_mm_per_h, rain.scene_depth_m));
    assert!(with_none.wetting.is_none());
    let frame = picture(32, 24, None);
    let p = lit(&plain, 1.0, &SKY, Some(0.95));
    assert_eq!(
        codes(&render(&ctx, &frame, &plain, &p)),
        codes(&render(
            &ctx,
            &frame,
            &with_none,
            &lit(&with_none, 1.0, &SKY, Some(0.95))
        ))
    );
}

/// Cost of the wet ground per 1280×720 frame (no drops, so only the ground differs): wall time
/// per frame through the compositor with and without it, and the stage's GPU time.
/// `cargo test --release --test wet_ground -- --ignored --nocapture`
#[test]
#[ignore]
fn report_cost_per_frame_at_720p() {
    let Some(ctx) = gpu() else { return };
    let camera = Camera::new(1280, 720, 1.05, 1.6, f64::to_radians(-5.0), 0.0);
    // The stage's cost depends on the canvas only, not on the chroma layout.
    let frame = picture(1280, 720, None);
    let frames = 30;
    println!("| 720p | ms/frame (wall) | wet_ground GPU ms/frame |");
    println!("|---|---|---|");
    for (name, wetting) in [
        ("dry (no ground)", None),
        ("wet ground", Some(drying())),
        ("dry (no ground)", None),
        ("wet ground", Some(drying())),
    ] {
        let s = setup(&camera, 0, wetting);
        let p = lit(&s, 10.0, &SKY, Some(0.9));
        let mut comp =
            Compositor::new(ctx.clone(), frame.format, &frame.color, &s).expect("compositor");
        comp.render_one(&frame, &p).expect("warm-up");
        let start = std::time::Instant::now();
        let before = comp.gpu_times().wet_ground_s;
        for _ in 0..frames {
            comp.submit(&frame, &p).expect("submit");
        }
        comp.flush().expect("flush");
        let wall_ms = 1e3 * start.elapsed().as_secs_f64() / frames as f64;
        let gpu_ms = 1e3 * (comp.gpu_times().wet_ground_s - before) / frames as f64;
        println!("| {name} | {wall_ms:.2} | {gpu_ms:.2} |");
    }
}

/// With a depth map, what stands on the ground (here a box 1 m from the lens, nearer than any
/// ground the camera sees) stays dry; a hole in the map (0) and a far reading count as ground,
/// exactly as without a map; the stage and its twin agree with the map.
#[test]
fn what_stands_on_the_ground_stays_dry_with_a_depth_map() {
    let Some(ctx) = gpu() else { return };
    let (w, h) = (48u32, 32u32);
    let camera = Camera::new(w, h, 1.0, 1.6, f64::to_radians(-15.0), 0.0);
    // Columns 0–15: a box at 1 m; 16–31: unknown; 32–47: 1 km.
    let column_m = |x: u32| match x {
        0..16 => 1.0,
        16..32 => 0.0,
        _ => 1000.0,
    };
    let values: Vec<f32> = (0..w * h).map(|i| column_m(i % w)).collect();
    let map = DepthMap::from_values(w as usize, h as usize, &values, 1.0).expect("map");
    let plain = setup(&camera, 0, Some(drying()));
    let with_map = plain.clone().with_scene_depth(true);
    let p = lit(&plain, 120.0, &SKY, Some(1.0));
    let frame = picture(w, h, None);
    let render_behind = |s: &RainSetup, depth: Option<&DepthMap>| {
        codes(&render_with(&ctx, &frame, s, &p, |comp| {
            if let Some(d) = depth {
                comp.set_scene_depth(d).expect("depth");
            }
        }))
    };
    let dry = codes(&render(&ctx, &frame, &setup(&camera, 0, None), &p));
    let unmasked = render_behind(&plain, None);
    let masked = render_behind(&with_map, Some(&map));
    let (mut box_wet, mut ground_changed, mut off_mask) = (0, 0, 0);
    for (i, ((m, u), d)) in masked[0].iter().zip(&unmasked[0]).zip(&dry[0]).enumerate() {
        let x = i as u32 % w;
        if x < 16 {
            box_wet += (m != d) as usize;
        } else {
            off_mask += (m != u) as usize;
            ground_changed += (m != d) as usize;
        }
    }
    eprintln!("box pixels wetted {box_wet}, ground changed {ground_changed}, off {off_mask}");
    assert_eq!(box_wet, 0, "the box stays dry");
    assert_eq!(off_mask, 0, "holes and far readings wet as without a map");
    assert!(ground_changed > 200, "{ground_changed}");
    // The twin, with the same map.
    let mut canvas = yuv_to_rgb::yuv_to_rgb(&frame, &p);
    let wetness = drying().wetness_at(120.0);
    wet_ground::wet_ground(
        &mut canvas,
        &frame,
        &p,
        &WetParams::new(wetness, &FilmOptics::water(), 0.0),
        Some(&map),
    );
    let cpu = rgb_to_yuv::rgb_to_yuv(&canvas, frame.format, &frame.color);
    let worst = (0..3)
        .flat_map(|k| masked[k].iter().zip(&cpu[k]).map(|(a, b)| a.abs_diff(*b)))
        .max()
        .unwrap_or(0);
    assert!(worst <= 2, "{worst} codes off");
}

/// The wet ground as a layer: α in [0, 1], colour ≥ 0, and the layer over the dry plate is the
/// wet picture (the twin's decomposition; `tests/layers.rs` checks the GPU's end to end).
#[test]
fn the_wet_ground_as_a_layer_over_the_plate_is_the_wet_picture() {
    let camera = Camera::new(48, 32, 1.0, 1.6, f64::to_radians(-10.0), 0.2);
    let s = setup(&camera, 0, Some(drying()));
    let p = lit(&s, 120.0, &SKY, Some(0.9));
    let frame = picture(48, 32, None);
    let wet = WetParams::new(drying().wetness_at(120.0), &FilmOptics::water(), 0.0);
    let mut picture = yuv_to_rgb::yuv_to_rgb(&frame, &p);
    wet_ground::wet_ground(&mut picture, &frame, &p, &wet, None);
    let mut clear = p;
    clear.haze[3] = 1.0;
    let plate = yuv_to_rgb::yuv_to_rgb(&frame, &clear);
    let mut layer: Vec<[f64; 4]> = vec![[0.0; 4]; plate.len()];
    wet_ground::wet_ground_layer(&mut layer, &frame, &p, &wet, None, None);
    let mut wet_px = 0;
    for ((l, plate), want) in layer.iter().zip(&plate).zip(&picture) {
        if l[3] == 0.0 {
            continue;
        }
        assert!((0.0..=1.0).contains(&l[3]), "alpha {}", l[3]);
        for k in 0..3 {
            assert!(l[k] >= 0.0, "colour {l:?}");
            let over = l[k] + plate[k] * (1.0 - l[3]);
            assert!((over - want[k]).abs() < 1e-12, "{over} vs {}", want[k]);
        }
        wet_px += usize::from(l[3] > 0.05);
    }
    assert!(wet_px > 300, "{wet_px} wet pixels");
}
