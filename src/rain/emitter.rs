//! The stateless emitter: the rain volume around the camera's view, and the CPU twin of the
//! GPU drop state (`shaders/common/drops.wgsl`).
//!
//! ## How it works
//! Drops fall along a *fall axis* (terminal velocity of a typical drop plus the mean wind). The
//! view frustum between `near_m` and `far_m` is covered by columns aligned with that axis: a
//! grid of lateral cells, each with the extent along the axis where its lines cross the frustum
//! (padded by one exposure of travel so streaks entering the view are drawn). Each column gets
//! drops in proportion to its volume, so density is uniform. A drop is born at the top of its
//! column, falls through it, and is reborn at the top with a new lateral position when it
//! leaves at the bottom (thesis §5.1.1, eq. 5.1–5.3 with rebirth): its state at time t is a
//! closed form of (seed, id, t), and a frame needs no history.
//!
//! When the expected count exceeds the budget, every column keeps its share of the budget and
//! each drop's alpha is multiplied by `expected / budget` (`drop_weight`): the mean coverage of
//! the picture — what the eye reads as density — stays right, at the price of fewer, stronger
//! streaks.

use glam::{DMat3, DVec2, DVec3, Vec3};

use crate::config::{CameraConfig, RainConfig};
use crate::gpu::types::{Column, RainParams, SPEED_TABLE_LEN};
use crate::scene::Camera;

/// Lateral cells per side of the column grid.
const GRID: usize = 24;
/// Lateral sample points per cell side when measuring a column's extent.
const CELL_SAMPLES: usize = 4;

/// The drops of a shot: uniforms (without time) and columns, ready for the GPU.
#[derive(Debug, Clone)]
pub struct RainSetup {
    /// Uniforms; `time_s` and `radiance` are set per frame.
    pub params: RainParams,
    /// Columns in drop-id order (at least one, possibly with zero drops).
    pub columns: Vec<Column>,
    /// Drops a physically complete volume would hold.
    pub expected_drops: f64,
    /// Frustum volume between near and far, m³.
    pub frustum_volume_m3: f64,
    /// Volume of the columns, m³ (≥ the frustum's; the excess is the padding).
    pub column_volume_m3: f64,
}

/// One drop at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DropState {
    /// Position, world metres.
    pub pos_m: Vec3,
    /// Velocity, m/s.
    pub vel_mps: Vec3,
    /// Equivalent diameter, mm.
    pub diameter_mm: f32,
}

/// Maps display pixels to coded pixels for a display rotation of `rotation_deg` (the angle, in
/// degrees counter-clockwise, by which the coded picture is turned for display).
/// Returns (column-major 2×2 matrix, offset).
pub fn coded_from_display(rotation_deg: i32, coded_w: f32, coded_h: f32) -> ([f32; 4], [f32; 2]) {
    match rotation_deg.rem_euclid(360) {
        // Displayed = coded turned 90° counter-clockwise: display (x, y) ← coded (W − y, x).
        90 => ([0.0, 1.0, -1.0, 0.0], [coded_w, 0.0]),
        180 => ([-1.0, 0.0, 0.0, -1.0], [coded_w, coded_h]),
        // Displayed = coded turned 90° clockwise: display (x, y) ← coded (y, H − x).
        270 => ([0.0, -1.0, 1.0, 0.0], [0.0, coded_h]),
        _ => ([1.0, 0.0, 0.0, 1.0], [0.0, 0.0]),
    }
}

fn orthonormal_basis(axis: DVec3) -> (DVec3, DVec3) {
    let helper = if axis.x.abs() < 0.9 {
        DVec3::X
    } else {
        DVec3::Y
    };
    let e1 = helper.cross(axis).normalize();
    (e1, axis.cross(e1))
}

/// The frustum slab between depths `near` and `far`, as inward half-spaces in camera space.
fn clip_line(
    camera: &Camera,
    near: f64,
    far: f64,
    origin_cam: DVec3,
    dir_cam: DVec3,
) -> Option<(f64, f64)> {
    let f = camera.focal_px();
    let tx = 0.5 * camera.width_px as f64 / f;
    let ty = 0.5 * camera.height_px as f64 / f;
    // n·p + d ≥ 0 for points inside.
    let planes = [
        (DVec3::Z, -near),
        (DVec3::NEG_Z, far),
        (DVec3::new(-1.0, 0.0, tx), 0.0),
        (DVec3::new(1.0, 0.0, tx), 0.0),
        (DVec3::new(0.0, -1.0, ty), 0.0),
        (DVec3::new(0.0, 1.0, ty), 0.0),
    ];
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for (n, d) in planes {
        let a = n.dot(origin_cam) + d;
        let b = n.dot(dir_cam);
        if b.abs() < 1e-12 {
            if a < 0.0 {
                return None;
            }
        } else if b > 0.0 {
            lo = lo.max(-a / b);
        } else {
            hi = hi.min(-a / b);
        }
    }
    (lo < hi).then_some((lo, hi))
}

/// Builds the rain volume for `camera` (the displayed picture) and the coded frame size.
pub fn build(
    camera: &Camera,
    camera_config: &CameraConfig,
    rain: &RainConfig,
    exposure_s: f64,
    rotation_deg: i32,
    coded_size_px: (u32, u32),
) -> RainSetup {
    let dsd = interim::SizeDistribution::marshall_palmer(rain.rate_mm_per_h, rain.drop_scale);
    let speed =
        |d_mm: f64| interim::terminal_speed_mps(d_mm / rain.drop_scale) * rain.fall_speed_scale;
    let wind = DVec3::new(rain.wind_mps[0], rain.wind_mps[1], 0.0);
    let v_typical = speed(dsd.median_mm());
    let axis = (wind - DVec3::Z * v_typical).normalize();
    let (e1, e2) = orthonormal_basis(axis);
    let basis = DMat3::from_cols(e1, e2, axis);
    let near = rain.near_m;
    let far = rain.far_m;
    let camera_from_world = camera.world_from_camera.transpose();

    // Lateral bounds: the frustum's corners projected on (e1, e2).
    let f = camera.focal_px();
    let tx = 0.5 * camera.width_px as f64 / f;
    let ty = 0.5 * camera.height_px as f64 / f;
    let (mut lat_min, mut lat_max) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for z in [near, far] {
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
            let p = camera.world_from_camera * DVec3::new(sx * tx * z, sy * ty * z, z);
            let l = DVec2::new(p.dot(e1), p.dot(e2));
            lat_min = lat_min.min(l);
            lat_max = lat_max.max(l);
        }
    }
    let max_speed = speed(dsd.d_max_mm) + wind.length();
    let pad_m = max_speed * exposure_s;
    let cell = (lat_max - lat_min) / GRID as f64;
    let origin = camera.position_m;
    let dir_cam = camera_from_world * axis;

    let density = dsd.number_per_m3();
    let mut columns = Vec::with_capacity(GRID * GRID);
    let mut volumes = Vec::with_capacity(GRID * GRID);
    for i in 0..GRID {
        for j in 0..GRID {
            let cmin = lat_min + cell * DVec2::new(i as f64, j as f64);
            let (mut s_lo, mut s_hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for a in 0..=CELL_SAMPLES {
                for b in 0..=CELL_SAMPLES {
                    let l = cmin + cell * DVec2::new(a as f64, b as f64) / CELL_SAMPLES as f64;
                    let o_cam = camera_from_world * (l.x * e1 + l.y * e2);
                    if let Some((lo, hi)) = clip_line(camera, near, far, o_cam, dir_cam) {
                        s_lo = s_lo.min(lo);
                        s_hi = s_hi.max(hi);
                    }
                }
            }
            if s_lo < s_hi {
                let (s_lo, s_hi) = (s_lo - pad_m, s_hi + pad_m);
                volumes.push(cell.x * cell.y * (s_hi - s_lo));
                columns.push(Column {
                    lateral_min_m: [cmin.x as f32, cmin.y as f32],
                    lateral_size_m: [cell.x as f32, cell.y as f32],
                    s_lo_m: s_lo as f32,
                    s_len_m: (s_hi - s_lo) as f32,
                    first_drop: 0,
                    drop_count: 0,
                });
            }
        }
    }
    let column_volume: f64 = volumes.iter().sum();
    let expected = density * column_volume;
    let budget = rain.max_drops as f64;
    let (scale, weight) = if expected > budget {
        (budget / expected, expected / budget)
    } else {
        (1.0, 1.0)
    };
    // Largest-remainder rounding keeps the total exact and each column within one drop.
    let mut carry = 0.0;
    let mut next = 0u32;
    for (c, v) in columns.iter_mut().zip(&volumes) {
        let want = density * v * scale + carry;
        let n = want.floor().max(0.0);
        carry = want - n;
        c.first_drop = next;
        c.drop_count = n as u32;
        next += n as u32;
    }
    if columns.is_empty() {
        columns.push(bytemuck::Zeroable::zeroed());
    }

    let r = camera_from_world;
    let row = |k: usize| {
        let v = r.row(k);
        [v.x as f32, v.y as f32, v.z as f32, 0.0]
    };
    let (m, off) = coded_from_display(rotation_deg, coded_size_px.0 as f32, coded_size_px.1 as f32);
    let table_step_mm = dsd.d_max_mm / (SPEED_TABLE_LEN - 1) as f64;
    let speed_table = std::array::from_fn(|i| speed(i as f64 * table_step_mm) as f32);
    let v4 = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32, 0.0];
    let _ = camera_config;
    let params = RainParams {
        camera_pos_m: [
            camera.position_m.x as f32,
            camera.position_m.y as f32,
            camera.position_m.z as f32,
            f as f32,
        ],
        camera_from_world_0: row(0),
        camera_from_world_1: row(1),
        camera_from_world_2: row(2),
        principal_px: [
            camera.principal_px().x as f32,
            camera.principal_px().y as f32,
        ],
        display_size_px: [camera.width_px as f32, camera.height_px as f32],
        coded_from_display: m,
        coded_offset_px: off,
        coded_size_px: [coded_size_px.0 as f32, coded_size_px.1 as f32],
        fall_axis: v4(axis),
        lateral_e1: v4(basis.x_axis),
        lateral_e2: v4(basis.y_axis),
        volume_origin_m: v4(origin),
        wind_mps: v4(wind),
        radiance: [1.0, 1.0, 1.0, 0.0],
        time_s: 0.0,
        exposure_s: exposure_s as f32,
        seed: rain.seed,
        drop_count: next,
        column_count: columns.len() as u32,
        opacity: rain.opacity as f32,
        near_clip_m: (0.5 * near).max(0.02) as f32,
        drop_weight: weight as f32,
        d_min_mm: dsd.d_min_mm as f32,
        d_max_mm: dsd.d_max_mm as f32,
        lambda_per_mm: dsd.lambda_per_mm as f32,
        speed_table_step_mm: table_step_mm as f32,
        speed_table,
    };
    let frustum_volume_m3 = 4.0 * tx * ty * (far.powi(3) - near.powi(3)) / 3.0;
    RainSetup {
        params,
        columns,
        expected_drops: expected,
        frustum_volume_m3,
        column_volume_m3: column_volume,
    }
}

/// Marshall–Palmer sizes and a terminal-velocity fit, until `rain::physics` provides them.
mod interim {
    /// Truncated exponential drop-size distribution.
    pub struct SizeDistribution {
        pub n0_per_m3_mm: f64,
        pub lambda_per_mm: f64,
        pub d_min_mm: f64,
        pub d_max_mm: f64,
    }

    impl SizeDistribution {
        /// N(D) = N0 e^{−ΛD}, N0 = 8000 m⁻³ mm⁻¹, Λ = 4.1 R^−0.21 mm⁻¹, diameters × `scale`.
        pub fn marshall_palmer(rate_mm_per_h: f64, scale: f64) -> SizeDistribution {
            let lambda = 4.1 * rate_mm_per_h.max(1e-3).powf(-0.21) / scale;
            let n0 = if rate_mm_per_h > 0.0 {
                8000.0 / scale
            } else {
                0.0
            };
            // Drops under 0.5 mm are too faint to streak; over 6 mm they break up.
            SizeDistribution {
                n0_per_m3_mm: n0,
                lambda_per_mm: lambda,
                d_min_mm: 0.5 * scale,
                d_max_mm: 6.0 * scale,
            }
        }
        pub fn number_per_m3(&self) -> f64 {
            self.n0_per_m3_mm / self.lambda_per_mm
                * ((-self.lambda_per_mm * self.d_min_mm).exp()
                    - (-self.lambda_per_mm * self.d_max_mm).exp())
        }
        pub fn median_mm(&self) -> f64 {
            let tail = 1.0 - (-self.lambda_per_mm * (self.d_max_mm - self.d_min_mm)).exp();
            self.d_min_mm - (1.0 - 0.5 * tail).ln() / self.lambda_per_mm
        }
    }

    /// Atlas, Srivastava & Sekhon (1973) fit to Gunn & Kinzer, clipped at zero.
    pub fn terminal_speed_mps(d_mm: f64) -> f64 {
        (9.65 - 10.3 * (-0.6 * d_mm).exp()).max(0.0)
    }
}

// ---- CPU twin of shaders/common/rng.wgsl and drops.wgsl (f32, same operation order) ----

/// PCG-style integer hash (twin of `pcg_hash`).
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

fn unit_from_hash(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The k-th random number of the stream keyed by (seed, id, cycle) (twin of `rand_key`).
pub fn rand_key(seed: u32, id: u32, cycle: u32, k: u32) -> f32 {
    unit_from_hash(pcg_hash(
        pcg_hash(pcg_hash(seed ^ k.wrapping_mul(0x9e37_79b9)) ^ id) ^ cycle,
    ))
}

const DROP_CONSTANT_KEY: u32 = 0xffff_ffff;

fn terminal_speed_from_table(p: &RainParams, d_mm: f32) -> f32 {
    let x = (d_mm / p.speed_table_step_mm).clamp(0.0, 30.999);
    let i = x.floor() as usize;
    let f = x - i as f32;
    let (a, b) = (p.speed_table[i], p.speed_table[i + 1]);
    a + (b - a) * f
}

fn diameter_from_unit(p: &RainParams, u: f32) -> f32 {
    let span = p.d_max_mm - p.d_min_mm;
    let tail = 1.0 - (-p.lambda_per_mm * span).exp();
    p.d_min_mm - (1.0 - u * tail).ln() / p.lambda_per_mm
}

fn column_of(p: &RainParams, columns: &[Column], id: u32) -> usize {
    let (mut lo, mut hi) = (0usize, p.column_count as usize);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if columns[mid].first_drop <= id {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// Drop `id` at time `t_s` (twin of `drop_state` in `shaders/common/drops.wgsl`).
pub fn drop_state(p: &RainParams, columns: &[Column], id: u32, t_s: f32) -> DropState {
    let col = columns[column_of(p, columns, id)];
    let d_mm = diameter_from_unit(p, rand_key(p.seed, id, DROP_CONSTANT_KEY, 0));
    let vel = Vec3::new(
        p.wind_mps[0],
        p.wind_mps[1],
        -terminal_speed_from_table(p, d_mm),
    );
    let axis = v3(p.fall_axis);
    let w = vel.dot(axis).max(1e-3);
    let len = col.s_len_m.max(1e-3);
    let travel = rand_key(p.seed, id, DROP_CONSTANT_KEY, 1) * len + w * t_s;
    let cycle = (travel / len).floor();
    let s_in = travel - cycle * len;
    let k = (cycle as i32) as u32;
    let lateral = [
        col.lateral_min_m[0] + col.lateral_size_m[0] * rand_key(p.seed, id, k, 2),
        col.lateral_min_m[1] + col.lateral_size_m[1] * rand_key(p.seed, id, k, 3),
    ];
    let since_birth_s = s_in / w;
    let drift = vel - w * axis;
    let pos = v3(p.volume_origin_m)
        + lateral[0] * v3(p.lateral_e1)
        + lateral[1] * v3(p.lateral_e2)
        + (col.s_lo_m + s_in) * axis
        + drift * since_birth_s;
    DropState {
        pos_m: pos,
        vel_mps: vel,
        diameter_mm: d_mm,
    }
}
