//! The Whitted (1980) recursive ray tracer of S1 and S2.
//!
//! Colour at a hit = emission + ambient + Σ over visible lights (diffuse +
//! specular, Phong) + k_r·reflected + k_t·refracted. One shadow ray per
//! light; a light is blocked by any surface (transparent ones included:
//! hard geometric shadows, as in S1). The recursion (run as a loop over
//! an explicit stack of pending rays, [`trace`]) stops at the depth limit,
//! when a ray's weight (the product of k_r and k_t factors along its path)
//! falls below the threshold, or when nothing is hit within the maximum
//! distance (background colour).
//!
//! Refraction keeps a stack of the media the ray is inside (S1): entering a
//! transparent object pushes its index of refraction, leaving pops it. The
//! stack holds (object, index) pairs and leaving removes that object's entry
//! wherever it is, so overlapping objects do not corrupt it.
//!
//! Self-intersection: secondary rays start at the hit point offset along
//! the geometric normal ([`crate::shape::Hit::spawn_origin`], [`crate::shape::OFFSET_SCALE`]
//! says why 1e-4); shadow rays are [`crate::shape::Hit::shadow_segment`]s. The local
//! terms are [`crate::shading`]'s kernels, and which lights are seen is
//! [`crate::lighting`]'s rule ([`LightModel::Whitted`]: every point light).

use super::{Integrator, SampleContext};
use crate::lighting::{point_light_incidence, LightModel};
use crate::math::{Color, Ray, RayR, Real, V3};
use crate::scene::{Scene, View};
use crate::shading::{emission_and_ambient, phong, reflect, refract, Phong};
use crate::shape::Hit;
use crate::stats::{RayKind, Stats};
use smallvec::SmallVec;

/// Media the ray is inside, innermost last. The outermost medium (air,
/// index 1) is implicit.
#[derive(Clone, Copy, Debug)]
pub struct MediumStack {
    entries: [(u32, f32); Self::CAPACITY],
    len: usize,
}

impl Default for MediumStack {
    fn default() -> Self {
        Self {
            entries: [(0, 1.0); Self::CAPACITY],
            len: 0,
        }
    }
}

impl MediumStack {
    /// Nesting deeper than this is ignored (the innermost entries are kept
    /// up to here; deeper ones do not change the current index).
    pub const CAPACITY: usize = 16;

    /// Index of refraction of the medium the ray is in.
    pub fn current(&self) -> f32 {
        if self.len == 0 {
            1.0
        } else {
            self.entries[self.len - 1].1
        }
    }

    /// The object the ray is innermost in (`None`: air).
    pub fn innermost(&self) -> Option<u32> {
        self.len.checked_sub(1).map(|i| self.entries[i].0)
    }

    /// The stack after entering `object` with index `ior`.
    pub fn entered(mut self, object: u32, ior: f32) -> Self {
        if self.len < Self::CAPACITY {
            self.entries[self.len] = (object, ior);
            self.len += 1;
        }
        self
    }

    /// The stack after leaving `object` (a no-op if the ray was not known to
    /// be inside it, e.g. when the camera starts inside).
    pub fn left(mut self, object: u32) -> Self {
        if let Some(i) = self.entries[..self.len].iter().rposition(|e| e.0 == object) {
            self.entries.copy_within(i + 1..self.len, i);
            self.len -= 1;
        }
        self
    }
}

/// The Whitted integrator (settings come from the scene).
#[derive(Clone, Copy, Debug, Default)]
pub struct Whitted;

impl Integrator for Whitted {
    fn radiance<S: Stats>(
        &self,
        scene: &Scene,
        ray: &Ray,
        _: &SampleContext,
        stats: &mut S,
    ) -> Color {
        Whitted.radiance_of(scene, &RayR::from(*ray), stats).into()
    }
}

impl Whitted {
    /// The colour along a camera ray, over the view's scalar (`f32` for a
    /// render, dual numbers for its derivatives).
    pub fn radiance_of<V: View, S: Stats>(
        &self,
        view: &V,
        ray: &RayR<V::R>,
        stats: &mut S,
    ) -> V3<V::R> {
        stats.ray(RayKind::Camera);
        trace(view, ray, 0, 1.0, MediumStack::default(), stats)
    }

    /// The colour along camera ray `ray` given its first hit `hit` instead
    /// of finding it: how the boundary term takes the limit of the colour
    /// at a curved surface's silhouette from inside, where the hit grazes
    /// (a reflected ray there turns by twice the angle to the tangent
    /// plane, which shrinks only as the square root of the distance from
    /// the silhouette on the film).
    pub fn radiance_at_hit<V: View, S: Stats>(
        &self,
        view: &V,
        ray: &RayR<V::R>,
        hit: Hit,
        stats: &mut S,
    ) -> V3<V::R> {
        stats.ray(RayKind::Camera);
        let first = Pending {
            ray: *ray,
            factor: V::R::one(),
            depth: 0,
            weight: 1.0,
            media: MediumStack::default(),
        };
        let mut pending: PendingStack<V::R> = SmallVec::new();
        let mut color = shade_hit(view, &first, hit, &mut pending, stats);
        while let Some(p) = pending.pop() {
            color += shade(view, &p, &mut pending, stats) * p.factor;
        }
        color
    }
}

/// Index of refraction of the medium a ray is in: its innermost object's
/// material's, as the view gives it (air, 1, outside every object).
#[inline]
fn medium_ior<V: View>(view: &V, media: &MediumStack) -> V::R {
    match media.innermost() {
        None => V::R::one(),
        Some(object) => view.material(object).ior,
    }
}

// ANCHOR: whitted_trace
/// A ray waiting to be traced: the factor its colour is scaled by on the
/// way to the camera (the product of the k_t and k_r it passed), its
/// depth, its weight (the same product, as a value, for the cut-off) and
/// the media it is inside.
#[derive(Clone, Copy)]
struct Pending<R: Real> {
    ray: RayR<R>,
    factor: R,
    depth: u32,
    weight: f32,
    media: MediumStack,
}

/// Rays waiting to be traced. Each ray spawns at most two (refraction and
/// reflection) and the last pushed is traced first, so the stack holds at
/// most one waiting ray per level of the tree: eight fit inline, and a
/// deeper tree (glass behind glass behind glass …) spills to the heap.
/// Without recursion no scene can overflow the thread's stack, whatever
/// its `max_depth`.
type PendingStack<R> = SmallVec<[Pending<R>; 8]>;

/// The colour along `ray` (unit direction, so `t` is a distance for the
/// maximum-distance cut-off), entering with `depth`, `weight` and
/// `media`: Whitted's recursion as a loop. The colour of a ray is its local
/// terms plus k_t × the refracted ray's colour plus k_r × the reflected
/// ray's; unrolled, it is the sum over every ray of the tree of its local
/// terms times the product of the factors on its way up, which is what the
/// loop adds, visiting the rays in the recursion's order (refraction
/// before reflection). Which rays are traced (the depth and weight
/// cut-offs, total internal reflection) is decided on values, as the `f32`
/// render decides it.
pub fn trace<V: View, S: Stats>(
    view: &V,
    ray: &RayR<V::R>,
    depth: u32,
    weight: f32,
    media: MediumStack,
    stats: &mut S,
) -> V3<V::R> {
    let mut color = V3::zero();
    let mut pending: PendingStack<V::R> = SmallVec::new();
    pending.push(Pending {
        ray: *ray,
        factor: V::R::one(),
        depth,
        weight,
        media,
    });
    while let Some(p) = pending.pop() {
        color += shade(view, &p, &mut pending, stats) * p.factor;
    }
    color
}

/// One ray of the tree: its local terms (background, or emission, ambient
/// and the lights' Phong terms), with the rays it spawns pushed on
/// `pending` (reflection first, so refraction is traced first).
fn shade<V: View, S: Stats>(
    view: &V,
    p: &Pending<V::R>,
    pending: &mut PendingStack<V::R>,
    stats: &mut S,
) -> V3<V::R> {
    let scene = view.scene();
    let Some(found) = scene.intersect(&p.ray.value(), scene.settings.max_distance, stats) else {
        return view.background();
    };
    shade_hit(view, p, found, pending, stats)
}

/// [`shade`] once the ray's hit `found` is known.
#[inline]
fn shade_hit<V: View, S: Stats>(
    view: &V,
    p: &Pending<V::R>,
    found: Hit,
    pending: &mut PendingStack<V::R>,
    stats: &mut S,
) -> V3<V::R> {
    let scene = view.scene();
    let set = &scene.settings;
    let ray = &p.ray;
    let hit = view.surface(ray, found);
    let m = view.material(found.object);
    let n = hit.shading_normal;
    let view_dir = -ray.dir;
    let albedo = m.color_at(hit.point);

    let mut color = emission_and_ambient(m.emission, m.ambient, view.ambient(), albedo);
    let phong_terms = Phong {
        diffuse: m.diffuse,
        specular: m.specular,
        shininess: m.shininess,
        albedo,
        specular_color: m.specular_color,
    };
    for (i, light) in scene.lights.iter().enumerate() {
        if !LightModel::Whitted.sees(light) {
            continue;
        }
        if let Some(inc) = point_light_incidence(view, &hit, i, stats) {
            color += phong(&phong_terms, n, inc.dir, view_dir, inc.arriving);
        }
    }

    if p.depth + 1 >= set.max_depth {
        return color;
    }
    let (transparency, ior) = (m.transparency.value(), m.ior.value());
    let mut reflect_weight = m.reflectivity;
    let mut refracted = None;
    if transparency > 0.0 && p.weight * transparency >= set.min_weight {
        // Entering through a front face, leaving through a back face.
        let (n1, n2, next) = if found.front_face {
            (
                medium_ior(view, &p.media),
                m.ior,
                p.media.entered(found.object, ior),
            )
        } else {
            let next = p.media.left(found.object);
            (medium_ior(view, &p.media), medium_ior(view, &next), next)
        };
        match refract(view_dir, n, n1 / n2) {
            Some(t_dir) => {
                let t_dir = t_dir.normalize();
                stats.ray(RayKind::Refraction);
                refracted = Some(Pending {
                    ray: RayR::new(hit.spawn_origin(t_dir), t_dir),
                    factor: p.factor * m.transparency,
                    depth: p.depth + 1,
                    weight: p.weight * transparency,
                    media: next,
                });
            }
            // Total internal reflection: the transmitted share is reflected.
            None => reflect_weight += m.transparency,
        }
    }
    let rw = reflect_weight.value();
    if rw > 0.0 && p.weight * rw >= set.min_weight {
        let r_dir = reflect(ray.dir, n).normalize();
        stats.ray(RayKind::Reflection);
        pending.push(Pending {
            ray: RayR::new(hit.spawn_origin(r_dir), r_dir),
            factor: p.factor * reflect_weight,
            depth: p.depth + 1,
            weight: p.weight * rw,
            media: p.media,
        });
    }
    pending.extend(refracted);
    color
}
// ANCHOR_END: whitted_trace
