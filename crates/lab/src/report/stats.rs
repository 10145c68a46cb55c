//! The `raylab stats` report: what tracing a scene costs with each
//! accelerator, printed as one pbrt-style table (named counters, per-ray
//! ratios, distributions) plus per-pixel cost heatmaps. Part of the
//! top-layer [`crate::report`]: it loads scenes, builds accelerators,
//! renders and plots, so it sits above all of those (it used to be
//! `stats_report`, beside the bottom-layer [`raylab::stats`] counters).
//!
//! Data flow: a scene file is loaded once ([`load_scene`]); for each
//! accelerator the scene's acceleration structure is rebuilt (timed), the
//! image is rendered with [`render_with_costs`] (totals and per-pixel
//! [`Counters`]), and the camera rays through the pixel centres are traced
//! again one by one with a fresh [`Counters`] each, so that the per-ray
//! distributions are of single rays rather than of pixels that also hold
//! shadow and secondary rays. The layout of the table follows pbrt-v4's
//! statistics printout (Pharr, Jakob and Humphreys, *Physically Based
//! Rendering*, 4th ed., §B.7): sections, indented names, values right-aligned,
//! ratios with their numerator and denominator.

use crate::analysis::plot::Heatmap;
use crate::{Error, FileOp};
use ndarray::Array2;
use raylab::accel::{AccelKind, BvhConfig, BvhStats};
use raylab::integrator::{render_with_costs, Whitted};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::scene::Scene;
use raylab::shape::PreparedRay;
use raylab::stats::Counters;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Scenes with fewer bounded primitives than this also get the brute-force
/// tracer by default; above it brute force takes minutes per image and
/// mostly measures the primitive count.
pub const BRUTE_DEFAULT_LIMIT: usize = 5000;

/// What `raylab stats` was asked to do.
#[derive(Clone, Debug, Default)]
pub struct StatsOptions {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Accelerators to compare; empty means [`default_accels`].
    pub accels: Vec<AccelKind>,
    /// Image width override.
    pub width: Option<u32>,
    /// Image height override.
    pub height: Option<u32>,
    /// Where the heatmaps go; `None` means `out/stats/<scene stem>/`.
    pub out: Option<PathBuf>,
    /// Render threads; `None` means all cores.
    pub threads: Option<usize>,
    /// Where the render with counters runs: on the GPU each invocation
    /// counts its own pixel ([`raylab_gpu`]).
    pub device: super::render::Device,
}

/// Summary of a sample of non-negative counts: the mean and nearest-rank
/// percentiles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Distribution {
    pub mean: f64,
    pub p50: u64,
    pub p90: u64,
    pub p99: u64,
    pub max: u64,
}

impl Distribution {
    /// Summarise `values` (sorted in place). `None` for an empty sample.
    pub fn of(values: &mut [u64]) -> Option<Self> {
        values.sort_unstable();
        let n = values.len();
        if n == 0 {
            return None;
        }
        let sum: u64 = values.iter().sum();
        Some(Self {
            mean: sum as f64 / n as f64,
            p50: percentile(values, 50.0)?,
            p90: percentile(values, 90.0)?,
            p99: percentile(values, 99.0)?,
            max: values[n - 1],
        })
    }
}

/// The `p`-th percentile (0 ≤ p ≤ 100) of an ascending sample by the
/// nearest-rank method: the smallest value with at least p % of the sample
/// at or below it, i.e. element ⌈p·n/100⌉ (1-based), and the minimum for
/// p = 0 (Hyndman and Fan 1996, definition 1). Nearest rank always returns
/// an observed count, which is what a "tests per ray" figure should be.
/// `None` for an empty sample or p outside [0, 100].
pub fn percentile(sorted: &[u64], p: f64) -> Option<u64> {
    if sorted.is_empty() || !(0.0..=100.0).contains(&p) {
        return None;
    }
    let n = sorted.len();
    let rank = (p / 100.0 * n as f64).ceil() as usize;
    Some(sorted[rank.clamp(1, n) - 1])
}

/// The accelerators `raylab stats` compares when none is named: brute
/// force for small scenes, then the box BVH with the SAH builder (the
/// production baseline), its 4- and 8-wide collapses, and S3's sphere and ellipsoid
/// hierarchies.
pub fn default_accels(bounded_prims: usize) -> Vec<AccelKind> {
    let mut v = Vec::new();
    if bounded_prims < BRUTE_DEFAULT_LIMIT {
        v.push(AccelKind::Brute);
    }
    for name in ["bvh:aabb:sah", "bvh:sphere:s3", "bvh:ellipsoid:s3"] {
        // These names are part of the BVH grammar; a failure would mean the
        // grammar changed, and the remaining defaults are still useful.
        if let Ok(c) = name.parse::<BvhConfig>() {
            v.push(AccelKind::Bvh(c));
        }
    }
    v.insert(v.len() - 2, AccelKind::Bvh4);
    v.insert(v.len() - 2, AccelKind::Bvh8);
    v
}

/// A file-name-safe form of an accelerator name (`bvh:aabb:sah` →
/// `bvh-aabb-sah`): colons are not allowed in Windows file names.
pub fn file_stem(kind: AccelKind) -> String {
    kind.to_string().replace(':', "-")
}

/// What `raylab stats` holds at its peak beyond the loaded scene, per
/// accelerator (each one's are dropped before the next): while rendering,
/// the film's running statistics ([`PixelStats`](raylab::film::PixelStats);
/// the image is never developed) and, with a filter wider than the box,
/// every sample ([`FilmSample`](raylab::film::FilmSample)), beside each
/// row's per-pixel [`Counters`] and the image's gathered from them;
/// afterwards the gathered counters beside those of the camera rays
/// ([`camera_ray_costs`]), the two sorted per-ray costs and a heatmap's
/// data (three 8-byte values per pixel). The sum of both phases less the
/// film's second set of counters bounds the larger; and the worker
/// threads. Measured against peak resident memory in
/// crates/cli/tests/memory.rs (within +10 %/−0 %).
pub fn stats_bytes(scene: &Scene, threads: usize) -> u128 {
    use raylab::film::{memory::THREAD_BYTES, FilmSample, Filter, PixelStats};
    use std::mem::size_of;
    let pixels = u128::from(scene.camera.width) * u128::from(scene.camera.height);
    let samples = if scene.settings.filter == Filter::Box {
        0
    } else {
        u128::from(scene.settings.sampler.spp()) * size_of::<FilmSample>() as u128
    };
    let per_pixel = size_of::<PixelStats>() as u128
        + samples
        + 2 * size_of::<Counters>() as u128
        + 3 * size_of::<u64>() as u128;
    pixels * per_pixel + threads.max(1) as u128 * THREAD_BYTES
}

/// Costs of the camera ray through each pixel centre, row-major, each
/// traced alone (closest hit, accelerator plus unbounded primitives) into
/// its own [`Counters`].
pub fn camera_ray_costs(scene: &Scene) -> Vec<Counters> {
    let cam = &scene.camera;
    let mut out = Vec::with_capacity(cam.width as usize * cam.height as usize);
    for py in 0..cam.height {
        for px in 0..cam.width {
            let ray = cam.generate_ray(px as f32 + 0.5, py as f32 + 0.5);
            let mut c = Counters::default();
            scene.intersect_prim(&PreparedRay::new(ray), scene.settings.max_distance, &mut c);
            out.push(c);
        }
    }
    out
}

/// Everything measured for one accelerator.
#[derive(Clone, Debug)]
pub struct AccelReport {
    pub kind: AccelKind,
    /// Seconds to build the acceleration structure.
    pub build_seconds: f64,
    /// Seconds to render the image with full counters.
    pub render_seconds: f64,
    /// Counters summed over the whole render.
    pub totals: Counters,
    /// Bounding-volume tests per camera ray (traced alone).
    pub volume_tests: Option<Distribution>,
    /// Primitive tests per camera ray (traced alone).
    pub primitive_tests: Option<Distribution>,
    /// Shape of the BVH, if the accelerator is one.
    pub bvh: Option<BvhStats>,
    /// Heatmap stems written (without extension).
    pub heatmaps: Vec<PathBuf>,
}

/// Run the stats command: measure every accelerator, print the table to
/// `w` and write the heatmaps. Returns the measurements.
pub fn run(opts: &StatsOptions, w: &mut dyn Write) -> Result<Vec<AccelReport>, Error> {
    crate::check_threads(opts.threads)?;
    let overrides = Overrides {
        width: opts.width,
        height: opts.height,
        // Load with the cheapest accelerator; each one is then built and
        // timed on its own below.
        accel: Some(AccelKind::Brute),
        ..Default::default()
    };
    let t = Instant::now();
    let mut scene = load_scene(&opts.scene, &overrides)?;
    let load_seconds = t.elapsed().as_secs_f64();
    let threads = opts.threads.unwrap_or_else(rayon::current_num_threads);
    raylab::film::memory::check(
        || {
            format!(
                "counting the costs of {}×{} pixels",
                scene.camera.width, scene.camera.height
            )
        },
        stats_bytes(&scene, threads),
    )?;
    let bounded = scene.prims.len() - scene.unbounded.len();
    let accels = if opts.accels.is_empty() {
        let mut v = default_accels(bounded);
        if opts.device == super::render::Device::Gpu {
            // The GPU port has no 8-wide tree.
            v.retain(|&k| k != AccelKind::Bvh8);
        }
        v
    } else {
        opts.accels.clone()
    };
    let stem = opts
        .scene
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    let out_dir = opts
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join("stats").join(&stem));
    let maps: Vec<PathBuf> = accels
        .iter()
        .flat_map(|&k| heatmap_stems(&out_dir, k))
        .flat_map(|stem| ["png", "svg"].map(|ext| stem.with_extension(ext)))
        .collect();
    let outputs: Vec<(&str, &Path)> = maps.iter().map(|m| ("a heatmap", m.as_path())).collect();
    raylab::io::check_outputs(&[("the scene", opts.scene.as_path())], &outputs)?;
    std::fs::create_dir_all(&out_dir).map_err(|e| Error::io(&out_dir, FileOp::CreateFolder, e))?;

    let (width, height) = (scene.camera.width, scene.camera.height);
    writeln!(
        w,
        "Scene {}: {} primitives ({} bounded, {} triangles), {} lights, {width}×{height}, loaded in {:.3} s",
        opts.scene.display(),
        scene.prims.len(),
        bounded,
        scene.triangle_count(),
        scene.lights.len(),
        load_seconds
    )
    .map_err(Error::Print)?;

    let mut reports = Vec::with_capacity(accels.len());
    for kind in accels {
        let t = Instant::now();
        scene.set_accel(kind).map_err(Error::accel(kind))?;
        let build_seconds = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let PixelCosts { totals, pixels } = match opts.device {
            super::render::Device::Cpu => {
                let (_film, totals, pixels) = render_with_costs(&scene, &Whitted, opts.threads);
                PixelCosts { totals, pixels }
            }
            super::render::Device::Gpu => gpu_costs(&scene, w)?,
        };
        let render_seconds = t.elapsed().as_secs_f64();
        let rays = camera_ray_costs(&scene);
        let mut vt: Vec<u64> = rays.iter().map(Counters::bounding_volume_tests).collect();
        let mut pt: Vec<u64> = rays.iter().map(Counters::primitive_tests).collect();
        let heatmaps = write_heatmaps(&out_dir, kind, &pixels, width, height)?;
        let report = AccelReport {
            kind,
            build_seconds,
            render_seconds,
            totals,
            volume_tests: Distribution::of(&mut vt),
            primitive_tests: Distribution::of(&mut pt),
            bvh: scene.accel.bvh_stats(&scene.prims),
            heatmaps,
        };
        print_report(w, &report).map_err(Error::Print)?;
        reports.push(report);
    }
    writeln!(w, "Heatmaps (PNG + SVG) in {}", out_dir.display()).map_err(Error::Print)?;
    Ok(reports)
}

/// The render with counters on the GPU: totals and per-pixel counters,
/// after a line naming the adapter.
#[cfg(feature = "gpu")]
fn gpu_costs(scene: &Scene, w: &mut dyn Write) -> Result<PixelCosts, Error> {
    let run = super::render::gpu_render(scene, &raylab::integrator::IntegratorKind::Whitted, true)?;
    writeln!(
        w,
        "GPU: {}, kernel {:.4} s",
        run.adapter, run.render.times.kernel
    )
    .map_err(Error::Print)?;
    Ok(PixelCosts {
        totals: run.render.total(),
        pixels: run.render.pixel_counters,
    })
}

#[cfg(not(feature = "gpu"))]
fn gpu_costs(scene: &Scene, _: &mut dyn Write) -> Result<PixelCosts, Error> {
    match super::render::gpu_render(scene, &raylab::integrator::IntegratorKind::Whitted, true)? {}
}

/// A render's counters: summed over the image, and per pixel.
struct PixelCosts {
    totals: Counters,
    pixels: Vec<Counters>,
}

/// Reads one cost out of a pixel's counters.
type CostOf = fn(&Counters) -> u64;

/// The heatmaps of each accelerator: file suffix, what is counted, and
/// where it is read.
const HEATMAPS: [(&str, &str, CostOf); 2] = [
    ("nodes", "nodes visited", |c| c.nodes_visited),
    ("prim-tests", "primitive tests", Counters::primitive_tests),
];

/// Where accelerator `kind`'s heatmaps go in `dir`, without extension.
fn heatmap_stems(dir: &Path, kind: AccelKind) -> impl Iterator<Item = PathBuf> + '_ {
    HEATMAPS
        .into_iter()
        .map(move |(suffix, _, _)| dir.join(format!("{}-{suffix}", file_stem(kind))))
}

/// Per-pixel maps of nodes visited and primitive tests, log scale.
fn write_heatmaps(
    dir: &Path,
    kind: AccelKind,
    pixels: &[Counters],
    width: u32,
    height: u32,
) -> Result<Vec<PathBuf>, Error> {
    let shape = (height as usize, width as usize);
    let mut stems = Vec::new();
    for ((_, what, get), stem) in HEATMAPS.into_iter().zip(heatmap_stems(dir, kind)) {
        let data = Array2::from_shape_vec(shape, pixels.iter().map(|c| get(c) as f64).collect())
            .map_err(|e| {
                Error::Internal(format!("per-pixel costs do not match the image size: {e}"))
            })?;
        let mut map = Heatmap::new(format!("{kind}: {what} per pixel"), data);
        // Costs span decades (background vs silhouettes), hence log scale;
        // a map with no positive value (brute force visits no nodes) cannot
        // be drawn on one, so it is drawn linear (all one colour).
        map.log_scale = map.data.iter().any(|&v| v > 0.0);
        map.value_label = what.into();
        map.save(&stem)?;
        stems.push(stem);
    }
    Ok(stems)
}

fn row(w: &mut dyn Write, name: &str, value: impl std::fmt::Display) -> std::io::Result<()> {
    writeln!(w, "    {name:<44}{value:>20}")
}

fn ratio(w: &mut dyn Write, name: &str, num: u64, den: u64) -> std::io::Result<()> {
    let r = if den == 0 {
        0.0
    } else {
        num as f64 / den as f64
    };
    writeln!(w, "    {name:<44}{r:>20.3}  ({num} / {den})")
}

fn dist(w: &mut dyn Write, name: &str, d: &Option<Distribution>) -> std::io::Result<()> {
    match d {
        Some(d) => writeln!(
            w,
            "    {name:<44}{:>20.2}  p50 {} p90 {} p99 {} max {}",
            d.mean, d.p50, d.p90, d.p99, d.max
        ),
        None => row(w, name, "-"),
    }
}

/// One accelerator's section of the table.
fn print_report(w: &mut dyn Write, r: &AccelReport) -> std::io::Result<()> {
    let c = &r.totals;
    writeln!(w, "\nStatistics: {}", r.kind)?;
    writeln!(w, "  Time")?;
    row(w, "Build (s)", format!("{:.4}", r.build_seconds))?;
    row(
        w,
        "Render with counters (s)",
        format!("{:.4}", r.render_seconds),
    )?;
    writeln!(w, "  Rays")?;
    for (name, v) in [
        ("Camera", c.camera_rays),
        ("Shadow", c.shadow_rays),
        ("Reflection", c.reflection_rays),
        ("Refraction", c.refraction_rays),
        ("Path", c.path_rays),
        ("Total", c.rays()),
    ] {
        row(w, name, v)?;
    }
    writeln!(w, "  Traversal")?;
    row(w, "Nodes visited", c.nodes_visited)?;
    row(w, "Box tests", c.box_tests)?;
    row(w, "Bounding sphere tests", c.bounding_sphere_tests)?;
    row(w, "Bounding ellipsoid tests", c.bounding_ellipsoid_tests)?;
    writeln!(w, "  Intersections")?;
    row(w, "Triangle tests", c.triangle_tests)?;
    row(w, "Sphere tests", c.sphere_tests)?;
    row(w, "Ellipsoid tests", c.ellipsoid_tests)?;
    row(w, "Plane tests", c.plane_tests)?;
    row(w, "Hits", c.primitive_hits)?;
    writeln!(w, "  Per ray (all kinds)")?;
    ratio(w, "Nodes visited / ray", c.nodes_visited, c.rays())?;
    ratio(w, "Volume tests / ray", c.bounding_volume_tests(), c.rays())?;
    ratio(w, "Primitive tests / ray", c.primitive_tests(), c.rays())?;
    ratio(
        w,
        "Hits / primitive test",
        c.primitive_hits,
        c.primitive_tests(),
    )?;
    writeln!(w, "  Per camera ray, traced alone (mean, percentiles)")?;
    dist(w, "Volume tests", &r.volume_tests)?;
    dist(w, "Primitive tests", &r.primitive_tests)?;
    if let Some(b) = &r.bvh {
        writeln!(w, "  BVH")?;
        row(w, "Nodes", b.nodes)?;
        row(w, "Leaves", b.leaves)?;
        row(w, "Max depth", b.max_depth)?;
        row(
            w,
            "Mean / max primitives per leaf",
            format!("{:.2} / {}", b.mean_leaf_prims, b.max_leaf_prims),
        )?;
        row(
            w,
            "Memory (KiB)",
            format!("{:.1}", b.memory_bytes as f64 / 1024.0),
        )?;
        row(w, "SAH cost", format!("{:.2}", b.sah_cost))?;
        row(
            w,
            "Wasted area ratio (mean)",
            format!("{:.3}", b.mean_area_ratio),
        )?;
        row(
            w,
            "Wasted volume ratio (mean)",
            format!("{:.3}", b.mean_volume_ratio),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles_of_one_to_hundred_are_the_ranks() {
        let v: Vec<u64> = (1..=100).collect();
        assert_eq!(percentile(&v, 50.0), Some(50));
        assert_eq!(percentile(&v, 99.0), Some(99));
        assert_eq!(percentile(&v, 100.0), Some(100));
        assert_eq!(percentile(&v, 0.0), Some(1));
        assert_eq!(percentile(&[], 50.0), None);
    }
}
