//! A 4-wide box BVH (`bvh4`): the binary SAH box tree collapsed so that
//! each node holds up to four children, whose boxes are stored transposed
//! (one 4-lane vector per plane) and tested together with 4-wide
//! operations, as Embree's BVH4/BVH8 do.
//!
//! Why: a binary tree makes a ray visit about twice as many nodes as a
//! 4-wide one, and each visit is a dependent memory load. Incoherent rays
//! (random, diffuse) miss the caches on most of those loads, so their cost
//! is set by the number of levels rather than by arithmetic; halving the
//! levels is the main lever (see `analysis/embree-speed.toml`).
//!
//! Collapse: starting from a binary node's two children, repeatedly replace
//! the interior child of largest surface area by its two children until
//! there are four or only leaves are left (the greedy rule of Wald et al.,
//! "Getting Rid of Packets", 2008). Leaves and their primitives are the
//! binary tree's and the box test is the one of [`Aabb::slab`] lane by lane
//! (bit-identical entry and exit distances), so every ray finds the same
//! closest distance as with the binary tree (which of two primitives at
//! exactly the same distance wins may differ, as between any two trees).
//!
//! Counting: one `node_visit` per wide node and per leaf whose contents are
//! examined, one box test per valid child box tested (and one for the
//! root's box), primitive tests as the primitives count them.

use super::traverse::{pop_live, test_leaf};
use super::volume::BoundingVolume;
use super::{BuildOptions, Bvh, MAX_DEPTH};
use crate::accel::Accel;
use crate::math::{slab4, Aabb};
use crate::shape::{PreparedRay, PrimArrays, PrimHit, Primitive};
use crate::stats::Stats;
use glam::Vec4;

/// One 4-wide node: the children's boxes transposed (lane i = child i),
/// then per child either a wide node index (`count == 0`) or a leaf's run
/// of primitives (`first`, `count`). Unused lanes have `valid` cleared.
/// 128 bytes: two cache lines.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
pub struct Node4 {
    pub min: [Vec4; 3],
    pub max: [Vec4; 3],
    pub first: [u32; 4],
    pub count: [u32; 4],
    /// Number of children (2..=4).
    pub children: u32,
}

/// A child reference: a wide node, or a leaf's run of primitives.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ref {
    first: u32,
    /// 0 for a wide node.
    count: u32,
}

/// The 4-wide box BVH.
#[derive(Clone, Debug)]
pub struct Bvh4 {
    /// Box of everything (tested first), `None` for an empty tree.
    root_box: Option<Aabb>,
    /// Where traversal starts: the first wide node, or the single leaf.
    root: Ref,
    nodes: Vec<Node4>,
    indices: Vec<u32>,
    leaf_prims: PrimArrays,
    build_seconds: f64,
}

impl Bvh4 {
    /// Build the binary box tree with `options` and collapse it.
    pub fn build(prims: &[Primitive], ids: Vec<u32>, options: BuildOptions) -> Self {
        let start = std::time::Instant::now();
        let binary = Bvh::<Aabb>::build(prims, ids, options);
        let (bin, indices, leaf_prims) = binary.into_parts();
        let mut out = Bvh4 {
            root_box: bin.first().map(|n| n.volume),
            root: Ref { first: 0, count: 0 },
            nodes: Vec::new(),
            indices,
            leaf_prims,
            build_seconds: 0.0,
        };
        if let Some(root) = bin.first() {
            out.root = if root.is_leaf() {
                Ref {
                    first: root.first,
                    count: root.count,
                }
            } else {
                Ref {
                    first: collapse(&bin, 0, &mut out.nodes),
                    count: 0,
                }
            };
        }
        out.build_seconds = start.elapsed().as_secs_f64();
        out
    }

    /// The wide nodes (the first is the root unless the tree is one leaf).
    pub fn nodes(&self) -> &[Node4] {
        &self.nodes
    }

    /// The box of everything, tested before the root (`None` for an empty
    /// tree).
    pub fn root_box(&self) -> Option<Aabb> {
        self.root_box
    }

    /// Where traversal starts: (first, count), a wide node's index with
    /// count 0, or the single leaf's run of primitives.
    pub fn root(&self) -> (u32, u32) {
        (self.root.first, self.root.count)
    }

    /// Primitive indices (into the scene's list) in leaf order.
    pub fn indices(&self) -> &[u32] {
        &self.indices
    }

    /// Seconds the build took (binary build plus collapse).
    pub fn build_seconds(&self) -> f64 {
        self.build_seconds
    }

    /// Bytes of the wide nodes, the index array and the leaf-ordered
    /// primitive copies.
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.indices.as_slice())
            + self.leaf_prims.memory_bytes()
    }

    /// Entry distances of the (up to four) children of `n`, lane by lane
    /// the slab test of [`Aabb::slab`]; the mask says which were hit.
    #[inline]
    fn hit4<S: Stats>(n: &Node4, ray: &PreparedRay, t_max: f32, stats: &mut S) -> (Vec4, u32) {
        for _ in 0..n.children {
            stats.box_test();
        }
        let (enter, mask) = slab4(&n.min, &n.max, ray.ray.origin, ray.inv_dir, t_max);
        let valid = (1u32 << n.children) - 1;
        (enter, mask & valid)
    }

    /// The traversal, closest hit or (`ANY_HIT`) any hit; see the binary
    /// tree's [`Bvh::traverse`] for the contract.
    #[inline]
    fn traverse<S: Stats, const ANY_HIT: bool>(
        &self,
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
        // Each level pushes at most three siblings.
        let mut stack = [(Ref { first: 0, count: 0 }, 0.0f32); 3 * MAX_DEPTH as usize];
        let mut depth = 0usize;
        let mut cur = self.root;
        loop {
            stats.node_visit();
            if cur.count > 0 {
                let range = cur.first as usize..(cur.first + cur.count) as usize;
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
                let n = &self.nodes[cur.first as usize];
                let (t, mut mask) = Self::hit4(n, ray, t_max, stats);
                if mask != 0 {
                    let t = t.to_array();
                    // The hit children, nearest first (insertion sort of at
                    // most four; ties keep child order).
                    let mut hits = [(Ref { first: 0, count: 0 }, 0.0f32); 4];
                    let mut k = 0;
                    while mask != 0 {
                        let i = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let item = (
                            Ref {
                                first: n.first[i],
                                count: n.count[i],
                            },
                            t[i],
                        );
                        let mut j = k;
                        while j > 0 && hits[j - 1].1 > item.1 {
                            hits[j] = hits[j - 1];
                            j -= 1;
                        }
                        hits[j] = item;
                        k += 1;
                    }
                    // Push the farther ones, farthest first, and descend.
                    for h in hits[1..k].iter().rev() {
                        stack[depth] = *h;
                        depth += 1;
                    }
                    cur = hits[0].0;
                    continue;
                }
            }
            match pop_live(&stack, &mut depth, t_max) {
                Some(next) => cur = next,
                None => return best.is_some(),
            }
        }
    }
}

/// Collapse the binary subtree at interior node `b` into wide nodes
/// appended to `out`; returns the index of its wide node.
fn collapse(bin: &[super::Node<Aabb>], b: usize, out: &mut Vec<Node4>) -> u32 {
    let n = &bin[b];
    let mut kids = vec![n.first as usize, n.first as usize + 1];
    while kids.len() < 4 {
        // The interior child of largest area, if any.
        let Some((pos, _)) = kids
            .iter()
            .enumerate()
            .filter(|(_, &k)| !bin[k].is_leaf())
            .map(|(p, &k)| (p, bin[k].volume.surface_area()))
            .max_by(|a, b| a.1.total_cmp(&b.1))
        else {
            break;
        };
        let k = kids.remove(pos);
        kids.insert(pos, bin[k].first as usize + 1);
        kids.insert(pos, bin[k].first as usize);
    }
    let me = out.len();
    out.push(Node4 {
        min: [Vec4::ZERO; 3],
        max: [Vec4::ZERO; 3],
        first: [0; 4],
        count: [0; 4],
        children: kids.len() as u32,
    });
    let mut node = out[me];
    let (mut min, mut max) = ([[0.0f32; 4]; 3], [[0.0f32; 4]; 3]);
    for (i, &k) in kids.iter().enumerate() {
        let c = &bin[k];
        for a in 0..3 {
            min[a][i] = c.volume.min[a];
            max[a][i] = c.volume.max[a];
        }
        if c.is_leaf() {
            node.first[i] = c.first;
            node.count[i] = c.count;
        } else {
            node.first[i] = collapse(bin, k, out);
            node.count[i] = 0;
        }
    }
    node.min = min.map(Vec4::from_array);
    node.max = max.map(Vec4::from_array);
    out[me] = node;
    me as u32
}

impl Accel for Bvh4 {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::BvhConfig;
    use crate::math::Vec3;
    use crate::shape::{Shape, Triangle};

    /// A strip of `n` small triangles along x.
    fn strip(n: usize) -> Vec<Primitive> {
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

    /// Walk the wide tree: every child box contains its subtree's
    /// primitives, and every primitive is in exactly one leaf.
    #[test]
    fn collapse_keeps_every_leaf_once_under_boxes_that_contain_it() {
        let prims = strip(1000);
        let ids: Vec<u32> = (0..prims.len() as u32).collect();
        let t = Bvh4::build(&prims, ids, BvhConfig::default().options());
        let mut seen = vec![0u32; prims.len()];
        let mut stack = vec![(t.root, t.root_box.unwrap())];
        let (mut wide_nodes, mut leaves) = (0, 0usize);
        while let Some((r, b)) = stack.pop() {
            if r.count > 0 {
                leaves += 1;
                for j in r.first..r.first + r.count {
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
            assert!((2..=4).contains(&n.children));
            for i in 0..n.children as usize {
                let cb = Aabb {
                    min: Vec3::new(n.min[0][i], n.min[1][i], n.min[2][i]),
                    max: Vec3::new(n.max[0][i], n.max[1][i], n.max[2][i]),
                };
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
        // L leaves need L − 1 binary interior nodes; collapsed to up to
        // four children a node, at least (L − 1)/3. A collapse that opened
        // nothing would keep L − 1.
        let n = t.nodes.len();
        assert!(
            3 * n >= leaves - 1 && n < (leaves - 1) / 2,
            "{n} nodes, {leaves} leaves"
        );
    }
}
