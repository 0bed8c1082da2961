//! # rain-composite
//!
//! Adds physically based rain to real video. Each decoded frame is both the background and the
//! environment that lights the rain.
//!
//! The method follows B. B. S. Coutinho's M.Sc. dissertation, "Animação Computacional da Chuva
//! com Fluxo Superficial Simulado via SPH" (COPPE/UFRJ, 2011), with measured rain physics in
//! place of its ballistic drops. `docs/method.md` explains it module by module, with the meaning
//! of every equation number cited in the code (a bare `(5.7)` is the dissertation's) and full
//! references.
//!
//! ## Rendering a frame
//!
//! Every front end (the render job, `preview`, `bench`, a host's plug-in) renders through one
//! [`Renderer`]: a configuration and a description of the frames ([`shot::Footage`]) in, one
//! composited frame out per call.
//!
//! ```
//! # fn main() -> rain_composite::Result<()> {
//! use rain_composite::{Renderer, config::RenderConfig, gpu::AdapterRequest, shot::Footage};
//! use rain_composite::video::{Chroma, ColorParams, FrameFormat, YuvFrame};
//!
//! // A bright sky over dark ground, 320×180, 4:2:0 at 25 fps: rain shows where drops refract
//! // the sky against the ground (over a uniform picture a drop is all but invisible).
//! let format = FrameFormat { width: 320, height: 180, chroma: Chroma::Cs420, bit_depth: 8 };
//! let footage = Footage::picture(format, ColorParams::bt709(8), 25.0);
//! let mut frame = YuvFrame::filled(format, footage.color, [40, 128, 128]);
//! let sky = 320 * 80;
//! frame.planes[0].data[..sky].fill(220);
//!
//! let mut config = RenderConfig::default();
//! config.rain.rate_mm_per_h = 30.0;
//! let mut renderer = Renderer::new(&config, &footage, &AdapterRequest::default())?;
//! let wet = renderer.render(&frame, 0.0)?;
//! let changed = wet.planes[0].data.iter().zip(&frame.planes[0].data).filter(|(a, b)| a != b);
//! assert_eq!(wet.format, frame.format);
//! assert!(changed.count() > 100, "rain changes the picture");
//! # Ok(())
//! # }
//! ```
//!
//! ## How a frame flows
//!
//! ```text
//!  video::decode ──► YuvFrame ──► pipeline::Renderer ──────────────────────────► video::encode
//!                                  │  light feed: clipped light recovered → compact sources
//!                                  │    (direct term, exact RTF) + the rest on SH (PRT)
//!                                  │  water feed (SPH puddles), depth feed (--depth)
//!                                  ▼
//!                                 gpu::Compositor: upload planes → YUV→linear RGB + haze
//!                                  → rain: stateless drops (seed, id, t) → streaks, splashes
//!                                  → composite (premultiplied, linear light) → YUV → readback
//!  config ──► shot::Shot (camera, exposure, RainPlan: columns, far distance, budget)
//!              ──► gpu::uniforms (packed once, per-frame fields at t)
//! ```
//!
//! Data flows one way: nothing downstream of the decoder changes what the decoder does, and
//! every stage's state at a time `t` is a pure function of its inputs and `t`, so
//! `preview --at t` renders exactly the frame the full render writes at `t`.
//!
//! Modules, each with one job, lowest first (a module imports only those above it in this
//! list, never one below):
//! - [`error`], [`rng`], [`keyframes`] (curves of keyed settings), [`files`] (safe reads and
//!   atomic writes).
//! - [`video`]: FFmpeg demux/decode, encode/mux, colour tags, probing.
//! - [`scene`]: the pinhole camera, the ground plane and its estimate from a picture, depth
//!   maps.
//! - [`rain`]: CPU rain physics only: sizes, fall speeds, wind, the planned volume and the
//!   stateless drop (the CPU twin of the GPU one).
//! - [`lighting`]: spherical harmonics, the raindrop radiance-transfer function, PRT, light
//!   recovered from clipped frames, compact light sources, the wet ground's optics.
//! - [`drops`]: streak mattes: the generator of our Garg & Nayar-style database (`drops/`).
//! - [`config`] and [`preset`]: the settings, each default written once.
//! - [`fluid`]: SPH surface flow, the carpet free surface and the puddles.
//! - [`shot`]: the shot's facts and its rain plan, planned on the CPU.
//! - [`gpu`]: adapter choice, one object per WGSL stage (`gpu::stages`) and a CPU twin of each
//!   (`gpu::cpu`), the uniforms packer, the compositor and its readback.
//! - [`pipeline`]: the [`Renderer`], one render job from input to output, single-frame preview.
//! - [`inspect`]: the `inspect` reports (JSON, plots), one function per subcommand.
//!
//! The `rain-composite` binary (`src/bin/rain-composite/`) only parses flags, calls these and
//! prints. `docs/ARCHITECTURE.md` has the module map file by file.
#![cfg_attr(not(test), warn(clippy::unwrap_used))]

pub mod config;
pub mod drops;
pub mod error;
pub mod files;
pub mod fluid;
pub mod gpu;
pub mod inspect;
pub mod keyframes;
pub mod lighting;
pub mod pipeline;
pub mod preset;
pub mod rain;
pub mod rng;
pub mod scene;
pub mod shot;
pub mod video;

pub use error::{Error, Result};
pub use pipeline::Renderer;
