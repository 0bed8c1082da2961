//! The direct light term of compact sources against the brute-force integral over the drop
//! (`prt::brute_force_colour`, no table, no SH) of an environment that is a small bright disc,
//! and the geometry a photographer can check: the primary bow 42° from the antisolar point,
//! red outside, and irradiance falling with the square of the distance to a near lamp.

use glam::DVec3;
use rain_composite::lighting::prt::{brute_force_colour, channel_optics};
use rain_composite::lighting::rtf::{ChannelIndices, DropOptics, Polarisation, caustic_angle_rad};
use rain_composite::lighting::{LightSource, RtfTable, direct_colour};

const RHO: [f64; 3] = [1.331, 1.333, 1.337];

fn optics() -> [DropOptics; 3] {
    channel_optics(ChannelIndices(RHO), 9, Polarisation::default()).expect("optics")
}

fn tables(o: &[DropOptics; 3], bins: usize) -> [RtfTable; 3] {
    o.map(|o| o.tabulate(bins).expect("table"))
}

/// A unit vector making angle `theta` with `v`.
fn at_angle(v: DVec3, theta: f64) -> DVec3 {
    let helper = if v.z.abs() < 0.9 { DVec3::Z } else { DVec3::X };
    let e = helper.cross(v).normalize();
    v * theta.cos() + e * theta.sin()
}

/// Solid angle of a disc of angular radius `r`: 2π (1 − cos r).
fn cap_sr(r: f64) -> f64 {
    2.0 * std::f64::consts::PI * (1.0 - r.cos())
}

/// Brute-force drop radiance in a black sky holding one uniform disc of radiance `l` and
/// angular radius `r` around `centre`.
fn disc_reference(
    o: &[DropOptics; 3],
    centre: DVec3,
    r: f64,
    l: [f64; 3],
    view: DVec3,
) -> [f64; 3] {
    let cos_r = r.cos();
    brute_force_colour(
        |d| if d.dot(centre) >= cos_r { l } else { [0.0; 3] },
        o,
        view,
        4_000_000,
    )
    .expect("brute force")
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

#[test]
fn a_small_disc_matches_the_brute_force_integral() {
    let o = optics();
    let t = tables(&o, 1024);
    let view = DVec3::new(0.2, 1.0, -0.1).normalize();
    let r = 0.75f64.to_radians();
    let l = [1000.0, 800.0, 600.0];
    // Away from the caustics F varies little across the disc; the bin is 0.18° wide.
    for theta_deg in [10.0, 60.0, 120.0, 160.0] {
        let centre = at_angle(view, f64::to_radians(theta_deg));
        let light = LightSource {
            direction_world: centre,
            solid_angle_sr: cap_sr(r),
            radiance_rgb: l,
            distance_m: None,
        };
        let got = direct_colour(&[light], &t, None, view);
        let want = disc_reference(&o, centre, r, l, view);
        eprintln!("θ = {theta_deg}°: table {got:?}, brute force {want:?}");
        for c in 0..3 {
            assert!(
                rel(got[c], want[c]) < 0.03,
                "θ = {theta_deg}°, channel {c}: {} vs brute force {}",
                got[c],
                want[c]
            );
        }
    }
}

#[test]
fn a_light_ten_degrees_off_outshines_one_sixty_degrees_off_by_the_drop_s_ratio() {
    let o = optics();
    let t = tables(&o, 1024);
    let view = DVec3::Y;
    let r = 0.75f64.to_radians();
    let glow = |deg: f64| {
        let centre = at_angle(view, f64::to_radians(deg));
        let light = LightSource {
            direction_world: centre,
            solid_angle_sr: cap_sr(r),
            radiance_rgb: [1.0; 3],
            distance_m: None,
        };
        (
            direct_colour(&[light], &t, None, view)[1],
            disc_reference(&o, centre, r, [1.0; 3], view)[1],
        )
    };
    let (near, near_ref) = glow(10.0);
    let (far, far_ref) = glow(60.0);
    // Forward scattering dominates: the near light is much brighter, by the brute-force ratio.
    eprintln!(
        "10° / 60°: table {}, brute force {}",
        near / far,
        near_ref / far_ref
    );
    assert!(near_ref / far_ref > 10.0, "{near_ref} / {far_ref}");
    assert!(
        rel(near / far, near_ref / far_ref) < 0.05,
        "{} vs {}",
        near / far,
        near_ref / far_ref
    );
}

#[test]
fn the_sun_behind_the_camera_paints_the_bow_at_42_degrees_red_outside() {
    let t = tables(&optics(), 1024);
    // Sun low behind the camera: drops are seen at angle α from the antisolar point, and
    // scatter the sunlight through θ = 180° − α (see `lighting::sources`).
    let sun_dir = DVec3::new(0.0, -1.0, 0.3).normalize();
    let antisolar = -sun_dir;
    let sun = LightSource {
        direction_world: sun_dir,
        solid_angle_sr: 6.8e-5,
        radiance_rgb: [1e4; 3],
        distance_m: None,
    };
    let mut peak = [(0.0, 0.0); 3];
    let mut at_30 = [0.0; 3];
    for i in 0..=400 {
        let alpha_deg = 30.0 + 20.0 * i as f64 / 400.0;
        let view = at_angle(antisolar, alpha_deg.to_radians());
        let c = direct_colour(&[sun], &t, None, view);
        for k in 0..3 {
            if i == 0 {
                at_30[k] = c[k];
            }
            if c[k] > peak[k].1 {
                peak[k] = (alpha_deg, c[k]);
            }
        }
    }
    eprintln!("bow peaks (α°, radiance) R, G, B: {peak:?}; at 30°: {at_30:?}");
    for k in 0..3 {
        // Descartes' minimum deviation for this channel's index, independent of the table.
        let want = 180.0 - caustic_angle_rad(RHO[k], 3).expect("bow").to_degrees();
        assert!(
            (peak[k].0 - want).abs() < 0.4,
            "channel {k}: bow at {}° vs {want}°",
            peak[k].0
        );
        assert!(
            peak[k].1 > 3.0 * at_30[k],
            "channel {k}: the bow stands out"
        );
    }
    assert!(
        (41.0..43.5).contains(&peak[1].0),
        "green bow at {}°",
        peak[1].0
    );
    assert!(peak[0].0 > peak[2].0, "red outside blue: {:?}", peak);
}

#[test]
fn a_near_lamp_is_seen_from_the_drop_and_falls_off_with_distance_squared() {
    let o = optics();
    let t = tables(&o, 1024);
    // A lamp 4 m from the camera, 20° right of the view; a luminaire 0.2 m across.
    let d: f64 = 4.0;
    let dir = DVec3::new(20f64.to_radians().sin(), 20f64.to_radians().cos(), 0.0);
    let radius_m: f64 = 0.1;
    let r_cam = (radius_m / d).asin();
    let lamp = LightSource {
        direction_world: dir,
        solid_angle_sr: cap_sr(r_cam),
        radiance_rgb: [5000.0, 4000.0, 3000.0],
        distance_m: Some(d),
    };
    for drop in [
        DVec3::new(0.0, 2.0, 0.1),
        DVec3::new(0.5, 6.0, -0.3),
        DVec3::new(-1.0, 9.0, 0.5),
    ] {
        let view = drop.normalize();
        let got = direct_colour(&[lamp], &t, Some(drop), view);
        // Independent geometry: the luminaire as a sphere of radius 0.1 m at the lamp's place.
        let to = dir * d - drop;
        let want = disc_reference(
            &o,
            to.normalize(),
            (radius_m / to.length()).asin(),
            lamp.radiance_rgb,
            view,
        );
        for c in 0..3 {
            assert!(
                rel(got[c], want[c]) < 0.04,
                "drop {drop}: channel {c}: {} vs {}",
                got[c],
                want[c]
            );
        }
    }
    // With no drop position the lamp is seen as from the camera.
    let view = DVec3::Y;
    let a = direct_colour(&[lamp], &t, None, view);
    let b = direct_colour(
        &[LightSource {
            distance_m: None,
            ..lamp
        }],
        &t,
        None,
        view,
    );
    assert_eq!(a, b);
}
