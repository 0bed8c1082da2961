//! The library's messages as the command line says them: the library names settings by their
//! keys (`camera.fov_deg`) and phrases its errors without flags; here each key of the table in
//! `flags` becomes its flag (`--fov`) and each error names the flag that sets what it is about
//! (`invalid --config`, `use -y to overwrite`).

use rain_composite::Error;

use crate::flags;

/// The message of `e` and its causes, one line as `{e:#}` writes it, with each error of the
/// library in the command line's words.
pub fn for_user(e: &anyhow::Error) -> String {
    e.chain()
        .map(|cause| match cause.downcast_ref::<Error>() {
            Some(e) => library_error(e),
            None => cause.to_string(),
        })
        .collect::<Vec<_>>()
        .join(": ")
}

/// One error of the library in the command line's words.
pub fn library_error(e: &Error) -> String {
    match e {
        Error::Parameter {
            name,
            value,
            expected,
        } => format!(
            "invalid parameter {} = {value}: {}",
            flags::for_user(name),
            flags::in_prose(expected)
        ),
        Error::OverrideRange {
            assignment,
            name,
            value,
            expected,
            own,
        } => {
            let (name, expected) = (flags::for_user(name), flags::in_prose(expected));
            if *own {
                format!(
                    "invalid --set {assignment}: {value} is out of range: {expected} (the range \
                     of {name})"
                )
            } else {
                format!("invalid --set {assignment}: conflicts with {name} {value}: {expected}")
            }
        }
        // What the user typed, and the deserialiser's words about the configuration's keys.
        Error::Override { assignment, reason } => format!("invalid --set {assignment}: {reason}"),
        Error::Config { path, reason } => format!("invalid --config '{path}': {reason}"),
        Error::OutputExists(path) => format!(
            "output '{}' already exists (use -y to overwrite)",
            path.display()
        ),
        // The library's own prose.
        Error::OutOfRange(_) | Error::CorruptInput(_) | Error::Unsupported(_) => {
            flags::in_prose(&e.to_string())
        }
        e => e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Keys in prose become their flags, only whole keys.
    #[test]
    fn keys_in_prose_become_flags_only_whole() {
        assert_eq!(
            flags::in_prose("metres, ≥ 0.05 and below rain.far_m"),
            "metres, ≥ 0.05 and below --far"
        );
        assert_eq!(
            flags::in_prose("no camera.tilt_deg or camera.roll_deg besides it: ground.mode auto"),
            "no --tilt or --roll besides it: --ground auto"
        );
        assert_eq!(
            flags::in_prose("light.lights.distance_m, light.lights."),
            "--light distance, --light."
        );
        for kept in [
            "xrain.far_m",
            "rain.far_mm",
            "rain.far_m.x",
            "a.rain.far_m",
            "camera.pan_deg",
        ] {
            assert_eq!(flags::in_prose(kept), kept);
        }
    }

    /// Errors name the flag of their setting, in their name and their prose; what the user
    /// typed is left as it is.
    #[test]
    fn library_errors_name_flags() {
        let e = Error::Parameter {
            name: "rain.near_m",
            value: "5".into(),
            expected: "metres, ≥ 0.05 and below rain.far_m".into(),
        };
        assert_eq!(
            library_error(&e),
            "invalid parameter --near = 5: metres, ≥ 0.05 and below --far"
        );
        let e = Error::OverrideRange {
            assignment: "camera.fov_deg=200".into(),
            name: "camera.fov_deg",
            value: "200".into(),
            expected: "degrees in (1, 170)".into(),
            own: true,
        };
        assert_eq!(
            library_error(&e),
            "invalid --set camera.fov_deg=200: 200 is out of range: degrees in (1, 170) (the \
             range of --fov)"
        );
        let e = Error::Override {
            assignment: "rain.rate_mm_per_h.x=5".into(),
            reason: "rain.rate_mm_per_h is a single value, it has no key 'x'".into(),
        };
        assert_eq!(
            library_error(&e),
            "invalid --set rain.rate_mm_per_h.x=5: rain.rate_mm_per_h is a single value, it has \
             no key 'x'"
        );
        let e = anyhow::Error::from(Error::OutOfRange(
            "ground.depth has 3 depth maps, the clip has a frame 4 (counting from 0)".into(),
        ))
        .context("frame 4");
        assert_eq!(
            for_user(&e),
            "frame 4: --depth has 3 depth maps, the clip has a frame 4 (counting from 0)"
        );
        // A name that is no key of the table is shown as it is.
        let e = Error::Parameter {
            name: "camera.pan_deg",
            value: "400".into(),
            expected: "degrees in [-360, 360]".into(),
        };
        assert!(library_error(&e).contains("camera.pan_deg = 400"));
    }

    /// The keys the encoder, the job and the pipeline will name read as the flags they name
    /// today.
    #[test]
    fn keys_of_other_values_read_as_their_flags() {
        for (name, flag) in [
            ("encode.preset", "--preset"),
            ("encode.encoder_params", "--encoder-params"),
            ("encode.crf", "--crf"),
            ("encode.container", "--format"),
            ("job.output", "--output"),
            ("job.frames", "--frames/--from/--to"),
            ("job.at", "--at"),
            ("camera.shutter_deg", "--shutter"),
            ("rain.streaks", "--streaks"),
            ("ground.depth", "--depth"),
        ] {
            let e = Error::Parameter {
                name,
                value: "x".into(),
                expected: "y".into(),
            };
            assert_eq!(
                library_error(&e),
                format!("invalid parameter {flag} = x: y")
            );
        }
        for (library, user) in [
            (
                "a streak database, and none is installed: pass streak_db DIR",
                "a streak database, and none is installed: pass --streak-db DIR",
            ),
            (
                "a video file; image sequences are written for encode.layer or encode.matte",
                "a video file; image sequences are written for --layer-only or --matte",
            ),
        ] {
            let e = Error::Parameter {
                name: "job.output",
                value: "x".into(),
                expected: library.into(),
            };
            assert!(library_error(&e).ends_with(user), "{}", library_error(&e));
        }
        let e = Error::CorruptInput("ground.mode auto: no frame could be decoded".into());
        assert_eq!(
            library_error(&e),
            "the input is truncated or corrupt: --ground auto: no frame could be decoded"
        );
        let e = Error::Unsupported(
            "encode.matte writes an alpha layer, which mp4 output with encode.codec libx264 \
             cannot hold: leave encode.codec out"
                .into(),
        );
        assert_eq!(
            library_error(&e),
            "unsupported: --matte writes an alpha layer, which mp4 output with --codec libx264 \
             cannot hold: leave --codec out"
        );
        assert_eq!(
            crate::flags::in_prose("rain.max_drops 3000000 is more than this GPU holds"),
            "--max-drops 3000000 is more than this GPU holds"
        );
        assert_eq!(
            crate::flags::in_prose("ground.puddles: the picture shows no ground within reach"),
            "--puddles: the picture shows no ground within reach"
        );
    }
}
