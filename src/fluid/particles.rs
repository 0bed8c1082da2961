//! Particle storage: structure of arrays (one `Vec` per attribute), as in salva.
//!
//! How it works: the solver reorders all arrays into grid-cell order at every neighbour-search
//! rebuild (see [`super::grid`]), so neighbours are close in memory; `id` follows each particle
//! through the permutations. All particles share one mass ([`super::SphSettings`]).

use glam::Vec3;

/// The fluid particles, structure of arrays. Read-only outside the solver.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Particles {
    pub(crate) position_m: Vec<Vec3>,
    pub(crate) velocity_mps: Vec<Vec3>,
    pub(crate) acceleration_mps2: Vec<Vec3>,
    pub(crate) density_kg_m3: Vec<f32>,
    pub(crate) pressure_pa: Vec<f32>,
    pub(crate) surface: Vec<bool>,
    pub(crate) soaked_m3: Vec<f32>,
    pub(crate) id: Vec<u64>,
}

/// Reusable buffers for permuting [`Particles`] without allocating.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub(crate) struct PermuteScratch {
    vec3: Vec<Vec3>,
    f32s: Vec<f32>,
    bools: Vec<bool>,
    ids: Vec<u64>,
}

fn permute<T: Copy>(v: &mut Vec<T>, scratch: &mut Vec<T>, order: &[u32]) {
    scratch.clear();
    scratch.extend(order.iter().map(|&k| v[k as usize]));
    std::mem::swap(v, scratch);
}

impl Particles {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.position_m.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.position_m.is_empty()
    }

    /// Positions, m.
    pub fn positions_m(&self) -> &[Vec3] {
        &self.position_m
    }

    /// Velocities, m/s (at the end of the last step).
    pub fn velocities_mps(&self) -> &[Vec3] {
        &self.velocity_mps
    }

    /// Accelerations, m/s², from the last force evaluation (5.26).
    pub fn accelerations_mps2(&self) -> &[Vec3] {
        &self.acceleration_mps2
    }

    /// SPH densities, kg/m³ (5.18, self term and walls included).
    pub fn densities_kg_m3(&self) -> &[f32] {
        &self.density_kg_m3
    }

    /// Pressures from the equation of state, Pa.
    pub fn pressures_pa(&self) -> &[f32] {
        &self.pressure_pa
    }

    /// Whether each particle is a surface particle (highest in its column, thesis §5.3.1).
    pub fn surface(&self) -> &[bool] {
        &self.surface
    }

    /// Persistent particle ids (insertion order).
    pub fn ids(&self) -> &[u64] {
        &self.id
    }

    pub(crate) fn push(&mut self, position_m: Vec3, velocity_mps: Vec3, id: u64, soaked_m3: f32) {
        self.position_m.push(position_m);
        self.velocity_mps.push(velocity_mps);
        self.acceleration_mps2.push(Vec3::ZERO);
        self.density_kg_m3.push(0.0);
        self.pressure_pa.push(0.0);
        self.surface.push(false);
        self.soaked_m3.push(soaked_m3);
        self.id.push(id);
    }

    /// Reorders every array so that new slot `s` holds old particle `order[s]`.
    pub(crate) fn permute(&mut self, order: &[u32], s: &mut PermuteScratch) {
        permute(&mut self.position_m, &mut s.vec3, order);
        permute(&mut self.velocity_mps, &mut s.vec3, order);
        permute(&mut self.acceleration_mps2, &mut s.vec3, order);
        permute(&mut self.density_kg_m3, &mut s.f32s, order);
        permute(&mut self.pressure_pa, &mut s.f32s, order);
        permute(&mut self.soaked_m3, &mut s.f32s, order);
        permute(&mut self.surface, &mut s.bools, order);
        permute(&mut self.id, &mut s.ids, order);
    }

    /// Keeps the particles whose `keep` flag is set, in order.
    pub(crate) fn retain(&mut self, keep: &[bool]) {
        let mut w = 0;
        for (r, &kept) in keep.iter().enumerate().take(self.len()) {
            if kept {
                self.position_m[w] = self.position_m[r];
                self.velocity_mps[w] = self.velocity_mps[r];
                self.acceleration_mps2[w] = self.acceleration_mps2[r];
                self.density_kg_m3[w] = self.density_kg_m3[r];
                self.pressure_pa[w] = self.pressure_pa[r];
                self.surface[w] = self.surface[r];
                self.soaked_m3[w] = self.soaked_m3[r];
                self.id[w] = self.id[r];
                w += 1;
            }
        }
        self.position_m.truncate(w);
        self.velocity_mps.truncate(w);
        self.acceleration_mps2.truncate(w);
        self.density_kg_m3.truncate(w);
        self.pressure_pa.truncate(w);
        self.surface.truncate(w);
        self.soaked_m3.truncate(w);
        self.id.truncate(w);
    }
}
