//! The scene: meshes, materials, emitters and the camera, validated once.
//!
//! A [`Scene`] is built through [`SceneBuilder`], which rejects non-finite or
//! out-of-range host data with a [`SceneError`] before anything renders.
//! Geometry the core intersects is triangles; the scene loader tessellates
//! spheres and other shapes. A host with its own ray tracer may add
//! analytic [`shapes`] it intersects itself. Triangles are numbered
//! scene-globally (meshes in insertion order, triangles consecutively),
//! host shapes likewise with [`SHAPE_PRIM_BIT`] set, and every intersector
//! reports that numbering.

pub mod camera;
pub mod detail;
pub mod effects;
#[cfg(feature = "alloc")]
pub mod envmap;
pub mod grid;
#[cfg(feature = "alloc")]
pub mod light;
pub mod material;
pub mod medium;
pub mod texture;

#[cfg(feature = "alloc")]
pub mod shapes;
// `Scene` and its builder in `scene/scene.rs`: the module is the type's
// home, re-exported flat, so the path reads `scene::Scene`.
#[cfg(feature = "alloc")]
#[allow(clippy::module_inception)]
mod scene;
#[cfg(feature = "alloc")]
pub use scene::*;
#[cfg(feature = "alloc")]
pub use shapes::{SHAPE_PRIM_BIT, ShapeGroup, ShapePoint, ShapeSurface};

pub use camera::{Camera, CameraError, FovAxis};
pub use detail::Detail;
pub use effects::{Analysis, Effect, EffectSet};
#[cfg(feature = "alloc")]
pub use light::{Light, SUN_PROFILE_MU, SUN_PROFILE_S, SunProfile};
// The parameter types of the BSDF models that materials hold: declared by
// the models (in `bsdf`), public here, where the materials naming them are.
pub use crate::bsdf::conductor::ConductorFresnel;
pub use crate::bsdf::microfacet::Distribution;
pub use crate::bsdf::roughplastic::RoughCoating;
#[cfg(feature = "alloc")]
pub use grid::Grid;
pub use grid::{GridFilter, GridId, GridWrap};
pub use material::{
    MAX_ROUGHNESS, Material, MaterialId, MaterialKind, PrincipledParams, roughness_ok,
};
pub use medium::{Flight, Medium, MediumError, MediumId, MediumInterface, Phase};
#[cfg(feature = "alloc")]
pub use texture::Bitmap;
pub use texture::{BitmapId, Texture};
#[cfg(feature = "alloc")]
pub use texture::{TexCoords, TextureImages};
