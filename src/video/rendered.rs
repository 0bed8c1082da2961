//! A frame as the compositor hands it to the [`Sink`](super::Sink): a picture, or the rain as a
//! layer. It lives with the video types so that encoding needs nothing from the GPU side.

use super::{LayerFrame, YuvFrame};
use crate::{Error, Result};

/// A frame read back: the composite (or the layer over black) as Y'CbCr planes, or the
/// rain as an R'G'B'A layer.
#[derive(Debug, Clone, PartialEq)]
pub enum Rendered {
    /// Planes in the input's layout.
    Picture(YuvFrame),
    /// The layer, or the matte.
    Layer(LayerFrame),
}

impl Rendered {
    /// The picture, or an error for a layer.
    pub fn into_picture(self) -> Result<YuvFrame> {
        match self {
            Rendered::Picture(f) => Ok(f),
            Rendered::Layer(_) => Err(Error::Gpu(
                "this compositor writes R'G'B'A layers, not pictures".into(),
            )),
        }
    }
}
