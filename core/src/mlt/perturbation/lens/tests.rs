//! The lens perturbation on a real scene: its side chain's start value,
//! taken from the level-1 path's vertices, against a retrace.

use super::*;
use crate::accel::bvh::Bvh;
use crate::integrator::Settings;
use crate::integrator::bdpt::{PathStorage, sample_strategy, strategy_path};
use crate::mlt::perturbation::{Applicable, classify};
use crate::mlt::tests::scenes;
use crate::sampler::SampleStream;

/// Level 2 takes its side chain's start value from the level-1 path's
/// stored vertices (`LensTarget::evaluate_path`) instead of retracing it.
/// That value must be the lens target's, the one every candidate gets:
/// compared with a retrace of the same raster position, on paths with and
/// without specular chains (the mirror sphere) and on both lens ends
/// (emitter hit, connection).
#[test]
fn lens_start_from_stored_path_equals_its_retrace() {
    let scene = scenes::mirror_sphere_furnace();
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(&scene, &accel);
    let s = Settings {
        max_depth: Some(16),
        ..Settings::default()
    };
    let mut ws = PathStorage::with_capacity(8);
    let mut path = Vec::new();
    let (mut compared, mut through_mirror, mut agree) = (0u32, 0u32, 0u32);
    for i in 0..20_000u64 {
        let depth = 1 + (i % 5) as usize;
        let mut rng = SampleStream::new(3, depth as u64, i);
        let st = sample_strategy(&mut tracer, &s, &mut ws, depth, &mut rng);
        if st.l.is_black() || !strategy_path(&ws, &mut path) {
            continue;
        }
        let Applicable::Lens(anchor) = classify(&tracer, &path) else {
            continue;
        };
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
            .expect("the path fits its own anchor");
        let mut one = [Some(LensState {
            raster,
            value: Rgb::ZERO,
        })];
        let mut p = [0.0f32];
        target.evaluate(&mut one, &mut p);
        let traced = one[0].unwrap().value;
        compared += 1;
        through_mirror += (anchor.chain.len() > 0) as u32;
        let scale = stored.value.luminance().max(traced.luminance());
        let close = (0..3).all(|c| (stored.value[c] - traced[c]).abs() <= 1e-3 * scale);
        if close && scale > 0.0 {
            agree += 1;
        } else if compared - agree <= 5 {
            eprintln!(
                "sample {i}: stored {:?} vs retraced {traced:?}",
                stored.value
            );
        }
    }
    eprintln!("{agree} of {compared} agree ({through_mirror} through the mirror)");
    assert!(
        compared > 5_000 && through_mirror > 200,
        "{compared} {through_mirror}"
    );
    // Retracing may land on another triangle or miss at an edge (rounding);
    // anything else is a wrong factor in one of the two.
    assert!(
        agree as f64 >= 0.999 * compared as f64,
        "{agree} of {compared}"
    );
}
