//! Splashes where drops land: the impacts are where the stateless drops meet the ground, as
//! many per second and square metre as the Marshall–Palmer flux brings, only drops above the
//! splashing threshold splash, the GPU stage draws what its CPU twin draws (its draw list holding
//! exactly the drawn slots, in order), and without a ground the stage has nothing to do. The
//! CPU back end's splashes match the twin too (their renders: `tests/backend.rs`).

use glam::{DVec2, DVec3};
use rain_composite::config::RainConfig;
use rain_composite::gpu::cpu::rain_splashes::splash_streaks;
use rain_composite::gpu::host::simulate::HIDDEN;
use rain_composite::gpu::host::splashes::HostSplashes;
use rain_composite::gpu::probe::{probe_splash_draw_list, probe_splashes};
use rain_composite::gpu::types::{LightList, RainParams, Streak};
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::lighting::rtf::RtfTable;
use rain_composite::lighting::{EnvironmentSh, LightSource, RtfSh, direct_colour, prt_colour};
use rain_composite::rain::physics::splash::{SPLASH_SLOTS, splash_number, splashes};
use rain_composite::rain::physics::terminal_velocity_gk_mps;
use rain_composite::rain::volume::{impacts_between, landing_columns, sample_drop};
use rain_composite::scene::Camera;

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/render.rs"]
mod render;
use render::{looking_down, rain_seen_by, water_tables};

const EXPOSURE_S: f64 = 0.02;

/// A camera 1.6 m above the street looking down (the horizon 10 % from the top, 90° lens) in
/// `rate_mm_per_h` of rain, drops drawn `drop_scale` times their size, with or without a ground.
fn setup(w: u32, h: u32, rate_mm_per_h: f64, drop_scale: f64, ground: bool) -> RainSetup {
    setup_in_wind(w, h, rate_mm_per_h, drop_scale, ground, [0.0; 2], 0.0)
}

/// [`setup`] in a mean wind `wind_mps` with gusts of RMS `gust_mps`.
fn setup_in_wind(
    w: u32,
    h: u32,
    rate_mm_per_h: f64,
    drop_scale: f64,
    ground: bool,
    wind_mps: [f64; 2],
    gust_mps: f64,
) -> RainSetup {
    let rain = RainConfig {
        rate_mm_per_h,
        opacity: 4.0,
        near_m: 0.3,
        far_m: 6.0,
        max_drops: 400_000,
        drop_scale,
        wind_mps,
        gust_mps,
        ..RainConfig::default()
    };
    rain_seen_by(&looking_down(), (w, h), &rain, EXPOSURE_S, ground).1
}

/// ∫ f(D) dD over [a, b] by Simpson's rule on `n` (even) intervals.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let inner: f64 = (1..n)
        .map(|i| f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 })
        .sum();
    (f(a) + f(b) + inner) * h / 3.0
}

/// Impacts per second per m² of ground counted over 3 s equal the Marshall–Palmer flux
/// ∫ N(D) v(D) dD (N = 8000 e^−ΛD m⁻³ mm⁻¹, Λ = 4.1 R^−0.21 mm⁻¹, Gunn–Kinzer fall speeds),
/// in all and for the drops above the splashing threshold only, within 5 %.
#[test]
fn splashes_per_second_and_square_metre_are_the_marshall_palmer_flux_above_the_threshold() {
    let rate = 25.0;
    let s = setup(320, 180, rate, 3.0, true);
    assert!(!s.volume.budget_binds, "{}", s.summary());
    let grid = &s.volume.grid;
    let area_m2 =
        landing_columns(&s.volume).count() as f64 * grid.cell_size_m.x * grid.cell_size_m.y;
    let (t0, t1) = (2.0, 5.0);
    let hits = impacts_between(s.rainfall(), t0, t1);
    let per = |n: usize| n as f64 * s.volume.weight / (area_m2 * (t1 - t0));
    let splashing = hits
        .iter()
        .filter(|h| splashes(h.diameter_mm, h.normal_speed_mps()))
        .count();
    let lambda = 4.1 * rate.powf(-0.21);
    let (d_lo, d_hi) = s.model.dsd.range_mm();
    let speed = |d: f64| s.model.fall.density_factor() * terminal_velocity_gk_mps(d);
    let flux = |d: f64| 8000.0 * (-lambda * d).exp() * speed(d);
    let all_want = simpson(flux, d_lo, d_hi, 4000);
    let above_want = simpson(
        |d| if splashes(d, speed(d)) { flux(d) } else { 0.0 },
        d_lo,
        d_hi,
        20_000,
    );
    eprintln!(
        "{} impacts ({splashing} splashing) on {area_m2:.2} m² in {} s: {:.0} vs {all_want:.0} \
         per m² s; splashing {:.0} vs {above_want:.0}",
        hits.len(),
        t1 - t0,
        per(hits.len()),
        per(splashing)
    );
    assert!(splashing > 2000, "{splashing}");
    assert!((per(hits.len()) / all_want - 1.0).abs() < 0.05);
    assert!((per(splashing) / above_want - 1.0).abs() < 0.05);
}

/// Each impact is where the stateless drop meets the ground: on z = 0, with the drop 0.1 ms
/// earlier that fall time above it (its velocity times 0.1 ms back), and 0.1 ms later at the
/// top of its column.
#[test]
fn impacts_lie_on_the_ground_where_the_drops_meet_it() {
    let s = setup(320, 180, 25.0, 3.0, true);
    let hits = impacts_between(s.rainfall(), 7.0, 7.3);
    assert!(hits.len() > 500, "{}", hits.len());
    let eps = 1e-4;
    let mut worst = 0.0f64;
    for h in &hits {
        assert_eq!(h.position_m.z, 0.0);
        let d = sample_drop(s.rainfall(), h.id, h.time_s - eps).expect("drop");
        let want = h.position_m - h.velocity_mps * eps;
        worst = worst.max((d.position_m - want).length());
        assert!((d.diameter_mm - h.diameter_mm).abs() < 1e-12);
        let after = sample_drop(s.rainfall(), h.id, h.time_s + eps).expect("drop");
        let col = &s.volume.grid.columns[after.column];
        assert!(after.position_m.z > col.z_hi_m - 2.0 * eps * -h.velocity_mps.z - 1e-6);
    }
    eprintln!(
        "{} impacts; worst distance from the drop's path {worst:.1e} m",
        hits.len()
    );
    assert!(worst < 1e-5, "{worst}");
}

/// Drops below the threshold draw no splash; drops above it near the camera do.
#[test]
fn only_drops_above_the_splashing_threshold_splash() {
    let s = setup(320, 180, 25.0, 3.0, true);
    let (mut below, mut drawn) = (0, 0);
    for t in [1.3, 4.05] {
        let p = s.motion_at(t);
        for ci in landing_columns(&s.volume) {
            let col = s.volume.grid.columns[ci];
            for id in col.first_id..col.first_id + col.count as u64 {
                let (hit, streaks) = splash_streaks(&s, &p, id, t);
                let Some(hit) = hit else { continue };
                if splash_number(hit.diameter_mm, hit.normal_speed_mps()) <= 2100.0 {
                    below += 1;
                    assert!(streaks.is_empty(), "drop {id} splashed below the threshold");
                } else {
                    drawn += streaks.len();
                }
            }
        }
    }
    eprintln!("{below} impacts below the threshold, {drawn} splash streaks above it");
    assert!(below > 1000 && drawn > 100, "{below} {drawn}");
}

/// The GPU stage draws the splashes its CPU twin draws: the same streaks in the same slots,
/// their ends within 0.05 px; and without a ground it has no drop to handle.
#[test]
fn the_gpu_draws_the_splashes_its_twin_draws() {
    let Some(ctx) = gpu() else { return };
    let tables = water_tables(256);
    let none = LightList::new(&[]);
    let off = setup(160, 90, 25.0, 3.0, false);
    let (ids, _) = probe_splashes(&ctx, &off, &off.motion_at(1.0), &none, &tables).expect("probe");
    assert!(
        ids.is_empty(),
        "{} landing drops without a ground",
        ids.len()
    );
    let still = setup(160, 90, 25.0, 3.0, true);
    let gusty = setup_in_wind(160, 90, 25.0, 3.0, true, [2.0, 1.0], 2.0);
    let (mut compared, mut borderline, mut worst_px) = (0, 0, 0.0f64);
    for (s, t) in [(&still, 0.8), (&still, 3.37), (&gusty, 2.2)] {
        let p = s.motion_at(t);
        let (ids, gpu) = probe_splashes(&ctx, s, &p, &none, &tables).expect("probe");
        assert!(ids.len() > 1000, "{} landing drops", ids.len());
        for (g, &id) in ids.iter().enumerate() {
            let slots = &gpu[g * SPLASH_SLOTS as usize..(g + 1) * SPLASH_SLOTS as usize];
            let (_, cpu) = splash_streaks(s, &p, id as u64, t);
            for (slot, gs) in slots.iter().enumerate() {
                let c = cpu.iter().find(|c| c.slot as usize == slot);
                match c {
                    Some(c) if gs.len_px >= 0.0 => {
                        compared += 1;
                        let q0 = glam::DVec2::new(gs.q0_px[0] as f64, gs.q0_px[1] as f64);
                        let end = |q: glam::DVec2, dir: [f32; 2], len: f64| {
                            q + glam::DVec2::new(dir[0] as f64, dir[1] as f64) * len
                        };
                        let d0 = (q0 - c.shape.q0_px).length();
                        let d1 = (end(q0, gs.dir, gs.len_px as f64)
                            - (c.shape.q0_px + c.shape.dir * c.shape.len_px))
                            .length();
                        worst_px = worst_px.max(d0).max(d1);
                        assert!(
                            d0 < 0.05 && d1 < 0.05,
                            "drop {id} slot {slot}: {d0} {d1} px"
                        );
                        let a = gs.alpha_scale as f64;
                        assert!(
                            (a - c.shape.alpha_scale).abs() <= 1e-3 * c.shape.alpha_scale + 1e-6
                        );
                    }
                    // At a cut (a pixel wide, the faintest drawn): f32 may fall either side.
                    Some(c) => {
                        borderline += 1;
                        assert!(c.shape.r_px < 0.51 || c.shape.peak_alpha() < 0.6 / 255.0)
                    }
                    None if gs.len_px >= 0.0 => {
                        borderline += 1;
                        assert!(
                            gs.r_eff_px < 0.8 || gs.alpha_scale < 1e-2,
                            "drop {id} slot {slot} on the GPU only"
                        );
                    }
                    None => {}
                }
            }
        }
    }
    eprintln!(
        "{compared} splash streaks compared ({borderline} at a cut); worst end {worst_px:.1e} px"
    );
    assert!(compared > 50, "{compared}");
    assert!(borderline * 50 < compared, "{borderline} of {compared}");
}

/// The draw list the stage packs for its indirect draw is its drawn slots (those the rasteriser
/// does not skip), byte for byte and in slot order, and nothing else: drawing it blends exactly
/// what drawing every slot blends. The packing works in blocks of drops, so a drop order broken
/// at a block's edge, or a block counted twice or not at all, fails here.
#[test]
fn the_draw_list_is_the_drawn_slots_in_order() {
    let Some(ctx) = gpu() else { return };
    let tables = water_tables(256);
    let none = LightList::new(&[]);
    let still = setup(160, 90, 25.0, 3.0, true);
    let gusty = setup_in_wind(160, 90, 25.0, 3.0, true, [2.0, 1.0], 2.0);
    for (s, t) in [(&still, 0.8), (&still, 3.37), (&gusty, 2.2)] {
        let p = s.motion_at(t);
        let (ids, slots) = probe_splashes(&ctx, s, &p, &none, &tables).expect("probe");
        let list = probe_splash_draw_list(&ctx, s, &p, &none, &tables).expect("draw list");
        // The rasteriser skips len_px < 0 only (a NaN would go through).
        let expected: Vec<_> = slots
            .iter()
            .filter(|s| s.len_px >= 0.0 || s.len_px.is_nan())
            .collect();
        assert!(ids.len() > 1000 && !expected.is_empty());
        assert_eq!(list.len(), expected.len(), "t {t}");
        for (i, (a, b)) in list.iter().zip(&expected).enumerate() {
            assert_eq!(
                bytemuck::bytes_of(a),
                bytemuck::bytes_of(*b),
                "t {t}: streak {i}"
            );
        }
        eprintln!(
            "t {t}: {} of {} slots drawn ({} landing drops)",
            list.len(),
            slots.len(),
            ids.len()
        );
    }
}

/// A camera given no ground: no drop lands, whatever the stage (the render is unchanged byte
/// for byte, `tests/impacts.rs`).
#[test]
fn without_a_ground_nothing_splashes() {
    let s = setup(160, 90, 25.0, 3.0, false);
    let p = s.motion_at(2.0);
    for id in 0..s.volume.simulated {
        assert!(splash_streaks(&s, &p, id, 2.0).1.is_empty());
    }
}

/// The stage places a splash from the drop's drift at the frame's time: exactly the impact in
/// steady wind; in gusts near it (the drift rate of the frame's time standing for the last
/// fraction of a second).
#[test]
fn splashes_are_placed_at_the_impacts() {
    use rain_composite::gpu::cpu::rain_splashes::placed_from_frame;
    use rain_composite::rain::volume::latest_impact;
    for (wind, gust, bound_m) in [([2.0, 1.0], 0.0, 1e-5), ([2.0, 1.0], 2.0, 0.1)] {
        let s = setup_in_wind(160, 90, 25.0, 3.0, true, wind, gust);
        let (mut n, mut worst, mut sum) = (0, 0.0f64, 0.0);
        for t in [1.1, 6.4] {
            let p = s.motion_at(t);
            for id in 0..s.volume.simulated {
                let Some(hit) = latest_impact(s.rainfall(), id, t) else {
                    continue;
                };
                if t - hit.time_s > 0.5 {
                    continue;
                }
                let placed = placed_from_frame(&s, &p, hit, t);
                let off = (placed.position_m - hit.position_m).length();
                // A drift across a cell's edge wraps: measure modulo the cell.
                let cell = s.volume.grid.cell_size_m;
                let d = placed.position_m - hit.position_m;
                let off = off.min(
                    glam::DVec2::new(
                        d.x - (d.x / cell.x).round() * cell.x,
                        d.y - (d.y / cell.y).round() * cell.y,
                    )
                    .length(),
                );
                n += 1;
                worst = worst.max(off);
                sum += off;
            }
        }
        eprintln!(
            "gusts {gust} m/s: {n} splashes younger than 0.5 s, placed {:.1e} m from their \
             impacts on average, {worst:.1e} m at worst",
            sum / n as f64
        );
        assert!(n > 1000 && worst < bound_m, "{n} {worst}");
    }
}

// The splashes simulated on the CPU back end (`gpu::host::splashes`, f32 as the WGSL) against
// the twin (f64, from the splash model).

/// One random shot of splashes, lit by a sky, a sun and a near lamp.
struct Shot {
    setup: RainSetup,
    params: RainParams,
    camera: Camera,
    env: EnvironmentSh,
    sources: Vec<LightSource>,
    rtf: RtfSh,
    t_s: f64,
}

/// Shot `k` over a 320×180 picture: a camera 1.6 m up looking down at random (the horizon
/// 5–30 % from the top, a 60–100° lens), a random rate, wind and gusts, drops 1–3 times their
/// size, 1/50 or 1/100 s exposures, a time up to an hour in; on every third shot a keyed rate
/// that falls and stops in the second before the frame.
fn shot(k: u64) -> Shot {
    use rain_composite::lighting::FrameLight;
    use rain_composite::lighting::prt::channel_optics;
    use rain_composite::lighting::rtf::{ChannelIndices, Polarisation, WATER_RHO_RGB};
    let mut r = rain_composite::rng::SplitMix64(77 + k);
    let mut u = || r.next_f64();
    let mut config = looking_down();
    config.ground.mode = format!("horizon={:.3}", 0.05 + 0.25 * u())
        .parse()
        .expect("mode");
    config.camera.fov_deg = 60.0 + 40.0 * u();
    let rain = RainConfig {
        rate_mm_per_h: 5.0 + 45.0 * u(),
        opacity: 1.0 + 3.0 * u(),
        near_m: 0.3,
        far_m: 5.0 + 5.0 * u(),
        max_drops: 400_000,
        drop_scale: 1.0 + 2.0 * u(),
        wind_mps: [6.0 * (u() - 0.5), 4.0 * (u() - 0.5)],
        gust_mps: 2.0 * u(),
        seed: k as u32 * 13 + 5,
        ..RainConfig::default()
    };
    let exposure_s = [1.0 / 50.0, 1.0 / 100.0][k as usize % 2];
    let (camera, mut setup) = rain_seen_by(&config, (320, 180), &rain, exposure_s, true);
    let t_s = [0.8, 3.37, 41.9, 3600.25][k as usize % 4] + u();
    if k % 3 == 1 {
        // A keyed rate falling to 40 % of the peak, then stopping: passes born in it thin out.
        let peak = rain.rate_mm_per_h;
        let keys = rain_composite::keyframes::Curve::new(vec![
            ((t_s - 1.2).max(0.0), peak),
            (t_s - 0.6, 0.4 * peak),
            (t_s - 0.2, 0.0),
        ])
        .expect("keys");
        setup.plan.model = setup.plan.model.clone().with_rate_keys(&keys);
    }
    let optics =
        channel_optics(ChannelIndices(WATER_RHO_RGB), 5, Polarisation::default()).expect("optics");
    let rtf = RtfSh::from_optics(&optics, 4).expect("rtf");
    let mut env = EnvironmentSh::zeros(4);
    env.coeffs[0] = [0.8, 0.9, 1.0];
    env.coeffs[2] = [0.3, 0.35, 0.5];
    env.coeffs[5] = [0.1 * u() as f32, -0.05, 0.02];
    let sources = vec![
        LightSource {
            direction_world: DVec3::new(0.3, -0.8, 0.5).normalize(),
            solid_angle_sr: 6.8e-5,
            radiance_rgb: [2e4, 1.9e4, 1.7e4],
            distance_m: None,
        },
        LightSource {
            direction_world: camera.ray_world(glam::DVec2::new(100.0, 120.0)).normalize(),
            solid_angle_sr: 2e-3,
            radiance_rgb: [3000.0, 2500.0, 1500.0],
            distance_m: Some(2.0 + 3.0 * u()),
        },
    ];
    let zonal = rtf.to_gpu_array();
    let light = FrameLight {
        env: env.clone(),
        lights: sources.clone(),
    };
    let params = setup.params_at(t_s, &light, zonal);
    Shot {
        setup,
        params,
        camera,
        env,
        sources,
        rtf,
        t_s,
    }
}

/// The shot's splashes on the CPU back end: every slot of every landing drop, and the drop
/// ids; `None` where no column of the view reaches the ground.
fn host_slots(s: &Shot, tables: &[RtfTable; 3]) -> Option<(Vec<u32>, Vec<Streak>)> {
    let mut host = HostSplashes::new(&s.setup)?;
    host.set_transfer_table(tables);
    host.set_lights(&LightList::new(&s.sources));
    Some((host.drop_ids(), host.slots(&s.params)))
}

/// The twin's light at a streak's end (camera frame, m): the sky through the drop's PRT plus
/// the compact lights through the transfer table, clamped at 0 (`drop_radiance`).
fn twin_light(s: &Shot, tables: &[RtfTable; 3], end: DVec3) -> [f64; 3] {
    let offset = s.camera.world_from_camera * end;
    let env = prt_colour(&s.env, &s.rtf, offset);
    let direct = direct_colour(&s.sources, tables, Some(offset), offset);
    std::array::from_fn(|c| (env[c] + direct[c]).max(0.0))
}

/// The splashes simulated on the CPU match the twin's on random shots (lens, tilt, rate, keyed
/// rates, wind, gusts, exposure, an hour into the clip, lit by a sky, a sun and a near lamp): the same
/// streaks in the same slots but for a few at a cut, where f32 and f64 fall on either side
/// (a pixel wide, the faintest drawn, or a droplet's flight ending as the exposure opens);
/// where both draw, the ends within 0.01 px, radius and alpha within 10⁻³, the light within
/// 2 × 10⁻³ of the end's brightest channel (2 % on a few ends on a bow's caustic, where the
/// transfer table steps, as for the drops).
#[test]
fn host_splashes_match_the_twin() {
    let tables = water_tables(1024);
    let (mut compared, mut borderline, mut worst_px) = (0, 0, 0.0f64);
    let (mut worst_alpha, mut worst_light) = (0.0f64, 0.0f64);
    let (mut shots, mut lights, mut steep) = (0, 0, 0);
    for k in 0..12 {
        let s = shot(k);
        // A steep view of a short rain may end above the ground.
        let Some((ids, ours)) = host_slots(&s, &tables) else {
            eprintln!(
                "shot {k}: no column reaches the ground ({})",
                s.setup.summary()
            );
            continue;
        };
        shots += 1;
        let (mut here, mut cut) = (0, 0);
        for (g, &id) in ids.iter().enumerate() {
            let slots = &ours[g * SPLASH_SLOTS as usize..(g + 1) * SPLASH_SLOTS as usize];
            let (_, twin) = splash_streaks(&s.setup, &s.params, id as u64, s.t_s);
            for (slot, o) in slots.iter().enumerate() {
                let t = twin.iter().find(|c| c.slot as usize == slot);
                let what = format!("shot {k}, drop {id}, slot {slot}: {o:?} against {t:?}");
                match t {
                    Some(t) if o.len_px >= 0.0 => {
                        here += 1;
                        let t = &t.shape;
                        let q0 = DVec2::new(o.q0_px[0] as f64, o.q0_px[1] as f64);
                        let dir = DVec2::new(o.dir[0] as f64, o.dir[1] as f64);
                        let d0 = (q0 - t.q0_px).length();
                        let d1 =
                            (q0 + dir * o.len_px as f64 - (t.q0_px + t.dir * t.len_px)).length();
                        worst_px = worst_px.max(d0).max(d1);
                        assert!(d0 < 0.01 && d1 < 0.01, "{what}: {d0} {d1} px");
                        let rel = |a: f32, b: f64| (a as f64 - b).abs() / b.abs().max(1e-12);
                        worst_alpha = worst_alpha.max(rel(o.alpha_scale, t.alpha_scale));
                        assert!(rel(o.alpha_scale, t.alpha_scale) <= 1e-3, "{what}: alpha");
                        assert!(rel(o.r_eff_px, t.r_eff_px) <= 1e-3, "{what}: radius");
                        for (e, r) in [o.radiance0, o.radiance1].iter().enumerate() {
                            let want = twin_light(&s, &tables, t.ends_camera_m[e]);
                            let scale = want.iter().cloned().fold(1e-3, f64::max);
                            for c in 0..3 {
                                let err = (r[c] as f64 - want[c]).abs() / scale;
                                worst_light = worst_light.max(err);
                                lights += 1;
                                if err > 2e-3 {
                                    steep += 1;
                                    assert!(err <= 2e-2, "{what}: end {e} channel {c}: {want:?}");
                                }
                            }
                            assert!(rel(r[3], t.ends_camera_m[e].z) <= 1e-4, "{what}: depth");
                        }
                    }
                    // At a cut: a pixel wide, or the faintest drawn.
                    Some(t) => {
                        cut += 1;
                        let t = &t.shape;
                        assert!(t.r_px < 0.51 || t.peak_alpha() < 0.6 / 255.0, "{what}");
                    }
                    None if o.len_px >= 0.0 => {
                        cut += 1;
                        assert!(o.r_eff_px < 0.8 || o.alpha_scale < 1e-2, "{what}");
                    }
                    None => assert_eq!(*o, HIDDEN, "{what}"),
                }
            }
        }
        eprintln!(
            "shot {k}: {} landing drops, {here} splash streaks drawn alike, {cut} at a cut",
            ids.len()
        );
        assert!(here > 0, "shot {k}: nothing compared");
        compared += here;
        borderline += cut;
    }
    eprintln!(
        "{compared} splash streaks compared ({borderline} at a cut); worst end {worst_px:.1e} \
         px, alpha {worst_alpha:.1e}, light {worst_light:.1e} ({steep} of {lights} beyond 2e-3)"
    );
    assert!(
        steep * 200 <= lights,
        "{steep} of {lights} lights beyond 2e-3"
    );
    assert!(shots >= 9, "{shots} shots with splashes");
    assert!(compared > 5000, "{compared} compared");
    assert!(borderline * 100 < compared, "{borderline} of {compared}");
}

/// The splashes on the CPU are the same bits twice, on one thread as on many, and without the
/// cull of splashes whose droplets are all thinner than a pixel; their draw list is the drawn
/// slots, in order; another seed gives other splashes.
#[test]
fn host_splashes_are_deterministic() {
    let tables = water_tables(1024);
    let s = shot(3);
    let run = || host_slots(&s, &tables).expect("landing drops").1;
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool")
        .install(run);
    let (a, b) = (run(), run());
    assert!(a == b, "two runs differ");
    assert!(a == one, "one thread differs");
    // Skipping the droplets of splashes too thin to show changes no bit.
    for k in 0..6 {
        let s = shot(k);
        let Some(mut host) = HostSplashes::new(&s.setup) else {
            continue;
        };
        host.set_transfer_table(&tables);
        host.set_lights(&LightList::new(&s.sources));
        let cut = host.slots(&s.params);
        assert!(
            host.slots_uncut(&s.params) == cut,
            "shot {k}: the cull changes a bit"
        );
    }
    let mut host = HostSplashes::new(&s.setup).expect("landing drops");
    host.set_transfer_table(&tables);
    host.set_lights(&LightList::new(&s.sources));
    let drawn: Vec<Streak> = a.iter().filter(|x| x.len_px >= 0.0).copied().collect();
    assert!(drawn.len() > 100, "{} drawn", drawn.len());
    assert!(
        host.simulate(&s.params) == drawn.as_slice(),
        "the draw list"
    );
    let mut other = s.params;
    other.seed += 1;
    assert!(
        host.simulate(&other) != drawn.as_slice(),
        "the seed changes nothing"
    );
}
