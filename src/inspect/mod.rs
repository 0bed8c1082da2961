//! The `inspect` reports: one function per subcommand, taking the settings the command line
//! parsed and returning the JSON report (and drawing the optional plot). The binary only parses
//! flags, calls one of these and prints the value, so a report can also be produced (and
//! tested) without the CLI.
//!
//! Each report builds its model with the constructor the render uses — the drop plan with
//! the lens and the budget, the camera from [`CameraConfig`] — so what it prints is what a
//! render with the same settings draws.

pub mod camera;
pub mod ground;
pub mod puddles;
pub mod sky;

use std::path::Path;

use serde_json::Value;

use crate::Result;
use crate::config::{CameraConfig, RenderConfig};
use crate::lighting::inspect::{self as light_inspect, LinearImage};
use crate::lighting::{ChannelIndices, LightConfig, inspect_light, rtf};
use crate::rain::{physics, volume};
use crate::shot::rain as planner;

/// Refuses a plot that could not be written before the report's work is done.
fn check_plot(plot: Option<&Path>) -> Result<()> {
    plot.map_or(Ok(()), crate::files::check_png_output)
}

/// `inspect sph`: runs a validation scene (`column`, `dam-break`, `basin`) for `steps` solver
/// steps, or for the steps that reach its validated state when `None`; stops with
/// [`crate::Error::Interrupted`] once `cancel` is set.
pub fn sph(
    scene: &str,
    steps: Option<usize>,
    cancel: &std::sync::atomic::AtomicBool,
) -> Result<Value> {
    use crate::fluid::scenes::{SceneOptions, inspect_sph_or_stop, validated_steps};
    let steps = steps.unwrap_or_else(|| validated_steps(scene));
    inspect_sph_or_stop(scene, steps, &SceneOptions::default(), cancel)
}

/// Highest scattering order `inspect rtf` tabulates unless told: the render's.
pub const RTF_N_MAX: usize = rtf::DEFAULT_N_MAX;

/// `inspect rtf`: the raindrop's transfer function for refractive index `rho` (one per
/// channel for dispersion): the table per order, energies and zonal SH coefficients; with
/// `plot`, also a polar plot with the rainbow angles marked.
pub fn rtf(
    rho: ChannelIndices,
    n_max: usize,
    bins: usize,
    bands: usize,
    plot: Option<&Path>,
) -> Result<Value> {
    check_plot(plot)?;
    let v = light_inspect::inspect_rtf(rho, n_max, bins, bands)?;
    if let Some(path) = plot {
        light_inspect::plot_rtf(rho, n_max, bins, path)?;
    }
    Ok(v)
}

/// `inspect sh`: the SH coefficients of the image at `image` (a PNG standing for a frame) seen
/// through `camera` (the render's camera model: its height and roll included); with `plot`,
/// also the environment reconstructed from the coefficients beside the mapped original.
pub fn sh(image: &Path, camera: &CameraConfig, bands: usize, plot: Option<&Path>) -> Result<Value> {
    check_plot(plot)?;
    let img = LinearImage::load_png(image)?;
    let camera = camera.camera(img.width as u32, img.height as u32);
    let v = light_inspect::inspect_sh(&img, &camera, bands)?;
    if let Some(path) = plot {
        light_inspect::plot_sh(&img, &camera, bands, path)?;
    }
    Ok(v)
}

/// `inspect light`: the light sources recovered from the clipped highlights of the image at
/// `image` seen through `camera`, the SH of the extended remainder, and the radiance of a drop
/// seen through the centre of each cell of a `grid` (columns, rows), with and without
/// recovery; with `plot`, also the frame with the lights marked.
pub fn light(
    image: &Path,
    camera: &CameraConfig,
    grid: (usize, usize),
    light: &LightConfig,
    plot: Option<&Path>,
    labels: Option<&Path>,
) -> Result<Value> {
    check_plot(plot)?;
    check_plot(labels)?;
    let img = LinearImage::load_png(image)?;
    let camera = camera.camera(img.width as u32, img.height as u32);
    let report = inspect_light::light_report(&img, &camera, grid, light)?;
    if let Some(path) = plot {
        inspect_light::plot_light(&img, &camera, &report, path)?;
    }
    if let Some(path) = labels {
        inspect_light::write_labels(&report, (img.width, img.height), path)?;
    }
    Ok(inspect_light::inspect_light(&report, &camera))
}

/// `inspect drops`: the plan the render of a `size_px` picture at `fps` would use under
/// `config` (distances, counts per band, lens and budget included), and `count` drops sampled
/// from it at `time_s`.
pub fn drops(
    config: &RenderConfig,
    size_px: (u32, u32),
    count: usize,
    time_s: f64,
    fps: f64,
) -> Result<Value> {
    let (w, h) = size_px;
    let cam = &config.camera;
    let camera = cam.camera(w, h);
    let exposure = physics::exposure_s(cam.shutter_deg, fps)?;
    let setup = planner::plan_keyed(
        &camera,
        cam,
        &config.rain,
        &config.keyframes,
        exposure,
        0,
        size_px,
    )?;
    let params = planner::plan_params(cam, &config.rain, exposure)?;
    volume::inspect_drops(
        &camera,
        &setup.model,
        &setup.wind,
        &params,
        count,
        config.rain.seed,
        time_s,
    )
}

/// `inspect ground`: the horizon (tilt, roll, confidence and evidence) that `--ground auto`
/// estimates at `at_s` of the clip `input` through `camera`'s field of view; with `plot`, also
/// the frame with the horizon and a metre grid on the ground (at `camera.height_m`).
pub fn ground(input: &str, at_s: f64, camera: &CameraConfig, plot: Option<&Path>) -> Result<Value> {
    check_plot(plot)?;
    ground::report(input, at_s, camera, plot)
}

/// `inspect sky`: the open sky the haze finds in the frame of `input` at `at_s`, with its
/// mask written to `mask`.
pub fn sky(input: &str, at_s: f64, mask: Option<&Path>) -> Result<Value> {
    check_plot(mask)?;
    sky::report(input, at_s, mask)
}

/// `inspect camera`: the camera's pan, tilt, roll and field of view at every frame of `input`
/// as `camera_motion auto` estimates it, the first frame seen through `camera` (its field of
/// view, tilt and roll); the report is a pose file.
pub fn camera(input: &str, camera: &CameraConfig) -> Result<Value> {
    camera::report(input, camera)
}

/// `inspect puddles`: the water a render of `input` under `config` has on its ground at
/// `at_s` (fast-forwarded from the start), its ledger, and with `plot` the water-depth map;
/// with `keep`, the water is kept along the way as a render keeps it. Stops with
/// [`crate::Error::Interrupted`] once `cancel` is set.
pub fn puddles(
    config: &RenderConfig,
    input: &str,
    at_s: f64,
    plot: Option<&Path>,
    keep: Option<&crate::fluid::puddles::Checkpoints>,
    cancel: &std::sync::atomic::AtomicBool,
) -> Result<Value> {
    check_plot(plot)?;
    puddles::report(config, input, at_s, plot, keep, cancel)
}
