//! A tiny experiment for the experiment and shard tests: three scenes that
//! render in milliseconds and a manifest of 13 runs over them.

use std::path::{Path, PathBuf};

pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A scene small enough that a whole sweep renders in milliseconds.
pub const TINY_SCENE: &str = r#"[image]
width = 8
height = 6
[camera]
eye = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
[materials.m]
color = [0.5, 0.5, 0.5]
reflectivity = 0.3
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "m"
[[plane]]
point = [0.0, -1.0, 0.0]
normal = [0.0, 1.0, 0.0]
material = "m"
[[light]]
position = [2.0, 2.0, 2.0]
"#;

/// Two sweeps: 2 resolutions × 2 samplers = 4 runs, and 3 scenes (a
/// template over a range) × 3 depths (a counted range) = 9 runs.
pub const MANIFEST: &str = r#"name = "tiny"
kind = "render_cost"
description = "a test"
repeats = 3
warmup = 1
threads = 1

[fixed]
scene = "scene-1.toml"

[[sweep]]
name = "sizes"
resolution = ["8x6", "16x12"]
sampler = ["centre", "ogss:2"]

[[sweep]]
name = "scenes"
index = { from = 1, to = 3, step = 1 }
scene = "scene-{index}.toml"
max_depth = { from = 1, to = 5, count = 3 }

[quick]
repeats = 1
warmup = 0
[quick.sweep.sizes]
resolution = ["8x6"]
[quick.sweep.scenes]
index = [2]

[[figure]]
file = "time"
kind = "line"
sweep = "sizes"
x = "pixels"
y = "render_median_s"
series = "sampler"
title = "time"

[[figure]]
file = "ratio"
kind = "ratio"
sweep = "sizes"
x = "width"
y = ["render_median_s", "render_cpu_median_s"]
series = "sampler"
series_labels = { render_median_s = "wall" }
numerator = "ogss:2"
denominator = "centre"
title = "T"

[[figure.reference]]
label = "published"
x = [8, 16]
y = [3.0, 3.5]

[[figure]]
file = "depth"
kind = "bar"
sweep = "scenes"
x = "max_depth"
y = "rays"
series = "index"
title = "rays"
"#;

/// A temporary folder holding the tiny scenes and a manifest.
pub fn setup(manifest: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    for i in 1..=3 {
        write(dir.path(), &format!("scene-{i}.toml"), TINY_SCENE);
    }
    let m = write(dir.path(), "tiny.toml", manifest);
    (dir, m)
}

/// A data.csv row by column name.
pub type Row = std::collections::HashMap<String, String>;

/// Every row of a data.csv.
pub fn read_rows(csv_path: &Path) -> Vec<Row> {
    let mut rdr = csv::Reader::from_path(csv_path).unwrap();
    let header: Vec<String> = rdr.headers().unwrap().iter().map(String::from).collect();
    rdr.records()
        .map(|r| {
            header
                .iter()
                .cloned()
                .zip(r.unwrap().iter().map(String::from))
                .collect()
        })
        .collect()
}

/// A numeric cell.
pub fn num(row: &Row, col: &str) -> f64 {
    row[col]
        .parse()
        .unwrap_or_else(|_| panic!("column {col} = {:?} is not a number", row[col]))
}
