//! Every relative link of the README and of docs/ points to a file that exists, and every
//! `#anchor` to a heading of its page (named as GitHub names headings), so the guides do not
//! drift from each other or from the tree as files move.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The Markdown pages checked: the README, everything under docs/, and the folders' own notes.
fn pages() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .expect("readable folder")
            .map(|e| e.expect("entry").path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|e| e == "md") {
                out.push(p);
            }
        }
    }
    let root = Path::new(ROOT);
    let mut pages = vec![root.join("README.md")];
    walk(&root.join("docs"), &mut pages);
    for extra in [
        "samples/README.md",
        "drops/README.md",
        "tests/data/README.md",
    ] {
        let p = root.join(extra);
        if p.is_file() {
            pages.push(p);
        }
    }
    pages
}

/// The text without code: fenced blocks, indented blocks after a blank line, inline spans (which
/// may run on to the next line of their paragraph).
fn prose(text: &str) -> String {
    let mut out = String::new();
    let (mut fenced, mut indented, mut blank_before) = (false, false, true);
    let mut in_span = false;
    for line in text.lines() {
        if line.trim().is_empty() {
            in_span = false;
        }
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            out.push('\n');
            continue;
        }
        let code_line = line.starts_with("    ") && (blank_before || indented);
        indented = code_line || (indented && line.trim().is_empty());
        blank_before = line.trim().is_empty();
        if fenced || code_line {
            out.push('\n');
            continue;
        }
        // Inline code spans hold no links.
        for c in line.chars() {
            if c == '`' {
                in_span = !in_span;
            } else if !in_span {
                out.push(c);
            }
        }
        out.push('\n');
    }
    out
}

/// GitHub's anchor of a heading: lower case, only letters, digits, marks, `_`, `-` and spaces
/// kept, spaces made `-`.
fn slug(heading: &str) -> String {
    // A link in a heading shows its text only.
    let mut text = String::new();
    let mut rest = heading;
    while let Some(i) = rest.find("](") {
        let Some(j) = rest[i..].find(')') else { break };
        text.push_str(&rest[..i]);
        rest = &rest[i + j + 1..];
    }
    text.push_str(rest);
    text.trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// The anchors of a page's headings (a repeated heading gets `-1`, `-2`, … as on GitHub).
fn anchors(page: &Path) -> BTreeSet<String> {
    let text = std::fs::read_to_string(page).expect("readable page");
    let mut seen: BTreeSet<String> = BTreeSet::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        }
        if fenced || !line.starts_with('#') {
            continue;
        }
        let heading = line.trim_start_matches('#');
        if !heading.starts_with(' ') {
            continue;
        }
        let base = slug(heading.trim().trim_end_matches('#'));
        let mut anchor = base.clone();
        let mut n = 0;
        while seen.contains(&anchor) {
            n += 1;
            anchor = format!("{base}-{n}");
        }
        seen.insert(anchor);
    }
    seen
}

/// The link targets of a page: what stands between `](` and the next `)` in its prose.
fn targets(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find("](") {
        rest = &rest[i + 2..];
        let end = rest.find([')', ' ', '\n']).unwrap_or(rest.len());
        out.push(rest[..end].to_string());
        rest = &rest[end..];
    }
    out
}

#[test]
fn relative_links_point_to_files_and_headings_that_exist() {
    let mut broken = Vec::new();
    let mut checked = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).expect("readable page");
        for target in targets(&prose(&text)) {
            // A scheme (https:, mailto:) is outside the tree.
            if target
                .split(['/', '#'])
                .next()
                .is_some_and(|s| s.contains(':'))
            {
                continue;
            }
            checked += 1;
            let (path, anchor) = target.split_once('#').unwrap_or((&target, ""));
            let file = if path.is_empty() {
                page.clone()
            } else {
                page.parent().expect("a folder").join(path)
            };
            let name = page
                .strip_prefix(ROOT)
                .unwrap_or(&page)
                .display()
                .to_string();
            if !file.exists() {
                broken.push(format!("{name}: {target}: no such file"));
            } else if !anchor.is_empty()
                && (file.extension().is_none_or(|e| e != "md") || !anchors(&file).contains(anchor))
            {
                broken.push(format!("{name}: {target}: no such heading"));
            }
        }
    }
    assert!(
        checked > 100,
        "only {checked} links found: is the parser right?"
    );
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn anchors_are_named_as_github_names_them() {
    assert_eq!(
        slug("Two commands (fresh Debian 12, Rust ≥ 1.87 installed)"),
        "two-commands-fresh-debian-12-rust--187-installed"
    );
    assert_eq!(
        slug("Estimating it: `--ground auto`"),
        "estimating-it---ground-auto"
    );
    assert_eq!(
        slug("7.1 SPH (thesis §3.2 and §5.3.1, after Müller, Charypar & Gross 2003)"),
        "71-sph-thesis-32-and-531-after-müller-charypar--gross-2003"
    );
    assert_eq!(
        targets("see [a](b.md#c) and ![i](../x.png), not `[d](e.md)`"),
        ["b.md#c", "../x.png", "e.md"]
    );
    assert_eq!(
        targets(&prose("see `[d](e.md)` and\n\n    [f](g.md)\n")),
        Vec::<String>::new()
    );
    assert_eq!(
        targets(&prose("a `code\nspan` then [h](i.md), `one` [j](k.md)\n")),
        ["i.md", "k.md"]
    );
}
