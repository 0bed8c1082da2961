//! All the rain that lands on the ground, not only the drawn drops': the drawn volume's own
//! impacts where its columns stand on the ground, and a stateless impact stream elsewhere.
//!
//! The drawn volume reaches only to its far distance (a few metres at 720p), while the water
//! lies up to 20 m away. Beyond the drawn columns, [`GroundRain`] makes impacts on z = 0 as a
//! pure function of (seed, ground cell, time slot): in each square cell of side `cell_m` and
//! slot of `slot_s`, a Poisson number of impacts of mean Φ·cell²·slot, where
//!
//! Φ = ∫ N(D) v(D) dD
//!
//! is the number flux of drops through a horizontal plane (drops per m²·s; N the drop-size
//! distribution, v the terminal velocity): a horizontal wind moves drops along the plane and
//! leaves the flux through it unchanged. Each impact has a uniform point in its cell, a
//! uniform time in its slot and a diameter from the flux-weighted distribution N(D) v(D)/Φ
//! (large drops land more often than they are seen in the air). With a keyed rate, Φ and the
//! sizes are the peak's and each impact lands with the probability
//! [`RainModel::keeps`] of the rate at its time, which thins the peak's flux to exactly the
//! Marshall–Palmer flux of that rate, sizes included.
//!
//! The drawn volume's landing columns cover whole cells of its (u, v) grid at z = 0 (a drop is
//! wrapped inside its prism, so it lands uniformly over the column's cell): there its own
//! impacts are used, so a drawn drop's splash and its ring coincide, and the stream leaves them
//! out — but for the sizes the column does not simulate: a column simulates only diameters
//! from its cut D_c up (those whose streak or splash can show, [`super::visible`]), so in its
//! cell the stream keeps its impacts of D < D_c, and drops those of D ≥ D_c. The drawn drops
//! land N(D) v(D) for D ≥ D_c (the truncated sampling keeps the count of every size above the
//! cut), the stream the rest, so the water's mass balance is the full flux's. Where the drop
//! budget thinned the drawn drops (weight w > 1), the stream adds the missing 1 − 1/w of the
//! flux of D ≥ D_c there. No area or size is counted twice, none is missed.
//!
//! Everything is stateless: any interval (t0, t1] gives the impacts whose times fall in it,
//! whatever the intervals asked before, so a preview's fast-forward and a render's frames feed
//! the water the same drops.

use std::collections::HashMap;

use glam::{DVec2, DVec3};

use super::drop::{SIZE_KEEP_ALL, pcg_hash};
use super::impacts::{Impact, impacts_between, landing_columns};
use super::visible::cut_mm;
use super::{RainVolume, Rainfall};
use crate::rain::physics::RainModel;
use crate::rain::wind::Wind;

/// Mean impacts per cell and slot at the peak rate: small enough for the Poisson count by
/// inversion, large enough that few cells are visited per impact.
const IMPACTS_PER_CELL_SLOT: f64 = 8.0;
/// Time slot of the stream, s.
const SLOT_S: f64 = 0.1;
/// Intervals of the flux-weighted diameter table.
const SIZE_INTERVALS: usize = 512;
/// Salt of the stream's hash, so its numbers are not the drops'.
const STREAM_SALT: u32 = 0x5EED_6A1D;
/// Stream impacts carry ids with this bit set (drawn drops' ids are below 2³²).
pub const STREAM_ID_BIT: u64 = 1 << 63;

/// A drop of the stream landing on the ground: an [`Impact`] before its size is looked up
/// ([`GroundRain::landing_diameter_mm`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landing {
    /// The impact's id (as [`Impact::id`]).
    pub id: u64,
    /// Its time slot (as [`Impact::pass`]).
    pub pass: u32,
    /// Time of impact, s.
    pub time_s: f64,
    /// Point of impact on z = 0, m.
    pub position_m: DVec2,
    /// Flux-weighted quantile of its diameter.
    size_q: f64,
}

/// The stream over a rectangle and a span of time slots.
struct Stream {
    rect: GroundRect,
    /// The share of a drawn cell's other sizes the stream supplies.
    supplement: f64,
    /// The counts of drops a cell has in a slot.
    counts: PoissonTable,
    /// Cells along x and y, slots.
    x: std::ops::Range<i64>,
    y: std::ops::Range<i64>,
    slots: std::ops::Range<i64>,
}

impl Stream {
    /// The cells, x outer, y inner: the stream's order.
    fn cells(&self) -> impl Iterator<Item = (i64, i64)> + '_ {
        self.x
            .clone()
            .flat_map(move |ix| self.y.clone().map(move |iy| (ix, iy)))
    }
}

/// The spare slots a [`StreamSlots`] keeps at most.
const SPARE_SLOTS: usize = 4;

/// The stream's landings of whole time slots over one rectangle, kept from one call of
/// [`GroundRain::stream_landings_kept`] to the next.
#[derive(Debug, Clone, Default)]
pub struct StreamSlots {
    rect: Option<GroundRect>,
    slots: Vec<SlotLandings>,
    /// Slots gone by, their lists kept to be filled again: a slot's hundreds of thousands of
    /// landings then land in memory already mapped and grown (no fresh pages each slot).
    spare: Vec<SlotLandings>,
}

/// One slot's landings, cell after cell (cell c's are `starts[c]..starts[c + 1]`), a field
/// to an array: a frame reads each landing's time, and the position of those in its window
/// only (most of a slot's landings fall in another frame), so it streams through a third of
/// the memory a whole landing would cost it.
#[derive(Debug, Clone)]
struct SlotLandings {
    slot: i64,
    /// Each landing's time, s: what a frame's window is matched against.
    times_s: Vec<f64>,
    positions_m: Vec<DVec2>,
    ids: Vec<u64>,
    size_qs: Vec<f64>,
    starts: Vec<u32>,
    /// The landings in the window of the last call, `times_s`' indices in order.
    picked: Vec<u32>,
}

impl SlotLandings {
    fn clear(&mut self) {
        self.times_s.clear();
        self.positions_m.clear();
        self.ids.clear();
        self.size_qs.clear();
        self.starts.clear();
    }

    fn push(&mut self, l: Landing) {
        self.times_s.push(l.time_s);
        self.positions_m.push(l.position_m);
        self.ids.push(l.id);
        self.size_qs.push(l.size_q);
    }

    /// Picks the landings with time in (t0_s, t1_s], in order, into `picked`: without a
    /// branch on each time (a slot's times are in no order, so a branch on them would be
    /// mispredicted at every other landing).
    fn pick(&mut self, t0_s: f64, t1_s: f64) {
        self.picked.clear();
        self.picked.resize(self.times_s.len(), 0);
        let picked = self.picked.as_mut_slice();
        let mut n = 0;
        for (i, &t) in self.times_s.iter().enumerate() {
            picked[n] = i as u32;
            n += (t > t0_s && t <= t1_s) as usize;
        }
        self.picked.truncate(n);
    }

    /// Landing `i`, as [`SlotLandings::push`] was handed it.
    fn landing(&self, i: usize) -> Landing {
        Landing {
            id: self.ids[i],
            pass: self.slot as u32,
            time_s: self.times_s[i],
            position_m: self.positions_m[i],
            size_q: self.size_qs[i],
        }
    }
}

/// An axis-aligned rectangle of the ground z = 0, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundRect {
    /// Corner with the smallest x and y, m.
    pub min_m: DVec2,
    /// Corner with the largest x and y, m.
    pub max_m: DVec2,
}

impl GroundRect {
    /// Whether `p` lies in [min, max) on both axes.
    pub fn contains(&self, p: DVec2) -> bool {
        p.cmpge(self.min_m).all() && p.cmplt(self.max_m).all()
    }

    /// Area, m².
    pub fn area_m2(&self) -> f64 {
        let s = (self.max_m - self.min_m).max(DVec2::ZERO);
        s.x * s.y
    }
}

/// The cells of the drawn volume's grid whose columns stand on the ground, with the smallest
/// diameter each simulates, mm.
#[derive(Debug, Clone, Default, PartialEq)]
struct DrawnCells {
    origin_m: DVec2,
    cell_m: DVec2,
    cells: HashMap<(i64, i64), f64>,
    /// The cells' index range, inclusive: most of the ground lies outside it, where no
    /// lookup is needed.
    lo: (i64, i64),
    hi: (i64, i64),
    /// `cells` over the index range, row by row (`None`: no cell there), where the range
    /// holds at most [`DENSE_CELLS`] cells; empty otherwise. The stream asks for every one
    /// of its hundreds of thousands of landings a slot, and a hashed lookup cost a fifth of
    /// making them.
    dense: Vec<Option<f64>>,
}

/// The most cells [`DrawnCells::dense`] spans (16 MiB).
const DENSE_CELLS: i64 = 1 << 20;

impl DrawnCells {
    /// The landing columns' cells, indexed from the first one's corner (the grid's cells are
    /// whole steps apart, so rounding recovers their indices).
    fn of(volume: &RainVolume, model: &RainModel) -> DrawnCells {
        let grid = &volume.grid;
        let landing: Vec<_> = landing_columns(volume).map(|i| &grid.columns[i]).collect();
        let Some(first) = landing.first() else {
            return DrawnCells::default();
        };
        let origin_m = first.cell_min_m;
        let cell_m = grid.cell_size_m.max(DVec2::splat(1e-9));
        let index = |c: DVec2| {
            let i = ((c - origin_m) / cell_m).round();
            (i.x as i64, i.y as i64)
        };
        let (d_min, _) = model.dsd.range_mm();
        let cells: HashMap<(i64, i64), f64> = landing
            .iter()
            .map(|c| {
                let cut = if c.size_keep_q >= SIZE_KEEP_ALL {
                    d_min
                } else {
                    cut_mm(model, c.size_keep_q)
                };
                (index(c.cell_min_m), cut)
            })
            .collect();
        DrawnCells::from_cells(origin_m, cell_m, cells)
    }

    /// The drawn cells `cells` (indices from `origin_m` in steps of `cell_m`, each with its
    /// cut), with their range and dense table.
    fn from_cells(origin_m: DVec2, cell_m: DVec2, cells: HashMap<(i64, i64), f64>) -> DrawnCells {
        let (mut lo, mut hi) = ((i64::MAX, i64::MAX), (i64::MIN, i64::MIN));
        for &(i, j) in cells.keys() {
            lo = (lo.0.min(i), lo.1.min(j));
            hi = (hi.0.max(i), hi.1.max(j));
        }
        let (w, h) = (hi.0 - lo.0 + 1, hi.1 - lo.1 + 1);
        let dense = if w.saturating_mul(h) <= DENSE_CELLS {
            let mut dense = vec![None; (w * h) as usize];
            for (&(i, j), &cut) in &cells {
                dense[((j - lo.1) * w + (i - lo.0)) as usize] = Some(cut);
            }
            dense
        } else {
            Vec::new()
        };
        DrawnCells {
            origin_m,
            cell_m,
            cells,
            lo,
            hi,
            dense,
        }
    }

    /// The smallest diameter the drawn drops bring at world point `p` on z = 0, mm: `None`
    /// outside the landing columns' cells.
    fn cut_at(&self, p: DVec2) -> Option<f64> {
        if self.cells.is_empty() {
            return None;
        }
        let i = ((p - self.origin_m) / self.cell_m).floor();
        let (i, j) = (i.x as i64, i.y as i64);
        if i < self.lo.0 || j < self.lo.1 || i > self.hi.0 || j > self.hi.1 {
            return None;
        }
        if !self.dense.is_empty() {
            let w = self.hi.0 - self.lo.0 + 1;
            return self.dense[((j - self.lo.1) * w + (i - self.lo.0)) as usize];
        }
        self.cells.get(&(i, j)).copied()
    }
}

/// The rain landing on the ground: the drawn volume's impacts and the stream elsewhere (see
/// the module docs). Owns what it needs, so a puddle simulation can keep one.
#[derive(Debug, Clone)]
pub struct GroundRain {
    volume: RainVolume,
    model: RainModel,
    wind: Wind,
    seed: u32,
    drawn: DrawnCells,
    /// Φ of the peak rain, drops per m²·s.
    flux_per_m2_s: f64,
    /// Side of the stream's cells, m.
    cell_m: f64,
    /// The flux-weighted diameter CDF at `SIZE_INTERVALS + 1` equally spaced diameters.
    size_cdf: Vec<f64>,
}

impl GroundRain {
    /// The rain of `rain`'s model (its peak, with its keys) landing on the ground, with its
    /// volume's drawn drops where its columns stand on the ground.
    pub fn new(rain: Rainfall) -> GroundRain {
        let Rainfall {
            volume,
            model,
            wind,
            seed,
        } = rain;
        let (d0, d1) = model.dsd.range_mm();
        let h = (d1 - d0) / SIZE_INTERVALS as f64;
        let flux_density =
            |d: f64| model.dsd.density_per_m3_mm(d) * model.fall.terminal_velocity_mps(d);
        // Cumulative Simpson per interval: the CDF at the table's diameters.
        let mut size_cdf = Vec::with_capacity(SIZE_INTERVALS + 1);
        let mut acc = 0.0;
        size_cdf.push(0.0);
        for i in 0..SIZE_INTERVALS {
            let a = d0 + i as f64 * h;
            acc +=
                h / 6.0 * (flux_density(a) + 4.0 * flux_density(a + 0.5 * h) + flux_density(a + h));
            size_cdf.push(acc);
        }
        let flux_per_m2_s = if !model.rate.is_off() && acc.is_finite() && acc > 0.0 {
            acc
        } else {
            0.0
        };
        if flux_per_m2_s > 0.0 {
            size_cdf.iter_mut().for_each(|c| *c /= flux_per_m2_s);
        }
        let cell_m = if flux_per_m2_s > 0.0 {
            (IMPACTS_PER_CELL_SLOT / (flux_per_m2_s * SLOT_S))
                .sqrt()
                .clamp(0.02, 4.0)
        } else {
            1.0
        };
        GroundRain {
            volume: volume.clone(),
            model: model.clone(),
            wind: wind.clone(),
            seed,
            drawn: DrawnCells::of(volume, model),
            flux_per_m2_s,
            cell_m,
            size_cdf,
        }
    }

    /// Φ of the peak rain, impacts per m²·s.
    pub fn flux_per_m2_s(&self) -> f64 {
        self.flux_per_m2_s
    }

    /// Impacts per m²·s at `t_s`: Φ thinned by the keyed rate (∫ N v keeps dD over the
    /// flux-weighted sizes), Φ itself without keys.
    pub fn flux_at(&self, t_s: f64) -> f64 {
        let Some(keys) = &self.model.rate_keys else {
            return self.flux_per_m2_s;
        };
        let rate = keys.at(t_s);
        let n = 256;
        let kept: f64 = (0..n)
            .map(|i| {
                self.model
                    .keeps(rate, self.diameter_mm((i as f64 + 0.5) / n as f64))
            })
            .sum();
        self.flux_per_m2_s * kept / n as f64
    }

    /// `n` diameters at equally spaced quantiles of the flux-weighted distribution (the sizes
    /// that land, equally likely), mm.
    pub fn impact_diameters_mm(&self, n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| self.diameter_mm((i as f64 + 0.5) / n as f64))
            .collect()
    }

    /// The largest diameter that lands, mm (the size distribution's truncation).
    pub fn max_diameter_mm(&self) -> f64 {
        self.model.dsd.range_mm().1
    }

    /// Whether the drawn volume's own drops land at `p` (world x, y on z = 0).
    pub fn drawn_at(&self, p: DVec2) -> bool {
        self.drawn.cut_at(p).is_some()
    }

    /// The smallest diameter the drawn drops bring at `p` (world x, y on z = 0), mm; the stream
    /// brings the smaller ones there. `None` where the drawn drops do not land.
    pub fn drawn_cut_mm(&self, p: DVec2) -> Option<f64> {
        self.drawn.cut_at(p)
    }

    /// The rain that falls, as the drawn drops see it.
    pub fn rainfall(&self) -> Rainfall<'_> {
        Rainfall::new(&self.volume, &self.model, &self.wind, self.seed)
    }

    /// Every impact in `rect` (and the drawn volume's anywhere) with time in (t0_s, t1_s]:
    /// the drawn drops' first ([`impacts_between`]), then the stream's.
    pub fn impacts_between(&self, rect: &GroundRect, t0_s: f64, t1_s: f64) -> Vec<Impact> {
        self.impacts_between_kept(rect, t0_s, t1_s, |_| true)
    }

    /// [`GroundRain::impacts_between`] into `out` (cleared first): a caller asking step after
    /// step reuses one buffer instead of faulting in a fresh one of megabytes each time.
    pub fn impacts_between_into(
        &self,
        rect: &GroundRect,
        t0_s: f64,
        t1_s: f64,
        out: &mut Vec<Impact>,
    ) {
        out.clear();
        out.extend(impacts_between(self.rainfall(), t0_s, t1_s));
        self.stream_between(rect, t0_s, t1_s, out);
    }

    /// [`GroundRain::impacts_between`] less the impacts `keep` turns down, in the same order:
    /// for a caller that keeps a few of hundreds of thousands (the rings a picture resolves
    /// out of a second and a half of rain), so the others are never stored.
    pub fn impacts_between_kept(
        &self,
        rect: &GroundRect,
        t0_s: f64,
        t1_s: f64,
        mut keep: impl FnMut(&Impact) -> bool,
    ) -> Vec<Impact> {
        let mut out = impacts_between(self.rainfall(), t0_s, t1_s);
        out.retain(&mut keep);
        self.stream_landings(rect, t0_s, t1_s, |landing| {
            let hit = self.impact_of(&landing);
            if keep(&hit) {
                out.push(hit);
            }
        });
        out
    }

    /// The stream's impacts in `rect` with time in (t0_s, t1_s], appended to `out`: cell by
    /// cell (x, then y), slot by slot.
    pub fn stream_between(&self, rect: &GroundRect, t0_s: f64, t1_s: f64, out: &mut Vec<Impact>) {
        self.stream_landings(rect, t0_s, t1_s, |landing| {
            out.push(self.impact_of(&landing))
        });
    }

    /// A stream landing as an impact: its size and fall speed looked up.
    #[inline]
    fn impact_of(&self, landing: &Landing) -> Impact {
        let d_mm = self.landing_diameter_mm(landing);
        let p = landing.position_m;
        Impact {
            id: landing.id,
            pass: landing.pass,
            time_s: landing.time_s,
            position_m: DVec3::new(p.x, p.y, 0.0),
            diameter_mm: d_mm,
            velocity_mps: DVec3::new(0.0, 0.0, -self.model.fall.terminal_velocity_mps(d_mm)),
        }
    }

    /// The stream's impacts in `rect` with time in (t0_s, t1_s] as [`Landing`]s, in the order
    /// of [`GroundRain::stream_between`] and with its values, each handed to `f`: for a
    /// consumer that needs where a drop lands but its size only now and then (the water over
    /// its particle cap), so no diameter is looked up, and no fall speed, it does not use.
    pub fn stream_landings(
        &self,
        rect: &GroundRect,
        t0_s: f64,
        t1_s: f64,
        mut f: impl FnMut(Landing),
    ) {
        let Some(stream) = self.stream_of(rect, t0_s, t1_s) else {
            return;
        };
        let t0_s = t0_s.max(0.0);
        for (ix, iy) in stream.cells() {
            for slot in stream.slots.clone() {
                self.cell_slot(&stream, (ix, iy), slot, |l| {
                    if l.time_s > t0_s && l.time_s <= t1_s {
                        f(l)
                    }
                });
            }
        }
    }

    /// [`GroundRain::stream_landings`] (the same landings in the same order) with each time
    /// slot's landings made once and kept in `kept` for the frames that share the slot (a
    /// slot of 0.1 s spans two or three frames); `kept` holds the slots of the last call.
    pub fn stream_landings_kept(
        &self,
        kept: &mut StreamSlots,
        rect: &GroundRect,
        t0_s: f64,
        t1_s: f64,
        mut f: impl FnMut(Landing),
    ) {
        let Some(stream) = self.stream_of(rect, t0_s, t1_s) else {
            return;
        };
        let t0_s = t0_s.max(0.0);
        if kept.rect != Some(*rect) {
            kept.rect = Some(*rect);
            kept.spare.append(&mut kept.slots);
        }
        let (gone, live): (Vec<_>, Vec<_>) = std::mem::take(&mut kept.slots)
            .into_iter()
            .partition(|s| !stream.slots.contains(&s.slot));
        kept.slots = live;
        kept.spare.extend(gone);
        // As many as a call makes at most (a frame spans two or three slots).
        kept.spare.truncate(SPARE_SLOTS);
        for slot in stream.slots.clone() {
            if kept.slots.iter().all(|s| s.slot != slot) {
                let mut made = kept.spare.pop().unwrap_or_else(|| SlotLandings {
                    slot,
                    times_s: Vec::new(),
                    positions_m: Vec::new(),
                    ids: Vec::new(),
                    size_qs: Vec::new(),
                    starts: Vec::new(),
                    picked: Vec::new(),
                });
                made.slot = slot;
                made.clear();
                made.starts.push(0);
                for cell in stream.cells() {
                    self.cell_slot(&stream, cell, slot, |l| made.push(l));
                    made.starts.push(made.times_s.len() as u32);
                }
                kept.slots.push(made);
            }
        }
        kept.slots.sort_by_key(|s| s.slot);
        for s in &mut kept.slots {
            s.pick(t0_s, t1_s);
        }
        let mut next = vec![0usize; kept.slots.len()];
        for c in 0..stream.cells().count() {
            for (s, next) in kept.slots.iter().zip(&mut next) {
                let b = s.starts[c + 1];
                while let Some(&i) = s.picked.get(*next)
                    && i < b
                {
                    f(s.landing(i as usize));
                    *next += 1;
                }
            }
        }
    }

    /// The stream's cells over `rect` and its slots over (t0_s, t1_s]; `None` where no drop
    /// can land.
    fn stream_of(&self, rect: &GroundRect, t0_s: f64, t1_s: f64) -> Option<Stream> {
        let t0_s = t0_s.max(0.0);
        if self.flux_per_m2_s <= 0.0 || t1_s <= t0_s || rect.area_m2() <= 0.0 {
            return None;
        }
        // Where the drawn drops land the stream supplies only what the budget thinned out.
        let supplement = if self.volume.weight > 1.0 {
            1.0 - 1.0 / self.volume.weight
        } else {
            0.0
        };
        let mean = self.flux_per_m2_s * self.cell_m * self.cell_m * SLOT_S;
        let lo = (rect.min_m / self.cell_m).floor();
        let hi = (rect.max_m / self.cell_m).ceil();
        Some(Stream {
            rect: *rect,
            supplement,
            counts: PoissonTable::new(mean, (-mean).exp()),
            x: lo.x as i64..hi.x as i64,
            y: lo.y as i64..hi.y as i64,
            slots: (t0_s / SLOT_S).floor() as i64..(t1_s / SLOT_S).ceil() as i64,
        })
    }

    /// The landings of cell (`ix`, `iy`) in time slot `slot` that fall in the stream's
    /// rectangle and that the drawn drops and the rate's keys leave to the stream, in order,
    /// each handed to `f`.
    fn cell_slot(
        &self,
        stream: &Stream,
        (ix, iy): (i64, i64),
        slot: i64,
        mut f: impl FnMut(Landing),
    ) {
        let key = pcg_hash(
            pcg_hash(pcg_hash(pcg_hash(self.seed ^ STREAM_SALT) ^ ix as u32) ^ iy as u32)
                ^ slot as u32,
        );
        let n = stream.counts.count(unit_hashed(key, 0));
        for j in 0..n {
            let k = 8 * (j + 1);
            let time_s = (slot as f64 + unit_hashed(key, k)) * SLOT_S;
            let p = DVec2::new(
                (ix as f64 + unit_hashed(key, k + 1)) * self.cell_m,
                (iy as f64 + unit_hashed(key, k + 2)) * self.cell_m,
            );
            if !stream.rect.contains(p) {
                continue;
            }
            let size_q = unit_hashed(key, k + 4);
            // In a drawn cell: the sizes its drops leave out, and the budget's supplement of
            // the others.
            if let Some(cut) = self.drawn.cut_at(p)
                && self.diameter_mm(size_q) >= cut
                && unit_hashed(key, k + 3) >= stream.supplement
            {
                continue;
            }
            if let Some(keys) = &self.model.rate_keys
                && unit_hashed(key, k + 5)
                    >= self.model.keeps(keys.at(time_s), self.diameter_mm(size_q))
            {
                continue;
            }
            f(Landing {
                id: STREAM_ID_BIT | (key as u64) << 16 | j as u64,
                pass: slot as u32,
                time_s,
                position_m: p,
                size_q,
            });
        }
    }

    /// The diameter of a stream drop, mm.
    pub fn landing_diameter_mm(&self, landing: &Landing) -> f64 {
        self.diameter_mm(landing.size_q)
    }

    /// The diameter of flux-weighted quantile `u` (the table inverted, linear within an
    /// interval), mm.
    fn diameter_mm(&self, u: f64) -> f64 {
        let (d0, d1) = self.model.dsd.range_mm();
        let i = self
            .size_cdf
            .partition_point(|&c| c <= u)
            .clamp(1, SIZE_INTERVALS)
            - 1;
        let (c0, c1) = (self.size_cdf[i], self.size_cdf[i + 1]);
        let f = if c1 > c0 {
            ((u - c0) / (c1 - c0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        d0 + (i as f64 + f) * (d1 - d0) / SIZE_INTERVALS as f64
    }
}

/// Uniform in [0, 1) number `k` of the cell-slot `key` (24 bits): the plain form of
/// [`unit_hashed`].
#[cfg(test)]
fn unit(key: u32, k: u32) -> f64 {
    (pcg_hash(key ^ pcg_hash(k.wrapping_mul(0x9E37_79B9))) >> 8) as f64 * (1.0 / 16_777_216.0)
}

/// Numbers `k` whose inner hash [`NUMBER_HASHES`] holds: a cell-slot's first 63 landings
/// (a slot holds [`IMPACTS_PER_CELL_SLOT`] on average).
const HASHED_NUMBERS: usize = 8 * 64;

/// [`unit`]'s inner hash of each number `k` below [`HASHED_NUMBERS`], made at compile time:
/// the stream makes hundreds of thousands of landings a slot, each reading four to six
/// numbers, and half of [`unit`]'s hashing depends on the number alone.
const NUMBER_HASHES: [u32; HASHED_NUMBERS] = {
    let mut hashes = [0; HASHED_NUMBERS];
    let mut k = 0;
    while k < HASHED_NUMBERS {
        hashes[k] = pcg_hash((k as u32).wrapping_mul(0x9E37_79B9));
        k += 1;
    }
    hashes
};

/// [`unit`] with the inner hash read from [`NUMBER_HASHES`]: the same number.
#[inline(always)]
fn unit_hashed(key: u32, k: u32) -> f64 {
    let inner = match NUMBER_HASHES.get(k as usize) {
        Some(&h) => h,
        None => pcg_hash(k.wrapping_mul(0x9E37_79B9)),
    };
    (pcg_hash(key ^ inner) >> 8) as f64 * (1.0 / 16_777_216.0)
}

/// [`poisson`]'s cumulative sums for one mean, made once: the same counts, without its
/// division at every step for each of a slot's tens of thousands of cells.
#[derive(Debug, Clone)]
struct PoissonTable {
    /// The cumulative sum after each count, up to where the terms reach zero.
    cdf: Vec<f64>,
}

impl PoissonTable {
    /// The sums [`poisson`] makes for `mean` and `none` (the same operations in order).
    fn new(mean: f64, none: f64) -> PoissonTable {
        let (mut p, mut cdf) = (none, vec![none]);
        let mut n = 0;
        while p > 0.0 {
            n += 1;
            p *= mean / n as f64;
            cdf.push(cdf[n - 1] + p);
        }
        // The last sum's term is zero: poisson stops there whatever u is.
        cdf.pop();
        PoissonTable { cdf }
    }

    /// [`poisson`]'s count for `u`.
    fn count(&self, u: f64) -> u32 {
        self.cdf
            .iter()
            .position(|&c| u < c)
            .unwrap_or(self.cdf.len()) as u32
    }
}

/// The Poisson count of mean `mean` at quantile `u` (inversion; `mean` is a few); `none`:
/// e^−mean, the chance of none: the plain form of [`PoissonTable::count`].
#[cfg(test)]
fn poisson(mean: f64, none: f64, u: f64) -> u32 {
    let mut p = none;
    let mut cdf = p;
    let mut n = 0;
    while u >= cdf && p > 0.0 {
        n += 1;
        p *= mean / n as f64;
        cdf += p;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The numbers read through the table are [`unit`]'s, below, at and beyond its end.
    #[test]
    fn hashed_numbers_are_the_plain_ones() {
        for key in (0..64u32).map(pcg_hash).chain([0, u32::MAX]) {
            for k in 0..HASHED_NUMBERS as u32 + 40 {
                assert_eq!(
                    unit_hashed(key, k).to_bits(),
                    unit(key, k).to_bits(),
                    "{key} {k}"
                );
            }
        }
    }

    /// The dense table answers as the hashed cells do, inside and around their range, and
    /// a range too wide for a table is looked up in the hash.
    #[test]
    fn drawn_cells_answer_as_the_hash() {
        let mut rng = crate::rng::SplitMix64(9);
        let (origin, cell) = (DVec2::new(-3.2, 1.5), DVec2::new(0.7, 0.45));
        for wide in [false, true] {
            let mut cells = HashMap::new();
            for _ in 0..300 {
                let (i, j) = (
                    (rng.next_u64() % 40) as i64,
                    (rng.next_u64() % 25) as i64 - 7,
                );
                cells.insert((i, j), 0.1 + rng.next_f64());
            }
            if wide {
                cells.insert((5_000_000, 3), 0.5);
            }
            let drawn = DrawnCells::from_cells(origin, cell, cells.clone());
            assert_eq!(drawn.dense.is_empty(), wide);
            for _ in 0..20_000 {
                let p = origin
                    + DVec2::new(rng.next_f64() * 50.0 - 5.0, rng.next_f64() * 40.0 - 12.0) * cell;
                let i = ((p - origin) / cell).floor();
                let hashed = cells.get(&(i.x as i64, i.y as i64)).copied();
                assert_eq!(drawn.cut_at(p), hashed, "{p}");
            }
        }
    }

    #[test]
    fn the_poisson_table_counts_as_the_sums() {
        for mean in [0.0f64, 1e-3, 0.7, 8.0, 37.5] {
            let table = PoissonTable::new(mean, (-mean).exp());
            for i in 0..100_000u32 {
                let u = unit(pcg_hash(i), 0);
                assert_eq!(
                    table.count(u),
                    poisson(mean, (-mean).exp(), u),
                    "{mean} {u}"
                );
            }
            for u in [0.0, 1.0 - 1.0 / 16_777_216.0, 1.0, 2.0] {
                assert_eq!(
                    table.count(u),
                    poisson(mean, (-mean).exp(), u),
                    "{mean} {u}"
                );
            }
        }
    }

    #[test]
    fn poisson_counts_have_their_mean_and_variance() {
        let samples: Vec<f64> = (0..200_000u32)
            .map(|i| poisson(6.5, (-6.5f64).exp(), unit(pcg_hash(i), 0)) as f64)
            .collect();
        let mean = samples.iter().sum::<f64>() / samples.len() as f64;
        let var = samples.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / samples.len() as f64;
        assert!((mean - 6.5).abs() < 0.03, "{mean}");
        assert!((var - 6.5).abs() < 0.1, "{var}");
    }
}
