//! Bounding volume hierarchies, generic over the bounding volume (S3's box,
//! sphere and ellipsoid, in [`volume`]) and the builder (S3's median split
//! or binned SAH, in [`build`]). A built [`Bvh`] is a flat array of
//! plain-old-data [`Node`]s plus a reordered array of primitive indices,
//! ready to upload to a GPU as is; [`traverse`] walks it with a loop and a
//! fixed-size stack. [`BvhConfig`] names a variant (`bvh:ellipsoid:s3`) so
//! scenes and the CLI can pick one; [`BvhStats`] describes a built tree.

pub mod build;
mod collapse;
mod inline;
pub mod node;
pub mod packet;
pub mod traverse;
pub mod volume;
pub mod wide;

pub use crate::math::Aabb;
pub use inline::InlineAvx2;
pub use node::{Node4, Node8, WideNode};
pub use volume::{BoundingEllipsoid, BoundingSphere, BoundingVolume};
pub use wide::{has_avx2, Bvh4, Bvh8, WideBvh};

use super::Accel;
use crate::error::ParseError;
use crate::shape::{PreparedRay, PrimArrays, PrimHit, Primitive};
use crate::stats::{NoStats, Stats};
use std::fmt;
use std::str::FromStr;
use std::time::Instant;

/// Deepest level a tree may have (the root is level 0), which is also the
/// size of the traversal stack. Median splits stay far below (2⁶⁴
/// primitives); SAH trees on pathological inputs are cut off here by
/// making leaves.
pub const MAX_DEPTH: u32 = 64;

/// One node of a flattened tree. Plain old data: a volume, two `u32`s, no
/// enum payloads or pointers (a box node is 32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node<V> {
    pub volume: V,
    /// Interior node: index of its first child; the second child is at
    /// `first + 1`. Leaf: index of its first primitive in [`Bvh::indices`].
    pub first: u32,
    /// Number of primitives of a leaf (at least 1); 0 marks an interior
    /// node.
    pub count: u32,
}

impl<V> Node<V> {
    fn leaf(volume: V, first: u32, count: u32) -> Self {
        Node {
            volume,
            first,
            count,
        }
    }

    /// Whether this node holds primitives rather than children.
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// Copies of the primitives `indices` names, in that (leaf) order.
fn leaf_order(prims: &[Primitive], indices: &[u32]) -> PrimArrays {
    PrimArrays::new(indices.iter().map(|&i| &prims[i as usize]))
}

/// A node as the traversal reads it: for an interior node, both children's
/// volumes (in the volume's [`BoundingVolume::Pair`] layout) with the index
/// of the first child, so that one visit reads one record (64 bytes for
/// boxes: one cache line) and tests both children together. Built from
/// [`Node`]s after the build, index for index; a leaf's pair is unused.
/// Aligned to 64 bytes so that a record never straddles two cache lines.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
pub struct Packed<V: BoundingVolume> {
    pub children: V::Pair,
    /// As [`Node::first`].
    pub first: u32,
    /// As [`Node::count`].
    pub count: u32,
}

fn pack<V: BoundingVolume>(nodes: &[Node<V>]) -> Vec<Packed<V>> {
    nodes
        .iter()
        .map(|n| {
            let (l, r) = if n.is_leaf() {
                (&n.volume, &n.volume)
            } else {
                let f = n.first as usize;
                (&nodes[f].volume, &nodes[f + 1].volume)
            };
            Packed {
                children: V::pair(l, r),
                first: n.first,
                count: n.count,
            }
        })
        .collect()
}

/// How a node's volume is fitted to its primitives.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Fit {
    /// S3's fit: derived from the axis-aligned box of the primitives.
    #[default]
    Box,
    /// The volume's tight fit over the primitives' support points (Ritter's
    /// sphere for spheres and ellipsoids; the same box for boxes).
    Points,
}

/// Which top-down builder splits the nodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Builder {
    /// S3's builder: median centroid split on the longest axis (axes in
    /// turn for spheres) until a node holds at most the leaf size.
    S3,
    /// Binned surface area heuristic.
    #[default]
    Sah,
}

/// Everything that steers a build.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildOptions {
    pub builder: Builder,
    pub fit: Fit,
    /// The most primitives a leaf may hold (S3's "preset number"); the SAH
    /// builder may stop earlier when splitting does not pay. Default 4.
    pub leaf_size: u32,
    /// SAH bins per axis (2..=64). Default 16: Wald (2007) finds 16–32 bins
    /// within a few percent of the full sweep.
    pub bins: u32,
    /// SAH cost of visiting an interior node (testing its children's
    /// volumes), in units of one primitive test. Default 1.
    pub traversal_cost: f32,
    /// SAH cost of one primitive test. Default 1. Equal costs are the usual
    /// textbook choice; measured costs belong in an experiment, not here.
    pub intersection_cost: f32,
    /// Primitives are tested in blocks of this many (a leaf packet's
    /// width): the SAH counts each side's primitives rounded up to whole
    /// blocks, since a packet with empty lanes costs a full one. Default 1.
    pub block: u32,
    /// Weight w of rays that start on the scene's surfaces in the wide
    /// trees' collapse: a box B under the root box R, over triangles of
    /// total area S, is priced A(B) + w·A(R)·S(B)/S instead of its area A(B),
    /// S(B) the area whose rays start inside B (module `collapse`). Default
    /// 0, the plain SAH; the binary build does not use it.
    pub surface_origins: f32,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            builder: Builder::Sah,
            fit: Fit::Box,
            leaf_size: DEFAULT_LEAF_SIZE,
            bins: 16,
            traversal_cost: 1.0,
            intersection_cost: 1.0,
            block: 1,
            surface_origins: 0.0,
        }
    }
}

impl BuildOptions {
    /// The SAH's count of `n` primitives: `n` rounded up to whole
    /// [`block`](Self::block)s.
    #[inline]
    pub fn counted(&self, n: usize) -> usize {
        n.next_multiple_of(self.block.max(1) as usize)
    }

    /// The options of the 8-wide tree (`bvh8`), whose leaves are one
    /// packet of up to eight triangles tested together (`bvh4` keeps the
    /// binary tree's leaves, so the two can be compared level for level):
    /// leaves of up to 8, the SAH counting triangles in whole packets of 8
    /// (`block`), and a triangle costing 0.6 of a binary node visit, a
    /// packet 4.8. Picked by measurement (`analysis/embree-speed.toml`'s
    /// rays on the five meshes, 1 thread, 2026-11-25): counting whole
    /// packets rather than single triangles (cost 0.3, the earlier choice)
    /// raised random rays by 4–13 %, shadow rays by 3–8 % and diffuse rays
    /// by 2–7 %, and cut the build by 10–30 %: a leaf of five triangles
    /// beside one of three costs two packet tests where one of eight costs
    /// one. Costs of 0.2–1.0 per triangle lay within a few percent of each
    /// other on the meshes; below 0.6 the Cornell box's 36 large triangles
    /// went into leaves of 8 with overlapping boxes (18 triangle tests per
    /// ray instead of 10.5, its path-traced render 5 % slower). Blocks of 4
    /// (half a packet) lost a few percent against counting single triangles.
    ///
    /// The collapse weighs rays born on the surfaces (`surface_origins` 1:
    /// starting inside a box counts as much as the SAH's chance of hitting
    /// it from outside), and small scenes get a second, finer candidate
    /// tree ([`WideBvh::build`]). On the Cornell box's path-traced
    /// render (64×64, 16 spp, 1 thread) the two cut the instructions by
    /// 11 % (callgrind: 441.0 M to 392.9 M; 2026-11-28); on the five meshes
    /// the surface term moved node visits per ray by −1 to 0 % and triangle
    /// tests by 0 to +0.3 %.
    pub fn wide() -> Self {
        BuildOptions {
            leaf_size: 8,
            intersection_cost: 0.6,
            block: 8,
            surface_origins: 1.0,
            ..BuildOptions::default()
        }
    }
}

/// Leaf size when a name does not give one.
pub const DEFAULT_LEAF_SIZE: u32 = 4;

/// A bounding volume hierarchy over bounded primitives.
#[derive(Clone, Debug)]
pub struct Bvh<V: BoundingVolume> {
    nodes: Vec<Node<V>>,
    /// `nodes` in the traversal's layout.
    packed: Vec<Packed<V>>,
    indices: Vec<u32>,
    /// Copies of the primitives in `indices` order, so that a leaf reads
    /// its primitives from one contiguous run rather than through the
    /// index array (one memory access instead of two dependent ones, for
    /// the price of a second copy of the primitives).
    leaf_prims: PrimArrays,
    options: BuildOptions,
    build_seconds: f64,
}

impl<V: BoundingVolume> Bvh<V> {
    /// Build over the primitives `ids` (indices into `prims`; unbounded
    /// ones are skipped).
    pub fn build(prims: &[Primitive], ids: Vec<u32>, options: BuildOptions) -> Self {
        let start = Instant::now();
        let (nodes, indices) = build::build(prims, ids, &options);
        // Two independent copies of what the build made: side by side.
        let (packed, leaf_prims) = rayon::join(|| pack(&nodes), || leaf_order(prims, &indices));
        Bvh {
            nodes,
            packed,
            indices,
            leaf_prims,
            options,
            build_seconds: start.elapsed().as_secs_f64(),
        }
    }

    /// What [`Self::build`] makes before it packs the nodes for traversal:
    /// the node array, the index array and the leaf-ordered primitives,
    /// for the wide trees collapsed from it (which never traverse the
    /// binary nodes, so packing them would be wasted).
    pub(super) fn build_parts(
        prims: &[Primitive],
        ids: Vec<u32>,
        options: &BuildOptions,
    ) -> (Vec<Node<V>>, Vec<u32>, PrimArrays) {
        let (nodes, indices) = build::build(prims, ids, options);
        let leaf_prims = leaf_order(prims, &indices);
        (nodes, indices, leaf_prims)
    }

    /// The flattened nodes; the root is `nodes()[0]` (empty for no
    /// primitives).
    pub fn nodes(&self) -> &[Node<V>] {
        &self.nodes
    }

    /// Primitive indices (into the scene's list) in leaf order.
    pub fn indices(&self) -> &[u32] {
        &self.indices
    }

    pub fn options(&self) -> &BuildOptions {
        &self.options
    }

    /// Shape and cost figures of the tree (walks it; not for hot paths).
    pub fn stats(&self, prims: &[Primitive]) -> BvhStats {
        let mut s = BvhStats {
            nodes: self.nodes.len(),
            memory_bytes: std::mem::size_of_val(self.nodes.as_slice())
                + std::mem::size_of_val(self.packed.as_slice())
                + std::mem::size_of_val(self.indices.as_slice())
                + self.leaf_prims.memory_bytes(),
            build_seconds: self.build_seconds,
            ..BvhStats::default()
        };
        let Some(root) = self.nodes.first() else {
            return s;
        };
        let root_area = root.volume.surface_area();
        let mut waste = Waste::default();
        let mut sah = 0.0f64;
        // Post-order over (node, depth), computing each node's content box
        // from its children's; `boxes` is indexed by node.
        let mut boxes = vec![Aabb::EMPTY; self.nodes.len()];
        let mut stack = vec![(0usize, 0usize, false)];
        while let Some((i, depth, children_done)) = stack.pop() {
            let n = &self.nodes[i];
            if !n.is_leaf() && !children_done {
                stack.push((i, depth, true));
                stack.push((n.first as usize, depth + 1, false));
                stack.push((n.first as usize + 1, depth + 1, false));
                continue;
            }
            s.max_depth = s.max_depth.max(depth);
            let weight = area_weight(n.volume.surface_area(), root_area);
            boxes[i] = if n.is_leaf() {
                s.leaves += 1;
                s.max_leaf_prims = s.max_leaf_prims.max(n.count as usize);
                let counted = self.options.counted(n.count as usize) as f64;
                sah += weight * counted * self.options.intersection_cost as f64;
                content_box(
                    prims,
                    &self.indices[n.first as usize..(n.first + n.count) as usize],
                )
            } else {
                sah += weight * self.options.traversal_cost as f64;
                boxes[n.first as usize].union(boxes[n.first as usize + 1])
            };
            waste.add(n.volume.surface_area(), n.volume.volume(), &boxes[i]);
        }
        s.mean_leaf_prims = self.indices.len() as f64 / s.leaves as f64;
        s.sah_cost = sah;
        waste.finish(&mut s);
        s
    }

    /// Test every ray of `rays` against the volumes of up to `max_nodes`
    /// nodes spread evenly over the tree (every k-th node of the flat
    /// array), as the traversal would (`t_max` = ∞, [`NoStats`]), and
    /// return (tests made, sum of the entry distances of the hits). The sum
    /// is a result the caller must consume (e.g. with
    /// [`std::hint::black_box`]) so the tests cannot be optimised away; it
    /// exists to time one bounding-volume test of this tree's own volumes,
    /// free of traversal bookkeeping and primitive tests.
    pub fn test_volumes(&self, rays: &[PreparedRay], max_nodes: usize) -> (u64, f64) {
        let stride = self.nodes.len().div_ceil(max_nodes.max(1)).max(1);
        let mut tests = 0u64;
        let mut sum = 0.0f64;
        for ray in rays {
            for node in self.nodes.iter().step_by(stride) {
                tests += 1;
                if let Some(t) = node.volume.hit(ray, f32::INFINITY, &mut NoStats) {
                    sum += t as f64;
                }
            }
        }
        (tests, sum)
    }
}

impl<V: BoundingVolume> Accel for Bvh<V> {
    #[inline]
    fn intersect<S: Stats>(
        &self,
        _prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> Option<(u32, PrimHit)> {
        let mut best = None;
        self.traverse::<S, false>(ray, t_max, &mut best, stats);
        best
    }

    #[inline]
    fn occluded<S: Stats>(
        &self,
        _prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> bool {
        self.traverse::<S, true>(ray, t_max, &mut None, stats)
    }
}

/// A node's share of the rays under the SAH: its surface area over the
/// root's (1 when the root has none).
pub(crate) fn area_weight(area: f32, root_area: f32) -> f64 {
    if root_area > 0.0 {
        f64::from(area / root_area)
    } else {
        1.0
    }
}

/// The box of the bounded primitives `ids` (a leaf's contents).
pub(crate) fn content_box(prims: &[Primitive], ids: &[u32]) -> Aabb {
    ids.iter()
        .filter_map(|&id| prims[id as usize].bounds())
        .fold(Aabb::EMPTY, Aabb::union)
}

/// The wasted-space sums behind [`BvhStats`]' ratios, node by node.
#[derive(Default)]
pub(crate) struct Waste {
    nodes: usize,
    area_ratio_sum: f64,
    volume_ratio_sum: f64,
    node_volume_sum: f64,
    content_volume_sum: f64,
    solid_nodes: usize,
}

impl Waste {
    /// A node whose volume has surface area `area` and volume `volume`,
    /// and whose contents fill `content`.
    pub(crate) fn add(&mut self, area: f32, volume: f32, content: &Aabb) {
        self.nodes += 1;
        let (a, v) = (content.surface_area(), content.volume());
        if a > 0.0 {
            self.area_ratio_sum += f64::from(area / a);
        }
        if v > 0.0 {
            self.volume_ratio_sum += f64::from(volume / v);
            self.node_volume_sum += f64::from(volume);
            self.content_volume_sum += f64::from(v);
            self.solid_nodes += 1;
        }
    }

    /// The three ratios of [`BvhStats`].
    pub(crate) fn finish(self, s: &mut BvhStats) {
        s.mean_area_ratio = self.area_ratio_sum / self.nodes as f64;
        s.mean_volume_ratio = if self.solid_nodes > 0 {
            self.volume_ratio_sum / self.solid_nodes as f64
        } else {
            f64::NAN
        };
        s.total_volume_ratio = if self.content_volume_sum > 0.0 {
            self.node_volume_sum / self.content_volume_sum
        } else {
            f64::NAN
        };
    }
}

/// Figures describing a built tree, for `raylab stats` and the experiments.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct BvhStats {
    /// All nodes, interior and leaves.
    pub nodes: usize,
    pub leaves: usize,
    /// Depth of the deepest leaf (the root is depth 0).
    pub max_depth: usize,
    pub mean_leaf_prims: f64,
    pub max_leaf_prims: usize,
    /// Bytes of the node array plus the index array.
    pub memory_bytes: usize,
    /// Expected cost per ray under the SAH model with the build's constants:
    /// Σ_interior C_trav·A(n)/A(root) + Σ_leaf C_isect·N(n)·A(n)/A(root),
    /// with A the surface area of each node's own volume.
    pub sah_cost: f64,
    pub build_seconds: f64,
    /// Wasted space: surface area of each node's volume over that of the
    /// box of its contents, averaged over nodes (1 for boxes; larger is
    /// looser). Nodes whose content box has zero area are left out.
    pub mean_area_ratio: f64,
    /// The same with volumes, averaged over nodes whose content box has a
    /// non-zero volume (flat leaves, such as one triangle, have none); NaN
    /// when there is none.
    pub mean_volume_ratio: f64,
    /// Wasted volume summed rather than averaged: Σ vol(node's volume) /
    /// Σ vol(box of its contents) over the same nodes. The mean weighs
    /// every node alike (so the many small leaves dominate); this ratio
    /// weighs nodes by size (so the big nodes near the root, which most
    /// rays test, dominate). NaN when no node has a solid content box.
    pub total_volume_ratio: f64,
}

/// The bounding volume kinds selectable by name, with their fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum VolumeKind {
    /// `aabb`: axis-aligned box.
    #[default]
    Aabb,
    /// `sphere`: S3's sphere around the box of the contents.
    Sphere,
    /// `sphere-ritter`: the tight sphere over the contents' points.
    SphereRitter,
    /// `ellipsoid`: S3's axis-aligned ellipsoid through the box's corners.
    Ellipsoid,
    /// `ellipsoid-ritter`: the tight axis-aligned ellipsoid.
    EllipsoidRitter,
}

impl VolumeKind {
    /// Every kind, in the order of the names in error messages.
    pub const ALL: [VolumeKind; 5] = [
        VolumeKind::Aabb,
        VolumeKind::Sphere,
        VolumeKind::SphereRitter,
        VolumeKind::Ellipsoid,
        VolumeKind::EllipsoidRitter,
    ];

    pub fn name(self) -> &'static str {
        match self {
            VolumeKind::Aabb => Aabb::NAME,
            VolumeKind::Sphere => BoundingSphere::NAME,
            VolumeKind::SphereRitter => "sphere-ritter",
            VolumeKind::Ellipsoid => BoundingEllipsoid::NAME,
            VolumeKind::EllipsoidRitter => "ellipsoid-ritter",
        }
    }

    /// How nodes of this kind are fitted.
    pub fn fit(self) -> Fit {
        match self {
            VolumeKind::SphereRitter | VolumeKind::EllipsoidRitter => Fit::Points,
            _ => Fit::Box,
        }
    }
}

impl Builder {
    pub const ALL: [Builder; 2] = [Builder::S3, Builder::Sah];

    pub fn name(self) -> &'static str {
        match self {
            Builder::S3 => "s3",
            Builder::Sah => "sah",
        }
    }
}

/// A named BVH variant: `bvh:<volume>:<builder>[:<leaf size>]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BvhConfig {
    pub volume: VolumeKind,
    pub builder: Builder,
    pub leaf_size: u32,
}

impl Default for BvhConfig {
    /// `bvh` = `bvh:aabb:sah:4`.
    fn default() -> Self {
        BvhConfig {
            volume: VolumeKind::Aabb,
            builder: Builder::Sah,
            leaf_size: DEFAULT_LEAF_SIZE,
        }
    }
}

impl BvhConfig {
    /// The build options this name stands for (other options default).
    pub fn options(&self) -> BuildOptions {
        BuildOptions {
            builder: self.builder,
            fit: self.volume.fit(),
            leaf_size: self.leaf_size,
            ..BuildOptions::default()
        }
    }

    /// Every volume × builder combination with the default leaf size.
    pub fn all() -> impl Iterator<Item = BvhConfig> {
        VolumeKind::ALL.into_iter().flat_map(|volume| {
            Builder::ALL.into_iter().map(move |builder| BvhConfig {
                volume,
                builder,
                leaf_size: DEFAULT_LEAF_SIZE,
            })
        })
    }
}

/// The grammar of binary-BVH names, for error messages.
pub const BVH_GRAMMAR: &str = "`bvh:<volume>[:<builder>[:<leaf size>]]` with <volume> one of \
     aabb, sphere, sphere-ritter, ellipsoid, ellipsoid-ritter, <builder> s3 (median split on the \
     longest axis) or sah (binned SAH, the default), <leaf size> 1–1000 (default 4); `bvh2` \
     means `bvh:aabb:sah`, the binary box tree";

impl FromStr for BvhConfig {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, ParseError> {
        let bad = |problem: String| ParseError::Malformed {
            what: "BVH name",
            given: s.to_string(),
            problem,
            expected: BVH_GRAMMAR,
        };
        match s {
            "bvh2" => return Ok(BvhConfig::default()),
            "bvh" => return Err(bad("plain `bvh` names the fastest tree, `bvh8`".into())),
            _ => {}
        }
        let mut parts = s.split(':');
        if parts.next() != Some("bvh") {
            return Err(bad("it does not start with `bvh:`".into()));
        }
        let mut config = BvhConfig::default();
        if let Some(v) = parts.next() {
            config.volume = VolumeKind::ALL
                .into_iter()
                .find(|k| k.name() == v)
                .ok_or_else(|| bad(format!("unknown volume `{v}`")))?;
        }
        if let Some(b) = parts.next() {
            config.builder = Builder::ALL
                .into_iter()
                .find(|k| k.name() == b)
                .ok_or_else(|| bad(format!("unknown builder `{b}`")))?;
        }
        if let Some(l) = parts.next() {
            config.leaf_size = l
                .parse()
                .ok()
                .filter(|n| (1..=1000).contains(n))
                .ok_or_else(|| bad(format!("leaf size `{l}` is not a number in 1–1000")))?;
        }
        if let Some(extra) = parts.next() {
            return Err(bad(format!("unexpected `{extra}`")));
        }
        Ok(config)
    }
}

impl fmt::Display for BvhConfig {
    /// The full name, with the leaf size only when it is not the default;
    /// it parses back to the same configuration.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "bvh:{}:{}", self.volume.name(), self.builder.name())?;
        if self.leaf_size != DEFAULT_LEAF_SIZE {
            write!(f, ":{}", self.leaf_size)?;
        }
        Ok(())
    }
}
