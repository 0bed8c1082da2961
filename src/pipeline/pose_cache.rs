//! The camera's estimated motion kept on disk beside the water's checkpoints, so that
//! `camera_motion auto` reads a clip once: the first preview or render of a clip runs the
//! pre-pass over the whole clip and keeps what it found; later previews, chunks and renders of
//! the same file under the same first camera read it back in a moment.
//!
//! An estimate is a pure function of the decoded frames and the first camera, so the key is
//! the file (its canonical path, size and modification time: a clip written again is read
//! again), the first camera (picture size, field of view, tilt, roll) and this program's
//! version (a later estimator may read the frames otherwise). The file is a pose file (its
//! `frames` and `shots`, as `inspect camera --json` writes them) with the key beside them; one
//! whose key differs, or that cannot be read, is passed over and estimated anew. A cache that
//! cannot be written costs the next preview the pre-pass, not this one its frame: a warning.

use std::path::{Path, PathBuf};
use std::time::UNIX_EPOCH;

use serde::{Deserialize, Serialize};

use crate::scene::Camera;
use crate::scene::motion::Estimate;

/// Bumped when the estimator reads the same frames otherwise within one program version.
const FORMAT: u32 = 1;

/// A kept estimate.
#[derive(Serialize, Deserialize)]
struct Kept {
    key: String,
    #[serde(flatten)]
    estimate: Estimate,
}

/// What an estimate of `input` seen first by `first` depends on; `None` for what is not a
/// regular file (a stream is never kept).
pub fn key(input: &str, first: &Camera) -> Option<String> {
    let path = std::fs::canonicalize(input).ok()?;
    let meta = std::fs::metadata(&path).ok().filter(|m| m.is_file())?;
    let modified = meta.modified().ok()?.duration_since(UNIX_EPOCH).ok()?;
    let (pan, tilt, roll) = crate::scene::motion::pan_tilt_roll(first.world_from_camera);
    Some(format!(
        "rain-composite {} poses {FORMAT}\ninput {} {} bytes modified {}.{:09}\ncamera {}x{} \
         fov {:.12} pan {:.12} tilt {:.12} roll {:.12}",
        env!("CARGO_PKG_VERSION"),
        path.display(),
        meta.len(),
        modified.as_secs(),
        modified.subsec_nanos(),
        first.width_px,
        first.height_px,
        first.fov_x_rad,
        pan,
        tilt,
        roll
    ))
}

/// The file an estimate under `key` is kept in, in `dir`.
pub fn path(dir: &Path, key: &str) -> PathBuf {
    dir.join(format!(
        "poses-{:016x}.json",
        crate::fluid::puddles::checkpoint::fnv1a(key)
    ))
}

/// The estimate kept in `dir` under `key`, if one is there and whole.
pub fn load(dir: &Path, key: &str) -> Option<Estimate> {
    let bytes = std::fs::read(path(dir, key)).ok()?;
    let kept: Kept = serde_json::from_slice(&bytes).ok()?;
    (kept.key == key && kept.estimate.track.check().is_ok()).then_some(kept.estimate)
}

/// Keeps `estimate` in `dir` under `key` (written whole, then renamed into place); a failure
/// is a warning.
pub fn store(dir: &Path, key: &str, estimate: &Estimate) {
    let file = path(dir, key);
    let tmp = file.with_extension(format!("json.{}.tmp", std::process::id()));
    let kept = Kept {
        key: key.to_string(),
        estimate: estimate.clone(),
    };
    let written = std::fs::create_dir_all(dir)
        .and_then(|()| {
            let text = serde_json::to_vec(&kept).map_err(std::io::Error::other)?;
            std::fs::write(&tmp, text)
        })
        .and_then(|()| std::fs::rename(&tmp, &file));
    match written {
        Ok(()) => log::info!("camera motion: kept in {}", file.display()),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            log::warn!(
                "camera motion: the estimate was not kept in {}: {e} (the next preview reads the \
                 clip again)",
                dir.display()
            );
        }
    }
}
