//! What one film sample of a curve measures, and the per-pixel sums of a
//! curve's samples: shared by the curves placed by projection
//! ([`super::sample_curve`]) and those found as level sets in curved
//! mirrors ([`super::curved`]).

use super::{Boundary, BoundaryStats, OFFSET_PX};
use crate::diff::planes::{PixelMoments, Planes, Spread};
use crate::integrator::{IntegratorKind, SampleContext, Whitted};
use crate::math::{Ray, RayR, Vec3, V3};
use crate::scene::{Scene, View};
use crate::shape::{Hit, ShapeR};
use crate::stats::NoStats;
use std::collections::HashMap;

/// The jump f⁻ − f⁺ across a curve at film point `(x, y)`: the radiance
/// of the integrator on the camera rays at (x, y) ∓ `offset` (the curve's
/// film normal times [`OFFSET_PX`]), both with the sample's own random
/// numbers `ctx`, so that what they have in common cancels; on the side
/// `limit` names (+1 or −1) its value there instead ([`grazing`]).
// ANCHOR: edge_jump
pub(super) fn jump(
    scene: &Scene,
    integrator: &IntegratorKind,
    (x, y): (f32, f32),
    (ox, oy): (f32, f32),
    ctx: &SampleContext,
    limit: Option<(f32, V3<f32>)>,
) -> [f64; 3] {
    let f = |sign: f32| match limit {
        Some((side, value)) if side == sign => value,
        _ => {
            let ray = scene.camera_ray(x + sign * ox, y + sign * oy);
            integrator.radiance_on(scene, &ray, ctx)
        }
    };
    let (plus, minus) = (f(1.0), f(-1.0));
    [minus.x - plus.x, minus.y - plus.y, minus.z - plus.z].map(f64::from)
}
// ANCHOR_END: edge_jump

/// The Whitted colour at the silhouette point `s` of the sphere or
/// ellipsoid `prim` seen from the eye, in the limit from inside: the
/// camera ray through `s` with its hit there, the normal made
/// perpendicular to the ray (to within 10⁻⁶, on the eye's side), so that
/// a reflected ray goes on along it from just outside and a refracted one
/// enters at the critical angle. At a film distance δ
/// inside, the colour differs from this by what the reflected ray sees
/// turned by about 2√(2δ/r) (r the silhouette's radius on the film): two
/// degrees at [`OFFSET_PX`] on a sphere 7 pixels across, enough to see
/// the far side of a horizon. `None` where something else hides `s`.
pub(super) fn grazing(scene: &Scene, prim: u32, s: Vec3) -> Option<V3<f32>> {
    let eye = scene.camera.frame().eye.value();
    let to = s - eye;
    let dist = to.length();
    let dir = to / dist;
    let ray = Ray::new(eye, dir);
    let before = scene.intersect(&ray, dist * (1.0 - 1e-3), &mut NoStats);
    if before.is_some_and(|h| h.prim != prim) {
        return None;
    }
    let shape = ShapeR::<f32>::of(&scene.prims[prim as usize]);
    let n = shape.outward_normal(V3::from_vec3(s)).value();
    let mut n = (n - dir * n.dot(dir)).try_normalize()?;
    if n.dot(dir) > 0.0 {
        // Just towards the eye, so that the reflected ray starts outside.
        n = (n - dir * 1e-6).normalize();
    }
    let hit = Hit {
        t: dist,
        point: s,
        geometric_normal: n,
        shading_normal: n,
        prim,
        object: scene.prims[prim as usize].object,
        front_face: true,
    };
    Some(Whitted.radiance_at_hit(scene, &RayR::from(ray), hit, &mut NoStats))
}

/// A sample that lands at film point `(x, y)` of a film `width` pixels
/// wide and takes its two radiance evaluations: counted in `stats`, with
/// the pixel it lands in and its random numbers' context.
pub(super) fn landed(
    stats: &mut BoundaryStats,
    (x, y): (f32, f32),
    width: u32,
    index: u32,
    seed: u64,
) -> (usize, SampleContext) {
    stats.landed += 1;
    stats.evaluations += 2;
    let (px, py) = (x as u32, y as u32);
    let ctx = SampleContext {
        px,
        py,
        index,
        seed,
    };
    ((py * width + px) as usize, ctx)
}

/// The offset of [`jump`] for a film normal `(nx, ny)` of length `len`:
/// [`OFFSET_PX`] along it.
pub(super) fn offset(normal: (f32, f32), len: f32) -> (f32, f32) {
    offset_by(normal, len, OFFSET_PX)
}

/// `eps` pixels along the film normal `(nx, ny)` of length `len`.
pub(super) fn offset_by((nx, ny): (f32, f32), len: f32, eps: f32) -> (f32, f32) {
    (eps * nx / len, eps * ny / len)
}

/// Sample `jobs` on the current pool and add each result to `out` in the
/// order of the jobs, so that the sum is the same on any number of
/// threads. `sample` gets each job's index, for its seed. The jobs run a
/// few per thread at a time: each curve's sparse sums can touch many
/// pixels, and holding every curve's at once took about 1.3 kB per pixel
/// of the image (a 600×600 render of s1-spheres with one parameter, most
/// of `raylab grad`'s peak memory).
pub(crate) fn fold_in_order<J: Sync, const K: usize>(
    jobs: &[J],
    out: &mut Boundary,
    sample: impl Fn(usize, &J) -> CurveResult<K> + Sync,
) {
    use rayon::prelude::*;
    let batch = 4 * rayon::current_num_threads();
    for (b, chunk) in jobs.chunks(batch).enumerate() {
        let results: Vec<CurveResult<K>> = chunk
            .par_iter()
            .enumerate()
            .map(|(j, job)| sample(b * batch + j, job))
            .collect();
        for r in results {
            out.stats.add(&r.stats);
            r.sums.add_to(&mut out.planes, r.samples);
        }
    }
}

/// What one curve's samples add, over how many samples they were drawn,
/// and the work they took.
pub(crate) struct CurveResult<const K: usize> {
    pub sums: SparseSums<K>,
    pub samples: u32,
    pub stats: BoundaryStats,
}

/// The running sums of one curve's samples (or of one sphere's rim
/// samples, [`crate::diff::rim`]), per touched pixel, for the first `n` of
/// the K parameters.
pub(crate) struct SparseSums<const K: usize> {
    n: usize,
    sums: HashMap<usize, PixelMoments<K>>,
}

impl<const K: usize> SparseSums<K> {
    pub fn new(n: usize) -> Self {
        Self {
            n,
            sums: HashMap::new(),
        }
    }

    /// A sample in `pixel`: its jump times the curve's normal speed per
    /// parameter (already over the sample's density).
    pub fn add(&mut self, pixel: usize, jump: [f64; 3], speed: &[f32]) {
        let mut values = [[0.0; 3]; K];
        for (value, &v) in values.iter_mut().zip(speed) {
            *value = jump.map(|j| j * f64::from(v));
        }
        self.add_values(pixel, &values[..speed.len()]);
    }

    /// A sample in `pixel` with value `values[k]` (per channel, already
    /// over the sample's density) for parameter k.
    pub fn add_values(&mut self, pixel: usize, values: &[[f64; 3]]) {
        self.sums.entry(pixel).or_default().add(values);
    }

    /// The samples of `other` (the same curve's, drawn elsewhere) added in.
    pub fn merge(&mut self, other: Self) {
        for (pixel, o) in other.sums {
            self.sums.entry(pixel).or_default().merge(&o);
        }
    }

    /// Each touched pixel's estimate, the mean over all `samples` of the
    /// curve (those that landed elsewhere count as 0), with the variance
    /// of that mean, added to `planes`.
    pub fn add_to(&self, planes: &mut Planes, samples: u32) {
        self.add_to_scaled(planes, samples, 1.0);
    }

    /// [`Self::add_to`] with the variances times `spread_scale`
    /// ([`Planes::add_pixel_scaled`]).
    pub fn add_to_scaled(&self, planes: &mut Planes, samples: u32, spread_scale: f32) {
        for (&pixel, m) in &self.sums {
            planes.add_pixel_scaled(
                pixel,
                self.n,
                m,
                f64::from(samples),
                Spread::Mean,
                spread_scale,
            );
        }
    }
}
