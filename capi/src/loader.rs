//! Scene files and built-in scenes through the Mitsuba 3 loader, crate
//! `cmlt-mitsuba`, for `cmlt_scene_load_file` and `cmlt_scene_new_builtin`
//! ([`crate::scene`] checks their arguments and commits what is loaded).
//!
//! Only with the `loader` feature: the loader brings XML, mesh and image
//! decoders that an engine handing over its own arrays does not need.
//! Without it both functions exist all the same (the header and the ABI do
//! not depend on the feature) and [`file()`] and [`builtin()`] refuse with
//! `CMLT_ERROR_UNSUPPORTED`.

use cmlt_core::integrator::Settings;
use cmlt_core::scene::Scene;

use crate::error::{Error, Result, cmlt_status};

/// A loaded scene (its camera included) and the integrator settings its
/// file asks for.
pub(crate) struct Loaded {
    pub scene: Scene,
    pub settings: Settings,
}

/// The Mitsuba 3 XML scene file at `path`; unreadable or unsupported files
/// are `CMLT_ERROR_IO`.
#[cfg(feature = "loader")]
pub(crate) fn file(path: &str) -> Result<Loaded> {
    ::cmlt_mitsuba::load_scene(std::path::Path::new(path), &[])
        .map(Loaded::from)
        .map_err(|e| Error::new(cmlt_status::CMLT_ERROR_IO, e.to_string()))
}

/// The built-in scene `name` at `width × height` pixels; an unknown name is
/// an invalid argument.
#[cfg(feature = "loader")]
pub(crate) fn builtin(name: &str, width: u32, height: u32) -> Result<Loaded> {
    let defines = [
        ("resx".to_string(), width.to_string()),
        ("resy".to_string(), height.to_string()),
    ];
    ::cmlt_mitsuba::builtin_scene(name, &defines)
        .ok_or_else(|| {
            Error::invalid(format!(
                "no built-in scene named {name:?} (try \"cornell-box\")"
            ))
        })?
        .map(Loaded::from)
        .map_err(|e| Error::new(cmlt_status::CMLT_ERROR_INTERNAL, e.to_string()))
}

#[cfg(feature = "loader")]
impl From<::cmlt_mitsuba::LoadedScene> for Loaded {
    fn from(l: ::cmlt_mitsuba::LoadedScene) -> Self {
        Loaded {
            scene: l.scene,
            settings: l.settings,
        }
    }
}

/// Refused: this build has no loader.
#[cfg(not(feature = "loader"))]
pub(crate) fn file(_path: &str) -> Result<Loaded> {
    Err(not_built())
}

/// Refused: this build has no loader.
#[cfg(not(feature = "loader"))]
pub(crate) fn builtin(_name: &str, _width: u32, _height: u32) -> Result<Loaded> {
    Err(not_built())
}

#[cfg(not(feature = "loader"))]
fn not_built() -> Error {
    Error::new(
        cmlt_status::CMLT_ERROR_UNSUPPORTED,
        "this build of cmlt has no scene loader (cargo feature `loader`)",
    )
}
