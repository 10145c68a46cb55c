//! The library's layering, checked: every top-level module of `src/` has a
//! layer, and a module may name (`crate::m…`) only modules of lower layers.
//! The table below is the layering ARCHITECTURE.md documents; a new module
//! must be placed in it, and an import that points upwards (or sideways,
//! within one layer) fails with the file, the line and both layers.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Bottom to top. Modules on one line share a layer and may not import
/// each other.
const LAYERS: &[&[&str]] = &[
    &["math"],
    &["stats", "shading"],
    &["shape", "camera", "material", "sampler", "film"],
    &["light"],
    &["accel"],
    &["scene"],
    &["lighting", "workload"],
    &["gi"],
    &["integrator"],
    &["io", "gpu"],
    &["analysis", "diff"],
    &["validate"],
    &["experiment"],
    &["report"],
];

fn layer_of() -> BTreeMap<&'static str, usize> {
    LAYERS
        .iter()
        .enumerate()
        .flat_map(|(i, mods)| mods.iter().map(move |m| (*m, i)))
        .collect()
}

/// Top-level modules of `src/` (files and folders; lib.rs and main.rs are
/// not modules) with their source files.
fn modules(src: &Path) -> BTreeMap<String, Vec<PathBuf>> {
    let mut out = BTreeMap::new();
    for e in std::fs::read_dir(src).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_stem().unwrap().to_string_lossy().to_string();
        if p.is_dir() {
            let mut files = Vec::new();
            collect_rs(&p, &mut files);
            out.insert(name, files);
        } else if p.extension().is_some_and(|x| x == "rs") && name != "lib" && name != "main" {
            out.insert(name, vec![p]);
        }
    }
    out
}

fn collect_rs(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            collect_rs(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The top-level modules a line of code names through `crate::`: plain
/// paths (`crate::scene::Scene`) and groups (`use crate::{math::Vec3,
/// shape::{Hit, Shape}}`, possibly spread over several lines: `group`
/// carries the open group's depth from one line to the next).
fn named_modules(code: &str, group: &mut Option<usize>, out: &mut Vec<String>) {
    let chars: Vec<char> = code.chars().collect();
    let is_ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let ident_at = |i: usize| -> (String, usize) {
        let end = (i..chars.len())
            .find(|&k| !is_ident(chars[k]))
            .unwrap_or(chars.len());
        (chars[i..end].iter().collect(), end)
    };
    let mut i = 0;
    while i < chars.len() {
        if let Some(depth) = group.as_mut() {
            // Inside `crate::{ … }`: an identifier at depth 1 that starts an
            // item (after `{` or `,`) is a module.
            let c = chars[i];
            match c {
                '{' => *depth += 1,
                '}' => {
                    *depth -= 1;
                    if *depth == 0 {
                        *group = None;
                    }
                }
                _ if *depth == 1 && (c.is_ascii_alphabetic() || c == '_') => {
                    let prev = chars[..i].iter().rev().find(|c| !c.is_whitespace());
                    if matches!(prev, Some('{') | Some(',') | None) {
                        let (name, end) = ident_at(i);
                        out.push(name);
                        i = end;
                        continue;
                    }
                }
                _ => {}
            }
            i += 1;
            continue;
        }
        let rest: String = chars[i..chars.len().min(i + 7)].iter().collect();
        if rest == "crate::" && (i == 0 || !is_ident(chars[i - 1])) {
            if chars.get(i + 7) == Some(&'{') {
                *group = Some(1);
                i += 8;
                continue;
            }
            let (name, end) = ident_at(i + 7);
            out.push(name);
            i = end;
            continue;
        }
        i += 1;
    }
}

/// Code of a line: without `//` comments (doc links may point anywhere)
/// and without the contents of string literals.
fn code_of(line: &str) -> String {
    let mut out = String::new();
    let mut in_str = false;
    let mut prev = ' ';
    let chars: Vec<char> = line.chars().collect();
    let mut k = 0;
    while k < chars.len() {
        let c = chars[k];
        if in_str {
            if c == '"' && prev != '\\' {
                in_str = false;
            }
        } else if c == '"' {
            in_str = true;
        } else if c == '/' && chars.get(k + 1) == Some(&'/') {
            break;
        } else {
            out.push(c);
        }
        prev = if prev == '\\' && c == '\\' { ' ' } else { c };
        k += 1;
    }
    out
}

#[test]
fn no_module_imports_upwards() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let layer = layer_of();
    let mods = modules(&src);
    let mut problems = Vec::new();
    for name in mods.keys() {
        if !layer.contains_key(name.as_str()) {
            problems.push(format!(
                "module `{name}` has no layer: place it in tests/layers.rs and ARCHITECTURE.md"
            ));
        }
    }
    for (name, files) in &mods {
        let Some(&own) = layer.get(name.as_str()) else {
            continue;
        };
        for f in files {
            let text = std::fs::read_to_string(f).unwrap();
            let mut group = None;
            for (n, line) in text.lines().enumerate() {
                let mut named = Vec::new();
                named_modules(&code_of(line), &mut group, &mut named);
                for m in named {
                    let Some(&theirs) = layer.get(m.as_str()) else {
                        continue; // not a top-level module (e.g. a macro path)
                    };
                    if m != *name && theirs >= own {
                        problems.push(format!(
                            "{}:{}: `{name}` (layer {own}) names `{m}` (layer {theirs}): \
                             a module may use only lower layers",
                            f.strip_prefix(&src).unwrap_or(f).display(),
                            n + 1
                        ));
                    }
                }
            }
        }
    }
    assert!(
        problems.is_empty(),
        "layering broken:\n{}",
        problems.join("\n")
    );
}

/// The scanner itself: grouped imports over several lines, nested groups,
/// comments and strings.
#[test]
fn scanner_finds_grouped_and_plain_paths() {
    let mut group = None;
    let mut out = Vec::new();
    for line in [
        "use crate::{math::Vec3,",
        "    shape::{Hit, Shape}, // crate::nothing",
        "    stats};",
        "let x = crate::scene::Scene::new(\"crate::fake\");",
    ] {
        named_modules(&code_of(line), &mut group, &mut out);
    }
    assert_eq!(out, ["math", "shape", "stats", "scene"]);
    assert!(group.is_none());
}
