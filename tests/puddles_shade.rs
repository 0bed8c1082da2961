//! Puddles in the picture: the ripple rings against the group velocity of capillary–gravity
//! waves (and against a brute-force superposition of Bessel modes), the water's Fresnel
//! reflectance at normal and grazing incidence against the angle form of Fresnel's equations,
//! mirror images at the mirrored position of the object (at a distance, and standing on the
//! ground with a depth map), and the GPU stage against its CPU twin.
//! Set `RAIN_COMPOSITE_REQUIRE_GPU=1` to turn a missing adapter into a failure.

use std::f64::consts::{PI, TAU};
use std::sync::Arc;

use glam::{DVec2, DVec3, Vec2};
use rain_composite::fluid::Field2;
use rain_composite::fluid::ripples::{Ring, live_rings};
use rain_composite::gpu::cpu::puddles::{self, Water};
use rain_composite::gpu::cpu::{rgb_to_yuv, yuv_to_rgb};
use rain_composite::gpu::stages::puddles::{EDGE_DEPTH_M, water_params};
use rain_composite::gpu::types::{LightList, PuddleParams, RainParams, Ripple};
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::gpu::{Compositor, GpuContext};
use rain_composite::lighting::LightSource;
use rain_composite::lighting::wetness::{FilmOptics, WATER_INDEX};
use rain_composite::rain::volume::impacts::Impact;
use rain_composite::scene::{Camera, DepthMap};
use rain_composite::video::{ColorParams, YuvFrame};

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/render.rs"]
mod render;
use render::{dry_ground, lit, render_with};

#[path = "common/pictures.rs"]
mod pictures;

#[path = "common/rims.rs"]
mod rims;
use pictures::{codes, picture_444, plane_codes};
use rims::{rim_offsets_m, spread};

// ---------------------------------------------------------------------------------------------
// Ripples.

const G: f64 = 9.80665;
const SIGMA_OVER_RHO: f64 = 0.0728 / 1000.0;

/// ω(k) of capillary–gravity waves on deep water, written here.
fn omega(k: f64) -> f64 {
    (G * k + SIGMA_OVER_RHO * k * k * k).sqrt()
}

/// dω/dk by a central difference.
fn group_speed(k: f64) -> f64 {
    let h = 1e-4 * k;
    (omega(k + h) - omega(k - h)) / (2.0 * h)
}

/// J₀(x): Bessel's integral (1/π)∫₀^π cos(x sin θ) dθ by the midpoint rule where it converges
/// fast, Hankel's asymptotic form (two terms) beyond.
fn bessel_j0(x: f64) -> f64 {
    if x < 30.0 {
        let n = 128;
        (0..n)
            .map(|i| (x * ((i as f64 + 0.5) * PI / n as f64).sin()).cos())
            .sum::<f64>()
            / n as f64
    } else {
        let phase = x - PI / 4.0;
        (2.0 / (PI * x)).sqrt() * (phase.cos() + phase.sin() / (8.0 * x))
    }
}

/// The radius of a ring's energy, Σ η² r · r / Σ η² r, over r in (0, r_max).
fn energy_radius(eta: impl Fn(f64) -> f64, r_max: f64) -> f64 {
    let n = 3000;
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..n {
        let r = (i as f64 + 0.5) * r_max / n as f64;
        let e = eta(r).powi(2) * r;
        num += e * r;
        den += e;
    }
    num / den
}

#[test]
fn a_ring_grows_at_the_group_velocity_of_its_dominant_wavelength() {
    let impact = Impact {
        id: 1,
        pass: 0,
        time_s: 0.0,
        position_m: DVec3::ZERO,
        diameter_mm: 2.0,
        velocity_mps: DVec3::new(0.0, 0.0, -6.5),
    };
    let ring = Ring::from_impact(&impact);
    let k0 = ring.wavenumber;
    let c_g = group_speed(k0);
    let c_p = omega(k0) / k0;
    let (t1, t2) = (0.2, 0.6);
    // The model's surface.
    let radius = |t: f64| {
        let s = ring.at(t).expect("alive");
        energy_radius(|r| s.height(k0, r), 0.6)
    };
    let model = (radius(t2) - radius(t1)) / (t2 - t1);
    // The exact linear solution for a bump of the same spectrum: ∫ A(k) J₀(k r) cos(ω t) k dk,
    // A Gaussian about k₀ as wide as the model's packet (1/s₀ = k₀/2π).
    let dk = k0 / TAU;
    let ks: Vec<f64> = (0..400)
        .map(|i| k0 - 5.0 * dk + 10.0 * dk * (i as f64 + 0.5) / 400.0)
        .collect();
    let modes = |t: f64| {
        energy_radius(
            |r| {
                ks.iter()
                    .map(|&k| {
                        let a = (-0.5 * ((k - k0) / dk).powi(2)).exp();
                        a * bessel_j0(k * r) * (omega(k) * t).cos() * k
                    })
                    .sum()
            },
            0.6,
        )
    };
    let exact = (modes(t2) - modes(t1)) / (t2 - t1);
    eprintln!(
        "k₀ = {k0:.0} rad/m: c_g = {c_g:.4}, c_p = {c_p:.4}; ring speed: model {model:.4}, Bessel modes {exact:.4} m/s"
    );
    assert!((model - c_g).abs() < 0.1 * c_g, "model {model} vs {c_g}");
    assert!((exact - c_g).abs() < 0.1 * c_g, "modes {exact} vs {c_g}");
    // The test tells the two speeds apart: a ring at the phase speed would fail it.
    assert!((c_p - c_g).abs() > 0.2 * c_g);
    // Viscosity and spreading flatten it: the crest height falls with time.
    let heights: Vec<f64> = [0.1, 0.4, 0.8, 1.2]
        .iter()
        .map(|&t| ring.at(t).expect("alive").amplitude_m)
        .collect();
    assert!(heights.windows(2).all(|w| w[1] < w[0]), "{heights:?}");
    assert!(ring.at(-0.01).is_none() && ring.at(10.0).is_none());
}

// ---------------------------------------------------------------------------------------------
// Pictures, setups, renders.

fn grey(_: u32, _: u32, _: usize) -> u16 {
    512
}

/// No rain drawn; the ground z = 0 under `camera`.
fn setup(camera: &Camera, depth: bool) -> RainSetup {
    dry_ground(camera, 0).with_scene_depth(depth)
}

/// A uniform sky of radiance `l`: its only coefficient.
fn uniform_sky(l: f64) -> [(usize, [f32; 3]); 1] {
    let c = (l * 2.0 * PI.sqrt()) as f32;
    [(0, [c, c, c])]
}

/// Water `depth_m` deep everywhere within `half_m` of the camera's foot.
fn lake(depth_m: f32, half_m: f32) -> Field2 {
    let n = 64;
    Field2 {
        nx: n,
        ny: n,
        origin_m: Vec2::splat(-half_m),
        cell_m: 2.0 * half_m / n as f32,
        values: vec![depth_m; n * n],
    }
}

/// What a compositor is given besides the frame.
#[derive(Default)]
struct Inputs<'a> {
    water: Option<&'a Field2>,
    impacts: &'a [Impact],
    lights: Option<&'a LightList>,
    depth: Option<&'a DepthMap>,
    /// The far water's RMS slope and the depth where it takes over, m.
    far: Option<(f64, f64)>,
}

fn render(
    ctx: &Arc<GpuContext>,
    frame: &YuvFrame,
    setup: &RainSetup,
    p: &RainParams,
    inputs: &Inputs<'_>,
) -> YuvFrame {
    render_with(ctx, frame, setup, p, |comp| {
        if let Some(lights) = inputs.lights {
            comp.set_lights(lights);
        }
        if let Some(depth) = inputs.depth {
            comp.set_scene_depth(depth).expect("depth");
        }
        if let Some(water) = inputs.water {
            comp.set_water(water).expect("water");
            comp.set_ripples(inputs.impacts).expect("ripples");
            if let Some((slope_rms, depth_m)) = inputs.far {
                comp.set_far_ripples(slope_rms, depth_m)
                    .expect("far ripples");
            }
        }
    })
}

fn puddle_params(water: &Field2, rings: usize) -> PuddleParams {
    PuddleParams {
        ring_count: rings as u32,
        ..water_params(
            water.origin_m.to_array(),
            water.cell_m,
            [water.nx as u32, water.ny as u32],
        )
    }
}

// ---------------------------------------------------------------------------------------------
// GPU against the CPU twin.

#[test]
fn the_stage_matches_its_cpu_twin() {
    let Some(ctx) = gpu() else { return };
    // Stored as shown, and turned 90° (the reflection's projection goes back to coded pixels).
    for rotation_deg in [0, 90] {
        twin_case(&ctx, rotation_deg);
    }
}

fn twin_case(ctx: &Arc<GpuContext>, rotation_deg: i32) {
    let camera = Camera::new(
        96,
        64,
        1.0,
        1.6,
        f64::to_radians(-8.0),
        f64::to_radians(8.0),
    );
    let s = dry_ground(&camera, rotation_deg).with_scene_depth(false);
    let (w, h) = (
        s.params.coded_size_px[0] as u32,
        s.params.coded_size_px[1] as u32,
    );
    let t_s = 1.0;
    let sky = [
        (0, [1.6, 1.8, 2.2]),
        (2, [0.5, 0.6, 0.8]),
        (3, [0.3, 0.2, 0.1]),
    ];
    let p = lit(&s, t_s, &sky, Some(0.9));
    let frame = picture_444(
        w,
        h,
        |x, y| (100 + ((x * 37 + y * 91).wrapping_mul(2654435761) >> 7) % 700) as u16,
        |x, y, i| (480 + ((x * 13 + y * 7 + i as u32 * 5) % 64)) as u16,
    );
    // Puddles and dry ground between them, with soft edges, 0.25 m cells.
    let (nx, ny) = (48, 80);
    let water = Field2 {
        nx,
        ny,
        origin_m: Vec2::new(-6.0, 0.0),
        cell_m: 0.25,
        values: (0..nx * ny)
            .map(|k| {
                let (x, y) = ((k % nx) as f32 * 0.25 - 6.0, (k / nx) as f32 * 0.25);
                (0.02 * x.sin() * (0.5 * y).cos() + 0.004).max(0.0)
            })
            .collect(),
    };
    let impact = |x: f64, y: f64, t: f64, d_mm: f64| Impact {
        id: 0,
        pass: 0,
        time_s: t,
        position_m: DVec3::new(x, y, 0.0),
        diameter_mm: d_mm,
        velocity_mps: DVec3::new(0.0, 0.0, -6.0),
    };
    let impacts = [
        impact(0.3, 4.0, 0.7, 3.0),
        impact(-0.8, 5.0, 0.5, 2.5),
        impact(0.9, 3.2, 0.85, 2.0),
        impact(0.0, 3.0, 0.1, 2.0),
    ];
    // A lamp above the water ahead: its mirror image leaves the frame at the top.
    let (el, az) = (f64::to_radians(24.0), f64::to_radians(4.0));
    let lamp = LightSource {
        direction_world: DVec3::new(az.sin() * el.cos(), az.cos() * el.cos(), el.sin()),
        solid_angle_sr: 2e-4,
        radiance_rgb: [400.0, 300.0, 200.0],
        distance_m: Some(30.0),
    };
    let lights = LightList::new(&[lamp]);
    let gpu = codes(&render(
        ctx,
        &frame,
        &s,
        &p,
        &Inputs {
            water: Some(&water),
            impacts: &impacts,
            lights: Some(&lights),
            ..Inputs::default()
        },
    ));
    let dry = codes(&render(
        ctx,
        &frame,
        &s,
        &p,
        &Inputs {
            lights: Some(&lights),
            ..Inputs::default()
        },
    ));
    let frame_t = p.time_whole_s as f64 + p.time_frac_s as f64;
    let rings = live_rings(
        &impacts.iter().map(Ring::from_impact).collect::<Vec<_>>(),
        frame_t,
    );
    let ripples: Vec<Ripple> = rings
        .iter()
        .filter_map(|r| Ripple::new(r, frame_t))
        .collect();
    let twin = |ripples: &[Ripple], far: (f32, f32)| {
        let params = PuddleParams {
            far_slope_rms: far.0,
            resolve_depth_m: far.1,
            ..puddle_params(&water, ripples.len())
        };
        let mut canvas = yuv_to_rgb::yuv_to_rgb(&frame, &p);
        puddles::puddles(
            &mut canvas,
            &frame,
            &p,
            &Water {
                params: &params,
                depth_m: &water.values,
                ripples,
                lights: &lights,
            },
            None,
        );
        rgb_to_yuv::rgb_to_yuv(&canvas, frame.format, &frame.color)
    };
    let cpu = twin(&ripples, (0.0, 0.0));
    let flat = twin(&[], (0.0, 0.0));
    let (mut worst, mut changed, mut rippled) = (0, 0, 0);
    for plane in 0..3 {
        for i in 0..gpu[plane].len() {
            worst = worst.max(gpu[plane][i].abs_diff(cpu[plane][i]));
            changed += (gpu[plane][i] != dry[plane][i]) as usize;
            rippled += (cpu[plane][i].abs_diff(flat[plane][i]) > 2) as usize;
        }
    }
    eprintln!(
        "turned {rotation_deg}°, {} rings: worst {worst} codes, {changed} samples changed, {rippled} moved by the rings",
        ripples.len()
    );
    assert_eq!(ripples.len(), 4);
    // f16 canvas on the GPU against f64 on the CPU.
    assert!(worst <= 2, "{worst} codes off");
    assert!(changed > 1000, "the water shows: {changed} samples changed");
    assert!(rippled > 10, "the rings show: {rippled}");
    // The far water rained on (RMS slope 0.1 beyond 4 m, fully from 8 m): a blurred
    // reflection there, the same on both.
    let far = (0.1, 4.0);
    let gpu_far = codes(&render(
        ctx,
        &frame,
        &s,
        &p,
        &Inputs {
            water: Some(&water),
            impacts: &impacts,
            lights: Some(&lights),
            far: Some(far),
            ..Inputs::default()
        },
    ));
    let cpu_far = twin(&ripples, (far.0 as f32, far.1 as f32));
    let (mut worst, mut blurred) = (0, 0);
    for plane in 0..3 {
        for i in 0..gpu_far[plane].len() {
            worst = worst.max(gpu_far[plane][i].abs_diff(cpu_far[plane][i]));
            blurred += (cpu_far[plane][i].abs_diff(cpu[plane][i]) > 2) as usize;
        }
    }
    eprintln!(
        "turned {rotation_deg}°, far ripples: worst {worst} codes, {blurred} samples blurred"
    );
    assert!(worst <= 2, "{worst} codes off with the far ripples");
    assert!(blurred > 10, "the far ripples show: {blurred}");
}

#[test]
fn without_water_the_frame_is_untouched() {
    let Some(ctx) = gpu() else { return };
    let camera = Camera::new(40, 30, 1.0, 1.6, f64::to_radians(-10.0), 0.0);
    let s = setup(&camera, false);
    let p = lit(&s, 0.0, &uniform_sky(1.0), Some(1.0));
    let frame = picture_444(40, 30, |x, y| (200 + 11 * x + 7 * y) as u16, grey);
    let none = codes(&render(&ctx, &frame, &s, &p, &Inputs::default()));
    let dry_map = lake(0.0, 50.0);
    let dry = codes(&render(
        &ctx,
        &frame,
        &s,
        &p,
        &Inputs {
            water: Some(&dry_map),
            ..Inputs::default()
        },
    ));
    assert_eq!(none, dry, "a dry map changes nothing");
    assert_eq!(
        none,
        codes(&frame),
        "no water, no rain: the frame comes back"
    );
    // A map that does not add up is refused (a layer takes water: tests/layers.rs).
    let mut comp = Compositor::new(ctx.clone(), frame.format, &frame.color, &s).expect("comp");
    let broken = Field2 {
        values: vec![0.0; 5],
        ..lake(0.0, 1.0)
    };
    assert!(comp.set_water(&broken).is_err());
}

// ---------------------------------------------------------------------------------------------
// Fresnel.

/// Fresnel's unpolarised reflectance in angle form, air → water.
fn fresnel_angles(theta_i: f64) -> f64 {
    if theta_i < 1e-9 {
        return ((WATER_INDEX - 1.0) / (WATER_INDEX + 1.0)).powi(2);
    }
    let theta_t = (theta_i.sin() / WATER_INDEX).asin();
    let rs = (theta_i - theta_t).sin() / (theta_i + theta_t).sin();
    let rp = (theta_i - theta_t).tan() / (theta_i + theta_t).tan();
    0.5 * (rs * rs + rp * rp)
}

/// Renders a black ground under still water mirroring radiance `sky` from every direction
/// (the uniform environment, and the frame's sky where `frame_sky` is its code); returns the
/// worst code error against R(θ)·sky per pixel and R at the pixel nearest normal and nearest
/// grazing incidence (θ from the camera's own rays).
fn fresnel_render(ctx: &Arc<GpuContext>, camera: &Camera, frame_sky: u16) -> (u16, f64, f64) {
    let (w, h) = (camera.width_px, camera.height_px);
    let color = ColorParams::bt709(10);
    let sky = color.code_to_linear([frame_sky as f64, 512.0, 512.0])[1];
    let ray = |x: u32, y: u32| camera.ray_world(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
    let frame = picture_444(
        w,
        h,
        |x, y| if ray(x, y).z > 0.0 { frame_sky } else { 64 },
        grey,
    );
    let s = setup(camera, false);
    let p = lit(&s, 0.0, &uniform_sky(sky), Some(1.0));
    let water = lake(0.05, 500.0);
    let out = codes(&render(
        ctx,
        &frame,
        &s,
        &p,
        &Inputs {
            water: Some(&water),
            ..Inputs::default()
        },
    ));
    let (mut worst, mut normal, mut grazing) = (0, (0.0, 0.0), (1.0, 0.0));
    for y in 0..h {
        for x in 0..w {
            let d = ray(x, y);
            if d.z >= 0.0 {
                continue;
            }
            let theta = (-d.z).acos();
            let expected = color.linear_to_code([fresnel_angles(theta) * sky; 3])[0] as u16;
            let got = out[0][(y * w + x) as usize];
            worst = worst.max(got.abs_diff(expected));
            let r = color.code_to_linear([got as f64, 512.0, 512.0])[1] / sky;
            if -d.z > normal.0 {
                normal = (-d.z, r);
            }
            if -d.z < grazing.0 {
                grazing = (-d.z, r);
            }
        }
    }
    eprintln!(
        "R at cos θ = {:.4}: {:.4}; at cos θ = {:.4}: {:.4}",
        normal.0, normal.1, grazing.0, grazing.1
    );
    (worst, normal.1, grazing.1)
}

#[test]
fn still_water_reflects_as_fresnel_says_head_on_and_at_grazing() {
    let Some(ctx) = gpu() else { return };
    // Straight down: every mirrored ray leaves the frame behind the camera, into the sky.
    let down = Camera::new(32, 32, 0.5, 1.6, -PI / 2.0, 0.0);
    let (worst, normal, _) = fresnel_render(&ctx, &down, 700);
    let r0 = ((WATER_INDEX - 1.0) / (WATER_INDEX + 1.0)).powi(2);
    assert!(worst <= 1, "{worst} codes off");
    assert!((normal - r0).abs() < 0.05 * r0, "{normal} vs {r0}");
    // Level: the rows just below the horizon mirror the sky rows just above it.
    let level = Camera::new(64, 48, 1.0, 1.6, 0.0, 0.0);
    let (worst, _, grazing) = fresnel_render(&ctx, &level, 700);
    let theta = (0.5 / level.focal_px()).acos();
    assert!(worst <= 2, "{worst} codes off");
    assert!(
        (grazing - fresnel_angles(theta)).abs() < 0.01,
        "{grazing} at {:.2}°",
        theta.to_degrees()
    );
    assert!(grazing > 0.95);
}

// ---------------------------------------------------------------------------------------------
// Mirror images.

/// Luma of `frame` at every pixel.
fn luma(frame: &YuvFrame) -> Vec<f64> {
    plane_codes(frame, 0).iter().map(|&c| c as f64).collect()
}

#[test]
fn a_bright_object_in_the_sky_shows_at_its_mirrored_position() {
    let Some(ctx) = gpu() else { return };
    for tilt_deg in [0.0, -6.0, 4.0] {
        let camera = Camera::new(160, 120, 1.0, 1.6, f64::to_radians(tilt_deg), 0.0);
        // The sky-over-ground shot: a sky above the horizon, a dark ground below; a bright
        // 4 × 4 px object 20 px above the horizon.
        let horizon_row =
            camera.principal_px().y + camera.focal_px() * f64::to_radians(tilt_deg).tan();
        let object = DVec2::new(100.0, (horizon_row - 20.0).round());
        let ray = |x: u32, y: u32| camera.ray_world(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
        let shot = |with_object: bool| {
            picture_444(
                160,
                120,
                |x, y| {
                    let (dx, dy) = (x as f64 + 0.5 - object.x, y as f64 + 0.5 - object.y);
                    if with_object && dx.abs() < 2.0 && dy.abs() < 2.0 {
                        940
                    } else if ray(x, y).z > 0.0 {
                        470
                    } else {
                        160
                    }
                },
                grey,
            )
        };
        let s = setup(&camera, false);
        let p = lit(&s, 0.0, &uniform_sky(0.2), Some(1.0));
        let water = lake(0.05, 400.0);
        let inputs = Inputs {
            water: Some(&water),
            ..Inputs::default()
        };
        let with = luma(&render(&ctx, &shot(true), &s, &p, &inputs));
        let without = luma(&render(&ctx, &shot(false), &s, &p, &inputs));
        // The object's image in the water: the brightness it adds below the horizon.
        let (mut sum, mut at) = (0.0, DVec2::ZERO);
        for y in 0..120 {
            for x in 0..160 {
                if ray(x, y).z >= 0.0 {
                    continue;
                }
                let i = (y * 160 + x) as usize;
                let excess = (with[i] - without[i]).max(0.0);
                sum += excess;
                at += excess * DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            }
        }
        assert!(
            sum > 100.0,
            "tilt {tilt_deg}°: no image in the water ({sum})"
        );
        let found = at / sum;
        // Far away, the object's mirror image lies along its direction mirrored in the ground.
        let u = camera.ray_world(object);
        let mirrored = DVec3::new(u.x, u.y, -u.z);
        let expected = camera
            .project_world(camera.position_m + mirrored)
            .expect("in front");
        eprintln!("tilt {tilt_deg}°: image at {found:.2}, mirrored position {expected:.2}");
        assert!(
            found.distance(expected) < 2.0,
            "tilt {tilt_deg}°: {found} vs {expected}"
        );
    }
}

#[test]
fn a_pole_on_the_ground_is_mirrored_at_its_depth() {
    let Some(ctx) = gpu() else { return };
    let camera = Camera::new(160, 120, 1.0, 1.6, 0.0, 0.0);
    // A pole 3 m tall and 0.4 m wide, 20 m ahead and 1 m to the right, facing the camera.
    let (pole_x, pole_y, pole_w, pole_h) = (1.0, 20.0, 0.4, 3.0);
    let ray = |x: u32, y: u32| camera.ray_world(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
    let on_pole = |x: u32, y: u32| {
        let d = ray(x, y);
        let hit = camera.position_m + d * (pole_y / d.y);
        d.y > 0.0 && (hit.x - pole_x).abs() < 0.5 * pole_w && (0.0..pole_h).contains(&hit.z)
    };
    let shot = |with_pole: bool| {
        picture_444(
            160,
            120,
            |x, y| match (with_pole && on_pole(x, y), ray(x, y).z > 0.0) {
                (true, _) => 940,
                (false, true) => 470,
                (false, false) => 160,
            },
            grey,
        )
    };
    // The depth map: the pole, the ground (camera z of the plane), the sky unknown.
    let depth = |with_pole: bool| {
        let values: Vec<f32> = (0..120)
            .flat_map(|y| (0..160).map(move |x| (x, y)))
            .map(|(x, y)| {
                let d = ray(x, y);
                if with_pole && on_pole(x, y) {
                    pole_y as f32
                } else if d.z < 0.0 {
                    // Camera z = world y for a level camera.
                    (camera.position_m.z / -d.z * d.y) as f32
                } else {
                    f32::NAN
                }
            })
            .collect();
        DepthMap::from_values(160, 120, &values, 1.0).expect("map")
    };
    let s = setup(&camera, true);
    let p = lit(&s, 0.0, &uniform_sky(0.2), Some(1.0));
    let water = lake(0.05, 400.0);
    let image = |with_pole: bool| {
        let map = depth(with_pole);
        luma(&render(
            &ctx,
            &shot(with_pole),
            &s,
            &p,
            &Inputs {
                water: Some(&water),
                depth: Some(&map),
                ..Inputs::default()
            },
        ))
    };
    let (with, without) = (image(true), image(false));
    // The CPU twin marches the same rays through the same map (a ray grazing the pole's edge
    // may fall on the other side in f32 than in f64: a few samples may differ).
    let twin = {
        let map = depth(true);
        let frame = shot(true);
        let params = puddle_params(&water, 0);
        let mut canvas = yuv_to_rgb::yuv_to_rgb(&frame, &p);
        puddles::puddles(
            &mut canvas,
            &frame,
            &p,
            &Water {
                params: &params,
                depth_m: &water.values,
                ripples: &[],
                lights: &LightList::new(&[]),
            },
            Some(&map),
        );
        rgb_to_yuv::rgb_to_yuv(&canvas, frame.format, &frame.color)
    };
    let off = twin[0]
        .iter()
        .zip(&with)
        .filter(|(c, g)| (**c as f64 - **g).abs() > 2.0)
        .count();
    eprintln!(
        "GPU against the twin with the depth map: {off} of {} samples > 2 codes apart",
        with.len()
    );
    assert!(off < with.len() / 200, "{off} samples off");
    // The pole's column, down from its foot: its image ends where its top's mirror image lies.
    let column = camera
        .project_world(DVec3::new(pole_x, pole_y, 0.0))
        .expect("in front");
    let x = column.x as u32;
    let excess: Vec<f64> = (0..120)
        .map(|y| with[(y * 160 + x) as usize] - without[(y * 160 + x) as usize])
        .collect();
    let foot_row = column.y.ceil() as usize;
    let peak = excess[foot_row..].iter().cloned().fold(0.0, f64::max);
    assert!(peak > 20.0, "the pole shows in the water: {peak}");
    // The last row below the foot whose excess is above half the peak, plus a half pixel: the
    // edge of the image.
    let last = (foot_row..120)
        .rev()
        .find(|&y| excess[y] > 0.5 * peak)
        .expect("an image");
    let edge = last as f64 + 1.0;
    let top_mirrored = camera
        .project_world(DVec3::new(pole_x, pole_y, -pole_h))
        .expect("in front");
    // At a distance (no depth) it would end at the mirror of its top's direction instead.
    let u = camera.ray_world(
        camera
            .project_world(DVec3::new(pole_x, pole_y, pole_h))
            .expect("top"),
    );
    let far = camera
        .project_world(camera.position_m + DVec3::new(u.x, u.y, -u.z))
        .expect("in front");
    eprintln!(
        "pole image ends at row {edge:.1}: mirror of its top at {:.2} (at a distance: {:.2})",
        top_mirrored.y, far.y
    );
    assert!((edge - top_mirrored.y).abs() < 2.0);
    assert!(
        (far.y - top_mirrored.y).abs() > 10.0,
        "the test tells depth apart"
    );
}

// ---------------------------------------------------------------------------------------------
// Cost.

/// The stage's cost at 720p: time per frame without water, with still water, with 128 and
/// 1024 rings, with the far water's roughness (σ = 0.03 beyond 2 m: four mirror reads), and
/// with a depth map (the march), on this adapter. Run with
/// `cargo test --release --test puddles_shade -- --ignored --nocapture`.
#[test]
#[ignore]
fn report_the_cost_at_720p() {
    let Some(ctx) = gpu() else { return };
    let (w, h) = (1280, 720);
    let camera = Camera::new(w, h, 1.0, 1.6, f64::to_radians(-10.0), 0.0);
    let ray = |x: u32, y: u32| camera.ray_world(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
    let frame = picture_444(
        w,
        h,
        |x, y| {
            if ray(x, y).z > 0.0 {
                600
            } else {
                (150 + (x * 7 + y * 3) % 200) as u16
            }
        },
        grey,
    );
    // Half the ground under water: puddles 1 m across in a chequer to 40 m.
    let (nx, ny) = (160, 160);
    let water = Field2 {
        nx,
        ny,
        origin_m: Vec2::new(-20.0, 0.0),
        cell_m: 0.25,
        values: (0..nx * ny)
            .map(|k| {
                if ((k % nx) / 4 + (k / nx) / 4) % 2 == 0 {
                    0.01
                } else {
                    0.0
                }
            })
            .collect(),
    };
    let impacts: Vec<Impact> = (0..1024)
        .map(|i| Impact {
            id: i,
            pass: 0,
            time_s: 1.0 - i as f64 * 0.0013,
            position_m: DVec3::new(
                ((i * 37) % 100) as f64 * 0.1 - 5.0,
                2.0 + ((i * 53) % 100) as f64 * 0.1,
                0.0,
            ),
            diameter_mm: 2.0,
            velocity_mps: DVec3::new(0.0, 0.0, -6.5),
        })
        .collect();
    let ground_depth: Vec<f32> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let d = ray(x, y);
            if d.z < 0.0 {
                (1.6 / -d.z * d.y) as f32
            } else {
                f32::NAN
            }
        })
        .collect();
    let map = DepthMap::from_values(w as usize, h as usize, &ground_depth, 1.0).expect("map");
    let frames = 10;
    eprintln!("| puddles at {w}×{h} | ms per frame | puddles stage, ms (GPU timestamps) |");
    eprintln!("|---|---|---|");
    for (label, with_water, rings, far, depth) in [
        ("no water", false, 0, false, false),
        ("still water", true, 0, false, false),
        ("128 rings", true, 128, false, false),
        ("1024 rings", true, 1024, false, false),
        ("1024 rings, far roughness", true, 1024, true, false),
        ("128 rings, depth map", true, 128, false, true),
        (
            "1024 rings, far roughness, depth map",
            true,
            1024,
            true,
            true,
        ),
    ] {
        let s = setup(&camera, depth);
        let p = lit(&s, 1.0, &uniform_sky(0.5), Some(1.0));
        let mut comp =
            Compositor::new(ctx.clone(), frame.format, &frame.color, &s).expect("compositor");
        if depth {
            comp.set_scene_depth(&map).expect("depth");
        }
        if with_water {
            comp.set_water(&water).expect("water");
            comp.set_ripples(&impacts[..rings]).expect("rings");
            if far {
                comp.set_far_ripples(0.03, 2.0).expect("far ripples");
            }
        }
        comp.render_one(&frame, &p).expect("warm-up");
        let before = comp.gpu_times().puddles_s;
        let start = std::time::Instant::now();
        for _ in 0..frames {
            comp.render_one(&frame, &p).expect("render");
        }
        let per_frame_ms = start.elapsed().as_secs_f64() * 1e3 / frames as f64;
        let stage_ms = (comp.gpu_times().puddles_s - before) * 1e3 / frames as f64;
        eprintln!("| {label} | {per_frame_ms:.1} | {stage_ms:.1} |");
    }
}

/// Where water covers the ground, it replaces the wet ground's film instead of darkening the
/// ground a second time: the twin over a wet canvas and over the dry one agree on every pixel
/// under deep water (the flat water mirrors the sky, the same in both).
#[test]
fn water_replaces_the_wet_film_under_it() {
    use rain_composite::gpu::cpu::wet_ground;
    use rain_composite::gpu::types::WetParams;
    let camera = Camera::new(96, 64, 1.0, 1.6, -0.2, 0.0);
    let s = setup(&camera, false);
    let p = lit(&s, 0.0, &uniform_sky(0.4), Some(0.9));
    let frame = picture_444(
        96,
        64,
        |x, y| 300 + ((x * 7 + y * 13) % 200) as u16,
        |x, y, i| 500 + ((x + 3 * y + 40 * i as u32) % 60) as u16,
    );
    let water = lake(0.05, 20.0);
    let params = puddle_params(&water, 0);
    let lights = LightList::new(&[]);
    let pond = Water {
        params: &params,
        depth_m: &water.values,
        ripples: &[],
        lights: &lights,
    };
    let dry_canvas = yuv_to_rgb::yuv_to_rgb(&frame, &p);
    let mut wet_canvas = dry_canvas.clone();
    wet_ground::wet_ground(
        &mut wet_canvas,
        &frame,
        &p,
        &WetParams::new(0.9, &FilmOptics::water(), 0.0),
        None,
    );
    let (mut over_dry, mut over_wet) = (dry_canvas.clone(), wet_canvas.clone());
    puddles::puddles(&mut over_dry, &frame, &p, &pond, None);
    puddles::puddles(&mut over_wet, &frame, &p, &pond, None);
    let mut under_water = 0;
    for i in 0..dry_canvas.len() {
        let (x, y) = (i as u32 % 96, i as u32 / 96);
        let ray = camera.ray_world(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
        if ray.z >= -1e-3 {
            continue;
        }
        let hit = camera.position_m + ray * (camera.position_m.z / -ray.z);
        // Deep inside the lake (15 m of its 20 m half-width), away from its soft rim.
        if hit.x.abs() > 15.0 || hit.y.abs() > 15.0 {
            continue;
        }
        under_water += 1;
        assert!(wet_canvas[i] != dry_canvas[i], "the film wets pixel {i}");
        for k in 0..3 {
            assert!(
                (over_wet[i][k] - over_dry[i][k]).abs() < 1e-9,
                "pixel {i}: {} over the film, {} over the dry ground",
                over_wet[i][k],
                over_dry[i][k]
            );
        }
    }
    assert!(under_water > 50, "{under_water} pixels under water");
}

// ---------------------------------------------------------------------------------------------
// Rims.

/// A still pool in a bowl z = |P − centre|² / (2 R) filled to `level_m`: the carpet's fields on
/// cells of `cell_m` (surface: the level where wet, the ground where dry; depth), as a still
/// pool leaves them.
struct Bowl {
    centre_m: DVec2,
    radius_of_curvature_m: f64,
    level_m: f64,
}

impl Bowl {
    fn ground_m(&self, p: DVec2) -> f64 {
        (p - self.centre_m).length_squared() / (2.0 * self.radius_of_curvature_m)
    }

    /// The level's height above the ground at `p` beyond what covers half, and its gradient.
    fn rim(&self, p: DVec2) -> (f64, f64) {
        let above = self.level_m - self.ground_m(p) - 0.5 * EDGE_DEPTH_M;
        (
            above,
            (p - self.centre_m).length() / self.radius_of_curvature_m,
        )
    }

    /// The carpet's surface and depth on an `n`×`n` grid of `cell_m` around the bowl (its
    /// corner off the centre by a fraction of a cell, so the rim meets the cells at every phase).
    fn carpet(&self, n: usize, cell_m: f32) -> (Field2, Field2) {
        let origin = self.centre_m.as_vec2() - Vec2::splat(0.5 * n as f32 * cell_m)
            + Vec2::new(0.37, 0.71) * cell_m;
        let (mut surface, mut depth) = (Vec::new(), Vec::new());
        for k in 0..n * n {
            let c = origin + (Vec2::new((k % n) as f32, (k / n) as f32) + 0.5) * cell_m;
            let ground = self.ground_m(c.as_dvec2());
            let d = (self.level_m - ground).max(0.0);
            surface.push((ground + d) as f32);
            depth.push(d as f32);
        }
        let field = |values| Field2 {
            nx: n,
            ny: n,
            origin_m: origin,
            cell_m,
            values,
        };
        (field(surface), field(depth))
    }
}

/// A puddle's rim follows the line where its level meets the ground, between the water map's
/// cells, at 1:1 (a cell about 2 px wide) and at 2× (4 px): a still pool in a bowl, its rim a
/// circle that meets the cells at every angle and phase, drawn by the CPU twin (exact) and the
/// GPU stage (within a code of it). The depth smoothed over the cells, as the map once was,
/// puts the rim a cell off, in steps; the measure must see that.
#[test]
fn puddle_rims_follow_the_level_between_cells() {
    use rain_composite::fluid::puddles::shown::{smoothed, water_map};
    let ctx = gpu();
    let cell_m = 0.03f32;
    let bowl = Bowl {
        centre_m: DVec2::new(0.13, 2.4),
        radius_of_curvature_m: 15.0,
        level_m: 0.5f64.powi(2) / 30.0,
    };
    let (surface, depth) = bowl.carpet(48, cell_m);
    let map = water_map(&surface, &depth);
    let before = smoothed(&depth);
    let full = Field2 {
        values: vec![1.0; depth.values.len()],
        ..depth.clone()
    };
    let lights = LightList::new(&[]);
    for scale in [1u32, 2] {
        // 1.6 m up, 35° down, 40° across: the bowl's rim 2.8 m away, a cell about 2·scale px.
        let camera = Camera::new(
            160 * scale,
            120 * scale,
            f64::to_radians(40.0),
            1.6,
            f64::to_radians(-35.0),
            0.0,
        );
        let s = setup(&camera, false);
        let p = lit(&s, 0.0, &uniform_sky(0.6), Some(1.0));
        let frame = picture_444(camera.width_px, camera.height_px, |_, _| 400, |_, _, _| 512);
        let twin = |water: &Field2| {
            let params = puddle_params(water, 0);
            let mut canvas = yuv_to_rgb::yuv_to_rgb(&frame, &p);
            puddles::puddles(
                &mut canvas,
                &frame,
                &p,
                &Water {
                    params: &params,
                    depth_m: &water.values,
                    ripples: &[],
                    lights: &lights,
                },
                None,
            );
            canvas
        };
        let dry = yuv_to_rgb::yuv_to_rgb(&frame, &p);
        let wet = twin(&full);
        let cover_of = |canvas: &[[f64; 3]]| -> Vec<f64> {
            (0..canvas.len())
                .map(|i| {
                    let change = wet[i][1] - dry[i][1];
                    if change.abs() < 1e-4 {
                        0.0
                    } else {
                        (canvas[i][1] - dry[i][1]) / change
                    }
                })
                .collect()
        };
        let shown = twin(&map);
        let px_per_cell = camera.focal_px() * cell_m as f64 / 2.8;
        let mut results = Vec::new();
        for (name, canvas) in [("water map", &shown), ("smoothed depth", &twin(&before))] {
            let offsets = rim_offsets_m(&camera, &cover_of(canvas), |p| bowl.rim(p));
            let cells: Vec<f64> = offsets.iter().map(|d| d / cell_m as f64).collect();
            let (_, rms, sd, max) = spread(&cells);
            eprintln!(
                "{scale}×, {name}: {} crossings, rim off by RMS {rms:.3} cells ({:.2} px), \
                 {sd:.3} about its mean, at most {max:.3}",
                cells.len(),
                rms * px_per_cell,
            );
            assert!(
                cells.len() > 100 * scale as usize,
                "{} crossings",
                cells.len()
            );
            results.push((rms, max));
        }
        let ((rms, max), (rms_before, _)) = (results[0], results[1]);
        // The rim to a twelfth of a cell (a third of a pixel at 2×), nowhere a fifth off.
        assert!(
            rms < 0.08 && max < 0.2,
            "{scale}×: RMS {rms:.3}, max {max:.3} cells"
        );
        assert!(
            rms_before > 0.2,
            "the measure sees cell-sized rims: {rms_before:.3}"
        );
        if let Some(ctx) = &ctx {
            let gpu = codes(&render(
                ctx,
                &frame,
                &s,
                &p,
                &Inputs {
                    water: Some(&map),
                    ..Inputs::default()
                },
            ));
            let cpu = rgb_to_yuv::rgb_to_yuv(&shown, frame.format, &frame.color);
            let worst = (0..3)
                .flat_map(|k| gpu[k].iter().zip(&cpu[k]).map(|(a, b)| a.abs_diff(*b)))
                .max()
                .unwrap_or(0);
            eprintln!("{scale}×: GPU against the twin, worst {worst} codes");
            assert!(worst <= 1, "{scale}×: {worst} codes off");
        }
    }
}

/// The water map read bilinearly between cell centres, 0 off the map: how the picture once read
/// it, whose rim (the zero of a bilinear field: hyperbolic arcs) kinks at every cell edge.
fn bilinear_depth(params: &PuddleParams, map: &[f32], xy: DVec2) -> f64 {
    let (nx, ny) = (params.cells[0] as i64, params.cells[1] as i64);
    let u = (xy - Vec2::from_array(params.origin_m).as_dvec2()) / params.cell_m as f64 - 0.5;
    let (i0, f) = (u.floor(), u - u.floor());
    let mut sum = 0.0;
    for (j, wy) in [(0, 1.0 - f.y), (1, f.y)] {
        for (i, wx) in [(0, 1.0 - f.x), (1, f.x)] {
            let (i, j) = (i0.x as i64 + i, i0.y as i64 + j);
            if (0..nx).contains(&i) && (0..ny).contains(&j) {
                sum += wx * wy * map[(j * nx + i) as usize] as f64;
            }
        }
    }
    sum
}

/// The carpet of a still pool filled to `level_m` over `ground` (surface: the level where wet,
/// the ground where dry; depth), on `n`×`n` cells of `cell_m` from `origin`.
fn still_carpet(
    ground: impl Fn(DVec2) -> f64,
    level_m: f64,
    origin: Vec2,
    n: usize,
    cell_m: f32,
) -> (Field2, Field2) {
    let (mut surface, mut depth) = (Vec::new(), Vec::new());
    for k in 0..n * n {
        let c = origin + (Vec2::new((k % n) as f32, (k / n) as f32) + 0.5) * cell_m;
        let g = ground(c.as_dvec2());
        let d = (level_m - g).max(0.0);
        surface.push((g + d) as f32);
        depth.push(d as f32);
    }
    let field = |values| Field2 {
        nx: n,
        ny: n,
        origin_m: origin,
        cell_m,
        values,
    };
    (field(surface), field(depth))
}

/// A plane rising at 30 cm per metre across a shore at 17° to the cells, 2.6 m ahead, as a
/// still carpet of 96² cells of `cell_m` around the shore: its surface, its depth and the shore's
/// point and normal.
fn shore_at_17(cell_m: f32) -> (Field2, Field2, DVec2, DVec2) {
    let (c, n) = (
        DVec2::new(0.011, 2.617),
        DVec2::from_angle(17f64.to_radians()),
    );
    let (surface, depth) = still_carpet(
        |p| 0.3 * n.dot(p - c),
        0.0,
        c.as_vec2() - Vec2::splat(48.0 * cell_m),
        96,
        cell_m,
    );
    (surface, depth, c, n)
}

/// A puddle's rim turns smoothly across the water map's cells: the rim as drawn (where the
/// map's reading reaches the depth that covers half) traced in steps of about 1/40 of a cell,
/// on a pool in a bowl (a circle: each step turns by the step's angle about its centre) and on
/// a trough's straight shores at 17°, 31° and 45° to the cells, one gently and one steeply
/// banked (each step straight on). The largest turn beyond the true rim's is a kink: a smooth
/// rim turns there in proportion to the step (under half a degree), a rim that kinks at the
/// cells' edges by a fixed angle, as the bilinear reading's does (degrees); the rim also stays
/// on the level's, as before.
#[test]
fn puddle_rims_turn_smoothly_across_the_cells() {
    use rain_composite::fluid::puddles::shown::water_map;
    let cell_m = 0.03f32;
    let half = 0.5 * EDGE_DEPTH_M;
    // (name, map, contour lines, where along each, the true rim's turn per step, its offset).
    let mut cases = Vec::new();
    let bowl = Bowl {
        centre_m: DVec2::new(0.13, 2.4),
        radius_of_curvature_m: 15.0,
        level_m: 0.5f64.powi(2) / 30.0,
    };
    let (surface, depth) = bowl.carpet(48, cell_m);
    let steps = 4096;
    let step_rad = TAU / steps as f64;
    let true_radius = ((bowl.level_m - half) * 2.0 * bowl.radius_of_curvature_m).sqrt();
    cases.push((
        "a pool in a bowl".to_string(),
        water_map(&surface, &depth),
        Box::new(move |k: usize| (bowl.centre_m, DVec2::from_angle(k as f64 * step_rad)))
            as Box<dyn Fn(usize) -> (DVec2, DVec2)>,
        (0.3, 0.7),
        step_rad,
        Box::new(move |p: DVec2| (p - DVec2::new(0.13, 2.4)).length() - true_radius)
            as Box<dyn Fn(DVec2) -> f64>,
    ));
    for angle_deg in [17.0f64, 31.0, 45.0] {
        for curvature in [0.3, 3.0] {
            // Ground curvature·(n·(P − c))², filled to 1 cm: shores at n·(P − c) = ±√(level/curvature).
            let (c, level) = (DVec2::new(0.011, 0.017), 0.01);
            let n = DVec2::from_angle(angle_deg.to_radians());
            let (surface, depth) = still_carpet(
                |p| curvature * n.dot(p - c).powi(2),
                level,
                c.as_vec2() - Vec2::splat(24.0 * cell_m),
                48,
                cell_m,
            );
            let shore = ((level - half) / curvature).sqrt();
            let length = 1.0;
            cases.push((
                format!("a shore at {angle_deg}°, banked {curvature}/m"),
                water_map(&surface, &depth),
                Box::new(move |k: usize| {
                    let along = length * (k as f64 / steps as f64 - 0.5);
                    (c + along * n.perp(), n)
                }),
                (0.0, 0.6),
                0.0,
                Box::new(move |p: DVec2| n.dot(p - c) - shore),
            ));
        }
    }
    for (name, map, line, span, true_turn, off) in &cases {
        let params = puddle_params(map, 0);
        let mut kinks = Vec::new();
        for reading in [puddles::water_depth, bilinear_depth] {
            let rim = rims::contour_points(
                |p| reading(&params, &map.values, p) - half,
                steps,
                line,
                *span,
            )
            .expect("the rim crosses every line");
            let closed = *true_turn > 0.0;
            let kink = rims::turns(&rim, closed)
                .iter()
                .map(|t| (t - true_turn).abs().to_degrees())
                .fold(0.0f64, f64::max);
            let (_, rms, _, _) = spread(
                &rim.iter()
                    .map(|&p| off(p) / cell_m as f64)
                    .collect::<Vec<_>>(),
            );
            kinks.push((kink, rms));
        }
        let ((kink, rms), (kink_before, rms_before)) = (kinks[0], kinks[1]);
        eprintln!(
            "{name}: largest turn beyond the true rim's {kink:.3}° (bilinear {kink_before:.3}°), \
             rim off by RMS {rms:.4} cells (bilinear {rms_before:.4})"
        );
        assert!(kink < 0.5, "{name}: the rim kinks by {kink:.3}°");
        assert!(rms < 0.03, "{name}: the rim {rms:.4} cells off the level's");
        assert!(
            kink_before > 2.0,
            "{name}: the measure sees the bilinear reading's kinks: {kink_before:.3}°"
        );
    }
}

/// The map's reading is exact on a quadratic (Catmull-Rom reproduces polynomials to the
/// second degree: a pool in a bowl is read as the bowl), never leaves the range of the four
/// nearest cells (so it makes no water and no dry ground that none of them holds, as a
/// bilinear reading), and is C¹: its slope across a cell's edge is the same from both sides.
#[test]
fn the_water_map_is_read_exactly_on_quadratics_within_its_nearest_cells() {
    use rain_composite::rng::SplitMix64;
    let (n, cell_m) = (24usize, 0.05f32);
    let origin = Vec2::new(-0.3, 1.7);
    let map_of = |f: &dyn Fn(DVec2) -> f64| Field2 {
        nx: n,
        ny: n,
        origin_m: origin,
        cell_m,
        values: (0..n * n)
            .map(|k| f(DVec2::new((k % n) as f64 + 0.5, (k / n) as f64 + 0.5)) as f32)
            .collect(),
    };
    let ground = |c: DVec2| origin.as_dvec2() + c * cell_m as f64;
    // In cell units, increasing along x and y over the map: its extremes lie on cells' corners.
    let quadratic = |c: DVec2| {
        1e-3 * (0.3 * c.x * c.x + 0.2 * c.y * c.y + 0.1 * c.x * c.y + c.x - 2.0 * c.y + 5.0)
    };
    let map = map_of(&quadratic);
    let params = puddle_params(&map, 0);
    let mut rng = SplitMix64(7);
    let mut worst = 0.0f64;
    for _ in 0..2000 {
        let c = DVec2::new(2.0 + 20.0 * rng.next_f64(), 2.0 + 20.0 * rng.next_f64());
        let read = puddles::water_depth(&params, &map.values, ground(c));
        worst = worst.max((read - quadratic(c)).abs());
    }
    // The map's f32 rounding (values up to 0.3 m); a bilinear reading is off by up to 1e-3·(0.3
    // + 0.2)·2/8 = 1.25e-4 m midway between cells.
    assert!(worst < 1e-7, "a quadratic read {worst} m off");
    // A random map: within the nearest four, and the slope across cell edges continuous.
    let noise = Field2 {
        values: (0..n * n)
            .map(|_| (0.01 * (rng.next_f64() - 0.5)) as f32)
            .collect(),
        ..map.clone()
    };
    let params = puddle_params(&noise, 0);
    let read = |c: DVec2| puddles::water_depth(&params, &noise.values, ground(c));
    let (mut outside, mut jumps, mut checked) = (0, 0.0f64, 0);
    for _ in 0..4000 {
        let c = DVec2::new(1.0 + 20.0 * rng.next_f64(), 1.0 + 20.0 * rng.next_f64());
        let near = (c - 0.5).floor();
        let cells: Vec<f64> = [(0, 0), (1, 0), (0, 1), (1, 1)]
            .iter()
            .map(|&(i, j)| noise.values[(near.y as usize + j) * n + near.x as usize + i] as f64)
            .collect();
        let (lo, hi) = cells
            .iter()
            .fold((f64::MAX, f64::MIN), |a, &v| (a.0.min(v), a.1.max(v)));
        let v = read(c);
        if v < lo - 1e-12 || v > hi + 1e-12 {
            outside += 1;
        }
        // Across the edge x = near.x + 1.5 (a cell centre's column line), the slope along x from
        // both sides, where the clamp holds neither side.
        let edge = DVec2::new(near.x + 1.5, c.y);
        let h = 1e-5;
        let (a, b, m) = (
            read(edge - DVec2::X * h),
            read(edge + DVec2::X * h),
            read(edge),
        );
        let unclamped = |p: DVec2| {
            let q = (p - 0.5).floor();
            let (lo, hi) = [(0, 0), (1, 0), (0, 1), (1, 1)].iter().fold(
                (f64::MAX, f64::MIN),
                |acc, &(i, j)| {
                    let v = noise.values[(q.y as usize + j) * n + q.x as usize + i] as f64;
                    (acc.0.min(v), acc.1.max(v))
                },
            );
            let v = read(p);
            v > lo + 1e-9 && v < hi - 1e-9
        };
        if unclamped(edge - DVec2::X * h) && unclamped(edge + DVec2::X * h) {
            let (left, right) = ((m - a) / h, (b - m) / h);
            jumps = jumps.max((right - left).abs());
            checked += 1;
        }
    }
    eprintln!(
        "quadratic read to {worst:.2e} m; slope across {checked} edges the same to {jumps:.2e} \
         m per cell"
    );
    assert_eq!(outside, 0, "readings outside the nearest four cells' range");
    assert!(checked > 1000, "{checked} edges checked");
    // A kink of a bilinear reading is of the order of the cells' differences (1e-2 per cell);
    // a C¹ reading's difference of one-sided slopes is its second derivative times h.
    assert!(
        jumps < 1e-5,
        "the slope jumps by {jumps} m per cell across an edge"
    );
}

/// At night the water keeps the lamps' halo the haze laid on the ground: on the GPU, within a
/// code of the twin; in the twin, every pixel the water covers gains at least the glow the
/// plate had there with the lamp (its reflection of the lit picture only adds), where without
/// the glow term it would lose it under deep water.
#[test]
fn the_water_keeps_the_lamps_glow() {
    let camera = Camera::new(96, 64, 1.0, 1.6, 0.0, 0.0);
    let s = setup(&camera, false);
    let mut p = lit(&s, 0.0, &uniform_sky(0.02), None);
    // Haze from 3 m to 50 m, ending on the ground where it is nearer.
    let t: f64 = 0.85;
    p.haze = [3.0, 50.0, (-t.ln() / 47.0) as f32, t as f32];
    let frame = picture_444(96, 64, |_, _| 120, grey);
    let water = lake(0.05, 20.0);
    let params = puddle_params(&water, 0);
    let lamp = LightSource {
        direction_world: camera.ray_world(DVec2::new(48.0, 26.0)).normalize(),
        solid_angle_sr: 2e-4,
        radiance_rgb: [3000.0, 2400.0, 1200.0],
        distance_m: None,
    };
    let (lamps, none) = (LightList::new(&[lamp]), LightList::new(&[]));
    let tables = render::water_tables(1024);
    let glow = yuv_to_rgb::haze_glow(&p, &lamps, &tables, (96, 64));
    let twin = |lights: &LightList, glow: Option<&[[f64; 3]]>| {
        let before = yuv_to_rgb::yuv_to_rgb_lit(&frame, &p, lights, &tables);
        let mut after = before.clone();
        let pond = Water {
            params: &params,
            depth_m: &water.values,
            ripples: &[],
            lights,
        };
        puddles::puddles_lit(&mut after, &frame, &p, &pond, None, None, glow);
        (before, after)
    };
    let (dark, dark_water) = twin(&none, None);
    let (lamplit, lit_water) = twin(&lamps, Some(&glow));
    let mut halo_under_water = 0;
    for i in 0..dark.len() {
        let covered = dark_water[i] != dark[i];
        for k in 0..3 {
            let halo = lamplit[i][k] - dark[i][k];
            let kept = lit_water[i][k] - dark_water[i][k];
            assert!(
                kept >= halo - 1e-12,
                "pixel {i}: {kept} of the halo's {halo} kept"
            );
        }
        halo_under_water += usize::from(covered && lamplit[i][1] - dark[i][1] > 1e-3);
    }
    assert!(
        halo_under_water > 100,
        "{halo_under_water} pixels of halo under water"
    );
    let Some(ctx) = gpu() else { return };
    let gpu = codes(&render_with(&ctx, &frame, &s, &p, |comp| {
        comp.set_transfer_table(&tables);
        comp.set_lights(&lamps);
        comp.set_water(&water).expect("water");
    }));
    let cpu = rgb_to_yuv::rgb_to_yuv(&lit_water, frame.format, &frame.color);
    let worst = (0..3)
        .flat_map(|k| gpu[k].iter().zip(&cpu[k]).map(|(a, b)| a.abs_diff(*b)))
        .max()
        .unwrap_or(0);
    eprintln!("the water under the halo: GPU against the twin, worst {worst} codes");
    assert!(worst <= 1, "{worst} codes off");
}

/// A puddle's rim is antialiased: each pixel's cover is the share of its footprint under
/// water. At 1:1 (a cell about 2 px), on a straight shore at 17° to the cells and on a pool in
/// a bowl, both steep enough that the rim's ramp is a fraction of a pixel, every pixel's cover as drawn (by the CPU twin; the GPU stage within a code of it)
/// is compared with the mean of the cover taken at 16 × 16 points across the pixel (computed
/// here from the map's reading, point by point): on the rim's pixels inside the map the drawn cover's error
/// must be well below that of the cover taken at the pixel's centre alone, whose steps are off
/// by up to half a pixel's share, and no pixel's by a tenth (a pixel whose four nearest cells
/// are dry though its footprint reaches water beyond them is not left dry).
#[test]
fn puddle_rims_cover_the_share_of_each_pixel_under_water() {
    use rain_composite::fluid::puddles::shown::water_map;
    let ctx = gpu();
    let cell_m = 0.03f32;
    let bowl = Bowl {
        centre_m: DVec2::new(0.13, 2.4),
        radius_of_curvature_m: 1.5,
        level_m: 0.5f64.powi(2) / 3.0,
    };
    let (surface, depth) = bowl.carpet(48, cell_m);
    let (shore_surface, shore_depth, _, _) = shore_at_17(cell_m);
    let cases = [
        ("a pool in a bowl", water_map(&surface, &depth)),
        ("a shore at 17°", water_map(&shore_surface, &shore_depth)),
    ];
    let lights = LightList::new(&[]);
    let camera = Camera::new(
        160,
        120,
        f64::to_radians(40.0),
        1.6,
        f64::to_radians(-35.0),
        0.0,
    );
    let s = setup(&camera, false);
    let p = lit(&s, 0.0, &uniform_sky(0.6), Some(1.0));
    let frame = picture_444(camera.width_px, camera.height_px, |_, _| 400, |_, _, _| 512);
    let dry = yuv_to_rgb::yuv_to_rgb(&frame, &p);
    let edge = EDGE_DEPTH_M;
    let smooth = |x: f64| {
        let t = (x / edge).clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    };
    for (name, map) in &cases {
        let params = puddle_params(map, 0);
        let twin = |water: &[f32]| {
            let mut canvas = yuv_to_rgb::yuv_to_rgb(&frame, &p);
            puddles::puddles(
                &mut canvas,
                &frame,
                &p,
                &Water {
                    params: &params,
                    depth_m: water,
                    ripples: &[],
                    lights: &lights,
                },
                None,
            );
            canvas
        };
        let wet = twin(&vec![1.0; map.values.len()]);
        let drawn = twin(&map.values);
        // The cover at a point of the picture, read as the stage reads it at a pixel's centre.
        let point = |at: DVec2| {
            let ray = yuv_to_rgb::view_ray_at(&p, at);
            if ray.z >= 0.0 {
                return 0.0;
            }
            let g = DVec3::from_array(p.camera_pos_m.map(f64::from));
            let ground = g + (g.z / -ray.z) * ray;
            smooth(puddles::water_depth(
                &params,
                &map.values,
                ground.truncate(),
            ))
        };
        let (mut err, mut err_centre, mut rim) = (0.0, 0.0, 0usize);
        let mut worst = 0.0f64;
        for i in 0..drawn.len() {
            let (x, y) = ((i % 160) as f64, (i / 160) as f64);
            let change = wet[i][1] - dry[i][1];
            let cover = if change.abs() < 1e-4 {
                0.0
            } else {
                (drawn[i][1] - dry[i][1]) / change
            };
            let centre = point(DVec2::new(x + 0.5, y + 0.5));
            // Only the map's inside: beyond its edge it holds no water (the shore runs off it).
            let ray = yuv_to_rgb::view_ray_at(&p, DVec2::new(x + 0.5, y + 0.5));
            let ground = p.camera_pos_m[2] as f64 / -ray.z * ray.truncate()
                + DVec2::new(p.camera_pos_m[0] as f64, p.camera_pos_m[1] as f64);
            let inset = (ground - map.origin_m.as_dvec2()) / cell_m as f64;
            if ray.z >= 0.0
                || inset.min_element() < 3.0
                || inset.max_element() > map.nx as f64 - 3.0
            {
                continue;
            }
            let mut sum = 0.0;
            for k in 0..256 {
                let sub = DVec2::new((k % 16) as f64 + 0.5, (k / 16) as f64 + 0.5) / 16.0;
                sum += point(DVec2::new(x, y) + sub);
            }
            let reference = sum / 256.0;
            // The rim's pixels: partly covered by the reference or by either cover.
            let partial = |v: f64| v > 1e-3 && v < 1.0 - 1e-3;
            if partial(reference) || partial(cover) || partial(centre) {
                rim += 1;
                err += (cover - reference).powi(2);
                err_centre += (centre - reference).powi(2);
                worst = worst.max((cover - reference).abs());
            }
        }
        let (rms, rms_centre) = ((err / rim as f64).sqrt(), (err_centre / rim as f64).sqrt());
        eprintln!(
            "{name}: {rim} rim pixels, cover off the 16×16 mean by RMS {rms:.4} (at most \
             {worst:.3}), the centre's {rms_centre:.4}"
        );
        assert!(rim > 100, "{name}: {rim} rim pixels");
        assert!(
            rms_centre > 0.15,
            "{name}: the measure sees the centre's steps: {rms_centre:.4}"
        );
        assert!(
            rms < 0.25 * rms_centre,
            "{name}: RMS {rms:.4} against the centre's {rms_centre:.4}"
        );
        // No pixel left dry (or full) by a clamp to cells its footprint passes beyond.
        assert!(worst < 0.1, "{name}: a pixel off by {worst:.3}");
        if let Some(ctx) = &ctx {
            let gpu = codes(&render(
                ctx,
                &frame,
                &s,
                &p,
                &Inputs {
                    water: Some(map),
                    ..Inputs::default()
                },
            ));
            let cpu = rgb_to_yuv::rgb_to_yuv(&drawn, frame.format, &frame.color);
            let worst = (0..3)
                .flat_map(|k| gpu[k].iter().zip(&cpu[k]).map(|(a, b)| a.abs_diff(*b)))
                .max()
                .unwrap_or(0);
            eprintln!("{name}: GPU against the twin, worst {worst} codes");
            assert!(worst <= 1, "{name}: {worst} codes off");
        }
    }
}

/// The cover's clamp widens with the footprint without a jump: swept across a shore's rim and
/// across a map of random depths (±2 rim depths, cell to cell) in steps of 1/256 cell, a pixel's
/// footprint about half a cell, the twin's cover never steps by more than its smooth change
/// allows between cell-centre lines (where the four nearest cells change, as before), whereas
/// switching from the four nearest cells' range to the sixteen's where the footprint leaves
/// their square (computed here) jumps there on the random map.
#[test]
fn the_cover_widens_its_range_with_the_footprint_without_a_jump() {
    use rain_composite::fluid::puddles::shown::water_map;
    let cell_m = 0.03f32;
    let (surface, depth, c, n) = shore_at_17(cell_m);
    let shore = water_map(&surface, &depth);
    let mut rng = rain_composite::rng::SplitMix64(11);
    let noise = Field2 {
        values: (0..shore.values.len())
            .map(|_| (4.0 * EDGE_DEPTH_M * (rng.next_f64() - 0.5)) as f32)
            .collect(),
        ..shore.clone()
    };
    let cell = cell_m as f64;
    let per_px = [DVec2::new(0.45, 0.12) * cell, DVec2::new(-0.08, 0.5) * cell];
    let edge = EDGE_DEPTH_M;
    let cases = [
        ("a shore at 17°", &shore, n, false),
        ("random depths", &noise, DVec2::new(0.96, 0.28), true),
    ];
    for (name, map, across, jumps) in cases {
        let params = puddle_params(map, 0);
        let origin = map.origin_m.as_dvec2();
        // The cover with the range switched: the four nearest cells' inside their square, the
        // sixteen's once the footprint's bounding box leaves it.
        let switched = |xy: DVec2| {
            let (d, gradient, lo4, hi4) = puddles::water_depth_gradient(&params, &map.values, xy);
            let u = (xy - origin) / cell - DVec2::splat(0.5);
            let (i0, f) = (u.floor(), u - u.floor());
            let half = (per_px[0].abs() + per_px[1].abs()) * (0.5 / cell);
            let leaves =
                (half - f).max_element() > 0.0 || (f + half - DVec2::ONE).max_element() > 0.0;
            let (mut lo, mut hi) = (lo4, hi4);
            if leaves {
                for k in 0..16 {
                    let (i, j) = (i0.x as usize + k % 4 - 1, i0.y as usize + k / 4 - 1);
                    let v = map.values[j * map.nx + i] as f64;
                    (lo, hi) = (lo.min(v), hi.max(v));
                }
            }
            let width = DVec2::new(gradient.dot(per_px[0]), gradient.dot(per_px[1])).length();
            puddles::rim_cover(d, lo, hi, width, edge)
        };
        let (mut widened, mut hard) = (0.0f64, 0.0f64);
        for line in 0..128 {
            // Lines across the shore (or the noise) through the middle of the map.
            let side = DVec2::new(-across.y, across.x) * (line as f64 * 0.19 - 12.0) * cell;
            let start = c + side - across * 6.0 * cell;
            let step = across * cell / 256.0;
            let mut last: Option<(DVec2, f64, f64)> = None;
            for k in 0..=12 * 256 {
                let xy = start + step * k as f64;
                let u = ((xy - origin) / cell - DVec2::splat(0.5)).floor();
                let now = (
                    u,
                    puddles::water_cover(&params, &map.values, xy, per_px),
                    switched(xy),
                );
                if let Some(before) = last
                    && before.0 == now.0
                {
                    widened = widened.max((now.1 - before.1).abs());
                    hard = hard.max((now.2 - before.2).abs());
                }
                last = Some(now);
            }
        }
        eprintln!(
            "{name}: largest step per 1/256 cell: widened by the footprint {widened:.4}, \
             switched to the sixteen cells {hard:.4}"
        );
        assert!(
            widened < 0.02,
            "{name}: the widened range steps by {widened:.4}"
        );
        if jumps {
            assert!(hard > 0.03, "{name}: the switch's jump is seen: {hard:.4}");
        }
    }
}

/// Far puddles' rims cover the share of each pixel's footprint under water where the footprint
/// spans many cells: a street's ground 6–14 m ahead seen from 1.6 m at a grazing angle, where a
/// pixel row spans 3–20 cells of 2 cm in depth. Against the true share (the still water's own
/// cover, smoothstep(0, rim depth, level − ground), at 8 × 64 points across each pixel) on
/// straight shores at 17° and 58° to the cells (a plane rising 5 cm per metre, the camera
/// level and rolled 7°) and a round pool in a bowl: a reading at the footprint's centre alone
/// covers a pixel where its centre lands on water, so rims step from row to row (a
/// staircase) and a pixel whose footprint holds water beside its centre stays dry. Also the
/// shores' rims along each column of pixels (the wet share summed down the column: where a
/// straight rim crosses it) against the true share's, and the GPU stage within 1 code of its
/// twin.
#[test]
fn far_rims_cover_the_share_of_long_footprints() {
    use rain_composite::fluid::puddles::shown::water_map;
    let ctx = gpu();
    let cell_m = 0.02f32;
    let n = 560;
    let origin = Vec2::new(-2.8, 4.6);
    let edge = EDGE_DEPTH_M;
    let smooth = |x: f64| {
        let t = (x / edge).clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    };
    let shore = |deg: f64| {
        let (c, n) = (DVec2::new(0.13, 9.7), DVec2::from_angle(deg.to_radians()));
        move |p: DVec2| 0.05 * n.dot(p - c)
    };
    let bowl = |p: DVec2| (p - DVec2::new(0.21, 8.6)).length_squared() / (2.0 * 4.0);
    type Ground = Box<dyn Fn(DVec2) -> f64>;
    let cases: [(&str, Ground, f64, f64); 4] = [
        ("a shore at 17°", Box::new(shore(97.0)), 0.0, 0.0),
        ("a shore at 58°", Box::new(shore(148.0)), 0.0, 0.0),
        ("a shore at 17°, rolled 7°", Box::new(shore(97.0)), 0.0, 7.0),
        ("a round pool", Box::new(bowl), 0.9f64.powi(2) / 8.0, 0.0),
    ];
    let lights = LightList::new(&[]);
    for (name, ground, level, roll_deg) in &cases {
        let (surface, depth) = still_carpet(ground, *level, origin, n, cell_m);
        let map = water_map(&surface, &depth);
        let params = puddle_params(&map, 0);
        let camera = Camera::new(
            320,
            180,
            f64::to_radians(60.0),
            1.6,
            f64::to_radians(-4.0),
            roll_deg.to_radians(),
        );
        let s = setup(&camera, false);
        let p = lit(&s, 0.0, &uniform_sky(0.6), Some(1.0));
        let eye = DVec3::from_array(p.camera_pos_m.map(f64::from));
        let on_ground = |at: DVec2| {
            let ray = yuv_to_rgb::view_ray_at(&p, at);
            (ray.z < 0.0).then(|| (eye + (eye.z / -ray.z) * ray, ray))
        };
        let (lo, hi) = (
            origin.as_dvec2() + 0.5,
            origin.as_dvec2() + n as f64 * cell_m as f64 - 0.5,
        );
        let inside = |g: DVec3| g.x > lo.x && g.y > lo.y && g.x < hi.x && g.y < hi.y;
        let (w, h) = (camera.width_px as usize, camera.height_px as usize);
        let (mut drawn, mut truth) = (vec![f64::NAN; w * h], vec![f64::NAN; w * h]);
        let (mut err, mut rim, mut worst) = (0.0, 0usize, 0.0f64);
        for (k, (d, t)) in drawn.iter_mut().zip(truth.iter_mut()).enumerate() {
            let (x, y) = ((k % w) as f64, (k / w) as f64);
            let Some((g, ray)) = on_ground(DVec2::new(x + 0.5, y + 0.5)) else {
                continue;
            };
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)];
            if !corners
                .iter()
                .all(|&(a, b)| on_ground(DVec2::new(x + a, y + b)).is_some_and(|(g, _)| inside(g)))
            {
                continue;
            }
            let per_px = puddles::ground_per_px(&p, ray, eye.z / -ray.z);
            *d = puddles::water_cover(&params, &map.values, g.truncate(), per_px);
            let mut sum = 0.0;
            for m in 0..8 * 64 {
                let sub =
                    DVec2::new((m % 8) as f64 + 0.5, (m / 8) as f64 + 0.5) / DVec2::new(8.0, 64.0);
                let (q, _) = on_ground(DVec2::new(x, y) + sub).expect("below the horizon");
                sum += smooth(level - ground(q.truncate()));
            }
            *t = sum / 512.0;
            let partial = |v: f64| v > 1e-3 && v < 1.0 - 1e-3;
            if partial(*t) || partial(*d) {
                rim += 1;
                err += (*d - *t).powi(2);
                worst = worst.max((*d - *t).abs());
            }
        }
        let rms = (err / rim.max(1) as f64).sqrt();
        // The rim along each column where the column holds both water and dry ground: the
        // water's rows summed (a straight rim crosses a column once).
        let (mut off, mut columns) = (0.0, 0usize);
        if level == &0.0 {
            for x in 0..w {
                let column = |v: &[f64]| -> Option<f64> {
                    let c: Vec<f64> = (0..h)
                        .map(|y| v[y * w + x])
                        .filter(|v| !v.is_nan())
                        .collect();
                    (c.len() > 8
                        && c[0].min(c[c.len() - 1]) < 1e-3
                        && c[0].max(c[c.len() - 1]) > 1.0 - 1e-3)
                        .then(|| c.iter().sum())
                };
                if let (Some(a), Some(b)) = (column(&drawn), column(&truth)) {
                    off += (a - b).powi(2);
                    columns += 1;
                }
            }
        }
        let off = (off / columns.max(1) as f64).sqrt();
        eprintln!(
            "{name}: {rim} rim pixels, cover off the true share by RMS {rms:.4} (at most \
             {worst:.3}); rim along {columns} columns off the true one's by RMS {off:.3} px"
        );
        assert!(rim > 100, "{name}: {rim} rim pixels");
        assert!(rms < 0.02, "{name}: RMS {rms:.4}");
        assert!(worst < 0.1, "{name}: a pixel off by {worst:.3}");
        if level == &0.0 {
            assert!(columns > 100, "{name}: {columns} columns");
            assert!(off < 0.03, "{name}: the rim off by RMS {off:.3} px");
        }
        if let Some(ctx) = &ctx {
            let frame = picture_444(camera.width_px, camera.height_px, |_, _| 400, |_, _, _| 512);
            let gpu = codes(&render(
                ctx,
                &frame,
                &s,
                &p,
                &Inputs {
                    water: Some(&map),
                    ..Inputs::default()
                },
            ));
            let mut canvas = yuv_to_rgb::yuv_to_rgb(&frame, &p);
            puddles::puddles(
                &mut canvas,
                &frame,
                &p,
                &Water {
                    params: &params,
                    depth_m: &map.values,
                    ripples: &[],
                    lights: &lights,
                },
                None,
            );
            let cpu = rgb_to_yuv::rgb_to_yuv(&canvas, frame.format, &frame.color);
            let worst = (0..3)
                .flat_map(|k| gpu[k].iter().zip(&cpu[k]).map(|(a, b)| a.abs_diff(*b)))
                .max()
                .unwrap_or(0);
            eprintln!("{name}: GPU against the twin, worst {worst} codes");
            assert!(worst <= 1, "{name}: {worst} codes off");
        }
    }
}
