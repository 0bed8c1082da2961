//! The command line's shape (clap) and its translation into the library's settings. Defaults
//! of values that live in the library are read from it (`RenderConfig::default`,
//! `EncodeOptions::default`), never repeated here.

use anyhow::bail;
use clap::{Args, CommandFactory, FromArgMatches, Parser, Subcommand, ValueEnum};
use rain_composite::config::RenderConfig;
use rain_composite::gpu::AdapterRequest;
use rain_composite::lighting::HdrInput;
use rain_composite::pipeline::FrameRange;
use rain_composite::preset;
use rain_composite::video::{AlphaMode, AudioMode, EncodeOptions, Layer, VideoCodec};

use crate::bench::BenchArgs;
use crate::drops::DropsCommand;
use crate::inspect::InspectCommand;

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
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    #[command(flatten)]
    pub render: RenderArgs,
    #[command(flatten)]
    pub log: LogArgs,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render one frame exactly as the full render would, to a PNG.
    #[command(allow_negative_numbers = true)]
    Preview(PreviewArgs),
    /// Describe the streams of a file: colour tags, rotation, frame rate, what would be copied.
    Probe(ProbeArgs),
    /// Print the models behind the rain as JSON (drop sampling, ...).
    #[command(subcommand)]
    Inspect(InspectCommand),
    /// Streak mattes: generate the database of ray-traced oscillating drops.
    #[command(subcommand)]
    Drops(DropsCommand),
    /// Time a full render against a plain ffmpeg transcode of the same clip (needs the ffmpeg CLI).
    #[command(allow_negative_numbers = true)]
    Bench(BenchArgs),
    /// Print the effective configuration as JSON (`--print`), or list the presets (`--list`).
    Config(ConfigArgs),
    /// Print a shell completion script (bash: `source <(rain-composite completions bash)`).
    Completions {
        /// The shell.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print the manual page (roff), generated from these options: `rain-composite man > rain-composite.1`.
    Man,
    /// List the GPU adapters, best first.
    Adapters {
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Args, Debug)]
pub struct LogArgs {
    /// Print only errors.
    #[arg(short, long, global = true)]
    pub quiet: bool,
    /// Print more (repeat for debug output).
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Input video, or - for a stream on stdin (y4m, nut, matroska, mpegts).
    pub input: Option<String>,
    /// Output video (container from the extension), or - for stdout.
    #[arg(short, long)]
    pub output: Option<String>,
    /// Overwrite the output if it exists.
    #[arg(short = 'y', long)]
    pub overwrite: bool,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub encode: EncodeArgs,
    #[command(flatten)]
    pub gpu: GpuArgs,
    /// Progress report on stderr.
    #[arg(long, value_enum, default_value_t = ProgressMode::Auto)]
    pub progress: ProgressMode,
    /// Render only these frames (zero-based): A..B is A up to but not including B, A..=B includes B, A.. runs to the end. Chunks joined with `ffmpeg -f concat` equal the whole render.
    #[arg(long, value_name = "A..B", conflicts_with_all = ["from", "to"])]
    pub frames: Option<String>,
    /// Render only the frames shown at or after this time (seconds, 2.5s, 1500ms, 00:01:02.5).
    #[arg(long, value_name = "TIME")]
    pub from: Option<String>,
    /// Render only the frames shown before this time.
    #[arg(long, value_name = "TIME")]
    pub to: Option<String>,
    /// With --puddles: keep the water in a file after every N-th frame, so chunks start from the latest one at or before their first frame instead of simulating the water from the clip's start; 0 = keep none (kept files are still read).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub checkpoint_every: u64,
    #[command(flatten)]
    pub checkpoints: CheckpointArgs,
}

/// Where the puddles' water is kept between chunks.
#[derive(Args, Debug, Clone)]
pub struct CheckpointArgs {
    /// Folder of the puddles' water checkpoints, beside the output (a render) or the input (a preview) [default: STEM.water].
    #[arg(long, value_name = "DIR")]
    pub checkpoints: Option<std::path::PathBuf>,
}

impl CheckpointArgs {
    /// The folder: as given, or `<stem of input>.water` in `beside`'s folder.
    pub fn dir(&self, input: &str, beside: &str) -> std::path::PathBuf {
        use std::path::Path;
        if let Some(d) = &self.checkpoints {
            return d.clone();
        }
        let stem = Path::new(input)
            .file_stem()
            .map_or_else(|| "stdin".into(), |s| s.to_string_lossy().into_owned());
        let folder = match Path::new(beside).parent() {
            Some(p) if beside != "-" && !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => std::path::PathBuf::from("."),
        };
        folder.join(format!("{stem}.water"))
    }
}

/// The rain and camera: every value is optional, so that only the flags given override the
/// `--config` file; the help's `[default: …]` comes from `RenderConfig::default` (see
/// [`parse`]).
#[derive(Args, Debug, Clone)]
pub struct LookArgs {
    /// A preset by name (`rain-composite config --list`) or a JSON file of settings; --set and flags given here override it.
    #[arg(long, value_name = "NAME|FILE")]
    pub config: Option<String>,
    /// Override one setting of the configuration, e.g. rain.rate_mm_per_h=25 or rain.wind_mps=[3,0] (repeatable; keys as `config --print` shows them); flags given here override it.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Rain rate in mm/h, or drizzle (0.3) | light (1) | moderate (5) | heavy (20) | violent (75); 0 turns rain off.
    #[arg(long, value_name = "MM_PER_H")]
    pub rain: Option<String>,
    /// Multiplier on drop diameters.
    #[arg(long)]
    pub drop_scale: Option<f64>,
    /// Multiplier on fall speeds.
    #[arg(long)]
    pub fall_speed_scale: Option<f64>,
    /// Mean wind in m/s as X,Y: X to the right of the picture, Y away from the camera.
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
    pub wind: Option<String>,
    /// Multiplier on the streaks' physical coverage.
    #[arg(long)]
    pub opacity: Option<f64>,
    /// Random seed: the same seed gives the same rain.
    #[arg(long)]
    pub seed: Option<u32>,
    /// How streaks are drawn: simple (a smooth capsule) or mattes (the same coverage, the light spread along it by an oscillating drop's matte from --streak-db).
    #[arg(long, value_name = "STYLE", value_parser = ["simple", "mattes"])]
    pub streaks: Option<String>,
    /// The streak database for --streaks mattes: a folder made by `drops generate` (index.json) or a copy of Garg & Nayar's database; default: the drops/ shipped with the program.
    #[arg(long, value_name = "PATH")]
    pub streak_db: Option<String>,
    /// Horizontal field of view of the picture, degrees.
    #[arg(long)]
    pub fov: Option<f64>,
    /// Camera height above the ground, metres.
    #[arg(long)]
    pub camera_height: Option<f64>,
    /// Camera pitch, degrees up (negative: down).
    #[arg(long, allow_hyphen_values = true)]
    pub tilt: Option<f64>,
    /// Camera roll, degrees clockwise.
    #[arg(long, allow_hyphen_values = true)]
    pub roll: Option<f64>,
    /// Shutter angle, degrees (exposure = angle/360 of a frame).
    #[arg(long)]
    pub shutter: Option<f64>,
    /// Nearest drop distance, metres.
    #[arg(long)]
    pub near: Option<f64>,
    /// Farthest drop distance, metres; drops are drawn only as far as they are visible.
    #[arg(long)]
    pub far: Option<f64>,
    /// Most drops drawn per frame (beyond it the far distance shrinks, then drops are weighted).
    #[arg(long)]
    pub max_drops: Option<u32>,
    /// RMS of the wind gusts along the mean wind, m/s.
    #[arg(long)]
    pub gust: Option<f64>,
    /// Altitude of the scene, metres (thinner air, faster drops).
    #[arg(long, allow_hyphen_values = true)]
    pub altitude: Option<f64>,
    /// Focus distance, metres.
    #[arg(long)]
    pub focus: Option<f64>,
    /// Aperture f-number; 0 for a pinhole (no defocus).
    #[arg(long)]
    pub f_number: Option<f64>,
    /// Sensor width, mm (36 = full-frame equivalent).
    #[arg(long)]
    pub sensor_width: Option<f64>,
    /// Time constant of the lighting's smoothing over frames, seconds; 0 = off.
    #[arg(long)]
    pub light_smoothing: Option<f64>,
    /// Clipped highlights become this factor times the clip level, instead of the recovery's
    /// estimate (compact ones still become light sources).
    #[arg(long)]
    pub highlight_gain: Option<f64>,
    /// Whether the input is scene-referred: on trusts values above 1.0 and recovers nothing
    /// (ignores --highlight-gain); auto does so for PQ- and HLG-tagged streams; off recovers
    /// clipped light even there. Alone: on
    #[arg(long, value_enum, num_args = 0..=1, require_equals = true, default_missing_value = "on", value_name = "MODE")]
    pub hdr_input: Option<HdrInputArg>,
    /// Distance of the filmed scene, metres: rain beyond the drawn drops veils it; 0 = no haze.
    #[arg(long)]
    pub scene_depth: Option<f64>,
    /// The ground the rain lands on: none, auto (estimated from the clip's first shot; no ground, with a warning, when unsure), horizon=ROW[,roll=DEG] (ROW: where the horizon crosses the picture's vertical centre line, a fraction of the height from the top) or plane=nx,ny,nz,d (the plane n·X + d = 0 in the camera frame: x right, y down, z forward, metres; level ground 1.6 m below is plane=0,-1,0,1.6); it sets the camera's tilt and roll, and streaks end where drops land.
    #[arg(long, value_name = "MODE", allow_hyphen_values = true)]
    pub ground: Option<String>,
    /// Minutes it has rained (at --rain) before the clip starts: how wet a given ground already is (0: dry at the start, wetting during the clip).
    #[arg(long, value_name = "MIN")]
    pub pre_rain: Option<f64>,
    /// The scene's depth, drops behind it hidden: a 16-bit greyscale PNG in millimetres (camera z) for the whole clip, a directory of them (one per frame, in name order) or a 16-bit greyscale video; resampled to the picture; 0 = unknown.
    #[arg(long, value_name = "PATH")]
    pub depth: Option<std::path::PathBuf>,
    /// Factor on the depth file's values (1: millimetres; the right factor makes a relative depth map millimetres).
    #[arg(long)]
    pub depth_scale: Option<f64>,
    /// Standard deviation of the seeded fractal micro-relief the puddle simulation lays over the ground, metres (0: none); the ground's image is not displaced.
    #[arg(long, value_name = "M")]
    pub relief: Option<f64>,
    /// Seed of the micro-relief: the same seed gives the same puddles.
    #[arg(long, value_name = "N")]
    pub relief_seed: Option<u32>,
    /// Puddles on a given ground: the water already fallen (--pre-rain) and the clip's rain, simulated (SPH) and shaded in with ripples and reflections; about a second a frame on two cores.
    #[arg(long)]
    pub puddles: bool,
    /// Most SPH particles the puddles hold: finer water, more cost.
    #[arg(long, value_name = "N")]
    pub puddle_particles: Option<u32>,
    /// A light the frame does not show (repeatable): degrees right and up of the view direction, linear radiance relative to the frame's white (a street lamp at night: 10³–10⁵), and optionally its distance in metres (irradiance then falls with the square of each drop's distance to it). Disc of 3° unless a config sets `angular_diameter_deg`.
    #[arg(
        long = "light",
        value_name = "AZ,EL,R,G,B[,DISTANCE_M]",
        allow_hyphen_values = true
    )]
    pub lights: Vec<String>,
}

#[derive(Args, Debug, Clone)]
pub struct EncodeArgs {
    /// Video codec; a layer with alpha or a matte takes its container's [default: h264].
    #[arg(long, value_enum)]
    pub codec: Option<CodecArg>,
    /// Constant rate factor (H.264/HEVC; lower is better).
    #[arg(long, default_value_t = EncodeOptions::default().crf, value_parser = clap::value_parser!(u8).range(0..=51))]
    pub crf: u8,
    /// Encoder preset (H.264/HEVC).
    #[arg(long, default_value_t = EncodeOptions::default().preset)]
    pub preset: String,
    /// More H.264/HEVC encoder options, KEY=VALUE joined by ':' (as ffmpeg's -x264-params/-x265-params), applied over --preset and --crf; the default keeps faint streaks through the encoding; none: the encoder's own defaults.
    #[arg(long, default_value_t = EncodeOptions::default().encoder_params, value_name = "KEY=VALUE[:…]")]
    pub encoder_params: String,
    /// Container for stdout (or to override the extension).
    #[arg(long, value_enum)]
    pub format: Option<FormatArg>,
    /// What to do with audio and other streams.
    #[arg(long, value_enum, default_value_t = AudioArg::from(EncodeOptions::default().audio))]
    pub audio: AudioArg,
    /// Write the rain alone: `alpha` (the default) with its alpha to .mov (ProRes 4444), .mkv (FFV1) or a 16-bit PNG sequence (out_%05d.png); `black` over black, an ordinary video for a screen blend.
    #[arg(long, value_enum, num_args = 0..=1, require_equals = true, default_missing_value = "alpha", value_name = "MODE")]
    pub layer_only: Option<LayerArg>,
    /// Colour of the layer relative to its alpha [default: premultiplied].
    #[arg(long, value_enum, requires = "layer_only")]
    pub alpha: Option<AlphaArg>,
    /// Write the rain's coverage alone, as grey (to the outputs of --layer-only).
    #[arg(long, conflicts_with = "layer_only")]
    pub matte: bool,
}

/// `--hdr-input[=MODE]`.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum HdrInputArg {
    /// HDR when the stream is tagged PQ or HLG.
    Auto,
    /// Always HDR.
    On,
    /// Never HDR: recover clipped light.
    Off,
}

impl From<HdrInputArg> for HdrInput {
    fn from(a: HdrInputArg) -> HdrInput {
        match a {
            HdrInputArg::Auto => HdrInput::Auto,
            HdrInputArg::On => HdrInput::On,
            HdrInputArg::Off => HdrInput::Off,
        }
    }
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum LayerArg {
    /// The rain with its alpha.
    Alpha,
    /// The rain over black.
    Black,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum AlphaArg {
    /// Colour multiplied by alpha in linear light.
    Premultiplied,
    /// Colour divided by alpha.
    Straight,
}

#[derive(Args, Debug, Clone)]
pub struct GpuArgs {
    /// Use the adapter whose name contains NAME (see `rain-composite adapters`).
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
    /// Use a CPU (software) adapter only.
    #[arg(long)]
    pub cpu: bool,
}

#[derive(Args, Debug)]
pub struct PreviewArgs {
    /// Input video.
    pub input: String,
    /// Time of the frame: seconds, or with a unit (2.5s, 1500ms, 00:01:02.5).
    #[arg(long, conflicts_with = "frame", required_unless_present = "frame")]
    pub at: Option<String>,
    /// Zero-based frame index.
    #[arg(long)]
    pub frame: Option<u64>,
    /// Output PNG, or - for stdout.
    #[arg(short, long)]
    pub output: String,
    /// Overwrite the output if it exists.
    #[arg(short = 'y', long)]
    pub overwrite: bool,
    /// Bits per PNG channel.
    #[arg(long, value_enum, default_value_t = Bits::Eight)]
    pub bits: Bits,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub gpu: GpuArgs,
    #[command(flatten)]
    pub checkpoints: CheckpointArgs,
}

#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct ConfigArgs {
    /// Print the configuration the same --config, --set and flags give a render, as JSON that --config FILE reads back.
    #[arg(long, conflicts_with = "list", required_unless_present = "list")]
    pub print: bool,
    /// List the presets, one line each.
    #[arg(long)]
    pub list: bool,
    #[command(flatten)]
    pub look: LookArgs,
}

#[derive(Args, Debug)]
pub struct ProbeArgs {
    /// Input video.
    pub input: String,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Container the output would be written to (decides what can be copied).
    #[arg(long, value_name = "EXT")]
    pub for_output: Option<String>,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum ProgressMode {
    /// A bar when stderr is a terminal, nothing otherwise.
    Auto,
    /// One JSON object per line on stderr.
    Json,
    /// Nothing.
    None,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum Bits {
    /// 8 bits per channel.
    #[value(name = "8")]
    Eight,
    /// 16 bits per channel.
    #[value(name = "16")]
    Sixteen,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum CodecArg {
    /// H.264 (libx264).
    H264,
    /// HEVC (libx265).
    Hevc,
    /// Apple ProRes 422 HQ (prores_ks), 10-bit.
    Prores,
    /// FFV1, lossless.
    Ffv1,
}

impl From<CodecArg> for VideoCodec {
    fn from(c: CodecArg) -> VideoCodec {
        match c {
            CodecArg::H264 => VideoCodec::H264,
            CodecArg::Hevc => VideoCodec::Hevc,
            CodecArg::Prores => VideoCodec::ProRes,
            CodecArg::Ffv1 => VideoCodec::Ffv1,
        }
    }
}

impl From<VideoCodec> for CodecArg {
    fn from(c: VideoCodec) -> CodecArg {
        match c {
            VideoCodec::H264 => CodecArg::H264,
            VideoCodec::Hevc => CodecArg::Hevc,
            VideoCodec::ProRes => CodecArg::Prores,
            VideoCodec::Ffv1 => CodecArg::Ffv1,
        }
    }
}

#[derive(ValueEnum, Debug, Clone, Copy)]
pub enum FormatArg {
    /// YUV4MPEG2 (raw, constant frame rate).
    Y4m,
    /// NUT.
    Nut,
    /// Matroska.
    Matroska,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum AudioArg {
    /// Copy audio and other streams bit for bit (AAC where the container cannot hold them).
    Copy,
    /// Video only.
    None,
}

impl From<AudioArg> for AudioMode {
    fn from(a: AudioArg) -> AudioMode {
        match a {
            AudioArg::Copy => AudioMode::Copy,
            AudioArg::None => AudioMode::None,
        }
    }
}

impl From<AudioMode> for AudioArg {
    fn from(a: AudioMode) -> AudioArg {
        match a {
            AudioMode::Copy => AudioArg::Copy,
            AudioMode::None => AudioArg::None,
        }
    }
}

/// Parses the command line (exiting with clap's message on an error), with each rain and
/// camera flag's help ending in its default from [`RenderConfig::flag_values`].
pub fn parse() -> Cli {
    let matches = command().get_matches();
    Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
}

/// The command line's definition as the help, the completions and the manual page show it.
pub fn command() -> clap::Command {
    with_look_defaults(Cli::command(), &RenderConfig::default().flag_values())
}

/// Appends `[default: …]` to the help of each [`LookArgs`] flag in `command` and its
/// subcommands. A command flattens [`LookArgs`] exactly when it has `--config`; flags there
/// that carry a clap default of their own (none today) are left alone.
fn with_look_defaults(mut command: clap::Command, defaults: &[(&str, String)]) -> clap::Command {
    if command
        .get_arguments()
        .any(|a| a.get_long() == Some("config"))
    {
        for (flag, value) in defaults {
            let long = flag.trim_start_matches("--");
            let id = command
                .get_arguments()
                .find(|a| a.get_long() == Some(long) && a.get_default_values().is_empty())
                .map(|a| a.get_id().clone());
            if let Some(id) = id {
                command = command.mut_arg(id, |a| {
                    // clap drops the final period of a one-line doc comment; the default
                    // follows the sentence.
                    let help = a.get_help().map(|h| h.to_string()).unwrap_or_default();
                    a.help(format!("{help}. [default: {value}]"))
                });
            }
        }
    }
    let names: Vec<String> = command
        .get_subcommands()
        .map(|s| s.get_name().to_string())
        .collect();
    for name in names {
        command = command.mut_subcommand(name, |s| with_look_defaults(s, defaults));
    }
    command
}

fn parse_rain(s: &str) -> anyhow::Result<f64> {
    Ok(rain_composite::rain::physics::RainRate::parse(s)?.mm_per_h())
}

/// A time of the stream: seconds, `2.5s`, `1500ms` or `00:01:02.5`.
pub fn parse_time_s(s: &str) -> anyhow::Result<f64> {
    let bad = || {
        anyhow::anyhow!("invalid time '{s}': expected seconds (2.5, 2.5s, 1500ms or 00:01:02.5)")
    };
    let t = if let Some(ms) = s.strip_suffix("ms") {
        ms.trim().parse::<f64>().map_err(|_| bad())? / 1000.0
    } else if s.contains(':') {
        // [[HH:]MM:]SS: at most three fields, minutes and seconds below 60 after the first.
        let parts: Vec<&str> = s.split(':').collect();
        if parts.len() > 3 {
            return Err(bad());
        }
        let values = parts
            .iter()
            .map(|p| p.trim().parse::<f64>())
            .collect::<Result<Vec<f64>, _>>()
            .map_err(|_| bad())?;
        if values[1..].iter().any(|v| !(0.0..60.0).contains(v)) {
            return Err(bad());
        }
        values.iter().fold(0.0, |acc, v| acc * 60.0 + v)
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

/// The render settings, lowest precedence first: the defaults, the `--config` preset or file,
/// each `--set`, then each flag given.
pub fn render_config(look: &LookArgs) -> anyhow::Result<RenderConfig> {
    let base = match &look.config {
        Some(arg) => preset::load(arg)?,
        None => RenderConfig::default(),
    };
    let build = |sets: &[String]| -> anyhow::Result<RenderConfig> {
        let mut c = preset::with_overrides(&base, sets)?;
        apply_flags(look, &mut c)?;
        Ok(c)
    };
    let c = build(&look.sets)?;
    preset::validate_layered(&c, &look.sets, |skip| {
        let mut kept = look.sets.clone();
        kept.remove(skip);
        build(&kept).ok()
    })?;
    Ok(c)
}

/// Sets each value of `c` that a flag gives.
fn apply_flags(look: &LookArgs, c: &mut RenderConfig) -> anyhow::Result<()> {
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
    if let Some(d) = &look.depth {
        c.ground.depth = Some(d.clone());
    }
    if let Some(k) = look.depth_scale {
        c.ground.depth_scale = k;
    }
    if let Some(g) = &look.ground {
        c.ground.mode = g.parse()?;
        if c.ground.is_given() {
            for (flag, given) in [
                ("--tilt", look.tilt.is_some()),
                ("--roll", look.roll.is_some()),
                (
                    "--camera-height",
                    look.camera_height.is_some()
                        && matches!(
                            c.ground.mode,
                            rain_composite::scene::GroundMode::Plane { .. }
                        ),
                ),
            ] {
                if given {
                    bail!(
                        "--ground {g} and {flag} both set the camera's pose: give one of them \
                         (the ground's horizon fixes the tilt and roll, a plane also the height)"
                    );
                }
            }
        }
    }
    // A flag's constant replaces the keys of its setting.
    let k = &mut c.keyframes;
    if look.rain.is_some() {
        k.rate_mm_per_h = None;
    }
    if look.wind.is_some() {
        k.wind_mps = None;
    }
    if look.opacity.is_some() {
        k.opacity = None;
    }
    if look.focus.is_some() {
        k.focus_m = None;
    }
    if look.f_number.is_some() {
        k.f_number = None;
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
    if let Some(style) = &look.streaks {
        r.streaks = match style.as_str() {
            "mattes" => rain_composite::config::StreakStyle::Mattes,
            _ => rain_composite::config::StreakStyle::Simple,
        };
    }
    set!(look.light_smoothing => c.light.smoothing_s);
    if look.highlight_gain.is_some() {
        c.light.highlight_gain = look.highlight_gain;
    }
    if let Some(mode) = look.hdr_input {
        c.light.hdr_input = mode.into();
    }
    set!(look.altitude => r.altitude_m);
    set!(look.scene_depth => r.scene_depth_m);
    set!(look.pre_rain => c.ground.pre_rain_min);
    set!(look.relief => c.ground.relief_m);
    set!(look.relief_seed => c.ground.relief_seed);
    set!(look.puddle_particles => c.ground.puddle_particles);
    if look.puddles {
        c.ground.puddles = true;
    }
    set!(look.focus => cam.focus_m);
    set!(look.f_number => cam.f_number);
    set!(look.sensor_width => cam.sensor_width_mm);
    set!(look.fov => cam.fov_deg);
    set!(look.camera_height => cam.height_m);
    set!(look.tilt => cam.tilt_deg);
    set!(look.roll => cam.roll_deg);
    set!(look.shutter => cam.shutter_deg);
    if look.streak_db.is_some() {
        c.streak_db = look.streak_db.clone();
    }
    Ok(())
}

/// The frames `--frames` or `--from`/`--to` ask for.
pub fn frame_range(r: &RenderArgs) -> anyhow::Result<FrameRange> {
    if let Some(text) = &r.frames {
        let bad = || {
            anyhow::anyhow!(
                "invalid --frames '{text}': expected A..B (B excluded), A..=B (B included) or A.."
            )
        };
        let (a, b) = text.split_once("..").ok_or_else(bad)?;
        let start: u64 = a.trim().parse().map_err(|_| bad())?;
        let end = match b.strip_prefix('=') {
            Some(b) => Some(
                b.trim()
                    .parse::<u64>()
                    .ok()
                    .and_then(|b| b.checked_add(1))
                    .ok_or_else(bad)?,
            ),
            None if b.trim().is_empty() => None,
            None => Some(b.trim().parse().map_err(|_| bad())?),
        };
        return Ok(FrameRange::Indices { start, end });
    }
    if r.from.is_none() && r.to.is_none() {
        return Ok(FrameRange::All);
    }
    Ok(FrameRange::Times {
        from_s: r
            .from
            .as_deref()
            .map(parse_time_s)
            .transpose()?
            .unwrap_or(0.0),
        to_s: r.to.as_deref().map(parse_time_s).transpose()?,
    })
}

/// Which GPU adapter the flags ask for.
pub fn adapter(g: &GpuArgs) -> AdapterRequest {
    AdapterRequest {
        name: g.adapter.clone(),
        cpu_only: g.cpu,
    }
}

/// The encoder settings the flags ask for. Flags the output would silently ignore are refused:
/// H.264 for a layer with alpha or a matte (its container fixes the codec), `--alpha` for a
/// layer over black (it has no alpha).
pub fn encode_options(e: &EncodeArgs, overwrite: bool) -> anyhow::Result<EncodeOptions> {
    let rgba_layer = e.matte || e.layer_only == Some(LayerArg::Alpha);
    if rgba_layer && e.codec == Some(CodecArg::H264) {
        bail!(
            "--codec h264 cannot hold {}: leave --codec out (FFV1 in .mkv, ProRes 4444 in \
             .mov, 16-bit PNG in a sequence)",
            if e.matte {
                "the matte"
            } else {
                "a layer with alpha"
            }
        );
    }
    if e.alpha.is_some() && e.layer_only == Some(LayerArg::Black) {
        bail!("--alpha applies to --layer-only=alpha: a layer over black has no alpha");
    }
    Ok(EncodeOptions {
        codec: e
            .codec
            .map_or(EncodeOptions::default().codec, VideoCodec::from),
        crf: e.crf,
        preset: e.preset.clone(),
        encoder_params: match e.encoder_params.as_str() {
            "none" => String::new(),
            p => p.to_owned(),
        },
        container: e.format.map(|f| {
            match f {
                FormatArg::Y4m => "yuv4mpegpipe",
                FormatArg::Nut => "nut",
                FormatArg::Matroska => "matroska",
            }
            .to_string()
        }),
        audio: e.audio.into(),
        overwrite,
        layer: match (e.layer_only, e.matte) {
            (_, true) => Some(Layer::Matte),
            (Some(LayerArg::Black), _) => Some(Layer::OverBlack),
            (Some(LayerArg::Alpha), _) => Some(Layer::Alpha(match e.alpha {
                Some(AlphaArg::Straight) => AlphaMode::Straight,
                Some(AlphaArg::Premultiplied) | None => AlphaMode::Premultiplied,
            })),
            (None, false) => None,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parsed(args: &[&str]) -> Cli {
        let command = with_look_defaults(Cli::command(), &RenderConfig::default().flag_values());
        let m = command
            .try_get_matches_from(args)
            .unwrap_or_else(|e| panic!("{args:?}: {e}"));
        Cli::from_arg_matches(&m).expect("matches")
    }

    /// Every flag of `flag_values` sets the field it names: a configuration unlike the
    /// default in every value, given back as flags, is read back unchanged.
    #[test]
    fn each_flag_sets_the_value_it_names() {
        let mut c = RenderConfig::default();
        let (cam, r) = (&mut c.camera, &mut c.rain);
        (cam.fov_deg, cam.height_m, cam.tilt_deg, cam.roll_deg) = (47.5, 2.25, -7.5, 3.5);
        (cam.shutter_deg, cam.focus_m, cam.f_number) = (90.0, 3.5, 2.8);
        cam.sensor_width_mm = 23.5;
        (r.rate_mm_per_h, r.drop_scale, r.fall_speed_scale) = (7.5, 1.25, 0.75);
        (r.wind_mps, r.gust_mps, r.altitude_m) = ([2.5, -1.5], 1.5, 350.0);
        (r.opacity, r.seed, r.near_m, r.far_m) = (0.5, 17, 0.45, 120.0);
        (r.scene_depth_m, r.max_drops) = (80.0, 12_345);
        r.streaks = rain_composite::config::StreakStyle::Mattes;
        (c.light.smoothing_s, c.light.highlight_gain) = (0.5, Some(4.0));
        c.light.hdr_input = HdrInput::Off;
        c.ground.pre_rain_min = 25.0;
        (c.ground.depth, c.ground.depth_scale) = (Some("depth.png".into()), 0.25);
        (c.ground.relief_m, c.ground.relief_seed) = (0.01, 7);
        c.ground.puddle_particles = 12_000;
        let values = c.flag_values();
        let defaults = RenderConfig::default().flag_values();
        for (flag, d) in &defaults {
            if *flag == "--ground" {
                // Sets the tilt and roll itself: checked below.
                continue;
            }
            let v = values.iter().find(|(f, _)| f == flag).map(|(_, v)| v);
            assert_ne!(
                v,
                Some(d),
                "{flag} keeps its default in the test configuration"
            );
        }
        assert!(values.iter().any(|(f, _)| *f == "--highlight-gain"));
        assert!(values.iter().any(|(f, _)| *f == "--depth"));
        let mut args = vec!["rain-composite".to_string(), "in.mp4".into()];
        for (flag, v) in &values {
            args.push(format!("{flag}={v}"));
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let cli = parsed(&args);
        assert_eq!(render_config(&cli.render.look).expect("valid"), c);
        assert_eq!(
            render_config(&parsed(&["rain-composite", "in.mp4"]).render.look).expect("valid"),
            RenderConfig::default()
        );
    }

    /// `--ground` sets the ground mode, and refuses `--tilt` or `--roll` beside a ground that
    /// fixes the pose, naming both flags.
    #[test]
    fn ground_flag_sets_the_mode_and_excludes_tilt_and_roll() {
        let cli = parsed(&["rain-composite", "in.mp4", "--ground", "horizon=0.4,roll=5"]);
        let c = render_config(&cli.render.look).expect("valid");
        assert_eq!(c.ground.mode.to_string(), "horizon=0.4,roll=5");
        for extra in ["--tilt=-3", "--roll=2", "--camera-height=2"] {
            let cli = parsed(&[
                "rain-composite",
                "in.mp4",
                "--ground=plane=0,-1,0,1.6",
                extra,
            ]);
            let e = render_config(&cli.render.look)
                .expect_err(extra)
                .to_string();
            let flag = extra.split('=').next().expect("flag");
            assert!(e.contains("--ground") && e.contains(flag), "{e}");
        }
        // A horizon leaves the height to --camera-height.
        let cli = parsed(&[
            "rain-composite",
            "in.mp4",
            "--ground=horizon=0.4",
            "--camera-height=2",
        ]);
        assert_eq!(
            render_config(&cli.render.look)
                .expect("valid")
                .camera
                .height_m,
            2.0
        );
        // `none` leaves the pose to --tilt and --roll.
        let cli = parsed(&["rain-composite", "in.mp4", "--ground", "none", "--tilt=-3"]);
        assert_eq!(
            render_config(&cli.render.look)
                .expect("valid")
                .camera
                .tilt_deg,
            -3.0
        );
        // `auto` estimates the pose: not with --tilt.
        let cli = parsed(&["rain-composite", "in.mp4", "--ground", "auto"]);
        assert!(render_config(&cli.render.look).is_ok());
        let cli = parsed(&["rain-composite", "in.mp4", "--ground", "auto", "--tilt=4"]);
        let e = render_config(&cli.render.look)
            .expect_err("auto with tilt")
            .to_string();
        assert!(e.contains("--ground") && e.contains("--tilt"), "{e}");
    }

    /// `--frames` reads half-open, inclusive and open-ended ranges; `--from`/`--to` times.
    #[test]
    fn frame_ranges_parse() {
        let range = |args: &[&str]| {
            let mut all = vec!["rain-composite", "in.mp4"];
            all.extend_from_slice(args);
            frame_range(&parsed(&all).render)
        };
        let idx = |start, end| FrameRange::Indices { start, end };
        assert_eq!(range(&["--frames", "3..8"]).ok(), Some(idx(3, Some(8))));
        assert_eq!(range(&["--frames", "3..=8"]).ok(), Some(idx(3, Some(9))));
        assert_eq!(range(&["--frames", "3.."]).ok(), Some(idx(3, None)));
        assert_eq!(range(&[]).ok(), Some(FrameRange::All));
        assert_eq!(
            range(&["--from", "1.5s", "--to", "00:00:04"]).ok(),
            Some(FrameRange::Times {
                from_s: 1.5,
                to_s: Some(4.0)
            })
        );
        for bad in ["3", "a..b", "..4", "3..=x"] {
            let e = range(&["--frames", bad]).expect_err(bad).to_string();
            assert!(e.contains("--frames") && e.contains(bad), "{e}");
        }
    }

    /// The encoder flags' defaults are the library's.
    #[test]
    fn encode_defaults_are_the_library_defaults() {
        let cli = parsed(&["rain-composite", "in.mp4"]);
        assert_eq!(
            encode_options(&cli.render.encode, false).expect("valid"),
            EncodeOptions::default()
        );
    }
}
