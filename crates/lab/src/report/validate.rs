//! The `raylab validate` report: raylab's intersections checked against
//! Embree 4 as the oracle, printed as a table per ray set and the worst
//! cases, with the worst cases written as CSV and the figures on request;
//! the command fails when a set breaks the tolerances. Part of the
//! top-layer [`crate::report`] (with the `embree` feature); the checking
//! itself is [`crate::validate`].

use crate::validate::{validate, Input, ValidationOptions, ValidationReport};
use crate::Error;
use std::fmt;
use std::path::PathBuf;

/// What `raylab validate` was asked to do.
#[derive(Clone, Debug)]
pub struct ValidateOptions {
    /// A mesh file to check (takes precedence over `scene`).
    pub mesh: Option<PathBuf>,
    /// A scene file to check: its bounded primitives and its camera.
    pub scene: Option<PathBuf>,
    /// Ray sets, accelerators, oracle configuration and tolerances.
    pub options: ValidationOptions,
    /// Write the worst cases to this CSV file.
    pub csv: Option<PathBuf>,
    /// Folder for the histograms and the bar chart (PNG + SVG).
    pub out: Option<PathBuf>,
}

/// The validation, with the files written for it.
#[derive(Clone, Debug)]
pub struct ValidateReport {
    /// The comparison of every ray set.
    pub report: ValidationReport,
    /// The options it ran with (the tolerances judge it).
    pub options: ValidationOptions,
    /// The CSV of worst cases written.
    pub csv: Option<PathBuf>,
    /// The figures written, if a folder was given.
    pub figures: Option<FiguresWritten>,
}

/// Figures written into a folder.
#[derive(Clone, Debug)]
pub struct FiguresWritten {
    /// The folder.
    pub dir: PathBuf,
    /// The stems written there (each as PNG and SVG).
    pub stems: Vec<String>,
}

impl ValidateReport {
    /// Load the mesh or scene, trace every ray set both ways, and write
    /// the CSV and figures asked for.
    pub fn run(opts: &ValidateOptions) -> Result<Self, Error> {
        let inputs: Vec<_> = [("--mesh", &opts.mesh), ("--scene", &opts.scene)]
            .into_iter()
            .filter_map(|(role, p)| p.as_deref().map(|p| (role, p)))
            .collect();
        let outputs: Vec<_> = opts.csv.iter().map(|p| ("--csv", p.as_path())).collect();
        raylab::io::check_outputs(&inputs, &outputs)?;
        let input = match (&opts.mesh, &opts.scene) {
            (Some(mesh), _) => Input::from_mesh(mesh)?,
            (None, Some(scene)) => Input::from_scene(scene)?,
            (None, None) => return Err(Error::Argument("give --mesh FILE or --scene FILE".into())),
        };
        let report = validate(&input, &opts.options)?;
        if let Some(csv) = &opts.csv {
            report.write_csv(csv)?;
        }
        let figures = match &opts.out {
            Some(dir) => Some(FiguresWritten {
                dir: dir.clone(),
                stems: report.write_figures(dir, "validate-")?,
            }),
            None => None,
        };
        Ok(Self {
            report,
            options: opts.options.clone(),
            csv: opts.csv.clone(),
            figures,
        })
    }

    /// The tolerances broken, one line each (empty when it passed).
    pub fn breaches(&self) -> Vec<String> {
        self.report.breaches(&self.options.tolerances)
    }

    /// `Ok` when no tolerance is broken, else an error listing them.
    pub fn check(&self) -> Result<(), Error> {
        let breaches = self.breaches();
        if !breaches.is_empty() {
            return Err(Error::Tolerances { breaches });
        }
        Ok(())
    }
}

impl fmt::Display for ValidateReport {
    /// The table per ray set, the worst cases, and the files written.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.report.table())?;
        if !self.report.worst.is_empty() {
            writeln!(f, "worst cases:")?;
            f.write_str(&self.report.worst_text())?;
        }
        if let Some(csv) = &self.csv {
            writeln!(f, "wrote      {}", csv.display())?;
        }
        if let Some(figures) = &self.figures {
            for stem in &figures.stems {
                writeln!(f, "figure     {}/{stem}.{{png,svg}}", figures.dir.display())?;
            }
        }
        Ok(())
    }
}
