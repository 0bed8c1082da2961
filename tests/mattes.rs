//! Streak mattes: the generator against geometry, the Rayleigh frequencies, symmetry and the
//! RTF (same optics, independent code path), its determinism, the committed `drops/` database,
//! and the reader of Garg & Nayar's layout.

use std::path::Path;

use rain_composite::drops::database::{self, DatabaseSpec};
use rain_composite::drops::garg_nayar::GargNayarDb;
use rain_composite::drops::shape::rayleigh_frequency_hz;
use rain_composite::drops::{Amplitudes, LightAngles, MatteEntry, Streak, StreakSetup};
use rain_composite::lighting::DropOptics;
use rain_composite::rain::physics::{axis_ratio, terminal_velocity_gk_mps};

fn setup(d_mm: f64, exposure_s: f64) -> StreakSetup {
    StreakSetup {
        diameter_m: d_mm * 1e-3,
        amplitudes: Amplitudes::NONE,
        exposure_s,
        view_elevation_deg: 0.0,
        phase: 0.0,
        transverse_azimuth_deg: 0.0,
        pixel_m: d_mm * 1e-3 / 8.0,
        samples: 2,
        orders: 8,
        rho: 1.333,
        light_width_deg: 3.0,
    }
}

/// Σ over the columns of each row.
fn row_profile(s: &Streak, m: &[f64]) -> Vec<f64> {
    m.chunks(s.width).map(|r| r.iter().sum()).collect()
}

/// Σ over the rows of each column.
fn column_profile(s: &Streak, m: &[f64]) -> Vec<f64> {
    (0..s.width)
        .map(|c| m.iter().skip(c).step_by(s.width).sum())
        .collect()
}

/// Centre and standard deviation of a profile read as a distribution over pixel centres.
fn moments(p: &[f64]) -> (f64, f64) {
    let w: f64 = p.iter().sum();
    let mean = p
        .iter()
        .enumerate()
        .map(|(i, v)| (i as f64 + 0.5) * v)
        .sum::<f64>()
        / w;
    let var = p
        .iter()
        .enumerate()
        .map(|(i, v)| (i as f64 + 0.5 - mean).powi(2) * v)
        .sum::<f64>()
        / w;
    (mean, var.sqrt())
}

/// Where a profile first and last crosses half its maximum, linearly interpolated.
fn half_max_span(p: &[f64]) -> f64 {
    let half = 0.5 * p.iter().copied().fold(0.0, f64::max);
    let cross =
        |i: usize, j: usize| i as f64 + (half - p[i]) / (p[j] - p[i]) * (j as f64 - i as f64);
    let first = (0..p.len() - 1)
        .find(|&i| p[i] < half && p[i + 1] >= half)
        .expect("rises");
    let last = (1..p.len())
        .rev()
        .find(|&i| p[i] < half && p[i - 1] >= half)
        .expect("falls");
    cross(last - 1, last) - cross(first, first + 1)
}

#[test]
fn a_still_drop_in_uniform_light_makes_a_streak_as_wide_as_the_drop_and_as_long_as_its_fall() {
    let mut s = setup(1.0, 1.0 / 400.0);
    s.pixel_m = 1e-3 / 16.0;
    let streak = s.render(&[]).unwrap();
    let px_mm = s.pixel_m * 1e3;
    let r = axis_ratio(1.0);
    let (a_mm, b_mm) = (0.5 * r.powf(-1.0 / 3.0), 0.5 * r.powf(2.0 / 3.0));

    // Width: a chord profile √(1 − x²/a²) has σ = a/2, so 4σ is the horizontal diameter.
    let (centre, sigma) = moments(&column_profile(&streak, &streak.env));
    assert!((centre - streak.width as f64 / 2.0).abs() < 1e-6);
    assert!(
        (4.0 * sigma * px_mm - 2.0 * a_mm).abs() < 0.2 * px_mm,
        "width {} mm vs {}",
        4.0 * sigma * px_mm,
        2.0 * a_mm
    );

    // Length: the rows the drop's centre sweeps, speed × exposure; the drop's own height makes
    // the ends ramp symmetrically, so the half-maximum points are one travel apart.
    let travel_px = terminal_velocity_gk_mps(1.0) * s.exposure_s / s.pixel_m;
    let span = half_max_span(&row_profile(&streak, &streak.coverage));
    assert!(
        (span - travel_px).abs() < 1.0,
        "length {span} px vs {travel_px}"
    );

    // Integral: time-averaged coverage = the ellipse's area; radiance = energy kept by the
    // traced orders, from the RTF's integral over impact parameters.
    let area_px2 = std::f64::consts::PI * a_mm * b_mm / (px_mm * px_mm);
    let coverage: f64 = streak.coverage.iter().sum();
    assert!(
        (coverage / area_px2 - 1.0).abs() < 2e-3,
        "coverage {coverage} vs {area_px2}"
    );
    let kept: f64 = DropOptics::new(1.333, 8)
        .unwrap()
        .energy_per_order()
        .iter()
        .sum();
    let env: f64 = streak.env.iter().sum();
    assert!(
        (env / coverage - kept).abs() < 2e-3,
        "radiance {} vs {kept}",
        env / coverage
    );
}

/// The dominant spatial frequency of a profile, cycles per sample (DFT with parabolic peak
/// interpolation, the mean removed).
fn dominant_frequency(p: &[f64]) -> f64 {
    let n = p.len();
    let mean = p.iter().sum::<f64>() / n as f64;
    // Zero-padded 8× for a fine frequency grid.
    let m = 8 * n;
    let power = |k: usize| {
        let w = std::f64::consts::TAU * k as f64 / m as f64;
        let (re, im) = p.iter().enumerate().fold((0.0, 0.0), |(re, im), (i, v)| {
            let hann = 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / (n - 1) as f64).cos();
            let x = (v - mean) * hann;
            (re + x * (w * i as f64).cos(), im - x * (w * i as f64).sin())
        });
        re * re + im * im
    };
    let spectrum: Vec<f64> = (0..m / 2).map(power).collect();
    let k = (2..m / 2 - 1)
        .max_by(|&a, &b| spectrum[a].total_cmp(&spectrum[b]))
        .unwrap();
    let (a, b, c) = (spectrum[k - 1].ln(), spectrum[k].ln(), spectrum[k + 1].ln());
    (k as f64 + 0.5 * (a - c) / (a - 2.0 * b + c)) / m as f64
}

#[test]
fn an_oscillating_drop_leaves_a_ripple_whose_period_is_fall_speed_over_the_mode_frequency() {
    for d_mm in [1.0, 2.0] {
        let f2 = rayleigh_frequency_hz(2, d_mm * 1e-3);
        let mut s = setup(d_mm, 5.0 / f2);
        s.amplitudes = Amplitudes {
            a20: 0.08,
            a31: 0.0,
        };
        s.pixel_m = d_mm * 1e-3 / 6.0;
        s.samples = 1;
        s.orders = 2;
        let streak = s.render(&[]).unwrap();
        let rows = row_profile(&streak, &streak.env);
        // The plateau only: a drop's height in from both ends.
        let edge = (streak.start_row + s.radius_px() * 1.3).ceil() as usize;
        let plateau = &rows[edge..rows.len() - edge];
        let expected_px = streak.fall_speed_mps / f2 / s.pixel_m;
        let measured_px = 1.0 / dominant_frequency(plateau);
        println!("D = {d_mm} mm: ripple period {measured_px:.2} px, V/f₂ = {expected_px:.2} px");
        assert!(
            (measured_px / expected_px - 1.0).abs() < 0.03,
            "D = {d_mm} mm: period {measured_px:.2} px, expected {expected_px:.2}"
        );
    }
}

#[test]
fn a_light_in_the_plane_of_view_and_fall_gives_a_mirror_symmetric_streak_and_a_side_light_does_not()
{
    let mut s = setup(2.0, 1.0 / 250.0);
    s.amplitudes = Amplitudes::for_diameter_mm(2.0);
    s.view_elevation_deg = 20.0;
    s.samples = 1;
    s.orders = 4;
    let light = |elevation_deg, azimuth_deg| LightAngles {
        elevation_deg,
        azimuth_deg,
    };
    let lights = [
        light(40.0, 0.0),
        light(10.0, 180.0),
        light(20.0, 90.0),
        light(20.0, 270.0),
    ];
    let streak = s.render(&lights).unwrap();
    let asymmetry = |m: &[f64]| {
        let mirror_diff: f64 = m
            .chunks(streak.width)
            .flat_map(|r| r.iter().zip(r.iter().rev()).map(|(a, b)| (a - b).abs()))
            .sum();
        mirror_diff / m.iter().sum::<f64>()
    };
    for m in &streak.lights[..2] {
        assert!(
            asymmetry(m) < 1e-6,
            "in-plane light: asymmetry {}",
            asymmetry(m)
        );
    }
    // A light on the image's right: the glint sits on the side facing it, and the light at
    // the mirrored azimuth gives the mirrored streak.
    let centre = streak.width as f64 / 2.0;
    let (right, _) = moments(&column_profile(&streak, &streak.lights[2]));
    let (left, _) = moments(&column_profile(&streak, &streak.lights[3]));
    assert!(asymmetry(&streak.lights[2]) > 0.1);
    assert!(right > centre + 0.5, "centroid {right} vs centre {centre}");
    assert!((right - centre + left - centre).abs() < 1e-6);
}

#[test]
fn uniform_light_energy_per_order_agrees_with_the_rtf() {
    // A small drop is a sphere (axis ratio 1), where the tracer and the RTF's impact-parameter
    // integral must agree order by order.
    let optics = DropOptics::new(1.333, 4).unwrap();
    let eps = optics.energy_per_order();
    for orders in [1, 2, 4] {
        let mut s = setup(0.5, 1.0 / 2000.0);
        s.orders = orders;
        s.pixel_m = 0.5e-3 / 24.0;
        s.samples = 1;
        let streak = s.render(&[]).unwrap();
        let radiance = streak.env.iter().sum::<f64>() / streak.coverage.iter().sum::<f64>();
        let expected: f64 = eps[..orders].iter().sum();
        println!("orders ≤ {orders}: traced {radiance:.5}, RTF {expected:.5}");
        assert!(
            (radiance / expected - 1.0).abs() < 5e-3,
            "orders ≤ {orders}: {radiance} vs {expected}"
        );
    }
    // An oscillating drop, summed over phases, keeps the sphere's energy per order to within
    // the per cent or so its changing curvature moves between orders.
    let mut total = [0.0; 2];
    for k in 0..4 {
        let mut s = setup(2.0, 1.0 / 2000.0);
        s.amplitudes = Amplitudes::for_diameter_mm(2.0);
        s.phase = k as f64 / 4.0;
        s.orders = 1;
        s.samples = 1;
        let streak = s.render(&[]).unwrap();
        total[0] += streak.env.iter().sum::<f64>();
        total[1] += streak.coverage.iter().sum::<f64>();
    }
    println!(
        "oscillating 2 mm, 4 phases, order 1: {:.5} vs ε₁ {:.5}",
        total[0] / total[1],
        eps[0]
    );
    assert!(
        (total[0] / total[1] / eps[0] - 1.0).abs() < 0.02,
        "{} vs {}",
        total[0] / total[1],
        eps[0]
    );
}

/// The RTF's F smoothed by the light's von Mises–Fisher lobe of width `sigma`, at scattering
/// angle `theta`: ∫ F(θ′) K(ω′·l) dω′, integrated over the table's bins and the azimuth.
fn smoothed_rtf(theta: f64, sigma: f64) -> f64 {
    let table = DropOptics::new(1.333, 8).unwrap().tabulate(720).unwrap();
    let kappa = sigma.powi(-2);
    let lobe = |mu: f64| {
        kappa / (std::f64::consts::TAU * -(-2.0 * kappa).exp_m1()) * (kappa * (mu - 1.0)).exp()
    };
    let azimuths = 720;
    (0..720)
        .map(|m| {
            let t = table.bin_centre_rad(m);
            let ring: f64 = (0..azimuths)
                .map(|k| {
                    let phi = std::f64::consts::TAU * (k as f64 + 0.5) / azimuths as f64;
                    lobe(theta.cos() * t.cos() + theta.sin() * t.sin() * phi.cos())
                })
                .sum::<f64>()
                / azimuths as f64;
            table.value(t) * ring * table.bin_solid_angle_sr(m)
        })
        .sum()
}

#[test]
fn a_point_light_matte_averages_to_the_rtf_phase_function_at_its_scattering_angle() {
    // View 0 looks along +y; a light at azimuth 120° in the horizontal plane lies 60° from the
    // view ray, so the drop's mean radiance per unit irradiance is F(60°) seen through the
    // light's lobe. The tracer and the RTF's binned impact-parameter integral share only the
    // Fresnel formula.
    let mut s = setup(0.5, 1.0 / 8000.0);
    s.pixel_m = 0.5e-3 / 24.0;
    s.samples = 3;
    s.light_width_deg = 6.0;
    let light = LightAngles {
        elevation_deg: 0.0,
        azimuth_deg: 120.0,
    };
    let streak = s.render(&[light]).unwrap();
    let mean = streak.lights[0].iter().sum::<f64>() / streak.coverage.iter().sum::<f64>();
    let f = smoothed_rtf(60f64.to_radians(), 6f64.to_radians());
    println!("point light at 60°: mean {mean:.5} sr⁻¹, smoothed F(60°) {f:.5}");
    assert!(
        (mean / f - 1.0).abs() < 0.03,
        "mean {mean} sr⁻¹ vs smoothed F(60°) = {f}"
    );
}

#[test]
fn the_same_parameters_give_bit_identical_mattes_on_any_number_of_threads() {
    let mut s = setup(1.0, 1.0 / 1000.0);
    s.amplitudes = Amplitudes::for_diameter_mm(1.0);
    let light = [LightAngles {
        elevation_deg: 30.0,
        azimuth_deg: 60.0,
    }];
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| s.render(&light).unwrap())
    };
    assert_eq!(on(1), on(3));
}

#[test]
fn the_committed_database_regenerates_bit_for_bit() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("drops");
    let index = database::load_index(&dir).unwrap();
    assert_eq!(
        index.spec,
        DatabaseSpec::default(),
        "drops/ was made with the default grid"
    );
    // One streak of the grid (the largest drop seen from the steepest view: the shortest
    // streak, the last phase): every file it makes, byte for byte, and its index entries.
    let spec = &index.spec;
    let last = |v: &[f64]| v[v.len() - 1];
    let setup = database::setup(
        spec,
        last(&spec.sizes_mm),
        spec.exposures_s[0],
        last(&spec.view_elevations_deg),
        spec.phases - 1,
    );
    let streak = setup.render(&spec.lights).unwrap();
    let made = database::entries(spec, &setup, &streak);
    assert_eq!(made.len(), 1 + spec.lights.len());
    // index.json went through JSON once: so does the fresh entry (serde_json's float parsing
    // may move the last bit).
    let through_json = |e: &MatteEntry| {
        serde_json::from_str::<MatteEntry>(&serde_json::to_string(e).unwrap()).unwrap()
    };
    for (entry, matte) in made {
        let committed = index
            .mattes
            .iter()
            .find(|e| e.file == entry.file)
            .expect("entry in index.json");
        assert_eq!(committed, &through_json(&entry));
        let (codes, _) = database::quantise(&matte);
        let png = database::encode_png16(entry.width, entry.height, &codes).unwrap();
        assert!(
            std::fs::read(dir.join(&entry.file)).unwrap() == png,
            "{} differs",
            entry.file
        );
    }
}

#[test]
fn the_garg_nayar_reader_picks_the_nearest_file_that_exists() {
    let root = tempfile::tempdir().unwrap();
    let png = |path: &Path, code: u16| {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, database::encode_png16(2, 3, &[code; 6]).unwrap()).unwrap();
    };
    let env = root.path().join("env_light_database");
    for e in [0, 20, 40, 60, 80] {
        for k in 0..10 {
            png(&env.join(format!("size4/cv{e}_osc{k}.png")), 65535);
        }
    }
    let mut env_txt = String::new();
    for e in [0, 20, 40, 60, 80] {
        let m: Vec<String> = (0..10).map(|k| format!("{}", e * 100 + k)).collect();
        env_txt += &format!("cv{e}\n{}\n", m.join(" "));
    }
    std::fs::create_dir_all(env.join("txt")).unwrap();
    std::fs::write(env.join("txt/normalized_env_max.txt"), env_txt).unwrap();
    // Point lights for the 40° camera only, and only two light directions of it.
    let point = root.path().join("point_light_database");
    for (v, h) in [(30, 50), (-50, 150)] {
        for k in 0..10 {
            png(
                &point.join(format!("size4/dcam40/cv40_v{v}_h{h}_osc{k}.png")),
                32768,
            );
        }
    }
    std::fs::create_dir_all(point.join("txt")).unwrap();
    let mut point_txt = String::from("cv40\n");
    for (v, h) in [(30, 50), (-50, 150)] {
        let m: Vec<String> = (0..10).map(|k| format!("{}.5", v * 1000 + h + k)).collect();
        point_txt += &format!("v{v}\nh{h} {}\n", m.join(" "));
    }
    std::fs::write(point.join("txt/dcam40_point_max.txt"), point_txt).unwrap();

    let db = GargNayarDb::open(root.path(), 4).unwrap();
    let pick = db.env(47.0, 3).unwrap();
    assert!(pick.path.ends_with("size4/cv40_osc3.png"));
    assert_eq!(pick.multiplier, 4003.0);
    let pick = db.env(75.0, 12).unwrap();
    assert!(
        pick.path.ends_with("size4/cv80_osc2.png"),
        "{:?}",
        pick.path
    );

    // (35°, 40°) is nearest (30, 50) of the two that exist; (−60°, 160°) is nearest (−50, 150).
    let pick = db.point(38.0, 35.0, 40.0, 7).unwrap();
    assert!(
        pick.path.ends_with("dcam40/cv40_v30_h50_osc7.png"),
        "{:?}",
        pick.path
    );
    assert_eq!(pick.multiplier, 30057.5);
    let pick = db.point(41.0, -60.0, 160.0, 0).unwrap();
    assert_eq!(pick.light_deg, Some((-50, 150)));
    assert_eq!(pick.multiplier, -49850.5);
    let (w, h, m) = GargNayarDb::read(&pick).unwrap();
    assert_eq!((w, h), (2, 3));
    assert!((m[0] - 32768.0 / 65535.0 * -49850.5).abs() < 1e-9);
    // No point-light streaks for the 0° camera; not a database at all.
    assert!(db.point(0.0, 30.0, 50.0, 0).is_err());
    assert!(GargNayarDb::open(&root.path().join("env_light_database"), 4).is_err());
}

#[test]
fn the_command_line_generates_a_database_and_draws_its_contact_sheet() {
    let bin = env!("CARGO_BIN_EXE_rain-composite");
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("db");
    let run = |args: &[&str]| std::process::Command::new(bin).args(args).output().unwrap();
    let small = [
        "--sizes",
        "4",
        "--views",
        "60",
        "--phases",
        "1",
        "--exposures",
        "1/500",
        "--pixels-per-diameter",
        "4",
        "--samples",
        "1",
    ];
    let out = run(&[
        &["drops", "generate", "-o", db.to_str().unwrap()][..],
        &small[..],
    ]
    .concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let index = database::load_index(&db).unwrap();
    assert_eq!(index.mattes.len(), 1 + DatabaseSpec::default().lights.len());
    assert!((index.spec.exposures_s[0] - 0.002).abs() < 1e-15);
    for m in &index.mattes {
        let matte = database::read_matte(&db, m).unwrap();
        assert!(
            (matte.iter().sum::<f64>() / m.sum_px2 - 1.0).abs() < 1e-3,
            "{}",
            m.file
        );
    }
    let sheet = dir.path().join("sheet.png");
    let out = run(&[
        "inspect",
        "drops",
        "--mattes",
        sheet.to_str().unwrap(),
        "--streak-db",
        db.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(image::open(&sheet).is_ok());
    // Without --streak-db, outside the source tree: the database the render uses.
    let shipped = dir.path().join("shipped.png");
    let out = std::process::Command::new(bin)
        .current_dir(dir.path())
        .args(["inspect", "drops", "--mattes", "shipped.png"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(image::open(&shipped).is_ok());
    // Counts beyond their bounds are refused before any work.
    for (flag, value) in [("--phases", "65"), ("--samples", "17")] {
        let out = run(&["drops", "generate", "-o", db.to_str().unwrap(), flag, value]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(flag), "{stderr}");
    }
    let out = run(&[
        "drops",
        "generate",
        "-o",
        dir.path().join("many").to_str().unwrap(),
        "--views",
        "0,1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17,18,19,20,21,22,23,24,25,26,27,28,29,30,31,32,33,34,35,36,37,38,39,40,41,42,43,44,45,46,47,48,49,50,51,52,53,54,55,56,57,58,59,60",
        "--phases",
        "64",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("at most 10000 streaks"), "{stderr}");
    assert!(!dir.path().join("many").exists());
    // A mistake is one error line and nothing written.
    let bad = dir.path().join("bad");
    let out = run(&[
        "drops",
        "generate",
        "-o",
        bad.to_str().unwrap(),
        "--views",
        "90",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.trim().lines().count() == 1 && stderr.contains("--views"),
        "{stderr}"
    );
    assert!(!bad.exists());
}

#[test]
fn a_renderer_picks_the_nearest_matte_and_mirrors_lights_on_the_left() {
    let index = database::load_index(&Path::new(env!("CARGO_MANIFEST_DIR")).join("drops")).unwrap();
    let light = |elevation_deg, azimuth_deg| {
        Some(LightAngles {
            elevation_deg,
            azimuth_deg,
        })
    };
    // 1.6 mm is nearer 2 than 1; 1/50 s nearest 1/60; 40° nearer 30 than 60; phase 0.95 wraps
    // to 0; a light at (30°, 100°) is nearest (45°, 90°) of the grid.
    let (m, mirror) = index
        .pick(1.6, 1.0 / 50.0, 40.0, 0.95, light(30.0, 100.0))
        .unwrap();
    assert_eq!(
        (m.diameter_mm, m.view_elevation_deg, m.phase, mirror),
        (2.0, 30.0, 0.0, false)
    );
    assert_eq!(m.light, light(45.0, 90.0));
    // The same light on the other side (azimuth 260° = −100°) is its mirror image.
    let (m2, mirror) = index
        .pick(1.6, 1.0 / 50.0, 40.0, 0.95, light(30.0, 260.0))
        .unwrap();
    assert_eq!((m2.file.as_str(), mirror), (m.file.as_str(), true));
    let (env, _) = index.pick(3.5, 0.01, 5.0, 0.3, None).unwrap();
    assert_eq!(
        (
            env.diameter_mm,
            env.view_elevation_deg,
            env.phase,
            env.light
        ),
        (4.0, 0.0, 0.25, None)
    );
}

/// A copy of Garg & Nayar's database with its point-light part: the render's atlas takes
/// point-light layers from it, each direction's from the nearest file that exists, scaled to
/// the same unit integral as ours. Two light directions exist in every camera folder: one whose
/// streak is lit only in its top quarter, one only in its bottom quarter.
#[test]
fn a_garg_nayar_copy_with_point_lights_gives_the_render_its_glints() {
    use rain_composite::drops::MatteAtlas;
    use rain_composite::drops::atlas::{
        GARG_NAYAR_LIGHT_AZIMUTHS_DEG, GARG_NAYAR_LIGHT_ELEVATIONS_DEG,
    };
    let root = tempfile::tempdir().unwrap();
    let (w, h) = (4usize, 16usize);
    let png = |path: &Path, codes: &[u16]| {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, database::encode_png16(w, h, codes).unwrap()).unwrap();
    };
    let rows = |lit: std::ops::Range<usize>| -> Vec<u16> {
        (0..w * h)
            .map(|i| if lit.contains(&(i / w)) { 65535 } else { 0 })
            .collect()
    };
    let views = [0, 20, 40, 60, 80];
    let env = root.path().join("env_light_database");
    let point = root.path().join("point_light_database");
    let mut env_txt = String::new();
    let (top, bottom) = ((10, 90), (-50, 170));
    for e in views {
        env_txt += &format!("cv{e}\n{}\n", ["1"; 10].join(" "));
        let mut point_txt = String::new();
        for (v, hz) in [top, bottom] {
            point_txt += &format!("v{v}\nh{hz} {}\n", ["2"; 10].join(" "));
        }
        std::fs::create_dir_all(point.join("txt")).unwrap();
        std::fs::write(
            point.join(format!("txt/dcam{e:02}_point_max.txt")),
            point_txt,
        )
        .unwrap();
        for k in 0..10 {
            png(&env.join(format!("size16/cv{e}_osc{k}.png")), &rows(0..h));
            let lit_top = rows(0..h / 4);
            let lit_bottom = rows(3 * h / 4..h);
            for ((v, hz), codes) in [(top, &lit_top), (bottom, &lit_bottom)] {
                png(
                    &point.join(format!("size16/dcam{e:02}/cv{e}_v{v}_h{hz}_osc{k}.png")),
                    codes,
                );
            }
        }
    }
    std::fs::create_dir_all(env.join("txt")).unwrap();
    std::fs::write(env.join("txt/normalized_env_max.txt"), env_txt).unwrap();

    let atlas = MatteAtlas::load(root.path(), 1.0 / 60.0).unwrap();
    let targets: Vec<(f64, f64)> = GARG_NAYAR_LIGHT_ELEVATIONS_DEG
        .iter()
        .flat_map(|&e| GARG_NAYAR_LIGHT_AZIMUTHS_DEG.iter().map(move |&a| (e, a)))
        .collect();
    assert_eq!(atlas.lights.len(), targets.len());
    assert_eq!(
        atlas.layers(),
        atlas.light_layer0() * (1 + targets.len()),
        "one point-light layer per environment layer and direction"
    );
    // Which of the two files a target is nearest to, by the angle between directions.
    let dir = |(e, a): (f64, f64)| {
        LightAngles {
            elevation_deg: e,
            azimuth_deg: a,
        }
        .direction()
    };
    let nearest_top = |t: (f64, f64)| {
        let d = dir(t);
        d.dot(dir((top.0 as f64, top.1 as f64))) > d.dot(dir((bottom.0 as f64, bottom.1 as f64)))
    };
    let (phases, views_n) = (atlas.phases, atlas.views_deg.len());
    for (light, &t) in targets.iter().enumerate() {
        assert!((atlas.lights[light] - dir(t)).length() < 1e-12);
        for view in 0..views_n {
            for phase in [0, phases - 1] {
                let layer = atlas.light_layer0() + (view * targets.len() + light) * phases + phase;
                // The share of the layer's light in the first half of the streak.
                let (mut first, mut all) = (0.0, 0.0);
                for j in 0..200 {
                    let u = (j as f64 + 0.5) / 200.0;
                    let n = atlas.sample(layer, u, 0.0);
                    all += n;
                    if u < 0.5 {
                        first += n;
                    }
                }
                let share = first / all;
                let want_top = nearest_top(t);
                assert!(
                    if want_top { share > 0.99 } else { share < 0.01 },
                    "target {t:?}, view {view}: {share} of its light in the top half"
                );
            }
        }
    }
    // Without the point-light part, environment mattes only.
    std::fs::remove_dir_all(&point).unwrap();
    let env_only = MatteAtlas::load(root.path(), 1.0 / 60.0).unwrap();
    assert!(env_only.lights.is_empty());
    assert_eq!(env_only.layers(), env_only.light_layer0());
}

/// A database's files are read only when regular: a FIFO as `index.json` or as a matte is an
/// error at once, not a read that never ends.
#[test]
fn a_database_is_read_from_regular_files_only() {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("drops");
    let index = database::load_index(&shipped).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let fifo = |path: &Path| {
        assert!(
            std::process::Command::new("mkfifo")
                .arg(path)
                .status()
                .unwrap()
                .success()
        );
    };
    fifo(&dir.path().join("index.json"));
    let e = database::load_index(dir.path()).unwrap_err().to_string();
    assert!(e.contains("not a regular file"), "{e}");
    let entry = &index.mattes[0];
    let matte = dir.path().join(&entry.file);
    std::fs::create_dir_all(matte.parent().unwrap()).unwrap();
    fifo(&matte);
    let e = database::read_matte(dir.path(), entry)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a regular file"), "{e}");
}
