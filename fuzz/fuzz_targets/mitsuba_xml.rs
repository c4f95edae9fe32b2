//! Feeds arbitrary UTF-8 to the Mitsuba 3 XML importer: it must build a scene or return an error
//! with a position, never panic or hang. The scene is built with the linear list (no BVH) to
//! keep executions fast.
#![no_main]

use candela_render::accel::AccelKind;
use candela_scene::mitsuba::load_mitsuba;
use candela_scene::LoadOptions;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|text: &str| {
    let opts = LoadOptions {
        defines: vec![("spp".to_owned(), "4".to_owned())],
        accel: AccelKind::None,
        limits: candela_imageio::Limits::from_memory(256 << 20),
    };
    if let Err(e) = load_mitsuba(Path::new("/nonexistent/fuzz.xml"), text, &opts) {
        let _ = e.to_string();
    }
});
