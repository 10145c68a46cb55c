//! Brute force: test every primitive. The reference every other accelerator
//! must agree with, and S3's "basic tracer".

use super::Accel;
use crate::shape::{PreparedRay, PrimHit, Primitive};
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
/// are found. Shared by every accelerator's leaves and by the scene's list
/// of unbounded primitives.
#[inline]
pub fn closest_in<S: Stats>(
    prims: &[Primitive],
    ids: &[u32],
    ray: &PreparedRay,
    t_max: &mut f32,
    best: &mut Option<(u32, PrimHit)>,
    stats: &mut S,
) {
    for &id in ids {
        if let Some(h) = prims[id as usize].intersect(ray, *t_max, stats) {
            stats.primitive_hit();
            *t_max = h.t;
            *best = Some((id, h));
        }
    }
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
    for &id in ids {
        if prims[id as usize].intersect(ray, t_max, stats).is_some() {
            stats.primitive_hit();
            return true;
        }
    }
    false
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
