//! The `raylab` command line: parses arguments and calls the library.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use raylab::accel::AccelKind;
use raylab::analysis::diff_files;
use raylab::experiment;
use raylab::integrator::{render, Whitted};
use raylab::io::image::{write_image, ImageFormat};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::sampler::Sampler;
use raylab::stats::RayCounts;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// raylab: render, count, measure and plot what ray tracing costs.
#[derive(Parser, Debug)]
#[command(name = "raylab", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene file to an image (PNG: 8-bit sRGB; EXR: linear float).
    ///
    /// Prints the resolution, the rays traced by kind, the time to load the
    /// scene and to render it, and rays per second.
    Render(RenderArgs),
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
    /// writes meta.json and the manifest's figures (PNG + SVG). The manifest format is described in the README ("Running an
    /// experiment"). Study kinds: render_cost (time and counts of rendering a
    /// scene file) and accel_cost (an accelerator on a mesh in an automatic
    /// S3-style scene: build and render time, tests per ray, bounding-volume
    /// test cost, wasted volume, image equality with brute force; e.g.
    /// analysis/s3-bvh-ladder.toml, analysis/bvh-volumes.toml), accel_speed
    /// (raylab's BVH against Embree on identical rays: Mrays/s and their
    /// ratio, analysis/embree-speed.toml) and embree_oracle (validation
    /// against Embree over meshes and quadrics, analysis/embree-oracle.toml)
    /// and floodfill (S4's voxel flood-fill irradiance cache: residual per
    /// step, grid snapshots, step time, light leaking;
    /// analysis/floodfill-convergence.toml).
    /// Build with --release: timings of a debug build mean little, and raylab
    /// warns when it is one.
    Experiment(ExperimentArgs),
    /// Count what tracing a scene costs with each accelerator: a pbrt-style
    /// table (rays by kind, nodes visited, volume and primitive tests, per-ray
    /// means, p50/p90/p99/max per camera ray, BVH shape, build and render
    /// times) and per-pixel heatmaps `<accel>-nodes` and `<accel>-prim-tests`
    /// (PNG + SVG, log scale; `:` in names becomes `-`).
    ///
    /// Default accelerators: brute (only below 5000 primitives),
    /// bvh:aabb:sah, bvh4, bvh:sphere:s3, bvh:ellipsoid:s3.
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

/// A count such as `10000`, `1e6` or `2.5e5`: a whole number ≥ 1.
#[cfg(feature = "embree")]
fn parse_count(s: &str) -> Result<usize, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number (expected a count such as 10000 or 1e6)"))?;
    if !((1.0..=1e9).contains(&v) && v.fract() == 0.0) {
        return Err(format!("`{s}` must be a whole number from 1 to 1e9"));
    }
    Ok(v as usize)
}

/// A finite, non-negative number.
#[cfg(feature = "embree")]
fn parse_tolerance(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("`{s}` is not a finite, non-negative number")),
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
}

#[derive(clap::Args, Debug)]
struct RenderArgs {
    /// Scene file (TOML; schema in the README).
    scene: PathBuf,
    /// Output image; the extension chooses the format (.png or .exr).
    #[arg(short, long)]
    output: PathBuf,
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
    /// `random:N`, `halton:N` or `sobol:N` (randomised per pixel).
    #[arg(long, value_parser = Sampler::parse)]
    sampler: Option<Sampler>,
    /// Accelerator (default: the scene's): `brute`, `bvh[:volume[:builder[:leaf]]]`
    /// (volume aabb|sphere|sphere-ritter|ellipsoid|ellipsoid-ritter, builder
    /// s3|sah; `bvh` = bvh:aabb:sah), `bvh4` (4-wide box BVH, the fastest) or
    /// `embree[:low|medium|high][+robust]`.
    #[arg(long)]
    accel: Option<AccelKind>,
    /// Maximum recursion depth (camera rays are depth 0).
    #[arg(long)]
    max_depth: Option<u32>,
    /// Seed for randomised samplers and integrators.
    #[arg(long)]
    seed: Option<u64>,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => cmd_render(args),
        Command::Diff(args) => cmd_diff(args),
        Command::Experiment(args) => cmd_experiment(args),
        Command::Stats {
            scene,
            accel,
            width,
            height,
            out,
            threads,
        } => {
            let opts = raylab::stats_report::StatsOptions {
                scene,
                accels: accel,
                width,
                height,
                out,
                threads,
            };
            raylab::stats_report::run(&opts, &mut std::io::stdout().lock()).map(|_| ())
        }
        #[cfg(feature = "embree")]
        Command::Validate(args) => cmd_validate(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn cmd_render(args: RenderArgs) -> Result<()> {
    if ImageFormat::from_path(&args.output).is_none() {
        anyhow::bail!(
            "{}: unsupported output extension (expected .png or .exr)",
            args.output.display()
        );
    }
    if args.threads == Some(0) {
        anyhow::bail!("--threads must be at least 1");
    }
    let overrides = Overrides {
        width: args.width,
        height: args.height,
        sampler: args.sampler,
        accel: args.accel,
        max_depth: args.max_depth,
        seed: args.seed,
    };
    let t0 = Instant::now();
    let scene = load_scene(&args.scene, &overrides)?;
    let load_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let (film, RayCounts(counts)) = render::<_, RayCounts>(&scene, &Whitted, args.threads);
    let render_s = t1.elapsed().as_secs_f64();
    write_image(&args.output, &film.image())
        .with_context(|| format!("writing {}", args.output.display()))?;
    if !args.quiet {
        let cam = &scene.camera;
        let threads = args.threads.unwrap_or_else(rayon::current_num_threads);
        println!("scene      {}", args.scene.display());
        println!(
            "image      {}×{}  {} spp ({})  accel {}  {} threads",
            cam.width,
            cam.height,
            scene.settings.sampler.spp(),
            scene.settings.sampler.name(),
            scene.accel.kind(),
            threads
        );
        println!(
            "geometry   {} primitives ({} triangles), {} lights",
            scene.prims.len(),
            scene.triangle_count(),
            scene.lights.len()
        );
        println!(
            "rays       {} total: {} camera, {} shadow, {} reflection, {} refraction",
            counts.rays(),
            counts.camera_rays,
            counts.shadow_rays,
            counts.reflection_rays,
            counts.refraction_rays
        );
        println!(
            "time       load {:.3} s, render {:.3} s, {:.2} Mrays/s",
            load_s,
            render_s,
            counts.rays() as f64 / render_s / 1e6
        );
        println!("wrote      {}", args.output.display());
    }
    Ok(())
}

fn cmd_diff(args: DiffArgs) -> Result<()> {
    let metrics = diff_files(&args.test, &args.reference, args.out.as_deref())?;
    let mut text = String::new();
    if args.json {
        let mut json = serde_json::to_value(metrics)?;
        // JSON has no infinity (serde_json would write null): identical
        // images get the string "inf", as Python's float("inf") reads it.
        if metrics.psnr.is_infinite() {
            json["psnr"] = serde_json::Value::from("inf");
        }
        json["test"] = args.test.display().to_string().into();
        json["reference"] = args.reference.display().to_string().into();
        if let Some(out) = &args.out {
            json["error_map"] = out.display().to_string().into();
        }
        writeln!(text, "{}", serde_json::to_string_pretty(&json)?)?;
    } else {
        writeln!(text, "test       {}", args.test.display())?;
        writeln!(text, "reference  {}", args.reference.display())?;
        write!(text, "{metrics}")?;
        if let Some(out) = &args.out {
            writeln!(text, "wrote      {}", out.display())?;
        }
    }
    print_out(&text)
}

fn cmd_experiment(args: ExperimentArgs) -> Result<()> {
    if args.threads == Some(0) {
        anyhow::bail!("--threads must be at least 1");
    }
    let opts = experiment::Options {
        quick: args.quick,
        resume: args.resume,
        out_dir: args.out,
        threads: args.threads,
        progress: true,
    };
    let report = experiment::run_experiment(&args.manifest, &opts)?;
    let dir = report.out_dir.display();
    let mut text = String::new();
    writeln!(
        text,
        "experiment {}: {} runs ({} done now, {} kept from data.csv), {} threads, {:.1} s",
        report.name,
        report.runs_total,
        report.runs_done,
        report.runs_skipped,
        report.threads,
        report.wall_time_s
    )?;
    writeln!(text, "wrote      {dir}/{{data.csv, meta.json}}")?;
    for f in &report.figures {
        writeln!(text, "figure     {dir}/{f}.{{png,svg}}")?;
    }
    for s in &report.summary {
        writeln!(text, "summary    {}: mean of {}", s.figure, s.label)?;
        for m in &s.series {
            writeln!(
                text,
                "             {:.2} over {:>2} points  {}",
                m.mean, m.count, m.label
            )?;
        }
    }
    print_out(&text)
}

#[cfg(feature = "embree")]
fn cmd_validate(args: ValidateArgs) -> Result<()> {
    use raylab::validate::{validate, Input, Options, Tolerances};
    let input = match (&args.mesh, &args.scene) {
        (Some(mesh), _) => Input::from_mesh(mesh)?,
        (None, Some(scene)) => Input::from_scene(scene)?,
        (None, None) => anyhow::bail!("give --mesh FILE or --scene FILE"),
    };
    let tolerances = Tolerances {
        t_rel: args.t_rel,
        grazing_deg: args.grazing_deg,
        normal_angle: args.normal_angle,
        max_unexplained: args.max_unexplained,
        max_borderline: args.max_borderline,
    };
    let opts = Options {
        rays: args.rays,
        seed: args.seed,
        accels: args.accel,
        embree: args.embree,
        tolerances,
        worst: args.worst,
        any_hit: true,
    };
    let report = validate(&input, &opts)?;
    let mut text = report.table();
    if !report.worst.is_empty() {
        writeln!(text, "worst cases:")?;
        text.push_str(&report.worst_text());
    }
    if let Some(csv) = &args.csv {
        report.write_csv(csv)?;
        writeln!(text, "wrote      {}", csv.display())?;
    }
    if let Some(dir) = &args.out {
        for stem in report.write_figures(dir, "validate-")? {
            writeln!(text, "figure     {}/{stem}.{{png,svg}}", dir.display())?;
        }
    }
    print_out(&text)?;
    let breaches = report.breaches(&tolerances);
    if !breaches.is_empty() {
        anyhow::bail!("tolerances exceeded:\n  {}", breaches.join("\n  "));
    }
    Ok(())
}

/// Write to stdout; a reader that went away (`raylab diff … | head`) is
/// not an error.
fn print_out(text: &str) -> Result<()> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}
