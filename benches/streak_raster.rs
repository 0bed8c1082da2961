//! The CPU back end's rain of one 1080p frame at the default rate (10 mm/h): the drops
//! simulated (`gpu::host::simulate`), then their streaks drawn over a plate in tiles
//! (`gpu::host::streaks`) as capsules and with the shipped mattes, in the AVX2 build and the
//! baseline one. Prints the medians of wall and CPU time (all threads' time on a CPU, from
//! /proc on Linux: on a shared machine the CPU time is the steadier figure).
//! `cargo bench --bench streak_raster [-- RUNS] [WORD…]`: words keep only the rasters whose
//! line names them all (`capsules AVX2`: one raster, for a profile; `simulate`: none).

mod common;

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use rain_composite::drops::MatteAtlas;
use rain_composite::gpu::host::HostColour;
use rain_composite::gpu::host::simulate::{Drops, LightTable, simulate};
use rain_composite::gpu::host::streaks::{Rain, Raster, RasterCount};
use rain_composite::gpu::types::{LightList, RainParams, Streak};
use rain_composite::video::{ColorParams, YuvFrame};

const W: u32 = 1920;
const H: u32 = 1080;

/// Medians of wall and CPU ms of `f(state)` over `runs` runs (`setup(state)` before each, not
/// timed).
fn time<T>(
    runs: usize,
    state: &mut T,
    setup: impl Fn(&mut T),
    mut f: impl FnMut(&mut T),
) -> (f64, f64) {
    let (mut wall, mut cpu) = (Vec::new(), Vec::new());
    for _ in 0..runs {
        setup(state);
        let (t, c) = (Instant::now(), common::cpu_ms());
        f(state);
        wall.push(t.elapsed().as_secs_f64() * 1e3);
        cpu.push(common::cpu_ms() - c);
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    (median(&mut wall), median(&mut cpu))
}

/// The default rain's uniforms at 1.5 s and its drops simulated on the CPU.
fn rain_1080p(runs: usize) -> (RainParams, Vec<Streak>) {
    let setup = common::default_rain(&common::camera_1080p());
    let p = common::sky_params(&setup, 1.5);
    let table = LightTable::new(&rain_composite::gpu::lights::table_texels(
        &common::water_tables(),
    ));
    let none = LightList::new(&[]);
    let drops = Drops {
        columns: &setup.columns,
        lights: &none,
        table: Some(&table),
        glints: false,
    };
    let (mut streaks, mut glints) = (Vec::new(), Vec::new());
    let mut drawable = 0;
    let (wall, cpu) = time(
        runs,
        &mut (),
        |_| {},
        |_| drawable = simulate(&p, &drops, &mut streaks, &mut glints),
    );
    println!(
        "simulate: {drawable} of {} drops drawable; {wall:.2} ms wall, {cpu:.2} ms CPU",
        streaks.len()
    );
    (p, streaks)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let runs = args.iter().find_map(|a| a.parse().ok()).unwrap_or(15);
    // cargo bench passes `--bench`; numbers are the runs.
    let words: Vec<&str> = args
        .iter()
        .filter(|a| !a.starts_with('-') && a.parse::<usize>().is_err())
        .map(String::as_str)
        .collect();
    let (p, streaks) = rain_1080p(runs);
    let format = common::format_420(W, H);
    let mut frame = YuvFrame::filled(format, ColorParams::bt709(8), [90, 128, 128]);
    for (i, plane) in frame.planes.iter_mut().enumerate() {
        for (k, v) in plane.data.iter_mut().enumerate() {
            *v = ((k.wrapping_mul(2_654_435_761) >> (9 + i)) as u8 & 63) | 64;
        }
    }
    let mut clear = p;
    clear.haze = [0.0, 0.0, 0.0, 1.0];
    let plate = HostColour::new(format, &frame.color)
        .decode(&frame, &clear)
        .to_vec();
    let atlas = Arc::new(
        MatteAtlas::load(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("drops"),
            1.0 / 50.0,
        )
        .expect("drops/"),
    );
    type Draw = fn(&mut Raster, &mut [half::f16], usize, &Rain, &[Streak]) -> RasterCount;
    // Each build keeps its raster's buffers from run to run, as a render does.
    let builds: [(&str, Draw); 2] = [("AVX2", Raster::draw), ("baseline", Raster::draw_baseline)];
    for (style, mattes) in [("capsules", None), ("mattes", Some(&*atlas))] {
        let rain = Rain {
            params: &clear,
            mattes,
            glints: &[],
            depth: None,
        };
        for (build, raster) in builds {
            if !words.iter().all(|w| [style, build].contains(w)) {
                continue;
            }
            let mut canvas = plate.clone();
            let mut kept = Raster::default();
            let mut count = None;
            let (wall, cpu) = time(
                runs,
                &mut canvas,
                |c| c.copy_from_slice(&plate),
                |c| count = Some(raster(&mut kept, c, W as usize, &rain, &streaks)),
            );
            println!(
                "raster, {style}, {build} build: {count:?}; {wall:.2} ms wall, {cpu:.2} ms CPU"
            );
        }
    }
}
