//! The boundary terms inside the path tracer's vertex integrals
//! (secondary visibility): what `direct` and `path:K` gain when a
//! parameter moves a discontinuity that a path meets after the camera ray.
//!
//! At each vertex x of a path the estimator computes two integrals: light
//! sampling's over the emitters and the BRDF ray's over directions,
//! ∫ (ρ/π) cos θ C(ω) dω, C(ω) all the estimator gathers along ω (the
//! MIS-weighted emission the ray finds and every later vertex's light).
//! Both have discontinuities that move with the parameters:
//!
//! - **over the emitters**: the soft shadows of area lights, where an
//!   occluder's silhouette seen from x falls on an emitter ([`super::area`],
//!   weighted by light sampling's MIS weight);
//! - **over directions**: C jumps where ω crosses a silhouette, a border,
//!   a crease or the curve where two surfaces meet
//!   ([`super::meeting::meeting`]) seen from x (what the ray finds changes: indirect light,
//!   emitters found by the BRDF ray, their own edges), and where the ray's
//!   hit crosses the shadow edge of a point light (which the next vertex's
//!   light sampling sees or not).
//!
//! **The direction term.** Let p(t) be the curve in 3-D (a silhouette or
//! edge seen from x, or a point light's shadow edge on a receiver),
//! ω(t) = (p(t) − o)/|p(t) − o| its image on the sphere of directions, o the
//! origin of the vertex's rays (x moved off the surface by the renderer's
//! offset). Reynolds' theorem on the sphere adds
//! ∮ (g⁻ − g⁺)(v · m̂) dℓ, g = (ρ/π) cos θ C. The velocity v that counts is
//! the curve's *relative to the sampled directions*: for fixed random
//! numbers a direction turns with the vertex's shading frame, ω̇ₛ, so
//! v = (ṗ − ẋ)/|p − o| − ω̇ₛ (the components along ω drop out below). With
//! m = ω × p′/|p − o|, a normal of the curve on the sphere |dω/dt| long,
//! a sample (curve, t) drawn with density P contributes
//!
//! β · (ρ/π) cos θ · (C(ω − ε m̂) − C(ω + ε m̂)) · (v · m) / P,
//!
//! β the path's throughput at x, C on both sides evaluated by
//! [`PathTracer::continue_along`] with the path's own random numbers
//! (ε = [`DIR_OFFSET`] rad). Paths are drawn as the path tracer draws them
//! (on values; x, its normal and β on dual numbers), each vertex adds one
//! sample of each term, and the sum over a path is one sample of the
//! pixel's secondary term: an unbiased estimate, with its variance from
//! the film samples.
//!
//! **Sampling.** |m| = |dω/dt| grows as 1/distance near x, so a curve
//! drawn uniformly with t uniform makes near edges rare, large samples.
//! The curves seen from x are drawn instead in proportion to the angle
//! they subtend there and t uniformly in that angle
//! ([`super::angles::ByAngle`]): P = |dω/dt| / Φ, Φ the candidates' total
//! angle, and the factor cancels to Φ. The point lights' shadow edges
//! (curves on receivers, whose angle from x is not at hand without a ray
//! per curve) are drawn uniformly, t uniform, sharing the choice in
//! proportion to their number.
//!
//! The camera ray's own discontinuities (silhouettes and point lights'
//! shadow edges on the film) are [`super::boundary_term`]'s; the two
//! partitions do not overlap. The last vertex's BRDF ray only finds
//! emission, so point lights' shadow edges are taken at every vertex but
//! the last.
//!
//! **Checked** against central differences of converged renders, per
//! pixel (≥ 99 % within 4 standard errors of both) and by image mean
//! (z-tests): the Cornell box's blocks under `direct` and `path:2`, its
//! camera under `path:2`, its light moved and deformed under `direct`,
//! and two spheres through each other under `path:1`, whose meeting the
//! floor sees (98.8 % of pixels without the meeting curves here)
//! (`crates/core/tests/boundary/`).
//!
//! **Variance.** The terms are unbiased but not bounded: near a vertex an
//! edge's image on the sphere of directions grows as 1/distance, and a
//! vertex hit at grazing incidence on a moving surface moves as
//! 1/cos θ. Where the scene makes either common the estimate is heavy
//! tailed. The Cornell box is such a scene for parameters that move path
//! vertices (its camera, or a block the camera sees): its two-sided light
//! hangs 2 mm below the ceiling, so the ceiling round it is lit from
//! millimetres away, and the derivative of that light (the interior
//! derivative's as much as these terms') is dominated by rare samples: at
//! 16×16 the tall block's z under `path:2` comes out −1.95e-2 ± 0.05e-2
//! over 6 seeds × 1024 spp against central differences' −2.46e-2 ±
//! 0.01e-2. With the light lowered to 15 cm below the ceiling the same
//! estimates agree (−2.71e-2 ± 0.11e-2 against −2.71e-2 ± 0.05e-2), which
//! is why the tests use that variant. (Measured 2026-11-24 with `raylab
//! grad --check fd:0.02`, release build, 2-core AMD EPYC.)

use super::angles::ByAngle;
use super::area;
use super::curves::{edge_matters, mesh_edges, smooth_silhouette, Curve, Edge};
use super::meeting::{meeting_band, meeting_pairs};
use super::pick::{build, candidates, Pick};
use super::{behind, shadow_point, Boundary, BoundaryStats};
use crate::diff::params::is_geometric;
use crate::diff::planes::{PixelMoments, Spread};
use crate::diff::view::DualScene;
use crate::integrator::path::{NoEnd, PathTracer, Vertex};
use crate::integrator::{in_pool, SampleContext};
use crate::math::{orthonormal_basis_r, Dual, Real, SplitMix64, Vec3, V3};
use crate::scene::param::ParamId;
use crate::scene::View;
use crate::shape::{HitR, ShapeR};
use crate::stats::NoStats;
use rayon::prelude::*;
use std::time::Instant;

/// Angle (radians) from the curve at which C± are evaluated: above `f32`
/// round-off of directions (about 10⁻⁷) and of grazing intersections
/// (about 10⁻⁵ relative), small against the scenes' features.
pub const DIR_OFFSET: f32 = 1e-4;

/// What every vertex shares: the mesh edges, and the silhouettes seen from
/// each point light the path tracer uses (shadow edges), with the
/// light's position and whether the edges can move where x does not (the
/// light or some object moves).
struct Shared<const K: usize> {
    edges: Vec<Edge>,
    /// The primitives that pass through each other ([`meeting_pairs`]).
    meetings: Vec<(u32, u32)>,
    lights: Vec<(V3<Dual<K>>, Curve<Dual<K>>, bool)>,
}

fn moves<const K: usize>(p: &V3<Dual<K>>) -> bool {
    [p.x, p.y, p.z]
        .iter()
        .any(|c| c.d.iter().any(|&d| d != 0.0))
}

/// The secondary boundary term of the path tracer `tracer` (`direct` or
/// `path:K`) for `params`, `density` paths per pixel, seeded by `seed`, on
/// `threads` threads (the same on any number).
pub fn path_term<const K: usize>(
    view: &DualScene<'_, K>,
    params: &[ParamId],
    tracer: &PathTracer,
    density: u32,
    seed: u64,
    threads: Option<usize>,
) -> Boundary {
    let start = Instant::now();
    let scene = view.scene();
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let n = params.len();
    let mut out = Boundary::zeros(n, scene.camera.width, scene.camera.height);
    if !params.iter().any(is_geometric) {
        return out;
    }
    let shared = shared(view);
    let seed = SplitMix64::mix(seed ^ 0x5EC0_ADA1_0000_u64);
    let paths = Paths {
        view,
        shared: &shared,
        tracer,
        n,
        density,
        seed,
    };
    let rows: Vec<Vec<(PixelMoments<K>, BoundaryStats)>> = in_pool(threads, || {
        (0..h)
            .into_par_iter()
            .map(|py| {
                (0..w)
                    .map(|px| {
                        let mut stats = BoundaryStats::default();
                        let sums = pixel(&paths, (px, py), &mut stats);
                        (sums, stats)
                    })
                    .collect()
            })
            .collect()
    });
    let m = f64::from(density.max(1));
    for (py, row) in rows.into_iter().enumerate() {
        for (px, (sums, stats)) in row.into_iter().enumerate() {
            out.stats.add(&stats);
            out.planes.add_pixel(py * w + px, n, &sums, m, Spread::Mean);
        }
    }
    out.stats.seconds = start.elapsed().as_secs_f64();
    out
}

/// The mesh edges and the point lights' silhouettes.
fn shared<const K: usize>(view: &DualScene<'_, K>) -> Shared<K> {
    let scene = view.scene();
    let edges = mesh_edges(scene);
    let any_object = (0..scene.objects.len() as u32).any(|o| view.moves(o));
    let mut lights = Vec::new();
    for (i, l) in scene.lights.iter().enumerate() {
        if l.whitted_only {
            continue; // the path tracer skips them
        }
        let position = view.point_light(i).0;
        // Whether its shadow edges move even where x does not.
        let moving = moves(&position) || any_object;
        for prim in 0..scene.prims.len() as u32 {
            if let Some(c) = smooth_silhouette(&view.geometry(prim), position) {
                lights.push((position, c, moving));
            }
        }
        for (e, edge) in edges.iter().enumerate() {
            if edge_matters(scene, edge, position.value(), false) {
                let c = build(Pick::Edge(e), &edges, position, |prim| view.geometry(prim));
                lights.extend(c.map(|c| (position, c, moving)));
            }
        }
    }
    let meetings = meeting_pairs(scene);
    Shared {
        edges,
        meetings,
        lights,
    }
}

/// What every pixel's paths share: the view, the curves, the path tracer,
/// the first `n` of the K parameters, the paths per pixel and the seed.
struct Paths<'a, const K: usize> {
    view: &'a DualScene<'a, K>,
    shared: &'a Shared<K>,
    tracer: &'a PathTracer,
    n: usize,
    density: u32,
    seed: u64,
}

/// One pixel's sums over its `density` paths, per parameter.
fn pixel<const K: usize>(
    paths: &Paths<'_, K>,
    (px, py): (usize, usize),
    stats: &mut BoundaryStats,
) -> PixelMoments<K> {
    let Paths {
        view,
        shared,
        tracer,
        n,
        density,
        seed,
    } = *paths;
    let scene = view.scene();
    let w = scene.camera.width as usize;
    let mut sums = PixelMoments::<K>::default();
    let mut rng = SplitMix64(SplitMix64::mix(seed ^ (py * w + px) as u64));
    for index in 0..density {
        stats.paths += 1;
        let (fx, fy) = (px as f32 + rng.next_f32(), py as f32 + rng.next_f32());
        let ctx = SampleContext {
            px: px as u32,
            py: py as u32,
            index,
            seed,
        };
        let ray = view.camera_ray(fx, fy);
        let mut g = [[0.0f64; 3]; K];
        let mut add = |a: [[f64; 3]; K]| {
            for (gk, ak) in g.iter_mut().zip(a) {
                for c in 0..3 {
                    gk[c] += ak[c];
                }
            }
        };
        let mut visit = |v: &Vertex<'_, Dual<K>>| {
            stats.vertices += 1;
            let (beta, albedo) = (v.beta.value(), v.albedo.value());
            let u: [f32; 4] = std::array::from_fn(|_| rng.next_f32());
            if let Some(a) =
                area::at_vertex(view, &shared.edges, v.hit, albedo, beta, u[0], u[1], stats)
            {
                add(a);
            }
            if let Some(d) = direction_term(view, shared, tracer, v, &ctx, (u[2], u[3]), stats) {
                add(d);
            }
        };
        tracer.trace_visiting(view, &ray, &ctx, &mut NoStats, None::<&NoEnd>, &mut visit);
        sums.add(&g[..n]);
    }
    sums
}

/// One sample of the direction term at vertex `v` of the path `ctx`
/// (`u_curve` picks the curve, `t` the point on it): per parameter and
/// channel, or `None` where it is zero.
fn direction_term<const K: usize>(
    view: &DualScene<'_, K>,
    shared: &Shared<K>,
    tracer: &PathTracer,
    v: &Vertex<'_, Dual<K>>,
    ctx: &SampleContext,
    (u_curve, u_t): (f32, f32),
    stats: &mut BoundaryStats,
) -> Option<[[f64; 3]; K]> {
    let scene = view.scene();
    let hit = v.hit;
    let (x, n) = (hit.point, hit.shading_normal);
    let xv = x.value();
    // Everything seen from x matters when x or its frame moves; otherwise
    // only what moves.
    let x_moves = moves(&x) || moves(&n);
    let curves = (&shared.edges[..], &shared.meetings[..]);
    let picks = candidates(scene, curves, xv, hit.hit.prim, true, |o| {
        x_moves || view.moves(o)
    });
    let lights: Vec<usize> = if v.bounce < tracer.max_bounces {
        (0..shared.lights.len()).collect()
    } else {
        Vec::new()
    };
    // Pick a curve and a point t on it (module doc, "Sampling"): the
    // curves seen from x in proportion to the angle they subtend, t
    // uniform in that angle; the point lights' shadow edges uniformly,
    // t uniform. `weight` is 1 / (the pick's probability × t's density).
    let xf = V3::<f32>::from_vec3(xv);
    let seen = ByAngle::new(
        picks.iter().map(|&pick| {
            build(pick, &shared.edges, xf, |prim| {
                ShapeR::of(&scene.prims[prim as usize])
            })
        }),
        xv,
        None,
    );
    let seen_share = if seen.is_empty() { 0 } else { picks.len() };
    let m = seen_share + lights.len();
    if m == 0 {
        return None;
    }
    stats.samples += 1;
    let scaled = u_curve * m as f32;
    let (i, t, weight) = if scaled < seen_share as f32 {
        let share = seen_share as f64 / m as f64;
        let (i, t, density) = seen.draw(scaled / seen_share as f32, u_t)?;
        (i, t, 1.0 / (share * density))
    } else {
        let j = ((scaled as usize) - seen_share).min(lights.len() - 1);
        (picks.len() + j, u_t, m as f64)
    };
    // The curve point p (on K-wide duals) and on one-wide duals seeded
    // with t (its tangent).
    let lift = |c: &Curve<Dual<K>>| c.map(|p| V3::<Dual<1>>::from_vec3(p.value()));
    let t1 = Dual::<1>::variable(t, 0);
    let (p, p1) = if i < picks.len() {
        let curve = build(picks[i], &shared.edges, x, |prim| view.geometry(prim))?;
        (curve.point(Dual::from_f32(t)), lift(&curve).point(t1))
    } else {
        let (l, curve, light_moves) = &shared.lights[lights[i - picks.len()]];
        if !(*light_moves || x_moves) {
            return None;
        }
        let s = curve.point(Dual::from_f32(t));
        let s1 = lift(curve).point(t1);
        stats.light_rays += 1;
        let receiver = behind(scene, l.value(), s.value())?;
        let shape1 = ShapeR::of(&scene.prims[receiver.prim as usize]);
        let l1 = V3::<Dual<1>>::from_vec3(l.value());
        (
            shadow_point(*l, s, receiver, &view.geometry(receiver.prim)),
            shadow_point(l1, s1, receiver, &shape1),
        )
    };
    let pv = p.value();
    // The vertex's rays start at o, off the surface on the side of p.
    let o = hit.hit.spawn_origin((pv - xv).try_normalize()?);
    let to = pv - o;
    let dist = to.length();
    let w = to / dist;
    let cos = n.value().dot(w);
    if !(cos > 0.0 && hit.geometric_normal.value().dot(w) > 0.0) {
        return None;
    }
    let dp = Vec3::new(p1.x.d[0], p1.y.d[0], p1.z.d[0]);
    let normal = w.cross(dp) / dist;
    let len = normal.length();
    if !(len > 0.0 && len.is_finite()) {
        return None;
    }
    // The sampled direction with w's local coordinates, on duals: how it
    // turns with the frame for fixed random numbers.
    let nv = n.value();
    let (tv, bv) = orthonormal_basis_r(V3::<f32>::from_vec3(nv));
    let local = [tv.value().dot(w), bv.value().dot(w), nv.dot(w)];
    let (td, bd) = orthonormal_basis_r(n);
    let c = |a: f32| Dual::<K>::from_f32(a);
    let ws = (td * c(local[0]) + bd * c(local[1]) + n * c(local[2])).normalize();
    let mut speed = [0.0f64; K];
    for (k, sk) in speed.iter_mut().enumerate() {
        let part = |q: &V3<Dual<K>>| Vec3::new(q.x.d[k], q.y.d[k], q.z.d[k]);
        let vel = (part(&p) - part(&x)) / dist - part(&ws);
        *sk = f64::from(vel.dot(normal));
    }
    if speed.iter().all(|&s| s == 0.0) {
        return None;
    }
    // Nothing hides the curve point (where something does, both sides see
    // it and the jump is zero); the last hundredth of the way is left out,
    // where the ray grazes the curve's own surface.
    stats.light_rays += 1;
    let (ray, t_max) = hit.hit.shadow_segment(w, pv);
    if scene.occluded(&ray, 0.99 * t_max, &mut NoStats) {
        return None;
    }
    stats.landed += 1;
    stats.evaluations += 2;
    let hv = HitR::<f32>::from(hit.hit);
    let at = Vertex {
        bounce: v.bounce,
        hit: &hv,
        beta: V3::from_vec3(v.beta.value()),
        albedo: V3::from_vec3(v.albedo.value()),
    };
    // Where two surfaces meet, beyond the band along the curve where the
    // renderer's own rays misbehave ([`meeting_band`]).
    let offset = match picks.get(i) {
        Some(&Pick::Meeting(a, b)) => {
            let shape = |p: u32| ShapeR::<f32>::of(&scene.prims[p as usize]);
            DIR_OFFSET.max(meeting_band(&shape(a), &shape(b), pv, o) / dist)
        }
        _ => DIR_OFFSET,
    };
    let side = |sign: f32| {
        let dir = (w + normal / len * (sign * offset)).normalize();
        let c = tracer.continue_along(scene, &at, V3::from_vec3(dir), ctx, &mut NoStats);
        c.value()
    };
    let (plus, minus) = (side(1.0), side(-1.0));
    let jump = (minus - plus) * (cos / std::f32::consts::PI);
    if jump == Vec3::ZERO {
        return None;
    }
    let mut g = [[0.0f64; 3]; K];
    for (gk, &s) in g.iter_mut().zip(&speed) {
        for c in 0..3 {
            gk[c] = weight * f64::from(jump[c]) * s;
        }
    }
    Some(g)
}
