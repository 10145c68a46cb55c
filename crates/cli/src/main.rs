//! The `raylab` command line: the arguments (clap) and the dispatch. Each
//! command's work and output live in the library's top layer,
//! [`raylab_lab::report`]; `commands` turns the arguments into that
//! module's options, runs the report, and prints it.

// No unsafe code here, and none to come: the workspace's unsafe lives in
// `raylab`, each block with its SAFETY argument.
#![forbid(unsafe_code)]

use anyhow::Result;
use clap::{Parser, Subcommand};
use raylab::accel::AccelKind;
use raylab::film::Filter;
use raylab::integrator::IntegratorKind;
use raylab::io::scene_file::Overrides;
use raylab::sampler::Sampler;
use raylab::scene::param::Setting;
use raylab_lab::experiment;
use raylab_lab::report::{self, print_stdout};
use std::path::PathBuf;
use std::process::ExitCode;

mod commands;
#[cfg(feature = "embree")]
use commands::cmd_validate;
use commands::{
    cmd_diff, cmd_experiment, cmd_grad, cmd_merge, cmd_optimize, cmd_plot, cmd_render,
    cmd_spectrum, cmd_stats, quiet_wayland_probe,
};

/// raylab: render, count, measure and plot what ray tracing costs.
#[derive(Parser, Debug)]
#[command(name = "raylab", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene file to an image (PNG: 8-bit sRGB; EXR: linear float
    /// with per-pixel statistics).
    ///
    /// Prints the resolution, the rays traced by kind, the time to load the
    /// scene and to render it, rays per second, and the mean per-pixel
    /// variance; with --reference also MSE and relMSE against it. An EXR
    /// output holds channels R, G, B (each pixel's mean), variance.R/G/B
    /// (the unbiased sample variance of its samples) and count (samples).
    ///
    /// On a terminal, a render that takes more than a second shows a
    /// progress bar (rows, rate, ETA) on stderr; never in pipes or with
    /// --quiet. Ctrl-C leaves no partial output file (exit status 130).
    Render(RenderArgs),
    /// Derivatives of the image with respect to scene parameters
    /// (forward-mode automatic differentiation through the renderer).
    ///
    /// Writes the render and, per parameter, the image of ∂pixel/∂param
    /// (EXR with per-pixel variances, and a PNG on a diverging colour
    /// scale); prints each parameter's derivative of the image mean with
    /// its standard error, and the time against the plain render. Runs
    /// `whitted`, `direct` and `path:K` on the render's own samples (same
    /// seed), so each pixel is the derivative of the same estimator.
    ///
    /// Forward mode alone gives the *interior* derivative, which misses
    /// the change of which surface a sample sees when a parameter moves
    /// geometry (positions, radii, transforms, the camera, light
    /// positions). By default (`--visibility full`) the boundary term is
    /// added: edge sampling of the silhouettes, horizons, shadow edges and
    /// meetings of surfaces (spheres and ellipsoids through planes, spheres
    /// through spheres) the camera sees (under Whitted, in mirrors and
    /// through glass too) and, under `direct` and `path:K`, those every
    /// path vertex sees. Not covered: meshes seen in curved mirrors or
    /// through glass. `--check fd` compares with central differences.
    Grad(GradArgs),
    /// Recover scene parameters from an image: gradient descent (Adam or
    /// plain) on a loss between renders and a target.
    ///
    /// The spec (TOML) names the scene, the target (an image file, or the
    /// same scene with other parameter values, rendered first), the
    /// parameters with bounds and start values, the loss (l2, l1,
    /// relative_l2), the optimiser, the iterations and the samples per
    /// iteration; its format is in the book's command-line reference
    /// (book/src/reference/cli.md). Each iteration renders the gradient
    /// and the image with fresh, independent seeds.
    ///
    /// Writes to the output folder optimize.csv (one row per iteration:
    /// loss, gradient norm, parameters, gradient), final.toml (the scene
    /// with the latest parameters, after every iteration), target.exr/png
    /// and the figures loss, params and images (PNG + SVG); prints each
    /// parameter's start, final and (when known) true value. On a terminal
    /// a progress bar shows the loss. The first Ctrl-C stops after the
    /// current iteration and still draws the figures (exit status 130);
    /// a second ends at once. Rows already written stay whole.
    ///
    /// The derivatives are `raylab grad`'s, with the boundary term unless
    /// the spec says `visibility = "interior"`.
    Optimize(OptimizeArgs),
    /// Compare an image with a reference (MSE, relMSE, PSNR, ꟻLIP).
    ///
    /// Prints the mean squared error, relative MSE, PSNR, the largest
    /// absolute error and NVIDIA's ꟻLIP statistics. Both images are read as linear RGB (PNG is decoded from sRGB, EXR is
    /// taken as is) and must have the same size. PSNR is printed as `inf`
    /// in JSON (∞ in the table) when the images are identical.
    Diff(DiffArgs),
    /// Run an experiment manifest: timed sweeps to data.csv, meta.json, figures.
    ///
    /// Runs every point of the sweeps of a manifest (analysis/NAME.toml)
    /// with a progress bar, appending one row per run to data.csv, and
    /// writes meta.json and the manifest's figures (PNG + SVG). The manifest
    /// format is described in book/src/reference/manifests.md; the study
    /// kinds are listed below (`--help`).
    /// Build with --release: timings of a debug build mean little, and raylab
    /// warns when it is one.
    #[command(after_long_help = experiment::study::kinds_help())]
    Experiment(ExperimentArgs),
    /// Merge the shards of an experiment (`experiment --shard I/N`) into
    /// one data.csv, meta.json and the manifest's figures.
    ///
    /// Refuses shards of different manifests (the manifest hash in their
    /// meta.json), raylab versions, git revisions or shard counts, a shard
    /// given twice, and rows that appear in two shards; lists the runs that
    /// no shard has (and fails unless --allow-missing). The rows are written
    /// in the manifest's order, as an unsharded run writes them; meta.json
    /// lists each shard's machine, threads, start, end and wall time.
    /// scripts/slurm/ and scripts/parallel/ run shards and merge them.
    Merge(MergeArgs),
    /// Draw an experiment's figures again from its data.csv and meta.json
    /// (the manifest it recorded), with this raylab's plotting code and
    /// without re-running anything: after copying a run from another
    /// machine, or for the book's committed full runs.
    Plot {
        /// The experiment's folder (data.csv and meta.json).
        dir: PathBuf,
        /// Write the figures (and a copy of the data) here instead.
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Draw the figures of this manifest (as edited since the run)
        /// instead of the one meta.json recorded; its runs must include
        /// every row of the table.
        #[arg(long, value_name = "FILE")]
        manifest: Option<PathBuf>,
    },
    /// Count what tracing a scene costs with each accelerator: a pbrt-style
    /// table (rays by kind, nodes visited, volume and primitive tests, per-ray
    /// means, p50/p90/p99/max per camera ray, BVH shape, build and render
    /// times) and per-pixel heatmaps `<accel>-nodes` and `<accel>-prim-tests`
    /// (PNG + SVG, log scale; `:` in names becomes `-`).
    ///
    /// Default accelerators: brute (only below 5000 primitives),
    /// bvh:aabb:sah, bvh4, bvh8 (not with --device gpu), bvh:sphere:s3, bvh:ellipsoid:s3.
    Stats {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Accelerator to measure; repeat to compare several.
        #[arg(long)]
        accel: Vec<AccelKind>,
        /// Image width in pixels (overrides the scene's).
        #[arg(long)]
        width: Option<u32>,
        /// Image height in pixels (overrides the scene's).
        #[arg(long)]
        height: Option<u32>,
        /// Heatmap folder (default: out/stats/<scene stem>/).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Render threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// `cpu` (default) or `gpu`: where the render with counters runs.
        /// On the GPU each invocation counts its own pixel's rays, node
        /// visits and tests (no atomics), under the CPU's conventions; the
        /// per-camera-ray distributions are traced on the CPU.
        #[arg(long, value_parser = report::render::Device::parse, default_value = "cpu")]
        device: report::render::Device,
    },
    /// Check raylab's intersections against Embree 4 as the oracle.
    ///
    /// Generates named ray sets over a mesh or a scene (random rays through
    /// the bounds, rays aimed at the surface, camera rays, rays from inside
    /// closed meshes and quadrics, rays aimed exactly at edges and vertices,
    /// grazing rays), traces each with raylab's accelerators and with
    /// Embree (closest hit and any-hit), and prints a table per ray set:
    /// disagreements classified by where the first hit lies (edge, vertex,
    /// grazing, elsewhere), which side leaked at edges, |Δt|/t percentiles
    /// and normal angles; then the worst cases. Exits with status 1 when a
    /// set breaks the tolerances (defaults: no disagreement away from edges,
    /// vertices and grazing hits; |Δt|/t ≤ 1e-5 beyond 1° from grazing;
    /// normals within 1e-4 rad).
    #[cfg(feature = "embree")]
    Validate(ValidateArgs),
    /// Power spectra of sampling patterns: point-set periodograms.
    ///
    /// Each point set is one pixel's samples (index 0 … spp−1) of the
    /// sampler; the periodogram P(k) = |Σⱼ exp(−2πi k·xⱼ)|² / N (Heck,
    /// Schlömer & Deussen 2013, a direct sum over integer frequencies
    /// k ∈ [−F, F]²) is averaged over M pixels. Writes into --out:
    /// spectrum.png/.svg (log-scale periodogram, DC at the centre; one per
    /// sampler, spectrum-NAME, when several are given), radial.png/.svg
    /// (radially averaged power, rings of width 1, with the white-noise
    /// line P = 1 and the sampling rate √N), anisotropy.png/.svg (dB, with
    /// the white-noise line 10·log10(1/M)) and spectrum.csv (every ring of
    /// every sampler); prints a summary per sampler.
    Spectrum(SpectrumArgs),
}

#[derive(clap::Args, Debug)]
struct SpectrumArgs {
    /// Samplers, comma-separated, as for `render --sampler` (e.g.
    /// `jitter:4,random:16,sobol:16`); several are overlaid in the charts.
    #[arg(long, required = true, value_delimiter = ',', value_parser = Sampler::parse)]
    sampler: Vec<Sampler>,
    /// Point sets (pixels) averaged, M.
    #[arg(long, default_value_t = 1024)]
    sets: usize,
    /// Frequency bound F: k ranges over [−F, F]², rings 1 … F−1.
    #[arg(long, default_value_t = 32)]
    freq: usize,
    /// Seed of the randomised samplers.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
}

#[cfg(feature = "embree")]
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["mesh", "scene"])))]
struct ValidateArgs {
    /// Mesh file (.obj, .ply, .off, .3ds).
    #[arg(long)]
    mesh: Option<PathBuf>,
    /// Scene file (TOML): its bounded primitives and its camera (planes are
    /// left out: Embree has no infinite plane).
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Rays per ray set (e.g. 10000 or 1e5).
    #[arg(long, default_value = "10000", value_parser = parse_count)]
    rays: usize,
    /// Seed of the ray sets.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// raylab accelerators to check, comma-separated (default: brute below
    /// 5000 primitives, and bvh).
    #[arg(long, value_delimiter = ',')]
    accel: Vec<AccelKind>,
    /// The Embree configuration of the oracle: `embree[:low|medium|high][+robust]`.
    #[arg(long, default_value = "embree")]
    embree: raylab::accel::EmbreeConfig,
    /// Largest |Δt|/t for same-primitive hits beyond the grazing angle.
    #[arg(long, default_value_t = 1e-5, value_parser = parse_tolerance)]
    t_rel: f32,
    /// Angle to the surface (degrees) below which a hit counts as grazing.
    #[arg(long, default_value_t = 1.0, value_parser = parse_tolerance)]
    grazing_deg: f32,
    /// Largest angle (rad) between the two sides' normals (non-grazing hits).
    #[arg(long, default_value_t = 1e-4, value_parser = parse_tolerance)]
    normal_angle: f32,
    /// Allowed unexplained disagreements plus tolerance breaches per set.
    #[arg(long, default_value_t = 0)]
    max_unexplained: u64,
    /// Allowed edge/vertex/grazing disagreements per set (default: any).
    #[arg(long)]
    max_borderline: Option<u64>,
    /// Write the worst cases (ray, both answers) to this CSV file.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// How many worst cases to print and write.
    #[arg(long, default_value_t = 10)]
    worst: usize,
    /// Folder for histograms of |Δt|/t and normal angles and a bar chart of
    /// disagreements (PNG + SVG).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// An option's value that its parser below rejects (clap prints it after
/// the option's name).
#[derive(Debug, thiserror::Error)]
enum BadValue {
    /// `--rays`: not a number.
    #[error("`{0}` is not a number (expected a count such as 10000 or 1e6)")]
    #[cfg_attr(not(feature = "embree"), allow(dead_code))]
    NotANumber(String),
    /// `--rays`: not a whole number in range.
    #[error("`{0}` must be a whole number from 1 to 1e9")]
    #[cfg_attr(not(feature = "embree"), allow(dead_code))]
    Count(String),
    /// A tolerance of `validate`.
    #[error("`{0}` is not a finite, non-negative number")]
    #[cfg_attr(not(feature = "embree"), allow(dead_code))]
    Tolerance(String),
    /// `--rr-depth`.
    #[error("`{0}` is not a bounce count (a whole number ≥ 0) or `off`")]
    RrDepth(String),
}

/// A count such as `10000`, `1e6` or `2.5e5`: a whole number ≥ 1.
#[cfg(feature = "embree")]
fn parse_count(s: &str) -> Result<usize, BadValue> {
    let v: f64 = s.parse().map_err(|_| BadValue::NotANumber(s.into()))?;
    if !((1.0..=1e9).contains(&v) && v.fract() == 0.0) {
        return Err(BadValue::Count(s.into()));
    }
    Ok(v as usize)
}

/// A finite, non-negative number.
#[cfg(feature = "embree")]
fn parse_tolerance(s: &str) -> Result<f32, BadValue> {
    match s.parse::<f32>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(BadValue::Tolerance(s.into())),
    }
}

#[derive(clap::Args, Debug)]
struct DiffArgs {
    /// The image to judge (.png or .exr).
    test: PathBuf,
    /// The reference image (.png or .exr), same size as TEST.
    reference: PathBuf,
    /// Write the ꟻLIP error map here as a magma-coloured PNG.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the metrics as one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args, Debug)]
struct ExperimentArgs {
    /// The manifest (TOML).
    manifest: PathBuf,
    /// Run the reduced version declared in the manifest's [quick] block.
    #[arg(long)]
    quick: bool,
    /// Keep the rows of an existing data.csv and run only the missing ones.
    #[arg(long)]
    resume: bool,
    /// Output folder (default: out/NAME beside the manifest, e.g.
    /// analysis/out/NAME).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Worker threads (default: the manifest's `threads`, else all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Run only shard I of N (1 ≤ I ≤ N): every N-th run of the plan,
    /// starting at the I-th, into its own folder (default
    /// out/NAME.shards/I-of-N beside the manifest), without figures; join
    /// the shards with `raylab merge`.
    #[arg(long, value_name = "I/N")]
    shard: Option<experiment::Shard>,
}

#[derive(clap::Args, Debug)]
struct MergeArgs {
    /// The merged experiment's folder (created when missing).
    out: PathBuf,
    /// The shards' folders (each written by `experiment --shard I/N`).
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// Merge and draw the figures even when some runs are in no shard
    /// (meta.json then says "complete": false).
    #[arg(long)]
    allow_missing: bool,
}

/// What `render` and `grad` share: the scene and how to render it.
#[derive(clap::Args, Debug)]
struct SceneArgs {
    /// Scene file (TOML; schema in book/src/reference/scene-files.md).
    scene: PathBuf,
    /// Image width in pixels (overrides the scene's [image] width).
    #[arg(long)]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene's [image] height).
    #[arg(long)]
    height: Option<u32>,
    /// Worker threads (default: all cores). Images are identical for any count.
    #[arg(long)]
    threads: Option<usize>,
    /// Pixel sampler: `centre` (1 sample), `ogss:K` (K×K ordered grid),
    /// `rgss` (4-sample rotated grid), `jitter:K` (K×K stratified),
    /// `random:N`, `halton:N` or `sobol:N` (randomised per pixel), or
    /// `adaptive[:T[:D]]` (rays through pixel corners, squares whose corners
    /// differ in contrast by more than T (default 0.1) split in four, D
    /// levels deep (default 2)).
    #[arg(long, value_parser = Sampler::parse)]
    sampler: Option<Sampler>,
    /// Reconstruction filter: `box` (each pixel's own samples, S1's
    /// downsample), `tent` (radius 1 pixel) or `mitchell` (Mitchell–Netravali
    /// B = C = 1/3, radius 2). Not used by the adaptive sampler.
    #[arg(long, value_parser = Filter::parse)]
    filter: Option<Filter>,
    /// Accelerator (default: the scene's): `brute`, `bvh` (fastest: `bvh8`, 8-wide,
    /// AVX2 nodes, packet leaves), `bvh4` (4-wide), binary `bvh2` = `bvh:aabb:sah` or
    /// `bvh:volume[:builder[:leaf]]` (volume aabb|sphere|sphere-ritter|ellipsoid|
    /// ellipsoid-ritter, builder s3|sah), or `embree[:low|medium|high][+robust]`.
    #[arg(long)]
    accel: Option<AccelKind>,
    /// Integrator: `whitted` (recursive Phong/Whitted, the default),
    /// `direct` (path tracer, direct light only: emission seen plus light
    /// sampled at the first hit) or `path:K` (Monte Carlo path tracing with
    /// up to K bounces after the camera hit, i.e. paths of up to K+1
    /// reflections; MIS between light and BRDF sampling) or
    /// `floodfill[:key=value,…]` (S4: one bounce, then the voxel flood-fill
    /// cache × albedo; keys res, alpha, avg=linear|gamma, bounce=on|off,
    /// lookup=hemisphere|trilinear, warm=N|converge, steps, max, light; or
    /// `floodfill:s4`). Samples per pixel come from --sampler (e.g.
    /// `random:16`, `sobol:64`).
    #[arg(long, default_value = "whitted", value_parser = IntegratorKind::parse)]
    integrator: IntegratorKind,
    /// Path tracer: bounces taken before Russian roulette may end a path
    /// (default 3), or `off` to trace every path to K bounces.
    #[arg(long, value_parser = parse_rr_depth)]
    rr_depth: Option<RrDepth>,
    /// Maximum recursion depth of the Whitted integrator (camera rays are
    /// depth 0).
    #[arg(long)]
    max_depth: Option<u32>,
    /// Seed for randomised samplers and integrators.
    #[arg(long)]
    seed: Option<u64>,
    /// Set a scene parameter: PATH=VALUE, PATH a name `raylab grad --param`
    /// takes (`light[0].intensity`, `materials.glass.transparency`,
    /// `sphere[1].radius`, `camera.fov`, `render.ambient`…) and VALUE a
    /// number, or `[x,y,z]` for a vector (a component such as
    /// `materials.red.color[0]` takes a number). Repeat for more; applied in
    /// order after the other options, and the scene is then checked as a
    /// scene file is. Quote it in a shell: `--set 'render.ambient=[2,2,2]'`.
    #[arg(long = "set", value_name = "PATH=VALUE", value_parser = Setting::parse)]
    set: Vec<Setting>,
}

impl SceneArgs {
    fn overrides(&self) -> Overrides {
        Overrides {
            width: self.width,
            height: self.height,
            sampler: self.sampler,
            filter: self.filter,
            accel: self.accel,
            max_depth: self.max_depth,
            seed: self.seed,
        }
    }

    fn integrator(&self) -> IntegratorKind {
        match self.rr_depth {
            Some(RrDepth(rr)) => self.integrator.with_rr_start(rr),
            None => self.integrator,
        }
    }
}

#[derive(clap::Args, Debug)]
struct RenderArgs {
    #[command(flatten)]
    common: SceneArgs,
    /// Output image; the extension chooses the format (.png or .exr).
    #[arg(short, long)]
    output: PathBuf,
    /// Also write each pixel's sample count (rays spent by the adaptive
    /// sampler) as a heatmap PNG.
    #[arg(long)]
    spp_map: Option<PathBuf>,
    /// Reference image (.exr or .png, same size) to report MSE and relMSE
    /// against.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
    /// `cpu` (default) or `gpu`: the GPU port of the Whitted integrator
    /// (WGSL through wgpu: Vulkan, Metal or DX12; Mesa's lavapipe where
    /// there is no GPU). Prints the adapter and the upload, shader-build,
    /// kernel and readback times.
    #[arg(long, value_parser = report::render::Device::parse, default_value = "cpu")]
    device: report::render::Device,
}

#[derive(clap::Args, Debug)]
struct GradArgs {
    #[command(flatten)]
    common: SceneArgs,
    /// A parameter to differentiate by, named by its place in the scene
    /// file: `materials.NAME.color[0]`, `light[0].position[2]`,
    /// `sphere[1].radius`, `triangle[4].vertices[1][0]`,
    /// `mesh[0].translate[1]`, `camera.fov`… A vector without an index
    /// means all its components. Repeat for more.
    #[arg(long = "param", required = true)]
    params: Vec<String>,
    /// Output folder: image.exr (the render), and per parameter
    /// <param>.exr (R, G, B = ∂pixel/∂param, variance.R/G/B, count) and
    /// <param>.png (+ .svg, the channel mean on a diverging scale).
    #[arg(short, long)]
    output: PathBuf,
    /// Check against central finite differences: `fd` (step by the rule
    /// h = ε^(1/3)·max(|p|, 1)) or `fd:H` (step H). Two extra renders per
    /// parameter; writes <param>.fd-diff.png.
    #[arg(long, value_parser = report::grad::FdCheck::parse)]
    check: Option<report::grad::FdCheck>,
    /// `full`: the whole derivative, forward mode plus the boundary term
    /// at silhouettes and shadow edges (edge sampling; also written alone
    /// to <param>.boundary.exr/png); `interior`: forward mode alone,
    /// biased where a parameter moves an edge.
    #[arg(long, default_value = "full", value_parser = raylab::diff::Visibility::parse)]
    visibility: raylab::diff::Visibility,
}

#[derive(clap::Args, Debug)]
struct OptimizeArgs {
    /// The optimisation spec (TOML).
    spec: PathBuf,
    /// Output folder: optimize.csv, final.toml, target.exr/png, figures.
    #[arg(short, long)]
    output: PathBuf,
    /// Stop after N iterations: the first N of the spec's run, with its
    /// rate schedule (a quick look at a long run); snapshots beyond them
    /// are dropped.
    #[arg(long, value_name = "N")]
    stop_after: Option<u32>,
    /// Render the target (when the spec gives it as values) with this
    /// sampler instead of the spec's `[target] sampler`: a quicker, noisier
    /// target for a quick look (e.g. `random:1024`).
    #[arg(long, value_name = "SAMPLER", value_parser = Sampler::parse)]
    target_sampler: Option<Sampler>,
    /// Render threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print nothing but errors (and no progress bar).
    #[arg(short, long)]
    quiet: bool,
}

/// `--rr-depth`: a bounce count, or `off`.
#[derive(Clone, Copy, Debug)]
struct RrDepth(Option<u32>);

fn parse_rr_depth(s: &str) -> Result<RrDepth, BadValue> {
    if s == "off" {
        return Ok(RrDepth(None));
    }
    s.parse::<u32>()
        .map(|k| RrDepth(Some(k)))
        .map_err(|_| BadValue::RrDepth(s.into()))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // Ctrl-C leaves no partial output file (io::interrupt).
    #[cfg(unix)]
    raylab::io::interrupt::install();
    let result = match cli.command {
        Command::Render(args) => cmd_render(args),
        Command::Grad(args) => cmd_grad(args),
        Command::Optimize(args) => return cmd_optimize(args),
        Command::Diff(args) => cmd_diff(args),
        Command::Experiment(args) => cmd_experiment(args),
        Command::Merge(args) => cmd_merge(args),
        Command::Plot { dir, out, manifest } => cmd_plot(&dir, out.as_deref(), manifest.as_deref()),
        Command::Stats {
            scene,
            accel,
            width,
            height,
            out,
            threads,
            device,
        } => {
            quiet_wayland_probe(device);
            let opts = report::StatsOptions {
                scene,
                accels: accel,
                width,
                height,
                out,
                threads,
                device,
            };
            cmd_stats(&opts)
        }
        #[cfg(feature = "embree")]
        Command::Validate(args) => cmd_validate(args),
        Command::Spectrum(args) => cmd_spectrum(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            exit_status(&e)
        }
    }
}

/// 2 for a usage error found once the scene is read (a `--set` it
/// refuses), as clap exits for the options it refuses; 1 otherwise.
fn exit_status(e: &anyhow::Error) -> ExitCode {
    match e.downcast_ref::<raylab_lab::Error>() {
        Some(e) if e.is_usage() => ExitCode::from(2),
        _ => ExitCode::FAILURE,
    }
}
