//! The interior derivative near the rims of spheres, sampled on the sphere
//! instead of on the film.
//!
//! **Why.** Close to a sphere's silhouette the surface turns away from the
//! eye ever faster: at a film distance δ from the rim the normal turns
//! like √δ, so at a fixed film point the hit, its normal and every ray it
//! sends on (a mirror's reflection, a glass's refraction, even the
//! diffuse n·l) move with the parameters like 1/√δ. The interior
//! integrand ∂f/∂θ has that singularity: integrable, so its mean is
//! finite, but with an infinite variance (∫ dδ/δ diverges). A curved
//! mirror makes it worse: within a band a few hundredths of a pixel wide
//! at its rim it shows what lies just behind it, then, a little further
//! in, the far scene, and the interior derivative carries the whole
//! change across that band. Pixel samples hit the band once in hundreds
//! and then return a value hundreds of times the pixel's, so the pixel
//! estimate is heavy-tailed: most renders miss the band, their standard
//! errors are too small, and per-pixel checks fail along every mirror's
//! and glass's rim.
//!
//! **What.** The film is split: pixel samples whose camera ray's first
//! hit is a sphere at a viewing cosine |n·d| below [`RIM_COS`] (the rim
//! zone), or whose first hit is a flat mirror (under Whitted) and whose
//! reflected ray's is, count 0, and the zone is integrated on the sphere
//! instead. For
//! eye E, centre C, radius r, D = |E − C| and a = (E − C)/D, the points of
//! viewing cosine c form a circle about a: the normal n = cos α·a +
//! sin α·(cos ψ·e₁ + sin ψ·e₂) with
//! cos α = (r(1 − c²) + c·√(D² − r²(1 − c²)))/D
//! (the root of c²|E − p|² = (n·(E − p))² on the eye's side; c = 0 is the
//! silhouette, c = 1 the point facing the eye); seen in a flat mirror, E
//! is the eye's mirror image and p's film point that of its mirror
//! image ([`super::boundary::mirror`]). A sample draws ψ and c
//! uniformly on [0, 2π) × [0, RIM_COS) (ψ stratified, c a shifted rank-1
//! lattice), projects p = C + r·n to film point x(ψ, c), and if the
//! camera ray through x finds this sphere first at a cosine in the zone
//! (the test the pixel samples use, so the two parts tile the film), it
//! adds ∂f/∂θ(x)·|∂x/∂(ψ, c)|·2π·RIM_COS to x's pixel, over the number of
//! samples. In (ψ, c) the rim is not a singularity: δ grows like c², so
//! |∂x/∂c| ∝ c cancels the 1/√δ, and the band is spread over a range of c.
//! The Jacobian comes from forward mode on two-wide duals; ∂f/∂θ is the
//! integrator's, on the same K-wide duals as the pixel samples.
//!
//! Only parameters that move what camera rays meet ([`moves_hits`](super::params::moves_hits)) have
//! the singularity, and only passes with one of them split the film; for
//! the others the gradient render stays the derivative of the `f32`
//! render's own samples.
//!
//! Both are the interior derivative: with `--visibility interior` too, and
//! the boundary term (the silhouette's jump, taken in the limit at the
//! rim) is unchanged. Spheres are done, not ellipsoids (whose zone is not
//! a family of circles); an ellipsoid's rim keeps the heavy tail. Spheres
//! seen in curved mirrors or through glass keep it too, weakened by the
//! reflectivity or transparency on the way. The flat mirror's renderer
//! offset (its reflected rays start 10⁻⁴ off the plane) is left out of
//! the map x(ψ, c) but not out of the test that decides the zone: a
//! relative error of that order in the zone's edges and Jacobian.
//!
//! Checked (unit test): the two parts tile the film, pixel by pixel, the
//! rim samples' weights adding up to the area the pixel samples leave out
//! (to 0.3 % over the image), directly and in a reflecting floor. On S1's
//! inline test scene at 1024 samples per pixel the interior image-mean
//! derivative by a sphere's centre and radius agrees with the pixel
//! samples alone (−6.40e-3 ± 6e-5 against −6.33e-3 ± 1.2e-4; 1.275e-2 ±
//! 6e-5 against 1.281e-2 ± 1.8e-4), with a standard error 2–3 times
//! smaller.
//!
//! Samples per sphere: [`SAMPLES_PER_PX`] × the pixel samples per pixel ×
//! the silhouette's length on the film in pixels (at most [`MAX_SAMPLES`]).

use super::boundary::mirror::Mirror;
use super::boundary::sums::SparseSums;
use super::planes::Planes;
use super::view::DualScene;
use crate::integrator::{in_pool, IntegratorKind, SampleContext};
use crate::math::{orthonormal_basis, reflect, Dual, Ray, Real, SplitMix64, Vec3, V3};
use crate::scene::{Scene, View};
use crate::shape::{Hit, Shape};
use crate::stats::NoStats;
use rayon::prelude::*;
use std::time::Instant;

/// The viewing cosine below which a sphere's hit is in its rim zone.
pub const RIM_COS: f32 = 0.25;

/// Rim samples per pixel of silhouette length, per pixel sample.
pub const SAMPLES_PER_PX: f32 = 2.0;

/// The most samples one sphere's rim gets.
pub const MAX_SAMPLES: u64 = 1 << 22;

/// The most rim zones that [`Rims::owns`] rules out by a loop over the
/// spheres before tracing.
const PREFILTER_MAX: usize = 16;

/// Samples per parallel task.
const CHUNK: u64 = 256;

/// Points on the silhouette that measure its film length.
const LENGTH_POINTS: usize = 64;

/// What the rim sampler did, for the counters.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RimStats {
    /// Rim zones sampled: spheres seen directly or in a flat mirror.
    pub spheres: u32,
    /// Samples drawn, and those that landed on the film in their zone.
    pub samples: u64,
    pub landed: u64,
    /// Samples whose derivative was not finite (counted 0).
    pub dropped: u64,
    pub seconds: f64,
}

impl RimStats {
    /// Another pass's counters (the same zones, other parameters) added
    /// in: samples and time summed, the zones counted once.
    pub fn add(&mut self, o: &RimStats) {
        self.spheres = self.spheres.max(o.spheres);
        self.samples += o.samples;
        self.landed += o.landed;
        self.dropped += o.dropped;
        self.seconds += o.seconds;
    }
}

/// One rim zone: a sphere (primitive, centre, radius) seen directly
/// (`via` None) or in flat mirror `via` of [`Rims`]' mirrors.
#[derive(Clone, Copy, Debug)]
struct RimView {
    prim: u32,
    centre: Vec3,
    radius: f32,
    via: Option<usize>,
}

/// The rim zones of a scene: its spheres as the eye sees them from
/// outside, directly and in its flat mirrors.
#[derive(Clone, Debug, Default)]
pub struct Rims {
    views: Vec<RimView>,
    /// The views' (sphere, mirror) pairs, sorted, for the zone test.
    keys: Vec<(u32, Option<usize>)>,
    mirrors: Vec<Mirror<f32>>,
}

impl Rims {
    /// The rims of `scene`'s spheres seen directly and in `mirrors` (the
    /// flat mirrors, [`crate::diff::boundary::mirror::mirrors`]; none for
    /// an integrator that does not reflect), where the eye, or its mirror
    /// image, is outside the sphere.
    pub fn of(scene: &Scene, mirrors: &[Mirror<f32>]) -> Self {
        let mut rims = Rims {
            views: Vec::new(),
            keys: Vec::new(),
            mirrors: mirrors.to_vec(),
        };
        for (i, p) in scene.prims.iter().enumerate() {
            let Shape::Sphere(s) = &p.shape else {
                continue;
            };
            for via in std::iter::once(None).chain((0..mirrors.len()).map(Some)) {
                let view = RimView {
                    prim: i as u32,
                    centre: s.centre,
                    radius: s.radius,
                    via,
                };
                if (rims.eye(scene, &view) - s.centre).length() > s.radius * (1.0 + 1e-4) {
                    rims.views.push(view);
                    rims.keys.push((view.prim, view.via));
                }
            }
        }
        rims.keys.sort_unstable();
        rims
    }

    /// Whether the pixel sample on camera ray `ray` belongs to a rim zone
    /// (and so counts 0 there): its first hit is a sphere at a viewing
    /// cosine below [`RIM_COS`], or its first hit is one of the flat
    /// mirrors and the ray reflected there meets a sphere first at such a
    /// cosine.
    pub fn owns(&self, scene: &Scene, ray: &Ray) -> bool {
        if self.mirrors.is_empty() && self.views.len() <= PREFILTER_MAX {
            // A ray from outside that passes the centre at distance g
            // enters at the viewing cosine √(1 − g²/r²): in the zone when
            // r²(1 − RIM_COS²) < g² ≤ r² (with a margin for rounding; the
            // traced hit decides). Without mirrors, other rays are ruled
            // out without tracing (among a few spheres; among many, one
            // traced ray is cheaper than the loop).
            let near = self.views.iter().any(|v| {
                let to = v.centre - ray.origin;
                let along = to.dot(ray.dir) / ray.dir.length_squared();
                let gap2 = (to - ray.dir * along).length_squared();
                let r2 = v.radius * v.radius;
                let lo = r2 * (1.0 - RIM_COS * RIM_COS);
                along > 0.0 && gap2 >= lo * (1.0 - 1e-3) && gap2 <= r2 * (1.0 + 1e-3)
            });
            if !near {
                return false;
            }
        }
        self.zone_of(scene, ray).is_some()
    }

    /// The rim zone (sphere, mirror) that the camera ray `ray` falls in:
    /// its first hit is a sphere at a viewing cosine |n·d| below
    /// [`RIM_COS`], or its first hit is on one of the flat mirrors and
    /// the ray reflected there (the renderer's: reflected about the
    /// normal, started at the renderer's offset) meets a sphere first at
    /// such a cosine. The pixel samples and the rim samples both decide
    /// by this, so they tile the film.
    fn zone_of(&self, scene: &Scene, ray: &Ray) -> Option<(u32, Option<usize>)> {
        if self.views.is_empty() {
            return None;
        }
        let far = scene.settings.max_distance;
        let hit = scene.intersect(ray, far, &mut NoStats)?;
        if self.in_zone(&hit, ray, None) {
            return Some((hit.prim, None));
        }
        let material = &scene.materials[scene.objects[hit.object as usize].material as usize];
        if material.reflectivity <= 0.0 {
            return None;
        }
        let via = self.mirrors.iter().position(|m| m.holds(hit.point))?;
        let dir = reflect(ray.dir, hit.shading_normal).normalize();
        let reflected = Ray::new(hit.spawn_origin(dir), dir);
        let next = scene.intersect(&reflected, far, &mut NoStats)?;
        self.in_zone(&next, &reflected, Some(via))
            .then_some((next.prim, Some(via)))
    }

    /// Whether `hit` on `ray` is in the rim zone of a sphere seen through
    /// `via`.
    fn in_zone(&self, hit: &Hit, ray: &Ray, via: Option<usize>) -> bool {
        let ours = self.keys.binary_search(&(hit.prim, via)).is_ok();
        ours && hit.geometric_normal.dot(ray.dir.normalize()).abs() < RIM_COS
    }

    /// The eye as `view` sees its sphere: the eye, or its mirror image.
    fn eye(&self, scene: &Scene, view: &RimView) -> Vec3 {
        let eye = scene.camera.frame().eye.value();
        view.via
            .map_or(eye, |m| self.mirrors[m].reflect(V3::from_vec3(eye)).value())
    }

    /// The film point of the point (`psi`, `c`) of `view`'s rim zone
    /// ([`rim_point`] from the view's eye, mirrored back through its
    /// mirror), with its partials in (ψ, c).
    fn film(
        &self,
        scene: &Scene,
        view: &RimView,
        psi: Dual<2>,
        c: Dual<2>,
    ) -> Option<(Dual<2>, Dual<2>)> {
        let (w, h) = (scene.camera.width, scene.camera.height);
        let p = rim_point(self.eye(scene, view), view.centre, view.radius, psi, c);
        let p = match view.via {
            None => p,
            Some(m) => self.mirrors[m].value::<Dual<2>>().reflect(p),
        };
        scene.camera.frame().lift::<Dual<2>>().project(p, w, h)
    }

    /// Sample `k` of `samples` (seeded by `seed`) on `view`'s rim zone:
    /// its film point and its weight |∂x/∂(ψ, c)| / density, or `None`
    /// where the point is off the film or the camera ray through it does
    /// not fall in this zone ([`Rims::zone_of`]).
    fn sample(
        &self,
        scene: &Scene,
        view: &RimView,
        (k, samples, seed): (u64, u64, u64),
    ) -> Option<(f32, f32, f64)> {
        let (w, h) = (scene.camera.width, scene.camera.height);
        let mut rng = SplitMix64(SplitMix64::mix(seed ^ k));
        let (u1, u2) = (f64::from(rng.next_f32()), f64::from(rng.next_f32()));
        // In f64: the f32 sum k + u would round u away for large k.
        let psi = (std::f64::consts::TAU * (k as f64 + u1) / samples as f64) as f32;
        let lattice = (k as f64 * 0.618_033_988_749_895).fract();
        let c = RIM_COS * (u2 + lattice).fract() as f32;
        let (x, y) = self.film(scene, view, Dual::variable(psi, 0), Dual::variable(c, 1))?;
        let (xv, yv) = (x.value(), y.value());
        if !(0.0..w as f32).contains(&xv) || !(0.0..h as f32).contains(&yv) {
            return None;
        }
        let ray = scene.camera_ray(xv, yv).value();
        if self.zone_of(scene, &ray) != Some((view.prim, view.via)) {
            return None;
        }
        let jacobian = (x.d[0] * y.d[1] - x.d[1] * y.d[0]).abs();
        let density = std::f64::consts::TAU * f64::from(RIM_COS);
        Some((xv, yv, f64::from(jacobian) * density))
    }
}

/// The point of viewing cosine `c` at angle `psi` about the axis on the
/// sphere (centre `centre`, radius `r`) seen from `eye`, over any
/// [`Real`].
fn rim_point<R: Real>(eye: Vec3, centre: Vec3, r: f32, psi: R, c: R) -> V3<R> {
    let to = eye - centre;
    let d = to.length();
    let a = to / d;
    let (e1, e2) = orthonormal_basis(a);
    let one = R::one();
    let q = one - c * c;
    let rr = R::from_f32(r);
    let dd = R::from_f32(d);
    let cos_a = ((rr * q + c * (dd * dd - rr * rr * q).sqrt()) / dd).min(one);
    let sin_a = (one - cos_a * cos_a).max(R::zero()).sqrt();
    let v = |x: Vec3| V3::from_vec3(x);
    let n = v(a) * cos_a + (v(e1) * psi.cos() + v(e2) * psi.sin()) * sin_a;
    v(centre) + n * rr
}

/// The rim term of every sphere in `rims`, with `spp` pixel samples per
/// pixel setting the density; seeded by `seed`, the same for any number
/// of `threads`. Added into the pixel samples' `planes` (per parameter,
/// per pixel and channel, the mean, and the variance of the mean times
/// `spp`, the spread the pixel samples' planes hold; per pixel the same
/// for the channel mean); returns the counters.
#[allow(clippy::too_many_arguments)]
pub fn rim_term<const K: usize>(
    view: &DualScene<'_, K>,
    rims: &Rims,
    n: usize,
    integrator: &IntegratorKind,
    spp: u32,
    seed: u64,
    threads: Option<usize>,
    planes: &mut Planes,
) -> RimStats {
    let start = Instant::now();
    let scene = view.scene();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let mut stats = RimStats::default();
    let seed = SplitMix64::mix(seed ^ 0x0052_494D_5A4F_4E45);
    for view_ in &rims.views {
        // The silhouette's film length sets the samples.
        let length: f32 = (0..LENGTH_POINTS)
            .filter_map(|i| {
                let at = |j: usize| {
                    let psi = std::f32::consts::TAU * j as f32 / LENGTH_POINTS as f32;
                    let (x, y) =
                        rims.film(scene, view_, Dual::from_f32(psi), Dual::from_f32(0.0))?;
                    Some((x.value(), y.value()))
                };
                let ((x0, y0), (x1, y1)) = (at(i)?, at(i + 1)?);
                let on =
                    |x: f32, y: f32| (0.0..w as f32).contains(&x) && (0.0..h as f32).contains(&y);
                (on(x0, y0) || on(x1, y1)).then(|| (x1 - x0).hypot(y1 - y0))
            })
            .sum();
        let samples = ((SAMPLES_PER_PX * spp as f32 * length).ceil() as u64).min(MAX_SAMPLES);
        if samples == 0 {
            continue;
        }
        stats.spheres += 1;
        stats.samples += samples;
        let via = view_.via.map_or(0, |m| m as u64 + 1);
        let sphere_seed = SplitMix64::mix(seed ^ u64::from(view_.prim) ^ (via << 32));
        let chunks: Vec<(SparseSums<K>, u64, u64)> = in_pool(threads, || {
            (0..samples.div_ceil(CHUNK))
                .into_par_iter()
                .map(|chunk| {
                    let mut sums = SparseSums::<K>::new(n);
                    let (mut landed, mut dropped) = (0, 0);
                    for k in chunk * CHUNK..((chunk + 1) * CHUNK).min(samples) {
                        let sample = (k, samples, sphere_seed);
                        let Some((xv, yv, weight)) = rims.sample(scene, view_, sample) else {
                            continue;
                        };
                        let ray = view.camera_ray(xv, yv);
                        let (px, py) = (xv as u32, yv as u32);
                        let ctx = SampleContext {
                            px,
                            py,
                            index: spp.saturating_add(k.min(u64::from(u32::MAX / 2)) as u32),
                            seed,
                        };
                        let v = integrator.radiance_on(view, &ray, &ctx);
                        let values: Vec<[f64; 3]> = (0..n)
                            .map(|j| [v.x.d[j], v.y.d[j], v.z.d[j]].map(|d| f64::from(d) * weight))
                            .collect();
                        if values.iter().flatten().any(|v| !v.is_finite()) {
                            // A camera ray grazing the sphere to within
                            // rounding: its duals overflow (see the module
                            // doc), and it counts 0.
                            dropped += 1;
                            continue;
                        }
                        landed += 1;
                        sums.add_values((py * w + px) as usize, &values);
                    }
                    (sums, landed, dropped)
                })
                .collect()
        });
        let mut all = SparseSums::<K>::new(n);
        for (sums, landed, dropped) in chunks {
            all.merge(sums);
            stats.landed += landed;
            stats.dropped += dropped;
        }
        let samples = u32::try_from(samples).unwrap_or(u32::MAX);
        all.add_to_scaled(planes, samples, spp as f32);
    }
    stats.seconds = start.elapsed().as_secs_f64();
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::scene_file::{parse_scene, Overrides};

    /// Two spheres, one partly hiding the other, the second cut by the
    /// film's edge, over a floor, 24×24 pixels; `floor` goes in the
    /// floor's material.
    fn scene(floor: &str) -> String {
        format!(
            r#"
[image]
width = 24
height = 24
[camera]
eye = [0.3, 1.1, 5.0]
look_at = [0.4, 0.6, 0.0]
fov = 35.0
[materials.body]
color = [0.2, 0.7, 0.3]
[materials.floor]
color = [0.7, 0.7, 0.7]
{floor}
[[plane]]
point = [0.0, -0.35, 0.0]
normal = [0.0, 1.0, 0.0]
material = "floor"
[[sphere]]
center = [0.0, 0.6, 0.0]
radius = 0.9
material = "body"
[[sphere]]
center = [1.3, 0.9, 1.2]
radius = 0.5
material = "body"
"#
        )
    }

    /// The two parts tile the film: in every pixel the area the rim
    /// sampler's weights add up to is the area of the pixel samples it
    /// leaves out ([`Rims::owns`], measured on a 64 × 64 grid of film
    /// points per pixel), to within the two estimates' errors; with the
    /// floor a mirror, for the spheres' rims seen in it too.
    #[test]
    fn the_rim_samples_cover_the_film_area_the_pixel_samples_leave_out() {
        let floor = crate::diff::boundary::mirror::Mirror {
            object: 0,
            point: V3::new(0.0, -0.35, 0.0),
            normal: V3::new(0.0, 1.0, 0.0),
        };
        let cases = [("", vec![], 2), ("reflectivity = 0.5", vec![floor], 4)];
        for (material, mirrors, views) in cases {
            let text = scene(material);
            let path = std::path::Path::new("t.toml");
            let scene = parse_scene(&text, path, &Overrides::default()).unwrap();
            let rims = Rims::of(&scene, &mirrors);
            assert_eq!(rims.views.len(), views);
            let in_mirror = check_tiling(&scene, &rims);
            // The floor shows both spheres' rims.
            assert_eq!(in_mirror > 0.5, !mirrors.is_empty(), "{in_mirror}");
        }
    }

    /// Check the tiling; return the zones' area seen in mirrors.
    fn check_tiling(scene: &Scene, rims: &Rims) -> f64 {
        let (w, h) = (24usize, 24usize);
        const G: usize = 64;
        let mut owned = vec![0.0f64; w * h];
        for (j, a) in owned.iter_mut().enumerate() {
            let (px, py) = ((j % w) as f32, (j / w) as f32);
            for i in 0..G * G {
                let x = px + ((i % G) as f32 + 0.5) / G as f32;
                let y = py + ((i / G) as f32 + 0.5) / G as f32;
                if rims.owns(scene, &scene.camera_ray(x, y).value()) {
                    *a += 1.0 / (G * G) as f64;
                }
            }
        }
        let mut sampled = vec![0.0f64; w * h];
        let mut in_mirror = 0.0;
        let samples = 400_000u64;
        for view in &rims.views {
            for k in 0..samples {
                if let Some((x, y, weight)) = rims.sample(scene, view, (k, samples, 9)) {
                    sampled[y as usize * w + x as usize] += weight / samples as f64;
                    if view.via.is_some() {
                        in_mirror += weight / samples as f64;
                    }
                }
            }
        }
        let total: f64 = owned.iter().sum();
        let total_sampled: f64 = sampled.iter().sum();
        assert!(total > 5.0, "zone area {total} pixels");
        assert!(
            (total_sampled - total).abs() < 0.003 * total,
            "rim samples {total_sampled} vs pixel samples {total}"
        );
        for j in 0..w * h {
            // The grid resolves 1/4096 of a pixel; the zone's area in a
            // pixel is measured to a few 10⁻³.
            assert!(
                (sampled[j] - owned[j]).abs() < 0.004 + 0.03 * owned[j],
                "pixel {j}: rim samples {} vs pixel samples {}",
                sampled[j],
                owned[j]
            );
        }
        in_mirror
    }

    /// The rim point has the viewing cosine asked for, lies on the sphere,
    /// on the eye's side; c = 0 is on the silhouette.
    #[test]
    fn rim_points_have_the_viewing_cosine_asked_for() {
        let (eye, centre, r) = (Vec3::new(0.3, 2.0, 7.0), Vec3::new(-1.0, 0.5, 0.0), 1.3);
        for i in 0..50 {
            let psi = 0.37 * i as f32;
            let c = i as f32 / 49.0;
            let p = rim_point(eye, centre, r, psi, c).value();
            assert!(((p - centre).length() - r).abs() < 1e-5);
            let n = (p - centre) / r;
            let to_eye = (eye - p).normalize();
            assert!((n.dot(to_eye) - c).abs() < 1e-4, "c {c}: {}", n.dot(to_eye));
        }
    }
}
