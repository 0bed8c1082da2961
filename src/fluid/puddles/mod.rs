//! Puddles: the water on a shot's ground — the relief it stands on, the rain that fell before
//! the clip filled into it, and the SPH surface flow that carries it through the clip
//! (docs/method.md, "Puddles: the water").
//!
//! ```text
//!  camera + ground ──► relief (footprint up to a distance, plane or depth map + fractal
//!                      micro-relief)
//!  --pre-rain × rate ─► ledger (film, evaporation, infiltration) ─► fill (priority-flood,
//!                      volume conserved) ─► particles on a lattice in the depressions
//!  impacts per frame ─► SurfaceFlow (precipitation counters 5.29–5.31, SPH, carpet)
//!                      ─► water_depth(): Field2 on z = 0
//!                      ─► shown: the water map the shading reads (signed, rims between leaves)
//! ```
//!
//! Modules: [`checkpoint`] (the water kept in files for chunks), [`relief`] (footprint and micro-relief), [`fill`] (depression filling),
//! `columns` (the fill's water laid into the particle columns),
//! [`ledger`] (the water balance), [`shown`] (the water map the picture is shaded from),
//! [`kept_map`] (that map kept from frame to frame, made again where the water changed),
//! [`sim`] ([`PuddleSim`], the loop), [`report`]
//! (`inspect puddles`).
pub mod checkpoint;
mod columns;
pub mod fill;
pub mod kept_map;
pub mod ledger;
pub mod relief;
pub mod shown;
pub mod sim;

pub use checkpoint::Checkpoints;
pub use fill::{FilledWater, fill_depressions};
pub use kept_map::KeptWaterMap;
pub use ledger::WaterLedger;
pub use relief::{Footprint, ground_footprint, micro_relief};
pub use sim::{PuddleSettings, PuddleSim};
