//! The lens the frames show: whether the assumed field of view fits the picture's lines, and
//! which one does.
//!
//! The verticals' vanishing point `v` and the horizon are pole and polar with respect to the
//! image of the absolute conic: for every point `p` of the horizon, `(p − c)·(v − c) = −f²`
//! (`c` the principal point; Hartley & Zisserman 2004, §8.6). The verticals alone give a
//! horizon only through an assumed focal length, the receding level lines meet on the true one
//! whatever the lens: where they disagree ([`lens_mismatch`]), the field of view is not the
//! lens's, and the same relation names the one that is ([`read_lens`]).

use crate::scene::Camera;
use crate::scene::horizon::{HorizonEstimate, refusal};

/// Horizontal families converging farther than this (picture heights, a weighted mean) off
/// the horizon the verticals predict make a reading inconsistent with the assumed field of
/// view: see [`lens_mismatch`].
pub const LEVEL_OFFSET_MAX: f64 = 0.03;

/// Whether the verticals and the horizontal families disagree on the horizon under the assumed
/// focal length ([`HorizonEstimate::level_offset`] beyond [`LEVEL_OFFSET_MAX`]). The verticals
/// set the tilt through the focal length (their vanishing point `v` and the horizon are pole
/// and polar, `(p − c)·(v − c) = −f²`), the families' vanishing points show the horizon
/// directly: where they disagree the field of view is not the lens's, and the tilt read from
/// the verticals (a convergence a wider lens shows at a smaller tilt) is wrong. Synthetic
/// shots are drawn through an exactly known lens, so the confidence model cannot learn this.
pub fn lens_mismatch(e: &HorizonEstimate) -> bool {
    e.level_offset.abs() > LEVEL_OFFSET_MAX && e.horizon_shift.abs() >= LENS_SHIFT_MIN
}

/// A horizon the verticals put nearer the principal point than this (picture heights) is
/// exempt from [`lens_mismatch`]: a wrong focal length moves the horizon in proportion to its
/// distance from there (`y_h f²/f_a²` for `y_h` under the assumed `f_a`), so a level reading is
/// right under any lens, and an offset there is the level lines' own noise.
pub const LENS_SHIFT_MIN: f64 = 0.02;

/// What the lens check read of the lens where it refused the given one: the field of view
/// to try, or that no lens centred on the picture fits (the level lines' vanishing points
/// lie on the same side of the picture's centre as the verticals', as in a picture cropped
/// off its centre); `None` where the lens was not refused or nothing was read.
pub fn lens_hint(e: &HorizonEstimate) -> Option<String> {
    if !lens_mismatch(e) {
        return None;
    }
    match (e.lens_fov_deg, e.focal_scale_sq) {
        (Some(fov), _) => Some(format!(
            "the frames read consistently through a {fov:.0}° lens (try --fov {fov:.0})"
        )),
        (None, Some(k2)) if k2 <= 0.0 => Some(
            "no lens centred on the picture fits its lines (a picture cropped off its centre?)"
                .into(),
        ),
        _ => None,
    }
}

/// Widest and narrowest field of view [`read_lens`] reads, degrees.
pub const LENS_FOV_RANGE_DEG: [f64; 2] = [20.0, 120.0];

/// Readings through a lens read from the frames, at most.
pub const LENS_READINGS: usize = 3;

/// The estimate through `camera`; where that lens is refused ([`lens_mismatch`]), the lens
/// the frames show: the level lines and the verticals agree under `f = f_a √k²` (`k²` =
/// [`HorizonEstimate::focal_scale_sq`], positive, the field of view within
/// [`LENS_FOV_RANGE_DEG`]); the frame is read again through it, up to [`LENS_READINGS`]
/// times while that is refused, and a lens that is then accepted is reported
/// ([`HorizonEstimate::lens_fov_deg`]). The estimate stays the refused one: on steep views
/// looking up between towers, a level reading (the Manhattan alternative) refused through the
/// true lens is accepted, confidently and wrongly, through the lens it reads; so the lens read
/// is the user's to try (`--fov`), not a reading to engage.
pub fn read_lens(
    camera: &Camera,
    estimate: impl Fn(&Camera) -> HorizonEstimate,
) -> HorizonEstimate {
    let mut first = estimate(camera);
    let mut e = first;
    let mut cam = *camera;
    for _ in 0..LENS_READINGS {
        if !lens_mismatch(&e) {
            break;
        }
        let Some(k2) = e.focal_scale_sq.filter(|k2| *k2 > 0.0) else {
            return first;
        };
        let f = cam.focal_px() * k2.sqrt();
        let fov = 2.0 * (0.5 * cam.width_px as f64 / f).atan();
        let [lo, hi] = LENS_FOV_RANGE_DEG;
        if !(lo.to_radians()..=hi.to_radians()).contains(&fov) {
            return first;
        }
        cam.fov_x_rad = fov;
        e = estimate(&cam);
    }
    if lens_mismatch(&first) && !lens_mismatch(&e) && refusal(&e).is_none() {
        first.lens_fov_deg = Some(cam.fov_x_rad.to_degrees());
    }
    first
}
