//! Frames: Metropolis chains carried across camera moves stay unbiased.
//! The camera of the Cornell box turns away over a few frames and comes
//! back; the kept chains, re-evaluated at every move and run on, with the
//! b of the first frame carried (the later bootstraps get no time), then
//! accumulate at the original view — and converge to Mitsuba 3's
//! reference like a fresh render of the same budget. And frames kept by
//! the accumulation (each its own chains and b) converge as one offline
//! render of all their mutations.

use crate::common;

use cmlt::accel::bvh::Bvh;
use cmlt::mlt::{CmltSettings, Level2Settings};
use cmlt::renderer::{Accumulation, Estimator, RenderWorker, Renderer, RendererConfig, Temporal};
use cmlt::scene::Scene;
use cmlt_cli::accel::Accel;
use cmlt_cli::frames::{look_at_point, orbit_camera};
use cmlt_cli::image_io::Image;
use cmlt_cli::metrics::rel_mse;
use cmlt_cli::mitsuba::LoadedScene;
use common::{level1, load_reduced};

/// Renders the scene's view after `away` frames of a camera turned up to
/// `degrees` (each frame a few rounds of every chain), at `mpp` mutations
/// per pixel once back, with kept chains on two workers; returns the image.
fn moved_and_back(estimator: Estimator, away: usize, degrees: f32, mpp: u64, seed: u64) -> Image {
    let kept = Temporal {
        keep_chains: true,
        ..Temporal::default()
    };
    let (loaded, accel, cfg) = the_box(estimator, seed, kept);
    let scene = &loaded.scene;
    let home = scene.camera;
    let pivot = look_at_point(&home, &accel);
    let mut r = Renderer::new(cfg, home).unwrap();
    let mut ws: Vec<RenderWorker> = (0..2).map(|i| RenderWorker::new(&r, i).unwrap()).collect();
    let path = (0..=away).chain((0..away).rev());
    for (f, step) in path.enumerate() {
        if f > 0 {
            r.set_camera(orbit_camera(&home, pivot, degrees, step, away.max(1)))
                .unwrap();
        }
        // The first bootstrap runs to the end; the later ones get no
        // time, so the first frame's b carries over.
        let back = f == 2 * away;
        frame(&mut r, &mut ws, scene, &accel, f == 0, |r, i| {
            if back { r.steps_for(i, mpp) } else { 4 }
        });
    }
    resolved(&r, &ws)
}

/// The Cornell box at 1/8 of its reference resolution, our BVH over it,
/// and a config of two workers running `estimator` with `temporal`.
fn the_box(
    estimator: Estimator,
    seed: u64,
    temporal: Temporal,
) -> (LoadedScene, Accel, RendererConfig) {
    let (loaded, _) = load_reduced("cornell-box", 8);
    let accel = Accel::Ours(Bvh::build(&loaded.scene.triangles().collect::<Vec<_>>()));
    let cfg = RendererConfig {
        estimator,
        settings: loaded.settings,
        seed,
        workers: 2,
        temporal,
        ..RendererConfig::default()
    };
    (loaded, accel, cfg)
}

/// One frame as a host runs it (the camera already set): a due bootstrap's
/// pieces run while `set_up` (else it gets no time and waits), then each
/// worker renders `steps(r, worker index)` mutations.
fn frame(
    r: &mut Renderer,
    ws: &mut [RenderWorker],
    scene: &Scene,
    accel: &Accel,
    set_up: bool,
    steps: impl Fn(&Renderer, u32) -> u64,
) {
    if r.begin_prepare(scene) {
        for w in ws.iter_mut() {
            r.prepare_worker_while(w, scene, accel, &mut |_| set_up)
                .unwrap();
        }
        r.finish_prepare(ws.iter()).unwrap();
    }
    for w in ws.iter_mut() {
        let n = steps(r, w.index());
        r.render_steps(w, scene, accel, n).unwrap();
    }
}

/// The merged image of `ws`, asserting that no sample was non-finite.
fn resolved(r: &Renderer, ws: &[RenderWorker]) -> Image {
    let (w, h) = (r.camera().width() as usize, r.camera().height() as usize);
    let mut pixels = vec![cmlt::math::Rgb::ZERO; w * h];
    let refs: Vec<&RenderWorker> = ws.iter().collect();
    r.resolve(&refs, |i, c| pixels[i] = c).unwrap();
    assert_eq!(r.stats(&refs).nonfinite, 0);
    Image {
        width: w,
        height: h,
        pixels,
    }
}

/// Each channel mean of `image` within 3 % of `reference`'s.
fn assert_means_within_3_percent(image: &Image, reference: &Image) {
    let (m, want) = (image.mean(), reference.mean());
    for c in 0..3 {
        assert!(
            (m[c] / want[c] - 1.0).abs() < 0.03,
            "channel {c}: {} vs reference {}",
            m[c],
            want[c]
        );
    }
}

fn check(estimator: Estimator) {
    let (_, reference) = load_reduced("cornell-box", 8);
    let mpp = 64;
    let fresh = moved_and_back(estimator, 0, 0.0, mpp, 5);
    let moved = moved_and_back(estimator, 3, 12.0, mpp, 5);
    let (e_fresh, e_moved) = (rel_mse(&fresh, &reference), rel_mse(&moved, &reference));
    let (m, want) = (moved.mean(), reference.mean());
    eprintln!(
        "{estimator:?}: relMSE fresh {e_fresh:.4}, moved and back {e_moved:.4}; mean {m:?} vs {want:?}"
    );
    assert_means_within_3_percent(&moved, &reference);
    assert!(
        e_moved < 1.5 * e_fresh,
        "moved and back relMSE {e_moved} vs fresh {e_fresh}"
    );
}

#[test]
fn kept_mlt_chains_after_a_camera_that_moves_and_returns_converge_to_the_reference() {
    check(Estimator::Mlt(level1(64)));
}

#[test]
fn kept_cmlt_chains_after_a_camera_that_moves_and_returns_converge_to_the_reference() {
    check(Estimator::Cmlt(CmltSettings {
        mlt: level1(64),
        level2: Level2Settings {
            lens_sigma: 2.0,
            side_chain_min_depth: 0,
            ..Level2Settings::default()
        },
    }));
}

/// `frames` frames of a still camera at `mpp` mutations per pixel each,
/// kept by the accumulation (each frame its own bootstrap, chains and b),
/// on two workers: the image of the last.
fn kept_frames(estimator: Estimator, frames: usize, mpp: u64, seed: u64) -> Image {
    let (loaded, accel, cfg) = the_box(estimator, seed, Temporal::default());
    let scene = &loaded.scene;
    let mut r = Renderer::new(cfg, scene.camera).unwrap();
    r.set_accumulation(Accumulation::Keep).unwrap();
    let mut ws: Vec<RenderWorker> = (0..2).map(|i| RenderWorker::new(&r, i).unwrap()).collect();
    for f in 0..frames {
        if f > 0 {
            r.set_camera(scene.camera).unwrap();
        }
        frame(&mut r, &mut ws, scene, &accel, true, |r, i| {
            r.steps_for(i, mpp)
        });
    }
    resolved(&r, &ws)
}

/// Eight kept MLT frames of 8 mutations per pixel against one frame of 64
/// (the same total): both converge to the reference, the kept frames'
/// error within noise of the offline render's (`cmlt-bench frames
/// --still` measures the ratio over seeds).
#[test]
fn kept_mlt_frames_of_a_still_camera_converge_as_one_offline_render() {
    let (_, reference) = load_reduced("cornell-box", 8);
    let estimator = Estimator::Mlt(level1(64));
    let offline = kept_frames(estimator, 1, 64, 3);
    let kept = kept_frames(estimator, 8, 8, 3);
    let (e_offline, e_kept) = (rel_mse(&offline, &reference), rel_mse(&kept, &reference));
    let (m, want) = (kept.mean(), reference.mean());
    eprintln!("relMSE offline {e_offline:.4}, kept {e_kept:.4}; mean {m:?} vs {want:?}");
    assert_means_within_3_percent(&kept, &reference);
    assert!(
        e_kept < 1.5 * e_offline,
        "kept frames relMSE {e_kept} vs offline {e_offline}"
    );
}

/// A still camera's `frames` frames of `mpp` mutations per pixel each,
/// with kept chains and the accumulation kept, on two workers; the later
/// bootstraps (b refreshes) run to their end in every frame when
/// `refresh`, else get no time (the first frame's b carries); b tracked
/// from the large steps of `window` frames (0: off). Returns the last
/// frame's image and the records and pass records of all frames.
fn still_kept_chains(
    estimator: Estimator,
    (frames, mpp): (usize, u64),
    refresh: bool,
    window: u32,
    seed: u64,
) -> (Image, u64, u64) {
    let tracked = Temporal {
        keep_chains: true,
        large_step_window: window,
        ..Temporal::default()
    };
    let (loaded, accel, cfg) = the_box(estimator, seed, tracked);
    let scene = &loaded.scene;
    let mut r = Renderer::new(cfg, scene.camera).unwrap();
    r.set_accumulation(Accumulation::Keep).unwrap();
    let mut ws: Vec<RenderWorker> = (0..2).map(|i| RenderWorker::new(&r, i).unwrap()).collect();
    let (mut records, mut pass_records) = (0, 0);
    for f in 0..frames {
        if f > 0 {
            r.set_camera(scene.camera).unwrap();
        }
        frame(&mut r, &mut ws, scene, &accel, f == 0 || refresh, |r, i| {
            r.steps_for(i, mpp)
        });
        // Each frame's counters start from zero.
        let refs: Vec<&RenderWorker> = ws.iter().collect();
        let s = r.stats(&refs).mlt;
        records += s.records;
        pass_records += s.pass_records;
    }
    (resolved(&r, &ws), records, pass_records)
}

/// Whether each channel of `means` is within 2 % of `reference`'s mean.
fn means_within_2_percent(means: [f32; 3], reference: &Image) -> bool {
    let want = reference.mean();
    (0..3).all(|c| (means[c] / want[c] - 1.0).abs() < 0.02)
}

/// With kept chains and a still camera, each bootstrap's normalisation
/// passes' image joins the first frame that uses its b (it ran under that
/// frame's view), weighed by `pass_records` as an offline render weighs
/// it (`mlt/pass_image.rs`): kept frames of 8 mutations per pixel
/// converge to the reference (means within 2 %) with the first frame's
/// passes alone (the b refreshes get no time) and with every frame's b
/// refresh adding its own passes. Negative control: the same images with
/// the passes' records left out of the normalisation (the pass image
/// weighted as if it were free) miss the reference's means.
#[test]
fn kept_chains_of_a_still_camera_add_the_passes_image_once_per_bootstrap() {
    let (_, reference) = load_reduced("cornell-box", 8);
    let pixels = (reference.width * reference.height) as u64;
    let estimator = Estimator::Mlt(cmlt::mlt::MltSettings {
        pass_records: 1.0,
        ..level1(64)
    });
    let passes = u64::from(level1(64).normalisation_passes(pixels));
    let frames = 8;
    for refresh in [false, true] {
        let (mut sum, mut wrong) = ([0.0f32; 3], [0.0f32; 3]);
        let seeds = 4;
        for seed in 0..seeds {
            let (img, records, pass_records) =
                still_kept_chains(estimator, (frames, 8), refresh, 0, 20 + seed);
            // One pass record per pixel of every pass of every bootstrap
            // joined: the first frame's, and one per later frame when the
            // refreshes run.
            let joined = if refresh { frames as u64 } else { 1 };
            assert_eq!(pass_records, joined * passes * pixels, "refresh {refresh}");
            let m = img.mean();
            let k = records as f32 / (records - pass_records) as f32;
            for c in 0..3 {
                sum[c] += m[c] / seeds as f32;
                wrong[c] += m[c] * k / seeds as f32;
            }
        }
        eprintln!(
            "refresh {refresh}: mean {sum:?}, pass image as if free {wrong:?}, reference {:?}",
            reference.mean()
        );
        assert!(
            means_within_2_percent(sum, &reference),
            "refresh {refresh}: {sum:?}"
        );
        assert!(
            !means_within_2_percent(wrong, &reference),
            "negative control passed: {wrong:?}"
        );
    }
}

/// b tracked from the chains' own large steps (`Temporal::large_step_window`)
/// over a still camera's kept frames: the frames converge to the Cornell
/// box's reference (means within 3 % over four seeds), the large steps'
/// b pooled over the window as the bootstrap's passes would give it (b
/// from the same chains' large steps is a ratio estimate: consistent, its
/// bias of the order of 1/N).
#[test]
fn tracked_b_of_a_still_camera_converges_to_the_reference() {
    let (_, reference) = load_reduced("cornell-box", 8);
    let estimator = Estimator::Mlt(level1(64));
    let mut sum = [0.0f32; 3];
    for seed in 0..4 {
        let (img, _, _) = still_kept_chains(estimator, (8, 8), false, 4, 40 + seed);
        let m = img.mean();
        for c in 0..3 {
            sum[c] += m[c] / 4.0;
        }
    }
    let want = reference.mean();
    eprintln!("tracked b: mean {sum:?}, reference {want:?}");
    assert!(
        (0..3).all(|c| (sum[c] / want[c] - 1.0).abs() < 0.03),
        "{sum:?} vs {want:?}"
    );
}
