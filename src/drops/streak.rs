//! One streak: the image of an oscillating drop falling at terminal velocity through one
//! exposure, seen by an orthographic camera, under a uniform environment and under distant
//! point lights, integrated over the exposure.
//!
//! Frame: z up, the drop falls along −z; the camera sits at elevation e towards −y and looks
//! along v = (0, cos e, −sin e); image right is +x, image up w = (0, sin e, cos e), so the fall
//! projects onto the image's −w with speed V cos e. A light at elevation θ and azimuth φ lies
//! towards (sin φ cos θ, −cos φ cos θ, sin θ): φ = 0 behind the camera, φ = 180° behind the drop,
//! φ = 90° on the image's right.
//!
//! A matte's value at a pixel is the drop's radiance there averaged over the pixel and the
//! exposure, M = (1/T)∫ (1/|px|)∫ L dA dt, for an environment of radiance 1 or a light of
//! irradiance 1 (then in sr⁻¹, like the RTF's F). Summed over the pixels it is the drop's
//! time-averaged projected area in px² times its mean radiance (Garg & Nayar's time fraction:
//! a pixel the drop covers for τ of T holds τ/T of the drop's radiance).

use glam::DVec3;
use rayon::prelude::*;

use super::shape::{Amplitudes, OscillatingDrop, rayleigh_frequency_hz};
use super::trace::trace;
use crate::rain::physics::terminal_velocity_gk_mps;
use crate::{Error, Result};

/// A light direction relative to the camera, degrees.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LightAngles {
    /// Elevation above the horizontal.
    pub elevation_deg: f64,
    /// Azimuth from the camera's side (0 = behind the camera, 90 = image right, 180 = behind
    /// the drop).
    pub azimuth_deg: f64,
}

impl LightAngles {
    /// Unit vector from the drop towards the light.
    pub fn direction(&self) -> DVec3 {
        let (t, p) = (
            self.elevation_deg.to_radians(),
            self.azimuth_deg.to_radians(),
        );
        DVec3::new(p.sin() * t.cos(), -p.cos() * t.cos(), t.sin())
    }
}

/// Everything one streak depends on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreakSetup {
    /// Equivalent drop diameter, m.
    pub diameter_m: f64,
    /// Oscillation amplitudes.
    pub amplitudes: Amplitudes,
    /// Exposure time, s.
    pub exposure_s: f64,
    /// Camera elevation above the horizontal, degrees, in [0, 85].
    pub view_elevation_deg: f64,
    /// Oscillation phase at shutter open as a fraction of the (2,0) period (the drop's age
    /// in periods; both modes start at their maximum at age 0).
    pub phase: f64,
    /// Azimuth of the transverse (3,1) mode's axis from the camera's side, degrees (0 keeps the
    /// drop mirror-symmetric about the plane of view and fall).
    pub transverse_azimuth_deg: f64,
    /// Pixel pitch, m.
    pub pixel_m: f64,
    /// Samples per pixel side and time steps per pixel of travel.
    pub samples: usize,
    /// Highest scattering order traced.
    pub orders: usize,
    /// Refractive index of water.
    pub rho: f64,
    /// Angular radius of the point lights (σ of a von Mises–Fisher lobe), degrees.
    pub light_width_deg: f64,
}

/// The mattes of one streak, row-major, top row first (the drop falls down the image).
#[derive(Debug, Clone, PartialEq)]
pub struct Streak {
    /// Width, px.
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// Terminal velocity, m/s.
    pub fall_speed_mps: f64,
    /// Distance the drop's centre travels across the image in the exposure, px.
    pub travel_px: f64,
    /// Row of the drop's centre at shutter open.
    pub start_row: f64,
    /// Time fraction covered: 1 where the drop covers the pixel all the exposure.
    pub coverage: Vec<f64>,
    /// Uniform environment of radiance 1.
    pub env: Vec<f64>,
    /// One matte per light, irradiance 1.
    pub lights: Vec<Vec<f64>>,
}

impl StreakSetup {
    /// Checks the ranges a user can reach from the command line.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, value: f64, expected: &str| Error::Parameter {
            name,
            value: value.to_string(),
            expected: expected.into(),
        };
        if !(self.diameter_m.is_finite() && (0.1e-3..=6e-3).contains(&self.diameter_m)) {
            return Err(bad(
                "drops.sizes_mm",
                // Back to the millimetres the user typed (µm precision).
                (self.diameter_m * 1e6).round() / 1e3,
                "drop diameters in [0.1, 6] mm",
            ));
        }
        if !(self.exposure_s.is_finite() && (1e-5..=1.0).contains(&self.exposure_s)) {
            return Err(bad(
                "drops.exposures_s",
                self.exposure_s,
                "exposure times in [1e-5, 1] s",
            ));
        }
        if !(0.0..=85.0).contains(&self.view_elevation_deg) {
            return Err(bad(
                "drops.view_elevations_deg",
                self.view_elevation_deg,
                "elevations in [0, 85] degrees",
            ));
        }
        if !(self.pixel_m.is_finite() && self.pixel_m > 0.0 && self.pixel_m <= self.diameter_m) {
            return Err(bad(
                "drops.pixels_per_diameter",
                self.diameter_m / self.pixel_m,
                "at least 1",
            ));
        }
        if !(1..=16).contains(&self.samples) {
            return Err(bad("drops.samples", self.samples as f64, "1 to 16"));
        }
        if !(1..=32).contains(&self.orders) {
            return Err(bad("drops.orders", self.orders as f64, "1 to 32"));
        }
        if !(self.light_width_deg > 0.1 && self.light_width_deg <= 45.0) {
            return Err(bad(
                "drops.light_width_deg",
                self.light_width_deg,
                "degrees in (0.1, 45]",
            ));
        }
        Ok(())
    }

    /// The drop's equivalent radius in pixels.
    pub fn radius_px(&self) -> f64 {
        0.5 * self.diameter_m / self.pixel_m
    }

    /// Renders the streak under a uniform environment and under each light.
    pub fn render(&self, lights: &[LightAngles]) -> Result<Streak> {
        self.render_or_stop(lights, &std::sync::atomic::AtomicBool::new(false))
    }

    /// [`render`](Self::render), stopping with [`Error::Interrupted`] once `cancel` is set
    /// (polled per pixel: a fine streak takes minutes).
    pub fn render_or_stop(
        &self,
        lights: &[LightAngles],
        cancel: &std::sync::atomic::AtomicBool,
    ) -> Result<Streak> {
        use std::sync::atomic::Ordering;
        self.validate()?;
        let e = self.view_elevation_deg.to_radians();
        let view = DVec3::new(0.0, e.cos(), -e.sin());
        let up = DVec3::new(0.0, e.sin(), e.cos());
        let right = DVec3::X;
        let az = self.transverse_azimuth_deg.to_radians();
        let drop = OscillatingDrop::new(
            self.diameter_m,
            self.amplitudes,
            DVec3::new(az.sin(), -az.cos(), 0.0),
        );
        let bound_px = drop.at(0.0).bound_m / self.pixel_m;
        let speed = terminal_velocity_gk_mps(self.diameter_m * 1e3);
        let travel_px = speed * e.cos() * self.exposure_s / self.pixel_m;
        let half_width = bound_px.ceil() as usize + 1;
        let width = 2 * half_width;
        let start_row = bound_px + 1.0;
        let height = (2.0 * bound_px + travel_px).ceil() as usize + 2;
        let s = self.samples;
        let steps = ((s as f64 * travel_px).ceil() as usize).max(4 * s);
        let dt = self.exposure_s / steps as f64;
        let rows_per_s = speed * e.cos() / self.pixel_m;
        let age0 = self.phase / rayleigh_frequency_hz(2, self.diameter_m);
        let dirs: Vec<DVec3> = lights.iter().map(LightAngles::direction).collect();
        let kappa = self.light_width_deg.to_radians().powi(-2);
        let lobe_peak = kappa / (std::f64::consts::TAU * -(-2.0 * kappa).exp_m1());
        let far = 4.0 * drop.at(0.0).bound_m;
        let stride = 2 + dirs.len();
        let norm = 1.0 / (steps * s * s) as f64;

        let mut out = vec![0.0; width * height * stride];
        out.par_chunks_mut(stride).enumerate().for_each(|(k, acc)| {
            if cancel.load(Ordering::Relaxed) {
                return;
            }
            let (col, row) = (k % width, k / width);
            for b in 0..s {
                let y = row as f64 + (b as f64 + 0.5) / s as f64;
                let t_off = (b as f64 + 0.5) / s as f64;
                // Steps whose drop centre row lies within the bound of y.
                let (lo, hi) = if rows_per_s * dt > 0.0 {
                    let j = |row_c: f64| (row_c - start_row) / (rows_per_s * dt) - t_off;
                    let lo = j(y - bound_px).ceil().max(0.0) as usize;
                    let hi = (j(y + bound_px).floor() + 1.0).clamp(0.0, steps as f64) as usize;
                    (lo, hi)
                } else {
                    (0, steps)
                };
                for step in lo..hi {
                    let t = (step as f64 + t_off) * dt;
                    let shape = drop.at(age0 + t);
                    let dy = -(y - (start_row + rows_per_s * t)) * self.pixel_m;
                    for a in 0..s {
                        let dx = (col as f64 + (a as f64 + 0.5) / s as f64 - half_width as f64)
                            * self.pixel_m;
                        let origin = dx * right + dy * up - far * view;
                        let hit = trace(&shape, self.rho, self.orders, origin, view, |x| {
                            acc[1] += x.weight;
                            for (l, dir) in dirs.iter().enumerate() {
                                let mu = x.towards_light.dot(*dir);
                                acc[2 + l] += x.weight * lobe_peak * (kappa * (mu - 1.0)).exp();
                            }
                        });
                        if hit {
                            acc[0] += 1.0;
                        }
                    }
                }
            }
            acc.iter_mut().for_each(|v| *v *= norm);
        });
        if cancel.load(Ordering::Relaxed) {
            return Err(Error::Interrupted);
        }
        let channel = |c: usize| {
            out.iter()
                .skip(c)
                .step_by(stride)
                .copied()
                .collect::<Vec<f64>>()
        };
        Ok(Streak {
            width,
            height,
            fall_speed_mps: speed,
            travel_px,
            start_row,
            coverage: channel(0),
            env: channel(1),
            lights: (0..dirs.len()).map(|l| channel(2 + l)).collect(),
        })
    }
}
