//! A view of a wide tree whose traversal inlines into its caller: what
//! the path tracer's groups (`integrator::lanes`) query.

use super::node::{ChildTest, WideNode};
use super::wide::WideBvh;
use crate::accel::Accel;
use crate::math::Avx2;
use crate::shape::{PreparedRay, PrimHit, Primitive};
use crate::stats::Stats;

/// A wide tree whose AVX2 node test the CPU has, with a traversal that
/// inlines into its caller ([`WideBvh::inline_avx2`]). Inlined into code
/// compiled with AVX2 (the path tracer's groups, `integrator::lanes`), the
/// query loses the call, the dispatch on the accelerator kind and the CPU
/// check, and the compiler keeps the tree's pointers and the ray's set-up
/// in registers across the caller's loop: 11 % off the Cornell box's
/// path-traced render (`make bench-peers`' command at 64 spp and 1
/// thread, best of 5 against the build without it, 2-core AMD EPYC,
/// 2026-11-28). Called from code without AVX2 the intrinsics stay calls:
/// slower, still right. It holds the tree's [`Avx2`] token, so it exists
/// only on a CPU with AVX2.
#[derive(Clone, Copy, Debug)]
pub struct InlineAvx2<'a, const W: usize> {
    tree: &'a WideBvh<W>,
    avx2: Avx2,
}

impl<const W: usize> WideBvh<W>
where
    WideNode<W>: ChildTest<W>,
{
    /// The tree as an [`InlineAvx2`] accelerator, where the CPU has AVX2
    /// (and the tree uses it: 8-wide).
    pub fn inline_avx2(&self) -> Option<InlineAvx2<'_, W>> {
        self.avx2.map(|avx2| InlineAvx2 { tree: self, avx2 })
    }
}

impl<const W: usize> Accel for InlineAvx2<'_, W>
where
    WideNode<W>: ChildTest<W>,
{
    #[inline(always)]
    fn intersect<S: Stats>(
        &self,
        _prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> Option<(u32, PrimHit)> {
        let mut best = None;
        self.tree
            .traverse::<S, false, _>(self.avx2, ray, t_max, &mut best, stats);
        best
    }

    #[inline(always)]
    fn occluded<S: Stats>(
        &self,
        _prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> bool {
        self.tree
            .traverse::<S, true, _>(self.avx2, ray, t_max, &mut None, stats)
    }
}

#[cfg(test)]
mod tests {
    use super::super::wide::tests::strip;
    use super::*;
    use crate::accel::bvh::{has_avx2, BuildOptions, Bvh8};
    use crate::math::{Aabb, Vec3};

    /// The inlinable view ([`InlineAvx2`]) is the same traversal: the same
    /// hits, bit for bit, and the same counts, on rays from a box around a
    /// strip of triangles towards and past it. Where the CPU lacks AVX2 the
    /// view must not exist.
    #[test]
    fn inline_view_answers_as_the_tree() {
        use crate::math::{Ray, SplitMix64};
        use crate::stats::Counters;
        let prims = strip(300);
        let ids: Vec<u32> = (0..prims.len() as u32).collect();
        let t = Bvh8::build(&prims, ids, BuildOptions::wide());
        let Some(view) = t.inline_avx2() else {
            assert!(!has_avx2());
            return;
        };
        let mut rng = SplitMix64(7);
        let area = Aabb {
            min: Vec3::new(-5.0, -2.0, -2.0),
            max: Vec3::new(305.0, 3.0, 2.0),
        };
        let (mut hits, mut blocked) = (0, 0);
        for _ in 0..20_000 {
            let from = rng.in_box(&area);
            let to = rng.in_box(&area);
            let ray = PreparedRay::new(Ray::new(from, to - from));
            let t_max = rng.range(0.2, 2.0);
            let (mut a, mut b) = (Counters::default(), Counters::default());
            let hit = t.intersect(&prims, &ray, t_max, &mut a);
            assert_eq!(view.intersect(&prims, &ray, t_max, &mut b), hit);
            let occluded = t.occluded(&prims, &ray, t_max, &mut a);
            assert_eq!(view.occluded(&prims, &ray, t_max, &mut b), occluded);
            assert_eq!(a, b);
            hits += usize::from(hit.is_some());
            blocked += usize::from(occluded);
        }
        assert_eq!(hits, blocked);
        assert!(hits > 300, "{hits} hits of 20000");
    }
}
