//! The library's error type. Each variant's message is one line a user can act on; the binary
//! prints it after `error:` and exits non-zero.
//!
//! Messages name settings by their keys (`camera.fov_deg`, as `config --print` shows them and
//! `--set` takes them), never by a command line's flags: the binary shows each key as the flag
//! that sets it, by its one table of keys and flags.

use std::path::PathBuf;

/// Everything the library can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The input could not be opened or read.
    #[error("cannot open input '{path}': {reason}")]
    InputOpen {
        /// The path as the user gave it (`-` for stdin).
        path: String,
        /// FFmpeg's or the OS's reason.
        reason: String,
    },
    /// The input holds no video stream.
    #[error("'{0}' has no video stream")]
    NoVideo(String),
    /// The input stream is damaged beyond recovery.
    #[error("the input is truncated or corrupt: {0}")]
    CorruptInput(String),
    /// The output path already exists and overwriting was not allowed
    /// ([`EncodeOptions::overwrite`](crate::video::EncodeOptions::overwrite)).
    #[error("output '{}' already exists (allow overwriting to replace it)", .0.display())]
    OutputExists(PathBuf),
    /// The output names the input file: writing it would destroy the input.
    #[error("output '{output}' is the input '{input}': write to another file")]
    OutputIsInput {
        /// The input as the user gave it.
        input: String,
        /// The output as the user gave it.
        output: String,
    },
    /// The output cannot be created or written.
    #[error("cannot write output '{path}': {reason}")]
    OutputWrite {
        /// The path as the user gave it (`-` for stdout).
        path: String,
        /// The reason.
        reason: String,
    },
    /// A setting is outside its valid range.
    #[error("invalid setting {name} = {value}: {expected}")]
    Parameter {
        /// The setting's key, as `config --print` shows it and `--set` takes it
        /// (`camera.fov_deg`). A value that is no setting of
        /// [`RenderConfig`](crate::config::RenderConfig) has a key in the same dotted style:
        /// `encode.crf`, `job.frames`, `inspect.rtf.bins`, `volume.alpha_min`. The command
        /// line shows the flag of the key instead, where it has one.
        name: &'static str,
        /// The value given.
        value: String,
        /// What is accepted; other settings it names are named by their keys.
        expected: String,
    },
    /// A configuration file cannot be read or parsed.
    #[error("invalid configuration '{path}': {reason}")]
    Config {
        /// The path as the user gave it.
        path: String,
        /// What is wrong, with the line and column for a parse error.
        reason: String,
    },
    /// An override `key.path=value` names no setting or has the wrong type.
    #[error("invalid override {assignment}: {reason}")]
    Override {
        /// The override as the user gave it.
        assignment: String,
        /// What is wrong, with the keys or types allowed.
        reason: String,
    },
    /// An override `key.path=value` leaves a setting out of range: its own value, or a value
    /// of another setting it conflicts with (see [`crate::preset::validate_layered`]).
    #[error("invalid override {assignment}: {}", override_range(*.own, .name, .value, .expected))]
    OverrideRange {
        /// The override as the user gave it.
        assignment: String,
        /// The key of the setting out of range (as [`Error::Parameter`]'s `name`).
        name: &'static str,
        /// Its value.
        value: String,
        /// What is accepted.
        expected: String,
        /// Whether the override's own value is out of range; otherwise it conflicts with
        /// `name`'s `value`.
        own: bool,
    },
    /// The input uses a pixel format, codec or feature we cannot handle.
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// An FFmpeg call failed.
    #[error("{context}: {source}")]
    Ffmpeg {
        /// What we were doing.
        context: String,
        /// FFmpeg's error.
        #[source]
        source: ffmpeg_next::Error,
    },
    /// No usable GPU adapter, or the device was lost.
    #[error("GPU: {0}")]
    Gpu(String),
    /// A seek or frame request outside the clip.
    #[error("{0}")]
    OutOfRange(String),
    /// The encoding thread ended early; the job reports the encoder's own error instead.
    #[error("the encoder stopped")]
    EncoderStopped,
    /// The job was interrupted (Ctrl-C).
    #[error("interrupted")]
    Interrupted,
    /// Plain I/O.
    #[error("{context}: {source}")]
    Io {
        /// What we were doing.
        context: String,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
}

/// [`Error::OverrideRange`]'s reason.
fn override_range(own: bool, name: &str, value: &str, expected: &str) -> String {
    if own {
        format!("{value} is out of range: {expected} (the range of {name})")
    } else {
        format!("conflicts with {name} {value}: {expected}")
    }
}

/// `Ok` when `ok` holds and `value` is finite; otherwise the [`Error::Parameter`] naming the
/// setting `name` (its key) and what is `expected`.
pub(crate) fn check(name: &'static str, value: f64, ok: bool, expected: &str) -> Result<()> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(Error::Parameter {
            name,
            value: value.to_string(),
            expected: expected.to_string(),
        })
    }
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// Wraps an FFmpeg error with what we were doing when it happened.
    pub fn ffmpeg(context: impl Into<String>) -> impl FnOnce(ffmpeg_next::Error) -> Error {
        let context = context.into();
        move |source| Error::Ffmpeg { context, source }
    }

    /// Wraps an I/O error with what we were doing when it happened.
    pub fn io(context: impl Into<String>) -> impl FnOnce(std::io::Error) -> Error {
        let context = context.into();
        move |source| Error::Io { context, source }
    }
}
