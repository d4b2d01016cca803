//! Conductor `material` presets against Mitsuba 3 itself: the RGB (η, k) a
//! preset loads as, the image a gold mirror renders, and Mitsuba's rule for
//! a preset given together with `eta`/`k` (it refuses both).
//!
//! The reference numbers were printed by Mitsuba 3.9.1 (`pip install
//! mitsuba`, variant `scalar_rgb`): `mi.traverse` of
//! `{"type": "conductor", "material": NAME}` for η and k, and
//! `mi.render` of [`GOLD_MIRROR`] for the image.

use std::path::Path;

use cmlt::accel::bvh::Bvh;
use cmlt::integrator::{Tracer, pt};
use cmlt::math::{Rgb, Vec2};
use cmlt::sampler::SampleStream;
use cmlt::scene::{ConductorFresnel, MaterialKind};
use cmlt_mitsuba::{LoadError, LoadedScene, load_scene_str};

fn load(xml: &str) -> Result<LoadedScene, LoadError> {
    load_scene_str(xml, Path::new("."), "presets.xml", &[])
}

/// A scene of one conductor rectangle whose BSDF is `bsdf` (line 3).
fn one_conductor(bsdf: &str) -> String {
    format!(
        "<scene version=\"3.0.0\">\n  <sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>\n  \
         <shape type=\"rectangle\">{bsdf}</shape>\n</scene>"
    )
}

fn fresnel(l: &LoadedScene) -> ConductorFresnel {
    let s = &l.scene;
    match &s.materials[s.meshes[0].material.0 as usize].kind {
        MaterialKind::Conductor { fresnel, .. } | MaterialKind::RoughConductor { fresnel, .. } => {
            *fresnel
        }
        other => panic!("not a conductor: {other:?}"),
    }
}

fn close(a: Rgb, b: Rgb, tol: f32) -> bool {
    a.to_array()
        .iter()
        .zip(b.to_array())
        .all(|(x, y)| (x - y).abs() <= tol * y.abs().max(1.0))
}

/// η and k as Mitsuba 3.9.1's `scalar_rgb` variant loads them, for
/// `conductor` and `roughconductor` alike.
#[test]
fn presets_load_as_mitsubas_rgb() {
    let mitsuba = [
        (
            "Au",
            Rgb::new(0.14303598, 0.37530708, 1.4420453),
            Rgb::new(3.982997, 2.3855565, 1.6033592),
        ),
        (
            "Ag",
            Rgb::new(0.1552762, 0.116727956, 0.13838764),
            Rgb::new(4.8283544, 3.1222224, 2.1469011),
        ),
        (
            "Cr",
            Rgb::new(4.3696675, 2.9165053, 1.6549046),
            Rgb::new(5.206547, 4.231306, 3.7546988),
        ),
        (
            "d-C",
            Rgb::new(2.7087197, 2.3188257, 2.2288976),
            Rgb::new(0.0, 0.0, 0.0),
        ),
    ];
    for (name, eta_want, k_want) in mitsuba {
        for plugin in ["conductor", "roughconductor"] {
            let xml = one_conductor(&format!(
                r#"<bsdf type="{plugin}"><string name="material" value="{name}"/></bsdf>"#
            ));
            let l = load(&xml).unwrap_or_else(|e| panic!("{name} {plugin}: {e}"));
            let ConductorFresnel::Complex { eta, k } = fresnel(&l) else {
                panic!("{name} {plugin}: {:?}", fresnel(&l));
            };
            assert!(
                close(eta, eta_want, 1e-6) && close(k, k_want, 1e-6),
                "{name} {plugin}: η {eta:?} k {k:?}"
            );
        }
    }
}

/// Mitsuba refuses a preset together with `eta` ("Should specify either
/// (eta, k) or material, not both") and with `k` alone (an unreferenced
/// property); `material="none"` is the default, so `eta`/`k` beside it
/// are used (Mitsuba: η 0.5, k 2 here).
#[test]
fn a_preset_and_explicit_eta_or_k_are_refused_like_mitsuba() {
    for (plugin, extra) in [
        ("conductor", r#"<float name="eta" value="0.5"/>"#),
        ("roughconductor", r#"<rgb name="eta" value="0.5"/>"#),
        ("conductor", r#"<float name="k" value="2"/>"#),
    ] {
        let xml = one_conductor(&format!(
            r#"<bsdf type="{plugin}"><string name="material" value="Au"/>{extra}</bsdf>"#
        ));
        let e = load(&xml).unwrap_err();
        assert_eq!((e.file.as_str(), e.line), ("presets.xml", Some(3)), "{e}");
        assert!(e.message.contains("not both"), "{e}");
    }
    let xml = one_conductor(
        r#"<bsdf type="conductor"><string name="material" value="none"/><float name="eta" value="0.5"/><float name="k" value="2"/></bsdf>"#,
    );
    let l = load(&xml).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        fresnel(&l),
        ConductorFresnel::Complex {
            eta: Rgb::splat(0.5),
            k: Rgb::splat(2.0)
        }
    );
}

/// An unknown preset is an error at its line that lists the known ones.
#[test]
fn an_unknown_preset_is_refused_with_the_known_names() {
    let xml =
        one_conductor(r#"<bsdf type="conductor"><string name="material" value="gold"/></bsdf>"#);
    let e = load(&xml).unwrap_err();
    assert_eq!(e.line, Some(3), "{e}");
    for part in [
        "unknown conductor material preset 'gold'",
        "none, Ag, Al",
        "Au",
        "Cu",
    ] {
        assert!(e.message.contains(part), "{part}: {e}");
    }
}

/// A gold mirror filling a narrow camera under a white constant sky: every
/// camera ray reflects once and escapes, so each pixel is the Fresnel
/// reflectance of gold near normal incidence, noise-free.
const GOLD_MIRROR: &str = r#"<scene version="3.0.0">
  <integrator type="path"/>
  <sensor type="perspective">
    <float name="fov" value="1"/>
    <transform name="to_world"><lookat origin="0, 0, 1" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/><rfilter type="box"/></film>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
  <shape type="rectangle"><bsdf type="conductor"><string name="material" value="Au"/></bsdf></shape>
</scene>"#;

/// [`GOLD_MIRROR`] path-traced through the loaded scene matches Mitsuba
/// 3.9.1's render of the same file, every pixel (0.966679, 0.802010,
/// 0.324121), which is also its `fresnel_conductor` at normal incidence.
#[test]
fn a_gold_mirror_renders_as_in_mitsuba() {
    let l = load(GOLD_MIRROR).unwrap_or_else(|e| panic!("{e}"));
    let s = &l.scene;
    let bvh = Bvh::build(&s.triangles().collect::<Vec<_>>());
    let mut t = Tracer::new(s, &bvh);
    let mitsuba = Rgb::new(0.966_679_3, 0.802_010_2, 0.324_121_45);
    let (w, h) = (s.camera.width(), s.camera.height());
    assert_eq!((w, h), (4, 4));
    for i in 0..w * h {
        let mut rng = SampleStream::new(1, 0, i as u64);
        let raster = Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
        let ray = t.camera_ray(raster, Vec2::ZERO);
        let l = pt::radiance(&mut t, &l.settings, ray, &mut rng);
        assert!(close(l, mitsuba, 1e-4), "pixel {i}: {l:?}");
    }
}
