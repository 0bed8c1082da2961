//! `rain-composite inspect …`: the flags of each report, read into the settings that
//! `rain_composite::inspect` takes; the reports themselves are the library's.

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Subcommand;
use rain_composite::config::CameraConfig;
use rain_composite::inspect;
use rain_composite::lighting::{ChannelIndices, HdrInput, LightConfig};

use crate::args::{LookArgs, render_config};
use crate::out;

#[derive(Subcommand, Debug)]
pub enum InspectCommand {
    /// Run an SPH validation scene and print its measures (density error, pressure against
    /// depth, water front against Martin & Moyce, mass ledger, carpet flatness).
    Sph {
        /// column, dam-break or basin.
        #[arg(long, value_parser = ["column", "dam-break", "basin"])]
        scene: String,
        /// Solver steps, at most 100000 [default: the steps that reach the validated state:
        /// column 3500, dam-break 1500, basin 5000].
        #[arg(long)]
        steps: Option<usize>,
        /// Print JSON (the only format).
        #[arg(long)]
        json: bool,
    },
    /// The raindrop's radiance-transfer function: table per order, energy, zonal SH coefficients.
    Rtf {
        /// Refractive index: one value, or R,G,B for dispersion.
        #[arg(long, default_value = "1.333", value_delimiter = ',')]
        rho: Vec<f64>,
        /// Highest scattering order.
        #[arg(long, default_value_t = inspect::RTF_N_MAX)]
        nmax: usize,
        /// Angular bins of the table over [0, π].
        #[arg(long, default_value_t = 1024)]
        bins: usize,
        /// SH bands of the zonal coefficients.
        #[arg(long, default_value_t = 4)]
        bands: usize,
        /// Print JSON (the default; kept for scripts).
        #[arg(long)]
        json: bool,
        /// Also draw a polar plot with the rainbow angles marked to this PNG.
        #[arg(long, value_name = "PNG")]
        plot: Option<PathBuf>,
    },
    /// The SH coefficients of an image used as a frame under the camera model.
    #[command(allow_negative_numbers = true)]
    Sh {
        /// An image (PNG, sRGB) standing for a video frame.
        image: PathBuf,
        /// SH bands.
        #[arg(long, default_value_t = 4)]
        bands: usize,
        /// Horizontal field of view, degrees.
        #[arg(long, default_value_t = CameraConfig::default().fov_deg)]
        fov: f64,
        /// Camera pitch, degrees up.
        #[arg(long, default_value_t = CameraConfig::default().tilt_deg, allow_hyphen_values = true)]
        tilt: f64,
        /// Print JSON (the default; kept for scripts).
        #[arg(long)]
        json: bool,
        /// Also draw the environment reconstructed from its coefficients beside the mapped
        /// original to this PNG.
        #[arg(long, value_name = "PNG")]
        plot: Option<PathBuf>,
    },
    /// The light of an image used as a frame: recovered light sources, the SH of the extended
    /// remainder, and the radiance of a drop seen through a grid of pixel positions, with and
    /// without recovery (linear RGB, 1.0 = the frame's white).
    Light {
        /// An image (PNG, sRGB, 8 or 16 bit) standing for a video frame.
        image: PathBuf,
        /// Horizontal field of view, degrees.
        #[arg(long, default_value_t = CameraConfig::default().fov_deg)]
        fov: f64,
        /// Camera pitch, degrees up.
        #[arg(long, default_value_t = CameraConfig::default().tilt_deg, allow_hyphen_values = true)]
        tilt: f64,
        /// Grid of view rays, NxM (columns x rows).
        #[arg(long, default_value = "3x3")]
        grid: String,
        /// A fixed factor on the clip level for clipped pixels instead of the estimate.
        #[arg(long)]
        highlight_gain: Option<f64>,
        /// Trust the image as it is (no recovery).
        #[arg(long)]
        hdr_input: bool,
        /// Print JSON (the default; kept for scripts).
        #[arg(long)]
        json: bool,
        /// Also draw the frame with the lights marked to this PNG.
        #[arg(long, value_name = "PNG")]
        plot: Option<PathBuf>,
        /// Also write the clipped regions to this 16-bit greyscale PNG of the image's size:
        /// each pixel the 1-based index of its region in `regions` (0 = not clipped).
        #[arg(long, value_name = "PNG")]
        labels: Option<PathBuf>,
    },
    /// The ground `--ground auto` finds at a time of a clip: horizon_row (where the horizon
    /// crosses the vertical centre line, a fraction of the height from the top), tilt_deg and
    /// roll_deg (as --tilt and --roll), confidence (0–1) and the evidence.
    Ground {
        /// Input video.
        video: String,
        /// Time of the frame: seconds, or with a unit (2.5s, 1500ms, 00:01:02.5).
        #[arg(long, default_value = "0")]
        at: String,
        /// Horizontal field of view, degrees.
        #[arg(long, default_value_t = CameraConfig::default().fov_deg)]
        fov: f64,
        /// Camera height above the ground, metres (for the plot's metre grid).
        #[arg(long, default_value_t = CameraConfig::default().height_m)]
        camera_height: f64,
        /// Print JSON (the default; kept for scripts).
        #[arg(long)]
        json: bool,
        /// Also draw the frame with the horizon and a metre grid on the ground to this PNG.
        #[arg(long, value_name = "PNG")]
        plot: Option<PathBuf>,
    },
    /// The open sky the haze finds at a time of a clip (where the scene is infinitely far and
    /// the haze leaves the sky its own radiance; --sky): sky_share (of the picture) and the
    /// mask's grid.
    Sky {
        /// Input video.
        video: String,
        /// Time of the frame: seconds, or with a unit (2.5s, 1500ms, 00:01:02.5).
        #[arg(long, default_value = "0")]
        at: String,
        /// Print JSON (the default; kept for scripts).
        #[arg(long)]
        json: bool,
        /// Also write the mask to this PNG: each displayed pixel's sky weight as the haze reads
        /// it (white = sky).
        #[arg(long, value_name = "PNG")]
        mask: Option<PathBuf>,
    },
    /// The camera's motion `--camera-motion auto` estimates over a whole clip: per frame t, pan_deg (since the first frame, right positive), tilt_deg and roll_deg (as --tilt and --roll), fov_deg and confidence; per shot its confidence and largest turn. The report is a pose file for --camera-motion.
    #[command(allow_negative_numbers = true)]
    Camera {
        /// Input video.
        video: String,
        /// Horizontal field of view of the first frame, degrees.
        #[arg(long, default_value_t = CameraConfig::default().fov_deg)]
        fov: f64,
        /// Camera pitch at the first frame, degrees up.
        #[arg(long, default_value_t = CameraConfig::default().tilt_deg)]
        tilt: f64,
        /// Camera roll at the first frame, degrees clockwise.
        #[arg(long, default_value_t = CameraConfig::default().roll_deg)]
        roll: f64,
        /// Print JSON (the default; kept for scripts).
        #[arg(long)]
        json: bool,
    },
    /// Sample the drop emitter: the plan (distances, counts per band), diameters, velocities, positions.
    #[command(allow_negative_numbers = true)]
    Drops {
        /// Picture size the camera sees, WxH.
        #[arg(long, default_value = "1920x1080")]
        size: String,
        /// Drops to sample.
        #[arg(long, default_value_t = 1000)]
        count: usize,
        /// Time, seconds.
        #[arg(long, default_value_t = 0.0)]
        time: f64,
        /// Frame rate, for the exposure (shutter angle / 360 / fps).
        #[arg(long, default_value_t = 25.0)]
        fps: f64,
        /// Print JSON (the only format).
        #[arg(long)]
        json: bool,
        /// Instead of the plan, draw a labelled contact sheet of the streak mattes to this PNG.
        #[arg(long, value_name = "PNG")]
        mattes: Option<PathBuf>,
        /// The render's flags; `--streak-db` also names the database `--mattes` draws (ours,
        /// with index.json, or a copy of Garg & Nayar's) [default: the one the render uses].
        #[command(flatten)]
        look: Box<LookArgs>,
    },
    /// The water on the ground at a time of a clip, as a render with the same options
    /// simulates it (fast-forwarded from the start): water_volume_m3, puddle_area_m2, particle
    /// count and cap, the mass ledger, the time the fast-forward took.
    #[command(allow_negative_numbers = true)]
    Puddles {
        /// Input video.
        video: String,
        /// Time: seconds, or with a unit (2.5s, 1500ms, 00:01:02.5).
        #[arg(long, default_value = "0")]
        at: String,
        /// Print JSON (the default; kept for scripts).
        #[arg(long)]
        json: bool,
        /// Also draw the water-depth map seen from above (far side up) to this PNG.
        #[arg(long, value_name = "PNG")]
        plot: Option<PathBuf>,
        /// Keep the water after every N-th frame up to --at, as a render with --checkpoint-every N would: the simulation pass of a farm, before chunks that read --checkpoints.
        #[arg(long, value_name = "N", default_value_t = 0)]
        checkpoint_every: u64,
        #[command(flatten)]
        checkpoints: crate::args::CheckpointArgs,
        #[command(flatten)]
        look: Box<LookArgs>,
    },
}

/// `--fov` of the image reports: the range the render accepts.
fn check_fov(fov: f64) -> anyhow::Result<()> {
    if !(fov > 1.0 && fov < 170.0) {
        bail!("invalid --fov {fov}: expected degrees in (1, 170)");
    }
    Ok(())
}

/// Runs one report and prints it.
pub fn run(command: &InspectCommand) -> anyhow::Result<()> {
    let report = match command {
        InspectCommand::Sph { scene, steps, .. } => {
            inspect::sph(scene, *steps, &crate::INTERRUPTED)?
        }
        InspectCommand::Rtf {
            rho,
            nmax,
            bins,
            bands,
            plot,
            ..
        } => {
            let rho: ChannelIndices = match rho.as_slice() {
                [r] => (*r).into(),
                [r, g, b] => [*r, *g, *b].into(),
                _ => bail!("invalid --rho: give one index or three (R,G,B)"),
            };
            inspect::rtf(rho, *nmax, *bins, *bands, plot.as_deref())?
        }
        InspectCommand::Sh {
            image,
            bands,
            fov,
            tilt,
            plot,
            ..
        } => {
            check_fov(*fov)?;
            let camera = CameraConfig {
                fov_deg: *fov,
                tilt_deg: *tilt,
                ..CameraConfig::default()
            };
            inspect::sh(image, &camera, *bands, plot.as_deref())?
        }
        InspectCommand::Light {
            image,
            fov,
            tilt,
            grid,
            highlight_gain,
            hdr_input,
            plot,
            labels,
            ..
        } => {
            check_fov(*fov)?;
            let parsed = grid
                .split_once(['x', 'X'])
                .and_then(|(a, b)| Some((a.trim().parse().ok()?, b.trim().parse().ok()?)));
            let Some(grid) = parsed else {
                bail!("invalid --grid '{grid}': expected NxM, e.g. 3x3");
            };
            let camera = CameraConfig {
                fov_deg: *fov,
                tilt_deg: *tilt,
                ..CameraConfig::default()
            };
            let light = LightConfig {
                highlight_gain: *highlight_gain,
                hdr_input: if *hdr_input {
                    HdrInput::On
                } else {
                    HdrInput::Auto
                },
                ..LightConfig::default()
            };
            inspect::light(
                image,
                &camera,
                grid,
                &light,
                plot.as_deref(),
                labels.as_deref(),
            )?
        }
        InspectCommand::Ground {
            video,
            at,
            fov,
            camera_height,
            plot,
            ..
        } => {
            check_fov(*fov)?;
            let camera = CameraConfig {
                fov_deg: *fov,
                height_m: *camera_height,
                ..CameraConfig::default()
            };
            if !(camera_height.is_finite() && *camera_height > 0.0 && *camera_height <= 1000.0) {
                bail!("invalid --camera-height {camera_height}: expected metres in (0, 1000]");
            }
            let at_s = crate::args::parse_time_s(at)?;
            inspect::ground(video, at_s, &camera, plot.as_deref())?
        }
        InspectCommand::Sky {
            video, at, mask, ..
        } => {
            let at_s = crate::args::parse_time_s(at)?;
            inspect::sky(video, at_s, mask.as_deref())?
        }
        InspectCommand::Camera {
            video,
            fov,
            tilt,
            roll,
            ..
        } => {
            check_fov(*fov)?;
            for (flag, v) in [("--tilt", *tilt), ("--roll", *roll)] {
                if !(v.is_finite() && v.abs() <= 90.0) {
                    bail!("invalid {flag} {v}: expected degrees within ±90");
                }
            }
            let camera = CameraConfig {
                fov_deg: *fov,
                tilt_deg: *tilt,
                roll_deg: *roll,
                ..CameraConfig::default()
            };
            inspect::camera(video, &camera)?
        }
        InspectCommand::Drops {
            size,
            count,
            time,
            fps,
            look,
            mattes,
            ..
        } => {
            if let Some(sheet) = mattes {
                let db = match &look.streak_db {
                    Some(db) => PathBuf::from(db),
                    None => rain_composite::shot::default_streak_db().context(
                        "no streak database is installed beside the program \
                         (../share/rain-composite/drops, or drops/ next to it): pass --streak-db DIR",
                    )?,
                };
                let report = rain_composite::drops::sheet::contact_sheet(&db, sheet)?;
                return out(&serde_json::to_string_pretty(&report)?);
            }
            let config = render_config(look)?;
            let size_px = size
                .split_once('x')
                .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
                .filter(|&(w, h)| w > 0 && h > 0)
                .with_context(|| {
                    format!("invalid --size '{size}': expected WxH, e.g. 1920x1080")
                })?;
            inspect::drops(&config, size_px, *count, *time, *fps)?
        }
        InspectCommand::Puddles {
            video,
            at,
            plot,
            checkpoint_every,
            checkpoints,
            look,
            ..
        } => {
            let config = render_config(look)?;
            let at_s = crate::args::parse_time_s(at)?;
            let keep = rain_composite::fluid::puddles::Checkpoints {
                dir: checkpoints.dir(video, video),
                every_frames: *checkpoint_every,
            };
            inspect::puddles(
                &config,
                video,
                at_s,
                plot.as_deref(),
                Some(&keep),
                &crate::INTERRUPTED,
            )?
        }
    };
    out(&serde_json::to_string_pretty(&report)?)
}
