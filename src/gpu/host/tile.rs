//! A tile's rows between the f16 canvas and the raster's f32, eight values at a time with F16C
//! in the raster's and the puddles' AVX2 builds (a texel's four at a time for the puddles'
//! scattered reads), else through the `half` crate: exact one way, rounded to the nearest even
//! the other, so both give the same bits; and the next tile asked for ahead.

use half::f16;
use half::slice::HalfFloatSliceExt;

/// `src` as f32 into `dst` (the same length); `f16c`: the F16C instructions, inlined (only
/// inside a build with them enabled, run where the CPU has them).
#[inline(always)]
pub fn load(src: &[f16], dst: &mut [f32], f16c: bool) {
    #[cfg(target_arch = "x86_64")]
    if f16c {
        // SAFETY: `f16c` is set only in the raster's AVX2 build, which runs only where the CPU
        // has AVX2 and F16C (`super::streaks`).
        unsafe { x86::load(src, dst) };
        return;
    }
    let _ = f16c;
    src.convert_to_f32_slice(dst);
}

/// `src` rounded to f16 into `dst` (the same length); `f16c` as in [`load`].
#[inline(always)]
pub fn store(src: &[f32], dst: &mut [f16], f16c: bool) {
    #[cfg(target_arch = "x86_64")]
    if f16c {
        // SAFETY: as in `load`.
        unsafe { x86::store(src, dst) };
        return;
    }
    let _ = f16c;
    dst.convert_from_f32_slice(src);
}

/// One RGBA texel as f32; `f16c` as in [`load`] (one F16C conversion of four values).
#[inline(always)]
pub fn load_texel(src: &[f16; 4], f16c: bool) -> [f32; 4] {
    #[cfg(target_arch = "x86_64")]
    if f16c {
        // SAFETY: as in `load`.
        return unsafe { x86::load_texel(src) };
    }
    let _ = f16c;
    src.map(f16::to_f32)
}

/// Asks the CPU to bring `rows` rows of `len` values, `stride` apart from the start of
/// `canvas`, into its cache (no effect on any value; nothing where the CPU cannot).
#[inline(always)]
pub fn prefetch(canvas: &[f16], stride: usize, rows: usize, len: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // A cache line holds 32 values.
        for r in 0..rows {
            let Some(row) = canvas.get(r * stride..r * stride + len) else {
                return;
            };
            for k in (0..len).step_by(32) {
                // SAFETY: a prefetch reads nothing and faults on no address; this one is
                // within `row`.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(row.as_ptr().add(k).cast::<i8>()) };
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (canvas, stride, rows, len);
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::{
        __m128i, _MM_FROUND_TO_NEAREST_INT, _mm_cvtph_ps, _mm_loadl_epi64, _mm_loadu_si128,
        _mm_storeu_ps, _mm_storeu_si128, _mm256_cvtph_ps, _mm256_cvtps_ph, _mm256_loadu_ps,
        _mm256_storeu_ps,
    };

    use half::f16;
    use half::slice::HalfFloatSliceExt;

    /// See [`super::load`].
    #[inline]
    #[target_feature(enable = "avx,f16c")]
    pub unsafe fn load(src: &[f16], dst: &mut [f32]) {
        let n = src.len().min(dst.len());
        let whole = n / 8 * 8;
        for k in (0..whole).step_by(8) {
            // SAFETY: k + 8 ≤ n, within both slices; unaligned loads and stores.
            unsafe {
                let h = _mm_loadu_si128(src.as_ptr().add(k).cast::<__m128i>());
                _mm256_storeu_ps(dst.as_mut_ptr().add(k), _mm256_cvtph_ps(h));
            }
        }
        src[whole..n].convert_to_f32_slice(&mut dst[whole..n]);
    }

    /// See [`super::load_texel`].
    #[inline]
    #[target_feature(enable = "avx,f16c")]
    pub unsafe fn load_texel(src: &[f16; 4]) -> [f32; 4] {
        let mut out = [0f32; 4];
        // SAFETY: eight bytes read from `src`, sixteen written to `out`; unaligned.
        unsafe {
            let h = _mm_loadl_epi64(src.as_ptr().cast::<__m128i>());
            _mm_storeu_ps(out.as_mut_ptr(), _mm_cvtph_ps(h));
        }
        out
    }

    /// See [`super::store`].
    #[inline]
    #[target_feature(enable = "avx,f16c")]
    pub unsafe fn store(src: &[f32], dst: &mut [f16]) {
        let n = src.len().min(dst.len());
        let whole = n / 8 * 8;
        for k in (0..whole).step_by(8) {
            // SAFETY: as in `load`.
            unsafe {
                let v = _mm256_loadu_ps(src.as_ptr().add(k));
                let h = _mm256_cvtps_ph::<_MM_FROUND_TO_NEAREST_INT>(v);
                _mm_storeu_si128(dst.as_mut_ptr().add(k).cast::<__m128i>(), h);
            }
        }
        dst[whole..n].convert_from_f32_slice(&src[whole..n]);
    }
}
