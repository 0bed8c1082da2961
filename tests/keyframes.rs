//! Settings that change over a shot: a keyed rain rate thins the peak rate's drops once per
//! fall, at their birth above the view, into the Marshall–Palmer rain of the rate then; a keyed
//! wind moves the drops with their own lag. Checked on the CPU twin against independent
//! references (the size distribution, an ODE integration) and on the GPU against the twin.

use glam::{DVec2, DVec3};
use rain_composite::config::{CameraConfig, RainConfig, RenderConfig};
use rain_composite::gpu::probe::probe_drops;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::keyframes::{Curve, Keyframes};
use rain_composite::lighting::wetness::{RainHistory, SurfaceStore};
use rain_composite::rain::physics::{DropSizeDistribution, RainRate};
use rain_composite::rain::volume::Rainfall;
use rain_composite::rain::volume::{RATE_STREAM, cycle_uniform, drop_uniform, sample_drop};
use rain_composite::rain::wind::Wind;
use rain_composite::scene::Camera;

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

const FPS: f64 = 25.0;

fn ramp(keys: &[(f64, f64)]) -> Curve<f64> {
    Curve::new(keys.to_vec()).expect("keys")
}

/// The rain of `rain` with `keys`, seen by a level 960×540 camera.
fn keyed(rain: RainConfig, keys: Keyframes) -> (Camera, RainSetup) {
    let camera = Camera::new(960, 540, 1.0, 1.6, 0.0, 0.0);
    let setup = rain_composite::shot::rain::plan_keyed(
        &camera,
        &CameraConfig::default(),
        &rain,
        &keys,
        0.02,
        0,
        (960, 540),
    )
    .map(RainSetup::pack)
    .expect("rain");
    (camera, setup)
}

/// Whether a point is inside the picture between the near and far distances, by `margin_px`
/// (negative: within that much outside).
fn in_view(camera: &Camera, setup: &RainSetup, p: DVec3, margin_px: f64) -> bool {
    let c = camera.camera_from_world_point(p);
    let v = &setup.volume;
    if c.z < v.near_m || c.z > v.far_m {
        return false;
    }
    camera.project_camera(c).is_some_and(|q| {
        q.x > margin_px
            && q.y > margin_px
            && q.x < camera.width_px as f64 - margin_px
            && q.y < camera.height_px as f64 - margin_px
    })
}

/// Thinning the peak rate's drops by `keeps` leaves the Marshall–Palmer drops of the lower
/// rate: their number relative to the peak's and their mean diameter, against the size
/// distribution's own closed forms.
#[test]
fn thinning_leaves_the_marshall_palmer_rain_of_each_rate() {
    let peak = RainRate::from_mm_per_h(40.0).expect("rate");
    let (_, setup) = keyed(
        RainConfig {
            rate_mm_per_h: 40.0,
            ..RainConfig::default()
        },
        Keyframes::default(),
    );
    let model = &setup.model;
    let peak_dsd = DropSizeDistribution::marshall_palmer(peak);
    let n = 400_000u32;
    for r in [1.0, 5.0, 20.0, 40.0] {
        let dsd = DropSizeDistribution::marshall_palmer(RainRate::from_mm_per_h(r).expect("r"));
        let (mut kept, mut sum_d) = (0u32, 0.0);
        for id in 0..n {
            let d = peak_dsd.diameter_from_uniform_mm(drop_uniform(5, id, 3));
            if cycle_uniform(5, id, 17, RATE_STREAM) < model.keeps(r, d) {
                kept += 1;
                sum_d += d;
            }
        }
        let fraction = kept as f64 / n as f64;
        let want = dsd.number_density_per_m3() / peak_dsd.number_density_per_m3();
        assert!(
            (fraction / want - 1.0).abs() < 0.01,
            "{r} mm/h: kept {fraction:.4}, Marshall–Palmer {want:.4}"
        );
        let mean = sum_d / kept as f64;
        let want_mean = dsd.moment(1.0) / dsd.moment(0.0);
        assert!(
            (mean / want_mean - 1.0).abs() < 0.01,
            "{r} mm/h: mean diameter {mean:.4} mm, Marshall–Palmer {want_mean:.4} mm"
        );
    }
    assert_eq!(model.keeps(0.0, 1.0), 0.0, "no rain at 0 mm/h");
}

/// Rain rate 0 → 30 mm/h over 4 s: the drops in view rise frame after frame; a drop is only
/// ever added at its birth above the view (entering the picture from outside it), and only
/// ever removed at the end of its fall, never mid-air.
#[test]
fn a_keyed_rate_adds_drops_only_where_they_enter_the_view() {
    let keys = Keyframes {
        rate_mm_per_h: Some(ramp(&[(0.0, 0.0), (4.0, 30.0)])),
        ..Keyframes::default()
    };
    let (camera, setup) = keyed(
        RainConfig {
            max_drops: 60_000,
            ..RainConfig::default()
        },
        keys,
    );
    let n = setup.drop_count() as u64;
    assert!(n > 20_000, "{n} drops");
    let (vol, model, wind, seed) = (&setup.volume, &setup.model, &setup.wind, setup.params.seed);
    let mut unkeyed = model.clone();
    unkeyed.rate_keys = None;
    let mut counts = Vec::new();
    let mut prev: Vec<Option<_>> = vec![None; n as usize];
    let (mut entered, mut left) = (0, 0);
    for frame in 0..=(4.0 * FPS) as u32 {
        let t = frame as f64 / FPS;
        let mut count = 0;
        for id in 0..n {
            let cur = sample_drop(Rainfall::new(vol, model, wind, seed), id, t);
            let seen = cur.filter(|d| in_view(&camera, &setup, d.position_m, 0.0));
            count += seen.is_some() as u32;
            let before = std::mem::replace(&mut prev[id as usize], cur);
            if frame == 0 {
                continue;
            }
            match (before, cur) {
                (None, Some(d)) | (Some(_), Some(d)) if before.is_none_or(|b| b.pass != d.pass) => {
                    // A new pass: born since the last frame, at its column's top, which lies
                    // outside the view (within a pixel of its edge at most).
                    entered += 1;
                    assert!(
                        d.born_s > t - 1.0 / FPS - 1e-9 && d.born_s <= t,
                        "drop {id}"
                    );
                    let at_birth =
                        sample_drop(Rainfall::new(vol, model, wind, seed), id, d.born_s + 1e-7)
                            .expect("the same pass falls");
                    assert_eq!(at_birth.pass, d.pass);
                    assert!(
                        !in_view(&camera, &setup, at_birth.position_m, 1.0),
                        "drop {id} born inside the view at {:?}",
                        at_birth.position_m
                    );
                }
                (Some(b), None) => {
                    // Gone: only because its pass ended (it fell out of its column).
                    left += 1;
                    let now = sample_drop(Rainfall::new(vol, &unkeyed, wind, seed), id, t)
                        .expect("in a column");
                    assert_ne!(now.pass, b.pass, "drop {id} vanished mid-air at {t} s");
                }
                _ => {}
            }
        }
        counts.push(count);
    }
    assert_eq!(counts[0], 0, "no rain at 0 mm/h");
    assert!(
        entered > 1000 && left > 100,
        "entered {entered}, left {left}"
    );
    for (f, w) in counts.windows(2).enumerate() {
        assert!(
            w[1] >= w[0],
            "frame {}: {} drops after {}",
            f + 1,
            w[1],
            w[0]
        );
    }
    // At the peak the count approaches what the plan expects in view (weight 1: no budget).
    let last = *counts.last().expect("frames");
    assert!(last > counts[(FPS) as usize] * 2, "{counts:?}");
}

/// A drop's velocity under a keyed mean wind (ramps and a hold, slope changes at each key)
/// against a numerical integration of τ v' + v = W̄(t), and its displacement against the
/// integral of that velocity.
#[test]
fn drops_follow_a_keyed_wind_with_their_own_lag() {
    let keys = Curve::new(vec![
        (0.5, DVec2::new(0.0, 0.0)),
        (2.0, DVec2::new(9.0, -2.0)),
        (2.4, DVec2::new(9.0, -2.0)),
        (3.0, DVec2::new(4.0, 1.0)),
    ])
    .expect("keys");
    let wind = Wind::steady(DVec2::ZERO)
        .expect("wind")
        .with_mean_keys(&keys);
    for tau in [0.15, 0.7] {
        let (mut v, mut x, mut t) = (DVec2::ZERO, DVec2::ZERO, 0.0);
        let h = 1e-4;
        let f = |t: f64, v: DVec2| (keys.at(t) - v) / tau;
        while t < 5.0 - 1e-12 {
            // RK4 on (x, v).
            let k1 = f(t, v);
            let k2 = f(t + 0.5 * h, v + 0.5 * h * k1);
            let k3 = f(t + 0.5 * h, v + 0.5 * h * k2);
            let k4 = f(t + h, v + h * k3);
            let dv = h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            x += h * v + h * h / 6.0 * (k1 + k2 + k3);
            v += dv;
            t += h;
            let step = (t / h).round() as u64;
            if step.is_multiple_of(2500) {
                let (vc, xc) = (
                    wind.drop_velocity_mps(t, tau),
                    wind.drop_displacement_m(t, tau),
                );
                assert!((vc - v).length() < 1e-5, "τ {tau} t {t}: v {vc} vs {v}");
                assert!((xc - x).length() < 1e-5, "τ {tau} t {t}: x {xc} vs {x}");
            }
        }
        // The air itself (τ → 0) is the keyed wind.
        assert_eq!(wind.drop_velocity_mps(2.2, 0.0), DVec2::new(9.0, -2.0));
    }
}

/// The GPU emitter under a keyed rate and wind agrees with its CPU twin, drop by drop: the same
/// drops left out, the same positions and velocities.
#[test]
fn the_gpu_thins_and_blows_the_drops_as_the_twin_does() {
    let Some(ctx) = gpu() else { return };
    let keys = Keyframes {
        rate_mm_per_h: Some(ramp(&[(0.0, 2.0), (1.0, 0.0), (3.0, 40.0), (9.0, 5.0)])),
        wind_mps: Some(
            Curve::new(vec![
                (0.0, DVec2::ZERO),
                (1.5, DVec2::new(6.0, 1.0)),
                (4.0, DVec2::new(-2.0, 0.0)),
            ])
            .expect("wind"),
        ),
        ..Keyframes::default()
    };
    let (_, setup) = keyed(
        RainConfig {
            gust_mps: 1.5,
            seed: 11,
            ..RainConfig::default()
        },
        keys,
    );
    for t in [0.3, 1.7, 3.9, 8.25, 31.0] {
        let gpu_drops = probe_drops(&ctx, &setup, t, 8192).expect("probe");
        let (mut both, mut disagree, mut wrapped) = (0, 0, 0);
        for (id, g) in gpu_drops.iter().enumerate() {
            let c = sample_drop(setup.rainfall(), id as u64, t);
            match c {
                Some(c) if g.diameter_mm > 0.0 => {
                    both += 1;
                    assert!(
                        (g.vel_mps - c.velocity_mps.as_vec3()).length() < 2e-3,
                        "drop {id} t {t}: {:?} vs {:?}",
                        g.vel_mps,
                        c.velocity_mps
                    );
                    if (g.pos_m - c.position_m.as_vec3()).length() > 5e-3 {
                        wrapped += 1;
                    }
                }
                None if g.diameter_mm < 0.0 => {}
                _ => disagree += 1,
            }
        }
        // f32 against f64: a drop a hair from a threshold or its column's end may differ.
        assert!(
            disagree <= 4 && wrapped <= 8,
            "t {t}: {disagree} disagree, {wrapped} apart"
        );
        assert!(both > 100 || t < 1.0, "t {t}: only {both} drops fall");
    }
}

/// The wetting of a keyed rate: stepping the linear ramp at its midpoints lands what a
/// 1-ms-step history of the same ramp lands, and a constant key is a constant history.
#[test]
fn a_keyed_rate_wets_the_ground_as_it_falls() {
    let store = SurfaceStore::default();
    let keys = ramp(&[(1.0, 0.0), (7.0, 60.0), (9.0, 60.0), (11.0, 0.0)]);
    let fine = RainHistory::new(
        std::iter::once((-600.0, 0.0))
            .chain((0..12_000).map(|i| {
                let t = i as f64 * 1e-3;
                (t, keys.at(t + 0.5e-3))
            }))
            .collect(),
    )
    .expect("history");
    let coarse = RainHistory::keyed(&keys, 600.0);
    for t in [2.0, 6.5, 9.0, 11.9] {
        let (a, b) = (coarse.store_mm(&store, t), fine.store_mm(&store, t));
        assert!((a - b).abs() <= 1e-3 * b.max(1e-3), "t {t}: {a} vs {b} mm");
    }
    let constant = RainHistory::keyed(&Curve::constant(8.0), 300.0);
    let plain = RainHistory::constant(8.0, 300.0);
    for t in [0.0, 5.0, 60.0] {
        assert_eq!(constant.store_mm(&store, t), plain.store_mm(&store, t));
    }
}

/// Keys in a configuration: values at t = 0 where the plain settings are read, the keys back
/// in `to_value`, and each key's value checked against the setting's range.
#[test]
fn keyed_configurations_validate_every_key() {
    let text = r#"{"rain": {"rate_mm_per_h": [[0, 0], [4, 30]], "opacity": [[1, 1], [2, 3]]},
                   "camera": {"focus_m": [[0, 2], [3, 20]]}}"#;
    let config = RenderConfig::from_json(text).expect("keyed");
    assert_eq!(config.rain.rate_mm_per_h, 0.0);
    assert_eq!(config.at(2.0).rain.rate_mm_per_h, 15.0);
    assert_eq!(config.at(9.0).camera.focus_m, 20.0);
    config.validate().expect("in range");
    let back = RenderConfig::from_value(config.to_value()).expect("round trip");
    assert_eq!(back, config);

    let too_much = r#"{"rain": {"rate_mm_per_h": [[0, 0], [4, 900]]}}"#;
    let e = RenderConfig::from_json(too_much)
        .expect("parses")
        .validate()
        .expect_err("900 mm/h")
        .to_string();
    assert!(
        e.contains("900") && e.contains("at 4 s") && e.contains("mm/h"),
        "{e}"
    );
    let pinhole = r#"{"camera": {"f_number": [[0, 0], [4, 2.8]]}}"#;
    let e = RenderConfig::from_json(pinhole)
        .expect("parses")
        .validate()
        .expect_err("pinhole key")
        .to_string();
    assert!(e.contains("camera.f_number"), "{e}");
    let e = RenderConfig::from_json(r#"{"camera": {"shutter_deg": [[0, 180], [4, 90]]}}"#)
        .expect_err("not keyable")
        .to_string();
    assert!(
        e.contains("camera.shutter_deg") && e.contains("rain.rate_mm_per_h"),
        "{e}"
    );
    // A keyed pose is checked at each key too.
    let e = RenderConfig::from_json(r#"{"camera": {"tilt_deg": [[0, 0], [4, 100]]}}"#)
        .expect("parses")
        .validate()
        .expect_err("tilt beyond 90°")
        .to_string();
    assert!(e.contains("camera.tilt_deg") && e.contains("at 4 s"), "{e}");
}
