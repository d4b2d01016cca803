//! C API of cmlt.
//!
//! Empty until issue 5: the crate exists so the workspace layout, the
//! staticlib/cdylib build and the header path are fixed from the start.
