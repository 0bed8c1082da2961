//! The SPH solver's passes over the moving particles (thesis Algorithm 2, steps 3–5): density
//! and pressure, the surface particles, the accelerations.
//!
//! Each particle's sums run over its neighbours in grid order (see [`super`]). The density pass
//! keeps what the force pass needs at the same positions — the neighbours, moving and at rest,
//! and the mirrors — so the force pass searches and builds nothing again.

use super::{MIN_TASK, Muller2003};
use crate::fluid::boundary::Mirrors;
use crate::fluid::grid::neighbour_capacity;
use crate::fluid::kernels::{Kernel, Poly6, Spiky, Viscosity};
use crate::fluid::particles::Particles;
use glam::Vec3;
use rayon::prelude::*;

impl Muller2003 {
    /// (5.18) and (5.19): density with self term and wall ghosts, then pressure; records each
    /// particle's neighbours (within h, in grid order) for the force pass.
    pub(super) fn density_pass(&mut self) {
        let s = &self.settings;
        let (h, m, rho0, eos, clamp) = (
            s.smoothing_length_m,
            s.particle_mass_kg,
            s.rest_density_kg_m3,
            s.eos,
            s.clamp_negative_pressure,
        );
        let (h2, friction) = (h * h, s.ground_friction);
        let n = self.particles.len();
        let cap = neighbour_capacity(s.smoothing_length_m, s.particle_spacing_m);
        self.neighbours.capacity = cap;
        self.neighbours.list.resize(n * cap, 0);
        self.neighbours.count.resize(n, 0);
        self.rest_neighbours.capacity = cap;
        self.rest_neighbours.list.resize(n * cap, 0);
        self.rest_neighbours.count.resize(n, 0);
        self.pair_terms.resize(n, [0.0; 2]);
        self.covered.resize(n, false);
        self.mirrors.resize_with(n, Mirrors::default);
        debug_assert_eq!(self.ground.len(), n);
        self.ground.resize(n, None);
        let grid = &self.grid;
        let bounds = &self.boundaries;
        let resting = &self.resting;
        let half_dx2 = (0.5 * s.particle_spacing_m).powi(2);
        let Particles {
            position_m,
            density_kg_m3,
            pressure_pa,
            ..
        } = &mut self.particles;
        let pos = &*position_m;
        // The density sum, divided by its lattice value (see `LatticeMoments`).
        let m_sum = m / self.moments.density;
        let self_density = m_sum * Spiky::value_sq(0.0, h);
        density_kg_m3
            .par_iter_mut()
            .zip(pressure_pa.par_iter_mut())
            .zip(self.pair_terms.par_iter_mut())
            .zip(self.neighbours.list.par_chunks_mut(cap))
            .zip(self.neighbours.count.par_iter_mut())
            .zip(
                self.rest_neighbours
                    .list
                    .par_chunks_mut(cap)
                    .zip(self.rest_neighbours.count.par_iter_mut()),
            )
            .zip(self.covered.par_iter_mut())
            .zip(self.ground.par_iter_mut().zip(self.mirrors.par_iter_mut()))
            .enumerate()
            .with_min_len(MIN_TASK)
            .for_each(
                |(i, (((((((rho, p), terms), list), count), rest), covered), (ground, kept)))| {
                    let xi = pos[i];
                    if ground.is_none() {
                        *ground = bounds.terrain_under(xi);
                    }
                    // Friction only changes ghost velocities, unused here but kept for the
                    // force pass.
                    *kept = bounds.mirrors_on(xi, h, friction, *ground);
                    let mirrors = kept.as_slice();
                    let mut sum = 0.0f32;
                    let mut c = 0usize;
                    // Ghosts within h are images of neighbours within h (or of i itself).
                    let ghosts = |xj: Vec3| {
                        let mut g = 0.0;
                        for mirror in mirrors {
                            if let Some(ghost) = mirror.point(xj) {
                                g += Spiky::value_sq((xi - ghost).length_squared(), h);
                            }
                        }
                        g
                    };
                    sum += ghosts(xi);
                    grid.for_each_neighbour_run(xi, |run| {
                        for j in run {
                            let xj = pos[j];
                            let r2 = (xi - xj).length_squared();
                            if r2 < h2 && j != i {
                                sum += Spiky::value_sq(r2, h) + ghosts(xj);
                                if c < cap {
                                    list[c] = j as u32;
                                }
                                c += 1;
                            }
                        }
                    });
                    *count = c as u32;
                    // Water at rest around: its density and its ghosts'; above in the column, it
                    // is the surface there.
                    let mut above = false;
                    let (rest_list, rest_count) = rest;
                    let mut rc = 0usize;
                    resting.for_each_near_indexed(xi, h2, |j, xj, _| {
                        sum += Spiky::value_sq((xi - xj).length_squared(), h) + ghosts(xj);
                        above |= xj.z > xi.z && (xj - xi).truncate().length_squared() < half_dx2;
                        if rc < cap {
                            rest_list[rc] = j as u32;
                        }
                        rc += 1;
                    });
                    *rest_count = rc as u32;
                    *covered = above;
                    let r = self_density + m_sum * sum;
                    *rho = r;
                    let pr = eos.pressure_pa(r, rho0);
                    let pr = if clamp { pr.max(0.0) } else { pr };
                    *p = pr;
                    *terms = [m / r, pr / (r * r)];
                },
            );
    }

    /// Surface particles: the highest particle in each column of edge Δx (thesis §5.3.1, the
    /// carpet-cell criterion). Ties go to the lower index, so the result is deterministic.
    pub(super) fn surface_pass(&mut self) {
        let pos = &self.particles.position_m;
        let (lo, hi) = pos.iter().fold(
            (
                glam::Vec2::splat(f32::INFINITY),
                glam::Vec2::splat(f32::NEG_INFINITY),
            ),
            |(lo, hi), p| (lo.min(p.truncate()), hi.max(p.truncate())),
        );
        let budget = (4 * pos.len() + 1024) as u64;
        let mut cell = self.settings.particle_spacing_m;
        let (nx, ny) = loop {
            let d = ((hi - lo) / cell)
                .floor()
                .min(glam::Vec2::splat(1e6))
                .as_uvec2()
                + 1;
            if d.x as u64 * d.y as u64 <= budget {
                break (d.x as usize, d.y as usize);
            }
            cell *= 1.25;
        };
        self.column_best.clear();
        self.column_best.resize(nx * ny, u32::MAX);
        for (i, p) in pos.iter().enumerate() {
            let g = ((p.truncate() - lo) / cell).max(glam::Vec2::ZERO);
            let c = (g.y as usize).min(ny - 1) * nx + (g.x as usize).min(nx - 1);
            let b = &mut self.column_best[c];
            if *b == u32::MAX || p.z > pos[*b as usize].z {
                *b = i as u32;
            }
        }
        let surface = &mut self.particles.surface;
        surface.fill(false);
        for &b in &self.column_best {
            if b != u32::MAX {
                surface[b as usize] = !self.covered[b as usize];
            }
        }
    }

    /// (5.20)–(5.26): pressure, viscosity, surface tension and gravity → acceleration.
    pub(super) fn force_pass(&mut self) {
        let s = &self.settings;
        let (h, m, mu, sigma) = (
            s.smoothing_length_m,
            s.particle_mass_kg,
            s.viscosity_pa_s,
            s.surface_tension_n_per_m,
        );
        let g = s.gravity_mps2 * self.gravity_factor();
        let h2 = h * h;
        let grid = &self.grid;
        let kept_mirrors = &self.mirrors;
        let (bounds, ground, friction) = (&self.boundaries, &self.ground, s.ground_friction);
        let plain = self.plain_force_inputs;
        let neighbours = &self.neighbours;
        let terms = &self.pair_terms;
        let resting = &self.resting;
        let rest_neighbours = &self.rest_neighbours;
        let lattice = self.moments;
        let Particles {
            position_m,
            velocity_mps,
            acceleration_mps2,
            density_kg_m3,
            surface,
            ..
        } = &mut self.particles;
        let (pos, vel, rho, surf) = (&*position_m, &*velocity_mps, &*density_kg_m3, &*surface);
        // |n| below this is no surface at all (n ~ 1/h at a real surface).
        let n_min = 1e-3 / h * lattice.colour;
        acceleration_mps2
            .par_iter_mut()
            .enumerate()
            .with_min_len(MIN_TASK)
            .for_each(|(i, acc)| {
                let (xi, vi, rho_i) = (pos[i], vel[i], rho[i]);
                let [vol_i, p_over_rho2_i] = terms[i];
                let at_surface = surf[i] && sigma > 0.0;
                // Σ m (pᵢ/ρᵢ² + pⱼ/ρⱼ²) ∇W: minus the pressure acceleration.
                let mut a_press = Vec3::ZERO;
                // Σ Vⱼ (vⱼ − vᵢ) ∇²W: the velocity Laplacian.
                let mut lap_v = Vec3::ZERO;
                let mut normal = Vec3::ZERO;
                let mut lap_colour = if at_surface {
                    vol_i * Poly6::laplacian(0.0, h)
                } else {
                    0.0
                };
                let made;
                let mirrors = if plain {
                    made = bounds.mirrors_on(xi, h, friction, ground[i]);
                    made.as_slice()
                } else {
                    kept_mirrors[i].as_slice()
                };
                let mut add = |r_vec: Vec3, [vol_j, p_over_rho2_j]: [f32; 2], v_j: Vec3| {
                    let r2 = r_vec.length_squared();
                    if r2 >= h2 {
                        return;
                    }
                    let r = r2.sqrt();
                    a_press += Spiky::gradient(r_vec, h) * (m * (p_over_rho2_i + p_over_rho2_j));
                    lap_v += (v_j - vi) * (vol_j * Viscosity::laplacian(r, h));
                    if at_surface {
                        normal += Poly6::gradient(r_vec, h) * vol_j;
                        lap_colour += vol_j * Poly6::laplacian(r, h);
                    }
                };
                let mut with_ghosts = |xj: Vec3, terms_j: [f32; 2], vj: Vec3, real: bool| {
                    if real {
                        add(xi - xj, terms_j, vj);
                    }
                    for mirror in mirrors {
                        if let Some(ghost) = mirror.point(xj) {
                            add(xi - ghost, terms_j, mirror.velocity(vj));
                        }
                    }
                };
                with_ghosts(xi, terms[i], vi, false);
                neighbours.for_each(i, grid, pos, h2, |j| {
                    with_ghosts(pos[j], terms[j], vel[j], true)
                });
                // Water at rest: a neighbour with zero velocity (the density pass's list, in its
                // order, unless it overflowed).
                let (cap, rc) = (rest_neighbours.capacity, rest_neighbours.count[i] as usize);
                if rc <= cap && !plain {
                    for &j in &rest_neighbours.list[i * cap..i * cap + rc] {
                        let (xj, terms_j) = resting.at(j as usize);
                        with_ghosts(xj, terms_j, Vec3::ZERO, true);
                    }
                } else {
                    resting.for_each_near(xi, h2, |xj, terms_j| {
                        with_ghosts(xj, terms_j, Vec3::ZERO, true)
                    });
                }
                let mut f = lap_v * (mu / lattice.laplacian);
                if at_surface {
                    let n_len = normal.length();
                    if n_len > n_min {
                        // Müller 2003 eq. 19: f = −σ ∇²c n/|n| (n points into the fluid).
                        f += normal * (-sigma * lap_colour / (n_len * lattice.colour));
                    }
                }
                *acc = f / rho_i - a_press / lattice.gradient + g;
            });
    }
}
