//! Scene analysis on the shared scenes: the effect set each one calls for,
//! stated from what its XML contains (materials referenced by shapes that
//! exist, emitters, the camera); switching the analysis off changes no
//! image beyond noise; the per-effect work counters count only what the
//! scene has.

use crate::common;

use std::path::Path;

use cmlt::bsdf::Lobe;
use cmlt::integrator::Stats;
use cmlt::math::Rgb;
use cmlt::mlt::{CmltSettings, MltSettings};
use cmlt::renderer::{Estimator, RendererConfig};
use cmlt::scene::{Effect, EffectSet};
use cmlt_cli::mitsuba::{LoadedScene, load_scene};

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
    // Every shared scene is stated below.
    let mut names: Vec<String> = std::fs::read_dir(common::scenes_dir())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("scene.xml").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "caustic-pool",
            "cornell-box",
            "envmap",
            "glossy-room",
            "lights-punctual",
            "media-fog",
            "media-glass",
            "media-milk",
            "plastics",
            "principled",
            "rough-glass",
            "sunsky",
            "sunsky-complex",
            "surface-detail",
            "veach-ajar",
            "veach-bidir",
            "veach-mis",
            "volume-texture"
        ],
        "a shared scene was added: state its effects here"
    );
    // An environment map over diffuse and rough-metal objects.
    assert_eq!(
        effects("envmap"),
        (set(&[Diffuse, Glossy, Environment]), false)
    );
    // The sunsky's baked sky and sun disc over diffuse objects: both are
    // environments, so nothing but diffuse and the environment.
    assert_eq!(effects("sunsky"), (set(&[Diffuse, Environment]), false));
    // The complex sun over a diffuse slope: the same.
    assert_eq!(
        effects("sunsky-complex"),
        (set(&[Diffuse, Environment]), false)
    );
    // Point, spot, sun and sky over diffuse and rough-metal objects.
    assert_eq!(
        effects("lights-punctual"),
        (set(&[Diffuse, Glossy, PointLights, Environment]), false)
    );
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
    // Plastics (smooth and rough), a thin pane and a tinted glass sphere:
    // the glass makes specular chains, the plastics' coating does not (it
    // is not an all-delta BSDF).
    assert_eq!(
        effects("plastics"),
        (set(&[Diffuse, Refraction, AreaLights, Coating]), true)
    );
    // Principled spheres (metal, sheen, clearcoat, transmission): no Dirac
    // lobe, so no specular chains.
    assert_eq!(
        effects("principled"),
        (set(&[Diffuse, AreaLights, Principled]), false)
    );
    // Rough dielectrics on a diffuse floor: no Dirac lobe, so no specular
    // chains.
    assert_eq!(
        effects("rough-glass"),
        (set(&[Diffuse, AreaLights, RoughRefraction]), false)
    );
    // Water over a diffuse floor: refraction, so specular chains.
    assert_eq!(
        effects("caustic-pool"),
        (set(&[Diffuse, Refraction, AreaLights]), true)
    );
    // Rough metals and rough plastics: no Dirac lobe, no specular chains.
    assert_eq!(
        effects("glossy-room"),
        (set(&[Diffuse, Glossy, AreaLights, Coating]), false)
    );
    // Reflectances read from voxel grids (and a constvolume, which is a
    // constant): textures, nothing else.
    assert_eq!(
        effects("volume-texture"),
        (set(&[Diffuse, Textures, AreaLights]), false)
    );
    // Normal and bump maps and an alpha mask, all bitmaps.
    assert_eq!(
        effects("surface-detail"),
        (
            set(&[Diffuse, Textures, AreaLights, NormalMapping, AlphaMasks]),
            false
        )
    );
    // A haze around camera and scene and a fog box, both behind null
    // boundaries, over diffuse surfaces: media, and no Dirac lobe.
    assert_eq!(
        effects("media-fog"),
        (set(&[Diffuse, AreaLights, Media]), false)
    );
    // Absorbing interiors of a glass sphere and a glass cube: media, and
    // refraction, so specular chains.
    assert_eq!(
        effects("media-glass"),
        (set(&[Diffuse, Refraction, AreaLights, Media]), true)
    );
    // Scattering interiors of a smooth glass sphere and a rough glass cube:
    // media, refraction of both kinds, so specular chains.
    assert_eq!(
        effects("media-milk"),
        (
            set(&[Diffuse, Refraction, RoughRefraction, AreaLights, Media]),
            true
        )
    );
    // Bitmap and checkerboard textures; the dielectric's meshes are absent
    // from the snapshot (commented out in the XML), so no refraction.
    assert_eq!(
        effects("veach-ajar"),
        (set(&[Diffuse, Glossy, Textures, AreaLights]), false)
    );
}

fn small(scene: &str, res: u32) -> LoadedScene {
    let path = common::scenes_dir().join(scene).join("scene.xml");
    let d = |k: &str| (k.to_string(), res.to_string());
    load_scene(&path, &[d("resx"), d("resy")]).unwrap()
}

/// Mean colour and counters of a PT/BDPT render, the scene analysis on or
/// off (`all_effects`).
fn render_mean(
    loaded: &LoadedScene,
    all_effects: bool,
    method: Estimator,
    spp: u64,
    seed: u64,
) -> (Rgb, Stats) {
    let config = RendererConfig {
        estimator: method,
        seed,
        workers: 2,
        all_effects,
        ..RendererConfig::default()
    };
    let out = common::render_loaded(loaded, config, spp);
    (mean(&out.image.pixels), out.stats.tracer)
}

/// Mean colour and counters of a CMLT render, the scene analysis on or off.
fn render_mean_cmlt(loaded: &LoadedScene, all_effects: bool, mpp: u64, seed: u64) -> (Rgb, Stats) {
    // b from 16 passes exactly: the default floor of normalisation samples
    // would run up to 1 024 passes over these tiny images, most of the
    // test's time, and b is the same either way (the passes are BDPT,
    // which draws the same random numbers with the analysis on or off).
    let mlt = MltSettings {
        n_bootstrap: 500,
        n_chains: 64,
        b_passes: 16,
        b_min_samples: 0,
        ..MltSettings::default()
    };
    let config = RendererConfig {
        estimator: Estimator::Cmlt(CmltSettings {
            mlt,
            ..CmltSettings::default()
        }),
        seed,
        workers: 2,
        all_effects,
        ..RendererConfig::default()
    };
    let out = common::render_loaded(loaded, config, mpp);
    (mean(&out.image.pixels), out.stats.tracer)
}

fn mean(pixels: &[Rgb]) -> Rgb {
    pixels.iter().fold(Rgb::ZERO, |a, &p| a + p) / pixels.len() as f32
}

fn assert_close(a: Rgb, b: Rgb, tol: f32, what: &str) {
    let (la, lb) = (a.luminance(), b.luminance());
    assert!(la > 0.0, "{what}: black image");
    assert!(
        (la - lb).abs() <= tol * lb,
        "{what}: mean luminance {la} with the analysis, {lb} with --all-effects"
    );
}

#[test]
fn all_effects_changes_no_image_beyond_noise() {
    // PT and BDPT draw the same random numbers either way, so the images
    // agree up to rounding; CMLT's chains take other paths where the
    // analysis skips work (classification), hence a noise tolerance.
    for scene in ["cornell-box", "veach-mis", "veach-bidir"] {
        let loaded = small(scene, 24);
        for method in [Estimator::Path, Estimator::Bdpt] {
            let (on, _) = render_mean(&loaded, false, method, 8, 1);
            let (off, _) = render_mean(&loaded, true, method, 8, 1);
            assert_close(on, off, 1e-4, &format!("{scene} {method:?}"));
        }
        let (on, _) = render_mean_cmlt(&loaded, false, 8, 2);
        let (off, _) = render_mean_cmlt(&loaded, true, 8, 2);
        assert_close(on, off, 0.05, &format!("{scene} CMLT"));
    }
}

#[test]
fn diffuse_scenes_do_no_specular_work() {
    let loaded = small("cornell-box", 16);
    let runs = [
        render_mean(&loaded, false, Estimator::Path, 2, 3).1,
        render_mean(&loaded, false, Estimator::Bdpt, 2, 3).1,
        render_mean_cmlt(&loaded, false, 2, 3).1,
    ];
    for (i, s) in runs.iter().enumerate() {
        for lobe in [Lobe::Glossy, Lobe::SpecularReflection, Lobe::Refraction] {
            assert_eq!(s.bsdf_samples.get(lobe), 0, "run {i}: {lobe:?} samples");
            assert_eq!(s.bsdf_evals.get(lobe), 0, "run {i}: {lobe:?} evaluations");
        }
        assert!(s.bsdf_samples.get(Lobe::Diffuse) > 0, "run {i}");
        assert!(s.bsdf_evals.get(Lobe::Diffuse) > 0, "run {i}");
        // A pinhole: no lens sampled.
        assert_eq!(s.lens_samples, 0, "run {i}");
    }
    // The counters do count the other lobes where the scene has them.
    let glass = small("veach-bidir", 16);
    let s = render_mean(&glass, false, Estimator::Bdpt, 2, 3).1;
    assert!(s.bsdf_samples.get(Lobe::Refraction) > 0);
    assert!(s.bsdf_evals.get(Lobe::Glossy) > 0);
}
