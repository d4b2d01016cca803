//! Collapse of a binary tree into wide nodes ([`WIDTH`] slots), choosing
//! which binary subtrees become leaves, inner nodes, or are merged into
//! their parent's node so that the tree's SAH cost is least.
//!
//! The cost of a wide tree is `Σ_nodes A(n)·C_node + Σ_leaves A(l)·
//! (C_leaf·⌈k/4⌉ + C_tri·k)` over box half-areas `A` (proportional to the
//! chance that a ray through the root meets the box). Dynamic programming
//! over the binary tree, bottom up, finds the cheapest cover of every
//! binary subtree by at most `j ≤ WIDTH` slots, as in Ylitie et al. 2017
//! ("Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide
//! BVHs", section 4.1) for 8-wide nodes. Greedily opening the largest child
//! (what an earlier version did) left 40% of the nodes with two children
//! on the benchmark mesh, because two leaves of a binary node cannot be
//! opened; here leaves are cut where the SAH wants them.

use std::vec::Vec;

use glam::Vec3;

use super::binary::BinaryTree;
use crate::accel::bvh::node::{MAX_DEPTH, Node, WIDTH};

/// Relative costs, per unit of box area, of visiting a node (one box
/// test of all its slots), of a leaf's set-up and 4-wide triangle test
/// per group of up to four triangles (one block), and of each triangle (`build::COSTS` gives the values
/// used and how they were chosen).
#[derive(Clone, Copy, Debug)]
pub(super) struct Costs {
    pub node: f64,
    pub leaf: f64,
    pub tri: f64,
    /// Largest leaf the collapse makes (a binary subtree with more
    /// triangles is split into further slots).
    pub max_leaf: u32,
}

impl Costs {
    /// The cost of a leaf of `k` triangles, per unit of its box's area.
    pub fn leaf_of(&self, k: u32) -> f64 {
        let k = f64::from(k);
        self.leaf * (k / 4.0).ceil() + self.tri * k
    }
}

/// What covering one binary subtree costs with at most `j` slots, `j` =
/// 1..=WIDTH (index 0 unused), and how: `split[j] == 0` makes the subtree one
/// slot, `split[j] == l > 0` gives `l` slots to the left child's cover and
/// `j − l` to the right child's.
///
/// Costs are relative to the root's area (so at most about the triangle
/// count times the leaf cost) and stored in `f32`, rounded once per node:
/// 48 bytes per binary node instead of 84 in `f64`, which is most of a large
/// build's peak memory. Sums are formed in `f64`.
#[derive(Clone, Copy)]
struct Cover {
    cost: [f32; WIDTH + 1],
    split: [u8; WIDTH + 1],
}

/// A collapsed tree: what [`super::super::Bvh::from_parts`] takes, plus the
/// tree's SAH cost.
pub(super) struct Wide {
    /// Root first, children after parents; boxes are left empty for
    /// `node::refit` to compute from the stored triangles.
    pub nodes: Vec<Node>,
    /// Triangles in leaf order.
    pub tris: Vec<[Vec3; 3]>,
    /// Scene-global id of each of `tris`.
    pub ids: Vec<u32>,
    /// The SAH cost (see the module docs) relative to the root box's area:
    /// the expected cost of a ray that meets the root, if rays were spread
    /// uniformly.
    pub cost: f64,
}

/// The cheapest wide layout of `tree` under `costs`, over `tris` (the
/// builder's input; `ids[k]` is the scene-global id of `tris[k]`).
pub(super) fn collapse(tree: &BinaryTree, tris: &[[Vec3; 3]], ids: &[u32], costs: Costs) -> Wide {
    let b = &tree.nodes;
    let n = b.len();
    // Triangles under each binary node, and where their range starts in
    // `tree.order` (the builder partitions in place, so a subtree's
    // triangles are contiguous). Children come after parents, so a
    // reverse sweep is bottom up.
    let mut prims = vec![0u32; n];
    let mut start = vec![0u32; n];
    let root_area = b[0].bounds.half_area();
    // Areas relative to the root's. The root's area is positive (a
    // non-degenerate triangle's box has two non-zero extents); the guard
    // keeps a zero from turning every cost into NaN.
    let scale = if root_area > 0.0 {
        1.0 / root_area
    } else {
        1.0
    };
    let mut cover = vec![
        Cover {
            cost: [0.0; WIDTH + 1],
            split: [0; WIDTH + 1],
        };
        n
    ];
    // Whether the subtree's single slot is a leaf (else a wide node).
    let mut slot_leaf = vec![false; n];
    // Slots given to the left child when the subtree is a wide node.
    let mut node_split = vec![0u8; n];
    for i in (0..n).rev() {
        let node = &b[i];
        let area = node.bounds.half_area() * scale;
        let (l, r) = (node.first as usize, node.first as usize + 1);
        if node.is_leaf() {
            prims[i] = node.count;
            start[i] = node.first;
        } else {
            prims[i] = prims[l] + prims[r];
            start[i] = start[l];
        }
        // The cheapest split of `j` = 2..=WIDTH slots between the two
        // children's covers (the first on a tie); `j = WIDTH` is what the
        // subtree costs as a wide node, below the node itself.
        let mut pair = [(f64::INFINITY, 0u8); WIDTH + 1];
        if !node.is_leaf() {
            for (j, best) in pair.iter_mut().enumerate().skip(2) {
                for s in 1..j {
                    let c = f64::from(cover[l].cost[s]) + f64::from(cover[r].cost[j - s]);
                    if c < best.0 {
                        *best = (c, s as u8);
                    }
                }
            }
        }
        let leaf_cost =
            (prims[i] <= costs.max_leaf || node.is_leaf()).then(|| area * costs.leaf_of(prims[i]));
        let node_cost = (!node.is_leaf()).then(|| {
            node_split[i] = pair[WIDTH].1;
            area * costs.node + pair[WIDTH].0
        });
        let slot = match (leaf_cost, node_cost) {
            (Some(leaf), Some(inner)) if leaf <= inner => {
                slot_leaf[i] = true;
                leaf
            }
            (_, Some(inner)) => inner,
            (Some(leaf), None) => {
                slot_leaf[i] = true;
                leaf
            }
            (None, None) => unreachable!("a binary leaf can always be a leaf"),
        };
        let mut cost = [slot; WIDTH + 1];
        let mut split = [0u8; WIDTH + 1];
        for j in 2..=WIDTH {
            if pair[j].0 < slot {
                (cost[j], split[j]) = pair[j];
            }
        }
        cover[i] = Cover {
            cost: cost.map(|c| c as f32),
            split,
        };
    }

    let mut nodes = vec![Node::EMPTY];
    let mut out_tris = Vec::with_capacity(tree.order.len());
    let mut out_ids = Vec::with_capacity(tree.order.len());
    let mut emit_leaf = |i: usize, node: &mut Node, slot: usize| {
        node.child[slot] = out_tris.len() as u32;
        node.count[slot] = prims[i];
        let range = start[i] as usize..(start[i] + prims[i]) as usize;
        for &k in &tree.order[range] {
            out_tris.push(tris[k as usize]);
            out_ids.push(ids[k as usize]);
        }
    };
    let cost = f64::from(cover[0].cost[1]);
    if slot_leaf[0] {
        emit_leaf(0, &mut nodes[0], 0);
        return Wide {
            nodes,
            tris: out_tris,
            ids: out_ids,
            cost,
        };
    }
    // (binary node, our node, level of our node; the root is level 1)
    let mut work = vec![(0usize, 0usize, 1usize)];
    while let Some((i, our, level)) = work.pop() {
        let l = b[i].first as usize;
        let s = node_split[i] as usize;
        let mut slots = [0usize; WIDTH];
        let mut k = 0;
        // Unfold the covers of both children into at most WIDTH slots.
        let mut pending = [(0usize, 0usize); WIDTH];
        let mut top = 0;
        pending[top] = (l + 1, WIDTH - s);
        pending[top + 1] = (l, s);
        top += 2;
        while top > 0 {
            top -= 1;
            let (c, j) = pending[top];
            let sp = cover[c].split[j] as usize;
            if sp == 0 {
                slots[k] = c;
                k += 1;
            } else {
                let cl = b[c].first as usize;
                pending[top] = (cl + 1, j - sp);
                pending[top + 1] = (cl, sp);
                top += 2;
            }
        }
        let mut pushed = [(0usize, 0usize, 0usize); WIDTH];
        let mut np = 0;
        for (slot, &c) in slots[..k].iter().enumerate() {
            // Children of a node on the last allowed level must be
            // leaves: flatten whatever is below (pathological trees only).
            if slot_leaf[c] || level + 1 > MAX_DEPTH {
                emit_leaf(c, &mut nodes[our], slot);
            } else {
                let idx = nodes.len();
                nodes.push(Node::EMPTY);
                nodes[our].child[slot] = idx as u32;
                nodes[our].count[slot] = 0;
                pushed[np] = (c, idx, level + 1);
                np += 1;
            }
        }
        work.extend(pushed[..np].iter().rev());
    }
    Wide {
        nodes,
        tris: out_tris,
        ids: out_ids,
        cost,
    }
}

#[cfg(test)]
mod tests {
    use super::super::binary::Aabb;
    use super::super::{binned_sah, ploc};
    use super::*;
    use crate::accel::bvh::node::EMPTY_CHILD;

    fn soup(n: usize, seed: u64) -> Vec<[Vec3; 3]> {
        let mut s = seed;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n)
            .map(|_| {
                let c = Vec3::new(next(), next(), next()) * 10.0;
                let size = 0.05 + next() * next() * 3.0;
                [0; 3].map(|_| c + (Vec3::new(next(), next(), next()) - 0.5) * size)
            })
            .collect()
    }

    fn bounds<'a>(tris: impl IntoIterator<Item = &'a [Vec3; 3]>) -> Aabb {
        let mut b = Aabb::EMPTY;
        for &v in tris.into_iter().flatten() {
            b.grow(&Aabb { min: v, max: v });
        }
        b
    }

    /// The SAH cost of an emitted layout, from its triangles alone.
    fn layout_cost(w: &Wide, costs: Costs) -> f64 {
        fn node_cost(w: &Wide, n: usize, costs: Costs) -> (f64, Aabb) {
            let node = &w.nodes[n];
            let (mut sum, mut b) = (0.0, Aabb::EMPTY);
            for c in 0..WIDTH {
                if node.is_leaf(c) {
                    let first = node.child[c] as usize;
                    let k = node.count[c];
                    let lb = bounds(&w.tris[first..first + k as usize]);
                    sum += lb.half_area() * costs.leaf_of(k);
                    b.grow(&lb);
                } else if node.child[c] != EMPTY_CHILD {
                    let (s, cb) = node_cost(w, node.child[c] as usize, costs);
                    sum += s;
                    b.grow(&cb);
                }
            }
            let inner = (0..WIDTH).any(|c| node.is_inner(c))
                || (0..WIDTH).filter(|&c| !node.is_empty(c)).count() > 1;
            // A root holding one leaf is that leaf, not a node.
            let own = if n == 0 && !inner {
                0.0
            } else {
                b.half_area() * costs.node
            };
            (sum + own, b)
        }
        let (c, b) = node_cost(w, 0, costs);
        c / b.half_area()
    }

    /// Every triangle once, ids matching, leaves no larger than allowed.
    fn check_cover(w: &Wide, tris: &[[Vec3; 3]], ids: &[u32], costs: Costs) {
        let mut seen = vec![false; tris.len()];
        for (t, &id) in w.tris.iter().zip(&w.ids) {
            let k = ids.iter().position(|&i| i == id).expect("a known id");
            assert_eq!(*t, tris[k]);
            assert!(!seen[k], "triangle {k} stored twice");
            seen[k] = true;
        }
        assert!(seen.iter().all(|&s| s), "a triangle is missing");
        for n in &w.nodes {
            for c in 0..WIDTH {
                assert!(n.count[c] <= costs.max_leaf, "a leaf of {}", n.count[c]);
            }
        }
    }

    #[test]
    fn collapse_emits_the_cover_it_costs() {
        for (n, seed) in [(1, 1), (3, 2), (5, 3), (40, 4), (700, 5)] {
            let tris = soup(n, seed);
            let ids: Vec<u32> = (0..n as u32).map(|i| 3 * i + 1).collect();
            for (name, tree) in [("sah", binned_sah::build(&tris)), ("ploc", ploc(&tris))] {
                for costs in [
                    COSTS_FOR_TEST,
                    Costs {
                        leaf: 4.0,
                        tri: 1.0,
                        ..COSTS_FOR_TEST
                    },
                ] {
                    let w = collapse(&tree, &tris, &ids, costs);
                    check_cover(&w, &tris, &ids, costs);
                    let again = layout_cost(&w, costs);
                    assert!(
                        (again - w.cost).abs() <= 1e-5 * w.cost,
                        "{name} n={n}: layout costs {again}, collapse claimed {}",
                        w.cost
                    );
                }
            }
        }
    }

    #[test]
    fn collapse_beats_fixed_covers() {
        // Two simple covers of the same binary tree that the optimum must
        // not lose to: every binary subtree of ≤ 4 triangles a leaf, and
        // every triangle its own leaf (each opened greedily, largest box
        // first, into wide nodes).
        let tris = soup(3000, 9);
        let ids: Vec<u32> = (0..tris.len() as u32).collect();
        let tree = binned_sah::build(&tris);
        let best = collapse(&tree, &tris, &ids, COSTS_FOR_TEST).cost;
        for leaf_below in [4u32, 1] {
            let fixed = greedy_cost(&tree, leaf_below, COSTS_FOR_TEST);
            assert!(
                best <= fixed * (1.0 + 1e-5),
                "optimum {best} > greedy cover {fixed} (leaves of ≤ {leaf_below})"
            );
        }
        // And it is strictly better than the greedy cover that an earlier
        // version of the builder used.
        assert!(best < 0.97 * greedy_cost(&tree, 4, COSTS_FOR_TEST));
    }

    /// SAH cost of the greedy collapse: subtrees of ≤ `leaf_below`
    /// triangles are leaves; an inner node's slots are found by opening
    /// the inner slot of largest area while fewer than `WIDTH`.
    fn greedy_cost(tree: &BinaryTree, leaf_below: u32, costs: Costs) -> f64 {
        let b = &tree.nodes;
        let mut prims = vec![0u32; b.len()];
        for i in (0..b.len()).rev() {
            prims[i] = if b[i].is_leaf() {
                b[i].count
            } else {
                prims[b[i].first as usize] + prims[b[i].first as usize + 1]
            };
        }
        let is_leaf = |i: usize| b[i].is_leaf() || prims[i] <= leaf_below;
        let leaf = |i: usize| b[i].bounds.half_area() * costs.leaf_of(prims[i]);
        if is_leaf(0) {
            return leaf(0) / b[0].bounds.half_area();
        }
        let mut total = 0.0;
        let mut work = vec![0usize];
        while let Some(i) = work.pop() {
            total += b[i].bounds.half_area() * costs.node;
            let f = b[i].first as usize;
            let mut slots = vec![f, f + 1];
            while slots.len() < WIDTH {
                let open = (0..slots.len())
                    .filter(|&k| !is_leaf(slots[k]))
                    .max_by(|&x, &y| {
                        b[slots[x]]
                            .bounds
                            .half_area()
                            .total_cmp(&b[slots[y]].bounds.half_area())
                    });
                let Some(k) = open else { break };
                let f = b[slots[k]].first as usize;
                slots[k] = f;
                slots.push(f + 1);
            }
            for s in slots {
                if is_leaf(s) {
                    total += leaf(s);
                } else {
                    work.push(s);
                }
            }
        }
        total / b[0].bounds.half_area()
    }

    const COSTS_FOR_TEST: Costs = Costs {
        node: 1.0,
        leaf: 1.0,
        tri: 0.1,
        max_leaf: 4,
    };
}
