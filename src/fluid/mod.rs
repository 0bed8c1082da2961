//! SPH surface flow and the carpet free surface (thesis §5.3, after Müller, Charypar & Gross
//! 2003 and Kipfer & Westermann 2006).
//!
//! ## How it works
//!
//! ```text
//!  rain hits per cell ──► PrecipitationGrid (5.29–5.31: every S drops → one particle)
//!                                 │ queued particles, placed on the surface φ
//!  terrain (DEM, ground plane,    ▼
//!  depth map) ──► HeightField ──► Muller2003 (Algorithm 2: density → forces → KDK leapfrog
//!                                 │            → collide; sinks: outflow, infiltration)
//!                                 ▼ particle positions
//!                               Carpet (leaf = highest particle, parents = mean, trails fall)
//!                                 │
//!                                 ▼
//!                  water depth field, wetness field, φ for raindrop collisions
//! ```
//!
//! [`SurfaceFlow`] wires these together (not yet in the video path: the render does not drive
//! it); [`scenes`] holds the validation scenes behind `rain-composite inspect sph`.
//!
//! Modules: [`kernels`] (poly6, spiky, viscosity as types; lattice moments), [`eos`] (pressure
//! laws and the stiffness rule), [`grid`] (counting-sort neighbour search, neighbour lists),
//! [`particles`] (SoA storage), [`boundary`] (box and terrain: mirror ghosts and collisions),
//! [`terrain`] (height fields), [`settings`] (parameters), [`sph`] (the solver), [`resting`] (water placed at rest, not
//! stepped), [`sources`]
//! (precipitation, emitters, mass ledger), [`carpet`] (free surface and wetness), [`flow`]
//! (the rain-fed chain), [`scenes`] (validation), [`puddles`] (the water on a shot's ground).
//!
//! Units are SI throughout and z is up, as in the rest of the crate.
pub mod boundary;
pub mod carpet;
pub mod eos;
pub mod flow;
pub mod grid;
pub mod kernels;
pub mod particles;
pub mod puddles;
pub mod resting;
pub mod ripples;
pub mod scenes;
pub mod settings;
pub mod sources;
pub mod sph;
pub mod terrain;

pub use boundary::{Boundaries, Domain, Face};
pub use carpet::{Carpet, CarpetNode, CarpetSettings, Field2};
pub use eos::EquationOfState;
pub use flow::{SurfaceFlow, SurfaceFlowSettings};
pub use grid::UniformGrid;
pub use kernels::{Kernel, Poly6, Spiky, Viscosity};
pub use particles::Particles;
pub use resting::RestingWater;
pub use scenes::{SceneOptions, inspect_sph, inspect_sph_with};
pub use settings::{SphSettings, TimeStep};
pub use sources::{Emitter, MassLedger, NewParticle, PrecipitationGrid};
pub use sph::Muller2003;
pub use terrain::{HeightField, TerrainSample};
