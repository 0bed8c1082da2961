//! The few FFmpeg calls that ffmpeg-next 9 does not wrap, each in a small safe function.
//!
//! Everything `unsafe` in the video module lives here, so the rest reads as plain Rust. Each
//! function states the FFmpeg invariant it relies on.

use std::ffi::{CString, c_int};
use std::ptr;

use ffmpeg_next::packet::Ref as _;
use ffmpeg_next::{self as ff, ffi};

/// What the pixel-format descriptor says about a layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct PixDesc {
    /// Bits of the first component (luma or red).
    pub depth: u8,
    /// Number of components (1 = grey, 2 = grey + alpha, 3 = colour, 4 = colour + alpha).
    pub components: u8,
    /// log2 of the horizontal and vertical chroma subsampling.
    pub log2_chroma: (u8, u8),
    /// Components are R, G, B rather than Y, Cb, Cr.
    pub rgb: bool,
    /// Each component has its own plane.
    pub planar: bool,
    /// Big-endian samples.
    pub big_endian: bool,
    /// Palette format (colours are RGB entries).
    pub palette: bool,
    /// Hardware surface: no samples in memory.
    pub hwaccel: bool,
}

/// Reads the pixel-format descriptor (`None` for `Pixel::None` and unknown formats).
pub(crate) fn pix_desc(format: ff::format::Pixel) -> Option<PixDesc> {
    let desc = format.descriptor()?;
    // SAFETY: `descriptor()` returned a non-null pointer into FFmpeg's static descriptor table,
    // which lives for the whole program and is never written.
    let d = unsafe { &*desc.as_ptr() };
    let flags = d.flags;
    let has = |f: c_int| flags & f as u64 != 0;
    Some(PixDesc {
        depth: d.comp[0].depth.clamp(0, 255) as u8,
        components: d.nb_components,
        log2_chroma: (d.log2_chroma_w, d.log2_chroma_h),
        rgb: has(ffi::AV_PIX_FMT_FLAG_RGB),
        planar: has(ffi::AV_PIX_FMT_FLAG_PLANAR),
        big_endian: has(ffi::AV_PIX_FMT_FLAG_BE),
        palette: has(ffi::AV_PIX_FMT_FLAG_PAL),
        hwaccel: has(ffi::AV_PIX_FMT_FLAG_HWACCEL),
    })
}

/// True when every used plane of `frame` has a positive line size. Some decoders (bottom-up
/// BMP/AVI raw RGB) hand out negative line sizes, which ffmpeg-next's `stride()` would turn
/// into huge `usize`s; such frames go through swscale, which handles them.
pub(crate) fn strides_positive(frame: &ff::frame::Video) -> bool {
    // SAFETY: the frame is a valid, allocated AVFrame; `linesize` is a plain array field.
    let linesize = unsafe { (*frame.as_ptr()).linesize };
    let planes = pix_desc(frame.format())
        .map(|d| if d.planar { d.components.min(3) } else { 1 })
        .unwrap_or(1) as usize;
    linesize.iter().take(planes).all(|&l| l > 0)
}

/// swscale's colour-space id for a matrix (`SWS_CS_*`).
pub(crate) fn sws_colorspace(matrix: crate::video::Matrix) -> c_int {
    use crate::video::Matrix;
    match matrix {
        Matrix::Bt601 => ffi::SWS_CS_ITU601,
        Matrix::Bt709 => ffi::SWS_CS_ITU709,
        Matrix::Bt2020Ncl => ffi::SWS_CS_BT2020,
        Matrix::Smpte240m => ffi::SWS_CS_SMPTE240M,
        Matrix::Fcc => ffi::SWS_CS_FCC,
    }
}

/// Sets the matrix and range of both sides of a swscale context explicitly, replacing its
/// defaults (BT.601, range guessed from the `yuvj`/grey format names), which would otherwise
/// compress or expand the range of YUV → YUV layout changes.
pub(crate) fn sws_set_colorspace(
    ctx: &mut ff::software::scaling::Context,
    src: (c_int, bool),
    dst: (c_int, bool),
) -> bool {
    // SAFETY: `ctx` owns a valid SwsContext. `sws_getCoefficients` returns a pointer into a
    // static table (valid for any id, unknown ids fall back to BT.601). brightness 0 and
    // contrast/saturation 1.0 in 16.16 fixed point are the identity.
    unsafe {
        let inv = ffi::sws_getCoefficients(src.0);
        let table = ffi::sws_getCoefficients(dst.0);
        ffi::sws_setColorspaceDetails(
            ctx.as_mut_ptr(),
            inv,
            src.1 as c_int,
            table,
            dst.1 as c_int,
            0,
            1 << 16,
            1 << 16,
        ) >= 0
    }
}

/// The muxer FFmpeg would pick for a short name and/or a file name (by its extension).
pub(crate) fn guess_output_format(
    short_name: Option<&str>,
    file_name: Option<&str>,
) -> Option<ff::format::format::Output> {
    let name = short_name.and_then(|s| CString::new(s).ok());
    let file = file_name.and_then(|s| CString::new(s).ok());
    if name.is_none() && file.is_none() {
        return None;
    }
    // SAFETY: both strings are NUL-terminated and outlive the call; the returned muxer
    // descriptor is static.
    let fmt = unsafe {
        ffi::av_guess_format(
            name.as_ref().map_or(ptr::null(), |s| s.as_ptr()),
            file.as_ref().map_or(ptr::null(), |s| s.as_ptr()),
            ptr::null(),
        )
    };
    if fmt.is_null() {
        None
    } else {
        // SAFETY: non-null pointer to a static AVOutputFormat.
        Some(unsafe { ff::format::format::Output::wrap(fmt as *mut _) })
    }
}

/// Whether a muxer can hold a codec: `Some(true/false)`, or `None` when the muxer does not say.
pub(crate) fn muxer_accepts(
    fmt: &ff::format::format::Output,
    codec: ff::codec::Id,
) -> Option<bool> {
    // SAFETY: `fmt` wraps a static AVOutputFormat; the call only reads it.
    let r =
        unsafe { ffi::avformat_query_codec(fmt.as_ptr(), codec.into(), ffi::FF_COMPLIANCE_NORMAL) };
    match r {
        1.. => Some(true),
        0 => Some(false),
        _ => None,
    }
}

/// Attaches a display matrix to an output stream (before the header is written), which is how
/// the MP4/MOV muxers learn the display rotation in FFmpeg 5.1.
pub(crate) fn set_display_matrix(
    stream: &mut ff::format::stream::StreamMut,
    matrix: &[i32; 9],
) -> bool {
    // SAFETY: the stream belongs to an output context whose header is not written yet;
    // `av_stream_new_side_data` allocates 36 bytes owned by the stream (or returns null),
    // into which we copy exactly 9 i32s.
    unsafe {
        let data = ffi::av_stream_new_side_data(
            stream.as_mut_ptr(),
            ffi::AVPacketSideDataType::AV_PKT_DATA_DISPLAYMATRIX,
            std::mem::size_of_val(matrix),
        );
        if data.is_null() {
            return false;
        }
        ptr::copy_nonoverlapping(
            matrix.as_ptr() as *const u8,
            data,
            std::mem::size_of_val(matrix),
        );
        true
    }
}

/// Clears the codec tag of a stream-copied output stream (the input container's fourcc may not
/// exist in the output container; the muxer picks its own) and copies the input disposition.
pub(crate) fn prepare_copied_stream(
    stream: &mut ff::format::stream::StreamMut,
    disposition: c_int,
) {
    // SAFETY: a freshly added output stream always has an allocated `codecpar`.
    unsafe {
        let st = stream.as_mut_ptr();
        (*(*st).codecpar).codec_tag = 0;
        (*st).disposition = disposition;
    }
}

/// The raw disposition flags of an input stream.
pub(crate) fn disposition(stream: &ff::format::stream::Stream) -> c_int {
    stream.disposition().bits()
}

/// Asks FFmpeg's probers what the first bytes of a file look like, ignoring its name: the
/// container's name and score (100 = certain), or `None` when nothing recognises it. Used to
/// tell a damaged video ("moov atom not found") from a file that is not video at all.
pub(crate) fn probe_content(head: &[u8]) -> Option<(String, i32)> {
    let mut buf = Vec::with_capacity(head.len() + ffi::AVPROBE_PADDING_SIZE as usize);
    buf.extend_from_slice(head);
    buf.resize(head.len() + ffi::AVPROBE_PADDING_SIZE as usize, 0);
    let empty = c"";
    let pd = ffi::AVProbeData {
        filename: empty.as_ptr(),
        buf: buf.as_mut_ptr(),
        buf_size: head.len() as c_int,
        mime_type: ptr::null(),
    };
    let mut score: c_int = 0;
    // SAFETY: `pd` points at `head.len()` bytes followed by the required zero padding, and an
    // empty file name (so the extension cannot vote); the result is a static descriptor.
    let fmt = unsafe { ffi::av_probe_input_format3(&pd, 1, &mut score) };
    if fmt.is_null() {
        return None;
    }
    // SAFETY: non-null static AVInputFormat.
    let name = unsafe { ff::format::format::Input::wrap(fmt as *mut _) }
        .name()
        .to_owned();
    Some((name, score))
}

/// Flushes the output's I/O buffer (a pipe is not flushed by the trailer alone) and returns the
/// I/O layer's sticky error: FFmpeg's muxers ignore failed writes (a full disk, a closed pipe)
/// and record them in `AVIOContext::error` instead.
pub(crate) fn flush_io(octx: &mut ff::format::context::Output) -> Result<(), ff::Error> {
    // SAFETY: the output context is open; `pb` is either null (no file) or a valid AVIOContext.
    unsafe {
        let pb = (*octx.as_mut_ptr()).pb;
        if !pb.is_null() {
            ffi::avio_flush(pb);
            let err = (*pb).error;
            if err < 0 {
                return Err(ff::Error::from(err));
            }
        }
    }
    Ok(())
}

/// Whether the demuxer marked a packet to be decoded but not shown (`AV_PKT_FLAG_DISCARD`, e.g.
/// samples before an MP4 edit list's start); ffmpeg-next's `Flags` drops that bit.
pub(crate) fn packet_discarded(packet: &ff::Packet) -> bool {
    // SAFETY: the packet wraps a valid AVPacket; `flags` is a plain field.
    unsafe { (*packet.as_ptr()).flags & ffi::AV_PKT_FLAG_DISCARD != 0 }
}

/// Whether the input's container allows timestamp discontinuities (`AVFMT_TS_DISCONT`: MPEG-TS
/// and other broadcast streams, where joined recordings restart their clocks).
pub(crate) fn input_allows_discontinuities(ictx: &ff::format::context::Input) -> bool {
    // SAFETY: the input context is open, so `iformat` points at its demuxer's static description.
    unsafe {
        let iformat = (*ictx.as_ptr()).iformat;
        !iformat.is_null() && (*iformat).flags & ffi::AVFMT_TS_DISCONT != 0
    }
}

/// Whether the input's I/O layer has hit the end of the file (a demuxer error there means the
/// file is truncated, not that one packet is damaged).
pub(crate) fn input_at_eof(ictx: &ff::format::context::Input) -> bool {
    // SAFETY: the input context is open; `pb` is either null (demuxer without a file) or a
    // valid AVIOContext, whose `eof_reached` is a plain field.
    unsafe {
        let pb = (*ictx.as_ptr()).pb;
        !pb.is_null() && (*pb).eof_reached != 0
    }
}

/// The file name of image `number` of sequence pattern `pattern` (`out_%05d.png` → `out_00001.png`),
/// or `None` when the pattern has no frame number (FFmpeg's own substitution, so the check
/// agrees with what the image2 muxer writes).
pub(crate) fn sequence_file_name(pattern: &str, number: i32) -> Option<String> {
    let pattern = CString::new(pattern).ok()?;
    let mut buf = vec![0u8; 4096];
    // SAFETY: `buf` is writable for its length, which is passed; `pattern` is NUL-terminated.
    let ok = unsafe {
        ffi::av_get_frame_filename2(
            buf.as_mut_ptr().cast(),
            buf.len() as c_int,
            pattern.as_ptr(),
            number,
            0,
        )
    } >= 0;
    let end = buf.iter().position(|&b| b == 0)?;
    buf.truncate(end);
    ok.then(|| String::from_utf8_lossy(&buf).into_owned())
}
