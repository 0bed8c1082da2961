//! First what a 1080p frame costs the CPU back end before any rain: the decode with and without
//! the haze (its grid made each frame), the encode of the hazed canvas and the frame light's
//! estimate. Then the CPU back end's
//! colour passes at 720p (`gpu::host`): planes → hazed f16 canvas, with and
//! without the haze, and canvas → code values; the plain `f64` twins on the same frame for
//! scale. Then the streaks of the default rain (10 mm/h) drawn over a 1080p canvas in tiles,
//! beside the twin of `rain_simulate`'s geometry for the same drops (what simulating them on
//! the CPU would cost at the least). Then the ground's passes at 720p on a view two thirds
//! ground: the wet ground fused into the decode, and the puddles over a lake, still, with 128
//! rings, and marched against a depth map. Then the default rain's drops of a 1080p frame
//! simulated on the CPU back end (`gpu::host::simulate`): without compact lights and with 16,
//! on all of rayon's threads and on one, and without the AVX2 build. A whole 1080p frame of
//! that rain under the haze, the stages one after another against band by band.
//! `cargo bench --bench colour_passes`.

mod common;

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rain_composite::config::RainConfig;
use rain_composite::gpu::cpu::rain_simulate::streak_of;
use rain_composite::gpu::cpu::{rgb_to_yuv, yuv_to_rgb};
use rain_composite::gpu::host::{FrameRain, GroundFrame, HostColour};
use rain_composite::gpu::stages::puddles::{FrameWater, water_params};
use rain_composite::gpu::types::{PuddleParams, RainParams, Ripple, Streak, WetParams};
use rain_composite::lighting::wetness::FilmOptics;
use rain_composite::lighting::{EnvironmentSh, FrameLight, LightConfig, LightEstimator};
use rain_composite::rain::volume::sample_drop;
use rain_composite::scene::Camera;
use rain_composite::video::{ColorParams, YuvFrame};

const W: u32 = 1280;
const H: u32 = 720;

fn frame() -> YuvFrame {
    let mut f = YuvFrame::filled(
        common::format_420(W, H),
        ColorParams::bt709(8),
        [16, 128, 128],
    );
    for (i, plane) in f.planes.iter_mut().enumerate() {
        for (k, v) in plane.data.iter_mut().enumerate() {
            *v = (k.wrapping_mul(2_654_435_761) >> (7 + i)) as u8 | 16;
        }
    }
    f
}

/// No drops: the passes alone.
fn dry() -> RainConfig {
    RainConfig {
        rate_mm_per_h: 0.0,
        ..RainConfig::default()
    }
}

fn colour_passes(c: &mut Criterion) {
    let frame = frame();
    let camera = Camera::new(W, H, 1.0, 1.6, 0.05, 0.0);
    let setup = common::rain_setup(&camera, &dry());
    let mut env = EnvironmentSh::zeros(4);
    env.coeffs[0] = [0.9, 1.0, 1.3];
    let light = FrameLight {
        env,
        lights: Vec::new(),
    };
    let mut hazy = setup.params_at(0.0, &light, [[1.0, 0.4, 0.2, 0.1]; 3]);
    hazy.haze = [2.0, 60.0, 0.05, (-0.05f32 * 58.0).exp()];
    hazy.ground_clip = 1;
    let mut clear = hazy;
    clear.haze = [0.0, 0.0, 0.0, 1.0];
    let mut host = HostColour::new(frame.format, &frame.color);
    c.bench_function("host yuv→rgb 720p, no haze", |b| {
        b.iter(|| black_box(host.decode(&frame, &clear).len()))
    });
    c.bench_function("host yuv→rgb 720p, haze to the ground", |b| {
        b.iter(|| black_box(host.decode(&frame, &hazy).len()))
    });
    let canvas: Vec<u16> = host
        .decode(&frame, &hazy)
        .iter()
        .map(|v| v.to_bits())
        .collect();
    c.bench_function("host rgb→yuv 720p", |b| {
        b.iter(|| black_box(host.encode(&canvas, W as usize)))
    });
    let mut plain = HostColour::baseline(frame.format, &frame.color);
    c.bench_function("host yuv→rgb 720p, no haze, no AVX2", |b| {
        b.iter(|| black_box(plain.decode(&frame, &clear).len()))
    });
    c.bench_function("host rgb→yuv 720p, no AVX2", |b| {
        b.iter(|| black_box(plain.encode(&canvas, W as usize)))
    });
    let mut slow = c.benchmark_group("twins");
    slow.sample_size(10);
    slow.bench_function("twin yuv_to_rgb 720p, haze to the ground", |b| {
        b.iter(|| black_box(yuv_to_rgb::yuv_to_rgb(&frame, &hazy).len()))
    });
    let linear = yuv_to_rgb::yuv_to_rgb(&frame, &hazy);
    slow.bench_function("twin rgb_to_yuv 720p", |b| {
        b.iter(|| black_box(rgb_to_yuv::rgb_to_yuv(&linear, frame.format, &frame.color)))
    });
    slow.finish();
}

/// The drops of the default rain over a 1080p picture at 1.5 s, as `rain_simulate` draws them
/// (geometry from the twin; a grey radiance), with the uniforms.
fn rain_1080p() -> (RainParams, Vec<Streak>) {
    let setup = common::default_rain(&common::camera_1080p());
    let p = setup.motion_at(1.5);
    let hidden = Streak {
        len_px: -1.0,
        ..bytemuck::Zeroable::zeroed()
    };
    let streaks = (0..setup.drop_count() as u64)
        .map(|id| {
            let Some(d) = sample_drop(setup.rainfall(), id, 1.5) else {
                return hidden;
            };
            let Some(s) = streak_of(&p, d.position_m, d.velocity_mps, d.width_mm) else {
                return hidden;
            };
            let z = s.ends_camera_m.map(|c| c.z as f32);
            Streak {
                q0_px: s.q0_px.as_vec2().to_array(),
                dir: s.dir.as_vec2().to_array(),
                len_px: s.len_px as f32,
                r_eff_px: s.r_eff_px as f32,
                alpha_scale: s.alpha_scale as f32,
                drop_info: 0,
                radiance0: [0.5, 0.5, 0.55, z[0]],
                radiance1: [0.5, 0.5, 0.55, z[1]],
            }
        })
        .collect();
    (p, streaks)
}

fn streak_raster(c: &mut Criterion) {
    let (p, streaks) = rain_1080p();
    let format = common::format_420(1920, 1080);
    let frame = YuvFrame::filled(format, ColorParams::bt709(8), [90, 128, 128]);
    let mut host = HostColour::new(format, &frame.color);
    let mut clear = p;
    clear.haze = [0.0, 0.0, 0.0, 1.0];
    let drawn = streaks.iter().filter(|s| s.len_px >= 0.0).count();
    let area: f64 = streaks
        .iter()
        .filter(|s| s.len_px >= 0.0)
        .map(|s| {
            let ext = (s.r_eff_px + 0.5) as f64;
            (s.len_px as f64 + 2.0 * ext) * 2.0 * ext
        })
        .sum();
    let big = streaks.iter().filter(|s| s.r_eff_px > 5.0).count();
    eprintln!(
        "{drawn} of {} drops drawn; their quads cover {:.2} Mpx; {big} wider than 5 px",
        streaks.len(),
        area / 1e6
    );
    c.bench_function("host streaks 1080p, 10 mm/h (plate + raster)", |b| {
        b.iter(|| {
            host.decode(&frame, &clear);
            black_box(host.draw_streaks(&frame, &clear, &streaks, None, &[]))
        })
    });
    c.bench_function("host yuv→rgb 1080p, no haze (the plate alone)", |b| {
        b.iter(|| black_box(host.decode(&frame, &clear).len()))
    });
    let setup = common::default_rain(&common::camera_1080p());
    let mut slow = c.benchmark_group("twins");
    slow.sample_size(10);
    slow.bench_function("twin drop states and streak geometry 1080p, 10 mm/h", |b| {
        b.iter(|| {
            (0..setup.drop_count() as u64)
                .filter_map(|id| sample_drop(setup.rainfall(), id, 1.5))
                .filter_map(|d| streak_of(&p, d.position_m, d.velocity_mps, d.width_mm))
                .count()
        })
    });
    slow.finish();
}

fn ground_passes(c: &mut Criterion) {
    let frame = frame();
    let camera = Camera::new(W, H, 1.0, 1.6, -0.2, 0.0);
    let setup = common::rain_setup(&camera, &dry()).with_ground(true);
    let mut env = EnvironmentSh::zeros(4);
    env.coeffs[0] = [0.9, 1.0, 1.3];
    env.coeffs[2] = [0.3, 0.3, 0.4];
    let light = FrameLight {
        env,
        lights: Vec::new(),
    };
    let mut p = setup.params_at(0.0, &light, [[1.0, 0.4, 0.2, 0.1]; 3]);
    p.haze = [2.0, 60.0, 0.05, (-0.05f32 * 58.0).exp()];
    let optics = FilmOptics::water();
    let wet = WetParams::new(0.8, &optics, 0.0);
    // A lake 2 cm deep over the 40 m in front of the camera.
    let (nx, ny) = (160, 160);
    let depth_m = vec![0.02f32; nx * ny];
    let pool = |rings: u32| PuddleParams {
        ring_count: rings,
        ..water_params([-20.0, 0.0], 0.25, [nx as u32, ny as u32])
    };

    let ripples: Vec<Ripple> = (0..128)
        .map(|k| Ripple {
            centre_m: [-4.0 + 0.06 * k as f32, 3.0 + 0.1 * k as f32],
            radius_m: 0.1 + 0.002 * k as f32,
            width_m: 0.02,
            amplitude_m: 1e-3,
            wavenumber: 90.0,
            phase: 0.3 * k as f32,
            _pad: 0.0,
        })
        .collect();
    let water = |rings: u32| GroundFrame {
        wet: Some(wet),
        water: Some(FrameWater {
            params: pool(rings),
            depth_m: &depth_m,
            ripples: ripples.clone(),
        }),
    };
    let mut host = HostColour::new(frame.format, &frame.color);
    let mut group = c.benchmark_group("ground 720p");
    group.sample_size(10);
    group.bench_function("decode, dry", |b| {
        b.iter(|| black_box(host.decode(&frame, &p).len()))
    });
    let wet_only = GroundFrame {
        wet: Some(wet),
        water: None,
    };
    group.bench_function("decode with the wet ground", |b| {
        b.iter(|| black_box(host.decode_ground(&frame, &p, &wet_only)))
    });
    for (name, rings) in [("a still lake", 0), ("a lake with 128 rings", 128)] {
        let ground = water(rings);
        group.bench_function(format!("decode, wet ground and {name}"), |b| {
            b.iter(|| black_box(host.decode_ground(&frame, &p, &ground)))
        });
    }
    // A wall 6 m away on the left third, the rest unknown: the mirrored rays are marched.
    let wall: Vec<f32> = (0..(W * H) as usize)
        .map(|i| {
            if i % W as usize > W as usize / 3 {
                0.0
            } else {
                6.0
            }
        })
        .collect();
    host.set_scene_depth(wall);
    let ground = water(128);
    group.bench_function("decode, wet ground and the lake with rings, marched", |b| {
        b.iter(|| black_box(host.decode_ground(&frame, &p, &ground)))
    });
    group.finish();
}

/// 16 compact lights around a 1080p view: half at a few metres, half at infinity.
fn sixteen_lights(camera: &Camera) -> Vec<rain_composite::lighting::LightSource> {
    (0..16)
        .map(|k| rain_composite::lighting::LightSource {
            direction_world: camera.ray_world(glam::DVec2::new(
                120.0 * k as f64,
                200.0 + 40.0 * (k % 5) as f64,
            )),
            solid_angle_sr: 1e-4,
            radiance_rgb: [900.0, 800.0, 600.0],
            distance_m: (k % 2 == 0).then_some(3.0 + k as f64),
        })
        .collect()
}

fn drop_simulation(c: &mut Criterion) {
    use rain_composite::gpu::host::simulate::{Drops, LightTable, simulate, simulate_baseline};
    use rain_composite::gpu::types::LightList;
    let camera = common::camera_1080p();
    let setup = common::default_rain(&camera);
    let p = common::sky_params(&setup, 1.5);
    let table = LightTable::new(&rain_composite::gpu::lights::table_texels(
        &common::water_tables(),
    ));
    let none = LightList::new(&[]);
    let sixteen = LightList::new(&sixteen_lights(&camera));
    let drops = |lights| Drops {
        columns: &setup.columns,
        lights,
        table: Some(&table),
        glints: false,
    };
    let (mut streaks, mut glints) = (Vec::new(), Vec::new());
    let drawable = simulate(&p, &drops(&sixteen), &mut streaks, &mut glints);
    eprintln!("{drawable} of {} drops drawable", streaks.len());
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    c.bench_function("host simulate 1080p, 10 mm/h, no lights", |b| {
        b.iter(|| black_box(simulate(&p, &drops(&none), &mut streaks, &mut glints)))
    });
    c.bench_function("host simulate 1080p, 10 mm/h, 16 lights", |b| {
        b.iter(|| black_box(simulate(&p, &drops(&sixteen), &mut streaks, &mut glints)))
    });
    c.bench_function("host simulate 1080p, 10 mm/h, 16 lights, one thread", |b| {
        b.iter(|| {
            one.install(|| black_box(simulate(&p, &drops(&sixteen), &mut streaks, &mut glints)))
        })
    });
    c.bench_function(
        "host simulate 1080p, 10 mm/h, 16 lights, one thread, no AVX2",
        |b| {
            b.iter(|| {
                one.install(|| {
                    black_box(simulate_baseline(
                        &p,
                        &drops(&sixteen),
                        &mut streaks,
                        &mut glints,
                    ))
                })
            })
        },
    );
}

/// The splashes of a frame on the CPU back end (`gpu::host::splashes`) against their twin, at
/// 720p with the default rain over a ground whose horizon is 30 % down the picture.
fn splash_simulation(c: &mut Criterion) {
    use rain_composite::gpu::cpu::rain_splashes::splash_streaks;
    use rain_composite::gpu::host::splashes::HostSplashes;
    use rain_composite::gpu::types::LightList;
    // 1.6 m up, tilted down so that the horizon is 30 % down the picture.
    let fov = 60f64.to_radians();
    let tilt = -((0.5 - 0.3) * 2.0 * (0.5 * fov).tan() * 720.0 / 1280.0).atan();
    let camera = Camera::new(1280, 720, fov, 1.6, tilt, 0.0);
    let setup = common::default_rain(&camera).with_ground(true);
    let mut env = EnvironmentSh::zeros(4);
    env.coeffs[0] = [0.8, 0.9, 1.0];
    let light = FrameLight {
        env,
        lights: Vec::new(),
    };
    let t_s = 2.5;
    let p = setup.params_at(t_s, &light, [[1.0, 0.4, 0.2, 0.1]; 3]);
    let mut host = HostSplashes::new(&setup).expect("landing drops");
    host.set_transfer_table(&common::water_tables());
    host.set_lights(&LightList::new(&sixteen_lights(&camera)));
    let ids = host.drop_ids();
    eprintln!(
        "{} landing drops of {}, {} splash streaks drawn",
        ids.len(),
        p.drop_count,
        host.simulate(&p).len()
    );
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    c.bench_function("host splashes 720p, 10 mm/h, 16 lights", |b| {
        b.iter(|| black_box(host.simulate(&p).len()))
    });
    c.bench_function("host splashes 720p, 10 mm/h, 16 lights, one thread", |b| {
        b.iter(|| one.install(|| black_box(host.simulate(&p).len())))
    });
    c.bench_function("twin splashes 720p, 10 mm/h, no light", |b| {
        b.iter(|| {
            ids.iter()
                .map(|&id| splash_streaks(&setup, &p, id as u64, t_s).1.len())
                .sum::<usize>()
        })
    });
}

/// What the haze and the light cost a 1080p frame on their own, in CPU time (all threads:
/// the machine these run on is shared): the decode without the haze, with the haze to the
/// scene's depth (every pixel veiled, the veil's grid made each frame, as at the defaults)
/// and to the ground (each ray's own transmittance), and the frame light's estimate (the
/// block statistics of the thumbnail, its projection on the SH and the recovery).
fn frame_fixed_costs(c: &mut Criterion) {
    let camera = common::camera_1080p();
    let format = common::format_420(1920, 1080);
    let mut frame = YuvFrame::filled(format, ColorParams::bt709(8), [16, 128, 128]);
    for (i, plane) in frame.planes.iter_mut().enumerate() {
        for (k, v) in plane.data.iter_mut().enumerate() {
            *v = (k.wrapping_mul(2_654_435_761) >> (7 + i)) as u8 | 16;
        }
    }
    let setup = common::rain_setup(&camera, &dry());
    let mut env = EnvironmentSh::zeros(4);
    env.coeffs[0] = [0.9, 1.0, 1.3];
    env.coeffs[2] = [0.3, 0.3, 0.4];
    let light = FrameLight {
        env,
        lights: Vec::new(),
    };
    let mut scene = setup.params_at(0.0, &light, [[1.0, 0.4, 0.2, 0.1]; 3]);
    scene.haze = [2.0, 60.0, 0.05, (-0.05f32 * 58.0).exp()];
    let mut ground = scene;
    ground.ground_clip = 1;
    let mut clear = scene;
    clear.haze = [0.0, 0.0, 0.0, 1.0];
    let mut host = HostColour::new(format, &frame.color);
    for (name, p) in [
        ("host yuv→rgb 1080p, no haze, CPU", &clear),
        ("host yuv→rgb 1080p, haze to the scene, CPU", &scene),
        ("host yuv→rgb 1080p, haze to the ground, CPU", &ground),
    ] {
        c.bench_function(name, |b| {
            b.iter_custom(|n| {
                let start = common::cpu_time();
                for _ in 0..n {
                    black_box(host.decode(&frame, p).len());
                }
                common::cpu_time() - start
            })
        });
    }
    // The encode of the hazed canvas (every tile: the haze is on).
    let canvas: Vec<u16> = host
        .decode(&frame, &scene)
        .iter()
        .map(|v| v.to_bits())
        .collect();
    c.bench_function("host rgb→yuv 1080p, CPU", |b| {
        b.iter_custom(|n| {
            let start = common::cpu_time();
            for _ in 0..n {
                black_box(host.encode(&canvas, 1920)[0].data.len());
            }
            common::cpu_time() - start
        })
    });
    let mut estimator =
        LightEstimator::new(&camera, 0, &LightConfig::default()).expect("light estimator");
    let mut t_s = 0.0;
    c.bench_function(
        "frame light 1080p (block statistics, SH, recovery), CPU",
        |b| {
            b.iter_custom(|n| {
                let start = common::cpu_time();
                for _ in 0..n {
                    t_s += 1.0 / 30.0;
                    black_box(estimator.update(&frame, t_s).lights.len());
                }
                common::cpu_time() - start
            })
        },
    );
}

/// A whole 1080p frame of the default rain (10 mm/h) under the haze on the CPU back end, in
/// CPU time: the stages one after another (the plate, the raster, the encode, each over the
/// whole canvas) and band by band (`HostColour::render_bands`: each band decoded, drawn on
/// and encoded while it is in the cache), the same codes.
fn whole_frame(c: &mut Criterion) {
    let (mut p, streaks) = rain_1080p();
    p.haze = [2.0, 60.0, 0.05, (-0.05f32 * 58.0).exp()];
    let format = common::format_420(1920, 1080);
    let mut frame = YuvFrame::filled(format, ColorParams::bt709(8), [16, 128, 128]);
    for (i, plane) in frame.planes.iter_mut().enumerate() {
        for (k, v) in plane.data.iter_mut().enumerate() {
            *v = (k.wrapping_mul(2_654_435_761) >> (7 + i)) as u8 | 16;
        }
    }
    let mut host = HostColour::new(format, &frame.color);
    let none = GroundFrame::default();
    let rain = FrameRain {
        splashes: &[],
        streaks: &streaks,
        mattes: None,
        glints: &[],
    };
    c.bench_function("host whole frame 1080p, 10 mm/h, stages, CPU", |b| {
        b.iter_custom(|n| {
            let start = common::cpu_time();
            for _ in 0..n {
                host.lay_plate(&frame, &p, &none);
                host.draw_streaks(&frame, &p, &streaks, None, &[]);
                black_box(host.encode_canvas(&frame)[0].data.len());
            }
            common::cpu_time() - start
        })
    });
    c.bench_function("host whole frame 1080p, 10 mm/h, band by band, CPU", |b| {
        b.iter_custom(|n| {
            let start = common::cpu_time();
            for _ in 0..n {
                let f = host.render_bands(&frame, &p, &none, &rain);
                black_box(f.map(|f| f.planes[0].data.len()));
            }
            common::cpu_time() - start
        })
    });
}

criterion_group!(
    benches,
    frame_fixed_costs,
    whole_frame,
    colour_passes,
    streak_raster,
    ground_passes,
    drop_simulation,
    splash_simulation
);
criterion_main!(benches);
