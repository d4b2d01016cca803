//! Construction (feature `std`): obvhs builds a binary BVH, which is then
//! collapsed into our 4-wide layout.

use std::time::Duration;
use std::vec::Vec;

use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::ploc::{PlocSearchDistance, SortPrecision};
use obvhs::triangle::Triangle;

use super::Bvh;
use super::node::{MAX_DEPTH, Node4};
use crate::geometry::triangle::is_degenerate;

/// Largest leaf the binary builder may make (the 4-wide collapse keeps
/// leaves as they are, except when flattening at the depth limit).
const MAX_LEAF: u32 = 4;

/// A high-quality obvhs preset: obvhs' `slow_build` without spatial
/// pre-splits (they duplicate references and clip their boxes in rounded
/// arithmetic, which would make the boxes non-conservative), with leaves
/// sized for 4-wide traversal.
fn params() -> BvhBuildParams {
    BvhBuildParams {
        pre_split: false,
        ploc_search_distance: PlocSearchDistance::High,
        search_depth_threshold: 2,
        reinsertion_batch_ratio: 0.2,
        post_collapse_reinsertion_batch_ratio_multiplier: 2.0,
        sort_precision: SortPrecision::U128,
        max_prims_per_leaf: MAX_LEAF,
        collapse_traversal_cost: 3.0,
    }
}

pub(super) fn build(tris: &[[Vec3; 3]]) -> Bvh {
    assert!(
        tris.len() < u32::MAX as usize,
        "too many triangles for u32 primitive ids"
    );
    // Scene-global ids of the triangles that can be hit.
    let ids: Vec<u32> = (0..tris.len() as u32)
        .filter(|&i| {
            !is_degenerate(
                tris[i as usize][0],
                tris[i as usize][1],
                tris[i as usize][2],
            )
        })
        .collect();
    if ids.is_empty() {
        return Bvh::default();
    }
    let otris: Vec<Triangle> = ids
        .iter()
        .map(|&i| {
            let [v0, v1, v2] = tris[i as usize].map(Vec3A::from);
            Triangle { v0, v1, v2 }
        })
        .collect();
    let bvh2 = build_bvh2_from_tris(&otris, params(), &mut Duration::default());
    let mut c = Collapser {
        bvh2: &bvh2,
        tris,
        ids: &ids,
        nodes: Vec::new(),
        out_tris: Vec::with_capacity(ids.len()),
        out_ids: Vec::with_capacity(ids.len()),
    };
    c.collapse();
    let Collapser {
        mut nodes,
        out_tris,
        out_ids,
        ..
    } = c;
    super::node::refit(&mut nodes, &out_tris);
    Bvh::from_parts(nodes, out_tris, out_ids).expect("the builder produces valid layouts")
}

struct Collapser<'a> {
    bvh2: &'a Bvh2,
    /// Input triangles, scene-global order.
    tris: &'a [[Vec3; 3]],
    /// obvhs primitive index → scene-global id.
    ids: &'a [u32],
    nodes: Vec<Node4>,
    out_tris: Vec<[Vec3; 3]>,
    out_ids: Vec<u32>,
}

impl Collapser<'_> {
    /// Depth-first over the binary tree, turning every inner node into a
    /// [`Node4`] whose children are found by opening, while there are fewer
    /// than four, the inner child of largest surface area (the one most
    /// likely to be hit, per the SAH). Siblings get consecutive node
    /// indices, children always come after their parent, and triangles are
    /// stored in the order traversal reaches the leaves.
    fn collapse(&mut self) {
        let b = &self.bvh2.nodes;
        self.nodes.push(Node4::EMPTY);
        if b[0].is_leaf() {
            self.emit_leaf(0, 0, 0);
            return;
        }
        // (binary node, our node, level of our node; the root is level 1)
        let mut work = vec![(0usize, 0usize, 1usize)];
        while let Some((bn, n, level)) = work.pop() {
            let first = b[bn].first_index as usize;
            let mut kids = [first, first + 1, 0, 0];
            let mut k = 2;
            while k < 4 {
                let open = (0..k).filter(|&i| !b[kids[i]].is_leaf()).max_by(|&i, &j| {
                    b[kids[i]]
                        .aabb()
                        .half_area()
                        .total_cmp(&b[kids[j]].aabb().half_area())
                });
                let Some(i) = open else { break };
                let f = b[kids[i]].first_index as usize;
                kids[i] = f;
                kids[k] = f + 1;
                k += 1;
            }
            let mut pushed = Vec::new();
            for (slot, &kid) in kids[..k].iter().enumerate() {
                // Children of a node on the last allowed level must be
                // leaves: flatten whatever is below (pathological trees only).
                if b[kid].is_leaf() || level + 1 > MAX_DEPTH {
                    self.emit_leaf(kid, n, slot);
                } else {
                    let idx = self.nodes.len();
                    self.nodes.push(Node4::EMPTY);
                    self.nodes[n].child[slot] = idx as u32;
                    self.nodes[n].count[slot] = 0;
                    pushed.push((kid, idx, level + 1));
                }
            }
            work.extend(pushed.into_iter().rev());
        }
    }

    /// Stores all triangles under binary node `bn` as leaf slot `slot` of
    /// node `n`.
    fn emit_leaf(&mut self, bn: usize, n: usize, slot: usize) {
        let b = &self.bvh2.nodes;
        let first = self.out_tris.len();
        let mut stack = vec![bn];
        while let Some(i) = stack.pop() {
            let node = &b[i];
            if node.is_leaf() {
                let range =
                    node.first_index as usize..(node.first_index + node.prim_count) as usize;
                for &p in &self.bvh2.primitive_indices[range] {
                    let id = self.ids[p as usize];
                    self.out_tris.push(self.tris[id as usize]);
                    self.out_ids.push(id);
                }
            } else {
                stack.push(node.first_index as usize + 1);
                stack.push(node.first_index as usize);
            }
        }
        self.nodes[n].child[slot] = first as u32;
        self.nodes[n].count[slot] = (self.out_tris.len() - first) as u32;
    }
}
