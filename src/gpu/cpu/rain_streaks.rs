//! The CPU twin of the `rain_streaks` stage: each streak's quad rasterised over the canvas in
//! drop order, the exact time-averaged coverage of [`coverage`] at each pixel centre, the
//! radiance interpolated along the quad as the vertex stage does, blended premultiplied
//! (src + dst·(1 − α)); with a depth map of the displayed picture, each pixel's alpha times the
//! drop's [`visibility`] in front of the scene there.

use glam::DVec2;

pub use super::rain_simulate::coverage;
use crate::gpu::types::{RainParams, Streak};

/// Half a pixel of margin around each quad (`AA_MARGIN_PX` in the WGSL).
pub const AA_MARGIN_PX: f64 = 0.5;

/// Depth over which a drop passing behind the scene fades out, metres (`OCCLUSION_SOFTNESS_M`
/// in the WGSL): a few centimetres, so depth edges are soft and a drop touching a surface does
/// not flicker.
pub const OCCLUSION_SOFTNESS_M: f64 = 0.05;

/// How much of a drop at depth `drop_m` shows in front of a scene at depth `scene_m` (both
/// camera z, metres): a smoothstep over [`OCCLUSION_SOFTNESS_M`] centred on the surface; 1
/// where the scene's depth is unknown (`None`).
pub fn visibility(scene_m: Option<f64>, drop_m: f64) -> f64 {
    let Some(scene_m) = scene_m else { return 1.0 };
    let x = ((scene_m - drop_m) / OCCLUSION_SOFTNESS_M + 0.5).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// The drop's depth (camera z, m) `along` px down a streak of `len_px` whose ends lie at
/// `depth_m`: 1/z is affine in the picture along a projected segment.
pub fn drop_depth_m(along: f64, len_px: f64, depth_m: [f64; 2]) -> f64 {
    let t = if len_px >= 1e-3 {
        (along / len_px).clamp(0.0, 1.0)
    } else {
        0.0
    };
    1.0 / ((1.0 - t) / depth_m[0] + t / depth_m[1])
}

/// Blends `streaks` over `canvas` (linear RGB, row-major, the coded picture of
/// `p.coded_size_px`), with `p`'s display rotation.
pub fn rain_streaks(canvas: &mut [[f64; 3]], p: &RainParams, streaks: &[Streak]) {
    rain_streaks_occluded(canvas, p, streaks, None);
}

/// [`rain_streaks`] behind the scene of `depth` (metres per displayed pixel, the size of
/// `p.display_size_px`; `None` = unknown).
pub fn rain_streaks_occluded(
    canvas: &mut [[f64; 3]],
    p: &RainParams,
    streaks: &[Streak],
    depth: Option<&crate::scene::DepthMap>,
) {
    let (w, h) = (p.coded_size_px[0] as u32, p.coded_size_px[1] as u32);
    let m = p.coded_from_display.map(|v| v as f64);
    let off = DVec2::new(p.coded_offset_px[0] as f64, p.coded_offset_px[1] as f64);
    // The rotation is orthogonal: display = mᵀ (coded − offset).
    let to_display = |c: DVec2| {
        let d = c - off;
        DVec2::new(m[0] * d.x + m[1] * d.y, m[2] * d.x + m[3] * d.y)
    };
    for s in streaks.iter().filter(|s| s.len_px >= 0.0) {
        let q0 = DVec2::new(s.q0_px[0] as f64, s.q0_px[1] as f64);
        let dir = DVec2::new(s.dir[0] as f64, s.dir[1] as f64);
        let (len, r) = (s.len_px as f64, s.r_eff_px as f64);
        let ext = r + AA_MARGIN_PX;
        for y in 0..h {
            for x in 0..w {
                let d = to_display(DVec2::new(x as f64 + 0.5, y as f64 + 0.5)) - q0;
                let along = d.dot(dir);
                let across = d.x * -dir.y + d.y * dir.x;
                if along < -ext || along > len + ext || across.abs() > ext {
                    continue;
                }
                let mut a =
                    (coverage(along, across, len, r) * s.alpha_scale as f64).clamp(0.0, 1.0);
                if let Some(map) = depth {
                    let shown = to_display(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
                    let (px, py) = (shown.x.floor() as usize, shown.y.floor() as usize);
                    let scene = map
                        .at(px.min(map.width - 1), py.min(map.height - 1))
                        .map(f64::from);
                    let ends = [s.radiance0[3] as f64, s.radiance1[3] as f64];
                    a *= visibility(scene, drop_depth_m(along, len, ends));
                }
                if a <= 0.0 {
                    continue;
                }
                let t = (along + ext) / (len + 2.0 * ext);
                let px = &mut canvas[(y * w + x) as usize];
                for (k, c) in px.iter_mut().enumerate() {
                    let rad = s.radiance0[k] as f64 * (1.0 - t) + s.radiance1[k] as f64 * t;
                    *c = rad * a + *c * (1.0 - a);
                }
            }
        }
    }
}
