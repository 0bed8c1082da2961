//! Sources and sinks of fluid particles, and the mass ledger.
//!
//! How it works:
//! - [`PrecipitationGrid`] is the thesis's per-cell precipitation counter (eq. 5.29–5.31): each
//!   raindrop that hits the surface in cell (i, j) does `cont += 1`; when `cont ≥ S` (the
//!   precipitation scale) one SPH particle is queued at that cell and `S` is taken off the
//!   counter (for single hits that is the thesis's reset to 0; for a batch of hits from the GPU
//!   it keeps the remainder, so no drop is lost). The particle appears at the cell centre, moved
//!   by a deterministic sub-cell jitter so that successive particles of one cell do not stack
//!   exactly, half a spacing above the current surface (terrain or water, the φ of 5.29).
//! - [`Emitter`] pours particles at a given rate from a disk (a tap, a gutter).
//! - Sinks live in the solver: particles leaving through open faces (outflow) and particles in
//!   contact with the terrain soaking in at the infiltration rate.
//! - [`MassLedger`] counts particles in and out; every particle has the same mass, so
//!   `inserted − outflow − soaked − discarded = present` is an exact integer identity.

use crate::{Error, Result};
use glam::{Vec2, Vec3};

/// A particle to be inserted at the next step.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NewParticle {
    /// Position, m.
    pub position_m: Vec3,
    /// Velocity, m/s.
    pub velocity_mps: Vec3,
}

/// Particle counts in and out of the simulation. Mass = count × particle mass.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct MassLedger {
    /// Particles ever added (initial blocks, emitters, precipitation).
    pub inserted: u64,
    /// Particles that left through an open face of the box.
    pub outflow: u64,
    /// Particles that soaked into the terrain.
    pub soaked: u64,
    /// Particles dropped because their state became non-finite (should stay 0).
    pub discarded: u64,
}

impl MassLedger {
    /// Particles that should be present: inserted − outflow − soaked − discarded.
    pub fn present(&self) -> u64 {
        self.inserted - self.outflow - self.soaked - self.discarded
    }
}

pub(crate) use crate::rng::splitmix64;

/// A uniform number in [0, 1) from a hash.
pub(crate) fn unit_from_hash(x: u64) -> f32 {
    (splitmix64(x) >> 40) as f32 / (1u64 << 24) as f32
}

/// Per-cell precipitation counters (thesis eq. 5.30–5.31) on a regular grid over the terrain.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PrecipitationGrid {
    nx: usize,
    ny: usize,
    origin_m: Vec2,
    cell_m: f32,
    scale: u32,
    counters: Vec<u32>,
    births: Vec<u32>,
    queued: Vec<u32>,
}

impl PrecipitationGrid {
    /// `nx × ny` cells of edge `cell_m` from `origin_m`; one particle per `scale` drops (S).
    pub fn new(
        nx: usize,
        ny: usize,
        origin_m: Vec2,
        cell_m: f32,
        scale: u32,
    ) -> Result<PrecipitationGrid> {
        if nx == 0 || ny == 0 || nx.saturating_mul(ny) > 1 << 26 {
            return Err(Error::Parameter {
                name: "precipitation.cells",
                value: format!("{nx}×{ny}"),
                expected: "between 1 and 2²⁶ cells".into(),
            });
        }
        if !(cell_m.is_finite() && cell_m > 0.0 && origin_m.is_finite()) {
            return Err(Error::Parameter {
                name: "precipitation.cell_m",
                value: cell_m.to_string(),
                expected: "a finite cell size > 0 and a finite origin".into(),
            });
        }
        if scale == 0 {
            return Err(Error::Parameter {
                name: "precipitation.scale",
                value: "0".into(),
                expected: "S ≥ 1 drops per particle".into(),
            });
        }
        Ok(PrecipitationGrid {
            nx,
            ny,
            origin_m,
            cell_m,
            scale,
            counters: vec![0; nx * ny],
            births: vec![0; nx * ny],
            queued: Vec::new(),
        })
    }

    /// Cells along x and y.
    pub fn dims(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// The precipitation scale S.
    pub fn scale(&self) -> u32 {
        self.scale
    }

    /// Current counter values (row-major, x fastest).
    pub fn counters(&self) -> &[u32] {
        &self.counters
    }

    /// One drop hit cell (i, j): eq. (5.30)–(5.31).
    pub fn add_hit(&mut self, i: usize, j: usize) -> Result<()> {
        if i >= self.nx || j >= self.ny {
            return Err(Error::Parameter {
                name: "precipitation.cell",
                value: format!("({i}, {j})"),
                expected: format!("a cell inside {}×{}", self.nx, self.ny),
            });
        }
        self.add(j * self.nx + i, 1);
        Ok(())
    }

    /// One drop hit the surface at (x, y); returns whether it fell on the grid (drops outside
    /// are ignored, not errors: rain falls beyond the terrain too).
    pub fn add_hit_at(&mut self, x_m: f32, y_m: f32) -> bool {
        let g = (Vec2::new(x_m, y_m) - self.origin_m) / self.cell_m;
        if !(g.x >= 0.0 && g.y >= 0.0 && g.x < self.nx as f32 && g.y < self.ny as f32) {
            return false;
        }
        let (i, j) = (
            (g.x as usize).min(self.nx - 1),
            (g.y as usize).min(self.ny - 1),
        );
        self.add(j * self.nx + i, 1);
        true
    }

    /// Per-cell hit counts for one rain step (as a GPU rain system reports them).
    pub fn add_hit_counts(&mut self, counts: &[u32]) -> Result<()> {
        if counts.len() != self.counters.len() {
            return Err(Error::Parameter {
                name: "precipitation.counts",
                value: format!("{} values", counts.len()),
                expected: format!("{} values ({}×{})", self.counters.len(), self.nx, self.ny),
            });
        }
        for (c, &n) in counts.iter().enumerate() {
            if n > 0 {
                self.add(c, n);
            }
        }
        Ok(())
    }

    fn add(&mut self, cell: usize, hits: u32) {
        let cont = &mut self.counters[cell];
        *cont = cont.saturating_add(hits);
        while *cont >= self.scale {
            *cont -= self.scale;
            self.queued.push(cell as u32);
        }
    }

    /// Particles waiting to be released.
    pub fn queued(&self) -> usize {
        self.queued.len()
    }

    /// Releases the queued particles into `out`, each `clearance_m` above `surface_m(x, y)`
    /// (terrain or water height, m), with velocity `velocity_mps`. They come out in cell order,
    /// so what a step releases does not depend on the order its drops were reported in (a seek
    /// that reports a step's drops at once matches a render that reports them frame by frame).
    pub fn drain(
        &mut self,
        surface_m: impl Fn(f32, f32) -> f32,
        clearance_m: f32,
        velocity_mps: Vec3,
        out: &mut Vec<NewParticle>,
    ) {
        self.queued.sort_unstable();
        for &cell in &self.queued {
            let c = cell as usize;
            let birth = self.births[c];
            self.births[c] = birth.wrapping_add(1);
            let key = ((c as u64) << 32) | birth as u64;
            let jitter = Vec2::new(unit_from_hash(2 * key), unit_from_hash(2 * key + 1)) - 0.5;
            let xy = self.origin_m
                + (Vec2::new((c % self.nx) as f32, (c / self.nx) as f32) + 0.5 + 0.8 * jitter)
                    * self.cell_m;
            out.push(NewParticle {
                position_m: xy.extend(surface_m(xy.x, xy.y) + clearance_m),
                velocity_mps,
            });
        }
        self.queued.clear();
    }
}

/// A source pouring particles at a steady rate from a horizontal disk.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Emitter {
    /// Centre of the disk, m.
    pub centre_m: Vec3,
    /// Disk radius, m.
    pub radius_m: f32,
    /// Velocity of emitted particles, m/s.
    pub velocity_mps: Vec3,
    /// Particles per second.
    pub rate_per_s: f32,
    /// Stop after this many particles (`u64::MAX`: never).
    pub limit: u64,
    owed: f64,
    emitted: u64,
}

impl Emitter {
    /// A disk source at `centre_m`.
    pub fn new(
        centre_m: Vec3,
        radius_m: f32,
        velocity_mps: Vec3,
        rate_per_s: f32,
        limit: u64,
    ) -> Result<Emitter> {
        let valid = centre_m.is_finite()
            && velocity_mps.is_finite()
            && radius_m.is_finite()
            && radius_m >= 0.0
            && rate_per_s.is_finite()
            && rate_per_s >= 0.0;
        if !valid {
            return Err(Error::Parameter {
                name: "emitter",
                value: format!("centre {centre_m}, radius {radius_m}, rate {rate_per_s}"),
                expected: "finite values, radius ≥ 0 and rate ≥ 0".into(),
            });
        }
        Ok(Emitter {
            centre_m,
            radius_m,
            velocity_mps,
            rate_per_s,
            limit,
            owed: 0.0,
            emitted: 0,
        })
    }

    /// Particles emitted so far.
    pub fn emitted(&self) -> u64 {
        self.emitted
    }

    /// Emits the particles due over `dt_s` into `out` (at most 2¹⁶ per call; the rest stay
    /// owed), spread over the disk by a golden-angle (Vogel) spiral so the pattern is even and
    /// deterministic.
    pub fn emit(&mut self, dt_s: f32, out: &mut Vec<NewParticle>) {
        self.owed += self.rate_per_s as f64 * dt_s.max(0.0) as f64;
        let mut budget = 1u32 << 16;
        while self.owed >= 1.0 && self.emitted < self.limit && budget > 0 {
            budget -= 1;
            self.owed -= 1.0;
            let k = self.emitted % 64;
            let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
            let r = self.radius_m * ((k as f32 + 0.5) / 64.0).sqrt();
            let a = golden * k as f32 + 0.7 * (self.emitted / 64) as f32;
            out.push(NewParticle {
                position_m: self.centre_m + Vec3::new(r * a.cos(), r * a.sin(), 0.0),
                velocity_mps: self.velocity_mps,
            });
            self.emitted += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counters_follow_eq_5_30_and_5_31() {
        let mut g = PrecipitationGrid::new(4, 3, Vec2::ZERO, 0.5, 4).expect("grid");
        for _ in 0..3 {
            g.add_hit(1, 2).expect("in range");
        }
        assert_eq!(g.queued(), 0);
        assert_eq!(g.counters()[2 * 4 + 1], 3);
        g.add_hit(1, 2).expect("in range");
        assert_eq!(g.queued(), 1);
        assert_eq!(g.counters()[2 * 4 + 1], 0, "reset after insertion");
        let mut counts = vec![0u32; 12];
        counts[0] = 9;
        g.add_hit_counts(&counts).expect("shape");
        assert_eq!(g.queued(), 3);
        assert_eq!(g.counters()[0], 1);
        let mut out = Vec::new();
        g.drain(|_, _| 1.0, 0.01, Vec3::ZERO, &mut out);
        assert_eq!(out.len(), 3);
        assert!(out.iter().all(|p| (p.position_m.z - 1.01).abs() < 1e-6));
        assert!(
            out[1].position_m != out[2].position_m,
            "jitter separates births"
        );
        assert!(g.add_hit(4, 0).is_err());
        assert!(!g.add_hit_at(-0.1, 0.2));
    }

    #[test]
    fn emitter_rate_is_exact_over_time() {
        let mut e = Emitter::new(Vec3::ZERO, 0.01, Vec3::ZERO, 1000.0, u64::MAX).expect("emitter");
        let mut out = Vec::new();
        for _ in 0..1000 {
            e.emit(1e-3, &mut out);
        }
        assert!((out.len() as i64 - 1000).abs() <= 1, "{}", out.len());
    }
}
