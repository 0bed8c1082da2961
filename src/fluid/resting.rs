//! Water at rest: particles placed settled (the depressions' fill) that the solver does not
//! integrate — the moving water meets them as fluid (density, pressure, viscosity against a
//! body at rest), they never move.
//!
//! Why: water filled into a relief by priority flood ([`crate::fluid::puddles::fill`]) stands
//! level in its hollows by construction. Integrating it costs every particle every sound-speed
//! step (some 30 steps a frame), and over a clip it only settles by its own weak
//! compressibility (ρgh/c² ≤ 0.5 % at the solver's stiffness) and jitters at the lattice
//! scale. Placed at rest, it costs one density sum at the start; only the water that moves
//! (the rain's particles) is stepped.
//!
//! How it works: the particles are sorted once into a [`UniformGrid`] (cells of h/2, reused
//! for every step and rebuilt only when one soaks in). Each one's density is its SPH sum
//! (5.18) over resting neighbours and their wall ghosts, as the solver's density pass does;
//! its pressure follows from the equation of state (≈ 0 on the lattice, which is at ρ₀), so
//! the water resting on it is held up by its own pressure, as at a free surface. Particles
//! that touch the ground when placed soak in at the infiltration rate as moving ones do: all
//! share one clock of soaked volume, and each leaves when its own offset (spread as moving
//! particles' are) plus the clock reaches a particle's volume.

use super::boundary::Boundaries;
use super::grid::UniformGrid;
use super::kernels::{Kernel, LatticeMoments, Spiky};
use super::settings::SphSettings;
use glam::Vec3;
use rayon::prelude::*;

/// Particles held at rest (see the module docs).
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct RestingWater {
    position_m: Vec<Vec3>,
    id: Vec<u64>,
    /// Soaked volume at a clock of 0 (offset minus the clock at placement), m³.
    soaked_m3: Vec<f64>,
    /// Whether it touched the ground when placed (it soaks in).
    contact: Vec<bool>,
    /// Volume every ground-touching particle has soaked since the start, m³.
    clock_m3: f64,
    // Rebuilt from the above before use: left out of checkpoints.
    #[serde(skip)]
    grid: UniformGrid,
    /// m/ρ and p/ρ² of each particle.
    #[serde(skip)]
    terms: Vec<[f32; 2]>,
    /// The clock at which the next particle soaks in.
    #[serde(skip)]
    next_due_m3: Option<f64>,
    #[serde(skip)]
    ready: bool,
    /// Bumped whenever the set of particles changes (a carpet caches their footprint).
    #[serde(skip)]
    version: u64,
}

impl RestingWater {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.position_m.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.position_m.is_empty()
    }

    /// Positions, m (in grid order once the solver has stepped).
    pub fn positions_m(&self) -> &[Vec3] {
        &self.position_m
    }

    /// Stable particle ids (shared with the moving particles' numbering).
    pub fn ids(&self) -> &[u64] {
        &self.id
    }

    /// Adds a particle at `position_m` with `soaked_m3` already soaked; `contact`: it touches
    /// the ground.
    pub(crate) fn push(&mut self, position_m: Vec3, id: u64, soaked_m3: f32, contact: bool) {
        self.position_m.push(position_m);
        self.id.push(id);
        self.soaked_m3.push(soaked_m3 as f64 - self.clock_m3);
        self.contact.push(contact);
        self.ready = false;
        self.next_due_m3 = None;
        self.version += 1;
    }

    /// A number that changes whenever a particle is added or removed (not when they are only
    /// reordered): what a cache of their footprint is keyed by.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Advances the soak clock by `per_particle_m3` and removes the ground-touching particles
    /// whose soaked volume reaches `volume_m3`; returns how many left.
    pub(crate) fn soak(&mut self, per_particle_m3: f32, volume_m3: f32) -> u64 {
        if self.is_empty() || per_particle_m3 <= 0.0 {
            return 0;
        }
        self.clock_m3 += per_particle_m3 as f64;
        let volume = volume_m3 as f64;
        let due = *self.next_due_m3.get_or_insert_with(|| {
            self.soaked_m3
                .iter()
                .zip(&self.contact)
                .filter(|&(_, &c)| c)
                .map(|(&s, _)| volume - s)
                .fold(f64::INFINITY, f64::min)
        });
        if self.clock_m3 < due {
            return 0;
        }
        let clock = self.clock_m3;
        let keep: Vec<bool> = self
            .soaked_m3
            .iter()
            .zip(&self.contact)
            .map(|(&s, &c)| !(c && s + clock >= volume))
            .collect();
        let before = self.len();
        retain(&mut self.position_m, &keep);
        retain(&mut self.id, &keep);
        retain(&mut self.soaked_m3, &keep);
        retain(&mut self.contact, &keep);
        self.ready = false;
        self.next_due_m3 = None;
        self.version += 1;
        (before - self.len()) as u64
    }

    /// Sorts the particles into the grid and computes their density terms, if not done since
    /// the last change.
    pub(crate) fn prepare(
        &mut self,
        s: &SphSettings,
        moments: &LatticeMoments,
        bounds: &Boundaries,
    ) {
        if self.ready {
            return;
        }
        self.ready = true;
        let h = s.smoothing_length_m;
        let budget = 64 * self.len() + (1 << 16);
        self.grid.rebuild(&self.position_m, h, 0.5 * h, budget);
        let order = self.grid.order().to_vec();
        permute(&mut self.position_m, &order);
        permute(&mut self.id, &order);
        permute(&mut self.soaked_m3, &order);
        permute(&mut self.contact, &order);
        // Same points, same cells: the grid's slots are now the particles' indices.
        self.grid.rebuild(&self.position_m, h, 0.5 * h, budget);
        let (m, rho0, eos, clamp) = (
            s.particle_mass_kg,
            s.rest_density_kg_m3,
            s.eos,
            s.clamp_negative_pressure,
        );
        let h2 = h * h;
        let m_sum = m / moments.density;
        let self_density = m_sum * Spiky::value_sq(0.0, h);
        let pos = &self.position_m;
        let grid = &self.grid;
        self.terms = (0..pos.len())
            .into_par_iter()
            .with_min_len(256)
            .map(|i| {
                let xi = pos[i];
                let mirrors = bounds.mirrors(xi, h, 0.0);
                let mirrors = mirrors.as_slice();
                let ghosts = |xj: Vec3| -> f32 {
                    mirrors
                        .iter()
                        .filter_map(|mirror| mirror.point(xj))
                        .map(|g| Spiky::value_sq((xi - g).length_squared(), h))
                        .sum()
                };
                let mut sum = ghosts(xi);
                grid.for_each_neighbour_run(xi, |run| {
                    for j in run {
                        let r2 = (xi - pos[j]).length_squared();
                        if r2 < h2 && j != i {
                            sum += Spiky::value_sq(r2, h) + ghosts(pos[j]);
                        }
                    }
                });
                let rho = self_density + m_sum * sum;
                let p = eos.pressure_pa(rho, rho0);
                let p = if clamp { p.max(0.0) } else { p };
                [m / rho, p / (rho * rho)]
            })
            .collect();
    }

    /// Calls `f(x_j, terms_j)` for every particle within √`h2` of `x`, in grid order
    /// (after [`RestingWater::prepare`]).
    #[inline]
    pub(crate) fn for_each_near(&self, x: Vec3, h2: f32, mut f: impl FnMut(Vec3, [f32; 2])) {
        self.for_each_near_indexed(x, h2, |_, xj, terms_j| f(xj, terms_j));
    }

    /// [`RestingWater::for_each_near`], handing each particle's index first (for
    /// [`RestingWater::at`]); the indices come in increasing order.
    #[inline]
    pub(crate) fn for_each_near_indexed(
        &self,
        x: Vec3,
        h2: f32,
        mut f: impl FnMut(usize, Vec3, [f32; 2]),
    ) {
        if self.is_empty() {
            return;
        }
        let pos = &self.position_m;
        self.grid.for_each_neighbour_run(x, |run| {
            for j in run {
                if (x - pos[j]).length_squared() < h2 {
                    f(j, pos[j], self.terms[j]);
                }
            }
        });
    }

    /// Particle `j`'s position and density terms, as [`RestingWater::for_each_near`] hands
    /// them (after [`RestingWater::prepare`]).
    #[inline]
    pub(crate) fn at(&self, j: usize) -> (Vec3, [f32; 2]) {
        (self.position_m[j], self.terms[j])
    }

    /// Feeds every stored bit to `eat` (for the solver's state digest).
    pub(crate) fn digest(&self, mut eat: impl FnMut(u64)) {
        eat(self.clock_m3.to_bits());
        for (((p, id), s), c) in self
            .position_m
            .iter()
            .zip(&self.id)
            .zip(&self.soaked_m3)
            .zip(&self.contact)
        {
            for x in p.to_array() {
                eat(x.to_bits() as u64);
            }
            eat(*id);
            eat(s.to_bits());
            eat(*c as u64);
        }
    }
}

fn retain<T: Copy>(v: &mut Vec<T>, keep: &[bool]) {
    let mut k = keep.iter();
    v.retain(|_| *k.next().unwrap_or(&true));
}

fn permute<T: Copy>(v: &mut Vec<T>, order: &[u32]) {
    *v = order.iter().map(|&i| v[i as usize]).collect();
}
