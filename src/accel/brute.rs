//! Brute force: test every primitive. The reference every other accelerator
//! must agree with, and S3's "basic tracer".

use super::Accel;
use crate::shape::{PreparedRay, PrimHit, PrimSource, Primitive};
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
        prims,
        ids.iter().map(|&id| (id, id as usize)),
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
    any_of(prims, ids.iter().map(|&id| id as usize), ray, t_max, stats)
}

/// The closest-hit loop every accelerator's leaves run: test the
/// `(id, slot)` candidates of `source` in order, shrinking `t_max` as hits
/// are found and recording `(id, hit)` in `best`. Brute force passes scene
/// indices as slots; the BVH's leaves pass slots of their leaf-ordered
/// [`crate::shape::PrimArrays`].
#[inline(always)]
pub fn closest_of<P: PrimSource + ?Sized, S: Stats>(
    source: &P,
    candidates: impl Iterator<Item = (u32, usize)>,
    ray: &PreparedRay,
    t_max: &mut f32,
    best: &mut Option<(u32, PrimHit)>,
    stats: &mut S,
) {
    for (id, slot) in candidates {
        if let Some(h) = source.test(slot, ray, *t_max, stats) {
            stats.primitive_hit();
            *t_max = h.t;
            *best = Some((id, h));
        }
    }
}

/// The any-hit loop: whether a candidate slot of `source` is hit in
/// (0, t_max), stopping at the first.
#[inline(always)]
pub fn any_of<P: PrimSource + ?Sized, S: Stats>(
    source: &P,
    mut slots: impl Iterator<Item = usize>,
    ray: &PreparedRay,
    t_max: f32,
    stats: &mut S,
) -> bool {
    let hit = slots.any(|slot| source.test(slot, ray, t_max, stats).is_some());
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
