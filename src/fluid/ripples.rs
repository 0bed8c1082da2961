//! Ripples on standing water: each raindrop landing on a puddle starts a ring of
//! capillary–gravity waves (docs/method.md, "Puddles: shading").
//!
//! Linear waves on deep water obey ω² = g k + (σ/ρ) k³ (the depth h enters as tanh(k h): for a
//! 2 mm drop's 8 mm waves it is 0.98 at h = 3 mm and 0.999 from 5 mm, so it is left out). A ring is a narrow band of wavenumbers about the dominant k₀; by stationary phase
//! its envelope travels at the group velocity c_g = dω/dk at k₀ while its crests run through it
//! at the phase velocity ω/k, and it widens as the band disperses (ω″ ≠ 0). Each ring is thus
//! one Gaussian wave packet in the distance r from the impact:
//!
//! η(r, t) = a(t) · exp(−(r − R(t))² / (2 s(t)²)) · cos(k₀ r − ω₀ t),
//!
//! with R(t) = R₀ + c_g t, s(t) = s₀ √(1 + (ω″ t / s₀²)²) (a Gaussian packet's spreading), and
//! a(t) falling as the ring's energy a² · s · R is conserved but for viscous decay: energy of
//! a wave of wavenumber k decays as e^(−4 ν k² t), its amplitude as e^(−2 ν k² t) (Lamb, §348).
//! The surface's slope, not its height, is what the picture shows: [`RingState::slope`].

use glam::DVec2;

use crate::drops::shape::{WATER_DENSITY_KG_PER_M3, WATER_SURFACE_TENSION_N_PER_M};
use crate::fluid::carpet::Field2;
use crate::rain::physics::G_MPS2;
use crate::rain::volume::GroundRect;
use crate::rain::volume::impacts::Impact;
use crate::scene::Camera;

/// Kinematic viscosity of water at 20 °C, m²/s.
pub const WATER_KINEMATIC_VISCOSITY_M2_PER_S: f64 = 1.004e-6;

/// The dominant wavelength of a drop's ring over the drop's diameter. Rain rings are
/// capillary waves a few crater sizes long: 4 D (8 mm for a 2 mm drop) is a look choice.
pub const WAVELENGTH_PER_DIAMETER: f64 = 4.0;

/// The first crest's height over the drop's diameter (a look choice: 0.1 mm for a 2 mm drop,
/// a slope k₀a ≈ 0.08).
pub const AMPLITUDE_PER_DIAMETER: f64 = 0.05;

/// How long a ring is drawn, s: by then viscosity and spreading have flattened a 2 mm drop's
/// ring to a slope below 0.01.
pub const RING_LIFE_S: f64 = 1.5;

/// Most rings drawn in one frame: the newest of those the picture resolves on water
/// ([`rings_on_water`]). The stage culls rings per 8×8-pixel tile, so its cost grows with the rings that
/// reach each tile more than with the count.
pub const MAX_RINGS: usize = 1024;

/// Fewest pixels across a ring's dominant wavelength for it to be drawn on its own: finer
/// crests alias into noise (a 2 mm drop's 8 mm wavelength spans 2 px at about 4 m at 720p
/// with a 60° lens).
pub const MIN_RING_WAVELENGTH_PX: f64 = 2.0;

/// The angular frequency ω (rad/s) of capillary–gravity waves of wavenumber `k` (rad/m) on
/// deep water.
pub fn angular_frequency(k: f64) -> f64 {
    (G_MPS2 * k + tension_over_density() * k.powi(3)).sqrt()
}

/// The group velocity dω/dk (m/s) at wavenumber `k`: (g + 3 (σ/ρ) k²) / (2ω).
pub fn group_velocity(k: f64) -> f64 {
    (G_MPS2 + 3.0 * tension_over_density() * k * k) / (2.0 * angular_frequency(k))
}

/// d²ω/dk² (m²/s) at wavenumber `k`, from differentiating ω² twice: (3 (σ/ρ) k − c_g²) / ω.
pub fn group_velocity_dispersion(k: f64) -> f64 {
    let c_g = group_velocity(k);
    (3.0 * tension_over_density() * k - c_g * c_g) / angular_frequency(k)
}

fn tension_over_density() -> f64 {
    WATER_SURFACE_TENSION_N_PER_M / WATER_DENSITY_KG_PER_M3
}

/// One drop's ring: where and when it started, and its dominant wave.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ring {
    /// Point of impact on the ground plane, m.
    pub centre_m: DVec2,
    /// Time of impact, s.
    pub start_s: f64,
    /// Dominant wavenumber k₀, rad/m.
    pub wavenumber: f64,
    /// Crest height a₀ at the start, m.
    pub amplitude_m: f64,
}

/// A ring at one moment: the packet's parameters, for the surface at any distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RingState {
    /// Distance of the envelope's peak from the centre, m.
    pub radius_m: f64,
    /// The envelope's standard deviation s(t), m.
    pub width_m: f64,
    /// Crest height at the envelope's peak, m.
    pub amplitude_m: f64,
    /// The carrier's phase ω₀ t modulo 2π, rad.
    pub phase: f64,
}

impl Ring {
    /// The ring a drop landing as `impact` starts.
    pub fn from_impact(impact: &Impact) -> Ring {
        let d_m = impact.diameter_mm * 1e-3;
        Ring {
            centre_m: impact.position_m.truncate(),
            start_s: impact.time_s,
            wavenumber: std::f64::consts::TAU / (WAVELENGTH_PER_DIAMETER * d_m),
            amplitude_m: AMPLITUDE_PER_DIAMETER * d_m,
        }
    }

    /// The packet at time `t_s`, or `None` before the impact and after [`RING_LIFE_S`].
    pub fn at(&self, t_s: f64) -> Option<RingState> {
        let age_s = t_s - self.start_s;
        if !(0.0..RING_LIFE_S).contains(&age_s) {
            return None;
        }
        let k = self.wavenumber;
        // The packet starts one wavelength wide and one wavelength out (the crater's rim).
        let s0 = std::f64::consts::TAU / k;
        let r0 = s0;
        let spread = group_velocity_dispersion(k) * age_s / (s0 * s0);
        let width_m = s0 * (1.0 + spread * spread).sqrt();
        let radius_m = r0 + group_velocity(k) * age_s;
        // Energy a²·s·R conserved, amplitude damped by viscosity.
        let decay = (-2.0 * WATER_KINEMATIC_VISCOSITY_M2_PER_S * k * k * age_s).exp();
        let amplitude_m = self.amplitude_m * (s0 * r0 / (width_m * radius_m)).sqrt() * decay;
        Some(RingState {
            radius_m,
            width_m,
            amplitude_m,
            phase: (angular_frequency(k) * age_s).rem_euclid(std::f64::consts::TAU),
        })
    }
}

impl RingState {
    /// The surface height η at distance `r_m` from the centre, m (`k` the ring's wavenumber).
    pub fn height(&self, k: f64, r_m: f64) -> f64 {
        let u = r_m - self.radius_m;
        let envelope = (-0.5 * u * u / (self.width_m * self.width_m)).exp();
        self.amplitude_m * envelope * (k * r_m - self.phase).cos()
    }

    /// dη/dr at distance `r_m`: the envelope's slope and the carrier's.
    pub fn slope(&self, k: f64, r_m: f64) -> f64 {
        let u = r_m - self.radius_m;
        let s2 = self.width_m * self.width_m;
        let envelope = (-0.5 * u * u / s2).exp();
        let carrier = k * r_m - self.phase;
        self.amplitude_m * envelope * (-u / s2 * carrier.cos() - k * carrier.sin())
    }
}

/// Most impacts a feed keeps for the rings ([`keep_resolved_rings`]): enough for the newest
/// [`MAX_RINGS`] on water when the water covers 1/64 of the ground where rings resolve.
pub const RING_POOL: usize = 64 * MAX_RINGS;

/// Whether the ring of `impact` could be drawn on its own in `camera`'s picture: it lands in
/// the picture and its dominant wavelength spans at least [`MIN_RING_WAVELENGTH_PX`] there
/// (λ f / z, the ground's foreshortening left out: it only shrinks crests across the view).
pub fn ring_resolved(impact: &Impact, camera: &Camera) -> bool {
    let p_cam = camera.camera_from_world_point(impact.position_m);
    if p_cam.z <= 0.0 {
        return false;
    }
    // `project_camera`'s arithmetic, its focal length (a tangent) made once for both tests.
    let f = camera.focal_px();
    let wavelength_m = WAVELENGTH_PER_DIAMETER * impact.diameter_mm * 1e-3;
    let fine_enough = wavelength_m * f / p_cam.z >= MIN_RING_WAVELENGTH_PX;
    if !fine_enough {
        return false;
    }
    let px = camera.principal_px() + DVec2::new(p_cam.x, p_cam.y) * (f / p_cam.z);
    px.x >= 0.0 && px.y >= 0.0 && px.x < camera.width_px as f64 && px.y < camera.height_px as f64
}

/// The part of `rect` (ground z = 0) where a ring of a drop up to `max_diameter_mm` can be
/// resolved ([`ring_resolved`]): the bounding box of the rect cut to camera depths
/// z ≤ λ_max f / [`MIN_RING_WAVELENGTH_PX`] (a little more, for rounding). A feed asks the
/// rain for impacts there only, not over the whole simulated ground: the same rings.
pub fn ring_ground(camera: &Camera, rect: &GroundRect, max_diameter_mm: f64) -> GroundRect {
    let z_max = WAVELENGTH_PER_DIAMETER * max_diameter_mm * 1e-3 * camera.focal_px()
        / MIN_RING_WAVELENGTH_PX;
    let z_max = z_max * (1.0 + 1e-6) + 1e-6;
    let corners = [
        rect.min_m,
        DVec2::new(rect.max_m.x, rect.min_m.y),
        rect.max_m,
        DVec2::new(rect.min_m.x, rect.max_m.y),
    ];
    let depth = |p: DVec2| camera.camera_from_world_point(p.extend(0.0)).z;
    // Sutherland–Hodgman against one half-plane: the depth is affine on the ground.
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for k in 0..4 {
        let (a, b) = (corners[k], corners[(k + 1) % 4]);
        let (za, zb) = (depth(a), depth(b));
        if za <= z_max {
            (lo, hi) = (lo.min(a), hi.max(a));
        }
        if (za <= z_max) != (zb <= z_max) {
            let c = a + (b - a) * ((z_max - za) / (zb - za));
            (lo, hi) = (lo.min(c), hi.max(c));
        }
    }
    if lo.x > hi.x {
        return GroundRect {
            min_m: rect.min_m,
            max_m: rect.min_m,
        };
    }
    // Inclusive bounds, so the half-open rect reaches a hair beyond them.
    let pad = DVec2::splat(1e-6);
    GroundRect {
        min_m: (lo - pad).max(rect.min_m),
        max_m: (hi + pad).min(rect.max_m),
    }
}

/// Newest first, ties broken by drop: one order whatever order the impacts came in.
fn newest_first(a: &Impact, b: &Impact) -> std::cmp::Ordering {
    b.time_s
        .total_cmp(&a.time_s)
        .then(a.id.cmp(&b.id))
        .then(a.pass.cmp(&b.pass))
}

/// Adds to `rings` (the impacts a feed keeps for the ripples) those of `hits` that `camera`
/// resolves ([`ring_resolved`]) and keeps the newest [`RING_POOL`] alive at `t_s`: bounded
/// however hard it rains and however long the clip, and the same set whether the impacts
/// came frame by frame or at once (a render or a seek).
pub fn keep_resolved_rings(rings: &mut Vec<Impact>, hits: &[Impact], t_s: f64, camera: &Camera) {
    keep_rings_resolved_by(rings, hits, t_s, |_| *camera);
}

/// [`keep_resolved_rings`] for a camera that moves: each impact judged by `camera_at` its
/// landing time.
pub fn keep_rings_resolved_by(
    rings: &mut Vec<Impact>,
    hits: &[Impact],
    t_s: f64,
    camera_at: impl Fn(f64) -> Camera,
) {
    rings.extend(
        hits.iter()
            .filter(|h| ring_resolved(h, &camera_at(h.time_s))),
    );
    rings.retain(|h| h.time_s > t_s - RING_LIFE_S);
    if rings.len() > RING_POOL {
        rings.sort_by(newest_first);
        rings.truncate(RING_POOL);
    }
}

/// The newest [`MAX_RINGS`] of `rings` that land on water (`water_m`, the shown water depth,
/// > 0 at their point), newest first: the rings the picture draws one by one.
pub fn rings_on_water(rings: &[Impact], water_m: &Field2) -> Vec<Impact> {
    let on_water = |h: &&Impact| {
        let cell =
            ((h.position_m.truncate().as_vec2() - water_m.origin_m) / water_m.cell_m).floor();
        cell.x >= 0.0
            && cell.y >= 0.0
            && (cell.x as usize) < water_m.nx
            && (cell.y as usize) < water_m.ny
            && water_m.values[cell.y as usize * water_m.nx + cell.x as usize] > 0.0
    };
    let mut out: Vec<Impact> = rings.iter().filter(on_water).copied().collect();
    out.sort_by(newest_first);
    out.truncate(MAX_RINGS);
    out
}

/// The rings of `rings` alive at `t_s`, at most [`MAX_RINGS`], newest first.
pub fn live_rings(rings: &[Ring], t_s: f64) -> Vec<Ring> {
    let mut rings: Vec<Ring> = rings
        .iter()
        .filter(|r| r.at(t_s).is_some())
        .copied()
        .collect();
    rings.sort_by(|a, b| b.start_s.total_cmp(&a.start_s));
    rings.truncate(MAX_RINGS);
    rings
}

/// The time-integrated squared slope of one ring, ∫₀^life ∫ |∇η|² dA dt (m²·s), for a drop of
/// `diameter_mm`: a ring's share of the mean square slope of water rained on (see
/// [`rain_slope_variance`]). Midpoint quadrature over its age and over the distance R ± 6 s.
pub fn ring_slope_integral(diameter_mm: f64) -> f64 {
    const AGES: usize = 300;
    const RADII: usize = 400;
    let ring = Ring::from_impact(&Impact {
        id: 0,
        pass: 0,
        time_s: 0.0,
        position_m: glam::DVec3::ZERO,
        diameter_mm,
        velocity_mps: glam::DVec3::ZERO,
    });
    let dt = RING_LIFE_S / AGES as f64;
    (0..AGES)
        .filter_map(|i| ring.at((i as f64 + 0.5) * dt))
        .map(|state| {
            let (lo, hi) = (
                (state.radius_m - 6.0 * state.width_m).max(0.0),
                state.radius_m + 6.0 * state.width_m,
            );
            let dr = (hi - lo) / RADII as f64;
            let area_integral: f64 = (0..RADII)
                .map(|j| {
                    let r = lo + (j as f64 + 0.5) * dr;
                    state.slope(ring.wavenumber, r).powi(2) * std::f64::consts::TAU * r * dr
                })
                .sum();
            area_integral * dt
        })
        .sum()
}

/// The mean square slope ⟨|∇η|²⟩ of water on which `flux_per_m2_s` drops land per m²·s with
/// diameters of quantiles `diameters_mm` (equally likely, e.g. flux-weighted quantiles): by
/// Campbell's theorem, rings started at the points of a Poisson process in space and time sum
/// to a field whose mean square slope is the rate times one ring's ∫∫ |∇η|² dA dt — the
/// energy balance of the rings (impacts per m²·s × a ring's slope energy × its damping time).
/// What the far water shows where single rings are finer than a pixel.
pub fn rain_slope_variance(flux_per_m2_s: f64, diameters_mm: &[f64]) -> f64 {
    if diameters_mm.is_empty() {
        return 0.0;
    }
    let mean: f64 = diameters_mm
        .iter()
        .map(|&d| ring_slope_integral(d))
        .sum::<f64>()
        / diameters_mm.len() as f64;
    flux_per_m2_s * mean
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plain form of [`ring_resolved`]: the camera's own projection, then both tests.
    fn ring_resolved_plain(impact: &Impact, camera: &Camera) -> bool {
        let p_cam = camera.camera_from_world_point(impact.position_m);
        let Some(px) = camera.project_camera(p_cam) else {
            return false;
        };
        let inside = px.x >= 0.0
            && px.y >= 0.0
            && px.x < camera.width_px as f64
            && px.y < camera.height_px as f64;
        let wavelength_m = WAVELENGTH_PER_DIAMETER * impact.diameter_mm * 1e-3;
        inside && wavelength_m * camera.focal_px() / p_cam.z >= MIN_RING_WAVELENGTH_PX
    }

    /// Whether a ring is resolved agrees with the plain form on drops in front of, beside and
    /// behind cameras of several lenses and tilts, near and far, small and large (both answers
    /// occur).
    #[test]
    fn ring_resolved_is_its_plain_form() {
        let mut rng = crate::rng::SplitMix64(17);
        let (mut yes, mut no) = (0, 0);
        for k in 0..40 {
            let cam = Camera::new(
                320 + 8 * k,
                240,
                0.4 + 2.0 * rng.next_f64(),
                0.5 + 2.0 * rng.next_f64(),
                -0.2 - 0.8 * rng.next_f64(),
                0.0,
            );
            for _ in 0..2000 {
                let impact = Impact {
                    id: 0,
                    pass: 0,
                    time_s: 0.0,
                    position_m: glam::DVec3::new(
                        8.0 * rng.next_f64() - 4.0,
                        12.0 * rng.next_f64() - 2.0,
                        0.0,
                    ),
                    diameter_mm: 0.2 + 5.0 * rng.next_f64(),
                    velocity_mps: glam::DVec3::ZERO,
                };
                let plain = ring_resolved_plain(&impact, &cam);
                assert_eq!(ring_resolved(&impact, &cam), plain, "{impact:?} {cam:?}");
                (yes, no) = if plain { (yes + 1, no) } else { (yes, no + 1) };
            }
        }
        assert!(yes > 1000 && no > 1000, "{yes} {no}");
    }

    #[test]
    fn capillary_and_gravity_waves_meet_at_the_slowest_phase_speed() {
        // c_p = ω/k is least at k_m = √(ρg/σ), where it equals c_g (≈ 0.23 m/s, λ ≈ 1.7 cm).
        let k_m = (G_MPS2 / tension_over_density()).sqrt();
        let c_p = angular_frequency(k_m) / k_m;
        assert!((c_p - group_velocity(k_m)).abs() < 1e-12);
        assert!((c_p - 0.231).abs() < 0.002, "{c_p}");
        assert!((std::f64::consts::TAU / k_m - 0.0172).abs() < 2e-4);
        // dω/dk and d²ω/dk² against central differences.
        for k in [50.0, 400.0, 2000.0] {
            let h = 1e-3 * k;
            let fd = (angular_frequency(k + h) - angular_frequency(k - h)) / (2.0 * h);
            let fd2 = (group_velocity(k + h) - group_velocity(k - h)) / (2.0 * h);
            assert!((group_velocity(k) - fd).abs() < 1e-6 * fd.abs(), "{k}");
            assert!(
                (group_velocity_dispersion(k) - fd2).abs() < 1e-5 * fd2.abs(),
                "{k}"
            );
        }
    }

    #[test]
    fn rained_on_water_has_the_mean_square_slope_of_campbells_theorem() {
        // Brute force: rings of 2 mm drops at random points of a 1.2 m square (periodic, wider
        // than the oldest ring)
        // over the last ring life, the slope summed at sample points at t, its square averaged.
        use crate::rain::volume::pcg_hash;
        let (side_m, flux, d_mm) = (1.2, 3000.0, 2.0);
        let unit = |i: u32| (pcg_hash(i) >> 8) as f64 / 16_777_216.0;
        let n = (flux * side_m * side_m * RING_LIFE_S) as u32;
        let t = RING_LIFE_S;
        let rings: Vec<Ring> = (0..n)
            .map(|i| {
                Ring::from_impact(&Impact {
                    id: 0,
                    pass: 0,
                    time_s: unit(3 * i) * RING_LIFE_S,
                    position_m: glam::DVec3::new(
                        unit(3 * i + 1) * side_m,
                        unit(3 * i + 2) * side_m,
                        0.0,
                    ),
                    diameter_mm: d_mm,
                    velocity_mps: glam::DVec3::ZERO,
                })
            })
            .collect();
        let (mut sum, mut count) = (0.0, 0);
        for j in 0..2000u32 {
            let p = DVec2::new(unit(1_000_000 + 2 * j), unit(1_000_001 + 2 * j)) * side_m;
            let mut g = DVec2::ZERO;
            for ring in &rings {
                let Some(state) = ring.at(t) else { continue };
                // The nearest periodic image of the centre.
                let mut off = p - ring.centre_m;
                off -= (off / side_m).round() * side_m;
                let r = off.length();
                if r > 1e-9 {
                    g += off / r * state.slope(ring.wavenumber, r);
                }
            }
            sum += g.length_squared();
            count += 1;
        }
        let brute = sum / count as f64;
        let want = rain_slope_variance(flux, &[d_mm]);
        eprintln!("{n} rings: mean square slope {brute:.3e}, Campbell {want:.3e}");
        assert!((brute / want - 1.0).abs() < 0.15, "{brute} vs {want}");
    }
}
