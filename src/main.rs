//! The `rain-composite` command line: flags → library calls. anyhow lives only here.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, bail};
use clap::{Args, Parser, Subcommand, ValueEnum};
use rain_composite::config::RenderConfig;
use rain_composite::gpu::{AdapterRequest, list_adapters};
use rain_composite::pipeline::{self, FrameSelector, Job, Progress};
use rain_composite::video::{self, AudioMode, EncodeOptions, VideoCodec};

mod bench;

/// Adds physically based rain to video.
#[derive(Parser, Debug)]
#[command(
    name = "rain-composite",
    version,
    args_conflicts_with_subcommands = true,
    allow_negative_numbers = true
)]
#[command(
    after_help = "Examples:\n  rain-composite in.mp4 -o out.mp4 --rain heavy --wind 3,0\n  rain-composite preview in.mp4 --at 2.5s -o frame.png\n  ffmpeg -i in.mp4 -f yuv4mpegpipe - | rain-composite - -o - | ffplay -"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    render: RenderArgs,
    #[command(flatten)]
    log: LogArgs,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render one frame exactly as the full render would, to a PNG.
    #[command(allow_negative_numbers = true)]
    Preview(PreviewArgs),
    /// Describe the streams of a file: colour tags, rotation, frame rate, what would be copied.
    Probe(ProbeArgs),
    /// Print the models behind the rain as JSON (drop sampling, ...).
    #[command(subcommand)]
    Inspect(InspectCommand),
    /// Time a full render against a plain ffmpeg transcode of the same clip (needs the ffmpeg CLI).
    #[command(allow_negative_numbers = true)]
    Bench(BenchArgs),
    /// List the GPU adapters, best first.
    Adapters {
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Subcommand, Debug)]
enum InspectCommand {
    /// Run an SPH validation scene and print its measures (density error, pressure against
    /// depth, water front against Martin & Moyce, mass ledger, carpet flatness).
    Sph {
        /// column, dam-break or basin.
        #[arg(long, value_parser = ["column", "dam-break", "basin"])]
        scene: String,
        /// Solver steps [default: the steps that reach the validated state: column 3500,
        /// dam-break 1500, basin 5000].
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
        #[arg(long, default_value_t = 9)]
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
        #[arg(long, default_value_t = 60.0)]
        fov: f64,
        /// Camera pitch, degrees up.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
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
        #[arg(long, default_value_t = 60.0)]
        fov: f64,
        /// Camera pitch, degrees up.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
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
        #[command(flatten)]
        look: Box<LookArgs>,
    },
}

#[derive(Args, Debug)]
struct LogArgs {
    /// Print only errors.
    #[arg(short, long, global = true)]
    quiet: bool,
    /// Print more (repeat for debug output).
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    verbose: u8,
}

#[derive(Args, Debug)]
struct RenderArgs {
    /// Input video, or - for a stream on stdin (y4m, nut, matroska, mpegts).
    input: Option<String>,
    /// Output video (container from the extension), or - for stdout.
    #[arg(short, long)]
    output: Option<String>,
    /// Overwrite the output if it exists.
    #[arg(short = 'y', long)]
    overwrite: bool,
    #[command(flatten)]
    look: LookArgs,
    #[command(flatten)]
    encode: EncodeArgs,
    #[command(flatten)]
    gpu: GpuArgs,
    /// Progress report on stderr.
    #[arg(long, value_enum, default_value_t = ProgressMode::Auto)]
    progress: ProgressMode,
}

#[derive(Args, Debug, Clone)]
struct LookArgs {
    /// JSON file of settings (see samples/presets/); flags given here override it.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Rain rate in mm/h, or drizzle (0.3) | light (1) | moderate (5) | heavy (20) | violent (75); 0 turns rain off. [default: 10]
    #[arg(long, value_name = "MM_PER_H")]
    rain: Option<String>,
    /// Multiplier on drop diameters. [default: 1]
    #[arg(long)]
    drop_scale: Option<f64>,
    /// Multiplier on fall speeds. [default: 1]
    #[arg(long)]
    fall_speed_scale: Option<f64>,
    /// Mean wind in m/s as X,Y: X to the right of the picture, Y away from the camera. [default: 0,0]
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
    wind: Option<String>,
    /// Multiplier on the streaks' physical coverage. [default: 1]
    #[arg(long)]
    opacity: Option<f64>,
    /// Random seed: the same seed gives the same rain. [default: 1]
    #[arg(long)]
    seed: Option<u32>,
    /// Horizontal field of view of the picture, degrees. [default: 60]
    #[arg(long)]
    fov: Option<f64>,
    /// Camera height above the ground, metres. [default: 1.6]
    #[arg(long)]
    camera_height: Option<f64>,
    /// Camera pitch, degrees up (negative: down). [default: 0]
    #[arg(long, allow_hyphen_values = true)]
    tilt: Option<f64>,
    /// Camera roll, degrees clockwise. [default: 0]
    #[arg(long, allow_hyphen_values = true)]
    roll: Option<f64>,
    /// Shutter angle, degrees (exposure = angle/360 of a frame). [default: 180]
    #[arg(long)]
    shutter: Option<f64>,
    /// Nearest drop distance, metres. [default: 0.3]
    #[arg(long)]
    near: Option<f64>,
    /// Farthest drop distance, metres; drops are drawn only as far as they are visible. [default: 200]
    #[arg(long)]
    far: Option<f64>,
    /// Most drops drawn per frame (beyond it the far distance shrinks, then drops are weighted). [default: 300000]
    #[arg(long)]
    max_drops: Option<u32>,
    /// RMS of the wind gusts along the mean wind, m/s. [default: 0]
    #[arg(long)]
    gust: Option<f64>,
    /// Altitude of the scene, metres (thinner air, faster drops). [default: 0]
    #[arg(long, allow_hyphen_values = true)]
    altitude: Option<f64>,
    /// Focus distance, metres. [default: 6]
    #[arg(long)]
    focus: Option<f64>,
    /// Aperture f-number; 0 for a pinhole (no defocus). [default: 8]
    #[arg(long)]
    f_number: Option<f64>,
    /// Sensor width, mm (36 = full-frame equivalent). [default: 36]
    #[arg(long)]
    sensor_width: Option<f64>,
    /// Time constant of the lighting's smoothing over frames, seconds; 0 = off. [default: 0.25]
    #[arg(long)]
    light_smoothing: Option<f64>,
    /// Clipped highlights become this factor times the clip level, instead of the recovery's
    /// estimate (compact ones still become light sources).
    #[arg(long)]
    highlight_gain: Option<f64>,
    /// The input is scene-referred (PQ, HLG, float): trust values above 1.0, recover nothing
    /// (ignores --highlight-gain).
    #[arg(long)]
    hdr_input: bool,
    /// Distance of the filmed scene, metres: rain beyond the drawn drops veils it; 0 = no haze. [default: 50]
    #[arg(long)]
    scene_depth: Option<f64>,
    /// A light the frame does not show (repeatable): degrees right and up of the view direction, linear radiance relative to the frame's white (a street lamp at night: 10³–10⁵), and optionally its distance in metres (irradiance then falls with the square of each drop's distance to it). Disc of 3° unless a config sets `angular_diameter_deg`.
    #[arg(
        long = "light",
        value_name = "AZ,EL,R,G,B[,DISTANCE_M]",
        allow_hyphen_values = true
    )]
    lights: Vec<String>,
}

#[derive(Args, Debug, Clone)]
struct EncodeArgs {
    /// Video codec.
    #[arg(long, value_enum, default_value_t = CodecArg::H264)]
    codec: CodecArg,
    /// Constant rate factor (H.264/HEVC; lower is better).
    #[arg(long, default_value_t = 18, value_parser = clap::value_parser!(u8).range(0..=51))]
    crf: u8,
    /// Encoder preset (H.264/HEVC).
    #[arg(long, default_value = "medium")]
    preset: String,
    /// Container for stdout (or to override the extension).
    #[arg(long, value_enum)]
    format: Option<FormatArg>,
    /// What to do with audio and other streams.
    #[arg(long, value_enum, default_value_t = AudioArg::Copy)]
    audio: AudioArg,
}

#[derive(Args, Debug, Clone)]
struct GpuArgs {
    /// Use the adapter whose name contains NAME (see `rain-composite adapters`).
    #[arg(long, value_name = "NAME")]
    adapter: Option<String>,
    /// Use a CPU (software) adapter only.
    #[arg(long)]
    cpu: bool,
}

#[derive(Args, Debug)]
struct PreviewArgs {
    /// Input video.
    input: String,
    /// Time of the frame: seconds, or with a unit (2.5s, 1500ms, 00:01:02.5).
    #[arg(long, conflicts_with = "frame", required_unless_present = "frame")]
    at: Option<String>,
    /// Zero-based frame index.
    #[arg(long)]
    frame: Option<u64>,
    /// Output PNG, or - for stdout.
    #[arg(short, long)]
    output: String,
    /// Overwrite the output if it exists.
    #[arg(short = 'y', long)]
    overwrite: bool,
    /// Bits per PNG channel.
    #[arg(long, value_enum, default_value_t = Bits::Eight)]
    bits: Bits,
    #[command(flatten)]
    look: LookArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
struct BenchArgs {
    /// Input video (scaled to each height).
    input: String,
    /// Picture heights to test.
    #[arg(long, value_delimiter = ',', default_value = "720,1080")]
    heights: Vec<u32>,
    /// Runs per measurement (the median is reported).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=50))]
    runs: u32,
    #[command(flatten)]
    look: LookArgs,
    #[command(flatten)]
    encode: EncodeArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
struct ProbeArgs {
    /// Input video.
    input: String,
    /// Print JSON.
    #[arg(long)]
    json: bool,
    /// Container the output would be written to (decides what can be copied).
    #[arg(long, value_name = "EXT")]
    for_output: Option<String>,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
enum ProgressMode {
    /// A bar when stderr is a terminal, nothing otherwise.
    Auto,
    /// One JSON object per line on stderr.
    Json,
    /// Nothing.
    None,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
enum Bits {
    /// 8 bits per channel.
    #[value(name = "8")]
    Eight,
    /// 16 bits per channel.
    #[value(name = "16")]
    Sixteen,
}

#[derive(ValueEnum, Debug, Clone, Copy)]
enum CodecArg {
    /// H.264 (libx264).
    H264,
    /// HEVC (libx265).
    Hevc,
    /// Apple ProRes 422 HQ (prores_ks), 10-bit.
    Prores,
    /// FFV1, lossless.
    Ffv1,
}

#[derive(ValueEnum, Debug, Clone, Copy)]
enum FormatArg {
    /// YUV4MPEG2 (raw, constant frame rate).
    Y4m,
    /// NUT.
    Nut,
    /// Matroska.
    Matroska,
}

#[derive(ValueEnum, Debug, Clone, Copy)]
enum AudioArg {
    /// Copy audio and other streams bit for bit (AAC where the container cannot hold them).
    Copy,
    /// Video only.
    None,
}

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Our messages at the chosen level; other crates' (wgpu, naga) only at `-vv`, and then only
/// their warnings and errors.
struct StderrLogger {
    level: log::LevelFilter,
    third_party: bool,
}

impl log::Log for StderrLogger {
    fn enabled(&self, m: &log::Metadata) -> bool {
        if m.target().starts_with("rain_composite") {
            m.level() <= self.level
        } else {
            self.third_party && m.level() <= log::Level::Warn
        }
    }
    fn log(&self, r: &log::Record) {
        if self.enabled(r.metadata()) {
            let tag = match r.level() {
                log::Level::Error => "error",
                log::Level::Warn => "warning",
                log::Level::Info => "info",
                _ => "debug",
            };
            eprintln!("{tag}: {}", r.args());
        }
    }
    fn flush(&self) {}
}

fn parse_rain(s: &str) -> anyhow::Result<f64> {
    Ok(rain_composite::rain::physics::RainRate::parse(s)?.mm_per_h())
}

fn parse_time_s(s: &str) -> anyhow::Result<f64> {
    let bad = || {
        anyhow::anyhow!("invalid time '{s}': expected seconds (2.5, 2.5s, 1500ms or 00:01:02.5)")
    };
    let t = if let Some(ms) = s.strip_suffix("ms") {
        ms.trim().parse::<f64>().map_err(|_| bad())? / 1000.0
    } else if s.contains(':') {
        s.split(':')
            .try_fold(0.0, |acc, part| part.parse::<f64>().map(|v| acc * 60.0 + v))
            .map_err(|_| bad())?
    } else {
        s.strip_suffix('s')
            .unwrap_or(s)
            .trim()
            .parse::<f64>()
            .map_err(|_| bad())?
    };
    if !t.is_finite() || t < 0.0 {
        return Err(bad());
    }
    Ok(t)
}

fn render_config(look: &LookArgs) -> anyhow::Result<RenderConfig> {
    let mut c = match &look.config {
        Some(path) => RenderConfig::from_json_file(path)?,
        None => RenderConfig::default(),
    };
    if let Some(r) = &look.rain {
        c.rain.rate_mm_per_h = parse_rain(r)?;
    }
    if let Some(w) = &look.wind {
        let parts: Vec<&str> = w.split(',').collect();
        let parsed: Option<Vec<f64>> = parts.iter().map(|p| p.trim().parse().ok()).collect();
        match parsed.as_deref() {
            Some([x, y]) => c.rain.wind_mps = [*x, *y],
            Some([x]) => c.rain.wind_mps = [*x, 0.0],
            _ => bail!("invalid --wind '{w}': expected X,Y in m/s, e.g. 3,-1"),
        }
    }
    for text in &look.lights {
        c.light
            .lights
            .push(rain_composite::lighting::UserLight::parse(text)?);
    }
    let r = &mut c.rain;
    let cam = &mut c.camera;
    macro_rules! set {
        ($src:expr => $dst:expr) => {
            if let Some(v) = $src {
                $dst = v;
            }
        };
    }
    set!(look.drop_scale => r.drop_scale);
    set!(look.fall_speed_scale => r.fall_speed_scale);
    set!(look.opacity => r.opacity);
    set!(look.seed => r.seed);
    set!(look.near => r.near_m);
    set!(look.far => r.far_m);
    set!(look.max_drops => r.max_drops);
    set!(look.gust => r.gust_mps);
    set!(look.light_smoothing => c.light.smoothing_s);
    if look.highlight_gain.is_some() {
        c.light.highlight_gain = look.highlight_gain;
    }
    if look.hdr_input {
        c.light.hdr_input = true;
    }
    set!(look.altitude => r.altitude_m);
    set!(look.scene_depth => r.scene_depth_m);
    set!(look.focus => cam.focus_m);
    set!(look.f_number => cam.f_number);
    set!(look.sensor_width => cam.sensor_width_mm);
    set!(look.fov => cam.fov_deg);
    set!(look.camera_height => cam.height_m);
    set!(look.tilt => cam.tilt_deg);
    set!(look.roll => cam.roll_deg);
    set!(look.shutter => cam.shutter_deg);
    c.validate()?;
    Ok(c)
}

fn adapter(g: &GpuArgs) -> AdapterRequest {
    AdapterRequest {
        name: g.adapter.clone(),
        cpu_only: g.cpu,
    }
}

fn encode_options(e: &EncodeArgs, overwrite: bool) -> EncodeOptions {
    EncodeOptions {
        codec: match e.codec {
            CodecArg::H264 => VideoCodec::H264,
            CodecArg::Hevc => VideoCodec::Hevc,
            CodecArg::Prores => VideoCodec::ProRes,
            CodecArg::Ffv1 => VideoCodec::Ffv1,
        },
        crf: e.crf,
        preset: e.preset.clone(),
        container: e.format.map(|f| {
            match f {
                FormatArg::Y4m => "yuv4mpegpipe",
                FormatArg::Nut => "nut",
                FormatArg::Matroska => "matroska",
            }
            .to_string()
        }),
        audio: match e.audio {
            AudioArg::Copy => AudioMode::Copy,
            AudioArg::None => AudioMode::None,
        },
        overwrite,
    }
}

fn run_render(args: &RenderArgs) -> anyhow::Result<()> {
    let Some(input) = args.input.clone() else {
        bail!("no input given (usage: rain-composite INPUT -o OUTPUT; see --help)");
    };
    let Some(output) = args.output.clone() else {
        bail!("no output given: add -o OUTPUT (or -o - for stdout)");
    };
    let render = render_config(&args.look)?;
    let encode = encode_options(&args.encode, args.overwrite);
    let job = Job {
        input,
        output,
        render,
        encode,
        adapter: adapter(&args.gpu),
    };
    let bar = (args.progress == ProgressMode::Auto && std::io::stderr().is_terminal()).then(|| {
        let bar = indicatif::ProgressBar::new(0);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} frames  {per_sec}  ETA {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    });
    let json = args.progress == ProgressMode::Json;
    let mut report = |p: Progress| {
        if let Some(bar) = &bar {
            if let Some(total) = p.frames_total {
                bar.set_length(total);
            }
            bar.set_position(p.frames_done);
        } else if json {
            if let Ok(line) = serde_json::to_string(&p) {
                eprintln!("{line}");
            }
        }
    };
    let summary = pipeline::render(&job, &INTERRUPTED, &mut report)?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    log::info!(
        "{} frames in {:.2} s ({:.1} fps) on {}, {} drops per frame",
        summary.frames,
        summary.elapsed_s,
        summary.frames as f64 / summary.elapsed_s.max(1e-9),
        summary.adapter,
        summary.drops
    );
    if json {
        eprintln!("{}", serde_json::to_string(&summary)?);
    }
    Ok(())
}

fn run_preview(args: &PreviewArgs) -> anyhow::Result<()> {
    let to_stdout = args.output == "-";
    if !to_stdout {
        let is_png = std::path::Path::new(&args.output)
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if !is_png {
            bail!(
                "output '{}': preview writes PNG, give a name ending in .png (or - for stdout)",
                args.output
            );
        }
        video::check_output(&args.output, &[&args.input], args.overwrite)?;
    }
    let at = match (&args.at, args.frame) {
        (Some(t), _) => FrameSelector::At(parse_time_s(t)?),
        (None, Some(n)) => FrameSelector::Index(n),
        (None, None) => bail!("give --at TIME or --frame N"),
    };
    let render = render_config(&args.look)?;
    let (frame, info) =
        pipeline::preview(&args.input, at, &render, &adapter(&args.gpu), &INTERRUPTED)?;
    let bits = if args.bits == Bits::Sixteen { 16 } else { 8 };
    let png = video::still::encode_png(&frame, info.rotation_deg, bits)?;
    if to_stdout {
        use std::io::Write;
        let mut stdout = std::io::stdout().lock();
        return stdout
            .write_all(&png)
            .and_then(|()| stdout.flush())
            .map_err(|e| match e.kind() {
                std::io::ErrorKind::BrokenPipe => {
                    anyhow::anyhow!("stdout was closed before the PNG was complete")
                }
                _ => anyhow::anyhow!("cannot write the PNG to stdout: {e}"),
            });
    }
    // Written beside under a hidden name, then renamed: never a half-written PNG, and nothing
    // left behind when writing fails.
    let tmp = video::TempFile::beside(std::path::Path::new(&args.output));
    std::fs::write(tmp.path(), &png)
        .with_context(|| format!("cannot write output '{}'", args.output))?;
    tmp.publish()?;
    Ok(())
}

/// One line (or block) on stdout. A closed pipe (`| head`) ends the output quietly.
fn out(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    match writeln!(std::io::stdout().lock(), "{text}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        r => r.context("writing to stdout"),
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match &cli.command {
        None => run_render(&cli.render),
        Some(Command::Preview(p)) => run_preview(p),
        Some(Command::Probe(p)) => {
            let report = video::probe(&p.input, p.for_output.as_deref())?;
            if p.json {
                out(&serde_json::to_string_pretty(&report)?)?;
            } else {
                out(report.to_string().trim_end())?;
            }
            Ok(())
        }
        Some(Command::Inspect(InspectCommand::Sph { scene, steps, .. })) => {
            let steps = steps.unwrap_or(match scene.as_str() {
                "column" => 3500,
                "dam-break" => 1500,
                _ => 5000,
            });
            let v = rain_composite::fluid::scenes::inspect_sph(scene, steps)?;
            out(&serde_json::to_string_pretty(&v)?)?;
            Ok(())
        }
        Some(Command::Inspect(InspectCommand::Rtf {
            rho,
            nmax,
            bins,
            bands,
            plot,
            ..
        })) => {
            use rain_composite::lighting::{ChannelIndices, inspect};
            let rho: ChannelIndices = match rho.as_slice() {
                [r] => (*r).into(),
                [r, g, b] => [*r, *g, *b].into(),
                _ => bail!("invalid --rho: give one index or three (R,G,B)"),
            };
            let v = inspect::inspect_rtf(rho, *nmax, *bins, *bands)?;
            if let Some(path) = plot {
                inspect::plot_rtf(rho, *nmax, *bins, path)?;
            }
            out(&serde_json::to_string_pretty(&v)?)?;
            Ok(())
        }
        Some(Command::Inspect(InspectCommand::Sh {
            image,
            bands,
            fov,
            tilt,
            plot,
            ..
        })) => {
            use rain_composite::lighting::inspect;
            let img = inspect::LinearImage::load_png(image)?;
            if !(*fov > 1.0 && *fov < 170.0) {
                bail!("invalid --fov {fov}: expected degrees in (1, 170)");
            }
            let camera = rain_composite::config::CameraConfig {
                fov_deg: *fov,
                tilt_deg: *tilt,
                ..Default::default()
            }
            .camera(img.width as u32, img.height as u32);
            let v = inspect::inspect_sh(&img, &camera, *bands)?;
            if let Some(path) = plot {
                inspect::plot_sh(&img, &camera, *bands, path)?;
            }
            out(&serde_json::to_string_pretty(&v)?)?;
            Ok(())
        }
        Some(Command::Inspect(InspectCommand::Light {
            image,
            fov,
            tilt,
            grid,
            highlight_gain,
            hdr_input,
            plot,
            ..
        })) => {
            use rain_composite::lighting::{LightConfig, inspect, inspect_light};
            let img = inspect::LinearImage::load_png(image)?;
            if !(*fov > 1.0 && *fov < 170.0) {
                bail!("invalid --fov {fov}: expected degrees in (1, 170)");
            }
            let parsed = grid
                .split_once(['x', 'X'])
                .and_then(|(a, b)| Some((a.trim().parse().ok()?, b.trim().parse().ok()?)));
            let Some(grid) = parsed else {
                bail!("invalid --grid '{grid}': expected NxM, e.g. 3x3");
            };
            let camera = rain_composite::scene::Camera::new(
                img.width as u32,
                img.height as u32,
                fov.to_radians(),
                1.6,
                tilt.to_radians(),
                0.0,
            );
            let config = LightConfig {
                highlight_gain: *highlight_gain,
                hdr_input: *hdr_input,
                ..LightConfig::default()
            };
            let report = inspect_light::light_report(&img, &camera, grid, &config)?;
            if let Some(path) = plot {
                inspect_light::plot_light(&img, &camera, &report, path)?;
            }
            let v = inspect_light::inspect_light(&report, &camera);
            out(&serde_json::to_string_pretty(&v)?)?;
            Ok(())
        }
        Some(Command::Inspect(InspectCommand::Drops {
            size,
            count,
            time,
            fps,
            look,
            ..
        })) => {
            let c = render_config(look)?;
            let (w, h) = size
                .split_once('x')
                .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
                .filter(|&(w, h)| w > 0 && h > 0)
                .with_context(|| {
                    format!("invalid --size '{size}': expected WxH, e.g. 1920x1080")
                })?;
            let cam = &c.camera;
            let camera = cam.camera(w, h);
            let exposure = rain_composite::rain::physics::exposure_s(cam.shutter_deg, *fps)?;
            let setup =
                rain_composite::gpu::uniforms::build(&camera, cam, &c.rain, exposure, 0, (w, h))?;
            let params = rain_composite::gpu::uniforms::plan_params(cam, &c.rain, exposure)?;
            let v = rain_composite::rain::volume::inspect_drops(
                &camera,
                &setup.model,
                &setup.wind,
                &params,
                *count,
                c.rain.seed,
                *time,
            )?;
            out(&serde_json::to_string_pretty(&v)?)?;
            Ok(())
        }
        Some(Command::Bench(b)) => {
            bench::check_input(&b.input)?;
            let job = Job {
                input: b.input.clone(),
                output: String::new(),
                render: render_config(&b.look)?,
                encode: encode_options(&b.encode, true),
                adapter: adapter(&b.gpu),
            };
            bench::run(&job, &b.input, &b.heights, b.runs as usize)
        }
        Some(Command::Adapters { json }) => {
            let adapters = list_adapters();
            if *json {
                out(&serde_json::to_string_pretty(&adapters)?)?;
            } else if adapters.is_empty() {
                bail!(
                    "no GPU adapter found (install a Vulkan driver, or mesa-vulkan-drivers for the CPU one)"
                );
            } else {
                for a in adapters {
                    out(&format!(
                        "{:<40} {:<8} {:<14} {}",
                        a.name, a.backend, a.device_type, a.driver
                    ))?;
                }
            }
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        // Mesa's device-select Vulkan layer connects to a Wayland display to order the GPUs,
        // and libwayland prints "error: XDG_RUNTIME_DIR is invalid or not set" on stderr when
        // there is none (a server, CI, ssh), which reads as a failure. We rank adapters
        // ourselves, so the layer has nothing to add.
        // SAFETY: no other thread exists yet; nothing reads the environment concurrently.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
    let cli = Cli::parse();
    let level = match (cli.log.quiet, cli.log.verbose) {
        (true, _) => log::LevelFilter::Error,
        (false, 0) => log::LevelFilter::Warn,
        (false, 1) => log::LevelFilter::Info,
        _ => log::LevelFilter::Debug,
    };
    let third_party = !cli.log.quiet && cli.log.verbose >= 2;
    if log::set_logger(Box::leak(Box::new(StderrLogger { level, third_party }))).is_ok() {
        log::set_max_level(level);
    }
    if third_party {
        video::set_ffmpeg_log_level(ffmpeg_next::util::log::Level::Warning);
    }
    let _ = ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::Relaxed));
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
