//! Where the ground is: on a synthetic street ray-traced through the camera model (a road
//! between two façades with pilasters and windows, a railing along the road), the ground mask
//! found in the frame matches the true road (IoU), the wet ground and the puddles keep off the
//! walls and the railing (under 1 % of their pixels change) while the road away from its edges
//! still wets (at least 90 %), and without the mask the walls would have wetted (the test can
//! fail); the GPU stages match their CPU twins with a mask.
//! Set `RAIN_COMPOSITE_REQUIRE_GPU=1` to turn a missing adapter into a failure.

use glam::{DVec2, DVec3, Vec2};
use rain_composite::fluid::Field2;
use rain_composite::gpu::cpu::puddles::{Water, puddles_masked};
use rain_composite::gpu::cpu::wet_ground::wet_ground_masked;
use rain_composite::gpu::cpu::{rgb_to_yuv, yuv_to_rgb};
use rain_composite::gpu::stages::puddles::water_params;
use rain_composite::gpu::stages::yuv_to_rgb::GLOW_CELL_PX;
use rain_composite::gpu::types::{LightList, PuddleParams, RainParams, WetParams};
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::lighting::wetness::{FilmOptics, RainHistory, SurfaceStore, Wetting};
use rain_composite::pipeline::ground_mask_feed::point_views;
use rain_composite::rng::splitmix64;
use rain_composite::scene::Camera;
use rain_composite::scene::ground_mask::detect;
use rain_composite::scene::sky::{SkyGrid, TopEdge};
use rain_composite::video::YuvFrame;

#[path = "common/gpu.rs"]
mod shared_gpu;
use shared_gpu::gpu;

#[path = "common/render.rs"]
mod render;
use render::{dry_ground, lit, render_with};

#[path = "common/pictures.rs"]
mod pictures;
use pictures::{codes, interior};

const W: u32 = 320;
const H: u32 = 180;

/// The road's half-width to the façades, m.
const WALL_X_M: f64 = 5.0;
/// The railing stands this far left of the road's middle, m, 1 m high.
const RAILING_X_M: f64 = -3.6;

/// What a pixel's ray meets first.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Surface {
    Road,
    Wall,
    Railing,
    Sky,
}

/// A deterministic uniform number in [0, 1) from `seed` and `k`.
fn uniform(seed: u64, k: u64) -> f64 {
    (splitmix64(seed.wrapping_mul(0x9e37_79b9).wrapping_add(k)) >> 11) as f64 / (1u64 << 53) as f64
}

/// A street seen by `camera`: R'G'B' (0–1) and what each pixel shows.
struct Street {
    rgb: Vec<[f64; 3]>,
    truth: Vec<Surface>,
}

/// The asphalt at ground point `q`: grey with a texture of a few isotropic waves.
fn asphalt(q: DVec3, seed: u64) -> f64 {
    let waves: f64 = (0..4)
        .map(|k| {
            let angle = std::f64::consts::TAU * uniform(seed, 10 + k);
            let wavelength_m = 0.3 + 0.5 * uniform(seed, 20 + k);
            let dir = DVec2::new(angle.cos(), angle.sin());
            (std::f64::consts::TAU * dir.dot(q.truncate()) / wavelength_m).sin()
        })
        .sum();
    0.28 + 0.012 * waves
}

/// A façade at height `z` and distance `y` along the road: a plinth, pilasters every 4 m,
/// windows on each floor.
fn facade(y: f64, z: f64) -> [f64; 3] {
    let along = y.rem_euclid(4.0);
    let floor = (z - 1.0).rem_euclid(3.0);
    let v = if along < 0.3 {
        0.33
    } else if z < 0.3 {
        0.42
    } else if (1.2..2.8).contains(&along) && floor < 1.4 && z > 1.0 {
        0.14
    } else {
        0.58
    };
    [v * 1.05, v, v * 0.85]
}

fn street(camera: &Camera, seed: u64) -> Street {
    let eye = camera.position_m;
    let mut rgb = Vec::with_capacity((W * H) as usize);
    let mut truth = Vec::with_capacity((W * H) as usize);
    for y in 0..H {
        for x in 0..W {
            let r = camera.ray_world(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
            let mut best = (f64::INFINITY, Surface::Sky, [0.0; 3]);
            if r.z < 0.0 {
                let t = eye.z / -r.z;
                let q = eye + t * r;
                if q.x.abs() < WALL_X_M {
                    let v = asphalt(q, seed);
                    best = (t, Surface::Road, [v, v, v * 1.03]);
                }
            }
            for side in [-1.0, 1.0] {
                let t = (side * WALL_X_M - eye.x) / r.x;
                let q = eye + t * r;
                if t > 0.0 && t < best.0 && (0.0..12.0).contains(&q.z) && q.y > 0.5 {
                    best = (t, Surface::Wall, facade(q.y, q.z));
                }
            }
            let t = (RAILING_X_M - eye.x) / r.x;
            let q = eye + t * r;
            let post = q.y.rem_euclid(1.2) < 0.08;
            let rail = (0.9..1.0).contains(&q.z) || (0.45..0.52).contains(&q.z);
            if t > 0.0
                && t < best.0
                && (0.0..1.0).contains(&q.z)
                && (2.0..60.0).contains(&q.y)
                && (post || rail)
            {
                best = (t, Surface::Railing, [0.1, 0.11, 0.12]);
            }
            if best.1 == Surface::Sky {
                let f = y as f64 / H as f64;
                best.2 = [0.62 + 0.1 * f, 0.68 + 0.1 * f, 0.8 + 0.05 * f];
            }
            // Sensor noise of about a code.
            let grain = (uniform(seed, 7 * (y as u64 * 4096 + x as u64)) - 0.5) * 2.5 / 255.0;
            rgb.push(best.2.map(|v| v + grain));
            truth.push(best.1);
        }
    }
    Street { rgb, truth }
}

/// The street as an 8-bit 4:2:0 BT.709 limited-range frame.
fn frame(street: &Street) -> YuvFrame {
    pictures::bt709_420_from_rgb(W, H, &street.rgb)
}

fn grid() -> SkyGrid {
    SkyGrid::new(GLOW_CELL_PX, (W, H))
}

/// It rained at 10 mm/h for ten minutes and stops at the clip's start.
fn drying() -> Wetting {
    Wetting {
        store: SurfaceStore::default(),
        history: RainHistory::new(vec![(-600.0, 10.0), (0.0, 0.0)]).expect("history"),
        reach_m: 0.0,
    }
}

/// A uniform grey sky.
const SKY: [(usize, [f32; 3]); 1] = [(0, [2.0, 2.0, 2.1])];

/// The poses drawn: field of view (rad), tilt and roll (degrees), non-integer.
const POSES: [(f64, f64, f64); 3] = [(1.2, -4.3, 2.7), (1.05, -9.6, -5.2), (1.45, -2.2, 0.0)];

fn camera(pose: (f64, f64, f64)) -> Camera {
    Camera::new(W, H, pose.0, 1.6, pose.1.to_radians(), pose.2.to_radians())
}

/// The setup, uniforms, frame, truth and mask of a street seen at `pose`.
fn shot(pose: (f64, f64, f64), seed: u64) -> (RainSetup, RainParams, YuvFrame, Street, Vec<f32>) {
    let cam = camera(pose);
    let setup = dry_ground(&cam, 0).with_wetting(Some(drying()));
    let p = lit(&setup, 120.0, &SKY, Some(1.0));
    let s = street(&cam, seed);
    let f = frame(&s);
    let mask = detect(&f, grid(), TopEdge::Top, &point_views(&p, grid()));
    (setup, p, f, s, mask)
}

/// Water 3 cm deep everywhere within 40 m of the camera's foot.
fn lake() -> Field2 {
    let n = 80;
    Field2 {
        nx: n,
        ny: n,
        origin_m: Vec2::splat(-40.0),
        cell_m: 1.0,
        values: vec![0.03; n * n],
    }
}

fn puddle_params(water: &Field2) -> PuddleParams {
    water_params(
        water.origin_m.to_array(),
        water.cell_m,
        [water.nx as u32, water.ny as u32],
    )
}

/// The CPU twins' picture: the wet ground and the puddles over the decoded frame, with `mask`.
fn wet_picture(f: &YuvFrame, p: &RainParams, mask: Option<&[f32]>) -> Vec<[f64; 3]> {
    let mut canvas = yuv_to_rgb::yuv_to_rgb(f, p);
    let wet = WetParams::new(drying().wetness_at(120.0), &FilmOptics::water(), 0.0);
    wet_ground_masked(&mut canvas, f, p, &wet, None, mask);
    let water = lake();
    let params = puddle_params(&water);
    let lights = LightList::new(&[]);
    let pond = Water {
        params: &params,
        depth_m: &water.values,
        ripples: &[],
        lights: &lights,
    };
    puddles_masked(&mut canvas, f, p, &pond, None, mask);
    canvas
}

#[test]
fn the_mask_matches_the_true_road() {
    for (n, pose) in POSES.into_iter().enumerate() {
        let (_, _, _, s, mask) = shot(pose, 3 + n as u64);
        let g = grid();
        let (mut both, mut either, mut off_road) = (0usize, 0usize, 0usize);
        let standing = s
            .truth
            .iter()
            .filter(|t| matches!(t, Surface::Wall | Surface::Railing))
            .count();
        for (i, t) in s.truth.iter().enumerate() {
            let w = g.weight_at(&mask, i as u32 % W, i as u32 / W);
            let road = *t == Surface::Road;
            both += usize::from(w >= 0.5 && road);
            either += usize::from(w >= 0.5 || road);
            off_road += usize::from(w > 0.0 && matches!(t, Surface::Wall | Surface::Railing));
        }
        let iou = both as f64 / either as f64;
        eprintln!(
            "pose {pose:?}: IoU {iou:.3}; {off_road} of {standing} wall and railing pixels weighted"
        );
        assert!(iou >= 0.75, "pose {pose:?}: IoU {iou}");
        assert!(
            (off_road as f64) < 0.01 * standing as f64,
            "pose {pose:?}: {off_road} of {standing}"
        );
    }
}

#[test]
fn wetness_and_water_keep_off_the_walls_and_the_railing() {
    for (n, pose) in POSES.into_iter().enumerate() {
        let (_, p, f, s, mask) = shot(pose, 11 + n as u64);
        let dry = yuv_to_rgb::yuv_to_rgb(&f, &p);
        let masked = wet_picture(&f, &p, Some(&mask));
        let unmasked = wet_picture(&f, &p, None);
        let changed = |a: &[f64; 3], b: &[f64; 3]| (0..3).any(|k| (a[k] - b[k]).abs() > 1e-4);
        let inside = interior(&s.truth, (W, H), 12);
        let (mut standing, mut standing_wet, mut standing_wet_unmasked) = (0, 0, 0);
        let (mut road, mut road_wet) = (0, 0);
        for i in 0..(W * H) as usize {
            match s.truth[i] {
                Surface::Wall | Surface::Railing => {
                    standing += 1;
                    standing_wet += usize::from(changed(&masked[i], &dry[i]));
                    standing_wet_unmasked += usize::from(changed(&unmasked[i], &dry[i]));
                }
                Surface::Road if inside[i] => {
                    road += 1;
                    road_wet += usize::from(changed(&masked[i], &dry[i]));
                }
                _ => {}
            }
        }
        eprintln!(
            "pose {pose:?}: walls and railing {standing_wet} of {standing} wet ({standing_wet_unmasked} \
             without the mask); road away from its edges {road_wet} of {road} wet"
        );
        assert!(standing > 2000 && road > 2000, "{standing}, {road}");
        assert!(
            (standing_wet as f64) < 0.01 * standing as f64,
            "walls wet: {standing_wet} of {standing}"
        );
        assert!(
            road_wet as f64 >= 0.9 * road as f64,
            "road wet: {road_wet} of {road}"
        );
        // Without the mask everything below the horizon wets: the walls' lower parts too.
        assert!(standing_wet_unmasked as f64 > 0.1 * standing as f64);
    }
}

#[test]
fn the_gpu_stages_match_their_twins_with_a_mask() {
    let Some(ctx) = gpu() else { return };
    let (setup, p, f, _, mask) = shot(POSES[0], 5);
    let water = lake();
    let out = render_with(&ctx, &f, &setup, &p, |comp| {
        comp.set_water(&water).expect("water");
        comp.set_ground_mask(&mask).expect("mask");
    });
    let gpu = codes(&out);
    let twin = rgb_to_yuv::rgb_to_yuv(&wet_picture(&f, &p, Some(&mask)), f.format, &f.color);
    let unmasked = rgb_to_yuv::rgb_to_yuv(&wet_picture(&f, &p, None), f.format, &f.color);
    let (mut worst, mut differs) = (0, 0);
    for plane in 0..3 {
        for ((g, c), u) in gpu[plane].iter().zip(&twin[plane]).zip(&unmasked[plane]) {
            worst = worst.max(g.abs_diff(*c));
            differs += usize::from(c.abs_diff(*u) > 2);
        }
    }
    eprintln!("GPU vs twin with a mask: worst {worst} codes; the mask changes {differs} samples");
    assert!(worst <= 2, "{worst} codes off");
    assert!(differs > 500, "the mask changes {differs} samples");
    // A mask of another size is refused.
    let mut comp = rain_composite::gpu::Compositor::new(ctx.clone(), f.format, &f.color, &setup)
        .expect("compositor");
    assert!(comp.set_ground_mask(&mask[1..]).is_err());
}
