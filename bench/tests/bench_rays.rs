//! `cmlt-bench rays` on a tiny budget: the CSV has the documented header
//! and one well-formed row per (scene, ray set, kernel, threads), with
//! every kernel this machine runs (Embree's too with the feature on), also
//! when each cell is measured in several rounds.

mod common;

use std::collections::HashSet;
use std::process::Command;

use cmlt::accel::bvh::Kernel;

#[test]
fn bench_rays_writes_csv() {
    let dir = std::env::temp_dir().join(format!("cmlt-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("rays.csv");
    let out = Command::new(env!("CARGO_BIN_EXE_cmlt-bench"))
        .args(["rays", "--scenes", "cornell-box,mesh", "--time", "0"])
        .args([
            "--threads",
            "1,2",
            "--rays",
            "256",
            "--mesh-triangles",
            "2000",
            // Two rounds must still give one row per kernel and cell.
            "--rounds",
            "2",
        ])
        .arg("--scenes-dir")
        .arg(common::scenes_dir())
        .arg("--csv")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("scene,ray_set,kernel,threads,mrays_per_s")
    );
    let mut kernels = HashSet::new();
    let mut keys = HashSet::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 5, "{line}");
        assert!(["cornell-box", "mesh"].contains(&f[0]), "{line}");
        assert!(
            ["primary", "diffuse", "mtm8", "mtm16", "shadow"].contains(&f[1]),
            "{line}"
        );
        assert!(
            f[2].starts_with("ours") || f[2].starts_with("embree"),
            "{line}"
        );
        assert!(["1", "2"].contains(&f[3]), "{line}");
        let m: f64 = f[4].parse().unwrap();
        assert!(m.is_finite() && m > 0.0, "{line}");
        assert!(
            keys.insert((f[0], f[1], f[2], f[3])),
            "duplicate row {line}"
        );
        kernels.insert(f[2].to_string());
    }
    let mut want: HashSet<String> = Kernel::ALL
        .into_iter()
        .filter(|k| k.is_available())
        .map(|k| format!("ours-{}", k.name()))
        .collect();
    want.extend(
        [
            "ours-packet4",
            "ours-packet8",
            "ours-packet16",
            "ours-stream",
        ]
        .map(String::from),
    );
    if cfg!(feature = "embree") {
        want.extend(
            [
                "embree-1",
                "embree-4",
                "embree-8",
                "embree-16",
                "embree-stream",
            ]
            .map(String::from),
        );
    }
    assert_eq!(kernels, want);
    assert_eq!(keys.len(), 2 * 5 * 2 * want.len());

    // The run ends with the targets' summary: both scenes' rows, and the
    // packet target's tally over both scenes' two MTM sets.
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("best ours / best embree (1T / 2T)"),
        "{stdout}"
    );
    assert!(
        stdout.contains("1T packets >= 2x single rays, mtm:"),
        "{stdout}"
    );
    assert!(stdout.contains(" of 4"), "{stdout}");
    // `bench rays-summary` reads the CSV back: the same table, and with two
    // files the cells met in every run.
    let summary = Command::new(env!("CARGO_BIN_EXE_cmlt-bench"))
        .args(["rays-summary"])
        .arg(&csv)
        .arg(&csv)
        .output()
        .unwrap();
    assert!(summary.status.success());
    let text = String::from_utf8_lossy(&summary.stdout);
    let table = |s: &str| {
        s.lines()
            .skip_while(|l| !l.starts_with("best ours"))
            .take(3)
            .map(String::from)
            .collect::<Vec<_>>()
    };
    assert_eq!(table(&text), table(&stdout), "{text}");
    assert!(text.contains("across 2 runs"), "{text}");
    // A malformed CSV is an error that names the file and the line.
    let bad = dir.join("bad.csv");
    std::fs::write(
        &bad,
        format!(
            "{}\nmesh,primary,ours-avx2,1\n",
            "scene,ray_set,kernel,threads,mrays_per_s"
        ),
    )
    .unwrap();
    let failed = Command::new(env!("CARGO_BIN_EXE_cmlt-bench"))
        .args(["rays-summary"])
        .arg(&bad)
        .output()
        .unwrap();
    assert!(!failed.status.success());
    assert!(String::from_utf8_lossy(&failed.stderr).contains("bad.csv:2"));
    std::fs::remove_dir_all(&dir).ok();
}
