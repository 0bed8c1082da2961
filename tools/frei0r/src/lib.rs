//! rain-composite as a frei0r filter: physically based rain inside FFmpeg (`-vf frei0r`), MLT
//! (melt, Kdenlive, Shotcut) and GStreamer (`frei0r-filter-rain-composite`).
//!
//! The host hands over 8-bit RGBA frames with a time; each frame goes through the library's
//! [`Renderer`](rain_composite::Renderer) (one per instance, built at the first frame) and
//! comes back with rain, alpha untouched. Every frame is rendered on its own: the rain is a
//! pure function of the shot's time, and the light is estimated from the frame alone, because
//! MLT renders frames out of order on several instances at once.
//!
//! Nothing may unwind into a C host: every entry point catches panics, and a frame that cannot
//! be rendered (no GPU, a bad parameter, a panic) passes through unchanged, with the reason
//! written once to stderr. `RAIN_COMPOSITE_FREI0R_TRACE=1` writes each frame's host time and
//! shot time to stderr; `RAIN_COMPOSITE_ADAPTER=NAME` picks the GPU adapter by name.
//! docs/guide/editors.md is the user's guide.

pub mod abi;
pub mod clock;
pub mod instance;
pub mod params;

use std::collections::HashSet;
use std::ffi::{CStr, CString, c_char, c_int, c_uint, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::{Mutex, MutexGuard, OnceLock};

use abi::{
    COLOR_MODEL_RGBA8888, FREI0R_MAJOR_VERSION, PARAM_BOOL, PARAM_DOUBLE, PARAM_POSITION,
    PARAM_STRING, ParamInfo, PluginInfo, Position,
};
use instance::{Instance, Outcome};
use params::{SPECS, index};

/// The instance behind the `f0r_instance_t` pointer: locked, since GStreamer sets parameters
/// from the application's thread while its streaming thread renders.
type Handle = Mutex<Instance>;

/// Writes `message` to stderr the first time it comes up in this process.
fn log_once(message: &str) {
    static SEEN: Mutex<Option<HashSet<String>>> = Mutex::new(None);
    let mut seen = SEEN.lock().unwrap_or_else(|p| p.into_inner());
    if seen
        .get_or_insert_with(HashSet::new)
        .insert(message.to_string())
    {
        eprintln!("rain-composite (frei0r): {message}");
    }
}

/// Whether to write each frame's times to stderr.
fn tracing() -> bool {
    static TRACE: OnceLock<bool> = OnceLock::new();
    *TRACE.get_or_init(|| {
        std::env::var_os("RAIN_COMPOSITE_FREI0R_TRACE").is_some_and(|v| !v.is_empty() && v != "0")
    })
}

/// Runs `f`, turning a panic into `fallback` and a line on stderr.
fn guarded<T>(what: &str, fallback: T, f: impl FnOnce() -> T) -> T {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|_| {
        log_once(&format!(
            "{what} failed (a panic); the frame passes through"
        ));
        fallback
    })
}

/// The instance behind `ptr`, locked; a lock a panic poisoned drops the renderer, which is
/// rebuilt at the next frame.
///
/// # Safety
/// `ptr` is null or came from [`f0r_construct`] and was not destructed.
unsafe fn instance<'a>(ptr: *mut c_void) -> Option<MutexGuard<'a, Instance>> {
    // SAFETY: by the caller's contract, a non-null `ptr` is a live `Handle`.
    let handle = unsafe { (ptr as *const Handle).as_ref() }?;
    Some(handle.lock().unwrap_or_else(|poisoned| {
        handle.clear_poison();
        let mut inst = poisoned.into_inner();
        inst.reset();
        inst
    }))
}

/// `f0r_init`: nothing to set up (the GPU is opened by the first frame).
#[unsafe(no_mangle)]
pub extern "C" fn f0r_init() -> c_int {
    1
}

/// `f0r_deinit`.
#[unsafe(no_mangle)]
pub extern "C" fn f0r_deinit() {}

/// `f0r_get_plugin_info`.
///
/// # Safety
/// `info` is null or points to a writable `f0r_plugin_info_t`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn f0r_get_plugin_info(info: *mut PluginInfo) {
    guarded("f0r_get_plugin_info", (), || {
        // SAFETY: by the contract above.
        let Some(info) = (unsafe { info.as_mut() }) else {
            return;
        };
        *info = PluginInfo {
            name: c"rain-composite".as_ptr(),
            author: c"rain-composite authors".as_ptr(),
            plugin_type: abi::PLUGIN_TYPE_FILTER,
            color_model: COLOR_MODEL_RGBA8888,
            frei0r_version: FREI0R_MAJOR_VERSION,
            major_version: 0,
            minor_version: 1,
            num_params: SPECS.len() as c_int,
            explanation: c"Physically based rain, lit by the frame: stateless drops sized and timed like real rain, drawn as motion-blurred streaks"
                .as_ptr(),
        };
    });
}

/// `f0r_get_param_info`.
///
/// # Safety
/// `info` is null or points to a writable `f0r_param_info_t`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn f0r_get_param_info(info: *mut ParamInfo, param_index: c_int) {
    guarded("f0r_get_param_info", (), || {
        // SAFETY: by the contract above.
        let Some(info) = (unsafe { info.as_mut() }) else {
            return;
        };
        let Some((_, spec)) = spec_of(param_index) else {
            return;
        };
        *info = ParamInfo {
            name: spec.name.as_ptr(),
            kind: spec.kind,
            explanation: spec.explanation.as_ptr(),
        };
    });
}

/// `f0r_construct`: an instance for frames of `width`×`height` (cheap: hosts construct one
/// just to read the defaults).
#[unsafe(no_mangle)]
pub extern "C" fn f0r_construct(width: c_uint, height: c_uint) -> *mut c_void {
    guarded("f0r_construct", std::ptr::null_mut(), || {
        Box::into_raw(Box::new(Handle::new(Instance::new(width, height)))) as *mut c_void
    })
}

/// `f0r_destruct`.
///
/// # Safety
/// `instance` is null or came from [`f0r_construct`] and was not destructed.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn f0r_destruct(instance: *mut c_void) {
    guarded("f0r_destruct", (), || {
        if !instance.is_null() {
            // SAFETY: by the contract above, it is the Box `f0r_construct` leaked.
            drop(unsafe { Box::from_raw(instance as *mut Handle) });
        }
    });
}

/// The parameter a host names by `param_index`, with its index; `None` outside the table.
fn spec_of(param_index: c_int) -> Option<(usize, &'static params::Spec)> {
    let i = usize::try_from(param_index).ok()?;
    SPECS.get(i).map(|s| (i, s))
}

/// `f0r_set_param_value`. A number that is not finite, or a null string, is ignored.
///
/// # Safety
/// `instance` as for [`f0r_destruct`]; `param` is null or points to the parameter's type
/// (`double`, `f0r_param_position_t`, or a `char*` to a NUL-terminated string).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn f0r_set_param_value(
    instance: *mut c_void,
    param: *mut c_void,
    param_index: c_int,
) {
    guarded("f0r_set_param_value", (), || {
        // SAFETY: by the contract above.
        let Some(mut inst) = (unsafe { self::instance(instance) }) else {
            return;
        };
        let Some((i, spec)) = spec_of(param_index) else {
            return;
        };
        if param.is_null() {
            return;
        }
        let p = &mut inst.params;
        match spec.kind {
            PARAM_DOUBLE | PARAM_BOOL => {
                // SAFETY: a double parameter points to a double.
                let v = unsafe { *(param as *const f64) };
                if v.is_finite() {
                    p.numbers[i] = v;
                } else {
                    log_once(&format!("{}: {v} is not a number; kept", name(i)));
                }
            }
            PARAM_POSITION => {
                // SAFETY: a position parameter points to two doubles.
                let v = unsafe { *(param as *const Position) };
                if v.x.is_finite() && v.y.is_finite() {
                    p.horizon = [v.x, v.y];
                }
            }
            PARAM_STRING => {
                // SAFETY: a string parameter points to a `char*`, null or NUL-terminated.
                let s = unsafe { *(param as *const *const c_char) };
                if s.is_null() {
                    return;
                }
                // SAFETY: as above.
                let s = unsafe { CStr::from_ptr(s) }.to_owned();
                match i {
                    index::PRESET => p.preset = s,
                    _ => p.streaks = s,
                }
            }
            _ => {}
        }
    });
}

/// `f0r_get_param_value`: strings stay valid until the parameter is set again.
///
/// # Safety
/// As for [`f0r_set_param_value`], with `param` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn f0r_get_param_value(
    instance: *mut c_void,
    param: *mut c_void,
    param_index: c_int,
) {
    guarded("f0r_get_param_value", (), || {
        // SAFETY: by the contract above.
        let Some(inst) = (unsafe { self::instance(instance) }) else {
            return;
        };
        let Some((i, spec)) = spec_of(param_index) else {
            return;
        };
        if param.is_null() {
            return;
        }
        let p = &inst.params;
        // SAFETY (all three): `param` points to the parameter's type, writable.
        match spec.kind {
            PARAM_DOUBLE | PARAM_BOOL => unsafe { *(param as *mut f64) = p.numbers[i] },
            PARAM_POSITION => unsafe {
                *(param as *mut Position) = Position {
                    x: p.horizon[0],
                    y: p.horizon[1],
                }
            },
            PARAM_STRING => {
                let s: &CString = if i == index::PRESET {
                    &p.preset
                } else {
                    &p.streaks
                };
                unsafe { *(param as *mut *const c_char) = s.as_ptr() }
            }
            _ => {}
        }
    });
}

fn name(i: usize) -> String {
    SPECS[i].name.to_string_lossy().into_owned()
}

/// `f0r_update`: the frame shown at `time` (the host's clock) with rain.
///
/// # Safety
/// `instance` as for [`f0r_destruct`]; `inframe` and `outframe` are null or hold
/// width × height pixels of the size the instance was constructed with.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn f0r_update(
    instance: *mut c_void,
    time: f64,
    inframe: *const u32,
    outframe: *mut u32,
) {
    // SAFETY: the caller's contract is this function's.
    unsafe { update(instance, time, inframe, outframe) }
}

/// `f0r_update2`: as [`f0r_update`] with the first input (GStreamer calls this one).
///
/// # Safety
/// As for [`f0r_update`]; the second and third inputs are not read.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn f0r_update2(
    instance: *mut c_void,
    time: f64,
    inframe1: *const u32,
    _inframe2: *const u32,
    _inframe3: *const u32,
    outframe: *mut u32,
) {
    // SAFETY: the caller's contract is this function's.
    unsafe { update(instance, time, inframe1, outframe) }
}

/// # Safety
/// As for [`f0r_update`].
unsafe fn update(instance: *mut c_void, time: f64, inframe: *const u32, outframe: *mut u32) {
    if inframe.is_null() || outframe.is_null() {
        return;
    }
    // The frame size, read under the lock; a panic inside leaves the frame to the fallback.
    let mut bytes = 0usize;
    let rendered = guarded("rendering a frame", false, || {
        // SAFETY: by the contract above.
        let Some(mut inst) = (unsafe { self::instance(instance) }) else {
            return false;
        };
        bytes = inst.frame_bytes();
        // SAFETY: the host's frames hold `bytes` bytes each. A host that filters in place
        // passes one buffer for both: the input is copied first so the two never alias.
        let copy;
        let input: &[u8] = if inframe as *const u8 == outframe as *const u8 {
            copy = unsafe { std::slice::from_raw_parts(inframe as *const u8, bytes) }.to_vec();
            &copy
        } else {
            unsafe { std::slice::from_raw_parts(inframe as *const u8, bytes) }
        };
        let output = unsafe { std::slice::from_raw_parts_mut(outframe as *mut u8, bytes) };
        match inst.update(time, input, output) {
            Outcome::Rendered { t_s, fallback } => {
                if fallback {
                    log_once(&format!(
                        "the host's time {time} is not a time; the rain counts frames instead"
                    ));
                }
                if tracing() {
                    eprintln!("rain-composite (frei0r): host time {time} -> shot time {t_s} s");
                }
            }
            Outcome::PassedThrough(why) => {
                log_once(&format!("frames pass through without rain: {why}"));
            }
        }
        true
    });
    if !rendered && bytes > 0 {
        // SAFETY: both hold `bytes` bytes; `copy` allows them to be the same buffer.
        unsafe { std::ptr::copy(inframe as *const u8, outframe as *mut u8, bytes) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_send<T: Send>() {}

    /// An instance may move between the host's threads.
    #[test]
    fn instances_are_send() {
        assert_send::<Instance>();
    }

    /// The C entry points: info, parameters round trip, bad input ignored, no panic escapes.
    #[test]
    fn entry_points_describe_and_keep_parameters() {
        let mut info = PluginInfo {
            name: std::ptr::null(),
            author: std::ptr::null(),
            plugin_type: -1,
            color_model: -1,
            frei0r_version: 0,
            major_version: 0,
            minor_version: 0,
            num_params: 0,
            explanation: std::ptr::null(),
        };
        unsafe { f0r_get_plugin_info(&mut info) };
        assert_eq!((info.plugin_type, info.color_model), (0, 1));
        assert_eq!(info.num_params as usize, SPECS.len());
        let mut names = Vec::new();
        for i in 0..info.num_params {
            let mut p = ParamInfo {
                name: std::ptr::null(),
                kind: -1,
                explanation: std::ptr::null(),
            };
            unsafe { f0r_get_param_info(&mut p, i) };
            names.push(
                unsafe { CStr::from_ptr(p.name) }
                    .to_str()
                    .unwrap()
                    .to_string(),
            );
        }
        assert_eq!(names[0], "rain_rate");
        let inst = f0r_construct(4, 2);
        let mut v = 0.3f64;
        unsafe { f0r_set_param_value(inst, &mut v as *mut f64 as *mut c_void, 0) };
        let mut nan = f64::NAN;
        unsafe { f0r_set_param_value(inst, &mut nan as *mut f64 as *mut c_void, 0) };
        let storm = c"storm";
        let mut s = storm.as_ptr();
        unsafe { f0r_set_param_value(inst, &mut s as *mut *const c_char as *mut c_void, 4) };
        let mut back = 0.0f64;
        unsafe { f0r_get_param_value(inst, &mut back as *mut f64 as *mut c_void, 0) };
        assert_eq!(back, 0.3);
        let mut got: *const c_char = std::ptr::null();
        unsafe { f0r_get_param_value(inst, &mut got as *mut *const c_char as *mut c_void, 4) };
        assert_eq!(unsafe { CStr::from_ptr(got) }, storm);
        // Out of range indices and null pointers are ignored.
        unsafe { f0r_set_param_value(inst, std::ptr::null_mut(), 0) };
        unsafe { f0r_set_param_value(inst, &mut v as *mut f64 as *mut c_void, 99) };
        unsafe { f0r_get_param_info(std::ptr::null_mut(), 0) };
        unsafe { f0r_update(inst, 0.0, std::ptr::null(), std::ptr::null_mut()) };
        unsafe { f0r_destruct(inst) };
    }
}
