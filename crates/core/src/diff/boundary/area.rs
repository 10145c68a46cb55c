//! The boundary term of area lights' soft shadows inside each path
//! vertex's integral over the emitters (light sampling's half).
//!
//! The path tracer lights a vertex x by the emitters it sees,
//! E(x) = ∫ L_e(y) (ρ/π) cos θ_x |cos θ_y| / |x − y|² V(x, y) dA(y), by
//! light sampling and BRDF sampling combined with MIS weights
//! w_l + w_b = 1. The visibility V jumps along the curves on the emitters
//! where an occluder's silhouette, seen from x, projects; when a parameter
//! moves the occluder (or x, or the camera), those curves move and light
//! sampling's share of E gains the term
//!
//! ∫_{curves} w_l (F⁻ − F⁺) (∂y/∂θ · m̂) dℓ,
//!
//! F the integrand without V, m̂ the curve's unit normal within the
//! emitter's surface and F± on the side m̂ points to and the other. The
//! BRDF-sampling share, w_b (F⁻ − F⁺), is a jump of what the vertex's BRDF
//! ray finds, and is sampled with the other discontinuities over
//! directions ([`super::vertex`]).
//!
//! At a vertex x (drawn by [`super::vertex`]) one occluder silhouette
//! ([`super::curves`]) and a point s(t) on it are drawn with density P,
//! and the shadow rays' line from their origin o (x off the surface by the
//! renderer's offset) through s is continued past it. Where it lands on an
//! emitter at y, F± come from two shadow rays to y ± ε·m̂, and the sample
//! is β · w_l (F⁻ − F⁺)(∂y/∂θ · (dy/dt × n_y)) / P, β the path's
//! throughput at x and dy/dt × n_y being m̂ times the change of variables
//! |dy/dt|. ∂y/∂θ is the motion of the curve's point on the emitter for
//! fixed t (dual numbers through x, s and the emitter's plane).
//!
//! **Sampling.** F |dy/dt| carries cos θ_y / |x − y|² · |dy/dt|, the
//! speed of the curve's image on the sphere of directions at x: near
//! occluders and near emitters make it large. So the silhouettes are drawn
//! in proportion to the angle they subtend at x and t uniformly in that
//! angle ([`super::angles::ByAngle`]), which cancels that speed; and only
//! the arcs of them whose directions enter a cone round some emitter's
//! bounding sphere are drawn at all (a line outside every cone lands on
//! no emitter, so nothing is lost, and no sample is spent there). Drawn
//! uniformly among all silhouettes, most samples found no light.
//!
//! **A moving emitter.** Light sampling draws a point of the emitter for
//! fixed random numbers, so its samples are material points that move
//! with the emitter (and the interior derivative follows them). The
//! integral is then over the emitter's surface coordinates, and what moves
//! the visibility's curve in them is the curve's velocity *relative to the
//! material point under it*: ∂y/∂θ − ∂Y/∂θ, Y the point with y's surface
//! coordinates ([`crate::shape::ShapeR::material_point`]). For an emitter
//! that does not move the second term is zero; for an emitter and occluder
//! moving together with x fixed, it is the motion of the shadow across
//! the light. The emitter's own border is fixed in those coordinates and
//! adds nothing here; where it moves across the directions seen from x,
//! the BRDF share is the direction term's.

use super::angles::{ByAngle, Cone};
use super::curves::Edge;
use super::pick::{build, candidates};
use super::{behind, BoundaryStats};
use crate::diff::view::DualScene;
use crate::math::{Dual, RayR, Real, Vec3, V3};
use crate::scene::View;
use crate::shading::{area_to_solid_angle, cosine_pdf, power_heuristic};
use crate::shape::{HitR, ShapeR, OFFSET_SCALE};
use crate::stats::NoStats;

/// Relative distance (of |x − y|) from the curve on the emitter at which
/// the two shadow rays are cast.
const OFFSET: f32 = 1e-4;

/// The light-sampling half of the area-light boundary term at path vertex
/// `hit` (albedo and throughput β as values), one silhouette sample drawn
/// by `u_curve` and `t`: per parameter and channel, or `None` where it is
/// zero. `edges` are the scene's mesh edges.
#[allow(clippy::too_many_arguments)]
pub(super) fn at_vertex<const K: usize>(
    view: &DualScene<'_, K>,
    edges: &[Edge],
    hit: &HitR<Dual<K>>,
    albedo: Vec3,
    beta: Vec3,
    u_curve: f32,
    t: f32,
    stats: &mut BoundaryStats,
) -> Option<[[f64; 3]; K]> {
    let scene = view.scene();
    let found = hit.hit;
    let x = hit.point;
    let xv = x.value();
    // The silhouettes seen from x (of everything but x's own primitive),
    // chosen on values; only the chosen one is built on dual numbers.
    let picks = candidates(scene, (edges, &[]), xv, found.prim, false, |_| true);
    let xf = V3::<f32>::from_vec3(xv);
    // The cones round the emitters seen from x. The shadow rays start at
    // o, at most `slack` from x ([`crate::shape::OFFSET_SCALE`]); the
    // directions from o into a sphere are those from x into the sphere
    // moved by x − o, inside the sphere grown by `slack`.
    let slack = 2.0 * OFFSET_SCALE * xv.abs().max_element().max(1.0);
    let cones: Vec<Cone> = scene
        .area_lights
        .emitters
        .iter()
        .map(|e| {
            let (centre, radius) = e.bounding_sphere();
            Cone::towards(xv, centre, radius + slack)
        })
        .collect();
    let seen = ByAngle::new(
        picks.iter().map(|&pick| {
            build(pick, edges, xf, |prim| {
                ShapeR::of(&scene.prims[prim as usize])
            })
        }),
        xv,
        Some(&cones),
    );
    if seen.is_empty() {
        return None;
    }
    stats.samples += 1;
    let (i, t, density) = seen.draw(u_curve, t)?;
    let curve = build(picks[i], edges, x, |prim| view.geometry(prim))?;
    let s = curve.point(Dual::from_f32(t));
    // Nothing between x and the silhouette point, then an emitter behind.
    let (sv, dir) = (s.value(), (s.value() - xv).try_normalize()?);
    let (to_s, t_s) = hit.hit.shadow_segment(dir, sv);
    stats.light_rays += 2;
    if scene.occluded(&to_s, t_s, &mut NoStats) {
        return None;
    }
    // The shadow rays start at o, a small offset off the surface
    // ([`crate::shape::OFFSET_SCALE`]): the visibility they see jumps where
    // the line from o (not x) crosses the silhouette.
    let o = to_s.origin;
    let far = behind(scene, o, sv)?;
    let le = scene.materials[scene.objects[far.object as usize].material as usize].emission;
    if le.max_element() <= 0.0 {
        return None;
    }
    // y on the emitter, as a function of the parameters and of t.
    let emitter = view.geometry(far.prim);
    let od = x + V3::from_vec3(o - xv);
    let y_hit = HitR::on(&emitter, None, &RayR::new(od, (s - od).normalize()), far);
    let y = y_hit.point;
    // Light sampling draws the emitter's material points (fixed random
    // numbers move with it), so the curve's velocity that counts is its
    // velocity relative to the material point under it (module doc).
    let painted = emitter.material_point(y.value())?;
    let curve1 = curve.map(|p| V3::<Dual<1>>::from_vec3(p.value()));
    let x1 = V3::<Dual<1>>::from_vec3(o);
    let s1 = curve1.point(Dual::<1>::variable(t, 0));
    let shape1 = ShapeR::of(&scene.prims[far.prim as usize]);
    let y1 = HitR::on(&shape1, None, &RayR::new(x1, (s1 - x1).normalize()), far).point;
    let dy_dt = Vec3::new(y1.x.d[0], y1.y.d[0], y1.z.d[0]);
    let n_y = y_hit.geometric_normal.value();
    let normal = dy_dt.cross(n_y);
    let len = normal.length();
    if !(len > 0.0 && len.is_finite()) {
        return None;
    }
    // F± by two shadow rays either side of the curve on the emitter.
    let yv = y.value();
    let eps = OFFSET * (yv - o).length();
    let offset = normal / len * eps;
    let mut seen = |target: Vec3| {
        stats.light_rays += 1;
        let Some(d) = (target - xv).try_normalize() else {
            return false;
        };
        let (r, t_max) = hit.hit.shadow_segment(d, target);
        !scene.occluded(&r, t_max, &mut NoStats)
    };
    let (plus, minus) = (seen(yv + offset), seen(yv - offset));
    if plus == minus {
        return None;
    }
    stats.landed += 1;
    // F = L_e (ρ/π) cos θ_x |cos θ_y| / d² at y (its value: the jump
    // multiplies a velocity, its derivative would be second order).
    let to = yv - xv;
    let d2 = to.length_squared();
    let wi = to / d2.sqrt();
    let cos_x = hit.shading_normal.value().dot(wi);
    let cos_y = n_y.dot(wi).abs();
    if cos_x <= 0.0 || hit.geometric_normal.value().dot(wi) <= 0.0 {
        return None;
    }
    // The light-sampling MIS weight: the BRDF-sampling half of the jump is
    // in the direction term ([`super::vertex`]).
    let pdf_area = scene.emitter_pdf(far.prim, V3::from_vec3(le));
    let p_light = area_to_solid_angle(pdf_area, d2, cos_y);
    let w = if p_light > 0.0 && p_light.is_finite() {
        power_heuristic(p_light, cosine_pdf(cos_x))
    } else {
        return None;
    };
    let f = beta * le * albedo * (w * cos_x * cos_y / (std::f32::consts::PI * d2));
    let sign = if minus { 1.0 } else { -1.0 };
    let scale = sign / density;
    let mut g = [[0.0f64; 3]; K];
    for (k, gk) in g.iter_mut().enumerate() {
        let v = Vec3::new(
            y.x.d[k] - painted.x.d[k],
            y.y.d[k] - painted.y.d[k],
            y.z.d[k] - painted.z.d[k],
        );
        let speed = f64::from(v.dot(normal));
        for c in 0..3 {
            gk[c] = scale * f64::from(f[c]) * speed;
        }
    }
    Some(g)
}
