//! Rain: drop physics (sizes, fall speeds, wind) and the stateless emitter.
pub mod emitter;
pub mod physics;
pub mod streak;
pub mod volume;
pub mod wind;
