//! C API of cmlt (issue 5): not yet exported.
