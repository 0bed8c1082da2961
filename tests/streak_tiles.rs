//! The compute rasteriser (`streak_tiles`, `--gpu-raster compute`) against the quad-per-drop
//! draw (`rain_streaks`' capsules) on the same canvas and streaks: random streak sets, many
//! overlapping, a rotated picture, with and without a depth map, thousands in one tile, lists
//! past the end of the tile lists; the same within the canvas's f16 rounding, and the same bits
//! run after run.

#[path = "common/gpu.rs"]
mod shared_gpu;

use bytemuck::Zeroable;
use half::f16;
use rain_composite::gpu::stages::FrameStage;
use rain_composite::gpu::stages::rain_streaks::{CANVAS_FORMAT, RainStreaks, StreakInputs};
use rain_composite::gpu::stages::streak_tiles::{SORT_LOCAL, StreakTiles};
use rain_composite::gpu::types::{RainParams, Streak};
use rain_composite::gpu::uniforms::coded_from_display;
use rain_composite::rng::SplitMix64;
use wgpu::util::DeviceExt;

/// One test picture: its coded size, rotation, streaks and whether it has a depth map.
struct Scene {
    coded: (u32, u32),
    rotation_deg: i32,
    streaks: Vec<Streak>,
    depth: bool,
}

fn uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f32 {
    (lo + (hi - lo) * rng.next_f64()) as f32
}

/// `n` random streaks over a display of `size` px, their starts within `spot` (x0, y0, x1, y1)
/// of it: short and long, thin and wide, faint and opaque, some skipped, some of no length.
fn streaks(rng: &mut SplitMix64, n: usize, spot: [f32; 4]) -> Vec<Streak> {
    (0..n)
        .map(|_| {
            let angle = uniform(rng, 0.0, std::f64::consts::TAU);
            let kind = rng.next_f64();
            let len_px = if kind < 0.05 {
                -1.0
            } else if kind < 0.1 {
                0.0
            } else if kind < 0.15 {
                uniform(rng, 80.0, 300.0)
            } else {
                uniform(rng, 0.5, 40.0)
            };
            let depth = |rng: &mut SplitMix64| uniform(rng, 1.0, 20.0);
            let colour = |rng: &mut SplitMix64| {
                [
                    uniform(rng, 0.0, 2.0),
                    uniform(rng, 0.0, 2.0),
                    uniform(rng, 0.0, 2.0),
                    depth(rng),
                ]
            };
            Streak {
                q0_px: [
                    uniform(rng, spot[0] as f64, spot[2] as f64),
                    uniform(rng, spot[1] as f64, spot[3] as f64),
                ],
                dir: [angle.cos(), angle.sin()],
                len_px,
                r_eff_px: uniform(rng, 0.5, 5.0),
                alpha_scale: uniform(rng, 0.02, 1.5),
                drop_info: 0,
                radiance0: colour(rng),
                radiance1: colour(rng),
            }
        })
        .collect()
}

/// The display size of `scene`.
fn display(scene: &Scene) -> (u32, u32) {
    match scene.rotation_deg {
        90 | 270 => (scene.coded.1, scene.coded.0),
        _ => scene.coded,
    }
}

/// The scene's depth map (one zero: none) and the picture under the rain (f16 bits, RGBA).
fn inputs(scene: &Scene) -> (Vec<f32>, Vec<u16>) {
    let (w, h) = scene.coded;
    let (dw, dh) = display(scene);
    let mut rng = SplitMix64(7);
    let depth: Vec<f32> = if scene.depth {
        // Unknown (0) in places, else between the drops' depths.
        (0..dw * dh)
            .map(|_| {
                if rng.next_f64() < 0.1 {
                    0.0
                } else {
                    uniform(&mut rng, 1.0, 20.0)
                }
            })
            .collect()
    } else {
        vec![0.0]
    };
    let background: Vec<u16> = (0..4 * w * h)
        .map(|_| f16::from_f32(uniform(&mut rng, 0.0, 1.0)).to_bits())
        .collect();
    (depth, background)
}

/// The plain reference: per coded pixel centre, every streak in drop order with fs_main's
/// coverage, occlusion and colour (the radiance linear over the quad from its start corner to
/// its end corner), blended in f32 and rounded to the nearest f16 after each, as an
/// `Rgba16Float` render target holds it.
fn reference(scene: &Scene) -> Vec<u16> {
    let (w, h) = scene.coded;
    let (dw, dh) = display(scene);
    let (m, off) = coded_from_display(scene.rotation_deg, w as f32, h as f32);
    let (depth, background) = inputs(scene);
    let mut out = background.clone();
    for y in 0..h {
        for x in 0..w {
            let centre = [x as f32 + 0.5, y as f32 + 0.5];
            let d = [centre[0] - off[0], centre[1] - off[1]];
            let p = [m[0] * d[0] + m[1] * d[1], m[2] * d[0] + m[3] * d[1]];
            let scene_m = if depth.len() as u32 >= dw * dh {
                let px = (p[0].floor().max(0.0) as u32).min(dw - 1);
                let py = (p[1].floor().max(0.0) as u32).min(dh - 1);
                depth[(py * dw + px) as usize]
            } else {
                0.0
            };
            let i = 4 * (y * w + x) as usize;
            let mut c: [f32; 4] = std::array::from_fn(|k| f16::from_bits(out[i + k]).to_f32());
            for s in &scene.streaks {
                // Skipped (len < 0, or NaN as the shader reads it).
                if s.len_px.is_nan() || s.len_px < 0.0 {
                    continue;
                }
                let (dx, dy) = (p[0] - s.q0_px[0], p[1] - s.q0_px[1]);
                let along = dx * s.dir[0] + dy * s.dir[1];
                let across = s.dir[0] * dy - s.dir[1] * dx;
                let (len, r) = (s.len_px, s.r_eff_px);
                let h2 = r * r - across * across;
                if h2 <= 0.0 {
                    continue;
                }
                let half = h2.sqrt();
                let cover = if len < 1e-3 {
                    if along.abs() < half { 1.0 } else { 0.0 }
                } else {
                    ((along + half).clamp(0.0, len) - (along - half).clamp(0.0, len)) / len
                };
                if cover <= 0.0 {
                    continue;
                }
                let t = if len >= 1e-3 {
                    (along / len).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let drop_m = 1.0
                    / (1.0 / s.radiance0[3] + (1.0 / s.radiance1[3] - 1.0 / s.radiance0[3]) * t);
                let shown = if scene_m <= 0.0 {
                    1.0
                } else {
                    let u = ((scene_m - drop_m + 0.025) / 0.05).clamp(0.0, 1.0);
                    u * u * (3.0 - 2.0 * u)
                };
                let a = (cover * s.alpha_scale).clamp(0.0, 1.0) * shown;
                if a <= 0.0 {
                    continue;
                }
                let ext = r + 0.5;
                let f = (along + ext) / (len + 2.0 * ext);
                for (k, dst) in c.iter_mut().enumerate() {
                    let src = if k == 3 {
                        a
                    } else {
                        (s.radiance0[k] + (s.radiance1[k] - s.radiance0[k]) * f) * a
                    };
                    *dst = f16::from_f32(src + *dst * (1.0 - a)).to_f32();
                }
            }
            for (o, v) in out[i..i + 4].iter_mut().zip(c) {
                *o = f16::from_f32(v).to_bits();
            }
        }
    }
    out
}

/// The canvas after drawing `scene` over a random picture, by compute (`capacity` entries in
/// the tile lists, `None` the default) or by quads, as f16 bits.
fn draw(scene: &Scene, compute: Option<Option<u32>>) -> Vec<u16> {
    let ctx = shared_gpu::gpu().expect("a GPU adapter");
    let (device, queue) = (&ctx.device, &ctx.queue);
    let (w, h) = scene.coded;
    let (dw, dh) = display(scene);
    let (m, off) = coded_from_display(scene.rotation_deg, w as f32, h as f32);
    let (depth, background) = inputs(scene);
    let params = RainParams {
        display_size_px: [dw as f32, dh as f32],
        coded_from_display: m,
        coded_offset_px: off,
        coded_size_px: [w as f32, h as f32],
        ..RainParams::zeroed()
    };
    let buffer = |label, contents: &[u8], usage| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage,
        })
    };
    let rain_params = buffer(
        "rain_params",
        bytemuck::bytes_of(&params),
        wgpu::BufferUsages::UNIFORM,
    );
    // At least one record: a binding is never empty.
    let padded = [scene.streaks.as_slice(), &[Streak::zeroed()]].concat();
    let streak_buffer = buffer(
        "streaks",
        bytemuck::cast_slice(&padded),
        wgpu::BufferUsages::STORAGE,
    );
    let scene_depth = buffer(
        "scene_depth",
        bytemuck::cast_slice(&depth),
        wgpu::BufferUsages::STORAGE,
    );
    let size = wgpu::Extent3d {
        width: w,
        height: h,
        depth_or_array_layers: 1,
    };
    let canvas = device.create_texture_with_data(
        queue,
        &wgpu::TextureDescriptor {
            label: Some("canvas"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: CANVAS_FORMAT,
            usage: wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        bytemuck::cast_slice(&background),
    );
    let inputs = StreakInputs {
        rain_params: &rain_params,
        streaks: &streak_buffer,
        count: scene.streaks.len() as u32,
        scene_depth: &scene_depth,
        canvas: &canvas,
    };
    let mut encoder = device.create_command_encoder(&Default::default());
    match compute {
        Some(capacity) => {
            StreakTiles::with_inputs(device, &inputs, capacity).record(&mut encoder, None)
        }
        None => RainStreaks::capsules(device, &inputs).draw(&mut encoder, None),
    }
    let row = (8 * w).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: u64::from(row * h),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    encoder.copy_texture_to_buffer(
        canvas.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: None,
            },
        },
        size,
    );
    queue.submit([encoder.finish()]);
    readback.map_async(wgpu::MapMode::Read, .., |r| r.expect("maps"));
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("polls");
    let bytes = readback.get_mapped_range(..).expect("mapped").to_vec();
    bytes
        .chunks_exact(row as usize)
        .flat_map(|r| bytemuck::cast_slice::<u8, u16>(&r[..8 * w as usize]).to_vec())
        .collect()
}

/// A 10-bit code of linear `x` through the sRGB curve (stricter than the 8 bits most outputs
/// have).
fn code(x: f32) -> i32 {
    let x = x.clamp(0.0, 1.0) as f64;
    let v = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (v * 1023.0).round() as i32
}

/// (largest code difference, share of samples more than one code apart, largest relative
/// difference) of two canvases; alpha counted as a linear sample.
fn compare(a: &[u16], b: &[u16]) -> (i32, f64, f32) {
    assert_eq!(a.len(), b.len());
    let (mut worst, mut off, mut rel) = (0, 0usize, 0.0f32);
    for (&x, &y) in a.iter().zip(b) {
        let (x, y) = (f16::from_bits(x).to_f32(), f16::from_bits(y).to_f32());
        let d = (code(x) - code(y)).abs();
        worst = worst.max(d);
        off += (d > 1) as usize;
        rel = rel.max((x - y).abs() / x.abs().max(y.abs()).max(1e-3));
    }
    (worst, off as f64 / a.len() as f64, rel)
}

/// Compute on `scene` against the plain reference (within one code on 99.9 % of the samples,
/// the largest difference small), the same bits on a second run, the rain visible; and, with
/// `quads`, against the quad draw the same way.
fn check(what: &str, scene: &Scene, capacity: Option<u32>, quads: bool) {
    if shared_gpu::gpu().is_none() {
        return;
    }
    let tiles = draw(scene, Some(capacity));
    let again = draw(scene, Some(capacity));
    assert!(tiles == again, "{what}: two runs differ");
    let plain = reference(scene);
    let changed = compare(&plain, &inputs(scene).1);
    assert!(changed.1 > 0.01, "{what}: the rain shows");
    let (worst, share, rel) = compare(&plain, &tiles);
    eprintln!(
        "{what}: {} streaks, against the reference worst {worst} codes, {share:.5} > 1 code, relative {rel:.2e}; the rain changes {:.3} of the samples",
        scene.streaks.len(),
        changed.1
    );
    assert!(
        share <= 0.001,
        "{what}: {share} of samples > 1 code off the reference"
    );
    assert!(worst <= 2, "{what}: {worst} codes off the reference");
    if quads {
        let (worst, share, rel) = compare(&draw(scene, None), &tiles);
        eprintln!(
            "{what}: against the quads worst {worst} codes, {share:.5} > 1 code, relative {rel:.2e}"
        );
        // The share alone: the quads are held to the reference by their own tests, and on
        // an NVIDIA H200 (driver 580) they stray from it by up to 19 codes on 0.045 % of the
        // samples, where this draw keeps within one code of the reference.
        assert!(
            share <= 0.001,
            "{what}: {share} of samples > 1 code off the quads"
        );
    }
}

#[test]
fn compute_draws_what_the_quads_draw() {
    let mut rng = SplitMix64(1);
    let coded = (168, 100);
    for (rotation_deg, depth) in [(0, false), (90, true), (180, false), (270, true)] {
        let s = Scene {
            coded,
            rotation_deg,
            streaks: Vec::new(),
            depth,
        };
        let (dw, dh) = display(&s);
        let spot = [-30.0, -30.0, dw as f32 + 30.0, dh as f32 + 30.0];
        let scene = Scene {
            streaks: streaks(&mut rng, 400, spot),
            ..s
        };
        check(
            &format!("rotated {rotation_deg}°, depth {depth}"),
            &scene,
            None,
            true,
        );
    }
}

/// More streaks on one tile than its list sorts in workgroup memory: sorted where they lie.
#[test]
fn thousands_of_streaks_on_one_tile() {
    let mut rng = SplitMix64(2);
    let n = 3 * SORT_LOCAL as usize;
    let mut all = streaks(&mut rng, n, [36.0, 20.0, 44.0, 28.0]);
    for s in &mut all {
        s.alpha_scale *= 0.05;
        s.len_px = s.len_px.min(6.0);
    }
    let scene = Scene {
        coded: (96, 64),
        rotation_deg: 0,
        streaks: all,
        depth: false,
    };
    check("one crowded tile", &scene, None, false);
}

/// Lists past the end of the tile lists: those tiles read every streak, the picture the same.
#[test]
fn tiles_past_the_lists_end_read_every_streak() {
    let mut rng = SplitMix64(3);
    let scene = Scene {
        coded: (128, 80),
        rotation_deg: 90,
        streaks: streaks(&mut rng, 400, [-10.0, -10.0, 90.0, 138.0]),
        depth: true,
    };
    // 400 streaks meet at least 380 tiles: most lists lie past the end of 64 entries.
    check("short lists", &scene, Some(64), true);
}
