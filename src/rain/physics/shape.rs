//! Drop shape: the oblate axis ratio of Beard & Chuang (1987) and the streak width it gives.

// ------------------------------------------------------------------------------------------
// Drop shape
// ------------------------------------------------------------------------------------------

/// Axis ratio b/a (vertical over horizontal) of a falling drop of equivalent diameter `d_mm`:
/// Beard & Chuang (1987) polynomial 1.0048 + 5.7e-4 D − 2.628e-2 D² + 3.682e-3 D³ − 1.677e-4 D⁴,
/// with D clamped to [0, 7] mm (its fitted range) and the ratio to ≤ 1 (small drops are
/// spheres).
pub fn axis_ratio(d_mm: f64) -> f64 {
    let d = d_mm.clamp(0.0, 7.0);
    let r = 1.0048 + d * (5.7e-4 + d * (-2.628e-2 + d * (3.682e-3 + d * -1.677e-4)));
    r.min(1.0)
}

/// Horizontal diameter over equivalent diameter, r^−1/3: an oblate spheroid of volume πD³/6
/// and axis ratio r has horizontal axis D r^−1/3, which is the width of a streak seen from the
/// side (1.0 for small drops, 1.16 at 6 mm).
pub fn streak_width_factor(d_mm: f64) -> f64 {
    axis_ratio(d_mm).powf(-1.0 / 3.0)
}
