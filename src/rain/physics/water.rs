//! Liquid water's properties at about 20 °C, shared by the drops, the splashes and the water
//! on the ground.

/// Water's rest density used by Müller 2003 and Kelager 2006, kg/m³.
pub const WATER_REST_DENSITY_KG_M3: f32 = 998.29;
/// Surface tension of water against air at 20 °C, N/m.
pub const WATER_SURFACE_TENSION_N_PER_M: f32 = 0.0728;
