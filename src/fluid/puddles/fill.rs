//! Water at rest on a relief: priority-flood depression filling (Barnes, Lehman & Mulla 2014)
//! with a given volume of rain, conserved.
//!
//! How it works, on the height field's vertices (each the centre of a cell of one spacing
//! squared):
//! 1. **Priority-Flood** (Barnes et al. 2014, Algorithm 2, 8-neighbour). The edge vertices
//!    seed a priority queue at their own height; the lowest is taken, and each neighbour not
//!    yet reached gets the filled height F = max(H, F of the one that reached it), which is
//!    also its *receiver*. F is the surface with every depression filled to its spill level;
//!    every vertex reaches the edge through its receivers without climbing (H of a receiver ≤
//!    F of its giver).
//! 2. **Depressions**: the 8-connected sets of vertices with F > H. A set is flat in F (its
//!    spill level) and holds C = Σ (F − H)·A when full.
//! 3. **Routing the rain**: every vertex starts with the rain that fell on it. In the reverse
//!    order of the flood (givers before receivers) each vertex hands its water to its
//!    receiver; water reaching a depression stays there. A depression's first flooded vertex
//!    comes last among its own, so when it is reached the depression has all its inflow: it
//!    keeps up to C and hands the rest over its spill point. Water handed off the edge is run
//!    off.
//! 4. **Levels**: a depression that got V < C fills to the level L with Σ max(0, L − H)·A = V,
//!    found exactly from its sorted heights. Nested basins of one depression share one level
//!    (as if joined below the spill level): an approximation that changes where the water sits
//!    inside a depression, never how much.
//!
//! Volume is conserved by construction: held + run off = rain, to rounding.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};

use crate::fluid::terrain::HeightField;

/// Water filled into a relief.
#[derive(Debug, Clone, PartialEq)]
pub struct FilledWater {
    /// Water depth at each vertex, m (row-major, as the height field).
    pub depth_m: Vec<f32>,
    /// Water held in depressions, m³ (Σ depth × cell area).
    pub held_m3: f64,
    /// Water that ran off the edges, m³.
    pub run_off_m3: f64,
    /// What all depressions hold when full, m³.
    pub capacity_m3: f64,
    /// Number of depressions.
    pub depressions: usize,
}

#[derive(Clone, Copy, PartialEq)]
struct Queued {
    level_m: f32,
    order: u32,
    vertex: u32,
}

impl Eq for Queued {}

impl Ord for Queued {
    // A min-queue on the level, first-come first-served on ties (deterministic).
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .level_m
            .total_cmp(&self.level_m)
            .then(other.order.cmp(&self.order))
    }
}

impl PartialOrd for Queued {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// A heap entry of the flood: the level and the order as one integer key (ties on the level
/// go first-come first-served, as [`Queued`]'s), compared in one instruction instead of a
/// float's total order and then the order's.
#[derive(Clone, Copy, PartialEq, Eq)]
struct Keyed {
    key: u64,
    vertex: u32,
}

impl Keyed {
    fn of(q: Queued) -> Keyed {
        Keyed {
            key: (level_key(q.level_m) as u64) << 32 | q.order as u64,
            vertex: q.vertex,
        }
    }
}

impl Ord for Keyed {
    // A min-queue on the key.
    fn cmp(&self, other: &Self) -> Ordering {
        other.key.cmp(&self.key)
    }
}

impl PartialOrd for Keyed {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// An f32's place in `f32::total_cmp`'s order as an unsigned integer: a negative's bits
/// inverted (larger magnitudes come first), a positive's with the sign bit set (after every
/// negative), so −0 < +0 as there.
fn level_key(level_m: f32) -> u32 {
    let bits = level_m.to_bits();
    if bits >> 31 == 1 {
        !bits
    } else {
        bits | 0x8000_0000
    }
}

const NONE: u32 = u32::MAX;

/// Visits the eight neighbours of vertex `c` in [`neighbours`]' order; inside the grid without
/// its bounds tests (the flood's and the depressions' inner loop).
#[inline(always)]
fn for_each_neighbour(c: usize, nx: usize, ny: usize, mut visit: impl FnMut(usize)) {
    let (i, j) = (c % nx, c / nx);
    if i > 0 && j > 0 && i + 1 < nx && j + 1 < ny {
        for nb in [
            c - nx - 1,
            c - nx,
            c - nx + 1,
            c - 1,
            c + 1,
            c + nx - 1,
            c + nx,
            c + nx + 1,
        ] {
            visit(nb);
        }
    } else {
        neighbours(c, nx, ny).for_each(visit);
    }
}

/// The eight neighbours of vertex `v` on an `nx × ny` grid.
fn neighbours(v: usize, nx: usize, ny: usize) -> impl Iterator<Item = usize> {
    let (i, j) = ((v % nx) as i64, (v / nx) as i64);
    [
        (-1, -1),
        (0, -1),
        (1, -1),
        (-1, 0),
        (1, 0),
        (-1, 1),
        (0, 1),
        (1, 1),
    ]
    .into_iter()
    .map(move |(di, dj)| (i + di, j + dj))
    .filter(move |&(a, b)| a >= 0 && b >= 0 && a < nx as i64 && b < ny as i64)
    .map(move |(a, b)| b as usize * nx + a as usize)
}

/// A Priority-Flood under way: the heights, per vertex its filled height, receiver and
/// whether it was reached (arrays of their own: the first two are the flood's result as they
/// stand, and `reached`, read for every neighbour, takes a byte), the order so far and how
/// many entered a queue (each entry's order).
struct Flood<'a> {
    nx: usize,
    ny: usize,
    h: &'a [f32],
    filled: Vec<f32>,
    receiver: Vec<u32>,
    reached: Vec<bool>,
    order: Vec<u32>,
    pushed: u32,
}

impl<'a> Flood<'a> {
    /// The flood of the heights `h` (`nx × ny`, row-major), its edge vertices reached and
    /// handed to `enqueue` at their own height.
    fn new(h: &'a [f32], nx: usize, ny: usize, mut enqueue: impl FnMut(Queued)) -> Flood<'a> {
        let n = nx * ny;
        let mut flood = Flood {
            nx,
            ny,
            h,
            filled: h.to_vec(),
            receiver: vec![NONE; n],
            reached: vec![false; n],
            order: Vec::with_capacity(n),
            pushed: 0,
        };
        for (v, &z) in h.iter().enumerate() {
            let (i, j) = (v % nx, v / nx);
            if i == 0 || j == 0 || i == nx - 1 || j == ny - 1 {
                flood.reached[v] = true;
                enqueue(flood.entry(v, z));
            }
        }
        flood
    }

    /// The next queue entry: `vertex` at `level_m`.
    fn entry(&mut self, vertex: usize, level_m: f32) -> Queued {
        let q = Queued {
            level_m,
            order: self.pushed,
            vertex: vertex as u32,
        };
        self.pushed += 1;
        q
    }

    /// Takes `vertex` (next in the flood's order): each neighbour not yet reached gets the
    /// filled height max(H, F of `vertex`), `vertex` as its receiver, and enters a queue
    /// through `enqueue`, in the neighbours' order.
    fn take(&mut self, vertex: u32, mut enqueue: impl FnMut(Queued)) {
        let c = vertex as usize;
        self.order.push(vertex);
        let from = self.filled[c];
        let mut visit = |flood: &mut Flood, nb: usize| {
            if !flood.reached[nb] {
                flood.reached[nb] = true;
                let level = flood.h[nb].max(from);
                flood.filled[nb] = level;
                flood.receiver[nb] = vertex;
                let q = flood.entry(nb, level);
                enqueue(q);
            }
        };
        let (nx, ny) = (self.nx, self.ny);
        for_each_neighbour(c, nx, ny, |nb| visit(self, nb));
    }

    /// The filled heights, each vertex's receiver (`NONE` on the edge) and the order the
    /// vertices were taken.
    fn finish(self) -> (Vec<f32>, Vec<u32>, Vec<u32>) {
        (self.filled, self.receiver, self.order)
    }
}

/// Priority-Flood of the heights `h` (`nx × ny`, row-major) from the edges: the filled
/// heights, each vertex's receiver (`NONE` on the edge) and the order the vertices were taken.
fn priority_flood(h: &[f32], nx: usize, ny: usize) -> (Vec<f32>, Vec<u32>, Vec<u32>) {
    let mut queue = BinaryHeap::new();
    let mut flood = Flood::new(h, nx, ny, |q| queue.push(Keyed::of(q)));
    // A vertex flooded at the level being taken (the bulk of a depression) would enter the
    // heap behind every entry of that level and leave it before any higher one: it waits in
    // a first-in first-out queue instead (Barnes et al.'s pit queue), taken whenever its key
    // is the smaller, so the order is the heap's alone, without its cost (the pit's entries
    // share one level and come in order, so its front is its least).
    let mut pit: VecDeque<Keyed> = VecDeque::new();
    let mut pit_level = 0u32;
    loop {
        let from_pit = match (pit.front(), queue.peek()) {
            (Some(p), Some(top)) => p.key < top.key,
            (Some(_), None) => true,
            (None, _) => false,
        };
        let taken = if from_pit {
            pit.pop_front()
        } else {
            queue.pop()
        };
        let Some(Keyed { key, vertex }) = taken else {
            break;
        };
        let level = (key >> 32) as u32;
        flood.take(vertex, |q| {
            // All in the pit share one level (bit for bit: −0 and +0 differ in the order).
            let q = Keyed::of(q);
            if (q.key >> 32) as u32 == level && (pit.is_empty() || pit_level == level) {
                pit_level = level;
                pit.push_back(q);
            } else {
                queue.push(q);
            }
        });
    }
    flood.finish()
}

/// [`priority_flood`] with a heap of [`Queued`] alone: the plain reference the keys and the
/// pit queue are tested against.
#[cfg(test)]
fn priority_flood_reference(h: &[f32], nx: usize, ny: usize) -> (Vec<f32>, Vec<u32>, Vec<u32>) {
    let mut queue = BinaryHeap::new();
    let mut flood = Flood::new(h, nx, ny, |q| queue.push(q));
    while let Some(Queued { vertex, .. }) = queue.pop() {
        flood.take(vertex, |q| queue.push(q));
    }
    flood.finish()
}

/// The depressions of a flood: the 8-connected sets of flooded vertices (F > H), labelled in
/// flood order (so each one's first vertex is its first flooded one), their vertices listed
/// in vertex order, one array for all.
#[derive(Debug, PartialEq)]
struct Depressions {
    /// Each vertex's depression (`NONE` where not flooded).
    label: Vec<u32>,
    /// Each depression's first flooded vertex.
    first: Vec<usize>,
    /// Depression d's vertices are `members[start[d]..start[d + 1]]`.
    start: Vec<u32>,
    members: Vec<u32>,
}

impl Depressions {
    /// The depressions of the flood of `h` (`filled`, taken in `order`), each set found by a
    /// search from its first flooded vertex.
    fn of(h: &[f32], filled: &[f32], order: &[u32], (nx, ny): (usize, usize)) -> Depressions {
        let flooded: Vec<bool> = filled.iter().zip(h).map(|(f, z)| f > z).collect();
        let mut label = vec![NONE; h.len()];
        let mut first = Vec::new();
        let mut stack = Vec::new();
        for &v in order {
            let v = v as usize;
            if !flooded[v] || label[v] != NONE {
                continue;
            }
            let id = first.len() as u32;
            first.push(v);
            label[v] = id;
            stack.push(v);
            while let Some(c) = stack.pop() {
                let visit = |nb: usize| {
                    if flooded[nb] && label[nb] == NONE {
                        label[nb] = id;
                        stack.push(nb);
                    }
                };
                for_each_neighbour(c, nx, ny, visit);
            }
        }
        // Counted, then placed: each depression's vertices in vertex order.
        let mut start = vec![0u32; first.len() + 1];
        for &d in label.iter().filter(|&&d| d != NONE) {
            start[d as usize + 1] += 1;
        }
        for d in 0..first.len() {
            start[d + 1] += start[d];
        }
        let mut next = start.clone();
        let mut members = vec![0u32; start[first.len()] as usize];
        for (v, &d) in label.iter().enumerate().filter(|&(_, &d)| d != NONE) {
            members[next[d as usize] as usize] = v as u32;
            next[d as usize] += 1;
        }
        Depressions {
            label,
            first,
            start,
            members,
        }
    }

    /// [`Depressions::of`] in its plain form, the reference it is tested against: the
    /// neighbours by [`neighbours`], one list per depression.
    #[cfg(test)]
    fn plain(h: &[f32], filled: &[f32], order: &[u32], (nx, ny): (usize, usize)) -> Depressions {
        let flooded = |v: usize| filled[v] > h[v];
        let mut label = vec![NONE; h.len()];
        let mut first = Vec::new();
        let mut stack = Vec::new();
        for &v in order {
            let v = v as usize;
            if !flooded(v) || label[v] != NONE {
                continue;
            }
            let id = first.len() as u32;
            first.push(v);
            label[v] = id;
            stack.push(v);
            while let Some(c) = stack.pop() {
                for nb in neighbours(c, nx, ny) {
                    if flooded(nb) && label[nb] == NONE {
                        label[nb] = id;
                        stack.push(nb);
                    }
                }
            }
        }
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); first.len()];
        for (v, &d) in label.iter().enumerate() {
            if d != NONE {
                lists[d as usize].push(v as u32);
            }
        }
        let mut start = vec![0u32];
        for m in &lists {
            start.push(start.last().copied().unwrap_or(0) + m.len() as u32);
        }
        Depressions {
            label,
            first,
            start,
            members: lists.concat(),
        }
    }

    fn count(&self) -> usize {
        self.first.len()
    }

    /// Depression `d`'s vertices, in vertex order.
    fn members(&self, d: usize) -> &[u32] {
        &self.members[self.start[d] as usize..self.start[d + 1] as usize]
    }
}

/// The heights' flood: filled heights, receivers and the order taken.
type FloodOf = fn(&[f32], usize, usize) -> (Vec<f32>, Vec<u32>, Vec<u32>);
/// A flood's depressions.
type DepressionsOf = fn(&[f32], &[f32], &[u32], (usize, usize)) -> Depressions;

/// Fills `terrain` with `rain_m` of water over each vertex's cell (a uniform depth, m; the
/// water each cell received and did not lose otherwise).
pub fn fill_depressions(terrain: &HeightField, rain_m: f64) -> FilledWater {
    fill_with(terrain, rain_m, priority_flood, Depressions::of)
}

/// [`fill_depressions`] by the given flood and depressions (the fast ones, or the plain ones
/// they are tested against).
fn fill_with(
    terrain: &HeightField,
    rain_m: f64,
    flood: FloodOf,
    depressions: DepressionsOf,
) -> FilledWater {
    let (nx, ny) = (terrain.nx(), terrain.ny());
    let h = terrain.heights_m();
    let n = nx * ny;
    let area_m2 = (terrain.spacing_m() as f64).powi(2);

    // 1. Priority-Flood.
    let (filled, receiver, order) = flood(h, nx, ny);

    // 2. Depressions.
    let sets = depressions(h, &filled, &order, (nx, ny));
    let (label, first) = (&sets.label, &sets.first);
    let capacity: Vec<f64> = (0..sets.count())
        .map(|d| {
            sets.members(d)
                .iter()
                .map(|&v| (filled[v as usize] as f64 - h[v as usize] as f64) * area_m2)
                .sum()
        })
        .collect();

    // 3. Routing, givers before receivers.
    let mut water = vec![rain_m * area_m2; n];
    let mut pool = vec![0.0f64; sets.count()];
    let mut run_off_m3 = 0.0;
    for &v in order.iter().rev() {
        let v = v as usize;
        let mut out = water[v];
        if label[v] != NONE {
            let d = label[v] as usize;
            pool[d] += out;
            out = 0.0;
            if first[d] == v {
                out = (pool[d] - capacity[d]).max(0.0);
                pool[d] -= out;
            }
        }
        match receiver[v] {
            NONE => run_off_m3 += out,
            r => water[r as usize] += out,
        }
    }

    // 4. Levels.
    let mut depth_m = vec![0.0f32; n];
    let mut held_m3 = 0.0;
    let mut heights = Vec::new();
    for d in 0..sets.count() {
        let m = sets.members(d);
        let level = if pool[d] >= capacity[d] {
            filled[m[0] as usize] as f64
        } else {
            heights.clear();
            heights.extend(m.iter().map(|&v| h[v as usize] as f64));
            level_holding(&mut heights, pool[d] / area_m2)
        };
        for &v in m {
            let z = (level - h[v as usize] as f64).max(0.0);
            depth_m[v as usize] = z as f32;
            held_m3 += z * area_m2;
        }
    }
    FilledWater {
        depth_m,
        held_m3,
        run_off_m3,
        capacity_m3: capacity.iter().sum(),
        depressions: sets.count(),
    }
}

/// The level L with Σ max(0, L − hᵢ) = `volume` (in height × cells): between consecutive
/// sorted heights the sum is linear in L, so walk up to the bracket and solve it. (Sorted
/// unstably: equal in `total_cmp` is equal to the bit, so the order is the stable sort's.)
fn level_holding(heights: &mut [f64], volume: f64) -> f64 {
    heights.sort_unstable_by(f64::total_cmp);
    let mut below = 0.0; // Σ of the k lowest heights
    for k in 1..=heights.len() {
        below += heights[k - 1];
        let level = (volume + below) / k as f64;
        if k == heights.len() || level <= heights[k] {
            return level;
        }
    }
    heights.first().copied().unwrap_or(0.0)
}

#[cfg(test)]
mod fast_flood_tests {
    use super::*;
    use glam::Vec2;

    /// A rough relief with many pits, flat runs (equal heights), both zeros (−0 and +0 are
    /// apart in the order), heights below zero, a plateau in a corner and pits on the edge.
    fn rough(nx: usize, ny: usize) -> Vec<f32> {
        let mut state = 0x1234_5678_9abc_def0u64;
        (0..nx * ny)
            .map(|v| {
                state = crate::rng::splitmix64(state);
                let (x, y) = ((v % nx) as f32, (v / nx) as f32);
                let noise = (state >> 40) as f32 / (1u64 << 24) as f32;
                // Quantised to 1 mm, so many neighbours share a height.
                let z = 0.01 * (0.3 * x).sin() * (0.2 * y).cos() + 0.004 * noise;
                if x < 20.0 && y < 15.0 {
                    0.02
                } else {
                    (z * 1000.0).round() / 1000.0
                }
            })
            .collect()
    }

    /// The keyed heap and the pit queue take the vertices in the plain heap's order: the
    /// same filled heights, receivers and order.
    #[test]
    fn the_keyed_pit_queue_floods_as_the_plain_heap() {
        let (nx, ny) = (97, 61);
        let h = rough(nx, ny);
        let fast = priority_flood(&h, nx, ny);
        let plain = priority_flood_reference(&h, nx, ny);
        let pits = (0..nx * ny).filter(|&v| fast.0[v] > h[v]).count();
        assert!(pits > 500, "{pits} flooded vertices");
        assert!(h.iter().any(|z| z.to_bits() == (-0.0f32).to_bits()));
        assert!(
            fast.0
                .iter()
                .zip(&plain.0)
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
        assert_eq!(fast.1, plain.1);
        assert_eq!(fast.2, plain.2);
    }

    /// The key orders levels as `f32::total_cmp`: random bit patterns (NaNs, infinities and
    /// subnormals among them) and the values at the sign's seam, every pair.
    #[test]
    fn the_level_key_orders_as_total_cmp() {
        let mut state = 7u64;
        let mut levels: Vec<f32> = (0..400)
            .map(|_| {
                state = crate::rng::splitmix64(state);
                f32::from_bits(state as u32)
            })
            .collect();
        levels.extend([
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::from_bits(0x8000_0001),
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
            1.0,
            -1.0,
        ]);
        for a in &levels {
            for b in &levels {
                assert_eq!(
                    level_key(*a).cmp(&level_key(*b)),
                    a.total_cmp(b),
                    "{a:e} ({:#x}) vs {b:e} ({:#x})",
                    a.to_bits(),
                    b.to_bits()
                );
            }
        }
    }

    /// The depressions found with the inside's neighbours unrolled and listed in one array
    /// are the plain ones.
    #[test]
    fn the_depressions_are_the_plain_ones() {
        let (nx, ny) = (97, 61);
        let h = rough(nx, ny);
        let (filled, _, order) = priority_flood_reference(&h, nx, ny);
        let fast = Depressions::of(&h, &filled, &order, (nx, ny));
        let plain = Depressions::plain(&h, &filled, &order, (nx, ny));
        assert!(fast.count() > 50, "{} depressions", fast.count());
        // Some reach the edge's inner ring, where the neighbours are bounds-tested.
        assert!(
            fast.members
                .iter()
                .any(|&v| matches!(v as usize % nx, 1) || matches!(v as usize / nx, 1))
        );
        assert_eq!(fast, plain);
    }

    /// The whole fill by the fast flood and depressions is the fill by the plain ones, to
    /// the bit, where the rain fills some depressions partly and where it floods them all.
    #[test]
    fn the_fill_is_the_plain_fill_to_the_bit() {
        let (nx, ny) = (97, 61);
        let t =
            HeightField::new(nx, ny, Vec2::new(-1.0, 2.0), 0.03, rough(nx, ny)).expect("relief");
        for rain_m in [0.0005, 0.002, 0.5] {
            let fast = fill_depressions(&t, rain_m);
            let plain = fill_with(&t, rain_m, priority_flood_reference, Depressions::plain);
            assert!(fast.held_m3 > 0.0);
            let bits = |f: &FilledWater| {
                let mut b: Vec<u64> = f.depth_m.iter().map(|d| d.to_bits() as u64).collect();
                b.extend([f.held_m3, f.run_off_m3, f.capacity_m3].map(f64::to_bits));
                b.push(f.depressions as u64);
                b
            };
            assert!(bits(&fast) == bits(&plain), "rain {rain_m} m");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    #[test]
    fn a_bowl_fills_to_the_level_of_its_volume_and_spills_the_rest() {
        // z = k r² on a square: the water of depth d over the whole grid gathers in the
        // middle; its level solves Σ max(0, L − z) A = V, checked by brute force on L.
        let k = 0.5f32;
        let t = HeightField::from_fn(41, 41, Vec2::splat(-1.0), 0.05, |x, y| k * (x * x + y * y))
            .expect("bowl");
        let area = (t.spacing_m() as f64).powi(2);
        let f = fill_depressions(&t, 0.001);
        let rain = 0.001 * area * 41.0 * 41.0;
        // The rain on the edge vertices leaves; everything else drains into the bowl.
        let edge = 0.001 * area * (4.0 * 40.0);
        assert!(
            (f.run_off_m3 - edge).abs() < 1e-12,
            "{} vs {edge}",
            f.run_off_m3
        );
        assert!((f.held_m3 + f.run_off_m3 - rain).abs() < 1e-9 * rain);
        let rain = rain - edge;
        let held = |level: f64| -> f64 {
            t.heights_m()
                .iter()
                .map(|&z| (level - z as f64).max(0.0) * area)
                .sum()
        };
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if held(mid) < rain { lo = mid } else { hi = mid }
        }
        let centre = 20 * 41 + 20;
        assert!(
            (f.depth_m[centre] as f64 - lo).abs() < 1e-6,
            "{} vs {lo}",
            f.depth_m[centre]
        );
        // A flood: the bowl's rim (its lowest edge vertex, k·1²) caps the level.
        let f = fill_depressions(&t, 1.0);
        assert!((f.depth_m[centre] as f64 - 0.5).abs() < 1e-6);
        assert!((f.held_m3 - f.capacity_m3).abs() < 1e-9);
        assert!((f.held_m3 + f.run_off_m3 - area * 41.0 * 41.0).abs() < 1e-9);
    }

    #[test]
    fn a_plane_holds_nothing_and_overflow_reaches_the_next_basin_down() {
        let plane = HeightField::from_fn(20, 5, Vec2::ZERO, 0.1, |x, _| 0.1 * x).expect("plane");
        let f = fill_depressions(&plane, 0.01);
        assert_eq!(f.held_m3, 0.0);
        // Two pits on a slope, the upper one small: its overflow runs down into the lower.
        let pits = HeightField::from_fn(30, 7, Vec2::ZERO, 0.1, |x, y| {
            let pit = |cx: f32, depth: f32| {
                let r2 = (x - cx).powi(2) + (y - 0.3).powi(2);
                -depth * (-r2 / 0.01).exp()
            };
            0.02 * x + pit(2.2, 0.01) + pit(0.8, 0.05)
        })
        .expect("pits");
        let f = fill_depressions(&pits, 0.002);
        let upper = 3 * 30 + 22;
        let lower = 3 * 30 + 8;
        assert!(f.depth_m[upper] > 0.0 && f.depth_m[lower] > f.depth_m[upper]);
        let total = 0.002 * (pits.spacing_m() as f64).powi(2) * 30.0 * 7.0;
        assert!((f.held_m3 + f.run_off_m3 - total).abs() < 1e-9 * total);
    }
}
