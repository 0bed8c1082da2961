//! The library's shape, checked: its modules are layered (a module imports only the modules
//! below it, so no import circle can form between folders), no source file grows past what one
//! reader holds, and `docs/ARCHITECTURE.md` maps every file.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The library's top-level modules, lowest first: each may import only those before it.
const LAYERS: &[&str] = &[
    "error",
    "rng",
    "keyframes",
    "files",
    "video",
    "scene",
    "rain",
    "lighting",
    "drops",
    "config",
    "preset",
    "fluid",
    "shot",
    "gpu",
    "pipeline",
    "inspect",
];

/// Most lines a source file may have.
const MAX_FILE_LINES: usize = 900;

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// Every `.rs` file under `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).expect("readable source tree") {
            let path = entry.expect("a directory entry").path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// The top-level module a library file belongs to (`src/gpu/stages/mod.rs` → `gpu`); `None`
/// for the crate root and the binary.
fn top_module(path: &Path) -> Option<String> {
    let rel = path.strip_prefix(src()).ok()?;
    let first = rel.components().next()?.as_os_str().to_str()?;
    match first {
        "lib.rs" | "bin" => None,
        f => Some(f.trim_end_matches(".rs").to_string()),
    }
}

/// The code of a file without its comments and its unit tests (which may reach anywhere).
fn code_of(text: &str) -> String {
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => &text[..i],
        None => text,
    };
    text.lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The top-level modules a piece of code names: `crate::x` paths, and the first segments of
/// `use crate::{x::…, y, …}` groups.
fn imported_modules(code: &str) -> BTreeSet<String> {
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    let mut out = BTreeSet::new();
    for (i, _) in code.match_indices("crate::") {
        let rest = &code[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // Top-level entries of the group: split at commas outside nested braces.
            let mut depth = 0;
            let mut start = 0;
            for (k, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        out.insert(ident(group[start..k].trim()));
                        break;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        out.insert(ident(group[start..k].trim()));
                        start = k + 1;
                    }
                    _ => {}
                }
            }
        } else {
            out.insert(ident(rest));
        }
    }
    out.retain(|m| LAYERS.contains(&m.as_str()));
    out
}

/// Every library module imports only modules of lower layers.
#[test]
fn modules_import_only_the_layers_below_them() {
    let mut wrong = Vec::new();
    let mut seen = BTreeSet::new();
    for path in rust_files(&src()) {
        let Some(module) = top_module(&path) else {
            continue;
        };
        let level = LAYERS
            .iter()
            .position(|l| *l == module)
            .unwrap_or_else(|| panic!("{module} is missing from LAYERS"));
        seen.insert(module.clone());
        let code = code_of(&std::fs::read_to_string(&path).expect("readable"));
        for imported in imported_modules(&code) {
            let at = LAYERS
                .iter()
                .position(|l| *l == imported)
                .expect("filtered");
            if imported != module && at > level {
                wrong.push(format!(
                    "{} imports {imported}, a layer above {module}",
                    path.strip_prefix(src()).expect("under src").display()
                ));
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    let listed: BTreeSet<String> = LAYERS.iter().map(|s| s.to_string()).collect();
    assert_eq!(seen, listed, "LAYERS names a module that does not exist");
}

/// The import reader sees what it should: grouped, nested and plain paths.
#[test]
fn the_import_reader_finds_grouped_and_plain_paths() {
    let code = "use crate::{Error, Result, gpu::{A, b::C}, shot};\nlet x = crate::video::f();";
    let found = imported_modules(code);
    let want: BTreeSet<String> = ["gpu", "shot", "video"].map(String::from).into();
    assert_eq!(found, want);
    assert!(code_of("let a = 1; // crate::gpu\n").find("gpu").is_none());
}

/// No source file is longer than one reader holds.
#[test]
fn no_source_file_is_too_long() {
    let long: Vec<String> = rust_files(&src())
        .into_iter()
        .filter_map(|p| {
            let n = std::fs::read_to_string(&p)
                .expect("readable")
                .lines()
                .count();
            (n > MAX_FILE_LINES).then(|| format!("{} has {n} lines", p.display()))
        })
        .collect();
    assert!(long.is_empty(), "{}", long.join("\n"));
}

/// `docs/ARCHITECTURE.md`'s module map names every source file, and only files that exist.
#[test]
fn the_module_map_names_every_file() {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/ARCHITECTURE.md"))
            .expect("docs/ARCHITECTURE.md");
    let map = doc
        .split("## Module map")
        .nth(1)
        .expect("a Module map section");
    let named: BTreeSet<String> = map
        .lines()
        .filter_map(|l| l.trim_start().strip_prefix("- `"))
        .filter_map(|l| l.split('`').next())
        .map(String::from)
        .collect();
    let files: BTreeSet<String> = rust_files(&src())
        .iter()
        .map(|p| {
            p.strip_prefix(src())
                .expect("under src")
                .to_string_lossy()
                .replace('\\', "/")
        })
        .collect();
    let missing: Vec<_> = files.difference(&named).collect();
    let stale: Vec<_> = named.difference(&files).collect();
    assert!(
        missing.is_empty() && stale.is_empty(),
        "not in the module map: {missing:?}; in it but gone: {stale:?}"
    );
}
