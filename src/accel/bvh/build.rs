//! BVH builders: S3's median split and binned SAH, both top-down over
//! primitive references, both writing the flattened node array directly.
//!
//! Layout: the two children of an interior node are adjacent, at `first`
//! and `first + 1`, allocated together when their parent is split; each
//! child's subtree follows in depth-first order. The traversal tests both
//! children of a node together, so siblings sharing a cache line (two 32-byte
//! box nodes fill 64 bytes) is the access pattern it wants.
//!
//! The primitives of any subtree are a contiguous range of the reordered
//! index array, because each split partitions its range in place.
//!
//! Parallel build. Once a node is split, its two children's subtrees cover
//! disjoint ranges of the references and write disjoint runs of the node
//! array, so a node over more than [`PARALLEL_MIN`] primitives builds them
//! with `rayon::join`: the left subtree straight into the node array (it
//! starts where the serial build would start it), the right one into a
//! vector of its own, appended after the left subtree with its child indices
//! shifted by where it lands, which is where the serial build puts it.
//! Ranges that long also take their bounds and bin their centroids in
//! parallel chunks; only the partition of such a range stays serial. Below
//! the threshold a subtree is built by one thread, a few hundred
//! microseconds of work.
//!
//! The output does not depend on the number of threads: every node's split
//! is decided by the same floating-point operations on the same primitives
//! in the same order as in a serial build, and the node array and the index
//! order come out identical, bit for bit (tested below). What makes the
//! chunked passes exact is that a box fold keeps the first of equal
//! coordinates ([`Box4::union`]), which makes it associative down to the
//! sign of a zero; bin counts are integers, and the SAH sweep over the bins
//! is the serial one. The output is also the one the single-threaded
//! builder before it gave, bit for bit; the speed-ups of the serial code
//! (all three axes binned in one pass over 32-byte references, sweeps over
//! the occupied bins only, a branch-free partition) each keep every
//! operation that decides a split or makes a volume.

use super::volume::BoundingVolume;
use super::{BuildOptions, Builder, Fit, Node, MAX_DEPTH};
use crate::math::Aabb;
use crate::math::Vec3;
use crate::shape::{Primitive, Shape};
use glam::{BVec4A, Vec4};
use rayon::prelude::*;
use std::marker::PhantomData;

/// Most bins the SAH builder accepts.
pub const MAX_BINS: usize = 64;

/// Ranges of more primitives than this are split in parallel (their
/// children's subtrees with `rayon::join`, their bounds and bins in chunks
/// of this size); smaller ones are built by one thread. On the CGAL meshes
/// (20k–90k triangles) with two threads, every value from 512 to 16384
/// built within the noise of the others: the tasks are few either way
/// (a 20k-triangle tree has about five such nodes), and work stealing
/// balances them. 4096 keeps the chunks at 128 KiB of references.
const PARALLEL_MIN: usize = 4096;

/// Build the node array and the reordered primitive indices over `ids`
/// (indices into `prims`, all bounded).
pub(super) fn build<V: BoundingVolume>(
    prims: &[Primitive],
    ids: Vec<u32>,
    options: &BuildOptions,
) -> (Vec<Node<V>>, Vec<u32>) {
    build_with(prims, &ids, options, PARALLEL_MIN)
}

/// [`build`] with ranges of more than `parallel_min` primitives split in
/// parallel; `usize::MAX` builds on the calling thread alone.
fn build_with<V: BoundingVolume>(
    prims: &[Primitive],
    ids: &[u32],
    options: &BuildOptions,
    parallel_min: usize,
) -> (Vec<Node<V>>, Vec<u32>) {
    // The whole build runs on a pool thread: a parallel call from outside
    // the pool hands its work over to it and waits, tens of microseconds
    // each time.
    rayon::scope(|_| {
        let mut refs = Vec::with_capacity(ids.len());
        refs.extend(
            ids.iter()
                .filter_map(|&id| Some(PrimRef::new(id, &prims[id as usize].bounds()?))),
        );
        let mut nodes = Vec::new();
        if !refs.is_empty() {
            nodes.reserve(node_bound(refs.len(), options));
            let mut b = TreeBuilder::<V>::new(prims, options, parallel_min);
            let geo = b.range_bounds(&refs);
            nodes.push(Node::leaf(b.fit(&refs, &geo), 0, 0));
            b.split(&mut nodes, 0, &mut refs, 0, &geo, 0);
        }
        (nodes, refs.iter().map(PrimRef::id).collect())
    })
}

/// The most nodes a tree over `n` primitives can have, to reserve: with
/// at least m primitives in every leaf, 2n/m − 1. A leaf holds at least
/// one; a median split's leaf more than half the leaf size, since its
/// parent held more than that.
fn node_bound(n: usize, options: &BuildOptions) -> usize {
    let least = match options.builder {
        Builder::S3 => (options.leaf_size as usize).div_ceil(2).max(1),
        Builder::Sah => 1,
    };
    2 * n.div_ceil(least)
}

/// An axis-aligned box in the x, y, z lanes of two 4-wide vectors (the w
/// lanes carry no box), so that a union is two SIMD instructions.
#[derive(Clone, Copy, Debug)]
struct Box4 {
    lower: Vec4,
    upper: Vec4,
}

impl Box4 {
    const EMPTY: Box4 = Box4 {
        lower: Vec4::splat(f32::INFINITY),
        upper: Vec4::splat(f32::NEG_INFINITY),
    };

    /// The box grown by `later`. Where coordinates tie (+0 and −0) or
    /// `later`'s is NaN, `self`'s is kept: SSE's `_mm_min_ps(a, b)` answers
    /// `a < b ? a : b`. That is what `Aabb::union` does on x86 (its
    /// `f32::min` keeps its first operand unless the second is smaller), so
    /// folding in the same order gives the same bits; and "the first of
    /// equal values wins" is associative, so a fold split into chunks whose
    /// results are merged in order gives them too. (NEON's min and max are
    /// IEEE 754's minimum and maximum, associative as well, and the same as
    /// `f32::min` there but on NaN.)
    #[inline(always)]
    fn union(self, later: Box4) -> Box4 {
        Box4 {
            lower: later.lower.min(self.lower),
            upper: later.upper.max(self.upper),
        }
    }

    /// `a` if `pick_a`, else `b`, without a branch.
    #[inline(always)]
    fn select(pick_a: bool, a: Box4, b: Box4) -> Box4 {
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

    fn to_aabb(self) -> Aabb {
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
struct PrimRef(Box4);

impl PrimRef {
    fn new(id: u32, b: &Aabb) -> Self {
        PrimRef(Box4 {
            lower: b.min.extend(f32::from_bits(id)),
            upper: b.max.extend(0.0),
        })
    }

    fn id(&self) -> u32 {
        self.0.lower.w.to_bits()
    }

    fn bounds(&self) -> Aabb {
        self.0.to_aabb()
    }

    /// The box centre in the x, y, z lanes, computed as [`Aabb::centre`]
    /// does. The id is masked out first: its bits make a subnormal float
    /// (for ids below 2²³), and arithmetic on subnormals takes a microcode
    /// assist, which made the build several times slower.
    #[inline(always)]
    fn centroid(&self) -> Vec4 {
        const XYZ: BVec4A = BVec4A::new(true, true, true, false);
        0.5 * (Vec4::select(XYZ, self.0.lower, Vec4::ZERO) + self.0.upper)
    }
}

/// The box of a range's primitives and the box of their centroids: what a
/// node's fit and its split need, taken in one pass.
#[derive(Clone, Copy, Debug)]
struct RangeBounds {
    bounds: Box4,
    centroids: Box4,
}

impl RangeBounds {
    const EMPTY: RangeBounds = RangeBounds {
        bounds: Box4::EMPTY,
        centroids: Box4::EMPTY,
    };

    fn of(refs: &[PrimRef]) -> Self {
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

    /// `self` for a range followed by `later` for the range after it.
    fn merge(self, later: Self) -> Self {
        RangeBounds {
            bounds: self.bounds.union(later.bounds),
            centroids: self.centroids.union(later.centroids),
        }
    }
}

/// Maps centroids to SAH bins, all three axes at once.
struct Binner {
    min: Vec4,
    /// Bins per unit length along each axis of the centroid bounds; 0 on
    /// axes that cannot be binned, whose lanes are then ignored.
    scale: Vec4,
    last: Vec4,
    /// Which axes have a bin scale: those along which the centroid bounds
    /// are neither flat nor so thin (or not finite) that the scale is not
    /// finite.
    axes: [bool; 3],
}

impl Binner {
    fn new(cb: &Box4, bins: usize) -> Self {
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
    fn indices(&self, c: Vec4) -> [usize; 3] {
        let f = self.position(c);
        // SAFETY: every lane of `f` is in [0, bins − 1] ⊂ [0, 63], which
        // `to_int_unchecked` requires. (The checked `as` conversion tests
        // every lane against the limits again; that took an eighth of the
        // build.)
        let i = |x: f32| unsafe { x.to_int_unchecked::<u32>() } as usize;
        [i(f.x), i(f.y), i(f.z)]
    }

    /// Whether a centroid's bin along `axis` is below `split` (given in
    /// every lane): the integer part of a non-negative number is below an
    /// integer exactly when the number is, so this is [`Self::indices`]'s
    /// answer without the conversion.
    #[inline(always)]
    fn below(&self, c: Vec4, axis: usize, split: Vec4) -> bool {
        self.position(c).cmplt(split).test(axis)
    }
}

/// Per axis, the box and the number of the primitives whose centroid falls
/// in each bin, and which bins hold any.
#[derive(Clone)]
struct Bins {
    boxes: [[Box4; MAX_BINS]; 3],
    counts: [[u32; MAX_BINS]; 3],
    /// Bit i: bin i is occupied.
    occupied: [u64; 3],
}

impl Bins {
    /// All bins empty.
    fn new() -> Box<Self> {
        Box::new(Bins {
            boxes: [[Box4::EMPTY; MAX_BINS]; 3],
            counts: [[0; MAX_BINS]; 3],
            occupied: [0; 3],
        })
    }

    fn add(&mut self, refs: &[PrimRef], binner: &Binner) {
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

    /// Add the bins of the range after this one.
    fn merge(mut self: Box<Self>, later: Box<Self>) -> Box<Self> {
        for axis in 0..3 {
            for i in bits_up(later.occupied[axis]) {
                self.counts[axis][i] += later.counts[axis][i];
                self.boxes[axis][i] = self.boxes[axis][i].union(later.boxes[axis][i]);
            }
            self.occupied[axis] |= later.occupied[axis];
        }
        self
    }

    /// Empty the occupied bins again, so that all bins are empty for the
    /// next node: cheaper than clearing them all, since a small node fills
    /// few.
    fn empty(&mut self) {
        for axis in 0..3 {
            for i in bits_up(self.occupied[axis]) {
                self.boxes[axis][i] = Box4::EMPTY;
                self.counts[axis][i] = 0;
            }
            self.occupied[axis] = 0;
        }
    }

    /// The cheapest split along `axis` with `cost(A_L·N_L, A_R·N_R)`: the
    /// first of the cheapest, as (cost, split bin) with the bins below the
    /// split bin on the left; `None` when fewer than two bins are occupied.
    ///
    /// Only a boundary between two occupied bins divides the primitives
    /// differently from its neighbours (one beside an empty bin divides
    /// them as the boundary before that bin does, at the same cost, so it
    /// could never be strictly cheaper than that one), so the sweeps visit
    /// the occupied bins alone; most bins of the many small nodes are
    /// empty. Skipping an empty bin leaves the sums as they were: its box
    /// is the empty box, and a union with it gives back the same bits.
    fn best_split<V: BoundingVolume>(
        &self,
        axis: usize,
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
            right_cost[i] = side_cost::<V>(acc_box, acc_n);
        }
        // Left to right: split between each occupied bin i and the next
        // one, j.
        let mut best: Option<(f32, usize)> = None;
        let (mut acc_box, mut acc_n) = (Box4::EMPTY, 0usize);
        for (i, j) in bits_up(occupied).zip(bits_up(occupied).skip(1)) {
            acc_box = acc_box.union(boxes[i]);
            acc_n += count[i] as usize;
            let c = cost(side_cost::<V>(acc_box, acc_n), right_cost[j]);
            if best.map_or(true, |(b, _)| c < b) {
                best = Some((c, i + 1));
            }
        }
        best
    }
}

/// The set bits of `mask`, lowest first.
fn bits_up(mut mask: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        let i = mask.trailing_zeros() as usize;
        mask &= mask.wrapping_sub(1);
        (i < 64).then_some(i)
    })
}

/// The set bits of `mask`, highest first.
fn bits_down(mut mask: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        let i = 63_usize.wrapping_sub(mask.leading_zeros() as usize);
        mask &= !(1u64.wrapping_shl(i as u32));
        (i < 64).then_some(i)
    })
}

struct TreeBuilder<'a, V> {
    prims: &'a [Primitive],
    options: BuildOptions,
    parallel_min: usize,
    /// SAH bins, reused across nodes; all empty between nodes.
    bins: Box<Bins>,
    /// Scratch for the support points of a tight fit, reused across nodes.
    points: Vec<Vec3>,
    volume: PhantomData<V>,
}

impl<'a, V: BoundingVolume> TreeBuilder<'a, V> {
    fn new(prims: &'a [Primitive], options: &BuildOptions, parallel_min: usize) -> Self {
        TreeBuilder {
            prims,
            options: *options,
            parallel_min,
            bins: Bins::new(),
            points: Vec::new(),
            volume: PhantomData,
        }
    }

    /// Fold `refs` into one result, in parallel chunks merged in order
    /// when the range is long enough to pay for it; `merge` must make two
    /// adjacent chunks' results into that of both.
    fn fold<T: Send>(
        &self,
        refs: &[PrimRef],
        of: impl Fn(&[PrimRef]) -> T + Sync,
        merge: impl Fn(T, T) -> T + Sync,
    ) -> T {
        if refs.len() <= self.parallel_min {
            of(refs)
        } else {
            refs.par_chunks(self.parallel_min)
                .map(&of)
                .reduce_with(&merge)
                .expect("a long range has chunks")
        }
    }

    fn range_bounds(&self, refs: &[PrimRef]) -> RangeBounds {
        self.fold(refs, RangeBounds::of, RangeBounds::merge)
    }

    /// The volume of the primitives in `refs`, whose bounds are `geo`, with
    /// the configured fit.
    fn fit(&mut self, refs: &[PrimRef], geo: &RangeBounds) -> V {
        let b = geo.bounds.to_aabb();
        match self.options.fit {
            Fit::Box => V::from_bounds(&b),
            Fit::Points => {
                self.points.clear();
                for r in refs {
                    support_points(&self.prims[r.id() as usize], &r.bounds(), &mut self.points);
                }
                V::fit_points(&self.points, &b)
            }
        }
    }

    /// Turn `nodes[index]` (already holding its volume) over `refs`, the
    /// primitives from `offset` on in leaf order, whose bounds are `geo`,
    /// into a leaf or an interior node with two children, recursively.
    /// Children are appended to `nodes`.
    fn split(
        &mut self,
        nodes: &mut Vec<Node<V>>,
        index: usize,
        refs: &mut [PrimRef],
        offset: usize,
        geo: &RangeBounds,
        depth: u32,
    ) {
        let n = refs.len();
        // The traversal stack holds at most one entry per level: deeper
        // nodes become leaves whatever their size (only pathological inputs
        // get here; median splits reach depth log2(n)).
        let forced_leaf = n <= 1 || depth + 1 >= MAX_DEPTH;
        let mid = if forced_leaf {
            None
        } else {
            match self.options.builder {
                Builder::S3 => self.median_split(refs, geo, depth),
                Builder::Sah => self.sah_split(refs, geo),
            }
        };
        let Some(mid) = mid else {
            nodes[index].first = offset as u32;
            nodes[index].count = n as u32;
            return;
        };
        let (left, right) = refs.split_at_mut(mid);
        let (left_geo, right_geo) = (self.range_bounds(left), self.range_bounds(right));
        let first = nodes.len();
        let left_volume = self.fit(left, &left_geo);
        let right_volume = self.fit(right, &right_geo);
        nodes.push(Node::leaf(left_volume, 0, 0));
        nodes.push(Node::leaf(right_volume, 0, 0));
        nodes[index].first = first as u32;
        nodes[index].count = 0;
        if n <= self.parallel_min {
            self.split(nodes, first, left, offset, &left_geo, depth + 1);
            self.split(nodes, first + 1, right, offset + mid, &right_geo, depth + 1);
            return;
        }
        // The right subtree, built on the side: its root at index 0, its
        // descendants after it.
        let mut subtree = Vec::with_capacity(node_bound(right.len(), &self.options));
        subtree.push(nodes[first + 1]);
        let (prims, options, parallel_min) = (self.prims, self.options, self.parallel_min);
        rayon::join(
            || self.split(nodes, first, left, offset, &left_geo, depth + 1),
            || {
                TreeBuilder::new(prims, &options, parallel_min).split(
                    &mut subtree,
                    0,
                    right,
                    offset + mid,
                    &right_geo,
                    depth + 1,
                )
            },
        );
        append_subtree(nodes, first + 1, &subtree);
    }

    /// S3's builder: split at the median centroid along the longest axis of
    /// the centroid bounds (S3 says "of the node's bounds"; the centroid
    /// bounds are what the split actually divides, and they differ where
    /// large primitives overhang). Spheres take the axes in turn, as S3 does.
    ///
    /// We split at the median rather than the spatial midpoint: each child
    /// gets half the primitives, so the tree is balanced (depth ⌈log2(n/leaf)⌉)
    /// and the recursion always terminates, even when all centroids
    /// coincide, where a midpoint split would put everything on one side.
    ///
    /// Returns the size of the left part, or `None` for a leaf; so does
    /// [`Self::sah_split`].
    fn median_split(&self, refs: &mut [PrimRef], geo: &RangeBounds, depth: u32) -> Option<usize> {
        let n = refs.len();
        if n <= self.options.leaf_size as usize {
            return None;
        }
        let axis = if V::ROUND_ROBIN_AXES {
            depth as usize % 3
        } else {
            longest_axis(&geo.centroids.to_aabb())
        };
        let half = n / 2;
        refs.select_nth_unstable_by(half, |a, b| {
            a.centroid()[axis].total_cmp(&b.centroid()[axis])
        });
        Some(half)
    }

    /// Binned SAH (Wald, "On fast Construction of SAH-based Bounding Volume
    /// Hierarchies", 2007): drop the centroids into equal-width bins along
    /// each axis of the centroid bounds (all three axes in one pass) and
    /// evaluate the cost of splitting between every pair of adjacent bins,
    ///
    ///   C = C_trav + C_isect · (A_L·N_L + A_R·N_R) / A_P,
    ///
    /// where A is the surface area of the volume fitted (S3's fit) to each
    /// side's box, so the SAH weighs spheres as spheres and ellipsoids as
    /// ellipsoids. For the tight point fits this is an upper estimate: fitting
    /// points for every candidate would multiply the build cost by the number
    /// of bins. A leaf costs C_isect·N. The node becomes a leaf when it fits
    /// the leaf-size limit and no split is cheaper; larger nodes always split
    /// (at the list's middle when all centroids coincide).
    fn sah_split(&mut self, refs: &mut [PrimRef], geo: &RangeBounds) -> Option<usize> {
        let n = refs.len();
        let leaf_size = self.options.leaf_size as usize;
        let bins = (self.options.bins as usize).clamp(2, MAX_BINS);
        let binner = Binner::new(&geo.centroids, bins);
        let node_area = V::from_bounds(&geo.bounds.to_aabb()).surface_area();
        // A zero-area node (all primitives on one line or point) cannot rank
        // splits by area; any valid split is as good as another.
        let inv_area = if node_area > 0.0 {
            1.0 / node_area
        } else {
            0.0
        };
        let (c_trav, c_isect) = (self.options.traversal_cost, self.options.intersection_cost);

        let cost = |l: f32, r: f32| c_trav + c_isect * (l + r) * inv_area;
        let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, split bin)
        if binner.axes.contains(&true) {
            self.bin(refs, &binner);
            for axis in (0..3).filter(|&a| binner.axes[a]) {
                if let Some((c, split)) = self.bins.best_split::<V>(axis, cost) {
                    if best.map_or(true, |(b, _, _)| c < b) {
                        best = Some((c, axis, split));
                    }
                }
            }
            self.bins.empty();
        }

        let Some((cost, axis, split)) = best else {
            // All centroids coincide: nothing to bin.
            return (n > leaf_size).then_some(n / 2);
        };
        if n <= leaf_size && c_isect * n as f32 <= cost {
            return None;
        }
        // Swap each primitive that goes left with the first one not known
        // to, branch-free (one that stays writes both places back as they
        // were): the branch would be mispredicted about every other time.
        let split_at = Vec4::splat(split as f32);
        let mut left = 0;
        for j in 0..n {
            let r = refs[j];
            let goes_left = binner.below(r.centroid(), axis, split_at);
            let keep = refs[left];
            refs[left] = PrimRef(Box4::select(goes_left, r.0, keep.0));
            refs[j] = PrimRef(Box4::select(goes_left, keep.0, r.0));
            left += usize::from(goes_left);
        }
        // The partition recomputes the bins with the same arithmetic as the
        // binning, so both sides are non-empty as counted.
        debug_assert!(left > 0 && left < n);
        Some(left)
    }

    /// Fill `self.bins` with `refs`.
    fn bin(&mut self, refs: &[PrimRef], binner: &Binner) {
        if refs.len() <= self.parallel_min {
            self.bins.add(refs, binner);
        } else {
            let of = |chunk: &[PrimRef]| {
                let mut b = Bins::new();
                b.add(chunk, binner);
                b
            };
            self.bins = self.fold(refs, of, Bins::merge);
        }
    }
}

/// Put a subtree built in a vector of its own (its root at index 0, the
/// rest after it) in place: its root at `nodes[at]`, the rest appended,
/// with the child indices shifted by where they land.
fn append_subtree<V: Copy>(nodes: &mut Vec<Node<V>>, at: usize, subtree: &[Node<V>]) {
    // Index i ≥ 1 of the subtree lands at nodes.len() + i − 1; index 0 is
    // nobody's child.
    let shift = (nodes.len() - 1) as u32;
    let relocate = |mut node: Node<V>| {
        if !node.is_leaf() {
            node.first += shift;
        }
        node
    };
    nodes[at] = relocate(subtree[0]);
    nodes.extend(subtree[1..].iter().map(|&node| relocate(node)));
}

/// A side's term of the SAH sum: the surface area of the volume fitted to
/// its box times its number of primitives.
#[inline]
fn side_cost<V: BoundingVolume>(b: Box4, n: usize) -> f32 {
    V::from_bounds(&b.to_aabb()).surface_area() * n as f32
}

/// Axis of largest extent (x on ties).
fn longest_axis(b: &Aabb) -> usize {
    let e = b.extent();
    if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    }
}

/// Points whose convex hull contains the primitive: a triangle's vertices,
/// otherwise the 8 corners of its box.
fn support_points(prim: &Primitive, bounds: &Aabb, out: &mut Vec<Vec3>) {
    match &prim.shape {
        Shape::Triangle(t) => out.extend_from_slice(&t.p),
        _ => out.extend((0..8).map(|i| {
            Vec3::new(
                if i & 1 == 0 {
                    bounds.min.x
                } else {
                    bounds.max.x
                },
                if i & 2 == 0 {
                    bounds.min.y
                } else {
                    bounds.max.y
                },
                if i & 4 == 0 {
                    bounds.min.z
                } else {
                    bounds.max.z
                },
            )
        })),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::{BoundingEllipsoid, BoundingSphere};
    use crate::math::{Mat3, SplitMix64};
    use crate::shape::{Ellipsoid, Plane, Sphere, Triangle};

    fn prim(shape: Shape) -> Primitive {
        Primitive { shape, object: 0 }
    }

    /// `n` triangles of random sizes (up to a hundredth of the box) at
    /// random places in [−10, 10]³.
    fn triangles(seed: u64, n: usize) -> Vec<Primitive> {
        let mut rng = SplitMix64(seed);
        let b = Aabb {
            min: Vec3::splat(-10.0),
            max: Vec3::splat(10.0),
        };
        (0..n)
            .map(|_| {
                let p = rng.in_box(&b);
                let s = rng.range(0.001, 0.2);
                let q = p + s * rng.unit_vector();
                prim(Shape::Triangle(Triangle::new(
                    p,
                    q,
                    p + s * rng.unit_vector(),
                )))
            })
            .collect()
    }

    /// Triangles, spheres of very different radii, ellipsoids and a plane
    /// (unbounded: the build skips it).
    fn mixed(seed: u64, n: usize) -> Vec<Primitive> {
        let mut rng = SplitMix64(seed);
        let mut prims = triangles(seed, n / 3);
        for i in 0..n - n / 3 {
            let c = Vec3::new(
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
                rng.range(-1.0, 1.0),
            );
            prims.push(prim(if i % 2 == 0 {
                Shape::Sphere(Sphere::new(c, rng.range(0.001, 3.0)))
            } else {
                let radii = Vec3::new(
                    rng.range(0.1, 1.0),
                    rng.range(0.1, 1.0),
                    rng.range(0.1, 1.0),
                );
                Shape::Ellipsoid(Ellipsoid::new(c, radii, Mat3::IDENTITY))
            }));
        }
        prims.push(prim(Shape::Plane(Plane::new(Vec3::ZERO, Vec3::Y))));
        prims
    }

    /// Triangles whose coordinates are +0, −0 or ±0.5: which zero a box
    /// keeps depends on the order its primitives are folded in, so the
    /// chunked folds must keep the serial order's.
    fn signed_zeros(seed: u64, n: usize) -> Vec<Primitive> {
        let mut rng = SplitMix64(seed);
        let mut v = || Vec3::from_array([0; 3].map(|_| [0.0, -0.0, 0.5, -0.5][rng.below(4)]));
        (0..n)
            .map(|_| prim(Shape::Triangle(Triangle::new(v(), v(), v()))))
            .collect()
    }

    /// Build serially and with every range of more than 64 primitives
    /// split in parallel (so that even small inputs take the parallel
    /// paths), with both builders and both fits, and compare. The node
    /// arrays are compared through `Debug`, which prints every float
    /// exactly and −0 apart from +0: equal as numbers is not enough.
    fn assert_parallel_equals_serial<V: BoundingVolume>(prims: &[Primitive], what: &str) {
        let ids: Vec<u32> = (0..prims.len() as u32).collect();
        for builder in Builder::ALL {
            for fit in [Fit::Box, Fit::Points] {
                let options = BuildOptions {
                    builder,
                    fit,
                    ..BuildOptions::default()
                };
                let (serial_nodes, serial_indices) =
                    build_with::<V>(prims, &ids, &options, usize::MAX);
                let (nodes, indices) = build_with::<V>(prims, &ids, &options, 64);
                let case = format!("{what}, {} {builder:?} {fit:?}", V::NAME);
                assert_eq!(indices, serial_indices, "{case}: index order");
                assert_eq!(
                    format!("{nodes:?}"),
                    format!("{serial_nodes:?}"),
                    "{case}: nodes"
                );
            }
        }
    }

    #[test]
    fn parallel_build_equals_serial_build() {
        let same = prim(Shape::Triangle(Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y)));
        let cases = [
            ("20k random triangles", triangles(1, 20_000)),
            ("spheres, ellipsoids, triangles, a plane", mixed(2, 6_000)),
            ("signed zeros", signed_zeros(3, 5_000)),
            ("all centroids equal", vec![same; 3_000]),
            ("one primitive", triangles(4, 1)),
            ("no primitive", Vec::new()),
        ];
        for (what, prims) in &cases {
            assert_parallel_equals_serial::<Aabb>(prims, what);
            assert_parallel_equals_serial::<BoundingSphere>(prims, what);
            assert_parallel_equals_serial::<BoundingEllipsoid>(prims, what);
        }
    }
}
