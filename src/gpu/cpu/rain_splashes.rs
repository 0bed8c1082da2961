//! The CPU twin of the `rain_splashes` stage (`shaders/rain_splashes.wgsl`): the streaks a
//! landing drop's splash draws in the frame, from its exact impact
//! ([`latest_impact`](crate::rain::volume::latest_impact)) and the splash model
//! ([`crate::rain::physics::splash`]). `tests/splashes.rs` holds the GPU to it.
//!
//! ## How it works
//! The drop's latest impact before the exposure closes, placed as the stage places it
//! ([`placed_from_frame`]), if it splashed (K above the threshold),
//! draws its crown (slot 0) while the crown stands and each of its drawn droplets (slots 1…)
//! while it flies: the chord of the part of its arc inside the exposure, its alpha scaled by
//! that part of the exposure and by the real droplets it stands for. The crown is the drop's own
//! water spread over a capsule of the crown's radius and height, so its coverage is the drop's
//! projected area. Anything thinner than a pixel at its distance is skipped.

use glam::{DVec2, DVec3};

use super::rain_simulate::StreakShape;
use crate::gpu::types::RainParams;
use crate::gpu::uniforms::RainSetup;
use crate::rain::physics::G_MPS2;
use crate::rain::physics::splash::{
    CROWN_S, SPLASH_STREAM, crown_height_m, crown_radius_m, droplet, splash_size,
};
use crate::rain::volume::drop::{SPEED_BITS, SplitTime, drift_cells, lateral_fractions};
use crate::rain::volume::{Impact, cycle_uniform, latest_impact};

/// One streak of a splash.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplashStreak {
    /// Slot in the drop's splash: 0 the crown, j + 1 droplet j.
    pub slot: u32,
    /// The streak.
    pub shape: StreakShape,
    /// Its ends in the world (before near clipping), m.
    pub ends_world_m: [DVec3; 2],
}

/// The streak of water `width_m` wide moving from `w0` to `w1` (world) while in view for
/// `exposed` of the exposure, its coverage times `weight`; `None` where the GPU hides it
/// (behind the near plane, thinner than a pixel, fainter than the visibility threshold, off
/// the picture). Splashes are never capped in width.
pub fn segment_streak(
    p: &RainParams,
    w0: DVec3,
    w1: DVec3,
    exposed: f64,
    width_m: f64,
    weight: f64,
) -> Option<StreakShape> {
    super::rain_simulate::segment_streak(p, w0, w1, exposed, 0.5 * width_m, weight, f64::MAX, 1.0)
}

/// Drop `id`'s latest impact before the exposure around `t_s` closes, and the streaks its
/// splash draws in the frame under the uniforms `p` (which must be `setup.motion_at(t_s)` or
/// a lit copy of it). Nothing without a ground (`RainParams::ground_clip`).
pub fn splash_streaks(
    setup: &RainSetup,
    p: &RainParams,
    id: u64,
    t_s: f64,
) -> (Option<Impact>, Vec<SplashStreak>) {
    if p.ground_clip == 0 {
        return (None, Vec::new());
    }
    let exposure = p.exposure_s as f64;
    let (a, b) = (t_s - 0.5 * exposure, t_s + 0.5 * exposure);
    let Some(hit) = latest_impact(setup.rainfall(), id, b) else {
        return (None, Vec::new());
    };
    let hit = placed_from_frame(setup, p, hit, t_s);
    let mut out = Vec::new();
    let (d_mm, v) = (hit.diameter_mm, hit.normal_speed_mps());
    let Some(size) = splash_size(d_mm, v) else {
        return (Some(hit), out);
    };
    let scale = p.diameter_scale as f64;
    let (a, b) = (a - hit.time_s, b - hit.time_s);
    let mut push = |slot, w0: DVec3, w1: DVec3, exposed, width_m, weight| {
        if let Some(shape) = segment_streak(p, w0, w1, exposed, width_m, weight) {
            out.push(SplashStreak {
                slot,
                shape,
                ends_world_m: [w0, w1],
            });
        }
    };
    let (c_lo, c_hi) = (a.max(0.0), b.min(CROWN_S));
    if c_hi > c_lo {
        let tau = 0.5 * (c_lo + c_hi);
        let r = crown_radius_m(d_mm, v, tau);
        let h = crown_height_m(d_mm, v, tau);
        let d = d_mm * 1e-3;
        let cover =
            std::f64::consts::PI * 0.25 * d * d / (2.0 * r * h + std::f64::consts::PI * r * r);
        let top = hit.position_m + DVec3::Z * h;
        push(
            0,
            hit.position_m,
            top,
            (c_hi - c_lo) / exposure,
            2.0 * r * scale,
            cover,
        );
    }
    let weight = size.count / size.drawn as f64;
    for j in 0..size.drawn {
        let stream = SPLASH_STREAM + 4 * j;
        let u =
            std::array::from_fn(|s| cycle_uniform(p.seed, id as u32, hit.pass, stream + s as u32));
        let drop = droplet(d_mm, v, j, size.drawn, u);
        let (lo, hi) = (a.max(drop.launch_s), b.min(drop.launch_s + drop.flight_s));
        if hi <= lo {
            continue;
        }
        push(
            j + 1,
            hit.position_m + drop.position_m(lo),
            hit.position_m + drop.position_m(hi),
            (hi - lo) / exposure,
            size.droplet_mm * 1e-3 * scale,
            weight,
        );
    }
    (Some(hit), out)
}

/// `hit` placed as the stage places it: the drop's drift at the frame's time `t_s` moved back
/// (or on) at the frame's drift rate to the impact, in the impact's pass. Exact in steady wind;
/// with gusts it stands for the exact point ([`latest_impact`]) over the fraction of a second
/// a splash lives.
pub fn placed_from_frame(setup: &RainSetup, p: &RainParams, hit: Impact, t_s: f64) -> Impact {
    let (volume, wind) = (&setup.volume, &setup.wind);
    let grid = &volume.grid;
    let Some(ci) = grid.column_of(hit.id) else {
        return hit;
    };
    let vt = hit.normal_speed_mps();
    let speed_q = (vt * (1u32 << SPEED_BITS) as f64).round() as u32;
    let t = SplitTime::new(t_s);
    let vh = wind.drop_velocity_mps(t.seconds(), vt / G_MPS2);
    let cells_per_s = (vh + grid.slope * vt) / grid.cell_size_m.max(DVec2::splat(1e-6));
    let drift = drift_cells(volume, wind, speed_q, t) - cells_per_s * (t_s - hit.time_s);
    let uv = lateral_fractions(p.seed, hit.id as u32, drift, hit.pass);
    let mut position_m = grid.point_m(&grid.columns[ci], [uv[0], uv[1], 0.0]);
    position_m.z = 0.0;
    Impact { position_m, ..hit }
}
