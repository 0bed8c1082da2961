//! Depth maps: metres per pixel, with holes.
//!
//! Read from a 16-bit greyscale PNG in millimetres (the format depth cameras and most
//! monocular-depth tools write); `--depth-scale` multiplies the values (a relative depth map
//! becomes metres with the right factor). A zero sample, a NaN or an infinity is **unknown**,
//! never "at the camera". Resampling to the video's size is bilinear over the known neighbours
//! only, so a hole neither spreads nor drags its neighbours toward zero.
//!
//! The render reads depth through a [`DepthSource`]: one map for the whole clip, a directory of
//! PNGs (one per frame, in name order), or a 16-bit greyscale video whose codes are millimetres
//! (frame i of the clip takes frame i of the depth video). Drops behind the scene are hidden
//! (`shaders/rain_streaks.wgsl`).

use std::path::{Path, PathBuf};

use crate::{Error, Result};

/// Depth in metres per pixel, row-major; `NaN` where unknown.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthMap {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Metres, `NaN` = unknown.
    pub depth_m: Vec<f32>,
}

/// Largest side of a depth map read, pixels (a bound on memory for a wrong file).
pub const MAX_DEPTH_SIDE: u32 = 16_384;

impl DepthMap {
    /// A map from raw values times `scale_m` (metres per unit); 0, NaN, infinities and negative
    /// values become unknown.
    pub fn from_values(
        width: usize,
        height: usize,
        values: &[f32],
        scale_m: f64,
    ) -> Result<DepthMap> {
        if width == 0 || height == 0 || values.len() != width * height {
            return Err(Error::Parameter {
                name: "ground.depth",
                value: format!("{width}x{height} with {} samples", values.len()),
                expected: "a non-empty map of width × height samples".into(),
            });
        }
        let depth_m = values
            .iter()
            .map(|&v| {
                let m = v as f64 * scale_m;
                if m.is_finite() && m > 0.0 {
                    m as f32
                } else {
                    f32::NAN
                }
            })
            .collect();
        Ok(DepthMap {
            width,
            height,
            depth_m,
        })
    }

    /// Reads a 16-bit greyscale PNG in millimetres, times `depth_scale` (a regular file of
    /// bounded size, see [`crate::files::read_png`]).
    pub fn load_png(path: &Path, depth_scale: f64) -> Result<DepthMap> {
        let fail = |reason: String| Error::InputOpen {
            path: path.display().to_string(),
            reason,
        };
        check_scale(depth_scale)?;
        let img = crate::files::read_png(path).map_err(fail)?;
        if img.width() > MAX_DEPTH_SIDE || img.height() > MAX_DEPTH_SIDE {
            return Err(fail(format!("larger than {MAX_DEPTH_SIDE} pixels a side")));
        }
        // An 8-bit map would be read as millimetres × 257 (its codes stretched to 16 bits): a
        // silent scale no one means, so only the documented format is taken.
        if img.color() != image::ColorType::L16 {
            return Err(fail(format!(
                "a depth map is a 16-bit greyscale PNG in millimetres, this one is {}",
                color_name(img.color())
            )));
        }
        let grey = img.to_luma16();
        let values: Vec<f32> = grey.pixels().map(|p| p.0[0] as f32).collect();
        DepthMap::from_values(
            grey.width() as usize,
            grey.height() as usize,
            &values,
            depth_scale / 1000.0,
        )
    }

    /// Depth at pixel (x, y), metres; `None` where unknown.
    pub fn at(&self, x: usize, y: usize) -> Option<f32> {
        let v = self.depth_m[y * self.width + x];
        v.is_finite().then_some(v)
    }

    /// The map resampled to `width`×`height` (pixel centres aligned, as a picture scales):
    /// bilinear over the known neighbours, weights renormalised; unknown where all four are.
    pub fn resampled(&self, width: usize, height: usize) -> DepthMap {
        if (width, height) == (self.width, self.height) {
            return self.clone();
        }
        let sx = self.width as f64 / width as f64;
        let sy = self.height as f64 / height as f64;
        let mut out = Vec::with_capacity(width * height);
        for y in 0..height {
            let fy = ((y as f64 + 0.5) * sy - 0.5).clamp(0.0, (self.height - 1) as f64);
            let y0 = fy.floor() as usize;
            let y1 = (y0 + 1).min(self.height - 1);
            let ty = fy - y0 as f64;
            for x in 0..width {
                let fx = ((x as f64 + 0.5) * sx - 0.5).clamp(0.0, (self.width - 1) as f64);
                let x0 = fx.floor() as usize;
                let x1 = (x0 + 1).min(self.width - 1);
                let tx = fx - x0 as f64;
                let (mut sum, mut wsum) = (0.0, 0.0);
                for (xx, yy, w) in [
                    (x0, y0, (1.0 - tx) * (1.0 - ty)),
                    (x1, y0, tx * (1.0 - ty)),
                    (x0, y1, (1.0 - tx) * ty),
                    (x1, y1, tx * ty),
                ] {
                    if let Some(d) = self.at(xx, yy).filter(|_| w > 0.0) {
                        sum += w * d as f64;
                        wsum += w;
                    }
                }
                out.push(if wsum > 1e-12 {
                    (sum / wsum) as f32
                } else {
                    f32::NAN
                });
            }
        }
        DepthMap {
            width,
            height,
            depth_m: out,
        }
    }

    /// Fraction of the pixels whose depth is known.
    pub fn known_fraction(&self) -> f64 {
        self.depth_m.iter().filter(|v| v.is_finite()).count() as f64 / self.depth_m.len() as f64
    }
}

/// How a PNG's pixel layout is named in messages.
fn color_name(c: image::ColorType) -> String {
    use image::ColorType::*;
    match c {
        L8 => "8-bit greyscale".into(),
        La8 | La16 => "greyscale with alpha".into(),
        Rgb8 | Rgba8 => "8-bit colour".into(),
        Rgb16 | Rgba16 => "16-bit colour".into(),
        c => format!("{c:?}"),
    }
}

/// Checks `ground.depth_scale`: metres per millimetre of the file, relative; (0, 1000000].
pub fn check_scale(depth_scale: f64) -> Result<()> {
    if depth_scale.is_finite() && depth_scale > 0.0 && depth_scale <= 1e6 {
        Ok(())
    } else {
        Err(Error::Parameter {
            name: "ground.depth_scale",
            value: depth_scale.to_string(),
            expected: "a factor in (0, 1000000] on the file's millimetres".into(),
        })
    }
}

/// Where a render's depth comes from, read in the clip's frame order.
pub enum DepthSource {
    /// One map for the whole clip.
    Still(DepthMap),
    /// One PNG per frame, in name order.
    Frames {
        /// The maps' paths.
        paths: Vec<PathBuf>,
        /// `--depth-scale`.
        scale: f64,
    },
    /// A greyscale video, its codes millimetres at 16 bits.
    Video {
        /// The decoder.
        source: Box<crate::video::Source>,
        /// The index of the frame `next_frame` returns.
        next: u64,
        /// `--depth-scale`.
        scale: f64,
    },
}

impl std::fmt::Debug for DepthSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DepthSource::Still(m) => write!(f, "one {}x{} depth map", m.width, m.height),
            DepthSource::Frames { paths, .. } => write!(f, "{} depth maps", paths.len()),
            DepthSource::Video { .. } => write!(f, "a depth video"),
        }
    }
}

impl DepthSource {
    /// Opens `path` (a PNG, a directory of PNGs or a video) with `--depth-scale` `scale`, checking
    /// what can be checked before the render starts: the scale, that the file or the first of
    /// the directory's maps reads as a greyscale depth map, that a video opens.
    pub fn open(path: &Path, scale: f64) -> Result<DepthSource> {
        check_scale(scale)?;
        let fail = |reason: String| Error::InputOpen {
            path: path.display().to_string(),
            reason,
        };
        let meta = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
        if meta.is_dir() {
            let mut paths: Vec<PathBuf> = std::fs::read_dir(path)
                .map_err(|e| fail(e.to_string()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x.eq_ignore_ascii_case("png")))
                .collect();
            paths.sort();
            let Some(first) = paths.first() else {
                return Err(fail("a directory of depth maps holds no .png file".into()));
            };
            DepthMap::load_png(first, scale)?;
            return Ok(DepthSource::Frames { paths, scale });
        }
        // A FIFO or a device would block the read or never end.
        if !meta.is_file() {
            return Err(fail("not a regular file or a directory".into()));
        }
        let is_png = path
            .extension()
            .is_some_and(|x| x.eq_ignore_ascii_case("png"));
        if is_png {
            return Ok(DepthSource::Still(DepthMap::load_png(path, scale)?));
        }
        let source = crate::video::Source::open(&path.display().to_string())?;
        // Any other video (the clip itself, 8-bit or colour) would be read as depth on a scale
        // no one means.
        let pixel = &source.info().pixel_format;
        if !pixel.starts_with("gray16") {
            return Err(fail(format!(
                "a depth video is 16-bit greyscale in millimetres (e.g. FFV1 gray16le), this \
                 one is {pixel}"
            )));
        }
        Ok(DepthSource::Video {
            source: Box::new(source),
            next: 0,
            scale,
        })
    }

    /// Maps known ahead: 1 for a still, one per PNG, the video's count where known.
    pub fn frame_count(&self) -> Option<u64> {
        match self {
            DepthSource::Still(_) => None,
            DepthSource::Frames { paths, .. } => Some(paths.len() as u64),
            DepthSource::Video { source, .. } => source.info().frame_count,
        }
    }

    /// The depth of the clip's frame `index` (a still serves every frame). Reading in order is
    /// cheapest; a video seeks otherwise.
    pub fn at(&mut self, index: u64) -> Result<std::borrow::Cow<'_, DepthMap>> {
        use std::borrow::Cow;
        let missing = |count: u64| {
            Error::OutOfRange(format!(
                "ground.depth has {count} depth maps, the clip has a frame {index} (counting from 0)"
            ))
        };
        match self {
            DepthSource::Still(m) => Ok(Cow::Borrowed(m)),
            DepthSource::Frames { paths, scale } => {
                let path = paths
                    .get(index as usize)
                    .ok_or_else(|| missing(paths.len() as u64))?;
                Ok(Cow::Owned(DepthMap::load_png(path, *scale)?))
            }
            DepthSource::Video {
                source,
                next,
                scale,
            } => {
                let frame = if index == *next {
                    source.next_frame()?.ok_or_else(|| missing(index))?
                } else {
                    source.frame_at_index(index)?
                };
                *next = index + 1;
                Ok(Cow::Owned(depth_of_frame(&frame, *scale)?))
            }
        }
    }
}

/// The depth in a decoded greyscale frame: its luma code, as a fraction of the full 16-bit
/// range, is millimetres (times `scale`).
fn depth_of_frame(frame: &crate::video::YuvFrame, scale: f64) -> Result<DepthMap> {
    let r = frame.color.range_scale();
    let (w, h) = (frame.format.width, frame.format.height);
    let values: Vec<f32> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| ((frame.sample(0, x, y) as f64 - r.y_offset) / r.y_scale * 65535.0) as f32)
        .collect();
    DepthMap::from_values(w as usize, h as usize, &values, scale / 1000.0)
}
