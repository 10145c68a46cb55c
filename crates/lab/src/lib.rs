//! raylab's laboratory: what turns renders into findings. Image metrics,
//! spectra and plots ([`analysis`]), raylab's intersections against Embree
//! 4's ([`validate`], with the `embree` feature), experiments and their
//! studies, sweeps, shards and figures ([`experiment`]), and what each
//! `raylab` command prints and writes ([`report`], the top layer: the
//! binary only parses arguments and dispatches to it).
//!
//! It builds on the renderer core, the crate `raylab`, and with the `gpu`
//! feature on `raylab-gpu`.
//!
//! # Errors
//!
//! The lab has one error type, [`Error`], which every layer returns where
//! it reads or writes files, renders or runs experiments; [`Result`] is
//! its alias. One type rather than one per module, because a command
//! passes through every layer (`raylab experiment` loads a manifest, runs
//! studies that render, compare and plot, and writes tables and figures)
//! and its caller wants one thing to report; its variants say which part
//! failed and keep that part's own typed error: the core's
//! [`InputError`], [`OutputError`], [`raylab::diff::DiffError`],
//! [`raylab::integrator::RenderError`], [`raylab::gi::GiError`],
//! [`raylab::scene::param::SetError`],
//! [`raylab::accel::AccelError`] and [`CameraError`];
//! [`analysis::plot::PlotError`]
//! (plotting stays usable alone, so it has its own narrow error),
//! [`analysis::MetricsError`], [`experiment::params::RunParamError`],
//! [`experiment::row::RowError`] and, with the `gpu` feature,
//! [`raylab_gpu::GpuError`]. It lives here at the crate's root, beside the
//! module list, because it names the typed errors of several layers and
//! every layer returns it; it holds data, not code, so no layer depends
//! on another's code through it.
//!
//! Each message is whole: an error's `Display` includes what caused it
//! (`path: cannot read: No such file or directory`), in the words the
//! commands have always printed, and `source()` is none: a variant that
//! only wraps another error is `#[error(transparent)]`, and one that adds
//! context holds the inner error in a field named `error` (not a
//! `source`). So `{}` and `{:#}` print the same, and the command line's
//! `error: {e:#}` prints each cause once.

pub mod analysis;
pub mod experiment;
pub mod report;
#[cfg(feature = "embree")]
pub mod validate;

use raylab::accel::{AccelError, AccelKind};
use raylab::camera::CameraError;
use raylab::gi::GiError;
use raylab::integrator::RenderError;
use raylab::io::{InputError, OutputError, Place};
use std::fmt;
use std::path::PathBuf;

/// A [`std::result::Result`] whose error is the lab's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Why a lab operation (a command's report, an experiment, a validation,
/// a comparison of image files, a table or figure written) failed. The
/// crate docs say how its messages are built.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A problem with an input file: a scene, mesh, image, manifest,
    /// `data.csv` or `meta.json` whose content is wrong (`path:line:
    /// message`).
    #[error(transparent)]
    Input(#[from] InputError),
    /// An output file that could not be written (nothing is left at its
    /// path).
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A file or folder operation that failed: what was being done, to
    /// which path, and the system's reason.
    #[error("{}: {op}: {error}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What was being done to it.
        op: FileOp,
        /// The system's reason.
        error: std::io::Error,
    },
    /// A CSV file (`data.csv`, a per-ring table, the worst cases of a
    /// validation) that could not be read or written as CSV.
    #[error("{}{place}: {op}: {error}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// Where in it (a line), or the file as a whole.
        place: Place,
        /// What was being done to it.
        op: FileOp,
        /// The CSV reader's or writer's reason.
        error: csv::Error,
    },
    /// A file that could not be copied (a shard's or run's files into
    /// another experiment folder).
    #[error("cannot copy {} to {}: {error}", from.display(), to.display())]
    Copy {
        /// The file copied.
        from: PathBuf,
        /// Where to.
        to: PathBuf,
        /// The system's reason.
        error: std::io::Error,
    },
    /// A `meta.json` that is not an experiment's record.
    #[error(
        "{}: not an experiment's meta.json (or from an older raylab): {error}",
        path.display()
    )]
    Meta {
        /// The file.
        path: PathBuf,
        /// The JSON reader's reason.
        error: serde_json::Error,
    },
    /// A value that could not be written as JSON (`meta.json`, `raylab
    /// diff --json`).
    #[error("serialising {what}: {error}")]
    Json {
        /// What was being serialised.
        what: &'static str,
        /// The JSON writer's reason.
        error: serde_json::Error,
    },
    /// An image that could not be encoded and written (the ꟻLIP error
    /// map).
    #[error("{}: cannot write {what}: {error}", path.display())]
    Encode {
        /// The file.
        path: PathBuf,
        /// What it holds ("error map").
        what: &'static str,
        /// The encoder's reason.
        error: image::ImageError,
    },
    /// Writing a report to standard output (or the stream given) failed.
    #[error(transparent)]
    Print(std::io::Error),
    /// Work that would need more memory than this machine has (checked
    /// before it is allocated).
    #[error(transparent)]
    Memory(#[from] raylab::film::memory::MemoryError),
    /// An argument out of range or in conflict with another, checked past
    /// the command line's own parsing (so the command exits with status
    /// 1, not clap's 2): `--threads 0`, an error-map name that is not
    /// `.png`, neither a mesh nor a scene to validate.
    #[error("{0}")]
    Argument(String),
    /// A `--set PATH=VALUE` that the scene has no parameter for, of the
    /// wrong shape, or that leaves the scene invalid. A usage error, found
    /// only once the scene is read: the command line exits with status 2
    /// for it, as for the options clap refuses ([`Error::is_usage`]).
    #[error(transparent)]
    Set(#[from] raylab::scene::param::SetError),
    /// An error about a scene file: the file, then what went wrong with
    /// it.
    #[error("{}: {error}", path.display())]
    Scene {
        /// The scene file.
        path: PathBuf,
        /// What went wrong.
        error: Box<Error>,
    },
    /// The renderer could not render (or prepare to render) a scene; the
    /// core's message.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// An accelerator could not be built for a scene: which, and why.
    #[error("building `{kind}`: {error}")]
    Accel {
        /// The accelerator.
        kind: AccelKind,
        /// Why it could not be built (Embree's or obvhs's reason).
        error: AccelError,
    },
    /// Derivatives could not be set up or rendered (the scene for
    /// derivatives, its parameters, the integrator, a finite-difference
    /// step, an optimisation).
    #[error(transparent)]
    Diff(#[from] raylab::diff::DiffError),
    /// One iteration of an optimisation failed.
    #[error("iteration {iteration}: {error}")]
    Iteration {
        /// Its number, from 0.
        iteration: u32,
        /// Why it failed.
        error: raylab::diff::DiffError,
    },
    /// The flood-fill cache (voxel grid and irradiance) could not be
    /// built.
    #[error(transparent)]
    Cache(#[from] GiError),
    /// Two images that cannot be compared (sizes or channels differ).
    #[error(transparent)]
    Metrics(#[from] analysis::MetricsError),
    /// A comparison of two named images that could not be made (sizes or
    /// channels differ).
    #[error("{}: {error}", CompareWhat(test.as_ref(), reference))]
    Compare {
        /// The image judged, when it is a file.
        test: Option<PathBuf>,
        /// The reference image.
        reference: PathBuf,
        /// Why they cannot be compared.
        error: analysis::MetricsError,
    },
    /// The camera that frames a mesh automatically could not be built.
    #[error("{}: automatic camera: {error}", scene.display())]
    AutoCamera {
        /// The scene the mesh was placed in.
        scene: PathBuf,
        /// Why the camera was refused.
        error: CameraError,
    },
    /// A problem with the mesh of a study's run, named as the manifest
    /// names it.
    #[error("mesh `{label}`: {error}")]
    Mesh {
        /// The mesh as the manifest gives it (a file or a procedural spec).
        label: String,
        /// What went wrong.
        error: Box<Error>,
    },
    /// Embree, the oracle of a validation, could not be set up.
    #[cfg(feature = "embree")]
    #[error("Embree: {0}")]
    Oracle(raylab::accel::embree::EmbreeError),
    /// The GPU port could not open a device or render.
    #[cfg(feature = "gpu")]
    #[error(transparent)]
    Gpu(#[from] raylab_gpu::GpuError),
    /// A thread pool could not be started.
    #[error("cannot start the worker threads: {0}")]
    Threads(rayon::ThreadPoolBuildError),
    /// A figure could not be drawn.
    #[error(transparent)]
    Plot(#[from] analysis::plot::PlotError),
    /// A run's parameters are wrong (when a run finds what the check of
    /// every run before the first could not).
    #[error(transparent)]
    Param(#[from] experiment::params::RunParamError),
    /// A study's row that is not a row of columns (a bug in the study).
    #[error(transparent)]
    Row(#[from] experiment::row::RowError),
    /// One run of an experiment failed: the manifest, the run, how far
    /// the experiment got, and why the run failed.
    #[error(
        "{}: run `{run}` failed ({done} of {total} runs finished are in {}): {error}",
        manifest.display(),
        data.display()
    )]
    Run {
        /// The manifest.
        manifest: PathBuf,
        /// The run, described by its parameters that vary.
        run: String,
        /// Runs finished (this session's and those kept).
        done: usize,
        /// Runs of the experiment (or shard).
        total: usize,
        /// The `data.csv` holding the finished runs.
        data: PathBuf,
        /// Why the run failed.
        error: Box<Error>,
    },
    /// A study refused a run it cannot do (its data contradicts its
    /// parameters: a mesh above a face limit, a parameter naming several
    /// components where one is needed).
    #[error("{0}")]
    Study(String),
    /// A manifest's figure that cannot be drawn from the table: the
    /// figure's file stem, and what is wrong.
    #[error("figure `{file}`: {message}")]
    Figure {
        /// The figure's `file`.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A placeholder of a figure's title or label that cannot be filled
    /// from the table ([`experiment::figures::fill`]).
    #[error("placeholder `{{{placeholder}}}`: {message}")]
    Placeholder {
        /// The placeholder without its braces (`range:spp`).
        placeholder: String,
        /// What is wrong.
        message: String,
    },
    /// A column that a study's own figures read is missing from
    /// `data.csv`.
    #[error("data.csv has no column `{column}`")]
    MissingColumn {
        /// The column.
        column: String,
    },
    /// The figures of an experiment that failed after its table was
    /// written: where, and one line per figure.
    #[error("{what}:\n  {}", failures.join("\n  "))]
    Figures {
        /// The experiment and what was done before the figures failed.
        what: String,
        /// One message per failed figure.
        failures: Vec<String>,
    },
    /// Shards that cannot be merged (not shards, the same shard twice,
    /// shards of different runs, a row twice, runs in no shard).
    #[error("{0}")]
    Merge(String),
    /// A validation against Embree that broke its tolerances: one line
    /// per breach.
    #[error("tolerances exceeded:\n  {}", breaches.join("\n  "))]
    Tolerances {
        /// The tolerances broken, one line each.
        breaches: Vec<String>,
    },
    /// What was written when writing a file failed (an image, a figure):
    /// the file, then why.
    #[error("writing {}: {error}", path.display())]
    Writing {
        /// The file.
        path: PathBuf,
        /// Why writing it failed.
        error: Box<Error>,
    },
    /// Something that cannot happen happened: a bug, described.
    #[error("{0}")]
    Internal(String),
}

/// What was being done to a file or folder when it failed (the phrase
/// after the path in [`Error::Io`] and [`Error::Csv`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileOp {
    /// Reading a file (or its records).
    Read,
    /// Reading the header line of a CSV file.
    ReadHeader,
    /// Writing a file.
    Write,
    /// Creating a file.
    Create,
    /// Creating a folder the command was asked to write into.
    CreateFolder,
    /// Creating an experiment's (or spectrum's) output folder.
    CreateOutputFolder,
    /// Opening a table to append rows.
    OpenForAppending,
    /// Appending a row to a table.
    AppendRow,
    /// Listing a folder.
    List,
    /// Finding a shard's folder.
    FindShard,
}

impl fmt::Display for FileOp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FileOp::Read => "cannot read",
            FileOp::ReadHeader => "cannot read the header",
            FileOp::Write => "cannot write",
            FileOp::Create => "cannot create",
            FileOp::CreateFolder => "cannot create folder",
            FileOp::CreateOutputFolder => "cannot create the output folder",
            FileOp::OpenForAppending => "cannot open for appending",
            FileOp::AppendRow => "cannot append a row",
            FileOp::List => "cannot list",
            FileOp::FindShard => "no such shard folder",
        })
    }
}

/// A thread count given by `--threads`: from 1 to
/// [`MAX_THREADS`](raylab::integrator::MAX_THREADS).
pub fn check_threads(threads: Option<usize>) -> Result<(), Error> {
    use raylab::integrator::MAX_THREADS;
    match threads {
        Some(n) if n == 0 || n > MAX_THREADS => Err(Error::Argument(format!(
            "--threads must be from 1 to {MAX_THREADS} (raylab's limit, above any machine's \
             hardware threads), got {n}"
        ))),
        _ => Ok(()),
    }
}

impl Error {
    /// Whether it is a usage error found past the command line's own
    /// parsing (a `--set` the scene refuses): the command exits with
    /// status 2 for it, as clap does for the options it refuses.
    pub fn is_usage(&self) -> bool {
        matches!(self, Error::Set(_))
    }

    /// [`Error::Io`]: `op` on `path` failed with `error`.
    pub fn io(path: impl Into<PathBuf>, op: FileOp, error: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            op,
            error,
        }
    }

    /// [`Error::Csv`]: `op` on `path` (at `place`) failed with `error`.
    pub fn csv(path: impl Into<PathBuf>, place: Place, op: FileOp, error: csv::Error) -> Self {
        Error::Csv {
            path: path.into(),
            place,
            op,
            error,
        }
    }

    /// [`Error::Accel`] for `kind`, as a function of its error (for
    /// `map_err`).
    pub fn accel(kind: AccelKind) -> impl FnOnce(AccelError) -> Self {
        move |error| Error::Accel { kind, error }
    }

    /// [`Error::Scene`]: `error` concerns the scene file `path`.
    pub fn scene(path: impl Into<PathBuf>, error: impl Into<Error>) -> Self {
        Error::Scene {
            path: path.into(),
            error: Box::new(error.into()),
        }
    }

    /// [`Error::Writing`]: writing `path` failed with `error`.
    pub fn writing(path: impl Into<PathBuf>, error: impl Into<Error>) -> Self {
        Error::Writing {
            path: path.into(),
            error: Box::new(error.into()),
        }
    }
}

/// The subject of a failed comparison: `cannot compare TEST with REF`, or
/// `cannot compare with REF` when the judged image is not a file.
struct CompareWhat<'a>(Option<&'a PathBuf>, &'a PathBuf);

impl fmt::Display for CompareWhat<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(test) => write!(
                f,
                "cannot compare {} with {}",
                test.display(),
                self.1.display()
            ),
            None => write!(f, "cannot compare with {}", self.1.display()),
        }
    }
}
