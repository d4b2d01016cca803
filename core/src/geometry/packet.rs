//! Structure-of-arrays ray packets for coherent bundles.
//!
//! The layout mirrors Embree's `RTCRayN`/`RTCHitN` (one array per component,
//! lanes contiguous) so that the Embree backend and host callbacks can read a
//! packet without repacking. Packets are aligned to 64 bytes, which covers
//! the 16/32/64-byte alignment Embree wants for 4/8/16 lanes.

use glam::Vec3;

use super::{Hit, Ray};

/// Which lanes of a packet carry a ray; bit `i` is lane `i`. At most 16 lanes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(transparent)]
pub struct LaneMask(pub u32);

impl LaneMask {
    /// No lanes.
    pub const NONE: LaneMask = LaneMask(0);

    /// The first `n` lanes.
    #[inline]
    pub const fn first(n: usize) -> Self {
        if n >= 32 {
            LaneMask(u32::MAX)
        } else {
            LaneMask((1u32 << n) - 1)
        }
    }

    /// Whether lane `i` is set.
    #[inline]
    pub const fn get(self, i: usize) -> bool {
        self.0 >> i & 1 == 1
    }

    /// Sets lane `i`.
    #[inline]
    pub fn set(&mut self, i: usize) {
        self.0 |= 1 << i;
    }

    /// Number of set lanes.
    #[inline]
    pub const fn count(self) -> u32 {
        self.0.count_ones()
    }

    /// True when no lane is set.
    #[inline]
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Iterates the indices of set lanes in increasing order.
    #[inline]
    pub fn iter(self) -> impl Iterator<Item = usize> {
        let mut bits = self.0;
        core::iter::from_fn(move || {
            if bits == 0 {
                None
            } else {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                Some(i)
            }
        })
    }
}

/// `N` rays in SoA layout. Lanes outside the active mask hold arbitrary
/// (but initialised) values and must be ignored by every backend.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct RayPacket<const N: usize> {
    /// Origin x per lane.
    pub ox: [f32; N],
    /// Origin y per lane.
    pub oy: [f32; N],
    /// Origin z per lane.
    pub oz: [f32; N],
    /// Direction x per lane.
    pub dx: [f32; N],
    /// Direction y per lane.
    pub dy: [f32; N],
    /// Direction z per lane.
    pub dz: [f32; N],
    /// Exclusive upper bound of the hit distance per lane.
    pub t_max: [f32; N],
}

impl<const N: usize> Default for RayPacket<N> {
    fn default() -> Self {
        RayPacket {
            ox: [0.0; N],
            oy: [0.0; N],
            oz: [0.0; N],
            dx: [0.0; N],
            dy: [0.0; N],
            dz: [0.0; N],
            t_max: [0.0; N],
        }
    }
}

impl<const N: usize> RayPacket<N> {
    /// Writes `ray` into lane `i`.
    #[inline]
    pub fn set(&mut self, i: usize, ray: &Ray) {
        self.ox[i] = ray.o.x;
        self.oy[i] = ray.o.y;
        self.oz[i] = ray.o.z;
        self.dx[i] = ray.d.x;
        self.dy[i] = ray.d.y;
        self.dz[i] = ray.d.z;
        self.t_max[i] = ray.t_max;
    }

    /// Reads lane `i` back as a single ray.
    #[inline]
    pub fn get(&self, i: usize) -> Ray {
        Ray {
            o: Vec3::new(self.ox[i], self.oy[i], self.oz[i]),
            d: Vec3::new(self.dx[i], self.dy[i], self.dz[i]),
            t_max: self.t_max[i],
        }
    }
}

/// Closest hits of a packet in SoA layout; `prim[i] == HitPacket::MISS` marks
/// a lane that hit nothing (or was inactive).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct HitPacket<const N: usize> {
    /// Hit distance per lane.
    pub t: [f32; N],
    /// Scene-global triangle index per lane, or [`HitPacket::MISS`].
    pub prim: [u32; N],
    /// Barycentric of vertex 1 per lane.
    pub b1: [f32; N],
    /// Barycentric of vertex 2 per lane.
    pub b2: [f32; N],
}

impl<const N: usize> Default for HitPacket<N> {
    fn default() -> Self {
        HitPacket {
            t: [f32::INFINITY; N],
            prim: [Self::MISS; N],
            b1: [0.0; N],
            b2: [0.0; N],
        }
    }
}

impl<const N: usize> HitPacket<N> {
    /// Sentinel primitive index of a lane without a hit.
    pub const MISS: u32 = u32::MAX;

    /// Lane `i` as an optional single hit.
    #[inline]
    pub fn get(&self, i: usize) -> Option<Hit> {
        (self.prim[i] != Self::MISS).then(|| Hit {
            t: self.t[i],
            prim: self.prim[i],
            b1: self.b1[i],
            b2: self.b2[i],
        })
    }

    /// Stores an optional hit in lane `i`.
    #[inline]
    pub fn set(&mut self, i: usize, hit: Option<Hit>) {
        match hit {
            Some(h) => {
                self.t[i] = h.t;
                self.prim[i] = h.prim;
                self.b1[i] = h.b1;
                self.b2[i] = h.b2;
            }
            None => {
                self.t[i] = f32::INFINITY;
                self.prim[i] = Self::MISS;
            }
        }
    }
}
