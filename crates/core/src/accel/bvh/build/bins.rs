//! What the binned SAH builder works on: primitive references packed in
//! SIMD boxes, the bounds of a range of them, the bins their centroids fall
//! in, and the sweep over the bins that finds a node's cheapest split.
//!
//! Everything here keeps the floating-point operations, and their order,
//! that decide a split or make a volume in the scalar `Aabb` code, so the
//! tree comes out bit for bit as the scalar builder made it (see the
//! parent module).

use super::super::volume::BoundingVolume;
use super::MAX_BINS;
use crate::math::Aabb;
use glam::{BVec4A, Vec4};

/// An axis-aligned box in the x, y, z lanes of two 4-wide vectors (the w
/// lanes carry no box), so that a union is two SIMD instructions.
#[derive(Clone, Copy, Debug)]
pub(super) struct Box4 {
    pub(super) lower: Vec4,
    pub(super) upper: Vec4,
}

impl Box4 {
    pub(super) const EMPTY: Box4 = Box4 {
        lower: Vec4::splat(f32::INFINITY),
        upper: Vec4::splat(f32::NEG_INFINITY),
    };

    /// The box grown by `later`. Where coordinates tie (+0 and −0) or
    /// `later`'s is NaN, `self`'s is kept: SSE's `_mm_min_ps(a, b)` answers
    /// `a < b ? a : b`. That is what `Aabb::union` does on x86 (its
    /// `f32::min` keeps its first operand unless the second is smaller), so
    /// folding the same boxes in the same order gives the same bits.
    /// (NEON's min and max are IEEE 754's minimum and maximum, the same as
    /// `f32::min` there but on NaN.)
    #[inline(always)]
    pub(super) fn union(self, later: Box4) -> Box4 {
        Box4 {
            lower: later.lower.min(self.lower),
            upper: later.upper.max(self.upper),
        }
    }

    /// `a` if `pick_a`, else `b`, without a branch.
    #[inline(always)]
    pub(super) fn select(pick_a: bool, a: Box4, b: Box4) -> Box4 {
        let m = BVec4A::splat(pick_a);
        Box4 {
            lower: Vec4::select(m, a.lower, b.lower),
            upper: Vec4::select(m, a.upper, b.upper),
        }
    }

    /// The box grown to contain the point in `p`'s x, y, z lanes.
    #[inline(always)]
    fn include(self, p: Vec4) -> Box4 {
        self.union(Box4 { lower: p, upper: p })
    }

    #[inline]
    pub(super) fn to_aabb(self) -> Aabb {
        Aabb {
            min: self.lower.truncate(),
            max: self.upper.truncate(),
        }
    }
}

/// What the builder needs of a primitive: its box, with its id stored in
/// the box's spare lane (the bits of `lower.w`), 32 bytes in all, so that
/// the binning and partition loops stream through two cache lines per four
/// primitives.
#[derive(Clone, Copy, Debug)]
pub(super) struct PrimRef(pub(super) Box4);

impl PrimRef {
    #[inline]
    pub(super) fn new(id: u32, b: &Aabb) -> Self {
        PrimRef(Box4 {
            lower: b.min.extend(f32::from_bits(id)),
            upper: b.max.extend(0.0),
        })
    }

    #[inline]
    pub(super) fn id(&self) -> u32 {
        self.0.lower.w.to_bits()
    }

    #[inline]
    pub(super) fn bounds(&self) -> Aabb {
        self.0.to_aabb()
    }

    /// The box centre in the x, y, z lanes, computed as [`Aabb::centre`]
    /// does. The id is masked out first: its bits make a subnormal float
    /// (for ids below 2²³), and arithmetic on subnormals takes a microcode
    /// assist, which made the build several times slower.
    #[inline(always)]
    pub(super) fn centroid(&self) -> Vec4 {
        const XYZ: BVec4A = BVec4A::new(true, true, true, false);
        0.5 * (Vec4::select(XYZ, self.0.lower, Vec4::ZERO) + self.0.upper)
    }
}

/// The box of a range's primitives and the box of their centroids: what a
/// node's fit and its split need, taken in one pass.
#[derive(Clone, Copy, Debug)]
pub(super) struct RangeBounds {
    pub(super) bounds: Box4,
    pub(super) centroids: Box4,
}

impl RangeBounds {
    pub(super) const EMPTY: RangeBounds = RangeBounds {
        bounds: Box4::EMPTY,
        centroids: Box4::EMPTY,
    };

    #[inline]
    pub(super) fn of(refs: &[PrimRef]) -> Self {
        refs.iter().fold(Self::EMPTY, Self::add)
    }

    /// The bounds grown by the next primitive of the range.
    #[inline(always)]
    fn add(self, r: &PrimRef) -> Self {
        RangeBounds {
            bounds: self.bounds.union(r.0),
            centroids: self.centroids.include(r.centroid()),
        }
    }
}

/// Maps centroids to SAH bins, all three axes at once.
pub(super) struct Binner {
    min: Vec4,
    /// Bins per unit length along each axis of the centroid bounds; 0 on
    /// axes that cannot be binned, whose lanes are then ignored.
    scale: Vec4,
    last: Vec4,
    /// Which axes have a bin scale: those along which the centroid bounds
    /// are neither flat nor so thin (or not finite) that the scale is not
    /// finite.
    pub(super) axes: [bool; 3],
}

impl Binner {
    #[inline]
    pub(super) fn new(cb: &Box4, bins: usize) -> Self {
        // What makes `indices`' conversion sound: positions ≤ bins − 1 < 2³².
        assert!((2..=super::MAX_BINS).contains(&bins), "{bins} bins");
        let extent = cb.upper - cb.lower;
        let scale = Vec4::splat(bins as f32) / extent;
        let ok = extent.cmpgt(Vec4::ZERO) & scale.is_finite_mask();
        Binner {
            min: cb.lower,
            scale: Vec4::select(ok, scale, Vec4::ZERO),
            last: Vec4::splat((bins - 1) as f32),
            axes: [0, 1, 2].map(|axis| ok.test(axis)),
        }
    }

    /// Where a centroid falls along each axis in units of bins,
    /// `(c − min)·scale`, clamped to [0, bins − 1] with NaN at 0: its bin is
    /// the integer part, so the top edge and rounding beyond it land in the
    /// last bin.
    #[inline(always)]
    fn position(&self, c: Vec4) -> Vec4 {
        let f = (c - self.min) * self.scale;
        // The clamps as comparisons, so that NaN goes to 0 on every SIMD
        // back end (NEON's min and max propagate NaN).
        let f = Vec4::select(f.cmpgt(Vec4::ZERO), f, Vec4::ZERO);
        Vec4::select(f.cmplt(self.last), f, self.last)
    }

    /// The bin of a centroid along each axis.
    #[inline(always)]
    pub(super) fn indices(&self, c: Vec4) -> [usize; 3] {
        let f = self.position(c);
        // SAFETY: `position` clamps every lane of `f` to [0, bins − 1]
        // (NaN to 0), and `new` asserts bins ≤ MAX_BINS = 64: finite and
        // in u32's range after truncation, which `to_int_unchecked`
        // requires. (The checked `as` conversion tests every lane against
        // the limits again; that took an eighth of the build.)
        let i = |x: f32| unsafe { x.to_int_unchecked::<u32>() } as usize;
        [i(f.x), i(f.y), i(f.z)]
    }

    /// Whether a centroid's bin along `axis` is below `split` (given in
    /// every lane): the integer part of a non-negative number is below an
    /// integer exactly when the number is, so this is [`Self::indices`]'s
    /// answer without the conversion.
    #[inline(always)]
    pub(super) fn below(&self, c: Vec4, axis: usize, split: Vec4) -> bool {
        self.position(c).cmplt(split).test(axis)
    }
}

/// Per axis, the box and the number of the primitives whose centroid falls
/// in each bin, and which bins hold any.
#[derive(Clone)]
pub(super) struct Bins {
    boxes: [[Box4; MAX_BINS]; 3],
    counts: [[u32; MAX_BINS]; 3],
    /// Bit i: bin i is occupied.
    occupied: [u64; 3],
}

impl Bins {
    /// All bins empty.
    #[inline]
    pub(super) fn new() -> Box<Self> {
        Box::new(Bins {
            boxes: [[Box4::EMPTY; MAX_BINS]; 3],
            counts: [[0; MAX_BINS]; 3],
            occupied: [0; 3],
        })
    }

    #[inline]
    pub(super) fn add(&mut self, refs: &[PrimRef], binner: &Binner) {
        // (The masks in a local, which stays in registers.)
        let mut occupied = self.occupied;
        for r in refs {
            let idx = binner.indices(r.centroid());
            for (axis, &i) in idx.iter().enumerate() {
                self.counts[axis][i] += 1;
                self.boxes[axis][i] = self.boxes[axis][i].union(r.0);
                occupied[axis] |= 1 << i;
            }
        }
        self.occupied = occupied;
    }

    /// Empty the occupied bins again, so that all bins are empty for the
    /// next node: cheaper than clearing them all, since a small node fills
    /// few.
    #[inline]
    pub(super) fn empty(&mut self) {
        for axis in 0..3 {
            for i in bits_up(self.occupied[axis]) {
                self.boxes[axis][i] = Box4::EMPTY;
                self.counts[axis][i] = 0;
            }
            self.occupied[axis] = 0;
        }
    }

    /// The cheapest split along `axis` with `cost(A_L·N_L, A_R·N_R)`, each
    /// side's N being `counted(its primitives)`: the first of the cheapest,
    /// as (cost, split bin) with the bins below the split bin on the left;
    /// `None` when fewer than two bins are occupied.
    ///
    /// Only a boundary between two occupied bins divides the primitives
    /// differently from its neighbours (one beside an empty bin divides
    /// them as the boundary before that bin does, at the same cost, so it
    /// could never be strictly cheaper than that one), so the sweeps visit
    /// the occupied bins alone; most bins of the many small nodes are
    /// empty. Skipping an empty bin leaves the sums as they were: its box
    /// is the empty box, and a union with it gives back the same bits.
    pub(super) fn best_split<V: BoundingVolume>(
        &self,
        axis: usize,
        counted: impl Fn(usize) -> usize,
        cost: impl Fn(f32, f32) -> f32,
    ) -> Option<(f32, usize)> {
        let (boxes, count, occupied) = (&self.boxes[axis], &self.counts[axis], self.occupied[axis]);
        let first = occupied.trailing_zeros() as usize;
        // Right to left: area·count of the occupied bins from i on, for
        // each occupied bin i but the first.
        let mut right_cost = [0.0f32; MAX_BINS];
        let (mut acc_box, mut acc_n) = (Box4::EMPTY, 0usize);
        for i in bits_down(occupied).take_while(|&i| i > first) {
            acc_box = acc_box.union(boxes[i]);
            acc_n += count[i] as usize;
            right_cost[i] = side_cost::<V>(acc_box, counted(acc_n));
        }
        // Left to right: split between each occupied bin i and the next
        // one, j.
        let mut best: Option<(f32, usize)> = None;
        let (mut acc_box, mut acc_n) = (Box4::EMPTY, 0usize);
        for (i, j) in bits_up(occupied).zip(bits_up(occupied).skip(1)) {
            acc_box = acc_box.union(boxes[i]);
            acc_n += count[i] as usize;
            let c = cost(side_cost::<V>(acc_box, counted(acc_n)), right_cost[j]);
            if best.is_none_or(|(b, _)| c < b) {
                best = Some((c, i + 1));
            }
        }
        best
    }
}

/// The set bits of `mask`, lowest first.
#[inline]
fn bits_up(mut mask: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        let i = mask.trailing_zeros() as usize;
        mask &= mask.wrapping_sub(1);
        (i < 64).then_some(i)
    })
}

/// The set bits of `mask`, highest first.
#[inline]
fn bits_down(mut mask: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        let i = 63_usize.wrapping_sub(mask.leading_zeros() as usize);
        mask &= !(1u64.wrapping_shl(i as u32));
        (i < 64).then_some(i)
    })
}

/// A side's term of the SAH sum: the surface area of the volume fitted to
/// its box times its number of primitives.
#[inline]
fn side_cost<V: BoundingVolume>(b: Box4, n: usize) -> f32 {
    V::from_bounds(&b.to_aabb()).surface_area() * n as f32
}
