//! The ground the water runs on: the footprint of the picture's ground on z = 0 up to a
//! distance, and a seeded fractal micro-relief over it (in the fluid's height field only; the
//! ground's image is not displaced).
//!
//! How it works: [`ground_footprint`] casts a grid of view rays through the picture onto the
//! ground z = 0 and takes the bounding box of the hits, each pulled back to `max_distance_m`
//! (horizontal) from the camera where it lands farther: the ground beyond is seen at a
//! grazing angle and through the haze, and would cost particles nobody sees.
//! [`micro_relief`] is fractional Brownian motion: octaves of value noise (hashed lattice
//! values, quintic interpolation) with wavelengths halving from 2 m down to two grid cells and
//! amplitudes ∝ λ^H, H = 0.8 (a rough but not jagged surface), shifted to zero mean and scaled
//! to the standard deviation asked for over the simulated ground.

use glam::{DVec2, Vec2};
use rayon::prelude::*;

use crate::fluid::terrain::HeightField;
use crate::rng::splitmix64;
use crate::scene::Camera;
use crate::{Error, Result};

/// Longest wavelength of the micro-relief, m: a road's unevenness between its camber and the
/// texture of its surface.
pub const LONGEST_WAVELENGTH_M: f64 = 2.0;

/// Hurst exponent of the relief: amplitude ∝ wavelength^H.
pub const HURST: f64 = 0.8;

/// An axis-aligned rectangle of the ground z = 0, world metres.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Footprint {
    /// Corner with the smallest x and y, m.
    pub min_m: DVec2,
    /// Corner with the largest x and y, m.
    pub max_m: DVec2,
}

impl Footprint {
    /// Extent along x and y, m.
    pub fn size_m(&self) -> DVec2 {
        self.max_m - self.min_m
    }
}

/// The bounding box of the ground z = 0 the picture shows, nearer than `max_distance_m`
/// (horizontal distance from the camera); `None` when the picture shows no ground there (the
/// camera looks above the horizon, or stands on the ground).
pub fn ground_footprint(camera: &Camera, max_distance_m: f64) -> Option<Footprint> {
    const RAYS: usize = 32;
    let eye = camera.position_m;
    if !(eye.z > 0.0 && max_distance_m > 0.0) {
        return None;
    }
    let (w, h) = (camera.width_px as f64, camera.height_px as f64);
    let mut bounds: Option<(DVec2, DVec2)> = None;
    for j in 0..=RAYS {
        for i in 0..=RAYS {
            let px = DVec2::new(w * i as f64 / RAYS as f64, h * j as f64 / RAYS as f64);
            let ray = camera.ray_world(px);
            if ray.z >= -1e-9 {
                continue;
            }
            let hit = eye + ray * (eye.z / -ray.z);
            let mut offset = hit.truncate() - eye.truncate();
            let distance = offset.length();
            if distance > max_distance_m {
                offset *= max_distance_m / distance;
            }
            let p = eye.truncate() + offset;
            bounds = Some(match bounds {
                None => (p, p),
                Some((lo, hi)) => (lo.min(p), hi.max(p)),
            });
        }
    }
    bounds
        .filter(|(lo, hi)| (*hi - *lo).min_element() > 0.0)
        .map(|(min_m, max_m)| Footprint { min_m, max_m })
}

/// A value of the lattice noise of octave `octave` at lattice point (i, j), in [−1, 1).
fn lattice(seed: u32, octave: u32, i: i64, j: i64) -> f64 {
    let key = splitmix64(((seed as u64) << 32) | octave as u64) ^ splitmix64(i as u64);
    let bits = splitmix64(key ^ splitmix64(j as u64).rotate_left(17));
    (bits >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Value noise of one octave at (x, y) in lattice units: bilinear in the quintic fade of the
/// fractions, so its slope is continuous. (The plain form [`LatticeRows`] is tested against.)
#[cfg(test)]
fn value_noise(seed: u32, octave: u32, x: f64, y: f64) -> f64 {
    let fade = |t: f64| t * t * t * (t * (6.0 * t - 15.0) + 10.0);
    let (i, j) = (x.floor(), y.floor());
    let (u, v) = (fade(x - i), fade(y - j));
    let (i, j) = (i as i64, j as i64);
    let a = lattice(seed, octave, i, j);
    let b = lattice(seed, octave, i + 1, j);
    let c = lattice(seed, octave, i, j + 1);
    let d = lattice(seed, octave, i + 1, j + 1);
    (a + (b - a) * u) * (1.0 - v) + (c + (d - c) * u) * v
}

/// One octave's lattice values along the two lattice rows around lattice coordinate `y` (for
/// a run of x from `x_lo` to `x_hi`, lattice units, increasing): [`value_noise`] at (x, y) for
/// any x in the run, from values hashed once per lattice point instead of four per call.
struct LatticeRows {
    /// The first lattice column held.
    i0: i64,
    /// The lattice values of rows ⌊y⌋ and ⌊y⌋ + 1 from column `i0` on.
    below: Vec<f64>,
    above: Vec<f64>,
    /// The quintic fade of y's fraction.
    v: f64,
}

impl LatticeRows {
    fn new(seed: u32, octave: u32, y: f64, (x_lo, x_hi): (f64, f64)) -> LatticeRows {
        let fade = |t: f64| t * t * t * (t * (6.0 * t - 15.0) + 10.0);
        let j = y.floor();
        let v = fade(y - j);
        let j = j as i64;
        let (i0, i1) = (x_lo.floor() as i64, x_hi.floor() as i64 + 1);
        let row = |j: i64| (i0..=i1).map(|i| lattice(seed, octave, i, j)).collect();
        LatticeRows {
            i0,
            below: row(j),
            above: row(j + 1),
            v,
        }
    }

    /// [`value_noise`] at (x, y), the same expression on the same values.
    #[inline]
    fn value_noise(&self, x: f64) -> f64 {
        let fade = |t: f64| t * t * t * (t * (6.0 * t - 15.0) + 10.0);
        let i = x.floor();
        let u = fade(x - i);
        let k = (i as i64 - self.i0) as usize;
        let (a, b) = (self.below[k], self.below[k + 1]);
        let (c, d) = (self.above[k], self.above[k + 1]);
        let v = self.v;
        (a + (b - a) * u) * (1.0 - v) + (c + (d - c) * u) * v
    }
}

/// The micro-relief at the `nx × ny` vertices from `origin_m` at `spacing_m`: zero mean,
/// standard deviation `relief_m` over these vertices (all zero when `relief_m` is 0).
pub fn micro_relief(
    nx: usize,
    ny: usize,
    origin_m: Vec2,
    spacing_m: f32,
    relief_m: f64,
    seed: u32,
) -> Vec<f32> {
    let spacing = spacing_m as f64;
    let octaves: Vec<(u32, f64, f64)> = (0u32..12)
        .map(|k| (k, LONGEST_WAVELENGTH_M / f64::from(1u32 << k)))
        .take_while(|&(k, lambda)| k == 0 || lambda >= 2.0 * spacing)
        .map(|(k, lambda)| (k, lambda, lambda.powf(HURST)))
        .collect();
    // Row by row (collected in order): the same values whatever the threads. Each octave's
    // lattice values along the row's two lattice rows are hashed once per row
    // ([`LatticeRows`]), not four times per vertex: the same values, a few times cheaper.
    let mut raw = vec![0.0f64; nx * ny];
    raw.par_chunks_mut(nx.max(1))
        .enumerate()
        .with_min_len(8)
        .for_each(|(row, out)| {
            let y = origin_m.y as f64 + row as f64 * spacing;
            let x_at = |i: usize| origin_m.x as f64 + i as f64 * spacing;
            let rows: Vec<LatticeRows> = octaves
                .iter()
                .map(|&(k, lambda, _)| {
                    LatticeRows::new(
                        seed,
                        k,
                        y / lambda,
                        (x_at(0) / lambda, x_at(nx - 1) / lambda),
                    )
                })
                .collect();
            for (i, z) in out.iter_mut().enumerate() {
                let x = x_at(i);
                *z = octaves
                    .iter()
                    .zip(&rows)
                    .map(|(&(_, lambda, amplitude), r)| amplitude * r.value_noise(x / lambda))
                    .sum();
            }
        });
    let n = raw.len().max(1) as f64;
    let mean = raw.iter().sum::<f64>() / n;
    let sd = (raw.iter().map(|z| (z - mean) * (z - mean)).sum::<f64>() / n).sqrt();
    let gain = if sd > 0.0 { relief_m / sd } else { 0.0 };
    raw.iter().map(|z| ((z - mean) * gain) as f32).collect()
}

/// `terrain` with `relief` (one value per vertex, as [`micro_relief`] makes) added.
pub fn with_relief(terrain: &HeightField, relief: &[f32]) -> Result<HeightField> {
    if relief.len() != terrain.heights_m().len() {
        return Err(Error::Parameter {
            name: "relief",
            value: format!("{} values", relief.len()),
            expected: format!("{} (one per vertex)", terrain.heights_m().len()),
        });
    }
    let heights = terrain
        .heights_m()
        .iter()
        .zip(relief)
        .map(|(h, r)| h + r)
        .collect();
    HeightField::new(
        terrain.nx(),
        terrain.ny(),
        terrain.origin_m(),
        terrain.spacing_m(),
        heights,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`micro_relief`] against the plain sum of [`value_noise`] per vertex: the same bits,
    /// on grids across lattice lines and the origin, with negative coordinates.
    #[test]
    fn rows_of_lattice_values_give_the_plain_noise_bit_for_bit() {
        for (nx, ny, origin, spacing) in [
            (64, 48, Vec2::new(-1.0, 2.0), 0.02),
            (203, 37, Vec2::new(-10.006_568, 4.717_247), 0.02),
            (17, 90, Vec2::new(0.013, -3.3), 0.0371),
            (2, 2, Vec2::ZERO, 0.5),
        ] {
            let spacing_f64 = spacing as f64;
            let octaves: Vec<(u32, f64, f64)> = (0u32..12)
                .map(|k| (k, LONGEST_WAVELENGTH_M / f64::from(1u32 << k)))
                .take_while(|&(k, lambda)| k == 0 || lambda >= 2.0 * spacing_f64)
                .map(|(k, lambda)| (k, lambda, lambda.powf(HURST)))
                .collect();
            let raw: Vec<f64> = (0..nx * ny)
                .map(|v| {
                    let x = origin.x as f64 + (v % nx) as f64 * spacing_f64;
                    let y = origin.y as f64 + (v / nx) as f64 * spacing_f64;
                    octaves
                        .iter()
                        .map(|&(k, lambda, amplitude)| {
                            amplitude * value_noise(7, k, x / lambda, y / lambda)
                        })
                        .sum()
                })
                .collect();
            let n = raw.len() as f64;
            let mean = raw.iter().sum::<f64>() / n;
            let sd = (raw.iter().map(|z| (z - mean) * (z - mean)).sum::<f64>() / n).sqrt();
            let plain: Vec<u32> = raw
                .iter()
                .map(|z| (((z - mean) * (0.004 / sd)) as f32).to_bits())
                .collect();
            let rows: Vec<u32> = micro_relief(nx, ny, origin, spacing, 0.004, 7)
                .iter()
                .map(|z| z.to_bits())
                .collect();
            assert!(plain == rows, "{nx}×{ny} from {origin} at {spacing}");
        }
    }

    #[test]
    fn relief_has_the_asked_spread_and_is_seeded() {
        let a = micro_relief(64, 48, Vec2::new(-1.0, 2.0), 0.02, 0.004, 3);
        let mean = a.iter().map(|&z| z as f64).sum::<f64>() / a.len() as f64;
        let sd =
            (a.iter().map(|&z| (z as f64 - mean).powi(2)).sum::<f64>() / a.len() as f64).sqrt();
        assert!(
            mean.abs() < 1e-6 && (sd - 0.004).abs() < 1e-6,
            "{mean} {sd}"
        );
        assert_eq!(
            a,
            micro_relief(64, 48, Vec2::new(-1.0, 2.0), 0.02, 0.004, 3)
        );
        assert_ne!(
            a,
            micro_relief(64, 48, Vec2::new(-1.0, 2.0), 0.02, 0.004, 4)
        );
        assert!(
            micro_relief(8, 8, Vec2::ZERO, 0.02, 0.0, 3)
                .iter()
                .all(|&z| z == 0.0)
        );
    }

    #[test]
    fn footprint_of_a_camera_looking_down_holds_the_ground_below_the_picture() {
        // 60° lens, 1.6 m up, tilted 10° down: the picture's bottom edge sees the ground at
        // 1.6 / tan(10° + half the vertical field of view) ahead; its top edge, the sky.
        let cam = Camera::new(160, 90, 60f64.to_radians(), 1.6, -10f64.to_radians(), 0.0);
        let f = ground_footprint(&cam, 20.0).expect("ground in view");
        let near = 1.6 / (10f64.to_radians() + 0.5 * cam.fov_y_rad()).tan();
        let forward = |p: DVec2| {
            p.dot(
                (cam.world_from_camera * glam::DVec3::Z)
                    .truncate()
                    .normalize(),
            )
        };
        let corners = [
            f.min_m,
            f.max_m,
            DVec2::new(f.min_m.x, f.max_m.y),
            DVec2::new(f.max_m.x, f.min_m.y),
        ];
        let nearest = corners
            .iter()
            .map(|&c| forward(c))
            .fold(f64::INFINITY, f64::min);
        let farthest = corners
            .iter()
            .map(|&c| forward(c))
            .fold(f64::NEG_INFINITY, f64::max);
        assert!((nearest - near).abs() < 0.05, "{nearest} vs {near}");
        assert!(farthest <= 20.0 + 1e-9 && farthest > 19.0, "{farthest}");
        let up = Camera::new(160, 90, 60f64.to_radians(), 1.6, 40f64.to_radians(), 0.0);
        assert!(ground_footprint(&up, 20.0).is_none());
    }
}
