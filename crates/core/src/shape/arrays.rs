//! Primitives as plain data: one array per primitive kind, and one compact
//! reference per slot saying which array and where. This is what the BVH
//! leaves read (in leaf order), and what a GPU takes as it is: every
//! element is `#[repr(C)]` plain old data (`bytemuck::Pod`, checked at
//! compile time below), with no enums carrying payloads and no pointers.
//!
//! [`Shape`] remains the type scenes are built from; [`PrimArrays::new`]
//! turns a list of primitives into arrays; [`Slot`] tests one of them.

use super::{
    Ellipsoid, Intersect, Plane, PreparedRay, PrimHit, Primitive, Shape, Sphere, Triangle,
};
use crate::math::Aabb;
use crate::stats::Stats;

// The layouts a GPU buffer (and any other reader of the raw bytes) relies
// on: sizes and alignments, fixed at compile time.
const _: () = {
    assert!(std::mem::size_of::<Triangle>() == 44 && std::mem::align_of::<Triangle>() == 4);
    assert!(std::mem::size_of::<Sphere>() == 16 && std::mem::align_of::<Sphere>() == 4);
    assert!(std::mem::size_of::<Ellipsoid>() == 48 && std::mem::align_of::<Ellipsoid>() == 4);
    assert!(std::mem::size_of::<Plane>() == 24 && std::mem::align_of::<Plane>() == 4);
    assert!(std::mem::size_of::<PrimRef>() == 4);
};

/// The kind of a primitive: which array holds it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum PrimKind {
    Triangle = 0,
    Sphere = 1,
    Ellipsoid = 2,
    Plane = 3,
}

/// A primitive's kind (two high bits) and its index in that kind's array
/// (30 low bits): 4 bytes per slot.
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PrimRef(pub u32);

impl PrimRef {
    const INDEX_BITS: u32 = 30;
    const INDEX_MASK: u32 = (1 << Self::INDEX_BITS) - 1;
    /// The most primitives of one kind a set of arrays can hold.
    pub const MAX_INDEX: usize = Self::INDEX_MASK as usize;

    fn new(kind: PrimKind, index: usize) -> Self {
        assert!(
            index <= Self::MAX_INDEX,
            "more than 2^30 primitives of one kind"
        );
        PrimRef(((kind as u32) << Self::INDEX_BITS) | index as u32)
    }

    #[inline(always)]
    pub fn kind(self) -> PrimKind {
        match self.0 >> Self::INDEX_BITS {
            0 => PrimKind::Triangle,
            1 => PrimKind::Sphere,
            2 => PrimKind::Ellipsoid,
            _ => PrimKind::Plane,
        }
    }

    #[inline(always)]
    pub fn index(self) -> usize {
        (self.0 & Self::INDEX_MASK) as usize
    }
}

/// Primitives in plain arrays, one per kind, with a [`PrimRef`] per slot.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PrimArrays {
    pub triangles: Vec<Triangle>,
    pub spheres: Vec<Sphere>,
    pub ellipsoids: Vec<Ellipsoid>,
    pub planes: Vec<Plane>,
    /// Slot i's primitive.
    pub refs: Vec<PrimRef>,
}

impl PrimArrays {
    /// The primitives in order: slot i is the i-th primitive, and each
    /// kind's array keeps their relative order.
    pub fn new<'a>(prims: impl IntoIterator<Item = &'a Primitive>) -> Self {
        let mut a = PrimArrays::default();
        for p in prims {
            let r = match p.shape {
                Shape::Triangle(t) => {
                    a.triangles.push(t);
                    PrimRef::new(PrimKind::Triangle, a.triangles.len() - 1)
                }
                Shape::Sphere(s) => {
                    a.spheres.push(s);
                    PrimRef::new(PrimKind::Sphere, a.spheres.len() - 1)
                }
                Shape::Ellipsoid(e) => {
                    a.ellipsoids.push(e);
                    PrimRef::new(PrimKind::Ellipsoid, a.ellipsoids.len() - 1)
                }
                Shape::Plane(pl) => {
                    a.planes.push(pl);
                    PrimRef::new(PrimKind::Plane, a.planes.len() - 1)
                }
            };
            a.refs.push(r);
        }
        a
    }

    /// Number of slots.
    pub fn len(&self) -> usize {
        self.refs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.refs.is_empty()
    }

    /// Bounds of slot `slot`'s primitive (`None` for a plane).
    pub fn bounds(&self, slot: usize) -> Option<Aabb> {
        let r = self.refs[slot];
        let i = r.index();
        match r.kind() {
            PrimKind::Triangle => Some(self.triangles[i].bounds()),
            PrimKind::Sphere => Some(self.spheres[i].bounds()),
            PrimKind::Ellipsoid => Some(self.ellipsoids[i].bounds()),
            PrimKind::Plane => None,
        }
    }

    /// Bytes of the arrays and the references.
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self.triangles.as_slice())
            + std::mem::size_of_val(self.spheres.as_slice())
            + std::mem::size_of_val(self.ellipsoids.as_slice())
            + std::mem::size_of_val(self.planes.as_slice())
            + std::mem::size_of_val(self.refs.as_slice())
    }
}

impl PrimArrays {
    /// The triangles by slot, when every slot holds a triangle (a mesh
    /// scene's leaves): then slot i is `triangles[i]`, and a leaf loop can
    /// run over the slice with no reference to decode.
    #[inline(always)]
    pub fn triangles_only(&self) -> Option<&[Triangle]> {
        (self.triangles.len() == self.refs.len()).then_some(self.triangles.as_slice())
    }

    /// Slot `slot` as something to test.
    #[inline(always)]
    pub fn slot(&self, slot: usize) -> Slot<'_> {
        Slot { arrays: self, slot }
    }
}

/// One slot of a [`PrimArrays`], tested by its kind's test.
#[derive(Clone, Copy, Debug)]
pub struct Slot<'a> {
    arrays: &'a PrimArrays,
    slot: usize,
}

impl Intersect for Slot<'_> {
    #[inline(always)]
    fn test<S: Stats>(&self, r: &PreparedRay, t_max: f32, stats: &mut S) -> Option<PrimHit> {
        let a = self.arrays;
        let p = a.refs[self.slot];
        let i = p.index();
        match p.kind() {
            PrimKind::Triangle => a.triangles[i].test(r, t_max, stats),
            PrimKind::Sphere => a.spheres[i].test(r, t_max, stats),
            PrimKind::Ellipsoid => a.ellipsoids[i].test(r, t_max, stats),
            PrimKind::Plane => a.planes[i].test(r, t_max, stats),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Mat3, Ray, Vec3};
    use crate::stats::Counters;

    /// Every kind keeps its slot, survives a trip through raw bytes (what
    /// an upload does) and answers the ray test exactly as the primitive
    /// does, with the same count.
    #[test]
    fn arrays_hold_every_kind_and_test_like_the_primitives() {
        let prims: Vec<Primitive> = [
            Shape::Sphere(Sphere::new(Vec3::new(0.0, 0.0, -5.0), 1.0)),
            Shape::Triangle(Triangle::new(
                Vec3::new(-1.0, -1.0, -3.0),
                Vec3::new(1.0, -1.0, -3.0),
                Vec3::new(0.0, 1.0, -3.0),
            )),
            Shape::Ellipsoid(Ellipsoid::new(
                Vec3::new(0.0, 0.0, -8.0),
                Vec3::new(1.0, 2.0, 0.5),
                Mat3::IDENTITY,
            )),
            Shape::Plane(Plane::new(Vec3::new(0.0, 0.0, -10.0), Vec3::Z)),
        ]
        .into_iter()
        .enumerate()
        .map(|(i, shape)| Primitive {
            shape,
            object: i as u32,
        })
        .collect();
        let a = PrimArrays::new(&prims);
        assert_eq!(a.len(), 4);
        assert!(a.triangles_only().is_none());
        let tris = PrimArrays::new(&prims[1..2]);
        assert_eq!(tris.triangles_only(), Some(&tris.triangles[..]));
        let bytes: &[u8] = bytemuck::cast_slice(&a.triangles);
        let back: &[Triangle] = bytemuck::cast_slice(bytes);
        assert_eq!(back, a.triangles.as_slice());
        let ray = PreparedRay::new(Ray::new(Vec3::new(0.1, 0.05, 0.0), -Vec3::Z));
        for (slot, p) in prims.iter().enumerate() {
            assert_eq!(p.bounds(), a.bounds(slot));
            let (mut c1, mut c2) = (Counters::default(), Counters::default());
            let want = p.intersect(&ray, 100.0, &mut c1);
            let got = a.slot(slot).test(&ray, 100.0, &mut c2);
            assert!(want.is_some(), "slot {slot} should be hit");
            assert_eq!(want, got, "slot {slot}");
            assert_eq!(c1, c2, "slot {slot}");
        }
    }
}
