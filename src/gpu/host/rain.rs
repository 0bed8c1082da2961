//! The rain of a frame on the CPU back end: the drops simulated on the CPU
//! ([`super::simulate`], the `rain_simulate` stage's work) and their streaks rasterised over the
//! plate ([`super::streaks`]); neither the canvas nor the drops go to the adapter, which a
//! frame drawn this way does not touch.

use std::sync::Arc;

use super::simulate::{self, Drops, LightTable};
use super::streaks::RasterCount;
use crate::drops::MatteAtlas;
use crate::gpu::types::{Column, Glint, LightList, RainParams, Streak};
use crate::lighting::RtfTable;

/// The drops of a rain on the CPU, with the lights they are lit by and the records of the last
/// frame (kept to reuse their memory).
pub struct HostRain {
    columns: Vec<Column>,
    mattes: Option<Arc<MatteAtlas>>,
    /// Whether the drops carry glints (mattes with point lights).
    glints_on: bool,
    lights: LightList,
    table: Option<LightTable>,
    streaks: Vec<Streak>,
    glints: Vec<Glint>,
}

/// What one frame's rain cost and drew.
#[derive(Debug, Clone, Copy, Default)]
pub struct RainTimes {
    /// Wall time of the simulation, s.
    pub simulate_s: f64,
    /// Wall time of the raster, s.
    pub streaks_s: f64,
    /// Streaks the simulation found drawable.
    pub drawable: usize,
    /// What the raster drew.
    pub raster: RasterCount,
}

impl HostRain {
    /// The rain of the volume `columns`, its streaks drawn with `mattes` (`None`: capsules).
    pub fn new(columns: &[Column], mattes: Option<Arc<MatteAtlas>>) -> HostRain {
        HostRain {
            columns: columns.to_vec(),
            glints_on: mattes.as_ref().is_some_and(|m| !m.lights.is_empty()),
            mattes,
            lights: LightList::new(&[]),
            table: None,
            streaks: Vec::new(),
            glints: Vec::new(),
        }
    }

    /// The mattes the streaks are drawn with.
    pub fn mattes(&self) -> Option<&MatteAtlas> {
        self.mattes.as_deref()
    }

    /// The compact lights of the frames from now on.
    pub fn set_lights(&mut self, lights: &LightList) {
        self.lights = *lights;
    }

    /// The drop's transfer table the lights are seen through; until it is set they add
    /// nothing (as on the GPU).
    pub fn set_transfer_table(&mut self, tables: &[RtfTable; 3]) {
        self.table = Some(LightTable::new(&crate::gpu::lights::table_texels(tables)));
    }

    /// The frame's drops under `p`: one streak per drop and, with point-light mattes, their
    /// glints (the records `rain_simulate` writes); returns them with the count that can be
    /// drawn.
    pub fn simulate(&mut self, p: &RainParams) -> (&[Streak], &[Glint], usize) {
        let (streaks, _, glints, drawable) = self.simulate_for_draw(p);
        (streaks, glints, drawable)
    }

    /// [`simulate`](Self::simulate), returning with the streaks the mattes they are drawn
    /// with and the glints (for a caller that draws them later).
    pub fn simulate_for_draw(
        &mut self,
        p: &RainParams,
    ) -> (&[Streak], Option<&MatteAtlas>, &[Glint], usize) {
        let drops = Drops {
            columns: &self.columns,
            lights: &self.lights,
            table: self.table.as_ref(),
            glints: self.glints_on,
        };
        let drawable = simulate::simulate(p, &drops, &mut self.streaks, &mut self.glints);
        (
            &self.streaks,
            self.mattes.as_deref(),
            &self.glints,
            drawable,
        )
    }

    /// Simulates the frame's drops under `p` and draws them with `draw` (given the streaks, the
    /// glints and the mattes), timing both.
    pub fn draw(
        &mut self,
        p: &RainParams,
        draw: impl FnOnce(&[Streak], Option<&MatteAtlas>, &[Glint]) -> RasterCount,
    ) -> RainTimes {
        let started = std::time::Instant::now();
        let mattes = self.mattes.clone();
        let (streaks, glints, drawable) = self.simulate(p);
        let simulate_s = started.elapsed().as_secs_f64();
        let started = std::time::Instant::now();
        let raster = draw(streaks, mattes.as_deref(), glints);
        RainTimes {
            simulate_s,
            streaks_s: started.elapsed().as_secs_f64(),
            drawable,
            raster,
        }
    }
}
