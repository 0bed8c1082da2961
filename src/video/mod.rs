//! Video in and out through FFmpeg: demux and decode, encode and mux, colour, probing.
pub mod color;
pub mod frame;

pub use color::{ColorParams, Matrix, Transfer};
pub use frame::{Chroma, FrameFormat, Plane, YuvFrame};
pub mod still;
