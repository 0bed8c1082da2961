//! The water feed: the puddles' simulation, brought to the first frame rendered and advanced
//! with the rain that lands, handed to the compositor frame by frame.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::config::RenderConfig;
use crate::fluid::puddles::checkpoint::{self, Checkpoints};
use crate::fluid::puddles::{KeptWaterMap, PuddleSettings, PuddleSim};
use crate::gpu::Compositor;
use crate::gpu::uniforms::RainSetup;
use crate::rain::volume::{GroundRain, Impact};
use crate::scene::Camera;
use crate::scene::depth::DepthSource;
use crate::shot::Shot;
use crate::shot::rain::CameraTrack;
use crate::video::Layer;
use crate::{Error, Result};

/// Feeds the puddles (`--puddles`): the simulation is built for the first frame rendered (with
/// the relief of the clip's first depth map, if any) and brought to its time — from the clip's
/// start or from kept water, so a preview or a chunk sees the water a whole render shows
/// there; at that frame, or beforehand on its own thread ([`PuddleFeed::begin`]); then each
/// frame
/// hands it the drops that landed since the last one, and the compositor its water map and
/// the impacts of the last ring life for the ripples.
pub(super) enum PuddleFeed {
    /// No puddles.
    Off,
    /// Waiting for the first frame.
    Pending(Box<PuddlePlan>),
    /// Built for the first frame on its own thread ([`PuddleFeed::begin`]).
    Building(Box<Building>),
    /// Running.
    On(Box<PuddleRun>),
}

/// The water built on its own thread for the first frame `index`, shown at `t_s`.
pub(super) struct Building {
    plan: Box<PuddlePlan>,
    rain: GroundRain,
    index: u64,
    t_s: f64,
    thread: JoinHandle<Result<Built>>,
    /// Stops the thread's fast-forward; set when the build is dropped unfinished.
    stop: StopOnDrop,
}

/// Sets its flag when dropped: a build no one waits for stops at its next solver step.
struct StopOnDrop(Arc<AtomicBool>);

impl Drop for StopOnDrop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// The water a build made, or that it made none.
type Built = Option<(PuddleSim, Option<Keeping>)>;

impl Building {
    /// The thread's water, waited for; the caller's cancel flag, set meanwhile, stops it.
    fn join(self) -> Result<(Box<PuddlePlan>, GroundRain, Built)> {
        let Building {
            plan,
            rain,
            thread,
            stop,
            ..
        } = self;
        while !thread.is_finished() {
            if plan.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                stop.0.store(true, Ordering::Relaxed);
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        let built = thread
            .join()
            .map_err(|_| Error::Gpu("the water's thread panicked".into()))??;
        Ok((plan, rain, built))
    }
}

/// What the water is built from at the first frame.
#[derive(Clone)]
pub(super) struct PuddlePlan {
    /// The camera at the shot's start.
    camera: Camera,
    /// Every frame's camera: a camera that turns and zooms sees more ground over the shot.
    track: CameraTrack,
    fps: f64,
    config: RenderConfig,
    pub(super) checkpoints: Option<Checkpoints>,
    /// Stops the fast-forward.
    pub(super) cancel: Option<&'static AtomicBool>,
}

/// The water during a job.
pub(super) struct PuddleRun {
    sim: crate::fluid::puddles::PuddleSim,
    /// All the rain landing on the ground: the drawn drops' and the stream beyond them.
    rain: GroundRain,
    /// Every frame's camera (which rings the picture resolves, where they land).
    track: CameraTrack,
    /// The part of the simulated ground where a ring can be resolved: the only impacts the
    /// feed makes (the water takes its drops without them).
    rings: crate::rain::volume::GroundRect,
    /// The rings finer than a pixel, as a rough surface.
    far: FarRipples,
    /// The clip time the rain has been fed up to, s.
    fed_s: f64,
    /// The impacts of the last ring life whose rings the picture resolves (at most
    /// `RING_POOL`, the newest).
    recent: Vec<Impact>,
    /// Where the water is kept.
    keep: Option<Keeping>,
    /// The last frame's water map, made again only where the water changed.
    map: KeptWaterMap,
}

/// Where a run keeps its water, under which fingerprint.
#[derive(Clone)]
struct Keeping {
    checkpoints: Checkpoints,
    fingerprint: String,
}

impl PuddleRun {
    /// Keeps the water after frame `index` if it is a frame to keep; a file that cannot be
    /// written costs a later chunk time, not this render its output, so it is a warning.
    fn keep(&self, index: u64) {
        if let Some(Keeping {
            checkpoints,
            fingerprint,
        }) = &self.keep
            && checkpoints.keeps(index)
            && let Err(e) = checkpoints.save(fingerprint, index, &self.sim)
        {
            log::warn!("puddles: the water after frame {index} was not kept: {e}");
        }
    }
}

impl PuddleFeed {
    pub(super) fn new(shot: &Shot, layer: Option<Layer>) -> PuddleFeed {
        // The matte is the rain's coverage alone: no water in it.
        if !shot.config.ground.puddles || layer == Some(Layer::Matte) {
            return PuddleFeed::Off;
        }
        PuddleFeed::Pending(Box::new(PuddlePlan {
            camera: shot.camera,
            track: shot.rain.camera_track(),
            fps: shot.footage.fps,
            config: shot.config.clone(),
            checkpoints: None,
            cancel: None,
        }))
    }

    /// Starts building the water for the first frame rendered (frame `index`, shown at `t_s`)
    /// on its own thread, so that it runs beside the work before that frame (a preview's
    /// light window); [`PuddleFeed::start`] at that frame takes it, the same water as built
    /// there. No effect unless waiting for the first frame.
    pub(super) fn begin(
        &mut self,
        rain: &RainSetup,
        depth: &mut Option<DepthSource>,
        index: u64,
        t_s: f64,
    ) -> Result<()> {
        let PuddleFeed::Pending(plan) = self else {
            return Ok(());
        };
        let map = plan.first_depth_map(depth)?;
        let ground = GroundRain::new(rain.rainfall());
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (plan, ground, stop) = ((**plan).clone(), ground.clone(), stop.clone());
            std::thread::Builder::new()
                .name("water".into())
                .spawn(move || plan.build(&ground, map.as_deref(), index, t_s, &stop))
                .map_err(|e| Error::Gpu(format!("the water's thread did not start: {e}")))?
        };
        let PuddleFeed::Pending(plan) = std::mem::replace(self, PuddleFeed::Off) else {
            unreachable!("matched above");
        };
        *self = PuddleFeed::Building(Box::new(Building {
            plan,
            rain: ground,
            index,
            t_s,
            thread,
            stop: StopOnDrop(stop),
        }));
        Ok(())
    }

    /// Builds the water at the first frame rendered (frame `index`, shown at `t_s`); returns the
    /// impacts of the last ring life whose rings the picture resolves, for the ripples (none
    /// once running).
    pub(super) fn start(
        &mut self,
        rain: &RainSetup,
        depth: &mut Option<DepthSource>,
        index: u64,
        t_s: f64,
    ) -> Result<Vec<Impact>> {
        use crate::fluid::ripples::{RING_LIFE_S, ring_ground, ring_resolved};
        // Built beside the frames before for this very frame, or here.
        let plan = match std::mem::replace(self, PuddleFeed::Off) {
            PuddleFeed::Building(b) if b.index == index && b.t_s == t_s => Err(b),
            // Begun for another frame: that build stops, this one starts anew.
            PuddleFeed::Building(b) => Ok(b.plan),
            PuddleFeed::Pending(plan) => Ok(plan),
            other => {
                *self = other;
                return Ok(Vec::new());
            }
        };
        let (plan, rain, built) = match plan {
            Err(building) => building.join()?,
            Ok(plan) => {
                let rain = GroundRain::new(rain.rainfall());
                let map = plan.first_depth_map(depth)?;
                let never = AtomicBool::new(false);
                let stop = plan.cancel.unwrap_or(&never);
                let built = plan.build(&rain, map.as_deref(), index, t_s, stop)?;
                (plan, rain, built)
            }
        };
        let Some((sim, keep)) = built else {
            log::warn!(
                "ground.puddles: the {} shows no ground within reach; no puddles",
                if depth.is_some() {
                    "depth map"
                } else {
                    "picture"
                }
            );
            *self = PuddleFeed::Off;
            return Ok(Vec::new());
        };
        let track = plan.track.clone();
        // A still camera resolves rings only near it ([`ring_ground`]); a moving one is
        // asked about the whole ground.
        let rings = match track.poses(1.0).as_slice() {
            [still] => ring_ground(still, &sim.ground_rect(), rain.max_diameter_mm()),
            _ => sim.ground_rect(),
        };
        // Only the impacts whose rings the picture resolves (those `show` keeps): a few dozen
        // of the hundreds of thousands landing there in a ring's life.
        let hits = rain.impacts_between_kept(&rings, (t_s - RING_LIFE_S).max(0.0), t_s, |h| {
            ring_resolved(h, &track.at(h.time_s))
        });
        let far = FarRipples::new(&rain);
        log::info!(
            "puddles: {:.0} drops land per m²·s; single rings to {:.1} m, beyond them water of \
             RMS slope {:.3}",
            rain.flux_at(t_s),
            far.resolve_depth_m(&plan.camera),
            (rain.flux_at(t_s) * far.slope_variance_per_flux).sqrt()
        );
        let run = PuddleRun {
            sim,
            rain,
            track,
            rings,
            far,
            fed_s: t_s,
            recent: Vec::new(),
            keep,
            map: KeptWaterMap::new(),
        };
        run.keep(index);
        *self = PuddleFeed::On(Box::new(run));
        Ok(hits)
    }

    /// Feeds running water the rain that landed since the last frame and runs it to `t_s`
    /// (frame `index`, kept if due); returns those impacts whose rings the picture resolves.
    pub(super) fn advance(&mut self, index: u64, t_s: f64) -> Result<Vec<Impact>> {
        let PuddleFeed::On(run) = self else {
            return Ok(Vec::new());
        };
        if t_s <= run.fed_s {
            return Ok(Vec::new());
        }
        run.sim
            .advance_with_rain_between(&run.rain, run.fed_s, t_s)?;
        let track = &run.track;
        let hits = run
            .rain
            .impacts_between_kept(&run.rings, run.fed_s, t_s, |h| {
                crate::fluid::ripples::ring_resolved(h, &track.at(h.time_s))
            });
        run.fed_s = t_s;
        run.keep(index);
        Ok(hits)
    }

    /// The water map, the rings the picture resolves (with `hits`, the frame's new impacts) and
    /// the far water's roughness at `t_s`, to the compositor.
    pub(super) fn show(
        &mut self,
        compositor: &mut Compositor,
        hits: &[Impact],
        t_s: f64,
    ) -> Result<()> {
        use crate::fluid::ripples::{keep_rings_resolved_by, rings_on_water};
        if let PuddleFeed::On(run) = self {
            let water = run.sim.shown_depth_kept(&mut run.map);
            // A ring is judged by the camera of the moment it lands, so which rings are kept
            // depends on the impacts alone, not on the frame a render starts at.
            let track = &run.track;
            keep_rings_resolved_by(&mut run.recent, hits, t_s, |t| track.at(t));
            compositor.set_water(water)?;
            compositor.set_ripples(&rings_on_water(&run.recent, water))?;
            let slope_rms = (run.rain.flux_at(t_s) * run.far.slope_variance_per_flux).sqrt();
            let resolve_depth_m = run.far.resolve_depth_m(&run.track.at(t_s));
            compositor.set_far_ripples(slope_rms, resolve_depth_m)?;
        }
        Ok(())
    }
}

/// The ripples where single rings are finer than a pixel: the water's mean square slope per
/// unit impact flux ([`rain_slope_variance`](crate::fluid::ripples::rain_slope_variance) over
/// the sizes that land) and the camera depth where a ring of the mean landing size spans
/// [`MIN_RING_WAVELENGTH_PX`](crate::fluid::ripples::MIN_RING_WAVELENGTH_PX) (per frame: a zoom
/// moves it).
struct FarRipples {
    slope_variance_per_flux: f64,
    mean_diameter_mm: f64,
}

impl FarRipples {
    fn new(rain: &GroundRain) -> FarRipples {
        use crate::fluid::ripples::rain_slope_variance;
        let sizes_mm = rain.impact_diameters_mm(8);
        FarRipples {
            slope_variance_per_flux: rain_slope_variance(1.0, &sizes_mm),
            mean_diameter_mm: sizes_mm.iter().sum::<f64>() / sizes_mm.len() as f64,
        }
    }

    /// The camera depth beyond which `camera` resolves no single ring, m.
    fn resolve_depth_m(&self, camera: &Camera) -> f64 {
        use crate::fluid::ripples::{MIN_RING_WAVELENGTH_PX, WAVELENGTH_PER_DIAMETER};
        WAVELENGTH_PER_DIAMETER * self.mean_diameter_mm * 1e-3 * camera.focal_px()
            / MIN_RING_WAVELENGTH_PX
    }
}

impl PuddlePlan {
    /// The water at `t_s`, with where to keep it: from the latest checkpoint at or before
    /// frame `index` if there is one, otherwise built at the clip's start; either way
    /// fast-forwarded to `t_s`. `None` where no ground is in view.
    fn build(
        &self,
        rain: &GroundRain,
        depth_m: Option<&[f32]>,
        index: u64,
        t_s: f64,
        stop: &AtomicBool,
    ) -> Result<Built> {
        let started = Instant::now();
        let settings = PuddleSettings::of(&self.config);
        let fingerprint = checkpoint::fingerprint(&self.config, &self.camera, self.fps, &settings);
        let kept = self
            .checkpoints
            .as_ref()
            .and_then(|c| c.latest(&fingerprint, index));
        let keep = self.checkpoints.clone().map(|checkpoints| Keeping {
            checkpoints,
            fingerprint,
        });
        // Built either way: a checkpoint leaves out what the configuration fixes.
        let Some(fresh) = self.new_sim(depth_m, &settings)? else {
            return Ok(None);
        };
        let (from, mut sim) = match kept {
            Some((kept_index, sim)) => (
                format!("from the checkpoint of frame {kept_index}"),
                sim.with_fixed_parts_of(fresh),
            ),
            None => ("from the clip's start".to_string(), fresh),
        };
        if t_s > sim.time_s() {
            sim.advance_with_rain_or_stop(rain, t_s, stop)?;
        }
        let (cap, capped) = sim.particle_cap();
        log::info!(
            "puddles: {} particles (cap {cap}{}), water brought to {t_s:.2} s {from} in {:.1} s",
            sim.ledger().particles_present,
            if capped { ", reached" } else { "" },
            started.elapsed().as_secs_f64()
        );
        Ok(Some((sim, keep)))
    }

    /// The clip's first depth map (if any) in the camera's pixels, holes 0: the relief the
    /// water is built on, whichever frame a chunk starts at.
    fn first_depth_map(&self, depth: &mut Option<DepthSource>) -> Result<Option<Vec<f32>>> {
        let camera = &self.camera;
        Ok(match depth {
            Some(d) => Some(
                d.at(0)?
                    .resampled(camera.width_px as usize, camera.height_px as usize)
                    .depth_m
                    .into_iter()
                    .map(|z| if z.is_finite() { z } else { 0.0 })
                    .collect::<Vec<f32>>(),
            ),
            None => None,
        })
    }

    /// The water at the clip's start, on the relief of the clip's first depth map `depth_m`
    /// ([`PuddlePlan::first_depth_map`]): the ground a whole render starts from.
    fn new_sim(
        &self,
        depth_m: Option<&[f32]>,
        settings: &PuddleSettings,
    ) -> Result<Option<PuddleSim>> {
        let cameras = self.track.poses(crate::shot::rain::GROUND_VIEW_STEP_DEG);
        PuddleSim::seen_by(&self.config, &cameras, depth_m, self.fps, settings)
    }
}
