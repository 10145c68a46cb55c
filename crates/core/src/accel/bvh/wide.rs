//! Wide box BVHs: the binary SAH box tree collapsed so that each node
//! holds up to `W` children (4 for `bvh4`, 8 for `bvh8`), whose boxes are
//! stored transposed (one `W`-lane row per plane) and tested together, as
//! Embree's BVH4/BVH8 do; leaves of triangles are stored as packets of `W`
//! (a `bvh8` leaf of up to eight triangles is one packet) and tested
//! together ([`super::packet`]).
//!
//! Why: a binary tree makes a ray visit several times as many nodes as a
//! wide one, and each visit is a dependent memory load. Incoherent rays
//! (random, diffuse) miss the caches on most of those loads, so their cost
//! is set by the number of levels rather than by arithmetic; cutting the
//! levels is the main lever (see `analysis/embree-speed.toml`). The 8-wide
//! node test is one AVX2 instruction per operation of the slab test
//! ([`crate::math::slab8_avx2`]), chosen at build time when the CPU has
//! AVX2 (the tree keeps the [`Avx2`] token it detected, and the
//! traversal is compiled a second time for AVX2 and entered with it);
//! without it the same lanes go through two 4-wide tests
//! ([`crate::math::slab8`]).
//!
//! Collapse (module `collapse`): which binary nodes become wide nodes is
//! chosen to minimise the SAH cost of the wide tree. Leaves and their
//! primitives are the binary tree's, the box test is the one of [`Aabb::slab`] lane by lane
//! (bit-identical entry and exit distances) and the packet test is the
//! scalar triangle test lane by lane (bit-identical hits), so every ray
//! finds the same closest distance as with the binary tree (which of two
//! primitives at exactly the same distance wins may differ, as between any
//! two trees).
//!
//! Unused lanes hold an empty box at (+∞, +∞, +∞): its slab distances are
//! ±∞ on every axis, so with the node test's `t_max` capped at `f32::MAX`
//! it is never hit (a box of finite planes is never entered at +∞), and no
//! lane mask is needed. Their `first` and `count` are `u32::MAX`.
//!
//! Counting: one `node_visit` per wide node and per leaf whose contents are
//! examined, one box test per valid child box tested (and one for the
//! root's box), one triangle test per valid packet lane tested (per
//! triangle the scalar loop would have tested, for any-hit), other
//! primitives' tests as they count them. The counts of a ray are those of
//! the binary tree's convention applied to the wide layout.

use super::collapse::{Collapse, Ref};
use super::node::{ChildTest, WideNode};
use super::packet::{any_in_packets, closest_in_packets, TriPacket};
use super::traverse::{test_leaf, Pending};
use super::volume::BoundingVolume;
use super::{area_weight, content_box, BuildOptions, Bvh, BvhStats, Waste, MAX_DEPTH};
use crate::accel::Accel;
use crate::math::{Aabb, Avx2, Baseline, Isa};
use crate::shape::{PreparedRay, PrimArrays, PrimHit, Primitive};
use crate::stats::Stats;

/// A wide box BVH of arity `W`.
#[derive(Clone, Debug)]
pub struct WideBvh<const W: usize> {
    /// Box of everything (tested first), `None` for an empty tree.
    root_box: Option<Aabb>,
    /// Where traversal starts: the first wide node, or the single leaf.
    root: Ref,
    nodes: Vec<WideNode<W>>,
    indices: Vec<u32>,
    leaf_prims: PrimArrays,
    /// The leaves as packets of `W` triangles, when every primitive is a
    /// triangle (empty otherwise: leaves are then slot runs).
    packets: Vec<TriPacket<W>>,
    /// The proof that the CPU has AVX2, detected at build time, for the
    /// 8-wide tree (whose node test uses it); `None` otherwise.
    pub(super) avx2: Option<Avx2>,
    /// The options of the collapse's model, and of the binary build
    /// unless the fine candidate won (their SAH constants weigh
    /// [`WideBvh::stats`]' cost).
    options: BuildOptions,
    build_seconds: f64,
}

/// The most primitives for which [`WideBvh::build`] tries a second,
/// finer binary tree.
pub const FINE_BUILD_MAX: usize = 1024;

/// The 4-wide tree (`bvh4`).
pub type Bvh4 = WideBvh<4>;
/// The 8-wide tree (`bvh8`).
pub type Bvh8 = WideBvh<8>;

/// Whether this CPU runs the AVX2 node test ([`Avx2::detect`] finds a
/// token).
pub fn has_avx2() -> bool {
    Avx2::detect().is_some()
}

impl<const W: usize> WideBvh<W>
where
    WideNode<W>: ChildTest<W>,
{
    /// Build the binary box tree with `options` ([`BuildOptions::wide`] for
    /// `bvh8`, the defaults for `bvh4`) and collapse it. A scene of at most
    /// [`FINE_BUILD_MAX`] primitives whose options count packets
    /// (`block` > 1) also gets a second candidate, and keeps the one the
    /// collapse's model prices lower: the binary tree built down to leaves
    /// of two, counting single primitives, with the collapse choosing the
    /// leaves. Counting whole packets in the binary build pays on large
    /// meshes (fuller leaves), but on a small scene it distorts the upper
    /// splits (2 triangles beside 34 count as 8 beside 40) and fixes leaves
    /// the collapse cannot undo: in the Cornell box, one room-sized leaf of
    /// two walls and two block faces. On large meshes the fine tree took
    /// 1.4–2.3× Embree's build time against 0.8–1.6× (five meshes, one run
    /// each, 2026-11-28) and leaves emptier leaves (4.7 against 6.9
    /// triangles on the bunny), so it is not tried there.
    pub fn build(prims: &[Primitive], ids: Vec<u32>, options: BuildOptions) -> Self {
        let start = std::time::Instant::now();
        let fine = BuildOptions {
            leaf_size: options.leaf_size.min(2),
            block: 1,
            ..options
        };
        let try_fine = options.block > 1 && ids.len() <= FINE_BUILD_MAX;
        let fine_ids = try_fine.then(|| ids.clone());
        let mut tree = Self::collapsed(prims, ids, &options, &options);
        if let Some(ids) = fine_ids {
            let other = Self::collapsed(prims, ids, &fine, &options);
            if other.1 < tree.1 {
                tree = other;
            }
        }
        let mut tree = tree.0;
        tree.build_seconds = start.elapsed().as_secs_f64();
        tree
    }

    /// The binary tree built with `binary` and collapsed under `options`'
    /// model, with the model's cost.
    fn collapsed(
        prims: &[Primitive],
        ids: Vec<u32>,
        binary: &BuildOptions,
        options: &BuildOptions,
    ) -> (Self, f32) {
        let (bin, indices, leaf_prims) = Bvh::<Aabb>::build_parts(prims, ids, binary);
        let tris = leaf_prims.triangles_only().filter(|t| !t.is_empty());
        let mut c = Collapse::<W>::new(&bin, tris, options);
        let root = bin.first().map(|r| {
            if r.is_leaf() {
                c.leaf(r.first, r.count)
            } else {
                Ref {
                    first: c.node(0),
                    count: 0,
                }
            }
        });
        let (nodes, packets, cost) = (c.nodes, c.packets, c.cost);
        let tree = WideBvh {
            root_box: bin.first().map(|n| n.volume),
            root: root.unwrap_or(Ref { first: 0, count: 0 }),
            nodes,
            indices,
            leaf_prims,
            packets,
            avx2: Avx2::detect().filter(|_| W == 8),
            options: *options,
            build_seconds: 0.0,
        };
        (tree, cost)
    }

    /// The wide nodes (the first is the root unless the tree is one leaf).
    pub fn nodes(&self) -> &[WideNode<W>] {
        &self.nodes
    }

    /// The box of everything, tested before the root (`None` for an empty
    /// tree).
    pub fn root_box(&self) -> Option<Aabb> {
        self.root_box
    }

    /// Where traversal starts: (first, count), a wide node's index with
    /// count 0, or the single leaf.
    pub fn root(&self) -> (u32, u32) {
        (self.root.first, self.root.count)
    }

    /// The leaf-order slots of the leaf (`first`, `count`) of a node or of
    /// the root: for a packet tree `first` names a packet, otherwise it is
    /// the slot itself.
    pub fn leaf_slots(&self, first: u32, count: u32) -> std::ops::Range<u32> {
        let slot = if self.has_packets() {
            self.packets[first as usize].slot
        } else {
            first
        };
        slot..slot + count
    }

    /// Whether the leaves are packets of `W` triangles.
    pub fn has_packets(&self) -> bool {
        !self.packets.is_empty()
    }

    /// Whether the node test runs on AVX2.
    pub fn uses_avx2(&self) -> bool {
        self.avx2.is_some()
    }

    /// Primitive indices (into the scene's list) in leaf order.
    pub fn indices(&self) -> &[u32] {
        &self.indices
    }

    /// Seconds the build took (binary build plus collapse).
    pub fn build_seconds(&self) -> f64 {
        self.build_seconds
    }

    /// Bytes of the wide nodes, the index array, the leaf-ordered
    /// primitive copies and the packets.
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.indices.as_slice())
            + std::mem::size_of_val(self.packets.as_slice())
            + self.leaf_prims.memory_bytes()
    }

    /// Shape and cost figures of the tree, under the binary tree's
    /// definitions ([`BvhStats`]) with a wide node in place of a binary
    /// one: nodes are wide nodes plus leaves, depth counts wide levels, the
    /// SAH cost charges C_trav per wide node and C_isect per counted
    /// primitive of a leaf (the collapse's model), each weighted by the area
    /// of the box its parent stores for it over the root box's, and the
    /// wasted-space ratios compare each such box with the box of its
    /// contents. Walks the tree; not for hot paths.
    pub fn stats(&self, prims: &[Primitive]) -> BvhStats {
        let mut s = BvhStats {
            memory_bytes: self.memory_bytes(),
            build_seconds: self.build_seconds,
            ..BvhStats::default()
        };
        let Some(root_box) = self.root_box else {
            return s;
        };
        let mut walk = StatsWalk {
            tree: self,
            prims,
            root_area: root_box.surface_area(),
            stats: &mut s,
            waste: Waste::default(),
            sah: 0.0,
            prims_in_leaves: 0,
        };
        walk.visit(self.root, root_box, 0);
        let (waste, sah, in_leaves) = (walk.waste, walk.sah, walk.prims_in_leaves);
        s.sah_cost = sah;
        s.mean_leaf_prims = in_leaves as f64 / s.leaves as f64;
        waste.finish(&mut s);
        s
    }

    /// Test one leaf; see [`test_leaf`] for the contract.
    #[inline(always)]
    fn test_leaf<S: Stats, const ANY_HIT: bool, I: Isa>(
        &self,
        isa: I,
        leaf: Ref,
        ray: &PreparedRay,
        t_max: &mut f32,
        best: &mut Option<(u32, PrimHit)>,
        stats: &mut S,
    ) -> bool {
        if let Some(tris) = self
            .leaf_prims
            .triangles_only()
            .filter(|_| self.has_packets())
        {
            let first = leaf.first as usize;
            let packets = &self.packets[first..first + (leaf.count as usize).div_ceil(W)];
            if ANY_HIT {
                return any_in_packets(isa, packets, tris, ray, *t_max, stats);
            }
            closest_in_packets(isa, packets, tris, &self.indices, ray, t_max, best, stats);
            return false;
        }
        let range = leaf.first as usize..(leaf.first + leaf.count) as usize;
        test_leaf::<S, ANY_HIT>(
            &self.leaf_prims,
            &self.indices,
            range,
            ray,
            t_max,
            best,
            stats,
        )
    }

    /// The traversal, closest hit or (`ANY_HIT`) any hit; see the binary
    /// tree's [`Bvh::traverse`] for the contract. `isa` picks the node
    /// and packet tests' instructions.
    #[inline(always)]
    pub(super) fn traverse<S: Stats, const ANY_HIT: bool, I: Isa>(
        &self,
        isa: I,
        ray: &PreparedRay,
        mut t_max: f32,
        best: &mut Option<(u32, PrimHit)>,
        stats: &mut S,
    ) -> bool {
        let Some(root_box) = &self.root_box else {
            return false;
        };
        if root_box.hit(ray, t_max, stats).is_none() {
            return false;
        }
        // Each level pushes at most W − 1 siblings.
        let mut slots = Pending::<Ref, { 7 * MAX_DEPTH as usize }>::slots();
        let mut stack = Pending::new(&mut slots);
        let mut cur = self.root;
        loop {
            stats.node_visit();
            if cur.count > 0 {
                if self.test_leaf::<S, ANY_HIT, I>(isa, cur, ray, &mut t_max, best, stats) {
                    return true;
                }
            } else {
                let n = &self.nodes[cur.first as usize];
                if S::ENABLED {
                    let children = n.count.iter().filter(|&&c| c != u32::MAX).count();
                    stats.boxes_tested(children as u32);
                }
                // The cap keeps the empty lanes out (module doc).
                let (t, mut mask) = n.hit(isa, ray, t_max.min(f32::MAX));
                if mask != 0 {
                    // The hit children, nearest first, ties in child
                    // order: sorted as keys of the entry distance's bits
                    // above the child's index. The distances are ≥ 0,
                    // whose bits order as the numbers do once a −0 (which
                    // a node test's max with 0 may leave where SIMD is not
                    // used) has its sign bit cleared. Insertion sort.
                    let mut keys = [0u64; W];
                    let mut k = 0;
                    while mask != 0 {
                        let i = mask.trailing_zeros();
                        mask &= mask - 1;
                        let bits = t[i as usize].to_bits() & 0x7fff_ffff;
                        let key = u64::from(bits) << 32 | u64::from(i);
                        let mut j = k;
                        while j > 0 && keys[j - 1] > key {
                            keys[j] = keys[j - 1];
                            j -= 1;
                        }
                        keys[j] = key;
                        k += 1;
                    }
                    let child = |key: u64| {
                        let i = key as u32 as usize;
                        Ref {
                            first: n.first[i],
                            count: n.count[i],
                        }
                    };
                    // Push the farther ones, farthest first, and descend.
                    for &key in keys[1..k].iter().rev() {
                        stack.push(child(key), f32::from_bits((key >> 32) as u32));
                    }
                    cur = child(keys[0]);
                    continue;
                }
            }
            match stack.pop_live(t_max) {
                Some(next) => cur = next,
                None => return best.is_some(),
            }
        }
    }

    /// [`Self::traverse`] with the node test the CPU allows.
    #[inline(always)]
    fn query<S: Stats, const ANY_HIT: bool>(
        &self,
        ray: &PreparedRay,
        t_max: f32,
        best: &mut Option<(u32, PrimHit)>,
        stats: &mut S,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = self.avx2 {
            // SAFETY: `traverse_avx2` is compiled for AVX2, which `avx2`, a
            // token only `Avx2::detect` makes, proves this CPU has.
            return unsafe { traverse_avx2::<W, S, ANY_HIT>(avx2, self, ray, t_max, best, stats) };
        }
        self.traverse::<S, ANY_HIT, _>(Baseline, ray, t_max, best, stats)
    }
}

/// The recursion behind [`WideBvh::stats`].
struct StatsWalk<'a, const W: usize> {
    tree: &'a WideBvh<W>,
    prims: &'a [Primitive],
    root_area: f32,
    stats: &'a mut BvhStats,
    waste: Waste,
    sah: f64,
    prims_in_leaves: usize,
}

impl<const W: usize> StatsWalk<'_, W>
where
    WideNode<W>: ChildTest<W>,
{
    /// Tally the node or leaf `r`, whose parent stores `bounds` for it, at
    /// wide level `depth`, and return the box of its contents. Recursion
    /// is at most the tree's depth (below `MAX_DEPTH`).
    fn visit(&mut self, r: Ref, bounds: Aabb, depth: usize) -> Aabb {
        let (t, o) = (self.tree, &self.tree.options);
        self.stats.nodes += 1;
        self.stats.max_depth = self.stats.max_depth.max(depth);
        let weight = area_weight(bounds.surface_area(), self.root_area);
        let content = if r.count > 0 {
            let n = r.count as usize;
            self.stats.leaves += 1;
            self.stats.max_leaf_prims = self.stats.max_leaf_prims.max(n);
            self.prims_in_leaves += n;
            self.sah += weight * o.counted(n) as f64 * f64::from(o.intersection_cost);
            let slots = t.leaf_slots(r.first, r.count);
            content_box(
                self.prims,
                &t.indices[slots.start as usize..slots.end as usize],
            )
        } else {
            self.sah += weight * f64::from(o.traversal_cost);
            let n = t.nodes[r.first as usize];
            (0..W)
                .filter(|&i| n.count[i] != u32::MAX)
                .map(|i| {
                    let child = Ref {
                        first: n.first[i],
                        count: n.count[i],
                    };
                    self.visit(child, n.child_box(i), depth + 1)
                })
                .fold(Aabb::EMPTY, Aabb::union)
        };
        self.waste
            .add(bounds.surface_area(), bounds.volume(), &content);
        content
    }
}

/// The traversal compiled for AVX2, so that the 8-wide node test inlines
/// and the packets' lanes fill AVX registers. Safe to call from code
/// compiled for AVX2; from other code, only with the CPU's AVX2 proven
/// (`avx2`, which it also hands to the node and packet tests).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn traverse_avx2<const W: usize, S: Stats, const ANY_HIT: bool>(
    avx2: Avx2,
    bvh: &WideBvh<W>,
    ray: &PreparedRay,
    t_max: f32,
    best: &mut Option<(u32, PrimHit)>,
    stats: &mut S,
) -> bool
where
    WideNode<W>: ChildTest<W>,
{
    bvh.traverse::<S, ANY_HIT, _>(avx2, ray, t_max, best, stats)
}

impl<const W: usize> Accel for WideBvh<W>
where
    WideNode<W>: ChildTest<W>,
{
    #[inline]
    fn intersect<S: Stats>(
        &self,
        _prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> Option<(u32, PrimHit)> {
        let mut best = None;
        self.query::<S, false>(ray, t_max, &mut best, stats);
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
        self.query::<S, true>(ray, t_max, &mut None, stats)
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::shape::{Shape, Triangle};

    /// A strip of `n` small triangles along x.
    pub(in crate::accel::bvh) fn strip(n: usize) -> Vec<Primitive> {
        (0..n)
            .map(|i| {
                let x = i as f32;
                Primitive {
                    shape: Shape::Triangle(Triangle::new(
                        Vec3::new(x, 0.0, 0.0),
                        Vec3::new(x + 0.8, 0.0, 0.0),
                        Vec3::new(x, 0.8, (i % 3) as f32 * 0.1),
                    )),
                    object: 0,
                }
            })
            .collect()
    }

    /// Walk the wide trees: every child box contains its subtree's
    /// primitives, and every primitive is in exactly one leaf.
    #[test]
    fn collapse_keeps_every_leaf_once_under_boxes_that_contain_it() {
        // Below and above the size that gets a second, finer candidate.
        for n in [1000, 2000] {
            assert!((n <= FINE_BUILD_MAX) == (n == 1000));
            check_collapse::<4>(n);
            check_collapse::<8>(n);
        }
    }

    fn check_collapse<const W: usize>(n: usize)
    where
        WideNode<W>: ChildTest<W>,
    {
        let prims = strip(n);
        let ids: Vec<u32> = (0..prims.len() as u32).collect();
        let t = WideBvh::<W>::build(&prims, ids, BuildOptions::wide());
        assert!(t.has_packets());
        let mut seen = vec![0u32; prims.len()];
        let mut stack = vec![(t.root, t.root_box.unwrap())];
        let (mut wide_nodes, mut leaves) = (0, 0usize);
        while let Some((r, b)) = stack.pop() {
            if r.count > 0 {
                leaves += 1;
                for j in t.leaf_slots(r.first, r.count) {
                    let id = t.indices[j as usize];
                    seen[id as usize] += 1;
                    let pb = prims[id as usize].bounds().unwrap();
                    assert!(pb.min.cmpge(b.min).all() && pb.max.cmple(b.max).all());
                    assert_eq!(t.leaf_prims.bounds(j as usize), prims[id as usize].bounds());
                }
                continue;
            }
            wide_nodes += 1;
            let n = &t.nodes[r.first as usize];
            let children = n.count.iter().filter(|&&c| c != u32::MAX).count();
            assert!((2..=W).contains(&children));
            assert!(n.count[children..].iter().all(|&c| c == u32::MAX));
            for i in 0..children {
                let cb = n.child_box(i);
                assert!(cb.min.cmpge(b.min).all() && cb.max.cmple(b.max).all());
                let child = Ref {
                    first: n.first[i],
                    count: n.count[i],
                };
                stack.push((child, cb));
            }
        }
        assert!(seen.iter().all(|&k| k == 1));
        assert_eq!(wide_nodes, t.nodes.len());
        // The shape figures count the same tree; every stored box is its
        // contents' box, so no space is wasted.
        let st = t.stats(&prims);
        assert_eq!((st.nodes, st.leaves), (wide_nodes + leaves, leaves));
        assert!(st.max_leaf_prims <= 8 && st.max_depth >= 1);
        assert_eq!(st.mean_leaf_prims * leaves as f64, prims.len() as f64);
        assert_eq!((st.mean_area_ratio, st.total_volume_ratio), (1.0, 1.0));
        assert!(st.sah_cost > 0.0 && st.memory_bytes == t.memory_bytes());
        // L leaves need L − 1 binary interior nodes; collapsed to up to
        // W children a node, at least (L − 1)/(W − 1). A collapse that
        // opened nothing would keep L − 1.
        let n = t.nodes.len();
        assert!(
            (W - 1) * n >= leaves - 1 && n < (leaves - 1) / 2,
            "{n} nodes, {leaves} leaves"
        );
        // Every node has a parent slot but the root: n + leaves − 1
        // children. The strip's tree is balanced, so the collapse should
        // fill nodes (the greedy rule left 8-wide nodes half empty here).
        let mean = (n + leaves - 1) as f64 / n as f64;
        assert!(
            mean >= 0.9 * W as f64,
            "{mean} children a node, W = {W}, {leaves} leaves"
        );
    }
}
