//! The Miri subset on its own (`cargo +nightly miri test -p cmlt --test
//! miri`), so that Miri interprets only these tests. `cargo test` runs the
//! same module natively inside `tests/suite` and skips this binary
//! (`test = false` in Cargo.toml: one fewer binary instantiating the
//! renderer).

mod common;
#[path = "suite/miri.rs"]
mod miri;
