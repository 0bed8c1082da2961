//! The CPU back end of the per-pixel colour passes ([`super::Backend::Cpu`]): the planes → the
//! hazed linear canvas in f16 ([`plate`], veiled by [`veil`]), the streaks drawn over it
//! ([`streaks`], in tiles) and the canvas → packed code values ([`encode`]), in bands of rows
//! or tiles spread over rayon's threads. On a CPU adapter the GPU's
//! shaders run as JIT code on the same cores at about 100 ns a pixel; these loops do the same
//! work in a few. The plain `f64` twins of [`super::cpu`] are their references
//! (`tests/backend.rs`).

pub mod encode;
pub mod plate;
pub mod rain;
pub mod streaks;
pub mod veil;

use half::f16;

use crate::drops::MatteAtlas;
use crate::gpu::types::{Glint, LightList, RainParams, Streak};
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
    canvas: Vec<f16>,
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
            canvas: vec![f16::ZERO; 4 * format.width as usize * format.height as usize],
        }
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

    /// The hazed linear canvas of `frame` under `p`: RGBA f16, row-major, `width` texels a row
    /// (what `yuv_to_rgb` writes on the GPU).
    pub fn decode(&mut self, frame: &YuvFrame, p: &RainParams) -> &[f16] {
        let lit = self.tables.as_deref().map(|t| (&self.lights, t));
        let size = (self.format.width, self.format.height);
        let veil = veil::Veil::new(p, lit, self.depth.as_deref(), self.sky.as_deref(), size);
        self.decoder.decode(frame, veil.as_ref(), &mut self.canvas);
        &self.canvas
    }

    /// Draws `streaks` (with their `glints`, streak `mattes` where given, behind the scene's
    /// depth where set) over the canvas [`decode`](Self::decode) wrote last.
    pub fn draw_streaks(
        &mut self,
        p: &RainParams,
        streaks: &[Streak],
        mattes: Option<&MatteAtlas>,
        glints: &[Glint],
    ) -> streaks::RasterCount {
        let rain = streaks::Rain {
            params: p,
            mattes,
            glints,
            depth: self.depth.as_deref(),
        };
        streaks::rasterise(&mut self.canvas, self.format.width as usize, &rain, streaks)
    }

    /// The canvas as it stands: RGBA f16, row-major, `width` texels a row.
    pub fn canvas(&self) -> &[f16] {
        &self.canvas
    }

    /// The code planes of the canvas as it stands (see [`encode`](Self::encode)).
    pub fn encode_canvas(&self) -> [Plane; 3] {
        let texels: &[u16] = bytemuck::cast_slice(&self.canvas);
        self.encoder.encode(texels, self.format.width as usize)
    }

    /// The code planes of the canvas `canvas` (RGBA f16 bits, rows `stride_texels` apart), laid
    /// out as the GPU's `rgb_to_yuv` packs them (rows padded to whole 32-bit words).
    pub fn encode(&self, canvas: &[u16], stride_texels: usize) -> [Plane; 3] {
        self.encoder.encode(canvas, stride_texels)
    }
}
