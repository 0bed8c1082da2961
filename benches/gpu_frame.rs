//! The frame's GPU stages in a loop on the first adapter (colour in, the rain simulated, its
//! streaks drawn, colour out), each rain drawn twice in one process: its streaks by quads
//! through the rasteriser (`--gpu-raster fragments`) and by compute in tiles (`compute`). Per
//! row: drops drawn a frame, the streak draw's and all stages' GPU time per frame (timestamp
//! queries, where the adapter has them), render-only fps (1 / all stages' GPU time) and the
//! wall and CPU time per frame (decode and encode of the packed planes in it).
//! `cargo bench --bench gpu_frame [-- FRAMES] [WORD…]`: FRAMES timed frames a row (after a
//! tenth as many, 1 to 60, untimed), words keep only the rows whose line names them all
//! (`compute 1080p`).

mod common;

use std::sync::Arc;
use std::time::Instant;

use rain_composite::config::{GpuRaster, RainConfig};
use rain_composite::gpu::compositor::GpuStageTimes;
use rain_composite::gpu::{AdapterRequest, Backend, Compositor, GpuContext};
use rain_composite::scene::Camera;
use rain_composite::video::{ColorParams, YuvFrame};

/// All stages' GPU time and the streak draw's, s.
fn gpu_s(t: &GpuStageTimes) -> (f64, f64) {
    let all = t.yuv_to_rgb_s
        + t.rain_simulate_s
        + t.rain_splashes_s
        + t.rain_streaks_s
        + t.rgb_to_yuv_s
        + t.rgba_out_s
        + t.wet_ground_s
        + t.puddles_s;
    (all, t.rain_streaks_s)
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let (frames, words) = match args.first().and_then(|a| a.parse::<usize>().ok()) {
        Some(n) => (n, &args[1..]),
        None => (20, &args[..]),
    };
    let ctx = match GpuContext::new(&AdapterRequest {
        backend: Backend::Gpu,
        ..AdapterRequest::default()
    }) {
        Ok(c) => Arc::new(c),
        Err(e) => {
            eprintln!("no GPU adapter: {e}");
            return;
        }
    };
    let adapter = ctx.summary();
    println!(
        "{} ({}, {}), {frames} frames a row",
        adapter.name, adapter.backend, adapter.device_type
    );
    println!(
        "| picture | rain mm/h | drop budget | raster | drops drawn | streaks GPU ms | all stages GPU ms | render-only fps | wall ms | CPU ms |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let rows = [
        ((1920, 1080), 10.0, 300_000),
        ((1920, 1080), 75.0, 128_960),
        ((1920, 1080), 75.0, 300_000),
        ((1920, 1080), 150.0, 1_000_000),
        ((960, 540), 10.0, 300_000),
    ];
    for ((w, h), rate, budget) in rows {
        for raster in [GpuRaster::Fragments, GpuRaster::Compute] {
            let picture = if h == 1080 {
                "1080p".to_string()
            } else {
                format!("{w}x{h}")
            };
            let line = format!("{picture} {rate} {budget} {}", raster.name());
            if !words.iter().all(|w| line.contains(w.as_str())) {
                continue;
            }
            let camera = Camera::new(w, h, 60f64.to_radians(), 1.6, 0.0, 0.0);
            let rain = RainConfig {
                rate_mm_per_h: rate,
                max_drops: budget,
                ..RainConfig::default()
            };
            let mut setup = common::rain_setup(&camera, &rain);
            setup.plan.gpu_raster = raster;
            let format = common::format_420(w, h);
            let frame = YuvFrame::filled(format, ColorParams::bt709(8), [90, 120, 136]);
            let mut comp = Compositor::with_backend(
                ctx.clone(),
                format,
                &ColorParams::bt709(8),
                &setup,
                None,
                Backend::Gpu,
            )
            .expect("compositor");
            // Untimed frames first: a GPU idle before the row runs at a low clock until
            // kept busy a while (an H200 idles at 345 MHz and runs at 1 980).
            let warm_up = (frames / 10).clamp(1, 60);
            for i in 0..warm_up {
                let params = common::sky_params(&setup, i as f64 / 25.0);
                comp.submit(&frame, &params).expect("frame");
            }
            comp.flush().expect("frames");
            let before = gpu_s(&comp.gpu_times());
            let (start, cpu) = (Instant::now(), common::cpu_ms());
            for i in 0..frames {
                let params = common::sky_params(&setup, (warm_up + i) as f64 / 25.0);
                comp.submit(&frame, &params).expect("frame");
            }
            comp.flush().expect("frames");
            let wall_ms = start.elapsed().as_secs_f64() * 1e3 / frames as f64;
            let cpu_ms = (common::cpu_ms() - cpu) / frames as f64;
            let after = gpu_s(&comp.gpu_times());
            let per = |a: f64, b: f64| (a - b) * 1e3 / frames as f64;
            let (all_ms, streaks_ms) = (per(after.0, before.0), per(after.1, before.1));
            let fps = if all_ms > 0.0 {
                format!("{:.0}", 1e3 / all_ms)
            } else {
                "–".into()
            };
            println!(
                "| {picture} | {rate} | {budget} | {} | {} | {streaks_ms:.3} | {all_ms:.3} | {fps} | {wall_ms:.1} | {cpu_ms:.1} |",
                raster.name(),
                comp.drop_count()
            );
        }
    }
}
