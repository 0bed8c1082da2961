//! The light of one video frame, as the GPU needs it: the frame's environment on SH
//! (smoothed over time), the drop's transfer function, and the haze's in-scatter.
//!
//! Three names: [`LightConfig`] is what the user sets; a [`LightEstimator`], one per shot,
//! turns the shot's frames, in order, into one [`FrameLight`] each.
//!
//! The environment is projected from a small linear-light copy of the frame made straight from
//! its YUV planes (a sparse box filter in the displayed orientation, converted with the frame's
//! own colour parameters): four SH bands need about one sample per degree, not the full
//! picture, so this costs a few thousand conversions per frame instead of millions.
//!
//! The same pass counts, per block and channel, the samples at the frame's code-value ceiling;
//! [`recovery`](super::recovery) turns the clipped regions into light sources and an extended
//! remainder, and [`LightTracker`] smooths the sources like the SH. A frame without clipped
//! samples gives exactly the light it gave without recovery.

use super::envmap::{EnvMapper, EnvironmentSh, ShSmoother};
use super::prt::{RtfSh, channel_optics};
use super::recovery::{BlockStats, ClipLevel, RecoverySettings, recover};
use super::rtf::{ChannelIndices, Polarisation, RtfTable};
use super::sources::{LightSource, UserLight};
use super::tracker::LightTracker;
use crate::scene::Camera;
use crate::video::YuvFrame;
use crate::video::color::{EotfTable, eotf_signed};
use crate::video::frame::coded_pixel;
use crate::video::{ColorParams, Transfer};
use crate::{Error, Result};

/// SH bands used on the GPU.
pub const GPU_BANDS: usize = 4;
/// θ bins of the transfer table the GPU's direct light term reads (0.18° each: finer than
/// the bows' width and the sun's disc).
pub const GPU_RTF_BINS: usize = 1024;
/// Samples per side of each downsampled block.
const SAMPLES_PER_BLOCK: usize = 4;

/// How the rain is lit.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LightConfig {
    /// Refractive index of the drops per channel (R, G, B); differing values model dispersion.
    pub refractive_index: [f64; 3],
    /// Highest scattering order of the transfer function.
    pub n_max: usize,
    /// Time constant of the lighting's temporal smoothing, seconds (0 = off).
    pub smoothing_s: f64,
    /// Lights the frame does not show (a street lamp behind the camera), added to every
    /// frame's light list after the sources found in the frame.
    pub lights: Vec<UserLight>,
    /// A fixed factor on the clip level for clipped samples instead of the recovery's estimate
    /// (`None`: estimate).
    pub highlight_gain: Option<f64>,
    /// Whether the input is scene-referred (PQ, HLG, float): values above 1.0 are trusted and
    /// nothing is recovered. `auto` tells by the stream's transfer tag.
    pub hdr_input: HdrInput,
}

/// Whether light above the frame's diffuse white is real ([`LightConfig::hdr_input`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase", from = "HdrInputField")]
pub enum HdrInput {
    /// HDR when the stream is tagged SMPTE ST 2084 (PQ) or ARIB STD-B67 (HLG): both encode
    /// light far above diffuse white, so a value near their ceiling is a bright source, not
    /// clipping. Anything else is display-referred and its clipped light is recovered.
    #[default]
    Auto,
    /// Always HDR: trust every value, recover nothing (a float or log input tagged otherwise).
    On,
    /// Never HDR: recover clipped light even from a PQ or HLG stream.
    Off,
}

/// The JSON forms of [`HdrInput`]: its name, or a bool as configurations before `auto` wrote
/// it (`true` = on; `false`, which only meant "not forced", = auto).
#[derive(serde::Deserialize)]
#[serde(untagged)]
enum HdrInputField {
    Flag(bool),
    Mode(HdrInputMode),
}

#[derive(serde::Deserialize)]
#[serde(rename_all = "lowercase")]
enum HdrInputMode {
    Auto,
    On,
    Off,
}

impl From<HdrInputField> for HdrInput {
    fn from(f: HdrInputField) -> HdrInput {
        match f {
            HdrInputField::Flag(true) | HdrInputField::Mode(HdrInputMode::On) => HdrInput::On,
            HdrInputField::Flag(false) | HdrInputField::Mode(HdrInputMode::Auto) => HdrInput::Auto,
            HdrInputField::Mode(HdrInputMode::Off) => HdrInput::Off,
        }
    }
}

impl HdrInput {
    /// The name the command line and the configuration use.
    pub fn name(self) -> &'static str {
        match self {
            HdrInput::Auto => "auto",
            HdrInput::On => "on",
            HdrInput::Off => "off",
        }
    }

    /// Whether a frame coded with `transfer` is taken as HDR.
    pub fn is_hdr(self, transfer: Transfer) -> bool {
        match self {
            HdrInput::Auto => matches!(transfer, Transfer::Pq | Transfer::Hlg),
            HdrInput::On => true,
            HdrInput::Off => false,
        }
    }
}

impl Default for LightConfig {
    fn default() -> Self {
        LightConfig {
            refractive_index: super::rtf::WATER_RHO_RGB,
            n_max: super::rtf::DEFAULT_N_MAX,
            smoothing_s: ShSmoother::DEFAULT_TIME_CONSTANT_SECS,
            lights: Vec::new(),
            highlight_gain: None,
            hdr_input: HdrInput::Auto,
        }
    }
}

/// What one frame contributes to the GPU's lighting.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameLight {
    /// The smoothed environment, 4 bands: what the drawn drops show through PRT, and what the
    /// haze (the rain beyond them) scatters along each pixel's ray. Compact lights are not in
    /// it: on four bands a source a fraction of a degree wide would spread its drops' forward
    /// lobe over the whole sphere, and the veil would glow as brightly opposite a lamp as
    /// beside it; drawn drops carry them exactly.
    pub env: EnvironmentSh,
    /// Compact sources lit directly through the RTF table (empty: the SH carries all light).
    pub lights: Vec<super::sources::LightSource>,
}

/// Estimates each frame's light from the frame and the short history the smoothing needs.
#[derive(Debug, Clone)]
pub struct LightEstimator {
    mapper: EnvMapper,
    /// The camera of the frames now fed (a moving camera's; else the mapper's) and, when it
    /// turned from the mapper's, the rotation `world_from_camera · mapper's camera_from_world`
    /// that carries the mapper's environment to this camera's.
    frame_camera: Camera,
    turn: Option<glam::DMat3>,
    rtf: RtfSh,
    smoother: ShSmoother,
    tracker: LightTracker,
    recovery: Option<RecoverySettings>,
    hdr_input: HdrInput,
    rotation_deg: i32,
    tables: [RtfTable; 3],
    user_lights: Vec<LightSource>,
    frames_seen: u64,
    /// Bits the pictures were quantised to before they became these code values, when fewer
    /// than the codes carry (an editor's 8-bit RGBA in 16-bit planes): clipping is judged at
    /// that precision.
    source_bits: Option<u8>,
    /// The frames' transfer as a table (made at the first frame): the block statistics'
    /// conversions.
    eotf: std::sync::OnceLock<EotfTable>,
}

/// The drop's exact transfer table per channel (R, G, B) for `config`, [`GPU_RTF_BINS`] bins:
/// what the direct light term reads, on the GPU and in `inspect light`.
pub fn rtf_tables(config: &LightConfig) -> Result<[RtfTable; 3]> {
    let [r, g, b] = channel_optics(
        ChannelIndices::from(config.refractive_index),
        config.n_max,
        Polarisation::default(),
    )?
    .map(|o| o.tabulate(GPU_RTF_BINS));
    Ok([r?, g?, b?])
}

impl LightEstimator {
    /// Lighting for frames seen through `camera` (the displayed picture), stored rotated by
    /// `rotation_deg` (see `video::VideoInfo::rotation_deg`).
    pub fn new(camera: &Camera, rotation_deg: i32, config: &LightConfig) -> Result<LightEstimator> {
        let tables = rtf_tables(config)?;
        let user_lights = config
            .lights
            .iter()
            .map(|l| l.validate().map(|()| l.source(camera.world_from_camera)))
            .collect::<Result<Vec<_>>>()?;
        let recovery = recovery_settings(config)?;
        let smoother = ShSmoother::new(config.smoothing_s, ShSmoother::DEFAULT_CUT_THRESHOLD)?;
        Ok(LightEstimator {
            mapper: EnvMapper::new(camera, GPU_BANDS)?,
            frame_camera: *camera,
            turn: None,
            rtf: RtfSh::water(
                ChannelIndices::from(config.refractive_index),
                config.n_max,
                GPU_BANDS,
            )?,
            tracker: LightTracker::new(config.smoothing_s, smoother.window_secs()),
            smoother,
            recovery,
            hdr_input: config.hdr_input,
            rotation_deg,
            tables,
            user_lights,
            frames_seen: 0,
            source_bits: None,
            eotf: std::sync::OnceLock::new(),
        })
    }

    /// The frames carry pictures quantised to `bits` bits (see [`Self::update`]): a sample
    /// counts as clipped within [`super::recovery::CLIP_TOLERANCE_CODES`] of the ceiling at
    /// that depth, as the same picture decoded at its own depth would.
    pub fn set_source_bits(&mut self, bits: u8) {
        self.source_bits = Some(bits.clamp(8, 16));
    }

    /// Frames from now on are seen through `camera` (a moving camera's pose and zoom at the
    /// frame), so the environment and the recovered lights stay in world directions and the
    /// smoothing averages light fixed in the world. The frame→sphere map is defined in the
    /// camera's frame, so a turned camera's environment is the mapper's rotated by the turn
    /// (exact in SH, and cheap); a zoom rebuilds the map. The user's lights stay where they were
    /// given (the world of the camera at t = 0).
    pub fn set_camera(&mut self, camera: &Camera) -> Result<()> {
        let mapped = *self.mapper.camera();
        if mapped.fov_x_rad != camera.fov_x_rad {
            self.mapper = EnvMapper::new(camera, GPU_BANDS)?;
        }
        let mapped = self.mapper.camera().world_from_camera;
        self.turn = (mapped != camera.world_from_camera)
            .then(|| camera.world_from_camera * mapped.transpose());
        self.frame_camera = *camera;
        Ok(())
    }

    /// The mapper's projection of `small`, carried to the frame camera's turn.
    fn project(&self, small: &[[f32; 3]]) -> EnvironmentSh {
        let env = self.mapper.project_small(small);
        let Some(turn) = self.turn else {
            return env;
        };
        let channel = |k: usize| -> Vec<f64> {
            let c: Vec<f64> = env.coeffs.iter().map(|c| f64::from(c[k])).collect();
            super::sh::rotate(&c, turn)
        };
        let [r, g, b] = [0, 1, 2].map(channel);
        EnvironmentSh {
            bands: env.bands,
            coeffs: (0..r.len())
                .map(|i| [r[i] as f32, g[i] as f32, b[i] as f32])
                .collect(),
        }
    }

    /// The drop's transfer table per channel (R, G, B), [`GPU_RTF_BINS`] bins: what the
    /// direct light term reads.
    pub fn transfer_tables(&self) -> &[RtfTable; 3] {
        &self.tables
    }

    /// The lights the user added, in the world.
    pub fn user_lights(&self) -> &[LightSource] {
        &self.user_lights
    }

    /// Frames older than this (seconds before the current one) no longer affect the light.
    pub fn window_secs(&self) -> f64 {
        self.smoother.window_secs()
    }

    /// Whether the last [`update`](Self::update) started a new scene (the smoothing and the
    /// light tracking restarted).
    pub fn last_was_cut(&self) -> bool {
        self.smoother.last_was_cut()
    }

    /// The drop's zonal transfer coefficients per channel, as `RainParams::drop_zonal`.
    pub fn drop_zonal_gpu(&self) -> [[f32; 4]; 3] {
        self.rtf.to_gpu_array()
    }

    /// The transfer function.
    pub fn rtf(&self) -> &RtfSh {
        &self.rtf
    }

    /// Raw (unsmoothed) environment of `frame`: the extended remainder after recovery.
    pub fn environment(&self, frame: &YuvFrame) -> EnvironmentSh {
        self.raw_light(frame).0
    }

    /// Raw environment and compact sources of one frame.
    /// The frame's environment with recovered light (the remainder where sources became
    /// lights), the sources, and the display-referred environment that scene cuts are told by.
    fn raw_light(&self, frame: &YuvFrame) -> (EnvironmentSh, Vec<LightSource>, EnvironmentSh) {
        let stats = self.block_stats(frame);
        let display = self.project(&stats.mean);
        match &self.recovery {
            Some(settings)
                if stats.any_clipped() && !self.hdr_input.is_hdr(frame.color.transfer) =>
            {
                let r = recover(&stats, &self.frame_camera, settings);
                (self.project(&r.remainder), r.lights, display)
            }
            _ => (display.clone(), Vec::new(), display),
        }
    }

    /// Feeds the frame shown at `t_s` (increasing) and returns its light.
    pub fn update(&mut self, frame: &YuvFrame, t_s: f64) -> FrameLight {
        let (raw, found, display) = self.raw_light(frame);
        let env = self.smoother.update_keyed(&raw, &display, t_s);
        let cut = self.smoother.last_was_cut();
        // Sources found in the frame (smoothed over time), then the user's lights.
        let mut lights = self.tracker.update(&found, t_s, cut);
        let hdr = self.hdr_input.is_hdr(frame.color.transfer);
        if self.frames_seen == 0 && hdr {
            let tag = match frame.color.transfer {
                Transfer::Pq => "tagged PQ",
                Transfer::Hlg => "tagged HLG",
                _ => "light.hdr_input=on",
            };
            log::info!(
                "HDR input ({tag}): light above diffuse white is kept as it is, none is recovered"
            );
        }
        if (self.frames_seen == 0 || cut) && self.recovery.is_some() && !hdr {
            log_lights(t_s, &found);
        }
        self.frames_seen += 1;
        lights.extend_from_slice(&self.user_lights);
        FrameLight { env, lights }
    }

    /// Linear RGB of the frame box-filtered to the mapper's small size, displayed orientation,
    /// with the fraction of clipped samples per block.
    fn block_stats(&self, frame: &YuvFrame) -> BlockStats {
        let transfer = frame.color.transfer;
        let table = self.eotf.get_or_init(|| EotfTable::new(transfer));
        self.block_stats_with(frame, (table.transfer() == transfer).then_some(table))
    }

    /// [`block_stats`](Self::block_stats), each sample through the transfer's `table` where
    /// given (the plain form, a `pow` a channel, where not): the same clipped samples, and
    /// means within [`EotfTable::RELATIVE_ERROR`] of the plain form's.
    fn block_stats_with(&self, frame: &YuvFrame, table: Option<&EotfTable>) -> BlockStats {
        let cam = self.mapper.camera();
        let (dw, dh) = (cam.width_px as usize, cam.height_px as usize);
        let f = &frame.format;
        let (sx, sy) = f.chroma.shift();
        let rotation = self.rotation_deg.rem_euclid(360);
        let transfer = frame.color.transfer;
        let codes_per_unit = match self.source_bits {
            Some(bit_depth) if bit_depth < frame.color.bit_depth => {
                ColorParams {
                    bit_depth,
                    ..frame.color
                }
                .range_scale()
                .y_scale
            }
            _ => frame.color.range_scale().y_scale,
        };
        let clip = ClipLevel::from_eotf(|e| eotf_signed(transfer, e), codes_per_unit);
        BlockStats::build(
            (dw, dh),
            self.mapper.block_px(),
            Some(SAMPLES_PER_BLOCK),
            clip,
            |x, y| {
                let (cx, cy) = coded_pixel(rotation, f.width, f.height, x as u32, y as u32);
                let code = [
                    frame.sample(0, cx, cy) as f64,
                    frame.sample(1, cx >> sx, cy >> sy) as f64,
                    frame.sample(2, cx >> sx, cy >> sy) as f64,
                ];
                let Some(table) = table else {
                    return frame.color.code_to_linear(code);
                };
                let e = frame.color.code_to_encoded(code);
                std::array::from_fn(|k| linear_beside(table, e[k], clip.threshold[k]))
            },
        )
    }
}

/// Linear light of encoded value `e` through `table`, on the same side of `level` as the
/// function puts it: a tabled value this near the level could lie on the other side (the
/// chord of a convex curve lies above it), so there the function runs.
#[inline]
fn linear_beside(table: &EotfTable, e: f64, level: f64) -> f64 {
    let v = table.apply(e);
    if (v - level).abs() <= 4.0 * EotfTable::RELATIVE_ERROR * level.abs() {
        eotf_signed(table.transfer(), e)
    } else {
        v
    }
}

/// The recovery settings of a configuration (`None`: every input is trusted as it is; a
/// frame that [`HdrInput::is_hdr`] says is HDR is trusted too).
pub fn recovery_settings(config: &LightConfig) -> Result<Option<RecoverySettings>> {
    if let Some(g) = config.highlight_gain {
        if !(1.0..=super::recovery::MAX_GAIN).contains(&g) {
            return Err(Error::Parameter {
                name: "light.highlight_gain",
                value: g.to_string(),
                expected: "a factor in [1, 1000000] on the clip level".into(),
            });
        }
    }
    Ok(
        (config.hdr_input != HdrInput::On).then_some(RecoverySettings {
            highlight_gain: config.highlight_gain,
        }),
    )
}

/// `-v`: the sources found at the start of a scene.
fn log_lights(t_s: f64, lights: &[LightSource]) {
    if lights.is_empty() {
        log::info!("scene at {t_s:.3} s: no clipped light sources");
        return;
    }
    log::info!("scene at {t_s:.3} s: {} light source(s)", lights.len());
    for l in lights {
        let d = l.direction_world;
        log::info!(
            "  light: azimuth {:.1}° elevation {:.1}°, {:.2e} sr, radiance {:.3e} {:.3e} {:.3e}",
            d.x.atan2(d.y).to_degrees(),
            d.z.clamp(-1.0, 1.0).asin().to_degrees(),
            l.solid_angle_sr,
            l.radiance_rgb[0],
            l.radiance_rgb[1],
            l.radiance_rgb[2],
        );
    }
}

#[cfg(test)]
mod tests {
    use super::{LightConfig, LightEstimator};
    use crate::rng::SplitMix64;
    use crate::scene::Camera;
    use crate::video::color::{EotfTable, eotf_signed};
    use crate::video::{Chroma, ColorParams, FrameFormat, Matrix, Transfer, YuvFrame};

    /// A picture of scattered codes with a bright patch at and around the clip level (the
    /// ceiling and one to three codes under it, where the level lies), neutral and tinted.
    fn picture(format: FrameFormat, color: ColorParams, seed: u64) -> YuvFrame {
        let mut frame = YuvFrame::filled(format, color, [0, 0, 0]);
        let s = color.range_scale();
        let top = (s.y_offset + s.y_scale) as u16;
        let mid = s.c_offset as u16;
        let max = (1u32 << format.bit_depth) - 1;
        let mut rng = SplitMix64(seed);
        for i in 0..3 {
            let (w, h) = format.plane_size(i);
            let (sx, sy) = if i == 0 {
                (0, 0)
            } else {
                format.chroma.shift()
            };
            for y in 0..h as usize {
                for x in 0..w as usize {
                    let r = rng.next_u64();
                    let bright = (x << sx) < w as usize * (1 << sx) / 3 && (y << sy) < 40;
                    let v = if bright && i == 0 {
                        top - [0, 1, 2, 2, 3][(r % 5) as usize]
                    } else if bright {
                        mid + [0, 0, 0, 6][(r % 4) as usize]
                    } else {
                        (r % u64::from(max + 1)) as u16
                    };
                    let p = &mut frame.planes[i];
                    let at = y * p.stride + x * format.bytes_per_sample();
                    if format.bytes_per_sample() == 1 {
                        p.data[at] = v as u8;
                    } else {
                        p.data[at..at + 2].copy_from_slice(&v.to_le_bytes());
                    }
                }
            }
        }
        frame
    }

    /// Around the clip levels of 8- to 12-bit codes, every encoded value 10⁻⁹ apart (far
    /// finer than codes and their mixes fall): the tabled light lies on the side of the level
    /// the function puts it on, and where it runs the function, it is the function.
    #[test]
    fn tabled_light_takes_the_side_of_the_clip_level_the_function_takes() {
        for transfer in [Transfer::Bt709, Transfer::Srgb, Transfer::Gamma22] {
            let table = EotfTable::new(transfer);
            for codes_per_unit in [219.0, 255.0, 876.0, 1023.0, 3504.0] {
                let at = 1.0 - super::super::recovery::CLIP_TOLERANCE_CODES / codes_per_unit;
                let level = eotf_signed(transfer, at);
                for i in -20_000..=20_000 {
                    let e = at + f64::from(i) * 1e-9;
                    let (ours, exact) = (
                        super::linear_beside(&table, e, level),
                        eotf_signed(transfer, e),
                    );
                    assert_eq!(
                        ours >= level,
                        exact >= level,
                        "{transfer:?} {codes_per_unit} at {e}"
                    );
                }
            }
        }
    }

    /// The block statistics through the transfer's table against the plain form (a `pow` a
    /// channel): the same clipped share in every block (the samples at the clip level
    /// decided by the function), the means and clipped colours within the table's bound.
    #[test]
    fn block_statistics_through_the_table_are_the_plain_ones() {
        let format = |bit_depth, chroma| FrameFormat {
            width: 320,
            height: 180,
            chroma,
            bit_depth,
        };
        let cases = [
            (format(8, Chroma::Cs420), ColorParams::bt709(8)),
            (
                format(8, Chroma::Cs422),
                ColorParams {
                    matrix: Matrix::Bt601,
                    full_range: true,
                    transfer: Transfer::Srgb,
                    bit_depth: 8,
                },
            ),
            (
                format(10, Chroma::Cs420),
                ColorParams {
                    matrix: Matrix::Bt2020Ncl,
                    full_range: false,
                    transfer: Transfer::Bt709,
                    bit_depth: 10,
                },
            ),
        ];
        let camera = Camera::new(320, 180, 1.0, 1.6, 0.05, 0.0);
        let est = LightEstimator::new(&camera, 0, &LightConfig::default()).expect("estimator");
        for (k, (format, color)) in cases.into_iter().enumerate() {
            let frame = picture(format, color, k as u64);
            let table = EotfTable::new(color.transfer);
            let plain = est.block_stats_with(&frame, None);
            let fast = est.block_stats_with(&frame, Some(&table));
            assert_eq!(fast.clipped, plain.clipped, "{color:?}");
            let partly = plain.clipped.iter().filter(|f| **f > 0.0 && **f < 1.0);
            assert!(partly.count() > 0, "{color:?}: no block partly clipped");
            let mut worst = 0f64;
            for (a, b) in [
                (&fast.mean, &plain.mean),
                (&fast.clipped_colour, &plain.clipped_colour),
            ] {
                for (a, b) in a.iter().flatten().zip(b.iter().flatten()) {
                    let off = f64::from((a - b).abs()) / f64::from(b.abs()).max(1e-30);
                    worst = worst.max(off);
                }
            }
            eprintln!("{color:?}: worst {worst:.2e} relative");
            assert!(
                worst <= 2.0 * EotfTable::RELATIVE_ERROR,
                "{color:?}: {worst}"
            );
        }
    }
}
