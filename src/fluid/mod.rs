//! SPH surface flow and the carpet free surface (thesis §5.3).
pub mod boundary;
pub mod eos;
pub mod grid;
pub mod kernels;
pub mod particles;
pub mod sources;
pub mod sph;
pub mod terrain;

pub use boundary::{Boundaries, Domain, Face};
pub use eos::EquationOfState;
pub use grid::UniformGrid;
pub use kernels::{HalfSpace, Kernel, Poly6, Spiky, Viscosity};
pub use particles::Particles;
pub use sources::{Emitter, MassLedger, NewParticle, PrecipitationGrid};
pub use sph::{Muller2003, SphSettings, TimeStep};
pub use terrain::{HeightField, TerrainSample};
