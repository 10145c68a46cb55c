//! Chains of specular bounces: the ways the Whitted integrator's rays
//! reach what a curved mirror or a glass object shows, perhaps seen in
//! the floor first, or in another mirror or through glass after it.
//!
//! A chain is a sequence of steps, each off one primitive: a reflection
//! off a plane, a sphere or an ellipsoid, or a pass through a glass
//! sphere or ellipsoid (refracted in, reflected `inside` times off its
//! inside, refracted out). The film curves along which what the chain's
//! last ray meets changes are found on the disc of its first curved
//! object ([`super::grid::Cap`]); the planes before it are folded into
//! the eye (the eye's mirror image sees the curved object as the eye sees
//! it through the planes), and the steps after it are followed ray by
//! ray. [`chains`] lists the chains the renderer traces: every product
//! of the reflectivities and transparencies on the way at least its
//! `min_weight`, and fewer bounces than its `max_depth`.

use crate::camera::Frame;
use crate::math::{Ray, RayR, Real, V3};
use crate::scene::{Scene, View};
use crate::shading::{reflect, refract};
use crate::shape::{Hit, HitR, Shape, ShapeR};
use crate::stats::NoStats;

/// The most steps in a chain, and the most hits along one (the renderer's
/// depth limit bounds both; deeper chains are not followed).
pub(super) const MAX_STEPS: usize = 6;
pub(super) const MAX_HITS: usize = 6;

/// The most reflections inside glass followed (weights fall as
/// reflectivity^k; S1's glass, 0.08, is below the renderer's 10⁻²
/// cut-off at k = 2).
const MAX_INSIDE: u8 = 2;

/// One specular bounce of a chain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Step {
    /// Reflected off primitive `prim` (a plane, a sphere or an ellipsoid).
    Reflect(u32),
    /// Through sphere or ellipsoid `prim`: refracted in, reflected
    /// `inside` times off its inside, refracted out.
    Through { prim: u32, inside: u8 },
}

impl Step {
    pub(super) fn prim(self) -> u32 {
        match self {
            Step::Reflect(p) | Step::Through { prim: p, .. } => p,
        }
    }

    /// The hits on its primitive.
    fn hits(self) -> usize {
        match self {
            Step::Reflect(_) => 1,
            Step::Through { inside, .. } => usize::from(inside) + 2,
        }
    }
}

/// The steps of one chain, at least one of them off a curved object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Chain {
    steps: [Step; MAX_STEPS],
    len: usize,
}

impl Chain {
    pub(super) fn steps(&self) -> &[Step] {
        &self.steps[..self.len]
    }

    /// The index of the first step off a sphere or an ellipsoid (the
    /// steps before it reflect off planes).
    pub(super) fn first_curved(&self, scene: &Scene) -> Option<usize> {
        let curved = |s: &Step| !matches!(scene.prims[s.prim() as usize].shape, Shape::Plane(_));
        self.steps().iter().position(curved)
    }

    /// The primitive the last ray leaves.
    pub(super) fn last(&self) -> u32 {
        self.steps[self.len - 1].prim()
    }

    /// Rays cast to trace one film point along it: the camera ray and one
    /// per hit.
    pub(super) fn rays(&self) -> u64 {
        1 + self.hits() as u64
    }

    fn hits(&self) -> usize {
        self.steps().iter().map(|s| s.hits()).sum()
    }

    /// Per hit along the chain, the primitive and which face it must be
    /// (`None`: either, for a plane).
    fn expected(&self, scene: &Scene) -> [(u32, Option<bool>); MAX_HITS] {
        let mut out = [(u32::MAX, None); MAX_HITS];
        let mut k = 0;
        for s in self.steps() {
            let flat = matches!(scene.prims[s.prim() as usize].shape, Shape::Plane(_));
            for i in 0..s.hits() {
                out[k] = (s.prim(), (!flat).then_some(i == 0));
                k += 1;
            }
        }
        out
    }

    /// The chain with `step` appended, if it has room.
    fn then(&self, step: Step) -> Option<Chain> {
        (self.len < MAX_STEPS && self.hits() + step.hits() <= MAX_HITS).then(|| {
            let mut c = *self;
            c.steps[c.len] = step;
            c.len += 1;
            c
        })
    }
}

/// The chains the renderer traces that bounce off at least one sphere or
/// ellipsoid, in depth-first order: at each bounce off a plane or a
/// smooth object, its reflection where the weight so far times its
/// reflectivity is at least `min_weight`, and its passes through (0 to
/// [`MAX_INSIDE`] reflections inside) where the weight times
/// transparency² · reflectivity^inside is; never the same primitive twice
/// in a row (a plane or a convex object cannot send a ray back to
/// itself), and fewer hits than `max_depth`. Total internal reflection,
/// which adds the transparency to the reflectivity, is not foreseen:
/// where it happens, the chain through is cut.
pub(super) fn chains(scene: &Scene) -> Vec<Chain> {
    let set = &scene.settings;
    let candidates: Vec<(u32, bool, f32, f32)> = (0..scene.prims.len() as u32)
        .filter_map(|p| {
            let prim = &scene.prims[p as usize];
            let curved = match prim.shape {
                Shape::Sphere(_) | Shape::Ellipsoid(_) => true,
                Shape::Plane(_) => false,
                Shape::Triangle(_) => return None,
            };
            let m = View::material(scene, prim.object);
            let (r, t) = (m.reflectivity, if curved { m.transparency } else { 0.0 });
            (r > 0.0 || t > 0.0).then_some((p, curved, r, t))
        })
        .collect();
    let mut out = Vec::new();
    let start = Chain {
        steps: [Step::Reflect(u32::MAX); MAX_STEPS],
        len: 0,
    };
    let mut pending = vec![(start, 1.0f32, false)];
    while let Some((chain, weight, curved_seen)) = pending.pop() {
        let last = (chain.len > 0).then(|| chain.last());
        for &(p, curved, r, t) in candidates.iter().rev() {
            if Some(p) == last {
                continue;
            }
            let mut steps = vec![(Step::Reflect(p), weight * r)];
            if curved && t > 0.0 {
                for inside in 0..=MAX_INSIDE {
                    let w = weight * t * t * r.powi(i32::from(inside));
                    steps.push((Step::Through { prim: p, inside }, w));
                }
            }
            for (step, w) in steps {
                let Some(next) = chain.then(step) else {
                    continue;
                };
                if !(w > 0.0 && w >= set.min_weight && next.hits() < set.max_depth as usize) {
                    continue;
                }
                let seen = curved_seen || curved;
                if seen {
                    out.push(next);
                }
                pending.push((next, w, seen));
            }
        }
    }
    out
}

/// What the camera ray through a film point meets along a chain
/// (`hits`, in order), the ray that leaves its last step (origin, unit
/// direction) and what that ray meets next.
#[derive(Clone, Copy)]
pub(super) struct Trace {
    pub(super) hits: [Option<Hit>; MAX_HITS],
    pub(super) out: (V3<f32>, V3<f32>),
    pub(super) next: Option<Hit>,
}

/// The ray (origin, unit direction) that leaves the last step of `chain`
/// for the camera ray through film point `(x, y)`, where the `i`-th hit
/// along the way is `hit(i, ray)` and `shape(p)` is primitive `p`'s shape
/// and index of refraction (objects in air): the Whitted integrator's
/// reflection, refraction and spawn rules, as functions of the frame, the
/// film point, the geometry and the indices. `None` where a hit is
/// missing or a refracted ray is totally reflected.
pub(super) fn leaving<R: Real>(
    frame: &Frame<R>,
    (w, h): (u32, u32),
    (x, y): (R, R),
    chain: &Chain,
    shape: impl Fn(u32) -> (ShapeR<R>, R),
    mut hit: impl FnMut(usize, &RayR<R>) -> Option<Hit>,
) -> Option<(V3<R>, V3<R>)> {
    let mut ray = frame.ray_at(x, y, w, h);
    let mut k = 0;
    let mut meet = |ray: &RayR<R>, shape: &ShapeR<R>| {
        let on = HitR::on(shape, None, ray, hit(k, ray)?);
        k += 1;
        Some(on)
    };
    for &step in chain.steps() {
        let (shape, ior) = shape(step.prim());
        let mut on = meet(&ray, &shape)?;
        let d = match step {
            Step::Reflect(_) => reflect(ray.dir, on.shading_normal).normalize(),
            Step::Through { inside, .. } => {
                let mut d = refract(-ray.dir, on.shading_normal, R::one() / ior)?.normalize();
                for i in 1..=usize::from(inside) + 1 {
                    on = meet(&RayR::new(on.spawn_origin(d), d), &shape)?;
                    d = if i <= usize::from(inside) {
                        reflect(d, on.shading_normal).normalize()
                    } else {
                        refract(-d, on.shading_normal, ior)?.normalize()
                    };
                }
                d
            }
        };
        ray = RayR::new(on.spawn_origin(d), d);
    }
    Some((ray.origin, ray.dir))
}

/// The camera ray through `(x, y)` followed along `chain` (see
/// [`leaving`]): `None` where a ray along it meets another primitive
/// first, or the wrong face of a smooth one (the outside where it enters
/// or reflects, the inside where a ray through glass goes on).
pub(super) fn trace(scene: &Scene, xy: (f32, f32), chain: &Chain) -> Option<Trace> {
    traced(scene, xy, chain).ok()
}

/// [`trace`], or where it is cut off: whether at a sphere or an
/// ellipsoid after the chain's first curved step (its ray passes that
/// object's rim, or something in front of it; a refracted ray's total
/// internal reflection counts too).
pub(super) fn traced(scene: &Scene, (x, y): (f32, f32), chain: &Chain) -> Result<Trace, CutOff> {
    let max = scene.settings.max_distance;
    let expected = chain.expected(scene);
    let mut found = Trace {
        hits: [None; MAX_HITS],
        out: (V3::zero(), V3::zero()),
        next: None,
    };
    let size = (scene.camera.width, scene.camera.height);
    let shape = |p: u32| {
        let prim = &scene.prims[p as usize];
        (ShapeR::of(prim), View::material(scene, prim.object).ior)
    };
    let mut reached = 0;
    let left = leaving(
        &scene.camera.frame(),
        size,
        (x, y),
        chain,
        shape,
        |i, ray| {
            reached = i;
            let hit = scene.intersect(&ray.value(), max, &mut NoStats)?;
            let (prim, face) = expected[i];
            let ok = hit.prim == prim && face.is_none_or(|f| hit.front_face == f);
            found.hits[i] = ok.then_some(hit);
            found.hits[i]
        },
    );
    let Some((o, d)) = left else {
        // The step whose hit `reached` is.
        let mut hits = 0;
        let step = chain.steps().iter().position(|s| {
            hits += s.hits();
            hits > reached
        });
        let first = chain.first_curved(scene);
        let later_curved = step.zip(first).is_some_and(|(k, f)| {
            let shape = &scene.prims[chain.steps()[k].prim() as usize].shape;
            k > f && !matches!(shape, Shape::Plane(_))
        });
        return Err(CutOff { later_curved });
    };
    found.out = (o, d);
    found.next = scene.intersect(&Ray::new(o.value(), d.value()), max, &mut NoStats);
    Ok(found)
}

/// Where a film point's rays stop following a chain ([`traced`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct CutOff {
    /// At a sphere or an ellipsoid after the chain's first curved step.
    pub(super) later_curved: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// S1's floor (reflectivity 0.15), mirror (0.85) and glass
    /// (transparency 0.9, reflectivity 0.08) under its cut-offs (weight
    /// 10⁻², depth 6): the chains are the renderer's, and only those.
    #[test]
    fn s1s_chains_are_the_ones_its_renderer_traces() {
        let text = include_str!(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../data/scenes/s1-spheres.toml"
        ));
        let path = std::path::Path::new("s1-spheres.toml");
        let scene = crate::io::scene_file::parse_scene(text, path, &Default::default()).unwrap();
        let material = |p: u32| View::material(&scene, scene.prims[p as usize].object);
        let find = |keep: &dyn Fn(u32) -> bool| (0..scene.prims.len() as u32).find(|&p| keep(p));
        let floor = find(&|p| matches!(scene.prims[p as usize].shape, Shape::Plane(_))).unwrap();
        let mirror = find(&|p| material(p).reflectivity == 0.85).unwrap();
        let glass = find(&|p| material(p).transparency == 0.9).unwrap();
        let found = chains(&scene);
        let named = |c: &Chain| {
            c.steps()
                .iter()
                .map(|s| match *s {
                    Step::Reflect(p) => format!("R{p}"),
                    Step::Through { prim, inside } => format!("T{prim}.{inside}"),
                })
                .collect::<Vec<_>>()
                .join(" ")
        };
        let names: Vec<String> = found.iter().map(named).collect();
        eprintln!("{} chains: {}", names.len(), names.join(", "));
        let has = |n: &str| names.iter().any(|m| m == n);
        for n in [
            format!("R{mirror}"),
            format!("T{glass}.0"),
            format!("T{glass}.1"),
            format!("R{glass}"),
            format!("R{floor} R{mirror}"),
            format!("R{floor} T{glass}.0"),
            format!("R{mirror} T{glass}.0"),
            format!("T{glass}.0 R{mirror}"),
            format!("R{mirror} R{floor}"),
            format!("R{mirror} T{glass}.0 R{mirror}"),
        ] {
            assert!(has(&n), "{n} missing");
        }
        // 0.9²·0.08² and 0.15·0.9²·0.08 are below 10⁻²; the floor, the
        // mirror, the floor and the mirror again (0.15²·0.85² = 0.016) is
        // not.
        assert!(has(&format!("R{floor} R{mirror} R{floor} R{mirror}")));
        for n in [format!("T{glass}.2"), format!("R{floor} T{glass}.1")] {
            assert!(!has(&n), "{n} is not traced");
        }
        for c in &found {
            let w: f32 = c
                .steps()
                .iter()
                .map(|s| {
                    let m = material(s.prim());
                    match *s {
                        Step::Reflect(_) => m.reflectivity,
                        Step::Through { inside, .. } => {
                            m.transparency.powi(2) * m.reflectivity.powi(i32::from(inside))
                        }
                    }
                })
                .product();
            assert!(w >= 0.01 && c.hits() < 6, "{}", named(c));
            assert!(c.first_curved(&scene).is_some(), "{}", named(c));
            assert!(c.steps().windows(2).all(|p| p[0].prim() != p[1].prim()));
        }
        let unique: std::collections::HashSet<_> = names.iter().collect();
        assert_eq!(unique.len(), names.len());
    }
}
