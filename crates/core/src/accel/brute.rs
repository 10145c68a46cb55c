//! Brute force: test every primitive. The reference every other accelerator
//! must agree with, and S3's "basic tracer".

use super::Accel;
use crate::shape::{Intersect, PreparedRay, PrimHit, Primitive};
use crate::stats::Stats;

#[derive(Clone, Debug, Default)]
pub struct Brute {
    /// Indices of the primitives to test.
    pub prims: Vec<u32>,
}

impl Brute {
    pub fn new(prims: Vec<u32>) -> Self {
        Self { prims }
    }
}

/// Closest hit over a list of primitive indices, shrinking `t_max` as hits
/// are found. Shared by brute force and by the scene's list of unbounded
/// primitives.
#[inline]
pub fn closest_in<S: Stats>(
    prims: &[Primitive],
    ids: &[u32],
    ray: &PreparedRay,
    t_max: &mut f32,
    best: &mut Option<(u32, PrimHit)>,
    stats: &mut S,
) {
    closest_of(
        ids.iter().map(|&id| (id, &prims[id as usize])),
        ray,
        t_max,
        best,
        stats,
    );
}

/// Whether any primitive in the list is hit in (0, t_max).
#[inline]
pub fn any_in<S: Stats>(
    prims: &[Primitive],
    ids: &[u32],
    ray: &PreparedRay,
    t_max: f32,
    stats: &mut S,
) -> bool {
    any_of(ids.iter().map(|&id| &prims[id as usize]), ray, t_max, stats)
}

/// The closest-hit loop every accelerator's leaves run: test the `(id,
/// primitive)` candidates in order, shrinking `t_max` as hits are found and
/// recording `(id, hit)` in `best`. Brute force passes the scene's
/// primitives; the BVH's leaves pass their leaf-ordered plain arrays
/// ([`crate::shape::PrimArrays`]: a triangle slice, or slots).
#[inline(always)]
pub fn closest_of<T: Intersect, S: Stats>(
    candidates: impl Iterator<Item = (u32, T)>,
    ray: &PreparedRay,
    t_max: &mut f32,
    best: &mut Option<(u32, PrimHit)>,
    stats: &mut S,
) {
    for (id, p) in candidates {
        if let Some(h) = p.test(ray, *t_max, stats) {
            stats.primitive_hit();
            *t_max = h.t;
            *best = Some((id, h));
        }
    }
}

/// The any-hit loop: whether a candidate is hit in (0, t_max), stopping
/// at the first.
#[inline(always)]
pub fn any_of<T: Intersect, S: Stats>(
    mut candidates: impl Iterator<Item = T>,
    ray: &PreparedRay,
    t_max: f32,
    stats: &mut S,
) -> bool {
    let hit = candidates.any(|p| p.test(ray, t_max, stats).is_some());
    if hit {
        stats.primitive_hit();
    }
    hit
}

impl Accel for Brute {
    fn intersect<S: Stats>(
        &self,
        prims: &[Primitive],
        ray: &PreparedRay,
        mut t_max: f32,
        stats: &mut S,
    ) -> Option<(u32, PrimHit)> {
        let mut best = None;
        closest_in(prims, &self.prims, ray, &mut t_max, &mut best, stats);
        best
    }

    fn occluded<S: Stats>(
        &self,
        prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> bool {
        any_in(prims, &self.prims, ray, t_max, stats)
    }
}
