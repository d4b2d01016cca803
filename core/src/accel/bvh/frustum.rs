//! The whole-packet box test: which of a node's children some ray of a
//! coherent packet may hit, from the packet's bounds alone.
//!
//! A packet's per-lane box test costs one step per child and register of
//! lanes, so with eight children per node it is eight steps, most of them
//! for children no lane hits. Bounding the packet's origins and
//! reciprocal directions per axis gives, by interval arithmetic, a lower
//! bound of every lane's entry distance and an upper bound of every lane's
//! exit distance for all eight children at once (one single-ray-sized
//! test); the per-lane test then runs only for the children it cannot rule
//! out. Wald et al. 2007 ("Ray Tracing Deformable Scenes Using Dynamic
//! Bounding Volume Hierarchies") use such interval bounds of a packet to
//! cull whole subtrees; here they only cull children, so every lane's
//! answer still comes from its own test.
//!
//! **Conservative to the bit.** Each bound is formed from the same IEEE
//! operations as a lane's own slab distances, at the ends of the packet's
//! intervals: for a lane with origin `o ≤ o_max` and reciprocal direction
//! `inv ∈ [i0, i1]` (one sign), the lane's computed `fl(fl(p − o) · inv)`
//! is at least `min(fl(fl(p − o_max) · i0), fl(fl(p − o_max) · i1))`,
//! because rounding to nearest is monotone and `x · inv` is monotone in
//! each argument. So a child this test culls is one that the per-lane test
//! (node::boxes, per lane) reports missed by every lane, and the packet's
//! answers are those of its rays traced one by one.
//!
//! Only for packets whose live lanes agree on the direction's sign on
//! every axis and whose reciprocal directions are finite (a zero or
//! denormal direction component, `inv = ±∞`, would turn a bound into
//! `0 · ∞`); others are tested lane by lane.

use super::node::{FAR_SCALE, Node, WIDTH, max_keep, min_keep};

/// A packet's bounds, set up once per packet for [`Frustum::boxes`].
#[derive(Clone, Copy, Debug)]
pub(super) struct Frustum {
    /// Per axis, the row of `Node::rows` holding the near plane (`min` for
    /// a positive direction, `max` for a negative one), and of the far one.
    near: [usize; 3],
    far: [usize; 3],
    /// Per axis, the origin bound that gives the smallest `plane − o` for
    /// the near plane (`o_max` for positive directions, `o_min` for
    /// negative ones, whose distances fall as `plane − o` grows) ...
    o_near: [f32; 3],
    /// ... and the largest for the far plane.
    o_far: [f32; 3],
    /// Per axis, the smallest and largest reciprocal direction.
    inv_lo: [f32; 3],
    inv_hi: [f32; 3],
    /// The largest `t_max` of the packet's lanes.
    t_max: f32,
}

impl Frustum {
    /// The bounds of the lanes in `live` (bit `i` = lane `i`), whose
    /// direction signs per axis are `neg`; `None` if there is no live lane,
    /// if a live lane's origin or reciprocal direction is not finite, or if
    /// a lane's `t_max` is NaN.
    pub fn new<const N: usize>(
        o: &[[f32; N]; 3],
        inv: &[[f32; N]; 3],
        t_max: &[f32; N],
        neg: [bool; 3],
        live: u32,
    ) -> Option<Self> {
        if live == 0 {
            return None;
        }
        let mut f = Frustum {
            near: [0; 3],
            far: [0; 3],
            o_near: [0.0; 3],
            o_far: [0.0; 3],
            inv_lo: [0.0; 3],
            inv_hi: [0.0; 3],
            t_max: f32::NEG_INFINITY,
        };
        for a in 0..3 {
            let (mut o_min, mut o_max) = (f32::INFINITY, f32::NEG_INFINITY);
            let (mut i_min, mut i_max) = (f32::INFINITY, f32::NEG_INFINITY);
            for i in (0..N).filter(|&i| live >> i & 1 != 0) {
                let (oi, ii) = (o[a][i], inv[a][i]);
                if !oi.is_finite() || !ii.is_finite() {
                    return None;
                }
                o_min = o_min.min(oi);
                o_max = o_max.max(oi);
                i_min = i_min.min(ii);
                i_max = i_max.max(ii);
            }
            (f.near[a], f.far[a]) = if neg[a] { (3 + a, a) } else { (a, 3 + a) };
            (f.o_near[a], f.o_far[a]) = if neg[a] {
                (o_min, o_max)
            } else {
                (o_max, o_min)
            };
            (f.inv_lo[a], f.inv_hi[a]) = (i_min, i_max);
        }
        for i in (0..N).filter(|&i| live >> i & 1 != 0) {
            if t_max[i].is_nan() {
                return None;
            }
            f.t_max = f.t_max.max(t_max[i]);
        }
        Some(f)
    }

    /// The children of `node` that some lane may hit (bit `c` = child
    /// `c`): every child the per-lane test finds hit by a lane is in it.
    ///
    /// Per axis, the near plane's distance is bounded below by the smaller
    /// of `(p − o_near) · inv_lo` and `(p − o_near) · inv_hi`, the far
    /// plane's above by the larger of `(p − o_far) · inv_lo` and `(p −
    /// o_far) · inv_hi` (the ends of a product that is monotone in the
    /// reciprocal direction); a child is out when the largest lower bound
    /// exceeds the smallest upper bound, widened as in the per-lane test.
    #[inline(always)]
    pub fn boxes(&self, node: &Node) -> u32 {
        let rows = node.rows();
        let mut near = [0.0f32; WIDTH];
        let mut far = [self.t_max; WIDTH];
        for a in 0..3 {
            let (nb, fb) = (&rows[self.near[a] & 7], &rows[self.far[a] & 7]);
            for c in 0..WIDTH {
                let x = nb[c] - self.o_near[a];
                let (p, q) = (x * self.inv_lo[a], x * self.inv_hi[a]);
                near[c] = max_keep(near[c], if q < p { q } else { p });
                let y = fb[c] - self.o_far[a];
                let (p, q) = (y * self.inv_lo[a], y * self.inv_hi[a]);
                far[c] = min_keep(far[c], if q > p { q } else { p });
            }
        }
        let mut mask = 0;
        for c in 0..WIDTH {
            // Not `near <= far`: a NaN bound must keep the child.
            mask |= (!(near[c] > far[c] * FAR_SCALE) as u32) << c;
        }
        mask
    }

    /// [`Self::boxes`] with the node's children in one 256-bit register
    /// per plane (the same operations, so the same mask).
    ///
    /// # Safety
    /// The CPU must support AVX.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub unsafe fn boxes_avx(&self, node: &Node) -> u32 {
        use core::arch::x86_64::*;
        const { assert!(WIDTH == 8) };
        let rows = node.rows();
        // SAFETY: the caller guarantees AVX; every load touches one whole
        // `[f32; 8]` row (unaligned loads).
        unsafe {
            let mut near = _mm256_setzero_ps();
            let mut far = _mm256_set1_ps(self.t_max);
            for a in 0..3 {
                let (nb, fb) = (&rows[self.near[a] & 7], &rows[self.far[a] & 7]);
                let (lo, hi) = (
                    _mm256_set1_ps(self.inv_lo[a]),
                    _mm256_set1_ps(self.inv_hi[a]),
                );
                let x = _mm256_sub_ps(_mm256_loadu_ps(nb.as_ptr()), _mm256_set1_ps(self.o_near[a]));
                // vminps(q, p) is `if q < p { q } else { p }`; vmaxps(x,
                // acc) keeps acc for a NaN x, as max_keep(acc, x).
                let n = _mm256_min_ps(_mm256_mul_ps(x, hi), _mm256_mul_ps(x, lo));
                near = _mm256_max_ps(n, near);
                let y = _mm256_sub_ps(_mm256_loadu_ps(fb.as_ptr()), _mm256_set1_ps(self.o_far[a]));
                let f = _mm256_max_ps(_mm256_mul_ps(y, hi), _mm256_mul_ps(y, lo));
                far = _mm256_min_ps(f, far);
            }
            let scaled = _mm256_mul_ps(far, _mm256_set1_ps(FAR_SCALE));
            // Not-greater, unordered true: a NaN bound keeps the child.
            let keep = _mm256_cmp_ps::<_CMP_NGT_UQ>(near, scaled);
            _mm256_movemask_ps(keep) as u32
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::node::BoxRay;
    use crate::accel::bvh::node::boxes;

    /// A small xorshift generator: the test needs varied inputs, not
    /// statistics.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 32) as u32
        }
        fn f(&mut self, lo: f32, hi: f32) -> f32 {
            lo + (hi - lo) * (self.next() as f32 / u32::MAX as f32)
        }
    }

    /// A node of random (sometimes empty or flat) boxes around the origin.
    fn node(rng: &mut Rng) -> Node {
        let mut node = Node::EMPTY;
        for c in 0..WIDTH {
            if rng.next().is_multiple_of(6) {
                continue;
            }
            let (mut lo, mut hi) = ([0.0; 3], [0.0; 3]);
            for a in 0..3 {
                lo[a] = rng.f(-3.0, 3.0);
                hi[a] = if rng.next().is_multiple_of(5) {
                    lo[a]
                } else {
                    lo[a] + rng.f(0.01, 2.0)
                };
            }
            node.set_bounds(c, lo, hi);
        }
        node
    }

    /// For packets of one octant (tight bundles, loose fans, origins on
    /// box planes) and random nodes: every child that some lane's own
    /// single-ray test (`node::boxes`) hits is in the frustum's mask, and
    /// the AVX form gives the portable form's mask. Also checks that the
    /// test culls at all, so it cannot pass by keeping everything.
    #[test]
    fn frustum_keeps_every_child_a_lane_hits() {
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let (mut kept, mut culled) = (0u32, 0u32);
        for _ in 0..20_000 {
            let node = node(&mut rng);
            let neg = [0; 3].map(|_| rng.next().is_multiple_of(2));
            let spread = [0.001, 0.05, 1.0][rng.next() as usize % 3];
            let base_o = [0; 3].map(|_| rng.f(-6.0, 6.0));
            let base_d = [0; 3].map(|_| rng.f(0.05, 1.0));
            let (mut o, mut inv, mut t_max) = ([[0.0f32; 16]; 3], [[0.0f32; 16]; 3], [0.0; 16]);
            for i in 0..16 {
                for a in 0..3 {
                    o[a][i] = if rng.next().is_multiple_of(7) {
                        // Exactly on a box plane.
                        node.min[a][rng.next() as usize % WIDTH].clamp(-10.0, 10.0)
                    } else {
                        base_o[a] + rng.f(-spread, spread)
                    };
                    let d = (base_d[a] + rng.f(0.0, spread)).max(1e-3);
                    inv[a][i] = 1.0 / if neg[a] { -d } else { d };
                }
                t_max[i] = if rng.next().is_multiple_of(4) {
                    rng.f(0.0, 3.0)
                } else {
                    f32::INFINITY
                };
            }
            let live = rng.next() & 0xffff | 1;
            let f = Frustum::new(&o, &inv, &t_max, neg, live).expect("finite lanes");
            let mask = f.boxes(&node);
            #[cfg(target_arch = "x86_64")]
            if std::is_x86_feature_detected!("avx") {
                // SAFETY: AVX was just detected.
                assert_eq!(unsafe { f.boxes_avx(&node) }, mask);
            }
            let mut hit = 0;
            for i in (0..16).filter(|&i| live >> i & 1 != 0) {
                let r = BoxRay::with_inv([o[0][i], o[1][i], o[2][i]], [inv[0][i], inv[1][i], inv[2][i]]);
                hit |= boxes(&node, &r, t_max[i]).0;
            }
            assert_eq!(hit & !mask, 0, "a child hit by a lane was culled");
            kept += mask.count_ones();
            culled += WIDTH as u32 - mask.count_ones();
        }
        assert!(culled > kept / 4, "culled {culled}, kept {kept}");
    }

    #[test]
    fn frustum_needs_finite_lanes() {
        let o = [[0.0f32; 4]; 3];
        let mut inv = [[1.0f32; 4]; 3];
        let t = [1.0; 4];
        assert!(Frustum::new(&o, &inv, &t, [false; 3], 0).is_none());
        assert!(Frustum::new(&o, &inv, &t, [false; 3], 0b1111).is_some());
        inv[1][2] = f32::INFINITY;
        assert!(Frustum::new(&o, &inv, &t, [false; 3], 0b1111).is_none());
        // A lane outside `live` does not count.
        assert!(Frustum::new(&o, &inv, &t, [false; 3], 0b1011).is_some());
    }
}
