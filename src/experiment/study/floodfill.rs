//! `kind = "floodfill"`: convergence, speed and light leaking of S4's
//! flood-fill irradiance cache ([`crate::gi`]).
//!
//! One run loads a scene, voxelises it at `resolution` (timed with the
//! source set-up as `build_s`), then runs `steps` propagation steps on one
//! thread, each with its residual ‖I(t+1) − I(t)‖ (L2 and max). The row
//! gives the median step time, the first step whose max residual is below
//! `tolerance` × the largest stored value (`converged_step`; empty when it
//! never is), the final residuals, the mean and max luminance over the
//! empty voxels, whether the run diverged (non-finite values, or, without
//! convergence, a largest value that grew 2× over the second half of the
//! steps), and, when
//! `lit_box` / `dark_box` are given, the mean luminance of the empty voxels
//! whose centres lie in each box and their ratio `leak_ratio` (light
//! leaking through a wall into a room no light reaches directly).
//!
//! With `snapshots = true` the run also writes, into the experiment folder,
//! `residual-<tag>.png/svg` (residual per step, log y) and
//! `snapshots-<tag>.png/svg`: the luminance of the grid slice at depth
//! `slice` after steps 1, 2, 4, 8, … (S4's Figure 10), in a false-colour
//! log scale shared by all snapshots of the run (solid voxels grey).

use super::{
    bool_param, float_param, int_param, seconds_cell, str_param, ParamDoc, ParamError, Row,
    RunContext, Study, StudySettings,
};
use crate::analysis::plot::{ImageGrid, LineChart, Palette, Scale, Series, SeriesStyle};
use crate::experiment::sweep::RunPoint;
use crate::gi::{Averaging, FloodFill, FloodFillConfig, GridSpec, Residual, Threads, VoxelGrid};
use crate::io::scene_file::{load_scene, Overrides};
use crate::math::{luminance, srgb_decode, Vec3};
use ndarray::Array3;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The `floodfill` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct FloodFillStudy;

const PARAMETERS: &[ParamDoc] = &[
    ParamDoc {
        name: "scene",
        doc: "scene file (TOML), relative to the manifest's folder; required",
    },
    ParamDoc {
        name: "resolution",
        doc: "voxels along the scene's longest axis (default 64)",
    },
    ParamDoc {
        name: "alpha",
        doc: "gain per step α (default 1, energy-consistent; S4: 2.43902)",
    },
    ParamDoc {
        name: "averaging",
        doc: "`linear` (default) or `gamma` (S4's: mean of I^2.2, to the 1/2.2)",
    },
    ParamDoc {
        name: "surface_bounce",
        doc: "walls reflect the light in front of them (default true; S4: false)",
    },
    ParamDoc {
        name: "max_irradiance",
        doc: "stored values saturate here (default: no clamp)",
    },
    ParamDoc {
        name: "steps",
        doc: "propagation steps to run (default 256)",
    },
    ParamDoc {
        name: "tolerance",
        doc: "converged when max residual < tolerance × max I (default 1e-4)",
    },
    ParamDoc {
        name: "snapshots",
        doc: "write the residual figure and grid-slice snapshots (default false)",
    },
    ParamDoc {
        name: "slice",
        doc: "depth of the snapshot slice as a fraction of the grid's z (default 0.5)",
    },
    ParamDoc {
        name: "lit_box",
        doc: "\"x0 y0 z0 x1 y1 z1\": the lit room, for `lit_mean` (optional)",
    },
    ParamDoc {
        name: "dark_box",
        doc: "\"x0 y0 z0 x1 y1 z1\": the dark room, for `dark_mean`, `leak_ratio` (optional)",
    },
];

const COLUMNS: &[&str] = &[
    "grid_x",
    "grid_y",
    "grid_z",
    "voxel_size",
    "empty_voxels",
    "opaque_voxels",
    "emissive_voxels",
    "build_s",
    "step_ms",
    "steps_per_s",
    "steps_run",
    "converged_step",
    "final_residual_l2",
    "final_residual_max",
    "final_residual_rel",
    "mean_luminance",
    "max_luminance",
    "diverged",
    "lit_mean",
    "dark_mean",
    "leak_ratio",
];

/// A run's parameters, parsed.
struct Config {
    scene: PathBuf,
    resolution: usize,
    ff: FloodFillConfig,
    steps: usize,
    tolerance: f64,
    snapshots: bool,
    slice: f64,
    lit_box: Option<(Vec3, Vec3)>,
    dark_box: Option<(Vec3, Vec3)>,
}

fn box_param(run: &RunPoint, name: &str) -> Result<Option<(Vec3, Vec3)>, ParamError> {
    let Some(s) = str_param(run, name)? else {
        return Ok(None);
    };
    let v: Vec<f32> = s
        .split_whitespace()
        .map(str::parse::<f32>)
        .collect::<Result<_, _>>()
        .map_err(|_| ParamError::new(name, format!("`{s}`: expected six numbers")))?;
    if v.len() != 6 || v.iter().any(|x| !x.is_finite()) {
        return Err(ParamError::new(
            name,
            format!("`{s}`: expected six finite numbers \"x0 y0 z0 x1 y1 z1\""),
        ));
    }
    let (a, b) = (Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]));
    Ok(Some((a.min(b), a.max(b))))
}

fn config(run: &RunPoint, base_dir: &Path) -> Result<Config, ParamError> {
    let scene = super::render_cost::scene_param(run, base_dir)?;
    let resolution = int_param(
        run,
        "resolution",
        1,
        crate::gi::voxel::MAX_RESOLUTION as i64,
    )?
    .unwrap_or(64) as usize;
    let mut ff = FloodFillConfig::default();
    if let Some(a) = float_param(run, "alpha", f64::MIN, f64::MAX)? {
        ff.alpha = a as f32;
    }
    ff.averaging = match str_param(run, "averaging")? {
        None | Some("linear") => Averaging::Linear,
        Some("gamma") => Averaging::Gamma,
        Some(s) => {
            return Err(ParamError::new(
                "averaging",
                format!("`{s}`: expected `linear` or `gamma`"),
            ))
        }
    };
    if let Some(b) = bool_param(run, "surface_bounce")? {
        ff.surface_bounce = b;
    }
    if let Some(m) = float_param(run, "max_irradiance", f64::MIN, f64::MAX)? {
        ff.max_irradiance = m as f32;
    }
    ff.validate().map_err(|e| ParamError {
        param: None,
        message: e,
    })?;
    let steps = int_param(run, "steps", 1, 1_000_000)?.unwrap_or(256) as usize;
    let tolerance = float_param(run, "tolerance", f64::MIN, f64::MAX)?.unwrap_or(1e-4);
    if tolerance <= 0.0 {
        return Err(ParamError::new("tolerance", "must be positive"));
    }
    let slice = float_param(run, "slice", f64::MIN, f64::MAX)?.unwrap_or(0.5);
    if !(0.0..=1.0).contains(&slice) {
        return Err(ParamError::new(
            "slice",
            format!("must be in [0, 1], got {slice}"),
        ));
    }
    Ok(Config {
        scene,
        resolution,
        ff,
        steps,
        tolerance,
        snapshots: bool_param(run, "snapshots")?.unwrap_or(false),
        slice,
        lit_box: box_param(run, "lit_box")?,
        dark_box: box_param(run, "dark_box")?,
    })
}

/// Mean luminance of the empty voxels whose centres lie in `b` (NaN when
/// there are none).
fn box_mean(grid: &VoxelGrid, im: &Array3<Vec3>, b: (Vec3, Vec3)) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for ((x, y, z), k) in grid.kind.indexed_iter() {
        let c = grid.voxel_centre([x, y, z]);
        if !k.is_solid() && c.cmpge(b.0).all() && c.cmple(b.1).all() {
            sum += f64::from(luminance(im[[x, y, z]]));
            n += 1;
        }
    }
    if n == 0 {
        f64::NAN
    } else {
        sum / n as f64
    }
}

/// Number formatting for data.csv: empty for NaN.
fn cell(x: f64) -> String {
    if x.is_nan() {
        String::new()
    } else {
        format!("{x:e}")
    }
}

/// The luminance of slice `z` of `im` as a false-colour image (log10
/// scale over [lo, hi], row 0 at the top = largest y), each voxel `scale`
/// pixels wide; solid voxels grey.
fn slice_image(
    grid: &VoxelGrid,
    im: &Array3<Vec3>,
    z: usize,
    lo: f64,
    hi: f64,
    scale: usize,
) -> Array3<f32> {
    let [nx, ny, _] = grid.dims();
    let mut out = Array3::<f32>::zeros((ny * scale, nx * scale, 3));
    for x in 0..nx {
        for y in 0..ny {
            let rgb = if grid.kind[[x, y, z]].is_solid() {
                [128, 128, 128]
            } else {
                let l = f64::from(luminance(im[[x, y, z]]));
                let t = if l > 0.0 {
                    (l.log10() - lo) / (hi - lo)
                } else {
                    0.0
                };
                Palette::Viridis.colour(t)
            };
            let lin = rgb.map(|c| srgb_decode(f32::from(c) / 255.0));
            for i in 0..scale {
                for j in 0..scale {
                    let row = (ny - 1 - y) * scale + i;
                    for (c, v) in lin.iter().enumerate() {
                        out[[row, x * scale + j, c]] = *v;
                    }
                }
            }
        }
    }
    out
}

/// A file-name tag for a run: its sweep and parameter values.
fn run_tag(run: &RunPoint) -> String {
    let mut s = run.sweep.clone();
    for p in &run.params {
        if matches!(
            p.name.as_str(),
            "scene" | "lit_box" | "dark_box" | "snapshots" | "steps" | "tolerance"
        ) {
            continue;
        }
        s.push_str(&format!("-{}{}", p.name, p.value));
    }
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

impl Study for FloodFillStudy {
    fn kind(&self) -> &'static str {
        "floodfill"
    }

    fn parameters(&self) -> &'static [ParamDoc] {
        PARAMETERS
    }

    fn columns(&self, _settings: &StudySettings) -> Vec<String> {
        COLUMNS.iter().map(|s| s.to_string()).collect()
    }

    fn check(&self, run: &RunPoint, base_dir: &Path) -> Result<(), ParamError> {
        config(run, base_dir).map(|_| ())
    }

    fn run(&self, run: &RunPoint, ctx: &RunContext<'_>) -> anyhow::Result<Row> {
        let cfg = config(run, ctx.base_dir).map_err(ParamError::into_error)?;
        let scene = load_scene(&cfg.scene, &Overrides::default())?;
        let start = Instant::now();
        let grid = VoxelGrid::from_scene(&scene, &GridSpec::new(cfg.resolution))
            .map_err(|e| anyhow::anyhow!("{}: {e}", cfg.scene.display()))?;
        let mut ff = FloodFill::new(
            &grid,
            cfg.ff,
            crate::gi::wall_light(&scene, &cfg.ff, crate::gi::DEFAULT_WALL_LIGHT_SAMPLES),
        )
        .map_err(anyhow::Error::msg)?;
        let build_s = start.elapsed().as_secs_f64();

        let dims = grid.dims();
        let z_slice = ((cfg.slice * dims[2] as f64) as usize).min(dims[2] - 1);
        let mut snaps: Vec<(u64, Array3<Vec3>)> = Vec::new();
        let mut residuals: Vec<Residual> = Vec::with_capacity(cfg.steps);
        let mut times = Vec::with_capacity(cfg.steps);
        let mut converged = None;
        let mut max_at_half = f64::NAN;
        for s in 1..=cfg.steps {
            let t = Instant::now();
            let r = ff.step_with_residual(Threads::One);
            times.push(t.elapsed().as_secs_f64());
            residuals.push(r);
            let need_max = converged.is_none() || s == cfg.steps / 2;
            if need_max {
                let m = f64::from(ff.max_value());
                if s == cfg.steps / 2 {
                    max_at_half = m;
                }
                // A diverged grid (infinite values, NaN residuals) never
                // counts as converged.
                if converged.is_none() && m > 0.0 && m.is_finite() && r.max < cfg.tolerance * m {
                    converged = Some(s);
                }
            }
            if cfg.snapshots && s.is_power_of_two() {
                snaps.push((s as u64, ff.irradiance()));
            }
        }
        let im = ff.irradiance();
        let (mut lsum, mut lmax, mut n, mut vmax) = (0.0f64, 0.0f64, 0usize, 0.0f64);
        let mut finite = true;
        for (c, k) in im.iter().zip(grid.kind.iter()) {
            finite &= c.is_finite();
            vmax = vmax.max(f64::from(c.max_element()));
            if !k.is_solid() {
                let l = f64::from(luminance(*c));
                lsum += l;
                lmax = lmax.max(l);
                n += 1;
            }
        }
        // A converging run is within its tolerance of the fixed point by
        // then, or close; growing 2× over the second half is divergence.
        let diverged =
            !finite || (converged.is_none() && max_at_half > 0.0 && vmax / max_at_half > 2.0);
        let last = residuals.last().copied().unwrap_or_default();
        let step_s = super::median(&times);
        let lit = cfg.lit_box.map_or(f64::NAN, |b| box_mean(&grid, &im, b));
        let dark = cfg.dark_box.map_or(f64::NAN, |b| box_mean(&grid, &im, b));

        if cfg.snapshots {
            let tag = run_tag(run);
            let series = |name: &str, f: fn(&Residual) -> f64| {
                Series::new(
                    name,
                    residuals
                        .iter()
                        .enumerate()
                        .map(|(i, r)| ((i + 1) as f64, f(r)))
                        .filter(|p| p.1 > 0.0 && p.1.is_finite())
                        .collect(),
                    SeriesStyle::Line,
                )
            };
            let mut chart = LineChart::new(
                format!(
                    "Residual per step: {}³, α = {}, {:?}, bounce {}",
                    cfg.resolution, cfg.ff.alpha, cfg.ff.averaging, cfg.ff.surface_bounce
                ),
                "step",
                "‖I(t+1) − I(t)‖",
            );
            chart.series = vec![series("L2", |r| r.l2), series("max", |r| r.max)];
            chart.y_scale = Scale::Log10;
            chart.save(&ctx.out_dir.join(format!("residual-{tag}")))?;

            // One log scale for all snapshots: the last one's largest
            // luminance down four decades.
            let top = snaps
                .iter()
                .flat_map(|(_, a)| {
                    a.index_axis(ndarray::Axis(2), z_slice)
                        .iter()
                        .map(|c| f64::from(luminance(*c)))
                        .collect::<Vec<_>>()
                })
                .filter(|l| l.is_finite())
                .fold(0.0f64, f64::max);
            if top > 0.0 {
                let hi = top.log10();
                let lo = hi - 4.0;
                let scale = (256 / dims[0].max(dims[1])).max(1);
                let mut g = ImageGrid::new(
                    format!(
                        "Luminance of slice z = {z_slice} after n steps (log, 10^{lo:.1}..10^{hi:.1}; grey: solid)"
                    ),
                    snaps.len().min(5),
                );
                for (s, a) in &snaps {
                    g.cells.push((
                        slice_image(&grid, a, z_slice, lo, hi, scale),
                        format!("step {s}"),
                    ));
                }
                g.save(&ctx.out_dir.join(format!("snapshots-{tag}")))?;
            }
        }

        let (empty, opaque, emissive) = grid.counts();
        Ok(vec![
            ("grid_x".into(), dims[0].to_string()),
            ("grid_y".into(), dims[1].to_string()),
            ("grid_z".into(), dims[2].to_string()),
            ("voxel_size".into(), format!("{:e}", grid.voxel_size)),
            ("empty_voxels".into(), empty.to_string()),
            ("opaque_voxels".into(), opaque.to_string()),
            ("emissive_voxels".into(), emissive.to_string()),
            ("build_s".into(), seconds_cell(build_s)),
            ("step_ms".into(), format!("{:.4}", step_s * 1e3)),
            ("steps_per_s".into(), format!("{:.1}", 1.0 / step_s)),
            ("steps_run".into(), cfg.steps.to_string()),
            (
                "converged_step".into(),
                converged.map_or(String::new(), |s| s.to_string()),
            ),
            ("final_residual_l2".into(), cell(last.l2)),
            ("final_residual_max".into(), cell(last.max)),
            ("final_residual_rel".into(), cell(last.max / vmax)),
            ("mean_luminance".into(), cell(lsum / n.max(1) as f64)),
            ("max_luminance".into(), cell(lmax)),
            ("diverged".into(), diverged.to_string()),
            ("lit_mean".into(), cell(lit)),
            ("dark_mean".into(), cell(dark)),
            ("leak_ratio".into(), cell(dark / lit)),
        ])
    }
}
