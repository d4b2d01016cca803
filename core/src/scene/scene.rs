//! The scene's owned storage ([`Scene`]) and its validating builder.

use alloc::vec::Vec;
use core::fmt;

use glam::{Vec2, Vec3};

use super::camera::Camera;
use super::effects::{Analysis, Effect};
use super::grid::{Grid, GridId};
use super::light::{Chosen, Light, LightSet};
use super::material::{Material, MaterialId, MaterialKind};
use super::medium::{Medium, MediumId, MediumInterface};
use super::shapes::{SHAPE_PRIM_BIT, ShapeGroup};
use super::texture::{Bitmap, BitmapId, TexCoords, Texture, TextureImages};
use crate::geometry::Hit;
use crate::geometry::offset::{TrianglePoint, triangle_point};
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
        if let Some(e) = m.emission
            && !(e.is_finite() && e.r >= 0.0 && e.g >= 0.0 && e.b >= 0.0)
        {
            return Err(SceneError::InvalidEmission { mesh: mi });
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
    /// A texture names a voxel grid that was never added.
    UnknownGrid {
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
    /// More triangles than scene-global numbering allows (2^31 − 1).
    TooManyTriangles,
    /// The allocator refused storage the change needs (normals given to
    /// a mesh that had none).
    OutOfMemory,
    /// An update names a mesh that does not exist.
    UnknownMesh {
        /// Mesh index.
        mesh: usize,
    },
    /// A shape group names a material that was never added.
    UnknownShapeMaterial {
        /// Shape group index.
        group: usize,
    },
    /// More host shapes than their numbering allows (2^31 − 1).
    TooManyShapes,
    /// No camera was set.
    MissingCamera,
    /// A mesh's or the camera's medium does not exist, or media were
    /// attached to a mesh that does not exist.
    UnknownMedium {
        /// The mesh (`None`: the camera).
        mesh: Option<usize>,
    },
    /// A light's parameter is out of range.
    InvalidLight {
        /// Light index (in [`SceneBuilder::add_light`] order).
        light: usize,
        /// What is wrong.
        reason: &'static str,
    },
    /// The scene needs an effect whose code this build of the core left
    /// out (its cargo feature is off).
    EffectNotBuilt {
        /// The effect.
        effect: Effect,
    },
    /// The meshes lie so far from the origin, for their size, that f32
    /// cannot resolve them: see [`MAX_DISTANCE_TO_EXTENT`].
    TooFarFromOrigin {
        /// The largest |coordinate| of any vertex.
        max_coordinate: f32,
        /// The diagonal of the meshes' bounding box.
        extent: f32,
    },
}

/// Largest ratio of the meshes' largest |coordinate| to their bounding
/// box's diagonal that [`SceneBuilder::build`] accepts: 2^16.
///
/// Why: f32 positions at |p| are spaced |p|·2^-23 apart, and a hit
/// point's rounding error bound, by which secondary rays are offset
/// (pbrt-v4's robust spawn points, `geometry::offset`), is γ(7)·|p| ≈
/// 4·10^-7·|p|. At a ratio of 2^16 that offset is 2.7 % of the whole
/// scene and the grid spacing 0.8 %. Measured on PT's white furnace of a
/// box of diagonal 3.5 (exactly 2): 2.02 at 10^5 from the origin (ratio
/// 2.9·10^4), 2.05 at 3·10^5 (8.7·10^4), 1.97 at 10^6, 1.07 at 10^7. The
/// offsets are right; f32 cannot hold the scene there. A host should move
/// such a scene (and its camera) near the origin.
pub const MAX_DISTANCE_TO_EXTENT: f32 = 65_536.0;

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
            SceneError::OutOfMemory => f.write_str("out of memory"),
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
            SceneError::UnknownGrid { material } => {
                write!(f, "material {material}: voxel grid id does not exist")
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
            SceneError::TooManyTriangles => write!(f, "scene has more than 2^31 - 1 triangles"),
            SceneError::UnknownMesh { mesh } => write!(f, "mesh {mesh} does not exist"),
            SceneError::UnknownShapeMaterial { group } => {
                write!(f, "shape group {group}: material id does not exist")
            }
            SceneError::TooManyShapes => write!(f, "scene has more than 2^31 - 1 host shapes"),
            SceneError::MissingCamera => write!(f, "scene has no camera"),
            SceneError::UnknownMedium { mesh: Some(m) } => {
                write!(f, "mesh {m}: a medium (or the mesh) does not exist")
            }
            SceneError::UnknownMedium { mesh: None } => {
                write!(f, "the camera's medium does not exist")
            }
            SceneError::InvalidLight { light, reason } => write!(f, "light {light}: {reason}"),
            SceneError::EffectNotBuilt { effect } => write!(
                f,
                "the scene needs {}, which this build of cmlt leaves out (enable the `{}` feature)",
                effect.name(),
                effect.feature().unwrap_or("?")
            ),
            SceneError::TooFarFromOrigin {
                max_coordinate,
                extent,
            } => write!(
                f,
                "the meshes reach |coordinate| {max_coordinate:e} but span only {extent:e}: \
                 beyond {MAX_DISTANCE_TO_EXTENT} times its size from the origin, f32 cannot \
                 resolve a scene (rays would leave from the wrong places); move it and the \
                 camera near the origin"
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for SceneError {}

/// Refuses meshes too far from the origin for their size
/// ([`MAX_DISTANCE_TO_EXTENT`]); positions are finite (checked before).
fn check_precision<'a>(positions: impl Iterator<Item = &'a Vec3>) -> Result<(), SceneError> {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in positions {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    if lo.x > hi.x {
        return Ok(());
    }
    let max_coordinate = lo.abs().max(hi.abs()).max_element();
    let extent = (hi - lo).length();
    // Zero extent (degenerate meshes only) renders nothing either way.
    if extent > 0.0 && max_coordinate > MAX_DISTANCE_TO_EXTENT * extent {
        return Err(SceneError::TooFarFromOrigin {
            max_coordinate,
            extent,
        });
    }
    Ok(())
}

/// Collects meshes, materials, bitmaps and the camera, then validates them
/// all at once in [`SceneBuilder::build`].
#[derive(Clone, Default)]
pub struct SceneBuilder {
    meshes: Vec<Mesh>,
    materials: Vec<Material>,
    bitmaps: Vec<Bitmap>,
    grids: Vec<Grid>,
    shapes: Vec<ShapeGroup>,
    lights: Vec<Light>,
    camera: Option<Camera>,
    media: Vec<Medium>,
    /// (mesh, its media), in the order given; a later entry for a mesh
    /// replaces an earlier one.
    mesh_media: Vec<(usize, MediumInterface)>,
    camera_medium: Option<MediumId>,
}

impl SceneBuilder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Makes room for one more of each element, so that the next
    /// `add_*` of each kind cannot allocate (a host that must not run out
    /// of memory halfway through a change reserves first).
    pub fn try_reserve_one(&mut self) -> Result<(), alloc::collections::TryReserveError> {
        self.meshes.try_reserve(1)?;
        self.materials.try_reserve(1)?;
        self.bitmaps.try_reserve(1)?;
        self.grids.try_reserve(1)?;
        self.shapes.try_reserve(1)?;
        self.media.try_reserve(1)?;
        self.mesh_media.try_reserve(1)?;
        self.lights.try_reserve(1)
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

    /// Adds a voxel grid (a `volume` texture's data) and returns its id.
    pub fn add_grid(&mut self, g: Grid) -> GridId {
        self.grids.push(g);
        GridId(self.grids.len() as u32 - 1)
    }

    /// Adds a mesh; returns its index. Validation happens in `build`.
    pub fn add_mesh(&mut self, mesh: Mesh) -> usize {
        self.meshes.push(mesh);
        self.meshes.len() - 1
    }

    /// Adds a group of host shapes (see [`super::shapes`]); returns the
    /// shape index of its first shape, the one the host's intersector
    /// reports as `SHAPE_PRIM_BIT | index`. Validation happens in `build`.
    pub fn add_shapes(&mut self, group: ShapeGroup) -> u32 {
        let first = self.shapes.iter().map(|g| g.count).sum();
        self.shapes.push(group);
        first
    }

    /// Adds a light that is not an emissive mesh (a point, spot,
    /// directional light or an environment); returns its index.
    /// Validation happens in `build`.
    pub fn add_light(&mut self, light: Light) -> usize {
        self.lights.push(light);
        self.lights.len() - 1
    }

    /// Sets the camera.
    pub fn set_camera(&mut self, camera: Camera) {
        self.camera = Some(camera);
    }

    /// Adds a participating medium (checked when it was made,
    /// [`Medium::homogeneous`]) and returns its id.
    pub fn add_medium(&mut self, medium: Medium) -> MediumId {
        self.media.push(medium);
        MediumId(self.media.len() as u32 - 1)
    }

    /// Attaches media to the two sides of mesh `mesh` (an index
    /// [`SceneBuilder::add_mesh`] returned). Validation happens in `build`.
    pub fn set_mesh_media(&mut self, mesh: usize, media: MediumInterface) {
        self.mesh_media.push((mesh, media));
    }

    /// Sets the medium the camera sits in (`None`: vacuum, the default).
    pub fn set_camera_medium(&mut self, medium: Option<MediumId>) {
        self.camera_medium = medium;
    }

    /// Validates everything and builds the scene (light set included).
    pub fn build(self) -> Result<Scene, SceneError> {
        for (i, m) in self.materials.iter().enumerate() {
            m.validate().map_err(|reason| SceneError::InvalidMaterial {
                material: i,
                reason,
            })?;
            let tex_refs = match &m.kind {
                super::MaterialKind::Diffuse { reflectance }
                | super::MaterialKind::RoughDiffuse { reflectance, .. } => {
                    [Some(reflectance), None]
                }
                super::MaterialKind::Conductor {
                    specular_reflectance,
                    ..
                }
                | super::MaterialKind::RoughConductor {
                    specular_reflectance,
                    ..
                } => [Some(specular_reflectance), None],
                super::MaterialKind::Dielectric { .. } => [None, None],
                super::MaterialKind::TintedDielectric {
                    specular_reflectance,
                    specular_transmittance,
                    ..
                }
                | super::MaterialKind::ThinDielectric {
                    specular_reflectance,
                    specular_transmittance,
                    ..
                }
                | super::MaterialKind::RoughDielectric {
                    specular_reflectance,
                    specular_transmittance,
                    ..
                } => [Some(specular_reflectance), Some(specular_transmittance)],
                super::MaterialKind::Plastic {
                    diffuse_reflectance,
                    specular_reflectance,
                    ..
                }
                | super::MaterialKind::RoughPlastic {
                    diffuse_reflectance,
                    specular_reflectance,
                    ..
                } => [Some(diffuse_reflectance), Some(specular_reflectance)],
                super::MaterialKind::Principled(_) | super::MaterialKind::Null => [None, None],
            };
            let principled = match &m.kind {
                super::MaterialKind::Principled(p) => Some(p.textures()),
                _ => None,
            };
            for t in tex_refs
                .into_iter()
                .flatten()
                .chain(principled.into_iter().flatten())
                .chain(m.detail.textures())
            {
                if let Texture::Bitmap { id, .. } = t
                    && id.0 as usize >= self.bitmaps.len()
                {
                    return Err(SceneError::UnknownBitmap { material: i });
                }
                if let Texture::Grid(id) = t {
                    let Some(g) = self.grids.get(id.0 as usize) else {
                        return Err(SceneError::UnknownGrid { material: i });
                    };
                    // Every material slot a texture fills (reflectances,
                    // the principled scalars, opacity) is a fraction:
                    // trilinear weights are convex, so voxels in [0, 1]
                    // keep every lookup there, as `Material::validate`
                    // asks of constants.
                    let m = g.max();
                    if m.r > 1.0 || m.g > 1.0 || m.b > 1.0 {
                        return Err(SceneError::InvalidMaterial {
                            material: i,
                            reason: "a volume (grid) texture's voxels must lie in [0, 1]",
                        });
                    }
                }
            }
        }
        let mut total: u64 = 0;
        for (mi, m) in self.meshes.iter().enumerate() {
            m.validate(mi, self.materials.len())?;
            total += m.indices.len() as u64;
        }
        check_precision(self.meshes.iter().flat_map(|m| m.positions.iter()))?;
        // Triangle and shape indices share `Hit::prim`, split by its top bit.
        if total >= SHAPE_PRIM_BIT as u64 {
            return Err(SceneError::TooManyTriangles);
        }
        let mut first_shape = Vec::with_capacity(self.shapes.len());
        let mut shapes: u64 = 0;
        for (gi, g) in self.shapes.iter().enumerate() {
            if g.material.0 as usize >= self.materials.len() {
                return Err(SceneError::UnknownShapeMaterial { group: gi });
            }
            first_shape.push(shapes as u32);
            shapes += g.count as u64;
        }
        if shapes >= SHAPE_PRIM_BIT as u64 {
            return Err(SceneError::TooManyShapes);
        }
        for (li, l) in self.lights.iter().enumerate() {
            l.validate()
                .map_err(|reason| SceneError::InvalidLight { light: li, reason })?;
            // Infinite lights emit light subpaths through the scene's
            // bounding sphere, which host shapes do not report.
            if l.is_infinite() && !self.shapes.is_empty() {
                return Err(SceneError::InvalidLight {
                    light: li,
                    reason: "lights at infinity need the scene's bounds, which host shapes do not give",
                });
            }
            if let Light::Envmap { bitmap, .. } = *l {
                let Some(b) = self.bitmaps.get(bitmap.0 as usize) else {
                    return Err(SceneError::InvalidLight {
                        light: li,
                        reason: "environment map: bitmap id does not exist",
                    });
                };
                // Bitmaps are finite (Bitmap::new); radiance must also be
                // non-negative.
                if b.texels()
                    .iter()
                    .any(|t| t.r < 0.0 || t.g < 0.0 || t.b < 0.0)
                {
                    return Err(SceneError::InvalidLight {
                        light: li,
                        reason: "environment map: the bitmap has negative texels",
                    });
                }
            }
        }
        let camera = self.camera.ok_or(SceneError::MissingCamera)?;
        let medium_ok = |m: Option<MediumId>| m.is_none_or(|m| (m.0 as usize) < self.media.len());
        if !medium_ok(self.camera_medium) {
            return Err(SceneError::UnknownMedium { mesh: None });
        }
        // One interface per mesh, or none at all when no mesh names media
        // (then the estimators never look them up).
        let mut mesh_media = Vec::new();
        for &(mi, m) in &self.mesh_media {
            if mi >= self.meshes.len() || !medium_ok(m.interior) || !medium_ok(m.exterior) {
                return Err(SceneError::UnknownMedium { mesh: Some(mi) });
            }
            if mesh_media.is_empty() {
                mesh_media = alloc::vec![MediumInterface::default(); self.meshes.len()];
            }
            mesh_media[mi] = m;
        }
        let mut tri_mesh = Vec::with_capacity(total as usize);
        let mut first_tri = Vec::with_capacity(self.meshes.len());
        for (mi, m) in self.meshes.iter().enumerate() {
            first_tri.push(tri_mesh.len() as u32);
            tri_mesh.extend(core::iter::repeat_n(mi as u32, m.indices.len()));
        }
        let lights = LightSet::with_bitmaps(&self.meshes, &self.lights, &self.bitmaps);
        // The motion frame's starting positions: sized here, so that moving
        // meshes later allocates nothing.
        let mut first_vertex = Vec::with_capacity(self.meshes.len());
        let mut previous = Vec::new();
        for m in &self.meshes {
            first_vertex.push(previous.len());
            previous.extend_from_slice(&m.positions);
        }
        let moved_in = alloc::vec![0; self.meshes.len()];
        let scene = Scene {
            light_list: self.lights,
            meshes: self.meshes,
            materials: self.materials,
            bitmaps: self.bitmaps,
            grids: self.grids,
            shapes: self.shapes,
            camera,
            tri_mesh,
            first_tri,
            first_shape,
            lights,
            revision: 0,
            previous,
            first_vertex,
            moved_in,
            motion_frame: 1,
            media: self.media,
            mesh_media,
            camera_medium: self.camera_medium,
        };
        // A build without some effect's code must refuse a scene that needs
        // it (meshes and host shapes alike), never render it wrong.
        match scene.analysis(&scene.camera).unbuilt() {
            Some(effect) => Err(SceneError::EffectNotBuilt { effect }),
            None => Ok(scene),
        }
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
    /// Voxel grids referenced by textures.
    pub grids: Vec<Grid>,
    /// Host shape groups in insertion order.
    pub shapes: Vec<ShapeGroup>,
    /// The camera.
    pub camera: Camera,
    /// Mesh index of each scene-global triangle.
    tri_mesh: Vec<u32>,
    /// Global index of each mesh's first triangle.
    first_tri: Vec<u32>,
    /// Shape index of each shape group's first shape.
    first_shape: Vec<u32>,
    /// Emitters, with the power distribution used to pick one.
    pub lights: LightSet,
    /// The lights added with [`SceneBuilder::add_light`].
    light_list: Vec<Light>,
    /// Bumped by every [`Scene::update_mesh`]: renderers compare it to
    /// notice that the scene changed under them.
    revision: u64,
    /// Every mesh's vertex positions when the current motion frame
    /// ([`Scene::begin_frame`]) started, meshes one after the other from
    /// `first_vertex[mesh]`; a mesh's entries are current only when
    /// `moved_in[mesh] == motion_frame` (copied by its first update of the
    /// frame), otherwise it has not moved and its positions are its own.
    previous: Vec<Vec3>,
    first_vertex: Vec<usize>,
    /// The motion frame of each mesh's last update (0: never moved).
    moved_in: Vec<u64>,
    /// Counts [`Scene::begin_frame`] calls, from 1.
    motion_frame: u64,
    /// Participating media, referenced by [`MediumId`].
    pub media: Vec<Medium>,
    /// Each mesh's media; empty when no mesh names any.
    mesh_media: Vec<MediumInterface>,
    /// The medium the camera sits in.
    camera_medium: Option<MediumId>,
}

/// A light chosen by [`Scene::sample_emitter`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EmitterSample {
    /// A point on an emissive mesh and its density per unit area,
    /// selection included.
    Area {
        /// The point.
        sp: SurfacePoint,
        /// Density per unit area.
        pdf_area: f32,
    },
    /// Light `index` of [`LightSet::others`], chosen with probability
    /// `pmf`.
    Other {
        /// Index into [`LightSet::others`].
        index: usize,
        /// Selection probability.
        pmf: f32,
    },
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
    /// The surface the point lies on: a mesh index, or
    /// `SHAPE_PRIM_BIT | g` for host shape group `g`.
    pub surface: u32,
    /// The `Hit::prim` of the point: a scene-global triangle index, or
    /// `SHAPE_PRIM_BIT | shape` for a host shape.
    pub prim: u32,
}

impl SurfacePoint {
    /// Where textures are looked up at this point.
    #[inline]
    pub fn tex_coords(&self) -> TexCoords {
        TexCoords {
            uv: self.uv,
            p: self.p,
        }
    }
}

impl Scene {
    /// The images the scene's textures read.
    #[inline]
    pub fn texture_images(&self) -> TextureImages<'_> {
        TextureImages {
            bitmaps: &self.bitmaps,
            grids: &self.grids,
        }
    }

    /// What the scene calls for, seen through `camera` (its aperture
    /// decides depth of field): materials of meshes with triangles, emitting
    /// meshes.
    pub fn analysis(&self, camera: &Camera) -> Analysis {
        let used = |i: usize| {
            self.meshes
                .iter()
                .any(|m| m.material.0 as usize == i && !m.indices.is_empty())
                || self
                    .shapes
                    .iter()
                    .any(|g| g.material.0 as usize == i && g.count > 0)
        };
        let emitters = self
            .meshes
            .iter()
            .any(|m| m.emission.is_some() && !m.indices.is_empty());
        let mut a = Analysis::of(&self.materials, used, emitters, camera.aperture_radius());
        for l in self.lights.others() {
            a.effects = a.effects.with(l.effect());
        }
        if self.has_media() {
            a.effects = a.effects.with(Effect::Media);
            // Light scattered in a medium makes paths beyond one segment
            // count even when no surface scatters.
            a.emitters_only &= !self.media.iter().any(Medium::scatters);
        }
        a
    }

    /// Whether light meets a medium or a null boundary anywhere: a
    /// medium is attached to a mesh or the camera, or a used material is
    /// null. Only then do the estimators run the media code.
    pub fn has_media(&self) -> bool {
        !self.mesh_media.is_empty()
            || self.camera_medium.is_some()
            || self
                .meshes
                .iter()
                .map(|m| m.material)
                .chain(self.shapes.iter().map(|g| g.material))
                .any(|id| matches!(self.materials[id.0 as usize].kind, MaterialKind::Null))
    }

    /// Whether a used material has a Dirac lobe beside smooth ones
    /// (smooth plastic's coating over its diffuse base): BSDF sampling
    /// can take that lobe, which `eval` does not see.
    pub fn has_mixed_dirac_lobes(&self) -> bool {
        self.meshes
            .iter()
            .map(|m| m.material)
            .chain(self.shapes.iter().map(|g| g.material))
            .any(|id| {
                matches!(
                    self.materials[id.0 as usize].kind,
                    MaterialKind::Plastic { .. }
                )
            })
    }

    /// The medium the camera sits in.
    #[inline]
    pub fn camera_medium(&self) -> Option<MediumId> {
        self.camera_medium
    }

    /// The media on the two sides of the surface `surface` (a
    /// [`SurfacePoint::surface`]): none for host shapes and for meshes
    /// that name none.
    #[inline]
    pub fn surface_media(&self, surface: u32) -> MediumInterface {
        self.mesh_media
            .get(surface as usize)
            .copied()
            .unwrap_or_default()
    }

    /// The medium `id`.
    #[inline]
    pub fn medium(&self, id: MediumId) -> &Medium {
        &self.media[id.0 as usize]
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

    /// The surface point of barycentrics `(b1, b2)` on global triangle `prim`,
    /// kept a few ulps off the triangle's edges
    /// ([`crate::geometry::offset::triangle_point`]). Returns `None` for a
    /// degenerate (zero-area) triangle, which has no normal and scatters
    /// nothing.
    pub fn surface_point(&self, prim: u32, b1: f32, b2: f32) -> Option<SurfacePoint> {
        // Kept off the triangle's edges, so that a walk from a hit next to
        // an edge of a closed mesh stays inside it; the normal and uv are
        // interpolated at the weights of that point.
        self.mesh_point(prim, |tri| triangle_point(tri, b1, b2))
    }

    /// The surface point of barycentrics `(b1, b2)` on global triangle
    /// `prim` for shading alone — its normals, uv and material, for the
    /// auxiliary outputs ([`crate::aov`]) — not moved off the edges and
    /// with no error bound (`p_error` zero): no ray may leave from it
    /// (that is [`Scene::surface_point`]'s). `None` for a degenerate
    /// triangle.
    pub fn shading_point(&self, prim: u32, b1: f32, b2: f32) -> Option<SurfacePoint> {
        self.mesh_point(prim, |[p0, p1, p2]| {
            let b = [1.0 - b1 - b2, b1, b2];
            TrianglePoint {
                p: p0 * b[0] + p1 * b[1] + p2 * b[2],
                p_error: Vec3::ZERO,
                b,
            }
        })
    }

    /// Whether global triangle `prim`'s shading normal is the same at
    /// every point of it: its mesh has no vertex normals, or its three are
    /// equal (a face of Mitsuba's `rectangle` or `cube`; interpolated, they
    /// differ from the vertices' by the rounding of the weights' sum). A
    /// host shape: no.
    pub fn flat_shaded(&self, prim: u32) -> bool {
        if prim & SHAPE_PRIM_BIT != 0 {
            return false;
        }
        let (mi, ti) = self.locate(prim);
        let m = &self.meshes[mi];
        if m.normals.is_empty() {
            return true;
        }
        let [a, b, c] = m.indices[ti].map(|i| m.normals[i as usize]);
        a == b && b == c
    }

    /// The surface point on global triangle `prim` at the position and
    /// weights `at` gives for its vertices; normal and uv interpolated at
    /// those weights.
    #[inline(always)]
    fn mesh_point(
        &self,
        prim: u32,
        at: impl FnOnce([Vec3; 3]) -> TrianglePoint,
    ) -> Option<SurfacePoint> {
        let (mi, ti) = self.locate(prim);
        let m = &self.meshes[mi];
        let idx = m.indices[ti].map(|i| i as usize);
        let [p0, p1, p2] = idx.map(|i| m.positions[i]);
        let TrianglePoint {
            p,
            p_error,
            b: [b0, b1, b2],
        } = at([p0, p1, p2]);
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
            surface: mi as u32,
            prim,
        })
    }

    /// The surface point the host reports at parameters `(u, v)` of shape
    /// `shape`; `None` for an unknown shape or an invalid host answer.
    fn shape_point(&self, shape: u32, u: f32, v: f32) -> Option<SurfacePoint> {
        let g = self
            .first_shape
            .partition_point(|&f| f <= shape)
            .checked_sub(1)?;
        let group = &self.shapes[g];
        let local = shape - self.first_shape[g];
        if local >= group.count {
            return None;
        }
        let hp = group.surface.surface(local, u, v)?;
        let (ng, ns) = hp.unit_normals()?;
        Some(SurfacePoint {
            p: hp.p,
            p_error: hp.p_error,
            ng,
            ns,
            uv: hp.uv,
            surface: SHAPE_PRIM_BIT | g as u32,
            prim: SHAPE_PRIM_BIT | shape,
        })
    }

    /// The surface's parameterisation derivatives (∂p/∂u, ∂p/∂v) at `sp`,
    /// as Mitsuba's mesh computes them: from the triangle's uvs, or its
    /// edges p1 − p0 and p2 − p0 (the barycentric parameterisation) when
    /// the mesh has none, or the normal's own basis when the uvs are
    /// degenerate. Host shapes, which report no derivatives, get the
    /// geometric normal's basis. Only normal and bump maps need this.
    pub fn uv_tangents(&self, sp: &SurfacePoint) -> (Vec3, Vec3) {
        if sp.prim & SHAPE_PRIM_BIT != 0 {
            let f = crate::math::Frame::from_normal(sp.ng);
            return (f.s, f.t);
        }
        let (mi, ti) = self.locate(sp.prim);
        let m = &self.meshes[mi];
        let idx = m.indices[ti].map(|i| i as usize);
        let [p0, p1, p2] = idx.map(|i| m.positions[i]);
        let (dp0, dp1) = (p1 - p0, p2 - p0);
        if m.uvs.is_empty() {
            return (dp0, dp1);
        }
        let [uv0, uv1, uv2] = idx.map(|i| m.uvs[i]);
        let (duv0, duv1) = (uv1 - uv0, uv2 - uv0);
        let det = duv0.x * duv1.y - duv0.y * duv1.x;
        let inv = 1.0 / det;
        if det == 0.0 || !inv.is_finite() {
            let f = crate::math::Frame::from_normal(sp.ng);
            return (f.s, f.t);
        }
        (
            (dp0 * duv1.y - dp1 * duv0.y) * inv,
            (dp1 * duv0.x - dp0 * duv1.x) * inv,
        )
    }

    /// The surface point of an intersection: on a triangle, or on a host
    /// shape (asked of the host; `None` when its answer is invalid).
    #[inline]
    pub fn hit_point(&self, hit: &Hit) -> Option<SurfacePoint> {
        if hit.prim & SHAPE_PRIM_BIT == 0 {
            self.surface_point(hit.prim, hit.b1, hit.b2)
        } else {
            self.shape_point(hit.prim & !SHAPE_PRIM_BIT, hit.b1, hit.b2)
        }
    }

    /// Moves mesh `mesh`'s vertices to `positions` (and replaces its
    /// shading normals by `normals`, when given; an empty slice removes
    /// them): the scene update of an animated frame, e.g. a rigid
    /// transform the host applied. Topology, material and emission stay;
    /// counts must match the mesh's (normals: one per position). Everything is checked before anything changes, so on
    /// error the scene is as it was. Allocates nothing, except when normals
    /// are given to a mesh built without them (fallibly:
    /// [`SceneError::OutOfMemory`]) or when the set of emitting lights
    /// changes (an emitter's area becomes or stops being zero), which
    /// rebuilds the light set. The f32 precision bound of
    /// [`SceneBuilder::build`] ([`SceneError::TooFarFromOrigin`]) is checked
    /// again.
    ///
    /// Acceleration structures over the scene must follow (e.g.
    /// `Bvh::refit`); renderers notice the new [`Scene::revision`] at
    /// their next `prepare`, which starts a new frame.
    pub fn update_mesh(
        &mut self,
        mesh: usize,
        positions: &[Vec3],
        normals: Option<&[Vec3]>,
    ) -> Result<(), SceneError> {
        let m = self
            .meshes
            .get(mesh)
            .ok_or(SceneError::UnknownMesh { mesh })?;
        let n = m.positions.len();
        if positions.len() != n || normals.is_some_and(|ns| !ns.is_empty() && ns.len() != n) {
            return Err(SceneError::AttributeCount { mesh });
        }
        let bad = positions
            .iter()
            .chain(normals.unwrap_or(&[]))
            .position(|v| !v.is_finite());
        if let Some(v) = bad {
            return Err(SceneError::NonFiniteVertex {
                mesh,
                vertex: v % n.max(1),
            });
        }
        // The moved scene must still be resolvable in f32, as at build.
        check_precision(self.meshes.iter().enumerate().flat_map(|(i, m)| {
            if i == mesh {
                positions
            } else {
                &m.positions[..]
            }
        }))?;
        let m = &mut self.meshes[mesh];
        if let Some(ns) = normals {
            m.normals
                .try_reserve_exact(ns.len().saturating_sub(m.normals.len()))
                .map_err(|_| SceneError::OutOfMemory)?;
        }
        if self.moved_in[mesh] != self.motion_frame {
            // The mesh's first move of this motion frame: where it was
            // when the frame began is where motion vectors measure from.
            let first = self.first_vertex[mesh];
            self.previous[first..first + n].copy_from_slice(&m.positions);
            self.moved_in[mesh] = self.motion_frame;
        }
        m.positions.copy_from_slice(positions);
        if let Some(ns) = normals {
            m.normals.clear();
            m.normals.extend_from_slice(ns);
        }
        // Infinite lights depend on the scene's bounds; an emitter's
        // distribution on its triangles. Updated in place; rebuilt (which
        // allocates) only when the set of emitting lights changes.
        if (m.emission.is_some() || self.light_list.iter().any(Light::is_infinite))
            && !self.lights.refresh(&self.meshes, mesh)
        {
            self.lights = LightSet::with_bitmaps(&self.meshes, &self.light_list, &self.bitmaps);
        }
        self.revision += 1;
        Ok(())
    }

    /// How many times the scene was updated ([`Scene::update_mesh`]).
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// Starts a new motion frame: every mesh's current positions become
    /// the ones motion is measured from ([`Scene::previous_point`], the
    /// motion vectors of [`crate::aov`]). Call it once per displayed
    /// frame, before that frame's [`Scene::update_mesh`] calls; a mesh
    /// updated several times in one frame moves from where it was at the
    /// frame's start, one not updated does not move. Without it the
    /// motion of a mesh is measured from where it was before its first
    /// update. Changes no geometry (the [`Scene::revision`] stays) and
    /// allocates nothing.
    pub fn begin_frame(&mut self) {
        self.motion_frame += 1;
    }

    /// Where the point `p` at barycentric coordinates `(b1, b2)` of global
    /// primitive `prim` (a [`Hit`]'s) was when the current motion frame
    /// began ([`Scene::begin_frame`]): `p` moved back by its triangle's
    /// vertex displacements, weighted by the barycentric coordinates, when
    /// the triangle's mesh was updated in this frame; `p` itself otherwise
    /// (static meshes, host shapes).
    #[inline]
    pub fn previous_point(&self, prim: u32, b1: f32, b2: f32, p: Vec3) -> Vec3 {
        if prim & SHAPE_PRIM_BIT != 0 {
            return p;
        }
        let (mi, ti) = self.locate(prim);
        if self.moved_in[mi] != self.motion_frame {
            return p;
        }
        let m = &self.meshes[mi];
        let idx = m.indices[ti].map(|i| i as usize);
        let [p0, p1, p2] = idx.map(|i| m.positions[i]);
        let base = self.first_vertex[mi];
        let [q0, q1, q2] = idx.map(|i| self.previous[base + i]);
        // As displacements: a translation moves p back exactly (the
        // weights sum to 1), whatever the rounding of each weight.
        let b0 = 1.0 - b1 - b2;
        p + (q0 - p0) * b0 + (q1 - p1) * b1 + (q2 - p2) * b2
    }

    /// Number of host shapes (all groups).
    pub fn shape_count(&self) -> u32 {
        self.shapes.iter().map(|g| g.count).sum()
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
        match self.sample_emitter(u_select, u)? {
            EmitterSample::Area { sp, pdf_area } => Some((sp, pdf_area)),
            EmitterSample::Other { .. } => None,
        }
    }

    /// Chooses a light by power: a point on an area light with its density
    /// per unit area, or one of the other lights ([`LightSet::others`]),
    /// which the caller samples further. `None` when nothing emits or the
    /// chosen point is degenerate.
    // Forced: out of line, the surface point came back through memory and
    // was copied into the caller's `EmitterSample`.
    #[inline(always)]
    pub fn sample_emitter(&self, u_select: f32, u: Vec2) -> Option<EmitterSample> {
        match self.lights.choose(u_select, u)? {
            Chosen::Area(ls) => {
                let sp =
                    self.surface_point(self.global_prim(ls.mesh, ls.triangle), ls.b.x, ls.b.y)?;
                Some(EmitterSample::Area {
                    sp,
                    pdf_area: ls.pdf_area,
                })
            }
            Chosen::Other { index, pmf } => Some(EmitterSample::Other { index, pmf }),
        }
    }

    /// The material of a surface point.
    #[inline]
    pub fn material(&self, sp: &SurfacePoint) -> &Material {
        let id = if sp.surface & SHAPE_PRIM_BIT == 0 {
            self.meshes[sp.surface as usize].material
        } else {
            self.shapes[(sp.surface & !SHAPE_PRIM_BIT) as usize].material
        };
        &self.materials[id.0 as usize]
    }

    /// Radiance emitted from `sp` towards direction `w` (unit, pointing away
    /// from the surface): area emitters radiate only on the side their
    /// shading normal points to (Mitsuba's `area`).
    #[inline]
    pub fn emitted(&self, sp: &SurfacePoint, w: Vec3) -> Rgb {
        // Host shapes never emit (see `shapes`); `get` misses them.
        match self
            .meshes
            .get(sp.surface as usize)
            .and_then(|m| m.emission)
        {
            Some(le) if w.dot(sp.ns) > 0.0 => le,
            _ => Rgb::ZERO,
        }
    }
}
