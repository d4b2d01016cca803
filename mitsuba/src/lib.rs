//! Scenes for hosts with `std`, shared by the command-line front end
//! (`cmlt-cli`) and the C API (`cmlt-capi`, with its `loader` feature):
//! loading Mitsuba 3 XML scenes into a `cmlt::scene::Scene` ([`load_scene`],
//! [`builtin_scene`]). It is a crate of its own so that the C library and
//! the fuzz targets do not carry the CLI's image writers, plotting and
//! argument parsing, and so that a C library without it carries no XML,
//! image or mesh decoders. The ray-tracing backend a scene is traced with,
//! chosen at run time, is the core's (`cmlt::accel::backend`).
//!
//! The supported subset is what Bitterli's scenes in Mitsuba 3 syntax use,
//! with Mitsuba's semantics (defaults, conventions, error cases) read from
//! Mitsuba 3.9's sources:
//!
//! - document: `<scene version="2.x|3.x">`, `<default>` and `$name`
//!   substitution in every attribute (`defaults` passed to [`load_scene`]
//!   override `<default>` like `mitsuba -D`), `id` + `<ref>` (also forward
//!   references), comments;
//! - `<integrator>` of any type (recorded) with `max_depth`, `rr_depth`,
//!   `hide_emitters`;
//! - `<sensor type="perspective|thinlens">` with `fov`/`fov_axis` or
//!   `focal_length`, `to_world`, `aperture_radius`, `focus_distance` (accepted
//!   and unused by `perspective`, as in Mitsuba);
//!   `hdrfilm` `width`/`height`; `sampler` `sample_count`; `rfilter box`
//!   (other filters render as box, with a warning);
//! - shapes `obj`, `ply`, `serialized` (`shape_index`), `rectangle`, `cube`,
//!   `sphere`, `disk` (spheres and disks tessellated with exact area),
//!   `to_world`, `flip_normals`, `face_normals`, `flip_tex_coords`; one
//!   `area` emitter per shape;
//! - BSDFs `diffuse`, `conductor`, `roughconductor` (isotropic; named `material` presets),
//!   `dielectric` (with `specular_reflectance`/`specular_transmittance`),
//!   `thindielectric`, `roughdielectric`, `plastic`, `roughplastic`,
//!   `principled` (Mitsuba 3's parameters; scalars may be textures),
//!   Mitsuba 0.6's `roughdiffuse` (Oren–Nayar; 0.6's and the upgraded
//!   parameter names), `twosided`, and the wrappers `normalmap`,
//!   `bumpmap`, `mask`; textures `bitmap` (JPEG/PNG, OpenEXR, Radiance
//!   HDR and PFM), `checkerboard` and `volume` (`constvolume`, or a
//!   `gridvolume` `.vol` file read at the surface's world position);
//! - scene-level emitters `point`, `spot`, `directional`, `constant`,
//!   `envmap` (JPEG/PNG, OpenEXR, Radiance HDR or PFM lat-long images),
//!   `sunsky` (Hosek–Wilkie sky and sun disc, `complex_sun` included).
//!
//! Anything else is an error that names the file, line and column and the
//! unsupported plugin or property; nothing is dropped silently. Meshes are
//! added in document order, one per `<shape>`.

mod bsdf;
mod conductor_presets;
mod error;
mod image_io;
pub mod input;
mod loader;
mod media;
mod mesh_io;
mod pfm;
mod serialized;
mod shapes;
mod sunsky;
mod transform;
mod vol;
mod volume;
mod xml;

use std::path::Path;

pub use error::LoadError;

/// Names accepted by [`builtin_scene`].
pub const BUILTIN_SCENES: &[&str] = &["cornell-box"];

/// The Cornell box of Bitterli's rendering resources (CC0), embedded.
const CORNELL_BOX: &str = include_str!("../scenes/cornell-box.xml");

/// A loaded scene and what the file says about rendering it.
#[derive(Debug)]
pub struct LoadedScene {
    /// The validated scene (meshes in `<shape>` document order).
    pub scene: cmlt::scene::Scene,
    /// Path-tracing settings from the `<integrator>` (Mitsuba's defaults
    /// when the scene has none).
    pub settings: cmlt::integrator::Settings,
    /// Samples per pixel from the sensor's `<sampler>`, if given (Mitsuba
    /// would use 4 otherwise; the caller decides).
    pub spp: Option<u32>,
    /// The Mitsuba integrator type, e.g. `"path"`; unknown types are
    /// recorded, not rejected (the caller chooses the method). `"path"`
    /// when the scene names none, like Mitsuba.
    pub integrator: String,
    /// Things the loader approximated (e.g. a Gaussian reconstruction
    /// filter rendered as a box), each formatted `file:line:col: warning: …`.
    pub warnings: Vec<String>,
}

/// Loads a Mitsuba 3 XML scene file. Mesh and image paths are resolved
/// relative to the file's directory. `defaults` are `(name, value)` pairs
/// that override the scene's `<default>` values.
pub fn load_scene(path: &Path, defaults: &[(String, String)]) -> Result<LoadedScene, LoadError> {
    let name = path.display().to_string();
    let bytes = input::read_bounded(path, input::MAX_SCENE_BYTES, "scene file")
        .map_err(|e| LoadError::whole_file(&name, format!("cannot read scene file: {e}")))?;
    let text = match std::str::from_utf8(&bytes) {
        Ok(t) => t,
        Err(e) => {
            // Report where the text stops being UTF-8.
            let valid = &bytes[..e.valid_up_to()];
            let line = valid.iter().filter(|&&b| b == b'\n').count() as u32 + 1;
            let col_start = valid.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
            let col = std::str::from_utf8(&valid[col_start..])
                .map_or(1, |s| s.chars().count() as u32 + 1);
            return Err(LoadError::at(
                &name,
                line,
                col,
                "the scene file is not UTF-8 text (binary data?)",
            ));
        }
    };
    let base_dir = path.parent().unwrap_or(Path::new("."));
    load_scene_str(text, base_dir, &name, defaults)
}

/// Loads a scene from XML text; relative file names are resolved against
/// `base_dir`, and errors name `name_for_errors` as the file.
pub fn load_scene_str(
    xml: &str,
    base_dir: &Path,
    name_for_errors: &str,
    defaults: &[(String, String)],
) -> Result<LoadedScene, LoadError> {
    loader::load(xml, base_dir, name_for_errors, defaults)
}

/// A scene compiled into the binary, by name (see [`BUILTIN_SCENES`]);
/// `None` for an unknown name. Built-in scenes reference no files;
/// `defaults` override their `<default>` values as for files.
pub fn builtin_scene(
    name: &str,
    defaults: &[(String, String)],
) -> Option<Result<LoadedScene, LoadError>> {
    match name {
        "cornell-box" => Some(load_scene_str(
            CORNELL_BOX,
            Path::new("."),
            "builtin:cornell-box",
            defaults,
        )),
        _ => None,
    }
}
