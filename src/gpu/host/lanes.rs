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

/// `table[at[l] + offset]` for each lane; `avx2`: with AVX2's gather, inlined (only inside a
/// build with AVX2 enabled, run where the CPU has it).
///
/// # Panics
/// Where an index lies past the table (the callers clamp them first).
#[inline(always)]
pub fn gather(table: &[f32], at: [u32; LANES], offset: usize, avx2: bool) -> [f32; LANES] {
    let mut last = 0;
    for &i in &at {
        last = last.max(i);
    }
    assert!(
        last as usize + offset < table.len(),
        "a table read past its end"
    );
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: AVX2 is enabled in the build that passes `avx2` (see above); every index
        // plus `offset` lies inside `table` (asserted).
        return unsafe { x86::gather(table[offset..].as_ptr(), at) };
    }
    let _ = avx2;
    let mut out = [0f32; LANES];
    for (o, &i) in out.iter_mut().zip(&at) {
        *o = table[i as usize + offset];
    }
    out
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
        _mm_unpackhi_epi32, _mm_unpacklo_epi16, _mm_unpacklo_epi32, _mm256_cvtps_ph,
        _mm256_i32gather_ps, _mm256_loadu_ps, _mm256_loadu_si256, _mm256_storeu_ps,
    };

    use super::LANES;
    use half::f16;

    /// See [`super::gather`]: `base[at[l]]`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn gather(base: *const f32, at: [u32; LANES]) -> [f32; LANES] {
        let mut out = [0f32; LANES];
        // SAFETY: the caller keeps every `base + at[l]` inside its table; `at` and `out` are
        // eight lanes, read and written unaligned.
        unsafe {
            let i = _mm256_loadu_si256(at.as_ptr().cast());
            let v = _mm256_i32gather_ps::<4>(base, i);
            _mm256_storeu_ps(out.as_mut_ptr(), v);
        }
        out
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
