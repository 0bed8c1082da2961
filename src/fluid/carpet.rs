//! The carpet: the fluid's free surface as a height field over the terrain (Kipfer &
//! Westermann 2006, "Realistic and interactive simulation of rivers"; thesis §5.3.2), and the
//! wetness of the ground.
//!
//! How it works: a regular grid of leaves covers the terrain, with a quadtree above it (each
//! level halves the resolution, up to one root). On every update:
//! 1. Each particle raises the leaves its disk (the particle radius) covers to its height plus
//!    its radius — the leaf keeps the highest. Splatting the disk rather than the centre keeps
//!    a carpet finer than the particle spacing free of holes.
//! 2. The quadtree is walked from the root, entering only nodes that hold water or received a
//!    particle, so the cost follows the wet area, not the grid. A leaf with a particle sits at
//!    its height with zero vertical speed; a wet leaf without one falls under the trail
//!    acceleration (gravity in the thesis) until a particle arrives or it reaches the terrain —
//!    the wet trails of §5.3.2.
//! 3. On the way back up, each parent takes the mean of its children's heights (for level of
//!    detail, as the thesis does), their minimum terrain height and the maximum water depth.
//!    The mean alone can hide one wet leaf among dry ones (a dry leaf sits at the terrain), so
//!    pruning uses the maximum depth instead of "mean below terrain".
//!
//! Wetness model (ours; the thesis only draws trails): a leaf under water has wetness 1. Once
//! dry it decays exponentially, w(t) = w₀ e^{−(t − t₀)/τ}, τ the drying time; every raindrop
//! hitting a dry leaf adds a fixed amount (capped at 1). It is evaluated lazily, so dry leaves
//! cost nothing per update.

use super::terrain::HeightField;
use crate::{Error, Result};
use glam::{Vec2, Vec3};

/// Parameters of a [`Carpet`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CarpetSettings {
    /// Leaves along x.
    pub nx: usize,
    /// Leaves along y.
    pub ny: usize,
    /// Corner of leaf (0, 0), m.
    pub origin_m: Vec2,
    /// Leaf edge, m.
    pub cell_m: f32,
    /// Radius of a particle's footprint and of its cap above its centre, m (half the spacing).
    pub particle_radius_m: f32,
    /// Downward acceleration of a leaf that lost its particles, m/s² (thesis: gravity).
    pub trail_acceleration_mps2: f32,
    /// Drying time constant τ, s.
    pub drying_time_s: f32,
    /// Wetness added by one raindrop on a dry leaf, in [0, 1].
    pub wetting_per_hit: f32,
}

/// A cell-centred scalar field on a regular grid: value k sits at
/// `origin + ((k mod nx) + ½, (k div nx) + ½)·cell`.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Field2 {
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// Corner of cell (0, 0), m.
    pub origin_m: Vec2,
    /// Cell edge, m.
    pub cell_m: f32,
    /// Values, row-major (x fastest).
    pub values: Vec<f32>,
}

/// One quadtree node (or leaf) of the carpet.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CarpetNode {
    /// Surface height, m: water where wet, the terrain where dry; parents: the children's mean.
    pub height_m: f32,
    /// Lowest terrain under the node, m.
    pub min_terrain_m: f32,
    /// Deepest water under the node, m (0: dry, prunable).
    pub max_depth_m: f32,
}

#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct Level {
    nx: usize,
    ny: usize,
    nodes: Vec<CarpetNode>,
    touched: Vec<bool>,
}

/// The carpet over a terrain.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Carpet {
    settings: CarpetSettings,
    levels: Vec<Level>,
    leaf_terrain_m: Vec<f32>,
    leaf_speed_mps: Vec<f32>,
    splat_m: Vec<f32>,
    splatted: Vec<u32>,
    /// Per leaf, what its wetness is evaluated from.
    wet: Vec<LeafWet>,
    time_s: f64,
    /// [`Carpet::add_hits`]'s buffer.
    #[serde(skip)]
    sort_scratch: Vec<u32>,
    /// [`Carpet::update_split`]'s memory, rebuilt when missing (left out of checkpoints).
    #[serde(skip)]
    incremental: Option<Incremental>,
    /// The leaves updated since [`Carpet::take_visited`] last took them (left out of
    /// checkpoints and clones: a carpet read or cloned lists none).
    #[serde(skip)]
    visited: Visited,
}

/// The leaves [`Carpet::update_leaf`] visited since the stamp `since`, so that a reader that
/// keeps a copy of the leaves ([`crate::fluid::puddles::KeptWaterMap`]) compares only those,
/// not every leaf every frame. Every other leaf has kept its height and depth to the bit:
/// only `update_leaf` writes them.
#[derive(Debug)]
struct Visited {
    /// When the list started: a stamp no other list of any carpet has.
    since: u64,
    /// The leaves, repeats allowed; `None` when unknown (a carpet made, read or cloned, or a
    /// list grown past the leaves' count, never taken).
    leaves: Option<Vec<u32>>,
}

/// The next [`Visited`] stamp: unique in the process.
fn next_stamp() -> u64 {
    static STAMPS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    STAMPS.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

impl Default for Visited {
    /// No list, under a fresh stamp.
    fn default() -> Visited {
        Visited {
            since: next_stamp(),
            leaves: None,
        }
    }
}

impl Clone for Visited {
    /// No list, under a fresh stamp: a reader kept from the original must compare every leaf
    /// of the clone.
    fn clone(&self) -> Visited {
        Visited::default()
    }
}

/// The leaves a carpet updated since a reader last asked ([`Carpet::take_visited`]).
#[derive(Debug, Clone, PartialEq)]
pub struct VisitedLeaves {
    /// The stamp the list starts from: the reader's list is complete only if it took the
    /// carpet's leaves at this stamp.
    pub since: u64,
    /// The stamp the next list will start from.
    pub next: u64,
    /// The leaves (repeats allowed); `None`: unknown, compare them all.
    pub leaves: Option<Vec<u32>>,
}

/// A leaf's wetness state, in one record so a raindrop reads and writes one cache line: under
/// water (mirrors `max_depth_m > 0`), else `wet_ref` decaying from `wet_ref_time_s`.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
struct LeafWet {
    wet_ref: f32,
    under_water: bool,
    wet_ref_time_s: f64,
}

/// What lets [`Carpet::update_split`] visit only the leaves that can change: the footprint of
/// the water at rest and the leaves left moving by the last update.
#[derive(Debug, Clone)]
struct Incremental {
    /// The resting particles' version the footprint was made from.
    rest_version: u64,
    /// Per leaf, the highest top of a resting particle over it (−∞: none).
    rest_splat_m: Vec<f32>,
    /// Leaves whose next update may differ from their last: a moving particle's top was over
    /// the water at rest there, or the leaf is a falling trail.
    live: Vec<u32>,
}

impl Carpet {
    /// A dry carpet over `terrain`.
    pub fn new(settings: CarpetSettings, terrain: &HeightField) -> Result<Carpet> {
        let s = settings;
        if s.nx == 0 || s.ny == 0 || s.nx.saturating_mul(s.ny) > 1 << 24 {
            return Err(Error::Parameter {
                name: "carpet.size",
                value: format!("{}×{}", s.nx, s.ny),
                expected: "between 1 and 2²⁴ leaves".into(),
            });
        }
        for (name, v, ok) in [
            ("carpet.cell_m", s.cell_m, s.cell_m > 0.0),
            (
                "carpet.particle_radius_m",
                s.particle_radius_m,
                s.particle_radius_m >= 0.0,
            ),
            (
                "carpet.trail_acceleration_mps2",
                s.trail_acceleration_mps2,
                s.trail_acceleration_mps2 >= 0.0,
            ),
            (
                "carpet.drying_time_s",
                s.drying_time_s,
                s.drying_time_s > 0.0,
            ),
            (
                "carpet.wetting_per_hit",
                s.wetting_per_hit,
                (0.0..=1.0).contains(&s.wetting_per_hit),
            ),
        ] {
            if !(v.is_finite() && ok) {
                return Err(Error::Parameter {
                    name,
                    value: v.to_string(),
                    expected: "a finite value in range (cell and drying time > 0, radius and \
                               acceleration ≥ 0, wetting in [0, 1])"
                        .into(),
                });
            }
        }
        if !s.origin_m.is_finite() {
            return Err(Error::Parameter {
                name: "carpet.origin_m",
                value: s.origin_m.to_string(),
                expected: "a finite corner".into(),
            });
        }
        let n = s.nx * s.ny;
        // Row by row: no division per leaf to find its row and column.
        let mut leaf_terrain_m = Vec::with_capacity(n);
        for j in 0..s.ny {
            leaf_terrain_m.extend((0..s.nx).map(|i| {
                let c = s.origin_m + (Vec2::new(i as f32, j as f32) + 0.5) * s.cell_m;
                terrain.height_at_m(c.x, c.y)
            }));
        }
        let leaves = Level {
            nx: s.nx,
            ny: s.ny,
            nodes: leaf_terrain_m
                .iter()
                .map(|&t| CarpetNode {
                    height_m: t,
                    min_terrain_m: t,
                    max_depth_m: 0.0,
                })
                .collect(),
            touched: vec![false; n],
        };
        let mut levels = vec![leaves];
        while let Some(below) = levels.last().filter(|l| l.nx > 1 || l.ny > 1) {
            let (nx, ny) = (below.nx.div_ceil(2), below.ny.div_ceil(2));
            let mut level = Level {
                nx,
                ny,
                nodes: vec![
                    CarpetNode {
                        height_m: 0.0,
                        min_terrain_m: 0.0,
                        max_depth_m: 0.0
                    };
                    nx * ny
                ],
                touched: vec![false; nx * ny],
            };
            for j in 0..ny {
                for i in 0..nx {
                    level.nodes[j * nx + i] = combine(below, i, j);
                }
            }
            levels.push(level);
        }
        Ok(Carpet {
            settings,
            levels,
            leaf_terrain_m,
            leaf_speed_mps: vec![0.0; n],
            splat_m: vec![f32::NEG_INFINITY; n],
            splatted: Vec::new(),
            wet: vec![LeafWet::default(); n],
            time_s: 0.0,
            sort_scratch: Vec::new(),
            incremental: None,
            visited: Visited::default(),
        })
    }

    /// The settings.
    pub fn settings(&self) -> &CarpetSettings {
        &self.settings
    }

    /// Number of quadtree levels (0 = leaves; the last has one node).
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// Nodes along x and y at `level`.
    pub fn level_dims(&self, level: usize) -> Option<(usize, usize)> {
        self.levels.get(level).map(|l| (l.nx, l.ny))
    }

    /// Node (i, j) of `level`.
    pub fn node(&self, level: usize, i: usize, j: usize) -> Option<CarpetNode> {
        let l = self.levels.get(level)?;
        (i < l.nx && j < l.ny).then(|| l.nodes[j * l.nx + i])
    }

    /// Carpet time, s (the sum of update steps).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    fn leaf_of(&self, x_m: f32, y_m: f32) -> Option<usize> {
        let s = &self.settings;
        let g = (Vec2::new(x_m, y_m) - s.origin_m) / s.cell_m;
        (g.x >= 0.0 && g.y >= 0.0 && g.x < s.nx as f32 && g.y < s.ny as f32)
            .then(|| (g.y as usize).min(s.ny - 1) * s.nx + (g.x as usize).min(s.nx - 1))
    }

    /// The fluid surface height at (x, y), m: the φ of (5.29) against which raindrops collide
    /// (the terrain where dry). `None` outside the carpet.
    pub fn surface_height_m(&self, x_m: f32, y_m: f32) -> Option<f32> {
        self.leaf_of(x_m, y_m)
            .map(|k| self.levels[0].nodes[k].height_m)
    }

    /// A raindrop hit the ground at (x, y): wets a dry leaf (no effect under water or outside).
    pub fn add_hit(&mut self, x_m: f32, y_m: f32) {
        if let Some(k) = self.leaf_of(x_m, y_m) {
            let w = self.leaf_wetness(k);
            let leaf = &mut self.wet[k];
            leaf.wet_ref = (w + self.settings.wetting_per_hit).min(1.0);
            leaf.wet_ref_time_s = self.time_s;
        }
    }

    /// The leaf under (x, y), for [`Carpet::add_hits`]; `None` outside the carpet.
    pub fn leaf_index(&self, x_m: f32, y_m: f32) -> Option<u32> {
        self.leaf_of(x_m, y_m).map(|k| k as u32)
    }

    /// [`Carpet::add_hit`] once per entry of `leaves` (leaf indices, one per raindrop; emptied).
    /// The hits are applied in leaf order, so the memory is swept once rather than hit at
    /// random; the result is the same as adding them one by one in any order, since all hits
    /// of a leaf at one time are the same operation (the second and later see no decay).
    pub fn add_hits(&mut self, leaves: &mut Vec<u32>) {
        radix_sort(leaves, &mut self.sort_scratch, self.wet.len());
        let a = self.settings.wetting_per_hit;
        // A leaf's decay depends only on when it was last wetted, and a batch's leaves were
        // last wetted at a few dozen times at most (one per update): each time's factor is
        // made once, the same bits as `leaf_wetness` makes it.
        let mut decay = [(f64::NAN.to_bits(), 0.0f32); 64];
        for (n, &k) in leaves.iter().enumerate() {
            // The leaves are sorted but sparse (a drop every ten or so a frame): each is a cache
            // miss the hardware does not foresee, so the one some hits ahead is asked for now.
            if let Some(&ahead) = leaves.get(n + HITS_AHEAD) {
                prefetch(self.wet.get(ahead as usize));
            }
            let k = k as usize;
            if let Some(&leaf) = self.wet.get(k) {
                let w = if leaf.under_water {
                    1.0
                } else if leaf.wet_ref == 0.0 || self.time_s == leaf.wet_ref_time_s {
                    leaf.wet_ref
                } else {
                    let bits = leaf.wet_ref_time_s.to_bits();
                    let slot =
                        &mut decay[(bits.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 58) as usize];
                    if slot.0 != bits {
                        *slot = (bits, self.decay(leaf.wet_ref_time_s));
                    }
                    leaf.wet_ref * slot.1
                };
                let leaf = &mut self.wet[k];
                leaf.wet_ref = (w + a).min(1.0);
                leaf.wet_ref_time_s = self.time_s;
            }
        }
        leaves.clear();
    }

    fn leaf_wetness(&self, k: usize) -> f32 {
        let leaf = &self.wet[k];
        if leaf.under_water {
            return 1.0;
        }
        // Never wetted, or wetted at this very time: e^0 = 1, so no exponential (the same bits).
        if leaf.wet_ref == 0.0 || self.time_s == leaf.wet_ref_time_s {
            return leaf.wet_ref;
        }
        leaf.wet_ref * self.decay(leaf.wet_ref_time_s)
    }

    /// The factor a wetness set at `since_s` has decayed by now.
    #[inline]
    fn decay(&self, since_s: f64) -> f32 {
        let age = (self.time_s - since_s).max(0.0);
        (-age / self.settings.drying_time_s as f64).exp() as f32
    }

    /// Rebuilds the surface from particle positions and advances the trails and the drying by
    /// `dt_s`.
    pub fn update(&mut self, positions_m: &[Vec3], dt_s: f32) {
        self.time_s += dt_s as f64;
        self.incremental = None;
        self.splat(positions_m, true);
        let top = self.levels.len() - 1;
        for j in 0..self.levels[top].ny {
            for i in 0..self.levels[top].nx {
                self.visit(top, i, j, dt_s);
            }
        }
        for &k in &self.splatted {
            self.splat_m[k as usize] = f32::NEG_INFINITY;
        }
        self.splatted.clear();
    }

    /// Raises `splat_m` to each particle's top over the leaves its disk covers, listing the
    /// leaves first raised in `splatted`; `mark`: also mark them (and their parents) touched.
    fn splat(&mut self, positions_m: &[Vec3], mark: bool) {
        let s = self.settings;
        let r = s.particle_radius_m;
        for p in positions_m {
            let g0 = (p.truncate() - r - s.origin_m) / s.cell_m;
            let g1 = (p.truncate() + r - s.origin_m) / s.cell_m;
            if !(g1.x >= 0.0 && g1.y >= 0.0 && g0.x < s.nx as f32 && g0.y < s.ny as f32) {
                continue;
            }
            let (i0, j0) = (g0.x.max(0.0) as usize, g0.y.max(0.0) as usize);
            let (i1, j1) = ((g1.x as usize).min(s.nx - 1), (g1.y as usize).min(s.ny - 1));
            let top = p.z + r;
            for j in j0..=j1 {
                for i in i0..=i1 {
                    // Skip leaves the disk misses (its bounding square's corners).
                    let lo = s.origin_m + Vec2::new(i as f32, j as f32) * s.cell_m;
                    let nearest = p.truncate().clamp(lo, lo + s.cell_m);
                    if (nearest - p.truncate()).length_squared() > r * r && r > 0.0 {
                        continue;
                    }
                    let k = j * s.nx + i;
                    if self.splat_m[k] == f32::NEG_INFINITY {
                        self.splatted.push(k as u32);
                        if mark {
                            self.mark_touched(i, j);
                        }
                    }
                    self.splat_m[k] = self.splat_m[k].max(top);
                }
            }
        }
    }

    /// [`Carpet::update`] with the particles split into `resting_m` (water at rest, which
    /// changes only when `resting_version` does) and `moving_m`, visiting only the leaves that
    /// can change: those under a moving particle now or at the last update, falling trails,
    /// and those whose resting footprint changed; then their parents. A leaf under resting
    /// water alone, as at the last update, would be set to the same height again, so it is
    /// skipped. The nodes and the wetness equal [`Carpet::update`]'s bit for bit (the only
    /// difference: a leaf kept under water does not restamp the time its drying would start
    /// from, which is restamped when it dries, before anything reads it).
    pub fn update_split(
        &mut self,
        resting_m: &[Vec3],
        resting_version: u64,
        moving_m: &[Vec3],
        dt_s: f32,
    ) {
        self.time_s += dt_s as f64;
        let n = self.settings.nx * self.settings.ny;
        // The resting footprint: kept, remade on a change (the leaves that differ are
        // visited), or made afresh (every leaf the full update would visit is).
        let fresh = match self.incremental.take() {
            Some(inc) if inc.rest_version == resting_version => Ok(inc),
            other => Err(other),
        };
        let mut candidates = Vec::new();
        let mut inc = match fresh {
            Ok(inc) => inc,
            Err(old) => {
                self.splat(resting_m, false);
                let mut rest = vec![f32::NEG_INFINITY; n];
                for &k in &self.splatted {
                    rest[k as usize] = self.splat_m[k as usize];
                    self.splat_m[k as usize] = f32::NEG_INFINITY;
                }
                self.splatted.clear();
                match old {
                    Some(old) => {
                        candidates.extend(old.live);
                        candidates.extend(
                            (0..n as u32)
                                .filter(|&k| old.rest_splat_m[k as usize] != rest[k as usize]),
                        );
                    }
                    None => {
                        let wet = &self.levels[0].nodes;
                        candidates.extend((0..n as u32).filter(|&k| {
                            rest[k as usize] > f32::NEG_INFINITY
                                || wet[k as usize].max_depth_m > 0.0
                        }));
                    }
                }
                Incremental {
                    rest_version: resting_version,
                    rest_splat_m: rest,
                    live: Vec::new(),
                }
            }
        };
        candidates.append(&mut inc.live);
        self.splat(moving_m, false);
        candidates.extend_from_slice(&self.splatted);
        candidates.sort_unstable();
        candidates.dedup();

        for &k in &candidates {
            let k = k as usize;
            let splat = self.splat_m[k].max(inc.rest_splat_m[k]);
            self.update_leaf(k, splat, dt_s);
            let falling = splat == f32::NEG_INFINITY && self.levels[0].nodes[k].max_depth_m > 0.0;
            if splat != inc.rest_splat_m[k] || falling {
                inc.live.push(k as u32);
            }
        }
        for &k in &self.splatted {
            self.splat_m[k as usize] = f32::NEG_INFINITY;
        }
        self.splatted.clear();

        // The parents of what was visited, level by level, each once.
        let mut below = candidates;
        for level in 1..self.levels.len() {
            let nx_below = self.levels[level - 1].nx;
            let nx = self.levels[level].nx;
            let mut parents: Vec<u32> = Vec::with_capacity(below.len() / 2 + 1);
            for &c in &below {
                let (i, j) = (c as usize % nx_below / 2, c as usize / nx_below / 2);
                let p = j * nx + i;
                if !self.levels[level].touched[p] {
                    self.levels[level].touched[p] = true;
                    parents.push(p as u32);
                }
            }
            for &p in &parents {
                let (i, j) = (p as usize % nx, p as usize / nx);
                self.levels[level].touched[p as usize] = false;
                self.levels[level].nodes[p as usize] = combine(&self.levels[level - 1], i, j);
            }
            below = parents;
        }
        self.incremental = Some(inc);
    }

    fn mark_touched(&mut self, mut i: usize, mut j: usize) {
        for level in &mut self.levels {
            let t = &mut level.touched[j * level.nx + i];
            if *t {
                return;
            }
            *t = true;
            i /= 2;
            j /= 2;
        }
    }

    fn visit(&mut self, level: usize, i: usize, j: usize, dt_s: f32) {
        let k = j * self.levels[level].nx + i;
        self.levels[level].touched[k] = false;
        if level == 0 {
            self.update_leaf(k, self.splat_m[k], dt_s);
            return;
        }
        let below = level - 1;
        let (nx, ny) = (self.levels[below].nx, self.levels[below].ny);
        for cj in 2 * j..(2 * j + 2).min(ny) {
            for ci in 2 * i..(2 * i + 2).min(nx) {
                let c = cj * nx + ci;
                let child = &self.levels[below];
                if child.touched[c] || child.nodes[c].max_depth_m > 0.0 {
                    self.visit(below, ci, cj, dt_s);
                }
            }
        }
        self.levels[level].nodes[k] = combine(&self.levels[below], i, j);
    }

    /// The leaves updated since the last call (see [`VisitedLeaves`]), a new list started;
    /// `reuse`: a list to fill next (its leaves dropped), to spare an allocation a frame.
    pub fn take_visited(&mut self, reuse: Vec<u32>) -> VisitedLeaves {
        let next = next_stamp();
        let mut reuse = reuse;
        reuse.clear();
        let since = std::mem::replace(&mut self.visited.since, next);
        let leaves = self.visited.leaves.replace(reuse);
        VisitedLeaves {
            since,
            next,
            leaves,
        }
    }

    /// One leaf's step with `splat_m` the highest particle top over it (−∞: none).
    fn update_leaf(&mut self, k: usize, splat_m: f32, dt_s: f32) {
        if let Some(list) = &mut self.visited.leaves {
            if list.len() < self.leaf_terrain_m.len() {
                list.push(k as u32);
            } else {
                // As long as every leaf: a reader compares them all instead.
                self.visited.leaves = None;
            }
        }
        let terrain = self.leaf_terrain_m[k];
        let node = &mut self.levels[0].nodes[k];
        let was_wet = node.max_depth_m > 0.0;
        if splat_m > f32::NEG_INFINITY {
            node.height_m = splat_m.max(terrain);
            self.leaf_speed_mps[k] = 0.0;
        } else if node.height_m > terrain {
            // The thesis's trail: the node falls until a particle arrives or it meets the ground.
            let v = self.leaf_speed_mps[k] + self.settings.trail_acceleration_mps2 * dt_s;
            self.leaf_speed_mps[k] = v;
            node.height_m = (node.height_m - v * dt_s).max(terrain);
        }
        if node.height_m <= terrain {
            node.height_m = terrain;
            self.leaf_speed_mps[k] = 0.0;
        }
        node.max_depth_m = node.height_m - terrain;
        let under_water = node.max_depth_m > 0.0;
        let leaf = &mut self.wet[k];
        leaf.under_water = under_water;
        if under_water || was_wet {
            // Wet now, or just dried: drying starts from 1 at this time.
            leaf.wet_ref = 1.0;
            leaf.wet_ref_time_s = self.time_s;
        }
    }

    /// Water depth above the terrain per leaf, m.
    pub fn water_depth(&self) -> Field2 {
        self.field(|k| self.levels[0].nodes[k].max_depth_m)
    }

    /// Surface height per leaf (water or terrain), m.
    pub fn surface_height(&self) -> Field2 {
        self.field(|k| self.levels[0].nodes[k].height_m)
    }

    /// Leaf `k`'s surface height and water depth, m: [`Carpet::surface_height`] and
    /// [`Carpet::water_depth`] at k, read in place.
    #[inline]
    pub fn leaf_surface_and_depth(&self, k: usize) -> (f32, f32) {
        let leaf = &self.levels[0].nodes[k];
        (leaf.height_m, leaf.max_depth_m)
    }

    /// The leaves' grid, as a field without values.
    pub fn leaf_grid(&self) -> Field2 {
        self.field_of(Vec::new())
    }

    /// Wetness per leaf, in [0, 1] (see the module's wetness model).
    pub fn wetness(&self) -> Field2 {
        self.field(|k| self.leaf_wetness(k))
    }

    fn field(&self, f: impl Fn(usize) -> f32) -> Field2 {
        let s = &self.settings;
        self.field_of((0..s.nx * s.ny).map(f).collect())
    }

    fn field_of(&self, values: Vec<f32>) -> Field2 {
        let s = &self.settings;
        Field2 {
            nx: s.nx,
            ny: s.ny,
            origin_m: s.origin_m,
            cell_m: s.cell_m,
            values,
        }
    }
}

/// How many hits ahead [`Carpet::add_hits`] asks for a leaf's record.
const HITS_AHEAD: usize = 16;

/// Asks the CPU to bring `item` into its cache (no effect on any value; nothing where the CPU
/// cannot, or for `None`).
#[inline(always)]
fn prefetch<T>(item: Option<&T>) {
    #[cfg(target_arch = "x86_64")]
    if let Some(item) = item {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: a prefetch reads nothing and faults on no address; this one is a live
        // reference's.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((item as *const T).cast::<i8>()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = item;
}

/// Sorts `keys` (all below `bound`) ascending: least significant digit first, 11 bits a pass,
/// as many passes as `bound` needs.
fn radix_sort(keys: &mut Vec<u32>, scratch: &mut Vec<u32>, bound: usize) {
    const BITS: u32 = 11;
    let bits = usize::BITS - bound.saturating_sub(1).leading_zeros();
    scratch.clear();
    scratch.resize(keys.len(), 0);
    let mut shift = 0;
    while shift < bits {
        let mut start = [0usize; 1 << BITS];
        for &k in keys.iter() {
            start[((k >> shift) & ((1 << BITS) - 1)) as usize] += 1;
        }
        let mut sum = 0;
        for s in start.iter_mut() {
            (*s, sum) = (sum, sum + *s);
        }
        for &k in keys.iter() {
            let d = ((k >> shift) & ((1 << BITS) - 1)) as usize;
            scratch[start[d]] = k;
            start[d] += 1;
        }
        std::mem::swap(keys, scratch);
        shift += BITS;
    }
}

/// A parent from its (up to four) children at the level below.
fn combine(below: &Level, i: usize, j: usize) -> CarpetNode {
    let mut sum = 0.0;
    let mut n = 0;
    let mut min_terrain = f32::INFINITY;
    let mut max_depth = 0.0f32;
    for cj in 2 * j..(2 * j + 2).min(below.ny) {
        for ci in 2 * i..(2 * i + 2).min(below.nx) {
            let c = below.nodes[cj * below.nx + ci];
            sum += c.height_m;
            n += 1;
            min_terrain = min_terrain.min(c.min_terrain_m);
            max_depth = max_depth.max(c.max_depth_m);
        }
    }
    CarpetNode {
        height_m: sum / n as f32,
        min_terrain_m: min_terrain,
        max_depth_m: max_depth,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat_carpet(n: usize) -> Carpet {
        let terrain = HeightField::flat(n + 1, n + 1, Vec2::ZERO, 0.01, 0.0).expect("terrain");
        Carpet::new(
            CarpetSettings {
                nx: n,
                ny: n,
                origin_m: Vec2::ZERO,
                cell_m: 0.01,
                particle_radius_m: 0.004,
                trail_acceleration_mps2: 9.81,
                drying_time_s: 10.0,
                wetting_per_hit: 0.25,
            },
            &terrain,
        )
        .expect("carpet")
    }

    #[test]
    fn leaves_take_the_highest_particle_and_parents_the_mean() {
        let mut c = flat_carpet(4);
        let ps = [Vec3::new(0.005, 0.005, 0.02), Vec3::new(0.005, 0.005, 0.01)];
        c.update(&ps, 0.01);
        let leaf = c.node(0, 0, 0).expect("leaf");
        assert!((leaf.height_m - 0.024).abs() < 1e-6);
        let parent = c.node(1, 0, 0).expect("parent");
        assert!((parent.height_m - 0.006).abs() < 1e-6, "{parent:?}");
        assert!((c.node(2, 0, 0).expect("root").max_depth_m - 0.024).abs() < 1e-6);
    }

    #[test]
    fn trails_fall_under_gravity_then_dry() {
        let mut c = flat_carpet(4);
        c.update(&[Vec3::new(0.015, 0.015, 0.05)], 0.01);
        let h0 = c.node(0, 1, 1).expect("leaf").height_m;
        // The particle leaves: free fall from h0, so after t the drop is ½gt² (semi-implicit
        // Euler: ½g t² + ½g t δt).
        let dt = 0.01;
        for _ in 0..5 {
            c.update(&[], dt);
        }
        let t = 5.0 * dt;
        let expected = h0 - 0.5 * 9.81 * t * (t + dt);
        let h = c.node(0, 1, 1).expect("leaf").height_m;
        assert!((h - expected).abs() < 1e-5, "{h} vs {expected}");
        for _ in 0..20 {
            c.update(&[], dt);
        }
        assert_eq!(c.node(0, 1, 1).expect("leaf").max_depth_m, 0.0);
        let w = c.wetness().values[4 + 1];
        assert!(w < 1.0 && w > 0.9, "drying has started: {w}");
        c.add_hit(0.035, 0.035);
        assert!((c.wetness().values[15] - 0.25).abs() < 1e-6);
    }
}
