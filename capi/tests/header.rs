//! `include/cmlt.h` is what cbindgen generates from this crate today: a
//! stale committed header fails here. `CMLT_BLESS=1` rewrites it.

use std::path::PathBuf;

#[test]
fn committed_header_is_current() {
    let crate_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let config =
        cbindgen::Config::from_file(crate_dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let mut fresh = Vec::new();
    cbindgen::Builder::new()
        .with_crate(&crate_dir)
        .with_config(config)
        .generate()
        .expect("cbindgen generates the header")
        .write(&mut fresh);
    let fresh = String::from_utf8(fresh).expect("UTF-8 header");
    let path = crate_dir.join("../include/cmlt.h");
    if std::env::var_os("CMLT_BLESS").is_some() {
        std::fs::write(&path, &fresh).expect("write include/cmlt.h");
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == fresh,
        "include/cmlt.h is stale: regenerate it with `CMLT_BLESS=1 cargo test -p cmlt-capi --test header`"
    );
}
