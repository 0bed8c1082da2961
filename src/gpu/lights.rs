//! The direct light term's GPU inputs: the drop's RTF table per channel (uploaded once per
//! job) and the frame's compact lights (uploaded every frame). `rain_simulate` binds both
//! (bindings 3 and 4, see `shaders/common/lights.wgsl`).

use super::types::LightList;
use crate::lighting::RtfTable;

/// Bins the table buffer holds (the direct term's angular resolution).
pub const TABLE_BINS: usize = crate::lighting::frame_light::GPU_RTF_BINS;

/// The buffers of the direct light term.
#[derive(Clone)]
pub struct DirectLightBuffers {
    /// `LightList` uniform.
    pub list: wgpu::Buffer,
    /// `array<vec4<f32>>` of [`TABLE_BINS`] entries, rgb = F per channel.
    pub table: wgpu::Buffer,
}

impl DirectLightBuffers {
    /// Buffers with no light and a zero table.
    pub fn new(device: &wgpu::Device) -> DirectLightBuffers {
        let list = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("light_list"),
            size: std::mem::size_of::<LightList>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let table = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rtf_table"),
            size: 16 * TABLE_BINS as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        DirectLightBuffers { list, table }
    }

    /// Uploads the drop's transfer table (R, G, B), resampled to [`TABLE_BINS`] bins by
    /// interpolation if it has another size.
    pub fn upload_table(&self, queue: &wgpu::Queue, tables: &[RtfTable; 3]) {
        queue.write_buffer(&self.table, 0, bytemuck::cast_slice(&table_texels(tables)));
    }

    /// Uploads the frame's lights (the strongest [`MAX_LIGHTS`](super::types::MAX_LIGHTS)).
    pub fn upload_lights(&self, queue: &wgpu::Queue, lights: &LightList) {
        queue.write_buffer(&self.list, 0, bytemuck::bytes_of(lights));
    }
}

/// The table as the GPU reads it: [`TABLE_BINS`] × (F_R, F_G, F_B, 0).
pub fn table_texels(tables: &[RtfTable; 3]) -> Vec<[f32; 4]> {
    (0..TABLE_BINS)
        .map(|m| {
            let f = |t: &RtfTable| {
                if t.bins == TABLE_BINS {
                    t.total[m] as f32
                } else {
                    let theta = (m as f64 + 0.5) * std::f64::consts::PI / TABLE_BINS as f64;
                    t.interpolated(theta) as f32
                }
            };
            [f(&tables[0]), f(&tables[1]), f(&tables[2]), 0.0]
        })
        .collect()
}
