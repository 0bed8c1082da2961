//! SplitMix64 (Steele, Lea & Flood 2014): the one small seeded generator of the CPU code
//! (gust phases, SPH jitter, test data). The GPU uses its own 32-bit PCG hash
//! (`shaders/common/rng.wgsl`); nothing here needs to match it.

/// A seeded stream of 64-bit values.
#[derive(Debug, Clone)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        mix(self.0)
    }

    /// Uniform in [0, 1), 53 bits.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// The stateless form: the first value of the stream seeded with `x`.
pub fn splitmix64(x: u64) -> u64 {
    mix(x.wrapping_add(0x9E37_79B9_7F4A_7C15))
}

fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stateless_form_is_the_first_value_of_the_stream() {
        // Published first output of SplitMix64 seeded with 0 (Vigna's reference code).
        assert_eq!(SplitMix64(0).next_u64(), 0xE220_A839_7B1D_CDAF);
        for x in [0u64, 1, 42, u64::MAX] {
            assert_eq!(SplitMix64(x).next_u64(), splitmix64(x));
        }
    }
}
