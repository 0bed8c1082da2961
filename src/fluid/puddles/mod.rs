//! Puddles: the water on a shot's ground (docs/method.md, "Puddles: the water").
//!
//! Modules: [`relief`] (footprint and micro-relief).
pub mod relief;

pub use relief::{Footprint, ground_footprint, micro_relief};
