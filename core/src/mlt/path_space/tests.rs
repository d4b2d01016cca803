//! The path measure against BDPT: for paths BDPT's strategies sample, each
//! strategy's unweighted estimate is f(x̄)/p_{s,t}(x̄) (times the strategy
//! count of `sample_strategy`), with f and p computed from the path's
//! vertices alone.

use super::super::PrimarySampler;
use super::super::tests::scenes;
use crate::accel::bvh::Bvh;
use crate::integrator::bdpt::{self, path_contribution, path_densities, strategy_density};
use crate::integrator::{Settings, Tracer};
use crate::math::Rgb;
use crate::scene::{Material, Scene};

/// Checks every strategy of depths 1–4 on paths sampled in `scene`;
/// returns how many paths through a specular vertex were checked.
fn check_strategies(scene: &Scene) -> u32 {
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(&scene, &accel);
    let settings = Settings::default();
    let mut ws = bdpt::PathStorage::new();
    // Every strategy unweighted (MIS weight 1).
    ws.set_strategy_filter(Some(|_, _| true));
    let mut path = Vec::new();
    let (mut fwd, mut rev) = ([0.0f32; 8], [0.0f32; 8]);
    // Checked paths per (depth, t).
    let mut checked = [[0u32; 6]; 5];
    let mut specular = 0;
    for depth in 1..=4usize {
        for seed in 0..1000u64 {
            let mut s = PrimarySampler::new(seed * 7 + depth as u64, 0.01, 0.3);
            let r = bdpt::sample_strategy(&mut tracer, &settings, &mut ws, depth, &mut s);
            if r.l.is_black() {
                continue;
            }
            assert!(bdpt::strategy_path(&ws, &mut path));
            assert_eq!(path.len(), depth + 1);
            let camera = tracer.camera;
            let (f, raster) = path_contribution(scene, &camera, &path).unwrap();
            path_densities(scene, &camera, &path, &mut fwd, &mut rev);
            specular += path.iter().any(|v| v.is_specular()) as u32;
            let t = r.t as usize;
            let p = strategy_density(&fwd, &rev, t);
            let n = bdpt::strategy_count(depth) as f32;
            let expect = f * (n / p);
            for (got, want) in [(r.l.r, expect.r), (r.l.g, expect.g), (r.l.b, expect.b)] {
                assert!(
                    (got - want).abs() <= 2e-3 * want.abs(),
                    "depth {depth}, (s, t) = ({}, {t}), seed {seed}: BDPT {:?}, f/p {:?}",
                    r.s,
                    r.l,
                    expect
                );
            }
            assert!(
                (raster - r.raster).length() < 1e-2,
                "raster {raster} vs {}",
                r.raster
            );
            checked[depth][t] += 1;
        }
    }
    // Every strategy of every depth was checked on several paths ((1, 1)
    // is not a strategy).
    for depth in 1..=4usize {
        for t in 1..=depth + 1 {
            if depth == 1 && t == 1 {
                continue;
            }
            // Light tracing (t = 1) reaches the small image seldom.
            let least = if t == 1 { 5 } else { 20 };
            assert!(
                checked[depth][t] >= least,
                "depth {depth}, t {t}: {} paths",
                checked[depth][t]
            );
        }
    }
    specular
}

#[test]
fn strategy_estimates_are_contribution_over_density() {
    let diffuse = scenes::furnace_scene(Material::diffuse(Rgb::new(0.5, 0.4, 0.3)), 1.0);
    check_strategies(&diffuse);
    // An emitting mirror sphere: specular vertices, symbolic in f and p.
    let specular = check_strategies(&scenes::mirror_sphere_furnace());
    assert!(specular >= 50, "{specular} paths through the mirror");
}
