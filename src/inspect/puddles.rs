//! `inspect puddles`: the water on a clip's ground at a time, as a render with the same
//! options would simulate it — fast-forwarded from t = 0 with the clip's rain — and its
//! water-depth map as a plot.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use serde_json::{Value, json};

use crate::config::RenderConfig;
use crate::fluid::carpet::Field2;
use crate::fluid::puddles::checkpoint::{Checkpoints, fingerprint};
use crate::fluid::puddles::{PuddleSettings, PuddleSim};
use crate::shot::{Footage, camera_for, exposure_s};
use crate::video::Source;
use crate::{Error, Result};

/// The report at `at_s` (seconds from the clip's start) of `input` under `config`; with
/// `plot`, also the water depth seen from above to this PNG. Stops with
/// [`Error::Interrupted`] once `cancel` is set.
pub fn report(
    config: &RenderConfig,
    input: &str,
    at_s: f64,
    plot: Option<&Path>,
    keep: Option<&Checkpoints>,
    cancel: &AtomicBool,
) -> Result<Value> {
    if !(at_s.is_finite() && at_s >= 0.0) {
        return Err(Error::Parameter {
            name: "job.at",
            value: at_s.to_string(),
            expected: "a time ≥ 0 s".into(),
        });
    }
    config.validate()?;
    // The camera's motion as the render resolves it: the water covers every view, and the
    // water kept here is the render's.
    let config = &crate::pipeline::motion::resolve(config, input, cancel)?;
    let source = Source::open(input)?;
    let info = source.info().clone();
    let camera = camera_for(&info, config)?;
    let fps = Footage::of(&info).fps;
    // A time beyond the clip is refused, not simulated; its end (a farm's pass to the last
    // frame's end) is taken.
    if let Some(duration_s) = info.duration_s
        && at_s > duration_s + 1.0 / fps
    {
        return Err(Error::OutOfRange(format!(
            "{at_s} s is beyond the last frame of '{input}' (it lasts {duration_s:.2} s)"
        )));
    }
    let depth = match &config.ground.depth {
        Some(path) => {
            let mut maps = crate::scene::depth::DepthSource::open(path, config.ground.depth_scale)?;
            let map = maps.at(0)?;
            Some(
                map.resampled(camera.width_px as usize, camera.height_px as usize)
                    .depth_m,
            )
        }
        None => None,
    };
    let (w, h) = Footage::of(&info).display_size();
    let plan = crate::shot::rain::plan_keyed(
        &camera,
        &config.posed_camera(w, h)?,
        &config.rain,
        &config.keyframes,
        exposure_s(&info, config)?,
        info.rotation_deg,
        (info.format.width, info.format.height),
    )?;
    let settings = PuddleSettings::of(config);
    let built = Instant::now();
    let views = plan
        .camera_track()
        .poses(crate::shot::rain::GROUND_VIEW_STEP_DEG);
    let Some(mut sim) = PuddleSim::seen_by(config, &views, depth.as_deref(), fps, &settings)?
    else {
        return Ok(json!({
            "simulated": false,
            "reason": if depth.is_some() {
                "the depth map shows no ground within reach"
            } else if config.ground.is_given() {
                "the picture shows no ground within reach"
            } else {
                "no ground given (none, or auto): no fluid is built"
            },
        }));
    };
    let build_s = built.elapsed().as_secs_f64();
    let run = Instant::now();
    let rain = crate::rain::volume::GroundRain::new(plan.rainfall());
    let steps = match keep.filter(|k| k.every_frames > 0) {
        // Frame by frame, keeping the water after every N-th as a render would: a farm's
        // simulation pass before its chunks.
        Some(k) => {
            let print = fingerprint(config, &camera, fps, &settings);
            let mut steps = 0;
            let frames = (at_s * fps + 1e-9).floor() as u64;
            for index in 0..=frames {
                steps += sim.advance_with_rain_or_stop(&rain, index as f64 / fps, cancel)?;
                if k.keeps(index) {
                    k.save(&print, index, &sim)?;
                }
            }
            steps + sim.advance_with_rain_or_stop(&rain, at_s, cancel)?
        }
        None => sim.advance_with_rain_or_stop(&rain, at_s, cancel)?,
    };
    let fast_forward_s = run.elapsed().as_secs_f64();
    let depth = sim.water_depth();
    let cell_m2 = (depth.cell_m as f64).powi(2);
    let wet = depth.values.iter().filter(|&&d| d > 0.0).count();
    let ledger = sim.ledger();
    let (cap, capped) = sim.particle_cap();
    let f = sim.footprint();
    if let Some(path) = plot {
        plot_depth(&depth, path)?;
    }
    Ok(json!({
        "simulated": true,
        "time_s": sim.time_s(),
        "water_volume_m3": ledger.particles_present as f64 * ledger.particle_volume_m3,
        "carpet_volume_m3": depth.values.iter().map(|&d| d as f64).sum::<f64>() * cell_m2,
        "puddle_area_m2": wet as f64 * cell_m2,
        "deepest_m": depth.values.iter().fold(0.0f32, |a, &b| a.max(b)),
        "particles": ledger.particles_present,
        "particle_spacing_m": sim.particle_spacing_m(),
        "particle_cap": cap,
        "particle_cap_reached": capped,
        "solver_steps": steps,
        "footprint_m": { "min": [f.min_m.x, f.min_m.y], "max": [f.max_m.x, f.max_m.y] },
        "relief_m": config.ground.relief_m,
        "relief_seed": config.ground.relief_seed,
        "build_s": build_s,
        "fast_forward_s": fast_forward_s,
        "ledger": ledger,
        "depth_map": { "nx": depth.nx, "ny": depth.ny, "cell_m": depth.cell_m },
    }))
}

/// The water depth seen from above, far side up: dry ground grey, water blue, deeper darker
/// (linear up to the deepest cell).
pub fn plot_depth(depth: &Field2, path: &Path) -> Result<()> {
    let deepest = depth.values.iter().fold(0.0f32, |a, &b| a.max(b));
    let img = image::RgbImage::from_fn(depth.nx as u32, depth.ny as u32, |x, y| {
        let d = depth.values[(depth.ny - 1 - y as usize) * depth.nx + x as usize];
        if d <= 0.0 {
            return image::Rgb([150, 150, 150]);
        }
        let s = if deepest > 0.0 { d / deepest } else { 0.0 };
        image::Rgb([
            (120.0 * (1.0 - s)) as u8,
            (170.0 * (1.0 - s) + 40.0 * s) as u8,
            (255.0 - 120.0 * s) as u8,
        ])
    });
    crate::files::save_png(&img, path)
}
