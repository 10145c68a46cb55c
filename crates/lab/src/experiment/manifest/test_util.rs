//! Fixtures of the manifest tests: a good manifest and helpers that
//! check an error names the file, the line and the problem.

use super::parse_manifest;
use std::path::Path;

/// A good manifest: two sweeps (one with a template helper), a quick
/// block and a figure.
pub const GOOD: &str = r#"name = "t"
kind = "render_cost"
repeats = 2

[fixed]
scene = "scene.toml"

[[sweep]]
name = "sizes"
resolution = ["8x6", "16x12"]
sampler = ["centre", "ogss:2"]

[[sweep]]
name = "scenes"
index = { from = 1, to = 3, step = 1 }
scene = "scene-{index}.toml"

[quick]
repeats = 1
[quick.sweep.sizes]
resolution = ["8x6"]

[[figure]]
file = "time"
kind = "line"
sweep = "sizes"
x = "width"
y = ["render_median_s", "rays"]
series = "sampler"
only = { sampler = ["centre"] }
"#;

/// The error of loading `text` as `dir/m.toml`.
pub fn error(text: &str) -> String {
    parse_manifest(text, Path::new("dir/m.toml"))
        .expect_err("a bad manifest")
        .to_string()
}

/// `GOOD` with `from` replaced by `to`.
pub fn good_with(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "{from}");
    GOOD.replacen(from, to, 1)
}

/// Assert that `err` names the manifest at the line of `text` where
/// `at` first appears, and contains each of `expect`.
pub fn assert_at(err: &str, text: &str, at: &str, expect: &[&str]) {
    let line = text[..text.find(at).expect(at)].matches('\n').count() + 1;
    let place = format!("m.toml:{line}:");
    assert!(err.contains(&place), "{err:?} should contain {place:?}");
    for e in expect {
        assert!(err.contains(e), "{err:?} should contain {e:?}");
    }
}
