//! Where an output may go, checked before any work is done, and the hidden temporary file it is
//! written to first.
//!
//! Every output (video or PNG) is written beside its final path under a hidden temporary name
//! and renamed only when complete, so a failed or interrupted job leaves nothing behind and
//! never a half-written file. The checks here run before decoding starts, so a user mistake
//! (an output that is a directory, that is the input itself, or that lies in a missing
//! directory) costs nothing.

use std::path::{Path, PathBuf};

use crate::{Error, Result};

/// Longest file name most file systems accept, in bytes (ext4, XFS, APFS, NTFS in UTF-16 units).
const NAME_MAX_BYTES: usize = 255;

/// Refuses an output that cannot be written or must not be: an existing file without
/// `overwrite`, a directory, a path in a missing directory, or any of `inputs` itself (also
/// through hard or symbolic links). `"-"` (stdout) always passes.
pub fn check_output(output: &str, inputs: &[&str], overwrite: bool) -> Result<()> {
    if output == "-" {
        return Ok(());
    }
    let path = Path::new(output);
    let refuse = |reason: &str| Error::OutputWrite {
        path: output.to_owned(),
        reason: reason.to_owned(),
    };
    if output.is_empty() {
        return Err(refuse("the path is empty"));
    }
    if path.is_dir() || output.ends_with('/') {
        return Err(refuse("it is a directory; give a file name"));
    }
    if let Some(input) = inputs
        .iter()
        .find(|i| **i != "-" && same_file(Path::new(i), path))
    {
        return Err(Error::OutputIsInput {
            input: (*input).to_owned(),
            output: output.to_owned(),
        });
    }
    if path.exists() && !overwrite {
        return Err(Error::OutputExists(PathBuf::from(output)));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(refuse(&format!(
            "the directory '{}' does not exist",
            dir.display()
        )));
    }
    Ok(())
}

/// Whether `a` and `b` name the same existing file (device and inode on Unix, so hard links
/// and symbolic links count; the canonical path elsewhere).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (std::fs::metadata(a), std::fs::metadata(b)) {
            (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        match (a.canonicalize(), b.canonicalize()) {
            (Ok(x), Ok(y)) => x == y,
            _ => false,
        }
    }
}

/// `.name.rain-<pid>-<n>.ext` in the output's directory: hidden, on the same file system (so
/// the final rename is atomic), keeping the extension. The stem is shortened (on a character
/// boundary) so the name stays within the file system's limit even when the output's own name
/// is at that limit.
pub fn temp_path(output: &Path) -> PathBuf {
    use std::sync::atomic::{AtomicU32, Ordering};
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    let mut ext = output
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let tag = format!(".rain-{}-{n}", std::process::id());
    if 1 + tag.len() + ext.len() > NAME_MAX_BYTES / 2 {
        // An absurd extension: keep the name valid, not the extension.
        ext.clear();
    }
    let room = NAME_MAX_BYTES - 1 - tag.len() - ext.len();
    let mut cut = stem.len().min(room);
    while !stem.is_char_boundary(cut) {
        cut -= 1;
    }
    let name = format!(".{}{tag}{ext}", &stem[..cut]);
    match output.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.join(name),
        _ => PathBuf::from(name),
    }
}

/// A temporary file that is removed unless [`TempFile::publish`] renames it onto its output.
#[derive(Debug)]
pub struct TempFile {
    temp: PathBuf,
    output: PathBuf,
    published: bool,
}

impl TempFile {
    /// A temporary name beside `output` (nothing is created yet).
    pub fn beside(output: &Path) -> TempFile {
        TempFile {
            temp: temp_path(output),
            output: output.to_owned(),
            published: false,
        }
    }

    /// The path to write to.
    pub fn path(&self) -> &Path {
        &self.temp
    }

    /// Renames the finished file onto the output.
    pub fn publish(mut self) -> Result<()> {
        std::fs::rename(&self.temp, &self.output).map_err(|e| Error::OutputWrite {
            path: self.output.display().to_string(),
            reason: format!("renaming the finished temporary file: {e}"),
        })?;
        self.published = true;
        Ok(())
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.published {
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temp_name_fits_at_the_name_limit() {
        for stem_len in [1, 100, 240, 250, 251] {
            for ext in ["mp4", "mov", ""] {
                let stem = "é".repeat(stem_len / 2) + &"a".repeat(stem_len % 2);
                let name = if ext.is_empty() {
                    stem.clone()
                } else {
                    format!("{stem}.{ext}")
                };
                let t = temp_path(Path::new("dir").join(&name).as_path());
                let file = t.file_name().unwrap().to_string_lossy().into_owned();
                assert!(file.len() <= NAME_MAX_BYTES, "{} bytes", file.len());
                assert!(file.starts_with('.'));
                if !ext.is_empty() {
                    assert!(file.ends_with(&format!(".{ext}")), "{file}");
                }
                assert_eq!(t.parent(), Some(Path::new("dir")));
            }
        }
    }

    #[test]
    fn output_that_is_the_input_is_refused_through_links() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("a.mp4");
        std::fs::write(&input, b"x").unwrap();
        let hard = dir.path().join("hard.mp4");
        std::fs::hard_link(&input, &hard).unwrap();
        let s = |p: &Path| p.to_string_lossy().into_owned();
        let inp = s(&input);
        for out in [
            s(&input),
            s(&hard),
            format!("{}/./a.mp4", dir.path().display()),
        ] {
            let err = check_output(&out, &[&inp], true).unwrap_err();
            assert!(matches!(err, Error::OutputIsInput { .. }), "{err}");
        }
        #[cfg(unix)]
        {
            let soft = dir.path().join("soft.mp4");
            std::os::unix::fs::symlink(&input, &soft).unwrap();
            assert!(check_output(&s(&soft), &[&inp], true).is_err());
        }
        let other = s(&dir.path().join("b.mp4"));
        check_output(&other, &[&inp], false).unwrap();
        assert!(check_output(&s(dir.path()), &[&inp], true).is_err());
        let missing = s(&dir.path().join("no/such/dir/b.mp4"));
        assert!(check_output(&missing, &[&inp], true).is_err());
    }
}
