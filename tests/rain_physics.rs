//! Rain physics against independent references: published data (Gunn & Kinzer 1949) and
//! analytic results (the Marshall–Palmer integrals, pinhole and thin-lens geometry, the
//! first-order ODE), never against numbers printed by the code under test.

use glam::{DVec2, DVec3};
use rain_composite::rain::physics::{
    DropSizeDistribution, DsdShape, FallSpeed, RainModel, RainRate, ThinLens, image_velocity_pxps,
    projected_streak_px, streak_length_px,
};
use rain_composite::rain::volume::Rainfall;
use rain_composite::rain::volume::{
    ColumnGrid, RainVolume, VolumeParams, drop_uniform, inspect_drops, sample_drop,
};
use rain_composite::rain::wind::{Wind, step_response_velocity_mps};
use rain_composite::scene::Camera;

fn rate(r: f64) -> RainRate {
    RainRate::from_mm_per_h(r).expect("valid rate")
}

fn camera_1080(fov_deg: f64, tilt_rad: f64) -> Camera {
    Camera::new(1920, 1080, fov_deg.to_radians(), 1.6, tilt_rad, 0.0)
}

/// Upper critical value of χ² with `k` degrees of freedom at significance 0.001
/// (Wilson–Hilferty approximation, z = 3.0902).
fn chi2_critical_0001(k: f64) -> f64 {
    let z = 3.0902;
    k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3)
}

/// χ² of sampled counts against expected counts per bin, merging bins with < 5 expected.
fn chi_square(edges: &[f64], samples: &[f64], prob: impl Fn(f64, f64) -> f64) -> (f64, f64) {
    let n = samples.len() as f64;
    let mut bins: Vec<(f64, f64)> = Vec::new(); // (observed, expected)
    let (mut obs, mut exp) = (0.0, 0.0);
    for w in edges.windows(2) {
        obs += samples.iter().filter(|&&d| d >= w[0] && d < w[1]).count() as f64;
        exp += n * prob(w[0], w[1]);
        if exp >= 5.0 {
            bins.push((obs, exp));
            obs = 0.0;
            exp = 0.0;
        }
    }
    if let Some(last) = bins.last_mut() {
        last.0 += obs;
        last.1 += exp;
    }
    let chi2 = bins.iter().map(|(o, e)| (o - e).powi(2) / e).sum();
    (chi2, bins.len() as f64 - 1.0)
}

#[test]
fn sampled_diameters_follow_marshall_palmer() {
    // Significance 0.001, seed fixed: the test is deterministic.
    for r in [1.0, 10.0, 50.0] {
        let dsd = DropSizeDistribution::marshall_palmer(rate(r));
        let samples: Vec<f64> = (0..40_000)
            .map(|i| dsd.diameter_from_uniform_mm(drop_uniform(42, i, 3)))
            .collect();
        // Reference: N(D) = 8000 e^{−ΛD}, Λ = 4.1 R^−0.21, truncated to [0.1, 6] mm.
        let l = 4.1 * r.powf(-0.21);
        let mass = |a: f64, b: f64| ((-l * a).exp() - (-l * b).exp()) / l;
        let total = mass(0.1, 6.0);
        let edges: Vec<f64> = (0..=59).map(|i| 0.1 + 0.1 * i as f64).collect();
        let (chi2, dof) = chi_square(&edges, &samples, |a, b| mass(a, b) / total);
        assert!(
            chi2 < chi2_critical_0001(dof),
            "R={r}: χ²={chi2:.1} dof={dof}"
        );
        assert!(samples.iter().all(|&d| (0.1..=6.0).contains(&d)));
    }
}

#[test]
fn sampled_diameters_follow_the_gamma_distribution() {
    let mu = 2.0;
    let dsd = DropSizeDistribution::new(rate(10.0), DsdShape::Gamma { mu }).expect("gamma");
    let l = dsd.lambda_per_mm();
    let samples: Vec<f64> = (0..40_000)
        .map(|i| dsd.diameter_from_uniform_mm(drop_uniform(9, i, 3)))
        .collect();
    // Reference: ∫ D^μ e^{−ΛD} dD by a fine midpoint rule, independent of the sampler's table.
    let integral = |a: f64, b: f64| {
        let n = 2000;
        let h = (b - a) / n as f64;
        (0..n)
            .map(|i| {
                let d = a + (i as f64 + 0.5) * h;
                d.powf(mu) * (-l * d).exp() * h
            })
            .sum::<f64>()
    };
    let total = integral(0.1, 6.0);
    let edges: Vec<f64> = (0..=59).map(|i| 0.1 + 0.1 * i as f64).collect();
    let (chi2, dof) = chi_square(&edges, &samples, |a, b| integral(a, b) / total);
    assert!(chi2 < chi2_critical_0001(dof), "χ²={chi2:.1} dof={dof}");
    // Ulbrich normalisation: same median volume diameter as Marshall–Palmer, D0 = 3.67/Λ_MP.
    assert!((l - (3.67 + mu) / (3.67 / (4.1 * 10f64.powf(-0.21)))).abs() < 1e-12);
}

/// Gunn & Kinzer (1949), Table 2: diameter mm, terminal velocity m/s (typed from the paper's
/// table, 20 °C, 1013 hPa).
const GK: [(f64, f64); 34] = [
    (0.1, 0.27),
    (0.2, 0.72),
    (0.3, 1.17),
    (0.4, 1.62),
    (0.5, 2.06),
    (0.6, 2.47),
    (0.7, 2.87),
    (0.8, 3.27),
    (0.9, 3.67),
    (1.0, 4.03),
    (1.2, 4.64),
    (1.4, 5.17),
    (1.6, 5.65),
    (1.8, 6.09),
    (2.0, 6.49),
    (2.2, 6.90),
    (2.4, 7.27),
    (2.6, 7.57),
    (2.8, 7.82),
    (3.0, 8.06),
    (3.2, 8.26),
    (3.4, 8.44),
    (3.6, 8.60),
    (3.8, 8.72),
    (4.0, 8.83),
    (4.2, 8.92),
    (4.4, 8.98),
    (4.6, 9.03),
    (4.8, 9.07),
    (5.0, 9.09),
    (5.2, 9.12),
    (5.4, 9.14),
    (5.6, 9.16),
    (5.8, 9.17),
];

#[test]
fn mean_fall_speed_per_diameter_bin_matches_gunn_kinzer() {
    // Violent rain has many large drops; sea-level air (the standard atmosphere is 1.7 %
    // denser than Gunn & Kinzer's lab, −0.7 % in speed).
    let model = RainModel::marshall_palmer(rate(300.0));
    let n = 400_000u32;
    let drops: Vec<(f64, f64)> = (0..n)
        .map(|i| {
            let d = model.dsd.diameter_from_uniform_mm(drop_uniform(5, i, 3));
            (d, model.fall.terminal_velocity_mps(d))
        })
        .collect();
    let mut tested = 0;
    // Skip 0.1 mm: its bin would be one-sided at the truncation edge.
    for &(dk, vk) in &GK[1..] {
        let bin: Vec<f64> = drops
            .iter()
            .filter(|(d, _)| (d - dk).abs() <= 0.02)
            .map(|&(_, v)| v)
            .collect();
        if bin.len() < 20 {
            continue;
        }
        let mean = bin.iter().sum::<f64>() / bin.len() as f64;
        assert!((mean / vk - 1.0).abs() < 0.03, "D={dk}: {mean:.3} vs {vk}");
        tested += 1;
    }
    assert!(tested >= 30, "only {tested} bins had drops");
}

#[test]
fn no_drop_exceeds_terminal_velocity_in_still_air() {
    let cam = camera_1080(60.0, 0.0);
    let model = RainModel::marshall_palmer(rate(25.0));
    let wind = Wind::still();
    let vol = RainVolume::plan(&cam, &model, &wind, &VolumeParams::default()).expect("plan");
    let step = (vol.simulated / 20_000).max(1);
    let mut worst = 0.0f64;
    for id in (0..vol.simulated).step_by(step as usize) {
        for t in [0.0, 1.7, 60.0] {
            let d = sample_drop(Rainfall::new(&vol, &model, &wind, 3), id, t).expect("drop");
            // The emitter's fall speed is its table of Gunn & Kinzer's curve by size quantile
            // (16 steps per octave of 1 − u, 1/1024 m/s steps), within 0.01 m/s of the curve.
            let vt = -d.velocity_mps.z;
            let curve = model.fall.terminal_velocity_mps(d.diameter_mm);
            worst = worst.max((vt - curve).abs());
            assert!(
                (vt - curve).abs() < 0.01,
                "{vt} vs {curve} m/s at {} mm",
                d.diameter_mm
            );
            assert!(d.velocity_mps.length() <= vt * (1.0 + 1e-12));
            assert!(d.velocity_mps.z < 0.0);
        }
    }
    eprintln!("largest fall-speed table error: {worst:.4} m/s");
}

/// Whether a world point lies in the frustum slab [near, far] above the ground.
fn in_slab(cam: &Camera, p: DVec3, near: f64, far: f64, ground: Option<f64>) -> bool {
    let q = cam.camera_from_world_point(p);
    let a = 0.5 * cam.width_px as f64 / cam.focal_px();
    let b = 0.5 * cam.height_px as f64 / cam.focal_px();
    q.z >= near
        && q.z <= far
        && q.x.abs() <= a * q.z
        && q.y.abs() <= b * q.z
        && ground.is_none_or(|g| p.z >= g)
}

/// Number density of simulated drops (times their weight) inside the view slab, per m³.
fn measured_density(cam: &Camera, model: &RainModel, wind: &Wind, params: &VolumeParams) -> f64 {
    let vol = RainVolume::plan(cam, model, wind, params).expect("plan");
    let inside = (0..vol.simulated)
        .filter(|&id| {
            let d = sample_drop(Rainfall::new(&vol, model, wind, 11), id, 3.7).expect("drop");
            in_slab(cam, d.position_m, vol.near_m, vol.far_m, params.ground_z_m)
        })
        .count();
    inside as f64 * vol.weight / vol.view_volume_m3
}

#[test]
fn simulated_number_density_matches_marshall_palmer() {
    // Reference: N_T = N0/Λ (e^{−Λ·0.1} − e^{−Λ·6}), the MP integral over the truncation.
    let r: f64 = 10.0;
    let l = 4.1 * r.powf(-0.21);
    let reference = 8000.0 / l * ((-0.1 * l).exp() - (-6.0 * l).exp());
    let cam = Camera::new(1280, 720, 60f64.to_radians(), 1.6, -0.1, 0.0);
    let model = RainModel::marshall_palmer(rate(r));
    let wind = Wind::new(DVec2::new(4.0, 1.0), 2.0, 3).expect("wind");
    // Free run, then with the budget binding (weights > 1); every size simulated (the size
    // cut's own rain is held to this one in tests/visible_sizes.rs).
    for budget in [1 << 22, 20_000] {
        let params = VolumeParams {
            budget,
            visible_sizes: false,
            ..VolumeParams::default()
        };
        let rho = measured_density(&cam, &model, &wind, &params);
        assert!(
            (rho / reference - 1.0).abs() < 0.05,
            "budget {budget}: {rho} vs {reference}"
        );
    }
    let bound = RainVolume::plan(
        &cam,
        &model,
        &wind,
        &VolumeParams {
            budget: 20_000,
            ..VolumeParams::default()
        },
    )
    .expect("plan");
    assert!(bound.budget_binds && bound.simulated == 20_000);
}

#[test]
fn halving_far_scales_the_count_with_the_frustum_volume() {
    let cam = camera_1080(60.0, 0.0);
    let model = RainModel::marshall_palmer(rate(5.0));
    let near: f64 = 0.3;
    let plan = |far: f64| {
        let params = VolumeParams {
            far_max_m: far,
            alpha_min: 1e-6, // visible to the cap
            ground_z_m: None,
            budget: 1 << 30,
            visible_sizes: false,
            ..VolumeParams::default()
        };
        RainVolume::plan(&cam, &model, &Wind::still(), &params).expect("plan")
    };
    let (full, half) = (plan(20.0), plan(10.0));
    assert_eq!((full.far_m, half.far_m), (20.0, 10.0));
    // Frustum slab volume (4/3) tan(fx/2) tan(fy/2) (far³ − near³).
    let a = (30f64).to_radians().tan();
    let b = a * 1080.0 / 1920.0;
    let frustum = |far: f64| 4.0 / 3.0 * a * b * (far.powi(3) - near.powi(3));
    let density = model.dsd.number_density_per_m3();
    assert!((full.expected_in_view / (density * frustum(20.0)) - 1.0).abs() < 1e-9);
    let ratio = half.expected_in_view / full.expected_in_view;
    assert!((ratio / (frustum(10.0) / frustum(20.0)) - 1.0).abs() < 1e-9);
    // The simulated count follows (columns overhang the slab a little).
    let sim_ratio = half.simulated as f64 / full.simulated as f64;
    assert!(
        (sim_ratio / ratio - 1.0).abs() < 0.05,
        "{sim_ratio} vs {ratio}"
    );
    // Band volumes add up to the slab.
    let bands: f64 = full.bands.iter().map(|b| b.volume_m3).sum();
    assert!((bands / frustum(20.0) - 1.0).abs() < 1e-9);
}

#[test]
fn streak_length_matches_projected_end_points() {
    let exposure = 1.0 / 50.0;
    for tilt in [0.0, -0.4, 0.7] {
        let cam = camera_1080(60.0, tilt);
        let axis = cam.world_from_camera * DVec3::Z;
        // A velocity perpendicular to the optical axis.
        let v = axis.cross(DVec3::X).normalize() * 6.5;
        for (i, &(x, y, depth)) in [(0.0, 0.0, 1.0), (0.3, -0.2, 2.5), (-0.5, 0.25, 8.0)]
            .iter()
            .enumerate()
        {
            let p =
                cam.position_m + cam.world_from_camera * DVec3::new(x * depth, y * depth, depth);
            let a = cam.project_world(p).expect("in front");
            let b = cam.project_world(p + v * exposure).expect("in front");
            let want = streak_length_px(6.5, exposure, cam.focal_px(), depth);
            assert!(((b - a).length() - want).abs() < 1.0, "case {i}");
            // The general form, for any velocity: exact end points, and the image velocity is
            // their derivative (finite difference over 10 µs).
            let v_any = DVec3::new(1.5, -2.0, -7.0);
            let ends = projected_streak_px(&cam, p, v_any, 1e-5).expect("in front");
            let fd = (ends[1] - ends[0]) / 1e-5;
            let lin = image_velocity_pxps(&cam, p, v_any).expect("in front");
            assert!(
                (fd - lin).length() < 1e-3 * lin.length(),
                "case {i} general"
            );
        }
    }
}

#[test]
fn defocus_equals_the_thin_lens_circle_of_confusion() {
    let cam = camera_1080(60.0, 0.0);
    for (n, focus) in [(2.8, 3.0), (1.4, 10.0), (8.0, 0.8)] {
        let lens = ThinLens::new(36.0, n, focus).expect("lens");
        // Lens equation: 1/f = 1/z + 1/z'. A point at z images at z'; the sensor sits at the
        // focus's image distance z'_f, so the blur disc is A |z' − z'_f| / z' with A = f/N.
        let f_mm = 18.0 / (30f64).to_radians().tan();
        let image = |z_m: f64| 1.0 / (1.0 / f_mm - 1.0 / (z_m * 1e3));
        for z in [0.5, 1.0, 2.0, 3.0, 7.0, 40.0] {
            let blur_mm = f_mm / n * (image(z) - image(focus)).abs() / image(z);
            let want_radius_px = 0.5 * blur_mm / 36.0 * 1920.0;
            let got = lens.defocus_radius_px(&cam, z);
            assert!(
                (got - want_radius_px).abs() < 1e-9 * (1.0 + want_radius_px),
                "N={n} z={z}"
            );
        }
    }
}

/// Mean streak angle from the picture's downward vertical, degrees, of the drops near the
/// optical axis (where perspective does not bend a streak), and the mean of
/// `atan(wind / (fall_speed_scale · v_t(D)))` over the same drops: what a steady wind predicts.
fn streak_angles_deg(
    cam: &Camera,
    model: &RainModel,
    wind_x_mps: f64,
    fall_speed_scale: f64,
) -> (f64, f64) {
    let wind = Wind::steady(DVec2::new(wind_x_mps, 0.0)).expect("wind");
    let params = VolumeParams {
        fall_speed_scale,
        ..VolumeParams::default()
    };
    let vol = RainVolume::plan(cam, model, &wind, &params).expect("plan");
    let (mut got, mut want, mut n) = (0.0, 0.0, 0);
    for id in 0..vol.simulated {
        let d = sample_drop(Rainfall::new(&vol, model, &wind, 8), id, 2.0).expect("drop");
        let q = cam.camera_from_world_point(d.position_m);
        if q.z < 1.0 || (q.x / q.z).abs() > 0.05 || (q.y / q.z).abs() > 0.05 {
            continue;
        }
        let ends = projected_streak_px(cam, d.position_m, d.velocity_mps, 0.02).expect("ok");
        let s = ends[1] - ends[0];
        got += s.x.atan2(s.y);
        let v = fall_speed_scale * model.fall.terminal_velocity_mps(d.diameter_mm);
        want += (wind_x_mps / v).atan();
        n += 1;
    }
    assert!(n > 50, "only {n} drops near the axis");
    (
        (got / n as f64).to_degrees(),
        (want / n as f64).to_degrees(),
    )
}

#[test]
fn mean_streak_angle_matches_wind_over_fall_speed() {
    let cam = camera_1080(60.0, 0.0);
    let model = RainModel::marshall_palmer(rate(10.0));
    for w in [3.0, 12.0] {
        let (got, want) = streak_angles_deg(&cam, &model, w, 1.0);
        assert!((got - want).abs() < 0.5, "w={w}: {got}° vs {want}°");
    }
}

/// Fourth-order Runge–Kutta for τ dv/dt = w(t) − v, also integrating x = ∫ v dt.
fn rk4(wind: &Wind, tau: f64, t0: f64, t1: f64, dt: f64, v0: DVec2) -> (DVec2, DVec2) {
    let f = |t: f64, v: DVec2| (wind.wind_velocity_mps(t) - v) / tau;
    let steps = ((t1 - t0) / dt).round() as usize;
    let h = (t1 - t0) / steps as f64;
    let (mut v, mut x, mut t) = (v0, DVec2::ZERO, t0);
    for _ in 0..steps {
        let k1 = f(t, v);
        let k2 = f(t + 0.5 * h, v + 0.5 * h * k1);
        let k3 = f(t + 0.5 * h, v + 0.5 * h * k2);
        let k4 = f(t + h, v + h * k3);
        // x' = v: its RK4 stages are the v stages.
        x += h / 6.0 * (v + 2.0 * (v + 0.5 * h * k1) + 2.0 * (v + 0.5 * h * k2) + (v + h * k3));
        v += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        t += h;
    }
    (v, x)
}

#[test]
fn relaxed_velocity_converges_to_a_step_in_the_wind() {
    let w = DVec2::new(7.0, -2.0);
    let wind = Wind::steady(w).expect("wind");
    let tau = FallSpeed::sea_level().relaxation_time_s(2.0);
    // ODE from rest: v(t) = w (1 − e^{−t/τ}).
    for t in [0.1, 0.5, 2.0] {
        let (v, _) = rk4(&wind, tau, 0.0, t, 1e-4, DVec2::ZERO);
        let closed = step_response_velocity_mps(DVec2::ZERO, w, t, tau);
        assert!((v - closed).length() < 1e-9, "t={t}");
    }
    let (v, _) = rk4(&wind, tau, 0.0, 10.0 * tau, 1e-4, DVec2::ZERO);
    assert!((v - w).length() < 1e-3 * w.length());
    assert_eq!(wind.drop_velocity_mps(5.0, tau), w);
}

#[test]
fn closed_form_gust_response_matches_the_ode() {
    let wind = Wind::new(DVec2::new(5.0, 2.0), 3.0, 2024).expect("wind");
    let fall = FallSpeed::sea_level();
    for d_mm in [0.5, 2.0, 5.0] {
        let tau = fall.relaxation_time_s(d_mm);
        // Start 40 s early from the air's velocity: transients decay as e^{−40/τ}.
        let (v0, _) = rk4(&wind, tau, -40.0, 0.0, 1e-3, wind.wind_velocity_mps(-40.0));
        assert!(
            (v0 - wind.drop_velocity_mps(0.0, tau)).length() < 1e-8,
            "D={d_mm}"
        );
        for t in [2.5, 10.0] {
            let (v, x) = rk4(&wind, tau, 0.0, t, 1e-3, v0);
            assert!(
                (v - wind.drop_velocity_mps(t, tau)).length() < 1e-8,
                "D={d_mm} t={t}"
            );
            assert!(
                (x - wind.drop_displacement_m(t, tau)).length() < 1e-8,
                "D={d_mm} t={t}"
            );
        }
    }
}

#[test]
fn columns_cover_the_view_slab() {
    for (wind, tilt) in [
        (DVec2::ZERO, 0.0),
        (DVec2::new(40.0, 0.0), 0.0),
        (DVec2::new(-20.0, 30.0), -0.6),
    ] {
        let cam = camera_1080(60.0, tilt);
        let slope = -wind / 6.0;
        let grid = ColumnGrid::build(&cam, 0.3, 12.0, Some(0.0), slope, 1024);
        let a = 0.5 * cam.width_px as f64 / cam.focal_px();
        let b = 0.5 * cam.height_px as f64 / cam.focal_px();
        let mut tested = 0;
        for i in 0..5000u32 {
            let (x, y, z) = (
                drop_uniform(2, i, 0),
                drop_uniform(2, i, 1),
                drop_uniform(2, i, 2),
            );
            let depth = 0.3 + z * 11.7;
            let q = DVec3::new(
                (2.0 * x - 1.0) * a * depth,
                (2.0 * y - 1.0) * b * depth,
                depth,
            );
            let p = cam.position_m + cam.world_from_camera * q;
            if p.z < 0.0 {
                continue;
            }
            tested += 1;
            let uv = DVec2::new(p.x, p.y) - grid.slope * p.z;
            let covered = grid.columns.iter().any(|c| {
                let r = uv - c.cell_min_m;
                r.x >= -1e-9
                    && r.y >= -1e-9
                    && r.x <= grid.cell_size_m.x + 1e-9
                    && r.y <= grid.cell_size_m.y + 1e-9
                    && p.z >= c.z_lo_m - 1e-9
                    && p.z <= c.z_hi_m + 1e-9
            });
            assert!(covered, "wind {wind:?}: {p:?} not in any column");
        }
        assert!(tested > 1000);
    }
}

fn check_plan(label: &str, cam: &Camera, model: &RainModel, wind: &Wind, params: &VolumeParams) {
    let vol = RainVolume::plan(cam, model, wind, params).unwrap_or_else(|e| panic!("{label}: {e}"));
    let finite = [
        vol.near_m,
        vol.far_m,
        vol.far_visible_m,
        vol.view_volume_m3,
        vol.expected_in_view,
        vol.weight,
        vol.grid.volume_m3,
        vol.reference_speed_mps,
    ];
    assert!(
        finite.iter().all(|x| x.is_finite() && *x >= 0.0),
        "{label}: {finite:?}"
    );
    assert!(vol.far_m > vol.near_m, "{label}");
    assert!(vol.simulated <= params.budget, "{label}");
    // weight = expected/round(expected): ≥ 1 − 1/(2·simulated) from rounding alone.
    let floor = 1.0 - 0.5 / vol.simulated.max(1) as f64 - 1e-12;
    assert!(vol.weight >= floor, "{label}: weight {}", vol.weight);
    let mut next = 0u64;
    for (i, c) in vol.grid.columns.iter().enumerate() {
        assert!(
            c.height_m() > 0.0 && c.height_m().is_finite(),
            "{label}: column {i}"
        );
        assert!(c.count > 0 && c.first_id == next, "{label}: column {i}");
        assert!(vol.grid.column_volume_m3(i) > 0.0, "{label}: column {i}");
        next += c.count as u64;
    }
    assert_eq!(next, vol.simulated, "{label}");
    for b in &vol.bands {
        assert!(b.expected.is_finite() && b.simulated.is_finite(), "{label}");
    }
    for id in (0..vol.simulated).step_by((vol.simulated / 200).max(1) as usize) {
        let d = sample_drop(Rainfall::new(&vol, model, wind, 1), id, 12.3).expect("drop");
        assert!(
            d.position_m.is_finite() && d.velocity_mps.is_finite(),
            "{label}: drop {id}"
        );
        assert_eq!(vol.grid.column_of(id), Some(d.column));
    }
    assert!(!vol.summary().contains("NaN"), "{label}");
}

#[test]
fn hard_cases_stay_finite() {
    let pi = std::f64::consts::PI;
    for r in [0.0, 0.1, 300.0] {
        let model = RainModel::marshall_palmer(rate(r));
        for wind in [
            Wind::still(),
            Wind::new(DVec2::new(40.0, 0.0), 8.0, 1).expect("wind"),
        ] {
            for fov in [5.0, 60.0, 150.0] {
                for tilt in [-0.5 * pi, 0.0, 0.5 * pi] {
                    let cam = camera_1080(fov, tilt);
                    let params = VolumeParams {
                        max_columns: 512,
                        budget: 200_000,
                        ..VolumeParams::default()
                    };
                    let label = format!("R={r} wind={:?} fov={fov} tilt={tilt:.2}", wind.mean_mps);
                    check_plan(&label, &cam, &model, &wind, &params);
                }
            }
        }
        if r == 0.0 {
            let cam = camera_1080(60.0, 0.0);
            let vol = RainVolume::plan(&cam, &model, &Wind::still(), &VolumeParams::default())
                .expect("plan");
            assert_eq!(vol.simulated, 0);
            assert!(vol.grid.columns.is_empty());
        }
    }
    // A camera under the ground sees no rain, and says so without failing.
    let cam = Camera::new(1920, 1080, 1.0, -2.0, -0.3, 0.0);
    let model = RainModel::marshall_palmer(rate(10.0));
    check_plan(
        "underground",
        &cam,
        &model,
        &Wind::still(),
        &VolumeParams::default(),
    );
    // A lens focused close: distant drops blur away, the plan stays finite.
    let lens = ThinLens::new(36.0, 1.4, 0.5).expect("lens");
    let params = VolumeParams {
        lens: Some(lens),
        ..VolumeParams::default()
    };
    check_plan(
        "defocus",
        &camera_1080(60.0, 0.0),
        &model,
        &Wind::still(),
        &params,
    );
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let cam = camera_1080(60.0, 0.0);
    let model = RainModel::marshall_palmer(rate(10.0));
    let still = Wind::still();
    for params in [
        VolumeParams {
            exposure_s: 0.0,
            ..VolumeParams::default()
        },
        VolumeParams {
            near_m: f64::NAN,
            ..VolumeParams::default()
        },
        VolumeParams {
            far_max_m: 0.1,
            ..VolumeParams::default()
        },
        VolumeParams {
            budget: 0,
            ..VolumeParams::default()
        },
    ] {
        assert!(RainVolume::plan(&cam, &model, &still, &params).is_err());
    }
    let bad_cam = Camera::new(1920, 1080, 4.0, 1.6, 0.0, 0.0);
    assert!(RainVolume::plan(&bad_cam, &model, &still, &VolumeParams::default()).is_err());
    assert!(ThinLens::new(36.0, 0.0, 3.0).is_err());
    assert!(DropSizeDistribution::new(rate(1.0), DsdShape::Gamma { mu: 99.0 }).is_err());
    assert!(
        DropSizeDistribution::truncated(rate(1.0), DsdShape::MarshallPalmer, 2.0, 1.0).is_err()
    );
}

#[test]
fn inspect_reports_sampled_bands_close_to_the_plan() {
    let cam = Camera::new(1280, 720, 60f64.to_radians(), 1.6, 0.0, 0.0);
    let model = RainModel::marshall_palmer(rate(25.0));
    let wind = Wind::new(DVec2::new(3.0, 0.0), 1.0, 5).expect("wind");
    let v = inspect_drops(
        &cam,
        &model,
        &wind,
        &VolumeParams::default(),
        20_000,
        7,
        1.0,
    )
    .expect("inspect");
    let text = serde_json::to_string(&v).expect("json");
    assert!(
        !text.contains("null"),
        "a NaN or missing value in {}",
        &text[..400]
    );
    let bands = v["sample"]["bands"].as_array().expect("bands");
    assert!(!bands.is_empty());
    for b in bands {
        let (s, p) = (
            b["sampled_fraction"].as_f64().unwrap(),
            b["planned_fraction"].as_f64().unwrap(),
        );
        assert!((s - p).abs() < 0.02, "{b}");
    }
    assert_eq!(
        v["sample"]["drops"].as_array().map(|d| d.len()),
        Some(20_000)
    );
}

/// Numbers for docs/measurements.md: simulated drops against rain rate, default camera (fov 60°, 1.6 m,
/// level, 1/50 s), default budget and thresholds. `cargo test --test rain_physics -- --ignored
/// --nocapture readme`.
#[test]
#[ignore]
fn readme_drop_counts() {
    for (w, h) in [(1280, 720), (1920, 1080)] {
        let cam = Camera::new(w, h, 60f64.to_radians(), 1.6, 0.0, 0.0);
        for r in [0.5, 2.5, 10.0, 25.0, 50.0] {
            let model = RainModel::marshall_palmer(rate(r));
            for ground in [Some(0.0), None] {
                let params = VolumeParams {
                    ground_z_m: ground,
                    ..VolumeParams::default()
                };
                let vol = RainVolume::plan(&cam, &model, &Wind::still(), &params).expect("plan");
                println!(
                    "{w}x{h} R={r:>4} ground={ground:?}: Dref {:.2} mm far {:.2} m (vis {:.2}) expected {:.0} simulated {} weight {:.3} columns {}",
                    vol.reference_diameter_mm,
                    vol.far_m,
                    vol.far_visible_m,
                    vol.expected_in_view,
                    vol.simulated,
                    vol.weight,
                    vol.grid.columns.len()
                );
            }
        }
    }
}

/// Column overhang (simulated ÷ expected in view) and planning time against the number of
/// cells. `cargo test --test rain_physics -- --ignored --nocapture overhang`.
#[test]
#[ignore]
fn overhang_against_cell_count() {
    let cam = camera_1080(60.0, 0.0);
    let model = RainModel::marshall_palmer(rate(10.0));
    for wind in [
        Wind::still(),
        Wind::steady(DVec2::new(10.0, 0.0)).expect("wind"),
    ] {
        for max_columns in [16, 64, 256, 1024, 4096, 16384] {
            let params = VolumeParams {
                max_columns,
                ..VolumeParams::default()
            };
            let t0 = std::time::Instant::now();
            let vol = RainVolume::plan(&cam, &model, &wind, &params).expect("plan");
            println!(
                "wind {:>4} cells ≤ {max_columns:>5}: cell {:.2}×{:.2} m, overhang {:.3}, plan {:.1} ms",
                wind.mean_mps.x,
                vol.grid.cell_size_m.x,
                vol.grid.cell_size_m.y,
                vol.simulated as f64 / vol.expected_in_view,
                t0.elapsed().as_secs_f64() * 1e3
            );
        }
    }
}

/// The drop twin's split-time arithmetic (whole seconds in integers, the fraction in floats)
/// against the same closed form evaluated directly in `f64` — w = w₀ − rate·t, drift =
/// rate·t + mean wind·t + gusts — at short and very long times: the split loses nothing.
#[test]
fn the_drop_twin_equals_its_closed_form_at_any_time() {
    use rain_composite::rain::volume::cycle_uniform;
    use rain_composite::rain::volume::drop::{
        DRIFT_PHASE_BITS, FALL_RATE_BITS, SPEED_BITS, fall_rate_q, inv_height_q, size_bits,
    };
    let cam = camera_1080(60.0, 0.0);
    let model = RainModel::marshall_palmer(rate(12.0));
    let wind = Wind::new(DVec2::new(2.5, -1.5), 1.5, 4).expect("wind");
    let params = VolumeParams {
        budget: 20_000,
        fall_speed_scale: 1.3,
        diameter_scale: 1.2,
        ..VolumeParams::default()
    };
    let vol = RainVolume::plan(&cam, &model, &wind, &params).expect("plan");
    let grid = &vol.grid;
    let seed = 9;
    let (mut compared, mut edge) = (0, 0);
    for t in [10.25, 3_600.5, 36_000.25, 36_000.25 + 7.0 * 86_400.0] {
        for id in (0..vol.simulated).step_by(97) {
            let d = sample_drop(Rainfall::new(&vol, &model, &wind, seed), id, t).expect("drop");
            let col = &grid.columns[d.column];
            let id32 = id as u32;
            // The size quantile mapped onto the column's share of the sizes' top.
            let q = size_bits(seed, id32, col.size_keep_q);
            let share = col.size_keep_q as f64 / 16_777_216.0;
            assert!(q as f64 / 16_777_216.0 >= 1.0 - share - 1e-7);
            let d_want = model.dsd.diameter_from_uniform_mm(q as f64 / 16_777_216.0);
            assert!((d.diameter_mm - d_want).abs() < 1e-12);
            let speed_q = vol.motion.fall_speed_q(q);
            let vt = speed_q as f64 / (1u32 << SPEED_BITS) as f64;
            let rate = fall_rate_q(speed_q, inv_height_q(col.height_m())) as f64
                / (1u32 << FALL_RATE_BITS) as f64;
            let w_total = drop_uniform(seed, id32, 2) - rate * t;
            let cycle = w_total.floor();
            if (w_total - cycle).min(cycle + 1.0 - w_total) < 1e-7 {
                edge += 1;
                continue;
            }
            let k = cycle as i64 as i32 as u32;
            let drift = DVec2::new(vol.motion.drift_q[0] as f64, vol.motion.drift_q[1] as f64)
                * (speed_q as f64 / (1u64 << DRIFT_PHASE_BITS) as f64)
                * t;
            let tau = vt / rain_composite::rain::physics::G_MPS2;
            let cells = drift + wind.drop_displacement_m(t, tau) / grid.cell_size_m;
            let u = (drop_uniform(seed, id32, 0) + cells.x + cycle_uniform(seed, id32, k, 4))
                .rem_euclid(1.0);
            let v = (drop_uniform(seed, id32, 1) + cells.y + cycle_uniform(seed, id32, k, 5))
                .rem_euclid(1.0);
            if [u, v].iter().any(|x| x.min(1.0 - x) < 1e-7) {
                edge += 1;
                continue;
            }
            let want = grid.point_m(col, [u, v, w_total - cycle]);
            assert!(
                (d.position_m - want).length() < 1e-6,
                "drop {id} at t = {t}: {:?} vs {want:?}",
                d.position_m
            );
            assert!((d.velocity_mps.z + vt).abs() < 1e-12);
            assert!((d.drawn_mm - 1.2 * d.diameter_mm).abs() < 1e-12);
            compared += 1;
        }
    }
    assert!(
        compared > 500 && edge * 100 < compared,
        "{compared} compared, {edge} at an edge"
    );
}

/// The drawn scales reach the plan: wider drops stay visible farther, faster ones (longer,
/// fainter streaks) less far, and with a fall-speed scale the streaks lean by the wind over the
/// *scaled* fall speed (the columns follow the drawn fall direction).
#[test]
fn the_plan_follows_the_drop_and_fall_speed_scales() {
    let cam = camera_1080(60.0, 0.0);
    let model = RainModel::marshall_palmer(rate(10.0));
    let still = Wind::steady(DVec2::ZERO).expect("wind");
    let far = |diameter_scale: f64, fall_speed_scale: f64| {
        let params = VolumeParams {
            diameter_scale,
            fall_speed_scale,
            ..VolumeParams::default()
        };
        RainVolume::plan(&cam, &model, &still, &params)
            .expect("plan")
            .far_visible_m
    };
    let base = far(1.0, 1.0);
    assert!(far(2.0, 1.0) > 1.5 * base, "{} vs {base}", far(2.0, 1.0));
    assert!(far(1.0, 3.0) < base, "{} vs {base}", far(1.0, 3.0));

    let (got, want) = streak_angles_deg(&cam, &model, 6.0, 2.0);
    assert!((got - want).abs() < 0.5, "{got}° vs {want}°");
}
