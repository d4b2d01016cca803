//! The feature-stripped build's test on its own, for builds without the
//! effects the rest of the suite needs (CI: `cargo test -p cmlt
//! --no-default-features --features std --test effects --profile dev`).
//! `cargo test` runs the same module with every effect inside
//! `tests/suite` and skips this binary (`test = false` in Cargo.toml).

mod common;
#[path = "suite/effects.rs"]
mod effects;
