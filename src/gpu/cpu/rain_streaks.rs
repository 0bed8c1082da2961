//! The CPU twin of the `rain_streaks` stage: each streak's quad rasterised over the canvas in
//! drop order, the exact time-averaged coverage of [`coverage`] at each pixel centre, the
//! radiance interpolated along the quad as the vertex stage does, blended premultiplied
//! (src + dst·(1 − α)).

use glam::DVec2;

pub use super::rain_simulate::coverage;
use crate::gpu::types::{RainParams, Streak};

/// Half a pixel of margin around each quad (`AA_MARGIN_PX` in the WGSL).
pub const AA_MARGIN_PX: f64 = 0.5;

/// Blends `streaks` over `canvas` (linear RGB, row-major, the coded picture of
/// `p.coded_size_px`), with `p`'s display rotation.
pub fn rain_streaks(canvas: &mut [[f64; 3]], p: &RainParams, streaks: &[Streak]) {
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
                let a = (coverage(along, across, len, r) * s.alpha_scale as f64).clamp(0.0, 1.0);
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
