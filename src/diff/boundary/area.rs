//! The boundary term of area lights' soft shadows for the `direct`
//! integrator: edge sampling inside each shading point's integral over
//! the emitters.
//!
//! `direct` lights the camera ray's hit x by the emitters it sees,
//! E(x) = ∫ L_e(y) (ρ/π) cos θ_x |cos θ_y| / |x − y|² V(x, y) dA(y), by
//! light sampling and BRDF sampling combined. The visibility V jumps along
//! the curves on the emitters where an occluder's silhouette, seen from x,
//! projects; when a parameter moves the occluder (or x, or the camera),
//! those curves move and E gains the term
//!
//! ∫_{curves} (F⁻ − F⁺) (∂y/∂θ · m̂) dℓ,
//!
//! F the integrand without V, m̂ the curve's unit normal within the
//! emitter's surface and F± on the side m̂ points to and the other. Both
//! strategies estimate the same E, so the term is added once, unweighted.
//!
//! Per pixel, `density` film points are drawn uniformly in the pixel (the
//! pixel integral of the term); at each hit x one occluder silhouette is
//! chosen uniformly among the M seen from x ([`super::curves`]), a point
//! s(t) uniformly on it, and the ray from x through s continued past it.
//! Where it lands on an emitter at y, F± come from two shadow rays to
//! y ± ε·m̂, and the sample is M · (F⁻ − F⁺)(∂y/∂θ · (dy/dt × n_y)),
//! dy/dt × n_y being m̂ times the change of variables |dy/dt|. ∂y/∂θ is the
//! motion of the curve's point on the emitter for fixed t (dual numbers
//! through x, s and the emitter's plane).
//!
//! Not covered here: an emitter that itself moves (its material points
//! move with it, and the velocity that counts is the curve's relative to
//! them; its own edges also bound the BRDF-sampled rays that find it), and
//! `path:K` with K ≥ 1, where every silhouette seen from x bounds the
//! indirect light too, not only those in front of an emitter.

use super::curves::{edge_curve, edge_matters, mesh_edges, smooth_silhouette, Curve, Edge};
use super::{behind, is_geometric, Boundary, BoundaryStats};
use crate::diff::params::Param;
use crate::diff::view::DualScene;
use crate::integrator::in_pool;
use crate::math::{Dual, RayR, Real, SplitMix64, Vec3, V3};
use crate::scene::View;
use crate::shape::{HitR, Shape, ShapeR};
use crate::stats::NoStats;
use rayon::prelude::*;
use std::time::Instant;

/// Relative distance (of |x − y|) from the curve on the emitter at which
/// the two shadow rays are cast.
const OFFSET: f32 = 1e-4;

/// The area-light boundary term for `direct`, `density` film samples per
/// pixel, seeded by `seed`, on `threads` threads (the same on any number).
pub fn area_shadow_term<const K: usize>(
    view: &DualScene<'_, K>,
    params: &[Param],
    density: u32,
    seed: u64,
    threads: Option<usize>,
) -> Boundary {
    let start = Instant::now();
    let scene = view.scene();
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let n = params.len();
    let mut out = Boundary::zeros(n, scene.camera.width, scene.camera.height);
    if !params.iter().any(is_geometric) || scene.area_lights.emitters.is_empty() {
        return out;
    }
    let edges = mesh_edges(scene);
    let seed = SplitMix64::mix(seed ^ 0xA4EA_5A0D_0000_u64);
    type Row = (Vec<([f64; 3], [f64; 3], f64, f64)>, BoundaryStats);
    let rows: Vec<Vec<Row>> = in_pool(threads, || {
        (0..h)
            .into_par_iter()
            .map(|py| {
                (0..w)
                    .map(|px| {
                        let mut stats = BoundaryStats::default();
                        let per_param = pixel(view, &edges, (px, py), n, density, seed, &mut stats);
                        (per_param, stats)
                    })
                    .collect()
            })
            .collect()
    });
    let m = f64::from(density.max(1));
    for (py, row) in rows.into_iter().enumerate() {
        for (px, (per_param, stats)) in row.into_iter().enumerate() {
            out.stats.add(&stats);
            let i = py * w + px;
            for (k, (s1, s2, g1, g2)) in per_param.into_iter().enumerate() {
                let var = |a: f64, b: f64| {
                    if density > 1 {
                        ((b - a * a / m) / (m * (m - 1.0))).max(0.0) as f32
                    } else {
                        0.0
                    }
                };
                for c in 0..3 {
                    out.mean[k][3 * i + c] = (s1[c] / m) as f32;
                    out.variance[k][3 * i + c] = var(s1[c], s2[c]);
                }
                out.variance_grey[k][i] = var(g1, g2);
            }
        }
    }
    out.stats.seconds = start.elapsed().as_secs_f64();
    out
}

/// One pixel's sums over its film samples, per parameter: Σg and Σg² per
/// channel, and the same for the channel mean.
fn pixel<const K: usize>(
    view: &DualScene<'_, K>,
    edges: &[Edge],
    (px, py): (usize, usize),
    n: usize,
    density: u32,
    seed: u64,
    stats: &mut BoundaryStats,
) -> Vec<([f64; 3], [f64; 3], f64, f64)> {
    let scene = view.scene();
    let w = scene.camera.width as usize;
    let mut sums = vec![([0.0f64; 3], [0.0f64; 3], 0.0f64, 0.0f64); n];
    let mut rng = SplitMix64(SplitMix64::mix(seed ^ (py * w + px) as u64));
    for _ in 0..density {
        stats.shading_points += 1;
        let (fx, fy) = (px as f32 + rng.next_f32(), py as f32 + rng.next_f32());
        let (u_curve, t) = (rng.next_f32(), rng.next_f32());
        let Some(g) = sample(view, edges, (fx, fy), u_curve, t, stats) else {
            continue;
        };
        for (s, gk) in sums.iter_mut().zip(&g) {
            let grey = (gk[0] + gk[1] + gk[2]) / 3.0;
            for (c, &v) in gk.iter().enumerate() {
                s.0[c] += v;
                s.1[c] += v * v;
            }
            s.2 += grey;
            s.3 += grey * grey;
        }
    }
    sums
}

/// One film sample's boundary contribution per parameter and channel, or
/// `None` where it has none.
fn sample<const K: usize>(
    view: &DualScene<'_, K>,
    edges: &[Edge],
    (fx, fy): (f32, f32),
    u_curve: f32,
    t: f32,
    stats: &mut BoundaryStats,
) -> Option<[[f64; 3]; K]> {
    let scene = view.scene();
    let ray = view.camera_ray(fx, fy);
    let found = scene.intersect(&ray.value(), scene.settings.max_distance, &mut NoStats)?;
    let hit = view.surface(&ray, found);
    let albedo = view
        .material(found.object)
        .lambert_albedo(hit.point)
        .value();
    if albedo.max_element() <= 0.0 {
        return None;
    }
    let x = hit.point;
    let xv = x.value();
    // The silhouettes seen from x (of everything but x's own primitive),
    // chosen on values; only the chosen one is built on dual numbers.
    enum Pick {
        Smooth(u32),
        Edge(usize),
    }
    let mut picks: Vec<Pick> = Vec::new();
    for (prim, p) in scene.prims.iter().enumerate() {
        let prim = prim as u32;
        if prim != found.prim && matches!(p.shape, Shape::Sphere(_) | Shape::Ellipsoid(_)) {
            let shape = ShapeR::<f32>::of(p);
            if smooth_silhouette(&shape, V3::from_vec3(xv)).is_some() {
                picks.push(Pick::Smooth(prim));
            }
        }
    }
    for (i, e) in edges.iter().enumerate() {
        if !e.faces.contains(&found.prim) && edge_matters(scene, e, xv, false) {
            picks.push(Pick::Edge(i));
        }
    }
    if picks.is_empty() {
        return None;
    }
    let m = picks.len();
    let curve: Curve<Dual<K>> = match picks[((u_curve * m as f32) as usize).min(m - 1)] {
        Pick::Smooth(prim) => smooth_silhouette(&view.geometry(prim), x)?,
        Pick::Edge(i) => edge_curve(&edges[i], |prim, corner| match view.geometry(prim) {
            ShapeR::Triangle { p } => p[corner],
            _ => unreachable!("mesh edges join triangles"),
        }),
    };
    let s = curve.point(Dual::from_f32(t));
    // Nothing between x and the silhouette point, then an emitter behind.
    let (sv, dir) = (s.value(), (s.value() - xv).try_normalize()?);
    let (to_s, t_s) = hit.hit.shadow_segment(dir, sv);
    stats.light_rays += 2;
    if scene.occluded(&to_s, t_s, &mut NoStats) {
        return None;
    }
    let far = behind(scene, xv, sv)?;
    let le = scene.materials[scene.objects[far.object as usize].material as usize].emission;
    if le.max_element() <= 0.0 {
        return None;
    }
    // y on the emitter, as a function of the parameters and of t.
    let on = |r: RayR<Dual<K>>| HitR::on(&view.geometry(far.prim), None, &r, far);
    let y_hit = on(RayR::new(x, (s - x).normalize()));
    let y = y_hit.point;
    let curve1 = curve.map(|p| V3::<Dual<1>>::from_vec3(p.value()));
    let x1 = V3::<Dual<1>>::from_vec3(xv);
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
    let eps = OFFSET * (yv - xv).length();
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
    let f = le * albedo * (cos_x * cos_y / (std::f32::consts::PI * d2));
    let sign = if minus { 1.0 } else { -1.0 };
    let scale = m as f64 * sign;
    let mut g = [[0.0f64; 3]; K];
    for (k, gk) in g.iter_mut().enumerate() {
        let v = Vec3::new(y.x.d[k], y.y.d[k], y.z.d[k]);
        let speed = f64::from(v.dot(normal));
        for c in 0..3 {
            gk[c] = scale * f64::from(f[c]) * speed;
        }
    }
    Some(g)
}
