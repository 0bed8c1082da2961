//! `inspect light`: what the lighting makes of one still standing for a video frame — the
//! recovered light sources, the SH of the extended remainder, and the radiance of a drop seen
//! through a grid of pixel positions, with and without recovery.
//!
//! The drop radiance is what the renderer gives a drop at the camera: the remainder's PRT
//! ([`prt_colour`]) plus the sources' direct term through the exact RTF table
//! ([`direct_colour`]), linear RGB in the frame's own units (1.0 = the frame's white). "Without
//! recovery" is the frame taken as it is (the SH of the clipped frame, no sources).

use std::path::Path;

use glam::DVec2;
use serde_json::{Value, json};

use super::envmap::{EnvMapper, EnvironmentSh};
use super::frame_light::{GPU_BANDS, LightConfig, recovery_settings};
use super::inspect::{LinearImage, linear_to_srgb, srgb_to_linear};
use super::prt::{RtfSh, prt_colour};
use super::recovery::{BlockStats, ClipLevel, Region, recover};
use super::sources::{LightSource, direct_colour};
use crate::scene::Camera;
use crate::{Error, Result};

/// Everything `inspect light` reports.
#[derive(Debug, Clone)]
pub struct LightReport {
    /// Recovered compact sources, brightest first.
    pub lights: Vec<LightSource>,
    /// The clipped regions found.
    pub regions: Vec<Region>,
    /// SH of the extended remainder (after recovery).
    pub env: EnvironmentSh,
    /// SH of the frame as it is.
    pub env_without_recovery: EnvironmentSh,
    /// Grid size (columns, rows).
    pub grid: (usize, usize),
    /// Pixel positions of the grid, row by row from the top left.
    pub positions_px: Vec<[f64; 2]>,
    /// Drop radiance along each grid ray, with recovery.
    pub drop_radiance: Vec<[f64; 3]>,
    /// Drop radiance along each grid ray, the frame taken as it is.
    pub drop_radiance_without_recovery: Vec<[f64; 3]>,
    /// Per pixel (row-major, the image's size): the 1-based index of its clipped region in
    /// `regions`, 0 where the pixel is not clipped.
    pub labels: Vec<u16>,
}

/// The light of `image` (an sRGB still, decoded to linear) seen through `camera`, and the drop
/// radiance on an `grid.0 × grid.1` grid of view rays through pixel positions
/// `((i + ½) W/N, (j + ½) H/M)`.
pub fn light_report(
    image: &LinearImage,
    camera: &Camera,
    grid: (usize, usize),
    config: &LightConfig,
) -> Result<LightReport> {
    if image.width != camera.width_px as usize || image.height != camera.height_px as usize {
        return Err(Error::Parameter {
            name: "camera",
            value: format!("{}x{}", camera.width_px, camera.height_px),
            expected: format!("the image's size, {}x{}", image.width, image.height),
        });
    }
    if grid.0 == 0 || grid.1 == 0 || grid.0 * grid.1 > 1 << 20 {
        return Err(Error::Parameter {
            name: "inspect.light.grid",
            value: format!("{}x{}", grid.0, grid.1),
            expected: "NxM with N, M ≥ 1 (at most 2^20 rays)".into(),
        });
    }
    let settings = recovery_settings(config)?;
    let mapper = EnvMapper::new(camera, GPU_BANDS)?;
    let clip = ClipLevel::from_eotf(|e| f64::from(srgb_to_linear(e as f32)), 255.0);
    let w = image.width;
    let stats = BlockStats::build(
        (image.width, image.height),
        mapper.block_px(),
        None,
        clip,
        |x, y| image.pixels[y * w + x].map(f64::from),
    );
    let env_without_recovery = mapper.project_small(&stats.mean);
    let (env, lights, regions, block_region) = match settings {
        Some(s) => {
            let r = recover(&stats, camera, &s);
            (
                mapper.project_small(&r.remainder),
                r.lights,
                r.regions,
                r.block_region,
            )
        }
        None => (
            env_without_recovery.clone(),
            Vec::new(),
            Vec::new(),
            vec![0; stats.mean.len()],
        ),
    };
    // A pixel belongs to the region of its block where one of its channels is clipped.
    let labels = image
        .pixels
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let clipped = (0..3).any(|k| f64::from(p[k]) >= clip.threshold[k]);
            let b = (i / w) / stats.block_px * stats.width + (i % w) / stats.block_px;
            if clipped {
                block_region[b].min(u32::from(u16::MAX)) as u16
            } else {
                0
            }
        })
        .collect();
    let rtf = RtfSh::water(config.refractive_index, config.n_max, GPU_BANDS)?;
    let tables = rtf_tables(config)?;
    let (n, m) = grid;
    let mut positions_px = Vec::with_capacity(n * m);
    let mut drop_radiance = Vec::with_capacity(n * m);
    let mut without = Vec::with_capacity(n * m);
    for j in 0..m {
        for i in 0..n {
            let p = DVec2::new(
                (i as f64 + 0.5) * image.width as f64 / n as f64,
                (j as f64 + 0.5) * image.height as f64 / m as f64,
            );
            let v = camera.ray_world(p);
            let sh = prt_colour(&env, &rtf, v);
            let direct = direct_colour(&lights, &tables, None, v);
            positions_px.push(p.to_array());
            drop_radiance.push([0, 1, 2].map(|k| sh[k] + direct[k]));
            without.push(prt_colour(&env_without_recovery, &rtf, v));
        }
    }
    Ok(LightReport {
        lights,
        regions,
        env,
        env_without_recovery,
        grid,
        positions_px,
        drop_radiance,
        drop_radiance_without_recovery: without,
        labels,
    })
}

pub use super::frame_light::rtf_tables;

/// The report as JSON.
pub fn inspect_light(report: &LightReport, camera: &Camera) -> Value {
    let lights: Vec<Value> = report
        .lights
        .iter()
        .map(|l| {
            let c = camera.world_from_camera.transpose() * l.direction_world;
            let px = camera.project_camera(c).map(|p| p.to_array().to_vec());
            json!({
                "direction_world": l.direction_world.to_array(),
                "azimuth_deg": c.x.atan2(c.z).to_degrees(),
                "elevation_deg": (-c.y).atan2(c.x.hypot(c.z)).to_degrees(),
                "pixel": px,
                "solid_angle_sr": l.solid_angle_sr,
                "radiance_rgb": l.radiance_rgb,
                "radiance_times_solid_angle_rgb": l.radiance_times_solid_angle(),
                "distance_m": l.distance_m,
            })
        })
        .collect();
    json!({
        "conventions": "world z up; a level camera looks along +y; azimuth and elevation from the camera's view direction, right and up positive; radiance linear RGB in frame units (1.0 = the frame's white); drop radiance = SH remainder PRT + direct term of the lights through the RTF table, for a drop at the camera seen through each grid position, row by row from the top left",
        "width": camera.width_px,
        "height": camera.height_px,
        "fov_deg": camera.fov_x_rad.to_degrees(),
        "lights": lights,
        "regions": report.regions,
        "sh_remainder": report.env.coeffs_f64(),
        "sh_without_recovery": report.env_without_recovery.coeffs_f64(),
        "grid": [report.grid.0, report.grid.1],
        "positions_px": report.positions_px,
        "drop_radiance": report.drop_radiance,
        "drop_radiance_without_recovery": report.drop_radiance_without_recovery,
    })
}

/// The frame (sRGB) with each light ringed at its clipped solid angle (at least 6 px) and
/// crossed, compact regions' rings in red, extended regions' centroids in cyan, grid positions as
/// yellow dots.
pub fn plot_light(
    image: &LinearImage,
    camera: &Camera,
    report: &LightReport,
    path: &Path,
) -> Result<()> {
    let (w, h) = (image.width, image.height);
    let mut px: Vec<[u8; 3]> = image
        .pixels
        .iter()
        .map(|p| p.map(|v| (linear_to_srgb(v) * 255.0).round() as u8))
        .collect();
    let mut put = |x: f64, y: f64, c: [u8; 3]| {
        if x >= 0.0 && y >= 0.0 && (x as usize) < w && (y as usize) < h {
            px[y as usize * w + x as usize] = c;
        }
    };
    let f = camera.focal_px();
    for l in &report.lights {
        let c = camera.world_from_camera.transpose() * l.direction_world;
        let Some(p) = camera.project_camera(c) else {
            continue;
        };
        let r = (f * (l.solid_angle_sr / std::f64::consts::PI).sqrt()).max(6.0);
        let steps = (2.0 * std::f64::consts::PI * r).ceil() as usize * 2;
        for s in 0..steps {
            let a = 2.0 * std::f64::consts::PI * s as f64 / steps as f64;
            for dr in [0.0, 1.0] {
                put(
                    p.x + (r + dr) * a.cos(),
                    p.y + (r + dr) * a.sin(),
                    [255, 40, 40],
                );
            }
        }
        for d in -(2.0 * r) as i64..=(2.0 * r) as i64 {
            if (d as f64).abs() > 1.2 * r {
                put(p.x + d as f64, p.y, [255, 40, 40]);
                put(p.x, p.y + d as f64, [255, 40, 40]);
            }
        }
    }
    for reg in &report.regions {
        if !reg.light {
            let [x, y] = reg.centre_px;
            for d in -5..=5 {
                put(x + d as f64, y, [40, 230, 230]);
                put(x, y + d as f64, [40, 230, 230]);
            }
        }
    }
    for p in &report.positions_px {
        for dy in -1..=1 {
            for dx in -1..=1 {
                put(p[0] + dx as f64, p[1] + dy as f64, [250, 220, 30]);
            }
        }
    }
    let bytes: Vec<u8> = px.into_iter().flatten().collect();
    let fail = |reason: String| Error::OutputWrite {
        path: path.display().to_string(),
        reason,
    };
    let img = image::RgbImage::from_raw(w as u32, h as u32, bytes)
        .ok_or_else(|| fail("bad canvas size".into()))?;
    crate::files::save_png(&img, path)
}

/// Writes the report's region labels as a 16-bit greyscale PNG of the image's size: each pixel
/// the 1-based index of its region in the JSON's `regions`, 0 where nothing is clipped; atomic,
/// as every output (an existing file is replaced only by a complete one).
pub fn write_labels(report: &LightReport, size: (usize, usize), path: &Path) -> Result<()> {
    let fail = |reason: String| Error::OutputWrite {
        path: path.display().to_string(),
        reason,
    };
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(
        size.0 as u32,
        size.1 as u32,
        report.labels.clone(),
    )
    .ok_or_else(|| fail("the labels do not match the image's size".into()))?;
    let mut png = std::io::Cursor::new(Vec::new());
    img.write_to(&mut png, image::ImageFormat::Png)
        .map_err(|e| fail(e.to_string()))?;
    crate::files::write_atomic(path, png.get_ref())
}
