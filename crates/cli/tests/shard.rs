//! Shards and merging: three shards merged give the rows of one unsharded
//! run (same keys in the same order, same counters); the merge refuses
//! shards that do not belong together and lists what is missing.

use raylab_lab::experiment::data::Table;
use raylab_lab::experiment::merge::{merge_shards, MergeOptions};
use raylab_lab::experiment::meta::Meta;
use raylab_lab::experiment::{run_experiment, ExperimentOptions, Shard};
use std::path::{Path, PathBuf};
use std::process::Command;

use raylab_testkit::experiment::{setup, write, MANIFEST};

/// Columns that measure time (or follow from a time): they differ between
/// any two runs. Every other column — keys, sizes, samples, every counter,
/// rays — must be equal.
fn is_timing(column: &str) -> bool {
    column.ends_with("_s")
        || column.contains("_s_")
        || column == "rays_per_s"
        || column == "ns_per_sample"
}

fn run(manifest: &Path, out: &Path, shard: Option<Shard>) {
    let opts = ExperimentOptions {
        out_dir: Some(out.to_path_buf()),
        shard,
        ..ExperimentOptions::default()
    };
    run_experiment(manifest, &opts).unwrap();
}

fn shard(index: usize, count: usize) -> Option<Shard> {
    Some(Shard { index, count })
}

/// The tiny manifest run whole and as three shards, in `dir`.
fn whole_and_shards(dir: &Path, manifest: &Path) -> (PathBuf, Vec<PathBuf>) {
    let whole = dir.join("whole");
    run(manifest, &whole, None);
    let shards: Vec<PathBuf> = (1..=3)
        .map(|i| {
            let out = dir.join(format!("shard-{i}"));
            run(manifest, &out, shard(i, 3));
            out
        })
        .collect();
    (whole, shards)
}

fn merge(out: &Path, shards: &[PathBuf], allow_missing: bool) -> raylab_lab::Result<()> {
    merge_shards(&MergeOptions {
        out_dir: out.to_path_buf(),
        shards: shards.to_vec(),
        allow_missing,
    })
    .map(|_| ())
}

#[test]
fn three_shards_merge_to_the_unsharded_rows() {
    let (dir, manifest) = setup(MANIFEST);
    let (whole, shards) = whole_and_shards(dir.path(), &manifest);

    // Each shard holds its deal, no figures: 13 runs in 11 groups (the
    // ratio figure pairs centre with ogss:2 at each of 2 sizes; 9 single
    // runs) dealt round-robin: 4, 4 and 3 groups, 5, 5 and 3 runs.
    let counts: Vec<usize> = shards
        .iter()
        .map(|s| Table::read(&s.join("data.csv")).unwrap().table.rows.len())
        .collect();
    assert_eq!(counts, [5, 5, 3]);
    assert!(!shards[0].join("time.png").exists());
    let meta = Meta::read(&shards[1]).unwrap();
    assert_eq!(meta.shard, shard(2, 3));
    assert_eq!(meta.manifest_hash.len(), 64);

    let merged = dir.path().join("merged");
    // Any order of the folders.
    let mut given = shards.clone();
    given.reverse();
    merge(&merged, &given, false).unwrap();

    let a = Table::read(&whole.join("data.csv")).unwrap().table;
    let b = Table::read(&merged.join("data.csv")).unwrap().table;
    assert_eq!(a.columns, b.columns);
    assert_eq!(a.rows.len(), b.rows.len());
    let compared: Vec<usize> = (0..a.columns.len())
        .filter(|&c| !is_timing(&a.columns[c]))
        .collect();
    assert!(compared.len() > 20, "counters are compared");
    for (ra, rb) in a.rows.iter().zip(&b.rows) {
        for &c in &compared {
            assert_eq!(ra[c], rb[c], "column {}", a.columns[c]);
        }
    }
    for fig in ["time", "ratio", "depth"] {
        assert!(merged.join(format!("{fig}.png")).is_file(), "{fig}");
    }
    let meta = Meta::read(&merged).unwrap();
    assert!(meta.complete);
    assert_eq!(meta.shard, None);
    assert_eq!(meta.shards.len(), 3);
    assert_eq!(meta.shards[0].shard, shard(1, 3).unwrap());
    assert_eq!(meta.runs_done, 13);
    assert!(meta.shards.iter().all(|s| !s.host.is_empty()));
}

#[test]
fn merge_refuses_what_does_not_belong_together() {
    let (dir, manifest) = setup(MANIFEST);
    let (whole, shards) = whole_and_shards(dir.path(), &manifest);
    let out = dir.path().join("merged");
    let err = |shards: &[PathBuf]| format!("{:#}", merge(&out, shards, false).unwrap_err());

    // A missing shard: its runs listed by shard and key.
    let e = err(&shards[..2]);
    assert!(e.contains("3 of 13 runs are in no shard"), "{e}");
    assert!(e.contains("shard 3/3: "), "{e}");
    // ... unless --allow-missing: merged, drawn, marked incomplete.
    merge(&out, &shards[..2], true).unwrap();
    assert!(out.join("time.png").is_file());
    let meta = Meta::read(&out).unwrap();
    assert!(!meta.complete);
    assert_eq!(meta.runs_done, 10);

    // The same folder twice, or a copy of a shard.
    assert!(err(&[shards[0].clone(), shards[0].join(".")]).contains("same folder"));
    let copy = dir.path().join("copy");
    copy_dir(&shards[0], &copy);
    assert!(err(&[shards[0].clone(), copy.clone()]).contains("both shard 1/3"));
    // An unsharded run is not a shard.
    assert!(err(std::slice::from_ref(&whole)).contains("not a shard"));
    // A shard of another manifest (the same runs, another text).
    let other = write(
        dir.path(),
        "other.toml",
        &MANIFEST.replace("description = \"a test\"", "description = \"another\""),
    );
    let foreign = dir.path().join("foreign");
    run(&other, &foreign, shard(3, 3));
    let e = err(&[shards[0].clone(), shards[1].clone(), foreign]);
    assert!(e.contains("differ in their manifest"), "{e}");
    // A row in the wrong shard's folder.
    let t3 = Table::read(&shards[2].join("data.csv")).unwrap().table;
    let mut text = std::fs::read_to_string(copy.join("data.csv")).unwrap();
    text.push_str(&t3.rows[0].join(","));
    text.push('\n');
    std::fs::write(copy.join("data.csv"), text).unwrap();
    let e = err(&[copy, shards[1].clone(), shards[2].clone()]);
    assert!(e.contains("belongs to shard 3/3"), "{e}");
}

#[test]
fn cli_shards_and_merges() {
    let (dir, manifest) = setup(MANIFEST);
    let bin = env!("CARGO_BIN_EXE_raylab");
    let m = manifest.to_str().unwrap();
    // Default shard folders: out/NAME.shards/I-of-N beside the manifest.
    for i in 1..=2 {
        let o = Command::new(bin)
            .args(["experiment", m, "--quick", "--shard", &format!("{i}/2")])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let shards = dir.path().join("out/tiny.shards");
    let out = dir.path().join("merged");
    let o = Command::new(bin)
        .arg("merge")
        .arg(&out)
        .arg(shards.join("1-of-2"))
        .arg(shards.join("2-of-2"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("2 shards, 5 of 5 runs"), "{stdout}");
    assert!(out.join("data.csv").is_file());
    // Bad shard specifications are usage errors (exit 2).
    for bad in ["0/2", "3/2", "1/0", "a/b", "1"] {
        let o = Command::new(bin)
            .args(["experiment", m, "--shard", bad])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{bad}");
        assert!(String::from_utf8_lossy(&o.stderr).contains("is not a shard"));
    }
    // A quick shard and a full shard do not merge.
    let o = Command::new(bin)
        .args(["experiment", m, "--shard", "2/2", "--out"])
        .arg(dir.path().join("full-2"))
        .output()
        .unwrap();
    assert!(o.status.success());
    let o = Command::new(bin)
        .arg("merge")
        .arg(&out)
        .arg(shards.join("1-of-2"))
        .arg(dir.path().join("full-2"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("differ in their manifest"));
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_file() {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}
