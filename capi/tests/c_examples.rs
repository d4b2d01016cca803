//! Builds every C program in `examples-c/` against the staticlib of this
//! test run's own build of `cmlt-capi` (same profile and features) with
//! `-std=c99 -Wall -Wextra -Werror -pedantic`, checks that the header also
//! compiles as C++, runs the programs and checks their output against
//! Rust-side renders of the same scenes. With `CMLT_VALGRIND=1` every
//! program runs under valgrind memcheck and must report no errors and no
//! definite leaks. `minimal.c` loads the built-in scene and runs only with
//! the `loader` feature; the others build their scenes from host arrays
//! and run in every build.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The staticlib of this test binary's own `cmlt-capi` unit: the same
/// profile and features as the Rust code the examples are compared with.
/// Cargo builds every crate type of the library in one go, so the
/// `cargo test` that built this binary also wrote the `.a`, next to it in
/// `deps/` (a separate release build took 4 min 33 s of `cargo test
/// --workspace`). Cargo names it without a hash, so a later build with
/// other features overwrites it, and a fresh build does not rewrite it.
/// The checks below make a library of the other Embree or loader setting
/// an error; one with other effect features is not told apart.
fn staticlib() -> &'static Path {
    static LIB: OnceLock<PathBuf> = OnceLock::new();
    LIB.get_or_init(|| {
        let exe = std::env::current_exe().expect("the test binary's path");
        let name = if cfg!(windows) {
            "cmlt_capi.lib"
        } else {
            "libcmlt_capi.a"
        };
        let lib = exe.with_file_name(name);
        assert!(
            lib.is_file(),
            "{} is missing: it is written with this test binary's library unit",
            lib.display()
        );
        // The Embree backend's entry points are referenced by, and the
        // loader crate's symbols are in, only a library built with the
        // feature.
        let nm = Command::new("nm").arg(&lib).output().expect("run nm");
        assert!(nm.status.success(), "nm {} failed", lib.display());
        let symbols = String::from_utf8_lossy(&nm.stdout);
        for (symbol, built) in [
            ("rtcNewDevice", cfg!(feature = "embree")),
            ("cmlt_mitsuba", cfg!(feature = "loader")),
        ] {
            assert_eq!(
                symbols.contains(symbol),
                built,
                "{} was written by a build with other features since this one \
                 (cargo gives staticlibs one name); rebuild it: touch capi/src/lib.rs",
                lib.display()
            );
        }
        lib
    })
}

fn out_dir() -> PathBuf {
    let d = workspace().join("target/c-examples");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Compiles `examples-c/NAME.c` into an executable; returns its path.
fn build_example(name: &str) -> PathBuf {
    build_source(name, false)
}

/// Compiles `examples-c/NAME.c` (C99) or, with `cpp`, `NAME.cpp` (C++17,
/// the header-only wrapper `include/cmlt.hpp`), with every warning an
/// error; returns the executable's path.
fn build_source(name: &str, cpp: bool) -> PathBuf {
    let out = out_dir();
    let compiler = cc::Build::new()
        .cpp(cpp)
        .cargo_metadata(false)
        .cargo_warnings(false)
        .opt_level(2)
        .target(env!("CMLT_TEST_TARGET"))
        .host(env!("CMLT_TEST_TARGET"))
        .out_dir(&out)
        .get_compiler();
    let exe = out.join(name);
    let mut cmd = compiler.to_command();
    cmd.args([
        if cpp { "-std=c++17" } else { "-std=c99" },
        "-Wall",
        "-Wextra",
        "-Werror",
        "-pedantic",
        "-g",
        "-I",
    ])
    .arg(workspace().join("include"))
    .arg(workspace().join(format!(
        "examples-c/{name}.{}",
        if cpp { "cpp" } else { "c" }
    )))
    .arg(staticlib())
    .arg("-o")
    .arg(&exe);
    // The staticlib itself links Embree when built with the feature.
    if cfg!(feature = "embree") {
        cmd.arg("-lembree3");
    }
    cmd.args([
        "-lgcc_s",
        "-lutil",
        "-lrt",
        "-lpthread",
        "-lm",
        "-ldl",
        "-lc",
    ]);
    let o = cmd.output().expect("run the C compiler");
    assert!(
        o.status.success(),
        "compiling {name}.c failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    exe
}

/// Runs an example (under valgrind with `CMLT_VALGRIND=1`); returns stdout.
fn run(exe: &Path, args: &[&str]) -> String {
    let mut cmd = if std::env::var_os("CMLT_VALGRIND").is_some() {
        let mut c = Command::new("valgrind");
        c.args([
            "--error-exitcode=99",
            "--leak-check=full",
            "--errors-for-leak-kinds=definite",
            "--quiet",
        ])
        .arg(exe);
        c
    } else {
        Command::new(exe)
    };
    let o = cmd
        .args(args)
        .current_dir(out_dir())
        .output()
        .expect("run example");
    assert!(
        o.status.success(),
        "{} {args:?} failed ({}):\n{}\n{}",
        exe.display(),
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

/// The numbers after `key` on the line starting with it.
fn numbers(out: &str, key: &str) -> Vec<f64> {
    out.lines()
        .find_map(|l| l.strip_prefix(key))
        .unwrap_or_else(|| panic!("no `{key}` line in:\n{out}"))
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect()
}

#[test]
fn header_compiles_as_cpp() {
    let compiler = cc::Build::new()
        .cpp(true)
        .cargo_metadata(false)
        .cargo_warnings(false)
        .opt_level(0)
        .target(env!("CMLT_TEST_TARGET"))
        .host(env!("CMLT_TEST_TARGET"))
        .out_dir(out_dir())
        .get_compiler();
    let src = out_dir().join("header_check.cpp");
    std::fs::write(
        &src,
        "#include \"cmlt.h\"\nint main() { return cmlt_version() > 0 ? 0 : 1; }\n",
    )
    .unwrap();
    let o = compiler
        .to_command()
        .args([
            "-std=c++11",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
            "-fsyntax-only",
            "-I",
        ])
        .arg(workspace().join("include"))
        .arg(&src)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// minimal.c's image equals, to float rounding of the mean, the Rust
/// renderer's image of the same scene, configuration and seed.
#[cfg(feature = "loader")]
#[test]
fn minimal_matches_a_rust_render() {
    use cmlt_core::renderer::{EstimatorKind, RenderWorker, Renderer, RendererConfig};

    let exe = build_example("minimal");
    for (method, estimator, per_pixel) in [
        ("bdpt", EstimatorKind::Bdpt, 4u64),
        ("cmlt", EstimatorKind::Cmlt, 8),
    ] {
        let out = run(&exe, &["minimal.ppm", method, &per_pixel.to_string(), "32"]);
        let c_mean = numbers(&out, "mean");
        assert!(out.contains("bad calls refused"), "{out}");
        assert_eq!(numbers(&out, "rays")[1], 0.0, "non-finite samples");

        let loaded = cmlt_mitsuba::builtin_scene(
            "cornell-box",
            &[("resx".into(), "32".into()), ("resy".into(), "32".into())],
        )
        .unwrap()
        .unwrap();
        let scene = &loaded.scene;
        let bvh = cmlt_core::accel::bvh::Bvh::build(&scene.triangles().collect::<Vec<_>>());
        // cmlt_renderer_config_default's values: the core's defaults.
        let cfg = RendererConfig {
            settings: loaded.settings,
            seed: 1,
            ..RendererConfig::for_estimator(estimator)
        };
        let mut r = Renderer::new(cfg, scene.camera).unwrap();
        let mut w = RenderWorker::new(&r, 0).unwrap();
        if r.begin_prepare(scene) {
            r.prepare_worker(&mut w, scene, &bvh).unwrap();
            r.finish_prepare([&w]).unwrap();
        }
        r.render(&mut w, scene, &bvh, per_pixel * 32 * 32).unwrap();
        let mut sum = [0.0f64; 3];
        r.resolve(&[&w], |_, c| {
            sum[0] += c.r as f64;
            sum[1] += c.g as f64;
            sum[2] += c.b as f64;
        })
        .unwrap();
        for c in 0..3 {
            let rust = sum[c] / 1024.0;
            assert!(
                (c_mean[c] - rust).abs() <= 1e-5 * rust.max(1e-3),
                "{method} channel {c}: C {} vs Rust {rust}",
                c_mean[c]
            );
        }
        assert!(c_mean[0] > 0.01, "{method}: black image");
    }
}

/// frame_loop.c: frames of a moving camera on two host threads allocate
/// nothing (its allocator aborts otherwise) and show the scene.
#[test]
fn frame_loop_allocates_nothing_per_frame() {
    let exe = build_example("frame_loop");
    for method in ["bdpt", "cmlt"] {
        let out = run(&exe, &["4", method]);
        assert_eq!(
            numbers(&out, "allocations during frames"),
            vec![0.0],
            "{out}"
        );
        let means: Vec<f64> = out
            .lines()
            .filter(|l| l.starts_with("frame "))
            .map(|l| numbers(l, "frame")[1])
            .collect();
        assert_eq!(means.len(), 4, "{out}");
        assert!(
            means.iter().all(|&m| m > 5.0 && m < 250.0),
            "{method}: {means:?}"
        );
        assert!(numbers(&out, "renderer needs")[0] > 0.0);
    }
}

/// frame_trial.cpp (the host of `cmlt-bench frames`): the C++17 wrapper
/// compiles with -Wall -Wextra -pedantic -Werror, and a moving camera and
/// mesh, frames bounded by the host's clock, every estimator (and every
/// accumulation mode), the Metropolis set-up in pieces: nothing allocates
/// per frame and every frame shows light.
#[test]
fn cpp_frame_trial_runs_every_estimator_without_allocating() {
    let exe = build_source("frame_trial", true);
    for method in [
        "pt",
        "bdpt+keep",
        "bdpt+decay",
        "mlt",
        "mlt+decay",
        "cmlt",
        "cmlt+keep",
    ] {
        let out = run(&exe, &[method, "64", "36", "20", "4"]);
        let trial = numbers(&out, &format!("trial {method} 64x36 triangles"));
        // triangles, budget, frames, p50, p95, setup, setup p50, black,
        // flicker, allocations, cpu p50, cpu p95, over, over lost, setup
        // cpu
        assert_eq!(trial.len(), 15, "{out}");
        assert!(trial[11] > 0.0, "{method}: a frame's CPU time\n{out}");
        assert!(trial[0] > 5000.0, "{out}");
        assert_eq!(trial[2], 4.0, "{out}");
        assert_eq!(trial[9], 0.0, "{method}: allocations per frame\n{out}");
        let means: Vec<f64> = out
            .lines()
            .filter(|l| l.starts_with("frame "))
            .map(|l| numbers(l, "frame")[3])
            .collect();
        assert_eq!(means.len(), 4, "{out}");
        assert!(means.iter().all(|&m| m > 0.0), "{method}: {means:?}");
    }
}

/// point_light.c: a point light added through `cmlt_scene_add_light`
/// lights the floor below it with the analytic radiance ρI/(πh²) (PT's
/// next-event estimation is exact there; BDPT adds light tracing), and
/// the corners, further from the light, are darker by the inverse-square
/// and cosine falloff.
/// `outputs.c`: the banded read-outs equal one call; at a floor pixel
/// the white floor's albedo (0.7) and normal (+y), at a sphere pixel the
/// mirror's reflectance (0.9); in the second frame (camera 0.1 along its
/// x axis, image-left; sphere 0.2 along the same axis) the analytic
/// motion of each: W/2 · Δ / (z · tan 25°) pixels, with Δ = −0.1 for the
/// floor (static) and +0.1 for the sphere (0.2 − 0.1), z the printed
/// depth, and no vertical motion.
#[test]
fn outputs_example_reads_bands_and_gives_the_analytic_motion() {
    let exe = build_example("outputs");
    let out = run(&exe, &[]);
    for frame in ["frame 1", "frame 2"] {
        assert_eq!(
            numbers(&out, &format!("{frame} bands identical")),
            vec![1.0],
            "{out}"
        );
    }
    // depth, normal (3), albedo (3), motion (2)
    let px = |key: &str| numbers(&out, key);
    let near = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol;
    let floor = px("frame 1 floor");
    assert!(floor[0].is_finite() && floor[0] > 1.0, "{out}");
    assert!(
        near(floor[2], 1.0, 1e-4) && near(floor[1], 0.0, 1e-4),
        "{out}"
    );
    assert!(floor[4..7].iter().all(|a| near(*a, 0.7, 2e-4)), "{out}");
    assert!(floor[7..9].iter().all(|m| near(*m, 0.0, 2e-3)), "{out}");
    let sphere = px("frame 1 sphere");
    let n = (sphere[1].powi(2) + sphere[2].powi(2) + sphere[3].powi(2)).sqrt();
    assert!(
        sphere[0] > 1.0 && near(n, 1.0, 1e-3) && sphere[3] < 0.0,
        "{out}"
    );
    assert!(sphere[4..7].iter().all(|a| near(*a, 0.9, 2e-4)), "{out}");
    let tan = (25.0f64).to_radians().tan();
    for (key, delta) in [("frame 2 floor", -0.1), ("frame 2 sphere", 0.1)] {
        let p = px(key);
        let want = 32.0 * delta / (p[0] * tan);
        assert!(near(p[7], want, 2e-3), "{key}: {} for {want}\n{out}", p[7]);
        assert!(near(p[8], 0.0, 2e-3), "{key}: {}\n{out}", p[8]);
    }
}

#[test]
fn point_light_example_matches_the_analytic_radiance() {
    let exe = build_example("point_light");
    for (method, tol) in [("pt", 0.01), ("bdpt", 0.03)] {
        let out = run(&exe, &[method, "64"]);
        let centre = numbers(&out, "centre");
        let (got, want) = (centre[0], centre[1]);
        assert!(
            (want - 0.5 * 2.0 / std::f64::consts::PI).abs() < 1e-5,
            "{out}"
        );
        assert!((got / want - 1.0).abs() < tol, "{method}: {out}");
        // Corners at ≈ 0.72 from the nadir: (1 + 0.72²)^(−3/2) ≈ 0.5.
        let corners = numbers(&out, "corners")[0];
        assert!(
            corners > 0.35 * got && corners < 0.7 * got,
            "{method}: {out}"
        );
    }
}

/// media.c: a glowing wall seen through a box of absorbing medium bounded
/// by a null (index-matched) boundary keeps exp(−σ_t d) of its radiance
/// per channel (Beer–Lambert), by every estimator; a bad medium and a bad
/// medium id are refused. A medium that only absorbs is passed with its
/// transmittance as the weight (`Medium::sample_flight`), so PT and BDPT
/// are exact up to the rays' at most 0.1 % longer paths through the box;
/// sampling a distance there instead (each sample passing with weight
/// T/P or not at all) leaves about 4 % of noise at 16 samples per pixel
/// over the 64 pixels, and a boundary that did not change the medium
/// leaves the centre at the wall's 1.
#[test]
fn media_example_matches_beer_lambert() {
    let exe = build_example("media");
    for (method, budget, tol) in [
        ("pt", "16", 0.003),
        ("bdpt", "16", 0.003),
        ("cmlt", "64", 0.01),
    ] {
        let out = run(&exe, &[method, budget]);
        let v = numbers(&out, "centre");
        let (got, want) = (&v[..3], &v[3..]);
        assert!((want[1] - (-1.0f64).exp()).abs() < 1e-5, "{out}");
        for c in 0..3 {
            assert!(
                (got[c] / want[c] - 1.0).abs() < tol,
                "{method}: channel {c}: {out}"
            );
        }
    }
}

/// host_geometry.c: the host's intersector (single rays and packets)
/// renders the same picture as our BVH, and CMLT's bundles reach the
/// packet callbacks.
#[test]
fn host_intersector_matches_our_bvh() {
    check_host_example("host_geometry");
}

/// embree_host.c: the host's Embree scene serves the callbacks with
/// rtcIntersect1/4/8/16 and renders the same picture as our BVH (the
/// staticlib of an `embree` build links libembree3 already).
#[cfg(feature = "embree")]
#[test]
fn embree_host_matches_our_bvh() {
    check_host_example("embree_host");
}

/// Runs a host-intersector example (BDPT and CMLT) and compares its two
/// renders.
fn check_host_example(name: &str) {
    let exe = build_example(name);
    for (method, budget) in [("bdpt", "16"), ("cmlt", "32")] {
        let out = run(&exe, &[method, budget]);
        let host = numbers(&out, "host mean")[0];
        let bvh = numbers(&out, "bvh mean")[0];
        let calls = numbers(&out, "callbacks");
        let bad = numbers(&out, "rejected");
        eprintln!("{method}: host {host} bvh {bvh} calls {calls:?} {bad:?}");
        assert!(host > 0.01, "{out}");
        assert!(
            (host / bvh - 1.0).abs() < 0.05,
            "{method}: host {host} vs bvh {bvh}"
        );
        assert!(calls[0] > 0.0);
        assert_eq!(bad, vec![0.0, 0.0, 0.0], "{out}");
        if method == "cmlt" {
            assert!(
                calls[1] > 0.0 && calls[2] > calls[1],
                "no packets reached the host: {calls:?}"
            );
        }
    }
}

/// Runs `cmd` (in `dir`); panics with its output when it fails.
fn checked(cmd: &mut Command, what: &str) -> String {
    let o = cmd.output().unwrap_or_else(|e| panic!("{what}: {e}"));
    assert!(
        o.status.success(),
        "{what} failed ({}):\n{}\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// What `make -C examples-c install` installs is usable as a package: a
/// CMake project finds it with `find_package(cmlt 0.1)` and links the
/// static (`cmlt::cmlt`) and the shared (`cmlt::shared`) library, a
/// `find_package(cmlt 0.2)` is refused, and `pkg-config --static` links
/// the static one. Each program creates and releases a scene and checks
/// the header's version against the library's. Installs this test run's
/// own libraries (`make install-files`; `install` would build a release
/// library first). Needs `cmake` and `pkg-config`, so `cargo test` skips
/// it; `.ci/run` installs both and runs it (`-- --ignored`).
#[test]
#[ignore = "needs cmake and pkg-config: .ci/run runs it"]
fn installed_package_links_through_cmake_and_pkg_config() {
    let lib = staticlib();
    let shlib = lib.with_file_name("libcmlt_capi.so");
    assert!(shlib.is_file(), "{} is missing", shlib.display());
    let root = out_dir().join("install-check");
    let _ = std::fs::remove_dir_all(&root);
    let prefix = root.join("prefix");
    let mut make = Command::new("make");
    make.arg("-C")
        .arg(workspace().join("examples-c"))
        .arg("install-files")
        .arg(format!("PREFIX={}", prefix.display()))
        .arg(format!("LIB={}", lib.display()))
        .arg(format!("SHLIB={}", shlib.display()));
    checked(&mut make, "make install-files");
    let project = root.join("project");
    std::fs::create_dir_all(&project).unwrap();
    std::fs::write(
        project.join("app.c"),
        "#include <cmlt.h>\n#include <stdio.h>\n\
         int main(void) {\n\
             cmlt_scene *s = NULL;\n\
             if (cmlt_version() != CMLT_VERSION) return 1;\n\
             if (cmlt_scene_new(&s) != CMLT_OK) return 2;\n\
             cmlt_scene_release(s);\n\
             puts(\"cmlt ok\");\n\
             return 0;\n\
         }\n",
    )
    .unwrap();
    let cmake_lists = |version: &str| {
        format!(
            "cmake_minimum_required(VERSION 3.16)\nproject(app C)\n\
             find_package(cmlt {version} REQUIRED)\n\
             add_executable(app_static app.c)\n\
             target_link_libraries(app_static PRIVATE cmlt::cmlt)\n\
             add_executable(app_shared app.c)\n\
             target_link_libraries(app_shared PRIVATE cmlt::shared)\n"
        )
    };
    let configure = |build: &Path| {
        let mut c = Command::new("cmake");
        c.arg("-S")
            .arg(&project)
            .arg("-B")
            .arg(build)
            .arg(format!("-DCMAKE_PREFIX_PATH={}", prefix.display()));
        c
    };
    // A version the package does not satisfy is refused at configure time.
    std::fs::write(project.join("CMakeLists.txt"), cmake_lists("0.2")).unwrap();
    let refused = configure(&root.join("build-0.2"))
        .output()
        .expect("run cmake");
    assert!(
        !refused.status.success(),
        "find_package(cmlt 0.2) was accepted"
    );
    std::fs::write(project.join("CMakeLists.txt"), cmake_lists("0.1")).unwrap();
    let build = root.join("build");
    checked(&mut configure(&build), "cmake configure");
    checked(
        Command::new("cmake").arg("--build").arg(&build),
        "cmake --build",
    );
    for exe in ["app_static", "app_shared"] {
        let out = checked(&mut Command::new(build.join(exe)), exe);
        assert_eq!(out, "cmlt ok\n", "{exe}");
    }
    // The shared one really is: it needs libcmlt.so at run time.
    let ldd = checked(Command::new("ldd").arg(build.join("app_shared")), "ldd");
    assert!(
        ldd.contains("libcmlt.so"),
        "app_shared does not load libcmlt.so:\n{ldd}"
    );
    // pkg-config: the static library and its system libraries.
    let flags = checked(
        Command::new("pkg-config")
            .args(["--cflags", "--libs", "--static", "cmlt"])
            .env("PKG_CONFIG_PATH", prefix.join("lib/pkgconfig")),
        "pkg-config",
    );
    let exe = root.join("app_pkg_config");
    checked(
        Command::new("cc")
            .arg(project.join("app.c"))
            .arg("-o")
            .arg(&exe)
            .args(flags.split_whitespace()),
        "cc with pkg-config's flags",
    );
    assert_eq!(
        checked(&mut Command::new(&exe), "app_pkg_config"),
        "cmlt ok\n"
    );
}
