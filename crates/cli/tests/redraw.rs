//! `raylab plot`: an experiment's figures drawn again from its data.csv and
//! the manifest its meta.json recorded are the figures the run drew, byte
//! for byte; the source folder is left alone; a table that does not fit the
//! recorded manifest, or whose last row was cut short, is refused.

use raylab_lab::experiment::meta::Meta;
use raylab_lab::experiment::{redraw, run_experiment, ExperimentOptions};
use std::path::{Path, PathBuf};
use std::process::Command;

use raylab_testkit::experiment::{setup, MANIFEST};

fn figures(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png") || n.ends_with(".svg"))
        .collect();
    names.sort();
    names
}

/// The tiny manifest's quick run, in `run/` of a fresh folder.
fn quick_run() -> (tempfile::TempDir, PathBuf) {
    let (dir, manifest) = setup(MANIFEST);
    let run = dir.path().join("run");
    let opts = ExperimentOptions {
        out_dir: Some(run.clone()),
        quick: true,
        ..ExperimentOptions::default()
    };
    run_experiment(&manifest, &opts).unwrap();
    (dir, run)
}

#[test]
fn redrawn_figures_equal_the_run_s() {
    let (dir, run) = quick_run();
    let drawn = figures(&run);
    assert!(drawn.len() >= 4, "{drawn:?}");

    let again = dir.path().join("again");
    let r = redraw(&run, Some(&again), None).unwrap();
    assert_eq!(figures(&again), drawn);
    for f in &drawn {
        let a = std::fs::read(run.join(f)).unwrap();
        let b = std::fs::read(again.join(f)).unwrap();
        assert!(a == b, "{f} differs when redrawn");
    }
    assert_eq!(r.rows, 5);
    let (m1, m2) = (Meta::read(&run).unwrap(), Meta::read(&again).unwrap());
    assert_eq!(m1.figures, m2.figures);
    assert_eq!(m1.summary.len(), m2.summary.len());
    for (a, b) in m1.summary.iter().zip(&m2.summary) {
        for (x, y) in a.series.iter().zip(&b.series) {
            assert_eq!(x.mean, y.mean, "{}", a.figure);
        }
    }
    assert_eq!(
        std::fs::read(run.join("data.csv")).unwrap(),
        std::fs::read(again.join("data.csv")).unwrap()
    );

    // In place: the figures are drawn again over the old ones.
    std::fs::remove_file(run.join(&drawn[0])).unwrap();
    redraw(&run, None, None).unwrap();
    assert_eq!(figures(&run), drawn);

    // The CLI prints what it drew; a folder that is no experiment is an
    // error naming the file (exit 1).
    let bin = env!("CARGO_BIN_EXE_raylab");
    let o = Command::new(bin).arg("plot").arg(&run).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("plot tiny: 5 rows"));
    let o = Command::new(bin)
        .arg("plot")
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("meta.json: cannot read"));
}

#[test]
fn redraw_refuses_a_table_that_does_not_fit() {
    let (_dir, run) = quick_run();
    let data = std::fs::read_to_string(run.join("data.csv")).unwrap();

    // A row cut short by an interrupted write.
    std::fs::write(run.join("data.csv"), &data[..data.len() - 3]).unwrap();
    let e = redraw(&run, None, None).unwrap_err().to_string();
    assert!(e.contains("last row is incomplete"), "{e}");

    // Columns that are not the recorded manifest's.
    let renamed = data.replacen("render_median_s", "render_mean_s", 1);
    std::fs::write(run.join("data.csv"), renamed).unwrap();
    let e = format!("{:#}", redraw(&run, None, None).unwrap_err());
    assert!(e.contains("columns differ"), "{e}");

    // A record without the manifest's text.
    std::fs::write(run.join("data.csv"), &data).unwrap();
    let mut meta = Meta::read(&run).unwrap();
    meta.manifest_text.clear();
    meta.write(&run).unwrap();
    let e = redraw(&run, None, None).unwrap_err().to_string();
    assert!(e.contains("records no manifest text"), "{e}");
}

#[test]
fn redraw_with_an_edited_manifest() {
    let (dir, run) = quick_run();
    let manifest = dir.path().join("tiny.toml");
    let before = std::fs::read(run.join("time.png")).unwrap();

    // A figure's title edited after the run: the new figure from the old data.
    let edited = MANIFEST.replace("title = \"time\"", "title = \"render time, edited\"");
    assert_ne!(edited, MANIFEST);
    std::fs::write(&manifest, &edited).unwrap();
    let out = dir.path().join("edited");
    redraw(&run, Some(&out), Some(&manifest)).unwrap();
    let after = std::fs::read(out.join("time.png")).unwrap();
    assert!(before != after, "the edited title changed nothing");
    // The source folder keeps its figures.
    assert_eq!(std::fs::read(run.join("time.png")).unwrap(), before);

    // A sweep changed so that the table's rows are no runs of it.
    let moved = MANIFEST.replace(
        "[quick.sweep.sizes]\nresolution = [\"8x6\"]",
        "[quick.sweep.sizes]\nresolution = [\"16x12\"]",
    );
    assert_ne!(moved, MANIFEST);
    std::fs::write(&manifest, moved).unwrap();
    let e = redraw(&run, Some(&out), Some(&manifest))
        .unwrap_err()
        .to_string();
    assert!(e.contains("is not a run of the manifest"), "{e}");

    // Another experiment's manifest.
    std::fs::write(
        &manifest,
        MANIFEST.replace("name = \"tiny\"", "name = \"other\""),
    )
    .unwrap();
    let e = redraw(&run, Some(&out), Some(&manifest))
        .unwrap_err()
        .to_string();
    assert!(e.contains("holds a run of `tiny`"), "{e}");
}
