// Counter-based randomness: the same (seed, drop id, stream) gives the same number on every
// device and in the CPU reference (`rain::volume::drop_uniform`). PCG integer hash
// (Jarzynski & Olano 2020, "Hash functions for GPU rendering").

fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Uniform in [0, 1) with 24 bits, exactly representable in f32.
fn unit_from_hash(h: u32) -> f32 {
    return f32(h >> 8u) * (1.0 / 16777216.0);
}

// The 24 random bits of stream `stream` of drop `id`.
fn drop_bits(seed: u32, id: u32, stream: u32) -> u32 {
    return pcg_hash(pcg_hash(pcg_hash(seed) ^ id) ^ (stream * 0x9E3779B9u)) >> 8u;
}

// Random stream `stream` of drop `id`.
fn drop_uniform(seed: u32, id: u32, stream: u32) -> f32 {
    return f32(drop_bits(seed, id, stream)) * (1.0 / 16777216.0);
}

// Random stream `stream` of drop `id` in its `cycle`-th pass through its column.
fn cycle_uniform(seed: u32, id: u32, cycle: u32, stream: u32) -> f32 {
    return unit_from_hash(pcg_hash(pcg_hash(pcg_hash(seed) ^ id) ^ (stream * 0x9E3779B9u) ^ pcg_hash(cycle)));
}
