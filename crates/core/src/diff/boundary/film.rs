//! Where a curve's points lie on the film: seen directly, as the shadow
//! point a light casts through them onto a receiver, or in a flat mirror
//! ([`on_film`]); the curve's length there ([`film_length`]); and whether
//! the eye sees a point ([`eye_sees`]).

use super::curves::Curve;
use super::mirror::Mirror;
use super::BoundaryStats;
use crate::camera::Frame;
use crate::diff::view::DualScene;
use crate::math::{max_abs, Dual, Ray, RayR, Real, Vec3, V3};
use crate::scene::{Scene, View};
use crate::shape::{Hit, HitR, ShapeR, OFFSET_SCALE};
use crate::stats::NoStats;

/// Curve points traced to estimate a curve's length on the film.
const LENGTH_POINTS: usize = 32;

/// Whether the camera ray through film point `(x, y)` reaches `target`:
/// nothing hides the first 99 % of the way to it (the rest is where a
/// silhouette's ray grazes its own surface, or a shadow's receiver is hit
/// at the point itself).
pub(super) fn eye_sees(scene: &Scene, (x, y): (f32, f32), target: Vec3) -> bool {
    let ray = scene.camera_ray(x, y).value();
    let dist = (target - ray.origin).length();
    !scene.occluded(&ray, 0.99 * dist, &mut NoStats)
}

/// The ray from light position `l` through curve point `s`, continued past
/// it to the first surface: that surface's hit, its distance measured from
/// `l` (`None` when the ray leaves the scene).
pub(super) fn behind(scene: &Scene, l: Vec3, s: Vec3) -> Option<Hit> {
    let d = s - l;
    let dir = d.try_normalize()?;
    let start = s + dir * (1e-4 * d.length().max(1e-3));
    let hit = scene.intersect(
        &Ray::new(start, dir),
        scene.settings.max_distance,
        &mut NoStats,
    )?;
    Some(Hit {
        t: hit.t + (start - l).length(),
        ..hit
    })
}

/// Where the curve point `s` lies on the film: seen directly (`shadow`
/// None), or the point of `receiver` hit at `hit` by the ray from light
/// position `l` through `s`; directly, or in `mirror` (`None` for a shadow
/// edge in the mirror's own plane, seen directly instead).
pub(super) fn on_film<R: Real>(
    frame: &Frame<R>,
    (w, h): (u32, u32),
    s: V3<R>,
    shadow: Option<(V3<R>, Hit, ShapeR<R>)>,
    mirror: Option<&Mirror<R>>,
) -> Option<(R, R)> {
    let shadowed = shadow.is_some();
    let p = match shadow {
        None => s,
        Some((l, hit, receiver)) => shadow_point(l, s, hit, &receiver),
    };
    let p = match mirror {
        None => p,
        Some(m) if shadowed && m.holds(p.value()) => return None,
        Some(m) => m.reflect(p),
    };
    frame.project(p, w, h)
}

/// The point of the shadow edge cast by curve point `s` from light
/// position `l` on `receiver`, whose hit by the ray from `l` through `s`
/// is `hit`. The renderer's shadow rays start ε along the normal
/// ([`crate::shape::OFFSET_SCALE`]), which moves the edge: it is at the
/// point p whose ray origin p + ε·n lies on the line from the light
/// through s (exact for flat receivers).
pub(super) fn shadow_point<R: Real>(l: V3<R>, s: V3<R>, hit: Hit, receiver: &ShapeR<R>) -> V3<R> {
    let ray = RayR::new(l, (s - l).normalize());
    let on = HitR::on(receiver, None, &ray, hit);
    let n = on.geometric_normal;
    let eps = R::from_f32(OFFSET_SCALE * max_abs(on.point.value()).max(1.0));
    let cos = -ray.dir.dot(n);
    on.point - ray.dir * (eps / cos) - n * eps
}

/// The curve's length on the film in pixels, from [`LENGTH_POINTS`] points
/// (the pieces with an end inside the film).
pub(super) fn film_length<const K: usize>(
    view: &DualScene<'_, K>,
    curve: &Curve<Dual<K>>,
    light: Option<usize>,
    mirror: Option<&Mirror<Dual<K>>>,
    stats: &mut BoundaryStats,
) -> f32 {
    let scene = view.scene();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let frame = scene.camera.frame();
    let c = curve.map(|p| V3::<f32>::from_vec3(p.value()));
    let l = light.map(|i| scene.lights[i].position);
    let mirror = mirror.map(|m| m.value::<f32>());
    let mut points = Vec::with_capacity(LENGTH_POINTS + 1);
    for i in 0..=LENGTH_POINTS {
        let s = c.point(i as f32 / LENGTH_POINTS as f32);
        let shadow = match l {
            None => None,
            Some(l) => {
                stats.light_rays += 1;
                behind(scene, l, s.value()).map(|hit| {
                    (
                        V3::from_vec3(l),
                        hit,
                        ShapeR::of(&scene.prims[hit.prim as usize]),
                    )
                })
            }
        };
        points.push(on_film(&frame, (w, h), s, shadow, mirror.as_ref()));
    }
    let inside =
        |(x, y): (f32, f32)| x >= -1.0 && y >= -1.0 && x <= w as f32 + 1.0 && y <= h as f32 + 1.0;
    points
        .windows(2)
        .filter_map(|p| match (p[0], p[1]) {
            (Some(a), Some(b)) if inside(a) || inside(b) => Some(
                ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2))
                    .sqrt()
                    .min(4.0 * (w + h) as f32),
            ),
            _ => None,
        })
        .sum()
}
