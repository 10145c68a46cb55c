//! The `raylab optimize` report: inverse rendering from a spec
//! ([`raylab::diff::optimize`]), with what it writes as it goes and at the
//! end. Part of the top-layer [`crate::report`].
//!
//! In the output folder:
//! - `optimize.csv`: one row per iteration (its parameters, loss, gradient
//!   and time), appended and flushed as each iteration ends, so an
//!   interrupted or killed run leaves whole rows;
//! - `final.toml`: the scene file with the latest parameters, replaced
//!   atomically after every iteration;
//! - `target.exr` and `target.png`;
//! - `loss.png`/`.svg` (loss against iteration), `params.png`/`.svg`
//!   (each parameter's relative error when the truth is known, else its
//!   value), `images.png`/`.svg` (the target beside renders at the
//!   snapshot iterations and the end).
//!
//! The first Ctrl-C stops the run after the current iteration and still
//! draws the figures; a second one ends the process at once.

use crate::analysis::plot::{AxisScale, ImageGrid, LineChart, Series, SeriesStyle};
use crate::{Error, FileOp};
use raylab::diff::optimize::{
    average_last, load_spec, relative_error, Iteration, OptimizeTarget, Optimizer, Problem, Spec,
};
use raylab::io::image::write_image;
use raylab::io::write_atomically;
use raylab::sampler::Sampler;
use std::fmt;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What `raylab optimize` was asked to do.
#[derive(Clone, Debug)]
pub struct OptimizeOptions {
    pub spec: PathBuf,
    /// The output folder (created if missing).
    pub out_dir: PathBuf,
    /// Stop after this many iterations: the first ones of the spec's run
    /// (its rate schedule unchanged); snapshots beyond them are dropped.
    pub stop_after: Option<u32>,
    /// Render a target given by values with this sampler instead of the
    /// spec's (a quicker, noisier target for a quick look); an error when
    /// the spec's target is an image file.
    pub target_sampler: Option<Sampler>,
    /// Render threads; `None` means all cores.
    pub threads: Option<usize>,
    /// Show a progress bar with the loss on a terminal.
    pub progress: bool,
}

/// One parameter's outcome.
#[derive(Clone, Debug)]
pub struct ParamOutcome {
    pub name: String,
    pub start: f64,
    pub end: f64,
    /// The true value, when the target was rendered from values.
    pub truth: Option<f64>,
}

/// What one `raylab optimize` did and measured.
#[derive(Clone, Debug)]
pub struct OptimizeReport {
    pub spec: PathBuf,
    pub out_dir: PathBuf,
    pub description: String,
    pub setup: String,
    /// Iterations run, asked for (`--stop-after`, else the spec's) and
    /// planned by the spec (its rate schedule's length).
    pub iterations: u32,
    pub asked: u32,
    pub planned: u32,
    /// How many last iterates the result averages (1: the last one).
    pub averaged: u32,
    /// Whether Ctrl-C stopped the run early.
    pub interrupted: bool,
    pub target_s: f64,
    /// Seconds in the iterations, in all.
    pub optimize_s: f64,
    pub first_loss: f64,
    pub last_loss: f64,
    pub params: Vec<ParamOutcome>,
}

impl OptimizeReport {
    /// The largest relative error of the final parameters, when the truth
    /// is known.
    pub fn max_relative_error(&self) -> Option<f64> {
        self.params
            .iter()
            .map(|p| p.truth.map(|t| relative_error(p.end, t)))
            .try_fold(0.0f64, |m, e| e.map(|e| m.max(e)))
    }

    pub fn run(opts: &OptimizeOptions) -> Result<Self, Error> {
        crate::check_threads(opts.threads)?;
        let mut spec = load_spec(&opts.spec)?;
        let run = match opts.stop_after {
            Some(0) => return Err(Error::Argument("--stop-after must be at least 1".into())),
            Some(n) => n.min(spec.iterations),
            None => spec.iterations,
        };
        spec.snapshots.retain(|&i| i < run);
        if let Some(chosen) = opts.target_sampler {
            match &mut spec.target {
                OptimizeTarget::Values { sampler, .. } => *sampler = chosen,
                OptimizeTarget::Image(path) => {
                    return Err(Error::Argument(format!(
                        "--target-sampler applies to a target rendered from values; \
                         {}'s target is the image {}",
                        opts.spec.display(),
                        path.display()
                    )))
                }
            }
        }
        check_outputs_of(&spec, &opts.spec, &opts.out_dir)?;
        let problem = Problem::new(spec, opts.threads)?;
        std::fs::create_dir_all(&opts.out_dir)
            .map_err(|e| Error::io(&opts.out_dir, FileOp::CreateFolder, e))?;
        let dir = &opts.out_dir;
        let spec = &problem.spec;
        write_image(&dir.join("target.exr"), &problem.target)?;
        write_image(&dir.join("target.png"), &problem.target)?;

        let csv_path = dir.join("optimize.csv");
        let mut csv = std::fs::File::create(&csv_path)
            .map_err(|e| Error::io(&csv_path, FileOp::Create, e))?;
        let truth = spec.truth();
        let header = csv_header(spec, truth.is_some());
        csv.write_all(header.as_bytes())
            .map_err(|e| Error::io(&csv_path, FileOp::Write, e))?;

        let bar = progress_bar(run, opts.progress);
        let deferred = raylab::io::interrupt::defer();
        let mut theta = problem.start();
        let mut optimizer = Optimizer::new(spec.optimizer, theta.len());
        let mut history: Vec<Iteration> = Vec::new();
        // The iterates after each step.
        let mut iterates: Vec<Vec<f64>> = Vec::new();
        let start = Instant::now();
        let mut interrupted = false;
        for i in 0..run {
            let it = problem
                .iterate(i, &mut theta, &mut optimizer, opts.threads)
                .map_err(|error| Error::Iteration {
                    iteration: i,
                    error,
                })?;
            // One write per row: a killed run leaves whole rows.
            csv.write_all(csv_row(&it, truth.as_deref()).as_bytes())
                .and_then(|()| csv.flush())
                .map_err(|e| Error::io(&csv_path, FileOp::Write, e))?;
            iterates.push(theta.clone());
            write_final(&problem, &theta, dir, &opts.spec, i + 1, 1)?;
            bar.set_message(format!("loss {:.4e}", it.loss));
            bar.inc(1);
            history.push(it);
            if raylab::io::interrupt::requested() {
                interrupted = true;
                break;
            }
        }
        let optimize_s = start.elapsed().as_secs_f64();
        bar.finish_and_clear();
        drop(deferred);
        // The iterates of the spec's last `average_last` steps that ran (a
        // run stopped early averages only what reached that window).
        let window = spec.iterations.saturating_sub(spec.optimizer.average_last);
        let averaged = (iterates.len() as u32).saturating_sub(window);
        if averaged > 1 {
            theta = average_last(&iterates, averaged);
            write_final(
                &problem,
                &theta,
                dir,
                &opts.spec,
                iterates.len() as u32,
                averaged,
            )?;
        }

        draw_figures(
            &problem,
            &history,
            &theta,
            truth.as_deref(),
            dir,
            opts.threads,
        )?;
        let params = spec
            .params
            .iter()
            .enumerate()
            .map(|(k, p)| ParamOutcome {
                name: p.name.clone(),
                start: f64::from(p.start),
                end: theta[k],
                truth: truth.as_ref().map(|t| f64::from(t[k])),
            })
            .collect();
        Ok(Self {
            spec: opts.spec.clone(),
            out_dir: opts.out_dir.clone(),
            description: spec.description.clone(),
            setup: format!(
                "{}, {}, {} loss, {}",
                spec.integrator.name(),
                spec.sampler.name(),
                spec.loss.name(),
                spec.optimizer.describe()
            ),
            iterations: history.len() as u32,
            asked: run,
            planned: spec.iterations,
            averaged: averaged.max(1),
            interrupted,
            target_s: problem.target_seconds,
            optimize_s,
            first_loss: history.first().map_or(f64::NAN, |h| h.loss),
            last_loss: history.last().map_or(f64::NAN, |h| h.loss),
            params,
        })
    }
}

/// The files `optimize` writes into its folder (the figures as PNG and
/// SVG).
const OUTPUTS: [&str; 10] = [
    "target.exr",
    "target.png",
    "optimize.csv",
    "final.toml",
    "loss.png",
    "loss.svg",
    "params.png",
    "params.svg",
    "images.png",
    "images.svg",
];

/// Refuse an output folder where one of [`OUTPUTS`] is an input: the spec,
/// its scene or its target image (`-o` set to the spec's own folder would
/// replace the user's `target.png`).
fn check_outputs_of(spec: &Spec, spec_path: &Path, dir: &Path) -> Result<(), Error> {
    let mut inputs = vec![
        ("the spec", spec_path),
        ("the spec's scene", spec.source.path.as_path()),
    ];
    if let OptimizeTarget::Image(target) = &spec.target {
        inputs.push(("the spec's target image", target.as_path()));
    }
    let outputs: Vec<_> = OUTPUTS
        .iter()
        .map(|name| (format!("-o's {name}"), dir.join(name)))
        .collect();
    let outputs: Vec<_> = outputs
        .iter()
        .map(|(role, p)| (role.as_str(), p.as_path()))
        .collect();
    Ok(raylab::io::check_outputs(&inputs, &outputs)?)
}

/// `DIR/final.toml`: the scene with `theta`, after `done` iterations, the
/// mean of the last `averaged` iterates.
fn write_final(
    problem: &Problem,
    theta: &[f64],
    dir: &Path,
    spec: &Path,
    done: u32,
    averaged: u32,
) -> Result<(), Error> {
    let text = problem.text_for(theta, dir)?;
    let what = if averaged > 1 {
        format!(", the mean of the last {averaged} iterates")
    } else {
        String::new()
    };
    let head = format!(
        "# Written by `raylab optimize {}` after {done} iteration{}{what}.\n",
        spec.display(),
        if done == 1 { "" } else { "s" }
    );
    let path = dir.join("final.toml");
    write_atomically(&path, |p| {
        std::fs::write(p, head + &text).map_err(|e| Error::io(&path, FileOp::Write, e))
    })
}

fn csv_header(spec: &Spec, truth: bool) -> String {
    let mut cols = vec![
        "iteration".to_string(),
        "loss".into(),
        "gradient_norm".into(),
        "rate_factor".into(),
        "seconds".into(),
    ];
    if truth {
        cols.push("max_rel_error".into());
    }
    cols.extend(spec.params.iter().map(|p| p.name.clone()));
    cols.extend(spec.params.iter().map(|p| format!("grad:{}", p.name)));
    cols.join(",") + "\n"
}

fn csv_row(it: &Iteration, truth: Option<&[f32]>) -> String {
    let mut cols = vec![
        it.index.to_string(),
        format!("{:.6e}", it.loss),
        format!("{:.6e}", it.gradient_norm()),
        format!("{:.6e}", it.rate_factor),
        format!("{:.6}", it.seconds),
    ];
    if let Some(t) = truth {
        cols.push(format!("{:.6e}", max_error(&it.theta, t)));
    }
    cols.extend(it.theta.iter().map(|v| format!("{v:.7}")));
    cols.extend(it.gradient.iter().map(|g| format!("{g:.6e}")));
    cols.join(",") + "\n"
}

fn max_error(theta: &[f64], truth: &[f32]) -> f64 {
    theta
        .iter()
        .zip(truth)
        .map(|(&v, &t)| relative_error(v, f64::from(t)))
        .fold(0.0, f64::max)
}

fn progress_bar(n: u32, enabled: bool) -> indicatif::ProgressBar {
    if !enabled || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(u64::from(n));
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "optimize [{bar:30}] {pos}/{len} iterations, {msg}, eta {eta}",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

/// loss, params and images (module docs).
fn draw_figures(
    problem: &Problem,
    history: &[Iteration],
    end: &[f64],
    truth: Option<&[f32]>,
    dir: &Path,
    threads: Option<usize>,
) -> Result<(), Error> {
    if history.is_empty() {
        return Ok(());
    }
    let spec = &problem.spec;
    let name = spec
        .path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    let mut loss = LineChart::new(
        format!("{name}: loss"),
        "iteration",
        format!("{} loss against the target", spec.loss.name()),
    );
    loss.y_scale = AxisScale::Log10;
    loss.series.push(Series::new(
        format!(
            "loss of a {}-spp render (gradient: {} spp)",
            spec.image_sampler.spp(),
            spec.sampler.spp()
        ),
        history
            .iter()
            .map(|h| (f64::from(h.index), h.loss))
            .collect(),
        SeriesStyle::Line,
    ));
    loss.save(&dir.join("loss"))?;

    let mut params = match truth {
        Some(_) => {
            let mut c = LineChart::new(
                format!("{name}: parameter error"),
                "iteration",
                "relative error |θ − θ*| / |θ*|",
            );
            c.y_scale = AxisScale::Log10;
            c
        }
        None => LineChart::new(format!("{name}: parameters"), "iteration", "value"),
    };
    for (k, p) in spec.params.iter().enumerate() {
        let points = history
            .iter()
            .map(|h| {
                let v = h.theta[k];
                let y = truth.map_or(v, |t| relative_error(v, f64::from(t[k])));
                (f64::from(h.index), y)
            })
            .collect();
        // The palette has eight colours: the ninth series on are dashed.
        let style = if k < 8 {
            SeriesStyle::Line
        } else {
            SeriesStyle::Dashed
        };
        params
            .series
            .push(Series::new(p.name.clone(), points, style));
    }
    params.save(&dir.join("params"))?;

    let mut grid = ImageGrid::new(format!("{name}: renders during the optimisation"), 4);
    grid.cells
        .push((problem.target.clone(), "target".to_string()));
    for &i in &spec.snapshots {
        if let Some(h) = history.get(i as usize) {
            let img = problem.snapshot(&h.theta, threads)?;
            grid.cells.push((img, format!("iteration {i}")));
        }
    }
    let img = problem.snapshot(end, threads)?;
    grid.cells
        .push((img, format!("after {} iterations", history.len())));
    grid.save(&dir.join("images"))?;
    Ok(())
}

impl fmt::Display for OptimizeReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "optimize {}: {}", self.spec.display(), self.setup)?;
        if !self.description.is_empty() {
            writeln!(f, "{}", self.description)?;
        }
        if self.asked < self.planned {
            writeln!(
                f,
                "stopped after {} of the spec's {} iterations (--stop-after)",
                self.asked, self.planned
            )?;
        }
        if self.interrupted {
            writeln!(
                f,
                "interrupted (Ctrl-C) after {} of {} iterations",
                self.iterations, self.asked
            )?;
        }
        writeln!(
            f,
            "{} iterations in {:.2} s ({:.3} s each; target {:.2} s); loss {:.4e} → {:.4e}",
            self.iterations,
            self.optimize_s,
            self.optimize_s / f64::from(self.iterations.max(1)),
            self.target_s,
            self.first_loss,
            self.last_loss
        )?;
        if self.averaged > 1 {
            writeln!(f, "final: the mean of the last {} iterates", self.averaged)?;
        }
        writeln!(
            f,
            "{:<34} {:>11} {:>11} {:>11} {:>10}",
            "parameter", "start", "final", "true", "rel.error"
        )?;
        for p in &self.params {
            match p.truth {
                Some(t) => writeln!(
                    f,
                    "{:<34} {:>11.5} {:>11.5} {:>11.5} {:>9.3}%",
                    p.name,
                    p.start,
                    p.end,
                    t,
                    100.0 * relative_error(p.end, t)
                )?,
                None => writeln!(f, "{:<34} {:>11.5} {:>11.5}", p.name, p.start, p.end)?,
            }
        }
        if let Some(e) = self.max_relative_error() {
            writeln!(f, "largest relative error: {:.3}%", 100.0 * e)?;
        }
        write!(
            f,
            "optimize.csv, final.toml and figures in {}",
            self.out_dir.display()
        )
    }
}
