//! Collapsing a binary box tree into a `W`-wide one: which binary nodes
//! become wide nodes, and which become children of which.
//!
//! The greedy rule (open the child of largest area until the node is full;
//! Wald et al., "Getting Rid of Packets", 2008) fills the upper levels but
//! leaves a level of two-child nodes at the bottom wherever the binary
//! depth is not a multiple of log₂ W: an 8-wide tree of 256 leaves got 73
//! nodes with 4.5 children on average. Here the choice is the one of least
//! SAH cost, found by dynamic programming over the binary tree (the
//! formulation of Ylitie, Karras & Laine, "Efficient Incoherent Ray
//! Traversal on GPUs Through Compressed Wide BVHs", HPG 2017):
//!
//! - `best(n, k)`: the least cost of n's subtree as at most k children of
//!   a wide node. With k = 1 it is n itself as one child: a binary leaf
//!   costs C_isect·N·P(n); an interior node becomes either a wide node,
//!   C_trav·P(n) plus its subtree as at most W children, or, when its
//!   subtree holds at most `leaf_size` primitives, one leaf of all of them,
//!   C_isect·N·P(n) (Ylitie et al. choose leaves in the same programme, so
//!   a binary tree built down to small leaves lets the collapse pick the
//!   leaves that suit the wide layout). With k ≥ 2 an interior node may
//!   instead be opened, its k slots shared between its two children:
//!   minⱼ best(left, j) + best(right, k − j).
//!
//! N is counted in whole packets ([`BuildOptions::counted`]) and C_trav,
//! C_isect are the build's SAH constants, so the collapse and the binary
//! build optimise the same model. P(n), the weight of n's box B, is its
//! surface area A(B) plus, for a tree of triangles with
//! [`BuildOptions::surface_origins`] w > 0, a term for rays that start on
//! the scene's surfaces (every ray of a path tracer but the camera's):
//!
//!   P(B) = A(B) + w · A(R) · S(B) / S,
//!
//! R the root box, S the area of all the triangles and S(B) the area from
//! which a ray leaving the surface starts inside B. Divided by A(R), the
//! first term is the SAH's chance that a ray from outside R which hits R
//! also hits B; the second is w times the chance that a ray born at a
//! uniformly chosen point of the surfaces starts inside B, and so must
//! test B's contents whatever its direction, which the area does not see.
//! A triangle inside B counts whole; one lying in a face of B half (rays
//! leave it on both sides, and only those on B's side start inside); one
//! lying in a flat B not at all (a ray leaving it leaves B). The Cornell
//! box shows why: packet counting in the binary build put the back and
//! right walls and two block faces into one room-sized leaf, which rays
//! born on those walls and on the blocks start inside; priced this way,
//! each wall gets a flat leaf of its own.
//!
//! O(nodes · W²) work. Every leaf holds one run of the leaf order (a
//! binary leaf, or a binary subtree's leaves in order), so hits are those
//! of the binary tree.

use super::node::WideNode;
use super::packet::TriPacket;
use super::{BuildOptions, Node};
use crate::math::Aabb;
use crate::shape::Triangle;

/// A child reference: a wide node, or a leaf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Ref {
    pub(super) first: u32,
    /// 0 for a wide node.
    pub(super) count: u32,
}

/// The collapse of one binary box tree (and, for triangle trees, of its
/// leaves into packets).
pub(super) struct Collapse<'a, const W: usize> {
    bin: &'a [Node<Aabb>],
    /// The leaf-ordered triangles, when every primitive is one.
    tris: Option<&'a [Triangle]>,
    pub(super) nodes: Vec<WideNode<W>>,
    pub(super) packets: Vec<TriPacket<W>>,
    /// Per binary node and k − 1: how many of k slots an opened node gives
    /// its left child, 0 when it takes one slot itself.
    split: Vec<[u8; W]>,
    /// Per binary node: the leaf-order slots (first, count) of its subtree.
    span: Vec<(u32, u32)>,
    /// Per binary node: whether, as one child, it becomes one leaf.
    as_leaf: Vec<bool>,
    /// The model's cost of the whole wide tree (its root a wide node, or
    /// the one leaf).
    pub(super) cost: f32,
}

impl<'a, const W: usize> Collapse<'a, W> {
    /// Solve the dynamic programme of the module doc over `bin`.
    pub(super) fn new(
        bin: &'a [Node<Aabb>],
        tris: Option<&'a [Triangle]>,
        o: &BuildOptions,
    ) -> Self {
        let mut best = vec![[0.0f32; W]; bin.len()];
        let mut split = vec![[0u8; W]; bin.len()];
        let mut span = vec![(0u32, 0u32); bin.len()];
        let mut as_leaf = vec![false; bin.len()];
        let price = Price::new(bin.first().map(|r| r.volume), tris, o.surface_origins);
        let leaf_cost = |n: u32, p: f32| o.intersection_cost * o.counted(n as usize) as f32 * p;
        // Set at every node; the root (b = 0) comes last.
        let mut root_cost = 0.0;
        // Children sit after their parent in the array: go backwards.
        for b in (0..bin.len()).rev() {
            let n = &bin[b];
            if n.is_leaf() {
                span[b] = (n.first, n.count);
                best[b] = [leaf_cost(n.count, price.of(span[b], &n.volume)); W];
                root_cost = best[b][0];
                continue;
            }
            let (l, r) = (n.first as usize, n.first as usize + 1);
            // The builder lays a subtree's leaves out in order, left first.
            debug_assert_eq!(span[l].0 + span[l].1, span[r].0);
            span[b] = (span[l].0, span[l].1 + span[r].1);
            let p = price.of(span[b], &n.volume);
            // open[k − 1]: the best share of k slots between the children.
            let mut open = [(f32::INFINITY, 0u8); W];
            for k in 2..=W {
                for j in 1..k {
                    let c = best[l][j - 1] + best[r][k - j - 1];
                    if c < open[k - 1].0 {
                        open[k - 1] = (c, j as u8);
                    }
                }
            }
            // As one child: a wide node over its opened subtree, or a leaf.
            let node = o.traversal_cost * p + open[W - 1].0;
            root_cost = node;
            let mut single = node;
            if span[b].1 <= o.leaf_size {
                let leaf = leaf_cost(span[b].1, p);
                if leaf < node {
                    (single, as_leaf[b]) = (leaf, true);
                }
            }
            let (mut cost, mut choice) = (single, 0u8);
            best[b][0] = single;
            for k in 2..=W {
                if open[k - 1].0 < cost {
                    (cost, choice) = open[k - 1];
                }
                best[b][k - 1] = cost;
                split[b][k - 1] = choice;
            }
            // A wide node made of b always opens it: remember its share of
            // W slots in the k = 1 entry, which as a child is never opened.
            split[b][0] = open[W - 1].1;
        }
        Collapse {
            bin,
            tris,
            nodes: Vec::new(),
            packets: Vec::new(),
            split,
            span,
            as_leaf,
            cost: root_cost,
        }
    }

    /// The binary nodes that fill `k` slots for `b`'s subtree, appended to
    /// `out`.
    fn slots(&self, b: usize, k: usize, out: &mut Vec<usize>) {
        let j = if k == 1 {
            0
        } else {
            self.split[b][k - 1] as usize
        };
        if j == 0 {
            out.push(b);
            return;
        }
        let l = self.bin[b].first as usize;
        self.slots(l, j, out);
        self.slots(l + 1, k - j, out);
    }

    /// The reference of a binary leaf (slots `first..first + count`).
    pub(super) fn leaf(&mut self, first: u32, count: u32) -> Ref {
        let Some(tris) = self.tris else {
            return Ref { first, count };
        };
        let packet = self.packets.len() as u32;
        TriPacket::pack(tris, first as usize, count as usize, &mut self.packets);
        Ref {
            first: packet,
            count,
        }
    }

    /// Collapse the binary subtree at interior node `b` into wide nodes;
    /// returns the index of its wide node.
    pub(super) fn node(&mut self, b: usize) -> u32 {
        let bin = self.bin;
        let l = bin[b].first as usize;
        let j = self.split[b][0] as usize;
        let mut kids = Vec::with_capacity(W);
        self.slots(l, j, &mut kids);
        self.slots(l + 1, W - j, &mut kids);
        let me = self.nodes.len();
        let mut node = WideNode {
            min: [[f32::INFINITY; W]; 3],
            max: [[f32::INFINITY; W]; 3],
            first: [u32::MAX; W],
            count: [u32::MAX; W],
        };
        self.nodes.push(node);
        for (i, &k) in kids.iter().enumerate() {
            let c = &bin[k];
            for a in 0..3 {
                node.min[a][i] = c.volume.min[a];
                node.max[a][i] = c.volume.max[a];
            }
            let r = if c.is_leaf() {
                self.leaf(c.first, c.count)
            } else if self.as_leaf[k] {
                let (first, count) = self.span[k];
                self.leaf(first, count)
            } else {
                Ref {
                    first: self.node(k),
                    count: 0,
                }
            };
            node.first[i] = r.first;
            node.count[i] = r.count;
        }
        self.nodes[me] = node;
        me as u32
    }
}

/// The weight P(B) of a box in the collapse's cost (module doc).
struct Price {
    /// w · A(R) / S, 0 without the surface term.
    per_surface: f32,
    /// Prefix sums of the triangles' areas in leaf order (n + 1 entries).
    area_before: Vec<f64>,
    /// The triangles lying in an axis-aligned plane, in leaf order: (slot,
    /// axis, the plane's coordinate, area). Only they can lie on a box's
    /// face.
    flat: Vec<(u32, usize, f32, f32)>,
}

impl Price {
    fn new(root: Option<Aabb>, tris: Option<&[Triangle]>, surface_origins: f32) -> Self {
        let mut price = Price {
            per_surface: 0.0,
            area_before: Vec::new(),
            flat: Vec::new(),
        };
        let (Some(root), Some(tris)) = (root, tris) else {
            return price;
        };
        if surface_origins <= 0.0 {
            return price;
        }
        price.area_before.reserve(tris.len() + 1);
        price.area_before.push(0.0);
        let mut total = 0.0f64;
        for (slot, t) in tris.iter().enumerate() {
            let area = t.area();
            total += f64::from(area);
            price.area_before.push(total);
            if let Some(axis) = (0..3).find(|&a| t.p[0][a] == t.p[1][a] && t.p[0][a] == t.p[2][a]) {
                price.flat.push((slot as u32, axis, t.p[0][axis], area));
            }
        }
        let k = f64::from(surface_origins) * f64::from(root.surface_area()) / total;
        if k.is_finite() && k > 0.0 {
            price.per_surface = k as f32;
        }
        price
    }

    /// P of the box `b` over the leaf-order slots `span`.
    fn of(&self, (first, count): (u32, u32), b: &Aabb) -> f32 {
        let area = b.surface_area();
        if self.per_surface == 0.0 {
            return area;
        }
        let (lo, hi) = (first as usize, (first + count) as usize);
        let mut inside = self.area_before[hi] - self.area_before[lo];
        // A triangle on a face of the box starts half its rays (those
        // leaving on the box's side) inside; one in a flat box, none.
        let from = self.flat.partition_point(|f| (f.0 as usize) < lo);
        for &(_, axis, c, a) in self.flat[from..].iter().take_while(|f| (f.0 as usize) < hi) {
            let faces = u8::from(b.min[axis] == c) + u8::from(b.max[axis] == c);
            inside -= 0.5 * f64::from(faces) * f64::from(a);
        }
        area + self.per_surface * inside.max(0.0) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    fn cube(lo: f32, hi: f32) -> Aabb {
        Aabb {
            min: Vec3::splat(lo),
            max: Vec3::splat(hi),
        }
    }

    /// The surface term counts a triangle whole inside a box, half in one
    /// of its faces and not at all in a flat box; without a weight, or for
    /// primitives other than triangles, the price is the area.
    #[test]
    fn the_surface_term_counts_where_rays_leaving_a_triangle_start() {
        // `flat` lies in the plane y = 0 (area 1/2); `tilted` in no
        // axis-aligned plane (area √2/2).
        let flat = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Z);
        let tilted = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.0, 1.0));
        let tris = [flat, tilted];
        let s = 0.5 + 0.5 * 2f32.sqrt();
        let root = cube(0.0, 1.0);
        let price = Price::new(Some(root), Some(&tris), 1.0);
        let per = root.surface_area() / s;
        let near = |a: f32, b: f32| (a - b).abs() <= 1e-5 * b;
        // In the root's face y = 0: half of `flat`; `tilted` whole.
        assert!(near(price.of((0, 1), &root), 6.0 + per * 0.25));
        assert!(near(price.of((1, 1), &root), 6.0 + per * 0.5 * 2f32.sqrt()));
        assert!(near(
            price.of((0, 2), &root),
            6.0 + per * (0.25 + 0.5 * 2f32.sqrt())
        ));
        // Strictly inside a larger box: whole.
        let big = cube(-1.0, 1.0);
        assert!(near(price.of((0, 1), &big), 24.0 + per * 0.5));
        // `flat`'s own flat box: nothing starts inside it.
        let slab = Aabb {
            min: Vec3::ZERO,
            max: Vec3::new(1.0, 0.0, 1.0),
        };
        assert_eq!(price.of((0, 1), &slab), slab.surface_area());
        // No weight, or no triangles: the area alone.
        for plain in [
            Price::new(Some(root), Some(&tris), 0.0),
            Price::new(Some(root), None, 1.0),
        ] {
            assert_eq!(plain.of((0, 2), &big), big.surface_area());
        }
    }
}
