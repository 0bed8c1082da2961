//! The container's header: the file's tags and the muxer's options, written once every stream
//! has been added.

use ffmpeg_next as ff;

use super::options::EncodeOptions;
use super::{MP4_FAMILY, Y4M, dictionary};
use crate::video::{Layer, VideoInfo};
use crate::{Error, Result};

/// Tags the file with the input's metadata (and a layer's alpha mode) and writes the header of
/// `muxer`.
pub(super) fn write_header(
    octx: &mut ff::format::context::Output,
    info: &VideoInfo,
    opts: &EncodeOptions,
    muxer: &str,
    output: &str,
) -> Result<()> {
    let mut metadata = dictionary(&info.metadata, &["encoder", "alpha_mode"]);
    if let Some(Layer::Alpha(mode)) = opts.layer {
        // No container has a standard field for it: a tag, in the file (MOV keeps only
        // file-level tags) and on the video stream (Matroska).
        metadata.set("alpha_mode", mode.name());
    }
    octx.set_metadata(metadata);
    let mut header_opts = ff::Dictionary::new();
    if MP4_FAMILY.contains(&muxer) {
        // A file gets its index up front (web playback); a pipe cannot seek back, so it
        // gets a fragmented file instead.
        let flags = if output == "-" {
            "frag_keyframe+empty_moov+default_base_moof"
        } else {
            "+faststart"
        };
        let tagged = if opts.layer.is_some_and(Layer::is_rgba) {
            "+use_metadata_tags"
        } else {
            ""
        };
        header_opts.set("movflags", &format!("{flags}{tagged}"));
    }
    if muxer == Y4M && (info.format.bit_depth > 8) {
        // FFmpeg calls high-depth y4m "unofficial" but writes it (rav1e, x264 read it).
        header_opts.set("strict", "unofficial");
    }
    octx.write_header_with(header_opts)
        .map_err(|e| Error::OutputWrite {
            path: output.to_owned(),
            reason: format!("writing the {muxer} header: {e}"),
        })?;
    Ok(())
}
