//! `inspect sky`: the open sky the haze finds in a frame of a clip (`scene::sky`), and its
//! mask as a picture.

use std::path::Path;

use serde_json::{Value, json};

use crate::gpu::stages::yuv_to_rgb::GLOW_CELL_PX;
use crate::scene::sky::{SkyGrid, TopEdge, detect};
use crate::video::Source;
use crate::video::frame::coded_pixel;
use crate::{Error, Result};

/// The sky of the frame of `input` at `at_s` (no ground: the horizon does not bound it): the
/// share of the displayed picture taken as sky and the mask's grid; with `mask`, the weight of
/// each displayed pixel as the haze reads it, as an 8-bit greyscale PNG (255 = sky).
pub fn report(input: &str, at_s: f64, mask: Option<&Path>) -> Result<Value> {
    let mut source = Source::open(input)?;
    let rot = source.info().rotation_deg;
    let frame = source.seek_to_time(at_s)?;
    let f = frame.format;
    let grid = SkyGrid::new(GLOW_CELL_PX, (f.width, f.height));
    let top = TopEdge::of_rotation(rot, (f.width, f.height));
    let t0 = std::time::Instant::now();
    let weights = detect(&frame, grid, top, None);
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    let (dw, dh) = if rot.rem_euclid(180) == 90 {
        (f.height, f.width)
    } else {
        (f.width, f.height)
    };
    let shown: Vec<u8> = (0..dh)
        .flat_map(|y| (0..dw).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (cx, cy) = coded_pixel(rot, f.width, f.height, x, y);
            (grid.weight_at(&weights, cx, cy).clamp(0.0, 1.0) * 255.0).round() as u8
        })
        .collect();
    let sky = shown.iter().filter(|&&v| v >= 128).count();
    if let Some(path) = mask {
        let img = image::GrayImage::from_raw(dw, dh, shown)
            .ok_or_else(|| Error::Unsupported("an empty picture".into()))?;
        let rgb = image::DynamicImage::ImageLuma8(img).to_rgb8();
        crate::files::save_png(&rgb, path)?;
    }
    Ok(json!({
        "frame_size": [dw, dh],
        "sky_share": sky as f64 / (f64::from(dw) * f64::from(dh)).max(1.0),
        "grid": { "cell_px": grid.cell_px, "points": [grid.width, grid.height] },
        "top_edge": format!("{top:?}").to_lowercase(),
        "detect_ms": ms,
    }))
}
