//! One node of a wide box BVH and its child test: the children's boxes
//! stored transposed (one `W`-lane row per plane), tested together by the
//! slab test in SIMD lanes ([`slab4`], [`crate::math::slab8`], and with an
//! AVX2 token [`crate::math::slab8_avx2`]: [`slab8_with`]). The collapse
//! (module `collapse`) makes these nodes and the traversal
//! ([`super::wide`]) reads them.

use crate::math::{slab4, slab8_with, Aabb, Isa, Planes8, Vec3};
use crate::shape::PreparedRay;
use glam::Vec4;

/// One wide node: the children's boxes transposed (lane i = child i),
/// then per child either a wide node index (`count == 0`) or a leaf
/// (`count` primitives from `first`: a slot of the leaf order, or for a
/// packet tree the first of the leaf's ⌈count/4⌉ packets). Unused lanes
/// (the last ones) have `first == count == u32::MAX` and the empty box of
/// the module doc. 128 bytes for `W = 4`, 256 for `W = 8`: two or four
/// cache lines, aligned.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
pub struct WideNode<const W: usize> {
    pub min: [[f32; W]; 3],
    pub max: [[f32; W]; 3],
    pub first: [u32; W],
    pub count: [u32; W],
}

impl<const W: usize> WideNode<W> {
    /// Child `i`'s box.
    pub fn child_box(&self, i: usize) -> Aabb {
        Aabb {
            min: Vec3::new(self.min[0][i], self.min[1][i], self.min[2][i]),
            max: Vec3::new(self.max[0][i], self.max[1][i], self.max[2][i]),
        }
    }
}

/// The 4-wide node.
pub type Node4 = WideNode<4>;
/// The 8-wide node.
pub type Node8 = WideNode<8>;

/// The node tests of each width.
pub trait ChildTest<const W: usize> {
    /// Entry distances of the children (clamped to 0) and the mask of
    /// those hit in [0, t_max], with the instructions `isa` allows
    /// ([`crate::math::isa`]).
    fn hit<I: Isa>(&self, isa: I, ray: &PreparedRay, t_max: f32) -> ([f32; W], u32);
}

impl ChildTest<4> for Node4 {
    /// One 4-lane test in SSE, which every x86-64 CPU has: the same code
    /// whatever the capability.
    #[inline(always)]
    fn hit<I: Isa>(&self, _: I, ray: &PreparedRay, t_max: f32) -> ([f32; 4], u32) {
        let rows = |p: &[[f32; 4]; 3]| p.map(Vec4::from_array);
        let (t, mask) = slab4(
            &rows(&self.min),
            &rows(&self.max),
            ray.ray.origin,
            ray.inv_dir,
            t_max,
        );
        (t.to_array(), mask)
    }
}

impl ChildTest<8> for Node8 {
    #[inline(always)]
    fn hit<I: Isa>(&self, isa: I, ray: &PreparedRay, t_max: f32) -> ([f32; 8], u32) {
        let (lo, hi): (&Planes8, &Planes8) = (&self.min, &self.max);
        slab8_with(isa, lo, hi, ray.ray.origin, ray.inv_dir, t_max)
    }
}
