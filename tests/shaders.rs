//! Every WGSL stage parses and validates with naga, and every Rust twin of a WGSL struct has
//! the WGSL's size and field offsets.

use naga::valid::{Capabilities, ValidationFlags, Validator};
use rain_composite::gpu::shaders::Stage;
use rain_composite::gpu::types::{
    Column, DirectLight, FrameParams, Glint, LightList, MatteParams, PuddleParams, RainParams,
    Ripple, Streak, TileParams, WetParams,
};

fn module(stage: Stage) -> naga::Module {
    let src = stage.source();
    let module = naga::front::wgsl::parse_str(&src)
        .unwrap_or_else(|e| panic!("{}: {}", stage.name(), e.emit_to_string(&src)));
    Validator::new(ValidationFlags::all(), Capabilities::all())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}: {e:?}", stage.name()));
    module
}

#[test]
fn every_stage_validates() {
    for stage in Stage::ALL {
        module(stage);
    }
}

/// (size, [(field name, offset)]) of a WGSL struct as naga lays it out.
fn layout(module: &naga::Module, name: &str) -> (u32, Vec<(String, u32)>) {
    for (_, ty) in module.types.iter() {
        if ty.name.as_deref() == Some(name) {
            if let naga::TypeInner::Struct { members, span } = &ty.inner {
                return (
                    *span,
                    members
                        .iter()
                        .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                        .collect(),
                );
            }
        }
    }
    panic!("struct {name} not found");
}

macro_rules! assert_twin {
    ($module:expr, $ty:ty, [$($field:ident),* $(,)?]) => {{
        let (size, fields) = layout(&$module, stringify!($ty));
        assert_eq!(size as usize, std::mem::size_of::<$ty>(), "size of {}", stringify!($ty));
        let rust: Vec<(String, u32)> = vec![$((stringify!($field).to_string(), std::mem::offset_of!($ty, $field) as u32)),*];
        assert_eq!(fields, rust, "fields of {}", stringify!($ty));
    }};
}

#[test]
fn wet_params_twin_matches_wgsl_layout() {
    let m = module(Stage::WetGround);
    assert_twin!(
        m,
        WetParams,
        [
            wetness,
            water_index,
            diffuse_external,
            diffuse_internal,
            reach_m,
            _pad0,
            _pad1,
            _pad2
        ]
    );
}

#[test]
fn puddle_twins_match_wgsl_layout() {
    let m = module(Stage::Puddles);
    assert_twin!(
        m,
        PuddleParams,
        [
            origin_m,
            cell_m,
            edge_depth_m,
            cells,
            ring_count,
            far_slope_rms,
            water_index,
            diffuse_external,
            diffuse_internal,
            light_lobe,
            resolve_depth_m,
            _pad0,
            _pad1,
            _pad2
        ]
    );
    assert_twin!(
        m,
        Ripple,
        [
            centre_m,
            radius_m,
            width_m,
            amplitude_m,
            wavenumber,
            phase,
            _pad
        ]
    );
}

#[test]
fn rust_twins_match_wgsl_layouts() {
    let m = module(Stage::RainStreaks);
    assert_twin!(
        m,
        RainParams,
        [
            camera_pos_m,
            focal_px,
            camera_from_world_0,
            camera_from_world_1,
            camera_from_world_2,
            principal_px,
            display_size_px,
            coded_from_display,
            coded_offset_px,
            coded_size_px,
            column_slope,
            cell_size_m,
            wind_mean_mps,
            mean_travel_cells,
            haze,
            env_sh,
            drop_zonal,
            gust_amp,
            gust_phase,
            time_whole_s,
            time_frac_s,
            exposure_s,
            seed,
            drop_count,
            column_count,
            opacity,
            near_clip_m,
            drop_weight,
            d_min_mm,
            d_max_mm,
            lambda_per_mm,
            diameter_scale,
            lens_blur_k_px_m,
            inv_focus_per_m,
            gravity_mps2,
            drift_q,
            ground_clip,
            _pad,
            wind_slope_mps2,
            wind_start_mps,
            wind_kink_count,
            rate_key_count,
            _pad_keys,
            wind_kinks,
            rate_keys,
            speed_q,
        ]
    );
    assert_twin!(
        m,
        Column,
        [
            cell_min_m,
            z_lo_m,
            height_m,
            first_drop,
            drop_count,
            inv_height_q,
            size_keep_q
        ]
    );
    let m = module(Stage::RainSimulate);
    assert_twin!(
        m,
        Streak,
        [
            q0_px,
            dir,
            len_px,
            r_eff_px,
            alpha_scale,
            drop_info,
            radiance0,
            radiance1
        ]
    );
    assert_twin!(m, DirectLight, [direction_distance, strength]);
    assert_twin!(
        module(Stage::RainStreaks),
        MatteParams,
        [counts, sizes_mm, views_deg, lights, light_count, reach]
    );
    assert_twin!(module(Stage::RainSimulate), Glint, [colour, light_dir]);
    assert_twin!(
        module(Stage::StreakTiles),
        TileParams,
        [tiles_xy, streak_count, capacity]
    );
    assert_twin!(m, LightList, [count, table_bins, _pad, lights]);
    let m = module(Stage::YuvToRgb);
    assert_twin!(
        m,
        FrameParams,
        [
            width,
            height,
            chroma_shift_x,
            chroma_shift_y,
            y_offset,
            y_scale,
            c_offset,
            c_scale,
            max_code,
            transfer,
            kr,
            kb,
            bytes_per_sample,
            y_row_words,
            c_row_words,
            cb_offset_words,
            cr_offset_words,
            chroma_width,
            chroma_height,
            _pad,
        ]
    );
}

#[test]
fn stage_sources_take_their_includes_and_constants_from_the_declarations() {
    use rain_composite::gpu::shaders::{constants, includes};
    let simulate = Stage::RainSimulate.source();
    // The header spans two comment lines; every module it names is included once, in order.
    assert_eq!(
        includes(Stage::RainSimulate.body()),
        [
            "common/types.wgsl",
            "common/rng.wgsl",
            "common/drops.wgsl",
            "common/sh.wgsl",
            "common/camera.wgsl",
            "common/lights.wgsl",
            "common/streak.wgsl"
        ]
    );
    assert_eq!(
        includes(Stage::RainStreaks.body()),
        [
            "common/types.wgsl",
            "common/rng.wgsl",
            "common/depth.wgsl",
            "common/capsule.wgsl"
        ]
    );
    assert!(simulate.starts_with(&constants()));
    assert_eq!(simulate.matches("fn pcg_hash").count(), 1);
    // Sizes are defined once, in Rust: no WGSL file repeats them as literals.
    let gusts = format!("const GUSTS: u32 = {}u;", rain_composite::gpu::types::GUSTS);
    assert!(constants().contains(&gusts));
    for stage in Stage::ALL {
        let body = stage.body();
        assert!(!body.contains("workgroup_size(64)") && !body.contains("workgroup_size(16"));
    }
    let types = Stage::RainStreaks.source();
    assert!(types.contains("array<vec4<f32>, GUSTS>"));
    assert!(types.contains("array<DirectLight, MAX_LIGHTS>"));
}

/// Every pipeline's inferred bind-group layout (`layout: None`: what its entry point uses, as
/// naga's analysis reports it) stays within wgpu's downlevel limits per shader stage, so the
/// device the compositor opens with those limits (GLES 3.1-class adapters offer no more:
/// four storage buffers a stage) builds every stage.
#[test]
fn every_entry_point_fits_the_downlevel_limits() {
    let limits = wgpu::Limits::downlevel_defaults();
    let mut over = Vec::new();
    for stage in Stage::ALL {
        let src = stage.source();
        let module = naga::front::wgsl::parse_str(&src).expect("parses");
        let info = Validator::new(ValidationFlags::all(), Capabilities::all())
            .validate(&module)
            .expect("validates");
        for (i, entry) in module.entry_points.iter().enumerate() {
            let uses = info.get_entry_point(i);
            let (mut storage, mut uniform, mut sampled, mut storage_textures, mut samplers) =
                (0, 0, 0, 0, 0);
            for (handle, var) in module.global_variables.iter() {
                if uses[handle].is_empty() || var.binding.is_none() {
                    continue;
                }
                match (var.space, &module.types[var.ty].inner) {
                    (naga::AddressSpace::Storage { .. }, _) => storage += 1,
                    (naga::AddressSpace::Uniform, _) => uniform += 1,
                    (_, naga::TypeInner::Image { class, .. }) => match class {
                        naga::ImageClass::Storage { .. } => storage_textures += 1,
                        _ => sampled += 1,
                    },
                    (_, naga::TypeInner::Sampler { .. }) => samplers += 1,
                    (space, ty) => panic!("{}: {space:?} {ty:?}", stage.name()),
                }
            }
            let counts = [
                (
                    "storage buffers",
                    storage,
                    limits.max_storage_buffers_per_shader_stage,
                ),
                (
                    "uniform buffers",
                    uniform,
                    limits.max_uniform_buffers_per_shader_stage,
                ),
                (
                    "sampled textures",
                    sampled,
                    limits.max_sampled_textures_per_shader_stage,
                ),
                (
                    "storage textures",
                    storage_textures,
                    limits.max_storage_textures_per_shader_stage,
                ),
                ("samplers", samplers, limits.max_samplers_per_shader_stage),
            ];
            eprintln!("{}::{}: {counts:?}", stage.name(), entry.name);
            for (what, n, max) in counts {
                if n > max {
                    over.push(format!(
                        "{}::{}: {n} {what} > {max}",
                        stage.name(),
                        entry.name
                    ));
                }
            }
        }
    }
    assert!(over.is_empty(), "{over:#?}");
}
