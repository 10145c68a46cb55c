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
//! Self-intersection: secondary rays start at the hit point offset along
//! the geometric normal ([`Hit::spawn_origin`], [`crate::shape::OFFSET_SCALE`]
//! says why 1e-4); shadow rays are [`Hit::shadow_segment`]s. The local
//! terms are [`crate::shading`]'s kernels, and which lights are seen is
//! [`crate::lighting`]'s rule ([`LightModel::Whitted`]: every point light).

use super::{Integrator, SampleContext};
use crate::lighting::{point_light_incidence, LightModel};
use crate::math::{Color, Ray, Vec3, V3};
use crate::scene::Scene;
use crate::shading::{emission_and_ambient, phong, reflect, refract, Phong};
use crate::stats::{RayKind, Stats};

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
    let n = V3::from(hit.shading_normal);
    let view = -V3::from(ray.dir);
    let albedo = V3::from(m.color_at(hit.point));

    let mut color = emission_and_ambient(
        V3::from(m.emission),
        m.ambient,
        V3::from(set.ambient),
        albedo,
    );
    let phong_terms = Phong {
        diffuse: m.diffuse,
        specular: m.specular,
        shininess: m.shininess,
        albedo,
        specular_color: V3::from(m.specular_color),
    };
    for light in scene.lights.iter().filter(|l| LightModel::Whitted.sees(l)) {
        if let Some(i) = point_light_incidence(scene, &hit, light, stats) {
            color += phong(&phong_terms, n, V3::from(i.dir), view, V3::from(i.arriving));
        }
    }
    let mut color = Color::from(color);

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
                let t_dir = Vec3::from(t_dir).normalize();
                let r = Ray::new(hit.spawn_origin(t_dir), t_dir);
                stats.ray(RayKind::Refraction);
                let w = weight * m.transparency;
                color += m.transparency * trace(scene, &r, depth + 1, w, next, stats);
            }
            // Total internal reflection: the transmitted share is reflected.
            None => reflect_weight += m.transparency,
        }
    }
    if reflect_weight > 0.0 && weight * reflect_weight >= set.min_weight {
        let r_dir = Vec3::from(reflect(V3::from(ray.dir), n)).normalize();
        let r = Ray::new(hit.spawn_origin(r_dir), r_dir);
        stats.ray(RayKind::Reflection);
        let w = weight * reflect_weight;
        color += reflect_weight * trace(scene, &r, depth + 1, w, media, stats);
    }
    color
}
// ANCHOR_END: whitted_trace
