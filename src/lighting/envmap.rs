//! The environment map: a video frame spread over the sphere of directions around the camera,
//! projected on real SH (the thesis's environment map; `docs/method.md`, "Lighting"), plus
//! temporal smoothing.
//!
//! ## The mapping (frame → sphere)
//!
//! A world direction ω is expressed in camera space `c = (x right, y down, z forward)`.
//! - **Inside the field of view** (c.z > 0 and the pinhole image of ω inside the picture): the
//!   frame pixel through the pinhole model, `(X, Y) = f (c.x, c.y)/c.z` about the principal point.
//! - **Outside, in front**: the picture is extended like a cylinder around the camera's vertical
//!   axis. The column is the nearest one (`X` clamped to the picture), then the row is the one
//!   at the *same camera elevation* in that column, `Y = c.y/√(c.x²+c.z²) · √(X² + f²)`, clamped
//!   to the picture. So directions above the picture read the top rows (sky), below it the
//!   bottom rows (ground), and to the sides the edge columns at the same height, which keeps a
//!   level camera's horizon on the horizon all around.
//! - **Behind the camera** (c.z < 0): the same rule applied to the mirror image `(c.x, c.y,
//!   −c.z)` through the picture plane: what is behind is assumed to look like what is in front
//!   (sky still above, ground below, left still left), which is the best guess a single frame
//!   allows, and it is continuous across the side plane.
//! - **Blur**: away from the picture the lookup blends towards a strongly blurred copy of the
//!   frame, with weight `b = min(1, d/ramp)`, `d` the angular distance outside the picture
//!   (azimuth or elevation, measured before mirroring, so b = 1 straight behind), `ramp` = 90°
//!   by default. Extending edge pixels sharply would smear single objects into streaks and
//!   fans; the blurred copy keeps only the frame's large-scale light, which is all that four SH
//!   bands can carry anyway.
//!
//! The fill is defined in the camera's frame; for a level camera (the default) camera up is
//! world up. Everything above is linear in the frame, and 4 bands need little resolution, so
//! [`EnvMapper`] precomputes once per camera the linear map from a box-downsampled frame
//! (≈ 1° per pixel, at most 64 wide) to the SH coefficients, integrating the mapping over a
//! fine equirectangular grid with exact texel solid angles. Per frame the cost is the box
//! downsample (one pass over the frame) and a small matrix product.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::lighting::sh;
use crate::scene::Camera;
use crate::{Error, Result};

/// SH coefficients of an environment, RGB per coefficient (linear light).
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentSh {
    /// Number of bands.
    pub bands: usize,
    /// `bands²` coefficients, index `l(l+1)+m`, convention of [`sh`].
    pub coeffs: Vec<[f32; 3]>,
}

impl EnvironmentSh {
    /// All-zero coefficients.
    pub fn zeros(bands: usize) -> EnvironmentSh {
        EnvironmentSh {
            bands,
            coeffs: vec![[0.0; 3]; bands * bands],
        }
    }

    /// Coefficients as `f64`.
    pub fn coeffs_f64(&self) -> Vec<[f64; 3]> {
        self.coeffs.iter().map(|c| c.map(f64::from)).collect()
    }

    /// The band-limited environment's radiance in direction `dir` (4.19).
    pub fn eval(&self, dir: DVec3) -> [f64; 3] {
        let y = sh::basis(dir, self.bands);
        let mut out = [0.0; 3];
        for (c, yi) in self.coeffs.iter().zip(&y) {
            for k in 0..3 {
                out[k] += f64::from(c[k]) * yi;
            }
        }
        out
    }

    /// GPU layout `array<vec4<f32>, 16>`: coefficient i as `(r, g, b, 0)`, bands above 4
    /// dropped, missing ones zero.
    pub fn to_gpu_array(&self) -> [[f32; 4]; 16] {
        let mut out = [[0.0; 4]; 16];
        for (o, c) in out.iter_mut().zip(&self.coeffs) {
            *o = [c[0], c[1], c[2], 0.0];
        }
        out
    }

    /// Euclidean norm of all coefficients; by Parseval the L2 norm of the band-limited
    /// environment over the sphere (all channels).
    pub fn norm(&self) -> f64 {
        self.coeffs
            .iter()
            .flatten()
            .map(|v| f64::from(*v).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    /// `‖a − b‖ / max(‖a‖, ‖b‖)` ∈ [0, 2]: the relative L2 change of the band-limited
    /// environment. 0 when both are zero; 2 when the band counts differ.
    pub fn normalised_distance(&self, other: &EnvironmentSh) -> f64 {
        if self.bands != other.bands {
            return 2.0;
        }
        let d: f64 = self
            .coeffs
            .iter()
            .flatten()
            .zip(other.coeffs.iter().flatten())
            .map(|(a, b)| (f64::from(*a) - f64::from(*b)).powi(2))
            .sum::<f64>()
            .sqrt();
        let n = self.norm().max(other.norm());
        if n > 0.0 { d / n } else { 0.0 }
    }
}

/// Where a direction reads the frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnvLookup {
    /// Frame position, pixels (pixel centres at half-integers), inside the picture.
    pub pixel_px: DVec2,
    /// True when the direction is inside the field of view (a plain pinhole lookup).
    pub inside: bool,
    /// Weight of the blurred frame, 0 inside the picture, 1 far from it.
    pub blur: f64,
}

/// Tunables of the frame → sphere mapping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnvMapSettings {
    /// Upper bound on the downsampled frame's width, pixels.
    pub max_small_width_px: usize,
    /// Angular distance outside the picture over which the lookup blends to the blurred frame.
    pub blur_ramp_rad: f64,
    /// Box-blur radius of the blurred frame, as a fraction of the downsampled size.
    pub blur_radius_frac: f64,
}

impl Default for EnvMapSettings {
    fn default() -> Self {
        EnvMapSettings {
            max_small_width_px: 64,
            blur_ramp_rad: std::f64::consts::FRAC_PI_2,
            blur_radius_frac: 0.125,
        }
    }
}

/// Frame → SH projector for one camera (the mapping in the module doc, precomputed).
#[derive(Debug, Clone)]
pub struct EnvMapper {
    camera: Camera,
    settings: EnvMapSettings,
    bands: usize,
    block_px: usize,
    small_w: usize,
    small_h: usize,
    /// `[pixel][coeff]` weights applied to the downsampled frame.
    a_sharp: Vec<f32>,
    /// `[pixel][coeff]` weights applied to the blurred downsampled frame.
    a_blur: Vec<f32>,
}

impl EnvMapper {
    /// Precomputes the projection for `camera` with default settings.
    pub fn new(camera: &Camera, bands: usize) -> Result<EnvMapper> {
        EnvMapper::with_settings(camera, bands, EnvMapSettings::default())
    }

    /// Precomputes the projection for `camera`.
    pub fn with_settings(
        camera: &Camera,
        bands: usize,
        settings: EnvMapSettings,
    ) -> Result<EnvMapper> {
        sh::check_bands(bands)?;
        if !(settings.blur_ramp_rad > 0.0 && settings.blur_ramp_rad <= std::f64::consts::PI) {
            return Err(Error::Parameter {
                name: "blur_ramp_rad",
                value: settings.blur_ramp_rad.to_string(),
                expected: "an angle in (0, π]".into(),
            });
        }
        if !(0.0..=1.0).contains(&settings.blur_radius_frac) {
            return Err(Error::Parameter {
                name: "blur_radius_frac",
                value: settings.blur_radius_frac.to_string(),
                expected: "a fraction in [0, 1]".into(),
            });
        }
        let (w, h) = (camera.width_px as usize, camera.height_px as usize);
        if w == 0 || h == 0 {
            return Err(Error::Parameter {
                name: "frame size",
                value: format!("{w}x{h}"),
                expected: "a non-empty picture".into(),
            });
        }
        if !(camera.fov_x_rad > 0.0 && camera.fov_x_rad < std::f64::consts::PI) {
            return Err(Error::Parameter {
                name: "camera.fov_deg",
                value: camera.fov_x_rad.to_degrees().to_string(),
                expected: "a horizontal field of view in (0°, 180°)".into(),
            });
        }
        // ≈ 1° per downsampled pixel, which over-resolves 8 bands (≈ 22° per half-wave).
        let target = (camera.fov_x_rad.to_degrees().round() as usize)
            .clamp(8, settings.max_small_width_px.max(8))
            .min(w);
        let block_px = w.div_ceil(target);
        let (small_w, small_h) = (w.div_ceil(block_px), h.div_ceil(block_px));
        let mut mapper = EnvMapper {
            camera: *camera,
            settings,
            bands,
            block_px,
            small_w,
            small_h,
            a_sharp: Vec::new(),
            a_blur: Vec::new(),
        };
        mapper.precompute();
        Ok(mapper)
    }

    /// Number of bands produced.
    pub fn bands(&self) -> usize {
        self.bands
    }

    /// The camera this mapper was built for.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Side of the square block of frame pixels behind one downsampled pixel.
    pub fn block_px(&self) -> usize {
        self.block_px
    }

    /// Size of the downsampled frame, pixels.
    pub fn small_size(&self) -> (usize, usize) {
        (self.small_w, self.small_h)
    }

    /// Where direction `dir` (world, unit) reads the frame (module doc).
    pub fn lookup(&self, dir: DVec3) -> EnvLookup {
        let cam = &self.camera;
        let c = cam.world_from_camera.transpose() * dir.normalize_or(DVec3::Y);
        let f = cam.focal_px();
        let (half_w, half_h) = (0.5 * cam.width_px as f64, 0.5 * cam.height_px as f64);
        let cz = c.z.abs(); // mirror through the picture plane behind the camera
        let horiz = (c.x * c.x + cz * cz).sqrt();
        let x = if cz > 1e-12 * horiz {
            f * c.x / cz
        } else if horiz > 0.0 {
            c.x.signum() * f64::INFINITY
        } else {
            0.0 // camera pole: any column; take the centre
        };
        let xc = x.clamp(-half_w, half_w);
        let ray = (xc * xc + f * f).sqrt();
        let y = if horiz > 0.0 {
            c.y / horiz * ray
        } else {
            c.y.signum() * f64::INFINITY
        };
        let yc = y.clamp(-half_h, half_h);
        let inside = c.z > 0.0 && x.abs() <= half_w && y.abs() <= half_h;
        // Angular distance outside the picture, before mirroring.
        let az = c.x.atan2(c.z).abs();
        let d_az = (az - (half_w / f).atan()).max(0.0);
        let el = (-c.y).atan2(horiz).abs();
        let d_el = (el - (half_h / ray).atan()).max(0.0);
        let blur = if inside {
            0.0
        } else {
            (d_az.max(d_el) / self.settings.blur_ramp_rad).min(1.0)
        };
        let p = cam.principal_px() + DVec2::new(xc, yc);
        let pixel_px = DVec2::new(
            p.x.clamp(0.5, cam.width_px as f64 - 0.5),
            p.y.clamp(0.5, cam.height_px as f64 - 0.5),
        );
        EnvLookup {
            pixel_px,
            inside,
            blur,
        }
    }

    /// Bilinear taps `(small pixel index, weight)` for a frame position.
    fn taps(&self, p: DVec2) -> [(usize, f64); 4] {
        let b = self.block_px as f64;
        let u = (p.x / b - 0.5).clamp(0.0, (self.small_w - 1) as f64);
        let v = (p.y / b - 0.5).clamp(0.0, (self.small_h - 1) as f64);
        let (x0, y0) = (u.floor() as usize, v.floor() as usize);
        let (x1, y1) = (
            (x0 + 1).min(self.small_w - 1),
            (y0 + 1).min(self.small_h - 1),
        );
        let (fx, fy) = (u - x0 as f64, v - y0 as f64);
        let i = |x: usize, y: usize| y * self.small_w + x;
        [
            (i(x0, y0), (1.0 - fx) * (1.0 - fy)),
            (i(x1, y0), fx * (1.0 - fy)),
            (i(x0, y1), (1.0 - fx) * fy),
            (i(x1, y1), fx * fy),
        ]
    }

    fn precompute(&mut self) {
        let nc = self.bands * self.bands;
        let npx = self.small_w * self.small_h;
        // Sphere grid at about half a downsampled pixel, exact texel solid angles.
        let px_rad = self.camera.fov_x_rad / self.small_w as f64;
        let eq_w = ((4.0 * std::f64::consts::PI / px_rad).ceil() as usize).clamp(256, 2048);
        let eq_h = eq_w / 2;
        let (sharp, blur) = (0..eq_h)
            .into_par_iter()
            .fold(
                || (vec![0.0f64; npx * nc], vec![0.0f64; npx * nc]),
                |(mut sharp, mut blur), row| {
                    let w_sr = sh::equirect_texel_solid_angle_sr(row, eq_w, eq_h);
                    let mut y = vec![0.0; nc];
                    for col in 0..eq_w {
                        let d = sh::equirect_direction(col, row, eq_w, eq_h);
                        sh::eval_basis(d, self.bands, &mut y);
                        let lk = self.lookup(d);
                        for (px, tw) in self.taps(lk.pixel_px) {
                            let (ws, wb) = (w_sr * tw * (1.0 - lk.blur), w_sr * tw * lk.blur);
                            for i in 0..nc {
                                sharp[px * nc + i] += ws * y[i];
                                blur[px * nc + i] += wb * y[i];
                            }
                        }
                    }
                    (sharp, blur)
                },
            )
            .reduce(
                || (vec![0.0f64; npx * nc], vec![0.0f64; npx * nc]),
                |(mut a, mut b), (c, d)| {
                    a.iter_mut().zip(c).for_each(|(x, y)| *x += y);
                    b.iter_mut().zip(d).for_each(|(x, y)| *x += y);
                    (a, b)
                },
            );
        self.a_sharp = sharp.into_iter().map(|v| v as f32).collect();
        self.a_blur = blur.into_iter().map(|v| v as f32).collect();
    }

    fn check_frame(&self, frame: &[[f32; 3]]) -> Result<()> {
        let (w, h) = (
            self.camera.width_px as usize,
            self.camera.height_px as usize,
        );
        if frame.len() != w * h {
            return Err(Error::Parameter {
                name: "frame",
                value: format!("{} pixels", frame.len()),
                expected: format!("{w}x{h} = {} pixels, matching the camera", w * h),
            });
        }
        Ok(())
    }

    /// Box-downsamples a linear RGB frame (row-major, the camera's size) by the mapper's block.
    pub fn downsample(&self, frame: &[[f32; 3]]) -> Result<Vec<[f32; 3]>> {
        self.check_frame(frame)?;
        let (w, h, b) = (
            self.camera.width_px as usize,
            self.camera.height_px as usize,
            self.block_px,
        );
        let mut small = vec![[0.0f32; 3]; self.small_w * self.small_h];
        small
            .par_chunks_mut(self.small_w)
            .enumerate()
            .for_each(|(sy, out)| {
                let rows = sy * b..((sy + 1) * b).min(h);
                let n_rows = rows.len();
                for y in rows {
                    let line = &frame[y * w..(y + 1) * w];
                    for (sx, o) in out.iter_mut().enumerate() {
                        let mut acc = [0.0f32; 3];
                        for p in &line[sx * b..((sx + 1) * b).min(w)] {
                            acc[0] += p[0];
                            acc[1] += p[1];
                            acc[2] += p[2];
                        }
                        o[0] += acc[0];
                        o[1] += acc[1];
                        o[2] += acc[2];
                    }
                }
                for (sx, o) in out.iter_mut().enumerate() {
                    let n = (n_rows * (((sx + 1) * b).min(w) - sx * b)) as f32;
                    o.iter_mut().for_each(|v| *v /= n);
                }
            });
        Ok(small)
    }

    /// The strongly blurred copy of a downsampled frame (two separable box passes, edges
    /// renormalised).
    pub fn blur_small(&self, small: &[[f32; 3]]) -> Vec<[f32; 3]> {
        let (w, h) = (self.small_w, self.small_h);
        let rx = ((w as f64 * self.settings.blur_radius_frac).round() as usize).max(1);
        let ry = ((h as f64 * self.settings.blur_radius_frac).round() as usize).max(1);
        let pass = |src: &[[f32; 3]], horizontal: bool, r: usize| -> Vec<[f32; 3]> {
            let mut out = vec![[0.0f32; 3]; w * h];
            for y in 0..h {
                for x in 0..w {
                    let (c, n) = if horizontal { (x, w) } else { (y, h) };
                    let (lo, hi) = (c.saturating_sub(r), (c + r).min(n - 1));
                    let mut acc = [0.0f32; 3];
                    for k in lo..=hi {
                        let p = if horizontal {
                            src[y * w + k]
                        } else {
                            src[k * w + x]
                        };
                        (0..3).for_each(|i| acc[i] += p[i]);
                    }
                    let cnt = (hi - lo + 1) as f32;
                    out[y * w + x] = acc.map(|v| v / cnt);
                }
            }
            out
        };
        let mut img = small.to_vec();
        for _ in 0..2 {
            img = pass(&img, true, rx);
            img = pass(&img, false, ry);
        }
        img
    }

    /// SH coefficients of the environment of a linear RGB frame (row-major, camera size).
    pub fn project(&self, frame: &[[f32; 3]]) -> Result<EnvironmentSh> {
        let small = self.downsample(frame)?;
        Ok(self.project_small(&small))
    }

    /// SH coefficients from an already downsampled frame ([`EnvMapper::downsample`]).
    pub fn project_small(&self, small: &[[f32; 3]]) -> EnvironmentSh {
        let blurred = self.blur_small(small);
        let nc = self.bands * self.bands;
        let mut acc = vec![[0.0f64; 3]; nc];
        for (px, (s, b)) in small.iter().zip(&blurred).enumerate() {
            let (rs, rb) = (
                &self.a_sharp[px * nc..][..nc],
                &self.a_blur[px * nc..][..nc],
            );
            for i in 0..nc {
                for k in 0..3 {
                    acc[i][k] += f64::from(rs[i] * s[k] + rb[i] * b[k]);
                }
            }
        }
        EnvironmentSh {
            bands: self.bands,
            coeffs: acc.iter().map(|c| c.map(|v| v as f32)).collect(),
        }
    }

    /// The mapping itself as a `width × height` equirectangular image (texel centres per
    /// [`sh::equirect_direction`]), for inspection.
    pub fn equirect(
        &self,
        frame: &[[f32; 3]],
        width: usize,
        height: usize,
    ) -> Result<Vec<[f32; 3]>> {
        let small = self.downsample(frame)?;
        let blurred = self.blur_small(&small);
        let mut out = Vec::with_capacity(width * height);
        for row in 0..height {
            for col in 0..width {
                let lk = self.lookup(sh::equirect_direction(col, row, width, height));
                let mut c = [0.0f64; 3];
                for (px, tw) in self.taps(lk.pixel_px) {
                    for k in 0..3 {
                        c[k] += tw
                            * ((1.0 - lk.blur) * f64::from(small[px][k])
                                + lk.blur * f64::from(blurred[px][k]));
                    }
                }
                out.push(c.map(|v| v as f32));
            }
        }
        Ok(out)
    }
}

/// The band-limited environment sampled on a `width × height` equirectangular grid.
pub fn reconstruct_equirect(env: &EnvironmentSh, width: usize, height: usize) -> Vec<[f32; 3]> {
    (0..width * height)
        .map(|i| {
            env.eval(sh::equirect_direction(i % width, i / width, width, height))
                .map(|v| v as f32)
        })
        .collect()
}

/// Temporal smoothing of the environment, reset on scene cuts: a pure function of the frames
/// in a short window, so any frame can be reproduced by feeding the frames before it
/// (`preview` does exactly that) and the result never depends on where decoding started.
///
/// The output at time t is the average of the raw coefficients of the frames in
/// (t − W, t], weighted by `exp(−(t − t_k)/τ)` (an exponential filter truncated at W = 4τ,
/// where the weights have fallen below 2 %), over the frames after the last **cut** in the
/// window. A cut is declared when the normalised distance between consecutive raw coefficient
/// vectors ([`EnvironmentSh::normalised_distance`], the relative L2 change of the band-limited
/// environment) exceeds the threshold, so a cut never smears the previous shot's light into
/// the next. Default threshold 0.3: within a shot the low-frequency light changes by a few
/// percent per frame (a 30°/s pan moves it 1° per frame at 30 fps, far below what 4 bands
/// resolve), while a cut to another shot typically changes the mean level, tint or the
/// sky/ground dipole by tens of percent. A lightning flash also trips it, which is what the
/// rain should do then.
#[derive(Debug, Clone)]
pub struct ShSmoother {
    time_constant_secs: f64,
    cut_threshold: f64,
    window: std::collections::VecDeque<(f64, EnvironmentSh)>,
    /// What the last frame's cut test compared against (see [`ShSmoother::update_keyed`]).
    last_key: Option<EnvironmentSh>,
    last_was_cut: bool,
}

impl Default for ShSmoother {
    fn default() -> Self {
        ShSmoother {
            time_constant_secs: ShSmoother::DEFAULT_TIME_CONSTANT_SECS,
            cut_threshold: ShSmoother::DEFAULT_CUT_THRESHOLD,
            window: Default::default(),
            last_key: None,
            last_was_cut: false,
        }
    }
}

impl ShSmoother {
    /// Default time constant τ, seconds.
    pub const DEFAULT_TIME_CONSTANT_SECS: f64 = 0.25;
    /// Default cut threshold on the normalised distance.
    pub const DEFAULT_CUT_THRESHOLD: f64 = 0.3;
    /// Window length in time constants.
    pub const WINDOW_TIME_CONSTANTS: f64 = 4.0;

    /// A smoother with time constant `time_constant_secs` (0 disables smoothing) and cut
    /// threshold `cut_threshold` in (0, 2] (2 never cuts).
    pub fn new(time_constant_secs: f64, cut_threshold: f64) -> Result<ShSmoother> {
        if !(time_constant_secs.is_finite() && time_constant_secs >= 0.0) {
            return Err(Error::Parameter {
                name: "light.smoothing_s",
                value: time_constant_secs.to_string(),
                expected: "a time constant in seconds, ≥ 0 (0 = off)".into(),
            });
        }
        if !(cut_threshold > 0.0 && cut_threshold <= 2.0) {
            return Err(Error::Parameter {
                name: "smoother.cut_threshold",
                value: cut_threshold.to_string(),
                expected: "a normalised distance in (0, 2]".into(),
            });
        }
        Ok(ShSmoother {
            time_constant_secs,
            cut_threshold,
            ..ShSmoother::default()
        })
    }

    /// How far back a frame still counts, seconds: the frames in (t − window, t] decide the
    /// output at t.
    pub fn window_secs(&self) -> f64 {
        Self::WINDOW_TIME_CONSTANTS * self.time_constant_secs
    }

    /// Feeds the coefficients of the frame at `t_secs` (increasing); returns the smoothed
    /// environment at that time.
    pub fn update(&mut self, raw: &EnvironmentSh, t_secs: f64) -> EnvironmentSh {
        self.update_keyed(raw, raw, t_secs)
    }

    /// As [`update`](Self::update), but scene cuts are detected on `key` instead of `raw`:
    /// the frame's display-referred environment, when `raw` carries light recovered from
    /// clipped pixels, whose estimate moves more from frame to frame than the picture does.
    pub fn update_keyed(
        &mut self,
        raw: &EnvironmentSh,
        key: &EnvironmentSh,
        t_secs: f64,
    ) -> EnvironmentSh {
        let cut = self
            .last_key
            .as_ref()
            .is_some_and(|prev| prev.normalised_distance(key) > self.cut_threshold);
        self.last_key = Some(key.clone());
        self.last_was_cut = cut;
        if cut || self.time_constant_secs == 0.0 {
            self.window.clear();
        }
        self.window.push_back((t_secs, raw.clone()));
        let horizon = t_secs - self.window_secs();
        while self.window.len() > 1 && self.window.front().is_some_and(|(t, _)| *t <= horizon) {
            self.window.pop_front();
        }
        let mut sum = vec![[0.0f64; 3]; raw.coeffs.len()];
        let mut total = 0.0;
        for (t, env) in &self.window {
            let w = if self.time_constant_secs > 0.0 {
                (-(t_secs - t) / self.time_constant_secs).exp()
            } else {
                1.0
            };
            total += w;
            for (acc, c) in sum.iter_mut().zip(&env.coeffs) {
                for k in 0..3 {
                    acc[k] += w * c[k] as f64;
                }
            }
        }
        EnvironmentSh {
            bands: raw.bands,
            coeffs: sum.iter().map(|a| a.map(|v| (v / total) as f32)).collect(),
        }
    }

    /// True when the last [`update`](Self::update) detected a cut.
    pub fn last_was_cut(&self) -> bool {
        self.last_was_cut
    }

    /// Forgets the history (e.g. after a seek).
    pub fn reset(&mut self) {
        self.window.clear();
        self.last_key = None;
        self.last_was_cut = false;
    }
}
