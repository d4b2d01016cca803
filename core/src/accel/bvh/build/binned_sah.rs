//! Top-down binary BVH construction with the binned surface area heuristic
//! (Wald 2007, "On fast Construction of SAH-based Bounding Volume
//! Hierarchies"): at every node the triangles' centroids are sorted into
//! [`BINS`] equal bins per axis and the node is split at the bin boundary
//! of least SAH cost, `A(L)·|L| + A(R)·|R|`.
//!
//! The tree goes down to single triangles: which subtrees become leaves is
//! decided by the wide collapse, which knows what a leaf costs in our
//! kernels (see `collapse`). The boxes here only steer the build: the
//! traversal's boxes are recomputed exactly from the stored triangles
//! afterwards (`node::refit`), so nothing here has to be conservative.

use std::vec::Vec;

use glam::Vec3;

use super::binary::{Aabb, BinNode, BinaryTree};

/// Bins per axis. A full sweep over every split position did not give
/// better trees after the collapse (SAH cost: veach-bidir 6.55 against
/// 6.58, veach-mis 3.38 against 3.43, cornell-box 6.15 against 5.84).
const BINS: usize = 32;

/// Builds the binary tree over `tris` (non-empty).
pub(super) fn build(tris: &[[Vec3; 3]]) -> BinaryTree {
    let boxes: Vec<Aabb> = tris
        .iter()
        .map(|&[a, b, c]| Aabb {
            min: a.min(b).min(c),
            max: a.max(b).max(c),
        })
        .collect();
    // Halves first: `min + max` could overflow to infinity.
    let centroids: Vec<Vec3> = boxes.iter().map(|b| 0.5 * b.min + 0.5 * b.max).collect();
    let mut order: Vec<u32> = (0..tris.len() as u32).collect();
    let mut nodes = Vec::with_capacity(2 * tris.len());
    nodes.push(BinNode::UNSET);
    // (node, the range of `order` it covers); children are partitioned in
    // place, so every subtree's triangles stay contiguous.
    let mut work = vec![(0usize, 0usize, tris.len())];
    while let Some((n, lo, hi)) = work.pop() {
        let prims = &mut order[lo..hi];
        let mut bounds = Aabb::EMPTY;
        for &p in prims.iter() {
            bounds.grow(&boxes[p as usize]);
        }
        nodes[n].bounds = bounds;
        if prims.len() == 1 {
            nodes[n].first = lo as u32;
            nodes[n].count = 1;
            continue;
        }
        // Coinciding centroids (the only case without a binned split) are
        // split in the middle of the range: any split of them costs the same.
        let mid = lo + split(prims, &boxes, &centroids).unwrap_or(prims.len() / 2);
        let first = nodes.len();
        nodes.extend([BinNode::UNSET; 2]);
        nodes[n].first = first as u32;
        work.push((first + 1, mid, hi));
        work.push((first, lo, mid));
    }
    BinaryTree { nodes, order }
}

/// Partitions `prims` (at least two) at the binned split of least SAH
/// cost; returns the size of the left part, in `1..prims.len()`, or `None`
/// when every centroid falls into one bin on every axis.
fn split(prims: &mut [u32], boxes: &[Aabb], centroids: &[Vec3]) -> Option<usize> {
    let (mut cmin, mut cmax) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for &p in prims.iter() {
        cmin = cmin.min(centroids[p as usize]);
        cmax = cmax.max(centroids[p as usize]);
    }
    // In `f64`: the extent of finite centroids cannot overflow there.
    let (cmin, extent) = (cmin.as_dvec3(), cmax.as_dvec3() - cmin.as_dvec3());
    let bin_of = |p: u32, axis: usize, scale: f64| -> usize {
        // `as` saturates, and the `min` keeps the largest centroid in the
        // last bin whatever the rounding of `scale`.
        let c = f64::from(centroids[p as usize][axis]);
        (((c - cmin[axis]) * scale) as usize).min(BINS - 1)
    };
    // (cost, axis, first bin of the right part)
    let mut best: Option<(f64, usize, usize)> = None;
    for axis in 0..3 {
        if !(extent[axis] > 0.0) {
            continue;
        }
        let scale = BINS as f64 / extent[axis];
        let mut bins = [(Aabb::EMPTY, 0usize); BINS];
        for &p in prims.iter() {
            let b = &mut bins[bin_of(p, axis, scale)];
            b.0.grow(&boxes[p as usize]);
            b.1 += 1;
        }
        // right_cost[b]: A·N of bins b.. (b ≥ 1).
        let mut right_cost = [0.0f64; BINS];
        let (mut acc, mut count) = (Aabb::EMPTY, 0usize);
        for b in (1..BINS).rev() {
            acc.grow(&bins[b].0);
            count += bins[b].1;
            right_cost[b] = acc.half_area() * count as f64;
        }
        let (mut acc, mut count) = (Aabb::EMPTY, 0usize);
        for b in 1..BINS {
            acc.grow(&bins[b - 1].0);
            count += bins[b - 1].1;
            if count == 0 || count == prims.len() {
                continue;
            }
            let cost = acc.half_area() * count as f64 + right_cost[b];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    let (_, axis, first_right) = best?;
    let scale = BINS as f64 / extent[axis];
    let (mut i, mut j) = (0, prims.len());
    while i < j {
        if bin_of(prims[i], axis, scale) < first_right {
            i += 1;
        } else {
            j -= 1;
            prims.swap(i, j);
        }
    }
    Some(i)
}
