//! The frei0r 1.2 ABI, written out from the layout `frei0r.h` gives its structs and constants,
//! so the plug-in builds without the C header.

use std::ffi::{c_char, c_int};

/// `FREI0R_MAJOR_VERSION`: the API version a plug-in reports in `frei0r_version` (1.2's
/// major; hosts refuse anything above 1).
pub const FREI0R_MAJOR_VERSION: c_int = 1;

/// `F0R_PLUGIN_TYPE_FILTER`: one input frame, one output frame.
pub const PLUGIN_TYPE_FILTER: c_int = 0;

/// `F0R_COLOR_MODEL_RGBA8888`: bytes R, G, B, A in memory, straight alpha, sRGB.
pub const COLOR_MODEL_RGBA8888: c_int = 1;

/// `F0R_PARAM_BOOL`: a `double`, true from 0.5 up.
pub const PARAM_BOOL: c_int = 0;
/// `F0R_PARAM_DOUBLE`: a `double`, by convention in [0, 1].
pub const PARAM_DOUBLE: c_int = 1;
/// `F0R_PARAM_COLOR`: three `float`s (not used by this plug-in).
pub const PARAM_COLOR: c_int = 2;
/// `F0R_PARAM_POSITION`: two `double`s, x and y, by convention in [0, 1] of the frame.
pub const PARAM_POSITION: c_int = 3;
/// `F0R_PARAM_STRING`: a `char*`; the host passes a pointer to it.
pub const PARAM_STRING: c_int = 4;

/// `f0r_plugin_info_t`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct PluginInfo {
    /// Short name; GStreamer makes its element name from it.
    pub name: *const c_char,
    /// Author.
    pub author: *const c_char,
    /// `F0R_PLUGIN_TYPE_*`.
    pub plugin_type: c_int,
    /// `F0R_COLOR_MODEL_*`.
    pub color_model: c_int,
    /// The frei0r major version the plug-in is built for.
    pub frei0r_version: c_int,
    /// The plug-in's major version.
    pub major_version: c_int,
    /// The plug-in's minor version.
    pub minor_version: c_int,
    /// How many parameters `f0r_get_param_info` describes.
    pub num_params: c_int,
    /// One line on what the plug-in does.
    pub explanation: *const c_char,
}

/// `f0r_param_info_t`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct ParamInfo {
    /// The name hosts address it by (MLT's property, GStreamer's property after
    /// lower-casing and `_` → `-`).
    pub name: *const c_char,
    /// `F0R_PARAM_*`.
    pub kind: c_int,
    /// What the host shows beside it: here, the mapping from the host's value to the setting.
    pub explanation: *const c_char,
}

/// `f0r_param_position_t`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Position {
    /// Horizontal, 0 = left edge, 1 = right edge.
    pub x: f64,
    /// Vertical, 0 = top, 1 = bottom.
    pub y: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{align_of, offset_of, size_of};

    /// The structs are laid out as the C compiler lays out `frei0r.h`'s on an LP64 or LLP64
    /// target: pointers first, six `int`s, then a pointer at the next 8-byte boundary.
    #[test]
    fn layouts_match_the_header() {
        let ptr = size_of::<*const c_char>();
        assert_eq!(offset_of!(PluginInfo, author), ptr);
        assert_eq!(offset_of!(PluginInfo, plugin_type), 2 * ptr);
        assert_eq!(offset_of!(PluginInfo, num_params), 2 * ptr + 5 * 4);
        let explanation = (2 * ptr + 6 * 4).next_multiple_of(align_of::<*const c_char>());
        assert_eq!(offset_of!(PluginInfo, explanation), explanation);
        assert_eq!(size_of::<PluginInfo>(), explanation + ptr);
        assert_eq!(offset_of!(ParamInfo, kind), ptr);
        assert_eq!(offset_of!(ParamInfo, explanation), 2 * ptr);
        assert_eq!(size_of::<Position>(), 16);
        assert_eq!(
            [
                PARAM_BOOL,
                PARAM_DOUBLE,
                PARAM_COLOR,
                PARAM_POSITION,
                PARAM_STRING
            ],
            [0, 1, 2, 3, 4]
        );
    }
}
