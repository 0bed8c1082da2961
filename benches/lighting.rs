//! Lighting costs: environment projection per 1080p frame, RTF tables and zonal coefficients,
//! and the per-pixel PRT colour (CPU twin of the shader).
//!
//! `cargo bench --bench lighting`

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use rain_composite::lighting::envmap::EnvMapper;
use rain_composite::lighting::prt::{RtfSh, prt_colour_f64};
use rain_composite::lighting::rtf::{DropOptics, WATER_RHO_RGB};
use rain_composite::lighting::sh;
use rain_composite::scene::Camera;

fn envmap(c: &mut Criterion) {
    let cam = Camera::new(1920, 1080, 60f64.to_radians(), 1.6, 0.0, 0.0);
    let mapper = EnvMapper::new(&cam, 4).expect("mapper");
    let frame: Vec<[f32; 3]> = (0..1920 * 1080)
        .map(|i| [(i % 1920) as f32 / 1920.0, 0.5, (i / 1920) as f32 / 1080.0])
        .collect();
    c.bench_function("envmap_project_1080p_4_bands", |b| {
        b.iter(|| mapper.project(black_box(&frame)).expect("project"))
    });
    c.bench_function("envmap_setup_1080p_4_bands", |b| {
        b.iter(|| EnvMapper::new(black_box(&cam), 4).expect("mapper"))
    });
}

fn rtf(c: &mut Criterion) {
    let optics = DropOptics::new(1.333, 9).expect("optics");
    c.bench_function("rtf_tabulate_1024_bins_9_orders", |b| {
        b.iter(|| black_box(&optics).tabulate(1024).expect("table"))
    });
    c.bench_function("rtf_zonal_gamma_8_bands_9_orders", |b| {
        b.iter(|| black_box(&optics).zonal(8))
    });
}

fn prt(c: &mut Criterion) {
    let rtf = RtfSh::water(WATER_RHO_RGB, 9, 4).expect("rtf");
    let env: Vec<[f64; 3]> = (0..16).map(|i| [1.0 / (1 + i) as f64; 3]).collect();
    let v = DVec3::new(0.3, 0.8, -0.2).normalize();
    c.bench_function("prt_colour_4_bands_per_pixel", |b| {
        b.iter(|| prt_colour_f64(black_box(&env), &rtf, black_box(v)))
    });
    c.bench_function("sh_basis16_cartesian", |b| {
        b.iter(|| sh::basis16_cartesian(black_box(v)))
    });
    let mut out = [0.0; 16];
    c.bench_function("sh_eval_basis_4_bands", |b| {
        b.iter(|| sh::eval_basis(black_box(v), 4, &mut out))
    });
}

criterion_group!(benches, envmap, rtf, prt);
criterion_main!(benches);
