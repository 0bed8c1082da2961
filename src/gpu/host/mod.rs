//! The CPU back end of the per-pixel colour passes ([`super::Backend::Cpu`]): the planes → the
//! hazed linear canvas in f16 ([`plate`], veiled by [`veil`], the wet ground fused in:
//! [`wet_ground`]), the puddles ([`puddles`]), the splashes and the streaks drawn over it
//! ([`splashes`], [`streaks`], in tiles) and the canvas → packed code values ([`encode`]), in
//! bands of rows or tiles spread over rayon's threads. On a CPU adapter the GPU's
//! shaders run as JIT code on the same cores at about 100 ns a pixel; these loops do the same
//! work in a few. The plain `f64` twins of [`super::cpu`] are their references
//! (`tests/backend.rs`).

mod bands;
mod blend;
pub mod drop_light;
pub mod encode;
pub mod lanes;
pub mod plate;
mod puddle_cells;
pub mod puddles;
pub mod rain;
pub mod simulate;
pub mod splashes;
mod streak_mattes;
mod streak_runs;
pub mod streaks;
pub mod tile;
pub mod veil;
pub mod wet_ground;

use std::sync::Mutex;

use half::f16;

pub use bands::{BandedFrame, FrameRain};

use crate::drops::MatteAtlas;
use crate::gpu::stages::puddles::FrameWater;
use crate::gpu::types::{Glint, LightList, RainParams, Streak, WetParams};
use crate::lighting::RtfTable;
use crate::video::{ColorParams, FrameFormat, Plane, YuvFrame};

/// The colour passes of one picture format on the CPU, with what the haze needs between
/// frames (the lamps, the drop's transfer table, the scene's depth, the sky).
pub struct HostColour {
    format: FrameFormat,
    decoder: plate::Decoder,
    encoder: encode::Encoder,
    lights: LightList,
    tables: Option<Box<[RtfTable; 3]>>,
    /// The scene's depth per displayed pixel, metres, 0 where unknown.
    depth: Option<Vec<f32>>,
    /// The open sky's weight at the glow's grid points.
    sky: Option<Vec<f32>>,
    /// The ground's weight at the glow's grid points.
    ground_mask: Option<Vec<f32>>,
    canvas: Vec<f16>,
    /// Which of the raster's tiles the canvas holds the plate in (`None`: all of them); the
    /// others pass through ([`HostColour::lay_plate`]).
    laid: Option<Vec<bool>>,
    /// Whether [`HostColour::lay_plate`] may let untouched tiles pass through.
    pass_through: bool,
    /// Seconds the draws spent laying the plate in the tiles they reach, since last taken
    /// ([`HostColour::take_laying_s`]).
    laying_s: f64,
    /// The streak raster's buffers, kept from frame to frame.
    raster: streaks::Raster,
    /// The splashes' raster where a frame is drawn band by band ([`bands`]: both draws'
    /// streaks are binned before the first band).
    splash_raster: streaks::Raster,
    /// Each thread's buffers for [`HostColour::render_bands`].
    band_work: Vec<Mutex<bands::BandWork>>,
    /// The SH basis at the haze grid's rays, kept while the camera stays.
    rays: veil::GridRays,
    /// Whether the puddles run their AVX2 build where the CPU has it.
    puddles_avx2: bool,
}

/// Whether every pixel no streak or splash is drawn over leaves the frame as it came in:
/// no haze (`veil`: the in-scatter, the lamps' glow and the open sky's weight all ride on it,
/// and it is `None` exactly when the haze is off), no wet ground (`wet`: `None` where the
/// ground is dry or no ray reaches it) and no water. Nothing else changes the plate: the
/// exposure, the highlight recovery and the light estimate change only what the haze and
/// the streaks add, the depth map and the masks only where the haze, the ground or a streak
/// falls, and the mattes' glints are drawn inside their streaks' boxes. This is the one place
/// that decides; where it says no, the whole frame is decoded and encoded.
fn plate_passes(
    veil: Option<&veil::Veil>,
    wet: Option<&wet_ground::WetGround>,
    water: Option<&FrameWater>,
) -> bool {
    veil.is_none() && wet.is_none() && water.is_none()
}

/// What lies on the ground of one frame: the wet ground's uniforms and the water.
#[derive(Default)]
pub struct GroundFrame<'a> {
    /// The wet ground (`None`: dry, or no ground).
    pub wet: Option<WetParams>,
    /// The puddles (`None`: no water set).
    pub water: Option<FrameWater<'a>>,
}

impl HostColour {
    /// The passes for frames of `format` coded in `color`.
    pub fn new(format: FrameFormat, color: &ColorParams) -> HostColour {
        HostColour {
            format,
            decoder: plate::Decoder::new(format, color),
            encoder: encode::Encoder::new(format, color),
            lights: LightList::new(&[]),
            tables: None,
            depth: None,
            sky: None,
            ground_mask: None,
            canvas: vec![f16::ZERO; 4 * format.width as usize * format.height as usize],
            laid: None,
            pass_through: true,
            laying_s: 0.0,
            raster: streaks::Raster::default(),
            splash_raster: streaks::Raster::default(),
            band_work: Vec::new(),
            rays: veil::GridRays::default(),
            puddles_avx2: true,
        }
    }

    /// [`new`](Self::new) without the AVX2 builds of the decode, the puddles and the encode,
    /// and without the decode's tables by code (each routine in its plain form): the same
    /// bits, slower (`tests/backend.rs` holds the two equal).
    pub fn baseline(format: FrameFormat, color: &ColorParams) -> HostColour {
        let mut host = HostColour::new(format, color);
        host.decoder.set_baseline(true);
        host.decoder.set_code_tables(false);
        host.encoder.set_baseline(true);
        host.puddles_avx2 = false;
        host
    }

    /// Whether [`lay_plate`](Self::lay_plate) lets the tiles nothing is drawn on pass through
    /// (the default) or decodes and encodes every tile (slower; the same codes wherever the
    /// round trip keeps the frame's, as it does on every picture `tests/backend.rs` tries).
    pub fn set_pass_through(&mut self, on: bool) {
        self.pass_through = on;
    }

    /// The compact lights whose glow the haze shows from the next frame on.
    pub fn set_lights(&mut self, lights: &LightList) {
        self.lights = *lights;
    }

    /// The drop's transfer table the glow is seen through; until it is set the lamps add
    /// nothing (as on the GPU).
    pub fn set_transfer_table(&mut self, tables: &[RtfTable; 3]) {
        self.tables = Some(Box::new(tables.clone()));
    }

    /// The scene's depth per displayed pixel (row-major, metres, 0 where unknown), as the GPU's
    /// `scene_depth` buffer holds it.
    pub fn set_scene_depth(&mut self, metres: Vec<f32>) {
        self.depth = Some(metres);
    }

    /// The open sky's weight at the glow's grid points, as the GPU's `sky_mask` buffer holds it.
    pub fn set_sky_mask(&mut self, weights: Vec<f32>) {
        self.sky = Some(weights);
    }

    /// The ground's weight at the glow's grid points, as the GPU's `ground_mask` buffer holds
    /// it: the wet ground and the puddles keep to it where the depth map does not know a pixel.
    pub fn set_ground_mask(&mut self, weights: Vec<f32>) {
        self.ground_mask = Some(weights);
    }

    /// The scene's depth last set (see [`set_scene_depth`](Self::set_scene_depth)).
    pub fn scene_depth(&self) -> Option<&[f32]> {
        self.depth.as_deref()
    }

    /// The sky mask last set (see [`set_sky_mask`](Self::set_sky_mask)).
    pub fn sky_mask(&self) -> Option<&[f32]> {
        self.sky.as_deref()
    }

    /// The hazed linear canvas of `frame` under `p`: RGBA f16, row-major, `width` texels a row
    /// (what `yuv_to_rgb` writes on the GPU).
    pub fn decode(&mut self, frame: &YuvFrame, p: &RainParams) -> &[f16] {
        self.decode_ground(frame, p, &GroundFrame::default());
        &self.canvas
    }

    /// As [`decode`](Self::decode), with the wet ground (fused into the decode) and the
    /// puddles of `ground` (the `wet_ground` and `puddles` stages' work); returns the seconds
    /// the puddles took and the pixels under water.
    pub fn decode_ground(
        &mut self,
        frame: &YuvFrame,
        p: &RainParams,
        ground: &GroundFrame,
    ) -> (f64, usize) {
        self.plate(frame, p, ground, false)
    }

    /// [`decode_ground`](Self::decode_ground) for a frame rendered whole: where nothing but
    /// the streaks and the splashes changes the picture ([`plate_passes`]) and pass-through is
    /// on, nothing is decoded yet; the draws of [`draw_streaks`](Self::draw_streaks) and
    /// [`draw_splashes`](Self::draw_splashes) decode the tiles they reach first, and
    /// [`encode_canvas`](Self::encode_canvas) copies the frame's codes for the others.
    pub fn lay_plate(
        &mut self,
        frame: &YuvFrame,
        p: &RainParams,
        ground: &GroundFrame,
    ) -> (f64, usize) {
        self.plate(frame, p, ground, self.pass_through)
    }

    fn plate(
        &mut self,
        frame: &YuvFrame,
        p: &RainParams,
        ground: &GroundFrame,
        defer: bool,
    ) -> (f64, usize) {
        let lit = self.tables.as_deref().map(|t| (&self.lights, t));
        let size = (self.format.width, self.format.height);
        let (depth, sky) = (self.depth.as_deref(), self.sky.as_deref());
        let veil = veil::Veil::new(p, lit, depth, sky, size, &mut self.rays);
        let on_ground =
            wet_ground::Ground::new(p, size, self.depth.as_deref(), self.ground_mask.as_deref());
        let wet = ground
            .wet
            .as_ref()
            .and_then(|w| wet_ground::WetGround::new(&on_ground, w));
        if defer && plate_passes(veil.as_ref(), wet.as_ref(), ground.water.as_ref()) {
            let (tiles_x, tiles_y) = self.tiles();
            let mut laid = self.laid.take().unwrap_or_default();
            laid.clear();
            laid.resize(tiles_x * tiles_y, false);
            self.laid = Some(laid);
            return (0.0, 0);
        }
        self.laid = None;
        self.decoder
            .decode(frame, veil.as_ref(), wet.as_ref(), &mut self.canvas);
        let Some(water) = &ground.water else {
            return (0.0, 0);
        };
        let started = std::time::Instant::now();
        let wet = puddles::Puddles::new(&on_ground, water, &self.lights).map_or(0, |w| {
            let (canvas, decoder, veil) = (&mut self.canvas, &self.decoder, veil.as_ref());
            if self.puddles_avx2 {
                w.shade(canvas, frame, decoder, veil)
            } else {
                w.shade_baseline(canvas, frame, decoder, veil)
            }
        });
        (started.elapsed().as_secs_f64(), wet)
    }

    /// The raster's tiles across and down the picture.
    fn tiles(&self) -> (usize, usize) {
        let (w, h) = (self.format.width as usize, self.format.height as usize);
        (w.div_ceil(streaks::TILE_W), h.div_ceil(streaks::TILE_H))
    }

    /// The tiles of the last frame laid that went through the decode and the encode, and the
    /// picture's tiles: the rest passed through.
    pub fn tiles_converted(&self) -> (usize, usize) {
        let (tiles_x, tiles_y) = self.tiles();
        let all = tiles_x * tiles_y;
        let laid = self.laid.as_ref();
        (laid.map_or(all, |l| l.iter().filter(|&&t| t).count()), all)
    }

    /// Draws `streaks` (with their `glints`, streak `mattes` where given, behind the scene's
    /// depth where set) over `frame`'s canvas, laid by [`decode`](Self::decode) or
    /// [`lay_plate`](Self::lay_plate) last.
    pub fn draw_streaks(
        &mut self,
        frame: &YuvFrame,
        p: &RainParams,
        streaks: &[Streak],
        mattes: Option<&MatteAtlas>,
        glints: &[Glint],
    ) -> streaks::RasterCount {
        self.draw(frame, p, streaks, mattes, glints)
    }

    /// Draws the splashes' `streaks` (capsules, behind the scene's depth where set) over
    /// `frame`'s canvas, before the drops' own: the `rain_splashes` stage's draw.
    pub fn draw_splashes(
        &mut self,
        frame: &YuvFrame,
        p: &RainParams,
        streaks: &[Streak],
    ) -> streaks::RasterCount {
        self.draw(frame, p, streaks, None, &[])
    }

    /// The raster over the canvas, the plate of `frame` laid first in the tiles it reaches
    /// that do not hold it yet.
    fn draw(
        &mut self,
        frame: &YuvFrame,
        p: &RainParams,
        streaks: &[Streak],
        mattes: Option<&MatteAtlas>,
        glints: &[Glint],
    ) -> streaks::RasterCount {
        let HostColour {
            format,
            decoder,
            depth,
            canvas,
            laid,
            raster,
            laying_s,
            ..
        } = self;
        let rain = streaks::Rain {
            params: p,
            mattes,
            glints,
            depth: depth.as_deref(),
        };
        let width = format.width as usize;
        raster.draw_over(canvas, width, &rain, streaks, |canvas, reached| {
            let Some(laid) = laid else { return };
            let started = std::time::Instant::now();
            let mut need = vec![false; laid.len()];
            reached.mark(&mut need);
            for (need, laid) in need.iter_mut().zip(laid.iter_mut()) {
                *need &= !*laid;
                *laid |= *need;
            }
            decoder.decode_tiles(frame, &need, canvas);
            *laying_s += started.elapsed().as_secs_f64();
        })
    }

    /// The seconds the draws spent laying the plate in the tiles they reach since the last
    /// call (the decode's share of a frame whose tiles pass through, timed inside the draws).
    pub fn take_laying_s(&mut self) -> f64 {
        std::mem::take(&mut self.laying_s)
    }

    /// The canvas as it stands: RGBA f16, row-major, `width` texels a row (after a
    /// [`lay_plate`](Self::lay_plate) that let tiles pass through, only the tiles drawn on
    /// hold the frame; [`render_bands`](Self::render_bands) does not write it).
    pub fn canvas(&self) -> &[f16] {
        &self.canvas
    }

    /// The code planes of `frame`'s canvas as it stands (see [`encode`](Self::encode)): the
    /// tiles that passed through ([`lay_plate`](Self::lay_plate)) are `frame`'s codes.
    pub fn encode_canvas(&self, frame: &YuvFrame) -> [Plane; 3] {
        let texels: &[u16] = bytemuck::cast_slice(&self.canvas);
        let from = self.laid.as_deref().map(|laid| (frame, laid));
        self.encoder
            .encode_tiles(texels, self.format.width as usize, from)
    }

    /// The code planes of the canvas `canvas` (RGBA f16 bits, rows `stride_texels` apart), laid
    /// out as the GPU's `rgb_to_yuv` packs them (rows padded to whole 32-bit words).
    pub fn encode(&self, canvas: &[u16], stride_texels: usize) -> [Plane; 3] {
        self.encoder.encode(canvas, stride_texels)
    }
}
