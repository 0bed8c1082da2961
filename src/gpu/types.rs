//! Rust twins of the WGSL structs in `shaders/common/types.wgsl`: same names, same field
//! order, `#[repr(C)]` and `Pod` so a value uploads with one `bytemuck` cast.
//! `tests/shaders.rs` checks every size and offset against naga's layout of the WGSL.

use bytemuck::{Pod, Zeroable};

use crate::keyframes::MAX_KEYS;
use crate::video::{ColorParams, FrameFormat};

/// WGSL `FrameParams`: a frame's layout and colour interpretation.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
#[allow(missing_docs)]
pub struct FrameParams {
    pub width: u32,
    pub height: u32,
    pub chroma_shift_x: u32,
    pub chroma_shift_y: u32,
    pub y_offset: f32,
    pub y_scale: f32,
    pub c_offset: f32,
    pub c_scale: f32,
    pub max_code: f32,
    pub transfer: u32,
    pub kr: f32,
    pub kb: f32,
    pub bytes_per_sample: u32,
    pub y_row_words: u32,
    pub c_row_words: u32,
    pub cb_offset_words: u32,
    pub cr_offset_words: u32,
    pub chroma_width: u32,
    pub chroma_height: u32,
    pub _pad: u32,
}

impl FrameParams {
    /// Layout of the packed output buffer and the colour constants for `format`/`color`.
    pub fn new(format: &FrameFormat, color: &ColorParams) -> FrameParams {
        let bps = format.bytes_per_sample() as u32;
        let (cw, ch) = format.plane_size(1);
        let (sx, sy) = format.chroma.shift();
        let y_row_words = (format.width * bps).div_ceil(4);
        let c_row_words = (cw * bps).div_ceil(4);
        let s = color.range_scale();
        let (kr, kb) = color.matrix.kr_kb();
        let cb_offset_words = y_row_words * format.height;
        FrameParams {
            width: format.width,
            height: format.height,
            chroma_shift_x: sx,
            chroma_shift_y: sy,
            y_offset: s.y_offset as f32,
            y_scale: s.y_scale as f32,
            c_offset: s.c_offset as f32,
            c_scale: s.c_scale as f32,
            max_code: s.max_code as f32,
            transfer: color.transfer.gpu_id(),
            kr: kr as f32,
            kb: kb as f32,
            bytes_per_sample: bps,
            y_row_words,
            c_row_words,
            cb_offset_words,
            cr_offset_words: cb_offset_words + c_row_words * ch,
            chroma_width: cw,
            chroma_height: ch,
            _pad: 0,
        }
    }

    /// Total u32 words of the packed output (three planes).
    pub fn total_words(&self) -> u32 {
        self.cr_offset_words + self.c_row_words * self.chroma_height
    }
}

/// Entries of the fall-speed-by-quantile table (`RainParams::speed_q`).
pub use crate::rain::volume::drop::SPEED_TABLE_LEN;

/// SH coefficients of an environment on the GPU (4 bands, the order of `shaders/common/sh.wgsl`).
pub const SH_COEFFS: usize = 16;

/// Gust components in `RainParams` (`rain::wind::GUST_COMPONENTS`).
pub const GUSTS: usize = 8;

/// WGSL `RainParams`: camera, rain volume and streak look for one frame.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
#[allow(missing_docs)]
pub struct RainParams {
    pub camera_pos_m: [f32; 3],
    /// The pinhole's focal length, px.
    pub focal_px: f32,
    pub camera_from_world_0: [f32; 4],
    pub camera_from_world_1: [f32; 4],
    pub camera_from_world_2: [f32; 4],
    pub principal_px: [f32; 2],
    pub display_size_px: [f32; 2],
    pub coded_from_display: [f32; 4],
    pub coded_offset_px: [f32; 2],
    pub coded_size_px: [f32; 2],
    pub column_slope: [f32; 2],
    pub cell_size_m: [f32; 2],
    pub wind_mean_mps: [f32; 2],
    /// The mean wind's travel over the cell size, modulo 1.
    pub mean_travel_cells: [f32; 2],
    /// The haze: x where it starts (the farthest drawn drop, m), y where it ends (the scene,
    /// m), z its extinction coefficient β (1/m), w its transmittance T to y (1: no haze).
    pub haze: [f32; 4],
    pub env_sh: [[f32; 4]; SH_COEFFS],
    pub drop_zonal: [[f32; 4]; 3],
    pub gust_amp: [[f32; 4]; GUSTS],
    pub gust_phase: [[f32; 4]; GUSTS],
    /// Whole seconds of the frame's time.
    pub time_whole_s: u32,
    /// The rest of the frame's time, s, in [0, 1).
    pub time_frac_s: f32,
    pub exposure_s: f32,
    pub seed: u32,
    pub drop_count: u32,
    pub column_count: u32,
    pub opacity: f32,
    pub near_clip_m: f32,
    pub drop_weight: f32,
    pub d_min_mm: f32,
    pub d_max_mm: f32,
    pub lambda_per_mm: f32,
    pub diameter_scale: f32,
    pub lens_blur_k_px_m: f32,
    pub inv_focus_per_m: f32,
    pub gravity_mps2: f32,
    /// The columns' drift per metre fallen, 2⁻¹⁶ cells/m (`rain::volume::DropMotion`).
    pub drift_q: [i32; 2],
    /// 1: streaks end where their drops land on the ground z = 0 (a ground is given); 0: as
    /// without a ground.
    pub ground_clip: u32,
    pub _pad: u32,
    /// Keyed wind: the mean wind's slope at the frame's time, m/s².
    pub wind_slope_mps2: [f32; 2],
    /// Keyed wind: the mean wind at t = 0, m/s.
    pub wind_start_mps: [f32; 2],
    pub wind_kink_count: u32,
    /// 0: the rate is constant and every drop falls.
    pub rate_key_count: u32,
    pub _pad_keys: [u32; 2],
    /// The mean wind's slope changes up to the frame: (t − t_j s, Δb_j m/s², unused).
    pub wind_kinks: [[f32; 4]; MAX_KEYS],
    /// The keyed rate: (t_k − t s, rate mm/h, unused, unused).
    pub rate_keys: [[f32; 4]; MAX_KEYS],
    /// Fall speed by size quantile, 2⁻¹⁰ m/s (`rain::volume::DropMotion`).
    pub speed_q: [u32; SPEED_TABLE_LEN],
}

/// WGSL `Column`: a sheared prism of the rain volume.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
#[allow(missing_docs)]
pub struct Column {
    pub cell_min_m: [f32; 2],
    pub z_lo_m: f32,
    pub height_m: f32,
    pub first_drop: u32,
    pub drop_count: u32,
    /// 1 / height, 2⁻²² m⁻¹ (`rain::volume::drop::inv_height_q`).
    pub inv_height_q: u32,
    /// The share of sizes the column simulates, 2⁻²⁴ (`rain::volume::drop::size_bits`).
    pub size_keep_q: u32,
}

/// WGSL `Streak`: one drop's streak for the frame (`rain_simulate` → `rain_streaks`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
#[allow(missing_docs)]
pub struct Streak {
    pub q0_px: [f32; 2],
    pub dir: [f32; 2],
    pub len_px: f32,
    pub r_eff_px: f32,
    pub alpha_scale: f32,
    /// pack2x16unorm(diameter mm / 10, view elevation / 90°): what picks the streak's matte.
    pub drop_info: u32,
    /// rgb: the drop's radiance seen at `q0_px`; w: its depth there (camera z), metres.
    pub radiance0: [f32; 4],
    /// The same at the end of the path.
    pub radiance1: [f32; 4],
}

/// Most compact lights the GPU's direct term takes per frame (`LightList::lights`).
pub const MAX_LIGHTS: usize = 16;

/// WGSL `DirectLight`: one compact light (see [`crate::lighting::LightSource`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
#[allow(missing_docs)]
pub struct DirectLight {
    /// xyz: unit direction camera → light, world; w: distance, m (0 = at infinity).
    pub direction_distance: [f32; 4],
    /// rgb: radiance × solid angle at the camera; w: closest a drop may be, m.
    pub strength: [f32; 4],
}

impl DirectLight {
    /// The light seen from a point `from_camera_m` (world axes, metres from the camera): ω, the
    /// unit direction point → light, and the factor on its solid angle. A light at distance d
    /// is seen at (d/|light − point|)², the distance clamped at the closest a drop may be,
    /// where Ω would exceed a hemisphere; a light at infinity is the same from everywhere
    /// (twin of `light_seen_from` in common/types.wgsl).
    pub fn seen_from(&self, from_camera_m: glam::DVec3) -> (glam::DVec3, f64) {
        let [x, y, z, d] = self.direction_distance.map(f64::from);
        let omega = glam::DVec3::new(x, y, z);
        if d <= 0.0 {
            return (omega, 1.0);
        }
        let to_light = omega * d - from_camera_m;
        let r = to_light.length();
        let omega = if r > 0.0 { to_light / r } else { omega };
        (omega, (d / r.max(self.strength[3] as f64)).powi(2))
    }
}

/// WGSL `LightList`: the frame's compact lights and the size of the RTF table.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
#[allow(missing_docs)]
pub struct LightList {
    pub count: u32,
    pub table_bins: u32,
    pub _pad: [u32; 2],
    pub lights: [DirectLight; MAX_LIGHTS],
}

impl LightList {
    /// The [`MAX_LIGHTS`] strongest of `sources` (by the luminance of radiance × solid angle at
    /// the camera; the rest are dropped), for the table of [`super::lights::TABLE_BINS`] bins.
    pub fn new(sources: &[crate::lighting::LightSource]) -> LightList {
        let luminance = |s: &crate::lighting::LightSource| {
            let [r, g, b] = s.radiance_times_solid_angle();
            0.2126 * r + 0.7152 * g + 0.0722 * b
        };
        let mut order: Vec<&crate::lighting::LightSource> = sources.iter().collect();
        order.sort_by(|a, b| luminance(b).total_cmp(&luminance(a)));
        let mut list = LightList {
            table_bins: super::lights::TABLE_BINS as u32,
            ..Zeroable::zeroed()
        };
        for (slot, s) in list.lights.iter_mut().zip(order) {
            let d = s.direction_world;
            let [r, g, b] = s.radiance_times_solid_angle();
            *slot = DirectLight {
                direction_distance: [
                    d.x as f32,
                    d.y as f32,
                    d.z as f32,
                    s.distance_m.unwrap_or(0.0) as f32,
                ],
                strength: [
                    r as f32,
                    g as f32,
                    b as f32,
                    s.min_distance_m().unwrap_or(0.0) as f32,
                ],
            };
            list.count += 1;
        }
        list
    }
}

/// WGSL `WetParams`: the wet ground's look for one frame (see [`crate::lighting::wetness`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
#[allow(missing_docs)]
pub struct WetParams {
    /// Share of the ground under a water film, [0, 1].
    pub wetness: f32,
    pub water_index: f32,
    pub diffuse_external: f32,
    pub diffuse_internal: f32,
    /// How far the ground reaches, m: wetness fades out from half this distance to it (0: no
    /// limit). See [`crate::lighting::wetness::Wetting::reach_m`].
    pub reach_m: f32,
    pub _pad0: f32,
    pub _pad1: f32,
    pub _pad2: f32,
}

impl WetParams {
    /// The uniforms for wetness `wetness` of a film with `optics`, on ground reaching `reach_m`.
    pub fn new(
        wetness: f64,
        optics: &crate::lighting::wetness::FilmOptics,
        reach_m: f64,
    ) -> WetParams {
        WetParams {
            wetness: wetness as f32,
            water_index: optics.index as f32,
            diffuse_external: optics.diffuse_external as f32,
            diffuse_internal: optics.diffuse_internal as f32,
            reach_m: reach_m as f32,
            _pad0: 0.0,
            _pad1: 0.0,
            _pad2: 0.0,
        }
    }
}

/// WGSL `MatteParams`: the bins of the streak mattes ([`crate::drops::MatteAtlas`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
#[allow(missing_docs)]
pub struct MatteParams {
    /// Size bins, view bins, phases, 0.
    pub counts: [u32; 4],
    pub sizes_mm: [[f32; 4]; 2],
    pub views_deg: [[f32; 4]; 2],
    /// xyz: the point-light mattes' directions.
    pub lights: [[f32; 4]; crate::drops::atlas::MAX_MATTE_LIGHTS],
    /// Point-light directions, the first point-light layer, 0, 0.
    pub light_count: [u32; 4],
    /// How far across a streak its matte reaches, drop radii; the reciprocal of the matte
    /// texture's width and height in texels; 0.
    pub reach: [f32; 4],
}

/// Compact lights per drop drawn with their point-light mattes (`--streaks mattes`): the
/// drop's strongest, `glints[GLINTS_PER_DROP · id + k]`; weaker ones stay in the smooth colour.
/// With up to six lamps of similar strength the rest carry under half a per cent of the drops'
/// direct light (docs/method.md §5.3). At most 4: `rain_streaks` passes a drop's glints as
/// four varyings.
pub const GLINTS_PER_DROP: usize = 4;
const _: () = assert!(GLINTS_PER_DROP <= 4);

/// WGSL `Glint`: one of a drop's strongest compact lights, drawn with its point-light matte.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
#[allow(missing_docs)]
pub struct Glint {
    /// rgb: the light's radiance on the drop, taken out of the streak's colour; 0: none.
    pub colour: [f32; 4],
    /// xyz: drop → light: x image right, y away from the camera, z against the fall.
    pub light_dir: [f32; 4],
}

impl MatteParams {
    /// The bins of `atlas` (at most [`crate::drops::atlas::MAX_MATTE_BINS`] of each).
    pub fn new(atlas: &crate::drops::MatteAtlas) -> MatteParams {
        let pack = |values: &[f64]| {
            let mut out = [[0.0f32; 4]; 2];
            for (k, v) in values.iter().enumerate().take(8) {
                out[k / 4][k % 4] = *v as f32;
            }
            out
        };
        MatteParams {
            counts: [
                atlas.sizes_mm.len() as u32,
                atlas.views_deg.len() as u32,
                atlas.phases as u32,
                0,
            ],
            sizes_mm: pack(&atlas.sizes_mm),
            views_deg: pack(&atlas.views_deg),
            lights: std::array::from_fn(|k| {
                atlas
                    .lights
                    .get(k)
                    .map_or([0.0; 4], |d| [d.x as f32, d.y as f32, d.z as f32, 0.0])
            }),
            light_count: [atlas.lights.len() as u32, atlas.light_layer0() as u32, 0, 0],
            reach: {
                let (w, h) = super::stages::rain_streaks::matte_texture_size(atlas);
                [
                    atlas.reach_radii() as f32,
                    1.0 / w as f32,
                    1.0 / h as f32,
                    0.0,
                ]
            },
        }
    }
}

/// WGSL `PuddleParams`: the puddles' water map and look for one frame (stage `puddles`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
#[allow(missing_docs)]
pub struct PuddleParams {
    /// Corner of the water map's cell (0, 0) on the ground, m.
    pub origin_m: [f32; 2],
    pub cell_m: f32,
    /// Water covers the ground smoothly as its depth rises from 0 to this, m.
    pub edge_depth_m: f32,
    pub cells: [u32; 2],
    /// Live entries of the ripple buffer.
    pub ring_count: u32,
    /// RMS slope of the water rained on ([`crate::fluid::ripples::rain_slope_variance`]),
    /// shown beyond `resolve_depth_m` as a blurred reflection; 0: none.
    pub far_slope_rms: f32,
    pub water_index: f32,
    pub diffuse_external: f32,
    pub diffuse_internal: f32,
    /// Concentration κ of a compact light's mirror image (a von Mises–Fisher lobe), rad⁻².
    pub light_lobe: f32,
    /// Camera depth beyond which single rings are finer than a pixel and the far slope takes
    /// over (fully from twice this depth), m.
    pub resolve_depth_m: f32,
    pub _pad0: f32,
    pub _pad1: f32,
    pub _pad2: f32,
}

/// WGSL `Ripple`: one ring at the frame's time ([`crate::fluid::ripples::RingState`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
#[allow(missing_docs)]
pub struct Ripple {
    pub centre_m: [f32; 2],
    pub radius_m: f32,
    pub width_m: f32,
    pub amplitude_m: f32,
    /// rad/m.
    pub wavenumber: f32,
    /// ω t modulo 2π, rad.
    pub phase: f32,
    pub _pad: f32,
}

impl Ripple {
    /// The ring `ring` at time `t_s`, or `None` where it is not alive then.
    pub fn new(ring: &crate::fluid::ripples::Ring, t_s: f64) -> Option<Ripple> {
        let s = ring.at(t_s)?;
        Some(Ripple {
            centre_m: [ring.centre_m.x as f32, ring.centre_m.y as f32],
            radius_m: s.radius_m as f32,
            width_m: s.width_m as f32,
            amplitude_m: s.amplitude_m as f32,
            wavenumber: ring.wavenumber as f32,
            phase: s.phase as f32,
            _pad: 0.0,
        })
    }
}

/// WGSL `TileParams` (`shaders/streak_tiles.wgsl`): the tile grid the compute rasteriser bins
/// the streaks into.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct TileParams {
    /// Tiles across and down the coded picture.
    pub tiles_xy: [u32; 2],
    /// Streaks drawn: the first of the streak buffer.
    pub streak_count: u32,
    /// Entries the tiles' lists hold in all.
    pub capacity: u32,
}
