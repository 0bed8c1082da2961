//! Where and when drops land: closed form from the stateless drop.
//!
//! A drop falls through its column in column heights at the constant rate r (its fixed-point
//! fall rate, [`fall_rate_q`]): its height fraction is x(t) = u₂ − r t modulo 1, and it wraps
//! through the column's bottom — lands, where the bottom is the ground — each time x(t)
//! crosses an integer c, at t = (u₂ − c)/r. Its pass through the column before that impact is c
//! (the pass index is ⌊x(t)⌋, modulo 2³²), so the point of impact is the column point of the
//! lateral fractions of pass c at that time. Everything is a pure function of (seed, drop id,
//! t), so a preview, a chunk and a full render see the same impacts.
//!
//! Only columns whose bottom is the ground z = 0 land; the others wrap at the view volume's
//! edge, which is no surface.

use glam::DVec3;

use super::RainVolume;
use super::drop::{
    FALL_RATE_BITS, SPEED_BITS, SplitTime, drift_cells, drop_uniform, fall_rate_q, falls,
    inv_height_q, lateral_fractions, size_bits,
};
use super::rainfall::Rainfall;
use crate::rain::physics::G_MPS2;

/// A column bottom this close to z = 0 (m) stands on the ground.
pub const GROUND_TOLERANCE_M: f64 = 1e-6;

/// One drop landing on the ground z = 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// Drop id.
    pub id: u64,
    /// The drop's pass through its column that ended here (seeds the splash's randomness).
    pub pass: u32,
    /// Time of impact, s.
    pub time_s: f64,
    /// Point of impact (z = 0), m.
    pub position_m: DVec3,
    /// Diameter, mm (physical, not the drawn one).
    pub diameter_mm: f64,
    /// Velocity at impact, m/s (z < 0: the fall speed).
    pub velocity_mps: DVec3,
}

impl Impact {
    /// Speed normal to the ground, m/s.
    pub fn normal_speed_mps(&self) -> f64 {
        -self.velocity_mps.z
    }
}

/// Indices of the columns whose bottom is the ground.
pub fn landing_columns(volume: &RainVolume) -> impl Iterator<Item = usize> + '_ {
    volume
        .grid
        .columns
        .iter()
        .enumerate()
        .filter(|(_, c)| c.z_lo_m.abs() < GROUND_TOLERANCE_M)
        .map(|(i, _)| i)
}

/// The size quantile (24 bits) of drop `id` in column `ci`, truncated to the column's sizes.
fn size_q(volume: &RainVolume, seed: u32, ci: usize, id: u64) -> u32 {
    size_bits(seed, id as u32, volume.grid.columns[ci].size_keep_q)
}

/// The diameter of drop `id` in column `ci`, mm (physical).
fn diameter_mm(rain: Rainfall, ci: usize, id: u64) -> f64 {
    let q = size_q(rain.volume, rain.seed, ci, id);
    rain.model
        .dsd
        .diameter_from_uniform_mm(q as f64 * (1.0 / 16_777_216.0))
}

/// The fall of drop `id` in column `ci`: (u₂, rate in column heights per second, speed_q).
fn fall(volume: &RainVolume, seed: u32, ci: usize, id: u64) -> (f64, f64, u32) {
    let col = &volume.grid.columns[ci];
    let speed_q = volume.motion.fall_speed_q(size_q(volume, seed, ci, id));
    let rate_q = fall_rate_q(speed_q, inv_height_q(col.height_m()));
    (
        drop_uniform(seed, id as u32, 2),
        rate_q as f64 / (1u32 << FALL_RATE_BITS) as f64,
        speed_q,
    )
}

/// The impact of drop `id` (in column `ci`) when its height fraction crosses the integer `c`.
fn impact(rain: Rainfall, ci: usize, id: u64, c: i64) -> Impact {
    let Rainfall {
        volume, wind, seed, ..
    } = rain;
    let (u2, rate, speed_q) = fall(volume, seed, ci, id);
    let time_s = (u2 - c as f64) / rate;
    let pass = c as u32;
    let t = SplitTime::new(time_s);
    let id32 = id as u32;
    let uv = lateral_fractions(seed, id32, drift_cells(volume, wind, speed_q, t), pass);
    let col = &volume.grid.columns[ci];
    let mut position_m = volume.grid.point_m(col, [uv[0], uv[1], 0.0]);
    position_m.z = 0.0;
    let vt = speed_q as f64 / (1u32 << SPEED_BITS) as f64;
    let vh = wind.drop_velocity_mps(t.seconds(), vt / G_MPS2);
    Impact {
        id,
        pass,
        time_s,
        position_m,
        diameter_mm: diameter_mm(rain, ci, id),
        velocity_mps: DVec3::new(vh.x, vh.y, -vt),
    }
}

/// Whether the pass of drop `id` (in column `ci`) that ends when its height fraction crosses
/// `c` falls at all ([`falls`]): it was born one column height before.
fn pass_falls(rain: Rainfall, ci: usize, id: u64, c: i64) -> bool {
    let Rainfall {
        volume,
        model,
        seed,
        ..
    } = rain;
    let (u2, rate, _) = fall(volume, seed, ci, id);
    let birth_s = (u2 - c as f64 - 1.0) / rate;
    falls(
        model,
        seed,
        id as u32,
        c as u32,
        birth_s,
        diameter_mm(rain, ci, id),
    )
}

/// Every impact on the ground in (t0_s, t1_s], 0 ≤ t0_s, in drop order then time order.
pub fn impacts_between(rain: Rainfall, t0_s: f64, t1_s: f64) -> Vec<Impact> {
    let Rainfall { volume, seed, .. } = rain;
    let mut out = Vec::new();
    for ci in landing_columns(volume) {
        let col = &volume.grid.columns[ci];
        for id in col.first_id..col.first_id + col.count as u64 {
            let (u2, rate, _) = fall(volume, seed, ci, id);
            if rate <= 0.0 {
                continue;
            }
            // x = u₂ − r t ∈ [u₂ − r t₁, u₂ − r t₀): the integers crossed, earliest first.
            let lo = (u2 - rate * t1_s).ceil() as i64;
            let hi = (u2 - rate * t0_s.max(0.0)).ceil() as i64;
            for c in (lo..hi).rev() {
                if pass_falls(rain, ci, id, c) {
                    out.push(impact(rain, ci, id, c));
                }
            }
        }
    }
    out
}

/// Drop `id`'s latest impact at or before `t_s` (`None` if its column does not stand on the
/// ground, or its latest impact would be before t = 0).
pub fn latest_impact(rain: Rainfall, id: u64, t_s: f64) -> Option<Impact> {
    let Rainfall { volume, seed, .. } = rain;
    let ci = volume.grid.column_of(id)?;
    if volume.grid.columns[ci].z_lo_m.abs() >= GROUND_TOLERANCE_M {
        return None;
    }
    let (u2, rate, _) = fall(volume, seed, ci, id);
    if rate <= 0.0 {
        return None;
    }
    let c = (u2 - rate * t_s).ceil() as i64;
    let hit = impact(rain, ci, id, c);
    (hit.time_s >= 0.0 && pass_falls(rain, ci, id, c)).then_some(hit)
}
