//! The scene: meshes, materials, emitters and the camera, validated once.
//!
//! A [`Scene`] is built through [`SceneBuilder`], which rejects non-finite or
//! out-of-range host data with a [`SceneError`] before anything renders.
//! Geometry is triangles only; spheres and other shapes are tessellated by
//! the front end. Triangles are numbered scene-globally (meshes in insertion
//! order, triangles consecutively), and every intersector reports that
//! numbering.

pub mod camera;
pub mod effects;
#[cfg(feature = "alloc")]
pub mod light;
pub mod material;
pub mod texture;

#[cfg(feature = "alloc")]
mod store;
#[cfg(feature = "alloc")]
pub use store::*;

pub use camera::{Camera, CameraError, FovAxis};
pub use effects::{Analysis, Effect, EffectSet};
pub use material::{ConductorFresnel, Distribution, Material, MaterialId, MaterialKind};
#[cfg(feature = "alloc")]
pub use texture::Bitmap;
pub use texture::{BitmapId, Texture};
