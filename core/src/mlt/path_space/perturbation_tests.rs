//! The level-1 perturbations: detailed balance per pair of paths, with T
//! from the path's BDPT densities rather than from level 2's targets, and
//! the chain's stationary distribution on the mirror furnace with the
//! perturbations on.

use super::bidirectional::Proposal;
use super::chain::Mutations;
use super::perturbations::coordinates;
use super::selection::Mutation;
use super::state::PathState;
use super::tests::{furnace_chains, start_path};
use crate::accel::bvh::Bvh;
use crate::integrator::Tracer;
use crate::integrator::bdpt::{PathVertex, path_densities};
use crate::mlt::PathMutations;
use crate::mlt::perturbation::Applicable;
use crate::mlt::tests::scenes;
use crate::sampler::SampleStream;
use crate::scene::{Camera, Scene};

/// |∂u/∂A| of path `y` for the perturbation of `class`, up to factors of
/// the fixed vertices: the density in the moving vertices' area measure
/// of a unit density in the perturbation's coordinates u, from
/// [`path_densities`] (a specular vertex's symbolic density is its lobe's
/// selection probability, 1 at the mirror furnace's mirrors: the solid-angle
/// density 1 of a perturbation, which keeps the lobes). Lens: the camera side's
/// ∏_{i=1}^{t} fwd[i] (a uniform raster position's area density at x₁,
/// then the specular vertices'), times the image area. Caustic: the
/// direction leaving x_j carried to x₁, ∏_{i=1}^{j−1} |n_i·ω|/d². Multi-
/// chain: the lens part to x_t, then ω leaving x_t carried to x_u.
fn jacobian(scene: &Scene, camera: &Camera, y: &[PathVertex], class: &Applicable) -> f64 {
    let n = y.len();
    let (mut fwd, mut rev) = (vec![0.0f32; n], vec![0.0f32; n]);
    path_densities(scene, camera, y, &mut fwd, &mut rev);
    let image_area = (camera.width() * camera.height()) as f64;
    let camera_side =
        |t: usize| -> f64 { fwd[1..=t].iter().map(|&v| v as f64).product::<f64>() * image_area };
    // Solid angle at a to area at b (geometric normals, as the densities),
    // or to volume at a medium vertex b (no cosine there).
    let carried = |a: &PathVertex, b: &PathVertex| {
        let w = b.sp.p - a.sp.p;
        let d2 = w.length_squared();
        let cos = if b.is_medium() {
            1.0
        } else {
            b.sp.ng.dot(w).abs() / d2.sqrt()
        };
        (cos / d2) as f64
    };
    match class {
        Applicable::Lens(a) => camera_side(a.chain.len() + 1),
        Applicable::Caustic(a) => {
            let j = a.chain.len() + 2;
            (1..j).map(|i| carried(&y[i + 1], &y[i])).product()
        }
        Applicable::MultiChain(a) => {
            let t = a.first.len() + 1;
            let u = t + a.second.len() + 1;
            camera_side(t)
                * (t + 1..=u)
                    .map(|i| carried(&y[i - 1], &y[i]))
                    .product::<f64>()
        }
        Applicable::Neither => unreachable!(),
    }
}

/// Pairs (x̄, ȳ) of perturbation moves on the mirror furnace, each
/// checked for detailed balance Y(f(x̄))·T(x̄→ȳ)·a(x̄→ȳ) =
/// Y(f(ȳ))·T(ȳ→x̄)·a(ȳ→x̄), with the acceptances the chain computes
/// (`a` from level 2's targets) and T = q·|∂u/∂A| ([`jacobian`], q
/// symmetric). Returns, per perturbation, the pairs checked and those
/// off by more than 1 %.
fn balance(scene: &Scene, broken: bool, want: u32) -> [(u32, u32); 3] {
    balance_counting(scene, broken, want).0
}

/// [`balance`], with the number of pairs whose proposal has a medium
/// vertex among the ones the perturbation moved.
fn balance_counting(scene: &Scene, broken: bool, want: u32) -> ([(u32, u32); 3], u32) {
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(scene, &accel);
    let camera = tracer.camera;
    let mut m = Mutations::new(
        &PathMutations::default(),
        8,
        camera.width(),
        camera.height(),
        camera.pixel_angle(),
    );
    m.perturbations.broken = broken;
    let mut y = PathState::with_capacity(8);
    let mut back = PathState::with_capacity(8);
    let mut out = [(0u32, 0u32); 3];
    let mut worst = [0.0f64; 3];
    let mut through_media = 0;
    // Start paths of depths 1–6 until every perturbation has enough
    // pairs (caustic and multi-chain paths are rare on the furnace).
    for first in 0..60_000u64 {
        if out.iter().all(|&(n, _)| n >= want) {
            break;
        }
        let depth = 1 + (first % 6) as usize;
        let x = start_path(&mut tracer, depth, first * 97);
        let class = m.class(&mut tracer, &x.path);
        let Some(kind) = Mutation::perturbation(&class) else {
            continue;
        };
        let slot = kind as usize - Mutation::Lens as usize;
        if out[slot].0 >= want {
            continue;
        }
        for i in 0..8u64 {
            let mut rng = SampleStream::new(first, i, 5);
            let Proposal::Made { ratio: r_xy } =
                m.perturbations
                    .propose(&mut tracer, &x, &class, &mut y, &mut rng)
            else {
                continue;
            };
            let y_class = m.class(&mut tracer, &y.path);
            assert_eq!(Mutation::perturbation(&y_class), Some(kind));
            let to_x = coordinates(&x, &class).unwrap();
            let Proposal::Made { ratio: r_yx } =
                m.perturbations
                    .propose_to(&mut tracer, &y, &y_class, &to_x, &mut back)
            else {
                continue;
            };
            let (fx, fy) = (x.target() as f64, y.target() as f64);
            let a_xy = (fy * r_xy as f64 / fx).min(1.0);
            let a_yx = (fx * r_yx as f64 / fy).min(1.0);
            let lhs = fx * jacobian(scene, &camera, &y.path, &y_class) * a_xy;
            let rhs = fy * jacobian(scene, &camera, &x.path, &class) * a_yx;
            let off = (lhs - rhs).abs() / lhs.max(rhs);
            out[slot].0 += 1;
            out[slot].1 += (off > 0.01) as u32;
            let moved = match &class {
                Applicable::Lens(a) => 1..a.chain.len() + 2,
                Applicable::Caustic(a) => 1..a.chain.len() + 2,
                Applicable::MultiChain(a) => 1..a.first.len() + a.second.len() + 3,
                Applicable::Neither => 0..0,
            };
            through_media += y.path[moved].iter().any(|v| v.is_medium()) as u32;
            worst[slot] = worst[slot].max(off);
        }
    }
    eprintln!(
        "broken {broken}: pairs (checked, off) {out:?}, worst {worst:?}, {through_media} moving a medium vertex"
    );
    (out, through_media)
}

#[test]
fn perturbations_keep_detailed_balance() {
    let scene = scenes::mirror_sphere_furnace();
    for (kind, (checked, off)) in ["lens", "caustic", "multi-chain"]
        .iter()
        .zip(balance(&scene, false, 200))
    {
        assert!(checked >= 200, "{kind}: only {checked} pairs");
        assert!(
            off * 100 <= checked,
            "{kind}: {off} of {checked} pairs out of balance"
        );
    }
    // Negative control: the ratio without the Jacobians (T taken as
    // symmetric in the area measure) is out of balance.
    for (kind, (checked, off)) in ["lens", "caustic", "multi-chain"]
        .iter()
        .zip(balance(&scene, true, 200))
    {
        assert!(
            off * 4 > checked,
            "{kind}: a T without Jacobians went unnoticed ({off} of {checked})"
        );
    }
}

#[test]
fn chain_with_perturbations_samples_paths_in_proportion_to_their_contribution() {
    // Each depth's share of ∫Y(f), b_d / b, and every pixel alike,
    // whichever mutations move the chain. On the grey furnace every path
    // is the lens perturbation's; on the mirror furnace all three
    // perturbations run.
    let grey = scenes::furnace_scene(
        crate::scene::Material::diffuse(crate::math::Rgb::splat(0.5)),
        1.0,
    );
    let mirror = scenes::mirror_sphere_furnace();
    for (name, scene) in [("grey", &grey), ("mirror", &mirror)] {
        furnace_chains(scene, &PathMutations::default(), None, 64, 20_000).check_furnace(name);
    }
}

#[test]
fn mutation_weights_are_checked() {
    let ok = PathMutations::default();
    assert_eq!(ok.validate(), Ok(()));
    let bad = [
        PathMutations {
            bidirectional: 0.0,
            ..ok
        },
        PathMutations {
            caustic: -1.0,
            ..ok
        },
        PathMutations {
            lens_subpath: f32::NAN,
            ..ok
        },
        PathMutations { sigma: 0.0, ..ok },
        PathMutations {
            caustic_scale: f32::INFINITY,
            ..ok
        },
    ];
    for p in bad {
        assert!(p.validate().is_err(), "{p:?} accepted");
        let mlt = crate::mlt::MltSettings {
            path_mutations: p,
            ..Default::default()
        };
        assert!(mlt.validate().is_err(), "{p:?} accepted by MltSettings");
    }
}

/// [`perturbations_keep_detailed_balance`] through media, on `fog_box`
/// (a haze around everything, a null-bounded ball of another medium, a
/// mirror): the perturbations retrace their rays through the haze and the
/// ball's boundary and keep a moving medium vertex's free-flight distance
/// (`perturbation/media.rs`), so T in the path measure has, for such a
/// vertex, the volume element s² of its fixed distance along the new
/// direction (`jacobian`: no cosine there). Pairs with the perturbation's
/// own ratio must balance against T from the path's densities.
#[cfg(all(feature = "media", feature = "specular"))]
#[test]
fn perturbations_keep_detailed_balance_through_media() {
    let scene = crate::mlt::perturbation::media_tests::fog_box();
    let (got, through_media) = balance_counting(&scene, false, 200);
    for (kind, (checked, off)) in ["lens", "caustic", "multi-chain"].iter().zip(got) {
        assert!(
            off * 100 <= checked,
            "{kind}: {off} of {checked} pairs out of balance"
        );
    }
    assert!(
        got[0].0 >= 200 && got[1].0 >= 200 && got[2].0 >= 50,
        "{got:?}"
    );
    assert!(
        through_media >= 100,
        "{through_media} pairs moved a medium vertex"
    );
    for (kind, (checked, off)) in ["lens", "caustic"].iter().zip(balance(&scene, true, 200)) {
        assert!(
            off * 4 > checked,
            "{kind}: a T without Jacobians went unnoticed ({off} of {checked})"
        );
    }
}

/// The chain with every mutation through media: on `fog_box` path-space
/// chains with the perturbations as well spread their records over the
/// depths as b_d ([`super::tests::depth_shares`]).
#[cfg(all(feature = "media", feature = "specular"))]
#[test]
fn chain_with_perturbations_through_media_samples_depths_in_proportion() {
    let scene = crate::mlt::perturbation::media_tests::fog_box();
    let want = super::tests::depth_shares(&scene);
    let got = furnace_chains(&scene, &PathMutations::default(), None, 32, 5_000);
    eprintln!(
        "fog box, every mutation: depth shares {:?} ± {:?}, from b_d {want:?}",
        got.depths, got.errors
    );
    assert!(super::tests::shares_agree(&got, &want));
}
