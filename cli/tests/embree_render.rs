//! Renders through the Embree backend match renders through our BVH: the
//! same scene, seed and sample count give the same image statistics. The
//! backends differ only in the rounding of hit distances, so paths mostly
//! follow the same sample streams and the means agree to well within the
//! noise (pixels are not bit-identical: the last bits of hit points differ).
//! MLT and CMLT go through the `cmlt` binary's `--accel` flag.
#![cfg(feature = "embree")]

mod common;

use cmlt::accel::bvh::Bvh;
use cmlt::accel::embree::EmbreeScene;
use cmlt::renderer::{Estimator, RendererConfig};
use cmlt_cli::accel::Accel;
use cmlt_cli::render::{Budget, render};

#[test]
fn embree_render_matches_bvh_render() {
    let (loaded, _) = common::load_reduced("cornell-box", 8);
    let tris: Vec<_> = loaded.scene.triangles().collect();
    let accel = Accel::Ours(Bvh::build(&tris));
    let embree = Accel::Embree(EmbreeScene::new(&tris).expect("Embree device"));
    for method in [Estimator::Path, Estimator::Bdpt] {
        let config = RendererConfig {
            estimator: method,
            settings: loaded.settings,
            seed: 3,
            workers: 2,
            ..RendererConfig::default()
        };
        let ours =
            render(&loaded.scene, &accel, config, Budget::PerPixel(16), &|_| {}).expect("render");
        let theirs = render(
            &loaded.scene,
            &embree,
            config,
            Budget::PerPixel(16),
            &|_| {},
        )
        .expect("render");
        let (a, b) = (ours.image, theirs.image);
        let (ma, mb) = (a.mean(), b.mean());
        for (x, y) in [(ma.r, mb.r), (ma.g, mb.g), (ma.b, mb.b)] {
            assert!(
                x > 0.0 && (x - y).abs() <= 0.01 * x,
                "{method:?}: mean {ma:?} vs {mb:?}"
            );
        }
    }
}

/// `cmlt render --method mlt|cmlt --accel embree` against `--accel ours`:
/// same scene, seed and mutation budget, image means within 2% per
/// channel. (Chains may drift apart where the backends' last bits differ,
/// but the image mean is pinned by the bootstrap's b, a BDPT estimate.)
#[test]
fn mlt_render_through_embree_flag_matches_ours() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("embree-render");
    std::fs::create_dir_all(&dir).unwrap();
    for method in ["mlt", "cmlt"] {
        let mut means = Vec::new();
        for accel in ["ours", "embree"] {
            let out = dir.join(format!("{method}-{accel}.exr"));
            let o = std::process::Command::new(env!("CARGO_BIN_EXE_cmlt"))
                .args(["render", "--method", method, "--accel", accel])
                .args(["-D", "resx=32", "-D", "resy=32"])
                .args([
                    "--mutations-per-pixel",
                    "16",
                    "--threads",
                    "2",
                    "--seed",
                    "5",
                ])
                .arg("--quiet")
                .arg("-o")
                .arg(&out)
                .output()
                .expect("cmlt runs");
            let stderr = String::from_utf8_lossy(&o.stderr);
            assert!(o.status.success(), "{method} --accel {accel}: {stderr}");
            assert!(
                stderr.contains(&format!("({accel} BVH)")),
                "{method}: backend not reported: {stderr}"
            );
            means.push(cmlt_cli::image_io::read_exr(&out).unwrap().mean());
        }
        let (a, b) = (means[0], means[1]);
        for (x, y) in [(a.r, b.r), (a.g, b.g), (a.b, b.b)] {
            assert!(
                x > 0.0 && (x - y).abs() <= 0.02 * x,
                "{method}: mean {a:?} (ours) vs {b:?} (embree)"
            );
        }
    }
}
