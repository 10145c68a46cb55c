//! The `raylab` command line: parses arguments and calls the library.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use raylab::accel::AccelKind;
use raylab::integrator::{render, Whitted};
use raylab::io::image::{write_image, ImageFormat};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::sampler::Sampler;
use raylab::stats::RayCounts;
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
    /// Pixel sampler: `centre` (1 sample) or `ogss:K` (K×K ordered grid).
    #[arg(long, value_parser = Sampler::parse)]
    sampler: Option<Sampler>,
    /// Accelerator: `brute`.
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
