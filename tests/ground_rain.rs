//! All the rain landing on the ground: the drawn drops' impacts where their columns stand on
//! the ground and the stateless stream elsewhere, together the Marshall–Palmer flux everywhere
//! (no gap and no double count at the seam), flux-weighted sizes, none at rate 0, the same
//! impacts however the time is cut.

use glam::DVec2;
use rain_composite::config::RainConfig;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::keyframes::Curve;
use rain_composite::rain::physics::terminal_velocity_gk_mps;
use rain_composite::rain::volume::Rainfall;
use rain_composite::rain::volume::{GroundRain, GroundRect, Impact, StreamSlots, landing_columns};

#[path = "common/render.rs"]
mod render;
use render::{looking_down, rain_seen_by};

/// A camera 1.6 m above the street looking down (the horizon 10 % from the top, 90° lens) in
/// `rate_mm_per_h` of still rain, drops drawn 3 times their size to 6 m (so the drawn drops
/// land on the first few metres of ground).
fn setup(rate_mm_per_h: f64) -> RainSetup {
    let rain = RainConfig {
        rate_mm_per_h,
        near_m: 0.3,
        far_m: 6.0,
        max_drops: 400_000,
        drop_scale: 3.0,
        ..RainConfig::default()
    };
    rain_seen_by(&looking_down(), (320, 180), &rain, 0.02, true).1
}

fn ground_rain(s: &RainSetup) -> GroundRain {
    GroundRain::new(s.rainfall())
}

/// ∫ f(D) dD over [a, b] by Simpson's rule on `n` (even) intervals.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let inner: f64 = (1..n)
        .map(|i| f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 })
        .sum();
    (f(a) + f(b) + inner) * h / 3.0
}

/// The Marshall–Palmer flux ∫ N(D) v(D) D^k dD of `s`'s rain (N = 8000 e^−ΛD m⁻³ mm⁻¹,
/// Λ = 4.1 R^−0.21 mm⁻¹, Gunn–Kinzer fall speeds), over its truncation range.
fn flux_moment(s: &RainSetup, rate_mm_per_h: f64, k: i32) -> f64 {
    let lambda = 4.1 * rate_mm_per_h.powf(-0.21);
    let (a, b) = s.model.dsd.range_mm();
    let v = |d: f64| s.model.fall.density_factor() * terminal_velocity_gk_mps(d);
    simpson(
        |d| 8000.0 * (-lambda * d).exp() * v(d) * d.powi(k),
        a,
        b,
        4000,
    )
}

fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> GroundRect {
    GroundRect {
        min_m: DVec2::new(x0, y0),
        max_m: DVec2::new(x1, y1),
    }
}

fn inside(hits: &[Impact], r: &GroundRect) -> usize {
    hits.iter()
        .filter(|h| r.contains(h.position_m.truncate()))
        .count()
}

#[test]
fn impacts_per_square_metre_and_second_are_the_marshall_palmer_flux_inside_and_beyond_the_drawn_drops()
 {
    let rate = 25.0;
    let s = setup(rate);
    let g = ground_rain(&s);
    let want = flux_moment(&s, rate, 0);
    assert!((want / 6830.0 - 1.0).abs() < 0.01, "{want}");
    let (t0, t1) = (3.0, 5.0);
    // Beyond the drawn drops (they reach 6 m): the stream alone.
    let far = rect(-1.0, 12.0, 1.0, 14.0);
    let hits = g.impacts_between(&far, t0, t1);
    let beyond = inside(&hits, &far) as f64 / (far.area_m2() * (t1 - t0));
    // On the drawn columns' cells: the drawn drops (and what the budget thinned, if any).
    let grid = &s.volume.grid;
    let cells = landing_columns(&s.volume).count() as f64;
    assert!(cells > 50.0, "{cells}");
    let area_m2 = cells * grid.cell_size_m.x * grid.cell_size_m.y;
    let near = rect(-20.0, -1.0, 20.0, 8.0);
    let hits = g.impacts_between(&near, t0, t1);
    let drawn = hits
        .iter()
        .filter(|h| g.drawn_at(h.position_m.truncate()))
        .count() as f64
        / (area_m2 * (t1 - t0));
    eprintln!("flux {want:.0} /m²s: beyond the drawn drops {beyond:.0}, on them {drawn:.0}");
    assert!((beyond / want - 1.0).abs() < 0.03, "{beyond} vs {want}");
    assert!((drawn / want - 1.0).abs() < 0.05, "{drawn} vs {want}");
}

#[test]
fn strips_across_the_seam_between_drawn_drops_and_stream_count_the_same_rain() {
    // Strips 0.5 m deep across the ground ahead, from inside the drawn drops' footprint to
    // beyond it: each holds flux × area × time impacts, within 4 σ of the Poisson count.
    let rate = 25.0;
    let s = setup(rate);
    let g = ground_rain(&s);
    let want = flux_moment(&s, rate, 0);
    let (t0, t1) = (1.0, 2.0);
    let all = g.impacts_between(&rect(-0.5, 2.0, 0.5, 9.0), t0, t1);
    let (mut drawn_strips, mut stream_strips) = (0, 0);
    for i in 0..14 {
        let y = 2.0 + 0.5 * i as f64;
        let strip = rect(-0.5, y, 0.5, y + 0.5);
        let hits: Vec<&Impact> = all
            .iter()
            .filter(|h| strip.contains(h.position_m.truncate()))
            .collect();
        let drawn = hits
            .iter()
            .filter(|h| g.drawn_at(h.position_m.truncate()))
            .count();
        drawn_strips += (drawn * 2 > hits.len()) as usize;
        stream_strips += (drawn * 2 < hits.len()) as usize;
        let expected = want * strip.area_m2() * (t1 - t0);
        let z = (hits.len() as f64 - expected) / expected.sqrt();
        eprintln!(
            "y {y:.1}–{:.1} m: {} impacts ({drawn} drawn), {expected:.0} expected, z = {z:+.1}",
            y + 0.5,
            hits.len()
        );
        assert!(
            z.abs() < 4.0,
            "strip at {y} m: {} vs {expected:.0}",
            hits.len()
        );
    }
    assert!(
        drawn_strips >= 2 && stream_strips >= 2,
        "{drawn_strips} / {stream_strips}"
    );
}

#[test]
fn impact_sizes_follow_the_flux_weighted_distribution() {
    // Drops land in proportion to N(D) v(D): the mean diameter of impacts is ∫D N v / ∫N v,
    // larger than the mean diameter of drops in the air ∫D N / ∫N.
    let rate = 10.0;
    let s = setup(rate);
    let g = ground_rain(&s);
    let far = rect(-2.0, 12.0, 2.0, 16.0);
    // The stream's impacts in the patch (the drawn drops' elsewhere simulate only the sizes
    // that show there; the stream brings the rest).
    let hits: Vec<_> = g
        .impacts_between(&far, 0.0, 2.0)
        .into_iter()
        .filter(|h| far.contains(h.position_m.truncate()))
        .collect();
    let n = hits.len() as f64;
    let mean = hits.iter().map(|h| h.diameter_mm).sum::<f64>() / n;
    let var = hits
        .iter()
        .map(|h| (h.diameter_mm - mean).powi(2))
        .sum::<f64>()
        / n;
    let want = flux_moment(&s, rate, 1) / flux_moment(&s, rate, 0);
    let in_air = s.model.dsd.moment(1.0) / s.model.dsd.moment(0.0);
    eprintln!("{n} impacts: mean diameter {mean:.4} mm, want {want:.4} (in the air {in_air:.4})");
    assert!(
        (mean - want).abs() < 4.0 * (var / n).sqrt() + 1e-3,
        "{mean} vs {want}"
    );
    assert!(want > in_air * 1.2);
}

#[test]
fn no_rain_lands_at_rate_zero_and_a_keyed_rate_thins_the_stream() {
    let s = setup(0.0);
    let g = ground_rain(&s);
    assert!(
        g.impacts_between(&rect(-5.0, 0.0, 5.0, 20.0), 0.0, 2.0)
            .is_empty()
    );
    // 20 mm/h, 10 mm/h from 1.1 s to 3 s, none from 3.1 s on: the peak's stream thinned to
    // the Marshall–Palmer flux of 10 mm/h, then to nothing.
    let s = setup(20.0);
    let keys = Curve::new(vec![(1.0, 20.0), (1.1, 10.0), (3.0, 10.0), (3.1, 0.0)]).expect("keys");
    let model = s.model.clone().with_rate_keys(&keys);
    let g = GroundRain::new(Rainfall::new(&s.volume, &model, &s.wind, s.params.seed));
    let far = rect(-1.0, 12.0, 1.0, 14.0);
    let ten = inside(&g.impacts_between(&far, 1.5, 2.5), &far) as f64;
    let want = flux_moment(&setup(10.0), 10.0, 0) * far.area_m2();
    eprintln!("keyed to 10 mm/h: {ten} impacts, {want:.0} expected");
    assert!((ten - want).abs() < 4.0 * want.sqrt(), "{ten} vs {want}");
    let after = inside(&g.impacts_between(&far, 3.1, 4.0), &far);
    assert_eq!(after, 0);
}

#[test]
fn the_same_impacts_whatever_the_intervals_asked() {
    let s = setup(15.0);
    let g = ground_rain(&s);
    let r = rect(-1.0, 1.0, 1.0, 10.0);
    let whole = g.impacts_between(&r, 0.0, 0.4);
    let mut parts: Vec<Impact> = (0..10)
        .flat_map(|i| g.impacts_between(&r, 0.04 * i as f64, 0.04 * (i + 1) as f64))
        .collect();
    let key = |h: &Impact| (h.id, h.pass, h.time_s.to_bits());
    let mut whole = whole;
    whole.sort_by_key(key);
    parts.sort_by_key(key);
    assert_eq!(whole.len(), parts.len());
    assert!(whole.iter().zip(&parts).all(|(a, b)| a == b));
}

/// The stream's landings (where and when, the size looked up only when asked) are the
/// stream's impacts, in the same order with the same values: with a keyed rate (sizes thinned
/// by rate) and drawn drops landing on part of the ground (sizes left to them there).
#[test]
fn the_streams_landings_are_its_impacts() {
    let s = setup(20.0);
    let keys = Curve::new(vec![(0.0, 20.0), (0.5, 8.0)]).expect("keys");
    let model = s.model.clone().with_rate_keys(&keys);
    for g in [
        ground_rain(&s),
        GroundRain::new(Rainfall::new(&s.volume, &model, &s.wind, s.params.seed)),
    ] {
        let r = rect(-3.0, 0.0, 3.0, 12.0);
        let mut impacts = Vec::new();
        g.stream_between(&r, 0.3, 0.7, &mut impacts);
        let mut landings = Vec::new();
        g.stream_landings(&r, 0.3, 0.7, |l| landings.push(l));
        assert!(impacts.len() > 10_000, "{}", impacts.len());
        assert!(
            impacts.iter().any(|h| g.drawn_at(h.position_m.truncate())),
            "some land among the drawn drops"
        );
        assert_eq!(impacts.len(), landings.len());
        for (h, l) in impacts.iter().zip(&landings) {
            assert_eq!(
                (h.id, h.pass, h.time_s, h.position_m.truncate()),
                (l.id, l.pass, l.time_s, l.position_m)
            );
            assert_eq!(h.diameter_mm, g.landing_diameter_mm(l));
            assert_eq!(
                -h.velocity_mps.z,
                terminal_velocity_gk_mps(h.diameter_mm) * {
                    s.model.fall.terminal_velocity_mps(1.0) / terminal_velocity_gk_mps(1.0)
                }
            );
        }
        // Frame by frame at 25 fps, the slots kept from frame to frame (2–3 frames share
        // one): each frame's landings are the plain stream's, in its order.
        let mut kept = StreamSlots::default();
        for frame in 0..12 {
            let (t0, t1) = (0.3 + 0.04 * frame as f64, 0.3 + 0.04 * (frame + 1) as f64);
            let (mut plain, mut made) = (Vec::new(), Vec::new());
            g.stream_landings(&r, t0, t1, |l| plain.push(l));
            g.stream_landings_kept(&mut kept, &r, t0, t1, |l| made.push(l));
            assert!(!plain.is_empty());
            assert_eq!(plain, made, "frame {frame}");
        }
        // Another rectangle: its own slots.
        let other = rect(-1.0, 2.0, 2.0, 5.0);
        let (mut plain, mut made) = (Vec::new(), Vec::new());
        g.stream_landings(&other, 0.75, 0.79, |l| plain.push(l));
        g.stream_landings_kept(&mut kept, &other, 0.75, 0.79, |l| made.push(l));
        assert_eq!(plain, made);
        // Windows over more slots than a frame's (a long step), on slots' edges, and back in
        // time: each slot's landings picked and merged cell by cell as the plain stream's.
        for (t0, t1) in [(0.05, 0.83), (0.2, 0.4), (0.0, 0.1), (0.35, 0.36)] {
            let (mut plain, mut made) = (Vec::new(), Vec::new());
            g.stream_landings(&other, t0, t1, |l| plain.push(l));
            g.stream_landings_kept(&mut kept, &other, t0, t1, |l| made.push(l));
            assert!(!plain.is_empty());
            assert_eq!(plain, made, "({t0}, {t1}]");
        }
    }
}

/// The impacts a filter keeps, asked for with the filter, are the impacts asked for without
/// it and then filtered: the same ones in the same order, the drawn drops' and the stream's
/// (a filter that keeps each in turn of both sorts, by id).
#[test]
fn impacts_kept_by_a_filter_are_the_filtered_impacts() {
    let s = setup(20.0);
    let g = ground_rain(&s);
    let r = rect(-3.0, 0.0, 3.0, 12.0);
    for modulus in [1u64, 3, 1000] {
        let keep = |h: &Impact| (h.id ^ h.pass as u64).is_multiple_of(modulus);
        let plain: Vec<Impact> = g
            .impacts_between(&r, 0.2, 0.5)
            .into_iter()
            .filter(keep)
            .collect();
        let kept = g.impacts_between_kept(&r, 0.2, 0.5, keep);
        assert!(plain.len() > 20, "{modulus}: {}", plain.len());
        assert!(
            plain.iter().any(|h| g.drawn_at(h.position_m.truncate())),
            "{modulus}: some land among the drawn drops"
        );
        assert_eq!(plain, kept, "{modulus}");
    }
}
