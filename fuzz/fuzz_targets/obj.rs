//! Feeds arbitrary bytes to the OBJ mesh reader: it must return a mesh or an error, never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|bytes: &[u8]| {
    if let Err(e) = candela_scene::mesh::load_obj(Path::new("fuzz.obj"), bytes) {
        let _ = e.to_string();
    }
});
