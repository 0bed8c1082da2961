//! The command line's definition as the help, the completions and the manual page show it:
//! each flag of a setting ends its help in the library's default, the flag found by the
//! setting's key in the table of `flags`.

use clap::{CommandFactory, FromArgMatches};
use rain_composite::config::RenderConfig;

use super::Cli;
use crate::flags;

/// Parses the command line (exiting with clap's message on an error), with each setting's
/// flag's help ending in its default (see [`flag_values`]).
pub fn parse() -> Cli {
    let matches = command().get_matches();
    Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
}

/// The command line's definition as the help, the completions and the manual page show it.
pub fn command() -> clap::Command {
    with_look_defaults(Cli::command(), &flag_values(&RenderConfig::default()))
}

/// Each value of `config` that a flag sets, under that flag (`("--wind", "3,-1")`): the
/// library's [`RenderConfig::setting_values`], each key replaced by its flag in the table.
pub fn flag_values(config: &RenderConfig) -> Vec<(&'static str, String)> {
    config
        .setting_values()
        .into_iter()
        .filter_map(|(key, value)| Some((flags::option_of(key)?, value)))
        .collect()
}

/// Appends `[default: …]` to the help of each flag of `defaults` in `command` and its
/// subcommands that flatten [`LookArgs`](super::LookArgs), which is exactly when they have
/// `--config`; flags there that carry a clap default of their own (none today) are left alone.
fn with_look_defaults(mut command: clap::Command, defaults: &[(&str, String)]) -> clap::Command {
    if command
        .get_arguments()
        .any(|a| a.get_long() == Some("config"))
    {
        for (flag, value) in defaults {
            let long = flag.trim_start_matches("--");
            let id = command
                .get_arguments()
                .find(|a| a.get_long() == Some(long) && a.get_default_values().is_empty())
                .map(|a| a.get_id().clone());
            if let Some(id) = id {
                command = command.mut_arg(id, |a| {
                    // clap drops the final period of a one-line doc comment; the default
                    // follows the sentence.
                    let help = a.get_help().map(|h| h.to_string()).unwrap_or_default();
                    a.help(format!("{help}. [default: {value}]"))
                });
            }
        }
    }
    let names: Vec<String> = command
        .get_subcommands()
        .map(|s| s.get_name().to_string())
        .collect();
    for name in names {
        command = command.mut_subcommand(name, |s| with_look_defaults(s, defaults));
    }
    command
}

#[cfg(test)]
mod tests {
    use std::collections::{BTreeMap, BTreeSet};

    use super::*;
    use crate::flags::{FLAGS, NON_CONFIG};

    /// Every long flag of the command line, in any subcommand, with the names of its values
    /// (empty for a switch).
    fn clap_flags() -> BTreeMap<String, BTreeSet<String>> {
        fn walk(c: &clap::Command, into: &mut BTreeMap<String, BTreeSet<String>>) {
            for a in c.get_arguments() {
                if let Some(long) = a.get_long() {
                    let takes_value = a.get_num_args().is_some_and(|n| n.max_values() > 0);
                    let value = match a.get_value_names() {
                        Some(names) if takes_value => names
                            .iter()
                            .map(|n| n.to_string())
                            .collect::<Vec<_>>()
                            .join(","),
                        _ if takes_value => a.get_id().as_str().to_uppercase(),
                        _ => String::new(),
                    };
                    into.entry(format!("--{long}")).or_default().insert(value);
                }
            }
            for s in c.get_subcommands() {
                walk(s, into);
            }
        }
        let mut command = Cli::command();
        // Settles what clap infers, such as how many values each flag takes.
        command.build();
        let mut flags = BTreeMap::new();
        walk(&command, &mut flags);
        flags
    }

    /// The long flags of the argument group `group` (a flattened `Args` struct) of the render.
    fn group_flags(group: &str) -> Vec<String> {
        let command = Cli::command();
        let ids: Vec<_> = command
            .get_groups()
            .find(|g| g.get_id() == group)
            .unwrap_or_else(|| panic!("no group {group}"))
            .get_args()
            .cloned()
            .collect();
        command
            .get_arguments()
            .filter(|a| ids.contains(a.get_id()))
            .filter_map(|a| a.get_long().map(|l| format!("--{l}")))
            .collect()
    }

    /// The node of `key` in `tree`, the first element standing for any of a list.
    fn lookup<'a>(tree: &'a serde_json::Value, key: &str) -> Option<&'a serde_json::Value> {
        key.split('.').try_fold(tree, |node, part| match node {
            serde_json::Value::Array(items) => items.first()?.get(part),
            node => node.get(part),
        })
    }

    /// Each key and each flag has one row.
    #[test]
    fn each_key_and_flag_is_listed_once() {
        for (i, f) in FLAGS.iter().enumerate() {
            assert!(
                FLAGS[..i]
                    .iter()
                    .all(|g| g.key != f.key && g.flag != f.flag),
                "{f:?} is listed twice"
            );
        }
        assert_eq!(
            crate::flags::option_of("rain.rate_mm_per_h"),
            Some("--rain")
        );
        assert_eq!(crate::flags::option_of("light.lights.azimuth_deg"), None);
        assert_eq!(crate::flags::option_of("job.frames"), None);
        assert_eq!(crate::flags::for_user("camera.pan_deg"), "camera.pan_deg");
    }

    /// Every flag that sets a value of the configuration or of the encoder is in the table;
    /// every key of the table is a key of the configuration (an element of a list standing
    /// for all) or under a documented prefix of other values; every flag of the table is the
    /// command line's, with the value the help names.
    #[test]
    fn the_table_covers_the_flags_and_names_real_keys() {
        let layering = ["--config", "--set"];
        for flag in group_flags("LookArgs")
            .into_iter()
            .chain(group_flags("EncodeArgs"))
            .filter(|f| !layering.contains(&f.as_str()))
        {
            assert!(
                FLAGS.iter().any(|f| f.flag == flag),
                "{flag} sets a value but is not in the table of flags.rs"
            );
        }
        let mut config = RenderConfig::default();
        config
            .light
            .lights
            .push(rain_composite::lighting::UserLight::default());
        let tree = config.to_value();
        for (prefix, _) in NON_CONFIG {
            let top = prefix.trim_end_matches('.');
            assert!(
                tree.get(top).is_none(),
                "{prefix} is a key of the configuration"
            );
        }
        let clap = clap_flags();
        for f in FLAGS {
            let documented = NON_CONFIG.iter().any(|(p, _)| f.key.starts_with(p));
            assert!(
                documented || lookup(&tree, f.key).is_some(),
                "{} is no key of the configuration (`config --print`)",
                f.key
            );
            let (flags, part) = match f.flag.split_once(' ') {
                Some((flag, _)) => (flag, true),
                None => (f.flag, false),
            };
            for flag in flags.split('/') {
                let values = clap
                    .get(flag)
                    .unwrap_or_else(|| panic!("{flag} of {} is no flag", f.key));
                if flag == flags.split('/').next().unwrap_or_default() {
                    assert!(
                        values.iter().any(|v| if part {
                            v.contains(f.value)
                        } else {
                            v == f.value
                        }),
                        "{flag} of {} names its value {values:?}, not {:?}",
                        f.key,
                        f.value
                    );
                }
            }
        }
    }

    /// The help of every setting's flag ends in the library's default.
    #[test]
    fn the_help_shows_the_library_defaults() {
        let help = command().render_help().to_string();
        let defaults = flag_values(&RenderConfig::default());
        assert!(defaults.len() > 25, "{defaults:?}");
        for (flag, value) in defaults {
            let line = help
                .lines()
                .skip_while(|l| {
                    let rest = l.trim_start().strip_prefix(flag);
                    !rest.is_some_and(|r| r.starts_with([' ', '[']))
                })
                .find(|l| l.contains("[default: "))
                .unwrap_or_else(|| panic!("{flag} has no default"));
            assert!(
                line.contains(&format!("[default: {value}]")),
                "{flag}: {line}"
            );
        }
    }
}
