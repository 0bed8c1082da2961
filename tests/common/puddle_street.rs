//! The street the puddle tests simulate: a camera looking down it, the rain on its ground, and
//! the water's ledger checked to the particle and to the drop.
#![allow(dead_code)]

use rain_composite::config::RenderConfig;
use rain_composite::fluid::puddles::PuddleSim;
use rain_composite::gpu::uniforms::RainSetup;
use rain_composite::rain::volume::GroundRain;
use rain_composite::scene::Camera;

/// A camera looking down the street (the horizon 10 % from the top, a 90° lens, 1.6 m up) on a
/// `w`×`h` picture, over `rain_mm_per_h` of rain that has fallen for `pre_rain_min`, with
/// `relief_m` of micro-relief.
pub fn street_of(
    (w, h): (u32, u32),
    rain_mm_per_h: f64,
    pre_rain_min: f64,
    relief_m: f64,
) -> (RenderConfig, Camera) {
    let mut c = RenderConfig::default();
    c.ground.mode = "horizon=0.1".parse().expect("mode");
    c.camera.fov_deg = 90.0;
    c.rain.rate_mm_per_h = rain_mm_per_h;
    c.ground.pre_rain_min = pre_rain_min;
    c.ground.relief_m = relief_m;
    let camera = c.camera(w, h).expect("camera");
    (c, camera)
}

/// [`street_of`] on a 320×240 picture.
pub fn street(rain_mm_per_h: f64, pre_rain_min: f64, relief_m: f64) -> (RenderConfig, Camera) {
    street_of((320, 240), rain_mm_per_h, pre_rain_min, relief_m)
}

/// The rain of `config` on the ground seen by `camera` (exposed 0.02 s), as a render's frames
/// land it.
pub fn ground_rain(config: &RenderConfig, camera: &Camera) -> GroundRain {
    let rain = rain_composite::shot::rain::plan(
        camera,
        &config.camera,
        &config.rain,
        0.02,
        0,
        (camera.width_px, camera.height_px),
    )
    .map(RainSetup::pack)
    .expect("rain");
    GroundRain::new(rain.rainfall())
}

/// The particles to the particle: in − out = present, and every particle inserted was placed
/// at the start or came with the rain.
pub fn assert_particles_balance(sim: &PuddleSim) {
    let l = sim.ledger();
    let p = l.particles;
    assert_eq!(
        p.inserted - p.outflow - p.soaked - p.discarded,
        l.particles_present
    );
    assert_eq!(p.inserted, l.initial_particles + l.rain_particles);
}

/// Every drop that landed is in a counter or, S of them at a time, in a particle (5.31).
pub fn assert_drops_counted(sim: &PuddleSim) {
    let l = sim.ledger();
    let s = sim.flow().precipitation.scale() as u64;
    let counted: u64 = sim
        .flow()
        .precipitation
        .counters()
        .iter()
        .map(|&c| c as u64)
        .sum();
    assert_eq!(l.rain_drops, s * l.rain_particles + counted);
}
