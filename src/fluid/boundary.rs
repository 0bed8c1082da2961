//! Boundaries: the simulation box (walls or open faces) and the height-field terrain.
//!
//! How it works: walls act on a particle twice.
//! 1. By the method of images: every neighbour j has a ghost, its mirror image behind each wall
//!    within h of particle i, carrying j's density and pressure (and j's velocity, mirrored;
//!    the tangential part scaled by 1 − 2·friction, so friction 1 is no slip). Ghosts count in
//!    density, pressure, viscosity and the colour field exactly like real neighbours. For plane
//!    walls the ghosts are the mirror copy of the whole fluid, so the system stays Lagrangian:
//!    forces are gradients of one energy and nothing is pumped in. (A semi-analytic wall whose
//!    pressure copies pᵢ, tried first, is not a gradient and fed a growing oscillation.) Near a
//!    box edge or corner, the compositions of the reflections (up to 7 images) are included.
//!    The terrain is mirrored across particle i's tangent plane (height and barycentric normal
//!    of the triangle below it) — exact for planes, close while the terrain's radius of
//!    curvature is large against h. Only fluid on the fluid side of a plane is mirrored, and
//!    for axis-aligned walls every ghost within h of i is the image of a real neighbour within h,
//!    so the neighbour search needs nothing extra.
//! 2. As a hard collision after each drift (thesis §5.3.1): a particle found beyond a wall or
//!    below the terrain is moved back (by its damped penetration, at most half a spacing) and
//!    the normal component of its velocity is reflected and multiplied by the damping factor
//!    in [0, 1]. The thesis damps the whole velocity; we damp only the normal part, because
//!    damping the tangential part at every contact would be a hidden friction (friction is
//!    `ground_friction` instead).
//!
//! Particles beyond an open face leave the simulation and are counted as outflow.

use super::terrain::{HeightField, TerrainSample};
use crate::{Error, Result};
use glam::Vec3;

/// What a face of the simulation box does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Face {
    /// A solid wall (semi-analytic boundary + collision).
    Wall,
    /// An open face: particles crossing it are removed and counted as outflow.
    Open,
}

/// The simulation box, m, z up. Faces in the order −x, +x, −y, +y, −z, +z.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
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
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Boundaries {
    /// The simulation box.
    pub domain: Domain,
    /// The terrain (thesis §5.2), if any. Not in a checkpoint (the largest part of the water's
    /// state and fixed by its configuration): a restored solver gets it back from a fresh one.
    #[serde(skip)]
    pub terrain: Option<HeightField>,
}

/// What the collision step decided for a particle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Fate {
    Stays,
    Leaves,
    Invalid,
}

/// A reflection taking fluid points to their ghost images.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Mirror {
    /// Reflect the coordinates selected by `mask` across the planes x_a = c_a
    /// (`twice_plane` = 2c).
    Axes {
        /// Which axes are reflected.
        mask: glam::BVec3,
        /// Twice the plane coordinates.
        twice_plane: Vec3,
        /// Factor on the ghost's tangential velocity.
        tangential: f32,
    },
    /// Reflect across the plane n·x = `offset` (the terrain's tangent plane).
    Plane {
        /// Unit normal towards the fluid.
        normal: Vec3,
        /// n·(a point of the plane).
        offset: f32,
        /// Factor on the ghost's tangential velocity.
        tangential: f32,
    },
}

impl Mirror {
    /// The ghost of `x`, or None if `x` is behind the plane (it has no ghost there).
    #[inline]
    pub(crate) fn point(&self, x: Vec3) -> Option<Vec3> {
        match *self {
            Mirror::Axes {
                mask, twice_plane, ..
            } => Some(Vec3::select(mask, twice_plane - x, x)),
            Mirror::Plane { normal, offset, .. } => {
                let d = x.dot(normal) - offset;
                (d >= 0.0).then(|| x - normal * (2.0 * d))
            }
        }
    }

    /// The ghost's velocity: normal part reversed, tangential part scaled by 1 − 2·friction
    /// (free slip … no slip).
    #[inline]
    pub(crate) fn velocity(&self, v: Vec3) -> Vec3 {
        match *self {
            Mirror::Axes {
                mask, tangential, ..
            } => Vec3::select(mask, -v, v * tangential),
            Mirror::Plane {
                normal, tangential, ..
            } => {
                let vn = normal * v.dot(normal);
                (v - vn) * tangential - vn
            }
        }
    }
}

/// Mirrors held in place: a box corner's 7 images and the terrain; more (a box narrower than
/// 2h) go to the heap. Made twice a step for every moving particle, so kept small.
const INLINE_MIRRORS: usize = 8;

/// The mirrors acting on one particle (at most 26 box images plus the terrain).
#[derive(Debug, Clone)]
pub(crate) struct Mirrors {
    list: [Mirror; INLINE_MIRRORS],
    len: usize,
    /// All of them, in order, where there are more than [`INLINE_MIRRORS`].
    more: Vec<Mirror>,
}

impl Default for Mirrors {
    /// None.
    #[inline(always)]
    fn default() -> Mirrors {
        Mirrors {
            // A filler of zero bits (never read past `len`): cleared in a few wide stores.
            list: [Mirror::Axes {
                mask: glam::BVec3::FALSE,
                twice_plane: Vec3::ZERO,
                tangential: 0.0,
            }; INLINE_MIRRORS],
            len: 0,
            more: Vec::new(),
        }
    }
}

impl Mirrors {
    #[inline]
    pub(crate) fn as_slice(&self) -> &[Mirror] {
        if self.more.is_empty() {
            &self.list[..self.len]
        } else {
            &self.more
        }
    }

    #[inline]
    fn push(&mut self, mirror: Mirror) {
        if self.len < INLINE_MIRRORS {
            self.list[self.len] = mirror;
        } else {
            if self.more.is_empty() {
                self.more.extend_from_slice(&self.list);
            }
            self.more.push(mirror);
        }
        self.len += 1;
    }
}

impl Boundaries {
    /// The mirrors for a particle at `p`: reflections across every wall closer than `h_m`, their
    /// compositions across different axes, and the terrain's tangent plane if closer than h.
    /// `ground_friction` ∈ [0, 1] applies to the ground (terrain and box floor); the other
    /// walls are free-slip (the side walls of the validation tanks stand for symmetry planes).
    #[inline]
    pub(crate) fn mirrors(&self, p: Vec3, h_m: f32, ground_friction: f32) -> Mirrors {
        self.mirrors_on(p, h_m, ground_friction, self.terrain_under(p))
    }

    /// The terrain under `p` ([`HeightField::sample`]), if there is a terrain: what
    /// [`Boundaries::mirrors_on`] takes, kept by a pass that asks for the mirrors of one
    /// position twice.
    #[inline]
    pub(crate) fn terrain_under(&self, p: Vec3) -> Option<TerrainSample> {
        self.terrain.as_ref().map(|t| t.sample(p.x, p.y))
    }

    /// [`Boundaries::mirrors`] with the terrain under `p` given (`terrain_under(p)`). Always
    /// inlined: the solver's passes call it twice a step per particle, and a call returns the
    /// list through a copy of its whole inline storage.
    #[inline(always)]
    pub(crate) fn mirrors_on(
        &self,
        p: Vec3,
        h_m: f32,
        ground_friction: f32,
        terrain: Option<TerrainSample>,
    ) -> Mirrors {
        let rough = 1.0 - 2.0 * ground_friction;
        let d = &self.domain;
        let mut m = Mirrors::default();
        // Per axis: the planes (twice their coordinate) within h.
        let mut planes = [[0.0f32; 2]; 3];
        let mut count = [0usize; 3];
        for axis in 0..3 {
            if d.faces[2 * axis] == Face::Wall && p[axis] - d.min_m[axis] < h_m {
                planes[axis][count[axis]] = 2.0 * d.min_m[axis];
                count[axis] += 1;
            }
            if d.faces[2 * axis + 1] == Face::Wall && d.max_m[axis] - p[axis] < h_m {
                planes[axis][count[axis]] = 2.0 * d.max_m[axis];
                count[axis] += 1;
            }
        }
        if count.iter().any(|&c| c > 0) {
            for cz in 0..=count[2] {
                for cy in 0..=count[1] {
                    for cx in 0..=count[0] {
                        if cx + cy + cz == 0 {
                            continue;
                        }
                        let pick = |c: usize, axis: usize| {
                            if c == 0 { 0.0 } else { planes[axis][c - 1] }
                        };
                        let twice_plane = Vec3::new(pick(cx, 0), pick(cy, 1), pick(cz, 2));
                        let floor = cz > 0 && twice_plane.z == 2.0 * d.min_m.z;
                        m.push(Mirror::Axes {
                            mask: glam::BVec3::new(cx > 0, cy > 0, cz > 0),
                            twice_plane,
                            tangential: if floor { rough } else { 1.0 },
                        });
                    }
                }
            }
        }
        if let Some(s) = terrain {
            let dist = (p.z - s.height_m) * s.normal.z;
            if dist < h_m {
                let foot = Vec3::new(p.x, p.y, s.height_m);
                m.push(Mirror::Plane {
                    normal: s.normal,
                    offset: s.normal.dot(foot),
                    tangential: rough,
                });
            }
        }
        m
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
    pub(crate) fn collide(
        &self,
        p: &mut Vec3,
        v: &mut Vec3,
        damping: f32,
        max_push_m: f32,
    ) -> Fate {
        self.collide_sampled(p, v, damping, max_push_m, &mut None)
    }

    /// [`Boundaries::collide`], leaving in `sampled` the terrain it read and where (x, y):
    /// the terrain under the particle after the collision wherever the walls left x and y
    /// alone, which a caller reads again only where they moved.
    #[inline]
    pub(crate) fn collide_sampled(
        &self,
        p: &mut Vec3,
        v: &mut Vec3,
        damping: f32,
        max_push_m: f32,
        sampled: &mut Option<(glam::Vec2, TerrainSample)>,
    ) -> Fate {
        if !(p.is_finite() && v.is_finite()) {
            return Fate::Invalid;
        }
        if let Some(t) = &self.terrain {
            let s = t.sample(p.x, p.y);
            *sampled = Some((p.truncate(), s));
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
