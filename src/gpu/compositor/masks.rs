//! The masks a compositor reads from the frames: the open sky's weight for the haze and the
//! ground's weight for the wet ground and the puddles, both on the glow's grid.

use super::Compositor;
use crate::gpu::stages::yuv_to_rgb::glow_grid_size;
use crate::{Error, Result};

impl Compositor {
    /// The glow's grid points of the coded picture, the masks' size.
    fn glow_points(&self) -> usize {
        let (gw, gh) = glow_grid_size((self.format.width, self.format.height));
        gw as usize * gh as usize
    }

    /// Sets the open sky's weight (in [0, 1]) at the glow's grid points
    /// (`stages::yuv_to_rgb::glow_grid_size` of the coded picture, row-major) for the frames
    /// submitted from now on: the haze leaves the sky its own radiance (`scene::sky`). A mask of
    /// another size is refused.
    pub fn set_sky_mask(&mut self, weights: &[f32]) -> Result<()> {
        if weights.len() != self.glow_points() {
            return Err(Error::Gpu(format!(
                "a sky mask of {} points for a grid of {}",
                weights.len(),
                self.glow_points()
            )));
        }
        if let Some(host) = &mut self.host {
            host.set_sky_mask(weights.to_vec());
        }
        if let Some(gpu) = &self.gpu {
            self.ctx
                .queue
                .write_buffer(&gpu.sky_mask, 0, bytemuck::cast_slice(weights));
        }
        Ok(())
    }

    /// Sets the ground's weight (in [0, 1]) at the glow's grid points
    /// (`stages::yuv_to_rgb::glow_grid_size` of the coded picture, row-major) for the frames
    /// submitted from now on: the wet ground and the puddles keep to it where the depth map
    /// does not know the pixel (`scene::ground_mask`). A mask of another size is refused.
    pub fn set_ground_mask(&mut self, weights: &[f32]) -> Result<()> {
        if weights.len() != self.glow_points() {
            return Err(Error::Gpu(format!(
                "a ground mask of {} points for a grid of {}",
                weights.len(),
                self.glow_points()
            )));
        }
        if let Some(host) = &mut self.host {
            host.set_ground_mask(weights.to_vec());
        }
        if let Some(gpu) = &self.gpu {
            self.ctx
                .queue
                .write_buffer(&gpu.ground_mask, 0, bytemuck::cast_slice(weights));
        }
        Ok(())
    }
}
