//! Rendering one image as parts and merging them (`cmlt render --part I/N
//! --state`, `cmlt merge`): two parts of equal budget merge into the image
//! a single process renders at twice the budget (means agree, relMSE
//! against the reference halves), with every estimator; parts that do not
//! belong together are refused and nothing is written.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

use cmlt::accel::bvh::Bvh;
use cmlt::mlt::{CmltSettings, Level2Settings};
use cmlt::renderer::{Estimator, RendererConfig};
use cmlt_cli::accel::Accel;
use cmlt_cli::image_io::Image;
use cmlt_cli::metrics::rel_mse;
use cmlt_cli::mitsuba::LoadedScene;
use cmlt_cli::render::{Budget, render_with_sums};
use cmlt_cli::state::{self, Identity, PartState, merge, part_seed};
use common::{level1, load_reduced};

/// Renders part `part` of 2 (seed [`part_seed`]`(seed, part)`) at `budget`
/// per pixel and returns its state.
fn render_part(
    loaded: &LoadedScene,
    accel: &Accel,
    config: RendererConfig,
    budget: u64,
    seed: u64,
    part: u32,
) -> PartState {
    let config = RendererConfig {
        seed: part_seed(seed, part),
        ..config
    };
    let (out, sums) = render_with_sums(
        &loaded.scene,
        accel,
        config,
        Budget::PerPixel(budget),
        &|_| {},
    )
    .expect("render");
    assert_eq!(out.stats.nonfinite, 0);
    let s = state::from_render(
        &out,
        sums,
        &config,
        Identity {
            part,
            parts: 2,
            frame: 0,
            seed,
            scene_hash: 1,
        },
    );
    // The state resolves to the image its render resolved, bit for bit.
    assert_eq!(s.resolve().pixels, out.image.pixels);
    s
}

/// Over `seeds` seeds: two parts of `budget` merged, one part alone, and a
/// single render at 2·`budget`, against the reference. Asserts that the
/// merged means agree with the single renders' and the reference's, and
/// that the merged relMSE is about half a part's and about a 2×-budget
/// render's; and that the same criterion fails for a part merged with a
/// copy of itself (the negative control).
fn check_merge(
    name: &str,
    loaded: &LoadedScene,
    reference: &Image,
    config: RendererConfig,
    budget: u64,
    seeds: u64,
) {
    let tris: Vec<_> = loaded.scene.triangles().collect();
    let accel = Accel::Ours(Bvh::build(&tris));
    let (mut e_part, mut e_merged, mut e_single, mut e_dup) = (0.0, 0.0, 0.0, 0.0);
    let (mut m_merged, mut m_single) = (Vec::new(), Vec::new());
    for s in 0..seeds {
        let seed = 1000 + 17 * s;
        let a = render_part(loaded, &accel, config, budget, seed, 0);
        let b = render_part(loaded, &accel, config, budget, seed, 1);
        let merged = merge(&[a.clone(), b]).expect("parts merge");
        assert!(merged.missing.is_empty());
        // The negative control: part 0 again under index 1, bypassing the
        // check `merge` makes against it.
        let copy = PartState {
            part: 1,
            ..a.clone()
        };
        let dup = merge(&[a.clone(), copy]).unwrap();
        // The single render at twice the budget, its own seed.
        let single = render_part(loaded, &accel, config, 2 * budget, seed + 7, 0).resolve();
        let part_img = a.resolve();
        e_part += rel_mse(&part_img, reference);
        e_merged += rel_mse(&merged.image, reference);
        e_single += rel_mse(&single, reference);
        e_dup += rel_mse(&dup.image, reference);
        m_merged.push(merged.image.mean());
        m_single.push(single.mean());
    }
    let n = seeds as f64;
    let (e_part, e_merged, e_single, e_dup) = (e_part / n, e_merged / n, e_single / n, e_dup / n);
    eprintln!(
        "{name}: relMSE part {e_part:.5}, merged {e_merged:.5} (ratio {:.2}), single at 2x {e_single:.5} (merged/single {:.2}), part merged with itself {e_dup:.5}",
        e_merged / e_part,
        e_merged / e_single,
    );
    // Means: merged against single renders and the reference, within 3%
    // or 4 standard errors of the seeds' spread (low budgets have heavy
    // tails: a few bright paths decide a render's mean).
    let rm = reference.mean();
    let mean_se = |xs: &[f64]| {
        let mu = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mu) * (x - mu)).sum::<f64>() / (n - 1.0);
        (mu, (var / n).sqrt())
    };
    for c in 0..3 {
        let r = rm[c] as f64;
        let merged: Vec<f64> = m_merged.iter().map(|m| m[c] as f64).collect();
        let diff: Vec<f64> = m_merged
            .iter()
            .zip(&m_single)
            .map(|(a, b)| (a[c] - b[c]) as f64)
            .collect();
        let (mu, se) = mean_se(&merged);
        let (d, se_d) = mean_se(&diff);
        eprintln!(
            "{name}, channel {c}: merged mean {mu:.5} ± {se:.5}, minus single {d:.5} ± {se_d:.5}, reference {r:.5}"
        );
        assert!(
            (mu - r).abs() <= (0.03 * r).max(4.0 * se),
            "{name}, channel {c}: merged mean {mu:.5} ± {se:.5} vs reference {r:.5}"
        );
        assert!(
            d.abs() <= (0.03 * r).max(4.0 * se_d),
            "{name}, channel {c}: merged minus single mean {d:.5} ± {se_d:.5}"
        );
    }
    // Two parts halve the error (0.5 expected); a merge that counted one
    // part twice, or dropped one, stays at 1.
    let halves = |e: f64| e <= 0.7 * e_part;
    assert!(
        halves(e_merged),
        "{name}: merged relMSE {e_merged:.5} vs one part {e_part:.5}"
    );
    assert!(
        !halves(e_dup),
        "{name}: the negative control passed ({e_dup:.5} vs {e_part:.5})"
    );
    // The same error as one process at twice the budget (the merge pools b
    // over both bootstraps, so it may be lower still).
    let ratio = e_merged / e_single;
    assert!(
        (0.5..=1.4).contains(&ratio),
        "{name}: merged relMSE {e_merged:.5}, single at 2x {e_single:.5}"
    );
}

/// [`check_merge`] of two parts of `budget` on the Cornell box at 1/8 of
/// its resolution, over 4 seeds, on two workers.
fn check_merge_cornell_box(estimator: Estimator, budget: u64) {
    let (loaded, reference) = load_reduced("cornell-box", 8);
    let config = RendererConfig {
        estimator,
        settings: loaded.settings,
        workers: 2,
        ..RendererConfig::default()
    };
    check_merge(
        estimator.kind().name(),
        &loaded,
        &reference,
        config,
        budget,
        4,
    );
}

// One test per estimator, so that the two test threads share them out.

#[test]
fn two_parts_merge_like_twice_the_budget_pt() {
    check_merge_cornell_box(Estimator::Path, 4);
}

#[test]
fn two_parts_merge_like_twice_the_budget_bdpt() {
    check_merge_cornell_box(Estimator::Bdpt, 2);
}

#[test]
fn two_parts_merge_like_twice_the_budget_mlt() {
    check_merge_cornell_box(Estimator::Mlt(level1(64)), 8);
}

#[test]
fn two_parts_merge_like_twice_the_budget_cmlt() {
    let cmlt = Estimator::Cmlt(CmltSettings {
        mlt: level1(64),
        level2: Level2Settings {
            k: 4,
            m: 2,
            ..Level2Settings::default()
        },
    });
    check_merge_cornell_box(cmlt, 4);
}

fn cmlt() -> Command {
    Command::new(env!("CARGO_BIN_EXE_cmlt"))
}

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("parts-tests");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// `cmlt render` of the built-in Cornell box at 16×16 as part `part`,
/// with `extra` options, writing the state to `state`.
fn part(state: &Path, part: &str, extra: &[&str]) {
    let o = cmlt()
        .args([
            "render",
            "--quiet",
            "--threads",
            "1",
            "-D",
            "resx=16",
            "-D",
            "resy=16",
        ])
        .args(["--part", part, "--state"])
        .arg(state)
        .args(extra)
        .output()
        .expect("cmlt runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// `cmlt merge STATES -o OUT`: the exit status, stderr and whether OUT
/// exists afterwards.
fn merge_cli(states: &[&Path], out: &Path) -> (bool, String, bool) {
    let _ = std::fs::remove_file(out);
    let o = cmlt()
        .arg("merge")
        .args(states)
        .arg("-o")
        .arg(out)
        .output()
        .expect("cmlt runs");
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
        out.exists(),
    )
}

#[test]
fn cli_merges_parts_and_refuses_what_does_not_belong() {
    let pt = ["--method", "bdpt", "--spp", "2"];
    let (a, b) = (tmp("a.part"), tmp("b.part"));
    part(&a, "0/2", &pt);
    part(&b, "1/2", &pt);
    let out = tmp("merged.exr");
    let (ok, err, written) = merge_cli(&[&a, &b], &out);
    assert!(ok && written, "{err}");
    // A part alone: a notice, and its image, equal to a plain render's.
    let (ok, err, _) = merge_cli(&[&a], &out);
    assert!(ok && err.contains("missing: 1"), "{err}");
    let plain = tmp("plain.exr");
    let o = cmlt()
        .args([
            "render",
            "--quiet",
            "--threads",
            "1",
            "-D",
            "resx=16",
            "-D",
            "resy=16",
        ])
        .args(pt)
        .arg("-o")
        .arg(&plain)
        .output()
        .unwrap();
    assert!(o.status.success());
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&plain).unwrap());

    // Each refusal names the reason and writes nothing.
    let refused = |states: &[&Path], why: &str| {
        let (ok, err, written) = merge_cli(states, &out);
        assert!(!ok && !written, "{why}: merged anyway ({err})");
        assert!(err.contains(why), "expected '{why}' in: {err}");
    };
    refused(&[&a, &a], "given twice");
    let other_scene = tmp("scene.part");
    let xml = common::scenes_dir().join("cornell-box/scene.xml");
    let o = cmlt()
        .args([
            "render",
            "--quiet",
            "--threads",
            "1",
            "-D",
            "resx=16",
            "-D",
            "resy=16",
        ])
        .arg(&xml)
        .args(pt)
        .args(["--part", "1/2", "--state"])
        .arg(&other_scene)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    refused(&[&a, &other_scene], "the scene");
    let other_method = tmp("method.part");
    part(&other_method, "1/2", &["--method", "pt", "--spp", "2"]);
    refused(&[&a, &other_method], "the method");
    let (m0, m1) = (tmp("m0.part"), tmp("m1.part"));
    let mlt = ["--method", "mlt", "--spp", "1", "--bootstrap", "100"];
    part(&m0, "0/2", &mlt);
    part(&m1, "1/2", &[&mlt[..], &["--b-passes", "3"]].concat());
    refused(&[&m0, &m1], "the settings");
    let three = tmp("three.part");
    part(&three, "1/3", &pt);
    refused(&[&a, &three], "the part count");
    let seeded = tmp("seed.part");
    part(&seeded, "1/2", &[&pt[..], &["--seed", "5"]].concat());
    refused(&[&a, &seeded], "the base seed");

    // Truncated, corrupt and foreign files.
    let bytes = std::fs::read(&b).unwrap();
    let cut = tmp("cut.part");
    std::fs::write(&cut, &bytes[..bytes.len() - 9]).unwrap();
    refused(&[&a, &cut], "truncated");
    let flipped = tmp("flipped.part");
    let mut f = bytes.clone();
    f[200] ^= 1;
    std::fs::write(&flipped, &f).unwrap();
    refused(&[&a, &flipped], "corrupt");
    let foreign = tmp("foreign.part");
    std::fs::write(&foreign, b"P6 16 16 255\n").unwrap();
    refused(&[&a, &foreign], "wrong magic");
    let mut v = bytes;
    v[8] = 9;
    let newer = tmp("newer.part");
    std::fs::write(&newer, &v).unwrap();
    refused(&[&a, &newer], "version 9");
}

#[test]
fn one_frame_of_a_sequence_renders_as_parts() {
    let bdpt = ["--method", "bdpt", "--spp", "2", "--frames", "3", "--orbit"];
    // The whole sequence in one process.
    let seq = tmp("seq.exr");
    let o = cmlt()
        .args([
            "render",
            "--quiet",
            "--threads",
            "1",
            "-D",
            "resx=16",
            "-D",
            "resy=16",
        ])
        .args(bdpt)
        .arg("-o")
        .arg(&seq)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Frame 2 alone, as the only part: the sequence's frame 2, bit for bit.
    let f2 = tmp("f2.part");
    part(&f2, "0/1", &[&bdpt[..], &["--frame", "2"]].concat());
    let out = tmp("f2.exr");
    let (ok, err, _) = merge_cli(&[&f2], &out);
    assert!(ok, "{err}");
    assert_eq!(
        std::fs::read(&out).unwrap(),
        std::fs::read(tmp("seq-0002.exr")).unwrap()
    );
    // Parts of different frames do not merge.
    let (a, b) = (tmp("f1a.part"), tmp("f2b.part"));
    part(&a, "0/2", &[&bdpt[..], &["--frame", "1"]].concat());
    part(&b, "1/2", &[&bdpt[..], &["--frame", "2"]].concat());
    let (ok, err, written) = merge_cli(&[&a, &b], &out);
    assert!(!ok && !written && err.contains("the frame"), "{err}");
    // A frame that depends on the previous ones is refused.
    let o = cmlt()
        .args([
            "render",
            "--quiet",
            "--threads",
            "1",
            "-D",
            "resx=16",
            "-D",
            "resy=16",
        ])
        .args([
            "--method",
            "mlt",
            "--spp",
            "1",
            "--frames",
            "3",
            "--keep-chains",
        ])
        .args(["--frame", "1", "--part", "0/1", "--state"])
        .arg(tmp("kept.part"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--keep-chains"));
}
