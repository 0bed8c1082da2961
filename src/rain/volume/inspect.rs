//! `inspect drops`: the plan, the distributions and a sample of drops, as JSON.

use glam::DVec3;
use serde_json::{Value, json};

use super::rainfall::Rainfall;
use super::{RainVolume, SampledDrop, VolumeParams, sample_drop};
use crate::Result;
use crate::rain::physics::{DsdShape, RainModel};
use crate::rain::wind::Wind;
use crate::scene::Camera;

/// the emitter at time `t_s` (ids spread evenly over all simulated drops), with the sampled
/// share of drops per distance band next to the planned share.
pub fn inspect_drops(
    camera: &Camera,
    model: &RainModel,
    wind: &Wind,
    params: &VolumeParams,
    count: usize,
    seed: u32,
    t_s: f64,
) -> Result<Value> {
    let volume = RainVolume::plan(camera, model, wind, params)?;
    let dsd = &model.dsd;
    let n = (count as u64).min(volume.simulated).min(1_000_000);
    let drops: Vec<SampledDrop> = (0..n)
        .filter_map(|i| {
            // i < n, so n > 0 here.
            let id = i * volume.simulated / n.max(1);
            sample_drop(Rainfall::new(&volume, model, wind, seed), id, t_s)
        })
        .collect();
    let depth = |p: DVec3| camera.camera_from_world_point(p).z;
    let in_view = |p: DVec3| {
        let q = camera.camera_from_world_point(p);
        q.z >= volume.near_m
            && q.z <= volume.far_m
            && camera.project_camera(q).is_some_and(|px| {
                px.x >= 0.0
                    && px.y >= 0.0
                    && px.x <= camera.width_px as f64
                    && px.y <= camera.height_px as f64
            })
            && params.ground_z_m.is_none_or(|g| p.z >= g)
    };
    let total_band: f64 = volume.bands.iter().map(|b| b.simulated).sum();
    let sim_cols = volume.simulated.max(1) as f64;
    let bands: Vec<Value> = volume
        .bands
        .iter()
        .map(|b| {
            let k = drops
                .iter()
                .filter(|d| in_view(d.position_m))
                .filter(|d| (b.near_m..b.far_m).contains(&depth(d.position_m)))
                .count();
            json!({
                "near_m": b.near_m,
                "far_m": b.far_m,
                "sampled": k,
                "sampled_fraction": k as f64 / drops.len().max(1) as f64,
                "planned_fraction": b.simulated / sim_cols,
            })
        })
        .collect();
    let mean = |f: &dyn Fn(&SampledDrop) -> f64| {
        drops.iter().map(f).sum::<f64>() / drops.len().max(1) as f64
    };
    let (lo, hi) = dsd.range_mm();
    let shape = match dsd.shape() {
        DsdShape::MarshallPalmer => json!({"kind": "marshall-palmer"}),
        DsdShape::Gamma { mu } => json!({"kind": "gamma", "mu": mu}),
    };
    let table = model.fall.velocity_table(32, lo, hi);
    let mean_d = if dsd.number_density_per_m3() > 0.0 {
        dsd.moment(1.0) / dsd.number_density_per_m3()
    } else {
        0.0
    };
    let w_t = wind.wind_velocity_mps(t_s);
    let drop_list: Vec<Value> = drops
        .iter()
        .map(|d| {
            json!({
                "id": d.id,
                "column": d.column,
                "diameter_mm": d.diameter_mm,
                "velocity_mps": [d.velocity_mps.x, d.velocity_mps.y, d.velocity_mps.z],
                "position_m": [d.position_m.x, d.position_m.y, d.position_m.z],
                "depth_m": depth(d.position_m),
                "in_view": in_view(d.position_m),
            })
        })
        .collect();
    Ok(json!({
        "rain": {
            "mm_per_h": model.rate.mm_per_h(),
            "class": model.rate.class().map(|c| c.name()),
        },
        "distribution": {
            "shape": shape,
            "n0": dsd.n0(),
            "lambda_per_mm": dsd.lambda_per_mm(),
            "d_min_mm": lo,
            "d_max_mm": hi,
            "number_density_per_m3": dsd.number_density_per_m3(),
            "mean_diameter_mm": mean_d,
            "mass_weighted_diameter_mm": dsd.mass_weighted_diameter_mm(),
            "liquid_water_g_per_m3": dsd.liquid_water_g_per_m3(),
        },
        "fall": {
            "altitude_m": model.fall.altitude_m(),
            "density_factor": model.fall.density_factor(),
            "velocity_table_d_range_mm": [table.d_min_mm, table.d_max_mm],
            "velocity_table_mps": table.v_mps,
        },
        "wind": {
            "mean_mps": [wind.mean_mps.x, wind.mean_mps.y],
            "gust_components": wind.gusts.len(),
            "at_t_mps": [w_t.x, w_t.y],
        },
        "volume": volume.to_json(),
        "sample": {
            "seed": seed,
            "time_s": t_s,
            "count": drops.len(),
            "in_view": drops.iter().filter(|d| in_view(d.position_m)).count(),
            "mean_diameter_mm": mean(&|d| d.diameter_mm),
            "mean_speed_mps": mean(&|d| d.velocity_mps.length()),
            "bands": bands,
            "total_planned_in_view": total_band,
            "drops": drop_list,
        },
    }))
}
