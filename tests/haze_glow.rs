//! The haze's glow around compact lights: the GPU stage against its CPU twin, the twin's halo
//! against a brute-force integral along the ray, no lights adding nothing, and the halo going
//! on below the horizon over a ground, wet or dry.
//! Set `RAIN_COMPOSITE_REQUIRE_GPU=1` to turn a missing adapter into a failure.

use glam::DVec3;
use rain_composite::config::{CameraConfig, RainConfig};
use rain_composite::gpu::cpu::{rgb_to_yuv, wet_ground, yuv_to_rgb};
use rain_composite::gpu::types::{LightList, RainParams, WetParams};
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::lighting::LightSource;
use rain_composite::lighting::wetness::{FilmOptics, RainHistory, SurfaceStore, Wetting};
use rain_composite::scene::Camera;
use rain_composite::video::{Chroma, ColorParams, FrameFormat, YuvFrame};

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/render.rs"]
mod render;
use render::{lit, render_with, water_tables};

#[path = "common/pictures.rs"]
mod pictures;
use pictures::codes;

const W: u32 = 96;
const H: u32 = 64;
/// The haze from the farthest drawn drop to the scene, metres, and its transmittance.
const HAZE_NEAR_M: f64 = 3.0;
const HAZE_FAR_M: f64 = 50.0;
const HAZE_T: f64 = 0.85;

fn camera() -> Camera {
    Camera::new(W, H, 60f64.to_radians(), 1.6, 0.0, 0.0)
}

/// No drops; a dim environment; the haze given by the constants above.
fn setup_and_params(cam: &Camera) -> (RainSetup, RainParams) {
    let setup = rain_composite::shot::rain::plan(
        cam,
        &CameraConfig::default(),
        &RainConfig {
            rate_mm_per_h: 0.0,
            ..RainConfig::default()
        },
        1.0 / 50.0,
        0,
        (W, H),
    )
    .map(RainSetup::pack)
    .expect("rain");
    let mut p = lit(&setup, 0.0, &[(0, [0.05, 0.05, 0.08])], None);
    p.haze = [HAZE_NEAR_M as f32, HAZE_FAR_M as f32, 0.0, HAZE_T as f32];
    (setup, p)
}

/// A dark night frame, 8-bit BT.709 4:2:0.
fn dark_frame() -> YuvFrame {
    let format = FrameFormat {
        width: W,
        height: H,
        chroma: Chroma::Cs420,
        bit_depth: 8,
    };
    YuvFrame::filled(format, ColorParams::bt709(8), [24, 130, 126])
}

/// The GPU frame with `lights` in the haze, and the CPU twins' (yuv_to_rgb with the glow →
/// rgb_to_yuv).
fn both(lights: &[LightSource]) -> ([Vec<u16>; 3], [Vec<u16>; 3]) {
    let ctx = gpu().expect("adapter");
    let cam = camera();
    let (setup, p) = setup_and_params(&cam);
    let frame = dark_frame();
    let tables = water_tables(1024);
    let list = LightList::new(lights);
    let gpu = codes(&render_with(&ctx, &frame, &setup, &p, |comp| {
        comp.set_transfer_table(&tables);
        comp.set_lights(&list);
    }));
    let canvas = yuv_to_rgb::yuv_to_rgb_lit(&frame, &p, &list, &tables);
    (
        gpu,
        rgb_to_yuv::rgb_to_yuv(&canvas, frame.format, &frame.color),
    )
}

#[test]
fn gpu_glow_matches_the_cpu_twin() {
    if gpu().is_none() {
        return;
    }
    let cam = camera();
    let (gpu, cpu) = both(&render::lamps(&cam));
    let mut worst = 0;
    for (g, c) in gpu[0].iter().zip(&cpu[0]) {
        worst = worst.max(g.abs_diff(*c));
    }
    for (g, c) in gpu.iter().zip(&cpu).skip(1) {
        for (a, b) in g.iter().zip(c) {
            worst = worst.max(a.abs_diff(*b));
        }
    }
    assert!(worst <= 1, "{worst} codes off");
    // The halo shows: the luma next to the lamp at infinity is well above the veil's far from
    // both lamps.
    let luma = |x: u32, y: u32| gpu[0][(y * W + x) as usize];
    assert!(
        luma(72, 30) >= luma(50, 60) + 5,
        "{} {}",
        luma(72, 30),
        luma(50, 60)
    );
}

/// Without lights the glow adds nothing: the GPU frame is the one without any light list, and
/// the twin's canvas is exactly the unlit one.
#[test]
fn no_lights_add_nothing() {
    let cam = camera();
    let (_, p) = setup_and_params(&cam);
    let frame = dark_frame();
    let tables = water_tables(1024);
    let unlit = yuv_to_rgb::yuv_to_rgb(&frame, &p);
    let lit = yuv_to_rgb::yuv_to_rgb_lit(&frame, &p, &LightList::new(&[]), &tables);
    assert_eq!(unlit, lit);
    if gpu().is_none() {
        return;
    }
    let (gpu, cpu) = both(&[]);
    let worst = gpu
        .iter()
        .zip(&cpu)
        .flat_map(|(g, c)| g.iter().zip(c).map(|(a, b)| a.abs_diff(*b)))
        .max();
    assert!(worst <= Some(1));
}

/// The halo's profile along a row through each lamp, against a brute-force integral along the
/// ray: a fine Riemann sum over s of β e^(−β (s − s_near)) · L Ω (d / r)² · F(θ) (β the haze's
/// extinction as a picture sees it: the diffracted half of a drop's extinction stays within
/// 0.03° of the beam, so what the beam loses is what the geometric optics F scatter), with F
/// from a table eight times finer read as its bin averages, and the geometry in plain vectors.
#[test]
fn glow_follows_the_single_scattering_integral() {
    let cam = camera();
    let (_, p) = setup_and_params(&cam);
    let coarse = water_tables(1024);
    let fine = water_tables(8192);
    let beta = -HAZE_T.ln() / (HAZE_FAR_M - HAZE_NEAR_M);
    for lamp in render::lamps(&cam) {
        let list = LightList::new(std::slice::from_ref(&lamp));
        let lamp_px = {
            let mut best = (0, 0, -2.0);
            for y in 0..H {
                for x in 0..W {
                    let d = yuv_to_rgb::view_ray(&p, x, y).normalize();
                    let c = d.dot(lamp.direction_world);
                    if c > best.2 {
                        best = (x, y, c);
                    }
                }
            }
            (best.0, best.1)
        };
        let min_m = lamp.min_distance_m().unwrap_or(0.0);
        let mut profile = Vec::new();
        for x in 0..W {
            let y = lamp_px.1;
            // The ray through the pixel's centre.
            let v = yuv_to_rgb::view_ray(&p, x, y).normalize();
            let glow = yuv_to_rgb::haze_glow_along(&p, &list, &coarse, v);
            let steps = 100_000;
            let ds = (HAZE_FAR_M - HAZE_NEAR_M) / steps as f64;
            let mut truth = [0.0; 3];
            for i in 0..steps {
                let s = HAZE_NEAR_M + (i as f64 + 0.5) * ds;
                let drop = v * s;
                let (to_light, scale) = match lamp.distance_m {
                    None => (lamp.direction_world, 1.0),
                    Some(d) => {
                        let r: DVec3 = lamp.direction_world * d - drop;
                        (r.normalize(), (d / r.length().max(min_m)).powi(2))
                    }
                };
                let theta = to_light.dot(v).clamp(-1.0, 1.0).acos();
                let w = beta * (-beta * (s - HAZE_NEAR_M)).exp() * ds * scale;
                for k in 0..3 {
                    truth[k] +=
                        w * lamp.radiance_rgb[k] * lamp.solid_angle_sr * fine[k].value(theta);
                }
            }
            profile.push((x, glow, truth));
        }
        // The halo peaks at the lamp; a lamp at a finite distance is seen by the haze's drops
        // under angles that sweep through the bows, which 16 samples follow to a few per cent
        // of the peak.
        let peak: f64 = profile.iter().map(|(_, _, t)| t[1]).fold(0.0, f64::max);
        let (x_peak, _, _) = profile
            .iter()
            .max_by(|a, b| a.2[1].total_cmp(&b.2[1]))
            .expect("a row");
        assert!(
            x_peak.abs_diff(lamp_px.0) <= 1,
            "the halo peaks at the lamp"
        );
        let tolerance = if lamp.distance_m.is_some() {
            0.02
        } else {
            0.002
        };
        for (x, glow, truth) in &profile {
            for k in 0..3 {
                let err = (glow[k] - truth[k]).abs();
                assert!(
                    err <= 0.01 * truth[k] + tolerance * peak,
                    "lamp at {:?} m, pixel {x}: channel {k}: {} vs {} (peak {peak})",
                    lamp.distance_m,
                    glow[k],
                    truth[k]
                );
            }
        }
    }
}

/// The ground of the lamp-lit night: the level camera of [`camera`] (the horizon across the
/// picture's middle), the ground given, the wet ground reaching `REACH_M` when `wet`.
const REACH_M: f64 = 12.0;

fn ground_setup(cam: &Camera, wet: bool) -> RainSetup {
    let (setup, _) = setup_and_params(cam);
    let wetting = Wetting {
        store: SurfaceStore::default(),
        history: RainHistory::new(vec![(-600.0, 10.0), (0.0, 0.0)]).expect("history"),
        reach_m: REACH_M,
    };
    setup.with_ground(true).with_wetting(wet.then_some(wetting))
}

/// The haze of [`setup_and_params`] with its extinction, so that it ends on the ground.
fn ground_params(setup: &RainSetup) -> RainParams {
    let mut p = lit(setup, 0.0, &[(0, [0.05, 0.05, 0.08])], None);
    let beta = -HAZE_T.ln() / (HAZE_FAR_M - HAZE_NEAR_M);
    p.haze = [
        HAZE_NEAR_M as f32,
        HAZE_FAR_M as f32,
        beta as f32,
        HAZE_T as f32,
    ];
    p
}

/// A bright lamp at infinity 4° above the horizon, mid-picture: its halo reaches well below
/// the horizon.
fn street_lamp(cam: &Camera) -> LightSource {
    LightSource {
        direction_world: cam.ray_world(glam::DVec2::new(48.0, 26.0)).normalize(),
        solid_angle_sr: 2e-4,
        radiance_rgb: [3000.0, 2400.0, 1200.0],
        distance_m: None,
    }
}

/// Whether coded pixel (x, y) shows ground the wetting leaves dry (farther than the reach,
/// with a margin for the GPU's f32 rays).
fn beyond_reach(p: &RainParams, x: u32, y: u32) -> bool {
    let d = yuv_to_rgb::view_ray(p, x, y).normalize();
    d.z < -1e-3 && 1.6 / -d.z > 1.02 * REACH_M
}

/// The wetness of [`ground_setup`]'s ground at the frame's time.
fn wet_params() -> WetParams {
    let wetting = ground_setup(&camera(), true)
        .wetting
        .clone()
        .expect("a wetting ground");
    WetParams::new(wetting.wetness_at(0.0), &FilmOptics::water(), REACH_M)
}

/// At night the lamps' halo goes on below the horizon over a ground: where the ground stays
/// dry (beyond the wetting's reach) the frame with the wet ground is, within a code, the frame
/// without it, halo included; where it is wet the GPU agrees with the twin, whose wet ground
/// keeps the glow the haze laid there.
#[test]
fn the_glow_goes_on_over_the_ground() {
    let Some(ctx) = gpu() else { return };
    let cam = camera();
    let (plain, wet) = (ground_setup(&cam, false), ground_setup(&cam, true));
    let p = ground_params(&plain);
    let frame = dark_frame();
    let tables = water_tables(1024);
    let lamp = LightList::new(&[street_lamp(&cam)]);
    let draw = |setup: &RainSetup, lights: &LightList| {
        codes(&render_with(&ctx, &frame, setup, &p, |comp| {
            comp.set_transfer_table(&tables);
            comp.set_lights(lights);
        }))
    };
    let unlit = draw(&plain, &LightList::new(&[]));
    let lit_plain = draw(&plain, &lamp);
    let lit_wet = draw(&wet, &lamp);
    // A sample is dry when every pixel it covers is (chroma is 4:2:0).
    let dry_sample = |plane: usize, i: usize| {
        let (step, w) = if plane == 0 { (1, W) } else { (2, W / 2) };
        let (sx, sy) = ((i as u32 % w) * step, (i as u32 / w) * step);
        (0..step).all(|dy| (0..step).all(|dx| beyond_reach(&p, sx + dx, sy + dy)))
    };
    let (mut dry, mut worst_dry, mut halo) = (0, 0, 0);
    for plane in 0..3 {
        for i in 0..lit_plain[plane].len() {
            if !dry_sample(plane, i) {
                continue;
            }
            dry += 1;
            worst_dry = worst_dry.max(lit_wet[plane][i].abs_diff(lit_plain[plane][i]));
            halo += usize::from(plane == 0 && lit_plain[0][i] >= unlit[0][i] + 2);
        }
    }
    eprintln!("{dry} dry ground samples, worst {worst_dry} codes; {halo} lumas lit by the halo");
    // The halo is on the dry ground (a wet ground that dropped it would be off by as much).
    assert!(halo > 40, "{halo} lumas lit by the halo");
    assert!(worst_dry <= 1, "{worst_dry} codes off on the dry ground");
    // The whole frame against the twin, wet ground and glow.
    let glow = yuv_to_rgb::haze_glow(&p, &lamp, &tables, (W, H));
    let mut canvas = yuv_to_rgb::yuv_to_rgb_lit(&frame, &p, &lamp, &tables);
    wet_ground::wet_ground_lit(
        &mut canvas,
        &frame,
        &p,
        &wet_params(),
        None,
        None,
        Some(&glow),
    );
    let twin = rgb_to_yuv::rgb_to_yuv(&canvas, frame.format, &frame.color);
    let (mut worst, mut wetted) = (0, 0);
    for plane in 0..3 {
        for (i, (g, c)) in lit_wet[plane].iter().zip(&twin[plane]).enumerate() {
            worst = worst.max(g.abs_diff(*c));
            wetted += usize::from(g != &lit_plain[plane][i]);
        }
    }
    eprintln!("GPU against the twin: worst {worst} codes, {wetted} samples wetted");
    assert!(worst <= 1, "{worst} codes off the twin");
    assert!(wetted > 300, "the near ground wets: {wetted} samples");
}

/// The wet ground's change is the film's alone: on every pixel, the wet ground minus the
/// ground before it is the same with the lamp as without (the glow passes through untouched,
/// none lost, none added twice), while the glow lies on the wet pixels; and as a layer over
/// the plate it gives back the lit wet picture exactly.
#[test]
fn the_wet_ground_keeps_the_glow_it_lies_under() {
    let cam = camera();
    let p = ground_params(&ground_setup(&cam, true));
    let frame = dark_frame();
    let tables = water_tables(1024);
    let lamp = LightList::new(&[street_lamp(&cam)]);
    let glow = yuv_to_rgb::haze_glow(&p, &lamp, &tables, (W, H));
    let wet = wet_params();
    let wetted = |before: &[[f64; 3]], glow: Option<&[[f64; 3]]>| {
        let mut c = before.to_vec();
        wet_ground::wet_ground_lit(&mut c, &frame, &p, &wet, None, None, glow);
        c
    };
    let dark = yuv_to_rgb::yuv_to_rgb_with_depth(&frame, &p, None);
    let lamplit = yuv_to_rgb::yuv_to_rgb_lit(&frame, &p, &lamp, &tables);
    let (wet_dark, wet_lit) = (wetted(&dark, None), wetted(&lamplit, Some(&glow)));
    let mut glowing_wet = 0;
    for i in 0..dark.len() {
        let (x, y) = (i as u32 % W, i as u32 / W);
        for k in 0..3 {
            let film_dark = wet_dark[i][k] - dark[i][k];
            let film_lit = wet_lit[i][k] - lamplit[i][k];
            assert!(
                (film_lit - film_dark).abs() < 1e-12,
                "pixel ({x}, {y}): the film changes it by {film_lit} lit, {film_dark} dark"
            );
        }
        let wet_here = wet_dark[i] != dark[i];
        glowing_wet += usize::from(wet_here && lamplit[i][1] - dark[i][1] > 1e-3);
    }
    assert!(glowing_wet > 100, "{glowing_wet} wet pixels under the halo");
    // As a layer: over the plate, the lit wet picture.
    let mut clear = p;
    clear.haze[3] = 1.0;
    let plate = yuv_to_rgb::yuv_to_rgb(&frame, &clear);
    let mut layer = vec![[0.0; 4]; plate.len()];
    wet_ground::wet_ground_layer(&mut layer, &frame, &p, &wet, None, Some(&glow));
    let mut ground = 0;
    for ((l, plate), want) in layer.iter().zip(&plate).zip(&wet_lit) {
        if l[3] == 0.0 && l[..3] == [0.0; 3] {
            continue;
        }
        ground += 1;
        for k in 0..3 {
            let over = l[k] + plate[k] * (1.0 - l[3]);
            assert!((over - want[k]).abs() < 1e-12, "{over} vs {}", want[k]);
        }
    }
    assert!(ground > 1000, "{ground} ground pixels on the layer");
}
