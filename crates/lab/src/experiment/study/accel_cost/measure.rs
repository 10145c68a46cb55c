//! The measurements of an `accel_cost` run beyond a timed render: the
//! reference images it compares with (rendered once per process and
//! cached), pixel-exact image comparison, brute force extrapolated from a
//! reduced render where a full one would take too long, and the cost of
//! one bounding-volume test.

use super::super::{StudySettings, Timings};
use super::AccelCostConfig;
use crate::Error;
use raylab::accel::AccelKind;
use raylab::integrator::{render, Whitted};
use raylab::io::image::LinearImage;
use raylab::scene::Scene;
use raylab::shape::PreparedRay;
use raylab::stats::{Counters, NoStats};
use std::collections::HashMap;
use std::hint::black_box;
use std::sync::{Arc, Mutex, OnceLock};

/// Smallest side of the reduced brute-force render (64 pixels: fewer make
/// the share of rays that hit the mesh, and so tests per ray, too coarse).
pub const MIN_SAMPLE_SIDE: u32 = 8;

/// Rays per side of the camera-ray grid used to time bounding-volume tests.
const VOLUME_TEST_GRID: u32 = 32;

/// Nodes each of those rays is tested against.
const VOLUME_TEST_NODES: usize = 2048;

/// Reference images already rendered by this process, by (mesh, size,
/// accelerator): each BVH row of a mesh compares with the same image, and
/// rendering it once per mesh rather than once per row keeps brute force
/// affordable. A row never depends on this cache for its numbers: a miss
/// only means rendering the image again (e.g. in another shard).
fn reference_cache() -> &'static Mutex<HashMap<String, Arc<LinearImage>>> {
    static CACHE: OnceLock<Mutex<HashMap<String, Arc<LinearImage>>>> = OnceLock::new();
    CACHE.get_or_init(Default::default)
}

pub(super) fn cache_key(cfg: &AccelCostConfig, accel: AccelKind) -> String {
    format!("{}|{}x{}|{accel}", cfg.label, cfg.width, cfg.height)
}

/// The cached image, if any (a poisoned lock only means another run
/// panicked mid-insert; the map itself is still usable).
pub(super) fn cached(key: &str) -> Option<Arc<LinearImage>> {
    let map = reference_cache().lock().unwrap_or_else(|e| e.into_inner());
    map.get(key).cloned()
}

pub(super) fn store(key: String, image: LinearImage) -> Arc<LinearImage> {
    let image = Arc::new(image);
    let mut map = reference_cache().lock().unwrap_or_else(|e| e.into_inner());
    map.insert(key, image.clone());
    image
}

/// How two images of the same size differ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageDifference {
    /// Pixels with any channel not bit-for-bit equal.
    pub pixels: u64,
    /// The largest absolute channel difference.
    pub max: f32,
}

/// How two images of the same size differ.
pub fn image_difference(a: &LinearImage, b: &LinearImage) -> ImageDifference {
    assert_eq!(a.dim(), b.dim(), "images of different sizes");
    let (h, w, channels) = a.dim();
    let mut differing = 0u64;
    let mut max = 0.0f32;
    for y in 0..h {
        for x in 0..w {
            let mut differs = false;
            for c in 0..channels {
                let (p, q) = (a[[y, x, c]], b[[y, x, c]]);
                if p.to_bits() != q.to_bits() {
                    differs = true;
                    max = max.max((p - q).abs());
                }
            }
            differing += u64::from(differs);
        }
    }
    ImageDifference {
        pixels: differing,
        max,
    }
}

/// What the timed part of a row measured.
pub(super) struct Measured {
    pub(super) timings: Timings,
    /// Factor from the timings to the reported times (1, or for an
    /// extrapolated row the full-size triangle tests over the sample's).
    pub(super) scale: f64,
    pub(super) counters: Counters,
    pub(super) sample_side: Option<u32>,
}

/// Brute force's time at full size from a reduced render (module docs):
/// the reference accelerator counts the full-size rays, brute force renders
/// a square sample of about `brute_sample_tests` triangle tests with
/// repeats, and the timings are scaled by full-size tests over sample
/// tests. Leaves `scene` with brute force at the sample size.
pub(super) fn extrapolate_brute(
    scene: &mut Scene,
    cfg: &AccelCostConfig,
    settings: StudySettings,
) -> Result<Measured, Error> {
    scene
        .set_accel(cfg.reference)
        .map_err(Error::accel(cfg.reference))?;
    let (_, full) = render::<_, Counters>(scene, &Whitted, None);
    let full_camera = scene.camera;
    let pixels = f64::from(full_camera.width) * f64::from(full_camera.height);
    let rays_per_pixel = full.rays() as f64 / pixels;
    let faces = scene.triangle_count().max(1) as f64;
    let side = (cfg.brute_sample_tests / (rays_per_pixel * faces))
        .sqrt()
        .floor()
        .clamp(
            f64::from(MIN_SAMPLE_SIDE),
            f64::from(full_camera.width.min(full_camera.height)),
        ) as u32;
    // Same eye, frame and view angles; fewer, larger pixels.
    scene.camera.width = side;
    scene.camera.height = side;
    scene
        .set_accel(AccelKind::Brute)
        .map_err(Error::accel(AccelKind::Brute))?;
    let timings = Timings::measure(settings.warmup, settings.repeats, || {
        render::<_, NoStats>(scene, &Whitted, None)
    });
    let (_, sample) = render::<_, Counters>(scene, &Whitted, None);
    scene.camera = full_camera;
    let tests_per_ray = sample.triangle_tests as f64 / sample.rays().max(1) as f64;
    let full_tests = tests_per_ray * full.rays() as f64;
    let counters = Counters {
        nodes_visited: 0,
        box_tests: 0,
        bounding_sphere_tests: 0,
        bounding_ellipsoid_tests: 0,
        triangle_tests: full_tests.round() as u64,
        ..full
    };
    Ok(Measured {
        timings,
        scale: full_tests / sample.triangle_tests.max(1) as f64,
        counters,
        sample_side: Some(side),
    })
}

/// Nanoseconds per test of the scene's own bounding volumes (module docs),
/// from the median wall-clock and the median process CPU time (the test
/// loop runs on one thread, so on a shared machine the CPU time is the
/// steadier of the two); `None` without a BVH.
pub(super) fn volume_test_ns(scene: &Scene, settings: StudySettings) -> Option<(f64, f64)> {
    let cam = &scene.camera;
    let rays: Vec<PreparedRay> = (0..VOLUME_TEST_GRID * VOLUME_TEST_GRID)
        .map(|i| {
            let (gx, gy) = (i % VOLUME_TEST_GRID, i / VOLUME_TEST_GRID);
            let x = (gx as f32 + 0.5) * cam.width as f32 / VOLUME_TEST_GRID as f32;
            let y = (gy as f32 + 0.5) * cam.height as f32 / VOLUME_TEST_GRID as f32;
            PreparedRay::new(cam.generate_ray(x, y))
        })
        .collect();
    let (tests, _) = scene.accel.test_volumes(&rays, VOLUME_TEST_NODES)?;
    let t = Timings::measure(settings.warmup.max(1), settings.repeats.max(1), || {
        black_box(
            scene
                .accel
                .test_volumes(black_box(&rays), VOLUME_TEST_NODES),
        )
    });
    let per_test = 1e9 / tests.max(1) as f64;
    Some((t.median() * per_test, t.cpu_median() * per_test))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array3;

    #[test]
    fn image_difference_counts_pixels_not_channels() {
        let a = Array3::<f32>::zeros((2, 3, 3));
        let mut b = a.clone();
        b[[1, 2, 0]] = 0.25;
        b[[1, 2, 2]] = -0.5;
        b[[0, 0, 1]] = 0.125;
        assert_eq!(
            image_difference(&a, &b),
            ImageDifference {
                pixels: 2,
                max: 0.5
            }
        );
        assert_eq!(
            image_difference(&a, &a),
            ImageDifference {
                pixels: 0,
                max: 0.0
            }
        );
    }
}
