//! Files the user names: read only when regular and within a size bound, written through a
//! temporary name beside them.
//!
//! A FIFO would block the read forever and a device such as `/dev/zero` (or a link to one)
//! would fill the memory, so anything but a regular file is refused before it is opened. An
//! output is written under a hidden name in its folder and renamed when complete, so a failed
//! write never truncates or half-writes the file it replaces; [`output`] holds that temporary
//! file and the checks every output (video or PNG) passes before any work is done.

pub mod output;

use std::path::Path;

pub use output::{TempFile, check_output, same_file, temp_path};

use crate::{Error, Result};

/// The bytes of the regular file at `path` (links followed), at most `max_bytes` of them; the
/// error is one line saying why not.
pub fn read_regular(path: &Path, max_bytes: u64) -> std::result::Result<Vec<u8>, String> {
    use std::io::Read;
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err("not a regular file".into());
    }
    let too_big = || format!("larger than {}", size_text(max_bytes));
    if meta.len() > max_bytes {
        return Err(too_big());
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    std::fs::File::open(path)
        .and_then(|f| f.take(max_bytes + 1).read_to_end(&mut bytes))
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_big());
    }
    Ok(bytes)
}

/// `bytes` as "N MiB" (or "N GiB" from 1 GiB), for messages.
fn size_text(bytes: u64) -> String {
    if bytes >= 1 << 30 {
        format!("{} GiB", bytes >> 30)
    } else {
        format!("{} MiB", bytes >> 20)
    }
}

/// Writes `bytes` to `path` through a hidden temporary file beside it: the file at `path` is
/// replaced only when the new one is complete, and left as it was on any failure.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = TempFile::beside(path);
    std::fs::write(tmp.path(), bytes).map_err(|e| Error::OutputWrite {
        path: path.display().to_string(),
        reason: e.to_string(),
    })?;
    tmp.publish()
}

/// Refuses a PNG output (a report's plot or sheet) that could not be written: a name not
/// ending in `.png`, a directory, or a path in a missing folder. Checked before the work, so a
/// mistake costs nothing and leaves any existing file as it is.
pub fn check_png_output(path: &Path) -> Result<()> {
    let is_png = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if !is_png && !path.is_dir() {
        return Err(Error::OutputWrite {
            path: path.display().to_string(),
            reason: "plots are PNG: give a name ending in .png".into(),
        });
    }
    check_output(&path.to_string_lossy(), &[], true)
}

/// Encodes `img` as PNG (whatever the name's extension) and writes it to `path` atomically.
pub fn save_png(img: &image::RgbImage, path: &Path) -> Result<()> {
    let mut png = std::io::Cursor::new(Vec::new());
    img.write_to(&mut png, image::ImageFormat::Png)
        .map_err(|e| Error::OutputWrite {
            path: path.display().to_string(),
            reason: e.to_string(),
        })?;
    write_atomic(path, png.get_ref())
}

/// Largest PNG read (an image standing for a frame, a depth map), bytes.
pub const MAX_PNG_BYTES: u64 = 256 << 20;

/// Largest side of a PNG decoded, pixels.
pub const MAX_PNG_SIDE: u32 = 16_384;

/// Most memory a PNG's decoding may take, bytes: a 16-bit RGBA picture of 8192² pixels.
const MAX_PNG_ALLOC: u64 = 8192 * 8192 * 8;

/// The PNG at `path`, a regular file of at most [`MAX_PNG_BYTES`], decoded within
/// [`MAX_PNG_SIDE`] pixels a side and a bounded allocation (the header is read before the
/// pixels, so a huge picture is refused without decoding it). Other formats are refused by
/// their content, whatever the name says.
pub fn read_png(path: &Path) -> std::result::Result<image::DynamicImage, String> {
    let bytes = read_regular(path, MAX_PNG_BYTES)?;
    if !bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        return Err("not a PNG image".into());
    }
    let mut reader = image::ImageReader::with_format(
        std::io::Cursor::new(bytes.as_slice()),
        image::ImageFormat::Png,
    );
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_PNG_SIDE);
    limits.max_image_height = Some(MAX_PNG_SIDE);
    limits.max_alloc = Some(MAX_PNG_ALLOC);
    reader.limits(limits);
    reader.decode().map_err(|e| match e {
        image::ImageError::Limits(_) => format!(
            "too large: at most {MAX_PNG_SIDE} pixels a side and {} MiB decoded",
            MAX_PNG_ALLOC >> 20
        ),
        e => e.to_string(),
    })
}
