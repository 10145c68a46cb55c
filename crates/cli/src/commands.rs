//! What each subcommand does with its parsed arguments: turn them into
//! the options of its report in [`raylab_lab::report`], run it, and print
//! what it returns.

use super::*;

/// Mesa's Vulkan drivers probe for a Wayland display when a device is
/// created, and libwayland prints "error: XDG_RUNTIME_DIR is invalid or
/// not set" (several times) when that variable is unset, as on servers and
/// in CI: noise that reads like raylab's own errors. With the variable set
/// the probe fails quietly; raylab opens no window, so any folder will do.
/// Called before the GPU is opened, while this process has one thread.
pub(super) fn quiet_wayland_probe(device: report::render::Device) {
    if device == report::render::Device::Gpu && std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
}

pub(super) fn cmd_render(args: RenderArgs) -> Result<()> {
    quiet_wayland_probe(args.device);
    let opts = report::RenderOptions {
        overrides: args.common.overrides(),
        integrator: args.common.integrator(),
        settings: args.common.set,
        scene: args.common.scene,
        output: args.output,
        reference: args.reference,
        spp_map: args.spp_map,
        threads: args.common.threads,
        progress: !args.quiet,
        device: args.device,
    };
    let report = report::RenderReport::run(&opts)?;
    if args.quiet {
        return Ok(());
    }
    Ok(print_stdout(&report.to_string())?)
}

pub(super) fn cmd_grad(args: GradArgs) -> Result<()> {
    let opts = report::grad::GradOptions {
        overrides: args.common.overrides(),
        integrator: args.common.integrator(),
        settings: args.common.set,
        scene: args.common.scene,
        out_dir: args.output,
        params: args.params,
        check: args.check,
        visibility: args.visibility,
        threads: args.common.threads,
        progress: true,
    };
    Ok(print_stdout(
        &report::grad::GradReport::run(&opts)?.to_string(),
    )?)
}

/// Exit status 130 when Ctrl-C stopped the run (after its figures were
/// drawn), as a shell reports an interrupted command.
pub(super) fn cmd_optimize(args: OptimizeArgs) -> ExitCode {
    let opts = report::optimize::OptimizeOptions {
        spec: args.spec,
        out_dir: args.output,
        stop_after: args.stop_after,
        target_sampler: args.target_sampler,
        threads: args.threads,
        progress: !args.quiet,
    };
    match report::optimize::OptimizeReport::run(&opts) {
        Ok(report) => {
            if !args.quiet {
                if let Err(e) = print_stdout(&report.to_string()) {
                    eprintln!("error: {e:#}");
                    return ExitCode::FAILURE;
                }
            }
            if report.interrupted {
                ExitCode::from(130)
            } else {
                ExitCode::SUCCESS
            }
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

pub(super) fn cmd_diff(args: DiffArgs) -> Result<()> {
    let report = report::DiffReport::run(&args.test, &args.reference, args.out.as_deref())?;
    if args.json {
        Ok(print_stdout(&report.json()?)?)
    } else {
        Ok(print_stdout(&report.to_string())?)
    }
}

pub(super) fn cmd_spectrum(args: SpectrumArgs) -> Result<()> {
    let opts = report::SpectrumOptions {
        samplers: args.sampler,
        sets: args.sets,
        freq: args.freq,
        seed: args.seed,
        out: args.out,
    };
    Ok(print_stdout(
        &report::SpectrumReport::run(&opts)?.to_string(),
    )?)
}

pub(super) fn cmd_experiment(args: ExperimentArgs) -> Result<()> {
    // The gpu_speed study opens the GPU.
    quiet_wayland_probe(report::render::Device::Gpu);
    let opts = experiment::ExperimentOptions {
        quick: args.quick,
        resume: args.resume,
        out_dir: args.out,
        threads: args.threads,
        progress: true,
        shard: args.shard,
    };
    Ok(print_stdout(
        &report::ExperimentReport::run(&args.manifest, &opts)?.to_string(),
    )?)
}

pub(super) fn cmd_merge(args: MergeArgs) -> Result<()> {
    let opts = experiment::MergeOptions {
        out_dir: args.out,
        shards: args.shards,
        allow_missing: args.allow_missing,
    };
    Ok(print_stdout(&report::MergeReport::run(&opts)?.to_string())?)
}

pub(super) fn cmd_plot(
    dir: &std::path::Path,
    out: Option<&std::path::Path>,
    manifest: Option<&std::path::Path>,
) -> Result<()> {
    Ok(print_stdout(
        &report::PlotReport::run(dir, out, manifest)?.to_string(),
    )?)
}

pub(super) fn cmd_stats(opts: &report::StatsOptions) -> Result<()> {
    report::stats::run(opts, &mut std::io::stdout().lock())?;
    Ok(())
}

#[cfg(feature = "embree")]
pub(super) fn cmd_validate(args: ValidateArgs) -> Result<()> {
    use raylab_lab::validate::{Tolerances, ValidationOptions};
    let opts = report::ValidateOptions {
        mesh: args.mesh,
        scene: args.scene,
        options: ValidationOptions {
            rays: args.rays,
            seed: args.seed,
            accels: args.accel,
            embree: args.embree,
            tolerances: Tolerances {
                t_rel: args.t_rel,
                grazing_deg: args.grazing_deg,
                normal_angle: args.normal_angle,
                max_unexplained: args.max_unexplained,
                max_borderline: args.max_borderline,
            },
            worst: args.worst,
            any_hit: true,
        },
        csv: args.csv,
        out: args.out,
    };
    let report = report::ValidateReport::run(&opts)?;
    print_stdout(&report.to_string())?;
    Ok(report.check()?)
}
