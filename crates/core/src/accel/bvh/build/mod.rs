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
//! array, so a node over more than `PARALLEL_MIN` primitives builds them
//! with `rayon::join`: the left subtree straight into the node array (it
//! starts where the serial build would start it), the right one into a
//! vector of its own, appended after the left subtree with its child indices
//! shifted by where it lands, which is where the serial build puts it.
//! Below the threshold a subtree is built by one thread (about a
//! millisecond of work at most). The passes over one range (bounds,
//! binning, partition) stay serial: binning the top levels' ranges in
//! parallel chunks measured no faster on two cores, the levels below
//! keeping both threads busy.
//!
//! The output does not depend on the number of threads: every node is
//! decided and fitted by the same floating-point operations on the same
//! primitives in the same order as in a serial build, so the node array and
//! the index order come out identical, bit for bit (tested below). It is
//! also the output of the single-threaded builder this one replaced, bit
//! for bit (compared on the CGAL meshes and on random inputs, every volume,
//! builder and fit, when this was written): the speed-ups of the serial
//! code (all three axes binned in one pass over 32-byte references, sweeps
//! over the occupied bins only, a branch-free partition) each keep every
//! operation that decides a split or makes a volume, and its order.
//!
//! The small helpers here are `#[inline]`: the generic tree code is
//! compiled in whichever codegen unit instantiates it, and calls helpers
//! that landed in another one instead of inlining them, which made the
//! build's speed change by 10–15% with unrelated edits elsewhere.

use super::volume::BoundingVolume;
use super::{BuildOptions, Builder, Fit, Node, MAX_DEPTH};
use crate::math::Aabb;
use crate::math::Vec3;
use crate::shape::{Primitive, Shape};
use glam::Vec4;
use std::marker::PhantomData;

mod bins;
use bins::{Binner, Bins, Box4, PrimRef, RangeBounds};

/// Most bins the SAH builder accepts.
pub const MAX_BINS: usize = 64;

/// Nodes over more primitives than this build their children's subtrees
/// in parallel; smaller ones are built by one thread. On the CGAL meshes
/// (20k–90k triangles) with two threads, every value from 512 to 16384
/// built within the noise of the others: work stealing balances the
/// tasks whatever their number (a 20k-triangle tree has about a dozen
/// nodes over 4096).
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

/// [`build`] with the subtrees of nodes over more than `parallel_min`
/// primitives built in parallel; `usize::MAX` builds on the calling thread
/// alone.
fn build_with<V: BoundingVolume>(
    prims: &[Primitive],
    ids: &[u32],
    options: &BuildOptions,
    parallel_min: usize,
) -> (Vec<Node<V>>, Vec<u32>) {
    let mut refs = Vec::with_capacity(ids.len());
    refs.extend(
        ids.iter()
            .filter_map(|&id| Some(PrimRef::new(id, &prims[id as usize].bounds()?))),
    );
    let mut nodes = Vec::new();
    if !refs.is_empty() {
        nodes.reserve(node_bound(refs.len(), options));
        let mut b = TreeBuilder::<V>::new(prims, options, parallel_min);
        let geo = RangeBounds::of(&refs);
        nodes.push(Node::leaf(b.fit(&refs, &geo), 0, 0));
        b.split(&mut nodes, 0, &mut refs, 0, &geo, 0);
    }
    (nodes, refs.iter().map(PrimRef::id).collect())
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
        let (left_geo, right_geo) = (RangeBounds::of(left), RangeBounds::of(right));
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
            self.bins.add(refs, &binner);
            for axis in (0..3).filter(|&a| binner.axes[a]) {
                if let Some((c, split)) =
                    self.bins
                        .best_split::<V>(axis, |n| self.options.counted(n), cost)
                {
                    if best.is_none_or(|(b, _, _)| c < b) {
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
        if n <= leaf_size && c_isect * self.options.counted(n) as f32 <= cost {
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

/// Axis of largest extent (x on ties).
#[inline]
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
        _ => out.extend((0..8).map(|i| bounds.corner(i))),
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
    /// keeps depends on the order its primitives are folded in, which must
    /// be the serial build's.
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
            for (fit, block) in [(Fit::Box, 1), (Fit::Points, 1), (Fit::Box, 8)] {
                let options = BuildOptions {
                    builder,
                    fit,
                    block,
                    ..BuildOptions::default()
                };
                let (serial_nodes, serial_indices) =
                    build_with::<V>(prims, &ids, &options, usize::MAX);
                let (nodes, indices) = build_with::<V>(prims, &ids, &options, 64);
                let case = format!("{what}, {} {builder:?} {fit:?} block {block}", V::NAME);
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
