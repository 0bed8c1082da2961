//! The CPU twin of the `rain_simulate` stage (`streak_of` in `shaders/rain_simulate.wgsl`),
//! with `coverage` of `shaders/common/capsule.wgsl`: where a drop's streak lies in the picture, how wide it is drawn
//! and how much of each pixel it covers. `tests/gpu.rs` holds the GPU to it.
//!
//! ## How it works
//!
//! The drop's path over the exposure is clipped to the near plane and projected. Its disc of
//! radius r (px) is widened to `r_eff = √(r² + b²)` by the defocus blur radius b (at least
//! [`MIN_RADIUS_PX`]) and its alpha scaled by `(r/r_eff)²`, so the integrated coverage stays
//! `π r²` (Garg & Nayar's time-averaged streak, thesis 5.1.2). Near the lens b can fill the
//! view: the drawn radius is capped at [`NEAR_FIELD_MAX_RADIUS`] of the picture height and the
//! alpha follows the cap, which keeps both the coverage and the cost of those few drops bounded.
//!
//! With a ground (`RainParams::ground_clip`), a drop moving at constant velocity over the
//! exposure meets the ground z = 0 at the fraction `s = z₀/(z₀ − z₁)` of it (z₀, z₁ its heights
//! at the exposure's start and end): the streak ends at the impact and, being in the air for
//! only `s` of the exposure, covers each pixel for `s` times as long (alpha × s). A drop that
//! landed before the exposure opened (z₀ ≤ 0) is not drawn.
//!
//! With point-light mattes, [`take_glints`] is the twin of the stage's `main_mattes`: the
//! drop's strongest compact lights leave the streak's smooth colour as glints.

use glam::{DVec2, DVec3};

use crate::gpu::types::{DirectLight, GLINTS_PER_DROP, Glint, LightList, RainParams, Streak};
use crate::lighting::RtfTable;
use crate::lighting::sources::angle_between_rad;

/// The renderer's cull and widening, defined with the physics the rain plan bounds them by.
pub use crate::rain::physics::{MIN_PEAK_ALPHA, MIN_RADIUS_PX, NEAR_FIELD_MAX_RADIUS};

/// One drop's streak in the displayed picture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreakShape {
    /// Start of the centre's path, px.
    pub q0_px: DVec2,
    /// Unit direction of motion in the picture.
    pub dir: DVec2,
    /// Path length, px.
    pub len_px: f64,
    /// Drawn radius, px.
    pub r_eff_px: f64,
    /// Projected radius of the drop itself, px.
    pub r_px: f64,
    /// Coverage multiplier (`(r/r_eff)²` × opacity × weight).
    pub alpha_scale: f64,
    /// Path ends in camera space (after near clipping), metres.
    pub ends_camera_m: [DVec3; 2],
    /// Fraction of the exposure the drop is in the air: below 1 when it lands on the ground
    /// during the exposure (`RainParams::ground_clip`), where its streak ends.
    pub exposed_fraction: f64,
}

impl StreakShape {
    /// Alpha at display position `p_px` (coverage × alpha scale, clamped to 1).
    pub fn alpha_at(&self, p_px: DVec2) -> f64 {
        let d = p_px - self.q0_px;
        let along = d.dot(self.dir);
        let across = d.perp_dot(self.dir);
        (coverage(along, across, self.len_px, self.r_eff_px) * self.alpha_scale).clamp(0.0, 1.0)
    }

    /// Peak alpha on the streak's axis.
    pub fn peak_alpha(&self) -> f64 {
        self.alpha_scale * (2.0 * self.r_eff_px / self.len_px.max(1e-3)).min(1.0)
    }
}

/// Fraction of the exposure during which a disc of radius `r`, moving uniformly from 0 to
/// `len` along x, covers the point (`along`, `across`).
pub fn coverage(along: f64, across: f64, len: f64, r: f64) -> f64 {
    let h2 = r * r - across * across;
    if h2 <= 0.0 {
        return 0.0;
    }
    let h = h2.sqrt();
    if len < 1e-3 {
        return if along.abs() < h { 1.0 } else { 0.0 };
    }
    ((along + h).clamp(0.0, len) - (along - h).clamp(0.0, len)) / len
}

/// The streak of a drop at `pos_m` (world) moving at `vel_mps`, drawn `width_mm` wide, under
/// the uniforms `p`; `None` where the GPU hides it (behind the near plane, off the picture, or
/// fainter than [`MIN_PEAK_ALPHA`]).
pub fn streak_of(
    p: &RainParams,
    pos_m: DVec3,
    vel_mps: DVec3,
    width_mm: f64,
) -> Option<StreakShape> {
    let half = vel_mps * (0.5 * p.exposure_s as f64);
    let (w0, mut w1) = (pos_m - half, pos_m + half);
    let mut exposed = 1.0;
    if p.ground_clip != 0 && w1.z < 0.0 {
        if w0.z <= 0.0 {
            return None;
        }
        exposed = w0.z / (w0.z - w1.z);
        w1 = w0.lerp(w1, exposed);
    }
    let max_radius_px = NEAR_FIELD_MAX_RADIUS * p.display_size_px[1] as f64;
    segment_streak(
        p,
        w0,
        w1,
        exposed,
        0.5e-3 * width_mm,
        1.0,
        max_radius_px,
        0.0,
    )
}

/// The streak of water of radius `radius_m` moving from `w0` to `w1` (world) while in view for
/// `exposed` of the exposure, its coverage times `weight`, drawn no wider than `max_radius_px`
/// (the WGSL's `segment_streak`, common/streak.wgsl); `None` where the GPU hides it: behind the
/// near plane, thinner than `min_width_px` before widening, fainter than [`MIN_PEAK_ALPHA`], off
/// the picture. For the drops and the splash droplets alike.
#[allow(clippy::too_many_arguments)]
pub fn segment_streak(
    p: &RainParams,
    w0: DVec3,
    w1: DVec3,
    exposed: f64,
    radius_m: f64,
    weight: f64,
    max_radius_px: f64,
    min_width_px: f64,
) -> Option<StreakShape> {
    let v2 = |a: [f32; 2]| DVec2::new(a[0] as f64, a[1] as f64);
    let (mut c0, mut c1) = (super::to_camera(p, w0), super::to_camera(p, w1));
    let near = p.near_clip_m as f64;
    if c0.z < near && c1.z < near {
        return None;
    }
    if c0.z < near {
        c0 = c0.lerp(c1, (near - c0.z) / (c1.z - c0.z));
    }
    if c1.z < near {
        c1 = c1.lerp(c0, (near - c1.z) / (c0.z - c1.z));
    }
    let f = p.focal_px as f64;
    let z = c0.z.min(c1.z);
    let r = radius_m * f / z;
    if 2.0 * r < min_width_px {
        return None;
    }
    let principal = v2(p.principal_px);
    let q0 = principal + f * DVec2::new(c0.x, c0.y) / c0.z;
    let q1 = principal + f * DVec2::new(c1.x, c1.y) / c1.z;
    let blur = 0.5 * p.lens_blur_k_px_m as f64 * (p.inv_focus_per_m as f64 - 1.0 / z).abs();
    let r_eff = (r * r + blur * blur)
        .sqrt()
        .max(MIN_RADIUS_PX)
        .min(max_radius_px);
    let seg = q1 - q0;
    let len = seg.length();
    let dir = if len > 1e-4 { seg / len } else { DVec2::Y };
    let alpha_scale =
        r * r / (r_eff * r_eff) * p.opacity as f64 * p.drop_weight as f64 * exposed * weight;
    let shape = StreakShape {
        q0_px: q0,
        dir,
        len_px: len,
        r_eff_px: r_eff,
        r_px: r,
        alpha_scale,
        ends_camera_m: [c0, c1],
        exposed_fraction: exposed,
    };
    if shape.peak_alpha() < MIN_PEAK_ALPHA {
        return None;
    }
    let size = v2(p.display_size_px);
    let ext = r_eff + 1.0;
    let lo = q0.min(q1) - DVec2::splat(ext);
    let hi = q0.max(q1) + DVec2::splat(ext);
    if hi.x < 0.0 || hi.y < 0.0 || lo.x > size.x || lo.y > size.y {
        return None;
    }
    Some(shape)
}

/// The radiance `L·Ω·F(θ)` per channel light `l` gives a drop at `offset_m` from the camera
/// (world axes) seen along unit `v`, and ω (unit, drop → light): a light at a finite distance
/// is seen from the drop, its solid angle scaled by (d/|light − drop|)², the distance clamped
/// where Ω would exceed a hemisphere (`light_term` in common/lights.wgsl).
pub fn light_term(
    l: &DirectLight,
    tables: &[RtfTable; 3],
    v: DVec3,
    offset_m: DVec3,
) -> ([f64; 3], DVec3) {
    let [r, g, b, _] = l.strength.map(f64::from);
    let (omega, scale) = l.seen_from(offset_m);
    let theta = angle_between_rad(omega, v);
    let strength = [r, g, b];
    (
        std::array::from_fn(|c| strength[c] * scale * tables[c].interpolated(theta)),
        omega,
    )
}

/// The glints of the drop at `pos_m` moving at `vel_mps` (the stage's `main_mattes`): its
/// [`GLINTS_PER_DROP`] strongest lights of `lights` (by the sum of their rgb; ties keep the
/// list's order; lights giving nothing are none), strongest first, their directions in the
/// matte's frame (x image right, y away from the camera, z against the fall); the rest zero.
/// Their light leaves `streak`'s smooth colour, whose integral along the streak is the mean of
/// its ends: per channel the glints take at most that mean (scaled down to it where the lights
/// at mid-exposure exceed the colour given at the ends), both ends lose what they take, or one
/// end all it has and the other the rest. So glints + smooth hold the streak's light exactly
/// once and no colour goes negative. A hidden streak (or no light) is left as it is.
pub fn take_glints(
    p: &RainParams,
    lights: &LightList,
    tables: &[RtfTable; 3],
    pos_m: DVec3,
    vel_mps: DVec3,
    streak: &mut Streak,
) -> [Glint; GLINTS_PER_DROP] {
    let mut glints = [Glint {
        colour: [0.0; 4],
        light_dir: [0.0; 4],
    }; GLINTS_PER_DROP];
    let count = (lights.count as usize).min(lights.lights.len());
    if streak.len_px < 0.0 || count == 0 {
        return glints;
    }
    let cam = &p.camera_pos_m;
    let offset = pos_m - DVec3::new(cam[0] as f64, cam[1] as f64, cam[2] as f64);
    let v = offset.normalize();
    let sum = |c: &[f64; 3]| c[0] + c[1] + c[2];
    let mut terms: Vec<([f64; 3], DVec3)> = lights.lights[..count]
        .iter()
        .map(|l| light_term(l, tables, v, offset))
        .filter(|(c, _)| sum(c) > 0.0)
        .collect();
    terms.sort_by(|a, b| sum(&b.0).total_cmp(&sum(&a.0)));
    terms.truncate(GLINTS_PER_DROP);
    let up = -vel_mps.normalize_or(DVec3::NEG_Z);
    let away = (v - up * v.dot(up)).try_normalize().unwrap_or(DVec3::Y);
    let right = away.cross(up);
    for k in 0..3 {
        let total: f64 = terms.iter().map(|(c, _)| c[k]).sum();
        let (r0, r1) = (streak.radiance0[k] as f64, streak.radiance1[k] as f64);
        let taken = total.min(0.5 * (r0 + r1));
        let left = (r0 + r1 - 2.0 * taken).max(0.0);
        let end0 = (r0 - taken).clamp(0.0, left);
        streak.radiance0[k] = end0 as f32;
        streak.radiance1[k] = (left - end0) as f32;
        let share = if total <= taken { 1.0 } else { taken / total };
        for (g, (c, _)) in glints.iter_mut().zip(&terms) {
            g.colour[k] = (c[k] * share) as f32;
        }
    }
    for (g, (_, omega)) in glints.iter_mut().zip(&terms) {
        g.light_dir = [
            omega.dot(right) as f32,
            omega.dot(away) as f32,
            omega.dot(up) as f32,
            0.0,
        ];
    }
    glints
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{CameraConfig, RainConfig};
    use crate::scene::Camera;

    /// Σ alpha over the picture plane (0.5 px grid over the streak's footprint), px².
    fn integrated_alpha(s: &StreakShape) -> f64 {
        let ext = s.r_eff_px + 1.0;
        let q1 = s.q0_px + s.dir * s.len_px;
        let (lo, hi) = (s.q0_px.min(q1) - ext, s.q0_px.max(q1) + ext);
        let step = 0.5;
        let mut sum = 0.0;
        let mut y = lo.y + 0.5 * step;
        while y < hi.y {
            let mut x = lo.x + 0.5 * step;
            while x < hi.x {
                sum += s.alpha_at(DVec2::new(x, y));
                x += step;
            }
            y += step;
        }
        sum * step * step
    }

    /// A 2.5 mm drop falling at 7 m/s, `z_m` in front of a 20° lens at `f_number` focused at
    /// 10 m, 1/100 s exposure: its uniforms and streak.
    fn near_drop(z_m: f64, f_number: f64) -> (RainParams, Option<StreakShape>) {
        let camera = Camera::new(1280, 720, 20f64.to_radians(), 1.6, 0.0, 0.0);
        let lens = CameraConfig {
            fov_deg: 20.0,
            f_number,
            focus_m: 10.0,
            ..CameraConfig::default()
        };
        let setup =
            crate::shot::rain::plan(&camera, &lens, &RainConfig::default(), 0.01, 0, (1280, 720))
                .map(crate::gpu::uniforms::RainSetup::pack)
                .expect("rain");
        let mut p = setup.motion_at(0.0);
        p.drop_weight = 1.0;
        let pos = camera.position_m + camera.world_from_camera * DVec3::new(0.0, 0.0, z_m);
        let s = streak_of(&p, pos, DVec3::new(0.0, 0.0, -7.0), 2.5);
        (p, s)
    }

    #[test]
    fn a_drop_near_the_lens_is_a_soft_visible_disc_with_its_physical_coverage() {
        let (p, s) = near_drop(0.35, 4.0);
        let s = s.expect("drawn");
        let z = s.ends_camera_m[0].z.min(s.ends_camera_m[1].z);
        let blur = 0.5 * p.lens_blur_k_px_m as f64 * (p.inv_focus_per_m as f64 - 1.0 / z).abs();
        // Wider than a tenth of the picture: the blur of a drop on the lens, not a streak.
        assert!(blur > 0.1 * 720.0, "blur radius {blur} px");
        assert!(
            s.r_eff_px > 5.0 * s.r_px,
            "soft: {} vs drop {}",
            s.r_eff_px,
            s.r_px
        );
        assert!(
            s.peak_alpha() >= MIN_PEAK_ALPHA,
            "visible: peak {}",
            s.peak_alpha()
        );
        // Time-averaged coverage integrates to the drop's own projected area, π r².
        let want = std::f64::consts::PI * s.r_px * s.r_px;
        let got = integrated_alpha(&s);
        assert!((got / want - 1.0).abs() < 0.01, "{got} vs {want} px²");
    }

    #[test]
    fn a_drop_whose_blur_would_fill_the_view_is_capped_and_keeps_its_coverage() {
        let (p, s) = near_drop(0.2, 2.0);
        let s = s.expect("drawn");
        let z = s.ends_camera_m[0].z.min(s.ends_camera_m[1].z);
        let blur = 0.5 * p.lens_blur_k_px_m as f64 * (p.inv_focus_per_m as f64 - 1.0 / z).abs();
        assert!(
            blur > NEAR_FIELD_MAX_RADIUS * 720.0,
            "blur radius {blur} px"
        );
        assert!((s.r_eff_px - NEAR_FIELD_MAX_RADIUS * 720.0).abs() < 1e-9);
        let want = std::f64::consts::PI * s.r_px * s.r_px;
        let got = integrated_alpha(&s);
        assert!((got / want - 1.0).abs() < 0.01, "{got} vs {want} px²");
    }
}
