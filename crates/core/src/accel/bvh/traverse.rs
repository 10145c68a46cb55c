//! BVH traversal: one loop with a fixed-size stack, written once for
//! closest-hit and any-hit queries and for every bounding volume.
//!
//! The root's volume is tested first; after that, visiting an interior node
//! tests the volumes of both its children (together, from the parent's
//! [`super::Packed`] record), descends into the nearer one
//! (smaller entry distance) and pushes the other with its entry distance. A
//! popped node whose entry distance exceeds the closest hit found since it
//! was pushed is dropped without being visited. A leaf tests its primitives
//! with the brute-force helpers, which shrink `t_max` as hits are found.
//!
//! Counting: `node_visit` once per node whose contents are examined (its two
//! children's volumes tested, or its primitives tested); one bounding-volume
//! test per volume tested (the root's, then two per interior node visited);
//! primitive tests as the primitives count them.

use super::volume::BoundingVolume;
use super::{Bvh, MAX_DEPTH};
use crate::accel::brute::{any_of, closest_of};
use crate::shape::{PreparedRay, PrimArrays, PrimHit};
use crate::stats::Stats;
use std::mem::MaybeUninit;

impl<V: BoundingVolume> Bvh<V> {
    // ANCHOR: traverse
    /// The shared traversal. With `ANY_HIT` it returns at the first
    /// primitive hit in (0, t_max) (shadow rays); otherwise it records the
    /// closest hit in `best` and returns whether there was one.
    #[inline]
    pub(super) fn traverse<S: Stats, const ANY_HIT: bool>(
        &self,
        ray: &PreparedRay,
        mut t_max: f32,
        best: &mut Option<(u32, PrimHit)>,
        stats: &mut S,
    ) -> bool {
        let Some(root) = self.nodes.first() else {
            return false;
        };
        if root.volume.hit(ray, t_max, stats).is_none() {
            return false;
        }
        // One pending sibling per level at most, and no tree is deeper than
        // MAX_DEPTH (the builders stop there).
        let mut slots = Pending::<u32, { MAX_DEPTH as usize }>::slots();
        let mut stack = Pending::new(&mut slots);
        let mut node = 0usize;
        loop {
            stats.node_visit();
            let n = &self.packed[node];
            if n.count > 0 {
                let range = n.first as usize..(n.first + n.count) as usize;
                if test_leaf::<S, ANY_HIT>(
                    &self.leaf_prims,
                    &self.indices,
                    range,
                    ray,
                    &mut t_max,
                    best,
                    stats,
                ) {
                    return true;
                }
            } else {
                let left = n.first as usize;
                let right = left + 1;
                let [hit_left, hit_right] = V::hit_pair(&n.children, ray, t_max, stats);
                match (hit_left, hit_right) {
                    (Some(tl), Some(tr)) => {
                        let (near, far, t_far) = if tl <= tr {
                            (left, right, tr)
                        } else {
                            (right, left, tl)
                        };
                        stack.push(far as u32, t_far);
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = left;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = right;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            // Pop the nearest pending node that can still hold a closer hit.
            // Entry distances carry rounding, so a node entered exactly at
            // the current closest t is still visited (a hit there would have
            // to be closer by a rounding error to count).
            match stack.pop_live(t_max) {
                Some(next) => node = next as usize,
                None => return best.is_some(),
            }
        }
    }
    // ANCHOR_END: traverse
}

/// Test the primitives of one leaf: slots `range` of the leaf-ordered
/// arrays `leaf` (whose scene indices are `indices[range]`). With `ANY_HIT`
/// returns whether one is hit in (0, t_max); otherwise records the closest
/// in `best`, shrinking `t_max`, and returns false. Shared by the binary and
/// the 4-wide traversal.
#[inline(always)]
pub(super) fn test_leaf<S: Stats, const ANY_HIT: bool>(
    leaf: &PrimArrays,
    indices: &[u32],
    range: std::ops::Range<usize>,
    ray: &PreparedRay,
    t_max: &mut f32,
    best: &mut Option<(u32, PrimHit)>,
    stats: &mut S,
) -> bool {
    let ids = indices[range.clone()].iter().copied();
    // A mesh's leaves hold only triangles: loop over the slice itself.
    match leaf.triangles_only() {
        Some(tris) if ANY_HIT => any_of(tris[range].iter(), ray, *t_max, stats),
        Some(tris) => {
            closest_of(ids.zip(&tris[range]), ray, t_max, best, stats);
            false
        }
        None if ANY_HIT => any_of(range.map(|s| leaf.slot(s)), ray, *t_max, stats),
        None => {
            closest_of(
                ids.zip(range.map(|s| leaf.slot(s))),
                ray,
                t_max,
                best,
                stats,
            );
            false
        }
    }
}

/// The traversal stack: pending (node, entry distance) pairs, at most `N`,
/// in an array the caller lends ([`Pending::slots`]). Left uninitialised:
/// the wide trees' capacity (7 siblings a level, 64 levels) would otherwise
/// cost a memset of kilobytes per ray. The array lives apart from the
/// length so that the length stays in a register (in one struct with the
/// array, the compiler kept it in memory and reloaded it at every push).
pub(super) struct Pending<'a, T, const N: usize> {
    items: &'a mut [MaybeUninit<(T, f32)>; N],
    len: usize,
}

impl<'a, T: Copy, const N: usize> Pending<'a, T, N> {
    /// Storage for a stack.
    #[inline(always)]
    pub(super) fn slots() -> [MaybeUninit<(T, f32)>; N] {
        [const { MaybeUninit::uninit() }; N]
    }

    /// An empty stack in `items`.
    #[inline(always)]
    pub(super) fn new(items: &'a mut [MaybeUninit<(T, f32)>; N]) -> Self {
        Pending { items, len: 0 }
    }

    /// Push a node with its entry distance (panics past `N`, which the
    /// depth limit of the builders rules out).
    #[inline(always)]
    pub(super) fn push(&mut self, node: T, t_enter: f32) {
        self.items[self.len] = MaybeUninit::new((node, t_enter));
        self.len += 1;
    }

    /// Pop pending nodes until one whose entry distance does not exceed
    /// `t_max` (entry distances carry rounding, so a node entered exactly
    /// at the current closest t is still visited); `None` when none is
    /// left.
    #[inline(always)]
    pub(super) fn pop_live(&mut self, t_max: f32) -> Option<T> {
        while self.len > 0 {
            self.len -= 1;
            // SAFETY: the slots below `len` are initialised: `len` starts
            // at 0 (`new`), `push` writes a slot before counting it, and
            // only these two methods change `len` (a private field); `len`
            // was above this slot before the decrement.
            let (next, t_enter) = unsafe { self.items[self.len].assume_init() };
            if t_enter <= t_max {
                return Some(next);
            }
        }
        None
    }
}
