//! The one table of the command line's names for the library's settings: each setting's key
//! (as `config --print` shows it and `--set` takes it) ↔ the flag that sets it ↔ the name of
//! the flag's value in the help.
//!
//! The library names settings by key only; the binary turns the keys of its messages into
//! these flags (`messages`) and shows the library's defaults in the help of these flags
//! (`args::help`). Besides the keys of [`RenderConfig`](rain_composite::config::RenderConfig),
//! the table holds the keys the library gives to values that are no setting of it, under the
//! prefixes of [`NON_CONFIG`].
//!
//! This file is plain data and string functions, with no path into either crate: the library
//! reads it too, for `RenderConfig::flag_values`.

/// One setting and its flag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Flag {
    /// The setting's key (`rain.rate_mm_per_h`); an element of a list is keyed without its
    /// index (`light.lights.azimuth_deg`: the azimuth of any light).
    pub key: &'static str,
    /// What the command line calls it: a long flag (`--rain`), the flags that set it together
    /// joined by `/` (`--frames/--from/--to`), or a flag and the part of its value
    /// (`--light azimuth`).
    pub flag: &'static str,
    /// The flag's value as the help names it (`MM_PER_H`; of the first of flags joined by `/`),
    /// or the part of it for a part of a value; empty for a switch.
    pub value: &'static str,
}

const fn row(key: &'static str, flag: &'static str, value: &'static str) -> Flag {
    Flag { key, flag, value }
}

/// The key prefixes of values that are no setting of the render configuration, and what they
/// hold (the table's test reads them).
#[cfg_attr(not(test), allow(dead_code))]
pub const NON_CONFIG: &[(&str, &str)] = &[
    ("encode.", "the encoder's options (`EncodeOptions`)"),
    (
        "job.",
        "what a run reads and writes: output, frames, the time of a frame",
    ),
    ("probe.", "the arguments of `probe`"),
    ("inspect.", "the arguments of the `inspect` reports"),
    (
        "drops.",
        "the arguments of `drops generate` (`DatabaseSpec`)",
    ),
];

/// Every setting the command line sets by a flag, and the keys of other values the library's
/// messages name.
pub const FLAGS: &[Flag] = &[
    // The rain.
    row("rain.rate_mm_per_h", "--rain", "MM_PER_H"),
    row("rain.drop_scale", "--drop-scale", "DROP_SCALE"),
    row(
        "rain.fall_speed_scale",
        "--fall-speed-scale",
        "FALL_SPEED_SCALE",
    ),
    row("rain.wind_mps", "--wind", "X,Y"),
    row("rain.gust_mps", "--gust", "GUST"),
    row("rain.altitude_m", "--altitude", "ALTITUDE"),
    row("rain.opacity", "--opacity", "OPACITY"),
    row("rain.seed", "--seed", "SEED"),
    row("rain.near_m", "--near", "NEAR"),
    row("rain.far_m", "--far", "FAR"),
    row("rain.scene_depth_m", "--scene-depth", "SCENE_DEPTH"),
    row("rain.max_drops", "--max-drops", "MAX_DROPS"),
    row("rain.streaks", "--streaks", "STYLE"),
    row("streak_db", "--streak-db", "PATH"),
    row("gpu_raster", "--gpu-raster", "HOW"),
    // The camera.
    row("camera.fov_deg", "--fov", "FOV"),
    row("camera.height_m", "--camera-height", "CAMERA_HEIGHT"),
    row("camera.tilt_deg", "--tilt", "TILT"),
    row("camera.roll_deg", "--roll", "ROLL"),
    row("camera.shutter_deg", "--shutter", "SHUTTER"),
    row("camera.focus_m", "--focus", "FOCUS"),
    row("camera.f_number", "--f-number", "F_NUMBER"),
    row("camera.sensor_width_mm", "--sensor-width", "SENSOR_WIDTH"),
    // The light.
    row("light.smoothing_s", "--light-smoothing", "LIGHT_SMOOTHING"),
    row("light.highlight_gain", "--highlight-gain", "HIGHLIGHT_GAIN"),
    row("light.hdr_input", "--hdr-input", "MODE"),
    row("light.lights", "--light", "AZ,EL,R,G,B[,DISTANCE_M]"),
    row("light.lights.azimuth_deg", "--light azimuth", "AZ"),
    row("light.lights.elevation_deg", "--light elevation", "EL"),
    row("light.lights.radiance_rgb", "--light radiance", "R,G,B"),
    row("light.lights.distance_m", "--light distance", "DISTANCE_M"),
    // The ground.
    row("ground.mode", "--ground", "MODE"),
    row("ground.pre_rain_min", "--pre-rain", "MIN"),
    row("ground.depth", "--depth", "PATH"),
    row("ground.depth_scale", "--depth-scale", "DEPTH_SCALE"),
    row("ground.sky", "--sky", "MODE"),
    row("ground.mask", "--ground-mask", "MODE"),
    row("ground.relief_m", "--relief", "M"),
    row("ground.relief_seed", "--relief-seed", "N"),
    row("ground.puddles", "--puddles", ""),
    row("ground.puddle_particles", "--puddle-particles", "N"),
    // The camera's motion.
    row("camera_motion", "--camera-motion", "MODE"),
    // The encoder.
    row("encode.codec", "--codec", "CODEC"),
    row("encode.crf", "--crf", "CRF"),
    row("encode.preset", "--preset", "PRESET"),
    row("encode.encoder_params", "--encoder-params", "KEY=VALUE[:…]"),
    row("encode.container", "--format", "FORMAT"),
    row("encode.audio", "--audio", "AUDIO"),
    row("encode.layer", "--layer-only", "MODE"),
    row("encode.alpha", "--alpha", "ALPHA"),
    row("encode.matte", "--matte", ""),
    // The job.
    row("job.output", "--output", "OUTPUT"),
    row("job.frames", "--frames/--from/--to", "A..B"),
    row("job.at", "--at", "AT"),
    row("probe.for_output", "--for-output", "EXT"),
    // The reports.
    row("inspect.rtf.n_max", "--nmax", "NMAX"),
    row("inspect.rtf.bins", "--bins", "BINS"),
    row("inspect.bands", "--bands", "BANDS"),
    row("inspect.light.grid", "--grid", "GRID"),
    row("inspect.sph.scene", "--scene", "SCENE"),
    row("inspect.sph.steps", "--steps", "STEPS"),
    row("inspect.drops.fps", "--fps", "FPS"),
    // The streak database.
    row("drops.sizes_mm", "--sizes", "MM"),
    row("drops.exposures_s", "--exposures", "S"),
    row("drops.view_elevations_deg", "--views", "DEG"),
    row("drops.phases", "--phases", "PHASES"),
    row(
        "drops.pixels_per_diameter",
        "--pixels-per-diameter",
        "PIXELS_PER_DIAMETER",
    ),
    row("drops.samples", "--samples", "SAMPLES"),
    row(
        "drops.streaks",
        "--sizes/--exposures/--views/--phases",
        "MM",
    ),
];

/// What the command line calls the setting `key`, if it has a flag.
pub fn flag_of(key: &str) -> Option<&'static str> {
    FLAGS.iter().find(|f| f.key == key).map(|f| f.flag)
}

/// The one long flag that sets `key` (`--rain`), if it has one: not a part of a flag's value,
/// nor flags that set it together.
pub fn option_of(key: &str) -> Option<&'static str> {
    flag_of(key).filter(|f| !f.contains([' ', '/']))
}

/// `name` as the command line says it: the flag of a key, or the name as it is (a key without
/// a flag).
pub fn for_user(name: &str) -> &str {
    flag_of(name).unwrap_or(name)
}

/// `text` with each key of the table in it replaced by its flag. A key counts only whole: not
/// inside a longer key (`light.lights` in `light.lights.distance_m`) or another word.
pub fn in_prose(text: &str) -> String {
    let is_word = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    'scan: while let Some(c) = rest.chars().next() {
        let starts_word = !out
            .chars()
            .next_back()
            .is_some_and(|p| is_word(p) || p == '.');
        if starts_word && c.is_ascii_lowercase() {
            // The longest key at this point, ending where a word ends.
            let found = FLAGS
                .iter()
                .filter(|f| rest.starts_with(f.key))
                .filter(|f| {
                    let mut after = rest[f.key.len()..].chars();
                    match after.next() {
                        None => true,
                        Some('.') => !after.next().is_some_and(is_word),
                        Some(n) => !is_word(n),
                    }
                })
                .max_by_key(|f| f.key.len());
            if let Some(f) = found {
                out.push_str(f.flag);
                rest = &rest[f.key.len()..];
                continue 'scan;
            }
        }
        out.push(c);
        rest = &rest[c.len_utf8()..];
    }
    out
}
