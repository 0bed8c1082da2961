//! One place for each default: the library's `Default` impls. The binary's help and the
//! README's option tables must say the same; these tests read both and compare.

use std::collections::BTreeMap;
use std::process::Command;

use rain_composite::config::RenderConfig;
use rain_composite::video::EncodeOptions;

/// Each option of `rain-composite -h` (long and short names) → its `[default: …]`, if any.
fn help_defaults() -> BTreeMap<String, Option<String>> {
    let out = Command::new(env!("CARGO_BIN_EXE_rain-composite"))
        .arg("-h")
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .expect("spawn");
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).expect("utf-8 help");
    // Entries: a line starting with `-` (after indentation) names the option; its help runs
    // on (the same line or the following, more indented ones) until the next entry.
    let mut entries: Vec<(Vec<String>, String)> = Vec::new();
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with('-') && line.len() - t.len() <= 6 {
            let spec = t.split("  ").next().unwrap_or(t);
            let names = spec
                .split([',', ' '])
                .filter(|w| w.starts_with('-'))
                .map(|w| {
                    // `--flag[=<VALUE>]`: an optional value is not part of the name.
                    let w = w.split("[=").next().unwrap_or(w);
                    w.trim_end_matches("...").to_string()
                })
                .collect();
            entries.push((names, t[spec.len()..].to_string()));
        } else if let Some((_, help)) = entries.last_mut() {
            if t.is_empty() || !line.starts_with(' ') {
                continue;
            }
            help.push(' ');
            help.push_str(t);
        }
    }
    let mut map = BTreeMap::new();
    for (names, help) in entries {
        let default = help.split_once("[default: ").map(|(_, rest)| {
            let end = rest.find(']').expect("closed [default: …]");
            rest[..end].to_string()
        });
        for n in names {
            map.insert(n, default.clone());
        }
    }
    map
}

/// The README's option tables: (first option name of the row, its `default` cell).
fn readme_defaults() -> Vec<(String, String)> {
    let readme = include_str!("../README.md");
    let section = readme
        .split("### Options")
        .nth(1)
        .expect("README has an Options section");
    let section = section.split("\n### ").next().unwrap_or(section);
    let mut rows = Vec::new();
    let mut default_col = None;
    for line in section.lines() {
        let cells: Vec<&str> = line.trim().trim_matches('|').split('|').collect();
        if !line.trim_start().starts_with('|') {
            default_col = None;
            continue;
        }
        let cells: Vec<&str> = cells.iter().map(|c| c.trim()).collect();
        if cells.first() == Some(&"option") {
            default_col = cells.iter().position(|c| *c == "default");
            continue;
        }
        let (Some(col), Some(first)) = (default_col, cells.first()) else {
            continue;
        };
        if first.starts_with("---") {
            continue;
        }
        let name = first
            .trim_matches('`')
            .split([' ', '`', '['])
            .next()
            .expect("an option name")
            .to_string();
        rows.push((name, cells[col].trim_matches('`').to_string()));
    }
    assert!(rows.len() > 20, "README option tables not found: {rows:?}");
    rows
}

/// Every default the README lists is the one the help shows, and every option it names exists.
#[test]
fn readme_table_matches_the_help() {
    let help = help_defaults();
    for (name, readme_default) in readme_defaults() {
        let shown = help
            .get(&name)
            .unwrap_or_else(|| panic!("README lists {name}, which `rain-composite -h` lacks"));
        if let Some(shown) = shown {
            assert_eq!(
                &readme_default, shown,
                "README's default of {name} differs from the help's"
            );
        }
    }
}

/// The help's defaults are the library's: every rain and camera value of
/// `RenderConfig::default()` and the encoder's `EncodeOptions::default()`; and the README
/// lists each of them.
#[test]
fn help_shows_the_library_defaults() {
    let help = help_defaults();
    let readme: BTreeMap<String, String> = readme_defaults().into_iter().collect();
    let e = EncodeOptions::default();
    let mut expected = RenderConfig::default().flag_values();
    expected.push(("--crf", e.crf.to_string()));
    expected.push(("--preset", e.preset.clone()));
    for (flag, value) in expected {
        assert_eq!(
            help.get(flag),
            Some(&Some(value.clone())),
            "help of {flag} should end in [default: {value}]"
        );
        assert_eq!(
            readme.get(flag),
            Some(&value),
            "README's table should list {flag} with default {value}"
        );
    }
}

/// `samples/presets/default.json` is the built-in configuration written out, field by field.
#[test]
fn the_default_preset_is_the_built_in_configuration() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/presets/default.json");
    let text = std::fs::read_to_string(path).expect("default.json");
    let preset = rain_composite::config::RenderConfig::from_json(&text).expect("parses");
    let built_in = rain_composite::config::RenderConfig::default();
    if preset != built_in {
        panic!(
            "default.json differs from the built-in defaults; write it as:\n{}",
            serde_json::to_string_pretty(&built_in).expect("json")
        );
    }
}
