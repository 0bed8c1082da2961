//! FFmpeg pixel formats ↔ the planar layouts of [`FrameFormat`], and the swscale step between
//! them.
//!
//! How it works: a decoded format that already is one of our layouts (`yuv420p`,
//! `yuv422p10le`, … and the `yuvj*` aliases) is copied plane by plane. Anything else (NV12,
//! P010, grey, packed RGB, 4:1:1…) is converted by swscale to the nearest layout of the same
//! depth. swscale gets its matrix and both ranges set explicitly: for YUV → YUV both sides are
//! equal, so only the sample arrangement changes; for RGB sources the matrix is BT.709 and the
//! range full (see [`RGB_SOURCE_COLOR`]).

use ffmpeg_next::format::Pixel;
use ffmpeg_next::software::scaling;
use ffmpeg_next::{self as ff};

use super::ffi::{self, PixDesc};
use super::{Chroma, FrameFormat, Matrix, Plane, YuvFrame};
use crate::{Error, Result};

/// RGB sources become YUV 4:4:4 with this matrix and full range, so the GPU's YUV → RGB gives
/// back the source's RGB (to rounding). BT.709 because RGB sources (PNG, screen captures) are
/// sRGB, whose primaries are BT.709's.
pub const RGB_SOURCE_COLOR: (Matrix, bool) = (Matrix::Bt709, true);

/// The FFmpeg pixel format of a planar layout (`None` for a depth FFmpeg has no format for).
pub fn pixel_of(format: &FrameFormat) -> Option<Pixel> {
    use Chroma::*;
    Some(match (format.chroma, format.bit_depth) {
        (Cs420, 8) => Pixel::YUV420P,
        (Cs422, 8) => Pixel::YUV422P,
        (Cs444, 8) => Pixel::YUV444P,
        (Cs420, 9) => Pixel::YUV420P9LE,
        (Cs422, 9) => Pixel::YUV422P9LE,
        (Cs444, 9) => Pixel::YUV444P9LE,
        (Cs420, 10) => Pixel::YUV420P10LE,
        (Cs422, 10) => Pixel::YUV422P10LE,
        (Cs444, 10) => Pixel::YUV444P10LE,
        (Cs420, 12) => Pixel::YUV420P12LE,
        (Cs422, 12) => Pixel::YUV422P12LE,
        (Cs444, 12) => Pixel::YUV444P12LE,
        (Cs420, 14) => Pixel::YUV420P14LE,
        (Cs422, 14) => Pixel::YUV422P14LE,
        (Cs444, 14) => Pixel::YUV444P14LE,
        (Cs420, 16) => Pixel::YUV420P16LE,
        (Cs422, 16) => Pixel::YUV422P16LE,
        (Cs444, 16) => Pixel::YUV444P16LE,
        _ => return None,
    })
}

/// The planar layout of an FFmpeg format if it is one of ours as it stands: `(chroma, depth,
/// full_range_alias)`, the last being true for the `yuvj*` aliases.
pub fn layout_of(pixel: Pixel) -> Option<(Chroma, u8, bool)> {
    let (p, jpeg) = match pixel {
        Pixel::YUVJ420P => (Pixel::YUV420P, true),
        Pixel::YUVJ422P => (Pixel::YUV422P, true),
        Pixel::YUVJ444P => (Pixel::YUV444P, true),
        p => (p, false),
    };
    let d = ffi::pix_desc(p)?;
    if d.rgb || d.palette || d.hwaccel || !d.planar || d.big_endian || d.components != 3 {
        return None;
    }
    let chroma = chroma_of(d.log2_chroma)?;
    let format = FrameFormat {
        width: 1,
        height: 1,
        chroma,
        bit_depth: d.depth,
    };
    (pixel_of(&format) == Some(p)).then_some((chroma, d.depth, jpeg))
}

fn chroma_of(log2: (u8, u8)) -> Option<Chroma> {
    match log2 {
        (1, 1) => Some(Chroma::Cs420),
        (1, 0) => Some(Chroma::Cs422),
        (0, 0) => Some(Chroma::Cs444),
        _ => None,
    }
}

/// What a decoded pixel format becomes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SourceLayout {
    /// The planar layout frames leave the source in.
    pub chroma: Chroma,
    /// Bits per sample.
    pub bit_depth: u8,
    /// The decoded format already is this layout (no swscale).
    pub direct: bool,
    /// The source is RGB (converted with [`RGB_SOURCE_COLOR`]).
    pub rgb: bool,
    /// The source is grey only (chroma planes are filled with the neutral value).
    pub gray: bool,
    /// A `yuvj*` format: full range by definition.
    pub jpeg: bool,
}

/// Chooses the planar layout for a decoded pixel format: same depth (rounded up to one
/// FFmpeg has, at least 8, at most 16), subsampling rounded to the nearest of 4:2:0, 4:2:2,
/// 4:4:4 that keeps all chroma detail (4:1:1 → 4:2:2, 4:1:0 → 4:2:0, 4:4:0 → 4:4:4); RGB
/// → 4:4:4; grey → 4:2:0 (its chroma is flat anyway).
pub fn source_layout(pixel: Pixel) -> Result<SourceLayout> {
    if let Some((chroma, bit_depth, jpeg)) = layout_of(pixel) {
        return Ok(SourceLayout {
            chroma,
            bit_depth,
            direct: true,
            rgb: false,
            gray: false,
            jpeg,
        });
    }
    let d: PixDesc = ffi::pix_desc(pixel)
        .filter(|d| !d.hwaccel && d.components > 0)
        .ok_or_else(|| Error::Unsupported(format!("pixel format {}", pixel_name(pixel))))?;
    // Palette entries are RGB colours.
    let rgb = d.rgb || d.palette;
    let gray = !rgb && d.components <= 2;
    let chroma = if rgb {
        Chroma::Cs444
    } else if gray {
        Chroma::Cs420
    } else {
        match d.log2_chroma {
            (0, _) => Chroma::Cs444,
            (_, 0) => Chroma::Cs422,
            _ => Chroma::Cs420,
        }
    };
    let bit_depth = match d.depth {
        0..=8 => 8,
        9 => 9,
        10 => 10,
        11 | 12 => 12,
        13 | 14 => 14,
        _ => 16,
    };
    Ok(SourceLayout {
        chroma,
        bit_depth,
        direct: false,
        rgb,
        gray,
        jpeg: false,
    })
}

/// The descriptor facts of a pixel format (depth, subsampling, RGB…).
pub(crate) fn pix_desc(pixel: Pixel) -> Option<PixDesc> {
    ffi::pix_desc(pixel)
}

/// FFmpeg's name of a pixel format (`"yuv420p10le"`).
pub fn pixel_name(pixel: Pixel) -> String {
    pixel
        .descriptor()
        .map(|d| d.name().to_owned())
        .unwrap_or_else(|| format!("{pixel:?}").to_lowercase())
}

/// A swscale context that only changes the sample arrangement (and, for RGB, converts with an
/// explicit matrix). `Send`: an SwsContext has no thread affinity, it is only used by its owner.
pub struct Converter {
    ctx: scaling::Context,
    out: ff::frame::Video,
}

// SAFETY: SwsContext holds no thread-local state; the context is used by one thread at a time
// (it is owned and reached only through `&mut self`).
unsafe impl Send for Converter {}

impl Converter {
    /// A converter between two formats of the same size. `src`/`dst` give the swscale matrix and
    /// full-range flag of each side; pass the same pair to both to keep the numbers unchanged.
    pub fn new(
        from: (Pixel, u32, u32),
        to: (Pixel, u32, u32),
        src: (Matrix, bool),
        dst: (Matrix, bool),
    ) -> Result<Converter> {
        let flags = scaling::Flags::BICUBIC
            | scaling::Flags::ACCURATE_RND
            | scaling::Flags::FULL_CHR_H_INT
            | scaling::Flags::FULL_CHR_H_INP
            | scaling::Flags::BITEXACT;
        let mut ctx = scaling::Context::get(from.0, from.1, from.2, to.0, to.1, to.2, flags)
            .map_err(|_| {
                Error::Unsupported(format!(
                    "pixel format conversion {} → {}",
                    pixel_name(from.0),
                    pixel_name(to.0)
                ))
            })?;
        let ok = ffi::sws_set_colorspace(
            &mut ctx,
            (ffi::sws_colorspace(src.0), src.1),
            (ffi::sws_colorspace(dst.0), dst.1),
        );
        if !ok {
            log::warn!(
                "swscale refused explicit colour details for {} → {}",
                pixel_name(from.0),
                pixel_name(to.0)
            );
        }
        Ok(Converter {
            ctx,
            out: ff::frame::Video::new(to.0, to.1, to.2),
        })
    }

    /// Converts one frame into a frame the caller allocated (and may hand on).
    pub fn run_into(&mut self, input: &ff::frame::Video, out: &mut ff::frame::Video) -> Result<()> {
        self.ctx
            .run(input, out)
            .map_err(Error::ffmpeg("converting the pixel format"))
    }

    /// Converts one frame; the result is borrowed until the next call.
    pub fn run(&mut self, input: &ff::frame::Video) -> Result<&ff::frame::Video> {
        self.ctx
            .run(input, &mut self.out)
            .map_err(Error::ffmpeg("converting the pixel format"))?;
        Ok(&self.out)
    }
}

/// Copies the three planes of an FFmpeg frame in one of our layouts into tightly packed planes
/// (`stride` = [`FrameFormat::packed_stride`]), honouring FFmpeg's line sizes.
pub fn planes_from_av(frame: &ff::frame::Video, format: &FrameFormat) -> [Plane; 3] {
    std::array::from_fn(|i| {
        let (_, h) = format.plane_size(i);
        let row = format.packed_stride(i);
        let stride = frame.stride(i);
        let src = frame.data(i);
        let mut data = Vec::with_capacity(row * h as usize);
        for y in 0..h as usize {
            data.extend_from_slice(&src[y * stride..y * stride + row]);
        }
        Plane { data, stride: row }
    })
}

/// Copies a [`YuvFrame`]'s planes into an allocated FFmpeg frame of the same layout.
pub fn planes_to_av(frame: &YuvFrame, out: &mut ff::frame::Video) -> Result<()> {
    for i in 0..3 {
        let (_, h) = frame.format.plane_size(i);
        let row = frame.format.packed_stride(i);
        let plane = &frame.planes[i];
        let needed = if h == 0 {
            0
        } else {
            plane.stride * (h as usize - 1) + row
        };
        if plane.stride < row || plane.data.len() < needed {
            return Err(Error::Parameter {
                name: "frame",
                value: format!(
                    "plane {i}: {} bytes, stride {}",
                    plane.data.len(),
                    plane.stride
                ),
                expected: format!("{h} rows of at least {row} bytes"),
            });
        }
        let dst_stride = out.stride(i);
        let dst = out.data_mut(i);
        for y in 0..h as usize {
            dst[y * dst_stride..y * dst_stride + row]
                .copy_from_slice(&plane.data[y * plane.stride..y * plane.stride + row]);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts_round_trip_and_aliases_are_full_range() {
        ff::init().unwrap();
        for chroma in [Chroma::Cs420, Chroma::Cs422, Chroma::Cs444] {
            for bit_depth in [8, 9, 10, 12, 14, 16] {
                let f = FrameFormat {
                    width: 2,
                    height: 2,
                    chroma,
                    bit_depth,
                };
                let p = pixel_of(&f).unwrap();
                assert_eq!(layout_of(p), Some((chroma, bit_depth, false)), "{p:?}");
            }
        }
        assert_eq!(layout_of(Pixel::YUVJ420P), Some((Chroma::Cs420, 8, true)));
        assert_eq!(layout_of(Pixel::NV12), None);
        assert_eq!(layout_of(Pixel::YUV420P10BE), None);
    }

    #[test]
    fn nearest_layouts_keep_depth_and_chroma_detail() {
        ff::init().unwrap();
        let l = |p| {
            let s = source_layout(p).unwrap();
            (s.chroma, s.bit_depth, s.direct)
        };
        assert_eq!(l(Pixel::NV12), (Chroma::Cs420, 8, false));
        assert_eq!(l(Pixel::P010LE), (Chroma::Cs420, 10, false));
        assert_eq!(l(Pixel::NV16), (Chroma::Cs422, 8, false));
        assert_eq!(l(Pixel::YUV411P), (Chroma::Cs422, 8, false));
        assert_eq!(l(Pixel::YUV440P), (Chroma::Cs444, 8, false));
        assert_eq!(l(Pixel::GRAY10LE), (Chroma::Cs420, 10, false));
        assert_eq!(l(Pixel::RGB24), (Chroma::Cs444, 8, false));
        assert_eq!(l(Pixel::RGB48LE), (Chroma::Cs444, 16, false));
        assert_eq!(l(Pixel::GBRP10LE), (Chroma::Cs444, 10, false));
        assert_eq!(l(Pixel::YUV420P10BE), (Chroma::Cs420, 10, false));
        assert_eq!(l(Pixel::YUV422P), (Chroma::Cs422, 8, true));
    }

    #[test]
    fn p010_is_unpacked_without_changing_samples() {
        ff::init().unwrap();
        let (w, h) = (8u32, 4u32);
        let mut p010 = ff::frame::Video::new(Pixel::P010LE, w, h);
        let value = |x: usize, y: usize, c: usize| ((x * 37 + y * 101 + c * 7) % 1024) as u16;
        // P010: 10-bit samples in the high bits; chroma interleaved Cb, Cr.
        let s0 = p010.stride(0);
        for y in 0..h as usize {
            for x in 0..w as usize {
                let v = value(x, y, 0) << 6;
                p010.data_mut(0)[y * s0 + 2 * x..][..2].copy_from_slice(&v.to_le_bytes());
            }
        }
        let s1 = p010.stride(1);
        for y in 0..(h / 2) as usize {
            for x in 0..(w / 2) as usize {
                for c in 0..2 {
                    let v = value(x, y, 1 + c) << 6;
                    p010.data_mut(1)[y * s1 + 4 * x + 2 * c..][..2]
                        .copy_from_slice(&v.to_le_bytes());
                }
            }
        }
        let layout = source_layout(Pixel::P010LE).unwrap();
        let format = FrameFormat {
            width: w,
            height: h,
            chroma: layout.chroma,
            bit_depth: layout.bit_depth,
        };
        let c = (Matrix::Bt709, false);
        let mut conv = Converter::new(
            (Pixel::P010LE, w, h),
            (pixel_of(&format).unwrap(), w, h),
            c,
            c,
        )
        .unwrap();
        let planes = planes_from_av(conv.run(&p010).unwrap(), &format);
        let frame = YuvFrame {
            format,
            color: crate::video::ColorParams::bt709(10),
            planes,
            pts: 0,
            index: 0,
        };
        for y in 0..h {
            for x in 0..w {
                assert_eq!(frame.sample(0, x, y), value(x as usize, y as usize, 0));
            }
        }
        for y in 0..h / 2 {
            for x in 0..w / 2 {
                assert_eq!(frame.sample(1, x, y), value(x as usize, y as usize, 1));
                assert_eq!(frame.sample(2, x, y), value(x as usize, y as usize, 2));
            }
        }
    }
}
