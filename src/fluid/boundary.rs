//! Boundaries: the simulation box (walls or open faces) and the height-field terrain.
//!
//! How it works: every wall and the terrain act on a particle twice.
//! 1. As a continuum of fluid at rest beyond a plane (a semi-analytic boundary): for a particle at
//!    distance d < h, the kernel's half-space integrals ([`super::kernels::HalfSpace`]) give the
//!    missing density ρ₀Φ(d), a mirrored-pressure force and optional friction. Without this,
//!    particles near walls see too few neighbours, pack too tightly and feel no pressure from
//!    the wall. The terrain is treated as its local tangent plane: d = (z − H(x, y))·n_z with n
//!    the interpolated normal.
//! 2. As a hard collision after each drift (thesis §5.3.1): a particle found beyond a wall or
//!    below the terrain is moved back (by its damped penetration, at most half a spacing) and
//!    the normal component of its velocity is reflected and multiplied by the damping factor
//!    in (0, 1). The thesis damps the whole velocity; we damp only the normal part, because
//!    damping the tangential part at every contact would be a hidden friction (friction is the
//!    explicit `wall_friction` instead).
//!
//! Particles beyond an open face leave the simulation and are counted as outflow.

use super::terrain::HeightField;
use crate::{Error, Result};
use glam::Vec3;

/// What a face of the simulation box does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Face {
    /// A solid wall (semi-analytic boundary + collision).
    Wall,
    /// An open face: particles crossing it are removed and counted as outflow.
    Open,
}

/// The simulation box, m, z up. Faces in the order −x, +x, −y, +y, −z, +z.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Domain {
    /// Lower corner, m.
    pub min_m: Vec3,
    /// Upper corner, m.
    pub max_m: Vec3,
    /// Face behaviour: −x, +x, −y, +y, −z, +z.
    pub faces: [Face; 6],
}

impl Domain {
    /// A box with six walls.
    pub fn closed(min_m: Vec3, max_m: Vec3) -> Domain {
        Domain {
            min_m,
            max_m,
            faces: [Face::Wall; 6],
        }
    }

    /// A box whose four sides are open (water running off the terrain's edge leaves), with a
    /// floor wall and an open top.
    pub fn open_sides(min_m: Vec3, max_m: Vec3) -> Domain {
        Domain {
            min_m,
            max_m,
            faces: [
                Face::Open,
                Face::Open,
                Face::Open,
                Face::Open,
                Face::Wall,
                Face::Open,
            ],
        }
    }

    /// Checks that the box is finite and non-empty.
    pub fn validate(&self) -> Result<()> {
        if !(self.min_m.is_finite() && self.max_m.is_finite() && self.min_m.cmplt(self.max_m).all())
        {
            return Err(Error::Parameter {
                name: "sph.domain",
                value: format!("{} .. {}", self.min_m, self.max_m),
                expected: "a finite box with min < max on every axis".into(),
            });
        }
        Ok(())
    }

    /// Whether `p` lies inside the box (faces included).
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min_m).all() && p.cmple(self.max_m).all()
    }
}

/// The box plus an optional terrain.
#[derive(Debug, Clone, PartialEq)]
pub struct Boundaries {
    /// The simulation box.
    pub domain: Domain,
    /// The terrain (thesis §5.2), if any.
    pub terrain: Option<HeightField>,
}

/// What the collision step decided for a particle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Fate {
    Stays,
    Leaves,
    Invalid,
}

const AXES: [Vec3; 3] = [Vec3::X, Vec3::Y, Vec3::Z];

impl Boundaries {
    /// Calls `f(d, n)` for every wall and the terrain closer than `h_m` to `p`: `d` the signed
    /// distance on the fluid side (m), `n` the unit normal pointing into the fluid.
    #[inline]
    pub fn for_each_wall(&self, p: Vec3, h_m: f32, mut f: impl FnMut(f32, Vec3)) {
        let d = &self.domain;
        for (axis, n) in AXES.iter().enumerate() {
            if d.faces[2 * axis] == Face::Wall {
                let dist = p[axis] - d.min_m[axis];
                if dist < h_m {
                    f(dist, *n);
                }
            }
            if d.faces[2 * axis + 1] == Face::Wall {
                let dist = d.max_m[axis] - p[axis];
                if dist < h_m {
                    f(dist, -*n);
                }
            }
        }
        if let Some(t) = &self.terrain {
            let s = t.sample(p.x, p.y);
            let dist = (p.z - s.height_m) * s.normal.z;
            if dist < h_m {
                f(dist, s.normal);
            }
        }
    }

    /// Terrain height at (x, y), or the box floor without a terrain, m.
    pub fn ground_m(&self, x_m: f32, y_m: f32) -> f32 {
        match &self.terrain {
            Some(t) => t.height_at_m(x_m, y_m).max(self.domain.min_m.z),
            None => self.domain.min_m.z,
        }
    }

    /// Collision after a drift (thesis §5.3.1): pushes `p` back above the terrain and inside
    /// walls, reflecting the normal velocity with factor `damping`; reports particles that left
    /// through an open face or became non-finite.
    #[inline]
    pub(crate) fn collide(&self, p: &mut Vec3, v: &mut Vec3, damping: f32, max_push_m: f32) -> Fate {
        if !(p.is_finite() && v.is_finite()) {
            return Fate::Invalid;
        }
        if let Some(t) = &self.terrain {
            let s = t.sample(p.x, p.y);
            let gap = p.z - s.height_m;
            if gap < 0.0 {
                p.z = s.height_m + (damping * -gap).min(max_push_m);
                let vn = v.dot(s.normal);
                if vn < 0.0 {
                    *v -= s.normal * ((1.0 + damping) * vn);
                }
            }
        }
        let d = &self.domain;
        for axis in 0..3 {
            let (lo, hi) = (d.min_m[axis], d.max_m[axis]);
            if p[axis] < lo {
                if d.faces[2 * axis] == Face::Open {
                    return Fate::Leaves;
                }
                p[axis] = (lo + (damping * (lo - p[axis])).min(max_push_m)).min(hi);
                if v[axis] < 0.0 {
                    v[axis] *= -damping;
                }
            } else if p[axis] > hi {
                if d.faces[2 * axis + 1] == Face::Open {
                    return Fate::Leaves;
                }
                p[axis] = (hi - (damping * (p[axis] - hi)).min(max_push_m)).max(lo);
                if v[axis] > 0.0 {
                    v[axis] *= -damping;
                }
            }
        }
        Fate::Stays
    }
}
