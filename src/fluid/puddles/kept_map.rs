//! The water map kept from frame to frame: a render's next map made again only in the leaves
//! whose neighbourhoods changed, the same map bit for bit as [`water_map`] makes anew.
//!
//! How it works: a leaf's value in the map reads the carpet's wet leaves within [`REACH`]
//! leaves of it (the wet share's order-8 kernel) and its surface and depth within
//! [`LEVEL_REACH`] (the level and the rim), and nothing else. Between two frames only the
//! moving water and the rain's new particles change the carpet, a few thousand of its million
//! leaves and few of them turning wet or dry, so the map is kept in tiles of [`TILE`] ×
//! [`TILE`] leaves. A frame makes again the values of the leaves within [`LEVEL_REACH`] of a
//! leaf whose surface or depth changed (to the bit), from the kept wet share, and the wet
//! share of the tiles within [`REACH`] of a leaf that turned wet or dry (then the values of
//! every leaf within [`REACH`] of it); each with the same sums in the same order as
//! [`water_map`]'s passes. A leaf's value is a function of the leaves it reads, so a kept one
//! holds what making it again would give. Leaf by leaf rather than whole tiles: the carpet's
//! changes are scattered drops, and the tiles they touch hold five times the leaves they reach.
//!
//! [`water_map`]: super::shown::water_map

use rayon::prelude::*;

use super::shown::{
    KERNEL, LEVEL_KERNEL, LEVEL_REACH, REACH, leaf_value_bounded, taps, water_map_and_share,
    wet_share,
};
use crate::fluid::carpet::{Field2, VisitedLeaves};

/// Leaves along a tile's edge: small enough that a scattered change makes few leaves again
/// (a tile and its neighbours within [`REACH`]), large enough that the margin each tile reads
/// twice stays a fraction of it.
pub const TILE: usize = 8;

/// The water map of the last frame, with the carpet it was made from (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct KeptWaterMap {
    /// The carpet's surface heights the map was made from, m.
    surface_m: Vec<f32>,
    /// The carpet's water depths the map was made from, m.
    depth_m: Vec<f32>,
    /// The map; `None` before the first frame.
    map: Option<Field2>,
    /// The wet share of each leaf's neighbourhood the map was made with.
    share: Vec<f32>,
    /// Tiles made again by the last update, and the tiles in all.
    made: (usize, usize),
    /// Leaves whose value the last update made again.
    leaves_made: usize,
    /// Per leaf, whether the update under way makes its value again (all false between
    /// updates: kept to spare a fresh array a frame).
    stale_leaf: Vec<bool>,
    /// The carpet's stamp ([`VisitedLeaves::next`]) when the kept leaves were taken from
    /// it: its next list of visited leaves is complete for them if it starts there.
    stamp: Option<u64>,
    /// The last list of visited leaves, handed back to the carpet to fill again.
    spare: Vec<u32>,
}

impl KeptWaterMap {
    /// An empty map: the first update makes every tile.
    pub fn new() -> KeptWaterMap {
        KeptWaterMap::default()
    }

    /// The water map of a carpet with surface heights `surface_m` and water depths
    /// `depth_m` ([`water_map`](super::shown::water_map)'s arguments, and its value bit for
    /// bit), making again only the tiles near leaves that changed since the last call (the
    /// whole map, by [`water_map`](super::shown::water_map)'s passes, on the first call or on
    /// another grid).
    ///
    /// # Panics
    /// If the two fields are not on one grid (they are the same carpet's).
    pub fn update(&mut self, surface_m: &Field2, depth_m: &Field2) -> &Field2 {
        assert!(
            surface_m.nx == depth_m.nx
                && surface_m.ny == depth_m.ny
                && surface_m.values.len() == depth_m.values.len()
                && depth_m.values.len() == depth_m.nx * depth_m.ny,
            "surface and depth on one grid"
        );
        let (s, d) = (&surface_m.values, &depth_m.values);
        self.update_leaves(depth_m, |k| (s[k], d[k]))
    }

    /// [`update`](Self::update) with the carpet's leaves read where they are: `leaf(k)` the
    /// surface height and water depth of leaf k of the grid `grid` (its values unused), the
    /// map the same to the bit, without copying the carpet into two fields every frame.
    pub fn update_leaves(
        &mut self,
        grid: &Field2,
        leaf: impl Fn(usize) -> (f32, f32) + Sync,
    ) -> &Field2 {
        self.stamp = None;
        self.update_from(grid, None, leaf);
        self.map.as_ref().expect("made by the update")
    }

    /// [`update_leaves`](Self::update_leaves) comparing only the leaves the carpet lists in
    /// `visited` ([`Carpet::take_visited`]) where that list is complete for the kept leaves
    /// (it starts at the stamp they were taken at), every leaf otherwise: the same map to
    /// the bit, without reading the million leaves every frame.
    pub fn update_visited(
        &mut self,
        grid: &Field2,
        visited: VisitedLeaves,
        leaf: impl Fn(usize) -> (f32, f32) + Sync,
    ) -> &Field2 {
        let complete = self.stamp == Some(visited.since);
        self.stamp = Some(visited.next);
        match visited.leaves {
            Some(list) if complete => {
                self.update_from(grid, Some(&list), leaf);
                self.spare = list;
            }
            other => {
                if let Some(list) = other {
                    self.spare = list;
                }
                self.update_from(grid, None, leaf);
            }
        }
        self.map.as_ref().expect("made by the update")
    }

    /// A list for the carpet to fill with the leaves it visits next (the last one, emptied).
    pub fn take_spare_list(&mut self) -> Vec<u32> {
        let mut list = std::mem::take(&mut self.spare);
        list.clear();
        list
    }

    /// The update: the leaves `listed` compared (all if `None`).
    fn update_from(
        &mut self,
        grid: &Field2,
        listed: Option<&[u32]>,
        leaf: impl Fn(usize) -> (f32, f32) + Sync,
    ) {
        let (nx, ny) = (grid.nx, grid.ny);
        let (tx, ty) = (nx.div_ceil(TILE), ny.div_ceil(TILE));
        let same_grid = self.map.as_ref().is_some_and(|m| {
            (m.nx, m.ny, m.origin_m, m.cell_m) == (nx, ny, grid.origin_m, grid.cell_m)
        });
        if !same_grid {
            // Every tile: the whole-grid passes make the same map to the bit without the
            // margins each tile reads again.
            let on_grid = |values: Vec<f32>| Field2 {
                nx,
                ny,
                origin_m: grid.origin_m,
                cell_m: grid.cell_m,
                values,
            };
            let (surface, depth) = (0..nx * ny).map(&leaf).unzip();
            let (surface, depth) = (on_grid(surface), on_grid(depth));
            let (map, share) = water_map_and_share(&surface, &depth);
            self.map = Some(map);
            self.share = share;
            self.made = (tx * ty, tx * ty);
            self.leaves_made = nx * ny;
            self.stale_leaf = vec![false; nx * ny];
            log::debug!("puddles: the water map made whole ({} tiles)", tx * ty);
            self.surface_m = surface.values;
            self.depth_m = depth.values;
            return;
        }
        let stale = self.take_changes(nx, ny, listed, leaf);
        let made = stale.iter().filter(|&&s| s != Stale::No).count();
        self.made = (made, tx * ty);
        let map = self.map.as_mut().expect("made above");
        self.leaves_made = 0;
        if made > 0 {
            let (s, d) = (&self.surface_m, &self.depth_m);
            let band = TILE * nx.max(1);
            self.leaves_made = map
                .values
                .par_chunks_mut(band)
                .zip(self.share.par_chunks_mut(band))
                .zip(self.stale_leaf.par_chunks_mut(band))
                .zip(stale.par_chunks(tx.max(1)))
                .enumerate()
                .map(|(b, (((rows, share), marks), stale))| {
                    let mut leaves = 0;
                    for (t, &how) in stale.iter().enumerate().filter(|(_, s)| **s != Stale::No) {
                        let tile = (t * TILE, b * TILE);
                        leaves += make_tile((rows, share, marks), how, (nx, ny), tile, (s, d));
                    }
                    leaves
                })
                .sum();
        }
        log::debug!(
            "puddles: the water map made again in {} leaves of {made} of {} tiles ({} with \
             their wet share)",
            self.leaves_made,
            tx * ty,
            stale.iter().filter(|&&s| s == Stale::Share).count()
        );
    }

    /// Leaves whose value the last update made again.
    pub fn leaves_made(&self) -> usize {
        self.leaves_made
    }

    /// Tiles the last update made again, and the tiles in all.
    pub fn tiles_made(&self) -> (usize, usize) {
        self.made
    }

    /// Takes the carpet's new leaves `leaf(k)` into the kept ones and says what each tile
    /// must make again: its wet share where a leaf within [`REACH`] turned wet or dry, values
    /// where a leaf within [`LEVEL_REACH`] changed its surface or depth (to the bit); marks in
    /// `stale_leaf` the leaves whose value changes (within [`REACH`] of a leaf that turned,
    /// within [`LEVEL_REACH`] of one that changed).
    fn take_changes(
        &mut self,
        nx: usize,
        ny: usize,
        listed: Option<&[u32]>,
        leaf: impl Fn(usize) -> (f32, f32) + Sync,
    ) -> Vec<Stale> {
        let (tx, ty) = (nx.div_ceil(TILE), ny.div_ceil(TILE));
        // The changed leaves, each with whether it turned wet or dry (the stale marks below
        // do not depend on their order).
        let changed: Vec<(usize, bool)> = match listed {
            Some(list) => {
                let mut changed = Vec::new();
                for &k in list {
                    let k = k as usize;
                    let (s, d) = (&mut self.surface_m[k], &mut self.depth_m[k]);
                    let (s_new, d_new) = leaf(k);
                    if s_new.to_bits() != s.to_bits() || d_new.to_bits() != d.to_bits() {
                        changed.push((k, (d_new > 0.0) != (*d > 0.0)));
                        (*s, *d) = (s_new, d_new);
                    }
                }
                changed
            }
            None => self
                .surface_m
                .par_chunks_mut(nx.max(1))
                .zip(self.depth_m.par_chunks_mut(nx.max(1)))
                .enumerate()
                .flat_map_iter(|(j, (surface, depth))| {
                    let mut row = Vec::new();
                    for (i, (s, d)) in surface.iter_mut().zip(depth.iter_mut()).enumerate() {
                        let k = j * nx + i;
                        let (s_new, d_new) = leaf(k);
                        if s_new.to_bits() != s.to_bits() || d_new.to_bits() != d.to_bits() {
                            row.push((k, (d_new > 0.0) != (*d > 0.0)));
                            (*s, *d) = (s_new, d_new);
                        }
                    }
                    row
                })
                .collect(),
        };
        let mut stale = vec![Stale::No; tx * ty];
        for (k, turned) in changed {
            // A leaf turning wet or dry changes the wet share within the wide reach; any
            // change, the level and the rim within the narrow one.
            let (how, reach) = if turned {
                (Stale::Share, REACH)
            } else {
                (Stale::Values, LEVEL_REACH)
            };
            let (i, j) = (k % nx, k / nx);
            let (i0, i1) = (
                i.saturating_sub(reach) / TILE,
                (i + reach).min(nx - 1) / TILE,
            );
            let (j0, j1) = (
                j.saturating_sub(reach) / TILE,
                (j + reach).min(ny - 1) / TILE,
            );
            for row in stale[j0 * tx..(j1 + 1) * tx].chunks_mut(tx) {
                for s in &mut row[i0..=i1] {
                    *s = (*s).max(how);
                }
            }
            let (li0, lj0) = (i.saturating_sub(reach), j.saturating_sub(reach));
            let (li1, lj1) = ((i + reach).min(nx - 1), (j + reach).min(ny - 1));
            for row in self.stale_leaf[lj0 * nx..(lj1 + 1) * nx].chunks_mut(nx) {
                row[li0..=li1].fill(true);
            }
        }
        stale
    }
}

/// What a tile must make again, least first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Stale {
    /// Nothing: its leaves' neighbourhoods are as they were.
    No,
    /// Its values, from the kept wet share (no leaf within [`REACH`] turned wet or dry).
    Values,
    /// Its wet share and its values.
    Share,
}

/// Makes the tile whose first leaf is (`i0`, `j0`) in `rows` and `share`, the map's rows of
/// its band and their wet shares (starting at row `j0`), as `how` says, from the carpet's
/// `surface` and `depth` on a grid of `dims`: the values of the leaves `marks` (the band's
/// rows of `stale_leaf`) holds, clearing the marks. Returns the leaves made.
fn make_tile(
    (rows, share, marks): (&mut [f32], &mut [f32], &mut [bool]),
    how: Stale,
    (nx, ny): (usize, usize),
    (i0, j0): (usize, usize),
    (surface, depth): (&[f32], &[f32]),
) -> usize {
    let (i1, j1) = ((i0 + TILE).min(nx), (j0 + TILE).min(ny));
    let w = i1 - i0;
    if how == Stale::Share {
        let made = window(&KERNEL, (nx, ny), (i0, i1), (j0, j1), |k| {
            wet_share(depth[k])
        });
        for (j, line) in made.chunks(w).enumerate() {
            share[j * nx + i0..j * nx + i1].copy_from_slice(line);
        }
    }
    let mut leaves = 0;
    for j in j0..j1 {
        for i in i0..i1 {
            let at = (j - j0) * nx + i;
            if !std::mem::take(&mut marks[at]) {
                continue;
            }
            leaves += 1;
            // The smoothed surface only where [`leaf_value`] reads it: under water all around.
            let level = if share[at] >= 1.0 {
                window_at(&LEVEL_KERNEL, (nx, ny), (i, j), |k| surface[k])
            } else {
                f32::NAN
            };
            let around = (share[at], level);
            rows[at] = leaf_value_bounded(j * nx + i, (nx, ny), around, (surface, depth));
        }
    }
    leaves
}

/// [`window`]'s value at the one leaf (`i`, `j`): the same terms in the same order, without
/// the passes' arrays.
fn window_at<const N: usize>(
    kernel: &[f32; N],
    (nx, ny): (usize, usize),
    (i, j): (usize, usize),
    value: impl Fn(usize) -> f32,
) -> f32 {
    let total: f32 = kernel.iter().sum();
    let (lo_x, weights_x, whole_x) = taps(kernel, i, nx);
    let (lo_y, weights_y, whole_y) = taps(kernel, j, ny);
    let norm = if whole_y {
        total
    } else {
        weights_y.iter().sum::<f32>()
    };
    let mut sum = 0.0f32;
    for (t, wt) in weights_y.iter().enumerate() {
        let row = (lo_y + t) * nx + lo_x;
        let (mut along_x, mut weight) = (0.0f32, 0.0f32);
        let x = if whole_x {
            for (u, wu) in kernel.iter().enumerate() {
                along_x += wu * value(row + u);
            }
            along_x / total
        } else {
            for (u, wu) in weights_x.iter().enumerate() {
                along_x += wu * value(row + u);
                weight += wu;
            }
            along_x / weight
        };
        sum += wt * x;
    }
    sum / norm
}

/// `kernel` convolved along x, then along y, over the field `value(k)` on a grid of `dims`,
/// at the leaves `i0..i1` × `j0..j1` (row-major): each value summed as
/// [`water_map`](super::shown::water_map)'s separable passes sum it, the same terms in the same
/// order, so it is the same to the bit.
fn window<const N: usize>(
    kernel: &[f32; N],
    (nx, ny): (usize, usize),
    (i0, i1): (usize, usize),
    (j0, j1): (usize, usize),
    value: impl Fn(usize) -> f32,
) -> Vec<f32> {
    let half = N / 2;
    let total: f32 = kernel.iter().sum();
    let w = i1 - i0;
    // The pass along x on the rows the pass along y reads.
    let (r0, r1) = (j0.saturating_sub(half), (j1 + half).min(ny));
    let mut x = Vec::with_capacity((r1 - r0) * w);
    for r in r0..r1 {
        for i in i0..i1 {
            let (lo, weights, whole) = taps(kernel, i, nx);
            let row = r * nx + lo;
            let (mut sum, mut weight) = (0.0f32, 0.0f32);
            if whole {
                // The whole kernel, a loop of known length.
                for (t, wt) in kernel.iter().enumerate() {
                    sum += wt * value(row + t);
                }
                x.push(sum / total);
            } else {
                for (t, wt) in weights.iter().enumerate() {
                    sum += wt * value(row + t);
                    weight += wt;
                }
                x.push(sum / weight);
            }
        }
    }
    let mut out = Vec::with_capacity((j1 - j0) * w);
    for j in j0..j1 {
        let (lo, weights, whole) = taps(kernel, j, ny);
        let norm = if whole {
            total
        } else {
            weights.iter().sum::<f32>()
        };
        let mut sum = vec![0.0f32; w];
        for (t, wt) in weights.iter().enumerate() {
            let row = &x[(lo + t - r0) * w..(lo + t - r0 + 1) * w];
            for (s, v) in sum.iter_mut().zip(row) {
                *s += wt * v;
            }
        }
        out.extend(sum.iter().map(|s| s / norm));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fluid::puddles::shown::water_map;
    use crate::rng::SplitMix64;

    fn grid(nx: usize, ny: usize, values: Vec<f32>) -> Field2 {
        Field2 {
            nx,
            ny,
            origin_m: glam::Vec2::new(-1.0, 2.0),
            cell_m: 0.02,
            values,
        }
    }

    /// A carpet of `nx` × `ny` leaves: ground with a few millimetres of relief, pools where it
    /// lies below a level, a scatter of single wet leaves (drops) on dry ground.
    fn carpet(nx: usize, ny: usize, rng: &mut SplitMix64) -> (Field2, Field2) {
        let (mut surface, mut depth) = (Vec::new(), Vec::new());
        for j in 0..ny {
            for i in 0..nx {
                let ground = 0.004 * ((i as f32 * 0.31).sin() + (j as f32 * 0.23).cos())
                    + 0.0005 * rng.next_f64() as f32;
                let d = if rng.next_f64() < 0.02 {
                    0.017 * rng.next_f64() as f32
                } else {
                    (0.002 - ground).max(0.0)
                };
                surface.push(ground + d);
                depth.push(d);
            }
        }
        (grid(nx, ny, surface), grid(nx, ny, depth))
    }

    fn same_bits(a: &Field2, b: &Field2) -> bool {
        (a.nx, a.ny, a.origin_m, a.cell_m) == (b.nx, b.ny, b.origin_m, b.cell_m)
            && a.values.len() == b.values.len()
            && a.values
                .iter()
                .zip(&b.values)
                .all(|(x, y)| x.to_bits() == y.to_bits())
    }

    /// Made whole (grids that are and are not multiples of a tile, narrower than the
    /// kernel), the map is the plain map to the bit; then, changing a few leaves at a time
    /// (at the grid's edges and corners too), each update is the plain map of the changed
    /// carpet and makes only the tiles near the changes again.
    #[test]
    fn a_kept_map_is_the_plain_map_bit_for_bit_frame_after_frame() {
        let mut rng = SplitMix64(7);
        for (nx, ny) in [(3, 2), (16, 16), (37, 21), (64, 50)] {
            let (mut surface, mut depth) = carpet(nx, ny, &mut rng);
            let mut kept = KeptWaterMap::new();
            assert!(same_bits(
                kept.update(&surface, &depth),
                &water_map(&surface, &depth)
            ));
            let tiles = nx.div_ceil(TILE) * ny.div_ceil(TILE);
            assert_eq!(kept.tiles_made(), (tiles, tiles));
            for frame in 0..12 {
                let changes = if frame == 3 { 0 } else { 1 + frame % 4 };
                for c in 0..changes {
                    let k = match (frame + c) % 5 {
                        0 => 0,
                        1 => nx * ny - 1,
                        _ => (rng.next_u64() % (nx * ny) as u64) as usize,
                    };
                    let ground = surface.values[k] - depth.values[k];
                    let d = if depth.values[k] > 0.0 && rng.next_f64() < 0.5 {
                        0.0
                    } else {
                        0.02 * rng.next_f64() as f32
                    };
                    (surface.values[k], depth.values[k]) = (ground + d, d);
                }
                let fresh = water_map(&surface, &depth);
                assert!(
                    same_bits(kept.update(&surface, &depth), &fresh),
                    "{nx}×{ny}, frame {frame}"
                );
                let (made, all) = kept.tiles_made();
                assert_eq!(all, tiles);
                // Each changed leaf makes at most the 2 × 2 tiles its reach can span, and at
                // most the 9 × 9 leaves of its reach.
                assert!(made <= 4 * changes, "{made} tiles for {changes} leaves");
                assert_eq!(made == 0, changes == 0);
                let leaves = kept.leaves_made();
                assert!(
                    leaves <= 81 * changes,
                    "{leaves} leaves for {changes} changes"
                );
                assert_eq!(leaves == 0, changes == 0);
            }
        }
    }

    /// A map kept from the leaves a carpet lists as visited is the plain map of the carpet
    /// bit for bit, frame after frame: water moving and resting, trails falling, the
    /// resting water changed, a full update, the carpet cloned (the clone lists nothing: every
    /// leaf compared), and a second map reading the same carpet in turn (each list is
    /// complete only for the map that took the one before it).
    #[test]
    fn a_map_kept_from_the_carpets_visited_leaves_is_the_plain_map() {
        use crate::fluid::carpet::{Carpet, CarpetSettings};
        use crate::fluid::terrain::HeightField;
        use glam::{Vec2, Vec3};
        let (nx, ny, cell) = (45, 33, 0.01);
        let terrain = HeightField::from_fn(nx + 1, ny + 1, Vec2::ZERO, cell, |x, y| {
            0.004 * ((x * 31.0).sin() + (y * 23.0).cos())
        })
        .expect("terrain");
        let settings = CarpetSettings {
            nx,
            ny,
            origin_m: Vec2::ZERO,
            cell_m: cell,
            particle_radius_m: 0.006,
            trail_acceleration_mps2: 9.81,
            drying_time_s: 10.0,
            wetting_per_hit: 0.25,
        };
        let mut carpet = Carpet::new(settings, &terrain).expect("carpet");
        let mut rng = SplitMix64(17);
        let mut at = |w: f64| {
            let x = (rng.next_f64() * w) as f32;
            let y = (rng.next_f64() * ny as f64 * cell as f64) as f32;
            Vec3::new(x, y, 0.002 + 0.004 * rng.next_f64() as f32)
        };
        let mut resting: Vec<Vec3> = (0..40).map(|_| at(0.2)).collect();
        let mut moving: Vec<Vec3> = (0..25).map(|_| at(0.45)).collect();
        let (mut first, mut second) = (KeptWaterMap::new(), KeptWaterMap::new());
        let mut version = 0;
        let mut listed = 0;
        for frame in 0..40 {
            for p in &mut moving {
                p.x = (p.x + 0.007).rem_euclid(0.45);
                p.z *= 0.97;
            }
            if frame % 9 == 4 {
                resting.truncate(resting.len() - 5);
                version += 1;
            }
            if frame == 23 {
                carpet.update(&[resting.clone(), moving.clone()].concat(), 1.0 / 30.0);
            } else {
                carpet.update_split(&resting, version, &moving, 1.0 / 30.0);
            }
            if frame == 15 {
                carpet = carpet.clone();
            }
            let plain = water_map(&carpet.surface_height(), &carpet.water_depth());
            let kept = if frame >= 30 && frame % 2 == 1 {
                &mut second
            } else {
                &mut first
            };
            let visited = carpet.take_visited(kept.take_spare_list());
            listed += visited.leaves.as_ref().map_or(0, |l| l.len());
            let map = kept.update_visited(&carpet.leaf_grid(), visited, |k| {
                carpet.leaf_surface_and_depth(k)
            });
            assert!(same_bits(map, &plain), "frame {frame}");
        }
        // The lists were used, and shorter than the leaves.
        assert!(listed > 0 && listed < 40 * nx * ny / 2, "{listed}");
    }

    /// A carpet on another grid is made whole again.
    #[test]
    fn another_grid_is_made_whole() {
        let mut rng = SplitMix64(3);
        let mut kept = KeptWaterMap::new();
        let (s, d) = carpet(40, 30, &mut rng);
        kept.update(&s, &d);
        let (s, mut d) = carpet(30, 40, &mut rng);
        assert!(same_bits(kept.update(&s, &d), &water_map(&s, &d)));
        let mut s = s;
        s.origin_m.x += 0.5;
        d.origin_m.x += 0.5;
        assert!(same_bits(kept.update(&s, &d), &water_map(&s, &d)));
        let tiles = 30usize.div_ceil(TILE) * 40usize.div_ceil(TILE);
        assert_eq!(kept.tiles_made(), (tiles, tiles));
    }

    /// The cost of a frame's map, made whole and kept, on a street-sized carpet (1002 × 765
    /// leaves, pools and scattered drops) with 200 particles a frame changing 3 × 3 leaves each:
    /// `cargo test --release --lib kept_map::tests::report -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn report() {
        let mut rng = SplitMix64(11);
        let (nx, ny) = (1002, 765);
        let (mut surface, mut depth) = carpet(nx, ny, &mut rng);
        let mut kept = KeptWaterMap::new();
        kept.update(&surface, &depth);
        let (mut whole_s, mut kept_s) = (0.0, 0.0);
        for _ in 0..10 {
            for _ in 0..200 {
                let c = (rng.next_u64() % ((nx - 2) * (ny - 2)) as u64) as usize;
                let d = 0.02 * rng.next_f64() as f32;
                for k in (0..9).map(|m| (c / (nx - 2) + m / 3) * nx + c % (nx - 2) + m % 3) {
                    let ground = surface.values[k] - depth.values[k];
                    (surface.values[k], depth.values[k]) = (ground + d, d);
                }
            }
            let t = std::time::Instant::now();
            let fresh = water_map(&surface, &depth);
            whole_s += t.elapsed().as_secs_f64();
            let t = std::time::Instant::now();
            assert!(same_bits(kept.update(&surface, &depth), &fresh));
            kept_s += t.elapsed().as_secs_f64();
        }
        println!(
            "water map, ms a frame: made whole {:.1}, kept {:.1} ({} of {} tiles made)",
            whole_s * 100.0,
            kept_s * 100.0,
            kept.tiles_made().0,
            kept.tiles_made().1
        );
    }
}
