//! Recovered light sources followed over frames, so lights neither flicker nor jump.

use std::collections::VecDeque;

use glam::DVec3;

use super::recovery::luminance;
use super::sources::LightSource;

/// Smallest angle at which two sightings of a source are the same source, radians.
const MATCH_MIN_RAD: f64 = 0.035;

/// Temporal smoothing of the recovered sources over a window of past frames, reset at scene
/// cuts: a pure function of the frames in the window, like
/// [`ShSmoother`](super::envmap::ShSmoother), with the same weights `exp(−(t − t_k)/τ)` over
/// (t − 4τ, t].
///
/// Sightings are grouped by direction (newest first; a sighting joins the group whose newest
/// direction is within `max(2°, 2 (r_a + r_b))`, r the sources' angular radii). A group's flux
/// `L Ω` is the weighted mean over *all* frames of the window, a frame that did not see it
/// counting as zero, so a lamp that switches on fades in over τ and a lamp flickering every other
/// frame shows as a steady lamp at its mean flux instead of blinking; its solid angle and
/// direction are the weighted means over the frames that saw it.
#[derive(Debug, Clone)]
pub struct LightTracker {
    time_constant_secs: f64,
    window_secs: f64,
    window: VecDeque<(f64, Vec<LightSource>)>,
}

impl LightTracker {
    /// A tracker with time constant `time_constant_secs` (0: no smoothing) and window
    /// `window_secs` (the smoother's).
    pub fn new(time_constant_secs: f64, window_secs: f64) -> LightTracker {
        LightTracker {
            time_constant_secs,
            window_secs,
            window: VecDeque::new(),
        }
    }

    /// Forgets the history.
    pub fn reset(&mut self) {
        self.window.clear();
    }

    /// Feeds the sources seen at `t_secs` (increasing); `cut` restarts the window. Returns the
    /// smoothed sources, brightest first.
    pub fn update(&mut self, lights: &[LightSource], t_secs: f64, cut: bool) -> Vec<LightSource> {
        if cut || self.time_constant_secs <= 0.0 {
            self.window.clear();
        }
        self.window.push_back((t_secs, lights.to_vec()));
        let horizon = t_secs - self.window_secs;
        while self.window.len() > 1 && self.window.front().is_some_and(|(t, _)| *t <= horizon) {
            self.window.pop_front();
        }
        struct Group {
            newest: LightSource,
            flux: [f64; 3],
            omega_w: f64,
            w_seen: f64,
            dir: DVec3,
            last_frame: usize,
        }
        let mut groups: Vec<Group> = Vec::new();
        let mut total_w = 0.0;
        for (frame, (t, seen)) in self.window.iter().rev().enumerate() {
            let w = if self.time_constant_secs > 0.0 {
                (-(t_secs - t) / self.time_constant_secs).exp()
            } else {
                1.0
            };
            total_w += w;
            for l in seen {
                let r = (l.solid_angle_sr / std::f64::consts::PI).sqrt();
                let phi = l.radiance_times_solid_angle();
                let weight_dir = luminance(phi).max(1e-300);
                let found = groups.iter_mut().find(|g| {
                    let rg = (g.newest.solid_angle_sr / std::f64::consts::PI).sqrt();
                    let limit = MATCH_MIN_RAD.max(2.0 * (r + rg));
                    g.newest.direction_world.dot(l.direction_world) >= limit.min(3.0).cos()
                });
                match found {
                    Some(g) => {
                        (0..3).for_each(|k| g.flux[k] += w * phi[k]);
                        if g.last_frame != frame {
                            g.omega_w += w * l.solid_angle_sr;
                            g.w_seen += w;
                            g.last_frame = frame;
                        }
                        g.dir += w * weight_dir * l.direction_world;
                    }
                    None => groups.push(Group {
                        newest: *l,
                        flux: phi.map(|v| w * v),
                        omega_w: w * l.solid_angle_sr,
                        w_seen: w,
                        dir: w * weight_dir * l.direction_world,
                        last_frame: frame,
                    }),
                }
            }
        }
        let mut out: Vec<LightSource> = groups
            .into_iter()
            .filter(|g| g.w_seen > 0.0 && g.omega_w > 0.0)
            .map(|g| {
                let omega = g.omega_w / g.w_seen;
                LightSource {
                    direction_world: g.dir.normalize_or(g.newest.direction_world),
                    solid_angle_sr: omega,
                    radiance_rgb: g.flux.map(|f| f / total_w / omega),
                    distance_m: g.newest.distance_m,
                }
            })
            .collect();
        out.sort_by(|a, b| {
            luminance(b.radiance_times_solid_angle())
                .total_cmp(&luminance(a.radiance_times_solid_angle()))
        });
        out
    }
}
