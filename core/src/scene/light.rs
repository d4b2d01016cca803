//! Area emitters and their sampling.
//!
//! Every emissive mesh is one light. A light is chosen with probability
//! proportional to its power Φ = π · A · Y(Le) (luminance, since p(x̄) is
//! luminance), then a triangle in proportion to its area, then a uniform
//! point on it. The resulting density is uniform in area measure over each
//! light: p_A = P(light) / A(light). Zero-area triangles are never chosen.

use alloc::vec::Vec;

use glam::Vec2;

use super::store::Mesh;
use crate::math::{PI, warp};

/// One emissive mesh.
#[derive(Clone, Debug)]
pub struct AreaLight {
    /// Mesh index in the scene.
    pub mesh: u32,
    /// Total surface area.
    pub area: f32,
    /// Cumulative triangle areas normalised to end at 1.
    tri_cdf: Vec<f32>,
}

/// All lights of a scene and the power distribution over them.
#[derive(Clone, Debug, Default)]
pub struct LightSet {
    lights: Vec<AreaLight>,
    /// Cumulative selection probabilities, ending at 1.
    cdf: Vec<f32>,
    /// Selection probability of each light.
    pmf: Vec<f32>,
    /// Light index of each mesh, or `u32::MAX` for non-emissive meshes.
    mesh_light: Vec<u32>,
}

/// Where a light sample landed, before any geometry is evaluated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightPointSample {
    /// Mesh-local triangle index.
    pub triangle: usize,
    /// Mesh index.
    pub mesh: usize,
    /// Barycentrics of vertices 1 and 2.
    pub b: Vec2,
    /// Density per unit area, selection included.
    pub pdf_area: f32,
}

/// Binary search of a cumulative distribution ending at 1: the first index
/// whose cumulative value exceeds `u`, skipping zero-probability entries.
fn sample_cdf(cdf: &[f32], u: f32) -> usize {
    let i = cdf.partition_point(|&c| c <= u);
    i.min(cdf.len() - 1)
}

impl LightSet {
    /// Builds the light set of the emissive meshes among `meshes`.
    pub fn new(meshes: &[Mesh]) -> Self {
        let mut set = LightSet {
            mesh_light: alloc::vec![u32::MAX; meshes.len()],
            ..Default::default()
        };
        let mut power = Vec::new();
        for (mi, m) in meshes.iter().enumerate() {
            let Some(le) = m.emission else { continue };
            let mut acc = 0.0f64;
            let mut cdf = Vec::with_capacity(m.indices.len());
            for t in &m.indices {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                let area = 0.5 * (b - a).cross(c - a).length() as f64;
                acc += if area.is_finite() { area } else { 0.0 };
                cdf.push(acc);
            }
            let phi = PI as f64 * acc * le.luminance() as f64;
            if !(acc > 0.0 && phi > 0.0) {
                continue;
            }
            set.mesh_light[mi] = set.lights.len() as u32;
            set.lights.push(AreaLight {
                mesh: mi as u32,
                area: acc as f32,
                tri_cdf: cdf.iter().map(|c| (c / acc) as f32).collect(),
            });
            power.push(phi);
        }
        let total: f64 = power.iter().sum();
        let mut acc = 0.0;
        for p in &power {
            acc += p;
            set.pmf.push((p / total) as f32);
            set.cdf.push((acc / total) as f32);
        }
        if let Some(last) = set.cdf.last_mut() {
            *last = 1.0;
        }
        for l in &mut set.lights {
            if let Some(last) = l.tri_cdf.last_mut() {
                *last = 1.0;
            }
        }
        set
    }

    /// Number of lights that can be sampled.
    pub fn len(&self) -> usize {
        self.lights.len()
    }

    /// True when nothing emits: every estimate of such a scene is black.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// The lights.
    pub fn lights(&self) -> &[AreaLight] {
        &self.lights
    }

    /// Samples a light by power and a uniform point on it. `u_select` picks
    /// the light and then, rescaled, the triangle; `u` places the point.
    pub fn sample(&self, u_select: f32, u: Vec2) -> Option<LightPointSample> {
        if self.lights.is_empty() {
            return None;
        }
        let li = sample_cdf(&self.cdf, u_select);
        let lo = if li == 0 { 0.0 } else { self.cdf[li - 1] };
        let pmf = self.pmf[li];
        // Reuse the leftover of u_select for the triangle choice.
        let u_tri = if pmf > 0.0 {
            ((u_select - lo) / pmf).clamp(0.0, 1.0 - f32::EPSILON)
        } else {
            0.0
        };
        let light = &self.lights[li];
        let ti = sample_cdf(&light.tri_cdf, u_tri);
        Some(LightPointSample {
            triangle: ti,
            mesh: light.mesh as usize,
            b: warp::square_to_uniform_triangle(u),
            pdf_area: pmf / light.area,
        })
    }

    /// Density per unit area with which [`LightSet::sample`] picks a point
    /// on surface `surface` (a `SurfacePoint::surface`: zero for
    /// non-emissive meshes and for host shapes, which never emit).
    #[inline]
    pub fn pdf_area(&self, surface: usize) -> f32 {
        match self.mesh_light.get(surface) {
            Some(&li) if li != u32::MAX => self.pmf[li as usize] / self.lights[li as usize].area,
            _ => 0.0,
        }
    }
}
