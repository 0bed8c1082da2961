//! Streak mattes: our own Garg & Nayar (2006) rain-streak database, generated from the physics
//! the rest of the crate uses (Gunn & Kinzer fall speed, Beard & Chuang shape, the RTF's
//! Fresnel optics), and a reader for the original database's layout.
//!
//! - [`shape`]: the oscillating drop (equilibrium spheroid + (2,0) and (3,1) Rayleigh modes).
//! - [`trace`]: reflection and refraction through one frozen shape, s and p separately.
//! - [`streak`]: one streak integrated over the exposure, under a uniform environment and
//!   point lights.
//! - [`database`]: the grid of streaks written as 16-bit PNGs with `index.json`.
//! - [`garg_nayar`]: picks files from a user's copy of the original database.
//! - [`sheet`]: a labelled contact sheet of either.

pub mod atlas;
pub mod database;
pub mod garg_nayar;
pub mod shape;
pub mod sheet;
pub mod streak;
pub mod trace;

pub use atlas::MatteAtlas;
pub use database::{DatabaseSpec, Index, MatteEntry};
pub use shape::{Amplitudes, OscillatingDrop};
pub use streak::{LightAngles, Streak, StreakSetup};
