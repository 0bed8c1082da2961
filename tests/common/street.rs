//! Synthetic streets seen through the project's own camera model, at poses and with layouts
//! drawn from a seeded generator: the ground truth the pose estimator is judged against.
#![allow(dead_code)]

use glam::{DVec2, DVec3};
use rain_composite::rng::SplitMix64;
use rain_composite::scene::{Camera, GroundPlane};
use rain_composite::video::YuvFrame;
use rain_composite::video::color::ColorParams;
use rain_composite::video::frame::{Chroma, FrameFormat};

/// Picture size of the synthetic shots.
pub const W: u32 = 640;
/// Picture height.
pub const H: u32 = 360;

/// An axis-aligned box standing on the ground: centre (x, y), half sizes, height, shade, and
/// whether it is a building (floors and windows drawn on its faces).
#[derive(Debug, Clone, Copy)]
pub struct Block {
    pub centre: [f64; 2],
    pub half: [f64; 2],
    pub top_m: f64,
    pub shade: f64,
    pub building: bool,
}

/// A street: blocks, a paving of square stones turned by `paving_deg`, a sky.
#[derive(Debug, Clone)]
pub struct Street {
    pub blocks: Vec<Block>,
    pub paving_deg: f64,
    pub stone_m: f64,
    pub sky: f64,
}

/// A camera pose of a shot.
#[derive(Debug, Clone, Copy)]
pub struct Pose {
    pub tilt_deg: f64,
    pub roll_deg: f64,
    pub fov_deg: f64,
    pub height_m: f64,
}

impl Pose {
    /// The camera of this pose.
    pub fn camera(&self) -> Camera {
        Camera::new(
            W,
            H,
            self.fov_deg.to_radians(),
            self.height_m,
            self.tilt_deg.to_radians(),
            self.roll_deg.to_radians(),
        )
    }

    /// The same lens, level (what the estimator is given: the intrinsics alone).
    pub fn intrinsics(&self) -> Camera {
        Camera::new(W, H, self.fov_deg.to_radians(), self.height_m, 0.0, 0.0)
    }

    /// The true horizon row (from the plane and the camera, not the estimator's formula).
    pub fn horizon_row(&self) -> Option<f64> {
        GroundPlane::LEVEL.horizon_row(&self.camera())
    }
}

impl Block {
    /// Where the ray from `o` along `d` enters this box (slab method): the distance along `d`
    /// and the axis of the face it enters through; `None` where it misses.
    pub fn entry(&self, o: DVec3, d: DVec3) -> Option<(f64, usize)> {
        let lo = DVec3::new(
            self.centre[0] - self.half[0],
            self.centre[1] - self.half[1],
            0.0,
        );
        let hi = DVec3::new(
            self.centre[0] + self.half[0],
            self.centre[1] + self.half[1],
            self.top_m,
        );
        let (mut t0, mut t1, mut axis) = (0.0f64, f64::MAX, 0);
        for k in 0..3 {
            let inv = 1.0 / d[k];
            let (mut a, mut e) = ((lo[k] - o[k]) * inv, (hi[k] - o[k]) * inv);
            if a > e {
                std::mem::swap(&mut a, &mut e);
            }
            if a > t0 {
                t0 = a;
                axis = k;
            }
            t1 = t1.min(e);
        }
        (t0 < t1).then_some((t0, axis))
    }
}

/// Luma of a paving of square stones `stone_m` wide, turned by `paving_deg`, with dark
/// joints, at ground point `p` seen `t` metres away: far away it averages out (as a real lens
/// would blur it).
pub fn paving(p: DVec3, t: f64, paving_deg: f64, stone_m: f64) -> f64 {
    let (s, c) = paving_deg.to_radians().sin_cos();
    let (u, v) = (
        (c * p.x + s * p.y) / stone_m,
        (-s * p.x + c * p.y) / stone_m,
    );
    let (fu, fv) = (u - u.floor(), v - v.floor());
    let joint = fu < 0.08 || fv < 0.08;
    let stone = if (u.floor() as i64 + v.floor() as i64) % 2 == 0 {
        0.55
    } else {
        0.4
    };
    let fade = (-t / 40.0).exp();
    let value = if joint { 0.15 } else { stone };
    fade * value + (1.0 - fade) * 0.42
}

fn uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.next_f64()
}

impl Street {
    /// A street drawn from `rng`: facades on both sides (set back 4–7 m, with gaps), posts
    /// along the kerbs, a paving turned at random.
    pub fn random(rng: &mut SplitMix64) -> Street {
        let mut blocks = Vec::new();
        for side in [-1.0, 1.0] {
            let setback = uniform(rng, 4.0, 7.0);
            let mut y = uniform(rng, -2.0, 6.0);
            while y < 70.0 {
                let len = uniform(rng, 6.0, 16.0);
                if rng.next_f64() < 0.85 {
                    let depth = uniform(rng, 4.0, 10.0);
                    blocks.push(Block {
                        centre: [side * (setback + depth), y + 0.5 * len],
                        half: [depth, 0.5 * len],
                        top_m: uniform(rng, 7.0, 24.0),
                        shade: uniform(rng, 0.45, 0.9),
                        building: true,
                    });
                }
                y += len + uniform(rng, 0.0, 3.0);
            }
            let mut y = uniform(rng, 1.0, 5.0);
            while y < 40.0 {
                blocks.push(Block {
                    centre: [side * (setback - uniform(rng, 0.5, 1.5)), y],
                    half: [0.08, 0.08],
                    top_m: uniform(rng, 2.5, 4.5),
                    shade: uniform(rng, 0.1, 0.35),
                    building: false,
                });
                y += uniform(rng, 5.0, 12.0);
            }
        }
        Street {
            blocks,
            paving_deg: uniform(rng, 0.0, 90.0),
            stone_m: uniform(rng, 0.4, 0.9),
            sky: uniform(rng, 0.7, 0.95),
        }
    }

    /// Luma in [0, 1] seen along world ray `d` from `o`.
    pub fn radiance(&self, o: DVec3, d: DVec3) -> f64 {
        let mut best = (f64::MAX, 0.0);
        for b in &self.blocks {
            let Some((t0, axis)) = b.entry(o, d) else {
                continue;
            };
            if t0 < best.0 {
                let p = o + d * t0;
                let face = [0.75, 1.0, 0.85][axis] * b.shade;
                let value = if b.building && axis < 2 {
                    // Floors of 3 m with a 0.6 m band; windows 1.2 m wide every 3 m along.
                    let along = if axis == 0 { p.y } else { p.x };
                    let (fz, fa) = ((p.z / 3.0).fract(), (along / 3.0).rem_euclid(1.0));
                    if fz < 0.2 {
                        face * 0.55
                    } else if p.z > 3.0 && (0.35..0.75).contains(&fz) && fa < 0.4 {
                        face * 0.35
                    } else {
                        face
                    }
                } else {
                    face
                };
                best = (t0, value);
            }
        }
        if d.z < 0.0 {
            let t = -o.z / d.z;
            if t < best.0 {
                return paving(o + d * t, t, self.paving_deg, self.stone_m);
            }
        }
        if best.0 < f64::MAX {
            return best.1;
        }
        self.sky + 0.05 * d.z.max(0.0)
    }
}

/// An 8-bit 4:2:0 frame of `scene` (luma along a ray) through `camera`, 2×2 supersampled.
pub fn render(camera: &Camera, scene: impl Fn(DVec3, DVec3) -> f64) -> YuvFrame {
    let (w, h) = (camera.width_px, camera.height_px);
    let format = FrameFormat {
        width: w,
        height: h,
        chroma: Chroma::Cs420,
        bit_depth: 8,
    };
    let mut f = YuvFrame::filled(format, ColorParams::bt709(8), [16, 128, 128]);
    for y in 0..h {
        for x in 0..w {
            let mut sum = 0.0;
            for (sx, sy) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                let d = camera.ray_world(DVec2::new(x as f64 + sx, y as f64 + sy));
                sum += scene(camera.position_m, d);
            }
            f.planes[0].data[(y * w + x) as usize] =
                (16.0 + 219.0 * (sum / 4.0).clamp(0.0, 1.0)).round() as u8;
        }
    }
    f
}

/// Shot `i` of the seeded set: a street and a pose (tilt −40…+20°, roll ±20°, field of view
/// 40–90°, camera 1.3–1.9 m up), both drawn from the stream of `seed + i`.
pub fn shot(seed: u64, i: u64) -> (Street, Pose) {
    let mut rng = SplitMix64(seed.wrapping_mul(1_000_003).wrapping_add(i));
    let pose = Pose {
        tilt_deg: uniform(&mut rng, -40.0, 20.0),
        roll_deg: uniform(&mut rng, -20.0, 20.0),
        fov_deg: uniform(&mut rng, 40.0, 90.0),
        height_m: uniform(&mut rng, 1.3, 1.9),
    };
    (Street::random(&mut rng), pose)
}

/// A city of towers seen in steep views: a grid of blocks 8–14 m wide and 10–40 m tall on
/// 20 m centres (streets of 6–12 m between them), paving between, a sky.
pub fn city(rng: &mut SplitMix64) -> Street {
    let mut blocks = Vec::new();
    for i in -3..=3 {
        for j in -3..=3 {
            let half = uniform(rng, 4.0, 7.0);
            blocks.push(Block {
                centre: [20.0 * i as f64, 20.0 * j as f64],
                half: [half, uniform(rng, 4.0, 7.0)],
                top_m: uniform(rng, 10.0, 40.0),
                shade: uniform(rng, 0.45, 0.9),
                building: true,
            });
        }
    }
    Street {
        blocks,
        paving_deg: uniform(rng, 0.0, 90.0),
        stone_m: uniform(rng, 0.4, 0.9),
        sky: uniform(rng, 0.7, 0.95),
    }
}

/// Steep shot `i` of `seed`: a city and a camera, two in three looking down 70–90° from
/// 50–80 m over a random point, one in three looking up 70–90° from 1.6 m in a street; roll
/// ±20°, field of view 40–90°. Returns the city, the pose and the camera (placed).
pub fn steep_shot(seed: u64, i: u64) -> (Street, Pose, Camera) {
    let mut rng = SplitMix64(seed.wrapping_mul(1_000_033).wrapping_add(i));
    let up = rng.next_f64() < 1.0 / 3.0;
    let tilt = uniform(&mut rng, 70.0, 90.0);
    let pose = Pose {
        tilt_deg: if up { tilt } else { -tilt },
        roll_deg: uniform(&mut rng, -20.0, 20.0),
        fov_deg: uniform(&mut rng, 40.0, 90.0),
        height_m: if up {
            1.6
        } else {
            uniform(&mut rng, 50.0, 80.0)
        },
    };
    let mut camera = pose.camera();
    // Looking up: in the street between two rows of towers; looking down: anywhere.
    let (x, y) = if up {
        (10.0, uniform(&mut rng, -20.0, 20.0))
    } else {
        (
            uniform(&mut rng, -20.0, 20.0),
            uniform(&mut rng, -20.0, 20.0),
        )
    };
    camera.position_m = DVec3::new(x, y, pose.height_m);
    (city(&mut rng), pose, camera)
}

/// The worst angle, degrees, between the streaks drawn (no wind) through a camera posed at
/// `tilt_deg`, `roll_deg` and the true nadir `nadir` in the picture, over the streaks at least
/// 60 px from it; and how many were judged.
pub fn streaks_off_nadir(
    pose: &Pose,
    tilt_deg: f64,
    roll_deg: f64,
    nadir: glam::DVec2,
) -> (usize, f64) {
    use rain_composite::config::{CameraConfig, RainConfig};
    use rain_composite::gpu::cpu::rain_simulate::streak_of;
    use rain_composite::gpu::uniforms::RainSetup;
    use rain_composite::keyframes::Keyframes;
    use rain_composite::rain::volume::sample_drop;
    let config = CameraConfig {
        fov_deg: pose.fov_deg,
        height_m: pose.height_m,
        tilt_deg,
        roll_deg,
        ..CameraConfig::default()
    };
    let camera = config.camera(W, H);
    let rain = RainConfig {
        rate_mm_per_h: 20.0,
        wind_mps: [0.0, 0.0],
        gust_mps: 0.0,
        far_m: 15.0,
        seed: 3,
        ..RainConfig::default()
    };
    let setup = rain_composite::shot::rain::plan_keyed(
        &camera,
        &config,
        &rain,
        &Keyframes::default(),
        0.02,
        0,
        (W, H),
    )
    .map(RainSetup::pack)
    .expect("rain");
    let params = setup.motion_at(0.5);
    let (mut judged, mut worst) = (0, 0.0f64);
    for id in 0..setup.drop_count() as u64 {
        let Some(d) = sample_drop(setup.rainfall(), id, 0.5) else {
            continue;
        };
        let Some(s) = streak_of(&params, d.position_m, d.velocity_mps, d.width_mm) else {
            continue;
        };
        let mid = s.q0_px + s.dir * (0.5 * s.len_px);
        let to_nadir = nadir - mid;
        if to_nadir.length() < 60.0 || s.len_px < 3.0 {
            continue;
        }
        let sin = s.dir.perp_dot(to_nadir.normalize()).abs();
        worst = worst.max(sin.asin().to_degrees());
        judged += 1;
    }
    (judged, worst)
}
