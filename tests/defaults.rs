//! One place for each default: the library's `Default` impls. The binary's help, the full
//! option tables of docs/guide/options.md and the README's short table of the most used options
//! must say the same; these tests read all three and compare.

use std::collections::BTreeMap;
use std::process::Command;

/// The binary's table of settings and their flags.
#[path = "../src/bin/rain-composite/flags.rs"]
#[allow(dead_code)]
mod flags;

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

/// The full option tables, with units and every default.
const OPTIONS_GUIDE: &str = include_str!("../docs/guide/options.md");
/// The README, with its short table of the most used options.
const README: &str = include_str!("../README.md");

/// The cells of a Markdown table row, trimmed; `\|` inside a cell is not a separator.
fn cells(line: &str) -> Vec<String> {
    let row = line.trim();
    let row = row.strip_prefix('|').unwrap_or(row);
    let row = row.strip_suffix('|').unwrap_or(row);
    let mut cells = vec![String::new()];
    let mut escaped = false;
    for c in row.chars() {
        match c {
            '|' if !escaped => cells.push(String::new()),
            _ => cells.last_mut().expect("a cell").push(c),
        }
        escaped = c == '\\';
    }
    cells.into_iter().map(|c| c.trim().to_string()).collect()
}

/// The option tables of a Markdown text: (first option name of the row, its `default` cell),
/// from every table whose header's first cell is `option` and which has a `default` column.
fn option_rows(markdown: &str) -> Vec<(String, String)> {
    let mut rows = Vec::new();
    let mut default_col = None;
    for line in markdown.lines() {
        if !line.trim_start().starts_with('|') {
            default_col = None;
            continue;
        }
        let cells = cells(line);
        if cells.first().map(String::as_str) == Some("option") {
            default_col = cells.iter().position(|c| c == "default");
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
        let default = cells.get(col).map_or("", |c| c.as_str());
        rows.push((name, default.trim_matches('`').to_string()));
    }
    rows
}

/// docs/guide/options.md's tables: every option of a render.
fn guide_defaults() -> Vec<(String, String)> {
    let rows = option_rows(OPTIONS_GUIDE);
    assert!(
        rows.len() > 40,
        "docs/guide/options.md's option tables not found: {rows:?}"
    );
    rows
}

/// The README's short table of the most used options.
fn readme_defaults() -> Vec<(String, String)> {
    let rows = option_rows(README);
    assert!(
        rows.len() >= 10,
        "the README's table of the most used options not found: {rows:?}"
    );
    rows
}

/// What `rows` (from `source`) say that the help does not: an option the help lacks, or a
/// default other than the help's `[default: …]` (rows of options without one are not checked).
fn disagreements(
    source: &str,
    rows: &[(String, String)],
    help: &BTreeMap<String, Option<String>>,
) -> Vec<String> {
    let mut wrong = Vec::new();
    for (name, default) in rows {
        match help.get(name) {
            None => wrong.push(format!(
                "{source} lists {name}, which `rain-composite -h` lacks"
            )),
            Some(Some(shown)) if shown != default => wrong.push(format!(
                "{source} gives {name} the default {default:?}, the help {shown:?}"
            )),
            Some(_) => {}
        }
    }
    wrong
}

/// Every default the options guide lists is the one the help shows, and every option it names
/// exists.
#[test]
fn options_guide_matches_the_help() {
    let wrong = disagreements("docs/guide/options.md", &guide_defaults(), &help_defaults());
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// The same for the README's short table.
#[test]
fn readme_table_matches_the_help() {
    let wrong = disagreements("README.md", &readme_defaults(), &help_defaults());
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// Every option of the README's short table is in the options guide, with the same default
/// (also where the help shows none, such as `off` or `all`).
#[test]
fn readme_table_agrees_with_the_options_guide() {
    let guide: BTreeMap<String, String> = guide_defaults().into_iter().collect();
    for (name, default) in readme_defaults() {
        assert_eq!(
            guide.get(&name),
            Some(&default),
            "README's table gives {name} the default {default:?}; docs/guide/options.md should too"
        );
    }
}

/// The checks above fail on a wrong table: a changed default, an option that does not exist.
#[test]
fn a_wrong_table_is_caught() {
    let table = "| option | unit | default | meaning |\n|---|---|---|---|\n\
                 | `--rain R` | mm/h | 11 | rain rate |\n\
                 | `--config NAME\\|FILE` | — | — | a preset |\n\
                 | `--no-such-option` | — | 0 | none |\n";
    let rows = option_rows(table);
    assert_eq!(
        rows,
        [
            ("--rain".to_string(), "11".to_string()),
            ("--config".to_string(), "—".to_string()),
            ("--no-such-option".to_string(), "0".to_string()),
        ]
    );
    let wrong = disagreements("the sample", &rows, &help_defaults());
    assert_eq!(wrong.len(), 2, "{wrong:?}");
    assert!(wrong[0].contains("--rain") && wrong[1].contains("--no-such-option"));
}

/// The help's defaults are the library's: every rain and camera value of
/// `RenderConfig::default()` and the encoder's `EncodeOptions::default()`; and the options
/// guide lists each of them.
#[test]
fn help_shows_the_library_defaults() {
    let help = help_defaults();
    let guide: BTreeMap<String, String> = guide_defaults().into_iter().collect();
    let e = EncodeOptions::default();
    let mut expected: Vec<(&str, String)> = RenderConfig::default()
        .setting_values()
        .into_iter()
        .filter_map(|(key, value)| Some((flags::option_of(key)?, value)))
        .collect();
    expected.push(("--crf", e.crf.to_string()));
    expected.push(("--preset", e.preset.clone()));
    for (flag, value) in expected {
        assert_eq!(
            help.get(flag),
            Some(&Some(value.clone())),
            "help of {flag} should end in [default: {value}]"
        );
        assert_eq!(
            guide.get(flag),
            Some(&value),
            "docs/guide/options.md's tables should list {flag} with default {value}"
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
