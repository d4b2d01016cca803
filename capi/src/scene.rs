//! Scenes: materials and meshes handed over by pointer (copied), an
//! optional host intersector with optional analytic host shapes, then
//! `cmlt_scene_commit` builds the acceleration structure and freezes the
//! scene. Renderers share a
//! committed scene; releasing the handle while renderers use it is fine.

use std::ffi::{CStr, c_char};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, RwLock, RwLockReadGuard};

use cmlt_core::accel::Intersector;
use cmlt_core::accel::backend::AccelKind;
use cmlt_core::geometry::{Hit, HitPacket, LaneMask, Ray, RayPacket};
use cmlt_core::integrator::Settings;
use cmlt_core::math::spectrum::srgb_to_linear;
use cmlt_core::math::{Affine2, Mat4, Rgb, Vec2, Vec3};
use cmlt_core::scene::{
    Bitmap, BitmapId, Camera, ConductorFresnel, Detail, Distribution, Effect, FovAxis, Light,
    Material, MaterialId, MaterialKind, Mesh, PrincipledParams, RoughCoating, SHAPE_PRIM_BIT,
    Scene, SceneBuilder, SceneError, ShapeGroup, Texture, roughness_ok,
};

use crate::alloc::{check_oom, try_reserve};
use crate::error::{Error, Result, cmlt_status, guard, read, write};
use crate::host::{HostIntersector, HostShapes, cmlt_intersector, cmlt_shapes};
use crate::loader::{self, Loaded};

mod grid;
mod media;
pub use grid::*;
pub use media::*;

/// Lambertian diffuse: `color` is the albedo.
pub const CMLT_MATERIAL_DIFFUSE: u32 = 0;
/// Smooth mirror: `color` is the specular reflectance.
pub const CMLT_MATERIAL_MIRROR: u32 = 1;
/// Smooth glass (dielectric): `ior` is the interior/exterior index ratio.
pub const CMLT_MATERIAL_GLASS: u32 = 2;
/// Rough metal (GGX, perfect Fresnel): `color` is the reflectance,
/// `roughness` the GGX α in (0, 1e4].
pub const CMLT_MATERIAL_ROUGH_METAL: u32 = 3;
/// Smooth plastic (Mitsuba's `plastic`): `color` is the base's diffuse
/// albedo, `specular_color` the coating's specular reflectance (set it to
/// 1 for an untinted coating), `ior` the coating's index ratio (> 0),
/// `nonlinear` Mitsuba's flag of that name.
pub const CMLT_MATERIAL_PLASTIC: u32 = 4;
/// Rough plastic (Mitsuba's `roughplastic`): as `CMLT_MATERIAL_PLASTIC`,
/// plus `roughness` (α in (0, 1e4]) and `distribution`; `ior` must not be 1.
pub const CMLT_MATERIAL_ROUGH_PLASTIC: u32 = 5;
/// Thin glass pane (Mitsuba's `thindielectric`): `ior` is the pane's index
/// ratio, `specular_color` and `transmission_color` tint the reflected and
/// the (unbent) transmitted light.
pub const CMLT_MATERIAL_THIN_GLASS: u32 = 6;
/// Tinted smooth glass: `CMLT_MATERIAL_GLASS` whose reflected and
/// transmitted light are tinted by `specular_color` and
/// `transmission_color` (Mitsuba's `dielectric` `specular_reflectance`,
/// `specular_transmittance`).
pub const CMLT_MATERIAL_TINTED_GLASS: u32 = 7;

/// `cmlt_material.distribution`: GGX (the default, 0).
pub const CMLT_DISTRIBUTION_GGX: u32 = 0;
/// `cmlt_material.distribution`: Beckmann.
pub const CMLT_DISTRIBUTION_BECKMANN: u32 = 1;

/// Rough glass (Mitsuba's `roughdielectric`, GGX): `ior` is the
/// interior/exterior index ratio (> 0, ≠ 1), `roughness` the GGX α in
/// (0, 1e4],
/// `color` the transmittance in [0, 1] (reflection is untinted). Always
/// one interface with an inside and an outside: `two_sided` is ignored.
pub const CMLT_MATERIAL_ROUGH_GLASS: u32 = 8;
/// Principled (Mitsuba 3's `principled`, the metallic-roughness model):
/// `color` (or `color_texture`) is the base colour in [0, 1], `roughness`
/// the perceptual roughness in [0, 1] (GGX α = roughness²), and `metallic`,
/// `anisotropic`, `spec_tint`, `spec_trans`, `sheen`, `sheen_tint`,
/// `clearcoat`, `clearcoat_gloss`, `flatness` the model's weights, each in
/// [0, 1] (Mitsuba's defaults: colour 0.5, roughness 0.5, specular 0.5,
/// the others 0). `ior` > 0 is the relative index η;
/// `ior` = 0 derives it from `specular` in [0, 1] (Mitsuba's: 0.5 is
/// η = 1.5). With `spec_trans` > 0, η must not be 1 and `two_sided` is
/// ignored (one interface). Each scalar may be replaced by a texture
/// (its luminance) in `principled_textures`.
pub const CMLT_MATERIAL_PRINCIPLED: u32 = 9;

/// Index of `roughness`'s texture in `cmlt_material.principled_textures`.
pub const CMLT_PRINCIPLED_ROUGHNESS: u32 = 0;
/// Index of `anisotropic`'s texture.
pub const CMLT_PRINCIPLED_ANISOTROPIC: u32 = 1;
/// Index of `metallic`'s texture.
pub const CMLT_PRINCIPLED_METALLIC: u32 = 2;
/// Index of `spec_trans`'s texture.
pub const CMLT_PRINCIPLED_SPEC_TRANS: u32 = 3;
/// Index of `spec_tint`'s texture.
pub const CMLT_PRINCIPLED_SPEC_TINT: u32 = 4;
/// Index of `sheen`'s texture.
pub const CMLT_PRINCIPLED_SHEEN: u32 = 5;
/// Index of `sheen_tint`'s texture.
pub const CMLT_PRINCIPLED_SHEEN_TINT: u32 = 6;
/// Index of `clearcoat`'s texture.
pub const CMLT_PRINCIPLED_CLEARCOAT: u32 = 7;
/// Index of `clearcoat_gloss`'s texture.
pub const CMLT_PRINCIPLED_CLEARCOAT_GLOSS: u32 = 8;
/// Index of `flatness`'s texture.
pub const CMLT_PRINCIPLED_FLATNESS: u32 = 9;
/// Rough diffuse (Oren–Nayar, Mitsuba 0.6's `roughdiffuse` with
/// `useFastApprox` false: the full model with interreflections): `color`
/// (or `color_texture`) is the facets' albedo in [0, 1], `roughness`
/// Mitsuba's `alpha`, the RMS facet slope in [0, 1e4] (0 is Lambertian;
/// Oren–Nayar's σ is α/√2).
pub const CMLT_MATERIAL_ROUGH_DIFFUSE: u32 = 10;
/// An index-matched boundary (Mitsuba's `null`): rays pass it unchanged
/// and it never scatters; it only changes the medium a ray is in, as the
/// mesh's media say (`cmlt_scene_set_mesh_media`). The other fields are
/// ignored. Needs the media effect (`CMLT_EFFECT_MEDIA`).
pub const CMLT_MATERIAL_NULL: u32 = 11;

/// The acceleration structure `cmlt_scene_commit` builds: our SIMD BVH
/// (default), or Embree (builds with the `embree` feature only). A scene
/// with a host intersector uses that instead.
pub const CMLT_ACCEL_BVH: u32 = 0;
/// Embree 3 (`CMLT_ERROR_UNSUPPORTED` in builds without it).
pub const CMLT_ACCEL_EMBREE: u32 = 1;

/// A material. Fields a type does not use are ignored.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct cmlt_material {
    /// One of the `CMLT_MATERIAL_*` values.
    pub type_: u32,
    /// Linear RGB albedo / reflectance (rough glass: transmittance), each
    /// in [0, 1]. The same rule holds for every colour of a material, in
    /// the scene loader too: a surface that reflects more than it receives
    /// creates energy, and no estimator converges in a closed scene with
    /// one (Mitsuba 0.6 rescales such a colour silently; cmlt refuses it).
    pub color: [f32; 3],
    /// Glass, rough glass: index of refraction ratio, > 0.
    pub ior: f32,
    /// Rough metal, rough plastic, rough glass: the microfacet α in
    /// (0, 1e4] (as in Mitsuba, α > 1 is allowed: extremely rough; 0 is
    /// refused, use the smooth type); rough diffuse: the RMS facet slope
    /// α in [0, 1e4].
    pub roughness: f32,
    /// Non-zero: both sides scatter alike (otherwise the back side is
    /// black, as Mitsuba's one-sided BSDFs).
    pub two_sided: u32,
    /// A texture replacing `color` (diffuse albedo, metal reflectance):
    /// an image (`cmlt_scene_add_texture`) looked up at the mesh's uvs, or
    /// a grid (`cmlt_scene_add_grid_texture`) looked up at the hit's
    /// world position; or `CMLT_NO_TEXTURE`.
    pub color_texture: u32,
    /// A tangent-space normal map (RGB in [0, 1] → n = 2c − 1, relative to
    /// the frame whose first tangent is ∂p/∂u; add it with `srgb` = 0), or
    /// `CMLT_NO_TEXTURE`. Not together with `bump_map`; not a grid.
    pub normal_map: u32,
    /// A height texture (its luminance) whose uv gradient times
    /// `bump_scale` tilts the shading normal, or `CMLT_NO_TEXTURE`; not a
    /// grid (it has no uv gradient).
    pub bump_map: u32,
    /// Scale of `bump_map`'s height (finite; Mitsuba's default is 1).
    pub bump_scale: f32,
    /// An opacity texture (its luminance, in [0, 1]): a ray passes through
    /// the surface with probability 1 − opacity (an alpha cut-out with 0
    /// and 1), or `CMLT_NO_TEXTURE` for an opaque surface.
    pub opacity_texture: u32,
    /// Plastics: the coating's specular reflectance; thin and tinted
    /// glass: the reflection tint. Each component in [0, 1].
    pub specular_color: [f32; 3],
    /// Thin and tinted glass: the transmission tint, each component in
    /// [0, 1].
    pub transmission_color: [f32; 3],
    /// Rough plastic: a `CMLT_DISTRIBUTION_*` value.
    pub distribution: u32,
    /// Plastics: non-zero for Mitsuba's `nonlinear` (internal reflections
    /// tint the base).
    pub nonlinear: u32,
    /// Principled: blend from dielectric (0) to metal (1).
    pub metallic: f32,
    /// Principled: anisotropy in [0, 1] (the lobe is stretched along ∂p/∂u).
    pub anisotropic: f32,
    /// Principled: Mitsuba's `specular` in [0, 1], used when `ior` is 0.
    pub specular: f32,
    /// Principled: tint of the dielectric specular towards `color`.
    pub spec_tint: f32,
    /// Principled: blend of the dielectric part towards transmission.
    pub spec_trans: f32,
    /// Principled: sheen weight.
    pub sheen: f32,
    /// Principled: tint of the sheen towards `color`.
    pub sheen_tint: f32,
    /// Principled: clearcoat weight.
    pub clearcoat: f32,
    /// Principled: clearcoat glossiness.
    pub clearcoat_gloss: f32,
    /// Principled: blend of the diffuse lobe towards fake subsurface.
    pub flatness: f32,
    /// Principled: textures replacing the scalars (their luminance), by
    /// `CMLT_PRINCIPLED_*` index, each `CMLT_NO_TEXTURE` or a texture id.
    pub principled_textures: [u32; 10],
}

/// "No texture" in `cmlt_material`'s texture fields: zero, so that a
/// zero-initialised material has none (texture ids start at 1).
pub const CMLT_NO_TEXTURE: u32 = 0;

/// A triangle mesh, read from the host's arrays during
/// `cmlt_scene_add_mesh` (copied; the arrays may be freed afterwards).
/// Strides are in bytes between consecutive elements; 0 means tightly
/// packed. Strides must be multiples of 4 and at least the element's size;
/// pointers must be 4-byte aligned.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct cmlt_mesh {
    /// `vertex_count` positions, 3 floats each.
    pub positions: *const f32,
    /// Number of vertices.
    pub vertex_count: usize,
    /// Bytes between positions (0 = 12).
    pub position_stride: usize,
    /// Per-vertex shading normals (3 floats), or NULL for flat shading.
    pub normals: *const f32,
    /// Bytes between normals (0 = 12).
    pub normal_stride: usize,
    /// Per-vertex texture coordinates (2 floats), or NULL.
    pub uvs: *const f32,
    /// Bytes between uvs (0 = 8).
    pub uv_stride: usize,
    /// `triangle_count` triangles of 3 vertex indices, counter-clockwise =
    /// front.
    pub indices: *const u32,
    /// Number of triangles.
    pub triangle_count: usize,
    /// Bytes between triangles (0 = 12).
    pub index_stride: usize,
    /// Material id from `cmlt_scene_add_material`.
    pub material: u32,
    /// Emitted radiance (linear RGB, ≥ 0) on the front side; all zero for
    /// a surface that does not emit.
    pub emission: [f32; 3],
}

/// A perspective camera looking from `position` at `target`, `up` giving
/// the image's vertical (Mitsuba's conventions: +x of the image is the
/// camera's left). `fov_degrees` is the horizontal field of view; a thin
/// lens of `aperture_radius` (0 = pinhole) focuses at `focus_distance`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
#[allow(non_camel_case_types)]
pub struct cmlt_camera {
    /// Centre of the lens.
    pub position: [f32; 3],
    /// A point on the optical axis.
    pub target: [f32; 3],
    /// Up direction (not parallel to the view direction).
    pub up: [f32; 3],
    /// Horizontal field of view in degrees, in (0, 180).
    pub fov_degrees: f32,
    /// Lens radius; 0 for a pinhole.
    pub aperture_radius: f32,
    /// Distance in focus (> 0; any value for a pinhole).
    pub focus_distance: f32,
}

impl cmlt_camera {
    /// The core camera at `width × height`, or why not.
    pub(crate) fn camera(&self, width: u32, height: u32) -> Result<Camera> {
        let p = Vec3::from_array(self.position);
        let dir = Vec3::from_array(self.target) - p;
        let up = Vec3::from_array(self.up);
        if !(p.is_finite() && dir.is_finite() && up.is_finite()) {
            return Err(Error::invalid(
                "camera position, target and up must be finite",
            ));
        }
        // Camera::perspective orthonormalises around the view direction
        // with y = up; x = up × z is Mitsuba's look_at "left".
        let to_world = Mat4::from_cols(
            up.cross(dir).extend(0.0),
            up.extend(0.0),
            dir.extend(0.0),
            p.extend(1.0),
        );
        Camera::perspective(
            to_world,
            self.fov_degrees,
            FovAxis::X,
            width,
            height,
            self.aperture_radius,
            self.focus_distance,
        )
        .map_err(|e| Error::invalid(format!("camera: {e}")))
    }

    /// The look-at description of a core camera.
    pub(crate) fn from_camera(c: &Camera) -> Self {
        cmlt_camera {
            position: c.position().to_array(),
            target: (c.position() + c.forward()).to_array(),
            up: c.up().to_array(),
            fov_degrees: c.fov_x_degrees(),
            aperture_radius: c.aperture_radius(),
            focus_distance: c.focus_distance(),
        }
    }
}

/// What a committed scene traces with: a backend the library builds (our
/// BVH or Embree, chosen at run time by the core's `accel::backend`) or
/// the host's callbacks.
pub(crate) enum Accel {
    Built(cmlt_core::accel::backend::Accel),
    Host(HostIntersector),
}

/// Calls `$body` with `$i` bound to the backend inside `$accel`.
macro_rules! dispatch {
    ($accel:expr, $i:ident => $body:expr) => {
        match $accel {
            Accel::Built($i) => $body,
            Accel::Host($i) => $body,
        }
    };
}

/// One intersector over either kind of backend, so the renderer calls stay
/// generic; the branch per query is negligible next to a traversal.
impl Intersector for Accel {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        dispatch!(self, i => i.intersect(ray))
    }

    fn occluded(&self, ray: &Ray) -> bool {
        dispatch!(self, i => i.occluded(ray))
    }

    fn intersect_packet<const N: usize>(
        &self,
        rays: &RayPacket<N>,
        active: LaneMask,
        hits: &mut HitPacket<N>,
    ) {
        dispatch!(self, i => i.intersect_packet(rays, active, hits))
    }

    fn occluded_packet<const N: usize>(&self, rays: &RayPacket<N>, active: LaneMask) -> LaneMask {
        dispatch!(self, i => i.occluded_packet(rays, active))
    }
}

/// What renderers trace: the scene and its acceleration structure, which
/// change together (`cmlt_scene_update_mesh`).
pub(crate) struct Live {
    pub scene: Scene,
    pub accel: Accel,
    /// `cmlt_scene_update_mesh`'s copies of strided host positions and
    /// normals, sized at commit for the largest mesh so that an update
    /// allocates nothing (packed arrays are read in place).
    scratch: [Vec<Vec3>; 2],
}

// Packed host arrays of 3 floats are read as `Vec3`s in place.
const _: () = assert!(std::mem::size_of::<Vec3>() == 12 && std::mem::align_of::<Vec3>() == 4);

/// A committed scene, shared by renderers: its structure is frozen; its
/// meshes can move between frames.
pub(crate) struct Committed {
    /// Read-locked while renderers prepare, render or report; write-locked
    /// by an update (each side gets `CMLT_ERROR_BUSY` rather than waiting).
    live: RwLock<Live>,
    /// Integrator settings a loaded scene file asked for (defaults
    /// otherwise).
    pub settings: Settings,
    /// Host shape points rejected as invalid (they scatter nothing).
    pub rejected_surfaces: Arc<AtomicU64>,
}

impl Committed {
    pub fn new(
        scene: Scene,
        accel: Accel,
        settings: Settings,
        rejected_surfaces: Arc<AtomicU64>,
    ) -> Result<Self> {
        let largest = scene
            .meshes
            .iter()
            .map(|m| m.positions.len())
            .max()
            .unwrap_or(0);
        let mut scratch = [Vec::new(), Vec::new()];
        for v in &mut scratch {
            try_reserve(v, largest)?;
        }
        Ok(Committed {
            live: RwLock::new(Live {
                scene,
                accel,
                scratch,
            }),
            settings,
            rejected_surfaces,
        })
    }

    /// The scene and accel for reading, or busy while an update runs.
    pub fn live(&self) -> Result<RwLockReadGuard<'_, Live>> {
        self.live
            .try_read()
            .map_err(|e| Error::lock(e, "the scene is being updated"))
    }

    /// Host shape points rejected so far.
    pub fn rejected_surfaces(&self) -> u64 {
        self.rejected_surfaces.load(Ordering::Relaxed)
    }
}

/// Reserves what one more element of any kind needs and fails with
/// out-of-memory if any block of this call was refused: called last before
/// an `add_*` changes the scene, so that nothing after it allocates.
fn room(b: &mut Building) -> Result<()> {
    b.builder
        .try_reserve_one()
        .map_err(|_| Error::out_of_memory("out of memory: the scene cannot grow"))?;
    b.textures
        .try_reserve(1)
        .map_err(|_| Error::out_of_memory("out of memory: the scene cannot grow"))?;
    check_oom()
}

struct Building {
    builder: SceneBuilder,
    materials: usize,
    /// The texture of each texture id − 1: an image
    /// (`cmlt_scene_add_texture`; environment maps' bitmaps are among the
    /// scene's bitmaps too, so ids and bitmaps differ) or a grid
    /// (`grid::cmlt_scene_add_grid_texture`).
    textures: Vec<Texture>,
    meshes: usize,
    /// Media added so far (`media::cmlt_scene_add_medium`).
    media: u32,
    triangles: u64,
    shapes: u64,
    intersector: Option<cmlt_intersector>,
    accel: u32,
    rejected_surfaces: Arc<AtomicU64>,
}

enum State {
    Building(Box<Building>),
    Committed(Arc<Committed>),
}

/// A scene handle (opaque to C).
#[allow(non_camel_case_types)]
pub struct cmlt_scene {
    state: Mutex<State>,
}

impl cmlt_scene {
    /// The committed scene, or an error when not committed yet.
    pub(crate) fn committed(&self) -> Result<Arc<Committed>> {
        let state = self
            .state
            .try_lock()
            .map_err(|e| Error::lock(e, "the scene is in use by another thread"))?;
        match &*state {
            State::Committed(c) => Ok(c.clone()),
            State::Building(_) => Err(Error::operation(
                "commit the scene first (cmlt_scene_commit)",
            )),
        }
    }

    fn building<R>(&self, f: impl FnOnce(&mut Building) -> Result<R>) -> Result<R> {
        let mut state = self
            .state
            .try_lock()
            .map_err(|e| Error::lock(e, "the scene is in use by another thread"))?;
        match &mut *state {
            State::Building(b) => {
                crate::error::bug_hook();
                f(b)
            }
            State::Committed(_) => Err(Error::operation(
                "the scene is committed and can no longer change",
            )),
        }
    }

    fn committed_from(c: Committed) -> Box<cmlt_scene> {
        Box::new(cmlt_scene {
            state: Mutex::new(State::Committed(Arc::new(c))),
        })
    }
}

/// Creates an empty scene to fill with materials and meshes.
///
/// # Safety
/// `out` is NULL or valid for writing a pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_new(out: *mut *mut cmlt_scene) -> cmlt_status {
    guard("cmlt_scene_new", || {
        // SAFETY: the caller's contract.
        let out = unsafe { write(out, "out") }?;
        let scene = Box::new(cmlt_scene {
            state: Mutex::new(State::Building(Box::new(Building {
                builder: SceneBuilder::new(),
                materials: 0,
                textures: Vec::new(),
                meshes: 0,
                media: 0,
                triangles: 0,
                shapes: 0,
                intersector: None,
                accel: CMLT_ACCEL_BVH,
                rejected_surfaces: Arc::default(),
            }))),
        });
        check_oom()?;
        *out = Box::into_raw(scene);
        Ok(())
    })
}

/// Releases a scene handle (NULL is ignored). Renderers made from it keep
/// the committed scene alive until they are released.
///
/// # Safety
/// `scene` is NULL or a handle from this library not released before and
/// not in use by another thread.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_release(scene: *mut cmlt_scene) {
    let _ = guard("cmlt_scene_release", || {
        if !scene.is_null() {
            // SAFETY: the caller's contract: `scene` came from Box::into_raw.
            drop(unsafe { Box::from_raw(scene) });
        }
        Ok(())
    });
}

/// The texture of id `id` (`CMLT_NO_TEXTURE`: none) among `textures`
/// added so far.
fn texture_from_c(id: u32, textures: &[Texture], what: &str) -> Result<Option<Texture>> {
    if id == CMLT_NO_TEXTURE {
        return Ok(None);
    }
    let Some(t) = textures.get(id as usize - 1) else {
        return Err(Error::invalid(format!(
            "material: {what} {id} is not a texture of this scene"
        )));
    };
    Ok(Some(*t))
}

/// The principled parameters of `m` (see `CMLT_MATERIAL_PRINCIPLED`);
/// ranges are checked by `PrincipledParams::validate` afterwards.
fn principled_from_c(
    m: &cmlt_material,
    base_color: Texture,
    textures: &[Texture],
) -> Result<PrincipledParams> {
    let scalar = |index: u32, value: f32| -> Result<Texture> {
        let id = m.principled_textures[index as usize];
        let t = texture_from_c(id, textures, "principled_textures")?;
        Ok(t.unwrap_or(Texture::Constant(Rgb::splat(value))))
    };
    let eta = if m.ior == 0.0 {
        if !(0.0..=1.0).contains(&m.specular) {
            return Err(Error::invalid(
                "material: principled specular must be in [0, 1]",
            ));
        }
        PrincipledParams::eta_from_specular(m.specular)
    } else {
        m.ior
    };
    Ok(PrincipledParams {
        base_color,
        roughness: scalar(CMLT_PRINCIPLED_ROUGHNESS, m.roughness)?,
        anisotropic: scalar(CMLT_PRINCIPLED_ANISOTROPIC, m.anisotropic)?,
        metallic: scalar(CMLT_PRINCIPLED_METALLIC, m.metallic)?,
        spec_trans: scalar(CMLT_PRINCIPLED_SPEC_TRANS, m.spec_trans)?,
        spec_tint: scalar(CMLT_PRINCIPLED_SPEC_TINT, m.spec_tint)?,
        sheen: scalar(CMLT_PRINCIPLED_SHEEN, m.sheen)?,
        sheen_tint: scalar(CMLT_PRINCIPLED_SHEEN_TINT, m.sheen_tint)?,
        clearcoat: scalar(CMLT_PRINCIPLED_CLEARCOAT, m.clearcoat)?,
        clearcoat_gloss: scalar(CMLT_PRINCIPLED_CLEARCOAT_GLOSS, m.clearcoat_gloss)?,
        flatness: scalar(CMLT_PRINCIPLED_FLATNESS, m.flatness)?,
        eta,
    })
}

pub(crate) fn material_from_c(m: &cmlt_material, textures: &[Texture]) -> Result<Material> {
    let color = Rgb::new(m.color[0], m.color[1], m.color[2]);
    let tex = texture_from_c(m.color_texture, textures, "color_texture")?;
    let colour = tex.unwrap_or(Texture::Constant(color));
    let specular = Rgb::new(
        m.specular_color[0],
        m.specular_color[1],
        m.specular_color[2],
    );
    let transmission = Rgb::new(
        m.transmission_color[0],
        m.transmission_color[1],
        m.transmission_color[2],
    );
    let kind = match m.type_ {
        CMLT_MATERIAL_DIFFUSE => MaterialKind::Diffuse {
            reflectance: colour,
        },
        CMLT_MATERIAL_MIRROR => MaterialKind::Conductor {
            fresnel: ConductorFresnel::Perfect,
            specular_reflectance: colour,
        },
        CMLT_MATERIAL_GLASS => {
            if tex.is_some() {
                return Err(Error::invalid("material: glass takes no color_texture"));
            }
            MaterialKind::Dielectric { eta: m.ior }
        }
        CMLT_MATERIAL_PLASTIC => MaterialKind::Plastic {
            eta: m.ior,
            diffuse_reflectance: colour,
            specular_reflectance: Texture::Constant(specular),
            nonlinear: m.nonlinear != 0,
        },
        CMLT_MATERIAL_ROUGH_PLASTIC => {
            let distribution = match m.distribution {
                CMLT_DISTRIBUTION_GGX => Distribution::Ggx,
                CMLT_DISTRIBUTION_BECKMANN => Distribution::Beckmann,
                d => {
                    return Err(Error::invalid(format!(
                        "material: unknown distribution {d}"
                    )));
                }
            };
            // Checked before the coating table is integrated from them
            // (the rule of `Material::validate`).
            if !roughness_ok(m.roughness) {
                return Err(Error::invalid("material: roughness must be in (0, 1e4]"));
            }
            if !(m.ior.is_finite() && m.ior > 0.0 && m.ior != 1.0) {
                return Err(Error::invalid(
                    "material: rough plastic ior must be finite, > 0 and ≠ 1",
                ));
            }
            MaterialKind::RoughPlastic {
                distribution,
                alpha: m.roughness,
                eta: m.ior,
                diffuse_reflectance: colour,
                specular_reflectance: Texture::Constant(specular),
                nonlinear: m.nonlinear != 0,
                coating: RoughCoating::new(distribution, m.roughness, m.ior),
            }
        }
        CMLT_MATERIAL_THIN_GLASS => MaterialKind::ThinDielectric {
            eta: m.ior,
            specular_reflectance: Texture::Constant(specular),
            specular_transmittance: Texture::Constant(transmission),
        },
        CMLT_MATERIAL_TINTED_GLASS => MaterialKind::TintedDielectric {
            eta: m.ior,
            specular_reflectance: Texture::Constant(specular),
            specular_transmittance: Texture::Constant(transmission),
        },
        CMLT_MATERIAL_ROUGH_METAL => MaterialKind::RoughConductor {
            distribution: Distribution::Ggx,
            alpha: m.roughness,
            fresnel: ConductorFresnel::Perfect,
            specular_reflectance: colour,
        },
        CMLT_MATERIAL_NULL => MaterialKind::Null,
        CMLT_MATERIAL_ROUGH_DIFFUSE => MaterialKind::RoughDiffuse {
            reflectance: colour,
            alpha: m.roughness,
            fast_approx: false,
        },
        CMLT_MATERIAL_ROUGH_GLASS => MaterialKind::RoughDielectric {
            distribution: Distribution::Ggx,
            alpha: m.roughness,
            eta: m.ior,
            specular_reflectance: Texture::Constant(Rgb::ONE),
            specular_transmittance: Texture::Constant(color),
        },
        CMLT_MATERIAL_PRINCIPLED => {
            MaterialKind::Principled(principled_from_c(m, colour, textures)?)
        }
        t => return Err(Error::invalid(format!("unknown material type {t}"))),
    };
    let detail = Detail {
        normal_map: texture_from_c(m.normal_map, textures, "normal_map")?,
        bump_map: texture_from_c(m.bump_map, textures, "bump_map")?,
        bump_scale: m.bump_scale,
        opacity: texture_from_c(m.opacity_texture, textures, "opacity_texture")?,
    };
    let material = Material {
        kind,
        two_sided: m.two_sided != 0,
        detail,
    };
    // Every parameter's range is the core's one rule (colours in [0, 1],
    // roughness in (0, 1e4]), shared with the scene loader.
    material
        .validate()
        .map_err(|e| Error::invalid(format!("material: {e}")))?;
    Ok(material)
}

/// Adds a material; its id (for `cmlt_mesh.material`) goes to `*out_id`.
///
/// # Safety
/// `scene` is a valid handle; `material` and `out_id` are NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_add_material(
    scene: *mut cmlt_scene,
    material: *const cmlt_material,
    out_id: *mut u32,
) -> cmlt_status {
    guard("cmlt_scene_add_material", || {
        // SAFETY: the caller's contract.
        let (scene, m, out) = unsafe {
            (
                read(scene, "scene")?,
                read(material, "material")?,
                write(out_id, "out_id")?,
            )
        };
        scene.building(|b| {
            let material = material_from_c(m, &b.textures)?;
            room(b)?;
            let MaterialId(id) = b.builder.add_material(material);
            b.materials += 1;
            *out = id;
            Ok(())
        })
    })
}

/// Adds a texture copied from host memory: `height` rows of `width` texels
/// of `channels` 8-bit values (1 = grey, 3 = RGB, 4 = RGBA with alpha
/// ignored), row 0 at v = 0, `stride` bytes between rows (0 = packed). With
/// `srgb` non-zero the values are sRGB-encoded and decoded to linear (a
/// colour texture); with 0 they are used as they are, /255 (normal, bump
/// and opacity maps). Sampled bilinearly with repeat wrapping. Its id, for
/// `cmlt_material`'s texture fields, goes to `*out_id` (ids start at 1 and
/// are shared with `cmlt_scene_add_grid_texture`; `CMLT_NO_TEXTURE` is 0).
/// On failure the scene is unchanged.
///
/// # Safety
/// `scene` is a valid handle; `texels` is NULL or points to `height` rows
/// of `stride` bytes (the last row: `width · channels` bytes); `out_id` is
/// NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_add_texture(
    scene: *mut cmlt_scene,
    width: u32,
    height: u32,
    channels: u32,
    texels: *const u8,
    stride: usize,
    srgb: u32,
    out_id: *mut u32,
) -> cmlt_status {
    guard("cmlt_scene_add_texture", || {
        // SAFETY: the caller's contract.
        let (scene, out) = unsafe { (read(scene, "scene")?, write(out_id, "out_id")?) };
        if !matches!(channels, 1 | 3 | 4) {
            return Err(Error::invalid(format!(
                "texture: channels must be 1, 3 or 4, got {channels}"
            )));
        }
        if width == 0 || height == 0 {
            return Err(Error::invalid("texture: width and height must be > 0"));
        }
        if texels.is_null() {
            return Err(Error::null("texels"));
        }
        let row = width as usize * channels as usize;
        let stride = if stride == 0 { row } else { stride };
        if stride < row {
            return Err(Error::invalid(format!(
                "texture: stride {stride} is less than a row's {row} bytes"
            )));
        }
        let bytes = (height as usize - 1)
            .checked_mul(stride)
            .and_then(|b| b.checked_add(row))
            .filter(|&b| b <= isize::MAX as usize)
            .ok_or_else(|| Error::invalid("texture: size overflows the address space"))?;
        // SAFETY: the caller's contract: `bytes` readable bytes at `texels`.
        let data = unsafe { std::slice::from_raw_parts(texels, bytes) };
        let lut: Vec<f32> = (0..256)
            .map(|i| {
                let v = i as f32 / 255.0;
                if srgb != 0 { srgb_to_linear(v) } else { v }
            })
            .collect();
        let c = channels as usize;
        let mut out_texels = Vec::new();
        try_reserve(&mut out_texels, width as usize * height as usize)?;
        for y in 0..height as usize {
            let r = &data[y * stride..y * stride + row];
            for t in r.chunks_exact(c) {
                let v = |k: usize| lut[t[if c == 1 { 0 } else { k }] as usize];
                out_texels.push(Rgb::new(v(0), v(1), v(2)));
            }
        }
        let bitmap = Bitmap::new(width, height, out_texels)
            .ok_or_else(|| Error::invalid("texture: invalid size"))?;
        scene.building(|b| {
            if b.textures.len() >= u32::MAX as usize - 1 {
                return Err(Error::invalid("scene: too many textures"));
            }
            room(b)?;
            let id = b.builder.add_bitmap(bitmap);
            b.textures.push(Texture::Bitmap {
                id,
                to_uv: Affine2::IDENTITY,
            });
            *out = b.textures.len() as u32;
            Ok(())
        })
    })
}

/// A point light (Mitsuba's `point`): `color` is the radiant intensity
/// (W/sr), `position` its place.
pub const CMLT_LIGHT_POINT: u32 = 0;
/// A spot light (Mitsuba's `spot`): `color` is the intensity on the axis,
/// `position` the apex, `direction` the axis; full intensity up to
/// `beam_width` degrees off the axis, falling linearly in angle to zero at
/// `cutoff_angle` degrees (Mitsuba's defaults are 20 and 15).
pub const CMLT_LIGHT_SPOT: u32 = 1;
/// A sun (Mitsuba's `directional`): `color` is the irradiance on a surface
/// facing it, `direction` the direction the light travels in.
pub const CMLT_LIGHT_DIRECTIONAL: u32 = 2;
/// A uniform environment (Mitsuba's `constant`): `color` is the radiance
/// arriving from every direction.
pub const CMLT_LIGHT_CONSTANT: u32 = 3;
/// An environment map (Mitsuba's `envmap`): the latitude-longitude image
/// `texels` (`width` × `height` linear RGB floats, copied in) times
/// `color` (Mitsuba's `scale` in all three; 1, 1, 1 for the image as it
/// is), turned by the rotation `to_world`. Row 0 is the zenith (+y of the
/// map's frame), texel column x lies at φ = 2π (x + ½)/width from −z
/// towards +x, as in Mitsuba.
pub const CMLT_LIGHT_ENVMAP: u32 = 4;
/// A sun disc (the sun of Mitsuba's `sunsky`): `color` is the disc's
/// radiance, `direction` the direction the light travels in (the sun is
/// seen along its opposite), `cutoff_angle` the disc's angular radius in
/// degrees, in (0, 90). Rays see it, unlike `CMLT_LIGHT_DIRECTIONAL`; pair
/// it with an environment map of the sky.
pub const CMLT_LIGHT_SUN: u32 = 5;

/// A light that is not an emitting mesh. Fields a type does not use are
/// ignored (but must be finite).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct cmlt_light {
    /// One of the `CMLT_LIGHT_*` values.
    pub type_: u32,
    /// Linear RGB intensity, irradiance or radiance (see the type), each
    /// finite and ≥ 0.
    pub color: [f32; 3],
    /// Point and spot: position.
    pub position: [f32; 3],
    /// Spot: the axis; directional and sun: the direction of travel.
    /// Non-zero.
    pub direction: [f32; 3],
    /// Spot: half-angle of the cone in degrees, in (0, 180]; sun: the
    /// disc's angular radius in degrees, in (0, 90).
    pub cutoff_angle: f32,
    /// Spot: half-angle of the full-intensity beam in degrees, in
    /// [0, `cutoff_angle`].
    pub beam_width: f32,
    /// Envmap: `height` rows of `width` RGB float triples, each finite and
    /// ≥ 0, 4-byte aligned; read during the call. Ignored by other types.
    pub texels: *const f32,
    /// Envmap: texels per row (> 0).
    pub width: u32,
    /// Envmap: rows (> 0).
    pub height: u32,
    /// Envmap: bytes from one row to the next (0 = packed, 12 · `width`);
    /// a multiple of 4, at least 12 · `width`.
    pub stride: usize,
    /// Envmap: the emitter-to-world rotation, a row-major 3×3 orthonormal
    /// matrix; all zeros means the identity.
    pub to_world: [f32; 9],
}

/// Copies an environment map's texels from a C light (times its `color`)
/// and reads its rotation.
///
/// # Safety
/// `l.texels` is NULL or points to `l.height` rows of `l.stride` bytes.
unsafe fn envmap_from_c(l: &cmlt_light) -> Result<(Bitmap, cmlt_core::math::Mat3)> {
    if l.color.iter().any(|v| v.is_nan() || *v < 0.0) {
        return Err(Error::invalid(
            "light: envmap color (the texels' factor) must be non-negative",
        ));
    }
    if l.texels.is_null() {
        return Err(Error::null("light.texels"));
    }
    if l.width == 0 || l.height == 0 {
        return Err(Error::invalid("light: envmap width and height must be > 0"));
    }
    if !(l.texels as usize).is_multiple_of(4) {
        return Err(Error::invalid(
            "light: envmap texels must be 4-byte aligned",
        ));
    }
    let row = l.width as usize * 12;
    let stride = if l.stride == 0 { row } else { l.stride };
    if stride < row || !stride.is_multiple_of(4) {
        return Err(Error::invalid(format!(
            "light: envmap stride {stride} must be a multiple of 4 and at least a row's {row} bytes"
        )));
    }
    (l.height as usize - 1)
        .checked_mul(stride)
        .and_then(|b| b.checked_add(row))
        .filter(|&b| b <= isize::MAX as usize)
        .ok_or_else(|| Error::invalid("light: envmap size overflows the address space"))?;
    let mut texels = Vec::new();
    texels
        .try_reserve_exact(l.width as usize * l.height as usize)
        .map_err(|_| Error::invalid("light: envmap too large for the available memory"))?;
    for y in 0..l.height as usize {
        // SAFETY: the caller's contract: row y starts y · stride bytes in,
        // holds 3 · width floats and is 4-byte aligned.
        let r = unsafe {
            std::slice::from_raw_parts(
                l.texels.cast::<u8>().add(y * stride).cast::<f32>(),
                3 * l.width as usize,
            )
        };
        for (x, t) in r.chunks_exact(3).enumerate() {
            if !t.iter().all(|v| v.is_finite() && *v >= 0.0) {
                return Err(Error::invalid(format!(
                    "light: envmap texel ({x}, {y}) must be finite and non-negative, got {t:?}"
                )));
            }
            texels.push(Rgb::new(t[0], t[1], t[2]) * Rgb::new(l.color[0], l.color[1], l.color[2]));
        }
    }
    let bitmap = Bitmap::new(l.width, l.height, texels)
        .ok_or_else(|| Error::invalid("light: envmap texels times color overflow"))?;
    let m = l.to_world;
    let to_world = if m.iter().all(|v| *v == 0.0) {
        cmlt_core::math::Mat3::IDENTITY
    } else {
        // Row-major in, glam's columns out.
        cmlt_core::math::Mat3::from_cols_array(&m).transpose()
    };
    Ok((bitmap, to_world))
}

/// Checks a C light and converts it.
fn light_from_c(l: &cmlt_light) -> Result<Light> {
    let finite = l.color.iter().all(|v| v.is_finite())
        && l.position.iter().all(|v| v.is_finite())
        && l.direction.iter().all(|v| v.is_finite())
        && l.cutoff_angle.is_finite()
        && l.beam_width.is_finite()
        && l.to_world.iter().all(|v| v.is_finite());
    if !finite {
        return Err(Error::invalid("light: every field must be finite"));
    }
    let color = Rgb::new(l.color[0], l.color[1], l.color[2]);
    let (position, direction) = (Vec3::from(l.position), Vec3::from(l.direction));
    let light = match l.type_ {
        CMLT_LIGHT_POINT => Light::Point {
            position,
            intensity: color,
        },
        CMLT_LIGHT_SPOT => Light::Spot {
            position,
            direction,
            intensity: color,
            cutoff_angle: l.cutoff_angle,
            beam_width: l.beam_width,
        },
        CMLT_LIGHT_DIRECTIONAL => Light::Directional {
            direction,
            irradiance: color,
        },
        CMLT_LIGHT_CONSTANT => Light::Constant { radiance: color },
        CMLT_LIGHT_SUN => Light::Sun {
            direction,
            radiance: color,
            half_aperture: l.cutoff_angle,
            profile: None,
        },
        // The bitmap is copied and the id set by cmlt_scene_add_light.
        CMLT_LIGHT_ENVMAP => Light::Envmap {
            bitmap: BitmapId(u32::MAX),
            scale: 1.0,
            to_world: cmlt_core::math::Mat3::IDENTITY,
        },
        t => return Err(Error::invalid(format!("light: unknown type {t}"))),
    };
    light
        .validate()
        .map_err(|reason| Error::invalid(format!("light: {reason}")))?;
    Ok(light)
}

/// Adds a light that is not an emitting mesh (point, spot, directional,
/// constant environment, environment map, whose texels are copied);
/// every field is checked first, and on failure the scene is unchanged.
/// `*out_index` (may be NULL) receives its index among the scene's
/// lights. A scene with lights at infinity (directional, constant,
/// envmap) cannot also have host shapes: commit refuses it (their light
/// paths need the scene's bounds).
///
/// # Safety
/// `scene` is a valid handle; `light` is NULL or valid; `out_index` is NULL
/// or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_add_light(
    scene: *mut cmlt_scene,
    light: *const cmlt_light,
    out_index: *mut u32,
) -> cmlt_status {
    guard("cmlt_scene_add_light", || {
        // SAFETY: the caller's contract.
        let (scene, l) = unsafe { (read(scene, "scene")?, read(light, "light")?) };
        let mut light = light_from_c(l)?;
        // SAFETY: the caller's contract.
        let envmap = match light {
            Light::Envmap { .. } => Some(unsafe { envmap_from_c(l)? }),
            _ => None,
        };
        if let Some((_, to_world)) = envmap {
            light = Light::Envmap {
                bitmap: BitmapId(u32::MAX),
                scale: 1.0,
                to_world,
            };
            light
                .validate()
                .map_err(|reason| Error::invalid(format!("light: {reason}")))?;
        }
        scene.building(|b| {
            room(b)?;
            if let (Some((bitmap, to_world)), Light::Envmap { scale, .. }) = (envmap, light) {
                light = Light::Envmap {
                    bitmap: b.builder.add_bitmap(bitmap),
                    scale,
                    to_world,
                };
            }
            let i = b.builder.add_light(light);
            if !out_index.is_null() {
                // SAFETY: non-NULL, so valid by the caller's contract.
                unsafe { *out_index = i as u32 };
            }
            Ok(())
        })
    })
}

/// Reads `count` elements of `N` floats (or u32) from `ptr` with `stride`
/// bytes between elements (0 = packed).
///
/// # Safety
/// When `count > 0`, `ptr` points to `count` elements at that stride.
unsafe fn gather<T: Copy + Default, const N: usize>(
    ptr: *const T,
    count: usize,
    stride: usize,
    what: &str,
) -> Result<Vec<[T; N]>> {
    let size = N * std::mem::size_of::<T>();
    let stride = if stride == 0 { size } else { stride };
    if count == 0 {
        return Ok(Vec::new());
    }
    if ptr.is_null() {
        return Err(Error::null(what));
    }
    if stride < size || stride % 4 != 0 {
        return Err(Error::invalid(format!(
            "{what}: stride {stride} must be a multiple of 4 and at least {size}"
        )));
    }
    if !(ptr as usize).is_multiple_of(std::mem::align_of::<T>()) {
        return Err(Error::invalid(format!(
            "{what}: pointer is not 4-byte aligned"
        )));
    }
    if count
        .checked_mul(stride)
        .is_none_or(|b| b > isize::MAX as usize)
    {
        return Err(Error::invalid(format!(
            "{what}: {count} elements overflow the address space"
        )));
    }
    let base = ptr.cast::<u8>();
    let mut out = Vec::new();
    try_reserve(&mut out, count)?;
    out.extend((0..count).map(|i| {
        let mut e = [T::default(); N];
        // SAFETY: element i lies inside the caller's array (checked
        // sizes above); it is aligned for T (aligned base, stride a
        // multiple of 4 = align_of::<T>()).
        unsafe {
            let p = base.add(i * stride).cast::<T>();
            for (k, v) in e.iter_mut().enumerate() {
                *v = p.add(k).read();
            }
        }
        e
    }));
    Ok(out)
}

/// Copies a mesh into the scene. Everything is checked first (pointers,
/// strides, finite values, indices in range, a known material, a finite
/// non-negative emission); on failure the scene is unchanged.
/// `*out_first_prim` (may be NULL) receives the scene-global index of the
/// mesh's first triangle, the numbering host intersectors report.
///
/// # Safety
/// `scene` is a valid handle; `mesh` is NULL or valid, and its arrays hold
/// what its counts and strides say; `out_first_prim` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_add_mesh(
    scene: *mut cmlt_scene,
    mesh: *const cmlt_mesh,
    out_first_prim: *mut u32,
) -> cmlt_status {
    guard("cmlt_scene_add_mesh", || {
        // SAFETY: the caller's contract.
        let (scene, m) = unsafe { (read(scene, "scene")?, read(mesh, "mesh")?) };
        if m.vertex_count > u32::MAX as usize || m.triangle_count > u32::MAX as usize {
            return Err(Error::invalid("mesh: more than 2^32 vertices or triangles"));
        }
        // SAFETY: the caller's contract on the arrays.
        let (positions, normals, uvs, indices) = unsafe {
            (
                gather::<f32, 3>(
                    m.positions,
                    m.vertex_count,
                    m.position_stride,
                    "mesh positions",
                )?,
                if m.normals.is_null() {
                    Vec::new()
                } else {
                    gather::<f32, 3>(m.normals, m.vertex_count, m.normal_stride, "mesh normals")?
                },
                if m.uvs.is_null() {
                    Vec::new()
                } else {
                    gather::<f32, 2>(m.uvs, m.vertex_count, m.uv_stride, "mesh uvs")?
                },
                gather::<u32, 3>(m.indices, m.triangle_count, m.index_stride, "mesh indices")?,
            )
        };
        let e = Rgb::new(m.emission[0], m.emission[1], m.emission[2]);
        let mesh = Mesh {
            positions: positions.into_iter().map(Vec3::from_array).collect(),
            normals: normals.into_iter().map(Vec3::from_array).collect(),
            uvs: uvs.into_iter().map(Vec2::from_array).collect(),
            indices,
            material: MaterialId(m.material),
            emission: (e != Rgb::ZERO).then_some(e),
        };
        if !normals_ok(&mesh) {
            return Err(Error::invalid("mesh: a shading normal has zero length"));
        }
        scene.building(|b| {
            mesh.validate(b.meshes, b.materials)
                .map_err(|e| Error::invalid(e.to_string()))?;
            let first = b.triangles;
            // Triangle and shape numbers share `prim_id`, split by its top bit.
            if first + mesh.indices.len() as u64 >= SHAPE_PRIM_BIT as u64 {
                return Err(Error::invalid(
                    "scene: too many triangles (2^31 − 1 at most)",
                ));
            }
            room(b)?;
            b.triangles += mesh.indices.len() as u64;
            b.meshes += 1;
            b.builder.add_mesh(mesh);
            if !out_first_prim.is_null() {
                // SAFETY: the caller's contract.
                unsafe { *out_first_prim = first as u32 };
            }
            Ok(())
        })
    })
}

/// Adds a group of analytic shapes the host intersects itself (see
/// `cmlt_shapes`, `cmlt_surface_fn`); the callbacks are copied.
/// `*out_first_shape` (may be NULL) receives the index of its first shape:
/// the host's intersector reports shape `i` of the group as
/// `prim_id = CMLT_SHAPE_BIT | (first + i)`. A scene with shapes needs a
/// host intersector (`cmlt_scene_set_intersector`) by commit time. On
/// failure the scene is unchanged.
///
/// # Safety
/// `scene` is a valid handle; `shapes` is NULL or valid, and its callback
/// stays callable while any renderer of the scene exists;
/// `out_first_shape` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_add_shapes(
    scene: *mut cmlt_scene,
    shapes: *const cmlt_shapes,
    out_first_shape: *mut u32,
) -> cmlt_status {
    guard("cmlt_scene_add_shapes", || {
        // SAFETY: the caller's contract.
        let (scene, g) = unsafe { (read(scene, "scene")?, read(shapes, "shapes")?) };
        if g.surface.is_none() {
            return Err(Error::null("shapes->surface"));
        }
        if g.count == 0 {
            return Err(Error::invalid("shapes: count must be at least 1"));
        }
        scene.building(|b| {
            if g.material as usize >= b.materials {
                return Err(Error::invalid(format!(
                    "shapes: material id {} does not exist",
                    g.material
                )));
            }
            let first = b.shapes;
            if first + g.count as u64 >= SHAPE_PRIM_BIT as u64 {
                return Err(Error::invalid("scene: too many shapes (2^31 − 1 at most)"));
            }
            let group = ShapeGroup {
                count: g.count,
                material: MaterialId(g.material),
                surface: Arc::new(HostShapes::new(*g, b.rejected_surfaces.clone())),
            };
            room(b)?;
            b.builder.add_shapes(group);
            b.shapes += g.count as u64;
            if !out_first_shape.is_null() {
                // SAFETY: the caller's contract.
                unsafe { *out_first_shape = first as u32 };
            }
            Ok(())
        })
    })
}

fn normals_ok(m: &Mesh) -> bool {
    m.normals
        .iter()
        .all(|n| !n.is_finite() || n.length_squared() > 0.0)
}

/// Makes the scene trace through the host's ray tracer instead of building
/// an acceleration structure (see `cmlt_intersector`); the callbacks are
/// copied. Hits must use the triangle numbering of the meshes added (and
/// `CMLT_SHAPE_BIT | shape` for host shapes).
///
/// # Safety
/// `scene` is a valid handle; `intersector` is NULL or valid, and its
/// callbacks stay callable while any renderer of the scene exists.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_set_intersector(
    scene: *mut cmlt_scene,
    intersector: *const cmlt_intersector,
) -> cmlt_status {
    guard("cmlt_scene_set_intersector", || {
        // SAFETY: the caller's contract.
        let (scene, i) = unsafe { (read(scene, "scene")?, read(intersector, "intersector")?) };
        if i.intersect.is_none() || i.occluded.is_none() {
            return Err(Error::null(
                "intersector->intersect or intersector->occluded",
            ));
        }
        scene.building(|b| {
            b.intersector = Some(*i);
            Ok(())
        })
    })
}

/// Chooses the acceleration structure `cmlt_scene_commit` builds
/// (`CMLT_ACCEL_BVH`, the default, or `CMLT_ACCEL_EMBREE`).
///
/// # Safety
/// `scene` is NULL or a valid handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_set_accel(scene: *mut cmlt_scene, accel: u32) -> cmlt_status {
    guard("cmlt_scene_set_accel", || {
        // SAFETY: the caller's contract.
        let scene = unsafe { read(scene, "scene") }?;
        if !accel_kind(accel)?.is_available() {
            return Err(Error::new(
                cmlt_status::CMLT_ERROR_UNSUPPORTED,
                "this build of cmlt has no Embree backend (cargo feature `embree`)",
            ));
        }
        scene.building(|b| {
            b.accel = accel;
            Ok(())
        })
    })
}

/// The backend a `CMLT_ACCEL_*` value names.
fn accel_kind(accel: u32) -> Result<AccelKind> {
    match accel {
        CMLT_ACCEL_BVH => Ok(AccelKind::Ours),
        CMLT_ACCEL_EMBREE => Ok(AccelKind::Embree),
        a => Err(Error::invalid(format!("unknown accel {a}"))),
    }
}

/// Builds a backend over `scene`'s triangles.
fn build_accel(kind: AccelKind, scene: &Scene) -> Result<Accel> {
    cmlt_core::accel::backend::Accel::build(kind, &scene.triangles().collect::<Vec<_>>())
        .map(Accel::Built)
        .map_err(|e| Error::new(cmlt_status::CMLT_ERROR_INTERNAL, e))
}

/// Validates the scene and builds its acceleration structure; afterwards
/// the scene is immutable and renderers can be made from it. On failure
/// the scene is unchanged and can still be edited. A scene in which
/// nothing emits commits too (its frames are black):
/// `cmlt_scene_light_count` tells.
///
/// Besides each element's own checks, meshes farther from the origin than
/// 65536 (2^16) times their bounding box's diagonal are refused
/// (`CMLT_ERROR_INVALID_ARGUMENT`): f32 cannot resolve them there (a unit
/// box 10^7 from the origin renders at half its brightness); translate the
/// scene and the camera near the origin.
///
/// # Safety
/// `scene` is NULL or a valid handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_commit(scene: *mut cmlt_scene) -> cmlt_status {
    guard("cmlt_scene_commit", || {
        // SAFETY: the caller's contract.
        let scene = unsafe { read(scene, "scene") }?;
        let mut state = scene
            .state
            .try_lock()
            .map_err(|e| Error::lock(e, "the scene is in use by another thread"))?;
        let State::Building(b) = &*state else {
            return Err(Error::operation("the scene is already committed"));
        };
        if b.shapes > 0 && b.intersector.is_none() {
            return Err(Error::operation(
                "a scene with host shapes needs the host's intersector \
                 (cmlt_scene_set_intersector): cmlt cannot intersect them",
            ));
        }
        let mut builder = b.builder.clone();
        // Renderers bring their own camera; the builder wants one.
        builder.set_camera(
            Camera::perspective(Mat4::IDENTITY, 60.0, FovAxis::X, 1, 1, 0.0, 1.0)
                .map_err(|e| Error::invalid(e.to_string()))?,
        );
        let built = builder.build().map_err(|e| Error::invalid(e.to_string()))?;
        let accel = match b.intersector {
            Some(i) => Accel::Host(HostIntersector::new(i, b.triangles as u32, b.shapes as u32)),
            None => build_accel(accel_kind(b.accel)?, &built)?,
        };
        let committed = Arc::new(Committed::new(
            built,
            accel,
            Settings::default(),
            b.rejected_surfaces.clone(),
        )?);
        check_oom()?;
        *state = State::Committed(committed);
        Ok(())
    })
}

/// Moves mesh `mesh` (0 for the first `cmlt_scene_add_mesh`, and so on)
/// of a committed scene: `vertex_count` new positions (as many as the mesh
/// has) and, unless `normals` is NULL, new shading normals — the scene
/// update of an animated frame, e.g. a rigid transform the host applied.
/// Topology, material and emission stay. cmlt's BVH is refitted (Embree's
/// scene rebuilt; a host intersector must follow on its own). Renderers of
/// the scene start a new frame at their next `cmlt_renderer_prepare`;
/// until then `cmlt_renderer_render` returns `CMLT_ERROR_INVALID_OPERATION`.
/// `CMLT_ERROR_BUSY` while a renderer of the scene prepares or renders.
/// On error the scene is unchanged. The moved scene must stay within the
/// f32 bound `cmlt_scene_commit` checks (`CMLT_ERROR_INVALID_ARGUMENT`).
///
/// Part of the allocation-free frame loop with cmlt's BVH: packed arrays
/// are read in place, strided ones copied into buffers sized at commit (24
/// bytes per vertex of the largest mesh), error messages are literals. It
/// allocates only to give normals to a mesh added without them, when an
/// emitter's area becomes or stops being zero (its light distribution is
/// rebuilt), and with Embree (its scene is rebuilt).
///
/// # Safety
/// `scene` is NULL or a valid handle; `positions` (and `normals`, unless
/// NULL) hold `vertex_count` elements of 3 floats at their strides.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_update_mesh(
    scene: *mut cmlt_scene,
    mesh: u32,
    positions: *const f32,
    vertex_count: usize,
    position_stride: usize,
    normals: *const f32,
    normal_stride: usize,
) -> cmlt_status {
    guard("cmlt_scene_update_mesh", || {
        // Part of the frame loop: nothing here allocates, error messages
        // included (literals), with cmlt's BVH.
        // SAFETY: the caller's contract.
        let scene = unsafe { read(scene, "scene") }?;
        if positions.is_null() {
            return Err(Error::null("positions"));
        }
        let c = scene.committed()?;
        let mut live = c
            .live
            .try_write()
            .map_err(|e| Error::lock(e, "renderers of this scene are preparing or rendering"))?;
        let Live {
            scene,
            accel,
            scratch: [p_scratch, n_scratch],
        } = &mut *live;
        let index = mesh as usize;
        let count = scene
            .meshes
            .get(index)
            .ok_or(Error::invalid("mesh: no mesh with this index"))?
            .positions
            .len();
        if vertex_count != count {
            return Err(Error::invalid(
                "vertex_count differs from the mesh's number of vertices",
            ));
        }
        // SAFETY: the caller's contract on the arrays.
        let p = unsafe { vec3s(positions, count, position_stride, p_scratch) }?;
        let n = if normals.is_null() {
            None
        } else {
            // SAFETY: the caller's contract on the arrays.
            Some(unsafe { vec3s(normals, count, normal_stride, n_scratch) }?)
        };
        if n.iter()
            .flat_map(|n| n.iter())
            .any(|v| v.length_squared() == 0.0)
        {
            return Err(Error::invalid("normals: a shading normal has zero length"));
        }
        // Embree's scene is rebuilt (allocating); should that fail, the
        // mesh is put back so scene and accel agree again.
        let old = match accel {
            Accel::Built(b) if b.name() != "ours" => Some((
                scene.meshes[index].positions.clone(),
                scene.meshes[index].normals.clone(),
            )),
            _ => None,
        };
        scene.update_mesh(index, p, n).map_err(update_error)?;
        if let Accel::Built(built) = accel
            && let Err(e) = built.update(scene)
        {
            if let Some((op, on)) = old {
                let _ = scene.update_mesh(index, &op, Some(&on));
            }
            return Err(Error::new(cmlt_status::CMLT_ERROR_INTERNAL, e));
        }
        Ok(())
    })
}

/// Starts a new animation frame of a committed scene: every mesh's current
/// positions become the ones the motion vectors of
/// `cmlt_renderer_aov_rows` measure from. Call it once per frame, before
/// that frame's `cmlt_scene_update_mesh` calls: a mesh then moves from
/// where it was when the frame began (however often it is updated), and a
/// mesh not updated does not move. Changes no geometry (renderers do not
/// restart) and allocates nothing. `CMLT_ERROR_BUSY` while a renderer of
/// the scene prepares, renders or computes auxiliary outputs.
///
/// # Safety
/// `scene` is NULL or a valid handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_begin_frame(scene: *mut cmlt_scene) -> cmlt_status {
    guard("cmlt_scene_begin_frame", || {
        // SAFETY: the caller's contract.
        let scene = unsafe { read(scene, "scene") }?;
        let c = scene.committed()?;
        let mut live = c
            .live
            .try_write()
            .map_err(|e| Error::lock(e, "renderers of this scene are preparing or rendering"))?;
        live.scene.begin_frame();
        Ok(())
    })
}

/// `count` host vectors of 3 floats at `stride` bytes (0 = packed): read in
/// place when packed, else copied into `scratch` (which has room for
/// `count`, so nothing is allocated). Literal error messages: a frame
/// calls this.
///
/// # Safety
/// `ptr` is non-NULL and points to `count` elements at that stride.
unsafe fn vec3s(
    ptr: *const f32,
    count: usize,
    stride: usize,
    scratch: &mut Vec<Vec3>,
) -> Result<&[Vec3]> {
    let stride = if stride == 0 { 12 } else { stride };
    if stride < 12 || stride % 4 != 0 {
        return Err(Error::invalid(
            "stride must be a multiple of 4 and at least 12",
        ));
    }
    if !(ptr as usize).is_multiple_of(4) {
        return Err(Error::invalid("array pointer is not 4-byte aligned"));
    }
    if count
        .checked_mul(stride)
        .is_none_or(|b| b > isize::MAX as usize)
    {
        return Err(Error::invalid("array overflows the address space"));
    }
    if stride == 12 {
        // SAFETY: `count` packed, aligned, initialised triples (the
        // caller's contract) have Vec3's layout (asserted above).
        return Ok(unsafe { std::slice::from_raw_parts(ptr.cast::<Vec3>(), count) });
    }
    if count > scratch.capacity() {
        return Err(Error::invalid("more vertices than the mesh has"));
    }
    scratch.clear();
    let base = ptr.cast::<u8>();
    scratch.extend((0..count).map(|i| {
        // SAFETY: element i lies inside the caller's array (checked sizes),
        // 4-byte aligned (aligned base, stride a multiple of 4).
        unsafe {
            let e = base.add(i * stride).cast::<f32>();
            Vec3::new(e.read(), e.add(1).read(), e.add(2).read())
        }
    }));
    Ok(scratch)
}

/// A refused mesh update, with a literal message (no allocation).
fn update_error(e: SceneError) -> Error {
    match e {
        SceneError::OutOfMemory => {
            Error::out_of_memory("out of memory: no room for the mesh's new normals")
        }
        SceneError::NonFiniteVertex { .. } => Error::invalid("a position or normal is not finite"),
        SceneError::TooFarFromOrigin { .. } => Error::invalid(
            "the moved meshes lie farther from the origin than 65536 times their \
             bounding box's diagonal: f32 cannot resolve them there",
        ),
        SceneError::AttributeCount { .. } => Error::invalid("normals must be one per position"),
        e => Error::invalid(e.to_string()),
    }
}

/// Loads a Mitsuba 3 XML scene file (the subset `cmlt render` reads) as a
/// committed scene with our BVH. `*out_camera`, `*out_width` and
/// `*out_height` (each may be NULL) receive the file's sensor.
///
/// Only in a library built with the `loader` cargo feature (the Mitsuba
/// loader, with its XML, mesh and image decoders); without it the call
/// returns `CMLT_ERROR_UNSUPPORTED` after checking its arguments, and
/// writes nothing.
///
/// # Safety
/// `path` is NULL or a NUL-terminated string; the out pointers are NULL or
/// valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_load_file(
    path: *const c_char,
    out: *mut *mut cmlt_scene,
    out_camera: *mut cmlt_camera,
    out_width: *mut u32,
    out_height: *mut u32,
) -> cmlt_status {
    guard("cmlt_scene_load_file", || {
        // SAFETY: the caller's contract.
        let (path, out) = unsafe { (read(path, "path")?, write(out, "out")?) };
        // SAFETY: `path` is NUL-terminated (the caller's contract).
        let path = unsafe { CStr::from_ptr(path) }
            .to_str()
            .map_err(|_| Error::invalid("path is not UTF-8"))?;
        let loaded = loader::file(path)?;
        // SAFETY: the caller's contract.
        unsafe { finish_loaded(loaded, out, out_camera, out_width, out_height) }
    })
}

/// A built-in scene by name: `"cornell-box"` (the Cornell box `cmlt render`
/// draws by default) at `width × height` pixels, committed with our BVH;
/// `*out_camera` (may be NULL) receives its camera.
///
/// Only in a library built with the `loader` cargo feature (the built-in
/// scenes are Mitsuba XML); without it the call returns
/// `CMLT_ERROR_UNSUPPORTED` after checking its arguments, and writes
/// nothing.
///
/// # Safety
/// `name` is NULL or NUL-terminated; the out pointers are NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_new_builtin(
    name: *const c_char,
    width: u32,
    height: u32,
    out: *mut *mut cmlt_scene,
    out_camera: *mut cmlt_camera,
) -> cmlt_status {
    guard("cmlt_scene_new_builtin", || {
        // SAFETY: the caller's contract.
        let (name, out) = unsafe { (read(name, "name")?, write(out, "out")?) };
        // SAFETY: NUL-terminated (the caller's contract).
        let name = unsafe { CStr::from_ptr(name) }.to_str().unwrap_or("");
        if width == 0 || height == 0 || width > 1 << 14 || height > 1 << 14 {
            return Err(Error::invalid("width and height must be in 1 ..= 16384"));
        }
        let loaded = loader::builtin(name, width, height)?;
        // SAFETY: the caller's contract.
        unsafe {
            finish_loaded(
                loaded,
                out,
                out_camera,
                std::ptr::null_mut(),
                std::ptr::null_mut(),
            )
        }
    })
}

/// Builds the BVH of a loaded scene and hands out the handle and camera.
///
/// # Safety
/// The out pointers other than `out` are NULL or valid.
unsafe fn finish_loaded(
    loaded: Loaded,
    out: &mut *mut cmlt_scene,
    out_camera: *mut cmlt_camera,
    out_width: *mut u32,
    out_height: *mut u32,
) -> Result<()> {
    let scene = loaded.scene;
    let cam = scene.camera;
    let accel = build_accel(AccelKind::Ours, &scene)?;
    let handle = cmlt_scene::committed_from(Committed::new(
        scene,
        accel,
        loaded.settings,
        Arc::default(),
    )?);
    check_oom()?;
    *out = Box::into_raw(handle);
    // SAFETY: the caller's contract.
    unsafe {
        if let Some(c) = out_camera.as_mut() {
            *c = cmlt_camera::from_camera(&cam);
        }
        if let Some(w) = out_width.as_mut() {
            *w = cam.width();
        }
        if let Some(h) = out_height.as_mut() {
            *h = cam.height();
        }
    }
    Ok(())
}

/// Lambertian reflection (bit of `cmlt_scene_get_effects`' mask).
pub const CMLT_EFFECT_DIFFUSE: u32 = 0x1;
/// Rough (microfacet) reflection.
pub const CMLT_EFFECT_GLOSSY: u32 = 0x2;
/// Smooth mirror reflection.
pub const CMLT_EFFECT_SPECULAR_REFLECTION: u32 = 0x4;
/// Smooth dielectric refraction.
pub const CMLT_EFFECT_REFRACTION: u32 = 0x8;
/// Textured reflectance.
pub const CMLT_EFFECT_TEXTURES: u32 = 0x10;
/// Emitting surfaces.
pub const CMLT_EFFECT_AREA_LIGHTS: u32 = 0x20;
/// A thin-lens camera (reported by `cmlt_renderer_get_stats`, which knows
/// the camera).
pub const CMLT_EFFECT_DEPTH_OF_FIELD: u32 = 0x40;
/// Normal or bump maps.
pub const CMLT_EFFECT_NORMAL_MAPPING: u32 = 0x80;
/// Alpha masks (opacity textures).
pub const CMLT_EFFECT_ALPHA_MASKS: u32 = 0x100;
/// Plastics (a dielectric coating over a diffuse base).
pub const CMLT_EFFECT_COATING: u32 = 0x200;
/// Rough dielectric reflection and refraction (`CMLT_MATERIAL_ROUGH_GLASS`).
pub const CMLT_EFFECT_ROUGH_REFRACTION: u32 = 0x400;
/// Point, spot and directional lights.
pub const CMLT_EFFECT_POINT_LIGHTS: u32 = 0x800;
/// An environment (constant or an environment map).
pub const CMLT_EFFECT_ENVIRONMENT: u32 = 0x1000;
/// A principled material (`CMLT_MATERIAL_PRINCIPLED`).
pub const CMLT_EFFECT_PRINCIPLED: u32 = 0x2000;
/// Rough diffuse reflection (`CMLT_MATERIAL_ROUGH_DIFFUSE`).
pub const CMLT_EFFECT_ROUGH_DIFFUSE: u32 = 0x4000;
/// Participating media and null boundaries (`cmlt_scene_add_medium`,
/// `CMLT_MATERIAL_NULL`).
pub const CMLT_EFFECT_MEDIA: u32 = 0x8000;

// The bits are the core's `Effect` discriminants (literals here so that
// cbindgen writes them into the header).
const _: () = assert!(
    CMLT_EFFECT_DIFFUSE == 1 << Effect::Diffuse as u32
        && CMLT_EFFECT_GLOSSY == 1 << Effect::Glossy as u32
        && CMLT_EFFECT_SPECULAR_REFLECTION == 1 << Effect::SpecularReflection as u32
        && CMLT_EFFECT_REFRACTION == 1 << Effect::Refraction as u32
        && CMLT_EFFECT_TEXTURES == 1 << Effect::Textures as u32
        && CMLT_EFFECT_AREA_LIGHTS == 1 << Effect::AreaLights as u32
        && CMLT_EFFECT_DEPTH_OF_FIELD == 1 << Effect::DepthOfField as u32
        && CMLT_EFFECT_NORMAL_MAPPING == 1 << Effect::NormalMapping as u32
        && CMLT_EFFECT_ALPHA_MASKS == 1 << Effect::AlphaMasks as u32
        && CMLT_EFFECT_COATING == 1 << Effect::Coating as u32
        && CMLT_EFFECT_ROUGH_REFRACTION == 1 << Effect::RoughRefraction as u32
        && CMLT_EFFECT_POINT_LIGHTS == 1 << Effect::PointLights as u32
        && CMLT_EFFECT_ENVIRONMENT == 1 << Effect::Environment as u32
        && CMLT_EFFECT_PRINCIPLED == 1 << Effect::Principled as u32
        && CMLT_EFFECT_ROUGH_DIFFUSE == 1 << Effect::RoughDiffuse as u32
        && CMLT_EFFECT_MEDIA == 1 << Effect::Media as u32
        && Effect::ALL.len() == 16
);

/// `*out_effects` = the `CMLT_EFFECT_*` bits a committed scene calls for
/// (materials of its meshes, its emitters); `*out_specular_chains` (may be
/// NULL) = 1 when a smooth conductor or dielectric is used, i.e. when the
/// caustic perturbation can apply.
///
/// # Safety
/// `scene` is NULL or a valid handle; the out pointers are NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_get_effects(
    scene: *const cmlt_scene,
    out_effects: *mut u32,
    out_specular_chains: *mut u32,
) -> cmlt_status {
    guard("cmlt_scene_get_effects", || {
        // SAFETY: the caller's contract.
        let (scene, out) = unsafe { (read(scene, "scene")?, write(out_effects, "out_effects")?) };
        let c = scene.committed()?;
        let pinhole = Camera::perspective(Mat4::IDENTITY, 60.0, FovAxis::X, 1, 1, 0.0, 1.0)
            .map_err(|e| Error::invalid(e.to_string()))?;
        let a = c.live()?.scene.analysis(&pinhole);
        *out = a.effects.0;
        // SAFETY: the caller's contract.
        if let Some(sc) = unsafe { out_specular_chains.as_mut() } {
            *sc = a.specular_chains as u32;
        }
        Ok(())
    })
}

/// Number of triangles of a committed scene.
///
/// # Safety
/// `scene` is NULL or a valid handle; `out` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_triangle_count(
    scene: *const cmlt_scene,
    out: *mut u32,
) -> cmlt_status {
    guard("cmlt_scene_triangle_count", || {
        // SAFETY: the caller's contract.
        let (scene, out) = unsafe { (read(scene, "scene")?, write(out, "out")?) };
        *out = scene.committed()?.live()?.scene.triangle_count() as u32;
        Ok(())
    })
}

/// Number of lights of a committed scene that emit: emitting meshes with
/// a non-zero area (degenerate triangles emit nothing), point, spot and
/// directional lights and environments of non-zero power. 0 means every
/// frame of the scene is black whatever the estimator; the scene still
/// commits and renders (a level may be dark on purpose), so a host that
/// did not mean it should check this after `cmlt_scene_commit` and after
/// `cmlt_scene_update_mesh` moved an emitter (an emitter squashed to zero
/// area stops counting, and counts again when it has area).
///
/// # Safety
/// `scene` is NULL or a valid handle; `out` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_light_count(
    scene: *const cmlt_scene,
    out: *mut u32,
) -> cmlt_status {
    guard("cmlt_scene_light_count", || {
        // SAFETY: the caller's contract.
        let (scene, out) = unsafe { (read(scene, "scene")?, write(out, "out")?) };
        *out = scene.committed()?.live()?.scene.lights.len() as u32;
        Ok(())
    })
}
