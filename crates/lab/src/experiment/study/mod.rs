//! Study kinds: what one run of an experiment measures.
//!
//! The runner ([`super::run_experiment`]) knows nothing about rendering: it
//! expands the manifest's sweeps into runs and hands each run to the study
//! named by the manifest's `kind`, which returns one row of `data.csv`.
//!
//! A study implements [`Study`] with three types of its own: its
//! parameters ([`Study::Params`], a struct deriving `Deserialize`, see
//! [`super::params`]), their checked form ([`Study::Config`]: paths
//! resolved, values checked together), and its row ([`Study::Row`], a
//! struct deriving `Serialize` whose fields are its columns, see
//! [`super::row`]). The runner sees it through [`DynStudy`], which every
//! [`Study`] implements. A new kind of experiment is a new module here
//! plus one entry in [`registry::KINDS`], the one list of study kinds that
//! the manifest reader, `raylab experiment --help` and the docs use.

pub mod aa_images;
pub mod aa_patterns;
pub mod accel_cost;
pub mod accel_speed;
#[cfg(feature = "embree")]
pub mod embree_oracle;
pub mod floodfill;
pub mod gi_quality;
#[cfg(feature = "gpu")]
pub mod gpu_speed;
pub mod gradient;
pub mod gradient_estimators;
pub mod registry;
pub mod render_cost;
pub mod timing;

pub use super::params::{ParamDoc, RunParamError};
pub use registry::{find, kinds_help, StudyKind, KINDS};
pub use timing::{median, process_cpu_seconds, Timings};

use super::data::Table;
use super::params::Params;
use super::row::{record, Record};
use super::sweep::RunPoint;
use crate::Error;
use serde::Serialize;
use std::path::Path;

/// The experiment-wide settings a study sees.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StudySettings {
    /// Timed repeats of each measurement.
    pub repeats: u32,
    /// Untimed warm-up runs before the repeats.
    pub warmup: u32,
}

/// What a run needs besides its parameters.
#[derive(Clone, Copy, Debug)]
pub struct RunContext<'a> {
    /// Relative paths in parameters are resolved against this folder (the
    /// manifest's).
    pub base_dir: &'a Path,
    /// The experiment's output folder, for studies that write per-run
    /// files beside data.csv.
    pub out_dir: &'a Path,
    /// Repeats and warm-up.
    pub settings: StudySettings,
}

/// One kind of experiment.
///
/// `run` is called inside the experiment's rayon thread pool, built once
/// with the experiment's thread count, so a study renders with
/// `threads = None` (the current pool) and thread start-up is not part of
/// its timings.
pub trait Study: Sync {
    /// The parameters as the manifest writes them.
    type Params: Params;
    /// The parameters checked together, files found: what a run uses.
    type Config;
    /// One row of `data.csv`; its fields are the study's columns (see
    /// [`super::row`]).
    type Row: Serialize + Default;

    /// Check one run's parameters (values agree with each other, files
    /// exist) and resolve them, without running anything: every run is
    /// checked before the first one starts.
    fn configure(
        &self,
        params: Self::Params,
        base_dir: &Path,
    ) -> Result<Self::Config, RunParamError>;

    /// A row with the shape every row of the experiment has: the header of
    /// `data.csv` is its column names. The default row, unless the columns
    /// depend on the settings (one column per timed repeat).
    fn template(&self, _settings: &StudySettings) -> Self::Row {
        Self::Row::default()
    }

    /// Perform one run and return its row. `run` is the run as the
    /// manifest gives it (for names of per-run files).
    fn run(
        &self,
        config: Self::Config,
        run: &RunPoint,
        ctx: &RunContext<'_>,
    ) -> Result<Self::Row, Error>;

    /// Figures the study draws itself after the sweep, beside the
    /// manifest's `[[figure]]`s, from `data.csv` (`table`, every row, so a
    /// resumed experiment redraws them all) and the per-run files its rows
    /// name in `out_dir`: for data a row cannot hold, such as a curve per
    /// run. Returns the stems written (each as PNG and SVG). None by
    /// default.
    fn figures(&self, _table: &Table, _out_dir: &Path) -> Result<Vec<String>, Error> {
        Ok(Vec::new())
    }

    /// The device the runs trace on besides the CPU, as meta.json records
    /// it (`device`): a GPU adapter's name, back end, driver and type.
    /// None by default (CPU-only studies).
    fn device(&self) -> Option<String> {
        None
    }
}

/// A [`Study`] with its types erased, as the registry and the runner hold
/// it. Every [`Study`] is one.
pub trait DynStudy: Sync {
    /// The parameters it reads, documented.
    fn parameters(&self) -> Vec<ParamDoc>;

    /// The names of the parameters it reads (its parameter struct's
    /// fields).
    fn parameter_names(&self) -> Vec<&'static str>;

    /// The columns of its rows, in order.
    fn columns(&self, settings: &StudySettings) -> Vec<String>;

    /// Read and check one run's parameters without running it.
    fn check(&self, run: &RunPoint, base_dir: &Path) -> Result<(), RunParamError>;

    /// Perform one run; its record has exactly [`DynStudy::columns`].
    fn run(&self, run: &RunPoint, ctx: &RunContext<'_>) -> Result<Record, Error>;

    /// See [`Study::figures`].
    fn figures(&self, table: &Table, out_dir: &Path) -> Result<Vec<String>, Error>;

    /// See [`Study::device`].
    fn device(&self) -> Option<String>;
}

impl<S: Study> DynStudy for S {
    fn parameters(&self) -> Vec<ParamDoc> {
        S::Params::docs()
    }

    fn parameter_names(&self) -> Vec<&'static str> {
        S::Params::names()
    }

    fn columns(&self, settings: &StudySettings) -> Vec<String> {
        match record(&self.template(settings)) {
            Ok(r) => r.columns,
            // The registry's tests write every template: a row type that
            // cannot be columns fails them, not an experiment.
            Err(e) => panic!("a study's row type is not a row of columns: {e}"),
        }
    }

    fn check(&self, run: &RunPoint, base_dir: &Path) -> Result<(), RunParamError> {
        let params = S::Params::from_run(run)?;
        self.configure(params, base_dir).map(|_| ())
    }

    fn run(&self, run: &RunPoint, ctx: &RunContext<'_>) -> Result<Record, Error> {
        let params = S::Params::from_run(run)?;
        let config = self.configure(params, ctx.base_dir)?;
        let row = Study::run(self, config, run, ctx)?;
        let rec = record(&row)?;
        let columns = self.columns(&ctx.settings);
        if rec.columns != columns {
            return Err(Error::Internal(format!(
                "internal error: the study's row has columns {} where its header has {}",
                rec.columns.join(","),
                columns.join(",")
            )));
        }
        Ok(rec)
    }

    fn figures(&self, table: &Table, out_dir: &Path) -> Result<Vec<String>, Error> {
        Study::figures(self, table, out_dir)
    }

    fn device(&self) -> Option<String> {
        Study::device(self)
    }
}
