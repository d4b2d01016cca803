//! cmlt front end library.
