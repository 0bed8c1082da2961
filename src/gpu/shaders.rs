//! The WGSL stages, embedded in the binary, and the assembler that makes each one a complete
//! module. WGSL has no includes: a stage file declares the shared modules it needs in its
//! `// Includes:` header, and [`Stage::source`] prepends them, after the constants the Rust side
//! defines ([`constants`]), so every stage validates alone and no size is written twice.

use super::stages;
use super::types::{GLINTS_PER_DROP, GUSTS, MAX_LIGHTS, SH_COEFFS};
use crate::rain::volume::drop::{
    DRIFT_BITS, DRIFT_PHASE_BITS, FALL_RATE_BITS, INV_HEIGHT_BITS, SPEED_BITS, SPEED_STEPS_LOG2,
    SPEED_TABLE_LEN,
};

/// One GPU stage: one file in `shaders/`, one pipeline label, one Rust twin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Decoded planes → linear canvas.
    YuvToRgb,
    /// Drops → their streaks for the frame (state, projection, light).
    RainSimulate,
    /// Streaks → the canvas.
    RainStreaks,
    /// Canvas → packed planes.
    RgbToYuv,
    /// Landing drops → their splashes' streaks for the frame.
    RainSplashes,
    /// Drop states written to a buffer (the GPU side of the CPU-twin test and `inspect`).
    RainProbe,
    /// Canvas → packed 16-bit R'G'B'A (the rain as a layer).
    RgbaOut,
    /// The ground below the horizon wetted on the canvas.
    WetGround,
    /// Puddles on the ground: water, ripples and the frame mirrored in them.
    Puddles,
    /// Streaks → the canvas by compute, in tiles (`--gpu-raster compute`).
    StreakTiles,
}

/// The shared modules a stage may name in its `// Includes:` header.
const COMMON: [(&str, &str); 16] = [
    (
        "common/types.wgsl",
        include_str!("../../shaders/common/types.wgsl"),
    ),
    (
        "common/color.wgsl",
        include_str!("../../shaders/common/color.wgsl"),
    ),
    (
        "common/rng.wgsl",
        include_str!("../../shaders/common/rng.wgsl"),
    ),
    (
        "common/drops.wgsl",
        include_str!("../../shaders/common/drops.wgsl"),
    ),
    (
        "common/camera.wgsl",
        include_str!("../../shaders/common/camera.wgsl"),
    ),
    (
        "common/depth.wgsl",
        include_str!("../../shaders/common/depth.wgsl"),
    ),
    (
        "common/streak.wgsl",
        include_str!("../../shaders/common/streak.wgsl"),
    ),
    (
        "common/sh.wgsl",
        include_str!("../../shaders/common/sh.wgsl"),
    ),
    (
        "common/lights.wgsl",
        include_str!("../../shaders/common/lights.wgsl"),
    ),
    (
        "common/plate.wgsl",
        include_str!("../../shaders/common/plate.wgsl"),
    ),
    (
        "common/water.wgsl",
        include_str!("../../shaders/common/water.wgsl"),
    ),
    (
        "common/glow.wgsl",
        include_str!("../../shaders/common/glow.wgsl"),
    ),
    (
        "common/glow_grid.wgsl",
        include_str!("../../shaders/common/glow_grid.wgsl"),
    ),
    (
        "common/sky.wgsl",
        include_str!("../../shaders/common/sky.wgsl"),
    ),
    (
        "common/capsule.wgsl",
        include_str!("../../shaders/common/capsule.wgsl"),
    ),
    (
        "common/ground_mask.wgsl",
        include_str!("../../shaders/common/ground_mask.wgsl"),
    ),
];

/// The `const` lines every stage starts with: sizes and workgroup sizes defined in Rust.
pub fn constants() -> String {
    [
        ("GUSTS", GUSTS as u32),
        ("SPEED_TABLE_LEN", SPEED_TABLE_LEN as u32),
        ("SPEED_BITS", SPEED_BITS),
        ("SPEED_STEPS_LOG2", SPEED_STEPS_LOG2),
        ("INV_HEIGHT_BITS", INV_HEIGHT_BITS),
        ("FALL_RATE_BITS", FALL_RATE_BITS),
        ("DRIFT_BITS", DRIFT_BITS),
        ("DRIFT_PHASE_BITS", DRIFT_PHASE_BITS),
        ("MAX_LIGHTS", MAX_LIGHTS as u32),
        ("GLINTS_PER_DROP", GLINTS_PER_DROP as u32),
        ("SH_COEFFS", SH_COEFFS as u32),
        ("SIMULATE_WORKGROUP", stages::rain_simulate::WORKGROUP),
        ("PIXEL_WORKGROUP", stages::PIXEL_WORKGROUP),
        ("GLOW_CELL_PX", stages::yuv_to_rgb::GLOW_CELL_PX),
        (
            "RING_WORDS",
            crate::fluid::ripples::MAX_RINGS.div_ceil(32) as u32,
        ),
        ("MATTE_WIDTH", crate::drops::atlas::ATLAS_WIDTH as u32),
        ("MATTE_HEIGHT", crate::drops::atlas::ATLAS_HEIGHT as u32),
        (
            "MATTE_TILES_ACROSS",
            stages::rain_streaks::MATTE_TILES_ACROSS as u32,
        ),
        ("QUAD_VERTICES", stages::rain_streaks::QUAD_VERTICES),
        ("TILE_SCAN_WORKGROUP", stages::streak_tiles::SCAN_WORKGROUP),
        ("STREAK_SORT_LOCAL", stages::streak_tiles::SORT_LOCAL),
        ("STREAK_BATCH", stages::streak_tiles::BATCH),
        (
            "MAX_MATTE_LIGHTS",
            crate::drops::atlas::MAX_MATTE_LIGHTS as u32,
        ),
    ]
    .iter()
    .map(|(name, v)| format!("const {name}: u32 = {v}u;\n"))
    .chain(cull_constants())
    .chain(splash_constants())
    .chain(keyframe_constants())
    .collect()
}

/// The streaks' widening and cull (`rain::physics`), which the rain plan's size bound reads
/// too (`rain::volume::visible`).
fn cull_constants() -> impl Iterator<Item = String> {
    use crate::rain::physics as p;
    [
        ("MIN_RADIUS_PX", p::MIN_RADIUS_PX),
        ("MIN_PEAK_ALPHA", p::MIN_PEAK_ALPHA),
        ("NEAR_FIELD_MAX_RADIUS", p::NEAR_FIELD_MAX_RADIUS),
    ]
    .into_iter()
    .map(|(name, v)| format!("const {name}: f32 = {:?};\n", v as f32))
}

/// What a keyed rate and wind need on the GPU (`keyframes`, `rain::volume::drop::falls`).
fn keyframe_constants() -> impl Iterator<Item = String> {
    use crate::rain::physics as dsd;
    let u = [
        ("MAX_KEYS", crate::keyframes::MAX_KEYS as u32),
        ("RATE_STREAM", crate::rain::volume::RATE_STREAM),
    ]
    .map(|(name, v)| format!("const {name}: u32 = {v}u;\n"));
    let f = [
        ("MP_LAMBDA_COEFF", dsd::MP_LAMBDA_COEFF),
        ("MP_LAMBDA_EXPONENT", dsd::MP_LAMBDA_EXPONENT),
    ]
    .map(|(name, v)| format!("const {name}: f32 = {:?};\n", v as f32));
    u.into_iter().chain(f)
}

/// The splash model's constants (`rain::physics::splash`), for `rain_splashes`.
fn splash_constants() -> impl Iterator<Item = String> {
    use crate::rain::physics::splash as s;
    let u = [
        ("SPLASH_SLOTS", s::SPLASH_SLOTS),
        ("SPLASH_MAX_DROPLETS", s::MAX_DROPLETS),
        ("SPLASH_STREAM", s::SPLASH_STREAM),
    ]
    .map(|(name, v)| format!("const {name}: u32 = {v}u;\n"));
    let f = [
        ("SPLASH_K_COEFFICIENT", s::splash_k_coefficient()),
        ("SPLASH_THRESHOLD_K", s::SPLASH_THRESHOLD_K),
        ("SPLASH_CROWN_S", s::CROWN_S),
        ("SPLASH_EJECTED_FRACTION_MAX", s::EJECTED_FRACTION_MAX),
        ("SPLASH_DROPLET_RATIO", s::DROPLET_RATIO),
        ("SPLASH_SPEED_MIN", s::LAUNCH_SPEED[0]),
        ("SPLASH_SPEED_MAX", s::LAUNCH_SPEED[1]),
        ("SPLASH_ELEVATION_MIN_DEG", s::LAUNCH_ELEVATION_DEG[0]),
        ("SPLASH_ELEVATION_MAX_DEG", s::LAUNCH_ELEVATION_DEG[1]),
    ]
    .map(|(name, v)| format!("const {name}: f32 = {:?};\n", v as f32));
    u.into_iter().chain(f)
}

/// The shared modules named by the `// Includes:` header of `body` (a comma-separated list that
/// may run over several comment lines and ends with a full stop).
pub fn includes(body: &str) -> Vec<&str> {
    let mut list = String::new();
    let mut in_header = false;
    for line in body.lines() {
        let Some(text) = line.trim_start().strip_prefix("//") else {
            if in_header {
                break;
            }
            continue;
        };
        let text = if in_header {
            text
        } else if let Some(rest) = text.trim_start().strip_prefix("Includes:") {
            in_header = true;
            rest
        } else {
            continue;
        };
        list.push_str(text);
        list.push(',');
        if text.trim_end().ends_with('.') {
            break;
        }
    }
    list.split(',')
        .map(|s| s.trim().trim_end_matches('.'))
        .filter(|s| !s.is_empty())
        .filter_map(|name| COMMON.iter().find(|(n, _)| *n == name).map(|(n, _)| *n))
        .collect()
}

impl Stage {
    /// Every stage, for validation.
    pub const ALL: [Stage; 10] = [
        Stage::YuvToRgb,
        Stage::RainSimulate,
        Stage::RainSplashes,
        Stage::RainStreaks,
        Stage::RgbToYuv,
        Stage::RainProbe,
        Stage::RgbaOut,
        Stage::WetGround,
        Stage::Puddles,
        Stage::StreakTiles,
    ];

    /// The snake_case name shared by the WGSL file, the pipeline label and the Rust twin.
    pub fn name(self) -> &'static str {
        match self {
            Stage::YuvToRgb => "yuv_to_rgb",
            Stage::RainSimulate => "rain_simulate",
            Stage::RainStreaks => "rain_streaks",
            Stage::RgbToYuv => "rgb_to_yuv",
            Stage::RainSplashes => "rain_splashes",
            Stage::RainProbe => "rain_probe",
            Stage::RgbaOut => "rgba_out",
            Stage::WetGround => "wet_ground",
            Stage::Puddles => "puddles",
            Stage::StreakTiles => "streak_tiles",
        }
    }

    /// The stage file as written.
    pub fn body(self) -> &'static str {
        match self {
            Stage::YuvToRgb => include_str!("../../shaders/yuv_to_rgb.wgsl"),
            Stage::RainSimulate => include_str!("../../shaders/rain_simulate.wgsl"),
            Stage::RainStreaks => include_str!("../../shaders/rain_streaks.wgsl"),
            Stage::RgbToYuv => include_str!("../../shaders/rgb_to_yuv.wgsl"),
            Stage::RainSplashes => include_str!("../../shaders/rain_splashes.wgsl"),
            Stage::RainProbe => include_str!("../../shaders/rain_probe.wgsl"),
            Stage::RgbaOut => include_str!("../../shaders/rgba_out.wgsl"),
            Stage::WetGround => include_str!("../../shaders/wet_ground.wgsl"),
            Stage::Puddles => include_str!("../../shaders/puddles.wgsl"),
            Stage::StreakTiles => include_str!("../../shaders/streak_tiles.wgsl"),
        }
    }

    /// The complete WGSL source: the Rust constants, the included modules, then the stage.
    pub fn source(self) -> String {
        let body = self.body();
        let mut s = constants();
        for name in includes(body) {
            if let Some((_, text)) = COMMON.iter().find(|(n, _)| *n == name) {
                s.push_str(text);
                s.push('\n');
            }
        }
        s.push_str(body);
        s
    }

    /// Compiles the stage on `device`.
    pub fn module(self, device: &wgpu::Device) -> wgpu::ShaderModule {
        device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(self.name()),
            source: wgpu::ShaderSource::Wgsl(self.source().into()),
        })
    }
}
