//! The WGSL stages, embedded in the binary. A stage file names the shared modules it needs;
//! [`Stage::source`] prepends them (WGSL has no includes), so every stage validates alone.

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
    /// Drop states written to a buffer (the GPU side of the CPU-twin test and `inspect`).
    RainProbe,
}

const TYPES: &str = include_str!("../../shaders/common/types.wgsl");
const COLOR: &str = include_str!("../../shaders/common/color.wgsl");
const RNG: &str = include_str!("../../shaders/common/rng.wgsl");
const DROPS: &str = include_str!("../../shaders/common/drops.wgsl");
const SH: &str = include_str!("../../shaders/common/sh.wgsl");
const LIGHTS: &str = include_str!("../../shaders/common/lights.wgsl");

impl Stage {
    /// Every stage, for validation.
    pub const ALL: [Stage; 5] = [
        Stage::YuvToRgb,
        Stage::RainSimulate,
        Stage::RainStreaks,
        Stage::RgbToYuv,
        Stage::RainProbe,
    ];

    /// The snake_case name shared by the WGSL file, the pipeline label and the Rust twin.
    pub fn name(self) -> &'static str {
        match self {
            Stage::YuvToRgb => "yuv_to_rgb",
            Stage::RainSimulate => "rain_simulate",
            Stage::RainStreaks => "rain_streaks",
            Stage::RgbToYuv => "rgb_to_yuv",
            Stage::RainProbe => "rain_probe",
        }
    }

    /// The complete WGSL source: shared modules, then the stage.
    pub fn source(self) -> String {
        let (common, body): (&[&str], &str) = match self {
            Stage::YuvToRgb => (
                &[TYPES, COLOR, SH],
                include_str!("../../shaders/yuv_to_rgb.wgsl"),
            ),
            Stage::RainSimulate => (
                &[TYPES, RNG, DROPS, SH, LIGHTS],
                include_str!("../../shaders/rain_simulate.wgsl"),
            ),
            Stage::RainStreaks => (&[TYPES], include_str!("../../shaders/rain_streaks.wgsl")),
            Stage::RgbToYuv => (
                &[TYPES, COLOR],
                include_str!("../../shaders/rgb_to_yuv.wgsl"),
            ),
            Stage::RainProbe => (
                &[TYPES, RNG, DROPS],
                include_str!("../../shaders/rain_probe.wgsl"),
            ),
        };
        let mut s = common.join("\n");
        s.push('\n');
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
