//! The memory estimator against what a command really holds. `raylab
//! render` prints the peak it estimated before rendering
//! (`film::memory::render_bytes` over what the process held once the
//! scene was loaded) and the kernel's count of its peak resident memory
//! (`VmHWM`). The estimate may not be below the peak (a check that
//! undercounts lets an allocation abort the process) and not more than
//! 10 % above it (one that overcounts refuses renders the machine could
//! do). `raylab diff`'s, `raylab stats`' and `raylab grad`'s estimates
//! are checked per pixel against the growth of their peak (`wait4`'s
//! `ru_maxrss`) between two sizes, within the same bounds.
//!
//! Why not `ru_maxrss` for the render too: a child made by `fork` starts
//! with the test process's memory, and Linux keeps that in the child's
//! `ru_maxrss` across `exec`; `VmHWM` belongs to the memory map `exec`
//! made. The diff sizes are large enough (peaks of 250 MB and more) that
//! the test process's own size cannot be the larger.

use std::process::Stdio;

use crate::LIT_SPHERE as SCENE;

/// Run `raylab ARGS…`; its stdout and its peak resident memory in bytes
/// (see the module docs for when that is the child's own).
/// The child is reaped by `wait4` (which returns its resource use), not
/// by `Child::wait`.
#[allow(clippy::zombie_processes)]
fn run_measured(args: &[&str]) -> (String, u128) {
    let child = crate::raylab_command()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut stdout = child.stdout.unwrap();
    let mut text = String::new();
    std::io::Read::read_to_string(&mut stdout, &mut text).unwrap();
    let mut status = 0;
    // SAFETY: an all-zero `rusage` is a valid value of that plain C
    // struct.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `pid` is our own child, not yet waited for (`Child` was
    // consumed without `wait`), and both pointers are to live locals.
    let got = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(got, pid);
    assert!(
        libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
        "{args:?}: {text}"
    );
    // Linux reports kilobytes.
    (text, usage.ru_maxrss as u128 * 1024)
}

/// The peak and the estimate `raylab render` printed: `memory     peak X
/// (estimated Y before the render)`, in decimal units.
fn peak_and_estimate(report: &str) -> (u128, u128) {
    let line = report
        .lines()
        .find(|l| l.starts_with("memory"))
        .unwrap_or_else(|| panic!("no memory line in\n{report}"));
    let bytes = |after: &str| {
        let mut words = line.split(after).nth(1).unwrap().split_whitespace();
        let value: f64 = words.next().unwrap().parse().unwrap();
        let unit = match words.next().unwrap() {
            "kB" => 1e3,
            "MB" => 1e6,
            "GB" => 1e9,
            u => panic!("unit {u}"),
        };
        (value * unit) as u128
    };
    (bytes("peak "), bytes("estimated "))
}

#[test]
fn the_render_estimate_bounds_the_peak_within_ten_percent() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let scene = scene.to_str().unwrap();
    let mut rows = Vec::new();
    // Sizes at which the film outweighs the process (~15 MB), each output,
    // and a filter that keeps every sample.
    let cases: &[(u32, &str, &[&str])] = &[
        (1000, "png", &[]),
        (1500, "png", &[]),
        (2000, "png", &[]),
        (1000, "exr", &[]),
        (1500, "exr", &[]),
        (2000, "exr", &[]),
        (800, "png", &["--sampler", "jitter:2", "--filter", "tent"]),
        (
            800,
            "exr",
            &["--sampler", "jitter:2", "--filter", "mitchell"],
        ),
    ];
    for &(n, ext, extra) in cases {
        let out = dir.path().join(format!("o.{ext}"));
        let size = n.to_string();
        let mut args = vec![
            "render",
            scene,
            "-o",
            out.to_str().unwrap(),
            "--width",
            &size,
            "--height",
            &size,
        ];
        args.extend_from_slice(extra);
        let o = crate::raylab(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (peak, estimate) = peak_and_estimate(&String::from_utf8_lossy(&o.stdout));
        let ratio = estimate as f64 / peak as f64;
        rows.push(format!(
            "{n}² {ext} {extra:?}: estimate {estimate}, peak {peak}, {ratio:.3}"
        ));
        // Both are printed rounded to 0.1 MB.
        let slack = 100_000.0 / peak as f64;
        assert!(
            (1.0 - slack..=1.10).contains(&ratio),
            "estimate / peak out of [1, 1.1]:\n{}",
            rows.join("\n")
        );
    }
    eprintln!("{}", rows.join("\n"));
}

/// `raylab diff`'s check counts [`DIFF_BYTES_PER_PIXEL`] for each pixel:
/// the peak's growth per pixel between two sizes (the process's own
/// memory cancels) may not exceed it, nor fall more than 10 % below it.
///
/// [`DIFF_BYTES_PER_PIXEL`]: raylab_lab::analysis::metrics::DIFF_BYTES_PER_PIXEL
#[test]
fn the_diff_estimate_bounds_its_growth_per_pixel_within_ten_percent() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let mut peaks = Vec::new();
    for n in [1500u32, 2500] {
        let size = n.to_string();
        let mut files = Vec::new();
        for sampler in ["centre", "jitter:2"] {
            let out = dir
                .path()
                .join(format!("{n}-{sampler}.png").replace(':', "-"));
            let o = crate::raylab(&[
                "render",
                scene.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--width",
                &size,
                "--height",
                &size,
                "--sampler",
                sampler,
                "-q",
            ]);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            files.push(out);
        }
        let (_, peak) = run_measured(&[
            "diff",
            files[0].to_str().unwrap(),
            files[1].to_str().unwrap(),
        ]);
        peaks.push((u128::from(n) * u128::from(n), peak));
    }
    let per_pixel = (peaks[1].1 - peaks[0].1) as f64 / (peaks[1].0 - peaks[0].0) as f64;
    let counted = raylab_lab::analysis::metrics::DIFF_BYTES_PER_PIXEL as f64;
    assert!(
        (per_pixel..=1.1 * per_pixel).contains(&counted),
        "diff grows by {per_pixel:.1} bytes a pixel; the check counts {counted}"
    );
}

/// How much a command's peak grows per pixel between two sizes, against
/// how much its estimate grows: `args(n)` runs it at n × n pixels and
/// `estimate(n)` is what its check counts there. The growth counted may
/// not be below the growth measured, nor more than 10 % above it.
fn check_growth(
    what: &str,
    sizes: [u32; 2],
    args: impl Fn(&str) -> Vec<String>,
    estimate: impl Fn(u32) -> u128,
) {
    let mut measured = Vec::new();
    for n in sizes {
        let size = n.to_string();
        let args = args(&size);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (_, peak) = run_measured(&args);
        measured.push(peak as f64);
    }
    let pixels = |n: u32| f64::from(n) * f64::from(n);
    let delta = pixels(sizes[1]) - pixels(sizes[0]);
    let per_pixel = (measured[1] - measured[0]) / delta;
    let counted = (estimate(sizes[1]) as f64 - estimate(sizes[0]) as f64) / delta;
    eprintln!("{what}: grows by {per_pixel:.1} bytes a pixel, the check counts {counted:.1}");
    assert!(
        (per_pixel..=1.1 * per_pixel).contains(&counted),
        "{what} grows by {per_pixel:.1} bytes a pixel; the check counts {counted:.1}"
    );
}

/// `raylab stats` ([`stats_bytes`]): one accelerator, one thread.
///
/// [`stats_bytes`]: raylab_lab::report::stats::stats_bytes
#[test]
fn the_stats_estimate_bounds_its_growth_per_pixel_within_ten_percent() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.path().join("maps");
    let (scene_arg, out_arg) = (scene.to_str().unwrap(), out.to_str().unwrap());
    check_growth(
        "stats",
        [1000, 1600],
        |n| {
            [
                "stats",
                scene_arg,
                "--accel",
                "bvh",
                "--width",
                n,
                "--height",
                n,
                "--threads",
                "1",
                "--out",
                out_arg,
            ]
            .map(String::from)
            .to_vec()
        },
        |n| {
            let overrides = raylab::io::scene_file::Overrides {
                width: Some(n),
                height: Some(n),
                ..Default::default()
            };
            let scene = raylab::io::scene_file::load_scene(&scene, &overrides).unwrap();
            raylab_lab::report::stats::stats_bytes(&scene, 1)
        },
    );
}

/// `raylab grad` ([`GradReport::memory`]), the interior derivative
/// (whose planes are all written; the boundary term's are counted whole
/// and written only where curves cross them): a colour's three
/// components (one pass of four-wide duals) under Whitted, and the
/// sphere's radius and centre (four, with rim zones) under the path
/// tracer's `direct`.
///
/// [`GradReport::memory`]: raylab_lab::report::grad::GradReport::memory
#[test]
fn the_grad_estimate_bounds_its_growth_per_pixel_within_ten_percent() {
    use raylab_lab::report::grad::{GradOptions, GradReport};
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.path().join("grad");
    let (scene_arg, out_arg) = (scene.to_str().unwrap(), out.to_str().unwrap());
    let cases: [(&str, &[&str], &str, raylab::diff::Visibility); 2] = [
        (
            "whitted",
            &["materials.m.color"],
            "interior",
            raylab::diff::Visibility::Interior,
        ),
        (
            "direct",
            &["sphere[0].radius", "sphere[0].center"],
            "interior",
            raylab::diff::Visibility::Interior,
        ),
    ];
    for (integrator, params, visibility, vis) in cases {
        check_growth(
            &format!("grad {integrator} {params:?} {visibility}"),
            [700, 1100],
            |n| {
                let mut args: Vec<String> = [
                    "grad",
                    scene_arg,
                    "--width",
                    n,
                    "--height",
                    n,
                    "--threads",
                    "1",
                    "--integrator",
                    integrator,
                    "--visibility",
                    visibility,
                    "--output",
                    out_arg,
                ]
                .map(String::from)
                .to_vec();
                for p in params {
                    args.extend(["--param".to_string(), p.to_string()]);
                }
                args
            },
            |n| {
                GradReport::memory(&GradOptions {
                    scene: scene.clone(),
                    out_dir: out.clone(),
                    overrides: raylab::io::scene_file::Overrides {
                        width: Some(n),
                        height: Some(n),
                        ..Default::default()
                    },
                    settings: Vec::new(),
                    integrator: raylab::integrator::IntegratorKind::parse(integrator).unwrap(),
                    params: params.iter().map(|p| p.to_string()).collect(),
                    check: None,
                    visibility: vis,
                    threads: Some(1),
                    progress: false,
                })
                .unwrap()
            },
        );
    }
}
