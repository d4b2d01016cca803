//! The lens perturbation through media on a real scene: its side chain's
//! start value, taken from the level-1 path's own vertices (their medium
//! indices, the transmittance of their segments), against a retrace that
//! finds x′_t at the kept free-flight distance and tracks the media across
//! null boundaries itself.

use glam::Vec3;

use super::media::lens_value;
use super::{Applicable, LensEnd, LensState, LensTarget, classify};
use crate::accel::bvh::Bvh;
use crate::integrator::bdpt::{PathStorage, sample_strategy, strategy_path};
use crate::integrator::{Settings, Tracer};
use crate::math::Rgb;
use crate::mlt::multiple_try::Target;
use crate::mlt::tests::scenes;
use crate::sampler::SampleStream;
use crate::scene::{Material, MaterialKind, Medium, MediumInterface, Phase, Scene, SceneBuilder};

/// The furnace box (walls of albedo ½ emitting ½) in a forward-scattering
/// haze that the camera is in, with a null-bounded ball of a denser
/// isotropic medium and a mirror sphere: paths with medium vertices at
/// either end of the lens connection, through null boundaries, and
/// through the mirror.
fn fog_box() -> Scene {
    let mut b = SceneBuilder::new();
    let wall = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    let boundary = b.add_material(Material {
        kind: MaterialKind::Null,
        two_sided: false,
        detail: Default::default(),
    });
    let mirror = b.add_material(scenes::perfect_mirror(0.9));
    let haze = b.add_medium(
        Medium::homogeneous(
            Rgb::new(0.6, 0.8, 1.0),
            Rgb::splat(0.9),
            1.0,
            Phase::HenyeyGreenstein { g: 0.5 },
        )
        .unwrap(),
    );
    let inner = b.add_medium(
        Medium::homogeneous(
            Rgb::new(1.5, 1.0, 0.8),
            Rgb::new(0.9, 0.8, 0.7),
            1.0,
            Phase::Isotropic,
        )
        .unwrap(),
    );
    let walls = b.add_mesh(scenes::inward_box(wall, 0.5));
    b.set_mesh_media(
        walls,
        MediumInterface {
            interior: Some(haze),
            exterior: Some(haze),
        },
    );
    let ball = b.add_mesh(scenes::sphere(Vec3::new(0.2, 0.0, 0.4), 0.35, boundary));
    b.set_mesh_media(
        ball,
        MediumInterface {
            interior: Some(inner),
            exterior: Some(haze),
        },
    );
    b.add_mesh(scenes::sphere(Vec3::new(-0.5, 0.2, 0.5), 0.3, mirror));
    b.set_camera(scenes::furnace_camera(Vec3::new(0.1, -0.2, -0.6), 0.0));
    b.set_camera_medium(Some(haze));
    b.build().unwrap()
}

/// Level 2 values a lens side chain's start from the level-1 path's
/// vertices (`LensTarget::evaluate_path`: the stored medium vertices, the
/// transmittance of the stored segments, σ_s of the stored medium); every
/// candidate is valued by a retrace (`media::lens_value`: x′_t at the kept
/// distance along the retraced ray, its medium found by crossing the null
/// boundaries). The two must agree on the level-1 path itself, for medium
/// vertices at x_t and at x_{t+1}, through the mirror and through the
/// ball's null boundary; a missing or doubled factor (σ_s, a phase value,
/// a transmittance), a wrong distance or a medium tracked wrongly in
/// either would make them differ. The negative control: the same
/// comparison with the retrace's free-flight distance moved by 10 %
/// disagrees on almost every path with a medium x_t.
#[test]
fn lens_start_through_media_equals_its_retrace() {
    let scene = fog_box();
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(&scene, &accel);
    let s = Settings {
        max_depth: Some(8),
        ..Settings::default()
    };
    let mut ws = PathStorage::with_capacity(8);
    let mut path = Vec::new();
    let (mut compared, mut agree, mut control_agree) = (0u32, 0u32, 0u32);
    let (mut medium_t, mut medium_next, mut mirror, mut inner) = (0u32, 0u32, 0u32, 0u32);
    for i in 0..20_000u64 {
        let depth = 1 + (i % 4) as usize;
        let mut rng = SampleStream::new(5, depth as u64, i);
        let st = sample_strategy(&mut tracer, &s, &mut ws, depth, &mut rng);
        if st.l.is_black() || !strategy_path(&ws, &mut path) {
            continue;
        }
        let Applicable::Lens(mut anchor) = classify(&tracer, &path) else {
            continue;
        };
        if !anchor.complete_media(&mut tracer, &path) {
            continue;
        }
        let media = anchor.media.expect("a scene with media");
        let camera = tracer.camera;
        let Some((_, raster)) =
            camera.importance(anchor.p_lens, (path[1].sp.p - anchor.p_lens).normalize())
        else {
            continue;
        };
        let mut target = LensTarget {
            tracer: &mut tracer,
            anchor: &anchor,
        };
        let stored = target
            .evaluate_path(&path, raster)
            .expect("the path fits its own anchor")
            .value;
        let mut one = [Some(LensState {
            raster,
            value: Rgb::ZERO,
        })];
        let mut p = [0.0f32];
        target.evaluate(&mut one, &mut p);
        let traced = one[0].unwrap().value;
        let t = anchor.chain.len() + 1;
        compared += 1;
        mirror += (t > 1) as u32;
        if path[t].is_medium() {
            medium_t += 1;
            inner += (path[t].sp.prim == 1) as u32;
            let mut moved = media;
            moved.scatter_at = moved.scatter_at.map(|s| 1.1 * s);
            let control = lens_value(&mut tracer, &anchor, &moved, raster);
            control_agree += close(stored, control) as u32;
        }
        if let LensEnd::Connect { next, .. } = &anchor.end {
            medium_next += next.is_medium() as u32;
        }
        if close(stored, traced) {
            agree += 1;
        } else if compared - agree <= 5 {
            eprintln!("sample {i}: stored {stored:?} vs retraced {traced:?}");
        }
    }
    eprintln!(
        "{agree} of {compared} agree ({medium_t} with a medium x_t, {inner} of them in the ball, \
         {medium_next} with a medium x_t+1, {mirror} through the mirror); \
         control: {control_agree} of {medium_t}"
    );
    assert!(
        compared > 5_000 && medium_t > 1_000 && medium_next > 1_000 && mirror > 100 && inner > 100,
        "{compared} {medium_t} {medium_next} {mirror} {inner}"
    );
    // Retracing may land on another triangle or miss at an edge (rounding);
    // anything else is a wrong factor in one of the two.
    assert!(
        agree as f64 >= 0.999 * compared as f64,
        "{agree} of {compared}"
    );
    assert!(
        (control_agree as f64) < 0.05 * medium_t as f64,
        "{control_agree} of {medium_t}"
    );
}

/// Every channel within 10⁻³ of the larger luminance, which is positive.
fn close(a: Rgb, b: Rgb) -> bool {
    let scale = a.luminance().max(b.luminance());
    scale > 0.0 && (0..3).all(|c| (a[c] - b[c]).abs() <= 1e-3 * scale)
}
