//! The `cmlt` binary end to end: the README's render command works, output
//! is bit-identical for a fixed seed and thread count, and bad input gets a
//! clear error (non-zero exit, the file named, no panic).

use std::path::PathBuf;
use std::process::Command;

use cmlt_cli::image_io::read_exr;

fn cmlt() -> Command {
    Command::new(env!("CARGO_BIN_EXE_cmlt"))
}

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cli-tests");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Runs `cmlt render ARGS --quiet -o OUT`, whatever its outcome.
fn run_render(args: &[&str], out: &PathBuf) -> std::process::Output {
    cmlt()
        .arg("render")
        .args(args)
        .arg("--quiet")
        .arg("-o")
        .arg(out)
        .output()
        .expect("cmlt runs")
}

fn render(args: &[&str], out: &PathBuf) -> std::process::Output {
    let o = run_render(args, out);
    assert!(
        o.status.success(),
        "cmlt failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

#[test]
fn builtin_scene_renders_to_exr_and_png() {
    let exr = tmp("builtin.exr");
    let png = tmp("builtin.png");
    let o = render(
        &[
            "--method",
            "bdpt",
            "--spp",
            "2",
            "-D",
            "resx=32",
            "-D",
            "resy=32",
            "--png",
            png.to_str().unwrap(),
        ],
        &exr,
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("M samples/s") && stdout.contains("Mrays/s"),
        "{stdout}"
    );
    let img = read_exr(&exr).unwrap();
    assert_eq!(
        (img.width, img.height),
        (32, 32),
        "-D overrides the built-in scene's defaults"
    );
    let mean = img.mean();
    assert!(mean.r > 0.05 && mean.r < 1.0, "a lit Cornell box: {mean:?}");
    assert!(png.metadata().unwrap().len() > 1000);
}

#[test]
fn same_seed_and_threads_give_identical_bits() {
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/scenes/cornell-box/scene.xml"
    );
    for method in ["pt", "bdpt"] {
        let (a, b, c) = (
            tmp(&format!("{method}-a.exr")),
            tmp(&format!("{method}-b.exr")),
            tmp(&format!("{method}-c.exr")),
        );
        let args = [
            "--method",
            method,
            "--spp",
            "3",
            "--threads",
            "2",
            "--seed",
            "5",
            "-D",
            "resx=24",
            "-D",
            "resy=24",
        ];
        render(&[&[scene][..], &args].concat(), &a);
        render(&[&[scene][..], &args].concat(), &b);
        let (ia, ib) = (read_exr(&a).unwrap(), read_exr(&b).unwrap());
        assert!(
            ia.pixels
                .iter()
                .zip(&ib.pixels)
                .all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits))
        );
        // A different seed changes the image (the seed is really used).
        let mut other = args;
        other[7] = "6";
        render(&[&[scene][..], &other].concat(), &c);
        assert_ne!(read_exr(&c).unwrap().pixels, ia.pixels);
    }
}

#[test]
fn bad_scenes_fail_cleanly() {
    let dir = tmp("bad");
    std::fs::create_dir_all(&dir).unwrap();
    let cases = [
        (
            "truncated.xml",
            "<scene version=\"3.0.0\"><sensor type=\"perspective\">",
        ),
        (
            "nan.xml",
            "<scene version=\"3.0.0\"><sensor type=\"perspective\"><float name=\"fov\" value=\"nan\"/></sensor></scene>",
        ),
        (
            "plugin.xml",
            "<scene version=\"3.0.0\"><bsdf type=\"hypothetical\"/></scene>",
        ),
    ];
    for (name, xml) in cases {
        let path = dir.join(name);
        std::fs::write(&path, xml).unwrap();
        let o = cmlt()
            .args([
                "render",
                path.to_str().unwrap(),
                "--spp",
                "1",
                "--quiet",
                "-o",
            ])
            .arg(tmp("never.exr"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{name}: {stderr}");
        assert!(
            stderr.contains(name) && stderr.starts_with("error:"),
            "{name}: {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
    }
    let o = cmlt()
        .args(["render", "/no/such/scene.xml", "--quiet"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("/no/such/scene.xml"));
}

/// Without the `embree` feature, `--accel embree` is refused with a message
/// that says how to get it (and `--accel ours` is the default).
#[cfg(not(feature = "embree"))]
#[test]
fn accel_embree_needs_the_feature() {
    let o = cmlt()
        .args(["render", "--accel", "embree", "--spp", "1", "--quiet"])
        .args(["-D", "resx=8", "-D", "resy=8", "-o"])
        .arg(tmp("no-embree.exr"))
        .output()
        .expect("cmlt runs");
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("built without Embree") && stderr.contains("--features embree"),
        "{stderr}"
    );
}

/// `--frames N --orbit` writes N numbered frames next to the output; the
/// same command replays them bit for bit, and the orbit moves the view.
#[test]
fn frames_orbit_writes_numbered_frames_and_replays() {
    let args = [
        "--method",
        "cmlt",
        "--frames",
        "3",
        "--orbit",
        "--orbit-degrees",
        "20",
        "--mutations-per-pixel",
        "2",
        "--chains",
        "32",
        "--bootstrap",
        "200",
        "--keep-chains",
        "--b-window",
        "4",
        "--threads",
        "2",
        "-D",
        "resx=24",
        "-D",
        "resy=24",
    ];
    let read = |dir: &str| {
        let out = tmp(&format!("{dir}/f.exr"));
        std::fs::create_dir_all(out.parent().unwrap()).unwrap();
        let o = render(&args, &out);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert_eq!(
            stdout.lines().filter(|l| l.starts_with("frame ")).count(),
            3,
            "{stdout}"
        );
        assert!(!out.exists(), "the un-numbered output was written");
        (0..3)
            .map(|f| {
                read_exr(&tmp(&format!("{dir}/f-{f:04}.exr")))
                    .unwrap()
                    .pixels
            })
            .collect::<Vec<_>>()
    };
    let a = read("frames-a");
    let b = read("frames-b");
    assert_eq!(a, b, "frames differ between identical runs");
    assert_ne!(a[0], a[2], "the orbit did not move the camera");
    assert!(a.iter().flatten().all(|c| c.is_finite()));
}

/// Runs `cmlt render ARGS -o OUT` expecting a refusal: non-zero exit, no
/// panic, the phrase in the message, nothing rendered and `out` untouched.
fn refused(args: &[&str], out: &PathBuf, phrase: &str) {
    // Only regular files are read back (`/dev/full` reads forever).
    let contents = |p: &PathBuf| p.is_file().then(|| std::fs::read(p).unwrap());
    let before = contents(out);
    let o = run_render(args, out);
    let stderr = String::from_utf8_lossy(&o.stderr);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(!o.status.success(), "{args:?} was accepted: {stdout}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    assert!(
        stderr.contains(phrase),
        "{args:?}: expected '{phrase}' in: {stderr}"
    );
    assert!(!stdout.contains("wrote"), "{args:?} rendered: {stdout}");
    assert_eq!(contents(out), before, "{args:?} changed {}", out.display());
}

#[test]
fn budgets_and_thread_counts_are_checked_before_rendering() {
    let out = tmp("refused-budget.exr");
    let _ = std::fs::remove_file(&out);
    let small = ["-D", "resx=8", "-D", "resy=8"];
    let cases: &[(&[&str], &str)] = &[
        (&["--time", "inf"], "time budget must be finite"),
        (&["--time", "1e30"], "time budget must be finite"),
        (&["--time", "0"], "time budget must be finite"),
        (&["--time", "NaN"], "time budget must be finite"),
        (&["--time=-1"], "time budget must be finite"),
        (&["--spp", "0"], "--spp"),
        (
            &["--method", "mlt", "--mutations-per-pixel", "0"],
            "--mutations-per-pixel",
        ),
        (
            &["--spp", "1", "--threads", "0"],
            "threads must be in 1..=1024",
        ),
        (
            &["--spp", "1", "--threads", "4294967295"],
            "threads must be in 1..=1024",
        ),
        (&["--spp", "1", "--frames", "0"], "frames must be in"),
    ];
    for (args, phrase) in cases {
        let all: Vec<&str> = args.iter().chain(small.iter()).copied().collect();
        refused(&all, &out, phrase);
    }
}

/// `--method` is the one choice of estimator: an option the method does
/// not read is refused (naming the option and the method) before
/// anything renders, and `--m` no longer turns MLT into CMLT.
#[test]
fn options_the_method_does_not_read_are_refused() {
    let out = tmp("refused-method.exr");
    let _ = std::fs::remove_file(&out);
    let small = ["-D", "resx=8", "-D", "resy=8"];
    let cases: &[(&[&str], &str)] = &[
        (
            &["--method", "mlt", "--m", "4"],
            "--m is read by --method cmlt only, not by --method mlt",
        ),
        (
            &["--method", "mlt", "--k", "2"],
            "--k is read by --method cmlt only, not by --method mlt",
        ),
        (
            &["--method", "pt", "--chains", "8"],
            "--chains is read by --method mlt and cmlt only, not by --method pt",
        ),
        (
            &["--method", "bdpt", "--lens-sigma", "2"],
            "--lens-sigma is read by --method cmlt only, not by --method bdpt",
        ),
        (
            &["--method", "pt", "--mutations-per-pixel", "4"],
            "--mutations-per-pixel is read by --method mlt and cmlt only",
        ),
        (
            &[
                "--method",
                "bdpt",
                "--spp",
                "1",
                "--frames",
                "2",
                "--keep-chains",
            ],
            "--keep-chains is read by --method mlt and cmlt only, not by --method bdpt",
        ),
        (
            &[
                "--method",
                "pt",
                "--spp",
                "1",
                "--frames",
                "2",
                "--b-window",
                "2",
            ],
            "--b-window is read by --method mlt and cmlt only, not by --method pt",
        ),
        (&["--method", "cmlt", "--m", "0"], "CMLT needs m ≥ 1"),
    ];
    for (args, phrase) in cases {
        let all: Vec<&str> = args.iter().chain(small.iter()).copied().collect();
        refused(&all, &out, phrase);
    }
}

#[test]
fn unwritable_outputs_are_found_before_rendering_and_keep_old_files() {
    let exr = tmp("kept.exr");
    render(&["--spp", "1", "-D", "resx=8", "-D", "resy=8"], &exr);
    let args = ["--spp", "1", "-D", "resx=8", "-D", "resy=8"];
    // A --png in a missing directory: the existing EXR stays as it was.
    let mut with_png = args.to_vec();
    with_png.extend(["--png", "/nonexistent-cmlt-dir/preview.png"]);
    refused(&with_png, &exr, "does not exist");
    // A missing output directory, a wrong extension, a device.
    refused(
        &args,
        &PathBuf::from("/nonexistent-cmlt-dir/out.exr"),
        "does not exist",
    );
    refused(&args, &tmp("out.tiff"), "must end in .exr or .png");
    refused(&args, &exr.join("out.exr"), "is not a directory");
    refused(
        &args,
        &PathBuf::from("/dev/full"),
        "must end in .exr or .png",
    );
    let mut png_to_exr = args.to_vec();
    png_to_exr.extend(["--png", exr.to_str().unwrap()]);
    refused(&png_to_exr, &tmp("other.exr"), "--png must end in .png");
    // No temporary file is left next to the outputs.
    let dir = exr.parent().unwrap();
    let leftovers: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn an_image_larger_than_memory_is_a_clear_error() {
    let out = tmp("huge.exr");
    let _ = std::fs::remove_file(&out);
    // 65536² pixels: the loader's largest film, 206 GB per film.
    refused(
        &[
            "--spp",
            "1",
            "--threads",
            "1",
            "-D",
            "resx=65536",
            "-D",
            "resy=65536",
        ],
        &out,
        "out of memory",
    );
}
