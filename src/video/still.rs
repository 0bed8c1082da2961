//! A frame as a PNG still (preview, README images): code values → R'G'B' with the frame's own
//! matrix and range, turned to the displayed orientation. The transfer is left as encoded,
//! as players show it (an HDR frame stays PQ/HLG-encoded in the PNG).

use std::path::Path;

use super::YuvFrame;
use super::color::ycbcr_to_rgb;
use crate::{Error, Result};

/// Displayed-orientation R'G'B' of `frame`, 16 bits per channel, row-major.
pub fn to_rgb16(frame: &YuvFrame, rotation_deg: i32) -> (u32, u32, Vec<u16>) {
    let f = &frame.format;
    let (sx, sy) = f.chroma.shift();
    let s = frame.color.range_scale();
    let rotation = rotation_deg.rem_euclid(360);
    let (w, h) = super::frame::display_size(rotation, f.width, f.height);
    let mut out = vec![0u16; (w * h * 3) as usize];
    for y in 0..h {
        for x in 0..w {
            // Display (x, y) ← coded (cx, cy); see video::frame::coded_from_display.
            let (cx, cy) = super::frame::coded_pixel(rotation, f.width, f.height, x, y);
            let code = [
                frame.sample(0, cx, cy) as f64,
                frame.sample(1, cx >> sx, cy >> sy) as f64,
                frame.sample(2, cx >> sx, cy >> sy) as f64,
            ];
            let ycc = [
                (code[0] - s.y_offset) / s.y_scale,
                (code[1] - s.c_offset) / s.c_scale,
                (code[2] - s.c_offset) / s.c_scale,
            ];
            let rgb = ycbcr_to_rgb(frame.color.matrix, ycc);
            let at = ((y * w + x) * 3) as usize;
            for k in 0..3 {
                out[at + k] = (rgb[k].clamp(0.0, 1.0) * 65535.0).round() as u16;
            }
        }
    }
    (w, h, out)
}

/// `frame` encoded as an 8- or 16-bit PNG, in display orientation.
pub fn encode_png(frame: &YuvFrame, rotation_deg: i32, bits: u8) -> Result<Vec<u8>> {
    let (w, h, rgb) = to_rgb16(frame, rotation_deg);
    let mut png = std::io::Cursor::new(Vec::new());
    let fail = |e: image::ImageError| Error::Unsupported(format!("encoding the PNG: {e}"));
    if bits == 16 {
        let img = image::ImageBuffer::<image::Rgb<u16>, _>::from_raw(w, h, rgb)
            .ok_or_else(|| Error::Unsupported("picture size".into()))?;
        img.write_to(&mut png, image::ImageFormat::Png)
            .map_err(fail)?;
    } else {
        let bytes: Vec<u8> = rgb
            .iter()
            .map(|&v| ((v as u32 * 255 + 32767) / 65535) as u8)
            .collect();
        let img = image::RgbImage::from_raw(w, h, bytes)
            .ok_or_else(|| Error::Unsupported("picture size".into()))?;
        img.write_to(&mut png, image::ImageFormat::Png)
            .map_err(fail)?;
    }
    Ok(png.into_inner())
}

/// Writes `frame` as an 8- or 16-bit PNG at `path`.
pub fn write_png(frame: &YuvFrame, rotation_deg: i32, bits: u8, path: &Path) -> Result<()> {
    let png = encode_png(frame, rotation_deg, bits)?;
    std::fs::write(path, png).map_err(|e| Error::OutputWrite {
        path: path.display().to_string(),
        reason: e.to_string(),
    })
}
