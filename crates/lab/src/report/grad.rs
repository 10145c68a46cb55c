//! The `raylab grad` report: derivative images of a scene with respect to
//! parameters named by their place in the scene file, their image-mean
//! derivatives with standard errors, the cost against the plain render,
//! and (with `--check fd`) the comparison with central differences.
//! Part of the top-layer [`crate::report`].

use crate::analysis::plot::Heatmap;
use crate::{Error, FileOp, Result};
use raylab::diff::{self, Comparison, GradientRender, Gradients, Renderer};
use raylab::integrator::IntegratorKind;
use raylab::io::image::{write_exr_channels, write_film_exr, ChannelData};
use raylab::io::scene_file::{Overrides, SceneSource};
use raylab::scene::param::ParamId;
use raylab::scene::param::Setting;
use raylab::scene::Scene;
use raylab::stats::NoStats;
use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `--check fd[:h]`: central differences with step `h` (absolute; `None`:
/// the rule of [`diff::default_step`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FdCheck {
    pub step: Option<f32>,
}

/// Text that is not a `--check` value.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FdCheckError {
    /// `fd:H` with H not a positive number.
    #[error("the step in `fd:{0}` must be a positive number")]
    Step(String),
    /// Neither `fd` nor `fd:H`.
    #[error("unknown check `{0}` (expected `fd` or `fd:H`, H the finite-difference step)")]
    Unknown(String),
}

impl FdCheck {
    /// Parse `fd` or `fd:H` (H a positive number).
    pub fn parse(s: &str) -> Result<Self, FdCheckError> {
        match s.split_once(':') {
            None if s == "fd" => Ok(Self { step: None }),
            Some(("fd", h)) => match h.parse::<f32>() {
                Ok(h) if h > 0.0 && h.is_finite() => Ok(Self { step: Some(h) }),
                _ => Err(FdCheckError::Step(h.to_string())),
            },
            _ => Err(FdCheckError::Unknown(s.to_string())),
        }
    }
}

/// What `raylab grad` was asked to do.
#[derive(Clone, Debug)]
pub struct GradOptions {
    pub scene: PathBuf,
    /// The folder the images are written to (created if missing).
    pub out_dir: PathBuf,
    pub overrides: Overrides,
    /// Scene parameters set to new values (`--set PATH=VALUE`), in order,
    /// before the derivatives are taken.
    pub settings: Vec<Setting>,
    pub integrator: IntegratorKind,
    /// Parameter names as given (`materials.red.color`, `sphere[0].radius`).
    pub params: Vec<String>,
    pub check: Option<FdCheck>,
    /// `Full`: interior + boundary term; `Interior`: forward mode alone.
    pub visibility: diff::Visibility,
    /// Render threads; `None` means all cores.
    pub threads: Option<usize>,
    /// Show a progress bar on a terminal ([`super::progress`]).
    pub progress: bool,
}

/// One parameter's results.
#[derive(Clone, Debug)]
pub struct ParamRow {
    pub param: ParamId,
    /// Its name (`materials.red.color[0]`), and its value in the scene.
    pub name: String,
    pub value: f32,
    /// ∂(image mean)/∂p and its standard error.
    pub d_mean: f64,
    pub std_error: f64,
    pub check: Option<Comparison>,
}

/// What one `raylab grad` did and measured.
#[derive(Clone, Debug)]
pub struct GradReport {
    pub scene: PathBuf,
    pub out_dir: PathBuf,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub integrator: String,
    /// Seconds of the plain render and of the gradient render.
    pub render_s: f64,
    pub gradient_s: f64,
    pub visibility: diff::Visibility,
    /// The boundary term's samples and cost (all zero with `Interior`).
    pub boundary: diff::BoundaryStats,
    /// The interior derivative's rim zones ([`diff::rim`]).
    pub rim: diff::rim::RimStats,
    pub rows: Vec<ParamRow>,
}

/// The scene file read with the overrides and `--set`'s values, and its
/// scene, built once.
fn load(opts: &GradOptions) -> Result<(SceneSource, Scene)> {
    let mut source = SceneSource::load(&opts.scene, &opts.overrides)?;
    source.set(&opts.settings)?;
    let scene = source.build()?;
    Ok((source, scene))
}

impl GradReport {
    /// The memory `run` checks for before it starts, in bytes: what the
    /// tests measure the peak against.
    pub fn memory(opts: &GradOptions) -> Result<u128> {
        let (source, scene) = load(opts)?;
        let params = diff::resolve_all(&opts.params, &source.description)?;
        Ok(grad_bytes(opts, &scene, &source.description, &params))
    }

    pub fn run(opts: &GradOptions) -> Result<Self> {
        crate::check_threads(opts.threads)?;
        let (source, scene) = load(opts)?;
        let desc = &source.description;
        let params = diff::resolve_all(&opts.params, desc)?;
        diff::check_supported(&scene, &opts.integrator)?;
        let step = |p: ParamId, c: FdCheck| diff::step_for(&source, p, c.step);
        if let Some(c) = opts.check {
            for &p in &params {
                diff::check_step(&source, p, step(p, c))?;
            }
        }
        let outputs = output_files(&opts.out_dir, desc, &params);
        let roles: Vec<(&str, &Path)> = outputs.iter().map(|f| ("an image", f.as_path())).collect();
        raylab::io::check_outputs(&[("the scene", opts.scene.as_path())], &roles)?;
        raylab::film::memory::check(
            || {
                format!(
                    "the derivatives of {}×{} pixels with respect to {} parameters",
                    scene.camera.width,
                    scene.camera.height,
                    params.len()
                )
            },
            grad_bytes(opts, &scene, desc, &params),
        )?;
        std::fs::create_dir_all(&opts.out_dir)
            .map_err(|e| Error::io(&opts.out_dir, FileOp::CreateFolder, e))?;

        let start = Instant::now();
        let (film, _) = opts
            .integrator
            .render::<NoStats>(&scene, opts.threads)
            .map_err(Error::Render)?;
        let render_s = start.elapsed().as_secs_f64();
        write_film_exr(&opts.out_dir.join("image.exr"), &film, &film.image())?;

        let start = Instant::now();
        let watch = super::progress::Watch::start("derivatives", "rows", opts.progress);
        let grads = diff::render_gradients(&GradientRender {
            scene: &scene,
            desc,
            params: &params,
            integrator: opts.integrator,
            visibility: opts.visibility,
            threads: opts.threads,
        })?;
        drop(watch);
        let gradient_s = start.elapsed().as_secs_f64();

        let mut rows = Vec::new();
        let renderer = Renderer {
            integrator: opts.integrator,
            threads: opts.threads,
        };
        for (i, &p) in params.iter().enumerate() {
            let name = desc.param_name(p);
            write_param_images(&opts.out_dir, &grads, &name, i)?;
            let (d_mean, std_error) = grads.image_mean(i);
            let check = match opts.check {
                None => None,
                Some(c) => {
                    let h = step(p, c);
                    let cmp = diff::check_param(&source, &scene, &grads, i, h, renderer)?;
                    let mut map = Heatmap::signed(
                        format!("AD − FD: {name} (h = {:.3e})", cmp.h),
                        &cmp.difference,
                        grads.width,
                        grads.height,
                    );
                    map.value_label = "∂I/∂p, AD minus central difference".into();
                    map.save(&opts.out_dir.join(format!("{name}.fd-diff")))?;
                    Some(cmp)
                }
            };
            rows.push(ParamRow {
                param: p,
                value: desc.value(p),
                name,
                d_mean,
                std_error,
                check,
            });
        }
        Ok(Self {
            scene: opts.scene.clone(),
            out_dir: opts.out_dir.clone(),
            width: grads.width,
            height: grads.height,
            spp: grads.count,
            integrator: opts.integrator.name(),
            render_s,
            gradient_s,
            visibility: opts.visibility,
            boundary: grads.boundary.stats,
            rim: grads.rim,
            rows,
        })
    }
}

/// What `raylab grad` holds at its peak beyond the loaded scene: the
/// plain render's film statistics (kept while the derivatives render),
/// and the larger of what writing that render held beside them (its
/// image and EXR channels) and what the gradient render holds
/// ([`diff::gradient_bytes`]); with `--check fd`, the check's five
/// renders (two per step and the base, each a film and its image) on
/// top, an upper bound as they are not all held at once.
fn grad_bytes(
    opts: &GradOptions,
    scene: &raylab::scene::Scene,
    desc: &raylab::scene::description::SceneDescription,
    params: &[ParamId],
) -> u128 {
    use raylab::film::memory::{render_bytes, OutputFormat, RenderHolds};
    let threads = opts.threads.unwrap_or_else(rayon::current_num_threads);
    let film = |output| {
        render_bytes(&RenderHolds {
            width: scene.camera.width,
            height: scene.camera.height,
            spp: scene.settings.sampler.spp(),
            keep_samples: false,
            output,
            threads,
        })
    };
    let check = if opts.check.is_some() {
        5 * film(OutputFormat::Png)
    } else {
        0
    };
    let pixels = u128::from(scene.camera.width) * u128::from(scene.camera.height);
    let kept = pixels * std::mem::size_of::<raylab::film::PixelStats>() as u128;
    let gradients = diff::gradient_bytes(&GradientRender {
        scene,
        desc,
        params,
        integrator: opts.integrator,
        visibility: opts.visibility,
        threads: opts.threads,
    });
    kept + (film(OutputFormat::Exr) - kept).max(gradients) + check
}

/// Every file `raylab grad` may write into `dir`: the render, and per
/// parameter its images, its boundary term's and its check's.
fn output_files(
    dir: &Path,
    desc: &raylab::scene::description::SceneDescription,
    params: &[ParamId],
) -> Vec<PathBuf> {
    let mut files = vec![dir.join("image.exr")];
    for &p in params {
        let name = desc.param_name(p);
        for file in [
            format!("{name}.exr"),
            format!("{name}.png"),
            format!("{name}.svg"),
            format!("{name}.boundary.exr"),
            format!("{name}.boundary.png"),
            format!("{name}.boundary.svg"),
            format!("{name}.fd-diff.png"),
            format!("{name}.fd-diff.svg"),
        ] {
            files.push(dir.join(file));
        }
    }
    files
}

/// `DIR/<param>.exr` (R, G, B = ∂pixel/∂param, `variance.R/G/B`, `count`)
/// and `DIR/<param>.png` (+ .svg): the channel mean on a diverging scale.
fn write_param_images(dir: &Path, g: &Gradients, name: &str, i: usize) -> Result<()> {
    let (w, h) = (g.width as usize, g.height as usize);
    let plane =
        |v: &[f32], c: usize| ChannelData::F32(v.iter().skip(c).step_by(3).copied().collect());
    let channels = vec![
        ("R", plane(&g.planes.mean[i], 0)),
        ("G", plane(&g.planes.mean[i], 1)),
        ("B", plane(&g.planes.mean[i], 2)),
        ("variance.R", plane(&g.planes.variance[i], 0)),
        ("variance.G", plane(&g.planes.variance[i], 1)),
        ("variance.B", plane(&g.planes.variance[i], 2)),
        ("count", ChannelData::U32(vec![g.count; w * h])),
    ];
    write_exr_channels(&dir.join(format!("{name}.exr")), w, h, channels)?;
    let mut map = Heatmap::signed(format!("∂I/∂{name}"), &g.grey(i), g.width, g.height);
    map.value_label = "∂(R+G+B)/3 / ∂p per pixel".into();
    map.save(&dir.join(name))?;
    if g.visibility == diff::Visibility::Full {
        let b = &g.boundary.planes;
        let (mean, var) = (&b.mean[i], &b.variance[i]);
        let channels = vec![
            ("R", plane(mean, 0)),
            ("G", plane(mean, 1)),
            ("B", plane(mean, 2)),
            ("variance.R", plane(var, 0)),
            ("variance.G", plane(var, 1)),
            ("variance.B", plane(var, 2)),
        ];
        let stem = format!("{name}.boundary");
        write_exr_channels(&dir.join(format!("{stem}.exr")), w, h, channels)?;
        let grey: Vec<f32> = mean
            .chunks_exact(3)
            .map(|c| (c[0] + c[1] + c[2]) / 3.0)
            .collect();
        let mut map = Heatmap::signed(
            format!("boundary term of ∂I/∂{name}"),
            &grey,
            g.width,
            g.height,
        );
        map.value_label = "∂(R+G+B)/3 / ∂p per pixel, edges only".into();
        map.save(&dir.join(stem))?;
    }
    Ok(())
}

impl fmt::Display for GradReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "grad {}: {}×{}, {}, {} samples per pixel, {} parameter{}",
            self.scene.display(),
            self.width,
            self.height,
            self.integrator,
            self.spp,
            self.rows.len(),
            if self.rows.len() == 1 { "" } else { "s" }
        )?;
        writeln!(
            f,
            "render {:.3} s, gradients {:.3} s: {:.2}× the render",
            self.render_s,
            self.gradient_s,
            self.gradient_s / self.render_s.max(1e-9)
        )?;
        let r = &self.rim;
        if r.spheres > 0 {
            writeln!(
                f,
                "rim zones: {} (spheres seen directly or in flat mirrors, viewing cosine < {}), \
                 {} samples ({} in their zone, {} not finite), {:.3} s",
                r.spheres,
                diff::rim::RIM_COS,
                r.samples,
                r.landed,
                r.dropped,
                r.seconds
            )?;
        }
        let b = &self.boundary;
        match self.visibility {
            diff::Visibility::Interior => writeln!(
                f,
                "visibility interior: forward mode only (biased where a parameter moves an edge)"
            )?,
            diff::Visibility::Full => writeln!(
                f,
                "visibility full: boundary term {:.3} s, {} curves from the eye and {} from \
                 point lights, {} paths with {} vertices, {} curve samples ({} contributing), \
                 {} light rays, {} radiance evaluations",
                b.seconds,
                b.primary_curves,
                b.shadow_curves,
                b.paths,
                b.vertices,
                b.samples,
                b.landed,
                b.light_rays,
                b.evaluations
            )?,
        }
        writeln!(
            f,
            "{:<34} {:>11} {:>13} {:>11}",
            "parameter", "value", "∂mean/∂p", "std. error"
        )?;
        for r in &self.rows {
            writeln!(
                f,
                "{:<34} {:>11.5} {:>13.5e} {:>11.2e}",
                r.name, r.value, r.d_mean, r.std_error
            )?;
        }
        if self.rows.iter().any(|r| r.check.is_some()) {
            writeln!(
                f,
                "\ncentral differences (interior error: |AD − FD| per pixel over the mean |FD|, \
                 pixels near an edge left out; within 4 SE: share of all pixels / of edge pixels \
                 where |AD − FD| ≤ 4 standard errors of AD + 10⁻³ of the mean |FD|)"
            )?;
            writeln!(
                f,
                "{:<34} {:>9} {:>12} {:>12} {:>9} {:>7} {:>27} {:>17}",
                "parameter",
                "h",
                "AD ∂mean",
                "FD ∂mean",
                "rel.err",
                "edge%",
                "interior p50 / p90 / p99",
                "within 4 SE"
            )?;
            for r in &self.rows {
                if let Some(c) = &r.check {
                    writeln!(
                        f,
                        "{:<34} {:>9.2e} {:>12.5e} {:>12.5e} {:>9.2e} {:>6.1}% {:>8.2e} / {:.2e} / {:.2e} {:>7.1}% / {:.1}%",
                        r.name,
                        c.h,
                        c.ad_mean,
                        c.fd_mean,
                        c.mean_rel_error,
                        100.0 * c.edge_fraction,
                        c.interior_error[0],
                        c.interior_error[1],
                        c.interior_error[2],
                        100.0 * c.within_4se,
                        100.0 * c.within_4se_edges
                    )?;
                }
            }
        }
        write!(f, "images in {}", self.out_dir.display())
    }
}
