//! Scene analysis on the shared scenes: the effect set each one calls for,
//! stated from what its XML contains (materials referenced by shapes that
//! exist, emitters, the camera).

use std::path::Path;

use cmlt::scene::{Effect, EffectSet};
use cmlt_cli::scene::load_scene;

fn effects(scene: &str) -> (EffectSet, bool) {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../tests/scenes/{scene}/scene.xml"));
    let loaded = load_scene(
        &path,
        &[("resx".into(), "8".into()), ("resy".into(), "8".into())],
    )
    .unwrap();
    let a = loaded.scene.analysis(&loaded.scene.camera);
    (a.effects, a.specular_chains)
}

fn set(effects: &[Effect]) -> EffectSet {
    effects.iter().fold(EffectSet::NONE, |s, &e| s.with(e))
}

#[test]
fn shared_scenes_call_for_what_they_contain() {
    use Effect::*;
    // Diffuse walls and one area light.
    assert_eq!(effects("cornell-box"), (set(&[Diffuse, AreaLights]), false));
    // Rough conductor plates, diffuse floor, spherical area lights.
    assert_eq!(
        effects("veach-mis"),
        (set(&[Diffuse, Glossy, AreaLights]), false)
    );
    // A glass egg: refraction, so specular chains (caustics).
    assert_eq!(
        effects("veach-bidir"),
        (set(&[Diffuse, Glossy, Refraction, AreaLights]), true)
    );
    // Bitmap and checkerboard textures; the dielectric's meshes are absent
    // from the snapshot (commented out in the XML), so no refraction.
    assert_eq!(
        effects("veach-ajar"),
        (set(&[Diffuse, Glossy, Textures, AreaLights]), false)
    );
}
