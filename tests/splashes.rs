//! Splashes where drops land: the impacts are where the stateless drops meet the ground, as
//! many per second and square metre as the Marshall–Palmer flux brings, only drops above the
//! splashing threshold splash, the GPU stage draws what its CPU twin draws (its draw list holding
//! exactly the drawn slots, in order), and without a ground the stage has nothing to do.

use rain_composite::config::RainConfig;
use rain_composite::gpu::cpu::rain_splashes::splash_streaks;
use rain_composite::gpu::probe::{probe_splash_draw_list, probe_splashes};
use rain_composite::gpu::types::LightList;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::rain::physics::splash::{SPLASH_SLOTS, splash_number, splashes};
use rain_composite::rain::physics::terminal_velocity_gk_mps;
use rain_composite::rain::volume::{impacts_between, landing_columns, sample_drop};

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
