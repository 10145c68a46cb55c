//! `kind = "floodfill"`: convergence, speed and light leaking of S4's
//! flood-fill irradiance cache ([`raylab::gi`]).
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

use super::{median, RunContext, Study};
use crate::analysis::plot::{AxisScale, ImageGrid, LineChart, Palette, Series, SeriesStyle};
use crate::experiment::params::render::scene_file;
use crate::experiment::params::{
    parsed_opt, typed_params, FromParam, InRange, ParamDoc, RunParamError,
};
use crate::experiment::row::{Exp, Fixed, Secs};
use crate::experiment::sweep::RunPoint;
use crate::Error;
use ndarray::Array3;
use raylab::gi::voxel::MAX_RESOLUTION;
use raylab::gi::{Averaging, FloodFill, FloodFillConfig, GridSpec, Residual, Threads, VoxelGrid};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::math::{luminance, srgb_decode, Vec3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The `floodfill` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct FloodFillStudy;

/// How neighbour values are averaged, as the manifest names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AveragingParam {
    /// [`Averaging::Linear`].
    Linear,
    /// [`Averaging::Gamma`].
    Gamma,
}

/// An axis-aligned box "x0 y0 z0 x1 y1 z1" (corners in any order).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxParam {
    /// The smallest corner.
    pub min: Vec3,
    /// The largest corner.
    pub max: Vec3,
}

impl FromParam for BoxParam {
    fn from_param(s: &str) -> Result<Self, RunParamError> {
        let v: Vec<f32> = s
            .split_whitespace()
            .map(str::parse::<f32>)
            .collect::<Result<_, _>>()
            .map_err(|_| RunParamError::run(format!("`{s}`: expected six numbers")))?;
        if v.len() != 6 || v.iter().any(|x| !x.is_finite()) {
            return Err(RunParamError::run(format!(
                "`{s}`: expected six finite numbers \"x0 y0 z0 x1 y1 z1\""
            )));
        }
        let (a, b) = (Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]));
        Ok(BoxParam {
            min: a.min(b),
            max: a.max(b),
        })
    }
}

/// The parameters of a run.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FloodFillParams {
    /// Scene file, relative to the manifest's folder.
    pub scene: String,
    /// Voxels along the scene's longest axis.
    #[serde(default)]
    pub resolution: Option<InRange<1, { MAX_RESOLUTION as i64 }>>,
    /// Gain per step.
    #[serde(default)]
    pub alpha: Option<f64>,
    /// Linear or gamma-space averaging.
    #[serde(default)]
    pub averaging: Option<AveragingParam>,
    /// Whether walls reflect the light in front of them.
    #[serde(default)]
    pub surface_bounce: Option<bool>,
    /// Stored values saturate here.
    #[serde(default)]
    pub max_irradiance: Option<f64>,
    /// Propagation steps.
    #[serde(default)]
    pub steps: Option<InRange<1, 1_000_000>>,
    /// Convergence tolerance, relative to the largest value.
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// Write the residual figure and snapshots.
    #[serde(default)]
    pub snapshots: bool,
    /// Depth of the snapshot slice, a fraction of the grid's z.
    #[serde(default)]
    pub slice: Option<f64>,
    /// The lit room.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub lit_box: Option<BoxParam>,
    /// The dark room.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub dark_box: Option<BoxParam>,
}

typed_params!(
    FloodFillParams,
    [
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
            doc: "\"x0 y0 z0 x1 y1 z1\": the dark room, for `dark_mean`, `leak_ratio` \
                  (optional)",
        },
    ]
);

/// One row: how the cache converged, what it cost, how much light leaked.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FloodFillRow {
    /// Grid size, x.
    pub grid_x: usize,
    /// Grid size, y.
    pub grid_y: usize,
    /// Grid size, z.
    pub grid_z: usize,
    /// Side of a voxel.
    pub voxel_size: Exp<f32>,
    /// Empty voxels.
    pub empty_voxels: usize,
    /// Opaque voxels.
    pub opaque_voxels: usize,
    /// Emissive voxels.
    pub emissive_voxels: usize,
    /// Voxelising and setting up the sources.
    pub build_s: Secs,
    /// Median step time, ms.
    pub step_ms: Fixed<4>,
    /// Steps per second at that time.
    pub steps_per_s: Fixed<1>,
    /// Steps run.
    pub steps_run: usize,
    /// First converged step (empty: never).
    pub converged_step: Option<usize>,
    /// Last step's L2 residual.
    pub final_residual_l2: Exp,
    /// Last step's max residual.
    pub final_residual_max: Exp,
    /// Last max residual over the largest value.
    pub final_residual_rel: Exp,
    /// Mean luminance over the empty voxels.
    pub mean_luminance: Exp,
    /// Largest luminance over the empty voxels.
    pub max_luminance: Exp,
    /// Whether the run diverged.
    pub diverged: bool,
    /// Mean luminance in `lit_box`.
    pub lit_mean: Exp,
    /// Mean luminance in `dark_box`.
    pub dark_mean: Exp,
    /// `dark_mean / lit_mean`.
    pub leak_ratio: Exp,
}

/// A run's parameters, checked.
pub struct FloodFillStudyConfig {
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
    type Params = FloodFillParams;
    type Config = FloodFillStudyConfig;
    type Row = FloodFillRow;

    fn configure(
        &self,
        p: FloodFillParams,
        base_dir: &Path,
    ) -> Result<FloodFillStudyConfig, RunParamError> {
        let mut ff = FloodFillConfig::default();
        if let Some(a) = p.alpha {
            ff.alpha = a as f32;
        }
        ff.averaging = match p.averaging {
            None | Some(AveragingParam::Linear) => Averaging::Linear,
            Some(AveragingParam::Gamma) => Averaging::Gamma,
        };
        if let Some(b) = p.surface_bounce {
            ff.surface_bounce = b;
        }
        if let Some(m) = p.max_irradiance {
            ff.max_irradiance = m as f32;
        }
        ff.validate().map_err(RunParamError::run)?;
        let tolerance = p.tolerance.unwrap_or(1e-4);
        if tolerance <= 0.0 {
            return Err(RunParamError::new("tolerance", "must be positive"));
        }
        let slice = p.slice.unwrap_or(0.5);
        if !(0.0..=1.0).contains(&slice) {
            return Err(RunParamError::new(
                "slice",
                format!("must be in [0, 1], got {slice}"),
            ));
        }
        let corners = |b: Option<BoxParam>| b.map(|b| (b.min, b.max));
        Ok(FloodFillStudyConfig {
            scene: scene_file(base_dir, &p.scene)?,
            resolution: p.resolution.map_or(64, |r| r.get() as usize),
            ff,
            steps: p.steps.map_or(256, |s| s.get() as usize),
            tolerance,
            snapshots: p.snapshots,
            slice,
            lit_box: corners(p.lit_box),
            dark_box: corners(p.dark_box),
        })
    }

    fn run(
        &self,
        cfg: FloodFillStudyConfig,
        run: &RunPoint,
        ctx: &RunContext<'_>,
    ) -> Result<FloodFillRow, Error> {
        let scene = load_scene(&cfg.scene, &Overrides::default())?;
        let start = Instant::now();
        let grid = VoxelGrid::from_scene(&scene, &GridSpec::new(cfg.resolution))
            .map_err(|e| Error::scene(&cfg.scene, Error::Cache(e)))?;
        let mut ff = FloodFill::new(
            &grid,
            cfg.ff,
            raylab::gi::wall_light(&scene, &cfg.ff, raylab::gi::DEFAULT_WALL_LIGHT_SAMPLES),
        )
        .map_err(Error::Cache)?;
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
        let step_s = median(&times);
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
            chart.y_scale = AxisScale::Log10;
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
        Ok(FloodFillRow {
            grid_x: dims[0],
            grid_y: dims[1],
            grid_z: dims[2],
            voxel_size: Exp(grid.voxel_size),
            empty_voxels: empty,
            opaque_voxels: opaque,
            emissive_voxels: emissive,
            build_s: Secs(build_s),
            step_ms: Fixed(step_s * 1e3),
            steps_per_s: Fixed(1.0 / step_s),
            steps_run: cfg.steps,
            converged_step: converged,
            final_residual_l2: Exp(last.l2),
            final_residual_max: Exp(last.max),
            final_residual_rel: Exp(last.max / vmax),
            mean_luminance: Exp(lsum / n.max(1) as f64),
            max_luminance: Exp(lmax),
            diverged,
            lit_mean: Exp(lit),
            dark_mean: Exp(dark),
            leak_ratio: Exp(dark / lit),
        })
    }
}
