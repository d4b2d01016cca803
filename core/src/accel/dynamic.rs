//! [`Intersector`] behind a trait object, so that the renderer's entry
//! points are ordinary functions, compiled once in this crate.
//!
//! Every estimator is generic over the intersector it traces through: the
//! hot loops see a concrete type and inline its calls. Taking the
//! intersector generically at the public entry points as well would make
//! every crate that renders (the CLI, the C library, benches, tests)
//! compile its own copy of all of them. [`DynIntersector`] is the
//! object-safe face of [`Intersector`]: the entry points take
//! `&dyn DynIntersector` (a `&impl Intersector` coerces to it at the call),
//! and the estimators run on it, one copy here. The price is one indirect
//! call per query or packet, next to a traversal of a few hundred
//! nanoseconds.

use core::any::Any;

use super::{Intersector, intersect_lanes, occluded_lanes};
use crate::geometry::{Hit, HitPacket, LaneMask, Ray, RayPacket};

/// The object-safe face of [`Intersector`], implemented for every
/// intersector: hosts never implement it, they implement [`Intersector`]
/// and pass `&their_intersector` where this is asked for.
///
/// The packet widths are the renderer's bundles (1, 4, 8 and 16 lanes,
/// as [`super::bvh`] compiles its kernels); a trait object traces other
/// widths lane by lane, with the same answers the contract promises.
pub trait DynIntersector {
    /// [`Intersector::intersect`].
    fn dyn_intersect(&self, ray: &Ray) -> Option<Hit>;
    /// [`Intersector::occluded`].
    fn dyn_occluded(&self, ray: &Ray) -> bool;
    /// [`Intersector::intersect_packet`] for 1 lane.
    fn dyn_intersect_1(&self, rays: &RayPacket<1>, active: LaneMask, hits: &mut HitPacket<1>);
    /// [`Intersector::intersect_packet`] for 4 lanes.
    fn dyn_intersect_4(&self, rays: &RayPacket<4>, active: LaneMask, hits: &mut HitPacket<4>);
    /// [`Intersector::intersect_packet`] for 8 lanes.
    fn dyn_intersect_8(&self, rays: &RayPacket<8>, active: LaneMask, hits: &mut HitPacket<8>);
    /// [`Intersector::intersect_packet`] for 16 lanes.
    fn dyn_intersect_16(&self, rays: &RayPacket<16>, active: LaneMask, hits: &mut HitPacket<16>);
    /// [`Intersector::occluded_packet`] for 1 lane.
    fn dyn_occluded_1(&self, rays: &RayPacket<1>, active: LaneMask) -> LaneMask;
    /// [`Intersector::occluded_packet`] for 4 lanes.
    fn dyn_occluded_4(&self, rays: &RayPacket<4>, active: LaneMask) -> LaneMask;
    /// [`Intersector::occluded_packet`] for 8 lanes.
    fn dyn_occluded_8(&self, rays: &RayPacket<8>, active: LaneMask) -> LaneMask;
    /// [`Intersector::occluded_packet`] for 16 lanes.
    fn dyn_occluded_16(&self, rays: &RayPacket<16>, active: LaneMask) -> LaneMask;
    /// [`Intersector::intersect_stream`].
    fn dyn_intersect_stream(&self, rays: &[Ray], hits: &mut [Option<Hit>]);
    /// [`Intersector::occluded_stream`].
    fn dyn_occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]);
}

impl<T: Intersector> DynIntersector for T {
    fn dyn_intersect(&self, ray: &Ray) -> Option<Hit> {
        self.intersect(ray)
    }
    fn dyn_occluded(&self, ray: &Ray) -> bool {
        self.occluded(ray)
    }
    fn dyn_intersect_1(&self, rays: &RayPacket<1>, active: LaneMask, hits: &mut HitPacket<1>) {
        self.intersect_packet(rays, active, hits)
    }
    fn dyn_intersect_4(&self, rays: &RayPacket<4>, active: LaneMask, hits: &mut HitPacket<4>) {
        self.intersect_packet(rays, active, hits)
    }
    fn dyn_intersect_8(&self, rays: &RayPacket<8>, active: LaneMask, hits: &mut HitPacket<8>) {
        self.intersect_packet(rays, active, hits)
    }
    fn dyn_intersect_16(&self, rays: &RayPacket<16>, active: LaneMask, hits: &mut HitPacket<16>) {
        self.intersect_packet(rays, active, hits)
    }
    fn dyn_occluded_1(&self, rays: &RayPacket<1>, active: LaneMask) -> LaneMask {
        self.occluded_packet(rays, active)
    }
    fn dyn_occluded_4(&self, rays: &RayPacket<4>, active: LaneMask) -> LaneMask {
        self.occluded_packet(rays, active)
    }
    fn dyn_occluded_8(&self, rays: &RayPacket<8>, active: LaneMask) -> LaneMask {
        self.occluded_packet(rays, active)
    }
    fn dyn_occluded_16(&self, rays: &RayPacket<16>, active: LaneMask) -> LaneMask {
        self.occluded_packet(rays, active)
    }
    fn dyn_intersect_stream(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.intersect_stream(rays, hits)
    }
    fn dyn_occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.occluded_stream(rays, occluded)
    }
}

/// The estimators trace through the trait object as through any
/// intersector; a packet's width picks its method (`N` is known where the
/// estimator is compiled, so the downcasts fold to one call).
impl Intersector for dyn DynIntersector + '_ {
    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.dyn_intersect(ray)
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        self.dyn_occluded(ray)
    }

    #[inline]
    fn intersect_packet<const N: usize>(
        &self,
        rays: &RayPacket<N>,
        active: LaneMask,
        hits: &mut HitPacket<N>,
    ) {
        let (r, h): (&dyn Any, &mut dyn Any) = (rays, &mut *hits);
        if let (Some(r), Some(h)) = (r.downcast_ref(), h.downcast_mut()) {
            return self.dyn_intersect_1(r, active, h);
        }
        let (r, h): (&dyn Any, &mut dyn Any) = (rays, &mut *hits);
        if let (Some(r), Some(h)) = (r.downcast_ref(), h.downcast_mut()) {
            return self.dyn_intersect_4(r, active, h);
        }
        let (r, h): (&dyn Any, &mut dyn Any) = (rays, &mut *hits);
        if let (Some(r), Some(h)) = (r.downcast_ref(), h.downcast_mut()) {
            return self.dyn_intersect_8(r, active, h);
        }
        let (r, h): (&dyn Any, &mut dyn Any) = (rays, &mut *hits);
        if let (Some(r), Some(h)) = (r.downcast_ref(), h.downcast_mut()) {
            return self.dyn_intersect_16(r, active, h);
        }
        intersect_lanes(self, rays, active, hits)
    }

    #[inline]
    fn occluded_packet<const N: usize>(&self, rays: &RayPacket<N>, active: LaneMask) -> LaneMask {
        let r: &dyn Any = rays;
        if let Some(r) = r.downcast_ref() {
            return self.dyn_occluded_1(r, active);
        }
        if let Some(r) = r.downcast_ref() {
            return self.dyn_occluded_4(r, active);
        }
        if let Some(r) = r.downcast_ref() {
            return self.dyn_occluded_8(r, active);
        }
        if let Some(r) = r.downcast_ref() {
            return self.dyn_occluded_16(r, active);
        }
        occluded_lanes(self, rays, active)
    }

    #[inline]
    fn intersect_stream(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.dyn_intersect_stream(rays, hits)
    }

    #[inline]
    fn occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.dyn_occluded_stream(rays, occluded)
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::accel::bvh::Bvh;
    use crate::math::Vec3;

    /// Answers every query with a hit whose `prim` says which method ran:
    /// 0 for a single ray, `100 + N` for a packet of `N` lanes.
    struct Probe;

    fn marker(prim: u32) -> Option<Hit> {
        Some(Hit {
            t: 1.0,
            prim,
            b1: 0.0,
            b2: 0.0,
        })
    }

    impl Intersector for Probe {
        fn intersect(&self, _: &Ray) -> Option<Hit> {
            marker(0)
        }
        fn occluded(&self, _: &Ray) -> bool {
            false
        }
        fn intersect_packet<const N: usize>(
            &self,
            _: &RayPacket<N>,
            active: LaneMask,
            hits: &mut HitPacket<N>,
        ) {
            for i in active.iter() {
                hits.set(i, marker(100 + N as u32));
            }
        }
        fn occluded_packet<const N: usize>(&self, _: &RayPacket<N>, active: LaneMask) -> LaneMask {
            active
        }
    }

    fn probe<const N: usize>(i: &dyn DynIntersector) -> (Option<Hit>, LaneMask) {
        let (rays, mut hits) = (RayPacket::<N>::default(), HitPacket::<N>::default());
        let active = LaneMask::first(N);
        i.intersect_packet(&rays, active, &mut hits);
        (hits.get(N - 1), i.occluded_packet(&rays, active))
    }

    /// Each of the renderer's widths reaches the intersector's own packet
    /// method through the trait object (a width sent lane by lane would
    /// lose the BVH's packet kernels); other widths go lane by lane.
    #[test]
    fn each_width_reaches_its_own_packet_method() {
        let i: &dyn DynIntersector = &Probe;
        assert_eq!(probe::<1>(i), (marker(101), LaneMask::first(1)));
        assert_eq!(probe::<4>(i), (marker(104), LaneMask::first(4)));
        assert_eq!(probe::<8>(i), (marker(108), LaneMask::first(8)));
        assert_eq!(probe::<16>(i), (marker(116), LaneMask::first(16)));
        // Lane by lane: single-ray answers, and `Probe::occluded` says no.
        assert_eq!(probe::<3>(i), (marker(0), LaneMask::NONE));
        assert_eq!(i.intersect(&Ray::new(Vec3::ZERO, Vec3::Z)), marker(0));
    }

    /// A grid of small triangles at varying depths, and rays through and
    /// beside them.
    fn scene() -> (Bvh, Vec<Ray>) {
        let mut tris = Vec::new();
        for i in 0..8 {
            for j in 0..8 {
                let (x, y, z) = (i as f32, j as f32, 1.0 + ((i * 3 + j) % 5) as f32);
                tris.push([
                    Vec3::new(x, y, z),
                    Vec3::new(x + 0.9, y, z),
                    Vec3::new(x, y + 0.9, z + 0.3),
                ]);
            }
        }
        let rays = (0..48)
            .map(|k| {
                let (x, y) = ((k % 8) as f32 + 0.3, (k / 8) as f32 * 1.4 + 0.2);
                Ray::new(
                    Vec3::new(x, y, -1.0),
                    Vec3::new(0.01 * k as f32, 0.0, 1.0).normalize(),
                )
            })
            .collect();
        (Bvh::build(&tris), rays)
    }

    fn packet<const N: usize>(rays: &[Ray]) -> RayPacket<N> {
        let mut p = RayPacket::<N>::default();
        for (i, r) in rays.iter().take(N).enumerate() {
            p.set(i, r);
        }
        p
    }

    /// Our BVH behind the trait object answers bit for bit as itself, for
    /// every width (inactive lanes untouched); the BVH's own other widths
    /// (lane by lane) agree with its single rays.
    fn same_answers<const N: usize>(bvh: &Bvh, rays: &[Ray]) -> usize {
        let d: &dyn DynIntersector = bvh;
        let mut found = 0;
        for chunk in rays.chunks(N) {
            let p = packet::<N>(chunk);
            // Every other lane, so inactive lanes are checked too.
            let active = LaneMask(LaneMask::first(chunk.len()).0 & 0x5555_5555);
            let stale = marker(u32::MAX - 1);
            let (mut a, mut b) = (HitPacket::<N>::default(), HitPacket::<N>::default());
            for i in 0..N {
                a.set(i, stale);
                b.set(i, stale);
            }
            d.intersect_packet(&p, active, &mut a);
            bvh.intersect_packet(&p, active, &mut b);
            for i in 0..N {
                assert_eq!(a.get(i), b.get(i), "lane {i} of {N}");
                if active.get(i) {
                    assert_eq!(a.get(i), bvh.intersect(&p.get(i)), "lane {i} of {N}");
                    found += a.get(i).is_some() as usize;
                } else {
                    assert_eq!(a.get(i), stale, "inactive lane {i} of {N}");
                }
            }
            let occluded = d.occluded_packet(&p, active);
            assert_eq!(occluded, bvh.occluded_packet(&p, active));
            for i in 0..N {
                assert_eq!(occluded.get(i), active.get(i) && bvh.occluded(&p.get(i)));
            }
        }
        let mut streamed = vec![None; rays.len()];
        d.intersect_stream(rays, &mut streamed);
        assert!(
            streamed
                .iter()
                .zip(rays)
                .all(|(h, r)| *h == bvh.intersect(r))
        );
        found
    }

    #[test]
    fn our_bvh_answers_the_same_through_the_trait_object() {
        let (bvh, rays) = scene();
        let found = [
            same_answers::<1>(&bvh, &rays),
            same_answers::<3>(&bvh, &rays),
            same_answers::<4>(&bvh, &rays),
            same_answers::<8>(&bvh, &rays),
            same_answers::<16>(&bvh, &rays),
        ];
        // Hits and misses both occur, so the comparisons are not vacuous.
        assert!(found.iter().all(|&f| f > 3 && f < 24), "{found:?}");
    }
}
