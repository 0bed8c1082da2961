//! The masks a compositor reads from the frames: the open sky's weight for the haze and the
//! ground's weight for the wet ground and the puddles, both on the glow's grid.

use super::Compositor;
use crate::{Error, Result};

impl Compositor {
    /// Sets the open sky's weight (in [0, 1]) at the glow's grid points
    /// (`stages::yuv_to_rgb::glow_grid_size` of the coded picture, row-major) for the frames
    /// submitted from now on: the haze leaves the sky its own radiance (`scene::sky`). A mask of
    /// another size is refused.
    pub fn set_sky_mask(&mut self, weights: &[f32]) -> Result<()> {
        if 4 * weights.len() as u64 != self.sky_mask.size() {
            return Err(Error::Gpu(format!(
                "a sky mask of {} points for a grid of {}",
                weights.len(),
                self.sky_mask.size() / 4
            )));
        }
        match &mut self.host {
            Some(host) => host.set_sky_mask(weights.to_vec()),
            None => self
                .ctx
                .queue
                .write_buffer(&self.sky_mask, 0, bytemuck::cast_slice(weights)),
        }
        Ok(())
    }

    /// Sets the ground's weight (in [0, 1]) at the glow's grid points
    /// (`stages::yuv_to_rgb::glow_grid_size` of the coded picture, row-major) for the frames
    /// submitted from now on: the wet ground and the puddles keep to it where the depth map
    /// does not know the pixel (`scene::ground_mask`). A mask of another size is refused.
    pub fn set_ground_mask(&mut self, weights: &[f32]) -> Result<()> {
        if 4 * weights.len() as u64 != self.ground_mask.size() {
            return Err(Error::Gpu(format!(
                "a ground mask of {} points for a grid of {}",
                weights.len(),
                self.ground_mask.size() / 4
            )));
        }
        if let Some(host) = &mut self.host {
            host.set_ground_mask(weights.to_vec());
        } else {
            self.ctx
                .queue
                .write_buffer(&self.ground_mask, 0, bytemuck::cast_slice(weights));
        }
        Ok(())
    }
}
