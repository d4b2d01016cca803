//! The watertight triangle test of a packet in explicit registers
//! ([`LaneVec`]): the portable `geometry::triangle::intersect_lanes` one
//! register of lanes at a time, bit for bit.

use super::lane_vec::LaneVec;
use crate::geometry::offset::gamma;
use crate::geometry::triangle::{
    Planes4, WatertightLanes, finish_lanes, permuted_lanes, planes_tri,
};

/// [`intersect_lanes`](crate::geometry::triangle::intersect_lanes) one register of lanes at a time ([`LaneVec`]) for
/// triangle `slot` of the four in `planes` (a leaf block): the same IEEE
/// operations in the same order per lane (those of the single-ray SSE
/// leaf test), so the same bits. Vertex components are broadcast straight
/// from the block's planes (by the shared permutation, or picked by the
/// permutation masks `k_is`): going through a `[Vec3; 3]` first stored and
/// reloaded every component (callgrind: about a tenth of the packet
/// kernel's instructions on the mesh's primary rays). `N` must be a
/// multiple of `V::W`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn intersect_lanes_simd<V: LaneVec, const N: usize>(
    r: &WatertightLanes<N>,
    planes: &Planes4,
    slot: usize,
    t_max: &[f32; N],
    lanes: u32,
    t: &mut [f32; N],
    b1: &mut [f32; N],
    b2: &mut [f32; N],
) -> u32 {
    debug_assert!(N.is_multiple_of(V::W));
    let slot = slot & 3;
    let (mut ok, mut unsure, mut zero) = (0u32, 0u32, 0u32);
    let chunk_bits = if V::W >= 32 {
        u32::MAX
    } else {
        (1u32 << V::W) - 1
    };
    // The shared permutation, clamped so that the compiler sees the plane
    // indices in range (`finish` stores values below 3).
    let uniform = r.uniform.map(|k| k.map(|a| a.min(2)));
    for chunk in 0..N / V::W {
        let at = chunk * V::W;
        let shift = at as u32;
        let live = lanes >> shift & chunk_bits;
        if live == 0 {
            continue;
        }
        // No closures in this function: a closure is compiled without the
        // caller's target features, so the AVX intrinsics inside it would
        // become calls.
        let org = [
            V::load(&r.org[0][at..]),
            V::load(&r.org[1][at..]),
            V::load(&r.org[2][at..]),
        ];
        let shear = [
            V::load(&r.shear[0][at..]),
            V::load(&r.shear[1][at..]),
            V::load(&r.shear[2][at..]),
        ];
        let sv = [
            permuted::<V, N>(r, uniform, &planes[0], slot, shift),
            permuted::<V, N>(r, uniform, &planes[1], slot, shift),
            permuted::<V, N>(r, uniform, &planes[2], slot, shift),
        ];
        let tm = V::load(&t_max[at..]);
        let Some(f) = lanes_f32(sv, org, shear, tm, live) else {
            continue;
        };
        zero |= f.zero << shift;
        f.t.store(&mut t[at..]);
        f.b1.store(&mut b1[at..]);
        f.b2.store(&mut b2[at..]);
        ok |= f.ok << shift;
        unsure |= f.unsure << shift;
    }
    if unsure | zero == 0 {
        return ok;
    }
    // Rare: lanes decided in f64 or redone by the single-ray test, from
    // the triangle and its permuted components made here.
    let tri = planes_tri(planes, slot);
    let sel = (unsure != 0).then(|| permuted_lanes(r, &tri));
    finish_lanes(r, &tri, t_max, ok, unsure, zero, sel.as_ref(), t, b1, b2)
}

/// What [`lanes_f32`] finds for one register of lanes.
struct LanesF32<V> {
    /// Lanes with an exactly zero edge function (redone in f64).
    zero: u32,
    /// Lanes that hit with `t` provably positive and below `t_max`.
    ok: u32,
    /// Lanes inside the edges whose `t` is not provably of either sign.
    unsure: u32,
    t: V,
    b1: V,
    b2: V,
}

/// The f32 part of the watertight test for one register of lanes: the
/// permuted vertices `sv[vertex][axis]`, each lane's permuted origin and
/// shear, `t_max`, and the `live` lanes. Returns only the zero-edge lanes
/// (`ok = unsure = 0`) when no live lane is inside the edges.
#[inline(always)]
fn lanes_f32<V: LaneVec>(
    sv: [[V; 3]; 3],
    org: [V; 3],
    shear: [V; 3],
    tm: V,
    live: u32,
) -> Option<LanesF32<V>> {
    let z = V::splat(0.0);
    let a = lanes_ray_space(sv[0], org, shear);
    let b = lanes_ray_space(sv[1], org, shear);
    let c = lanes_ray_space(sv[2], org, shear);
    // `edge_functions` and the inside test.
    let u = c[0].mul(b[1]).sub(c[1].mul(b[0]));
    let v = a[0].mul(c[1]).sub(a[1].mul(c[0]));
    let w = b[0].mul(a[1]).sub(b[1].mul(a[0]));
    let zc = (u.eq(z) | v.eq(z) | w.eq(z)) & live;
    let neg = u.lt(z) | v.lt(z) | w.lt(z);
    let pos = u.gt(z) | v.gt(z) | w.gt(z);
    let inside = !(neg & pos) & live & !zc;
    if inside == 0 {
        return (zc != 0).then_some(LanesF32 {
            zero: zc,
            ok: 0,
            unsure: 0,
            t: z,
            b1: z,
            b2: z,
        });
    }
    // `solve`.
    let det = u.add(v).add(w);
    let t_scaled = u.mul(a[2]).add(v.mul(b[2])).add(w.mul(c[2]));
    let inv_det = V::splat(1.0).div(det);
    let tt = t_scaled.mul(inv_det);
    let max_x = lanes_max3(a[0].abs(), b[0].abs(), c[0].abs());
    let max_y = lanes_max3(a[1].abs(), b[1].abs(), c[1].abs());
    let max_z = lanes_max3(a[2].abs(), b[2].abs(), c[2].abs());
    let max_zw = lanes_max3(a[3].abs(), b[3].abs(), c[3].abs());
    let (g2, g3, g5) = (V::splat(gamma(2)), V::splat(gamma(3)), V::splat(gamma(5)));
    let delta_z = g3.mul(max_z);
    let delta_x = g5.mul(max_x.add(max_zw));
    let delta_y = g5.mul(max_y.add(max_zw));
    let delta_e = V::splat(2.0).mul(
        g2.mul(max_x)
            .mul(max_y)
            .add(delta_y.mul(max_x))
            .add(delta_x.mul(max_y)),
    );
    let max_e = lanes_max3(u.abs(), v.abs(), w.abs());
    let sum = g3
        .mul(max_e)
        .mul(max_z)
        .add(delta_e.mul(max_z))
        .add(delta_z.mul(max_e));
    let dt = V::splat(3.0).mul(sum).mul(inv_det.abs());
    let det_ok = det.ne(z);
    let ok_c = det_ok & tt.gt(dt) & tt.lt(tm) & inside;
    let unsure_c = det_ok & tt.le(dt) & tt.gt(dt.neg()) & inside;
    Some(LanesF32 {
        zero: zc,
        ok: ok_c,
        unsure: unsure_c,
        t: tt,
        b1: v.mul(inv_det),
        b2: w.mul(inv_det),
    })
}

/// A vertex's components (`v[axis][slot]`, one vertex of a block's planes)
/// permuted per lane, for the register of lanes from `shift`: splats by
/// the shared permutation `uniform` (indices below 3), else picked by the
/// masks `k_is` (`k` is 0, 1 or 2 per lane).
#[inline(always)]
fn permuted<V: LaneVec, const N: usize>(
    r: &WatertightLanes<N>,
    uniform: Option<[usize; 3]>,
    v: &[[f32; 4]; 3],
    slot: usize,
    shift: u32,
) -> [V; 3] {
    match uniform {
        Some(k) => [
            V::splat(v[k[0]][slot]),
            V::splat(v[k[1]][slot]),
            V::splat(v[k[2]][slot]),
        ],
        None => {
            let (x, y, z) = (
                V::splat(v[0][slot]),
                V::splat(v[1][slot]),
                V::splat(v[2][slot]),
            );
            let [[a0, a1], [b0, b1], [c0, c1]] = r.k_is;
            [
                V::select(a0 >> shift, x, V::select(a1 >> shift, y, z)),
                V::select(b0 >> shift, x, V::select(b1 >> shift, y, z)),
                V::select(c0 >> shift, x, V::select(c1 >> shift, y, z)),
            ]
        }
    }
}

/// `transform` of one register of lanes.
#[inline(always)]
fn lanes_ray_space<V: LaneVec>(p: [V; 3], org: [V; 3], shear: [V; 3]) -> [V; 4] {
    let ax = p[0].sub(org[0]);
    let ay = p[1].sub(org[1]);
    let az = p[2].sub(org[2]);
    [
        ax.sub(shear[0].mul(az)),
        ay.sub(shear[1].mul(az)),
        shear[2].mul(az),
        az,
    ]
}

/// `max3` of one register of lanes (`maxps(p, q)` is `if p > q { p } else
/// { q }`, as in `max3`).
#[inline(always)]
fn lanes_max3<V: LaneVec>(p: V, q: V, r: V) -> V {
    p.max(q).max(r)
}
