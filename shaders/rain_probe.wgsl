// Stage rain_probe: writes the state of drops [first, first + count) at the frame's time to a buffer
// (position, diameter — −1 for a drop a keyed rate leaves out —, velocity, width), so tests can hold the GPU emitter against its CPU twin.
// Includes: common/types.wgsl, common/rng.wgsl, common/drops.wgsl.

@group(0) @binding(0) var<uniform> rain: RainParams;
@group(0) @binding(1) var<storage, read> columns: array<Column>;
@group(0) @binding(2) var<storage, read_write> probe_out: array<vec4<f32>>;

@compute @workgroup_size(SIMULATE_WORKGROUP)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= rain.drop_count { return; }
    let d = drop_state(id.x);
    probe_out[2u * id.x] = vec4<f32>(d.pos_m, select(-1.0, d.diameter_mm, d.falls));
    probe_out[2u * id.x + 1u] = vec4<f32>(d.vel_mps, d.width_mm);
}
