//! The SPH solver of Müller, Charypar & Gross (2003), as the thesis's Algorithm 2 (§5.3.1).
//!
//! How it works, per step (kick–drift–kick leapfrog, i.e. velocity Verlet):
//! 1. kick: v ← v + ½δt·a;  drift: x ← x + δt·v;  collide with walls and terrain (§5.3.1);
//!    remove particles that left through open faces or soaked in; insert queued particles.
//! 2. Neighbour search (counting sort into cells of edge h/2, [`super::grid`]); particles are
//!    reordered by cell.
//! 3. Density (5.18) ρᵢ = (m/S₀) Σⱼ W(rᵢⱼ), self term and wall ghosts ([`super::boundary`])
//!    included; pressure from the equation of state ([`super::EquationOfState`]; (5.19) with a
//!    stiffness from c ≥ 10·v_max, not k = 3).
//! 4. Surface particles: the highest particle of each column of the particle spacing, as the
//!    thesis does with the carpet cells instead of Müller's |∇c| threshold.
//! 5. Accelerations (5.26): pressure (5.20) in its symmetric form
//!    −(1/G₁) Σⱼ m (pᵢ/ρᵢ² + pⱼ/ρⱼ²) ∇W_spiky, viscosity (5.21) (μ/ρᵢ)(1/L₂) Σⱼ Vⱼ(vⱼ − vᵢ)∇²W_visc,
//!    surface tension (5.23–5.25) on surface particles, gravity (5.22).
//! 6. kick: v ← v + ½δt·a.
//!
//! Deviations from the thesis and the paper, each measured on the 2 000-particle column:
//! - **Integrator.** (5.27) kicks by δt/2 but drifts by δt, so each step applies half the force
//!   (gravity, pressure, viscosity). We use kick–drift–kick leapfrog: second order, symplectic
//!   for conservative forces, one force evaluation per step.
//! - **One kernel for density and pressure: spiky.** Müller's poly6 density with a spiky
//!   pressure gradient is not the gradient of any energy: at the stiffness that keeps density
//!   errors near 1 %, an inviscid resting column gained energy without bound (kinetic energy
//!   ×100 in 0.3 s), and with viscosity it settled at 48–99 % of ρgh depending on the particle
//!   arrangement. Poly6 for both is conservative, but its gradient vanishes at r → 0: 83 % of
//!   the particles collapsed into coincident pairs. Spiky for both is conservative, repels at
//!   short range, and its lattice sums agree across cubic, fcc and bcc packings to 0.2 %.
//!   Poly6 stays for the colour field (5.23) and the viscosity kernel for (5.21).
//! - **Lattice normalisation.** Spiky's cusp makes its lattice sum S₀ = 1.24/Δx³ at h = 2Δx
//!   (the continuum integral is 1), and the gradient and Laplacian moments G₁, L₂ are off too.
//!   Dividing by these constants (`LatticeMoments`) makes a lattice at spacing Δx have
//!   ρ = m/Δx³ and the discrete gradient exact for linear fields, so a resting column holds
//!   p = ρ₀g·depth; constants keep the force the gradient of an energy.
//! - **Pressure average.** (5.20) averages (pᵢ + pⱼ)/2; since Σⱼ Vⱼ∇Wᵢⱼ → 0 inside the fluid its
//!   continuum limit is ½∇p (a column would settle at 2ρgh). The symmetric form above has
//!   limit ∇p and conserves momentum.
//! - **Surface tension.** (5.25) as printed, −σκ n/|n| with n pointing into the fluid and
//!   κ = −∇²c/|n| (5.24), pushes a convex drop outward. We use Müller's eq. 19,
//!   f = −σ ∇²c · n/|n|, which pulls it inward.
//! - **Boundaries.** Walls and terrain act through mirror ghosts as well as collisions (see
//!   [`super::boundary`]); the thesis only collides, which leaves particles at walls with half
//!   their neighbours.
//! - **Viscosity is required.** Even conservative, weakly compressible SPH needs some
//!   dissipation; [`SphSettings::water`] sets μ = ρ₀αhc/10 with α = 0.05 (Monaghan's artificial
//!   viscosity), about 500 times water's at 5 mm spacing.
//!
//! Time step ([`TimeStep::Adaptive`]): δt = min(λ h/(c + v_max), 0.25 √(h/a_max),
//! 0.125 h²ρ₀/μ) — the sound-speed (CFL), force and viscous limits (Monaghan 1992; Müller 2003).
//!
//! Determinism: particles are reordered by cell at every step, each particle's sums run over
//! its neighbours in that fixed order, and the only parallel reductions are maxima, so the state
//! after N steps is bit-identical whatever the number of rayon threads.

use super::boundary::{Boundaries, Fate, Mirrors};
use super::grid::{NeighbourLists, UniformGrid};
use super::kernels::LatticeMoments;
use super::particles::{Particles, PermuteScratch};
use super::resting::RestingWater;
use super::settings::{DEFAULT_COURANT, SphSettings, TimeStep};
use super::sources::{Emitter, MassLedger, NewParticle, unit_from_hash};
use super::terrain::TerrainSample;
use crate::{Error, Result};
use glam::Vec3;
use rayon::prelude::*;

#[path = "sph_passes.rs"]
mod passes;

/// Smallest number of particles a rayon task handles.
const MIN_TASK: usize = 128;

/// The SPH solver (thesis Algorithm 2).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Muller2003 {
    settings: SphSettings,
    moments: LatticeMoments,
    boundaries: Boundaries,
    particles: Particles,
    /// Water placed at rest, never stepped ([`super::resting`]).
    #[serde(default)]
    resting: RestingWater,
    // Scratch, rebuilt before each use: left out of checkpoints.
    #[serde(skip)]
    grid: UniformGrid,
    #[serde(skip)]
    permute_scratch: PermuteScratch,
    #[serde(skip)]
    neighbours: NeighbourLists,
    /// Each particle's neighbours among the water at rest, from the density pass for the
    /// force pass (the same positions: the same list, one search a step fewer).
    #[serde(skip)]
    rest_neighbours: NeighbourLists,
    /// The force pass makes its mirrors and searches the water at rest again instead of
    /// reading `mirrors` and `rest_neighbours`: the plain form they are tested against.
    #[serde(skip)]
    plain_force_inputs: bool,
    #[serde(skip)]
    pair_terms: Vec<[f32; 2]>,
    #[serde(skip)]
    column_best: Vec<u32>,
    /// Whether resting water lies above the particle in its column (it is no surface).
    #[serde(skip)]
    covered: Vec<bool>,
    /// Each particle's mirrors, from the density pass (which reads only their points, the
    /// same whatever the ghosts' friction) for the force pass.
    #[serde(skip)]
    mirrors: Vec<Mirrors>,
    /// The terrain under each particle, from the density pass for the force pass (the same
    /// positions: one terrain read a pass fewer).
    #[serde(skip)]
    ground: Vec<Option<TerrainSample>>,
    /// The terrain the drift read under each particle where it ended (`None`: not read),
    /// from the drift to the next force computation, which takes it instead of reading it
    /// again (the same point: the same bits).
    #[serde(skip)]
    drift_ground: Vec<Option<TerrainSample>>,
    #[serde(skip)]
    keep: Vec<bool>,
    #[serde(skip)]
    fate: Vec<u8>,
    emitters: Vec<Emitter>,
    pending: Vec<NewParticle>,
    ledger: MassLedger,
    time_s: f64,
    steps: u64,
    next_id: u64,
    forces_current: bool,
    last_dt_s: f32,
}

const KEEP: u8 = 0;
const OUTFLOW: u8 = 1;
const SOAKED: u8 = 2;
const INVALID: u8 = 3;

impl Muller2003 {
    /// A solver with no particles.
    pub fn new(settings: SphSettings, boundaries: Boundaries) -> Result<Muller2003> {
        settings.validate()?;
        boundaries.domain.validate()?;
        Ok(Muller2003 {
            settings,
            moments: LatticeMoments::new(settings.particle_spacing_m, settings.smoothing_length_m),
            boundaries,
            particles: Particles::default(),
            resting: RestingWater::default(),
            grid: UniformGrid::new(),
            permute_scratch: PermuteScratch::default(),
            neighbours: NeighbourLists::default(),
            rest_neighbours: NeighbourLists::default(),
            plain_force_inputs: false,
            pair_terms: Vec::new(),
            column_best: Vec::new(),
            covered: Vec::new(),
            mirrors: Vec::new(),
            ground: Vec::new(),
            drift_ground: Vec::new(),
            keep: Vec::new(),
            fate: Vec::new(),
            emitters: Vec::new(),
            pending: Vec::new(),
            ledger: MassLedger::default(),
            time_s: 0.0,
            steps: 0,
            next_id: 0,
            forces_current: false,
            last_dt_s: 0.0,
        })
    }

    /// The settings.
    pub fn settings(&self) -> &SphSettings {
        &self.settings
    }

    /// The box and terrain.
    pub fn boundaries(&self) -> &Boundaries {
        &self.boundaries
    }

    /// Swaps the terrain: how a solver restored from a checkpoint (which does not hold it)
    /// gets it back from a fresh one.
    pub(crate) fn replace_terrain(
        &mut self,
        terrain: Option<super::terrain::HeightField>,
    ) -> Option<super::terrain::HeightField> {
        std::mem::replace(&mut self.boundaries.terrain, terrain)
    }

    /// The particles (in grid order, which changes every step; follow `ids`).
    pub fn particles(&self) -> &Particles {
        &self.particles
    }

    /// The water held at rest (not stepped).
    pub fn resting(&self) -> &RestingWater {
        &self.resting
    }

    /// All particles: moving and at rest.
    pub fn particle_count(&self) -> usize {
        self.particles.len() + self.resting.len()
    }

    /// Every particle's position, moving ones first, m.
    pub fn all_positions_m(&self) -> impl Iterator<Item = &Vec3> {
        self.particles
            .position_m
            .iter()
            .chain(self.resting.positions_m())
    }

    /// Particle counts in and out.
    pub fn ledger(&self) -> MassLedger {
        self.ledger
    }

    /// Simulated time, s.
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The last step's δt, s (0 before the first step).
    pub fn last_time_step_s(&self) -> f32 {
        self.last_dt_s
    }

    /// The emitters.
    pub fn emitters(&self) -> &[Emitter] {
        &self.emitters
    }

    /// Adds a source that emits during each step.
    pub fn add_emitter(&mut self, emitter: Emitter) {
        self.emitters.push(emitter);
    }

    fn push_particle(&mut self, position_m: Vec3, velocity_mps: Vec3) {
        let id = self.next_id;
        self.next_id += 1;
        // Spread the soak accumulators so a wet layer does not soak in all at once.
        let soaked = unit_from_hash(id ^ 0x5EED) * self.settings.particle_volume_m3();
        self.particles.push(position_m, velocity_mps, id, soaked);
        self.ledger.inserted += 1;
        self.forces_current = false;
    }

    /// Adds one particle now. It must be finite and inside the box.
    pub fn add_particle(&mut self, position_m: Vec3, velocity_mps: Vec3) -> Result<()> {
        let valid = position_m.is_finite()
            && velocity_mps.is_finite()
            && self.boundaries.domain.contains(position_m);
        if !valid {
            return Err(Error::Parameter {
                name: "sph.particle",
                value: format!("at {position_m} moving {velocity_mps}"),
                expected: "a finite position inside the simulation box and a finite velocity"
                    .into(),
            });
        }
        self.push_particle(position_m, velocity_mps);
        Ok(())
    }

    /// Adds one particle held at rest from now on ([`super::resting`]): the moving water meets
    /// it, it never moves; it soaks in if it touches the terrain. It must be finite and inside
    /// the box.
    pub fn add_resting_particle(&mut self, position_m: Vec3) -> Result<()> {
        if !(position_m.is_finite() && self.boundaries.domain.contains(position_m)) {
            return Err(Error::Parameter {
                name: "sph.resting_particle",
                value: format!("at {position_m}"),
                expected: "a finite position inside the simulation box".into(),
            });
        }
        let id = self.next_id;
        self.next_id += 1;
        let s = &self.settings;
        let soaked = unit_from_hash(id ^ 0x5EED) * s.particle_volume_m3();
        // The contact rule of the step's infiltration.
        let contact = self.boundaries.terrain.as_ref().is_some_and(|t| {
            let ts = t.sample(position_m.x, position_m.y);
            (position_m.z - ts.height_m) * ts.normal.z < 0.75 * s.particle_spacing_m
        });
        self.resting.push(position_m, id, soaked, contact);
        self.ledger.inserted += 1;
        self.forces_current = false;
        Ok(())
    }

    /// Fills the box `min_m..max_m` with a cubic lattice at the particle spacing (first layer
    /// half a spacing in from `min_m`), skipping points outside the domain or below the
    /// terrain. Returns the number added.
    pub fn add_block(&mut self, min_m: Vec3, max_m: Vec3, velocity_mps: Vec3) -> Result<usize> {
        let dx = self.settings.particle_spacing_m;
        let counts = ((max_m - min_m) / dx).floor();
        let valid = min_m.is_finite()
            && max_m.is_finite()
            && velocity_mps.is_finite()
            && counts.is_finite()
            && counts.min_element() >= 0.0
            && counts.x as f64 * counts.y as f64 * counts.z as f64 <= (1u64 << 26) as f64;
        if !valid {
            return Err(Error::Parameter {
                name: "sph.block",
                value: format!("{min_m} .. {max_m}"),
                expected: "a finite box of at most 2²⁶ particles".into(),
            });
        }
        let (nx, ny, nz) = (counts.x as usize, counts.y as usize, counts.z as usize);
        let mut added = 0;
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let p = min_m + (Vec3::new(i as f32, j as f32, k as f32) + 0.5) * dx;
                    if self.boundaries.domain.contains(p)
                        && p.z >= self.boundaries.ground_m(p.x, p.y)
                    {
                        self.push_particle(p, velocity_mps);
                        added += 1;
                    }
                }
            }
        }
        Ok(added)
    }

    /// Queues particles for insertion at the next step (after its drift). They must be finite.
    pub fn queue(&mut self, particles: &[NewParticle]) -> Result<()> {
        if let Some(bad) = particles
            .iter()
            .find(|p| !(p.position_m.is_finite() && p.velocity_mps.is_finite()))
        {
            return Err(Error::Parameter {
                name: "sph.new_particle",
                value: format!("{bad:?}"),
                expected: "finite position and velocity".into(),
            });
        }
        self.pending.extend_from_slice(particles);
        Ok(())
    }

    /// Recomputes densities, pressures, surface flags and accelerations at the current state
    /// (done automatically by [`Muller2003::step`]; call it to measure a freshly built scene).
    pub fn refresh(&mut self) {
        self.compute_forces();
    }

    /// Advances by one step; returns δt, s.
    pub fn step(&mut self) -> f32 {
        self.step_at_most(f32::INFINITY)
    }

    fn step_at_most(&mut self, max_dt_s: f32) -> f32 {
        if !self.forces_current {
            self.compute_forces();
        }
        let dt = self.next_time_step_s().min(max_dt_s);
        let half = 0.5 * dt;
        {
            let Particles {
                position_m,
                velocity_mps,
                acceleration_mps2,
                soaked_m3,
                ..
            } = &mut self.particles;
            let s = &self.settings;
            let bounds = &self.boundaries;
            let damping = s.collision_damping;
            let max_push = 0.5 * s.particle_spacing_m;
            let soak_per_step = s.infiltration_rate_mps * dt * s.particle_spacing_m.powi(2);
            let volume = s.particle_volume_m3();
            let contact = 0.75 * s.particle_spacing_m;
            self.fate.clear();
            self.fate.resize(position_m.len(), KEEP);
            self.drift_ground.clear();
            self.drift_ground.resize(position_m.len(), None);
            position_m
                .par_iter_mut()
                .zip(velocity_mps.par_iter_mut())
                .zip(acceleration_mps2.par_iter())
                .zip(soaked_m3.par_iter_mut())
                .zip(self.fate.par_iter_mut())
                .zip(self.drift_ground.par_iter_mut())
                .with_min_len(MIN_TASK)
                .for_each(|(((((x, v), a), soaked), fate), known)| {
                    // Kick, drift (leapfrog KDK, first half), collide (§5.3.1).
                    *v += *a * half;
                    *x += *v * dt;
                    let mut sampled = None;
                    *fate = match bounds.collide_sampled(x, v, damping, max_push, &mut sampled) {
                        Fate::Stays => KEEP,
                        Fate::Leaves => OUTFLOW,
                        Fate::Invalid => INVALID,
                    };
                    // The collision's terrain read, unless a wall moved x or y (the same
                    // bits either way: the same point).
                    let at = x.truncate().to_array().map(f32::to_bits);
                    *known = match sampled {
                        Some((xy, ts)) if xy.to_array().map(f32::to_bits) == at => Some(ts),
                        _ => None,
                    };
                    if *fate == KEEP && soak_per_step > 0.0 {
                        if let Some(t) = &bounds.terrain {
                            let ts = known.unwrap_or_else(|| t.sample(x.x, x.y));
                            *known = Some(ts);
                            if (x.z - ts.height_m) * ts.normal.z < contact {
                                *soaked += soak_per_step;
                                if *soaked >= volume {
                                    *fate = SOAKED;
                                }
                            }
                        }
                    }
                });
        }
        self.remove_marked();
        if self.boundaries.terrain.is_some() {
            let s = &self.settings;
            let per_particle = s.infiltration_rate_mps * dt * s.particle_spacing_m.powi(2);
            let gone = self.resting.soak(per_particle, s.particle_volume_m3());
            if gone > 0 {
                self.ledger.soaked += gone;
                self.forces_current = false;
            }
        }
        for e in &mut self.emitters {
            e.emit(dt, &mut self.pending);
        }
        self.insert_pending();
        self.time_s += dt as f64;
        self.compute_forces();
        let Particles {
            velocity_mps,
            acceleration_mps2,
            ..
        } = &mut self.particles;
        velocity_mps
            .par_iter_mut()
            .zip(acceleration_mps2.par_iter())
            .with_min_len(MIN_TASK)
            .for_each(|(v, a)| *v += *a * half);
        self.steps += 1;
        self.last_dt_s = dt;
        dt
    }

    /// Steps until `duration_s` more has been simulated (the last step is shortened to land on
    /// it); returns the number of steps.
    pub fn advance(&mut self, duration_s: f64) -> Result<usize> {
        if !(duration_s.is_finite() && duration_s >= 0.0) {
            return Err(Error::Parameter {
                name: "sph.duration_s",
                value: duration_s.to_string(),
                expected: "a finite duration ≥ 0".into(),
            });
        }
        let end = self.time_s + duration_s;
        let mut n = 0;
        while self.time_s < end - 1e-9 {
            self.step_at_most((end - self.time_s) as f32);
            n += 1;
        }
        Ok(n)
    }

    fn remove_marked(&mut self) {
        if self.fate.iter().all(|&f| f == KEEP) {
            return;
        }
        self.keep.clear();
        for &f in &self.fate {
            self.keep.push(f == KEEP);
            match f {
                OUTFLOW => self.ledger.outflow += 1,
                SOAKED => self.ledger.soaked += 1,
                INVALID => self.ledger.discarded += 1,
                _ => {}
            }
        }
        self.particles.retain(&self.keep);
        if self.drift_ground.len() == self.keep.len() {
            let mut w = 0;
            for r in 0..self.keep.len() {
                if self.keep[r] {
                    self.drift_ground[w] = self.drift_ground[r];
                    w += 1;
                }
            }
            self.drift_ground.truncate(w);
        }
    }

    fn insert_pending(&mut self) {
        let pending = std::mem::take(&mut self.pending);
        let max_push = 0.5 * self.settings.particle_spacing_m;
        for p in &pending {
            let (mut x, mut v) = (p.position_m, p.velocity_mps);
            let damping = self.settings.collision_damping;
            match self.boundaries.collide(&mut x, &mut v, damping, max_push) {
                Fate::Stays => self.push_particle(x, v),
                // Born outside the box: in and straight out again, so the ledger stays exact.
                Fate::Leaves => {
                    self.ledger.inserted += 1;
                    self.ledger.outflow += 1;
                }
                Fate::Invalid => {
                    self.ledger.inserted += 1;
                    self.ledger.discarded += 1;
                }
            }
        }
        self.pending = pending;
        self.pending.clear();
    }

    /// The adaptive step limit at the current state, s: min(λh/(c + v_max), 0.25√(h/a_max),
    /// 0.125h²ρ₀/μ), with λ the configured Courant number (0.4 under a fixed step).
    pub fn stable_time_step_s(&self) -> f32 {
        let s = &self.settings;
        let courant = match s.time_step {
            TimeStep::Adaptive { courant, .. } => courant,
            TimeStep::Fixed { .. } => DEFAULT_COURANT,
        };
        let h = s.smoothing_length_m;
        let v_max = self.max_speed_mps();
        let a_max = self
            .particles
            .acceleration_mps2
            .par_iter()
            .with_min_len(4 * MIN_TASK)
            .map(|a| a.length())
            .reduce(|| 0.0, f32::max);
        let mut dt = courant * h / (s.eos.sound_speed_mps() + v_max);
        if a_max > 0.0 {
            dt = dt.min(0.25 * (h / a_max).sqrt());
        }
        if s.viscosity_pa_s > 0.0 {
            dt = dt.min(0.125 * h * h * s.rest_density_kg_m3 / s.viscosity_pa_s);
        }
        dt
    }

    fn next_time_step_s(&self) -> f32 {
        match self.settings.time_step {
            TimeStep::Fixed { dt_s } => dt_s,
            TimeStep::Adaptive { max_s, .. } => self.stable_time_step_s().min(max_s),
        }
    }

    /// The gravity ramp at the current time: ½(1 − cos(π t/T)) for t < T, else 1.
    pub fn gravity_factor(&self) -> f32 {
        let ramp = self.settings.gravity_ramp_s as f64;
        if self.time_s >= ramp {
            1.0
        } else {
            (0.5 * (1.0 - (std::f64::consts::PI * self.time_s / ramp).cos())) as f32
        }
    }

    /// Largest particle speed, m/s.
    pub fn max_speed_mps(&self) -> f32 {
        self.particles
            .velocity_mps
            .par_iter()
            .with_min_len(4 * MIN_TASK)
            .map(|v| v.length())
            .reduce(|| 0.0, f32::max)
    }

    /// Total kinetic energy ½Σ m v², J (serial sum in f64, deterministic).
    pub fn kinetic_energy_j(&self) -> f64 {
        let m = self.settings.particle_mass_kg as f64;
        0.5 * m
            * self
                .particles
                .velocity_mps
                .iter()
                .map(|v| v.length_squared() as f64)
                .sum::<f64>()
    }

    /// A 64-bit digest of every particle's position, velocity and id bits, and of the clock:
    /// equal digests mean (barring collisions) bit-identical states.
    pub fn state_digest(&self) -> u64 {
        let mut h = 0xCBF2_9CE4_8422_2325u64;
        let mut eat = |x: u64| {
            h ^= x;
            h = h.wrapping_mul(0x0000_0100_0000_01B3).rotate_left(29);
        };
        eat(self.time_s.to_bits());
        for ((p, v), id) in self
            .particles
            .position_m
            .iter()
            .zip(&self.particles.velocity_mps)
            .zip(&self.particles.id)
        {
            for c in p.to_array().into_iter().chain(v.to_array()) {
                eat(c.to_bits() as u64);
            }
            eat(*id);
        }
        self.resting.digest(&mut eat);
        h
    }

    fn compute_forces(&mut self) {
        self.forces_current = true;
        if self.particles.is_empty() {
            return;
        }
        let h = self.settings.smoothing_length_m;
        let budget = 64 * self.particles.len() + (1 << 16);
        self.grid
            .rebuild_often(&self.particles.position_m, h, 0.5 * h, budget);
        self.particles
            .permute(self.grid.order(), &mut self.permute_scratch);
        // The drift's terrain reads in the new order; particles inserted since (at the end)
        // and a computation without a drift before it read theirs in the density pass.
        let n = self.particles.len();
        self.drift_ground.resize(n, None);
        self.ground.clear();
        self.ground.extend(
            self.grid
                .order()
                .iter()
                .map(|&k| self.drift_ground[k as usize]),
        );
        self.drift_ground.clear();
        self.resting
            .prepare(&self.settings, &self.moments, &self.boundaries);
        self.density_pass();
        self.surface_pass();
        self.force_pass();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fluid::boundary::Domain;
    use crate::fluid::terrain::HeightField;
    use glam::Vec2;

    /// A film running over water at rest on a sloped, bumpy ground with friction: the force
    /// pass reading the density pass's mirrors and neighbours at rest gives the state its plain
    /// form (mirrors made again, the water at rest searched again) gives, bit for bit — where a
    /// particle's list overflows (water at rest packed at half the spacing) too.
    #[test]
    fn kept_force_inputs_are_the_plain_ones() {
        let dx = 0.005;
        let terrain = HeightField::from_fn(31, 31, Vec2::ZERO, 0.005, |x, y| {
            0.01 + 0.05 * x + 0.002 * (40.0 * y).sin()
        })
        .expect("terrain");
        let mut s = SphSettings::water(dx, 0.02);
        s.ground_friction = 0.3;
        s.infiltration_rate_mps = 0.0;
        let bounds = Boundaries {
            domain: Domain::open_sides(Vec3::ZERO, Vec3::new(0.15, 0.15, 0.1)),
            terrain: Some(terrain.clone()),
        };
        let mut kept = Muller2003::new(s, bounds).expect("solver");
        let mut rng = crate::rng::SplitMix64(3);
        for j in 0..24 {
            for i in 0..24 {
                let (x, y) = (0.01 + i as f32 * dx, 0.01 + j as f32 * dx);
                let z = terrain.height_at_m(x, y) + 0.5 * dx;
                // Packed twice as densely in one corner: more neighbours than a list holds.
                let dense = i < 6 && j < 6;
                for k in 0..if dense { 16 } else { 1 } {
                    let off =
                        0.5 * dx * Vec3::new((k % 2) as f32, (k / 2 % 2) as f32, (k / 4) as f32);
                    kept.add_resting_particle(Vec3::new(x, y, z) + off)
                        .expect("inside");
                }
            }
        }
        // Over the water at rest, and on the bare ground beside it (ghosts in reach).
        for k in 0..200 {
            let (x, y) = (
                0.01 + 0.1 * rng.next_f64() as f32,
                0.01 + 0.1 * rng.next_f64() as f32,
            );
            let (x, lift) = if k % 4 == 0 {
                (0.127 + 0.015 * rng.next_f64() as f32, 0.3)
            } else {
                (x, 1.5)
            };
            let z = terrain.height_at_m(x, y) + dx * (lift + 0.6 * rng.next_f64() as f32);
            kept.add_particle(Vec3::new(x, y, z), Vec3::new(0.1, -0.05, 0.0))
                .expect("inside");
        }
        let mut plain = kept.clone();
        plain.plain_force_inputs = true;
        let mut overflowed = false;
        for step in 0..30 {
            kept.step();
            plain.step();
            let cap = kept.rest_neighbours.capacity;
            overflowed |= kept.rest_neighbours.count.iter().any(|&c| c as usize > cap);
            let bits = |m: &Muller2003| {
                m.particles()
                    .accelerations_mps2()
                    .iter()
                    .map(|a| a.to_array().map(f32::to_bits))
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(&kept), bits(&plain), "step {step}");
            assert_eq!(kept.state_digest(), plain.state_digest(), "step {step}");
        }
        assert!(overflowed, "no list overflowed");
        assert!(kept.particles().len() > 100, "the film left");
    }
}
