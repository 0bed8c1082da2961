//! Where the sink writes until it finishes: a hidden file beside the output, or for an image
//! sequence (PNG, OpenEXR) a hidden directory whose images are moved beside the output pattern
//! at the end.
//! Whatever happens before [`publish`], the temporary output is removed and the output's path is
//! left as it was.

use std::path::{Path, PathBuf};

use ffmpeg_next as ff;

use super::options::EncodeOptions;
use crate::files::temp_path;
use crate::video::Layer;
use crate::video::ffi;
use crate::{Error, Result};

/// The hidden temporary file beside `output`, or for an image sequence the hidden directory
/// (whose name must not read as a second frame-number pattern).
fn sink_temp_path(output: &str, sequence: bool) -> PathBuf {
    let t = temp_path(Path::new(output));
    if !sequence {
        return t;
    }
    let name = t.file_name().unwrap_or_default().to_string_lossy();
    t.with_file_name(name.replace('%', "_"))
}

/// Removes a temporary output: a file, or an image sequence's directory.
pub(super) fn discard(temp: &Path) {
    if temp.is_dir() {
        let _ = std::fs::remove_dir_all(temp);
    } else {
        let _ = std::fs::remove_file(temp);
    }
}

/// Creates the hidden directory an image sequence named like `output` is written into.
pub(super) fn sequence_dir(output: &str) -> Result<PathBuf> {
    let dir = sink_temp_path(output, true);
    std::fs::create_dir(&dir).map_err(|e| Error::OutputWrite {
        path: output.to_owned(),
        reason: e.to_string(),
    })?;
    Ok(dir)
}

/// The output context of a sink being created, and its temporary output, removed if
/// `Sink::create` fails half-way.
pub(super) struct TempGuard {
    octx: Option<ff::format::context::Output>,
    temp: Option<PathBuf>,
}

impl TempGuard {
    /// Opens `muxer` on a temporary output beside `output` (stdout for `"-"`); an image sequence
    /// gets a temporary directory, its images named like `output`.
    pub(super) fn open(output: &str, muxer: &str, sequence: bool) -> Result<TempGuard> {
        let write_err = |reason: String| Error::OutputWrite {
            path: output.to_owned(),
            reason,
        };
        let temp = (output != "-").then(|| sink_temp_path(output, sequence));
        let url = match &temp {
            Some(t) if sequence => {
                std::fs::create_dir(t).map_err(|e| write_err(e.to_string()))?;
                let name = Path::new(output).file_name().unwrap_or_default();
                t.join(name).to_string_lossy().into_owned()
            }
            Some(t) => t.to_string_lossy().into_owned(),
            None => "pipe:1".to_owned(),
        };
        // From here on the temporary output may exist: the guard removes it on any error.
        let mut guard = TempGuard { octx: None, temp };
        guard.octx =
            Some(ff::format::output_as(&url, muxer).map_err(|e| write_err(e.to_string()))?);
        Ok(guard)
    }

    /// The output context.
    pub(super) fn octx(&mut self) -> &mut ff::format::context::Output {
        self.octx.as_mut().expect("set by open")
    }

    /// Hands the context and the temporary output over to the sink, which now removes it.
    pub(super) fn disarm(mut self) -> (ff::format::context::Output, Option<PathBuf>) {
        let octx = self.octx.take().expect("set by open");
        (octx, self.temp.take())
    }
}

impl Drop for TempGuard {
    fn drop(&mut self) {
        drop(self.octx.take());
        if let Some(temp) = &self.temp {
            discard(temp);
        }
    }
}

/// Refuses an image sequence (PNG, OpenEXR) that could not be written: a layer is required
/// (images hold R'G'B'A layers only), the name needs a frame-number pattern, and an existing
/// first image needs `overwrite`.
pub(super) fn check_sequence(output: &str, opts: &EncodeOptions) -> Result<()> {
    if !opts.layer.is_some_and(Layer::is_rgba) {
        return Err(Error::Parameter {
            name: "job.output",
            value: output.to_owned(),
            expected: "a video file; image sequences are written for encode.layer or encode.matte"
                .into(),
        });
    }
    let name = Path::new(output)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = Path::new(output)
        .extension()
        .map_or("png".into(), |e| e.to_string_lossy().to_ascii_lowercase());
    let Some(first) = ffi::sequence_file_name(&name, 1) else {
        return Err(Error::Parameter {
            name: "job.output",
            value: output.to_owned(),
            expected: format!(
                "an image-sequence name with a frame number pattern, e.g. out_%05d.{ext}"
            ),
        });
    };
    // FFmpeg formats the number in a buffer of 19 digits: a wider pattern names every image
    // alike, and each would overwrite the last.
    if ffi::sequence_file_name(&name, 2).as_deref() == Some(first.as_str()) {
        return Err(Error::Parameter {
            name: "job.output",
            value: output.to_owned(),
            expected: format!("a frame number pattern of at most 19 digits, e.g. out_%05d.{ext}"),
        });
    }
    let first = Path::new(output).with_file_name(first);
    if first.exists() && !opts.overwrite {
        return Err(Error::OutputExists(first));
    }
    Ok(())
}

/// Moves a finished temporary output onto `output`: renames a file, or moves each image of a
/// sequence's directory beside the output pattern and removes the directory. The images are
/// numbered by source frame (frame `first_index` is image `first_index + 1`), so the chunks of
/// a shot write their own images of one sequence and never each other's.
pub(super) fn publish(temp: &Path, output: &str, first_index: u64) -> std::io::Result<()> {
    if !temp.is_dir() {
        return std::fs::rename(temp, output);
    }
    let dir = match Path::new(output).parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    // The file named like the pattern itself is the I/O context opened with the muxer; the
    // image2 muxer writes each image to a file of its own and leaves that one empty.
    let pattern = Path::new(output).file_name().unwrap_or_default();
    let text = pattern.to_string_lossy();
    let name = |number: u64| {
        i32::try_from(number)
            .ok()
            .and_then(|n| ffi::sequence_file_name(&text, n))
            .ok_or_else(|| std::io::Error::other(format!("no image name for frame {number}")))
    };
    // The muxer numbers the images it writes from 1.
    for k in 1.. {
        let written = temp.join(name(k)?);
        if !written.exists() {
            break;
        }
        std::fs::rename(written, dir.join(name(first_index + k)?))?;
    }
    std::fs::remove_file(temp.join(pattern)).or_else(|e| match e.kind() {
        std::io::ErrorKind::NotFound => Ok(()),
        _ => Err(e),
    })?;
    std::fs::remove_dir(temp)
}
