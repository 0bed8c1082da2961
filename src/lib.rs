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
//! ## How a frame flows
//!
//! ```text
//!  video::decode ──► YuvFrame ──► gpu::Compositor ─────────────────────────────► video::encode
//!                       │          upload planes → YUV→linear RGB (canvas, f16) + haze
//!                       │          rain: stateless drops (seed, id, t) → streaks
//!                       │          composite (premultiplied, linear light)
//!                       │          linear RGB → YUV planes → ring readback
//!                       └──► lighting: clipped light recovered → compact sources (direct term,
//!                            exact RTF) + the rest on SH (PRT), smoothed ──► RainParams, light list
//!  rain::volume (plan: columns, far distance, budget) ──► gpu::uniforms ──► RainParams
//! ```
//!
//! Data flows one way: nothing downstream of the decoder changes what the decoder does, and
//! every stage's state at a time `t` is a pure function of its inputs and `t`, so
//! `preview --at t` renders exactly the frame the full render writes at `t`.
//!
//! Modules, each with one job:
//! - [`video`]: FFmpeg demux/decode, encode/mux, colour tags, probing.
//! - [`gpu`]: adapter choice, one object per WGSL stage (`gpu::stages`) and a CPU twin of each
//!   (`gpu::cpu`), the uniforms builder, the compositor and its readback.
//! - [`rain`]: CPU rain physics only: sizes, fall speeds, wind, the planned volume and the
//!   stateless drop (the CPU twin of the GPU one).
//! - [`scene`]: the pinhole camera; the ground plane, its estimate from the frames (`--ground
//!   auto`, `inspect ground`) and depth maps (`--depth`).
//! - [`lighting`]: spherical harmonics, the raindrop radiance-transfer function, PRT, light
//!   recovered from clipped frames and compact light sources.
//! - [`fluid`]: SPH surface flow and the carpet free surface.
//! - [`drops`]: streak mattes: the generator of our Garg & Nayar-style database (`drops/`) and
//!   a reader of the original's layout (not used by the render yet).
//! - [`pipeline`]: one render job, from input to output, and single-frame preview.
//! - [`inspect`]: the `inspect` reports (JSON, plots), one function per subcommand.
//! - [`config`]: the settings, each default written once (the CLI and README read them).
//!
//! The `rain-composite` binary (`src/bin/rain-composite/`) only parses flags, calls these and
//! prints.
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
