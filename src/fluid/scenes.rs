//! Validation scenes for the SPH solver and their measures (`rain-composite inspect sph`).
//!
//! How it works: each scene builds a solver from published or analytic set-ups, and its
//! measures compare the state against an independent reference:
//! - `column`: water at rest in a closed box. Hydrostatics: p = ρ₀g·depth, density within 1 %
//!   of ρ₀ below the surface layer, kinetic energy decaying to zero.
//! - `dam-break`: a column a wide and 2a high collapsing in a tank (Martin & Moyce 1952,
//!   a = 2.25 in, n² = 2), in a slab a few particles thick between free-slip walls. Front
//!   Z = x/a against T = t√(2g/a) — the √2 is M&M's definition for n² = 2.
//! - `basin`: rain on a paraboloid bowl z = k r² through the full [`SurfaceFlow`] chain
//!   (precipitation counters → SPH → carpet). The pool collects at the lowest point with depth
//!   D = √(2kV/π) for volume V, and a flat carpet surface.

use super::boundary::{Boundaries, Domain};
use super::eos::{EquationOfState, STANDARD_GRAVITY_MPS2};
use super::flow::{SurfaceFlow, SurfaceFlowSettings};
use super::settings::{DEFAULT_COURANT, SphSettings, TimeStep};
use super::sources::splitmix64;
use super::sph::Muller2003;
use super::terrain::HeightField;
use crate::{Error, Result};
use glam::{Vec2, Vec3};
use serde_json::{Value, json};

/// The scene names [`inspect_sph`] accepts.
pub const SCENES: [&str; 3] = ["column", "dam-break", "basin"];

/// Solver steps that bring `scene` to its validated state: `column` 3 500 (1 s), `dam-break`
/// 1 500 (T ≈ 3.7), `basin` 5 000 (≈ 1 s; the basin runs whole 1/60 s frames, so it may
/// overshoot by a frame). An unknown name gets the basin's, and [`inspect_sph`] refuses it.
pub fn validated_steps(scene: &str) -> usize {
    match scene {
        "column" => 3500,
        "dam-break" => 1500,
        _ => 5000,
    }
}

/// Martin & Moyce (1952), two-dimensional collapse, a = 2.25 in, n² = 2: surge front
/// (T = t√(2g/a), Z = x/a), as transcribed in PySPH's `db_exp_data.py`.
pub const MARTIN_MOYCE_1952: [(f32, f32); 15] = [
    (0.832, 1.217),
    (1.219, 1.474),
    (1.997, 2.292),
    (2.547, 2.995),
    (3.345, 4.134),
    (4.034, 4.944),
    (4.418, 5.881),
    (5.091, 6.980),
    (5.685, 7.945),
    (6.306, 8.966),
    (6.822, 9.986),
    (7.439, 10.963),
    (8.031, 11.977),
    (8.633, 13.005),
    (9.237, 13.970),
];

/// Overrides for the scenes' defaults (None: the scene's choice).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SceneOptions {
    /// Particle spacing, m.
    pub particle_spacing_m: Option<f32>,
    /// Equation of state (e.g. [`EquationOfState::THESIS`] to see the compressibility).
    pub eos: Option<EquationOfState>,
    /// Time-step rule.
    pub time_step: Option<TimeStep>,
    /// Dynamic viscosity, Pa·s.
    pub viscosity_pa_s: Option<f32>,
    /// Kernel support h as a multiple of the spacing (the default viscosity, ∝ h, follows).
    pub smoothing_ratio: Option<f32>,
}

impl SceneOptions {
    fn apply(&self, s: &mut SphSettings) {
        if let Some(ratio) = self.smoothing_ratio {
            let h = ratio * s.particle_spacing_m;
            s.viscosity_pa_s *= h / s.smoothing_length_m;
            s.smoothing_length_m = h;
        }
        if let Some(eos) = self.eos {
            s.eos = eos;
        }
        if let Some(ts) = self.time_step {
            s.time_step = ts;
        }
        if let Some(mu) = self.viscosity_pa_s {
            s.viscosity_pa_s = mu;
        }
    }
}

/// Linear interpolation in a table of increasing x; None outside it.
pub fn interpolate(table: &[(f32, f32)], x: f32) -> Option<f32> {
    let k = table.windows(2).position(|w| x >= w[0].0 && x <= w[1].0)?;
    let ((x0, y0), (x1, y1)) = (table[k], table[k + 1]);
    Some(y0 + (y1 - y0) * (x - x0) / (x1 - x0))
}

/// Hydrostatic measures of water at rest.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Hydrostatics {
    /// Free surface: mean height of the surface particles plus half a spacing, m.
    pub free_surface_m: f32,
    /// Particles at least h below the free surface (full kernel support).
    pub interior_particles: usize,
    /// Mean |ρ − ρ₀|/ρ₀ over interior particles.
    pub density_error_mean: f32,
    /// Max |ρ − ρ₀|/ρ₀ over interior particles.
    pub density_error_max: f32,
    /// Least-squares slope −dp/dz over interior particles, Pa/m.
    pub pressure_gradient_pa_per_m: f32,
    /// ρ₀g, Pa/m.
    pub expected_gradient_pa_per_m: f32,
    /// Intercept-free check: mean |p − ρ₀g·depth| / (ρ₀g·H) over interior particles.
    pub pressure_profile_error: f32,
}

/// Measures hydrostatics of the solver's current state (water at rest under gravity −z).
pub fn hydrostatics(sph: &Muller2003) -> Hydrostatics {
    let s = sph.settings();
    let p = sph.particles();
    let (rho0, h, g) = (
        s.rest_density_kg_m3,
        s.smoothing_length_m,
        s.gravity_mps2.length(),
    );
    let tops: Vec<f32> = p
        .positions_m()
        .iter()
        .zip(p.surface())
        .filter(|(_, s)| **s)
        .map(|(x, _)| x.z)
        .collect();
    let free_surface_m =
        tops.iter().sum::<f32>() / tops.len().max(1) as f32 + 0.5 * s.particle_spacing_m;
    let floor = p
        .positions_m()
        .iter()
        .fold(f32::INFINITY, |m, x| m.min(x.z));
    let column = (free_surface_m - floor).max(h);
    let (mut n, mut e_sum, mut e_max) = (0usize, 0.0f64, 0.0f32);
    let (mut sz, mut sp, mut szz, mut szp) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut profile = 0.0f64;
    for ((x, &rho), &pr) in p
        .positions_m()
        .iter()
        .zip(p.densities_kg_m3())
        .zip(p.pressures_pa())
    {
        let depth = free_surface_m - x.z;
        if depth < h {
            continue;
        }
        n += 1;
        let e = (rho - rho0).abs() / rho0;
        e_sum += e as f64;
        e_max = e_max.max(e);
        let (z, pr) = (x.z as f64, pr as f64);
        sz += z;
        sp += pr;
        szz += z * z;
        szp += z * pr;
        profile += (pr - (rho0 * g * depth) as f64).abs();
    }
    let nf = n.max(1) as f64;
    let slope = (nf * szp - sz * sp) / (nf * szz - sz * sz);
    Hydrostatics {
        free_surface_m,
        interior_particles: n,
        density_error_mean: (e_sum / nf) as f32,
        density_error_max: e_max,
        pressure_gradient_pa_per_m: -slope as f32,
        expected_gradient_pa_per_m: rho0 * g,
        pressure_profile_error: (profile / nf / (rho0 * g * column) as f64) as f32,
    }
}

/// The hydrostatic column: 5 cm × 5 cm × 10 cm of water (spacing 5 mm: 2 000 particles) in a
/// closed box twice as tall, loaded by gravity ramped up over 0.2 s (7 periods of the
/// column's slowest sound mode, 4H/c = 29 ms), so it settles without ringing.
pub fn column(opts: &SceneOptions) -> Result<Muller2003> {
    let dx = opts.particle_spacing_m.unwrap_or(0.005);
    let (width, height) = (0.05f32, 0.1f32);
    let mut s = SphSettings::water(dx, height);
    s.gravity_ramp_s = 0.2;
    opts.apply(&mut s);
    let mut sph = Muller2003::new(
        s,
        Boundaries {
            domain: Domain::closed(Vec3::ZERO, Vec3::new(width, width, 2.0 * height)),
            terrain: None,
        },
    )?;
    sph.add_block(Vec3::ZERO, Vec3::new(width, width, height), Vec3::ZERO)?;
    Ok(sph)
}

/// A benchmark scene of exactly `particles` particles: a block of water 1 × 1 × 2 (in units of
/// its width) collapsing into a closed tank 4 wide, 2 deep and 3 tall, spacing 5 mm. The block
/// is filled layer by layer and the last layer is partial.
pub fn collapsing_block(particles: usize) -> Result<Muller2003> {
    let dx = 0.005f32;
    let side = ((particles as f32 / 2.0).cbrt().ceil() as usize).max(1);
    let width = side as f32 * dx;
    let mut s = SphSettings::water(dx, 2.0 * width);
    s.time_step = TimeStep::Adaptive {
        courant: DEFAULT_COURANT,
        max_s: 0.005,
    };
    let mut sph = Muller2003::new(
        s,
        Boundaries {
            domain: Domain::closed(Vec3::ZERO, Vec3::new(4.0, 2.0, 3.0) * width),
            terrain: None,
        },
    )?;
    let mut k = 0;
    'fill: for z in 0.. {
        for y in 0..side {
            for x in 0..side {
                if k == particles {
                    break 'fill;
                }
                let p = (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * dx;
                sph.add_particle(p, Vec3::ZERO)?;
                k += 1;
            }
        }
    }
    Ok(sph)
}

/// The dam-break scene of Martin & Moyce (1952).
#[derive(Debug, Clone)]
pub struct DamBreak {
    /// The solver.
    pub sph: Muller2003,
    /// Column width a, m (height 2a).
    pub a_m: f32,
}

impl DamBreak {
    /// a = 2.25 in = 0.05715 m, spacing a/20 by default, slab 4 spacings thick, tank 10a long.
    pub fn new(opts: &SceneOptions) -> Result<DamBreak> {
        let a = 0.05715f32;
        let dx = opts.particle_spacing_m.unwrap_or(a / 20.0);
        let mut s = SphSettings::water(dx, 2.0 * a);
        opts.apply(&mut s);
        let thickness = 4.0 * dx;
        let mut sph = Muller2003::new(
            s,
            Boundaries {
                domain: Domain::closed(Vec3::ZERO, Vec3::new(10.0 * a, thickness, 3.0 * a)),
                terrain: None,
            },
        )?;
        sph.add_block(Vec3::ZERO, Vec3::new(a, thickness, 2.0 * a), Vec3::ZERO)?;
        Ok(DamBreak { sph, a_m: a })
    }

    /// Surge front: the leading particle's x plus half a spacing, m.
    pub fn front_m(&self) -> f32 {
        let x = self
            .sph
            .particles()
            .positions_m()
            .iter()
            .fold(0.0f32, |m, p| m.max(p.x));
        x + 0.5 * self.sph.settings().particle_spacing_m
    }

    /// M&M's time T = t√(2g/a).
    pub fn normalised_time(&self) -> f32 {
        self.sph.time_s() as f32 * (2.0 * STANDARD_GRAVITY_MPS2 / self.a_m).sqrt()
    }
}

/// The basin: rain on a paraboloid bowl z = k(x² + y²) through [`SurfaceFlow`].
#[derive(Debug, Clone)]
pub struct Basin {
    /// Precipitation → SPH → carpet.
    pub flow: SurfaceFlow,
    /// Bowl curvature k, 1/m.
    pub curvature_per_m: f32,
    /// Rain falls for this long, s.
    pub rain_duration_s: f32,
    /// Frame length, s.
    pub frame_s: f32,
    frame: u64,
}

/// Measures of the basin's pool.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct BasinMeasures {
    /// Particles present.
    pub particles: usize,
    /// Water volume N·m/ρ₀, m³.
    pub volume_m3: f32,
    /// Horizontal distance of the water's centroid from the bowl's lowest point, m.
    pub centroid_offset_m: f32,
    /// Pool depth of a paraboloid holding that volume, √(2kV/π), m.
    pub expected_depth_m: f32,
    /// Carpet water depth at the lowest point, m.
    pub depth_m: f32,
    /// Standard deviation of the carpet surface over the pool's inner half radius, m.
    pub surface_std_m: f32,
    /// Range (max − min) of the carpet surface over the pool's inner half radius, m.
    pub surface_range_m: f32,
    /// Fraction of particles within the analytic pool radius (plus a spacing).
    pub fraction_in_pool: f32,
}

impl Basin {
    /// A bowl 0.2 m wide with k = 5/m (rim 5 cm above the bottom), spacing 4 mm by default,
    /// raining for 0.3 s (S = 4) onto every precipitation cell.
    pub fn new(opts: &SceneOptions) -> Result<Basin> {
        let dx = opts.particle_spacing_m.unwrap_or(0.004);
        let (half, k) = (0.1f32, 5.0f32);
        let mut fs = SurfaceFlowSettings::new(dx, 2.0 * k * half * half);
        fs.open_edges = false;
        fs.headroom_m = 0.05;
        opts.apply(&mut fs.sph);
        let n = 2 * (half / (0.5 * dx)).round() as usize + 1;
        let terrain = HeightField::from_fn(n, n, Vec2::splat(-half), 0.5 * dx, |x, y| {
            k * (x * x + y * y)
        })?;
        Ok(Basin {
            flow: SurfaceFlow::new(terrain, fs)?,
            curvature_per_m: k,
            rain_duration_s: 0.3,
            frame_s: 1.0 / 60.0,
            frame: 0,
        })
    }

    /// One frame: rain (while it lasts) then [`SurfaceFlow::advance`]. Every cell gets a drop
    /// with probability ¼ per frame, from a hash of (cell, frame) — deterministic.
    pub fn frame(&mut self) -> Result<usize> {
        if (self.frame as f32 * self.frame_s) < self.rain_duration_s {
            let (nx, ny) = self.flow.precipitation.dims();
            let counts: Vec<u32> = (0..nx * ny)
                .map(|c| (splitmix64(((c as u64) << 24) ^ self.frame) & 3 == 0) as u32)
                .collect();
            self.flow.add_hit_counts(&counts)?;
        }
        self.frame += 1;
        self.flow.advance(self.frame_s as f64)
    }

    /// Pool measures against the paraboloid's analytic depth.
    pub fn measure(&self) -> BasinMeasures {
        let sph = &self.flow.sph;
        let s = sph.settings();
        let pos = sph.particles().positions_m();
        let n = pos.len();
        let volume = n as f32 * s.particle_volume_m3();
        let centroid = pos.iter().fold(Vec2::ZERO, |c, p| c + p.truncate()) / n.max(1) as f32;
        let k = self.curvature_per_m;
        let depth = (2.0 * k * volume / std::f32::consts::PI).sqrt();
        let radius = (depth / k).sqrt();
        let in_pool = pos
            .iter()
            .filter(|p| p.truncate().length() <= radius + s.particle_spacing_m)
            .count();
        let surface = self.flow.carpet.surface_height();
        let water = self.flow.carpet.water_depth();
        let mut heights = Vec::new();
        let mut centre_depth = 0.0f32;
        let mut best = f32::INFINITY;
        for (idx, (&z, &d)) in surface.values.iter().zip(&water.values).enumerate() {
            let c = surface.origin_m
                + (Vec2::new((idx % surface.nx) as f32, (idx / surface.nx) as f32) + 0.5)
                    * surface.cell_m;
            if c.length() < best {
                best = c.length();
                centre_depth = d;
            }
            if c.length() <= 0.5 * radius && d > 0.0 {
                heights.push(z);
            }
        }
        let m = heights.iter().sum::<f32>() / heights.len().max(1) as f32;
        let var =
            heights.iter().map(|z| (z - m) * (z - m)).sum::<f32>() / heights.len().max(1) as f32;
        let (lo, hi) = heights
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &z| {
                (a.min(z), b.max(z))
            });
        BasinMeasures {
            particles: n,
            volume_m3: volume,
            centroid_offset_m: centroid.length(),
            expected_depth_m: depth,
            depth_m: centre_depth,
            surface_std_m: var.sqrt(),
            surface_range_m: if heights.is_empty() { 0.0 } else { hi - lo },
            fraction_in_pool: in_pool as f32 / n.max(1) as f32,
        }
    }
}

/// Runs scene `scene` ([`SCENES`]) for `steps` SPH steps and returns its measures as JSON
/// (`rain-composite inspect sph --scene … --steps N --json`); [`validated_steps`] gives the
/// steps that reach the validated states.
pub fn inspect_sph(scene: &str, steps: usize) -> Result<Value> {
    inspect_sph_with(scene, steps, &SceneOptions::default())
}

/// Most solver steps a scene runs: twenty times the longest validated run.
pub const MAX_STEPS: usize = 100_000;

/// [`inspect_sph`] with overrides.
pub fn inspect_sph_with(scene: &str, steps: usize, opts: &SceneOptions) -> Result<Value> {
    inspect_sph_or_stop(
        scene,
        steps,
        opts,
        &std::sync::atomic::AtomicBool::new(false),
    )
}

/// [`inspect_sph_with`], stopping with [`Error::Interrupted`] between two steps once `cancel`
/// is set; more than [`MAX_STEPS`] steps are refused.
pub fn inspect_sph_or_stop(
    scene: &str,
    steps: usize,
    opts: &SceneOptions,
    cancel: &std::sync::atomic::AtomicBool,
) -> Result<Value> {
    if !(1..=MAX_STEPS).contains(&steps) {
        return Err(Error::Parameter {
            name: "inspect.sph.steps",
            value: steps.to_string(),
            expected: format!("1 to {MAX_STEPS}"),
        });
    }
    let check = || {
        if cancel.load(std::sync::atomic::Ordering::Relaxed) {
            Err(Error::Interrupted)
        } else {
            Ok(())
        }
    };
    let started = std::time::Instant::now();
    let mut out = match scene {
        "column" => {
            let mut sph = column(opts)?;
            let mut ke = Vec::new();
            for k in 0..steps {
                check()?;
                sph.step();
                if k % (steps / 20).max(1) == 0 || k + 1 == steps {
                    ke.push(json!([sph.time_s(), sph.kinetic_energy_j()]));
                }
            }
            sph.refresh();
            let escaped = sph
                .particles()
                .positions_m()
                .iter()
                .filter(|p| !sph.boundaries().domain.contains(**p))
                .count();
            json!({
                "hydrostatics": hydrostatics(&sph),
                "kinetic_energy_j": ke,
                "escaped": escaped,
                "ledger": ledger_json(&sph),
                "time_s": sph.time_s(),
                "steps": sph.steps(),
                "particles": sph.particles().len(),
            })
        }
        "dam-break" => {
            let mut db = DamBreak::new(opts)?;
            let mut series = Vec::new();
            let mut worst = 0.0f32;
            let limit = 8.0; // Z beyond which the tank's end wall (10a) interferes.
            for k in 0..steps {
                check()?;
                db.sph.step();
                if k % (steps / 40).max(1) == 0 || k + 1 == steps {
                    let (t, z) = (db.normalised_time(), db.front_m() / db.a_m);
                    let reference = interpolate(&MARTIN_MOYCE_1952, t);
                    if let Some(r) = reference.filter(|&r| r < limit) {
                        worst = worst.max((z - r).abs() / r);
                    }
                    series.push(json!({"T": t, "Z": z, "martin_moyce_Z": reference}));
                }
            }
            json!({
                "a_m": db.a_m,
                "front": series,
                "max_relative_front_error": worst,
                "ledger": ledger_json(&db.sph),
                "kinetic_energy_j": db.sph.kinetic_energy_j(),
                "time_s": db.sph.time_s(),
                "steps": db.sph.steps(),
                "particles": db.sph.particles().len(),
            })
        }
        "basin" => {
            let mut b = Basin::new(opts)?;
            while (b.flow.sph.steps() as usize) < steps {
                check()?;
                b.frame()?;
            }
            json!({
                "pool": b.measure(),
                "ledger": ledger_json(&b.flow.sph),
                "kinetic_energy_j": b.flow.sph.kinetic_energy_j(),
                "time_s": b.flow.sph.time_s(),
                "steps": b.flow.sph.steps(),
                "particles": b.flow.sph.particles().len(),
            })
        }
        other => {
            return Err(Error::Parameter {
                name: "inspect.sph.scene",
                value: other.to_string(),
                expected: format!("one of {}", SCENES.join(", ")),
            });
        }
    };
    out["scene"] = json!(scene);
    out["wall_s"] = json!(started.elapsed().as_secs_f64());
    Ok(out)
}

fn ledger_json(sph: &Muller2003) -> Value {
    let l = sph.ledger();
    json!({
        "inserted": l.inserted,
        "outflow": l.outflow,
        "soaked": l.soaked,
        "discarded": l.discarded,
        "present": sph.particles().len(),
        "balanced": l.present() == sph.particles().len() as u64,
    })
}
