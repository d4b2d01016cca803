//! `cmlt-bench convergence` end to end on a tiny, deterministic study: the
//! CSV has the documented columns, one row per (method, budget, seed), PT's
//! error falls with its budget, the plots are written, and `cmlt-bench
//! plot` and `cmlt-bench score` read and extend the same CSV.
//!
//! Budgets are sample counts (`--samples`), not seconds: with a fixed seed
//! and thread count every render is bit-identical, so the test cannot be
//! flaky, and timings never enter an assertion.

mod common;

use std::path::PathBuf;
use std::process::Command;

use cmlt_bench::convergence::{CSV_HEADER, curves, read_csv};
use cmlt_cli::accel::{Accel, AccelKind};
use cmlt_cli::render::render;

fn bench() -> Command {
    Command::new(env!("CARGO_BIN_EXE_cmlt-bench"))
}

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("bench-convergence");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn ok(out: std::process::Output) -> String {
    assert!(
        out.status.success(),
        "cmlt-bench failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn pt_error_falls_with_budget_and_csv_is_well_formed() {
    let scene = common::scenes_dir().join("cornell-box");
    let (csv, plot) = (tmp("c.csv"), tmp("c"));
    let _ = std::fs::remove_file(&csv);
    let stdout = ok(bench()
        .args(["convergence"])
        .arg(scene.join("scene.xml"))
        .arg("--reference")
        .arg(scene.join("reference.exr"))
        // 1/8 of the reference's 256×256: the reference is box-filtered down.
        .args(["-D", "resx=32", "-D", "resy=32"])
        .args(["--methods", "pt,cmlt", "--budgets", "4,16,64", "--samples"])
        .args(["--seeds", "2", "--seeds-up-to", "1000", "--threads", "2"])
        .arg("--csv")
        .arg(&csv)
        .arg("--plot")
        .arg(&plot)
        .output()
        .unwrap());
    assert!(stdout.contains("wrote"), "{stdout}");

    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(
        text.lines().next(),
        Some(
            "method,budget_s,wall_s,seed,samples,rel_mse,rmse,mean_r,mean_g,mean_b,mrays_per_s,rel_mse_4,rel_mse_16,cpu_s"
        )
    );
    assert_eq!(text.lines().next(), Some(CSV_HEADER));
    let rows = read_csv(&csv).unwrap();
    // 3 budgets × 2 seeds × 2 methods, in that order (the methods take
    // turns at every seed, so a drift of the machine falls on both).
    assert_eq!(rows.len(), 12, "{text}");
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r.method, if i % 2 == 0 { "pt" } else { "cmlt" });
        assert_eq!(r.seed, (i / 2) as u64 % 2);
        // Sample budgets leave budget_s empty.
        assert_eq!(r.budget_s, None);
        let m = &r.m;
        assert!(m.wall_s > 0.0 && m.mrays_per_s > 0.0, "{r:?}");
        assert!(m.rel_mse > 0.0 && m.rel_mse.is_finite(), "{r:?}");
        assert!(m.rmse > 0.0 && m.rmse.is_finite(), "{r:?}");
        // The Cornell box's mean is about 0.1–0.2 per channel.
        assert!(m.mean.iter().all(|c| (0.02..1.0).contains(c)), "{r:?}");
    }
    // PT runs exactly its budget; MLT rounds up to whole rounds of chains.
    let budgets = [4.0, 16.0, 64.0];
    for (i, r) in rows.iter().enumerate() {
        let b = budgets[i / 4];
        if r.method == "pt" {
            assert_eq!(r.m.samples, b, "{r:?}");
        } else {
            assert!(r.m.samples >= b && r.m.samples < 2.0 * b + 1.0, "{r:?}");
        }
    }
    // PT's relMSE ∝ 1/spp: each 4× budget must cut it by well over 2×.
    let c = curves(&rows);
    let pt = c.iter().find(|c| c.method == "pt").unwrap();
    let e: Vec<f64> = pt.points.iter().map(|p| p.rel_mse).collect();
    assert_eq!(e.len(), 3);
    for w in e.windows(2) {
        assert!(
            w[1] < w[0] / 2.5,
            "PT relMSE did not fall with budget: {e:?}"
        );
    }
    for ext in ["png", "svg"] {
        let p = tmp(&format!("c.{ext}"));
        assert!(
            std::fs::metadata(&p).unwrap().len() > 1000,
            "{}",
            p.display()
        );
    }

    // A peer's image scored into the same CSV, then re-plotted.
    let img = tmp("peer.exr");
    // (rendered here by the product's driver: PT, 8 spp, 2 threads)
    let loaded = cmlt_cli::load_scene_or_builtin(
        &scene.join("scene.xml").to_string_lossy(),
        &[
            ("resx".to_string(), "32".to_string()),
            ("resy".to_string(), "32".to_string()),
        ],
    )
    .unwrap();
    let tris: Vec<_> = loaded.scene.triangles().collect();
    let accel = Accel::build(AccelKind::Ours, &tris).unwrap();
    let config = cmlt::renderer::RendererConfig {
        estimator: cmlt::renderer::Estimator::Path,
        settings: loaded.settings,
        workers: 2,
        ..Default::default()
    };
    let budget = cmlt::renderer::Budget::PerPixel(8);
    // The non-generic driver: this binary links it instead of compiling
    // the renderer again.
    let out = render(&loaded.scene, &accel, config, budget, &|_| {}).unwrap();
    cmlt_cli::image_io::write_image(&img, &out.image).unwrap();
    ok(bench()
        .args(["score"])
        .arg(&img)
        .arg("--reference")
        .arg(scene.join("reference.exr"))
        .args([
            "--method",
            "peer",
            "--budget-s",
            "1",
            "--wall-s",
            "0.5",
            "--samples",
            "8",
        ])
        .arg("--csv")
        .arg(&csv)
        .output()
        .unwrap());
    let rows = read_csv(&csv).unwrap();
    assert_eq!(rows.len(), 13);
    let peer = rows.last().unwrap();
    assert_eq!((peer.method.as_str(), peer.budget_s), ("peer", Some(1.0)));
    // 8 spp lies between PT's 4 and 16 spp renders in error.
    assert!(
        peer.m.rel_mse < e[0] && peer.m.rel_mse > e[1],
        "{peer:?} {e:?}"
    );
    let replot = tmp("replot");
    let stdout = ok(bench()
        .args(["plot", "--csv"])
        .arg(&csv)
        .arg("--plot")
        .arg(&replot)
        .output()
        .unwrap());
    assert!(
        stdout.contains("peer") && stdout.contains("cmlt"),
        "{stdout}"
    );
    assert!(tmp("replot.png").exists() && tmp("replot.svg").exists());
}
