//! The GPU back end's render-only speed: one picture through the frame's GPU stages (upload,
//! planes → linear canvas, the drops' simulation and streaks, canvas → planes, readback) many
//! times back to back, without decode or encode, so the GPU stays busy and its clock settles
//! (a render paced by its encoder leaves the GPU idle most of each frame, and its timestamps
//! then measure whatever clock it idles at). Per stage, the GPU time of each frame from the
//! stages' timestamp queries; "render-only fps" is 1 / their sum, and "wall fps" the rate of
//! whole frames, readback included. The rows follow `benches/gpu.sh` (rain rate, drop budget),
//! plus the mattes, and the dissertation's 128 960 drops at a quarter of the pixels, which
//! tells the streaks' fill from their per-drop cost.
//!
//! `cargo bench --bench gpu_frame [-- FRAMES]` (default 600 timed frames after a tenth as many,
//! at most 60, to warm up; on a CPU adapter such as lavapipe give a handful).

mod common;

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use rain_composite::config::{RainConfig, StreakStyle};
use rain_composite::drops::MatteAtlas;
use rain_composite::gpu::compositor::GpuStageTimes;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::gpu::{AdapterRequest, Compositor, GpuContext};
use rain_composite::video::{ColorParams, YuvFrame};

const FPS: f64 = 30.0;

/// A picture with a smooth gradient and fine noise in every plane (its content sets only the
/// drops' colour, not the work).
fn picture(width: u32, height: u32) -> YuvFrame {
    let mut f = YuvFrame::filled(
        common::format_420(width, height),
        ColorParams::bt709(8),
        [16, 128, 128],
    );
    for (i, plane) in f.planes.iter_mut().enumerate() {
        let w = plane.stride.max(1);
        for (k, v) in plane.data.iter_mut().enumerate() {
            let gradient = (k % w) * 160 / w + 40;
            let noise = (k.wrapping_mul(2_654_435_761) >> (20 + i)) & 15;
            *v = (gradient + noise) as u8;
        }
    }
    f
}

struct Row {
    rate_mm_per_h: f64,
    max_drops: u32,
    mattes: bool,
    height: u32,
}

fn main() {
    let frames: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(600);
    let warm_up = (frames / 10).clamp(1, 60);
    let ctx = match GpuContext::new(&AdapterRequest::default()) {
        Ok(ctx) => Arc::new(ctx),
        Err(e) => {
            eprintln!("gpu_frame: {e}");
            return;
        }
    };
    let adapter = ctx.summary();
    println!(
        "adapter: {} ({}, {}, {}); {frames} frames after {warm_up} to warm up",
        adapter.name, adapter.backend, adapter.device_type, adapter.driver
    );
    let atlas = Arc::new(MatteAtlas::load(Path::new("drops"), 1.0 / 50.0).expect("drops/"));
    println!(
        "| size | rain mm/h | drop budget | streaks | drops simulated | wall fps | GPU yuv→rgb ms | GPU simulate ms | GPU streaks ms | GPU rgb→yuv ms | render-only fps |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let rows = [
        (10.0, 300_000, false, 1080),
        (75.0, 128_960, false, 1080),
        (75.0, 300_000, false, 1080),
        (150.0, 1_000_000, false, 1080),
        (75.0, 128_960, true, 1080),
        (75.0, 128_960, false, 540),
    ];
    for (rate_mm_per_h, max_drops, mattes, height) in rows {
        let row = Row {
            rate_mm_per_h,
            max_drops,
            mattes,
            height,
        };
        measure(&ctx, &row, mattes.then(|| atlas.clone()), warm_up, frames);
    }
}

fn measure(
    ctx: &Arc<GpuContext>,
    row: &Row,
    atlas: Option<Arc<MatteAtlas>>,
    warm_up: usize,
    frames: usize,
) {
    let height = row.height;
    let width = height * 16 / 9;
    let camera =
        rain_composite::scene::Camera::new(width, height, 60f64.to_radians(), 1.6, 0.0, 0.0);
    let config = RainConfig {
        rate_mm_per_h: row.rate_mm_per_h,
        max_drops: row.max_drops,
        streaks: if row.mattes {
            StreakStyle::Mattes
        } else {
            StreakStyle::Simple
        },
        ..RainConfig::default()
    };
    let setup = common::rain_setup(&camera, &config).with_mattes(atlas);
    let frame = picture(width, height);
    let mut comp =
        Compositor::new(ctx.clone(), frame.format, &frame.color, &setup).expect("compositor");
    comp.set_transfer_table(&common::water_tables());
    run(&mut comp, &setup, &frame, 0, warm_up);
    let before = comp.gpu_times();
    let start = Instant::now();
    run(&mut comp, &setup, &frame, warm_up, frames);
    let wall_s = start.elapsed().as_secs_f64();
    let t = minus(comp.gpu_times(), before);
    let ms = |s: f64| 1000.0 * s / frames as f64;
    let sum = t.yuv_to_rgb_s + t.rain_simulate_s + t.rain_streaks_s + t.rgb_to_yuv_s;
    println!(
        "| {width}×{height} | {} | {} | {} | {} | {:.0} | {:.3} | {:.3} | {:.3} | {:.3} | {} |",
        row.rate_mm_per_h,
        row.max_drops,
        if row.mattes { "mattes" } else { "simple" },
        comp.drop_count(),
        frames as f64 / wall_s,
        ms(t.yuv_to_rgb_s),
        ms(t.rain_simulate_s),
        ms(t.rain_streaks_s),
        ms(t.rgb_to_yuv_s),
        if sum > 0.0 {
            format!("{:.0}", frames as f64 / sum)
        } else {
            "no timestamps".into()
        },
    );
}

/// Frames `first..first + count` of `setup` over `frame`, every one read back.
fn run(comp: &mut Compositor, setup: &RainSetup, frame: &YuvFrame, first: usize, count: usize) {
    for i in first..first + count {
        let p = common::sky_params(setup, i as f64 / FPS);
        comp.submit(frame, &p).expect("submit");
    }
    comp.flush().expect("flush");
}

/// The GPU time spent between two readings of the compositor's running sums.
fn minus(after: GpuStageTimes, before: GpuStageTimes) -> GpuStageTimes {
    GpuStageTimes {
        yuv_to_rgb_s: after.yuv_to_rgb_s - before.yuv_to_rgb_s,
        rain_simulate_s: after.rain_simulate_s - before.rain_simulate_s,
        rain_streaks_s: after.rain_streaks_s - before.rain_streaks_s,
        rgb_to_yuv_s: after.rgb_to_yuv_s - before.rgb_to_yuv_s,
        ..GpuStageTimes::default()
    }
}
