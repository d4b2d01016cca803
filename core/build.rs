//! Links the system's Embree 3 when the `embree` feature is on.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    if std::env::var_os("CARGO_FEATURE_EMBREE").is_some() {
        println!("cargo:rustc-link-lib=embree3");
    }
}
