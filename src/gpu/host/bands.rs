//! A whole frame on the CPU back end band by band: each band of [`TILE_H`] rows is decoded,
//! drawn on (the splashes, then the drops) and packed by one thread in a buffer of its own
//! before the next, so the band's canvas (0.5 MB at 1080p, within a core's second-level cache)
//! never goes to memory, where the stages one after another stream the whole f16 canvas
//! (16.6 MB at 1080p) out and back in three times. Each pixel goes through the same
//! operations in the same order as in [`HostColour::lay_plate`], the draws and
//! [`HostColour::encode_canvas`], so the codes are the same bits (`tests/backend.rs`).

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use half::f16;
use rayon::prelude::*;

use super::streaks::{self, RasterCount, TILE_H};
use super::{GroundFrame, HostColour, encode, plate, plate_passes, veil, wet_ground};
use crate::drops::MatteAtlas;
use crate::gpu::types::{Glint, RainParams, Streak};
use crate::video::{Plane, YuvFrame};

/// The rain a frame draws: the splashes' streaks first, then the drops' with their mattes
/// (`None`: capsules) and glints.
pub struct FrameRain<'a> {
    /// The splashes' streaks (capsules).
    pub splashes: &'a [Streak],
    /// The drops' streaks, one per drop.
    pub streaks: &'a [Streak],
    /// The streak mattes of the drops.
    pub mattes: Option<&'a MatteAtlas>,
    /// The drops' glints (may be empty).
    pub glints: &'a [Glint],
}

/// A frame rendered band by band: its code planes, what each draw drew, and the pass's wall
/// time shared among its parts by the time the threads spent in each (the parts overlap on
/// the threads, so their own wall times do not exist).
pub struct BandedFrame {
    /// The code planes, as [`HostColour::encode_canvas`] lays them out.
    pub planes: [Plane; 3],
    /// What the splashes' draw drew.
    pub splashes: RasterCount,
    /// What the drops' draw drew.
    pub streaks: RasterCount,
    /// Seconds of the pass: the decode's share (with the haze's set-up).
    pub decode_s: f64,
    /// The splashes' share (with their streaks' preparation and binning, before the bands).
    pub splashes_s: f64,
    /// The drops' share (with their streaks' preparation and binning, before the bands).
    pub streaks_s: f64,
    /// The encode's share.
    pub encode_s: f64,
}

/// One thread's buffers for a band: the band's canvas and the decode's and encode's scratch.
#[derive(Default)]
pub(super) struct BandWork {
    canvas: Vec<f16>,
    rows: plate::RowScratch,
    codes: encode::Scratch,
}

impl HostColour {
    /// `frame` under `p` with the wet ground of `ground` and `rain` drawn, band by band (see
    /// the module's comment), or `None` where the frame is not rendered this way: with water
    /// (the puddles read the canvas across bands), or where the tiles no rain reaches pass
    /// through ([`HostColour::lay_plate`]: then most of the frame is neither decoded nor
    /// encoded). Leaves [`canvas`](HostColour::canvas) as it was.
    pub fn render_bands(
        &mut self,
        frame: &YuvFrame,
        p: &RainParams,
        ground: &GroundFrame,
        rain: &FrameRain,
    ) -> Option<BandedFrame> {
        if ground.water.is_some() {
            return None;
        }
        let started = Instant::now();
        let HostColour {
            format,
            decoder,
            encoder,
            lights,
            tables,
            depth,
            sky,
            ground_mask,
            laid,
            pass_through,
            raster,
            splash_raster,
            rays,
            band_work,
            ..
        } = self;
        let lit = tables.as_deref().map(|t| (&*lights, t));
        let size = (format.width, format.height);
        let (depth, sky) = (depth.as_deref(), sky.as_deref());
        let veil = veil::Veil::new(p, lit, depth, sky, size, rays);
        let on_ground = wet_ground::Ground::new(p, size, depth, ground_mask.as_deref());
        let wet = ground
            .wet
            .as_ref()
            .and_then(|w| wet_ground::WetGround::new(&on_ground, w));
        if *pass_through && plate_passes(veil.as_ref(), wet.as_ref(), None) {
            return None;
        }
        *laid = None;
        let (w, h) = (format.width as usize, format.height as usize);
        let splash_rain = streaks::Rain {
            params: p,
            mattes: None,
            glints: &[],
            depth,
        };
        let drop_rain = streaks::Rain {
            params: p,
            mattes: rain.mattes,
            glints: rain.glints,
            depth,
        };
        let veil_s = started.elapsed().as_secs_f64();
        let (splash_bins, splash_buffers) =
            splash_raster.bin((w, h), &splash_rain, rain.splashes, true);
        let splash_bin_s = started.elapsed().as_secs_f64() - veil_s;
        let (drop_bins, drop_buffers) = raster.bin((w, h), &drop_rain, rain.streaks, true);
        let (mut planes, rows_per_chroma) = encoder.blank_planes();
        let set_up_s = started.elapsed().as_secs_f64();
        let drop_bin_s = set_up_s - veil_s - splash_bin_s;
        // One set of buffers a thread: a thread works on one band at a time, so its lock is
        // never contended.
        let threads = rayon::current_num_threads() + 1;
        if band_work.len() < threads {
            band_work.resize_with(threads, Mutex::default);
        }
        let band_work = &band_work[..];
        let nanos: [AtomicU64; 4] = Default::default();
        let since = |t: &mut Instant, k: usize| {
            let now = Instant::now();
            nanos[k].fetch_add((now - *t).as_nanos() as u64, Ordering::Relaxed);
            *t = now;
        };
        let [luma, cb, cr] = &mut planes;
        let (y_step, c_step) = (luma.stride * TILE_H, cb.stride * (TILE_H / rows_per_chroma));
        let (splash_tiles, drop_tiles) = luma
            .data
            .par_chunks_mut(y_step)
            .zip(cb.data.par_chunks_mut(c_step))
            .zip(cr.data.par_chunks_mut(c_step))
            .zip(splash_buffers.par_iter_mut())
            .zip(drop_buffers.par_iter_mut())
            .enumerate()
            .map(|(ty, ((((luma, cb), cr), splash_buffers), drop_buffers))| {
                let mut t = Instant::now();
                let slot =
                    rayon::current_thread_index().map_or(threads - 1, |i| i.min(threads - 1));
                let mut work = band_work[slot].lock().unwrap_or_else(|e| e.into_inner());
                let BandWork {
                    canvas,
                    rows,
                    codes,
                } = &mut *work;
                let y0 = ty * TILE_H;
                canvas.resize(4 * w * TILE_H, f16::ZERO);
                let band = &mut canvas[..4 * w * TILE_H.min(h - y0)];
                decoder.decode_rows(frame, (veil.as_ref(), wet.as_ref()), y0, band, rows);
                since(&mut t, 0);
                let splash_tiles = splash_bins.draw_band(ty, band, splash_buffers);
                since(&mut t, 1);
                let drop_tiles = drop_bins.draw_band(ty, band, drop_buffers);
                since(&mut t, 2);
                encoder.encode_rows(bytemuck::cast_slice(band), y0, [luma, cb, cr], codes);
                since(&mut t, 3);
                (splash_tiles, drop_tiles)
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        let pass_s = started.elapsed().as_secs_f64() - set_up_s;
        let spent = nanos.map(|n| n.into_inner() as f64);
        let total: f64 = spent.iter().sum::<f64>().max(1.0);
        let share = |k: usize| pass_s * spent[k] / total;
        Some(BandedFrame {
            planes,
            splashes: RasterCount {
                streaks: splash_bins.drawn,
                tiles: splash_tiles,
            },
            streaks: RasterCount {
                streaks: drop_bins.drawn,
                tiles: drop_tiles,
            },
            decode_s: veil_s + share(0),
            splashes_s: splash_bin_s + share(1),
            streaks_s: drop_bin_s + share(2),
            encode_s: share(3),
        })
    }
}
