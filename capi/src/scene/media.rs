//! Participating media through the C API: homogeneous media
//! (`cmlt_medium`, Mitsuba 3's `homogeneous`), attached to the two sides
//! of a mesh (`cmlt_scene_set_mesh_media`) and to the cameras
//! (`cmlt_scene_set_camera_medium`); `CMLT_MATERIAL_NULL` is the
//! index-matched boundary that only changes the medium a ray is in.
//!
//! Each call checks its ids against what the scene holds so far, so a bad
//! id is refused when it is passed (with the scene unchanged), not at
//! commit. PT, BDPT, MLT and CMLT render media, over either level 1; a
//! library built without the `media` feature refuses such a scene at
//! commit (`CMLT_EFFECT_MEDIA` not built).

use cmlt_core::math::Rgb;
use cmlt_core::scene::{Medium, MediumId, MediumInterface, Phase};

use super::{cmlt_scene, room};
use crate::error::{Error, Result, cmlt_status, guard, read};

/// Isotropic scattering, 1/(4π) over the sphere (`cmlt_medium.g` ignored).
pub const CMLT_PHASE_ISOTROPIC: u32 = 0;
/// Henyey–Greenstein scattering with asymmetry `cmlt_medium.g` in (−1, 1):
/// g > 0 scatters forwards, g < 0 backwards, 0 is isotropic.
pub const CMLT_PHASE_HG: u32 = 1;

/// "No medium" (vacuum) in `cmlt_scene_set_mesh_media` and
/// `cmlt_scene_set_camera_medium`.
pub const CMLT_MEDIUM_NONE: u32 = u32::MAX;

/// A homogeneous participating medium (Mitsuba 3's `homogeneous` with
/// its `scale` folded into `sigma_t`).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct cmlt_medium {
    /// Extinction coefficient σ_t per RGB channel, per unit of scene
    /// length: finite, ≥ 0. Light crossing a distance d keeps
    /// exp(−σ_t d) of itself.
    pub sigma_t: [f32; 3],
    /// Single-scattering albedo σ_s / σ_t per channel, in [0, 1]: 0 absorbs
    /// only, 1 scatters without absorbing.
    pub albedo: [f32; 3],
    /// One of the `CMLT_PHASE_*` values.
    pub phase: u32,
    /// Henyey–Greenstein asymmetry for `CMLT_PHASE_HG`, finite with
    /// |g| < 1; ignored (but must be finite) otherwise.
    pub g: f32,
}

/// The core's medium for a C description, checked.
fn medium_from_c(m: &cmlt_medium) -> Result<Medium> {
    let phase = match m.phase {
        CMLT_PHASE_ISOTROPIC if m.g.is_finite() => Phase::Isotropic,
        CMLT_PHASE_ISOTROPIC => return Err(Error::invalid("medium: g must be finite")),
        CMLT_PHASE_HG => Phase::HenyeyGreenstein { g: m.g },
        p => return Err(Error::invalid(format!("medium: unknown phase type {p}"))),
    };
    let rgb = |v: [f32; 3]| Rgb::new(v[0], v[1], v[2]);
    Medium::homogeneous(rgb(m.sigma_t), rgb(m.albedo), 1.0, phase)
        .map_err(|e| Error::invalid(e.to_string()))
}

/// `CMLT_MEDIUM_NONE` or an id below `count`, as the core's id.
fn medium_id(id: u32, count: u32, what: &str) -> Result<Option<MediumId>> {
    match id {
        CMLT_MEDIUM_NONE => Ok(None),
        id if id < count => Ok(Some(MediumId(id))),
        id => Err(Error::invalid(format!(
            "{what}: medium id {id} does not exist (the scene has {count}; \
             CMLT_MEDIUM_NONE for vacuum)"
        ))),
    }
}

/// Adds a homogeneous medium; its id (for `cmlt_scene_set_mesh_media` and
/// `cmlt_scene_set_camera_medium`; ids count from 0 in the order added)
/// goes to `*out_id` (may be NULL). On failure the scene is unchanged.
///
/// # Safety
/// `scene` is a valid handle; `medium` is NULL or valid; `out_id` is NULL
/// or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_add_medium(
    scene: *mut cmlt_scene,
    medium: *const cmlt_medium,
    out_id: *mut u32,
) -> cmlt_status {
    guard("cmlt_scene_add_medium", || {
        // SAFETY: the caller's contract.
        let (scene, m) = unsafe { (read(scene, "scene")?, read(medium, "medium")?) };
        let medium = medium_from_c(m)?;
        scene.building(|b| {
            if b.media == CMLT_MEDIUM_NONE {
                return Err(Error::invalid("scene: too many media"));
            }
            room(b)?;
            let MediumId(id) = b.builder.add_medium(medium);
            b.media += 1;
            if !out_id.is_null() {
                // SAFETY: the caller's contract.
                unsafe { *out_id = id };
            }
            Ok(())
        })
    })
}

/// Names the media on the two sides of mesh `mesh` (its index: 0 for the
/// first mesh added, as in `cmlt_scene_update_mesh`): `interior` on the
/// side its geometric normal points away from (the inside of a closed
/// mesh wound counter-clockwise seen from outside), `exterior` on the side
/// it points to; `CMLT_MEDIUM_NONE` for vacuum. A ray that crosses the
/// mesh (through a `CMLT_MATERIAL_NULL` surface, or refracted by glass)
/// is then in the medium of the side it leaves into. A later call for the
/// same mesh replaces the earlier one. On failure the scene is unchanged.
///
/// # Safety
/// `scene` is a valid handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_set_mesh_media(
    scene: *mut cmlt_scene,
    mesh: u32,
    interior: u32,
    exterior: u32,
) -> cmlt_status {
    guard("cmlt_scene_set_mesh_media", || {
        // SAFETY: the caller's contract.
        let scene = unsafe { read(scene, "scene")? };
        scene.building(|b| {
            if mesh as usize >= b.meshes {
                return Err(Error::invalid(format!(
                    "mesh media: mesh {mesh} does not exist (the scene has {})",
                    b.meshes
                )));
            }
            let media = MediumInterface {
                interior: medium_id(interior, b.media, "mesh media (interior)")?,
                exterior: medium_id(exterior, b.media, "mesh media (exterior)")?,
            };
            room(b)?;
            b.builder.set_mesh_media(mesh as usize, media);
            Ok(())
        })
    })
}

/// Sets the medium the cameras of the scene's renderers sit in
/// (`CMLT_MEDIUM_NONE`, the default, for vacuum): the medium camera rays
/// start in, until they cross a mesh that names media. On failure the
/// scene is unchanged.
///
/// # Safety
/// `scene` is a valid handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_set_camera_medium(
    scene: *mut cmlt_scene,
    medium: u32,
) -> cmlt_status {
    guard("cmlt_scene_set_camera_medium", || {
        // SAFETY: the caller's contract.
        let scene = unsafe { read(scene, "scene")? };
        scene.building(|b| {
            let id = medium_id(medium, b.media, "camera medium")?;
            b.builder.set_camera_medium(id);
            Ok(())
        })
    })
}
