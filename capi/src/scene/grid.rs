//! Voxel-grid textures through the C API: what Mitsuba's `volume` texture
//! over a `gridvolume` is to its loader. A surface reads the grid at its
//! world position, so a grid colours a mesh without uv coordinates (a
//! solid texture); it fills the same material slots as an image texture
//! (`cmlt_material.color_texture`, the principled scalars, the opacity)
//! and shares their ids, but cannot be a normal or bump map, which need
//! the surface's uv gradient.
//!
//! The grid is copied in and checked at the call, so a bad grid is
//! refused there with the scene unchanged: every slot a texture fills is
//! a fraction, so every voxel must lie in [0, 1] (trilinear weights are
//! convex, so every lookup does too), and the transform must be
//! invertible.

use cmlt_core::math::{Affine3A, Mat3, Rgb, Vec3};
use cmlt_core::scene::{Grid, GridFilter, GridWrap, Texture};

use super::{cmlt_scene, room};
use crate::alloc::try_reserve;
use crate::error::{Error, Result, cmlt_status, guard, read, write};

/// Trilinear interpolation between the eight voxel centres around the
/// point (Mitsuba's `filter_type = "trilinear"`, its default).
pub const CMLT_GRID_TRILINEAR: u32 = 0;
/// The voxel the point lies in (Mitsuba's `filter_type = "nearest"`).
pub const CMLT_GRID_NEAREST: u32 = 1;

/// Outside the grid, the nearest voxel on its boundary (Mitsuba's
/// `wrap_mode = "clamp"`, its default).
pub const CMLT_GRID_CLAMP: u32 = 0;
/// The grid tiled (Mitsuba's `wrap_mode = "repeat"`).
pub const CMLT_GRID_REPEAT: u32 = 1;
/// The grid tiled with every other copy mirrored (Mitsuba's
/// `wrap_mode = "mirror"`).
pub const CMLT_GRID_MIRROR: u32 = 2;

/// A grid of voxels spanning the unit cube [0, 1]³ of its own frame,
/// placed in the world by `to_world` (Mitsuba's `gridvolume`; a voxel's
/// value sits at its centre, (i + ½)/resolution in that frame).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct cmlt_grid {
    /// Voxels along x, y and z, each > 0.
    pub resolution: [u32; 3],
    /// Values per voxel: 1 (grey) or 3 (linear RGB).
    pub channels: u32,
    /// `resolution[0] · resolution[1] · resolution[2] · channels` floats,
    /// x fastest, then y, then z (the layout of Mitsuba's `.vol` files),
    /// each finite and in [0, 1]; 4-byte aligned, read during the call.
    pub voxels: *const f32,
    /// The grid-to-world transform, a row-major 3×4 affine matrix (the
    /// first three columns the linear part, the fourth the translation)
    /// mapping the unit cube to where the grid lies; invertible. All zeros
    /// means the identity.
    pub to_world: [f32; 12],
    /// `CMLT_GRID_TRILINEAR` or `CMLT_GRID_NEAREST`.
    pub filter: u32,
    /// `CMLT_GRID_CLAMP`, `CMLT_GRID_REPEAT` or `CMLT_GRID_MIRROR`.
    pub wrap: u32,
}

/// The world-to-grid map for a C `to_world`, refused when singular or not
/// finite.
fn to_local_from_c(m: &[f32; 12]) -> Result<Affine3A> {
    if m.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid("grid: to_world must be finite"));
    }
    if m.iter().all(|&v| v == 0.0) {
        return Ok(Affine3A::IDENTITY);
    }
    let col = |c: usize| Vec3::new(m[c], m[4 + c], m[8 + c]);
    let linear = Mat3::from_cols(col(0), col(1), col(2));
    let to_world = Affine3A::from_mat3_translation(linear, col(3));
    // A determinant that is zero, or tiny against the matrix's scale (the
    // inputs are finite, so it is too), squashes the grid onto a plane
    // or line: no inverse worth looking up through.
    let scale = linear
        .to_cols_array()
        .iter()
        .fold(0.0f32, |s, v| s.max(v.abs()));
    let det = linear.determinant();
    let to_local = to_world.inverse();
    if det.abs() <= 1e-6 * scale * scale * scale || !to_local.is_finite() {
        return Err(Error::invalid("grid: to_world must be invertible"));
    }
    Ok(to_local)
}

/// The core grid for a C description, checked and copied.
///
/// # Safety
/// `g.voxels` is NULL or points to the number of floats `g` says.
unsafe fn grid_from_c(g: &cmlt_grid) -> Result<Grid> {
    if !matches!(g.channels, 1 | 3) {
        return Err(Error::invalid(format!(
            "grid: channels must be 1 or 3, got {}",
            g.channels
        )));
    }
    if g.resolution.contains(&0) {
        return Err(Error::invalid("grid: every resolution must be > 0"));
    }
    let filter = match g.filter {
        CMLT_GRID_TRILINEAR => GridFilter::Trilinear,
        CMLT_GRID_NEAREST => GridFilter::Nearest,
        f => return Err(Error::invalid(format!("grid: unknown filter {f}"))),
    };
    let wrap = match g.wrap {
        CMLT_GRID_CLAMP => GridWrap::Clamp,
        CMLT_GRID_REPEAT => GridWrap::Repeat,
        CMLT_GRID_MIRROR => GridWrap::Mirror,
        w => return Err(Error::invalid(format!("grid: unknown wrap mode {w}"))),
    };
    let to_local = to_local_from_c(&g.to_world)?;
    let count = g
        .resolution
        .iter()
        .try_fold(1usize, |n, &r| n.checked_mul(r as usize))
        .filter(|n| {
            n.checked_mul(g.channels as usize * 4)
                .is_some_and(|b| b <= isize::MAX as usize)
        })
        .ok_or_else(|| Error::invalid("grid: size overflows the address space"))?;
    if g.voxels.is_null() {
        return Err(Error::null("voxels"));
    }
    if !(g.voxels as usize).is_multiple_of(4) {
        return Err(Error::invalid("grid: voxels must be 4-byte aligned"));
    }
    let c = g.channels as usize;
    // SAFETY: the caller's contract: `count · c` aligned, readable floats.
    let data = unsafe { std::slice::from_raw_parts(g.voxels, count * c) };
    if let Some(i) = data
        .iter()
        .position(|v| !(v.is_finite() && (0.0..=1.0).contains(v)))
    {
        return Err(Error::invalid(format!(
            "grid: voxel value {i} is {}: every value must be finite and in [0, 1] \
             (a texture fills reflectances and other fractions)",
            data[i]
        )));
    }
    let mut voxels = Vec::new();
    try_reserve(&mut voxels, count)?;
    voxels.extend(data.chunks_exact(c).map(|v| match v {
        [g] => Rgb::splat(*g),
        _ => Rgb::new(v[0], v[1], v[2]),
    }));
    Grid::new(g.resolution, voxels, to_local, filter, wrap)
        .ok_or_else(|| Error::invalid("grid: invalid grid"))
}

/// Adds a voxel-grid texture (see `cmlt_grid`), copied from host memory.
/// Its id goes to `*out_id`: ids are shared with `cmlt_scene_add_texture`
/// (they start at 1 and count the textures of both kinds in the order
/// added), for `cmlt_material`'s `color_texture`, `principled_textures`
/// and `opacity_texture`; a material naming it as `normal_map` or
/// `bump_map` is refused. On failure the scene is unchanged.
///
/// # Safety
/// `scene` is a valid handle; `grid` is NULL or valid, its `voxels` NULL
/// or pointing to as many floats as it says; `out_id` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_scene_add_grid_texture(
    scene: *mut cmlt_scene,
    grid: *const cmlt_grid,
    out_id: *mut u32,
) -> cmlt_status {
    guard("cmlt_scene_add_grid_texture", || {
        // SAFETY: the caller's contract.
        let (scene, g, out) = unsafe {
            (
                read(scene, "scene")?,
                read(grid, "grid")?,
                write(out_id, "out_id")?,
            )
        };
        // SAFETY: the caller's contract on `grid.voxels`.
        let grid = unsafe { grid_from_c(g) }?;
        scene.building(|b| {
            if b.textures.len() >= u32::MAX as usize - 1 {
                return Err(Error::invalid("scene: too many textures"));
            }
            room(b)?;
            let id = b.builder.add_grid(grid);
            b.textures.push(Texture::Grid(id));
            *out = b.textures.len() as u32;
            Ok(())
        })
    })
}
