//! The library's error type. Each variant's message is one line a user can act on; the binary
//! prints it after `error:` and exits non-zero.

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
    /// The output path already exists and `-y` was not given.
    #[error("output '{}' already exists (use -y to overwrite)", .0.display())]
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
    /// A parameter is outside its valid range.
    #[error("invalid parameter {name} = {value}: {expected}")]
    Parameter {
        /// The option's name as the user types it (`--fov`).
        name: &'static str,
        /// The value given.
        value: String,
        /// What is accepted.
        expected: String,
    },
    /// A configuration file cannot be read or parsed.
    #[error("invalid --config '{path}': {reason}")]
    Config {
        /// The path as the user gave it.
        path: String,
        /// What is wrong, with the line and column for a parse error.
        reason: String,
    },
    /// A `--set key.path=value` names no setting, has the wrong type or is out of range.
    #[error("invalid --set {assignment}: {reason}")]
    Override {
        /// The override as the user gave it.
        assignment: String,
        /// What is wrong, with the keys or range allowed.
        reason: String,
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
