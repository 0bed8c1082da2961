//! What we know about an input before rendering: the frame layout and colour the source
//! yields, timing, rotation, and every stream with what the output will do with it.

use ffmpeg_next::{self as ff, Rational, color};
use serde::{Serialize, Serializer};

use super::{ColorParams, FrameFormat, Matrix, Transfer};

/// The four colour tags as FFmpeg names them, written on the output unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ColorTags {
    /// YCbCr matrix (`color_space` in ffprobe).
    pub matrix: color::Space,
    /// Sample range (`color_range`).
    pub range: color::Range,
    /// Colour primaries (`color_primaries`).
    pub primaries: color::Primaries,
    /// Transfer characteristic (`color_transfer`).
    pub transfer: color::TransferCharacteristic,
}

impl ColorTags {
    /// All four unspecified.
    pub fn unspecified() -> ColorTags {
        ColorTags {
            matrix: color::Space::Unspecified,
            range: color::Range::Unspecified,
            primaries: color::Primaries::Unspecified,
            transfer: color::TransferCharacteristic::Unspecified,
        }
    }

    /// The tags as ffprobe prints them (`"bt709"`, `"tv"`, …; `"unknown"` when unspecified).
    pub fn names(&self) -> [&'static str; 4] {
        [
            self.matrix.name().unwrap_or("unknown"),
            self.range.name().unwrap_or("unknown"),
            self.primaries.name().unwrap_or("unknown"),
            self.transfer.name().unwrap_or("unknown"),
        ]
    }
}

impl Serialize for ColorTags {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let [matrix, range, primaries, transfer] = self.names();
        let mut st = s.serialize_struct("ColorTags", 4)?;
        st.serialize_field("matrix", matrix)?;
        st.serialize_field("range", range)?;
        st.serialize_field("primaries", primaries)?;
        st.serialize_field("transfer", transfer)?;
        st.end()
    }
}

/// The numerical interpretation of a YUV source's tags. Unspecified tags follow the players'
/// heuristic: BT.709 at heights ≥ 720, else BT.601; limited range unless the format is a
/// `yuvj*` one (or grey, which FFmpeg treats as full range); BT.709 transfer.
pub fn color_params(
    tags: &ColorTags,
    height: u32,
    bit_depth: u8,
    full_range_alias: bool,
) -> ColorParams {
    use color::Space as S;
    use color::TransferCharacteristic as T;
    let heuristic = if height >= 720 {
        Matrix::Bt709
    } else {
        Matrix::Bt601
    };
    let matrix = match tags.matrix {
        S::BT709 => Matrix::Bt709,
        S::BT470BG | S::SMPTE170M => Matrix::Bt601,
        S::BT2020NCL => Matrix::Bt2020Ncl,
        S::SMPTE240M => Matrix::Smpte240m,
        S::FCC => Matrix::Fcc,
        S::RGB | S::Unspecified | S::Reserved => heuristic,
        S::BT2020CL => {
            log::warn!("BT.2020 constant-luminance matrix treated as non-constant luminance");
            Matrix::Bt2020Ncl
        }
        other => {
            log::warn!("colour matrix {other:?} is not supported; treating it as {heuristic:?}");
            heuristic
        }
    };
    let transfer = match tags.transfer {
        T::IEC61966_2_1 => Transfer::Srgb,
        T::GAMMA22 => Transfer::Gamma22,
        T::GAMMA28 => Transfer::Gamma28,
        T::Linear => Transfer::Linear,
        T::SMPTE2084 => Transfer::Pq,
        T::ARIB_STD_B67 => Transfer::Hlg,
        T::BT709
        | T::SMPTE170M
        | T::BT2020_10
        | T::BT2020_12
        | T::SMPTE240M
        | T::BT1361_ECG
        | T::IEC61966_2_4
        | T::Unspecified
        | T::Reserved
        | T::Reserved0 => Transfer::Bt709,
        other => {
            log::warn!("transfer {other:?} is not supported; treating it as BT.709");
            Transfer::Bt709
        }
    };
    let full_range = match tags.range {
        color::Range::JPEG => true,
        color::Range::MPEG => false,
        color::Range::Unspecified => full_range_alias,
    };
    ColorParams {
        matrix,
        full_range,
        transfer,
        bit_depth,
    }
}

/// What kind of data a stream carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StreamKind {
    /// Pictures.
    Video,
    /// Sound.
    Audio,
    /// Subtitles.
    Subtitle,
    /// Timed data (timecode, telemetry…).
    Data,
    /// Attached files (fonts).
    Attachment,
    /// Anything else.
    Unknown,
}

impl From<ff::media::Type> for StreamKind {
    fn from(t: ff::media::Type) -> StreamKind {
        match t {
            ff::media::Type::Video => StreamKind::Video,
            ff::media::Type::Audio => StreamKind::Audio,
            ff::media::Type::Subtitle => StreamKind::Subtitle,
            ff::media::Type::Data => StreamKind::Data,
            ff::media::Type::Attachment => StreamKind::Attachment,
            _ => StreamKind::Unknown,
        }
    }
}

/// What the output does with an input stream.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case", tag = "action", content = "reason")]
pub enum StreamAction {
    /// The rendered video: decoded, rained on, encoded.
    Render,
    /// Packets copied bit for bit.
    Copy,
    /// Audio the output container cannot hold: decoded and re-encoded as AAC.
    TranscodeAac,
    /// Not written; the reason says why.
    Drop(String),
}

/// The codec parameters of an input stream, kept so the output can copy or transcode it.
/// `Sync` so a `VideoInfo` can be shared between threads.
pub struct CodecParams(pub(crate) ff::codec::Parameters);

// SAFETY: the wrapped parameters are an owned copy (`Parameters::clone` allocates a fresh
// AVCodecParameters) that is never mutated after construction; shared references only read it.
unsafe impl Sync for CodecParams {}

impl Clone for CodecParams {
    fn clone(&self) -> Self {
        CodecParams(self.0.clone())
    }
}

impl std::fmt::Debug for CodecParams {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "CodecParams({:?})", self.0.id())
    }
}

/// One input stream.
#[derive(Debug, Clone, Serialize)]
pub struct StreamInfo {
    /// Index in the input container.
    pub index: usize,
    /// Video, audio, subtitle…
    pub kind: StreamKind,
    /// FFmpeg's codec name (`"aac"`, `"pcm_s16le"`, `"h264"`).
    pub codec: String,
    /// A short human description (`"48000 Hz, 2 channels, fltp"`).
    pub details: String,
    /// Time base of the stream's timestamps.
    pub time_base: (i32, i32),
    /// First timestamp in `time_base` (`None` if the container does not say).
    pub start_pts: Option<i64>,
    /// The stream's tags (language, title, handler…).
    pub metadata: Vec<(String, String)>,
    /// What the output will do with it, once planned for an output container
    /// ([`super::plan_streams`]); `None` straight from [`super::Source::open`].
    pub action: Option<StreamAction>,
    #[serde(skip)]
    pub(crate) params: CodecParams,
    #[serde(skip)]
    pub(crate) disposition: i32,
}

/// Everything the pipeline needs to know about the input.
#[derive(Debug, Clone, Serialize)]
pub struct VideoInfo {
    /// Layout of the frames the source yields (coded size, before display rotation).
    pub format: FrameFormat,
    /// Numerical colour interpretation of those frames (unspecified tags resolved by heuristic).
    pub color: ColorParams,
    /// The tags written on the output. Equal to the input's, except: a `yuvj*` source with no
    /// range tag gets `pc` (its frames are full range), and an RGB source gets BT.709 matrix and
    /// `pc` range (its frames were converted with them, see [`super::RGB_SOURCE_COLOR`]) and,
    /// where untagged, BT.709 primaries and the sRGB transfer that `color` assumes.
    pub tags: ColorTags,
    /// Display rotation in degrees, normalised into {0, 90, 180, 270}: counter-clockwise, the
    /// convention of `av_display_rotation_get` and of ffprobe's side-data `rotation` field
    /// (a phone video shot in portrait typically reads 90 or 270). Frames stay in coded
    /// orientation; render the rain rotated by this angle.
    pub rotation_deg: i32,
    /// The raw display matrix (16.16 / 2.30 fixed point, as FFmpeg stores it), written back on
    /// the output as it is (flips included).
    pub display_matrix: Option<[i32; 9]>,
    /// Shape of one pixel (width : height); (0, 1) or (1, 1) for square pixels.
    pub sample_aspect_ratio: (i32, i32),
    /// Time base of the video stream: frame `pts` × `time_base` = seconds.
    pub time_base: (i32, i32),
    /// FFmpeg's `r_frame_rate` (the base rate; for VFR the finest common rate).
    pub frame_rate: (i32, i32),
    /// Average frame rate (frames / duration).
    pub avg_frame_rate: (i32, i32),
    /// pts of the first frame the source yields, in `time_base` (stream start time if no frame
    /// has been decoded; 0 if unknown). `seek_to_time(t)` counts `t` from here.
    pub start_pts: i64,
    /// Duration in seconds, from the stream or the container.
    pub duration_s: Option<f64>,
    /// Number of frames, when the container states it (MP4/MOV do, Matroska does not).
    pub frame_count: Option<u64>,
    /// The frame intervals are not constant (from the first few hundred timestamps, and from
    /// `r_frame_rate` ≠ `avg_frame_rate`).
    pub variable_frame_rate: bool,
    /// Video codec (`"h264"`).
    pub codec_name: String,
    /// Container (FFmpeg demuxer name, `"mov,mp4,m4a,3gp,3g2,mj2"`).
    pub container: String,
    /// The decoder's pixel format (`"yuvj420p"`, `"nv12"`), before any conversion.
    pub pixel_format: String,
    /// Index of the rendered video stream.
    pub video_stream: usize,
    /// Container tags (title, creation_time, …), copied to the output.
    pub metadata: Vec<(String, String)>,
    /// Every stream of the input, the video included.
    pub streams: Vec<StreamInfo>,
}

impl VideoInfo {
    /// Seconds per tick of `time_base`.
    pub fn seconds_per_tick(&self) -> f64 {
        self.time_base.0 as f64 / self.time_base.1 as f64
    }

    /// The frame rate to assume for constant-rate needs (y4m output, index arithmetic):
    /// `r_frame_rate` when set, else the average.
    pub fn nominal_fps(&self) -> (i32, i32) {
        let valid = |r: (i32, i32)| r.0 > 0 && r.1 > 0;
        if valid(self.frame_rate) {
            self.frame_rate
        } else if valid(self.avg_frame_rate) {
            self.avg_frame_rate
        } else {
            (25, 1)
        }
    }

    /// The stream with input index `index`.
    pub fn stream(&self, index: usize) -> Option<&StreamInfo> {
        self.streams.iter().find(|s| s.index == index)
    }
}

/// A rational as a plain pair.
pub(crate) fn pair(r: Rational) -> (i32, i32) {
    (r.numerator(), r.denominator())
}

/// Rotation (counter-clockwise degrees) from a display matrix, as `av_display_rotation_get`
/// computes it, rounded to the nearest quarter turn and normalised into 0..360.
pub fn rotation_from_matrix(m: &[i32; 9]) -> i32 {
    let fp = |v: i32| v as f64 / 65536.0;
    let scale0 = fp(m[0]).hypot(fp(m[3]));
    let scale1 = fp(m[1]).hypot(fp(m[4]));
    if scale0 == 0.0 || scale1 == 0.0 {
        return 0;
    }
    let deg = -(fp(m[1]) / scale1).atan2(fp(m[0]) / scale0).to_degrees();
    let quarter = (deg / 90.0).round() as i32;
    (quarter * 90).rem_euclid(360)
}

/// Reads the display matrix of a stream's side data.
pub(crate) fn display_matrix(stream: &ff::format::stream::Stream) -> Option<[i32; 9]> {
    stream
        .side_data()
        .find(|sd| sd.kind() == ff::codec::packet::side_data::Type::DisplayMatrix)
        .and_then(|sd| {
            let d = sd.data();
            (d.len() >= 36).then(|| {
                std::array::from_fn(|i| {
                    i32::from_ne_bytes([d[4 * i], d[4 * i + 1], d[4 * i + 2], d[4 * i + 3]])
                })
            })
        })
}

/// A dictionary as owned pairs.
pub(crate) fn dict_pairs(d: &ff::DictionaryRef) -> Vec<(String, String)> {
    d.iter()
        .map(|(k, v)| (k.to_owned(), v.to_owned()))
        .collect()
}

/// Describes a stream for humans and builds its [`StreamInfo`] (action left unplanned).
pub(crate) fn stream_info(stream: &ff::format::stream::Stream) -> StreamInfo {
    let params = stream.parameters();
    let kind = StreamKind::from(params.medium());
    let id = params.id();
    let codec = if id == ff::codec::Id::None {
        "none".to_owned()
    } else {
        id.name().to_owned()
    };
    let details = ff::codec::Context::from_parameters(stream.parameters())
        .ok()
        .map(|ctx| {
            let dec = ctx.decoder();
            match kind {
                StreamKind::Audio => dec
                    .audio()
                    .map(|a| {
                        format!(
                            "{} Hz, {} channels, {}",
                            a.rate(),
                            a.channels(),
                            a.format().name()
                        )
                    })
                    .unwrap_or_default(),
                StreamKind::Video => dec
                    .video()
                    .map(|v| {
                        format!(
                            "{}x{}, {}",
                            v.width(),
                            v.height(),
                            super::pixfmt::pixel_name(v.format())
                        )
                    })
                    .unwrap_or_default(),
                _ => String::new(),
            }
        })
        .unwrap_or_default();
    let start = stream.start_time();
    StreamInfo {
        index: stream.index(),
        kind,
        codec,
        details,
        time_base: pair(stream.time_base()),
        start_pts: (start != ff::ffi::AV_NOPTS_VALUE).then_some(start),
        metadata: dict_pairs(&stream.metadata()),
        action: None,
        params: CodecParams(params.clone()),
        disposition: super::ffi::disposition(stream),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_follows_av_display_rotation_get() {
        // The matrix the MP4 muxer writes for `rotate=90` (read back by ffprobe as 90).
        let m = [0, -65536, 0, 65536, 0, 0, 0, 0, 1 << 30];
        assert_eq!(rotation_from_matrix(&m), 90);
        let m = [0, 65536, 0, -65536, 0, 0, 0, 0, 1 << 30];
        assert_eq!(rotation_from_matrix(&m), 270);
        let m = [-65536, 0, 0, 0, -65536, 0, 0, 0, 1 << 30];
        assert_eq!(rotation_from_matrix(&m), 180);
        let m = [65536, 0, 0, 0, 65536, 0, 0, 0, 1 << 30];
        assert_eq!(rotation_from_matrix(&m), 0);
    }

    #[test]
    fn unspecified_tags_follow_the_height_heuristic() {
        let t = ColorTags::unspecified();
        assert_eq!(color_params(&t, 1080, 8, false).matrix, Matrix::Bt709);
        assert_eq!(color_params(&t, 480, 8, false).matrix, Matrix::Bt601);
        assert!(!color_params(&t, 480, 8, false).full_range);
        assert!(color_params(&t, 480, 8, true).full_range);
    }
}
