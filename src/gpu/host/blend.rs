//! A capsule's colour blended over up to eight pixels of a run in the raster's f32 tile
//! (premultiplied, `src + dst·(1 − α)`, as the `rain_streaks` stage's blend state): one pixel
//! at a time in the plain form, eight at once in the raster's AVX2 build (the pixels' four
//! channels turned into four vectors of eight lanes and back), the same operations in the same
//! order on each value, so the same bits.

/// Pixels one call blends at most (the raster's lanes).
pub const LANES: usize = 8;

/// From this many pixels on, the AVX2 build blends a group as vectors: turning the pixels into
/// lanes and back costs about what four pixels blended one at a time do.
const VECTOR_FROM: usize = 4;

/// Blends the colour `r0 + dr · t[l]` with alpha `a[l]` over the first `n` (≤ [`LANES`]) pixels
/// of `px`, pixel `l` at `px[l · stride..][..4]` (RGBA), as
/// `colour · a + dst · (1 − a)` and `a + dst_α · (1 − a)`; `avx`: in the raster's AVX2 build
/// (only inside a build with AVX enabled, run where the CPU has it). Pixels from `n` on are
/// neither read nor changed.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn blend(
    px: &mut [f32],
    stride: usize,
    n: usize,
    a: &[f32; LANES],
    t: &[f32; LANES],
    r0: [f32; 3],
    dr: [f32; 3],
    avx: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if avx && (VECTOR_FROM..=LANES).contains(&n) && stride >= 4 && (n - 1) * stride + 4 <= px.len()
    {
        // SAFETY: `avx` is set only in the raster's AVX2 build, which runs only where the CPU
        // has AVX2 (`super::streaks`); pixels 0..n lie within `px` (checked above).
        unsafe { x86::blend(px.as_mut_ptr(), stride, n, a, t, r0, dr) };
        return;
    }
    let _ = avx;
    plain(px, stride, n, a, t, r0, dr);
}

/// [`blend`] one pixel at a time: the reference, and the baseline build's form.
#[inline(always)]
pub fn plain(
    px: &mut [f32],
    stride: usize,
    n: usize,
    a: &[f32; LANES],
    t: &[f32; LANES],
    r0: [f32; 3],
    dr: [f32; 3],
) {
    for l in 0..n.min(LANES) {
        let keep = 1.0 - a[l];
        let px = &mut px[l * stride..][..4];
        px[0] = (r0[0] + dr[0] * t[l]) * a[l] + px[0] * keep;
        px[1] = (r0[1] + dr[1] * t[l]) * a[l] + px[1] * keep;
        px[2] = (r0[2] + dr[2] * t[l]) * a[l] + px[2] * keep;
        px[3] = a[l] + px[3] * keep;
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::{
        __m128, __m256, _mm_loadu_ps, _mm_storeu_ps, _mm256_add_ps, _mm256_castps128_ps256,
        _mm256_castps256_ps128, _mm256_extractf128_ps, _mm256_insertf128_ps, _mm256_loadu_ps,
        _mm256_mul_ps, _mm256_set1_ps, _mm256_shuffle_ps, _mm256_sub_ps, _mm256_unpackhi_ps,
        _mm256_unpacklo_ps,
    };

    use super::LANES;

    /// See [`super::blend`]; `px`: pixel 0's red, pixels `0..n` (`1 ≤ n ≤ 8`) readable and
    /// writable at `px + l · stride`. Pixels from `n` on read pixel `n − 1` and are stored
    /// before it, last to first, so pixel `n − 1` ends with its own lane's value.
    #[inline]
    #[target_feature(enable = "avx")]
    pub unsafe fn blend(
        px: *mut f32,
        stride: usize,
        n: usize,
        a: &[f32; LANES],
        t: &[f32; LANES],
        r0: [f32; 3],
        dr: [f32; 3],
    ) {
        let at = |l: usize| l.min(n - 1) * stride;
        // SAFETY (every read and write below): pixel `l.min(n − 1)` lies within the caller's
        // slice; unaligned 16-byte loads and stores.
        let load = |l: usize| unsafe { _mm_loadu_ps(px.add(at(l))) };
        let pair =
            |lo: __m128, hi: __m128| _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(lo), hi);
        // Pixels l and l + 4 in one register: [r g b α | r g b α].
        let (p04, p15) = (pair(load(0), load(4)), pair(load(1), load(5)));
        let (p26, p37) = (pair(load(2), load(6)), pair(load(3), load(7)));
        // Four by four, in each half: channel c of pixels 0–3 | 4–7.
        let (x0, x1) = (_mm256_unpacklo_ps(p04, p15), _mm256_unpackhi_ps(p04, p15));
        let (x2, x3) = (_mm256_unpacklo_ps(p26, p37), _mm256_unpackhi_ps(p26, p37));
        let dst = [
            _mm256_shuffle_ps::<0x44>(x0, x2),
            _mm256_shuffle_ps::<0xEE>(x0, x2),
            _mm256_shuffle_ps::<0x44>(x1, x3),
            _mm256_shuffle_ps::<0xEE>(x1, x3),
        ];
        // SAFETY: eight values from each array.
        let (a, t) = unsafe { (_mm256_loadu_ps(a.as_ptr()), _mm256_loadu_ps(t.as_ptr())) };
        let keep = _mm256_sub_ps(_mm256_set1_ps(1.0), a);
        let colour = |c: usize| -> __m256 {
            let lit = _mm256_add_ps(
                _mm256_set1_ps(r0[c]),
                _mm256_mul_ps(_mm256_set1_ps(dr[c]), t),
            );
            _mm256_add_ps(_mm256_mul_ps(lit, a), _mm256_mul_ps(dst[c], keep))
        };
        let (r, g, b) = (colour(0), colour(1), colour(2));
        let alpha = _mm256_add_ps(a, _mm256_mul_ps(dst[3], keep));
        // Back to pixels: [r g b α] of pixels l | l + 4.
        let (y0, y1) = (_mm256_unpacklo_ps(r, g), _mm256_unpackhi_ps(r, g));
        let (y2, y3) = (_mm256_unpacklo_ps(b, alpha), _mm256_unpackhi_ps(b, alpha));
        let q = [
            _mm256_shuffle_ps::<0x44>(y0, y2),
            _mm256_shuffle_ps::<0xEE>(y0, y2),
            _mm256_shuffle_ps::<0x44>(y1, y3),
            _mm256_shuffle_ps::<0xEE>(y1, y3),
        ];
        let store = |l: usize, v: __m128| unsafe { _mm_storeu_ps(px.add(at(l)), v) };
        for l in (4..8).rev() {
            store(l, _mm256_extractf128_ps::<1>(q[l - 4]));
        }
        for l in (0..4).rev() {
            store(l, _mm256_castps256_ps128(q[l]));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{LANES, blend, plain};

    /// A small deterministic stream of values in [0, 1).
    fn stream(seed: u64) -> impl FnMut() -> f32 {
        let mut s = seed;
        move || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (s >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// The AVX2 form gives the plain form's bits on every pixel it blends, leaves every other
    /// value as it was, for every count of pixels, along rows and columns, over a tile with
    /// signed zeros, large and tiny values, and alphas 0, 1 and between.
    #[test]
    fn vector_blend_matches_the_plain_one() {
        #[cfg(target_arch = "x86_64")]
        let avx = std::arch::is_x86_feature_detected!("avx");
        #[cfg(not(target_arch = "x86_64"))]
        let avx = false;
        let mut next = stream(7);
        let tile: Vec<f32> = (0..4 * 64 * 32)
            .map(|k| match k % 11 {
                0 => -0.0,
                1 => 0.0,
                2 => 6.0e4 * next(),
                3 => 1e-7 * next(),
                _ => 2.0 * next() - 0.2,
            })
            .collect();
        let mut vector_groups = 0;
        for trial in 0..400 {
            let n = 1 + trial % LANES;
            let stride = [4, 4 * 64, 8][trial % 3];
            let first = (next() * 512.0) as usize * 4;
            let (mut a, mut t) = ([0f32; LANES], [0f32; LANES]);
            for l in 0..LANES {
                a[l] = match (trial + l) % 5 {
                    0 => 0.0,
                    1 => 1.0,
                    _ => next(),
                };
                t[l] = 1.4 * next() - 0.2;
            }
            let r0 = [next() * 3.0, next(), next() * 0.01];
            let dr = [next() - 0.5, next() * 2.0, -next()];
            let (mut fast, mut slow) = (tile.clone(), tile.clone());
            if (n - 1) * stride + 4 > tile.len() - first {
                continue;
            }
            blend(&mut fast[first..], stride, n, &a, &t, r0, dr, avx);
            plain(&mut slow[first..], stride, n, &a, &t, r0, dr);
            vector_groups += usize::from(n >= 4);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert!(
                bits(&fast) == bits(&slow),
                "n {n}, stride {stride}: the vector blend differs"
            );
            // Blending changes the pixels it covers (with some alpha) and no other value.
            let changed = (0..tile.len()).filter(|&k| slow[k].to_bits() != tile[k].to_bits());
            for k in changed {
                assert!(k >= first, "value {k} changed");
                let (l, c) = ((k - first) / stride, (k - first) % stride);
                assert!(l < n && c < 4, "value {k} changed");
            }
        }
        assert!(vector_groups > 150);
    }
}
