//! Feeds arbitrary UTF-8 to the candela scene parser: it must return a description or an error,
//! never panic, overflow the stack or hang. The error must render too.
#![no_main]

use candela_scene::parse_scene;
use libfuzzer_sys::fuzz_target;
use std::collections::HashMap;
use std::path::Path;

fuzz_target!(|text: &str| {
    let overrides = HashMap::from([("clock".to_owned(), 1.0)]);
    if let Err(e) = parse_scene(text, Path::new("fuzz.txt"), &overrides) {
        let _ = e.to_string();
    }
});
