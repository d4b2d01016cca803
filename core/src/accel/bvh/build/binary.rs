//! The binary BVH both builders produce, before the collapse to 8-wide nodes.

use std::vec::Vec;

use glam::{DVec3, Vec3};

/// An axis-aligned box; the empty box is inverted. Stored in `f32` (the
/// input's precision, half the memory of a large build); areas are
/// computed in `f64`, where the extents of finite `f32` boxes and their
/// products cannot overflow.
#[derive(Clone, Copy, Debug)]
pub(super) struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    /// Grows the box to contain `b`.
    pub fn grow(&mut self, b: &Aabb) {
        self.min = self.min.min(b.min);
        self.max = self.max.max(b.max);
    }

    /// Half the surface area (the SAH only compares ratios); 0 for the
    /// empty box.
    pub fn half_area(&self) -> f64 {
        let d = (self.max.as_dvec3() - self.min.as_dvec3()).max(DVec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

/// A node of a [`BinaryTree`]. Inner nodes (`count == 0`) have their two
/// children at `first` and `first + 1`, always after the node itself;
/// leaves hold the `count > 0` triangles `order[first .. first + count]`.
#[derive(Clone, Copy, Debug)]
pub(super) struct BinNode {
    pub bounds: Aabb,
    pub first: u32,
    pub count: u32,
}

impl BinNode {
    pub const UNSET: BinNode = BinNode {
        bounds: Aabb::EMPTY,
        first: 0,
        count: 0,
    };

    /// Whether the node is a leaf.
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// A binary BVH over triangles `0..n` of the builder's input, root first.
/// `order` lists the triangles so that the triangles under any node are
/// one contiguous range of it (the collapse relies on that to emit a
/// subtree as one leaf).
pub(super) struct BinaryTree {
    pub nodes: Vec<BinNode>,
    pub order: Vec<u32>,
}

/// obvhs' binary tree, re-laid out so that every subtree's triangles are
/// contiguous in `order` (obvhs' own primitive order does not promise
/// that).
pub(super) fn from_obvhs(bvh2: &obvhs::bvh2::Bvh2) -> BinaryTree {
    let src = &bvh2.nodes;
    let mut nodes = vec![BinNode::UNSET];
    let mut order = Vec::with_capacity(bvh2.primitive_indices.len());
    // (obvhs node, our node), depth first, left child first.
    let mut work = vec![(0usize, 0usize)];
    while let Some((s, n)) = work.pop() {
        let sn = &src[s];
        nodes[n].bounds = Aabb {
            min: sn.aabb().min.into(),
            max: sn.aabb().max.into(),
        };
        if sn.is_leaf() {
            nodes[n].first = order.len() as u32;
            nodes[n].count = sn.prim_count;
            let r = sn.first_index as usize..(sn.first_index + sn.prim_count) as usize;
            order.extend_from_slice(&bvh2.primitive_indices[r]);
        } else {
            let first = nodes.len();
            nodes.extend([BinNode::UNSET; 2]);
            nodes[n].first = first as u32;
            work.push((sn.first_index as usize + 1, first + 1));
            work.push((sn.first_index as usize, first));
        }
    }
    BinaryTree { nodes, order }
}
