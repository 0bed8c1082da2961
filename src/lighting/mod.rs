//! Lighting the rain with the frame: the thesis's environment lighting by PRT (its chapter 4 and
//! §5.1.2), with the mathematics in `docs/method.md`, "Lighting".
//!
//! ## How it works
//!
//! ```text
//!  frame (linear RGB) ──► envmap: frame → sphere → SH L_lm (RGB) ──► ShSmoother ──┐
//!                                                                                 ├─► prt: Σ L_lm T_lm(v)
//!  drop optics (ρ per channel) ──► rtf: RTF F(θ), table, zonal z_l ──► T_lm(v) ───┘     = drop colour
//! ```
//!
//! - [`sh`]: real spherical harmonics (convention: no Condon–Shortley phase, z up).
//! - [`envmap`]: the frame spread over the sphere around the camera, projected on SH.
//! - [`rtf`]: the raindrop's radiance-transfer function (thesis Algorithm 1) and its zonal SH.
//! - [`prt`]: the drop colour for a view ray, and the brute-force reference.
//! - [`recovery`]: the light clipping removed from the frame (surfaces, sky, the sun, lamps).
//! - [`sources`]: compact light sources (direct term beside the SH).
//! - [`tracker`]: recovered sources smoothed over frames.
//! - [`inspect`], [`inspect_light`]: JSON reports and PNG plots for the CLI.
//!
//! Angles: θ between the environment lookup direction ω and the view ray v (eye → drop),
//! `cos θ = ω·v`; θ = 0 is straight through the drop. The GPU twin lives in
//! `shaders/common/sh.wgsl`.

mod block_grid;
pub mod envmap;
pub mod frame_light;
pub mod inspect;
pub mod inspect_light;
pub mod prt;
pub mod recovery;
pub mod rtf;
pub mod sh;
pub mod sources;
pub mod tracker;
pub mod wetness;

pub use envmap::{EnvMapper, EnvironmentSh, ShSmoother};
pub use frame_light::{FrameLight, HdrInput, LightConfig, LightEstimator};
pub use prt::{RtfSh, brute_force_colour, prt_colour};
pub use recovery::RecoverySettings;
pub use rtf::{ChannelIndices, DropOptics, Polarisation, RtfTable};
pub use sources::{LightSource, UserLight, direct_colour};
pub use tracker::LightTracker;
