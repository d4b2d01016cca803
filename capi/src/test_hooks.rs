//! What this crate's own integration tests (`tests/api`) reach inside the
//! library: a bug injected while a call holds an object's lock, the core
//! configuration a C configuration becomes, and a C material's core form.
//!
//! Compiled only with the `test-hooks` feature, which the crate's
//! dev-dependency on itself turns on for `cargo test` (the tests are an
//! integration test so that the library is compiled once for them, the C
//! examples and the other tests, not a second time as a unit-test crate).
//! A host's build never has the feature.

use cmlt_core::integrator::Settings;
use cmlt_core::renderer::RendererConfig;
use cmlt_core::scene::{Material, Texture};

use crate::renderer::cmlt_renderer_config;
use crate::scene::cmlt_scene;

/// The next call on this thread that holds an object's lock panics there,
/// as a bug would (the library's `bug_hook`).
pub fn panic_once() {
    crate::error::PANIC_ONCE.set(true);
}

/// The integrator settings of committed scene `scene`.
///
/// # Safety
/// `scene` is a scene handle from `cmlt_scene_new`, not released.
pub unsafe fn scene_settings(scene: *const cmlt_scene) -> Result<Settings, String> {
    // SAFETY: the caller's promise.
    let committed = unsafe { &*scene }
        .committed()
        .map_err(|e| e.message.into_owned())?;
    Ok(committed.settings)
}

/// The core configuration `c` becomes for committed scene `scene`.
///
/// # Safety
/// `scene` is a scene handle from `cmlt_scene_new`, not released.
pub unsafe fn core_config(
    c: &cmlt_renderer_config,
    scene: *const cmlt_scene,
) -> Result<RendererConfig, String> {
    // SAFETY: the caller's promise.
    let committed = unsafe { &*scene }
        .committed()
        .map_err(|e| e.message.into_owned())?;
    crate::renderer::core_config(c, &committed).map_err(|e| e.message.into_owned())
}

/// The core material C material `m` becomes, its texture indices resolved
/// through `textures`.
pub fn material_from_c(
    m: &crate::scene::cmlt_material,
    textures: &[Texture],
) -> Result<Material, String> {
    crate::scene::material_from_c(m, textures).map_err(|e| e.message.into_owned())
}
