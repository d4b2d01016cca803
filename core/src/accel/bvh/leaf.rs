//! Leaf storage: triangles in blocks of four, pre-transposed for the SIMD
//! leaf test.
//!
//! A leaf's triangles fill *slots* `child .. child + count` of the block
//! array (slot `s` is lane `s % 4` of block `s / 4`), and every leaf starts
//! at a block boundary. The single-ray leaf test loads a block's nine
//! planes (`v[vertex][axis]`, one lane per triangle) straight into SSE
//! registers; from triangles stored one after the other (`[Vec3; 3]`) it
//! had to gather and transpose them first (12 loads and 21 shuffles per
//! group) and to pass them through the stack to apply the ray's axis
//! permutation. Embree's `Triangle4` leaves are the same idea.
//!
//! Measured in one process against the per-triangle layout: single rays 1.06–1.20× as fast on the four shared
//! scenes, 1.03–1.07× on the 260k-triangle mesh. The cost is memory:
//! 160 bytes per block, so a leaf of one triangle takes what four would
//! (the benchmark mesh, 2.8 triangles per leaf, needs 56 bytes per
//! triangle for its leaves instead of 40).

use glam::Vec3;

use crate::geometry::triangle::planes_tri;

#[cfg(feature = "alloc")]
use super::node::{Node, WIDTH};
#[cfg(feature = "alloc")]
use alloc::vec::Vec;

/// Four triangle slots, transposed: `v[vertex][axis][lane]`, plus each
/// slot's scene-global id.
///
/// The SIMD test reads all four lanes of a leaf's last block and masks
/// those past the leaf's triangle count, whatever they hold; `Bvh::from_parts`
/// fills them with copies of the leaf's last triangle and id (ids are
/// checked in every lane, so a padding id must not be the reserved miss
/// value either). 160 bytes, aligned to 32 so the nine planes are aligned
/// 16-byte loads.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct TriBlock {
    /// Vertex `v`, axis `a`, lane `l`: `v[v][a][l]`.
    pub v: [[[f32; 4]; 3]; 3],
    /// Scene-global id of each lane's triangle, reported in
    /// [`crate::geometry::Hit::prim`].
    pub ids: [u32; 4],
}

// 144 bytes of planes and 16 of ids; `repr(C)` keeps the order.
const _: () = assert!(core::mem::size_of::<TriBlock>() == 160);

impl TriBlock {
    /// Lane `l`'s triangle (`l < 4`).
    #[inline(always)]
    pub fn tri(&self, l: usize) -> [Vec3; 3] {
        planes_tri(&self.v, l)
    }

    /// Stores `tri` with `id` in lane `l` (`l < 4`).
    #[inline]
    pub fn set(&mut self, l: usize, tri: [Vec3; 3], id: u32) {
        let l = l & 3;
        for (v, p) in tri.iter().enumerate() {
            for (a, x) in p.to_array().into_iter().enumerate() {
                self.v[v][a][l] = x;
            }
        }
        self.ids[l] = id;
    }

    /// A block of four copies of `tri` with `id`.
    #[inline]
    pub fn splat(tri: [Vec3; 3], id: u32) -> TriBlock {
        let mut b = TriBlock {
            v: [[[0.0; 4]; 3]; 3],
            ids: [id; 4],
        };
        for l in 0..4 {
            b.set(l, tri, id);
        }
        b
    }
}

/// Triangle slot `s`: lane `s % 4` of block `s / 4` (`s` in range).
#[inline(always)]
pub(super) fn slot_tri(blocks: &[TriBlock], s: usize) -> [Vec3; 3] {
    blocks[s / 4].tri(s % 4)
}

/// Scene-global id of slot `s`.
#[inline(always)]
pub(super) fn slot_id(blocks: &[TriBlock], s: usize) -> u32 {
    blocks[s / 4].ids[s % 4]
}

/// How many blocks [`pack`] makes for `nodes`: one per started group of
/// four triangles of each leaf. A `u64`, because leaf ranges may overlap,
/// so the sum is not bounded by the triangle count.
#[cfg(feature = "alloc")]
pub(super) fn blocks_needed(nodes: &[Node]) -> u64 {
    nodes
        .iter()
        .flat_map(|n| n.count)
        .map(|k| u64::from(k).div_ceil(4))
        .sum()
}

/// Packs a layout whose leaves index `tris` (leaf order: a leaf slot's
/// `child` is its first triangle) into blocks, rewriting each leaf's
/// `child` to its first slot. Leaves are packed in the order they are
/// met walking the node array, each from a fresh block, padded with its
/// last triangle.
///
/// The caller has checked every leaf range against `tris`, that `ids`
/// has one id per triangle, and that `n_blocks` (the [`blocks_needed`])
/// have fewer than `u32::MAX` slots.
#[cfg(feature = "alloc")]
pub(super) fn pack(
    nodes: &mut [Node],
    tris: &[[Vec3; 3]],
    ids: &[u32],
    n_blocks: usize,
) -> Vec<TriBlock> {
    let mut blocks = Vec::with_capacity(n_blocks);
    for node in nodes.iter_mut() {
        for c in 0..WIDTH {
            if !node.is_leaf(c) {
                continue;
            }
            let (first, count) = (node.child[c] as usize, node.count[c] as usize);
            node.child[c] = (4 * blocks.len()) as u32;
            let last = first + count - 1;
            for g in (first..=last).step_by(4) {
                let mut b = TriBlock::splat(tris[last], ids[last]);
                for (l, k) in (g..=last.min(g + 3)).enumerate() {
                    b.set(l, tris[k], ids[k]);
                }
                blocks.push(b);
            }
        }
    }
    blocks
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_then_tri_round_trips_and_splat_fills_every_lane() {
        let t = [Vec3::new(1.0, 2.0, 3.0), Vec3::X, Vec3::new(-4.0, 5.5, 6.0)];
        let u = [Vec3::Z, Vec3::Y, Vec3::new(7.0, 8.0, 9.0)];
        let mut b = TriBlock::splat(t, 7);
        b.set(2, u, 9);
        assert_eq!((b.tri(0), b.tri(1), b.tri(3)), (t, t, t));
        assert_eq!(b.tri(2), u);
        assert_eq!(b.ids, [7, 7, 9, 7]);
        // Planes are SoA: vertex 2's y of lane 2 is u[2].y.
        assert_eq!(b.v[2][1][2], 8.0);
    }

    #[test]
    fn pack_starts_leaves_at_block_boundaries_and_pads_with_the_last_triangle() {
        let tris: Vec<[Vec3; 3]> = (0..7)
            .map(|i| [Vec3::splat(i as f32), Vec3::X, Vec3::Y])
            .collect();
        let ids: Vec<u32> = (0..7).map(|i| 100 + i).collect();
        let mut nodes = [Node::EMPTY];
        // Leaves of 2 and 5 triangles.
        (nodes[0].child[0], nodes[0].count[0]) = (0, 2);
        (nodes[0].child[1], nodes[0].count[1]) = (2, 5);
        assert_eq!(blocks_needed(&nodes), 3);
        let blocks = pack(&mut nodes, &tris, &ids, 3);
        assert_eq!(blocks.len(), 3);
        assert_eq!((nodes[0].child[0], nodes[0].child[1]), (0, 4));
        assert_eq!(blocks[0].ids, [100, 101, 101, 101]);
        assert_eq!(blocks[1].ids, [102, 103, 104, 105]);
        assert_eq!(blocks[2].ids, [106, 106, 106, 106]);
        for s in 0..5 {
            assert_eq!(slot_tri(&blocks, 4 + s), tris[2 + s]);
            assert_eq!(slot_id(&blocks, 4 + s), 102 + s as u32);
        }
    }
}
