//! The workspace's layering, checked at three levels (ARCHITECTURE.md draws
//! the same picture; a new crate or module must be placed in both):
//!
//! 1. **Crates.** `raylab` (the core) < `raylab-gpu` < `raylab-lab` <
//!    `raylab-cli`: each depends only on crates below it, and the core on
//!    none of the crates that plot, tabulate, hash, draw progress bars,
//!    parse command lines or drive a GPU.
//! 2. **Modules.** Within a crate every top-level module has a layer, and
//!    a module may name (`crate::m…`, or `super::…` reaching it) only
//!    modules of lower layers: an import upwards or sideways fails with the
//!    file, the line and both layers.
//! 3. **Files.** Within a crate no files import each other in a circle
//!    (`crate::`, `super::` and `self::` paths, resolved to the file that
//!    defines the module they name). A module's own folder is one unit
//!    with it: a `mod.rs` naming its children, or a child naming its
//!    parent's items, is not a circle.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The crates, bottom to top: folder under `crates/`, package name, and
/// its top-level modules' layers (bottom to top; modules on one line share
/// a layer and may not import each other).
const CRATES: &[(&str, &str, &[&[&str]])] = &[
    (
        "core",
        "raylab",
        &[
            &["error"],
            &["math"],
            &["stats", "shading"],
            &["shape", "camera", "material", "sampler", "film"],
            &["light"],
            &["accel"],
            &["scene"],
            &["lighting", "workload"],
            &["gi"],
            &["integrator"],
            &["io"],
            &["diff"],
        ],
    ),
    ("gpu", "raylab-gpu", &[&["error"], &["upload"]]),
    (
        "lab",
        "raylab-lab",
        &[&["analysis"], &["validate"], &["experiment"], &["report"]],
    ),
    ("cli", "raylab-cli", &[&["commands"]]),
];

/// What the renderer core must not pull in: plotting, tables, hashing,
/// progress bars, command lines, the GPU, and `anyhow` (typed errors below
/// the command line).
const NOT_IN_CORE: &[&str] = &[
    "plotters",
    "plotters-svg",
    "csv",
    "sha2",
    "indicatif",
    "clap",
    "wgpu",
    "pollster",
    "anyhow",
];

fn crates_dir() -> PathBuf {
    raylab_testkit::repo().join("crates")
}

/// The `[dependencies]` of crate folder `name` (not dev- or build-).
fn dependencies(name: &str) -> BTreeSet<String> {
    let path = crates_dir().join(name).join("Cargo.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let manifest: toml::Table = toml::from_str(&text).unwrap();
    manifest
        .get("dependencies")
        .and_then(|d| d.as_table())
        .map(|d| d.keys().cloned().collect())
        .unwrap_or_default()
}

#[test]
fn crates_depend_only_on_crates_below_them() {
    let mut problems = Vec::new();
    for (i, (folder, package, _)) in CRATES.iter().enumerate() {
        let deps = dependencies(folder);
        for (j, (_, other, _)) in CRATES.iter().enumerate() {
            if j >= i && deps.contains(*other) {
                problems.push(format!(
                    "`{package}` depends on `{other}`, which is not below it"
                ));
            }
        }
    }
    for d in dependencies("core") {
        if NOT_IN_CORE.contains(&d.as_str()) {
            problems.push(format!("the core crate `raylab` depends on `{d}`"));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// One source file: its module path (`["accel", "bvh", "wide"]`; empty for
/// lib.rs or main.rs) and its code with comments and literals blanked.
struct File {
    path: PathBuf,
    module: Vec<String>,
    code: String,
}

fn source_files(src: &Path) -> Vec<File> {
    let mut out = Vec::new();
    collect(src, src, &mut out);
    out.sort_by(|a, b| a.path.cmp(&b.path));
    out
}

fn collect(src: &Path, dir: &Path, out: &mut Vec<File>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            collect(src, &p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            let rel = p.strip_prefix(src).unwrap().with_extension("");
            let mut module: Vec<String> = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            if module.last().is_some_and(|m| m == "mod")
                || (module.len() == 1 && (module[0] == "lib" || module[0] == "main"))
            {
                module.pop();
            }
            let code = blank_comments_and_literals(&std::fs::read_to_string(&p).unwrap());
            out.push(File {
                path: p,
                module,
                code,
            });
        }
    }
}

/// `text` with comments, string literals and character literals replaced
/// by spaces (newlines kept, so positions keep their lines): doc links may
/// point anywhere, and a path in a string is not an import.
fn blank_comments_and_literals(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = c.clone();
    let blank = |out: &mut Vec<char>, from: usize, to: usize| {
        for x in &mut out[from..to.min(c.len())] {
            if *x != '\n' {
                *x = ' ';
            }
        }
    };
    let mut i = 0;
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            let end = (i..c.len()).find(|&k| c[k] == '\n').unwrap_or(c.len());
            blank(&mut out, i, end);
            i = end;
        } else if c[i] == '/' && next == Some('*') {
            let mut depth = 0;
            let mut k = i;
            while k < c.len() {
                if c[k] == '/' && c.get(k + 1) == Some(&'*') {
                    depth += 1;
                    k += 2;
                } else if c[k] == '*' && c.get(k + 1) == Some(&'/') {
                    depth -= 1;
                    k += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    k += 1;
                }
            }
            blank(&mut out, i, k);
            i = k;
        } else if c[i] == 'r'
            && (next == Some('"') || next == Some('#'))
            && (i == 0 || !is_ident(c[i - 1]))
        {
            // A raw string r#"…"#: ends at a quote and as many hashes.
            let hashes = (i + 1..c.len()).take_while(|&k| c[k] == '#').count();
            let open = i + 1 + hashes;
            if c.get(open) != Some(&'"') {
                i += 1;
                continue;
            }
            let close: String = std::iter::once('"')
                .chain(std::iter::repeat_n('#', hashes))
                .collect();
            let rest: String = c[open + 1..].iter().collect();
            let end = rest.find(&close).map_or(c.len(), |k| {
                open + 1 + rest[..k].chars().count() + close.len()
            });
            blank(&mut out, i, end);
            i = end;
        } else if c[i] == '"' {
            let mut k = i + 1;
            while k < c.len() && c[k] != '"' {
                k += if c[k] == '\\' { 2 } else { 1 };
            }
            blank(&mut out, i, k + 1);
            i = k + 1;
        } else if c[i] == '\'' && next == Some('\\') {
            let end = (i + 2..c.len()).find(|&k| c[k] == '\'').unwrap_or(c.len());
            blank(&mut out, i, end + 1);
            i = end + 1;
        } else if c[i] == '\'' && c.get(i + 2) == Some(&'\'') {
            blank(&mut out, i, i + 3);
            i += 3;
        } else {
            i += 1;
        }
    }
    out.into_iter().collect()
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// A path found in code: its segments (`["crate", "scene", "Scene"]`,
/// groups expanded) and where it starts.
#[derive(Debug, PartialEq)]
struct Found {
    segments: Vec<String>,
    at: usize,
}

/// Every `crate::…`, `super::…` and `self::…` path in `code` (blanked by
/// [`blank_comments_and_literals`]), with `a::{b, c::{d, self}}` groups
/// expanded into one path per leaf.
fn paths(code: &str) -> Vec<Found> {
    let c: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        let starts = (i == 0 || !(is_ident(c[i - 1]) || c[i - 1] == ':'))
            && ["crate", "super", "self"].iter().any(|k| word_at(&c, i, k));
        if starts {
            let end = parse_path(&c, i, Vec::new(), i, &mut out);
            i = end.max(i + 1);
        } else {
            i += 1;
        }
    }
    out
}

fn word_at(c: &[char], i: usize, w: &str) -> bool {
    let n = w.chars().count();
    i + n <= c.len()
        && c[i..i + n].iter().copied().eq(w.chars())
        && c.get(i + n).is_none_or(|&x| !is_ident(x))
}

fn skip_space(c: &[char], mut i: usize) -> usize {
    while i < c.len() && c[i].is_whitespace() {
        i += 1;
    }
    i
}

/// Parse a path (or a group's item) at `i` after `prefix`; push what it
/// names to `out`; return where it ends.
fn parse_path(
    c: &[char],
    mut i: usize,
    mut prefix: Vec<String>,
    at: usize,
    out: &mut Vec<Found>,
) -> usize {
    loop {
        i = skip_space(c, i);
        if c.get(i) == Some(&'{') {
            // A group: items separated by commas until the matching brace.
            i += 1;
            loop {
                i = skip_space(c, i);
                match c.get(i) {
                    None => return i,
                    Some('}') => return i + 1,
                    Some(',') => i += 1,
                    Some(_) => {
                        let before = i;
                        i = parse_path(c, i, prefix.clone(), at, out);
                        // Skip what a path does not consume (`as name`, `*`).
                        while i < c.len() && !matches!(c[i], ',' | '}') {
                            i += 1;
                        }
                        if i == before {
                            i += 1;
                        }
                    }
                }
            }
        }
        let start = i;
        while i < c.len() && is_ident(c[i]) {
            i += 1;
        }
        if i == start {
            break;
        }
        prefix.push(c[start..i].iter().collect());
        let j = skip_space(c, i);
        if c.get(j) == Some(&':') && c.get(j + 1) == Some(&':') {
            i = j + 2;
        } else {
            break;
        }
    }
    if !prefix.is_empty() {
        out.push(Found {
            segments: prefix,
            at,
        });
    }
    i
}

/// Inline modules (`mod tests { … }`) of a file's code: their names and
/// the span of their braces, so that `super::` inside one resolves from
/// it and not from the file.
fn inline_modules(code: &str) -> Vec<(String, usize, usize)> {
    let c: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        if word_at(&c, i, "mod") && (i == 0 || !is_ident(c[i - 1])) {
            let s = skip_space(&c, i + 3);
            let mut e = s;
            while e < c.len() && is_ident(c[e]) {
                e += 1;
            }
            let open = skip_space(&c, e);
            if e > s && c.get(open) == Some(&'{') {
                let mut depth = 0;
                let mut k = open;
                while k < c.len() {
                    match c[k] {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                break;
                            }
                        }
                        _ => {}
                    }
                    k += 1;
                }
                out.push((c[s..e].iter().collect(), open, k));
            }
            i = e.max(i + 3);
        } else {
            i += 1;
        }
    }
    out
}

/// The module a path names, as the longest prefix of it that is a file's
/// module; `None` for paths that leave the crate or name nothing known.
fn resolve<'m>(
    file: &File,
    inline: &[(String, usize, usize)],
    found: &Found,
    modules: &'m BTreeSet<Vec<String>>,
) -> Option<&'m Vec<String>> {
    let mut here = file.module.clone();
    for (name, open, close) in inline {
        if *open < found.at && found.at < *close {
            here.push(name.clone());
        }
    }
    let mut segs = found.segments.iter().peekable();
    let mut base = match segs.next()?.as_str() {
        "crate" => Vec::new(),
        "self" => here,
        "super" => {
            here.pop()?;
            here
        }
        _ => return None,
    };
    while segs.peek().is_some_and(|s| *s == "super") {
        segs.next();
        base.pop()?;
    }
    base.extend(segs.cloned());
    (0..=base.len())
        .rev()
        .find_map(|k| modules.get(&base[..k].to_vec()))
}

fn line_of(code: &str, at: usize) -> usize {
    code.chars().take(at).filter(|&c| c == '\n').count() + 1
}

#[test]
fn no_module_imports_upwards_and_no_files_import_in_a_circle() {
    let mut problems = Vec::new();
    for (folder, package, layers) in CRATES {
        let src = crates_dir().join(folder).join("src");
        let layer: BTreeMap<&str, usize> = layers
            .iter()
            .enumerate()
            .flat_map(|(i, mods)| mods.iter().map(move |m| (*m, i)))
            .collect();
        let files = source_files(&src);
        let modules: BTreeSet<Vec<String>> = files.iter().map(|f| f.module.clone()).collect();
        for m in modules.iter().filter(|m| m.len() == 1) {
            if !layer.contains_key(m[0].as_str()) {
                problems.push(format!(
                    "`{package}`: module `{}` has no layer: place it in crates/cli/tests/layers.rs \
                     and ARCHITECTURE.md",
                    m[0]
                ));
            }
        }
        let mut edges: BTreeMap<&Vec<String>, BTreeSet<&Vec<String>>> = BTreeMap::new();
        for f in &files {
            let inline = inline_modules(&f.code);
            for found in paths(&f.code) {
                let Some(to) = resolve(f, &inline, &found, &modules) else {
                    continue;
                };
                let rel = f.path.strip_prefix(crates_dir()).unwrap_or(&f.path);
                if let (Some(own), Some(theirs)) = (f.module.first(), to.first()) {
                    if own != theirs {
                        if let (Some(&a), Some(&b)) =
                            (layer.get(own.as_str()), layer.get(theirs.as_str()))
                        {
                            if b >= a {
                                problems.push(format!(
                                    "crates/{}:{}: `{own}` (layer {a}) names `{theirs}` \
                                     (layer {b}): a module may use only lower layers",
                                    rel.display(),
                                    line_of(&f.code, found.at)
                                ));
                            }
                        }
                    }
                }
                let related = to.starts_with(&f.module) || f.module.starts_with(to.as_slice());
                if !related {
                    edges.entry(&f.module).or_default().insert(to);
                }
            }
        }
        for circle in circles(&edges) {
            let names: Vec<String> = circle
                .iter()
                .map(|m| {
                    let f = files.iter().find(|f| &&f.module == m).unwrap();
                    f.path
                        .strip_prefix(crates_dir())
                        .unwrap_or(&f.path)
                        .display()
                        .to_string()
                })
                .collect();
            problems.push(format!(
                "`{package}`: files import each other in a circle: {}",
                names.join(" ↔ ")
            ));
        }
    }
    assert!(
        problems.is_empty(),
        "layering broken:\n{}",
        problems.join("\n")
    );
}

/// The strongly connected components of more than one node (Tarjan).
fn circles<'a, N: Ord>(edges: &BTreeMap<&'a N, BTreeSet<&'a N>>) -> Vec<Vec<&'a N>> {
    struct State<'a, N> {
        index: BTreeMap<&'a N, usize>,
        low: BTreeMap<&'a N, usize>,
        stack: Vec<&'a N>,
        out: Vec<Vec<&'a N>>,
    }
    fn visit<'a, N: Ord>(v: &'a N, edges: &BTreeMap<&'a N, BTreeSet<&'a N>>, s: &mut State<'a, N>) {
        let i = s.index.len();
        s.index.insert(v, i);
        s.low.insert(v, i);
        s.stack.push(v);
        for &w in edges.get(v).into_iter().flatten() {
            if !s.index.contains_key(w) {
                visit(w, edges, s);
                let lw = s.low[w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if s.stack.contains(&w) {
                let iw = s.index[w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if s.low[v] == s.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = s.stack.pop() {
                comp.push(w);
                if std::ptr::eq(w, v) || w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                s.out.push(comp);
            }
        }
    }
    let mut s = State {
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        out: Vec::new(),
    };
    for &v in edges.keys() {
        if !s.index.contains_key(v) {
            visit(v, edges, &mut s);
        }
    }
    s.out
}

/// The scanner itself: grouped imports over several lines, nested groups,
/// `self` in groups, comments, strings, raw strings and inline modules.
#[test]
fn scanner_finds_grouped_and_plain_paths() {
    let code = blank_comments_and_literals(
        "use crate::{math::Vec3,\n    shape::{self, Hit}, // crate::nothing\n    stats};\n\
         let x = crate::scene::Scene::new(\"crate::fake\", r#\"super::fake\"#, '\"');\n\
         /* self::hidden */ use super::super::up::Thing;\n",
    );
    let found: Vec<String> = paths(&code).iter().map(|f| f.segments.join("::")).collect();
    assert_eq!(
        found,
        [
            "crate::math::Vec3",
            "crate::shape::self",
            "crate::shape::Hit",
            "crate::stats",
            "crate::scene::Scene::new",
            "super::super::up::Thing",
        ]
    );
    let inline = inline_modules("fn f() {}\n#[cfg(test)]\nmod tests {\n use super::*;\n}\n");
    assert_eq!(inline.len(), 1);
    assert_eq!(inline[0].0, "tests");
}

/// Resolution: `super` from a file and from an inline module, `crate`
/// paths to the longest known module, and the circle finder.
#[test]
fn paths_resolve_to_files_and_circles_are_found() {
    let modules: BTreeSet<Vec<String>> = [vec![], vec!["a"], vec!["a", "b"], vec!["a", "c"]]
        .into_iter()
        .map(|m| m.into_iter().map(String::from).collect())
        .collect();
    let file = File {
        path: PathBuf::from("a/b.rs"),
        module: vec!["a".into(), "b".into()],
        code: String::new(),
    };
    let at = |segments: &[&str], at| Found {
        segments: segments.iter().map(|s| s.to_string()).collect(),
        at,
    };
    let name = |m: Option<&Vec<String>>| m.map(|m| m.join("::"));
    let inline = vec![("tests".to_string(), 10, 20)];
    assert_eq!(
        name(resolve(
            &file,
            &inline,
            &at(&["super", "c", "X"], 0),
            &modules
        )),
        Some("a::c".into())
    );
    assert_eq!(
        name(resolve(&file, &inline, &at(&["super", "X"], 15), &modules)),
        Some("a::b".into())
    );
    assert_eq!(
        name(resolve(
            &file,
            &inline,
            &at(&["crate", "a", "c", "f"], 0),
            &modules
        )),
        Some("a::c".into())
    );
    let (x, y, z) = (1, 2, 3);
    let edges = BTreeMap::from([(&x, BTreeSet::from([&y])), (&y, BTreeSet::from([&x, &z]))]);
    assert_eq!(circles(&edges), vec![vec![&1, &2]]);
}
