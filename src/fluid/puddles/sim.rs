//! [`PuddleSim`]: the water on the shot's ground over a clip — built from the render's
//! configuration and camera, filled with the pre-rain water, fed the rain's impacts, stepped
//! every m-th frame, read as a water-depth map.
//!
//! How it works: [`PuddleSim::new`] takes the picture's ground footprint up to
//! `max_distance_m` ([`super::relief::ground_footprint`]), lays the micro-relief over the
//! plane z = 0 (or over a depth map's relief), fills it with the pre-rain water
//! ([`super::fill`], [`super::ledger`]) and turns the depressions' water into SPH particles on
//! a lattice, column by column: each column of the particle spacing gets ⌊(its water +
//! carry)/V⌋ particles, the remainder carried to the next column (error diffusion, so the
//! total is exact to less than one particle). The settled start (the default,
//! `settled_start`) places them at rest ([`crate::fluid::resting`]), each column hanging from
//! the fill's level: water at rest in its hollows is not stepped, only the rain's particles
//! are, which makes a seek to 1.5 s some 30 times cheaper (docs/measurements.md, "The settled
//! start"). Without it they stand on the relief and are all stepped. Only the columns the picture shows get particles (the footprint is the
//! bounding box of a wedge): the water of the others is counted, not simulated. The spacing is
//! the configured one unless the water would need more particles than `max_particles`; then
//! it grows to (water / cap)^⅓ and [`PuddleSim::particle_cap`] says so. [`PuddleSim::advance_to`] feeds impacts to the precipitation counters (5.29–5.31) and
//! runs [`SurfaceFlow`] in steps of m frame durations; a seek fast-forwards from t = 0
//! ([`PuddleSim::advance_with_rain`]), since the fluid has memory.

use glam::{Vec2, Vec3};

use super::columns::resample;
use super::fill::{FilledWater, fill_depressions};
use super::kept_map::KeptWaterMap;
use super::ledger::{WaterLedger, pre_rain_split};
use super::relief::{Footprint, ground_footprint, micro_relief, with_relief};
use crate::config::RenderConfig;
use crate::fluid::EquationOfState;
use crate::fluid::carpet::Field2;
use crate::fluid::flow::{SurfaceFlow, SurfaceFlowSettings};
use crate::fluid::terrain::HeightField;
use crate::lighting::wetness::SurfaceStore;
use crate::rain::volume::{GroundRain, GroundRect, Impact, StreamSlots, impacts_between};
use crate::scene::Camera;
use crate::{Error, Result};

/// Infiltration into a road, mm/h: a dense asphalt sheds nearly all rain (Yang, Hu & Beecham
/// 2024 measured dense-graded asphalt against porous mixes), but cracks and joints take some
/// in; 0.5 mm/h is our assumption for a used road (an urban hydrology model's continuing loss
/// for paved ground is of this order). A setting, not a measurement.
pub const DEFAULT_INFILTRATION_MM_PER_H: f64 = 0.5;

/// Parameters of a [`PuddleSim`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PuddleSettings {
    /// Farthest ground simulated, horizontal metres from the camera.
    pub max_distance_m: f64,
    /// Vertex spacing of the relief and of the initial fill, m.
    pub relief_cell_m: f32,
    /// Most relief vertices (the spacing grows beyond).
    pub max_vertices: usize,
    /// Finest particle spacing, m.
    pub particle_spacing_m: f32,
    /// Most particles in the initial puddles (the spacing grows beyond).
    pub max_particles: usize,
    /// The solver runs every m-th frame, m ≥ 1.
    pub step_every_frames: u32,
    /// Infiltration into the ground, mm/h.
    pub infiltration_mm_per_h: f64,
    /// Raindrops per new particle (S of 5.31).
    pub precipitation_scale: u32,
    /// Place the filled water at rest, not stepped (the settled start): only the rain's
    /// particles move. Off: every particle is stepped from the start.
    pub settled_start: bool,
    /// The solver's sound speed, m/s; `None`: [`EquationOfState::for_depth`] of the deepest
    /// fill. A film's ([`EquationOfState::for_film`] of two spacings) suits moderate rain over
    /// water at rest and takes fewer steps. The viscosity is that of the fill's depth either way.
    pub sound_speed_mps: Option<f32>,
}

impl Default for PuddleSettings {
    /// 20 m of ground (farther, a puddle is a few pixels and costs as many particles as a
    /// near one), 2 cm relief cells, 1 cm particles, at most 30 000 of them (about 1 s a frame
    /// on two cores; 100 000 cost 5), every frame.
    fn default() -> PuddleSettings {
        PuddleSettings {
            max_distance_m: 20.0,
            relief_cell_m: 0.02,
            max_vertices: 1 << 22,
            particle_spacing_m: 0.01,
            max_particles: 30_000,
            step_every_frames: 1,
            infiltration_mm_per_h: DEFAULT_INFILTRATION_MM_PER_H,
            precipitation_scale: 4,
            settled_start: true,
            sound_speed_mps: None,
        }
    }
}

impl PuddleSettings {
    /// The defaults, with the particle cap of `config` (`--puddle-particles`).
    pub fn of(config: &RenderConfig) -> PuddleSettings {
        PuddleSettings {
            max_particles: config.ground.puddle_particles as usize,
            ..PuddleSettings::default()
        }
    }
}

/// The water on a shot's ground (see the module docs).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct PuddleSim {
    flow: SurfaceFlow,
    footprint: Footprint,
    /// The water before the clip (a checkpoint leaves it out: the configuration fixes it).
    #[serde(skip)]
    initial: Field2,
    ledger: WaterLedger,
    capped: bool,
    max_particles: usize,
    time_s: f64,
    step_s: f64,
    /// Frames per solver step (m).
    frames_per_step: u32,
    steps: u64,
    /// The ground's stream of drops, its time slots kept for the frames that share them.
    #[serde(skip)]
    stream: StreamSlots,
}

/// A relief grid over `footprint` at `cell_m` or coarser, with at most `max_vertices`.
fn relief_grid(footprint: &Footprint, cell_m: f32, max_vertices: usize) -> (usize, usize, f32) {
    let size = footprint.size_m();
    let area_cells = size.x * size.y / (cell_m as f64).powi(2);
    let cell = if area_cells > max_vertices as f64 {
        (size.x * size.y / max_vertices as f64).sqrt() as f32 * 1.001
    } else {
        cell_m
    };
    let n = |extent: f64| ((extent / cell as f64).ceil() as usize + 1).max(2);
    (n(size.x), n(size.y), cell)
}

impl PuddleSim {
    /// The water at t = 0 on the ground of `config` seen by `camera` (the render's camera, its
    /// pose set by the ground), the rain stepped every `settings.step_every_frames` frames of
    /// `fps`. `depth_m`: the scene's depth (camera z per pixel of the camera's picture, 0
    /// unknown) to take the relief from; `None` or a map of holes only: the plane z = 0.
    /// `Ok(None)` without a ground, without ground in view or where the map shows none within
    /// reach: nothing is built.
    pub fn new(
        config: &RenderConfig,
        camera: &Camera,
        depth_m: Option<&[f32]>,
        fps: f64,
        settings: &PuddleSettings,
    ) -> Result<Option<PuddleSim>> {
        PuddleSim::seen_by(config, std::slice::from_ref(camera), depth_m, fps, settings)
    }

    /// As [`new`](Self::new) for a camera that turns and zooms over the shot, seen by each of
    /// `cameras` (its poses over the shot, the first the one `depth_m` is seen by): the
    /// ground and the water placed on it cover every view.
    pub fn seen_by(
        config: &RenderConfig,
        cameras: &[Camera],
        depth_m: Option<&[f32]>,
        fps: f64,
        settings: &PuddleSettings,
    ) -> Result<Option<PuddleSim>> {
        let Some(camera) = cameras.first() else {
            return Ok(None);
        };
        let s = settings;
        if !config.ground.is_given() {
            return Ok(None);
        }
        let valid = fps.is_finite()
            && fps > 0.0
            && s.step_every_frames >= 1
            && s.max_particles >= 1
            && s.max_distance_m > 0.0
            && s.relief_cell_m > 0.0
            && s.particle_spacing_m > 0.0
            && s.max_vertices >= 4
            && s.infiltration_mm_per_h >= 0.0
            && s.sound_speed_mps.is_none_or(|c| c.is_finite() && c > 0.0);
        if !valid {
            return Err(Error::Parameter {
                name: "puddles",
                value: format!("{s:?} at {fps} fps"),
                expected: "fps > 0, m ≥ 1, positive sizes and caps, infiltration ≥ 0".into(),
            });
        }
        let Some(footprint) = cameras
            .iter()
            .filter_map(|c| ground_footprint(c, s.max_distance_m))
            .reduce(|a, b| Footprint {
                min_m: a.min_m.min(b.min_m),
                max_m: a.max_m.max(b.max_m),
            })
        else {
            return Ok(None);
        };
        let (nx, ny, cell) = relief_grid(&footprint, s.relief_cell_m, s.max_vertices);
        let origin = footprint.min_m.as_vec2();
        // A map of holes only knows nothing: the ground is the plane, as without a map.
        let known = depth_m.filter(|d| d.iter().any(|&z| z.is_finite() && z > 0.0));
        let base = match known {
            Some(depth) => {
                // No known pixel on the ground within reach: the map shows a wall there.
                match HeightField::from_depth_map(camera, depth, nx, ny, origin, cell)? {
                    Some(base) => base,
                    None => return Ok(None),
                }
            }
            None => HeightField::flat(nx, ny, origin, cell, 0.0)?,
        };
        let g = &config.ground;
        let relief = micro_relief(nx, ny, origin, cell, g.relief_m, g.relief_seed);
        let terrain = with_relief(&base, &relief)?;

        // The pre-rain water, split and filled.
        let area_m2 = (nx * ny) as f64 * (cell as f64).powi(2);
        let duration_s = 60.0 * g.pre_rain_min;
        let rain_m = config.rain.rate_mm_per_h * 1e-3 * duration_s / 3600.0;
        let infiltration_mps = s.infiltration_mm_per_h * 1e-3 / 3600.0;
        let (film, evaporated, infiltrated, to_run) = pre_rain_split(
            &SurfaceStore::default(),
            rain_m,
            duration_s,
            infiltration_mps,
        );
        let filled = fill_depressions(&terrain, to_run);

        // Particles, where the picture shows the ground: the configured spacing unless the cap
        // asks for a coarser one (with 2 % to spare for the columns' edges).
        // Asked for every wet vertex: each camera's constants made once (the same pixels).
        let views: Vec<_> = cameras
            .iter()
            .map(|c| (c.projector(), c.width_px as f64, c.height_px as f64))
            .collect();
        let in_view = |x: f32, y: f32, z: f32| {
            let p = glam::DVec3::new(x as f64, y as f64, z as f64);
            let ahead = (p - camera.position_m).truncate().length() <= s.max_distance_m;
            ahead
                && views.iter().any(|(c, w, h)| {
                    c.project_world(p)
                        .is_some_and(|q| q.x >= 0.0 && q.y >= 0.0 && q.x <= *w && q.y <= *h)
                })
        };
        let shown_m3: f64 = (0..nx * ny)
            .filter(|&v| filled.depth_m[v] > 0.0)
            .filter(|&v| {
                let p = origin + Vec2::new((v % nx) as f32, (v / nx) as f32) * cell;
                in_view(p.x, p.y, terrain.heights_m()[v])
            })
            .map(|v| filled.depth_m[v] as f64 * (cell as f64).powi(2))
            .sum();
        let needed = shown_m3 / (s.particle_spacing_m as f64).powi(3);
        let capped = needed > s.max_particles as f64;
        let spacing = if capped {
            ((1.02 * shown_m3 / s.max_particles as f64).cbrt()) as f32
        } else {
            s.particle_spacing_m
        };
        let deepest = filled.depth_m.iter().fold(0.0f32, |a, &b| a.max(b));
        // The sound speed of the fill's depth unless one is given. At the settled start only the
        // rain's films move, and a film's own ([`EquationOfState::for_film`]) takes some 27 %
        // fewer steps with the same water on a street in moderate rain, but where the films
        // pile deeper (a cloudburst) it changes the outflow by more than the flow's own noise
        // (docs/measurements.md, "The rain's films: a sound speed from their depth"), so it is
        // not the default. The viscosity stays that of the fill's depth: only the step changes.
        let mut flow_settings = SurfaceFlowSettings::new(spacing, deepest.max(2.0 * spacing));
        if let Some(c) = s.sound_speed_mps {
            flow_settings.sph.eos = EquationOfState::Linear {
                stiffness_m2ps2: c * c,
            };
        }
        flow_settings.sph.infiltration_rate_mps = infiltration_mps as f32;
        flow_settings.precipitation_scale = s.precipitation_scale;
        flow_settings.carpet_cell_m = spacing.max(cell);
        flow_settings.precipitation_cell_m = spacing.max(cell);
        let mut flow = SurfaceFlow::new(terrain, flow_settings)?;
        let (leftover, outside_view) = place_particles(
            &mut flow,
            &filled,
            (nx, cell, origin),
            spacing,
            (s.max_particles, s.settled_start),
            in_view,
        )?;
        flow.update_carpet(0.0);

        let particle_volume_m3 = (spacing as f64).powi(3);
        let initial_particles = flow.sph.ledger().inserted;
        let ledger = WaterLedger {
            area_m2,
            pre_rain_m3: rain_m * area_m2,
            film_m3: film * area_m2,
            evaporated_m3: evaporated * area_m2,
            infiltrated_m3: infiltrated * area_m2,
            run_off_m3: filled.run_off_m3,
            puddles_m3: filled.held_m3,
            below_one_particle_m3: leftover,
            unsimulated_m3: outside_view,
            particle_volume_m3,
            initial_particles,
            rain_drops: 0,
            rain_drops_over_cap: 0,
            rain_drop_volume_m3: 0.0,
            rain_particles: 0,
            particles: flow.sph.ledger(),
            particles_present: flow.sph.particle_count() as u64,
        };
        let initial = Field2 {
            nx,
            ny,
            origin_m: origin - 0.5 * cell,
            cell_m: cell,
            values: filled.depth_m,
        };
        Ok(Some(PuddleSim {
            flow,
            footprint,
            initial,
            ledger,
            capped,
            max_particles: s.max_particles,
            time_s: 0.0,
            step_s: s.step_every_frames as f64 / fps,
            frames_per_step: s.step_every_frames,
            steps: 0,
            stream: StreamSlots::default(),
        }))
    }

    /// Feeds `impacts` (drops landing since the last call) to the precipitation counters and
    /// runs the solver in whole steps of m frames up to `t_s`; returns the solver steps taken.
    pub fn advance_to(&mut self, t_s: f64, impacts: &[Impact]) -> Result<usize> {
        let mut room = self.room();
        for hit in impacts {
            let (x, y) = (hit.position_m.x as f32, hit.position_m.y as f32);
            self.land(x, y, || hit.diameter_mm, &mut room);
        }
        self.step_to(t_s)
    }

    /// Particles that may still be added under the cap.
    fn room(&self) -> usize {
        self.max_particles
            .saturating_sub(self.flow.sph.particle_count() + self.flow.precipitation.queued())
    }

    /// One drop landed at (x, y) of diameter `diameter_mm()` (asked only where its water is
    /// counted): to the precipitation counters while under the cap, else it only wets the
    /// ground.
    #[inline]
    fn land(&mut self, x: f32, y: f32, diameter_mm: impl FnOnce() -> f64, room: &mut usize) {
        if !self.footprint_contains(x, y) {
            return;
        }
        if *room == 0 {
            // At the cap: the drop wets the ground but adds no water (counted).
            self.flow.wet_later(x, y);
            self.ledger.rain_drops_over_cap += 1;
        } else {
            let queued = self.flow.precipitation.queued();
            self.flow.add_hit_later(x, y);
            *room = room.saturating_sub(self.flow.precipitation.queued() - queued);
            self.ledger.rain_drops += 1;
            let r = 0.5e-3 * diameter_mm();
            self.ledger.rain_drop_volume_m3 += 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        }
    }

    /// Applies the wetting held back and runs the solver in whole steps of m frames up to
    /// `t_s` (the first step applies it beside the solver); returns the steps taken.
    fn step_to(&mut self, t_s: f64) -> Result<usize> {
        let mut steps = 0;
        while self.time_s + self.step_s <= t_s + 1e-9 {
            steps += self.flow.advance(self.step_s)?;
            self.time_s += self.step_s;
        }
        self.flow.flush_hits();
        self.steps += steps as u64;
        Ok(steps)
    }

    /// Runs from the current time to `t_s` with all the rain landing on the footprint
    /// ([`GroundRain`]: the drawn drops and the stream beyond them), its impacts computed per
    /// step, as a render feeds them frame by frame: the fast-forward of a seek.
    pub fn advance_with_rain(&mut self, rain: &GroundRain, t_s: f64) -> Result<usize> {
        self.advance_with_rain_or_stop(rain, t_s, &std::sync::atomic::AtomicBool::new(false))
    }

    /// [`advance_with_rain`](Self::advance_with_rain), stopping with [`Error::Interrupted`]
    /// between two steps once `cancel` is set (a fast-forward can take minutes; a step takes
    /// milliseconds). Each step's drops are fed as [`PuddleSim::advance_to`] is fed
    /// [`GroundRain::impacts_between`] (the drawn drops', then the stream's, in its order),
    /// but the stream's without making them [`Impact`]s: the water needs their size only
    /// under the cap.
    pub fn advance_with_rain_or_stop(
        &mut self,
        rain: &GroundRain,
        t_s: f64,
        cancel: &std::sync::atomic::AtomicBool,
    ) -> Result<usize> {
        // On one of the solver's own threads: its parallel passes over a few hundred moving
        // particles then start there, not by waking the pool from outside some five times a
        // step (the same results: each particle's update is its own).
        rayon::scope(|_| self.fast_forward(rain, t_s, cancel))
    }

    fn fast_forward(
        &mut self,
        rain: &GroundRain,
        t_s: f64,
        cancel: &std::sync::atomic::AtomicBool,
    ) -> Result<usize> {
        let mut steps = 0;
        while self.time_s + self.step_s <= t_s + 1e-9 {
            if cancel.load(std::sync::atomic::Ordering::Relaxed) {
                return Err(Error::Interrupted);
            }
            let (t0, t1) = (self.time_s, self.time_s + self.step_s);
            // Frame by frame, as a render reports them: at the cap, which drops still add
            // water depends on their order.
            let m = self.frames_per_step.max(1);
            for f in 0..m {
                let a = t0 + self.step_s * f as f64 / m as f64;
                let b = if f + 1 == m {
                    t1
                } else {
                    t0 + self.step_s * (f + 1) as f64 / m as f64
                };
                self.feed_rain(rain, a, b);
            }
            steps += self.step_to(t1)?;
        }
        Ok(steps)
    }

    /// Feeds all the rain landing on the footprint with time in (t0_s, t1_s] and runs the
    /// solver in whole steps up to `t1_s`: [`PuddleSim::advance_to`] with
    /// [`GroundRain::impacts_between`]'s drops, the same state, without making the stream's
    /// drops impacts. A render's frame.
    pub fn advance_with_rain_between(
        &mut self,
        rain: &GroundRain,
        t0_s: f64,
        t1_s: f64,
    ) -> Result<usize> {
        self.feed_rain(rain, t0_s, t1_s);
        self.step_to(t1_s)
    }

    /// The drops of (t0_s, t1_s] to the counters and the carpet (its wetting held back):
    /// the drawn drops', then the stream's, in [`GroundRain::impacts_between`]'s order.
    fn feed_rain(&mut self, rain: &GroundRain, t0_s: f64, t1_s: f64) {
        let mut room = self.room();
        for hit in impacts_between(rain.rainfall(), t0_s, t1_s) {
            let (x, y) = (hit.position_m.x as f32, hit.position_m.y as f32);
            self.land(x, y, || hit.diameter_mm, &mut room);
        }
        let mut kept = std::mem::take(&mut self.stream);
        let rect = self.ground_rect();
        rain.stream_landings_kept(&mut kept, &rect, t0_s, t1_s, |landing| {
            let p = landing.position_m;
            self.land(
                p.x as f32,
                p.y as f32,
                || rain.landing_diameter_mm(&landing),
                &mut room,
            );
        });
        self.stream = kept;
    }

    /// The simulated ground as the rectangle the rain is asked for.
    pub fn ground_rect(&self) -> GroundRect {
        GroundRect {
            min_m: self.footprint.min_m,
            max_m: self.footprint.max_m,
        }
    }

    /// Whether (x, y) falls on the precipitation grid.
    fn footprint_contains(&self, x_m: f32, y_m: f32) -> bool {
        let (nx, ny) = self.flow.precipitation.dims();
        let b = &self.flow.sph.boundaries().domain;
        let cell = self.flow.carpet.settings().cell_m;
        let g = (Vec2::new(x_m, y_m) - b.min_m.truncate()) / cell;
        g.x >= 0.0 && g.y >= 0.0 && g.x < nx as f32 && g.y < ny as f32
    }

    /// This water (read from a checkpoint) with the parts a checkpoint leaves out, taken from
    /// `fresh`: the same water built anew from the same configuration.
    pub fn with_fixed_parts_of(mut self, mut fresh: PuddleSim) -> PuddleSim {
        self.flow
            .sph
            .replace_terrain(fresh.flow.sph.replace_terrain(None));
        self.initial = fresh.initial;
        self
    }

    /// Simulated time, s.
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// Solver steps so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The simulated ground, z = 0 world metres.
    pub fn footprint(&self) -> Footprint {
        self.footprint
    }

    /// Water depth above the relief on the carpet's grid (cell-centred, world x/y metres on
    /// the ground z = 0), m: what the shading draws.
    pub fn water_depth(&self) -> Field2 {
        self.flow.water_depth()
    }

    /// The water map the picture is shaded from ([`super::shown::water_map`]): on the carpet's
    /// grid, the smoothed level of the water above each leaf's ground, negative where dry, so
    /// a puddle's rim falls where its level meets the ground, between the leaves.
    pub fn shown_depth(&self) -> Field2 {
        super::shown::water_map(&self.flow.carpet.surface_height(), &self.water_depth())
    }

    /// [`shown_depth`](Self::shown_depth) kept in `kept` from the last frame it was asked
    /// for, made again only where the water changed since (the same map to the bit).
    pub fn shown_depth_kept<'a>(&mut self, kept: &'a mut KeptWaterMap) -> &'a Field2 {
        let visited = self.flow.carpet.take_visited(kept.take_spare_list());
        let carpet = &self.flow.carpet;
        kept.update_visited(&carpet.leaf_grid(), visited, |k| {
            carpet.leaf_surface_and_depth(k)
        })
    }

    /// Wetness on the carpet's grid, [0, 1].
    pub fn wetness(&self) -> Field2 {
        self.flow.wetness()
    }

    /// The pre-rain water at rest on the relief grid (the fill the particles started from), m.
    pub fn initial_depth(&self) -> &Field2 {
        &self.initial
    }

    /// The water balance now.
    pub fn ledger(&self) -> WaterLedger {
        let mut l = self.ledger;
        l.particles = self.flow.sph.ledger();
        l.rain_particles = l.particles.inserted - l.initial_particles;
        l.particles_present = self.flow.sph.particle_count() as u64;
        l
    }

    /// The particle cap (the initial puddles and, through the clip, all particles: drops that
    /// would pass it wet the ground but add no water), and whether it made the initial
    /// spacing coarser than asked.
    pub fn particle_cap(&self) -> (usize, bool) {
        (self.max_particles, self.capped)
    }

    /// Particle spacing in use, m.
    pub fn particle_spacing_m(&self) -> f32 {
        self.flow.sph.settings().particle_spacing_m
    }

    /// The surface flow (solver, counters, carpet).
    pub fn flow(&self) -> &SurfaceFlow {
        &self.flow
    }
}

/// Turns the filled water into particles on a lattice of `spacing` columns (see the module
/// docs), only in the columns `in_view(x, y, ground)` says the picture shows and at most
/// `max_particles`; returns the water left over (less than one particle) and the water not
/// simulated (outside the picture or beyond the cap), m³. `grid`: the fill's vertices along x,
/// their spacing and origin.
fn place_particles(
    flow: &mut SurfaceFlow,
    filled: &FilledWater,
    (nx, cell, origin): (usize, f32, Vec2),
    spacing: f32,
    (max_particles, settled_start): (usize, bool),
    in_view: impl Fn(f32, f32, f32) -> bool,
) -> Result<(f64, f64)> {
    let b = flow.sph.boundaries();
    let (lo, hi) = (b.domain.min_m.truncate(), b.domain.max_m.truncate());

    let cols = ((hi - lo) / spacing).floor().max(Vec2::ONE);
    let (cx, cy) = (cols.x as usize, cols.y as usize);
    let mut water = vec![0.0f64; cx * cy];
    let area = (cell as f64).powi(2);
    for (v, &d) in filled.depth_m.iter().enumerate() {
        if d > 0.0 {
            let p = origin + Vec2::new((v % nx) as f32, (v / nx) as f32) * cell;
            let g = ((p - lo) / spacing).floor();
            let (i, j) = (
                (g.x.max(0.0) as usize).min(cx - 1),
                (g.y.max(0.0) as usize).min(cy - 1),
            );
            water[j * cx + i] += d as f64 * area;
        }
    }
    resample(
        &mut water,
        &filled.depth_m,
        ((nx, cell, origin), (cx, lo, spacing)),
    );
    let volume = (spacing as f64).powi(3);
    let (mut carry, mut outside) = (0.0, 0.0);
    for (c, &w) in water.iter().enumerate() {
        if w == 0.0 {
            continue;
        }
        let xy = lo + (Vec2::new((c % cx) as f32, (c / cx) as f32) + 0.5) * spacing;
        let ground = flow.sph.boundaries().ground_m(xy.x, xy.y);
        let room = max_particles.saturating_sub(flow.sph.particle_count()) as f64;
        if !in_view(xy.x, xy.y, ground) || room == 0.0 {
            outside += w;
            continue;
        }
        carry += w;
        let k = (carry / volume).floor().min(room);
        carry -= k * volume;
        if k == room {
            outside += carry;
            carry = 0.0;
        }
        // At rest, a column of k particles hangs from the fill's level L (the carpet puts the
        // surface a particle radius above the highest centre) at a pitch of (L − ground)/k,
        // at least half a spacing and at most one: a pool's surface stays level whatever the
        // rounding of its counts, within a quarter spacing for k ≥ 2. Stepped, the columns
        // stand on the ground at the spacing.
        let depth = (w / (spacing as f64).powi(2)) as f32;
        let pitch = (depth / k.max(1.0) as f32).clamp(0.5 * spacing, spacing);
        for m in 0..k as usize {
            let m = m as f32;
            if settled_start {
                let hung = ground + depth - (k as f32 - m - 0.5) * pitch;
                let z = hung.max(ground + (m + 0.5) * pitch);
                flow.sph.add_resting_particle(Vec3::new(xy.x, xy.y, z))?;
            } else {
                let z = ground + (m + 0.5) * spacing;
                flow.sph
                    .add_particle(Vec3::new(xy.x, xy.y, z), Vec3::ZERO)?;
            }
        }
    }
    Ok((carry, outside))
}
