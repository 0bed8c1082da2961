//! Wet ground: how much water the ground's surface holds as rain falls and stops, and what a
//! water film does to the ground's look (docs/method.md §2.3).
//!
//! The store is a linear reservoir, dS/dt = P·(1 − S/C) − S/τ: rain P fills the pores and
//! the film, the fraction S/C already full sheds what falls on it, and the water evaporates
//! with time constant τ. For a constant rate it has the closed form
//! S(t) = S∞ + (S₀ − S∞)·e^(−k t), k = P/C + 1/τ, S∞ = P/k, so a piecewise-constant rate
//! history is a product of exponentials: the wetness is a pure function of time, and a preview
//! at t equals the render at t. The wetness w = S/C ∈ [0, 1) is read as the share of the
//! surface under a film.
//!
//! The film's optics follow Lekner & Dorf (1988): light enters the water (losing R̄ₑ, the
//! external reflectance averaged over diffuse incidence), meets the rough surface (albedo a),
//! and what the surface sends back up is trapped in part by the film's internal reflection R̄ᵢ
//! (total beyond the critical angle), returning to the surface again and again. Seen from a
//! view angle with cosine μ the wet radiance over the dry one is
//! k(a, μ) = (1 − R(μ))·(1 − R̄ₑ) / (n²·(1 − a·R̄ᵢ)) (the n² is the radiance's change across
//! the interface), plus the film's mirror reflection R(μ)·L_env(mirrored view).

use super::rtf::fresnel;
use super::sh::composite_gauss;
use crate::{Error, Result};

/// Refractive index of water in the visible.
pub const WATER_INDEX: f64 = 1.333;

/// Default water a road surface holds in its pores and film before it sheds rain, mm.
pub const DEFAULT_CAPACITY_MM: f64 = 0.5;

/// Default e-folding time of drying, s: a full store then evaporates at 1 mm/h, the potential
/// evaporation of a mild day, so a road looks dry again about an hour after the rain.
pub const DEFAULT_DRYING_S: f64 = 1800.0;

/// The ground's surface water store (a linear reservoir; see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceStore {
    /// Water held when every pore is full, mm (C).
    pub capacity_mm: f64,
    /// e-folding time of drying, s (τ).
    pub drying_s: f64,
}

impl Default for SurfaceStore {
    fn default() -> Self {
        SurfaceStore {
            capacity_mm: DEFAULT_CAPACITY_MM,
            drying_s: DEFAULT_DRYING_S,
        }
    }
}

impl SurfaceStore {
    /// The store after `dt_s` seconds of rain at `rate_mm_per_h` from `start_mm`: the closed
    /// form of dS/dt = P·(1 − S/C) − S/τ.
    pub fn after(&self, start_mm: f64, rate_mm_per_h: f64, dt_s: f64) -> f64 {
        let p_mm_per_s = rate_mm_per_h / 3600.0;
        let k_per_s = p_mm_per_s / self.capacity_mm + 1.0 / self.drying_s;
        let full_mm = p_mm_per_s / k_per_s;
        full_mm + (start_mm - full_mm) * (-k_per_s * dt_s).exp()
    }
}

/// The rain rate over time, piecewise constant: `(start_s, rate_mm_per_h)` in time order, each
/// lasting until the next starts; dry before the first. Times are seconds from the clip's start
/// (negative: before it).
#[derive(Debug, Clone, PartialEq)]
pub struct RainHistory {
    segments: Vec<(f64, f64)>,
}

impl RainHistory {
    /// A history from its segments (finite times in increasing order, finite rates ≥ 0).
    pub fn new(segments: Vec<(f64, f64)>) -> Result<RainHistory> {
        let ordered = segments.windows(2).all(|s| s[0].0 < s[1].0);
        let valid = segments
            .iter()
            .all(|&(t, r)| t.is_finite() && r.is_finite() && r >= 0.0);
        if !(ordered && valid) {
            return Err(Error::Parameter {
                name: "rain history",
                value: format!("{segments:?}"),
                expected: "finite start times in increasing order and rates ≥ 0 mm/h".into(),
            });
        }
        Ok(RainHistory { segments })
    }

    /// Rain at `rate_mm_per_h` since `pre_rain_s` seconds before the clip's start.
    pub fn constant(rate_mm_per_h: f64, pre_rain_s: f64) -> RainHistory {
        RainHistory {
            segments: vec![(-pre_rain_s, rate_mm_per_h)],
        }
    }

    /// Rain at the keyed rate `keys` through the clip, and at its first key's rate since
    /// `pre_rain_s` before the clip's start. Between keys the rate is linear: it is taken in
    /// steps of at most [`KEYED_STEP_S`], each at its mean (the midpoint's) rate, so every
    /// step lands the right amount of water.
    pub fn keyed(keys: &crate::keyframes::Curve<f64>, pre_rain_s: f64) -> RainHistory {
        let k = keys.keys();
        let mut segments = vec![(-pre_rain_s.max(0.0), k[0].1)];
        for w in k.windows(2) {
            let (t0, t1) = (w[0].0, w[1].0);
            let steps = ((t1 - t0) / KEYED_STEP_S).ceil().max(1.0) as usize;
            let dt = (t1 - t0) / steps as f64;
            for i in 0..steps {
                let start = t0 + i as f64 * dt;
                segments.push((start, keys.at(start + 0.5 * dt)));
            }
        }
        let last = k[k.len() - 1];
        segments.push((last.0, last.1));
        // A key at t = −pre_rain (no pre-rain) repeats a start time: the later one holds. A
        // segment at the rate before it adds nothing.
        segments.dedup_by(|b, a| {
            if b.0 <= a.0 {
                *a = *b;
                return true;
            }
            b.1 == a.1
        });
        RainHistory { segments }
    }

    /// Whether any rain falls at all (otherwise the ground stays dry).
    pub fn any_rain(&self) -> bool {
        self.segments.iter().any(|&(_, r)| r > 0.0)
    }

    /// The water in `store` at `t_s`, mm, starting dry.
    pub fn store_mm(&self, store: &SurfaceStore, t_s: f64) -> f64 {
        let mut water_mm = 0.0;
        for (i, &(start_s, rate)) in self.segments.iter().enumerate() {
            if t_s <= start_s {
                break;
            }
            let end_s = self.segments.get(i + 1).map_or(t_s, |s| s.0.min(t_s));
            water_mm = store.after(water_mm, rate, end_s - start_s);
        }
        water_mm
    }
}

/// Longest step of a keyed rate's history, s (wetting changes over minutes).
pub const KEYED_STEP_S: f64 = 0.25;

/// How wet the ground is over a job: its store and the rain it has had.
#[derive(Debug, Clone, PartialEq)]
pub struct Wetting {
    /// The surface.
    pub store: SurfaceStore,
    /// The rain.
    pub history: RainHistory,
    /// How far the ground reaches, m (0: no limit): the filmed scene's distance. A view ray
    /// that meets the plane farther away has met the scene first (a facade, the far shore),
    /// so the wetting fades out between half this distance and it ([`reach_fade`]) rather
    /// than paint a sheen of the sky up to the horizon.
    pub reach_m: f64,
}

/// How much a pixel shows the ground at camera depth `ground_m` when the depth map says
/// `scene_m` there (`None`: unknown, taken for ground): nothing where the scene is nearer than
/// 80 % of the ground's depth (a car, a wall standing on it), all from 90 % (depth maps are
/// rarely better than 10 %), smoothstep between.
pub fn ground_shown(scene_m: Option<f64>, ground_m: f64) -> f64 {
    let Some(s) = scene_m.filter(|s| *s > 0.0) else {
        return 1.0;
    };
    let x = ((s - 0.8 * ground_m) / (0.1 * ground_m)).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// Share of the wetting kept on ground `distance_m` away when the ground reaches `reach_m`:
/// 1 nearer than half the reach, 0 beyond it, smoothstep between (no limit when `reach_m` ≤ 0).
pub fn reach_fade(distance_m: f64, reach_m: f64) -> f64 {
    if reach_m <= 0.0 {
        return 1.0;
    }
    let x = ((distance_m - 0.5 * reach_m) / (0.5 * reach_m)).clamp(0.0, 1.0);
    1.0 - x * x * (3.0 - 2.0 * x)
}

impl Wetting {
    /// Wetness w ∈ [0, 1] at `t_s`: the share of the surface under a film.
    pub fn wetness_at(&self, t_s: f64) -> f64 {
        (self.history.store_mm(&self.store, t_s) / self.store.capacity_mm).clamp(0.0, 1.0)
    }

    /// Whether the ground is ever wet (some rain falls).
    pub fn ever_wet(&self) -> bool {
        self.history.any_rain()
    }
}

/// Unpolarised Fresnel reflectance of a surface of index `index` seen from the air at incidence
/// cosine `cos_i` (the mean of the s and p reflectances: exact for unpolarised light).
pub fn reflectance(index: f64, cos_i: f64) -> f64 {
    let (rs, rp) = fresnel(index, cos_i);
    0.5 * (rs + rp)
}

/// [`reflectance`] of water.
pub fn water_reflectance(cos_i: f64) -> f64 {
    reflectance(WATER_INDEX, cos_i)
}

/// Reflectance of the water–air interface for light inside the water at cosine `cos_w`: total
/// beyond the critical angle, else (by reciprocity) the external value at the refracted angle.
pub fn internal_reflectance(cos_w: f64) -> f64 {
    let sin_air2 = WATER_INDEX * WATER_INDEX * (1.0 - cos_w * cos_w);
    if sin_air2 >= 1.0 {
        1.0
    } else {
        water_reflectance((1.0 - sin_air2).sqrt())
    }
}

/// The cosine-weighted hemispherical mean ∫ R(μ) 2μ dμ of `reflectance` over μ ∈ [0, 1], with a
/// panel edge at `kink` (where the integrand is not smooth; past the critical angle it rises
/// like a square root, hence the many panels).
fn diffuse_mean(reflectance: impl Fn(f64) -> f64, kink: f64) -> f64 {
    composite_gauss(0.0, kink, 256, 8)
        .into_iter()
        .chain(composite_gauss(kink, 1.0, 256, 8))
        .map(|(mu, w)| w * 2.0 * mu * reflectance(mu))
        .sum()
}

/// The film's optical constants: the index and the two diffuse reflectances of Lekner & Dorf.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilmOptics {
    /// Refractive index of the water.
    pub index: f64,
    /// R̄ₑ: reflectance for diffuse light arriving from the air.
    pub diffuse_external: f64,
    /// R̄ᵢ: reflectance for diffuse light inside the water (total internal reflection included).
    pub diffuse_internal: f64,
}

impl FilmOptics {
    /// A water film's constants, integrated from the Fresnel equations.
    pub fn water() -> FilmOptics {
        let critical_cos = (1.0 - 1.0 / (WATER_INDEX * WATER_INDEX)).sqrt();
        FilmOptics {
            index: WATER_INDEX,
            diffuse_external: diffuse_mean(water_reflectance, 0.5),
            diffuse_internal: diffuse_mean(internal_reflectance, critical_cos),
        }
    }

    /// k(a, μ): a fully wet surface's diffuse radiance over the dry one for dry albedo
    /// `albedo`, seen at view cosine `cos_view` (Lekner & Dorf's multiple reflection in the
    /// film; the specular reflection is separate).
    pub fn darkening(&self, albedo: f64, cos_view: f64) -> f64 {
        (1.0 - reflectance(self.index, cos_view)) * (1.0 - self.diffuse_external)
            / (self.index * self.index * (1.0 - albedo * self.diffuse_internal))
    }
}
