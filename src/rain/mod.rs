//! Rain: drop physics (sizes, fall speeds, wind) and the stateless emitter.
pub mod physics;
pub mod wind;
pub mod emitter;
