//! The boundary term of an image's derivative: what forward mode through
//! fixed samples misses when a parameter moves a silhouette or a shadow
//! edge ([`super`]), estimated by sampling the edges themselves.
//!
//! **The term.** A pixel P of the box filter is the mean of the radiance
//! f(x, θ) over its square, I_P = ∫_P f dx (film coordinates in pixels, so
//! the square has area 1). Where f jumps across a curve x(t, θ) that moves
//! with θ, Reynolds' transport theorem adds to the interior derivative
//! ∫_P ∂f/∂θ dx the line integral
//!
//! ∫_{curve ∩ P} (f⁻ − f⁺) (∂x/∂θ · n) dℓ,
//!
//! with n a unit normal of the curve and f⁺, f⁻ the radiance just on the
//! side n points to and just on the other: when the curve moves towards
//! n, film that saw f⁺ now sees f⁻.
//!
//! **The estimator** (edge sampling, after Li, Aittala, Durand & Lehtinen,
//! "Differentiable Monte Carlo ray tracing through edge sampling", 2018).
//! Each discontinuity curve is a 3-D curve s(t), t ∈ [0, 1), mapped to the
//! film: x(t) = project(s(t)) for what the camera sees directly, or
//! project(q(t)) for a shadow edge, q(t) the first surface behind s(t)
//! on the ray from a point light through it. A sample draws t uniformly,
//! evaluates f⁺ and f⁻ with the pixel's own integrator on camera rays at
//! x ± ε·n (ε = [`OFFSET_PX`]), and contributes to the pixel holding x
//!
//! (f⁻ − f⁺) · (∂x/∂θ · ⊥(dx/dt)),   ⊥(a, b) = (−b, a),
//!
//! which is the integrand above times |dx/dt| over the density 1 of t: the
//! change of variables from film arc length to t. Both derivatives come
//! from forward mode: ∂x/∂θ from the curve built on the K-wide duals of
//! the [`DualScene`] (the silhouette moves with the sphere, the eye, the
//! light), dx/dt from the same formulas on a one-wide dual seeded with t.
//! The two radiance values share their random numbers, so what they have
//! in common cancels. A sample counts only where the eye sees the curve
//! point (or, for a shadow edge, the shadow point): where something hides
//! the curve, both rays see the hiding surface and differ by its smooth
//! change over 2ε, an error of one sign along the hidden stretch that does
//! not average out, so one more ray tests visibility (`eye_sees`, or the
//! mirror's `shows`). The expectation is the line integral for every pixel the curve
//! crosses, so interior + boundary is an unbiased estimate of the whole
//! derivative, up to the offset ε: f± are taken ε pixels from the curve
//! (smooth shading there differs from its limit by O(ε), at a sphere's
//! silhouette by O(√ε) relative to the curvature radius in pixels). A
//! shadow edge is placed where the renderer's shadow rays put it: they
//! start a small offset off the surface, which shifts the edge by up to a
//! few hundredths of a pixel, more than ε (see `on_film`).
//!
//! **The curves** ([`curves`]): the silhouette of a sphere or an ellipsoid
//! from a point is a circle or an ellipse in closed form, so it is
//! sampled exactly, not as a polygon. A mesh contributes its border edges,
//! its silhouette edges (faces on both sides of the viewpoint) and, seen
//! from the eye, its creases where flat shading jumps. The viewpoints are
//! the eye (silhouettes and creases, moving with the object or the camera)
//! and every point light the integrator uses (shadow edges, moving with
//! the occluder, the light, the receiver or the camera). The eye also sees
//! each plane's horizon, the film line of the directions parallel to it,
//! which moves when the camera turns or the plane tilts
//! ([`curves::horizon`]), and the curves where two surfaces pass through
//! each other (a sphere or an ellipsoid through a plane, two spheres: a
//! circle or an ellipse in closed form, [`meeting::meeting`]), which move
//! with either surface; their jump is taken beyond the dark band the
//! renderer's offset rays leave along the curve
//! ([`meeting::meeting_band`]). Where one of the two casts a shadow on the other,
//! that shadow's edge touches their meeting curve tangentially, and over
//! the stretch where the two run closer on the film than ε each sample
//! sees both jumps; the excess shrinks as √ε in scene units, so it fades
//! with the image's resolution (measured on two spheres lit from the
//! side: the boundary term 36 % high at 64×64 pixels, 14 % at 256×256,
//! within the noise at 1024×1024; `crates/core/tests/boundary/`).
//!
//! **In flat mirrors** ([`mirror`]): under Whitted, what a reflecting
//! plane, lone triangle or planar mesh shows is the scene seen from the
//! eye's mirror image, so each curve is sampled once more per mirror,
//! placed on the film at the projection of its mirror image (the plane
//! moved by half the renderer's spawn offset towards the eye, where its
//! reflected rays start: [`Mirror::as_traced`]), and a sample counts
//! where two rays find that the mirror shows the curve point. A curve
//! seen directly counts where the eye sees its point (one ray).
//!
//! **In curved mirrors and through glass** ([`curved`]): a reflecting
//! sphere or ellipsoid shows each film point along its own reflected ray,
//! and a glass one along its own refracted one (straight through, or
//! after reflections inside), so the curves there (other smooth objects'
//! silhouettes, planes' horizons, point lights' shadow edges cast by
//! smooth objects) are level sets of functions of the film position,
//! found on a quarter-pixel grid over the object's image and sampled with
//! their normal speed from the implicit function theorem. The same holds
//! along every chain of specular bounces the renderer traces that
//! includes a curved one (a mirror seen in the floor, glass seen in a
//! mirror, …).
//!
//! **Why edge sampling.** raylab's primitives have exact silhouettes, and
//! edge sampling turns each into a 1-D integral whose estimate is unbiased
//! and whose cost is two radiance evaluations per sample, reported apart
//! ([`BoundaryStats`]). Reparameterisation (Loubet, Holzschuch & Jakob
//! 2019) is biased where its warp is not exact; warped-area sampling
//! (Bangaru, Li & Durand 2020) is unbiased but estimates its warp field
//! with further rays in every sample; projective sampling (Zhang, Roussel &
//! Jakob 2023) pays off for edges seen from many shading
//! points, which the curves here are not.
//!
//! **After the camera ray** ([`vertex`], [`area`]): under `direct` and
//! `path:K` every path vertex has an integral over the emitters (light
//! sampling) and one over directions (its BRDF ray), and both have moving
//! discontinuities: soft shadows on the emitters, and silhouettes, borders,
//! creases and point lights' shadow edges seen from the vertex. They are
//! sampled at every vertex of paths drawn as the path tracer draws them,
//! each curve in proportion to the angle it subtends at the vertex
//! ([`angles`]); a moving emitter counts by the motion relative to its
//! own material points.
//!
//! **Not covered** (left to the interior derivative, hence biased where
//! they act): triangle meshes' edges and shadows seen in a curved mirror
//! or through glass, anything seen in a mesh mirror not in one plane, in
//! a chain of bounces with a triangle mirror in it (a flat mirror seen in
//! a flat mirror included), or through glass that is not a sphere or an
//! ellipsoid, a plane's horizon seen in a flat mirror or from a path
//! vertex, the pieces of a curve in a curved mirror that its grid misses
//! (within a cell where something in front hides part of the mirror, or
//! at the rim of a second curved object the first shows), curves where
//! surfaces pass through each other other than those above (an ellipsoid
//! through a sphere or another ellipsoid, a triangle through anything)
//! or seen in a mirror's curve grid, and an edge that rests
//! on another surface (a block on a floor): moved into that surface it
//! moves nothing visible, while the term moves it with its jump (the
//! derivative at a contact is one-sided).

pub mod angles;
pub mod area;
pub mod curved;
pub mod curves;
mod film;
pub mod meeting;
pub mod mirror;
pub mod pick;
pub(crate) mod sums;
pub mod vertex;

use super::params::{is_camera, is_geometric};
use super::planes::Planes;
use super::view::DualScene;
use crate::camera::Frame;
use crate::integrator::{in_pool, IntegratorKind};
use crate::math::{Dual, Real, SplitMix64, V3};
use crate::scene::param::ParamId;
use crate::scene::View;
use crate::shape::{Shape, ShapeR};
use curved::{curved_jobs, sample_curved};
use curves::{edge_curve, edge_matters, horizon, mesh_edges, smooth_silhouette, Curve};
use film::{behind, eye_sees, film_length, on_film, shadow_point};
use meeting::{meeting, meeting_band, meeting_pairs};
use mirror::{mirrors, Mirror};
use std::time::Instant;
use sums::{fold_in_order, grazing, jump, landed, offset_by, CurveResult, SparseSums};

/// Distance in pixels from the curve at which f⁺ and f⁻ are evaluated:
/// far enough above `f32` round-off of film positions (about 10⁻⁵ px) and
/// of the curve itself (about 10⁻⁴ px) to land on the right side, near
/// enough that the radiance there is its limit at the curve.
pub const OFFSET_PX: f32 = 1e-3;

/// Which derivative is computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Visibility {
    /// Forward mode through fixed samples only: biased where parameters
    /// move silhouettes or shadow edges.
    Interior,
    /// Interior plus the boundary term: the whole derivative.
    #[default]
    Full,
}

impl Visibility {
    pub fn parse(s: &str) -> Result<Self, crate::ParseError> {
        match s {
            "interior" => Ok(Self::Interior),
            "full" => Ok(Self::Full),
            _ => Err(crate::ParseError::Unknown {
                what: "visibility",
                given: s.to_string(),
                expected: "`interior` or `full`".into(),
            }),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Interior => "interior",
            Self::Full => "full",
        }
    }
}

/// What the boundary term sampled and what it cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BoundaryStats {
    /// Curves sampled: silhouettes, creases, horizons and the curves where
    /// surfaces meet seen from the eye, and silhouettes seen from point
    /// lights (shadow edges).
    pub primary_curves: u64,
    pub shadow_curves: u64,
    /// Curve samples drawn (on the film, and in the path vertices'
    /// integrals over directions), and the samples that contributed: on
    /// the film where the curve moves, in a vertex's integral where the
    /// curve point is in view and moves, and for the area-light term where
    /// an emitter lies behind a silhouette with its visibility changing
    /// across it. (The others contribute 0 without a radiance evaluation.)
    pub samples: u64,
    pub landed: u64,
    /// The vertex terms ([`vertex`]): paths drawn (film samples) and
    /// their vertices, each sampled once for each term.
    pub paths: u64,
    pub vertices: u64,
    /// Rays cast to find and test curve points: from point lights past a
    /// curve (shadow edges, their film lengths), into a flat mirror and on
    /// to the curve point it shows (two per sample), from path vertices
    /// (visibility of the curve point, the area-light term's shadow rays);
    /// and radiance evaluations (two per landed sample: a camera ray, or a
    /// vertex's ray along a direction, and all that follows it).
    pub light_rays: u64,
    pub evaluations: u64,
    /// Wall time of the boundary term, seconds.
    pub seconds: f64,
}

impl BoundaryStats {
    fn add(&mut self, o: &Self) {
        self.primary_curves += o.primary_curves;
        self.shadow_curves += o.shadow_curves;
        self.samples += o.samples;
        self.paths += o.paths;
        self.vertices += o.vertices;
        self.landed += o.landed;
        self.light_rays += o.light_rays;
        self.evaluations += o.evaluations;
        self.seconds += o.seconds;
    }
}

/// The boundary term of each pixel's derivative for some parameters: its
/// planes hold the estimate and the variance of each pixel's estimate.
#[derive(Clone, Debug, Default)]
pub struct Boundary {
    pub planes: Planes,
    pub stats: BoundaryStats,
}

impl Boundary {
    /// Zero for `n` parameters over a `width` × `height` image.
    pub fn zeros(n: usize, width: u32, height: u32) -> Self {
        Self {
            planes: Planes::zeros(n, width, height),
            stats: BoundaryStats::default(),
        }
    }

    /// Another term for the same parameters added in; the stats summed.
    pub fn absorb(&mut self, o: Boundary) {
        self.planes.add_scaled(&o.planes, 1.0);
        self.stats.add(&o.stats);
    }

    /// Another pass's parameters after these; the stats summed.
    pub fn extend(&mut self, o: Boundary) {
        self.planes.extend(o.planes);
        self.stats.add(&o.stats);
    }
}

/// One curve to sample: where it lies, seen from the eye (`light` None)
/// or from point light `light`, directly or in `mirror`, and how many
/// samples it gets.
struct Job<const K: usize> {
    curve: Curve<Dual<K>>,
    light: Option<usize>,
    mirror: Option<Mirror<Dual<K>>>,
    /// The sphere or ellipsoid whose silhouette the curve is.
    smooth: Option<u32>,
    /// The two primitives that meet along the curve.
    meeting: Option<(u32, u32)>,
    samples: u32,
}

/// The boundary term for `params` (at most K, the parameters seeded in
/// `view`) with `integrator`, drawing about `density` samples per pixel of
/// curve length on the film, seeded by `seed`, on `threads` threads. The
/// result does not depend on the number of threads.
pub fn boundary_term<const K: usize>(
    view: &DualScene<'_, K>,
    params: &[ParamId],
    integrator: &IntegratorKind,
    density: f32,
    seed: u64,
    threads: Option<usize>,
) -> Boundary {
    let start = Instant::now();
    let scene = view.scene();
    let n = params.len();
    let mut out = Boundary::zeros(n, scene.camera.width, scene.camera.height);
    if !params.iter().any(is_geometric) {
        return out;
    }
    let jobs = collect_curves(view, params, integrator, density, &mut out.stats);
    let seed = SplitMix64::mix(seed ^ 0xB0DA_7E55_ED6E_u64);
    in_pool(threads, || {
        fold_in_order(&jobs, &mut out, |j, job| {
            sample_curve(view, job, n, integrator, SplitMix64::mix(seed ^ j as u64))
        });
        // Curves seen in curved mirrors, after the others (their seeds
        // follow on).
        let curved = curved_jobs(view, params, integrator, density, &mut out.stats);
        fold_in_order(&curved, &mut out, |j, job| {
            let seed = SplitMix64::mix(seed ^ (jobs.len() + j) as u64);
            sample_curved(view, job, n, integrator, seed)
        });
    });
    out.stats.seconds = start.elapsed().as_secs_f64();
    out
}

/// The curves that can move on the film for these parameters, each with
/// its number of samples.
fn collect_curves<const K: usize>(
    view: &DualScene<'_, K>,
    params: &[ParamId],
    integrator: &IntegratorKind,
    density: f32,
    stats: &mut BoundaryStats,
) -> Vec<Job<K>> {
    let scene = view.scene();
    let camera = params.iter().any(is_camera);
    let any_object = (0..scene.objects.len() as u32).any(|o| view.moves(o));
    let whitted = matches!(integrator, IntegratorKind::Whitted);
    // Viewpoints: the eye, then the point lights the integrator uses;
    // under Whitted, the same again in each flat mirror, with the eye's
    // mirror image in place of the eye (`mirror`).
    let mut viewpoints: Vec<(Option<usize>, V3<Dual<K>>, bool)> = Vec::new();
    viewpoints.push((None, view.frame().eye, camera));
    for (i, l) in scene.lights.iter().enumerate() {
        if l.whitted_only && !whitted {
            continue;
        }
        let moves = light_moves(view, i);
        viewpoints.push((
            Some(i),
            view.point_light(i).0,
            moves || camera || any_object,
        ));
    }
    let edges = mesh_edges(scene);
    let meetings = meeting_pairs(scene);
    let mirrors = if whitted { mirrors(view) } else { Vec::new() };
    let mut jobs = Vec::new();
    for mirror in std::iter::once(None).chain(mirrors.into_iter().map(Some)) {
        for &(light, o, all) in &viewpoints {
            let (o, all) = match (mirror, light) {
                (Some(m), None) => (m.reflect(o), all || view.moves(m.object)),
                _ => (o, all),
            };
            let include = |object: u32| all || view.moves(object);
            let mut curves = Vec::new();
            for (prim, p) in scene.prims.iter().enumerate() {
                let smooth = matches!(p.shape, Shape::Sphere(_) | Shape::Ellipsoid(_));
                if smooth && include(p.object) {
                    if let Some(c) = smooth_silhouette(&view.geometry(prim as u32), o) {
                        curves.push((c, Some(prim as u32), None));
                    }
                }
            }
            for e in &edges {
                let object = scene.prims[e.faces[0] as usize].object;
                if include(object) && edge_matters(scene, e, o.value(), light.is_none()) {
                    let c = edge_curve(e, |prim, corner| match view.geometry(prim) {
                        ShapeR::Triangle { p } => p[corner],
                        _ => unreachable!("mesh edges join triangles"),
                    });
                    // Seen from the eye, an edge in the mirror's plane is
                    // its own image.
                    if !(light.is_none() && mirror.is_some_and(|m| in_plane(&c, &m))) {
                        curves.push((c, None, None));
                    }
                }
            }
            // Seen from the eye, directly or in a mirror, where two
            // surfaces pass through each other (not from a light: the
            // curve lies on what it would shadow).
            if light.is_none() {
                for &(a, b) in &meetings {
                    let object = |prim: u32| scene.prims[prim as usize].object;
                    if !(include(object(a)) || include(object(b))) {
                        continue;
                    }
                    let c = meeting(&view.geometry(a), &view.geometry(b));
                    if let Some(c) = c.filter(|c| !mirror.is_some_and(|m| in_plane(c, &m))) {
                        curves.push((c, None, Some((a, b))));
                    }
                }
            }
            // Seen directly from the eye, the planes' horizons.
            if light.is_none() && mirror.is_none() {
                for (prim, p) in scene.prims.iter().enumerate() {
                    if !(matches!(p.shape, Shape::Plane(_)) && include(p.object)) {
                        continue;
                    }
                    if let ShapeR::Plane { normal, .. } = view.geometry(prim as u32) {
                        curves.extend(horizon(view.frame(), normal).map(|c| (c, None, None)));
                    }
                }
            }
            for (curve, smooth, meeting) in curves {
                let length = film_length(view, &curve, light, mirror.as_ref(), stats);
                let samples = (density * length).ceil().clamp(2.0, 1e7) as u32;
                match light {
                    None => stats.primary_curves += 1,
                    Some(_) => stats.shadow_curves += 1,
                }
                jobs.push(Job {
                    curve,
                    light,
                    mirror,
                    smooth,
                    meeting,
                    samples,
                });
            }
        }
    }
    jobs
}

/// Whether curve `c` lies in mirror `m`'s plane (three of its points do:
/// two suffice for a segment, three not on a line for an ellipse).
fn in_plane<const K: usize>(c: &Curve<Dual<K>>, m: &Mirror<Dual<K>>) -> bool {
    [0.0, 1.0 / 3.0, 2.0 / 3.0]
        .iter()
        .all(|&t| m.holds(c.point(Dual::from_f32(t)).value()))
}

/// Whether point light `i` moves with the parameters.
fn light_moves<const K: usize>(view: &DualScene<'_, K>, i: usize) -> bool {
    let position = view.point_light(i).0;
    let d = position.x.d.iter().chain(&position.y.d);
    d.chain(&position.z.d).any(|&d| d != 0.0)
}

/// Draw `job.samples` points on one curve and return what they add to
/// each pixel (the first `n` of the K parameters).
fn sample_curve<const K: usize>(
    view: &DualScene<'_, K>,
    job: &Job<K>,
    n: usize,
    integrator: &IntegratorKind,
    seed: u64,
) -> CurveResult<K> {
    let scene = view.scene();
    let whitted = matches!(integrator, IntegratorKind::Whitted);
    let (w, h) = (scene.camera.width, scene.camera.height);
    let frame1: Frame<Dual<1>> = scene.camera.frame().lift();
    let curve1 = job.curve.map(|p| V3::<Dual<1>>::from_vec3(p.value()));
    let mut stats = BoundaryStats {
        samples: u64::from(job.samples),
        ..Default::default()
    };
    let mut rng = SplitMix64(seed);
    let mut sums = SparseSums::<K>::new(n);
    let light = job.light.map(|i| view.point_light(i).0);
    let mirror1 = job.mirror.map(|m| m.value::<Dual<1>>());
    let mirror0 = job.mirror.map(|m| m.value::<f32>());
    for index in 0..job.samples {
        let t = rng.next_f32();
        let mut s = job.curve.point(Dual::from_f32(t));
        let mut s1 = curve1.point(Dual::<1>::variable(t, 0));
        let hit = match light {
            None => None,
            Some(l) => {
                stats.light_rays += 1;
                match behind(scene, l.value(), s.value()) {
                    Some(hit) => Some((l, hit)),
                    None => continue,
                }
            }
        };
        let place = |s: V3<Dual<K>>, s1: V3<Dual<1>>, mirror, mirror1| {
            let x = on_film(
                view.frame(),
                (w, h),
                s,
                hit.map(|(l, hit)| (l, hit, view.geometry(hit.prim))),
                mirror,
            );
            let x1 = on_film(
                &frame1,
                (w, h),
                s1,
                hit.map(|(l, hit)| {
                    let shape = ShapeR::of(&scene.prims[hit.prim as usize]);
                    (V3::from_vec3(l.value()), hit, shape)
                }),
                mirror1,
            );
            x.zip(x1)
        };
        let Some(((mut x, mut y), (mut x1, mut y1))) =
            place(s, s1, job.mirror.as_ref(), mirror1.as_ref())
        else {
            continue;
        };
        if let (Some(m), Some(m1), Some(m0)) = (&job.mirror, &mirror1, &mirror0) {
            // Place it again where the renderer's reflected rays see it,
            // off the plane by their spawn offset at the point they leave
            // from (`Mirror::as_traced`); a silhouette seen from the
            // mirrored eye moves with that eye.
            stats.light_rays += 1;
            let Some((ray, q)) = m0.meets(scene, (x.v, y.v)) else {
                continue;
            };
            let (m, m1) = (
                m.as_traced(q.point, ray.origin),
                m1.as_traced(q.point, ray.origin),
            );
            if let (Some(prim), None) = (job.smooth, job.light) {
                let o = m.reflect(view.frame().eye);
                let Some(c) = smooth_silhouette(&view.geometry(prim), o) else {
                    continue;
                };
                s = c.point(Dual::from_f32(t));
                let c1 = c.map(|p| V3::<Dual<1>>::from_vec3(p.value()));
                s1 = c1.point(Dual::<1>::variable(t, 0));
            }
            let Some(placed) = place(s, s1, Some(&m), Some(&m1)) else {
                continue;
            };
            ((x, y), (x1, y1)) = placed;
        }
        if !(x.v >= 0.0 && y.v >= 0.0 && x.v < w as f32 && y.v < h as f32) {
            continue;
        }
        // Only where the eye sees the curve point (or the receiver at the
        // shadow point), directly or in the mirror, is there an edge;
        // elsewhere the two evaluations would differ by the smooth change
        // of what is in front over 2ε (a bias the per-pixel check sees on
        // shadow edges hidden behind the sphere that casts them).
        let target = match hit {
            None => s.value(),
            Some((l, hit)) => shadow_point(l, s, hit, &view.geometry(hit.prim)).value(),
        };
        let seen = match &mirror0 {
            None => {
                stats.light_rays += 1;
                eye_sees(scene, (x.v, y.v), target)
            }
            Some(m) => {
                stats.light_rays += 2;
                m.shows(scene, (x.v, y.v), target)
            }
        };
        if !seen {
            continue;
        }
        // ANCHOR: edge_sample
        // ⊥(dx/dt): a normal of the curve on the film, |dx/dt| long.
        let normal = (-y1.d[0], x1.d[0]);
        let len = normal.0.hypot(normal.1);
        if !(len > 0.0 && len.is_finite()) {
            continue;
        }
        let speed: Vec<f32> = (0..n)
            .map(|k| x.d[k] * normal.0 + y.d[k] * normal.1)
            .collect();
        if speed.iter().all(|&v| v == 0.0) {
            continue;
        }
        // ANCHOR_END: edge_sample
        // A reflecting or refracting sphere's silhouette seen directly
        // (under Whitted): the colour inside is taken in its limit.
        let mut limit = None;
        if let (Some(prim), None, None, true) = (job.smooth, job.light, job.mirror, whitted) {
            let m = View::material(scene, scene.prims[prim as usize].object);
            if m.reflectivity > 0.0 || m.transparency > 0.0 {
                let Some(c) = grazing(scene, prim, s.value()) else {
                    continue;
                };
                let centre = match job.curve {
                    Curve::Ellipse { centre, .. } => centre.value(),
                    Curve::Segment { p0, .. } => p0.value(),
                };
                let side = scene
                    .camera
                    .frame()
                    .project(V3::<f32>::from_vec3(centre), w, h);
                let inward = side.map_or(0.0, |(cx, cy)| {
                    (cx - x.v) * normal.0 + (cy - y.v) * normal.1
                });
                limit = Some((if inward > 0.0 { 1.0 } else { -1.0 }, c));
            }
        }
        // Where two surfaces meet, the jump is taken beyond the band along
        // the curve where the renderer's own rays misbehave
        // ([`meeting::meeting_band`]): its width in scene units, turned into
        // pixels at the curve point's distance from the (mirrored) eye.
        let eps = match job.meeting {
            None => OFFSET_PX,
            Some((a, b)) => {
                let shape = |p: u32| ShapeR::<f32>::of(&scene.prims[p as usize]);
                let eye = view.frame().eye.value();
                let eye = mirror0.map_or(eye, |m| m.reflect(V3::from_vec3(eye)).value());
                let band = meeting_band(&shape(a), &shape(b), s.value(), eye);
                let frame = view.frame();
                let per_px = 2.0 * frame.half_height.value() / frame.near.value() / h as f32;
                OFFSET_PX.max(band / (per_px * (s.value() - eye).length()))
            }
        };
        // ANCHOR: edge_sample_add
        let (pixel, ctx) = landed(&mut stats, (x.v, y.v), w, index, seed);
        let jump = jump(
            scene,
            integrator,
            (x.v, y.v),
            offset_by(normal, len, eps),
            &ctx,
            limit,
        );
        sums.add(pixel, jump, &speed);
        // ANCHOR_END: edge_sample_add
    }
    CurveResult {
        sums,
        samples: job.samples,
        stats,
    }
}
