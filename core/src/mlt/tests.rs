//! Level 1 with its parts stepped by hand on the white furnace (closed
//! box, albedo ½, Le = 1: radiance 2 everywhere): the negative control
//! showing that the furnace tests of `core/tests/suite/mlt.rs` catch a
//! wrong splatting rule. Also home of the scene builders the unit tests
//! below `mlt` share with the integration tests.

use rand_core::Rng;
use rand_pcg::Pcg32;

use super::{Bootstrap, Chain, MltSettings, PrimarySampler, WorkerChains, image_scale, target};
use crate::accel::bvh::Bvh;
use crate::film::Film;
use crate::integrator::{Settings, Tracer, bdpt};
use crate::math::{Rgb, Vec3};
use crate::renderer::Estimator;
use crate::scene::{Material, SceneBuilder};

/// The integration tests' scene builders (`core/tests/common`), compiled
/// here too so that both kinds of test render the same scenes; they name
/// this crate `cmlt` (see `lib.rs`).
#[path = "../../tests/common/mod.rs"]
pub(crate) mod scenes;

/// The furnace's settings: depth 16 (the series 2·(1 − 2⁻¹⁶) is 2 to
/// 3·10⁻⁵) and 64 chains from 8 000 bootstrap samples per depth, b from 64
/// passes.
fn furnace_settings() -> (Settings, MltSettings) {
    let st = Settings {
        max_depth: Some(16),
        ..Settings::default()
    };
    let m = MltSettings {
        n_bootstrap: 8_000,
        b_passes: 64,
        b_min_samples: 0,
        n_chains: 64,
        // Chains in proportion to b_d at every depth: the hand-stepped
        // chains below are unweighted.
        direct_allocation: 1.0,
        ..MltSettings::default()
    };
    (st, m)
}

/// The bootstrap a one-worker renderer of `mlt` at `settings` with seed
/// `seed` computes for the scene's camera.
fn bootstrap(
    scene: &crate::scene::Scene,
    settings: Settings,
    mlt: MltSettings,
    seed: u64,
) -> Bootstrap {
    scenes::render(scene, Estimator::Mlt(mlt), settings, seed, 0).bootstrap
}

/// The furnace rendered by 64 level-1 chains of depth ≤ 16 stepped by
/// hand, recording the proposal (weight a) always and the current state
/// (weight 1 − a) only if `with_current`: the image's mean green.
fn furnace_mean_by_hand(with_current: bool) -> f32 {
    let scene = scenes::furnace_scene(Material::diffuse(Rgb::splat(0.5)), 1.0);
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(&scene, &accel);
    let (st, m) = furnace_settings();
    let boot = bootstrap(&scene, st, m, 21);
    let mut ws = bdpt::PathStorage::new();
    let mut film = Film::new(16, 12);
    let mut mutations = 0u64;
    for c in 0..64u64 {
        let mut rng = Pcg32::new(c, 99);
        let u = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        let depth = boot.chain_depth_at((c as f64 + 0.5) / 64.0).unwrap();
        let index = boot.pick(depth, u).unwrap();
        // Bootstrap sample i has depth 1 + i mod D, D = 16.
        assert_eq!(1 + (index % 16) as u32, depth);
        let mut s = PrimarySampler::new(boot.seed_of(index), m.sigma, m.large_step_prob);
        let init = target::evaluate(&mut tracer, &st, &mut ws, depth, &mut s);
        s.reseed(1000 + c);
        let mut chain = Chain::new(s, init, 2000 + c);
        for _ in 0..(64 * 16 * 12 / 64) {
            let step = chain.step(
                |s| target::evaluate(&mut tracer, &st, &mut ws, depth, s),
                None,
            );
            mutations += 1;
            let records = if with_current {
                [step.proposal, step.current]
            } else {
                [step.proposal, None]
            };
            for sp in records.into_iter().flatten() {
                film.add_splat(sp.raster, sp.value);
            }
        }
    }
    let img = film.resolve_scaled(image_scale(boot.b(), 16 * 12, mutations));
    let mut sum = Rgb::ZERO;
    for p in &img {
        sum += *p;
    }
    (sum / img.len() as f32).g
}

#[test]
fn negative_control_dropping_current_state_splats_is_caught() {
    let right = furnace_mean_by_hand(true);
    let wrong = furnace_mean_by_hand(false);
    eprintln!("by hand: with current {right}, without {wrong}");
    assert!(
        (right - 2.0).abs() / 2.0 < 0.01,
        "correct splatting: {right}"
    );
    // The same 1% check the furnace test applies fails for the bug.
    assert!(
        (wrong - 2.0).abs() / 2.0 > 0.05,
        "dropping the (1 − a) records went unnoticed: {wrong}"
    );
}

#[test]
fn workers_split_the_same_chains_deterministically() {
    // Two workers with different indices run different chains; running a
    // worker in two calls equals running it in one. Together they hold a
    // systematic sample of depths by b_d / b: depth 1 (half of b) gets half
    // of all chains, to within one.
    let scene = scenes::furnace_scene(Material::diffuse(Rgb::splat(0.5)), 1.0);
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(&scene, &accel);
    let (st, m) = furnace_settings();
    let boot = bootstrap(&scene, st, m, 2);
    let mut chains = |worker| {
        let mut c = WorkerChains::with_capacity(&st, &m, None, &scene.camera);
        c.restart(&mut tracer, &st, &m, &boot, 2, worker, 2);
        c
    };
    let (mut one, mut two, mut other) = (chains(0), chains(0), chains(1));
    let (mut f1, mut f2, mut f3) = (Film::new(16, 12), Film::new(16, 12), Film::new(16, 12));
    assert_eq!(one.run(&mut tracer, &st, &mut f1, 10), 640);
    two.run(&mut tracer, &st, &mut f2, 3);
    two.run(&mut tracer, &st, &mut f2, 7);
    other.run(&mut tracer, &st, &mut f3, 10);
    assert_eq!(f1, f2);
    assert_ne!(f1, f3);
    assert_eq!(one.stats(), two.stats());
    let depth1 = one
        .chain_depths()
        .chain(other.chain_depths())
        .filter(|&d| d == 1)
        .count();
    let expected = 128.0 * boot.depth_b()[0] / boot.b();
    assert!(
        (depth1 as f64 - expected).abs() <= 1.0,
        "{depth1} vs {expected}"
    );
}

#[test]
fn a_partial_round_in_strided_order_keeps_the_depths_in_proportion() {
    // The chains are ordered by depth; a round cut short after k of its n
    // mutations steps, per depth d, about k·n_d/n chains in the strided
    // order `advance` uses for time budgets, where chain order would step
    // the shallow depths only. Whole rounds step every chain once either
    // way.
    let scene = scenes::furnace_scene(Material::diffuse(Rgb::splat(0.5)), 1.0);
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(&scene, &accel);
    let (st, m) = furnace_settings();
    let boot = bootstrap(&scene, st, m, 3);
    let mut depths = |strided: bool, k: usize| -> Vec<(u32, usize, usize)> {
        let mut c = WorkerChains::with_capacity(&st, &m, None, &scene.camera);
        c.restart(&mut tracer, &st, &m, &boot, 3, 0, 1);
        let mut film = Film::new(16, 12);
        // A step draws from the chain's accept/reject stream, accepted
        // or not. (Not the chain's Debug text: PCG hides its state there,
        // and a rejected step restores the rest.)
        let before: Vec<_> = c
            .chains
            .iter()
            .map(|(ch, _)| ch.decision_stream().clone())
            .collect();
        assert_eq!(c.advance(&mut tracer, &st, &mut film, k, strided), k as u64);
        // (depth, chains of that depth, chains of it stepped)
        let mut out: Vec<(u32, usize, usize)> = Vec::new();
        for ((chain, d), b) in c.chains.iter().zip(&before) {
            let stepped = (chain.decision_stream() != b) as usize;
            match out.iter_mut().find(|e| e.0 == *d) {
                Some(e) => {
                    e.1 += 1;
                    e.2 += stepped;
                }
                None => out.push((*d, 1, stepped)),
            }
        }
        out
    };
    let n = m.n_chains as usize;
    let k = 24;
    let worst = |v: &[(u32, usize, usize)]| {
        v.iter()
            .map(|&(_, n_d, stepped)| (stepped as f64 - (k * n_d) as f64 / n as f64).abs())
            .fold(0.0, f64::max)
    };
    let (strided, ordered) = (depths(true, k), depths(false, k));
    assert!(strided.len() >= 4, "{strided:?}");
    assert!(worst(&strided) <= 2.0, "strided: {strided:?}");
    assert!(worst(&ordered) > 4.0, "chain order: {ordered:?}");
    assert!(depths(true, n).iter().all(|&(_, n_d, s)| s == n_d));
}

#[test]
fn direct_allocation_moves_chains_off_a_small_bright_emitter() {
    // A lamp seen directly, bright against the image's mean: depth 1 gets
    // fewer chains than its share of b (the systematic sample gives it
    // its share of q to within one chain), and the weights still give it
    // b_1/b of the image. The furnace's walls, seen everywhere and no
    // brighter than the mean, keep their b-proportional chains.
    let mut b = SceneBuilder::new();
    let walls = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    let lamp = b.add_material(Material::diffuse(Rgb::ZERO));
    b.add_mesh(scenes::inward_box(walls, 0.0));
    let mut sphere = scenes::sphere(Vec3::new(0.1, -0.1, 0.4), 0.15, lamp);
    sphere.emission = Some(Rgb::splat(20.0));
    b.add_mesh(sphere);
    b.set_camera(scenes::furnace_camera(Vec3::new(0.1, -0.2, -0.6), 0.0));
    let lamp_scene = b.build().unwrap();
    let furnace = scenes::furnace_scene(Material::diffuse(Rgb::splat(0.5)), 1.0);
    let (st, m) = furnace_settings();
    let m = MltSettings {
        direct_allocation: 0.1,
        ..m
    };
    for (scene, small) in [(&lamp_scene, true), (&furnace, false)] {
        let tris: Vec<_> = scene.triangles().collect();
        let accel = Bvh::build(&tris);
        let mut tracer = Tracer::new(scene, &accel);
        let boot = bootstrap(scene, st, m, 2);
        let mut c = WorkerChains::with_capacity(&st, &m, None, &scene.camera);
        c.restart(&mut tracer, &st, &m, &boot, 2, 0, 1);
        let share_b = boot.depth_b()[0] / boot.b();
        let q1 = boot.chain_share(1);
        if small {
            assert!(
                share_b > 0.3 && q1 < 0.5 * share_b && q1 >= 0.099 * share_b,
                "lamp: b_1/b {share_b}, q_1 {q1}"
            );
        } else {
            assert!((q1 - share_b).abs() < 1e-9, "furnace: {q1} vs {share_b}");
        }
        let depth1 = c.chain_depths().filter(|&d| d == 1).count();
        assert!(
            (depth1 as f64 - 64.0 * q1).abs() <= 1.0,
            "{depth1} chains at depth 1, expected {}",
            64.0 * q1
        );
        let weighted: f64 = c
            .chain_depths()
            .zip(&c.weights)
            .filter(|&(d, _)| d == 1)
            .map(|(_, &w)| w as f64)
            .sum::<f64>()
            / 64.0;
        assert!((weighted - share_b).abs() < 1e-5, "{weighted} vs {share_b}");
    }
}

/// The mirror-sphere furnace (radiance 2 everywhere; lens, caustic,
/// multi-chain and classless paths) rendered by the path-space level 1,
/// `per_pixel` mutations per pixel, with `level2` run from its states when
/// given: the image's mean green, its left and right halves' means, and
/// the counters. With `broken_carry`, classless states' records leave out
/// the level-2 share.
fn path_space_furnace(
    level2: Option<super::Level2Settings>,
    per_pixel: u64,
    broken_carry: bool,
) -> ([f32; 3], super::MltStats) {
    let scene = scenes::mirror_sphere_furnace();
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(&scene, &accel);
    let (st, m) = furnace_settings();
    let m = MltSettings {
        level1: super::Level1::PathSpace,
        ..m
    };
    let boot = bootstrap(&scene, st, m, 5);
    let mut chains = WorkerChains::with_capacity(&st, &m, level2.as_ref(), &scene.camera);
    chains.restart(&mut tracer, &st, &m, &boot, 5, 0, 1);
    if let Some((ps, ..)) = &mut chains.path_space {
        ps.broken_carry = broken_carry;
    }
    let mut film = Film::new(16, 12);
    chains.run(&mut tracer, &st, &mut film, per_pixel * 16 * 12 / 64);
    let stats = *chains.stats();
    let img = film.resolve_scaled(image_scale(boot.b(), 16 * 12, stats.records));
    let (mut all, mut left, mut right) = (0.0, 0.0, 0.0);
    for (i, p) in img.iter().enumerate() {
        all += p.g;
        if i % 16 < 8 {
            left += p.g;
        } else {
            right += p.g;
        }
    }
    ([all / 192.0, left / 96.0, right / 96.0], stats)
}

/// CMLT over the path-space level 1 on the mirror-sphere furnace
/// ([`path_space_furnace`]), side chains of 4 lane steps on every class
/// from depth 1.
fn path_space_cmlt_furnace(broken_carry: bool) -> ([f32; 3], super::MltStats) {
    let l2 = super::Level2Settings {
        m: 4,
        lens_sigma: 1.5,
        side_chain_min_depth: 0,
        ..super::Level2Settings::default()
    };
    path_space_furnace(Some(l2), 96, broken_carry)
}

/// Level 2 runs from path-space level-1 states as from primary-sample
/// ones: the furnace stays 2 (mean within 2 %, halves within 6 %), every
/// perturbation ran, and each mutation counted 1 + s records. Negative
/// control: records of classless states that do not carry the share s
/// (the side chains' weight) darken the image beyond the same check.
#[test]
fn path_space_cmlt_furnace_is_two() {
    let (right, st) = path_space_cmlt_furnace(false);
    eprintln!("path-space CMLT: {right:?}, {st:?}");
    assert!(
        st.lens_steps > 0 && st.caustic_steps > 0 && st.multi_chain_steps > 0,
        "{st:?}"
    );
    assert!(st.lens_accepted > 0 && st.caustic_accepted > 0, "{st:?}");
    assert_eq!(st.records, st.mutations * 5, "1 + m records per mutation");
    assert_eq!(
        st.lens_steps + st.caustic_steps + st.multi_chain_steps + st.identity_steps,
        st.mutations * 4
    );
    assert!((right[0] - 2.0).abs() / 2.0 < 0.02, "mean {right:?}");
    for half in &right[1..] {
        assert!((half - 2.0).abs() / 2.0 < 0.06, "halves {right:?}");
    }
    let (wrong, _) = path_space_cmlt_furnace(true);
    eprintln!("without the carried share: {wrong:?}");
    assert!(
        (wrong[0] - 2.0).abs() / 2.0 > 0.05,
        "the share carried by classless records went unnoticed: {wrong:?}"
    );
}

/// MLT over the path-space level 1 with its level-1 perturbations on the
/// mirror-sphere furnace (radiance 2 everywhere): the image's mean green
/// is 2 within 2 %, its halves within 6 %, and each of the three
/// perturbations moved chains.
#[test]
fn path_space_mlt_furnace_is_two() {
    let (means, stats) = path_space_furnace(None, 512, false);
    eprintln!("path-space MLT: {means:?}, {stats:?}");
    assert!(
        stats.perturbations_accepted.iter().all(|&n| n > 0),
        "{stats:?}"
    );
    assert!((means[0] - 2.0).abs() / 2.0 < 0.02, "mean {means:?}");
    for half in &means[1..] {
        assert!((half - 2.0).abs() / 2.0 < 0.06, "halves {means:?}");
    }
}
