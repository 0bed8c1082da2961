//! Video in and out through FFmpeg: demux and decode, encode and mux, colour, probing.
//!
//! [`Source`] turns an input (file or stdin) into [`YuvFrame`]s in one of the planar layouts of
//! [`frame`] plus the packets of the other streams; [`Sink`] encodes frames with the input's
//! timestamps, colour tags and rotation and copies those packets; [`probe()`] describes an input
//! without decoding it all.
//!
//! Video depends on nothing of the render: it imports only [`crate::error`] and
//! [`crate::files`] (where every output's temporary file and checks live), and the GPU side
//! hands it [`Rendered`] frames.
mod audio;
pub mod color;
pub mod decode;
pub mod encode;
mod ffi;
pub mod frame;
pub mod info;
pub mod layer;
pub mod pixfmt;
pub mod probe;
mod rendered;
pub mod rgba;
pub mod still;

pub use crate::files::{TempFile, check_output, same_file};
pub use color::{ColorParams, Matrix, Transfer};
pub use decode::{CopiedPacket, Source, SourceItem, init, set_ffmpeg_log_level};
pub use encode::{
    AudioMode, EncodeOptions, STREAK_PARAMS, Sink, VideoCodec, output_format, plan_streams,
};
pub use frame::{Chroma, FrameFormat, Plane, YuvFrame};
pub use info::{ColorTags, StreamAction, StreamInfo, StreamKind, VideoInfo};
pub use layer::{AlphaMode, Layer, LayerFrame, LayerSamples};
pub use pixfmt::RGB_SOURCE_COLOR;
pub use probe::{ProbeReport, probe};
pub use rendered::Rendered;
