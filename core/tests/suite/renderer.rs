//! The host's frame loop (`cmlt::renderer`): renders continue across
//! calls bit for bit, workers merge, the bootstrap is the same for every
//! split over workers, camera changes reset the accumulation, misuse is
//! refused without side effects, and — counted through a global
//! allocator — `set_camera`, preparing, `render` and `resolve` allocate
//! nothing.

use crate::common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use cmlt::accel::bvh::Bvh;
use cmlt::integrator::Settings;
use cmlt::math::{Mat4, Rgb, Vec3};
use cmlt::mlt::{Bootstrap, CmltSettings, Level2Settings, MltSettings};
use cmlt::renderer::{
    Accumulation, Estimator, EstimatorKind, PIECE, PixelBlock, RenderError, RenderWorker, Renderer,
    RendererConfig, Temporal,
};
use cmlt::scene::{
    Camera, ConductorFresnel, FovAxis, Material, MaterialKind, Mesh, Scene, SceneBuilder, Texture,
};

/// Counts allocations made by the current thread while counting is on
/// (other test threads allocate freely).
struct CountingAlloc;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static COUNT: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: forwards every call unchanged to `System`; the counters are
// const-initialised thread-locals without destructors, so touching them
// never allocates or re-enters the allocator.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        // SAFETY: same contract as our caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System` through `alloc`/`realloc`.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_allocation();
        // SAFETY: same contract as our caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

fn note_allocation() {
    if COUNTING.with(|c| c.get()) {
        COUNT.with(|c| c.set(c.get() + 1));
    }
}

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

/// Allocations `f` makes on this thread.
pub(crate) fn allocations<R>(f: impl FnOnce() -> R) -> (R, u64) {
    COUNT.with(|c| c.set(0));
    COUNTING.with(|c| c.set(true));
    let r = f();
    COUNTING.with(|c| c.set(false));
    (r, COUNT.with(|c| c.get()))
}

/// A closed diffuse room lit by a small ceiling quad, with a mirror sphere
/// (caustics: level 2's caustic perturbation applies) seen by a 16×12
/// pinhole camera.
pub(crate) fn room() -> Scene {
    room_with_sphere(Material {
        kind: MaterialKind::Conductor {
            fresnel: ConductorFresnel::Perfect,
            specular_reflectance: Texture::Constant(Rgb::splat(0.9)),
        },
        two_sided: false,
        detail: Default::default(),
    })
}

/// [`room`] with its sphere made of `sphere`.
pub(crate) fn room_with_sphere(sphere: Material) -> Scene {
    let mut b = SceneBuilder::new();
    let wall = b.add_material(Material::diffuse(Rgb::new(0.6, 0.5, 0.4)));
    let sphere = b.add_material(sphere);
    b.add_mesh(common::inward_box(wall, 0.0));
    b.add_mesh(common::sphere(Vec3::new(0.2, 0.3, 0.3), 0.4, sphere));
    let y = -0.98;
    b.add_mesh(Mesh {
        positions: vec![
            Vec3::new(-0.3, y, -0.3),
            Vec3::new(0.3, y, -0.3),
            Vec3::new(0.3, y, 0.3),
            Vec3::new(-0.3, y, 0.3),
        ],
        normals: vec![],
        uvs: vec![],
        // Facing +y, into the room.
        indices: vec![[0, 2, 1], [0, 3, 2]],
        material: wall,
        emission: Some(Rgb::splat(12.0)),
    });
    b.set_camera(camera(0.0));
    b.build().unwrap()
}

/// The room's camera, turned by `yaw` radians about the vertical axis.
fn camera(yaw: f32) -> Camera {
    Camera::perspective(
        Mat4::from_rotation_y(yaw) * Mat4::from_translation(Vec3::new(0.0, 0.0, -0.8)),
        70.0,
        FovAxis::X,
        16,
        12,
        0.0,
        1.0,
    )
    .unwrap()
}

fn settings() -> Settings {
    Settings {
        max_depth: Some(6),
        ..Settings::default()
    }
}

fn mlt_settings() -> MltSettings {
    MltSettings {
        n_bootstrap: 500,
        b_passes: 2,
        b_min_samples: 0,
        n_chains: 24,
        ..MltSettings::default()
    }
}

/// MLT with [`mlt_settings`].
fn mlt() -> Estimator {
    Estimator::Mlt(mlt_settings())
}

/// CMLT with [`mlt_settings`] and `k` candidates, side chains of `m`
/// steps on every path (no minimum depth) with a 2-pixel lens σ.
fn cmlt(k: u32, m: u32) -> Estimator {
    Estimator::Cmlt(CmltSettings {
        mlt: mlt_settings(),
        level2: Level2Settings {
            k,
            m,
            lens_sigma: 2.0,
            side_chain_min_depth: 0,
            ..Level2Settings::default()
        },
    })
}

fn config(estimator: Estimator, workers: u32) -> RendererConfig {
    RendererConfig {
        estimator,
        settings: settings(),
        seed: 7,
        workers,
        ..RendererConfig::default()
    }
}

/// Readies `r` for its frame with `workers` on this thread.
fn prepare(r: &mut Renderer, workers: &mut [RenderWorker], scene: &Scene, bvh: &Bvh) {
    common::prepare(r, workers, scene, bvh);
}

/// The renderer's image of `workers`.
fn resolve(r: &Renderer, workers: &[&RenderWorker]) -> Vec<Rgb> {
    let mut img = vec![Rgb::ZERO; 16 * 12];
    r.resolve(workers, |i, c| img[i] = c).unwrap();
    img
}

fn mean(img: &[Rgb]) -> f64 {
    img.iter().map(|c| c.luminance() as f64).sum::<f64>() / img.len() as f64
}

/// A render in two calls equals one call with the whole budget, bit for
/// bit: accumulation continues across calls (each estimator's samples
/// depend only on the seed, the pass or chain, and the step count).
#[test]
fn renders_continue_across_calls() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    for estimator in [Estimator::Path, Estimator::Bdpt, mlt(), cmlt(8, 2)] {
        let kind = estimator.kind();
        let mut r = Renderer::new(config(estimator, 1), scene.camera).unwrap();
        let mut w = RenderWorker::new(&r, 0).unwrap();
        prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
        let budget = 16 * 12 * 3;
        let a = r.render(&mut w, &scene, &bvh, budget).unwrap();
        let b = r.render(&mut w, &scene, &bvh, budget).unwrap();
        assert!(a >= budget && b >= budget, "{kind:?}: {a} {b}");
        let img = resolve(&r, &[&w]);

        let mut once = Renderer::new(config(estimator, 1), scene.camera).unwrap();
        let mut ow = RenderWorker::new(&once, 0).unwrap();
        prepare(&mut once, std::slice::from_mut(&mut ow), &scene, &bvh);
        assert_eq!(once.render(&mut ow, &scene, &bvh, a + b).unwrap(), a + b);
        assert!(mean(&img) > 0.0, "{kind:?} rendered black");
        assert_eq!(img, resolve(&once, &[&ow]), "{kind:?}");
        let stats = r.stats(&[&w]);
        assert_eq!(stats, once.stats(&[&ow]), "{kind:?}");
        assert_eq!(stats.nonfinite, 0);
        if kind.is_metropolis() {
            assert_eq!(stats.mlt.mutations, a + b);
            assert!(stats.b > 0.0);
            if kind == EstimatorKind::Cmlt {
                assert!(stats.mlt.caustic_steps + stats.mlt.lens_steps > 0);
                assert!(stats.tracer.packets > 0);
            }
        } else {
            assert_eq!(stats.passes, 6);
        }
    }
}

#[test]
fn workers_merge_into_one_image_of_the_same_mean() {
    // Two workers render disjoint passes / chains; their merged image
    // estimates the same picture as one worker with the same total budget.
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    for estimator in [Estimator::Bdpt, cmlt(2, 1)] {
        let kind = estimator.kind();
        let mut one = Renderer::new(config(estimator, 1), scene.camera).unwrap();
        let mut w = RenderWorker::new(&one, 0).unwrap();
        prepare(&mut one, std::slice::from_mut(&mut w), &scene, &bvh);
        let budget = 16 * 12 * 64;
        one.render(&mut w, &scene, &bvh, 2 * budget).unwrap();
        let single = mean(&resolve(&one, &[&w]));

        let mut two = Renderer::new(config(estimator, 2), scene.camera).unwrap();
        let mut ws = [
            RenderWorker::new(&two, 0).unwrap(),
            RenderWorker::new(&two, 1).unwrap(),
        ];
        prepare(&mut two, &mut ws, &scene, &bvh);
        let [w0, w1] = &mut ws;
        std::thread::scope(|s| {
            let (two, scene, bvh) = (&two, &scene, &bvh);
            let h = s.spawn(move || two.render(w1, scene, bvh, budget));
            two.render(w0, scene, bvh, budget).unwrap();
            h.join().unwrap().unwrap();
        });
        let [w0, w1] = &ws;
        let merged = resolve(&two, &[w0, w1]);
        let only0 = mean(&resolve(&two, &[w0]));
        let m = mean(&merged);
        eprintln!("{kind:?}: one worker {single}, two {m}, worker 0 alone {only0}");
        assert!(merged.iter().all(|c| c.is_finite()));
        assert!((m / single - 1.0).abs() < 0.05, "{kind:?}: {m} vs {single}");
        // Worker 0 alone is itself an estimate of the image.
        assert!(
            (only0 / single - 1.0).abs() < 0.1,
            "{kind:?}: {only0} vs {single}"
        );
        assert_ne!(merged, resolve(&two, &[w0]), "worker 1 added nothing");
    }
}

#[test]
fn camera_change_resets_accumulation_and_matches_a_fresh_renderer() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    for estimator in [Estimator::Bdpt, cmlt(2, 1)] {
        // The same random sequences every frame: frame 1 then equals a
        // fresh renderer's frame 0 through the same camera.
        let cfg = RendererConfig {
            temporal: Temporal {
                fixed_sequence: true,
                ..Temporal::default()
            },
            ..config(estimator, 1)
        };
        let mut r = Renderer::new(cfg, scene.camera).unwrap();
        let mut w = RenderWorker::new(&r, 0).unwrap();
        prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
        r.render(&mut w, &scene, &bvh, 16 * 12 * 4).unwrap();
        r.set_camera(camera(0.4)).unwrap();
        assert_eq!(
            r.render(&mut w, &scene, &bvh, 1),
            Err(RenderError::NotPrepared)
        );
        // Until the worker renders again it contributes nothing.
        assert!(resolve(&r, &[&w]).iter().all(|c| *c == Rgb::ZERO));
        prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
        r.render(&mut w, &scene, &bvh, 16 * 12 * 4).unwrap();
        let moved = resolve(&r, &[&w]);

        let mut fresh = Renderer::new(cfg, camera(0.4)).unwrap();
        let mut fw = RenderWorker::new(&fresh, 0).unwrap();
        prepare(&mut fresh, std::slice::from_mut(&mut fw), &scene, &bvh);
        fresh.render(&mut fw, &scene, &bvh, 16 * 12 * 4).unwrap();
        assert_eq!(moved, resolve(&fresh, &[&fw]), "{:?}", estimator.kind());
    }
}

#[test]
fn misuse_is_refused() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cfg = config(cmlt(2, 1), 2);
    let mut r = Renderer::new(cfg, scene.camera).unwrap();
    assert_eq!(RenderWorker::new(&r, 2).err(), Some(RenderError::Worker));
    let mut ws = [
        RenderWorker::new(&r, 0).unwrap(),
        RenderWorker::new(&r, 1).unwrap(),
    ];
    let w = &mut ws[0];
    assert_eq!(r.render(w, &scene, &bvh, 10), Err(RenderError::NotPrepared));
    let wide = Camera::perspective(Mat4::IDENTITY, 60.0, FovAxis::X, 17, 12, 0.0, 1.0).unwrap();
    assert_eq!(r.set_camera(wide), Err(RenderError::Resolution));
    assert_eq!(r.camera().width(), 16);
    let other = Renderer::new(cfg, scene.camera).unwrap();
    let mut foreign = RenderWorker::new(&other, 0).unwrap();
    prepare(&mut r, &mut ws, &scene, &bvh);
    assert_eq!(
        r.render(&mut foreign, &scene, &bvh, 10),
        Err(RenderError::Worker)
    );
    assert_eq!(r.resolve(&[&foreign], |_, _| {}), Err(RenderError::Worker));
    let Estimator::Cmlt(c) = cfg.estimator else {
        unreachable!()
    };
    let with = |level2| Estimator::Cmlt(CmltSettings { level2, ..c });
    for bad in [
        RendererConfig { workers: 0, ..cfg },
        RendererConfig {
            estimator: with(Level2Settings { k: 0, ..c.level2 }),
            ..cfg
        },
        RendererConfig {
            estimator: with(Level2Settings {
                lens_sigma: f32::NAN,
                ..c.level2
            }),
            ..cfg
        },
        RendererConfig {
            estimator: Estimator::Mlt(MltSettings {
                n_chains: 0,
                ..c.mlt
            }),
            ..cfg
        },
    ] {
        assert!(matches!(
            Renderer::new(bad, scene.camera),
            Err(RenderError::Config(_))
        ));
    }
}

#[test]
fn frames_allocate_nothing_after_setup() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    for estimator in [Estimator::Path, Estimator::Bdpt, mlt(), cmlt(8, 4)] {
        let cfg = RendererConfig {
            // Unbounded depth: the renderer caps it so storage is bounded.
            settings: Settings::default(),
            ..config(estimator, 1)
        };
        let mut r = Renderer::new(cfg, scene.camera).unwrap();
        let mut w = RenderWorker::new(&r, 0).unwrap();
        let mut img = vec![Rgb::ZERO; 16 * 12];
        let (_, n) = allocations(|| {
            for frame in 0..3 {
                // Every accumulation mode, frames ending inside passes
                // or rounds.
                let mode = [
                    Accumulation::Reset,
                    Accumulation::Keep,
                    Accumulation::Decay(0.5),
                ][frame];
                r.set_accumulation(mode).unwrap();
                // Full resolution, a host's block size, the fitted one.
                r.set_pixel_block(
                    [PixelBlock::Fixed(1), PixelBlock::Fixed(3), PixelBlock::Fit][frame],
                )
                .unwrap();
                r.set_camera(camera(0.1 * frame as f32)).unwrap();
                if r.begin_prepare(&scene) {
                    let mut asked = 0;
                    while !r
                        .prepare_worker_while(&mut w, &scene, &bvh, &mut |_| {
                            asked += 1;
                            asked % 7 != 0
                        })
                        .unwrap()
                    {}
                    r.finish_prepare([&w]).unwrap();
                }
                r.render(&mut w, &scene, &bvh, 16 * 12 * 4).unwrap();
                r.render(&mut w, &scene, &bvh, 16 * 12 * 4).unwrap();
                let mut n = 0;
                r.render_while(&mut w, &scene, &bvh, 1 << 40, &mut |_| {
                    n += 1;
                    n < 5
                })
                .unwrap();
                r.resolve(&[&w], |i, c| img[i] = c).unwrap();
            }
        });
        assert_eq!(n, 0, "{estimator:?}: {n} allocations");
        assert!(mean(&img) > 0.0);
        // The counter does count: a fresh worker allocates.
        let (_, n) = allocations(|| RenderWorker::new(&r, 0).unwrap());
        assert!(n > 0);
    }
}

/// Renders `frames` frames of `cfg` with the camera yawing by `step` per
/// frame, `workers` workers on as many threads; returns each frame's image.
fn frame_sequence(scene: &Scene, cfg: RendererConfig, frames: usize, step: f32) -> Vec<Vec<Rgb>> {
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let mut r = Renderer::new(cfg, camera(0.0)).unwrap();
    let mut ws: Vec<RenderWorker> = (0..cfg.workers)
        .map(|i| RenderWorker::new(&r, i).unwrap())
        .collect();
    let mut out = Vec::new();
    for f in 0..frames {
        r.set_camera(camera(step * f as f32)).unwrap();
        prepare(&mut r, &mut ws, scene, &bvh);
        std::thread::scope(|s| {
            for w in ws.iter_mut() {
                let (r, bvh) = (&r, &bvh);
                s.spawn(move || r.render(w, scene, bvh, 16 * 12 * 8).unwrap());
            }
        });
        let refs: Vec<&RenderWorker> = ws.iter().collect();
        out.push(resolve(&r, &refs));
        assert_eq!(r.stats(&refs).nonfinite, 0);
    }
    out
}

#[test]
fn frames_replay_bit_identically_with_any_worker_count() {
    let scene = room();
    for workers in [1, 3] {
        for temporal in [
            Temporal::default(),
            Temporal {
                keep_chains: true,
                b_window: 8,
                fixed_sequence: false,
                ..Temporal::default()
            },
        ] {
            let cfg = RendererConfig {
                temporal,
                ..config(cmlt(2, 1), workers)
            };
            let a = frame_sequence(&scene, cfg, 3, 0.05);
            let b = frame_sequence(&scene, cfg, 3, 0.05);
            assert_eq!(a, b, "{workers} workers, {temporal:?}");
            assert_ne!(a[1], a[2], "frames do not differ");
        }
    }
}

#[test]
fn temporal_switches_keep_moving_frames_right_and_steady_frames_steady() {
    let scene = room();
    let base = config(cmlt(2, 1), 1);
    // Moving camera: kept, re-evaluated chains give each frame the mean of
    // independent frames (same cameras) within noise.
    let independent = frame_sequence(&scene, base, 4, 0.08);
    let kept = frame_sequence(
        &scene,
        RendererConfig {
            temporal: Temporal {
                keep_chains: true,
                ..Temporal::default()
            },
            ..base
        },
        4,
        0.08,
    );
    for (f, (a, b)) in independent.iter().zip(&kept).enumerate().skip(1) {
        let (ma, mb) = (mean(a), mean(b));
        assert!(
            (mb / ma - 1.0).abs() < 0.05,
            "frame {f}: kept {mb} vs independent {ma}"
        );
    }
    // Static camera: the same random sequences make identical frames.
    let fixed = frame_sequence(
        &scene,
        RendererConfig {
            temporal: Temporal {
                fixed_sequence: true,
                ..Temporal::default()
            },
            ..base
        },
        3,
        0.0,
    );
    assert_eq!(fixed[1], fixed[2]);
    // Static camera: averaging b over frames makes the frame means vary
    // less than with each frame's own b.
    let spread = |frames: &[Vec<Rgb>]| {
        let m: Vec<f64> = frames.iter().map(|f| mean(f)).collect();
        let avg = m.iter().sum::<f64>() / m.len() as f64;
        (m.iter().map(|x| (x - avg).powi(2)).sum::<f64>() / m.len() as f64).sqrt() / avg
    };
    let own = frame_sequence(&scene, base, 12, 0.0);
    let windowed = frame_sequence(
        &scene,
        RendererConfig {
            temporal: Temporal {
                b_window: 16,
                ..Temporal::default()
            },
            ..base
        },
        12,
        0.0,
    );
    let (s_own, s_win) = (spread(&own[1..]), spread(&windowed[4..]));
    eprintln!("frame-mean spread: own b {s_own:.4}, windowed b {s_win:.4}");
    assert!(s_win < s_own, "windowed {s_win} vs own {s_own}");
}

/// `render_while` asks before every piece — [`PIECE`] camera samples (PT,
/// BDPT) or level-1 mutations (MLT, CMLT; a piece ends with its round) —
/// and stops at the first no: the units done are exactly the pieces the
/// clock allowed, none more. A frame that stopped inside a pass or round
/// goes on from there, and the finished pass or rounds are the ones
/// `render` renders at once — bit for bit with PT, and up to the order the
/// splats were added in otherwise (the pieces visit pixels and chains in
/// a strided order; every sample and every chain's mutations are the
/// same).
#[test]
fn render_while_stops_when_the_host_clock_says_so() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    for estimator in [Estimator::Path, Estimator::Bdpt, mlt(), cmlt(2, 1)] {
        let kind = estimator.kind();
        let cfg = config(estimator, 1);
        let mut r = Renderer::new(cfg, scene.camera).unwrap();
        let mut w = RenderWorker::new(&r, 0).unwrap();
        prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
        // The pieces' sizes: 16 each, and for 24 chains a round's end
        // cuts every second one to 8.
        let sizes: [u64; 4] = if kind.is_metropolis() {
            [16, 8, 16, 8]
        } else {
            [PIECE; 4]
        };
        let mut at = 0;
        for allowed in [1, 3] {
            // A "clock" that says yes `allowed − 1` times: `allowed` pieces.
            let mut asked = 0;
            let done = r
                .render_while(&mut w, &scene, &bvh, 1 << 40, &mut |_| {
                    asked += 1;
                    asked < allowed
                })
                .unwrap();
            let want: u64 = sizes[at..at + allowed].iter().sum();
            at += allowed;
            assert_eq!(done, want, "{kind:?}");
            assert_eq!(asked, allowed, "{kind:?}: asked {asked} times");
        }
        let mut r2 = Renderer::new(cfg, scene.camera).unwrap();
        let mut w2 = RenderWorker::new(&r2, 0).unwrap();
        prepare(&mut r2, std::slice::from_mut(&mut w2), &scene, &bvh);
        if kind.is_metropolis() {
            // Two whole rounds of the 24 chains.
            r2.render(&mut w2, &scene, &bvh, 48).unwrap();
        } else {
            // The rest of the open pass, then one whole pass at once.
            assert_eq!(
                r.render_steps(&mut w, &scene, &bvh, 1).unwrap(),
                16 * 12 - 4 * PIECE
            );
            r2.render(&mut w2, &scene, &bvh, 16 * 12).unwrap();
        }
        let (a, b) = (resolve(&r, &[&w]), resolve(&r2, &[&w2]));
        let refs = [&w];
        assert_eq!(r.stats(&refs).mlt.mutations, r2.stats(&[&w2]).mlt.mutations);
        if kind == EstimatorKind::Path {
            assert_eq!(a, b, "{kind:?}");
        } else {
            for (x, y) in a.iter().zip(&b) {
                let (x, y) = (x.luminance(), y.luminance());
                assert!(
                    (x - y).abs() <= 1e-5 * y.abs().max(1e-3),
                    "{kind:?}: {x} vs {y}"
                );
            }
            assert_ne!(mean(&a), 0.0);
        }
    }
}

/// MLT frames that end inside a round are normalised by the mutations
/// they made: frames of one and a half rounds have the image mean of
/// whole rounds, b (that the partial round's depths stay in proportion is
/// `mlt::tests`' `a_partial_round_in_strided_order_keeps_the_depths_in_proportion`).
#[test]
fn frames_ending_inside_a_round_keep_the_depths_in_proportion() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let estimator = Estimator::Mlt(MltSettings {
        n_chains: 96,
        ..mlt_settings()
    });
    let cfg = config(estimator, 1);
    let mut r = Renderer::new(cfg, scene.camera).unwrap();
    let mut w = RenderWorker::new(&r, 0).unwrap();
    prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
    let (mut sum, frames) = (0.0, 40);
    for f in 0..frames {
        if f > 0 {
            r.set_camera(scene.camera).unwrap();
            prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
        }
        // One and a half rounds: 9 pieces of 16 of the 96 chains.
        let mut n = 0;
        let done = r
            .render_while(&mut w, &scene, &bvh, 1 << 40, &mut |_| {
                n += 1;
                n < 9
            })
            .unwrap();
        assert_eq!(done, 144);
        sum += mean(&resolve(&r, &[&w])) / r.b();
    }
    let ratio = sum / frames as f64;
    assert!((ratio - 1.0).abs() < 0.03, "mean / b = {ratio}");
}

/// A frame that ends inside a pass shows each pixel with its own samples:
/// with PT, after two whole passes and five pieces of a third, the pixels
/// the pieces reached have the three-pass values and the others the
/// two-pass ones, exactly — and the pieces' pixels are spread over the
/// image (the strided order), not a band of rows.
#[test]
fn a_frame_ending_inside_a_pass_normalises_each_pixel_by_its_samples() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cfg = config(Estimator::Path, 1);
    let whole = {
        let mut r = Renderer::new(cfg, scene.camera).unwrap();
        let mut w = RenderWorker::new(&r, 0).unwrap();
        prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
        r.render(&mut w, &scene, &bvh, 3 * 16 * 12).unwrap();
        (resolve(&r, &[&w]), r)
    };
    let mut r = Renderer::new(cfg, scene.camera).unwrap();
    let mut w = RenderWorker::new(&r, 0).unwrap();
    prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
    // Two whole passes, then 5 pieces of the third.
    r.render(&mut w, &scene, &bvh, 2 * 16 * 12).unwrap();
    let mut n = 0;
    r.render_while(&mut w, &scene, &bvh, 1 << 40, &mut |_| {
        n += 1;
        n < 5
    })
    .unwrap();
    let partial = resolve(&r, &[&w]);
    let two = {
        let mut r = Renderer::new(cfg, scene.camera).unwrap();
        let mut w = RenderWorker::new(&r, 0).unwrap();
        prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
        r.render(&mut w, &scene, &bvh, 2 * 16 * 12).unwrap();
        resolve(&r, &[&w])
    };
    let stride = r.stride() as usize;
    let reached: Vec<usize> = (0..5 * PIECE as usize)
        .map(|k| k * stride % (16 * 12))
        .collect();
    for i in 0..16 * 12 {
        let want = if reached.contains(&i) {
            whole.0[i]
        } else {
            two[i]
        };
        assert_eq!(partial[i], want, "pixel {i}");
    }
    let mut rows: Vec<usize> = reached.iter().map(|i| i / 16).collect();
    rows.sort_unstable();
    rows.dedup();
    assert_eq!(rows.len(), 12, "rows reached: {rows:?}");
    drop(whole.1);
}

/// PT and BDPT accumulation across frames. With the same random sequence
/// every frame and a still camera: kept frames equal one frame of all
/// their passes, bit for bit; decayed frames weigh the older pass by the
/// factor (pixel = (f·s₀ + s₁) / (f + 1)); reset frames are each their own
/// pass. Metropolis renderers refuse keeping and decaying, and a factor
/// out of (0, 1) is refused.
#[test]
fn accumulation_is_kept_decayed_or_reset_per_frame() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    for estimator in [Estimator::Path, Estimator::Bdpt] {
        let cfg = RendererConfig {
            temporal: Temporal {
                fixed_sequence: true,
                ..Temporal::default()
            },
            ..config(estimator, 1)
        };
        let frames = |mode: Accumulation, n: usize| {
            let mut r = Renderer::new(cfg, scene.camera).unwrap();
            r.set_accumulation(mode).unwrap();
            let mut w = RenderWorker::new(&r, 0).unwrap();
            let mut out = Vec::new();
            for f in 0..n {
                if f > 0 {
                    r.set_camera(scene.camera).unwrap();
                }
                prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
                r.render(&mut w, &scene, &bvh, 16 * 12).unwrap();
                out.push(resolve(&r, &[&w]));
            }
            out
        };
        let reset = frames(Accumulation::Reset, 2);
        assert_eq!(reset[0], reset[1], "{estimator:?}: fixed sequence, reset");
        let kept = frames(Accumulation::Keep, 2);
        let mut r = Renderer::new(cfg, scene.camera).unwrap();
        let mut w = RenderWorker::new(&r, 0).unwrap();
        prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
        r.render(&mut w, &scene, &bvh, 2 * 16 * 12).unwrap();
        assert_eq!(kept[1], resolve(&r, &[&w]), "{estimator:?}: kept");
        let f = 0.25f32;
        let decayed = frames(Accumulation::Decay(f), 2);
        for i in 0..16 * 12 {
            let s0 = kept[0][i].luminance() as f64;
            let s1 = 2.0 * kept[1][i].luminance() as f64 - s0;
            let want = (f as f64 * s0 + s1) / (f as f64 + 1.0);
            let got = decayed[1][i].luminance() as f64;
            assert!(
                (got - want).abs() <= 1e-4 * want.abs().max(1.0),
                "{estimator:?} pixel {i}: {got} vs {want}"
            );
        }
    }
    let mut r = Renderer::new(config(Estimator::Path, 1), scene.camera).unwrap();
    for bad in [0.0, 1.0, f32::NAN] {
        assert!(matches!(
            r.set_accumulation(Accumulation::Decay(bad)),
            Err(RenderError::Config(_))
        ));
    }
    assert_eq!(r.accumulation(), Accumulation::Reset);
    let mut r = Renderer::new(config(mlt(), 1), scene.camera).unwrap();
    r.set_accumulation(Accumulation::Keep).unwrap();
    assert!(matches!(
        r.set_accumulation(Accumulation::Decay(1.0)),
        Err(RenderError::Config(_))
    ));
    assert_eq!(r.accumulation(), Accumulation::Keep);
}

/// MLT and CMLT keep or decay their frames' images, each normalised by
/// its own b: every frame restarts its chains from its own bootstrap (so
/// b differs from frame to frame), and the kept image is the
/// records-weighted mean of the frames' own images — those of the same
/// frames rendered with reset — with weights decayed by the factor per
/// frame of age. Two workers, merged.
#[test]
fn metropolis_frames_are_kept_or_decayed_each_with_its_own_b() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    for estimator in [mlt(), cmlt(8, 4)] {
        let cfg = config(estimator, 2);
        // Each frame's image, its records and b.
        let frames = |mode: Accumulation| {
            let mut r = Renderer::new(cfg, scene.camera).unwrap();
            r.set_accumulation(mode).unwrap();
            let mut ws: Vec<RenderWorker> =
                (0..2).map(|i| RenderWorker::new(&r, i).unwrap()).collect();
            let mut out = Vec::new();
            for f in 0..3 {
                if f > 0 {
                    r.set_camera(scene.camera).unwrap();
                }
                prepare(&mut r, &mut ws, &scene, &bvh);
                for w in ws.iter_mut() {
                    r.render(w, &scene, &bvh, 16 * 12 * 2).unwrap();
                }
                let refs: Vec<&RenderWorker> = ws.iter().collect();
                let records = r.stats(&refs).mlt.records as f64;
                out.push((resolve(&r, &refs), records, r.b()));
            }
            out
        };
        let own = frames(Accumulation::Reset);
        assert!(own[0].2 != own[1].2, "{estimator:?}: every frame its own b");
        for (mode, f) in [(Accumulation::Keep, 1.0), (Accumulation::Decay(0.5), 0.5)] {
            let got = frames(mode);
            for n in 0..3 {
                assert_eq!(got[n].2, own[n].2, "{estimator:?} {mode:?}: b of frame {n}");
                // Frame g's weight: its records times f^(n − g).
                let weight = |g: usize| own[g].1 * f64::powi(f, (n - g) as i32);
                let total: f64 = (0..=n).map(weight).sum();
                for i in 0..16 * 12 {
                    let want = (0..=n)
                        .map(|g| weight(g) * own[g].0[i].luminance() as f64)
                        .sum::<f64>()
                        / total;
                    let have = got[n].0[i].luminance() as f64;
                    assert!(
                        (have - want).abs() <= 1e-4 * want.abs().max(1e-3),
                        "{estimator:?} {mode:?} frame {n} pixel {i}: {have} vs {want}"
                    );
                }
            }
            // Kept frames fill pixels a frame of few mutations leaves black.
            let black = |img: &[Rgb]| img.iter().filter(|c| c.luminance() == 0.0).count();
            assert!(
                black(&got[2].0) <= black(&own[2].0),
                "{estimator:?} {mode:?}"
            );
        }
    }
}

/// The Metropolis set-up in pieces: `prepare_worker_while` stops when the
/// clock says so and goes on at the next call, and the bootstrap it ends
/// with is the one `prepare_worker` makes in one go, bit for bit; until
/// every share is complete a first frame is not ready. With kept chains,
/// a later frame is ready at once (the chains go on with the earlier b)
/// while its bootstrap goes on across frames, and joining it changes b.
/// None of it allocates.
#[test]
fn the_metropolis_set_up_runs_in_pieces_across_calls_and_frames() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cfg = RendererConfig {
        temporal: Temporal {
            keep_chains: true,
            ..Temporal::default()
        },
        ..config(mlt(), 2)
    };
    let mut whole = Renderer::new(cfg, scene.camera).unwrap();
    let mut wws: Vec<RenderWorker> = (0..2)
        .map(|i| RenderWorker::new(&whole, i).unwrap())
        .collect();
    prepare(&mut whole, &mut wws, &scene, &bvh);

    let mut r = Renderer::new(cfg, scene.camera).unwrap();
    let mut ws: Vec<RenderWorker> = (0..2).map(|i| RenderWorker::new(&r, i).unwrap()).collect();
    let ((calls, b1), n) = allocations(|| {
        assert!(r.begin_prepare(&scene));
        let mut calls = 0;
        loop {
            calls += 1;
            let mut finished = true;
            for w in ws.iter_mut() {
                // Three pieces per call.
                let mut asked = 0;
                finished &= r
                    .prepare_worker_while(w, &scene, &bvh, &mut |_| {
                        asked += 1;
                        asked < 3
                    })
                    .unwrap();
            }
            match r.finish_prepare(ws.iter()) {
                Ok(()) => break,
                Err(e) => {
                    assert_eq!(e, RenderError::BootstrapIncomplete);
                    assert!(!finished);
                    assert_eq!(
                        r.render(&mut ws[0], &scene, &bvh, 1),
                        Err(RenderError::NotPrepared)
                    );
                }
            }
        }
        for w in ws.iter_mut() {
            r.render(w, &scene, &bvh, 16 * 12).unwrap();
        }
        let b0 = r.b();
        // The next frame is ready at once; its bootstrap goes on over
        // frames, one piece per worker per frame.
        let mut frames = 0;
        loop {
            frames += 1;
            r.set_camera(camera(0.02 * frames as f32)).unwrap();
            assert!(r.begin_prepare(&scene));
            for w in ws.iter_mut() {
                r.prepare_worker_while(w, &scene, &bvh, &mut |_| false)
                    .unwrap();
            }
            r.finish_prepare(ws.iter()).unwrap();
            for w in ws.iter_mut() {
                r.render(w, &scene, &bvh, 16 * 12).unwrap();
            }
            if r.b() != b0 {
                break;
            }
            assert!(frames < 10_000);
        }
        (calls, r.b())
    });
    assert_eq!(n, 0, "{n} allocations");
    assert!(calls > 10, "{calls} calls");
    assert!(b1 > 0.0);
    assert_eq!(
        r.bootstrap().depth_b().len(),
        whole.bootstrap().depth_b().len()
    );
    // The first bootstrap, cut into pieces, is the one made in one go.
    let mut again = Renderer::new(cfg, scene.camera).unwrap();
    let mut aws: Vec<RenderWorker> = (0..2)
        .map(|i| RenderWorker::new(&again, i).unwrap())
        .collect();
    assert!(again.begin_prepare(&scene));
    loop {
        for w in aws.iter_mut() {
            let mut asked = 0;
            again
                .prepare_worker_while(w, &scene, &bvh, &mut |_| {
                    asked += 1;
                    asked < 2
                })
                .unwrap();
        }
        if again.finish_prepare(aws.iter()).is_ok() {
            break;
        }
    }
    assert_eq!(again.bootstrap(), whole.bootstrap());
    assert_eq!(again.b(), whole.b());
}

/// With kept chains a bootstrap's normalisation-pass image joins the
/// first frame that uses its b only when the bootstrap ran entirely under
/// that frame's camera and scene revision (`mlt/pass_image.rs`): the
/// first frame's, a b refresh evaluated across still frames, one begun
/// and joined within a moved camera's frame; not one whose frames moved
/// the camera (even when it came back) or updated the scene meanwhile.
/// Its records are counted once: the frames after the join add none.
#[test]
fn kept_chains_add_a_bootstraps_pass_image_only_under_its_one_view() {
    let mut scene = room();
    let mut bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cfg = RendererConfig {
        temporal: Temporal {
            keep_chains: true,
            ..Temporal::default()
        },
        ..config(mlt(), 2)
    };
    let ms = mlt_settings();
    let pixels = 16 * 12;
    let per_bootstrap =
        ms.pass_records as u64 * u64::from(ms.normalisation_passes(pixels)) * pixels;
    assert!(per_bootstrap > 0);
    let mut r = Renderer::new(cfg, scene.camera).unwrap();
    let mut ws: Vec<RenderWorker> = (0..2).map(|i| RenderWorker::new(&r, i).unwrap()).collect();
    // One frame through `yaw`: the workers' share of the pending bootstrap
    // (to its end when `finish`, else one piece each), a render; returns
    // whether a bootstrap was joined (b changed) and the frame's pass
    // records.
    fn frame(
        r: &mut Renderer,
        ws: &mut [RenderWorker],
        (scene, bvh): (&Scene, &Bvh),
        yaw: f32,
        finish: bool,
    ) -> (bool, u64) {
        if r.frame() > 0 || r.b() > 0.0 {
            r.set_camera(camera(yaw)).unwrap();
        }
        let b = r.b();
        if r.begin_prepare(scene) {
            for w in ws.iter_mut() {
                r.prepare_worker_while(w, scene, bvh, &mut |_| finish)
                    .unwrap();
            }
            r.finish_prepare(ws.iter()).unwrap();
        }
        for w in ws.iter_mut() {
            r.render(w, scene, bvh, 16 * 12).unwrap();
        }
        let refs: Vec<&RenderWorker> = ws.iter().collect();
        (r.b() != b, r.stats(&refs).mlt.pass_records)
    }
    let joined = (true, per_bootstrap);
    let (nothing, without) = ((false, 0), (true, 0));
    // The first frame's bootstrap.
    assert_eq!(frame(&mut r, &mut ws, (&scene, &bvh), 0.0, true), joined);
    // A refresh evaluated over still frames, then joined.
    assert_eq!(frame(&mut r, &mut ws, (&scene, &bvh), 0.0, false), nothing);
    assert_eq!(frame(&mut r, &mut ws, (&scene, &bvh), 0.0, true), joined);
    // Begun and joined within one moved camera's frame.
    assert_eq!(frame(&mut r, &mut ws, (&scene, &bvh), 0.1, true), joined);
    // The frame after a join adds nothing more.
    assert_eq!(frame(&mut r, &mut ws, (&scene, &bvh), 0.1, false), nothing);
    // A refresh whose frames moved the camera away and back.
    assert_eq!(frame(&mut r, &mut ws, (&scene, &bvh), 0.2, false), nothing);
    assert_eq!(frame(&mut r, &mut ws, (&scene, &bvh), 0.1, true), without);
    // A refresh across a scene update (the camera still).
    assert_eq!(frame(&mut r, &mut ws, (&scene, &bvh), 0.1, false), nothing);
    let light: Vec<Vec3> = scene.meshes[2]
        .positions
        .iter()
        .map(|p| *p + Vec3::Y * 0.01)
        .collect();
    scene.update_mesh(2, &light, None).unwrap();
    bvh.refit(|p| scene.triangle(p));
    assert_eq!(frame(&mut r, &mut ws, (&scene, &bvh), 0.1, true), without);
    // The next refresh runs under one view again.
    assert_eq!(frame(&mut r, &mut ws, (&scene, &bvh), 0.1, true), joined);
}

/// With kept chains whose later bootstraps get no time, b stays at the
/// first bootstrap's through a scene update that brightens the room;
/// tracked from the chains' large steps (`Temporal::large_step_window`)
/// it follows the new scene to within 10 % of a fresh renderer's b in a
/// window of frames, allocating nothing in any frame. Negative control:
/// the same frames without tracking keep the old b, off by more than the
/// tolerance.
#[test]
fn tracked_b_follows_a_scene_update_from_the_large_steps() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    // The light grows 1.5× each way: 2.25× the power.
    let light: Vec<Vec3> = scene.meshes[2]
        .positions
        .iter()
        .map(|p| *p * Vec3::new(1.5, 1.0, 1.5))
        .collect();
    let run = |window: u32| -> (f64, f64) {
        let mut scene = scene.clone();
        let mut bvh = bvh.clone();
        let cfg = RendererConfig {
            temporal: Temporal {
                keep_chains: true,
                large_step_window: window,
                ..Temporal::default()
            },
            ..config(mlt(), 2)
        };
        let mut r = Renderer::new(cfg, scene.camera).unwrap();
        let mut ws: Vec<RenderWorker> = (0..2).map(|i| RenderWorker::new(&r, i).unwrap()).collect();
        for f in 0..24 {
            if f == 4 {
                scene.update_mesh(2, &light, None).unwrap();
                bvh.refit(|p| scene.triangle(p));
            }
            let ((), n) = allocations(|| {
                if f > 0 {
                    r.set_camera(scene.camera).unwrap();
                }
                if r.begin_prepare(&scene) {
                    // The later bootstraps get no time: b is carried.
                    for w in ws.iter_mut() {
                        r.prepare_worker_while(w, &scene, &bvh, &mut |_| f == 0)
                            .unwrap();
                    }
                    r.finish_prepare(ws.iter()).unwrap();
                }
                for w in ws.iter_mut() {
                    r.render(w, &scene, &bvh, 16 * 12 * 16).unwrap();
                }
            });
            assert_eq!(n, 0, "frame {f}: {n} allocations");
        }
        let mut fresh = Renderer::new(config(mlt(), 1), scene.camera).unwrap();
        let mut fw = RenderWorker::new(&fresh, 0).unwrap();
        prepare(&mut fresh, std::slice::from_mut(&mut fw), &scene, &bvh);
        (r.b(), fresh.b())
    };
    let (tracked, want) = run(8);
    let (carried, _) = run(0);
    eprintln!("b tracked {tracked}, carried {carried}, fresh {want}");
    assert!(
        (tracked / want - 1.0).abs() < 0.1,
        "tracked b {tracked} vs fresh {want}"
    );
    assert!(
        (carried / want - 1.0).abs() > 0.1,
        "negative control: carried b {carried} vs fresh {want}"
    );
}

/// Moving a mesh between frames (`Scene::update_mesh` + `Bvh::refit`):
/// `render` refuses the updated scene until preparing, which starts a new
/// frame on its own — the same image as a fresh renderer on the moved
/// scene (fixed sequences, b window restarted although the camera stayed);
/// with kept chains the chains are re-evaluated and the mean agrees.
#[test]
fn scene_update_starts_a_frame_and_matches_a_fresh_renderer() {
    let mut scene = room();
    let mut bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    // The mirror sphere (mesh 1) slides and the light (mesh 2) rises.
    let sphere: Vec<Vec3> = scene.meshes[1]
        .positions
        .iter()
        .map(|p| *p + Vec3::new(-0.4, -0.1, 0.1))
        .collect();
    let light: Vec<Vec3> = scene.meshes[2]
        .positions
        .iter()
        .map(|p| *p * Vec3::new(1.5, 1.0, 1.5) + Vec3::Y * 0.01)
        .collect();
    for (estimator, keep_chains) in [(Estimator::Bdpt, false), (mlt(), false), (mlt(), true)] {
        let kind = estimator.kind();
        let mut scene = scene.clone();
        let mut bvh = bvh.clone();
        let metropolis = kind.is_metropolis();
        // Kept chains and the b window are Metropolis switches.
        let cfg = RendererConfig {
            temporal: Temporal {
                fixed_sequence: true,
                keep_chains,
                b_window: if metropolis { 4 } else { 0 },
                ..Temporal::default()
            },
            ..config(estimator, 1)
        };
        let mut r = Renderer::new(cfg, scene.camera).unwrap();
        let mut w = RenderWorker::new(&r, 0).unwrap();
        prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
        r.render(&mut w, &scene, &bvh, 16 * 12 * 4).unwrap();
        let before = resolve(&r, &[&w]);

        scene.update_mesh(1, &sphere, None).unwrap();
        scene.update_mesh(2, &light, None).unwrap();
        bvh.refit(|p| scene.triangle(p));
        assert_eq!(
            r.render(&mut w, &scene, &bvh, 1),
            Err(RenderError::NotPrepared)
        );
        let frame = r.frame();
        prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
        assert_eq!(r.frame(), frame + 1, "the update started a frame");
        r.render(&mut w, &scene, &bvh, 16 * 12 * 4).unwrap();
        let after = resolve(&r, &[&w]);
        assert_ne!(before, after);

        let mut fresh = Renderer::new(cfg, scene.camera).unwrap();
        let mut fw = RenderWorker::new(&fresh, 0).unwrap();
        prepare(&mut fresh, std::slice::from_mut(&mut fw), &scene, &bvh);
        fresh.render(&mut fw, &scene, &bvh, 16 * 12 * 4).unwrap();
        let want = resolve(&fresh, &[&fw]);
        assert_eq!(r.b(), fresh.b(), "{kind:?}: b window restarted");
        if keep_chains {
            let (a, b) = (mean(&after), mean(&want));
            assert!((a / b - 1.0).abs() < 0.05, "kept chains: {a} vs {b}");
        } else {
            assert_eq!(after, want, "{kind:?}, keep {keep_chains}");
        }
    }
    // A bad update changes nothing.
    let light_before = scene.meshes[2].positions.clone();
    let mut bad = light.clone();
    bad[3].x = f32::NAN;
    assert!(scene.update_mesh(2, &bad, None).is_err());
    assert!(scene.update_mesh(2, &light[..3], None).is_err());
    assert!(scene.update_mesh(7, &light, None).is_err());
    assert_eq!(scene.meshes[2].positions, light_before);
    assert_eq!(scene.revision(), 0);
    bvh.refit(|p| scene.triangle(p));
}

/// One frame of [`split_frames`]: the image, b and the bootstrap.
type Frame = (Vec<Rgb>, f64, Bootstrap);

/// Renders three frames of `cfg` (camera yawing by 0.05 per frame, each
/// worker 2 mutations per pixel), the bootstrap's shares evaluated on the
/// workers' own threads (`threads`) or one after the other on this thread
/// and joined in reverse worker order; returns each frame's image, b and
/// bootstrap.
fn split_frames(scene: &Scene, cfg: RendererConfig, threads: bool) -> Vec<Frame> {
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let mut r = Renderer::new(cfg, camera(0.0)).unwrap();
    let mut ws: Vec<RenderWorker> = (0..cfg.workers)
        .map(|i| RenderWorker::new(&r, i).unwrap())
        .collect();
    let mut out = Vec::new();
    for f in 0..3 {
        r.set_camera(camera(0.05 * f as f32)).unwrap();
        assert_eq!(r.begin_prepare(scene), cfg.estimator.is_metropolis());
        if threads {
            std::thread::scope(|s| {
                for w in ws.iter_mut() {
                    let (r, bvh) = (&r, &bvh);
                    s.spawn(move || r.prepare_worker(w, scene, bvh).unwrap());
                }
            });
        } else {
            for w in ws.iter_mut() {
                r.prepare_worker(w, scene, &bvh).unwrap();
            }
        }
        r.finish_prepare(ws.iter().rev()).unwrap();
        for w in ws.iter_mut() {
            let steps = r.steps_for(w.index(), 2);
            r.render_steps(w, scene, &bvh, steps).unwrap();
        }
        let refs: Vec<&RenderWorker> = ws.iter().collect();
        out.push((resolve(&r, &refs), r.b(), r.bootstrap().clone()));
    }
    out
}

/// The bootstrap is a function of the frame, not of how it is split: 1,
/// 2 and 3 workers (uneven shares), on their own threads or on one, give
/// the same bootstrap bit for bit, and the same image for the same split.
#[test]
fn bootstrap_is_the_same_for_every_split_over_workers() {
    let scene = room();
    // An odd number of passes and of bootstrap samples per worker: uneven
    // shares.
    let Estimator::Cmlt(c) = cmlt(2, 1) else {
        unreachable!()
    };
    let estimator = Estimator::Cmlt(CmltSettings {
        mlt: MltSettings {
            n_bootstrap: 333,
            b_passes: 5,
            b_min_samples: 0,
            ..c.mlt
        },
        ..c
    });
    for temporal in [
        Temporal::default(),
        Temporal {
            keep_chains: true,
            b_window: 2,
            fixed_sequence: false,
            ..Temporal::default()
        },
    ] {
        let boots = |frames: &[Frame]| -> Vec<(f64, Bootstrap)> {
            frames
                .iter()
                .map(|(_, b, boot)| (*b, boot.clone()))
                .collect()
        };
        let mut first = None;
        for workers in [1, 2, 3] {
            let cfg = RendererConfig {
                temporal,
                ..config(estimator, workers)
            };
            let spread = split_frames(&scene, cfg, true);
            let one = split_frames(&scene, cfg, false);
            assert!(spread.iter().all(|(_, b, _)| *b > 0.0));
            assert_eq!(spread, one, "{workers} workers, {temporal:?}");
            let first = first.get_or_insert_with(|| boots(&spread));
            assert_eq!(&boots(&spread), first, "{workers} workers, {temporal:?}");
        }
    }
    // PT has no bootstrap: `begin_prepare` readies the renderer at once.
    let cfg = config(Estimator::Path, 2);
    assert_eq!(
        split_frames(&scene, cfg, true),
        split_frames(&scene, cfg, false)
    );
}

/// Fewer normalisation passes than workers: the pass is still shared. With
/// one pass and two workers each evaluates half of its blocks
/// (`NORMALISATION_BLOCKS`), so the set-up's rays, which count towards
/// each worker's frame, are about equal — where worker 0 used to evaluate
/// the whole pass and worker 1 only its bootstrap samples (6 801 rays
/// against 162 here).
#[test]
fn one_normalisation_pass_is_shared_by_the_workers() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let estimator = Estimator::Mlt(MltSettings {
        n_bootstrap: 8,
        b_passes: 1,
        ..mlt_settings()
    });
    for workers in [2, 3] {
        let mut r = Renderer::new(config(estimator, workers), scene.camera).unwrap();
        let mut ws: Vec<RenderWorker> = (0..workers)
            .map(|i| RenderWorker::new(&r, i).unwrap())
            .collect();
        prepare(&mut r, &mut ws, &scene, &bvh);
        assert!(r.b() > 0.0);
        let rays: Vec<u64> = ws
            .iter_mut()
            .map(|w| {
                r.render(w, &scene, &bvh, 0).unwrap();
                r.worker_stats(w).tracer.total_rays()
            })
            .collect();
        let (lo, hi) = (rays.iter().min().unwrap(), rays.iter().max().unwrap());
        assert!(
            *hi as f64 <= 1.25 * *lo as f64,
            "{workers} workers: set-up rays {rays:?}"
        );
    }
}

#[test]
fn bootstrap_shares_allocate_nothing_and_all_are_needed() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cfg = config(mlt(), 2);
    let mut r = Renderer::new(cfg, scene.camera).unwrap();
    let mut w0 = RenderWorker::new(&r, 0).unwrap();
    let mut w1 = RenderWorker::new(&r, 1).unwrap();
    // One share missing, or one twice: refused, and the renderer is not
    // ready.
    assert!(r.begin_prepare(&scene));
    r.prepare_worker(&mut w0, &scene, &bvh).unwrap();
    assert_eq!(
        r.finish_prepare([&w0]),
        Err(RenderError::BootstrapIncomplete)
    );
    assert_eq!(
        r.finish_prepare([&w0, &w1]),
        Err(RenderError::BootstrapIncomplete)
    );
    assert_eq!(
        r.finish_prepare([&w0, &w0]),
        Err(RenderError::BootstrapIncomplete)
    );
    assert_eq!(
        r.render(&mut w0, &scene, &bvh, 1),
        Err(RenderError::NotPrepared)
    );
    // A worker of another renderer is refused.
    let other = Renderer::new(cfg, scene.camera).unwrap();
    let mut stranger = RenderWorker::new(&other, 1).unwrap();
    assert_eq!(
        r.prepare_worker(&mut stranger, &scene, &bvh),
        Err(RenderError::Worker)
    );
    let (_, n) = allocations(|| {
        for frame in 0..3 {
            if frame > 0 {
                r.set_camera(camera(0.1 * frame as f32)).unwrap();
                assert!(r.begin_prepare(&scene));
                r.prepare_worker(&mut w0, &scene, &bvh).unwrap();
            }
            r.prepare_worker(&mut w1, &scene, &bvh).unwrap();
            r.finish_prepare([&w0, &w1]).unwrap();
            // Ready: nothing more to do until the next frame.
            assert!(!r.begin_prepare(&scene));
            r.render(&mut w0, &scene, &bvh, 16 * 12).unwrap();
            r.render(&mut w1, &scene, &bvh, 16 * 12).unwrap();
        }
    });
    assert_eq!(n, 0, "{n} allocations");
    assert!(r.b() > 0.0);
    // The bootstrap's rays count towards the frame's.
    assert!(r.worker_stats(&w0).tracer.total_rays() > r.worker_stats(&w0).mlt.mutations);
}

#[test]
fn per_pixel_budgets_split_into_each_workers_steps() {
    let scene = room();
    let pixels = 16 * 12;
    // PT and BDPT: passes i, i + W, … below n.
    let r = Renderer::new(config(Estimator::Bdpt, 3), scene.camera).unwrap();
    let steps: Vec<u64> = (0..3).map(|i| r.steps_for(i, 5)).collect();
    assert_eq!(steps, [2, 2, 1]);
    assert_eq!(r.steps_for(2, 2), 0);
    // MLT: the same number of rounds on every worker, enough for n
    // mutations per pixel over all chains (24 per worker).
    let r = Renderer::new(config(mlt(), 2), scene.camera).unwrap();
    assert_eq!(r.steps_for(0, 3), (3 * pixels as u64).div_ceil(48));
    assert_eq!(r.steps_for(1, 3), r.steps_for(0, 3));
    assert_eq!(r.steps_for(0, 0), 0);
    // CMLT without side chains is refused.
    assert!(matches!(
        Renderer::new(config(cmlt(1, 0), 1), scene.camera),
        Err(RenderError::Config(_))
    ));
}

/// Settings an estimator does not read are refused, not ignored: the
/// Metropolis frame switches for PT and BDPT.
#[test]
fn switches_the_estimator_does_not_read_are_refused() {
    let scene = room();
    for estimator in [Estimator::Path, Estimator::Bdpt] {
        for temporal in [
            Temporal {
                keep_chains: true,
                ..Temporal::default()
            },
            Temporal {
                b_window: 2,
                ..Temporal::default()
            },
        ] {
            let cfg = RendererConfig {
                temporal,
                ..config(estimator, 1)
            };
            let Err(RenderError::Config(m)) = Renderer::new(cfg, scene.camera) else {
                panic!("{estimator:?} accepted {temporal:?}");
            };
            assert!(m.contains("MLT and CMLT only"), "{m}");
            assert_eq!(
                Renderer::memory_bound(&cfg, 16, 12),
                Err(RenderError::Config(m))
            );
        }
        // A fixed sequence applies to every estimator.
        let fixed = RendererConfig {
            temporal: Temporal {
                fixed_sequence: true,
                ..Temporal::default()
            },
            ..config(estimator, 1)
        };
        assert!(Renderer::new(fixed, scene.camera).is_ok());
    }
}

/// One depth limit: an unbounded depth renders at `depth_cap` for every
/// estimator — the same image as asking for that depth — and a bounded one
/// ignores the cap.
#[test]
fn unbounded_depth_renders_at_the_depth_cap_for_every_estimator() {
    let scene = room();
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    for estimator in [Estimator::Path, Estimator::Bdpt, mlt(), cmlt(1, 1)] {
        let image = |max_depth, depth_cap| {
            let cfg = RendererConfig {
                settings: Settings {
                    max_depth,
                    ..settings()
                },
                depth_cap,
                ..config(estimator, 1)
            };
            let mut r = Renderer::new(cfg, scene.camera).unwrap();
            assert_eq!(r.config().settings.max_depth, Some(cfg.max_depth()));
            let mut w = RenderWorker::new(&r, 0).unwrap();
            prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
            r.render(&mut w, &scene, &bvh, 16 * 12 * 2).unwrap();
            resolve(&r, &[&w])
        };
        let kind = estimator.kind();
        let capped = image(None, 3);
        assert_eq!(capped, image(Some(3), 40), "{kind:?}");
        assert_ne!(capped, image(None, 4), "{kind:?}: the cap is read");
    }
}
