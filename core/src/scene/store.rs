//! Owned scene storage and its validating builder.

use alloc::vec::Vec;
use core::fmt;

use glam::{Vec2, Vec3};

use super::camera::Camera;
use super::effects::{self, Analysis, Effect};
use super::light::LightSet;
use super::material::{Material, MaterialId};
use super::texture::{Bitmap, BitmapId, Texture};
use crate::geometry::{Hit, offset::barycentric_error};
use crate::math::Rgb;

/// A triangle mesh in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals; empty for flat (face-normal) shading.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates; empty when the mesh has none.
    pub uvs: Vec<Vec2>,
    /// Vertex indices of each triangle (counter-clockwise = front).
    pub indices: Vec<[u32; 3]>,
    /// Material of every triangle.
    pub material: MaterialId,
    /// Emitted radiance of an area emitter on the front side, if any.
    pub emission: Option<Rgb>,
}

impl Mesh {
    /// Checks the mesh alone as [`SceneBuilder::build`] will, naming it
    /// `index` in the error: attribute counts, finite vertices, indices in
    /// range, a material among the first `materials`, a finite
    /// non-negative emission. Lets a host reject a bad mesh when it hands
    /// it over.
    pub fn validate(&self, index: usize, materials: usize) -> Result<(), SceneError> {
        let (m, mi) = (self, index);
        let n = m.positions.len();
        if (!m.normals.is_empty() && m.normals.len() != n)
            || (!m.uvs.is_empty() && m.uvs.len() != n)
        {
            return Err(SceneError::AttributeCount { mesh: mi });
        }
        for v in 0..n {
            let bad = !m.positions[v].is_finite()
                || m.normals.get(v).is_some_and(|x| !x.is_finite())
                || m.uvs.get(v).is_some_and(|x| !x.is_finite());
            if bad {
                return Err(SceneError::NonFiniteVertex {
                    mesh: mi,
                    vertex: v,
                });
            }
        }
        if let Some(t) = m
            .indices
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= n))
        {
            return Err(SceneError::IndexOutOfRange {
                mesh: mi,
                triangle: t,
            });
        }
        if m.material.0 as usize >= materials {
            return Err(SceneError::UnknownMaterial { mesh: mi });
        }
        if let Some(e) = m.emission {
            if !(e.is_finite() && e.r >= 0.0 && e.g >= 0.0 && e.b >= 0.0) {
                return Err(SceneError::InvalidEmission { mesh: mi });
            }
        }
        Ok(())
    }
}

/// Why a scene was rejected. Each variant names the offending item.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneError {
    /// A mesh has a non-finite position, normal or uv.
    NonFiniteVertex {
        /// Mesh index.
        mesh: usize,
        /// Vertex index.
        vertex: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    IndexOutOfRange {
        /// Mesh index.
        mesh: usize,
        /// Triangle index within the mesh.
        triangle: usize,
    },
    /// Normals or uvs are given but their count differs from the positions'.
    AttributeCount {
        /// Mesh index.
        mesh: usize,
    },
    /// A mesh names a material that was never added.
    UnknownMaterial {
        /// Mesh index.
        mesh: usize,
    },
    /// A texture names a bitmap that was never added.
    UnknownBitmap {
        /// Material index.
        material: usize,
    },
    /// A material parameter is out of range.
    InvalidMaterial {
        /// Material index.
        material: usize,
        /// What is wrong.
        reason: &'static str,
    },
    /// An emitter's radiance is negative or not finite.
    InvalidEmission {
        /// Mesh index.
        mesh: usize,
    },
    /// More triangles than a `u32` can number.
    TooManyTriangles,
    /// No camera was set.
    MissingCamera,
    /// The scene needs an effect whose code this build of the core left
    /// out (its cargo feature is off).
    EffectNotBuilt {
        /// The effect.
        effect: Effect,
    },
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneError::NonFiniteVertex { mesh, vertex } => {
                write!(
                    f,
                    "mesh {mesh}: vertex {vertex} has a non-finite position, normal or uv"
                )
            }
            SceneError::IndexOutOfRange { mesh, triangle } => {
                write!(
                    f,
                    "mesh {mesh}: triangle {triangle} refers to a vertex index out of range"
                )
            }
            SceneError::AttributeCount { mesh } => {
                write!(
                    f,
                    "mesh {mesh}: normals/uvs must be empty or one per position"
                )
            }
            SceneError::UnknownMaterial { mesh } => {
                write!(f, "mesh {mesh}: material id does not exist")
            }
            SceneError::UnknownBitmap { material } => {
                write!(f, "material {material}: bitmap id does not exist")
            }
            SceneError::InvalidMaterial { material, reason } => {
                write!(f, "material {material}: {reason}")
            }
            SceneError::InvalidEmission { mesh } => {
                write!(
                    f,
                    "mesh {mesh}: emitted radiance must be finite and non-negative"
                )
            }
            SceneError::TooManyTriangles => write!(f, "scene has more than 2^32 - 1 triangles"),
            SceneError::MissingCamera => write!(f, "scene has no camera"),
            SceneError::EffectNotBuilt { effect } => write!(
                f,
                "the scene needs {}, which this build of cmlt leaves out (enable the `{}` feature)",
                effect.name(),
                effect.feature().unwrap_or("?")
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for SceneError {}

/// Collects meshes, materials, bitmaps and the camera, then validates them
/// all at once in [`SceneBuilder::build`].
#[derive(Clone, Default)]
pub struct SceneBuilder {
    meshes: Vec<Mesh>,
    materials: Vec<Material>,
    bitmaps: Vec<Bitmap>,
    camera: Option<Camera>,
}

impl SceneBuilder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a material and returns its id.
    pub fn add_material(&mut self, m: Material) -> MaterialId {
        self.materials.push(m);
        MaterialId(self.materials.len() as u32 - 1)
    }

    /// Adds a bitmap and returns its id.
    pub fn add_bitmap(&mut self, b: Bitmap) -> BitmapId {
        self.bitmaps.push(b);
        BitmapId(self.bitmaps.len() as u32 - 1)
    }

    /// Adds a mesh; returns its index. Validation happens in `build`.
    pub fn add_mesh(&mut self, mesh: Mesh) -> usize {
        self.meshes.push(mesh);
        self.meshes.len() - 1
    }

    /// Sets the camera.
    pub fn set_camera(&mut self, camera: Camera) {
        self.camera = Some(camera);
    }

    /// Validates everything and builds the scene (light set included).
    pub fn build(self) -> Result<Scene, SceneError> {
        for (i, m) in self.materials.iter().enumerate() {
            m.validate().map_err(|reason| SceneError::InvalidMaterial {
                material: i,
                reason,
            })?;
            let tex_refs = match &m.kind {
                super::MaterialKind::Diffuse { reflectance } => [Some(reflectance), None],
                super::MaterialKind::Conductor {
                    specular_reflectance,
                    ..
                }
                | super::MaterialKind::RoughConductor {
                    specular_reflectance,
                    ..
                } => [Some(specular_reflectance), None],
                super::MaterialKind::Dielectric { .. } => [None, None],
            };
            for t in tex_refs.into_iter().flatten() {
                if let Texture::Bitmap { id, .. } = t {
                    if id.0 as usize >= self.bitmaps.len() {
                        return Err(SceneError::UnknownBitmap { material: i });
                    }
                }
            }
        }
        let mut total: u64 = 0;
        for (mi, m) in self.meshes.iter().enumerate() {
            m.validate(mi, self.materials.len())?;
            total += m.indices.len() as u64;
        }
        if total >= u32::MAX as u64 {
            return Err(SceneError::TooManyTriangles);
        }
        let camera = self.camera.ok_or(SceneError::MissingCamera)?;
        effects::check_built(&self.materials, &self.meshes, &camera)?;
        let mut tri_mesh = Vec::with_capacity(total as usize);
        let mut first_tri = Vec::with_capacity(self.meshes.len());
        for (mi, m) in self.meshes.iter().enumerate() {
            first_tri.push(tri_mesh.len() as u32);
            tri_mesh.extend(core::iter::repeat_n(mi as u32, m.indices.len()));
        }
        let lights = LightSet::new(&self.meshes);
        Ok(Scene {
            meshes: self.meshes,
            materials: self.materials,
            bitmaps: self.bitmaps,
            camera,
            tri_mesh,
            first_tri,
            lights,
        })
    }
}

/// A validated, immutable scene. Shared read-only by all render threads.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Meshes in insertion order.
    pub meshes: Vec<Mesh>,
    /// Materials referenced by meshes.
    pub materials: Vec<Material>,
    /// Bitmaps referenced by textures.
    pub bitmaps: Vec<Bitmap>,
    /// The camera.
    pub camera: Camera,
    /// Mesh index of each scene-global triangle.
    tri_mesh: Vec<u32>,
    /// Global index of each mesh's first triangle.
    first_tri: Vec<u32>,
    /// Emitters, with the power distribution used to pick one.
    pub lights: LightSet,
}

/// A point on a surface with everything shading needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Position.
    pub p: Vec3,
    /// Conservative absolute error bound of `p`, per axis (for ray offsets).
    pub p_error: Vec3,
    /// Unit geometric normal, on the same side as `ns`.
    pub ng: Vec3,
    /// Unit shading normal (equal to `ng` for flat-shaded meshes).
    pub ns: Vec3,
    /// Texture coordinates (zero when the mesh has none).
    pub uv: Vec2,
    /// Mesh index.
    pub mesh: u32,
    /// Scene-global triangle index.
    pub prim: u32,
}

impl Scene {
    /// What the scene calls for, seen through `camera` (its aperture
    /// decides depth of field): materials of meshes with triangles, emitting
    /// meshes.
    pub fn analysis(&self, camera: &Camera) -> Analysis {
        let used = |i: usize| {
            self.meshes
                .iter()
                .any(|m| m.material.0 as usize == i && !m.indices.is_empty())
        };
        let emitters = self
            .meshes
            .iter()
            .any(|m| m.emission.is_some() && !m.indices.is_empty());
        Analysis::of(&self.materials, used, emitters, camera.aperture_radius())
    }

    /// Number of triangles in the scene.
    pub fn triangle_count(&self) -> usize {
        self.tri_mesh.len()
    }

    /// Mesh index and local triangle index of a global triangle.
    #[inline]
    pub fn locate(&self, prim: u32) -> (usize, usize) {
        let mi = self.tri_mesh[prim as usize] as usize;
        (mi, (prim - self.first_tri[mi]) as usize)
    }

    /// The three vertex positions of a global triangle.
    #[inline]
    pub fn triangle(&self, prim: u32) -> [Vec3; 3] {
        let (mi, ti) = self.locate(prim);
        let m = &self.meshes[mi];
        let [a, b, c] = m.indices[ti];
        [
            m.positions[a as usize],
            m.positions[b as usize],
            m.positions[c as usize],
        ]
    }

    /// Iterates all triangles' vertices in global order (for BVH builders).
    pub fn triangles(&self) -> impl Iterator<Item = [Vec3; 3]> + '_ {
        self.meshes.iter().flat_map(|m| {
            m.indices.iter().map(|t| {
                [
                    m.positions[t[0] as usize],
                    m.positions[t[1] as usize],
                    m.positions[t[2] as usize],
                ]
            })
        })
    }

    /// The surface point of barycentrics `(b1, b2)` on global triangle `prim`.
    /// Returns `None` for a degenerate (zero-area) triangle, which has no
    /// normal and scatters nothing.
    pub fn surface_point(&self, prim: u32, b1: f32, b2: f32) -> Option<SurfacePoint> {
        let (mi, ti) = self.locate(prim);
        let m = &self.meshes[mi];
        let idx = m.indices[ti].map(|i| i as usize);
        let [p0, p1, p2] = idx.map(|i| m.positions[i]);
        let b0 = 1.0 - b1 - b2;
        let p = p0 * b0 + p1 * b1 + p2 * b2;
        let p_error = barycentric_error(p0, p1, p2, b0, b1, b2);
        let ng = (p1 - p0).cross(p2 - p0);
        let len = ng.length();
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        let mut ng = ng / len;
        let mut ns = ng;
        if !m.normals.is_empty() {
            let n = m.normals[idx[0]] * b0 + m.normals[idx[1]] * b1 + m.normals[idx[2]] * b2;
            let l = n.length();
            // A zero interpolated normal (e.g. opposite vertex normals) falls
            // back to the face normal instead of producing NaNs.
            if l > 0.0 && l.is_finite() {
                ns = n / l;
                // Keep the geometric normal on the shading normal's side, as
                // Mitsuba does, so sidedness tests agree.
                if ng.dot(ns) < 0.0 {
                    ng = -ng;
                }
            }
        }
        let uv = if m.uvs.is_empty() {
            Vec2::ZERO
        } else {
            m.uvs[idx[0]] * b0 + m.uvs[idx[1]] * b1 + m.uvs[idx[2]] * b2
        };
        Some(SurfacePoint {
            p,
            p_error,
            ng,
            ns,
            uv,
            mesh: mi as u32,
            prim,
        })
    }

    /// The surface point of an intersection.
    #[inline]
    pub fn hit_point(&self, hit: &Hit) -> Option<SurfacePoint> {
        self.surface_point(hit.prim, hit.b1, hit.b2)
    }

    /// Scene-global index of triangle `tri` of mesh `mesh`.
    #[inline]
    pub fn global_prim(&self, mesh: usize, tri: usize) -> u32 {
        self.first_tri[mesh] + tri as u32
    }

    /// Samples a point on the lights (by power, then area): the point and
    /// its density per unit area. `None` when nothing emits or the chosen
    /// point is degenerate.
    #[inline]
    pub fn sample_light(&self, u_select: f32, u: Vec2) -> Option<(SurfacePoint, f32)> {
        let ls = self.lights.sample(u_select, u)?;
        let sp = self.surface_point(self.global_prim(ls.mesh, ls.triangle), ls.b.x, ls.b.y)?;
        Some((sp, ls.pdf_area))
    }

    /// The material of a surface point.
    #[inline]
    pub fn material(&self, sp: &SurfacePoint) -> &Material {
        &self.materials[self.meshes[sp.mesh as usize].material.0 as usize]
    }

    /// Radiance emitted from `sp` towards direction `w` (unit, pointing away
    /// from the surface): area emitters radiate only on the side their
    /// shading normal points to (Mitsuba's `area`).
    #[inline]
    pub fn emitted(&self, sp: &SurfacePoint, w: Vec3) -> Rgb {
        match self.meshes[sp.mesh as usize].emission {
            Some(le) if w.dot(sp.ns) > 0.0 => le,
            _ => Rgb::ZERO,
        }
    }
}
