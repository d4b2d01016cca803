//! The path-space level 1 on lights that are not meshes: a box lit by a
//! point light and a spot, and an open scene under an environment map and
//! a directional light. Per scene: the path measure against every BDPT
//! strategy; the bidirectional mutation's T as the density of its
//! proposals; the chain's depth shares against b_d from BDPT's strategies
//! (with the lens subpath mutation; the perturbations leave such paths
//! alone). Each with a negative control: T without the emitter vertex's
//! density.

use glam::{Mat3, Vec3};

use super::super::PrimarySampler;
use super::bidirectional::Broken;
use super::chain::{Mutations, PathChain};
use super::tests::{check_strategies, mutation_estimate, start_path};
use crate::accel::bvh::Bvh;
use crate::integrator::bdpt::{self, PathEnd, PathVertex};
use crate::integrator::{Settings, Tracer};
use crate::math::Rgb;
use crate::mlt::PathMutations;
use crate::mlt::tests::scenes;
use crate::scene::texture::Bitmap;
use crate::scene::{Light, Material, Mesh, Scene, SceneBuilder};

/// The diffuse box of the furnace tests, emitting nothing, with the
/// mirror sphere of `mirror_sphere_furnace`, lit by a point light and a
/// spot of a quarter of its power (chosen a fifth of the time: T's
/// selection probabilities differ between paths ending on the two),
/// whose cone misses the mirror (no caustic of it, which only light
/// tracing samples: the tests' estimates stay well resolved).
fn point_lit_box() -> Scene {
    let mut b = SceneBuilder::new();
    let wall = b.add_material(Material::diffuse(Rgb::new(0.5, 0.4, 0.3)));
    let mirror = b.add_material(scenes::perfect_mirror(0.5));
    b.add_mesh(scenes::inward_box(wall, 0.0));
    b.add_mesh(scenes::sphere(Vec3::new(0.2, 0.1, 0.3), 0.45, mirror));
    b.add_light(Light::Point {
        position: Vec3::new(-0.5, 0.6, 0.1),
        intensity: Rgb::new(2.0, 1.5, 1.0),
    });
    b.add_light(Light::spot(
        Vec3::new(0.6, -0.6, -0.3),
        Vec3::new(0.2, 1.0, 0.3),
        Rgb::splat(13.0),
    ));
    b.set_camera(scenes::furnace_camera(Vec3::new(0.1, -0.2, -0.6), 0.0));
    b.build().unwrap()
}

/// A diffuse floor and wall, a diffuse ball and a mirror ball under an environment
/// map (brighter towards +y, with a bright patch: its sampling is not
/// uniform) and a directional light, seen by the furnace tests' camera.
fn environment_lit() -> Scene {
    let mut b = SceneBuilder::new();
    let grey = b.add_material(Material::diffuse(Rgb::new(0.6, 0.5, 0.4)));
    let mirror = b.add_material(scenes::perfect_mirror(0.7));
    let texels = (0..8 * 4)
        .map(|i| {
            let (x, y) = (i % 8, i / 8);
            let patch = if (x, y) == (2, 1) { 8.0 } else { 0.0 };
            Rgb::new(0.4, 0.5, 0.6) * (1.0 + (3 - y) as f32) + Rgb::splat(patch)
        })
        .collect();
    let bitmap = b.add_bitmap(Bitmap::new(8, 4, texels).unwrap());
    b.add_light(Light::Envmap {
        bitmap,
        scale: 1.0,
        to_world: Mat3::IDENTITY,
    });
    b.add_light(Light::Directional {
        direction: Vec3::new(0.3, -1.0, 0.4),
        irradiance: Rgb::splat(20.0),
    });
    b.add_mesh(Mesh {
        positions: [(-1.6, -1.0), (1.6, -1.0), (1.6, 2.2), (-1.6, 2.2)]
            .map(|(x, z)| Vec3::new(x, -0.5, z))
            .to_vec(),
        normals: Vec::new(),
        uvs: Vec::new(),
        indices: vec![[0, 2, 1], [0, 3, 2]],
        material: grey,
        emission: None,
    });
    // Low walls behind and beside the balls, for paths of several
    // bounces; the sky shows above them.
    let walls: [[Vec3; 4]; 3] = [
        [(-1.6, 2.2), (1.6, 2.2), (1.6, 2.2), (-1.6, 2.2)],
        [(-1.6, -1.0), (-1.6, 2.2), (-1.6, 2.2), (-1.6, -1.0)],
        [(1.6, 2.2), (1.6, -1.0), (1.6, -1.0), (1.6, 2.2)],
    ]
    .map(|c| {
        let ys = [-0.5, -0.5, 1.0, 1.0];
        core::array::from_fn(|i| Vec3::new(c[i].0, ys[i], c[i].1))
    });
    for positions in walls {
        b.add_mesh(Mesh {
            positions: positions.to_vec(),
            normals: Vec::new(),
            uvs: Vec::new(),
            indices: vec![[0, 1, 2], [0, 2, 3]],
            material: grey,
            emission: None,
        });
    }
    b.add_mesh(scenes::sphere(Vec3::new(-0.3, -0.1, 1.2), 0.4, grey));
    b.add_mesh(scenes::sphere(Vec3::new(0.45, 0.0, 1.5), 0.35, mirror));
    b.set_camera(scenes::furnace_camera(Vec3::new(0.0, 0.1, -0.4), 0.0));
    b.build().unwrap()
}

/// How many of 2 000 BDPT sample paths of depths 1–3 end on each kind of
/// light: [area, point, directional, environment].
fn ends(scene: &Scene) -> [u32; 4] {
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(scene, &accel);
    let mut ws = bdpt::PathStorage::new();
    let mut path = Vec::new();
    let mut n = [0; 4];
    for seed in 0..2000u64 {
        let mut s = PrimarySampler::new(seed, 0.01, 0.3);
        let depth = 1 + (seed % 3) as usize;
        let r = bdpt::sample_strategy(&mut tracer, &Settings::default(), &mut ws, depth, &mut s);
        if r.l.is_black() || !bdpt::strategy_path(&ws, &mut path) {
            continue;
        }
        n[match PathEnd::of(scene, path.last().unwrap()) {
            PathEnd::Area => 0,
            PathEnd::Point(_) => 1,
            PathEnd::Directional(_) => 2,
            PathEnd::Environment => 3,
        }] += 1;
    }
    n
}

#[test]
fn strategy_estimates_are_contribution_over_density_on_other_lights() {
    let point = point_lit_box();
    let env = environment_lit();
    let (n_point, n_env) = (ends(&point), ends(&env));
    eprintln!("ends [area, point, directional, environment]: {n_point:?}, {n_env:?}");
    assert!(n_point[1] > 100 && n_point[0] + n_point[2] + n_point[3] == 0);
    assert!(n_env[2] > 40 && n_env[3] > 200 && n_env[0] + n_env[1] == 0);
    // Point lights: no strategy s = 0; the environment has every
    // strategy, but the open scene's paths of three segments are few, and
    // light tracing from it reaches the image seldom.
    let [specular, ..] = check_strategies(&point, false, [20, 5]);
    assert!(specular >= 50, "{specular} paths through the mirror");
    let [specular, ..] = check_strategies(&env, true, [5, 0]);
    assert!(specular >= 20, "{specular} paths through the mirror");
}

/// The class of a path of `scene` by its emitter: 0 for the first of
/// the lights that are not meshes or the environment, 1 for the second.
fn light_class(scene: &Scene, end: &PathVertex) -> usize {
    match PathEnd::of(scene, end) {
        PathEnd::Point(1) | PathEnd::Directional(1) => 1,
        _ => 0,
    }
}

/// b_d of `scene` for depths 1–4, split by [`light_class`] (bin
/// 2(d − 1) + class), from `n` primary-sample evaluations per depth, with
/// their standard errors.
fn depth_bs(scene: &Scene, n: u64) -> ([f64; 8], [f64; 8]) {
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(scene, &accel);
    let mut ws = bdpt::PathStorage::new();
    let mut path = Vec::new();
    let (mut sum, mut sum2) = ([0.0f64; 8], [0.0f64; 8]);
    for d in 0..4 {
        for i in 0..n {
            let mut s = PrimarySampler::new(0xB000 + i, 0.01, 0.3);
            let r =
                bdpt::sample_strategy(&mut tracer, &Settings::default(), &mut ws, d + 1, &mut s);
            if r.l.is_black() || !bdpt::strategy_path(&ws, &mut path) {
                continue;
            }
            let y = r.l.luminance() as f64;
            let bin = 2 * d + light_class(scene, path.last().unwrap());
            sum[bin] += y;
            sum2[bin] += y * y;
        }
    }
    let nf = n as f64;
    let b = sum.map(|s| s / nf);
    let e = core::array::from_fn(|i| ((sum2[i] / nf - b[i] * b[i]) / (nf - 1.0)).sqrt());
    (b, e)
}

#[test]
fn bidirectional_density_is_the_proposal_density_on_other_lights() {
    for (name, scene) in [
        ("point", point_lit_box()),
        ("environment", environment_lit()),
    ] {
        let (bins, errors) = depth_bs(&scene, 400_000);
        let b = |d: usize| bins[2 * d - 2] + bins[2 * d - 1];
        let be = |d: usize| errors[2 * d - 2].hypot(errors[2 * d - 1]);
        for depth in [1, 2, 3] {
            if b(depth) == 0.0 {
                continue;
            }
            let (est, se) = mutation_estimate(&scene, depth, 400_000, None);
            eprintln!(
                "{name}, depth {depth}: b_d {:.5} ± {:.5}, from the mutation's density {est:.5} ± {se:.5}",
                b(depth),
                be(depth)
            );
            // T resolved to several percent (point lights make the
            // estimate heavy-tailed), and within 4 standard errors.
            assert!(se < 0.08 * b(depth), "{name}, depth {depth}: ± {se}");
            assert!(
                (est - b(depth)).abs() < 4.0 * se.hypot(be(depth)),
                "{name}, depth {depth}: {est} vs b_d {}",
                b(depth)
            );
        }
        // Negative control: T without the emitter vertex's density.
        let (wrong, _) = mutation_estimate(&scene, 2, 100_000, Some(Broken::NoEmitterDensity));
        assert!(
            (wrong / b(2) - 1.0).abs() > 0.2,
            "{name}: the emitter's density went unnoticed: {wrong} vs {}",
            b(2)
        );
    }
}

/// Each bin's share (depth 1–4 × [`light_class`], as [`depth_bs`]) of
/// the records' luminance from `chains` path-space chains of `steps`
/// mutations (after 500 of burn-in) with paths of up to 4 segments,
/// started on BDPT samples of depths `first_depth` … 4 in turn, with the
/// spread of the chains' own shares (standard errors).
fn chain_shares(
    scene: &Scene,
    broken: Option<Broken>,
    first_depth: usize,
    chains: u64,
    steps: u32,
) -> ([f64; 8], [f64; 8]) {
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(scene, &accel);
    let camera = tracer.camera;
    let mut mutations = Mutations::new(
        &PathMutations::default(),
        4,
        camera.width(),
        camera.height(),
        camera.pixel_angle(),
    );
    mutations.bidirectional.broken = broken;
    let starts = 5 - first_depth as u64;
    let (mut sum, mut sum2) = ([0.0f64; 8], [0.0f64; 8]);
    for c in 0..chains {
        let depth = first_depth + (c % starts) as usize;
        let mut chain = PathChain::with_capacity(4);
        *chain.current_mut() = start_path(&mut tracer, depth, 1000 * c);
        chain.start(0xE0 + c);
        let mut bins = [0.0f64; 8];
        for i in 0..steps + 500 {
            let from = 2 * (chain.current().depth() - 1)
                + light_class(scene, chain.current().path.last().unwrap());
            let st = chain.step(&mut tracer, &mut mutations);
            if i < 500 {
                continue;
            }
            if let Some(sp) = st.proposal {
                // The proposal is the current path when accepted, the
                // other one when not.
                let y = if st.accepted {
                    chain.current()
                } else {
                    chain.other()
                };
                let bin = 2 * (y.depth() - 1) + light_class(scene, y.path.last().unwrap());
                bins[bin] += sp.value.luminance() as f64 / steps as f64;
            }
            if let Some(sp) = st.current {
                bins[from] += sp.value.luminance() as f64 / steps as f64;
            }
        }
        for (i, &v) in bins.iter().enumerate() {
            sum[i] += v;
            sum2[i] += v * v;
        }
    }
    let n = chains as f64;
    let shares = sum.map(|s| s / n);
    let errors =
        core::array::from_fn(|i| ((sum2[i] / n - shares[i] * shares[i]) / (n - 1.0)).sqrt());
    (shares, errors)
}

#[test]
fn chain_samples_paths_in_proportion_to_their_contribution_on_other_lights() {
    for (name, scene, first) in [
        ("point", point_lit_box(), 2),
        ("environment", environment_lit(), 1),
    ] {
        let (b, be) = depth_bs(&scene, 200_000);
        let total: f64 = b.iter().sum();
        let (shares, errors) = chain_shares(&scene, None, first, 64, 10_000);
        for i in 0..8 {
            let want = b[i] / total;
            let sigma = errors[i].hypot(be[i] / total);
            eprintln!(
                "{name}, depth {}, light {}: share {:.4} ± {:.4}, b/Σb {want:.4} ± {:.4}",
                i / 2 + 1,
                i % 2,
                shares[i],
                errors[i],
                be[i] / total
            );
            assert!(
                (shares[i] - want).abs() < 4.0 * sigma + 0.003,
                "{name}, depth {}, light {}: {} vs {want}",
                i / 2 + 1,
                i % 2,
                shares[i]
            );
        }
        // Negative control: T without the emitter vertex's density.
        let (wrong, _) = chain_shares(&scene, Some(Broken::NoEmitterDensity), first, 64, 10_000);
        let off = (0..8)
            .map(|i| (wrong[i] - b[i] / total).abs())
            .fold(0.0, f64::max);
        assert!(
            off > 0.03,
            "{name}: the emitter's density went unnoticed: {wrong:?}"
        );
    }
}
