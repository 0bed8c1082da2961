//! Geometric optics through one frozen drop shape: a ray from the eye is split at every
//! interface into its reflected and transmitted parts (Fresnel, s and p carried separately, the
//! RTF's [`fresnel`]), and each part that leaves the drop is an *exit*: a direction towards the
//! light it carries and the fraction of the ray's power it keeps. Order n leaves after n − 2
//! internal reflections, as in the RTF (5.5); on a sphere the two agree exactly.

use glam::DVec3;

use super::shape::Shape;
use crate::lighting::rtf::fresnel;

/// One part of a ray that left the drop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exit {
    /// Scattering order: 1 = external reflection, 2 = straight through, 3 = primary bow, …
    pub order: usize,
    /// Unit direction from the drop towards the light this part shows.
    pub towards_light: DVec3,
    /// Fraction of the eye ray's power, ½(w_s + w_p).
    pub weight: f64,
}

/// Mirror reflection of `d` about the unit normal `n`.
fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    d - 2.0 * d.dot(n) * n
}

/// Snell refraction of unit `d` through a surface with unit normal `n` facing the incoming side
/// (`d·n < 0`), relative index `eta` = n_from / n_to; `None` beyond the critical angle.
fn refract(d: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = -d.dot(n);
    let sin_t2 = eta * eta * (1.0 - cos_i * cos_i);
    (sin_t2 <= 1.0).then(|| eta * d + (eta * cos_i - (1.0 - sin_t2).sqrt()) * n)
}

/// Traces the eye ray `origin + s·dir` (unit `dir`) through `shape` of relative index `rho`,
/// calling `emit` for each exit of order ≤ `orders`. Returns whether the ray hit the drop.
pub fn trace(
    shape: &Shape,
    rho: f64,
    orders: usize,
    origin: DVec3,
    dir: DVec3,
    mut emit: impl FnMut(Exit),
) -> bool {
    let Some(s) = shape.entry(origin, dir) else {
        return false;
    };
    let p = origin + s * dir;
    let n = shape.normal(p);
    let cos_i = (-dir.dot(n)).clamp(0.0, 1.0);
    let (rs, rp) = fresnel(rho, cos_i);
    emit(Exit {
        order: 1,
        towards_light: reflect(dir, n),
        weight: 0.5 * (rs + rp),
    });
    let Some(mut d) = refract(dir, n, 1.0 / rho) else {
        return true;
    };
    let mut p = p;
    // Power left in the ray inside the drop, per polarisation.
    let (mut ws, mut wp) = (1.0 - rs, 1.0 - rp);
    for order in 2..=orders {
        p += shape.exit(p, d) * d;
        // Inward normal at the exit point faces the ray coming from inside.
        let n_in = -shape.normal(p);
        let cos_inside = (-d.dot(n_in)).clamp(0.0, 1.0);
        let sin_out2 = rho * rho * (1.0 - cos_inside * cos_inside);
        let (rs, rp) = if sin_out2 >= 1.0 {
            (1.0, 1.0)
        } else {
            // Reciprocity: the internal reflectance at β equals the external one at γ.
            fresnel(rho, (1.0 - sin_out2).sqrt())
        };
        if let Some(out) = refract(d, n_in, rho) {
            emit(Exit {
                order,
                towards_light: out,
                weight: 0.5 * (ws * (1.0 - rs) + wp * (1.0 - rp)),
            });
        }
        ws *= rs;
        wp *= rp;
        d = reflect(d, n_in);
    }
    true
}
