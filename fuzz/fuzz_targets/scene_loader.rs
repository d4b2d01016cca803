//! The Mitsuba loader on arbitrary text: it must return a scene or an
//! error, never panic (or abort on an absurd allocation). File references
//! resolve against a directory that does not exist.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(xml) = std::str::from_utf8(data) {
        let _ = cmlt_mitsuba::load_scene_str(
            xml,
            std::path::Path::new("/nonexistent/cmlt-fuzz"),
            "fuzz.xml",
            &[],
        );
    }
});
