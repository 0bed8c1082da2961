//! The rain of a shot as its stateless drops see it.

use super::RainVolume;
use crate::rain::physics::RainModel;
use crate::rain::wind::Wind;

/// The planned volume, the rain's model, the wind and the seed: every drop, impact and splash
/// is a pure function of these four, the drop's id and the time, so they travel together.
#[derive(Debug, Clone, Copy)]
pub struct Rainfall<'a> {
    /// Where drops are simulated: columns, distances, weights.
    pub volume: &'a RainVolume,
    /// Rate, sizes and fall speeds.
    pub model: &'a RainModel,
    /// The wind that carries the drops.
    pub wind: &'a Wind,
    /// The seed each drop's randomness derives from.
    pub seed: u32,
}

impl<'a> Rainfall<'a> {
    /// The rain of `volume`, `model` and `wind` under `seed`.
    pub fn new(volume: &'a RainVolume, model: &'a RainModel, wind: &'a Wind, seed: u32) -> Self {
        Rainfall {
            volume,
            model,
            wind,
            seed,
        }
    }
}
