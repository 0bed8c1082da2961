//! Surface flow on a terrain fed by rain: the precipitation counters, the SPH solver and the
//! carpet wired together — the interface a video pipeline is to drive once per frame (nothing
//! in the render path calls it yet).
//!
//! How it works: the rain system reports where drops hit the ground (per precipitation cell,
//! or one position at a time). Every S drops in a cell become one particle (5.29–5.31),
//! released half a spacing above the carpet surface φ at the next [`SurfaceFlow::advance`],
//! which then runs SPH sub-steps over the frame's duration and rebuilds the carpet once. The
//! outputs are the carpet's water depth and wetness fields, and φ for the rain's collisions.
//! The terrain may be a DEM, an estimated ground plane or a depth map ([`HeightField`]).

use super::boundary::{Boundaries, Domain};
use super::carpet::{Carpet, CarpetSettings, Field2};
use super::eos::EquationOfState;
use super::settings::SphSettings;
use super::sources::{NewParticle, PrecipitationGrid};
use super::sph::Muller2003;
use super::terrain::HeightField;
use crate::{Error, Result};
use glam::{Vec2, Vec3};

/// Parameters of a [`SurfaceFlow`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SurfaceFlowSettings {
    /// The SPH parameters.
    pub sph: SphSettings,
    /// Edge of a precipitation cell, m.
    pub precipitation_cell_m: f32,
    /// The precipitation scale S: drops per particle (5.31).
    pub precipitation_scale: u32,
    /// Edge of a carpet leaf, m.
    pub carpet_cell_m: f32,
    /// Drying time constant of the wetness, s.
    pub drying_time_s: f32,
    /// Wetness added by one raindrop on dry ground.
    pub wetting_per_hit: f32,
    /// Height of the simulation box above the highest terrain point, m.
    pub headroom_m: f32,
    /// Whether water running off the terrain's edge leaves (else the edges are walls).
    pub open_edges: bool,
}

impl SurfaceFlowSettings {
    /// Defaults for puddles up to `depth_m` deep at particle spacing `particle_spacing_m`:
    /// precipitation cells and carpet leaves of one spacing, S = 4, drying in 120 s, and a
    /// partly slipping ground (friction 0.3): the stabilising viscosity is hundreds of times
    /// water's, so a no-slip ground would hold thin films back by as much.
    pub fn new(particle_spacing_m: f32, depth_m: f32) -> SurfaceFlowSettings {
        SurfaceFlowSettings::with_eos(particle_spacing_m, EquationOfState::for_depth(depth_m))
    }

    /// [`SurfaceFlowSettings::new`] with the pressure law `eos` (the viscosity follows its sound
    /// speed).
    pub fn with_eos(particle_spacing_m: f32, eos: EquationOfState) -> SurfaceFlowSettings {
        let mut sph = SphSettings::water_with(particle_spacing_m, eos);
        sph.ground_friction = 0.3;
        SurfaceFlowSettings {
            sph,
            precipitation_cell_m: particle_spacing_m,
            precipitation_scale: 4,
            carpet_cell_m: particle_spacing_m,
            drying_time_s: 120.0,
            wetting_per_hit: 0.05,
            headroom_m: 0.1,
            open_edges: true,
        }
    }
}

/// Rain-fed surface flow over a terrain.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct SurfaceFlow {
    /// The SPH solver.
    pub sph: Muller2003,
    /// The per-cell precipitation counters.
    pub precipitation: PrecipitationGrid,
    /// The free surface and wetness.
    pub carpet: Carpet,
    precipitation_cell_m: f32,
    drained: Vec<NewParticle>,
    /// Carpet leaves hit by drops whose wetting is held back (empty between calls that a
    /// checkpoint can see).
    #[serde(skip)]
    held_hits: Vec<u32>,
}

impl SurfaceFlow {
    /// Surface flow over `terrain`; the box spans the terrain's extent, from below its lowest
    /// point to `headroom_m` above its highest.
    pub fn new(terrain: HeightField, settings: SurfaceFlowSettings) -> Result<SurfaceFlow> {
        let s = settings;
        if !(s.headroom_m.is_finite() && s.headroom_m > 0.0) {
            return Err(Error::Parameter {
                name: "flow.headroom_m",
                value: s.headroom_m.to_string(),
                expected: "a finite height > 0".into(),
            });
        }
        let (lo, hi) = terrain.height_range_m();
        let (min_xy, max_xy) = (terrain.origin_m(), terrain.max_m());
        let min_m = min_xy.extend(lo - s.sph.smoothing_length_m);
        let max_m = max_xy.extend(hi + s.headroom_m);
        let domain = if s.open_edges {
            Domain::open_sides(min_m, max_m)
        } else {
            Domain::closed(min_m, max_m)
        };
        let extent = max_xy - min_xy;
        let cells = |cell: f32, name: &'static str| -> Result<(usize, usize)> {
            if !(cell.is_finite() && cell > 0.0) {
                return Err(Error::Parameter {
                    name,
                    value: cell.to_string(),
                    expected: "a finite cell size > 0".into(),
                });
            }
            let n = (extent / cell).ceil().max(Vec2::ONE);
            Ok((n.x as usize, n.y as usize))
        };
        let (px, py) = cells(s.precipitation_cell_m, "flow.precipitation_cell_m")?;
        let (cx, cy) = cells(s.carpet_cell_m, "flow.carpet_cell_m")?;
        let precipitation = PrecipitationGrid::new(
            px,
            py,
            min_xy,
            s.precipitation_cell_m,
            s.precipitation_scale,
        )?;
        let carpet = Carpet::new(
            CarpetSettings {
                nx: cx,
                ny: cy,
                origin_m: min_xy,
                cell_m: s.carpet_cell_m,
                particle_radius_m: 0.5 * s.sph.particle_spacing_m,
                trail_acceleration_mps2: s.sph.gravity_mps2.length(),
                drying_time_s: s.drying_time_s,
                wetting_per_hit: s.wetting_per_hit,
            },
            &terrain,
        )?;
        let sph = Muller2003::new(
            s.sph,
            Boundaries {
                domain,
                terrain: Some(terrain),
            },
        )?;
        Ok(SurfaceFlow {
            sph,
            precipitation,
            carpet,
            precipitation_cell_m: s.precipitation_cell_m,
            drained: Vec::new(),
            held_hits: Vec::new(),
        })
    }

    /// Per-cell drop counts from one rain step (row-major over the precipitation grid).
    pub fn add_hit_counts(&mut self, counts: &[u32]) -> Result<()> {
        self.precipitation.add_hit_counts(counts)?;
        let (nx, _) = self.precipitation.dims();
        let cell = self.precipitation_cell_m;
        let origin = self.sph.boundaries().domain.min_m.truncate();
        for (k, &n) in counts.iter().enumerate() {
            let c = origin + (Vec2::new((k % nx) as f32, (k / nx) as f32) + 0.5) * cell;
            for _ in 0..n.min(64) {
                self.carpet.add_hit(c.x, c.y);
            }
        }
        Ok(())
    }

    /// One drop hit the ground at (x, y); false if outside the terrain.
    pub fn add_hit_at(&mut self, x_m: f32, y_m: f32) -> bool {
        self.carpet.add_hit(x_m, y_m);
        self.precipitation.add_hit_at(x_m, y_m)
    }

    /// [`SurfaceFlow::add_hit_at`] with the carpet's wetting held back until
    /// [`SurfaceFlow::flush_hits`] (or the next [`SurfaceFlow::advance`]) applies a batch of
    /// them in leaf order ([`Carpet::add_hits`]: the same result).
    pub fn add_hit_later(&mut self, x_m: f32, y_m: f32) -> bool {
        self.wet_later(x_m, y_m);
        self.precipitation.add_hit_at(x_m, y_m)
    }

    /// A drop that only wets the carpet at (x, y), held back as [`SurfaceFlow::add_hit_later`].
    pub fn wet_later(&mut self, x_m: f32, y_m: f32) {
        if let Some(k) = self.carpet.leaf_index(x_m, y_m) {
            self.held_hits.push(k);
        }
    }

    /// Applies the wetting held back by [`SurfaceFlow::add_hit_later`].
    pub fn flush_hits(&mut self) {
        self.carpet.add_hits(&mut self.held_hits);
    }

    /// Releases the drained particles, runs SPH for `dt_s` and rebuilds the carpet; the
    /// wetting held back is applied beside the SPH steps (it reads and writes only the
    /// wetness, which neither the release nor the steps read).
    pub fn advance(&mut self, dt_s: f64) -> Result<usize> {
        let clearance = 0.5 * self.sph.settings().particle_spacing_m;
        let carpet = &self.carpet;
        let bounds = self.sph.boundaries();
        self.drained.clear();
        self.precipitation.drain(
            |x, y| {
                carpet
                    .surface_height_m(x, y)
                    .unwrap_or_else(|| bounds.ground_m(x, y))
            },
            clearance,
            Vec3::ZERO,
            &mut self.drained,
        );
        self.sph.queue(&self.drained)?;
        let (carpet, held, sph) = (&mut self.carpet, &mut self.held_hits, &mut self.sph);
        let ((), steps) = rayon::join(|| carpet.add_hits(held), || sph.advance(dt_s));
        let steps = steps?;
        self.update_carpet(dt_s as f32);
        Ok(steps)
    }

    /// Rebuilds the carpet from every particle, moving and at rest, `dt_s` after the last:
    /// only where it can change ([`Carpet::update_split`]; the water at rest stays put).
    pub fn update_carpet(&mut self, dt_s: f32) {
        let resting = self.sph.resting();
        self.carpet.update_split(
            resting.positions_m(),
            resting.version(),
            &self.sph.particles().position_m,
            dt_s,
        );
    }

    /// Water depth above the terrain on the carpet grid, m.
    pub fn water_depth(&self) -> Field2 {
        self.carpet.water_depth()
    }

    /// Wetness on the carpet grid, [0, 1].
    pub fn wetness(&self) -> Field2 {
        self.carpet.wetness()
    }

    /// The surface φ at (x, y) for raindrop collisions (5.29), m.
    pub fn surface_height_m(&self, x_m: f32, y_m: f32) -> f32 {
        self.carpet
            .surface_height_m(x_m, y_m)
            .unwrap_or_else(|| self.sph.boundaries().ground_m(x_m, y_m))
    }
}
