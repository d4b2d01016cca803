//! Construction (feature `std`). Two builders make binary trees over the
//! same triangles: obvhs (PLOC with reinsertion) and our binned SAH
//! builder. Each is collapsed into 8-wide nodes by the SAH-optimal
//! collapse, and the tree of lower SAH cost is kept.
//!
//! Neither builder wins everywhere (callgrind instructions of our
//! kernels): PLOC's tree needs 13% fewer on veach-mis's diffuse
//! bounces and 19% fewer on its primary packets, the binned SAH tree 3–5%
//! fewer on the benchmark mesh's diffuse and primary rays. The SAH cost
//! picks the better of the two there; on veach-ajar it picks PLOC's, whose
//! count is 2–4% above the other's.

mod binary;
mod binned_sah;
mod collapse;

use std::time::Duration;
use std::vec::Vec;

use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::ploc::{PlocSearchDistance, SortPrecision};
use obvhs::triangle::Triangle;

use super::Bvh;
use crate::geometry::triangle::is_degenerate;
use binary::BinaryTree;
use collapse::{Costs, Wide};

/// Relative costs of node and leaf visits for the collapse. A leaf visit
/// costs our single-ray kernels about three node visits (callgrind, AVX2
/// form, mesh), but the SAH's uniform rays are not our rays: with leaf
/// costs of 0.5, 1 and 2 and triangle costs of 0.1 and 0.3, our kernels'
/// instructions moved by under 1% on the mesh, and for leaf costs of 1–3
/// the choice between the two trees was the same on every benchmark scene.
/// Rechecked with 8-wide nodes: leaf costs of 0.5 and 2 moved
/// eight cells (single rays and packets, 8k-triangle mesh and three room
/// scenes) by −2.1% to +0.6%.
const COSTS: Costs = Costs {
    node: 1.0,
    leaf: 1.0,
    tri: 0.1,
    max_leaf: 4,
};

/// obvhs' high-quality preset (`slow_build`) without spatial pre-splits
/// (they duplicate references and clip their boxes in rounded arithmetic,
/// which would make the boxes non-conservative), with single-triangle
/// leaves: the collapse decides what becomes a leaf.
fn ploc_params() -> BvhBuildParams {
    BvhBuildParams {
        pre_split: false,
        ploc_search_distance: PlocSearchDistance::High,
        search_depth_threshold: 2,
        reinsertion_batch_ratio: 0.2,
        post_collapse_reinsertion_batch_ratio_multiplier: 2.0,
        sort_precision: SortPrecision::U128,
        max_prims_per_leaf: 1,
        collapse_traversal_cost: 3.0,
    }
}

fn ploc(tris: &[[Vec3; 3]]) -> BinaryTree {
    let otris: Vec<Triangle> = tris
        .iter()
        .map(|t| {
            let [v0, v1, v2] = t.map(Vec3A::from);
            Triangle { v0, v1, v2 }
        })
        .collect();
    let bvh2 = build_bvh2_from_tris(&otris, ploc_params(), &mut Duration::default());
    binary::from_obvhs(&bvh2)
}

pub(super) fn build(tris: &[[Vec3; 3]]) -> Bvh {
    assert!(
        tris.len() < u32::MAX as usize,
        "too many triangles for u32 primitive ids"
    );
    // Scene-global ids of the triangles that can be hit, and those.
    let ids: Vec<u32> = (0..tris.len() as u32)
        .filter(|&i| {
            let [a, b, c] = tris[i as usize];
            !is_degenerate(a, b, c)
        })
        .collect();
    if ids.is_empty() {
        return Bvh::default();
    }
    let kept: Vec<[Vec3; 3]> = ids.iter().map(|&i| tris[i as usize]).collect();
    let collapse = |tree: BinaryTree| collapse::collapse(&tree, &kept, &ids, COSTS);
    // One after the other: a library call should not start threads its
    // host did not ask for. PLOC first: obvhs' working set is the larger,
    // and it is better not to hold the other layout during it.
    let ploc_wide = collapse(ploc(&kept));
    let sah_wide = collapse(binned_sah::build(&kept));
    let Wide {
        nodes,
        tris: leaf_tris,
        ids: leaf_ids,
        ..
    } = if sah_wide.cost <= ploc_wide.cost {
        sah_wide
    } else {
        ploc_wide
    };
    let mut bvh =
        Bvh::from_parts(nodes, leaf_tris, leaf_ids).expect("the builder produces valid layouts");
    super::node::refit(&mut bvh.nodes, &bvh.blocks);
    bvh
}
