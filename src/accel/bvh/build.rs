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

use super::volume::BoundingVolume;
use super::{BuildOptions, Builder, Fit, Node, MAX_DEPTH};
use crate::math::Aabb;
use crate::math::Vec3;
use crate::shape::{Primitive, Shape};
use std::ops::Range;

/// Most bins the SAH builder accepts (the bin arrays live on the stack).
pub const MAX_BINS: usize = 64;

/// What the builder needs of a primitive: its id, box and box centre.
#[derive(Clone, Copy, Debug)]
struct PrimRef {
    id: u32,
    bounds: Aabb,
    centroid: Vec3,
}

/// Build the node array and the reordered primitive indices over `ids`
/// (indices into `prims`, all bounded).
pub(super) fn build<V: BoundingVolume>(
    prims: &[Primitive],
    ids: Vec<u32>,
    options: &BuildOptions,
) -> (Vec<Node<V>>, Vec<u32>) {
    let refs: Vec<PrimRef> = ids
        .into_iter()
        .filter_map(|id| {
            let bounds = prims[id as usize].bounds()?;
            Some(PrimRef {
                id,
                bounds,
                centroid: bounds.centre(),
            })
        })
        .collect();
    let mut b = TreeBuilder {
        prims,
        options: *options,
        refs,
        nodes: Vec::new(),
        points: Vec::new(),
    };
    let n = b.refs.len();
    if n > 0 {
        // Median splits give at most 2n/leaf − 1 nodes; reserve for that.
        b.nodes
            .reserve(2 * n.div_ceil(options.leaf_size.max(1) as usize));
        let root = b.fit(0..n);
        b.nodes.push(Node::leaf(root, 0, 0));
        b.split(0, 0..n, 0);
    }
    let indices = b.refs.iter().map(|r| r.id).collect();
    (b.nodes, indices)
}

struct TreeBuilder<'a, V> {
    prims: &'a [Primitive],
    options: BuildOptions,
    refs: Vec<PrimRef>,
    nodes: Vec<Node<V>>,
    /// Scratch for the support points of a tight fit, reused across nodes.
    points: Vec<Vec3>,
}

impl<V: BoundingVolume> TreeBuilder<'_, V> {
    /// Box of the primitives in a range.
    fn bounds(&self, range: Range<usize>) -> Aabb {
        self.refs[range]
            .iter()
            .fold(Aabb::EMPTY, |b, r| b.union(r.bounds))
    }

    /// The volume of the primitives in a range, with the configured fit.
    fn fit(&mut self, range: Range<usize>) -> V {
        let b = self.bounds(range.clone());
        match self.options.fit {
            Fit::Box => V::from_bounds(&b),
            Fit::Points => {
                self.points.clear();
                for r in &self.refs[range] {
                    support_points(&self.prims[r.id as usize], &r.bounds, &mut self.points);
                }
                V::fit_points(&self.points, &b)
            }
        }
    }

    /// Turn node `index` (already holding its volume) over `range` into a
    /// leaf or an interior node with two children, recursively.
    fn split(&mut self, index: usize, range: Range<usize>, depth: u32) {
        let n = range.len();
        // The traversal stack holds at most one entry per level: deeper
        // nodes become leaves whatever their size (only pathological inputs
        // get here; median splits reach depth log2(n)).
        let forced_leaf = n <= 1 || depth + 1 >= MAX_DEPTH;
        let mid = if forced_leaf {
            None
        } else {
            match self.options.builder {
                Builder::S3 => self.median_split(range.clone(), depth),
                Builder::Sah => self.sah_split(range.clone()),
            }
        };
        let Some(mid) = mid else {
            self.nodes[index].first = range.start as u32;
            self.nodes[index].count = n as u32;
            return;
        };
        let first = self.nodes.len();
        let left = self.fit(range.start..mid);
        let right = self.fit(mid..range.end);
        self.nodes.push(Node::leaf(left, 0, 0));
        self.nodes.push(Node::leaf(right, 0, 0));
        self.nodes[index].first = first as u32;
        self.nodes[index].count = 0;
        self.split(first, range.start..mid, depth + 1);
        self.split(first + 1, mid..range.end, depth + 1);
    }

    /// Centroid bounds of a range.
    fn centroid_bounds(&self, range: Range<usize>) -> Aabb {
        self.refs[range]
            .iter()
            .fold(Aabb::EMPTY, |b, r| b.include(r.centroid))
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
    fn median_split(&mut self, range: Range<usize>, depth: u32) -> Option<usize> {
        let n = range.len();
        if n <= self.options.leaf_size as usize {
            return None;
        }
        let axis = if V::ROUND_ROBIN_AXES {
            depth as usize % 3
        } else {
            longest_axis(&self.centroid_bounds(range.clone()))
        };
        let half = n / 2;
        self.refs[range.clone()]
            .select_nth_unstable_by(half, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
        Some(range.start + half)
    }

    /// Binned SAH (Wald, "On fast Construction of SAH-based Bounding Volume
    /// Hierarchies", 2007): drop the centroids into equal-width bins along
    /// each axis of the centroid bounds and evaluate the cost of splitting
    /// between every pair of adjacent bins,
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
    fn sah_split(&mut self, range: Range<usize>) -> Option<usize> {
        let n = range.len();
        let leaf_size = self.options.leaf_size as usize;
        let bins = (self.options.bins as usize).clamp(2, MAX_BINS);
        let cb = self.centroid_bounds(range.clone());
        let node_area = V::from_bounds(&self.bounds(range.clone())).surface_area();
        // A zero-area node (all primitives on one line or point) cannot rank
        // splits by area; any valid split is as good as another.
        let inv_area = if node_area > 0.0 {
            1.0 / node_area
        } else {
            0.0
        };
        let (c_trav, c_isect) = (self.options.traversal_cost, self.options.intersection_cost);

        let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, split bin)
        for axis in 0..3 {
            let Some(scale) = bin_scale(&cb, axis, bins) else {
                continue;
            };
            let mut count = [0usize; MAX_BINS];
            let mut boxes = [Aabb::EMPTY; MAX_BINS];
            for r in &self.refs[range.clone()] {
                let i = bin_index(r.centroid[axis], cb.min[axis], scale, bins);
                count[i] += 1;
                boxes[i] = boxes[i].union(r.bounds);
            }
            // Right-to-left sweep: area·count of bins i.. for each i.
            let mut right_cost = [0.0f32; MAX_BINS];
            let (mut acc_box, mut acc_n) = (Aabb::EMPTY, 0usize);
            for i in (1..bins).rev() {
                acc_box = acc_box.union(boxes[i]);
                acc_n += count[i];
                // (An empty side is never evaluated: see the split loop.)
                if acc_n > 0 {
                    right_cost[i] = V::from_bounds(&acc_box).surface_area() * acc_n as f32;
                }
            }
            let (mut acc_box, mut acc_n) = (Aabb::EMPTY, 0usize);
            for split in 1..bins {
                acc_box = acc_box.union(boxes[split - 1]);
                acc_n += count[split - 1];
                if acc_n == 0 || acc_n == n {
                    continue;
                }
                let left_cost = V::from_bounds(&acc_box).surface_area() * acc_n as f32;
                let cost = c_trav + c_isect * (left_cost + right_cost[split]) * inv_area;
                if best.map_or(true, |(c, _, _)| cost < c) {
                    best = Some((cost, axis, split));
                }
            }
        }

        let Some((cost, axis, split)) = best else {
            // All centroids coincide: nothing to bin.
            return (n > leaf_size).then_some(range.start + n / 2);
        };
        if n <= leaf_size && c_isect * n as f32 <= cost {
            return None;
        }
        let scale = bin_scale(&cb, axis, bins).expect("axis had a bin scale");
        let min = cb.min[axis];
        let slice = &mut self.refs[range.clone()];
        let mut left = 0;
        for j in 0..slice.len() {
            if bin_index(slice[j].centroid[axis], min, scale, bins) < split {
                slice.swap(left, j);
                left += 1;
            }
        }
        // The partition recomputes the bin indices with the same arithmetic
        // as the binning, so both sides are non-empty as counted.
        debug_assert!(left > 0 && left < n);
        Some(range.start + left)
    }
}

/// Bins per unit length along `axis`, or `None` when the centroid bounds
/// are flat (or not finite) along it.
fn bin_scale(cb: &Aabb, axis: usize, bins: usize) -> Option<f32> {
    let extent = cb.max[axis] - cb.min[axis];
    let scale = bins as f32 / extent;
    (extent > 0.0 && scale.is_finite()).then_some(scale)
}

/// The bin of a centroid coordinate; the top edge and rounding beyond it go
/// to the last bin (`as usize` saturates, and maps NaN to 0).
#[inline]
fn bin_index(c: f32, min: f32, scale: f32, bins: usize) -> usize {
    (((c - min) * scale) as usize).min(bins - 1)
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
