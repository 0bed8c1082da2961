//! Eight pixels at a time for the colour passes: table reads (AVX2 gathers in the passes' AVX2
//! builds, else a load a lane) and linear RGB → RGBA f16 texels (F16C in those builds, else
//! through the `half` crate); either way the same bits.

use half::f16;

/// Pixels a lane block holds: one AVX2 vector of f32.
pub const LANES: usize = 8;

/// Whether the CPU runs the colour passes' AVX2 builds (AVX2 for the lanes and the gathers,
/// F16C for the canvas).
pub fn has_avx2_f16c() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("f16c");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// `table[at[l] + offset]` for each lane, an index past the table's end reading its last
/// entry (the callers keep them inside: the clamp is one vector minimum, where a check would
/// fold the eight lanes and branch); `avx2`: with AVX2's gather, inlined (only inside a build
/// with AVX2 enabled, run where the CPU has it).
///
/// # Panics
/// Where `table` holds no entry from `offset` on, or more than `i32::MAX`.
#[inline(always)]
pub fn gather(table: &[f32], at: [u32; LANES], offset: usize, avx2: bool) -> [f32; LANES] {
    let entries = table.len().saturating_sub(offset);
    assert!(
        entries > 0 && entries <= i32::MAX as usize,
        "a table read past its end"
    );
    let last = (entries - 1) as u32;
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: AVX2 is enabled in the build that passes `avx2` (see above); every index is
        // clamped to `last`, so each read lies inside `table[offset..]`.
        return unsafe { x86::gather(table[offset..].as_ptr(), at, last) };
    }
    let _ = avx2;
    let mut out = [0f32; LANES];
    for (o, &i) in out.iter_mut().zip(&at) {
        *o = table[i.min(last) as usize + offset];
    }
    out
}

/// `pairs[at[l]]` for each lane as two lane arrays (the pairs' first and second values), an
/// index past the end reading the last pair (as [`gather`]); `avx2`: two AVX2 gathers of four
/// 64-bit pairs each, inlined (as in [`gather`]): eight reads where two gathers of single
/// values make sixteen.
///
/// # Panics
/// Where `pairs` is empty or holds more than `i32::MAX` pairs.
#[inline(always)]
pub fn gather_pairs(
    pairs: &[[f32; 2]],
    at: [u32; LANES],
    avx2: bool,
) -> ([f32; LANES], [f32; LANES]) {
    assert!(
        !pairs.is_empty() && pairs.len() <= i32::MAX as usize,
        "a table read past its end"
    );
    let last = (pairs.len() - 1) as u32;
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: as in `gather`: every index is clamped to `last`.
        return unsafe { x86::gather_pairs(pairs.as_ptr().cast(), at, last) };
    }
    let _ = avx2;
    let (mut first, mut second) = ([0f32; LANES], [0f32; LANES]);
    for l in 0..LANES {
        [first[l], second[l]] = pairs[at[l].min(last) as usize];
    }
    (first, second)
}

/// Eight pixels' linear `rgb` as RGBA f16 texels (alpha 1) into `out` (32 values), rounded to
/// the nearest even; `f16c` as `avx2` in [`gather`].
#[inline(always)]
pub fn store_rgb(rgb: &[[f32; LANES]; 3], out: &mut [f16], f16c: bool) {
    let out = &mut out[..4 * LANES];
    #[cfg(target_arch = "x86_64")]
    if f16c {
        // SAFETY: as in `gather`: F16C is enabled in the build that passes `f16c`.
        unsafe { x86::store_rgb(rgb, out) };
        return;
    }
    let _ = f16c;
    for (l, px) in out.chunks_exact_mut(4).enumerate() {
        px[0] = f16::from_f32(rgb[0][l]);
        px[1] = f16::from_f32(rgb[1][l]);
        px[2] = f16::from_f32(rgb[2][l]);
        px[3] = f16::ONE;
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::{
        __m128i, _MM_FROUND_TO_NEAREST_INT, _mm_set1_epi16, _mm_storeu_si128, _mm_unpackhi_epi16,
        _mm_unpackhi_epi32, _mm_unpacklo_epi16, _mm_unpacklo_epi32, _mm256_castpd_ps,
        _mm256_castsi256_si128, _mm256_cvtps_ph, _mm256_extracti128_si256, _mm256_i32gather_pd,
        _mm256_i32gather_ps, _mm256_loadu_ps, _mm256_loadu_si256, _mm256_min_epu32,
        _mm256_permutevar8x32_epi32, _mm256_set1_epi32, _mm256_setr_epi32, _mm256_shuffle_ps,
        _mm256_storeu_ps,
    };

    use super::LANES;
    use half::f16;

    /// See [`super::gather`]: `base[min(at[l], last)]`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn gather(base: *const f32, at: [u32; LANES], last: u32) -> [f32; LANES] {
        let mut out = [0f32; LANES];
        // SAFETY: the caller keeps `base + last` inside its table (and `last` ≤ i32::MAX, so
        // the clamped indices read as signed are the same); `at` and `out` are eight lanes,
        // read and written unaligned.
        unsafe {
            let i = _mm256_loadu_si256(at.as_ptr().cast());
            let i = _mm256_min_epu32(i, _mm256_set1_epi32(last as i32));
            let v = _mm256_i32gather_ps::<4>(base, i);
            _mm256_storeu_ps(out.as_mut_ptr(), v);
        }
        out
    }

    /// See [`super::gather_pairs`]: the pairs `base[2 min(at[l], last)..][..2]`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn gather_pairs(
        base: *const f64,
        at: [u32; LANES],
        last: u32,
    ) -> ([f32; LANES], [f32; LANES]) {
        let (mut first, mut second) = ([0f32; LANES], [0f32; LANES]);
        // SAFETY: as in `gather`, each pair read as one unaligned 8-byte value.
        unsafe {
            let i = _mm256_loadu_si256(at.as_ptr().cast());
            let i = _mm256_min_epu32(i, _mm256_set1_epi32(last as i32));
            // Lanes 0, 1, 4, 5 in the low half, 2, 3, 6, 7 in the high: one shuffle of the two
            // gathers' values then gives each value's lanes in order.
            let i = _mm256_permutevar8x32_epi32(i, _mm256_setr_epi32(0, 1, 4, 5, 2, 3, 6, 7));
            let lo = _mm256_castpd_ps(_mm256_i32gather_pd::<8>(base, _mm256_castsi256_si128(i)));
            let hi = _mm256_castpd_ps(_mm256_i32gather_pd::<8>(
                base,
                _mm256_extracti128_si256::<1>(i),
            ));
            // lo: pairs 0 1 | 4 5, hi: pairs 2 3 | 6 7.
            _mm256_storeu_ps(first.as_mut_ptr(), _mm256_shuffle_ps::<0x88>(lo, hi));
            _mm256_storeu_ps(second.as_mut_ptr(), _mm256_shuffle_ps::<0xDD>(lo, hi));
        }
        (first, second)
    }

    /// See [`super::store_rgb`]: each channel to f16, then interleaved with alpha.
    #[inline]
    #[target_feature(enable = "avx2,f16c")]
    pub unsafe fn store_rgb(rgb: &[[f32; LANES]; 3], out: &mut [f16]) {
        debug_assert!(out.len() >= 4 * LANES);
        // SAFETY: `out` holds 32 values (the caller slices it so); loads and stores unaligned.
        unsafe {
            let half = |c: &[f32; LANES]| {
                _mm256_cvtps_ph::<_MM_FROUND_TO_NEAREST_INT>(_mm256_loadu_ps(c.as_ptr()))
            };
            let (r, g, b) = (half(&rgb[0]), half(&rgb[1]), half(&rgb[2]));
            let a = _mm_set1_epi16(f16::ONE.to_bits() as i16);
            let (rg_lo, rg_hi) = (_mm_unpacklo_epi16(r, g), _mm_unpackhi_epi16(r, g));
            let (ba_lo, ba_hi) = (_mm_unpacklo_epi16(b, a), _mm_unpackhi_epi16(b, a));
            let texels = [
                _mm_unpacklo_epi32(rg_lo, ba_lo),
                _mm_unpackhi_epi32(rg_lo, ba_lo),
                _mm_unpacklo_epi32(rg_hi, ba_hi),
                _mm_unpackhi_epi32(rg_hi, ba_hi),
            ];
            for (k, t) in texels.into_iter().enumerate() {
                _mm_storeu_si128(out.as_mut_ptr().add(8 * k).cast::<__m128i>(), t);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{LANES, gather, gather_pairs};

    /// The AVX2 gathers read the entries the plain loads read, in lane order, for indices
    /// anywhere in the table, repeated, and past its end (the last entry).
    #[test]
    fn gathers_read_what_the_loads_read() {
        let avx2 = super::has_avx2_f16c();
        let table: Vec<f32> = (0..1000).map(|i| i as f32 * 0.5 - 7.0).collect();
        let pairs: Vec<[f32; 2]> = (0..999).map(|i| [table[i], -table[i + 1]]).collect();
        let mut state = 5u32;
        for trial in 0..500 {
            let mut at = [0u32; LANES];
            for a in &mut at {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                *a = match trial % 4 {
                    0 => state >> 22,
                    1 => 990 + (state >> 29),
                    _ => (state >> 8) % 999,
                };
            }
            let offset = trial % 2;
            assert_eq!(
                gather(&table, at, offset, avx2),
                gather(&table, at, offset, false),
                "{at:?}"
            );
            let plain: [f32; LANES] =
                std::array::from_fn(|l| table[(at[l] as usize).min(999 - offset) + offset]);
            assert_eq!(gather(&table, at, offset, avx2), plain, "{at:?}");
            let (first, second) = gather_pairs(&pairs, at, avx2);
            for l in 0..LANES {
                assert_eq!(
                    [first[l], second[l]],
                    pairs[(at[l] as usize).min(998)],
                    "{at:?}"
                );
            }
        }
    }
}
