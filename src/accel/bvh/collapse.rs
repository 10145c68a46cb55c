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
//!   a wide node. With k = 1 it is n itself as one child: a leaf costs
//!   C_isect·N·A(n), an interior node becomes a wide node, C_trav·A(n) plus
//!   its subtree as at most W children. With k ≥ 2 an interior node may
//!   instead be opened, its k slots shared between its two children:
//!   minⱼ best(left, j) + best(right, k − j).
//!
//! A is the box's surface area and C_trav, C_isect are the build's SAH
//! constants, so the collapse and the binary build optimise the same model.
//! O(nodes · W²) work. The binary tree's leaves are kept as they are (a
//! leaf's primitives stay one run), so hits are those of the binary tree.

use super::packet::TriPacket;
use super::wide::WideNode;
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
        // Children sit after their parent in the array: go backwards.
        for b in (0..bin.len()).rev() {
            let n = &bin[b];
            let area = n.volume.surface_area();
            if n.is_leaf() {
                best[b] = [o.intersection_cost * o.counted(n.count as usize) as f32 * area; W];
                continue;
            }
            let (l, r) = (n.first as usize, n.first as usize + 1);
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
            // As one child: a wide node over its opened subtree.
            let single = o.traversal_cost * area + open[W - 1].0;
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
