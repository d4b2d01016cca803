//! `cmlt-bench flicker` end to end on a tiny budget.

use std::process::Command;

/// `cmlt-bench flicker` prints one row per switch set; b averaged over
/// frames steadies the frame means, fixed sequences make frames identical.
#[test]
fn bench_flicker_reports_every_switch() {
    let o = Command::new(env!("CARGO_BIN_EXE_cmlt-bench"))
        .args([
            "flicker",
            "--frames",
            "6",
            "--mutations-per-pixel",
            "2",
            "-D",
            "resx=16",
            "-D",
            "resy=16",
        ])
        .output()
        .expect("cmlt-bench runs");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{}\n{stdout}",
        String::from_utf8_lossy(&o.stderr)
    );
    let row = |name: &str| -> Vec<String> {
        stdout
            .lines()
            .find(|l| l.starts_with(name))
            .unwrap_or_else(|| panic!("no {name} row in\n{stdout}"))
            .split_whitespace()
            .map(str::to_string)
            .collect()
    };
    for name in ["none", "keep-chains", "b-window", "fixed-sequence", "all"] {
        assert_eq!(row(name).len(), 6, "{stdout}");
    }
    let flicker = |name: &str| row(name)[1].parse::<f64>().unwrap();
    assert!(flicker("none") > 0.0);
    assert!(flicker("b-window") < flicker("none"), "{stdout}");
    assert_eq!(row("fixed-sequence")[2], "identical", "{stdout}");
}
