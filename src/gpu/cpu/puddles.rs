//! The CPU twin of the `puddles` stage: where a pixel's view ray meets the ground on water, the
//! ground under the water is darkened as by a film (Lekner & Dorf) and the rippled surface
//! reflects, with the exact unpolarised Fresnel reflectance, what lies along the mirrored ray:
//! the frame (marched against the depth map when there is one, else the picture towards the
//! mirrored direction), or beyond the frame's border the environment and the compact lights
//! (docs/method.md, "Puddles: shading").

use glam::{DVec2, DVec3};

use super::to_camera;
use super::wet_ground::{irradiance, radiance};
use super::yuv_to_rgb::view_ray;
use crate::gpu::types::{LightList, MAX_LIGHTS, PuddleParams, RainParams, Ripple};
use crate::lighting::prt::prt_colour_f64;
use crate::lighting::wetness::{FilmOptics, ground_shown, reflectance};
use crate::scene::DepthMap;
use crate::video::YuvFrame;

/// The reflection fades from the frame to the environment over this many pixels at its border.
pub const EDGE_PX: f64 = 8.0;
/// The march along the mirrored ray's image: a step every this many pixels.
pub const MARCH_STRIDE_PX: f64 = 2.0;
/// Most steps of the march.
pub const MARCH_MAX_STEPS: usize = 64;
/// The march ends this share of the way to the ray's vanishing point.
pub const MARCH_FARTHEST: f64 = 0.999;
/// Halvings of the step that passed behind the scene.
pub const MARCH_HALVINGS: usize = 6;
/// A point counts as behind the scene only to this fraction of the scene's depth beyond it.
pub const MARCH_THICKNESS: f64 = 0.25;

/// What the water reflects and lies on, for one frame.
pub struct Water<'a> {
    /// Placement of the map, the water's optics, the ring count.
    pub params: &'a PuddleParams,
    /// The water map: signed depth per cell, m, negative where dry (row-major, x fastest).
    pub depth_m: &'a [f32],
    /// The rings at the frame's time (the first `params.ring_count`).
    pub ripples: &'a [Ripple],
    /// The compact lights.
    pub lights: &'a LightList,
}

/// Puts the water on `canvas` (the linear picture of `frame` with its haze, and the wet ground
/// if any; coded orientation, row-major) under the uniforms `p`. The reflection reads the
/// canvas as it was before; the ground under the water is `frame`'s own, so the water replaces
/// a wet ground's film where it covers it.
///
/// With `depth` (the scene's camera depth per displayed pixel), pixels whose scene stands
/// nearer than the ground keep their value ([`ground_shown`]) and mirrored rays are marched
/// against it.
pub fn puddles(
    canvas: &mut [[f64; 3]],
    frame_yuv: &YuvFrame,
    p: &RainParams,
    water: &Water<'_>,
    depth: Option<&DepthMap>,
) {
    puddles_masked(canvas, frame_yuv, p, water, depth, None);
}

/// [`puddles`] with the ground mask `mask` (weights at the glow's grid points; `None`: all
/// ground), which the water keeps to where the depth map does not know the pixel
/// ([`super::wet_ground::ground_weight`]).
pub fn puddles_masked(
    canvas: &mut [[f64; 3]],
    frame_yuv: &YuvFrame,
    p: &RainParams,
    water: &Water<'_>,
    depth: Option<&DepthMap>,
    mask: Option<&[f32]>,
) {
    puddles_lit(canvas, frame_yuv, p, water, depth, mask, None);
}

/// [`puddles_masked`] with the lamps' glow `glow` (per coded pixel, at the scene's opacity, as
/// [`super::yuv_to_rgb::haze_glow`] gives it; `None`: no lamps): the water keeps the glow
/// yuv_to_rgb laid on the ground, at its ray's share of the opacity.
pub fn puddles_lit(
    canvas: &mut [[f64; 3]],
    frame_yuv: &YuvFrame,
    p: &RainParams,
    water: &Water<'_>,
    depth: Option<&DepthMap>,
    mask: Option<&[f32]>,
    glow: Option<&[[f64; 3]]>,
) {
    let width = frame_yuv.format.width;
    let plate = super::yuv_to_rgb::plate(frame_yuv, p);
    let frame = Frame {
        pixels: canvas.to_vec(),
        width,
        height: (canvas.len() / width as usize) as u32,
    };
    let (env, drop) = super::yuv_to_rgb::environment_and_drop(p);
    let w = water.params;
    let optics = FilmOptics {
        index: w.water_index as f64,
        diffuse_external: w.diffuse_external as f64,
        diffuse_internal: w.diffuse_internal as f64,
    };
    let e_up = irradiance(&env, DVec3::Z);
    let camera = v3(&p.camera_pos_m);
    let h = camera.z;
    let mirror = Mirror {
        p,
        frame: &frame,
        env: &env,
        lights: water.lights,
        lobe: w.light_lobe as f64,
        depth,
    };
    for (i, pixel) in canvas.iter_mut().enumerate() {
        let (x, y) = (i as u32 % width, i as u32 / width);
        let ray = view_ray(p, x, y);
        let d = ray.normalize();
        if d.z >= 0.0 || h <= 0.0 {
            continue;
        }
        // `ray` has unit camera depth: the ground lies at camera depth h / −ray.z.
        let ground_z_m = h / -ray.z;
        let ground = camera + ground_z_m * ray;
        let cover = water_cover(
            w,
            water.depth_m,
            ground.truncate(),
            ground_per_px(p, ray, ground_z_m),
        );
        if cover <= 0.0 {
            continue;
        }
        let scene_m = depth.and_then(|map| {
            super::yuv_to_rgb::scene_depth_at(p, map, DVec2::new(x as f64 + 0.5, y as f64 + 0.5))
        });
        let shown = ground_shown(scene_m, ground_z_m)
            * super::wet_ground::ground_weight(p, depth, mask, x, y);
        if shown <= 0.0 {
            continue;
        }
        let transmittance = super::yuv_to_rgb::haze_transmittance(p, depth, x, y);
        let in_scatter = if transmittance < 1.0 {
            prt_colour_f64(&env, &drop, ray).map(|v| (1.0 - transmittance) * v.max(0.0))
        } else {
            [0.0; 3]
        };
        let share = (1.0 - transmittance) / (1.0 - p.haze[3] as f64).max(1e-300);
        let glow_px = glow.map_or([0.0; 3], |g| g[i].map(|v| v * share));
        let slope = ripple_slope(&water.ripples[..w.ring_count as usize], ground.truncate());
        let normal = DVec3::new(-slope.x, -slope.y, 1.0).normalize();
        let cos_i = (-d.dot(normal)).max(0.0);
        let mirrored = d + 2.0 * cos_i * normal;
        let r = reflectance(optics.index, cos_i);
        let reflected = rough_radiance(&mirror, w, ground, d, slope, mirrored, ground_z_m);
        for k in 0..3 {
            let scene = plate[i][k];
            let albedo = if e_up[k] > 0.0 {
                (std::f64::consts::PI * scene / e_up[k]).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let change = (optics.darkening(albedo, -d.z) - 1.0) * scene + r * reflected[k];
            let wet = scene * transmittance + in_scatter[k] + glow_px[k] + transmittance * change;
            pixel[k] += cover * shown * (wet - pixel[k]);
        }
    }
}

/// The reflection along `mirrored` off the water of slope `slope`, blurred beyond
/// `params.resolve_depth_m` by the far water's RMS slope σ: the mean of the reflections off
/// the slope moved by ±σ along x and along y (see `rough_reflected` in the shader).
fn rough_radiance(
    mirror: &Mirror,
    params: &PuddleParams,
    ground: DVec3,
    d: DVec3,
    slope: DVec2,
    mirrored: DVec3,
    depth_m: f64,
) -> [f64; 3] {
    if params.far_slope_rms <= 0.0 {
        return mirror.radiance(ground, mirrored);
    }
    let s = params.resolve_depth_m as f64;
    let sigma = params.far_slope_rms as f64 * smoothstep(s, 2.0 * s, depth_m);
    if sigma <= 0.0 {
        return mirror.radiance(ground, mirrored);
    }
    let mut sum = [0.0; 3];
    for tilt in [
        DVec2::new(sigma, 0.0),
        DVec2::new(-sigma, 0.0),
        DVec2::new(0.0, sigma),
        DVec2::new(0.0, -sigma),
    ] {
        let n = (-(slope + tilt)).extend(1.0).normalize();
        let c = (-d.dot(n)).max(0.0);
        let seen = mirror.radiance(ground, d + 2.0 * c * n);
        (0..3).for_each(|k| sum[k] += 0.25 * seen[k]);
    }
    sum
}

/// The canvas before the water, for the reflection.
struct Frame {
    pixels: Vec<[f64; 3]>,
    width: u32,
    height: u32,
}

impl Frame {
    /// The picture at coded position `at` (px): bilinear between pixel centres, clamped at the
    /// border.
    fn sample(&self, at: DVec2) -> [f64; 3] {
        let u = at - DVec2::splat(0.5);
        let (x0, y0) = (u.x.floor(), u.y.floor());
        let (fx, fy) = (u.x - x0, u.y - y0);
        let texel = |x: f64, y: f64| {
            let x = (x as i64).clamp(0, self.width as i64 - 1) as usize;
            let y = (y as i64).clamp(0, self.height as i64 - 1) as usize;
            self.pixels[y * self.width as usize + x]
        };
        let (a, b) = (texel(x0, y0), texel(x0 + 1.0, y0));
        let (c, e) = (texel(x0, y0 + 1.0), texel(x0 + 1.0, y0 + 1.0));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (e[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    }

    /// Distance (px) of `at` inside the frame's border (negative outside).
    fn inside(&self, at: DVec2) -> f64 {
        at.x.min(at.y)
            .min(self.width as f64 - at.x)
            .min(self.height as f64 - at.y)
    }
}

/// What the water mirrors.
struct Mirror<'a> {
    p: &'a RainParams,
    frame: &'a Frame,
    env: &'a [[f64; 3]],
    lights: &'a LightList,
    lobe: f64,
    depth: Option<&'a DepthMap>,
}

impl Mirror<'_> {
    /// Radiance along unit direction `dir` from ground point `ground`.
    fn radiance(&self, ground: DVec3, dir: DVec3) -> [f64; 3] {
        let env = self.environment(ground, dir);
        // Without a hit in the depth map: the picture towards the direction (its vanishing
        // point), content at a distance.
        let q = self
            .march(ground, dir)
            .unwrap_or_else(|| to_camera(self.p, v3(&self.p.camera_pos_m) + dir));
        if q.z <= 1e-6 {
            return env;
        }
        let at = project(self.p, q);
        let w = smoothstep(0.0, EDGE_PX, self.frame.inside(at));
        if w <= 0.0 {
            return env;
        }
        let seen = self.frame.sample(at);
        std::array::from_fn(|k| env[k] + (seen[k] - env[k]) * w)
    }

    /// The first point (camera space) where the ray from `ground` along `dir` passes behind
    /// the scene of the depth map, if any within the frame.
    fn march(&self, ground: DVec3, dir: DVec3) -> Option<DVec3> {
        let map = self.depth?;
        // Behind the scene at its pixel, not far, where the scene stands on the ground: nearer
        // than the plane along the pixel's ray (the 90 % of `ground_shown`), or above the
        // horizon. The mirrored ray runs above the plane and never meets it.
        let behind = |s: f64| {
            let q = to_camera(self.p, ground + s * dir);
            if q.z <= 0.0 {
                return false;
            }
            let at = project(self.p, q);
            let Some(z) = super::yuv_to_rgb::scene_depth_at(self.p, map, at) else {
                return false;
            };
            let ray = view_ray(self.p, at.x.max(0.0) as u32, at.y.max(0.0) as u32);
            let standing = ray.z >= 0.0 || z < 0.9 * self.p.camera_pos_m[2] as f64 / -ray.z;
            standing && q.z >= z && q.z <= z * (1.0 + MARCH_THICKNESS)
        };
        // Even steps along the ray's image, from the ground's pixel to the vanishing point:
        // share λ of the way lies at distance s = λ z_p / ((1 − λ) dir_z) along the ray.
        let q_p = to_camera(self.p, ground);
        let q_dir = to_camera(self.p, v3(&self.p.camera_pos_m) + dir);
        if q_dir.z <= 1e-6 {
            return None;
        }
        let distance = |share: f64| share * q_p.z / ((1.0 - share) * q_dir.z);
        let image_px = project(self.p, q_dir).distance(project(self.p, q_p));
        let steps = ((image_px / MARCH_STRIDE_PX).ceil() as usize).clamp(1, MARCH_MAX_STEPS);
        let mut before = 0.0;
        for i in 1..=steps {
            let share = MARCH_FARTHEST * i as f64 / steps as f64;
            let s = distance(share);
            if self
                .frame
                .inside(project(self.p, to_camera(self.p, ground + s * dir)))
                <= 0.0
            {
                return None;
            }
            if behind(s) {
                let (mut lo, mut hi) = (before, share);
                for _ in 0..MARCH_HALVINGS {
                    let mid = 0.5 * (lo + hi);
                    if behind(distance(mid)) {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return Some(to_camera(self.p, ground + distance(hi) * dir));
            }
            before = share;
        }
        None
    }

    /// Beyond the frame: the environment, and each compact light as a normalised von
    /// Mises–Fisher lobe (concentration κ) about its direction from `ground`, carrying its
    /// radiance × solid angle.
    fn environment(&self, ground: DVec3, dir: DVec3) -> [f64; 3] {
        let mut c = radiance(self.env, dir).map(|v| v.max(0.0));
        let from_camera = ground - v3(&self.p.camera_pos_m);
        let kappa = self.lobe;
        for l in &self.lights.lights[..(self.lights.count as usize).min(MAX_LIGHTS)] {
            let (omega, scale) = l.seen_from(from_camera);
            let lobe = kappa / std::f64::consts::TAU * (kappa * (omega.dot(dir) - 1.0)).exp();
            for (k, ck) in c.iter_mut().enumerate() {
                *ck += l.strength[k] as f64 * scale * lobe;
            }
        }
        c
    }
}

/// A probe of [`water_cover`] spans at most this many cells along each of the footprint's
/// axes: as far as [`footprint_range`]'s widening reaches beyond the four nearest cells.
pub const PROBE_CELLS: f64 = 2.0;

/// At most this many whole probes along an axis of the footprint (and two partial ones at its
/// ends): beyond, the probes lengthen.
pub const MAX_PROBES: f64 = 15.0;

/// The water's cover at ground point `xy` for a pixel whose ground point moves by `per_px`
/// ([`ground_per_px`]): the share of the pixel's footprint under water. Where the footprint
/// spans more than [`PROBE_CELLS`] cells along an axis (ground far off, seen at a grazing angle:
/// a pixel row of a street 10 m ahead spans 5 cells of 2 cm in depth), one reading at its
/// centre would stand for water it does not see, and rims would follow the rows of pixels
/// that happen to land on a wet cell: a staircase. So the footprint is cut along each axis
/// into a centre piece of [`PROBE_CELLS`], whole pieces out from it, and two shorter pieces at
/// its ends (their length growing from 0 as the footprint does, so the cover changes without
/// a jump where a piece is added), and the cover is the mean of [`probe_cover`] over the
/// pieces, weighted by their area. One piece where the footprint is within [`PROBE_CELLS`].
pub fn water_cover(params: &PuddleParams, depth_m: &[f32], xy: DVec2, per_px: [DVec2; 2]) -> f64 {
    let cell_m = params.cell_m as f64;
    let along_a = footprint_pieces(per_px[0].length() / cell_m);
    let along_b = footprint_pieces(per_px[1].length() / cell_m);
    let mut cover = 0.0;
    for &(ta, la) in along_a.iter().filter(|p| p.1 > 0.0) {
        for &(tb, lb) in along_b.iter().filter(|p| p.1 > 0.0) {
            let at = xy + ta * per_px[0] + tb * per_px[1];
            let piece = [la * per_px[0], lb * per_px[1]];
            cover += la * lb * probe_cover(params, depth_m, at, piece);
        }
    }
    cover
}

/// The pieces of an axis of a pixel's footprint `cells` long (see [`water_cover`]): each
/// (its centre's offset from the footprint's, its length), as shares of the axis; the lengths
/// add up to 1, and a piece of length 0 is left out by the caller.
pub fn footprint_pieces(cells: f64) -> Vec<(f64, f64)> {
    let share = (PROBE_CELLS / cells).max(1.0 / MAX_PROBES);
    if share >= 1.0 {
        return vec![(0.0, 1.0)];
    }
    let k = ((1.0 / share - 1.0) / 2.0).floor();
    let end = 0.5 * (1.0 - (2.0 * k + 1.0) * share);
    let mut pieces = vec![(0.0, share)];
    for m in 1..=k as usize {
        pieces.push((m as f64 * share, share));
        pieces.push((-(m as f64) * share, share));
    }
    let out = (k + 0.5) * share + 0.5 * end;
    pieces.push((out, end));
    pieces.push((-out, end));
    pieces
}

/// The cover of one probe at ground point `xy` whose footprint moves by `per_px`: the mean of
/// smoothstep(0, rim depth, depth) over a box of the footprint's width across the rim
/// ([`rim_cover`]), the depth read by [`water_depth`] and its change across the footprint by
/// the reading's own derivative. Clamped to [`footprint_range`], so a footprint that reaches a
/// wet cell beyond the four nearest is not left dry.
pub fn probe_cover(params: &PuddleParams, depth_m: &[f32], xy: DVec2, per_px: [DVec2; 2]) -> f64 {
    let (depth, gradient, _, _) = water_depth_gradient(params, depth_m, xy);
    let (lo, hi) = footprint_range(params, depth_m, xy, per_px);
    let width = DVec2::new(gradient.dot(per_px[0]), gradient.dot(per_px[1])).length();
    rim_cover(depth, lo, hi, width, params.edge_depth_m as f64)
}

/// The range the cover's depth is clamped to at ground point `xy` for a pixel whose footprint
/// moves by `per_px`: the four nearest cells' range, widened toward each of the twelve around
/// them by how far the footprint (its bounding box, half ½(|∂x| + |∂y|) per axis) passes the
/// square of the four nearest centres toward it, in cells (0 to 1, per axis, multiplied). It
/// widens continuously from the four cells' range where the footprint stays inside the square
/// (a hard switch to the sixteen would jump at the square's edge), and roughly as far as a
/// linear reading between the cells would reach at the footprint's edge.
pub fn footprint_range(
    params: &PuddleParams,
    depth_m: &[f32],
    xy: DVec2,
    per_px: [DVec2; 2],
) -> (f64, f64) {
    let (nx, ny) = (params.cells[0] as i64, params.cells[1] as i64);
    let origin = DVec2::new(params.origin_m[0] as f64, params.origin_m[1] as f64);
    let cell_m = params.cell_m as f64;
    let u = (xy - origin) / cell_m - DVec2::splat(0.5);
    let (i0, j0) = (u.x.floor() as i64, u.y.floor() as i64);
    let f = u - u.floor();
    let half = (per_px[0].abs() + per_px[1].abs()) * (0.5 / cell_m);
    let reach = |a: usize, f: f64, h: f64| match a {
        0 => (h - f).clamp(0.0, 1.0),
        3 => (f + h - 1.0).clamp(0.0, 1.0),
        _ => 1.0,
    };
    let cell = |a: usize, b: usize| {
        let (i, j) = (i0 + a as i64 - 1, j0 + b as i64 - 1);
        if (0..nx).contains(&i) && (0..ny).contains(&j) {
            depth_m[(j * nx + i) as usize] as f64
        } else {
            0.0
        }
    };
    let near = [cell(1, 1), cell(2, 1), cell(1, 2), cell(2, 2)];
    let lo = near.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = near.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (mut down, mut up) = (0.0f64, 0.0f64);
    for b in 0..4 {
        for a in 0..4 {
            let w = reach(a, f.x, half.x) * reach(b, f.y, half.y);
            let v = cell(a, b);
            down = down.max(w * (lo - v).max(0.0));
            up = up.max(w * (v - hi).max(0.0));
        }
    }
    (lo - down, hi + up)
}

/// The mean of smoothstep(0, `edge`, clamp(s, `lo`, `hi`)) for s spread evenly over `depth` ±
/// `width`/2 (the depth's run across one pixel): the parts beyond the clamp at its ends' cover,
/// the rest the ramp's integral, ∫₀ˢ smoothstep = edge·(t³ − t⁴/2), t = s/edge. A box of the
/// pixel's variance for any direction of the rim (|∇D|²/12, a square pixel's); the plain
/// smoothstep where the pixel spans under a thousandth of the ramp. Exactly 0 where `hi` ≤ 0
/// and 1 where `lo` ≥ `edge`.
pub fn rim_cover(depth: f64, lo: f64, hi: f64, width: f64, edge: f64) -> f64 {
    if width <= 1e-3 * edge {
        return smoothstep(0.0, edge, depth.max(lo).min(hi));
    }
    let area = |s: f64| {
        let t = s.clamp(0.0, edge) / edge;
        edge * t * t * t * (1.0 - 0.5 * t)
    };
    let (x0, x1) = (depth - 0.5 * width, depth + 0.5 * width);
    let below = (x1.min(lo) - x0).max(0.0) * smoothstep(0.0, edge, lo);
    let above = (x1 - x0.max(hi)).max(0.0) * smoothstep(0.0, edge, hi);
    let (a, b) = (x0.max(lo).min(hi), x1.max(lo).min(hi));
    let ramp = (b - a.max(edge)).max(0.0) + area(b) - area(a);
    ((below + ramp + above) / width).clamp(0.0, 1.0)
}

/// The ground point's change per coded pixel along x and along y (m) for the view ray `ray`
/// (unit camera depth) meeting the ground at camera depth `ground_z_m`: the ray is affine in
/// the pixel, r′ per pixel, and the point h·r/(−r_z) moves by (h/(−r_z))·(r′ − r·r′_z/r_z).
pub fn ground_per_px(p: &RainParams, ray: DVec3, ground_z_m: f64) -> [DVec2; 2] {
    let m = p.coded_from_display.map(f64::from);
    let (r0, r1) = (v3(&p.camera_from_world_0), v3(&p.camera_from_world_1));
    let f = p.focal_px as f64;
    let along = |a: f64, b: f64| {
        let r = (r0 * a + r1 * b) / f;
        (ground_z_m * (r - ray * (r.z / ray.z))).truncate()
    };
    [along(m[0], m[2]), along(m[1], m[3])]
}

/// Water depth (m, signed: negative where dry) at ground point `xy`: Catmull-Rom between cell
/// centres over the 4×4 cells around it (0 off the map), clamped to the range of the four
/// nearest. The reading is C¹, so the rim (its zero) turns smoothly across the cells' edges,
/// where a bilinear reading's zero (hyperbolic arcs) kinks; it reproduces planes and
/// quadratics (a pool in a bowl is read exactly), and the clamp keeps it from making water or
/// dry ground that none of the four nearest cells holds (its overshoot would, in a dry groove
/// between high banks).
pub fn water_depth(params: &PuddleParams, depth_m: &[f32], xy: DVec2) -> f64 {
    let (sum, _, lo, hi) = water_depth_gradient(params, depth_m, xy);
    sum.max(lo).min(hi)
}

/// [`water_depth`] before the clamp, its gradient (m per m, Catmull-Rom's derivative) and the
/// four nearest cells' range.
pub fn water_depth_gradient(
    params: &PuddleParams,
    depth_m: &[f32],
    xy: DVec2,
) -> (f64, DVec2, f64, f64) {
    let (nx, ny) = (params.cells[0] as i64, params.cells[1] as i64);
    let origin = DVec2::new(params.origin_m[0] as f64, params.origin_m[1] as f64);
    let u = (xy - origin) / params.cell_m as f64 - DVec2::splat(0.5);
    let (i0, j0) = (u.x.floor() as i64, u.y.floor() as i64);
    let (fx, fy) = (u.x - u.x.floor(), u.y - u.y.floor());
    let (wx, wy) = (catmull_rom(fx), catmull_rom(fy));
    let (sx, sy) = (catmull_rom_slope(fx), catmull_rom_slope(fy));
    let cell = |i: i64, j: i64| {
        if (0..nx).contains(&i) && (0..ny).contains(&j) {
            depth_m[(j * nx + i) as usize] as f64
        } else {
            0.0
        }
    };
    let (mut sum, mut lo, mut hi) = (0.0, f64::INFINITY, f64::NEG_INFINITY);
    let mut gradient = DVec2::ZERO;
    for b in 0..4 {
        let j = j0 + b as i64 - 1;
        let (mut row, mut row_slope) = (0.0, 0.0);
        for a in 0..4 {
            let value = cell(i0 + a as i64 - 1, j);
            row += wx[a] * value;
            row_slope += sx[a] * value;
            if (1..3).contains(&a) && (1..3).contains(&b) {
                (lo, hi) = (lo.min(value), hi.max(value));
            }
        }
        sum += wy[b] * row;
        gradient += DVec2::new(wy[b] * row_slope, sy[b] * row);
    }
    (sum, gradient / params.cell_m as f64, lo, hi)
}

/// The Catmull-Rom weights of the four cells around a point at fraction `t` of the way from
/// the second to the third (Keys' cubic convolution, a = −½).
pub fn catmull_rom(t: f64) -> [f64; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

/// The derivative of [`catmull_rom`]'s weights by `t`.
pub fn catmull_rom_slope(t: f64) -> [f64; 4] {
    let t2 = t * t;
    [
        0.5 * (-3.0 * t2 + 4.0 * t - 1.0),
        0.5 * (9.0 * t2 - 10.0 * t),
        0.5 * (-9.0 * t2 + 8.0 * t + 1.0),
        0.5 * (3.0 * t2 - 2.0 * t),
    ]
}

/// The gradient of the water's height at `xy`: the sum of every ring's radial slope dη/dr
/// ([`crate::fluid::ripples::RingState::slope`]) along r̂.
pub fn ripple_slope(ripples: &[Ripple], xy: DVec2) -> DVec2 {
    ripples
        .iter()
        .map(|ring| {
            let off = xy - DVec2::new(ring.centre_m[0] as f64, ring.centre_m[1] as f64);
            let r = off.length();
            let state = crate::fluid::ripples::RingState {
                radius_m: ring.radius_m as f64,
                width_m: ring.width_m as f64,
                amplitude_m: ring.amplitude_m as f64,
                phase: ring.phase as f64,
            };
            if r < 1e-6 || (r - state.radius_m).abs() > 4.0 * state.width_m {
                return DVec2::ZERO;
            }
            state.slope(ring.wavenumber as f64, r) * off / r
        })
        .sum()
}

/// Coded pixel position (px, continuous) of camera-space point `q` (q.z > 0): the pinhole,
/// then display → coded (coded = m (display) + offset).
pub fn project(p: &RainParams, q: DVec3) -> DVec2 {
    let f = p.focal_px as f64;
    let s = DVec2::new(p.principal_px[0] as f64, p.principal_px[1] as f64) + f * q.truncate() / q.z;
    let m = p.coded_from_display.map(f64::from);
    DVec2::new(m[0] * s.x + m[2] * s.y, m[1] * s.x + m[3] * s.y)
        + DVec2::new(p.coded_offset_px[0] as f64, p.coded_offset_px[1] as f64)
}

/// The scene's depth (m) at coded position `coded`, looked up at its displayed pixel; `None`
/// where unknown.
fn smoothstep(lo: f64, hi: f64, x: f64) -> f64 {
    let t = ((x - lo) / (hi - lo)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn v3(a: &[f32]) -> DVec3 {
    DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64)
}
