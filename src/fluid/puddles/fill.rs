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

const NONE: u32 = u32::MAX;

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

/// A Priority-Flood under way: per vertex its height, filled height, receiver and whether it
/// was reached (one record, so taking a vertex reads one cache line per neighbour, not four),
/// the order so far and how many entered a queue (each entry's order).
struct Flood {
    nx: usize,
    ny: usize,
    vertices: Vec<FloodVertex>,
    order: Vec<u32>,
    pushed: u32,
}

/// A vertex in the flood.
#[derive(Clone, Copy)]
struct FloodVertex {
    h: f32,
    filled: f32,
    receiver: u32,
    reached: bool,
}

impl Flood {
    /// The flood of the heights `h` (`nx × ny`, row-major), its edge vertices reached and
    /// pushed to `queue` at their own height.
    fn new(h: &[f32], nx: usize, ny: usize, queue: &mut BinaryHeap<Queued>) -> Flood {
        let n = nx * ny;
        let mut flood = Flood {
            nx,
            ny,
            vertices: h
                .iter()
                .map(|&z| FloodVertex {
                    h: z,
                    filled: z,
                    receiver: NONE,
                    reached: false,
                })
                .collect(),
            order: Vec::with_capacity(n),
            pushed: 0,
        };
        for (v, &z) in h.iter().enumerate() {
            let (i, j) = (v % nx, v / nx);
            if i == 0 || j == 0 || i == nx - 1 || j == ny - 1 {
                flood.vertices[v].reached = true;
                queue.push(flood.entry(v, z));
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
        let from = self.vertices[c].filled;
        let mut visit = |flood: &mut Flood, nb: usize| {
            let n = &mut flood.vertices[nb];
            if !n.reached {
                n.reached = true;
                n.filled = n.h.max(from);
                n.receiver = vertex;
                let level = n.filled;
                let q = flood.entry(nb, level);
                enqueue(q);
            }
        };
        let (nx, i, j) = (self.nx, c % self.nx, c / self.nx);
        if i > 0 && j > 0 && i + 1 < nx && j + 1 < self.ny {
            // Inside: the eight in [`neighbours`]' order, without its bounds tests.
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
                visit(self, nb);
            }
        } else {
            for nb in neighbours(c, nx, self.ny) {
                visit(self, nb);
            }
        }
    }

    /// The filled heights, each vertex's receiver (`NONE` on the edge) and the order the
    /// vertices were taken.
    fn finish(self) -> (Vec<f32>, Vec<u32>, Vec<u32>) {
        let filled = self.vertices.iter().map(|v| v.filled).collect();
        let receiver = self.vertices.iter().map(|v| v.receiver).collect();
        (filled, receiver, self.order)
    }
}

/// Priority-Flood of the heights `h` (`nx × ny`, row-major) from the edges: the filled
/// heights, each vertex's receiver (`NONE` on the edge) and the order the vertices were taken.
fn priority_flood(h: &[f32], nx: usize, ny: usize) -> (Vec<f32>, Vec<u32>, Vec<u32>) {
    let mut queue = BinaryHeap::new();
    let mut flood = Flood::new(h, nx, ny, &mut queue);
    // A vertex flooded at the level being taken (the bulk of a depression) would enter the
    // heap behind every entry of that level and leave it before any higher one: it waits in
    // a first-in first-out queue instead (Barnes et al.'s pit queue), taken whenever its
    // (level, order) is the smaller, so the order is the heap's alone, without its cost
    // (the pit's entries share one level and come in order, so its front is its least).
    let mut pit: VecDeque<(u32, u32)> = VecDeque::new();
    let mut pit_level = 0.0f32;
    loop {
        let from_pit = match (pit.front(), queue.peek()) {
            (Some(&(o, _)), Some(top)) => pit_level
                .total_cmp(&top.level_m)
                .then(o.cmp(&top.order))
                .is_lt(),
            (Some(_), None) => true,
            (None, _) => false,
        };
        let (level, vertex) = if from_pit {
            let Some((_, v)) = pit.pop_front() else {
                break;
            };
            (pit_level, v)
        } else {
            match queue.pop() {
                Some(q) => (q.level_m, q.vertex),
                None => break,
            }
        };
        flood.take(vertex, |q| {
            // All in the pit share one level (bit for bit: −0 and +0 differ in the order).
            let same = |a: f32| a.total_cmp(&level).is_eq();
            if same(q.level_m) && (pit.is_empty() || same(pit_level)) {
                pit_level = level;
                pit.push_back((q.order, q.vertex));
            } else {
                queue.push(q);
            }
        });
    }
    flood.finish()
}

/// [`priority_flood`] with the heap alone: the plain reference the pit queue is tested
/// against.
#[cfg(test)]
fn priority_flood_reference(h: &[f32], nx: usize, ny: usize) -> (Vec<f32>, Vec<u32>, Vec<u32>) {
    let mut queue = BinaryHeap::new();
    let mut flood = Flood::new(h, nx, ny, &mut queue);
    while let Some(Queued { vertex, .. }) = queue.pop() {
        flood.take(vertex, |q| queue.push(q));
    }
    flood.finish()
}

/// Fills `terrain` with `rain_m` of water over each vertex's cell (a uniform depth, m; the
/// water each cell received and did not lose otherwise).
pub fn fill_depressions(terrain: &HeightField, rain_m: f64) -> FilledWater {
    let (nx, ny) = (terrain.nx(), terrain.ny());
    let h = terrain.heights_m();
    let n = nx * ny;
    let area_m2 = (terrain.spacing_m() as f64).powi(2);

    // 1. Priority-Flood.
    let (filled, receiver, order) = priority_flood(h, nx, ny);

    // 2. Depressions: 8-connected flooded sets, labelled in flood order (so each label's
    // first vertex is the depression's first flooded one).
    let flooded = |v: usize| filled[v] > h[v];
    let mut label = vec![NONE; n];
    let mut first = Vec::new();
    let mut stack = Vec::new();
    for &v in &order {
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
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); first.len()];
    for v in 0..n {
        if label[v] != NONE {
            members[label[v] as usize].push(v);
        }
    }
    let capacity: Vec<f64> = members
        .iter()
        .map(|m| {
            m.iter()
                .map(|&v| (filled[v] as f64 - h[v] as f64) * area_m2)
                .sum()
        })
        .collect();

    // 3. Routing, givers before receivers.
    let mut water = vec![rain_m * area_m2; n];
    let mut pool = vec![0.0f64; first.len()];
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
    for (d, m) in members.iter().enumerate() {
        let level = if pool[d] >= capacity[d] {
            filled[m[0]] as f64
        } else {
            level_holding(m.iter().map(|&v| h[v] as f64).collect(), pool[d] / area_m2)
        };
        for &v in m {
            let z = (level - h[v] as f64).max(0.0);
            depth_m[v] = z as f32;
            held_m3 += z * area_m2;
        }
    }
    FilledWater {
        depth_m,
        held_m3,
        run_off_m3,
        capacity_m3: capacity.iter().sum(),
        depressions: first.len(),
    }
}

/// The level L with Σ max(0, L − hᵢ) = `volume` (in height × cells): between consecutive
/// sorted heights the sum is linear in L, so walk up to the bracket and solve it.
fn level_holding(mut heights: Vec<f64>, volume: f64) -> f64 {
    heights.sort_by(f64::total_cmp);
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
mod pit_queue_tests {
    use super::*;

    /// The pit queue takes the vertices in the heap's order: the same filled heights,
    /// receivers and order as the heap alone, on a rough relief with many pits, flat runs
    /// (equal heights) and a plateau.
    #[test]
    fn the_pit_queue_floods_as_the_heap_alone() {
        let (nx, ny) = (97, 61);
        let mut state = 0x1234_5678_9abc_def0u64;
        let h: Vec<f32> = (0..nx * ny)
            .map(|v| {
                state = crate::rng::splitmix64(state);
                let (x, y) = ((v % nx) as f32, (v / nx) as f32);
                let noise = (state >> 40) as f32 / (1u64 << 24) as f32;
                // Quantised to 1 mm, so many neighbours share a height (both zeros among them: −0
                // and +0 are apart in the order); a plateau in a corner.
                let z = 0.01 * (0.3 * x).sin() * (0.2 * y).cos() + 0.004 * noise;
                if x < 20.0 && y < 15.0 {
                    0.02
                } else {
                    (z * 1000.0).round() / 1000.0
                }
            })
            .collect();
        let fast = priority_flood(&h, nx, ny);
        let plain = priority_flood_reference(&h, nx, ny);
        let pits = (0..nx * ny).filter(|&v| fast.0[v] > h[v]).count();
        assert!(pits > 500, "{pits} flooded vertices");
        assert!(
            fast.0
                .iter()
                .zip(&plain.0)
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
        assert_eq!(fast.1, plain.1);
        assert_eq!(fast.2, plain.2);
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
