//! The Whitted (1980) recursive ray tracer of S1 and S2.
//!
//! Colour at a hit = emission + ambient + Σ over visible lights (diffuse +
//! specular, Phong) + k_r·reflected + k_t·refracted. One shadow ray per
//! light; a light is blocked by any surface (transparent ones included:
//! hard geometric shadows, as in S1). Recursion stops at the depth limit,
//! when a ray's weight (the product of k_r and k_t factors along its path)
//! falls below the threshold, or when nothing is hit within the maximum
//! distance (background colour).
//!
//! Refraction keeps a stack of the media the ray is inside (S1): entering a
//! transparent object pushes its index of refraction, leaving pops it. The
//! stack holds (object, index) pairs and leaving removes that object's entry
//! wherever it is, so overlapping objects do not corrupt it.
//!
//! Self-intersection: secondary rays start at the hit point moved along the
//! geometric normal, to the side the new ray leaves on, by
//! ε = 1e-4 · max(1, max|p_i|). The hit point o + t·d carries a rounding
//! error of a few ulps of its largest coordinate (≈ 1e-7 relative in f32);
//! 1e-4 relative is three orders of magnitude above that, yet far below the
//! size of any feature in our scenes (meshes are fitted to about unit size,
//! whose triangles are ≥ 1e-3 across). Shadow rays stop the same ε short of
//! the light.

use super::{Integrator, SampleContext};
use crate::math::{max_abs, reflect, refract, Color, Ray, Vec3};
use crate::scene::Scene;
use crate::shape::Hit;
use crate::stats::{RayKind, Stats};

/// Relative size of the self-intersection offset (see the module docs).
pub const OFFSET_SCALE: f32 = 1e-4;

/// The offset origin for a ray leaving `hit` towards the side `dir` points
/// to.
#[inline]
pub fn offset_origin(hit: &Hit, dir: Vec3) -> Vec3 {
    let eps = OFFSET_SCALE * max_abs(hit.point).max(1.0);
    let n = hit.geometric_normal;
    if n.dot(dir) >= 0.0 {
        hit.point + eps * n
    } else {
        hit.point - eps * n
    }
}

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
        stats.ray(RayKind::Camera);
        trace(scene, ray, 0, 1.0, MediumStack::default(), stats)
    }
}

// ANCHOR: whitted_trace
/// The recursive trace. `ray.dir` must be unit length (so `t` is a
/// distance for the maximum-distance cut-off).
pub fn trace<S: Stats>(
    scene: &Scene,
    ray: &Ray,
    depth: u32,
    weight: f32,
    media: MediumStack,
    stats: &mut S,
) -> Color {
    let set = &scene.settings;
    let Some(hit) = scene.intersect(ray, set.max_distance, stats) else {
        return set.background;
    };
    let m = scene.material(&hit);
    let n = hit.shading_normal;
    let view = -ray.dir;
    let albedo = m.color_at(hit.point);

    let mut color = m.emission + m.ambient * set.ambient * albedo;
    for light in &scene.lights {
        let to_light = light.position - hit.point;
        let dist = to_light.length();
        let l = to_light / dist;
        // Lights behind the surface (as seen from the ray's side) add
        // nothing; the geometric test keeps shadow rays from starting
        // inside the object.
        if n.dot(l) <= 0.0 || hit.geometric_normal.dot(l) <= 0.0 {
            continue;
        }
        if !super::visible(scene, &hit, l, light.position, stats) {
            continue;
        }
        let e = light.arriving(dist);
        let diffuse = m.diffuse * n.dot(l);
        let r = reflect(-l, n);
        let specular = m.specular * r.dot(view).max(0.0).powf(m.shininess);
        color += e * (diffuse * albedo + specular * m.specular_color);
    }

    if depth + 1 >= set.max_depth {
        return color;
    }
    let mut reflect_weight = m.reflectivity;
    if m.transparency > 0.0 && weight * m.transparency >= set.min_weight {
        // Entering through a front face, leaving through a back face.
        let (n1, n2, next) = if hit.front_face {
            (media.current(), m.ior, media.entered(hit.object, m.ior))
        } else {
            let next = media.left(hit.object);
            (media.current(), next.current(), next)
        };
        match refract(view, n, n1 / n2) {
            Some(t_dir) => {
                let t_dir = t_dir.normalize();
                let r = Ray::new(offset_origin(&hit, t_dir), t_dir);
                stats.ray(RayKind::Refraction);
                let w = weight * m.transparency;
                color += m.transparency * trace(scene, &r, depth + 1, w, next, stats);
            }
            // Total internal reflection: the transmitted share is reflected.
            None => reflect_weight += m.transparency,
        }
    }
    if reflect_weight > 0.0 && weight * reflect_weight >= set.min_weight {
        let r_dir = reflect(ray.dir, n).normalize();
        let r = Ray::new(offset_origin(&hit, r_dir), r_dir);
        stats.ray(RayKind::Reflection);
        let w = weight * reflect_weight;
        color += reflect_weight * trace(scene, &r, depth + 1, w, media, stats);
    }
    color
}
// ANCHOR_END: whitted_trace
