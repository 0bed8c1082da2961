//! Checkpoints of the water: a [`PuddleSim`]'s whole state in a file, so a chunk late in a shot
//! starts from the water a whole render had a few frames earlier instead of simulating it again
//! from the clip's start (the water has memory; the rain has none).
//!
//! A file holds the water after frame `index` was fed, bit for bit (every float as its bits:
//! postcard over the same serde derives as the state, so no field can be forgotten), under a
//! fingerprint of everything the water depends on — the configuration with its keys, the camera,
//! the frame rate, the simulation's settings and this format. Its name carries the fingerprint's
//! hash, so renders with other settings keep their own files side by side and a file is never
//! used for water it does not describe; the full fingerprint inside guards against a hash
//! collision. The settings that change only the picture (the streaks, the light, whether the
//! puddles are shown) are left out, so the simulation pass of `inspect puddles` and the chunks
//! of a render share their files. Files are written to a temporary name and renamed, so chunks
//! running in parallel may race to write the same one; each ends in a hash of the rest, so a
//! damaged file is passed over (and replaced when the water is kept again) instead of
//! silently changing the water.

use std::path::{Path, PathBuf};

use super::PuddleSim;
use crate::{Error, Result};

/// Changes whenever the layout of the state changes, or the solver's settings for the same
/// configuration do (a kept state would go on under the settings it was made with).
pub const FORMAT: u32 = 3;

/// Largest checkpoint read, bytes: the water of the most particles `--puddle-particles` allows
/// takes a few hundred MiB; the bound keeps a wrong file from filling the memory.
pub const MAX_CHECKPOINT_BYTES: u64 = 2 << 30;

/// Bytes of the hash that ends a file.
const HASH_BYTES: usize = 8;

const MAGIC: &[u8; 8] = b"RAINH2O\n";
const EXTENSION: &str = "water";

/// Where and how often a render keeps the water (`--checkpoints DIR`, `--checkpoint-every N`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Checkpoints {
    /// The folder the files go in (created when first written).
    pub dir: PathBuf,
    /// A file after every frame whose index is a multiple of this; 0 reads but writes none.
    pub every_frames: u64,
}

/// FNV-1a, 64 bits: a hash that stays the same across builds and machines (unlike std's).
pub(crate) fn fnv1a(text: &str) -> u64 {
    fnv1a_bytes(text.as_bytes())
}

/// [`fnv1a`] of bytes.
fn fnv1a_bytes(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

impl Checkpoints {
    /// The file of the water after frame `index` under `fingerprint`.
    pub fn path(&self, fingerprint: &str, index: u64) -> PathBuf {
        self.dir.join(format!(
            "{:016x}-{index:08}.{EXTENSION}",
            fnv1a(fingerprint)
        ))
    }

    /// Whether frame `index` is one to keep.
    pub fn keeps(&self, index: u64) -> bool {
        self.every_frames > 0 && index.is_multiple_of(self.every_frames)
    }

    /// Writes the water after frame `index`, unless a sound file for it is already there (a
    /// damaged one is replaced).
    pub fn save(&self, fingerprint: &str, index: u64, sim: &PuddleSim) -> Result<()> {
        let path = self.path(fingerprint, index);
        if path.exists() && sound(&path).is_ok() {
            return Ok(());
        }
        let failed = |reason: String| Error::OutputWrite {
            path: path.display().to_string(),
            reason,
        };
        let mut bytes = MAGIC.to_vec();
        bytes.extend(
            postcard::to_stdvec(&(FORMAT, fingerprint, index, sim))
                .map_err(|e| failed(e.to_string()))?,
        );
        bytes.extend(fnv1a_bytes(&bytes).to_le_bytes());
        if self.dir.exists() && !self.dir.is_dir() {
            return Err(failed(format!("'{}' is not a folder", self.dir.display())));
        }
        std::fs::create_dir_all(&self.dir).map_err(|e| failed(e.to_string()))?;
        let tmp = path.with_extension(format!("{EXTENSION}.{}.tmp", std::process::id()));
        std::fs::write(&tmp, &bytes)
            .and_then(|()| std::fs::rename(&tmp, &path))
            .map_err(|e| {
                let _ = std::fs::remove_file(&tmp);
                failed(e.to_string())
            })
    }

    /// Warns when the folder holds water only under other fingerprints: kept by a render or a
    /// simulation pass with settings that change the water, so this run simulates its own.
    fn warn_of_other_settings(&self, prefix: &str) {
        let others = std::fs::read_dir(&self.dir)
            .into_iter()
            .flatten()
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter(|n| n.ends_with(&format!(".{EXTENSION}")) && !n.starts_with(prefix))
            .count();
        if others > 0 {
            log::warn!(
                "puddles: '{}' holds {others} checkpoints of water simulated with other settings \
                 (rain, ground, camera, relief or particles differ); simulating this water anew",
                self.dir.display()
            );
        }
    }

    /// The water after the latest kept frame at or before `index` under `fingerprint`, with
    /// that frame's index; `None` when there is none. A file that cannot be read or does not
    /// hold this water is passed over with a warning (the water is then simulated instead).
    pub fn latest(&self, fingerprint: &str, index: u64) -> Option<(u64, PuddleSim)> {
        let prefix = format!("{:016x}-", fnv1a(fingerprint));
        let mut kept: Vec<u64> = std::fs::read_dir(&self.dir)
            .ok()?
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter_map(|name| {
                let rest = name.strip_prefix(&prefix)?;
                rest.strip_suffix(&format!(".{EXTENSION}"))?.parse().ok()
            })
            .filter(|&i| i <= index)
            .collect();
        if kept.is_empty() {
            self.warn_of_other_settings(&prefix);
        }
        kept.sort_unstable();
        kept.into_iter().rev().find_map(|i| {
            let path = self.path(fingerprint, i);
            match read(&path, fingerprint, i) {
                Ok(sim) => Some((i, sim)),
                Err(e) => {
                    log::warn!("puddles: checkpoint '{}' not used: {e}", path.display());
                    None
                }
            }
        })
    }
}

/// The body of the checkpoint at `path` (after the magic and the format, without the hash),
/// if it is a regular file of bounded size in this build's format whose hash matches.
fn sound(path: &Path) -> std::result::Result<Vec<u8>, String> {
    let mut bytes = crate::files::read_regular(path, MAX_CHECKPOINT_BYTES)?;
    let body = bytes
        .strip_prefix(MAGIC.as_slice())
        .ok_or("not a water checkpoint")?;
    let (format, _): (u32, _) = postcard::take_from_bytes(body).map_err(|e| e.to_string())?;
    if format != FORMAT {
        return Err(format!("format {format}, this build reads {FORMAT}"));
    }
    let end = bytes
        .len()
        .checked_sub(HASH_BYTES)
        .filter(|&e| e > MAGIC.len())
        .ok_or("damaged: truncated")?;
    let stored = u64::from_le_bytes(bytes[end..].try_into().map_err(|_| "damaged")?);
    if fnv1a_bytes(&bytes[..end]) != stored {
        return Err("damaged: its hash does not match its contents".into());
    }
    bytes.truncate(end);
    bytes.drain(..MAGIC.len());
    Ok(bytes)
}

/// The water in `path`, if the file holds the water of `fingerprint` after frame `index`.
fn read(path: &Path, fingerprint: &str, index: u64) -> std::result::Result<PuddleSim, String> {
    let body = sound(path)?;
    let (_, rest): (u32, _) = postcard::take_from_bytes(&body).map_err(|e| e.to_string())?;
    let (stored, rest): (String, _) = postcard::take_from_bytes(rest).map_err(|e| e.to_string())?;
    if stored != fingerprint {
        return Err("made with other settings".into());
    }
    let (at, rest): (u64, _) = postcard::take_from_bytes(rest).map_err(|e| e.to_string())?;
    if at != index {
        return Err(format!("holds frame {at}, named for frame {index}"));
    }
    let (sim, rest): (PuddleSim, _) =
        postcard::take_from_bytes(rest).map_err(|e| format!("damaged: {e}"))?;
    if !rest.is_empty() {
        return Err("damaged: bytes after the state".into());
    }
    Ok(sim)
}

/// Everything the water of a render depends on, as text: two renders whose fingerprints are
/// equal simulate the same water frame for frame. The settings of the picture alone are left
/// out (see the module's documentation).
pub fn fingerprint(
    config: &crate::config::RenderConfig,
    camera: &crate::scene::Camera,
    fps: f64,
    settings: &super::PuddleSettings,
) -> String {
    let mut water = config.to_value();
    if let Some(tree) = water.as_object_mut() {
        tree.remove("light");
        tree.remove("streak_db");
        // How the motion was found: what it found is in the keyframes, which stay.
        tree.remove("camera_motion");
    }
    // Where the sky and the ground are drawn changes the picture, not the water.
    for (section, key) in [
        ("ground", "puddles"),
        ("ground", "sky"),
        ("ground", "mask"),
        ("rain", "streaks"),
    ] {
        if let Some(s) = water.get_mut(section).and_then(|s| s.as_object_mut()) {
            s.remove(key);
        }
    }
    format!(
        "rain-composite {} water format {FORMAT}\nconfig {water}\ncamera {camera:?}\nfps \
         {fps:?}\nsettings {settings:?}",
        env!("CARGO_PKG_VERSION"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hash_is_fnv1a() {
        // The published FNV-1a 64 test vectors.
        assert_eq!(fnv1a(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a("a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a("foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn frames_are_kept_at_multiples() {
        let c = Checkpoints {
            dir: PathBuf::from("x"),
            every_frames: 12,
        };
        assert!(c.keeps(0) && c.keeps(24) && !c.keeps(13));
        let none = Checkpoints {
            every_frames: 0,
            ..c
        };
        assert!(!none.keeps(0) && !none.keeps(12));
    }
}
