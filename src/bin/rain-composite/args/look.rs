//! The rain, camera, light and ground flags, and the render configuration they make over the
//! defaults, the `--config` preset or file and each `--set`.

use anyhow::bail;
use clap::{Args, ValueEnum};
use rain_composite::config::RenderConfig;
use rain_composite::lighting::HdrInput;
use rain_composite::preset;

/// The rain and camera: every value is optional, so that only the flags given override the
/// `--config` file; the help's `[default: …]` comes from `RenderConfig::default` (see
/// [`super::help`]).
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
    /// How the GPU draws the capsule streaks: fragments (a quad per drop through the rasteriser) or compute (tiles drawn by compute shaders, for GPUs whose rasteriser runs on a few of their cores); the same picture. The mattes and the splashes are drawn as quads either way.
    #[arg(long, value_name = "HOW", value_parser = ["fragments", "compute"])]
    pub gpu_raster: Option<String>,
    /// Horizontal field of view of the picture, degrees.
    #[arg(long)]
    pub fov: Option<f64>,
    /// Camera height above the ground, metres.
    #[arg(long)]
    pub camera_height: Option<f64>,
    /// Camera pitch, degrees up (negative: down): looking up moves the horizon down the picture.
    #[arg(long, allow_hyphen_values = true)]
    pub tilt: Option<f64>,
    /// Camera roll, degrees clockwise seen from behind the camera (its right side down): the horizon in the picture rises to the right.
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
    /// The camera's motion: auto (estimated from the whole clip before the render: its pan, tilt, roll and zoom frame by frame, so the rain, and beside a ground the splashes, wet ground and puddles, stay in the world; a still or uncertain shot keeps the camera still, and camera keys keep it as they set it; the whole clip is read once per file, kept in the --checkpoints folder and read back by later previews, chunks and renders), none (the default), or a pose file as `inspect camera --json` writes it.
    #[arg(long, value_name = "MODE")]
    pub camera_motion: Option<String>,
    /// Minutes it has rained (at --rain) before the clip starts: how wet a given ground already is (0: dry at the start, wetting during the clip).
    #[arg(long, value_name = "MIN")]
    pub pre_rain: Option<f64>,
    /// The scene's depth, drops behind it hidden: a 16-bit greyscale PNG in millimetres (camera z) for the whole clip, a directory of them (one per frame, in name order) or a 16-bit greyscale video; resampled to the picture; 0 = unknown.
    #[arg(long, value_name = "PATH")]
    pub depth: Option<std::path::PathBuf>,
    /// Factor on the depth file's values (1: millimetres; the right factor makes a relative depth map millimetres).
    #[arg(long)]
    pub depth_scale: Option<f64>,
    /// The open sky: auto (found in each frame: smooth, sky-coloured regions reaching the picture's top edge, above a given ground's horizon; there the scene is infinitely far and the haze leaves the sky its own radiance) or off (veil every pixel without a depth to the ground or --scene-depth, for footage whose sky is found wrongly).
    #[arg(long, value_enum, value_name = "MODE")]
    pub sky: Option<SkyArg>,
    /// Where the ground is: auto (found in each frame: below the horizon, connected to the picture's bottom edge, without the vertical structure of walls, railings, poles and vehicles' sides, and not water that already mirrors the sky; wetness and puddles keep to it) or off (every pixel below the horizon is ground). A depth map, where given, decides.
    #[arg(long, value_enum, value_name = "MODE")]
    pub ground_mask: Option<GroundMaskArg>,
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

/// `--sky`'s values.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum SkyArg {
    /// Found in each frame.
    Auto,
    /// Not looked for.
    Off,
}

impl From<SkyArg> for rain_composite::scene::sky::SkyMode {
    fn from(a: SkyArg) -> Self {
        match a {
            SkyArg::Auto => Self::Auto,
            SkyArg::Off => Self::Off,
        }
    }
}

/// `--ground-mask`'s values.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum GroundMaskArg {
    /// Found in each frame.
    Auto,
    /// Everything below the horizon.
    Off,
}

impl From<GroundMaskArg> for rain_composite::scene::ground_mask::GroundMaskMode {
    fn from(a: GroundMaskArg) -> Self {
        match a {
            GroundMaskArg::Auto => Self::Auto,
            GroundMaskArg::Off => Self::Off,
        }
    }
}

fn parse_rain(s: &str) -> anyhow::Result<f64> {
    Ok(rain_composite::rain::physics::RainRate::parse(s)?.mm_per_h())
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
    if let Some(s) = look.sky {
        c.ground.sky = s.into();
    }
    if let Some(m) = &look.camera_motion {
        c.camera_motion = m.parse()?;
    }
    if let Some(m) = look.ground_mask {
        c.ground.mask = m.into();
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
    if let Some(raster) = &look.gpu_raster {
        c.gpu_raster = match raster.as_str() {
            "compute" => rain_composite::config::GpuRaster::Compute,
            _ => rain_composite::config::GpuRaster::Fragments,
        };
    }
    if look.streak_db.is_some() {
        c.streak_db = look.streak_db.clone();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::args::help::flag_values;
    use crate::args::parsed;
    use crate::messages;

    /// Every flag of `flag_values` sets the setting its key names: a configuration unlike the
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
        c.camera_motion = rain_composite::scene::motion::MotionSource::File("poses.json".into());
        c.ground.sky = rain_composite::scene::sky::SkyMode::Off;
        c.ground.mask = rain_composite::scene::ground_mask::GroundMaskMode::Off;
        let values = flag_values(&c);
        let defaults = flag_values(&RenderConfig::default());
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
        let refused = |args: &[&str]| {
            let e = render_config(&parsed(args).render.look).expect_err("refused");
            messages::for_user(&e)
        };
        let cli = parsed(&["rain-composite", "in.mp4", "--ground", "horizon=0.4,roll=5"]);
        let c = render_config(&cli.render.look).expect("valid");
        assert_eq!(c.ground.mode.to_string(), "horizon=0.4,roll=5");
        for extra in ["--tilt=-3", "--roll=2", "--camera-height=2"] {
            let e = refused(&[
                "rain-composite",
                "in.mp4",
                "--ground=plane=0,-1,0,1.6",
                extra,
            ]);
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
        // `auto` estimates the pose: not with --tilt. The library's error names the settings'
        // keys, the command line their flags.
        let cli = parsed(&["rain-composite", "in.mp4", "--ground", "auto"]);
        assert!(render_config(&cli.render.look).is_ok());
        let args = ["rain-composite", "in.mp4", "--ground", "auto", "--tilt=4"];
        let e = render_config(&parsed(&args).render.look)
            .expect_err("auto with tilt")
            .to_string();
        assert!(
            e.contains("ground.mode") && e.contains("camera.tilt_deg") && !e.contains("--"),
            "{e}"
        );
        let e = refused(&args);
        assert!(e.contains("--ground") && e.contains("--tilt"), "{e}");
    }

    /// A `--set` out of range, or conflicting with a flag, is named with the flag of the
    /// setting whose range it breaks.
    #[test]
    fn layered_errors_name_the_flags() {
        let refused = |args: &[&str]| {
            let e = render_config(&parsed(args).render.look).expect_err("refused");
            messages::for_user(&e)
        };
        assert_eq!(
            refused(&["rain-composite", "in.mp4", "--set", "camera.fov_deg=200"]),
            "invalid --set camera.fov_deg=200: 200 is out of range: degrees in (1, 170) (the \
             range of --fov)"
        );
        assert_eq!(
            refused(&["rain-composite", "in.mp4", "--near=5", "--far=4"]),
            "invalid parameter --near = 5: metres, ≥ 0.05 and below --far"
        );
        assert_eq!(
            refused(&[
                "rain-composite",
                "in.mp4",
                "--ground",
                "horizon=0.5",
                "--set",
                "camera.tilt_deg=5"
            ]),
            "invalid --set camera.tilt_deg=5: conflicts with --ground horizon=0.5: no --tilt or \
             --roll besides it: --ground auto/horizon=/plane= sets the camera's tilt and roll"
        );
        let e = refused(&["rain-composite", "in.mp4", "--light", "0,95,1,1,1"]);
        assert!(
            e.starts_with("invalid parameter --light elevation = 95"),
            "{e}"
        );
    }
}
