//! The CPU back end's colour passes at 720p (`gpu::host`): planes → hazed f16 canvas, with and
//! without the haze, and canvas → code values; the plain `f64` twins on the same frame for
//! scale. `cargo bench --bench colour_passes`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rain_composite::config::{CameraConfig, RainConfig};
use rain_composite::gpu::cpu::{rgb_to_yuv, yuv_to_rgb};
use rain_composite::gpu::host::HostColour;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::lighting::{EnvironmentSh, FrameLight};
use rain_composite::scene::Camera;
use rain_composite::video::{Chroma, ColorParams, FrameFormat, YuvFrame};

const W: u32 = 1280;
const H: u32 = 720;

fn frame() -> YuvFrame {
    let format = FrameFormat {
        width: W,
        height: H,
        chroma: Chroma::Cs420,
        bit_depth: 8,
    };
    let mut f = YuvFrame::filled(format, ColorParams::bt709(8), [16, 128, 128]);
    for (i, plane) in f.planes.iter_mut().enumerate() {
        for (k, v) in plane.data.iter_mut().enumerate() {
            *v = (k.wrapping_mul(2_654_435_761) >> (7 + i)) as u8 | 16;
        }
    }
    f
}

fn colour_passes(c: &mut Criterion) {
    let frame = frame();
    let camera = Camera::new(W, H, 1.0, 1.6, 0.05, 0.0);
    let rain = RainConfig {
        rate_mm_per_h: 0.0,
        ..RainConfig::default()
    };
    let setup =
        rain_composite::shot::rain::plan(&camera, &CameraConfig::default(), &rain, 0.02, 0, (W, H))
            .map(RainSetup::pack)
            .expect("rain");
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

criterion_group!(benches, colour_passes);
criterion_main!(benches);
