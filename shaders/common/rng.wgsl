// Counter-based randomness: the same (seed, drop id, cycle) gives the same numbers on every
// device and on the CPU twin (src/rain/emitter.rs). PCG-style integer hash (O'Neill 2014,
// as surveyed by Jarzynski & Olano 2020, "Hash functions for GPU rendering").

fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Uniform in [0, 1) with 24 bits, exactly representable in f32.
fn unit_from_hash(h: u32) -> f32 {
    return f32(h >> 8u) * (1.0 / 16777216.0);
}

// The k-th random number of a stream keyed by (seed, id, cycle).
fn rand_key(seed: u32, id: u32, cycle: u32, k: u32) -> f32 {
    return unit_from_hash(pcg_hash(pcg_hash(pcg_hash(seed ^ (k * 0x9e3779b9u)) ^ id) ^ cycle));
}
