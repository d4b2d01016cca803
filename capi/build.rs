//! Passes the target triple to the tests that compile the C examples.
fn main() {
    println!(
        "cargo:rustc-env=CMLT_TEST_TARGET={}",
        std::env::var("TARGET").expect("cargo sets TARGET")
    );
}
