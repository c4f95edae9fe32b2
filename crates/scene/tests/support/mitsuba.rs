//! Loading helpers of the Mitsuba-import tests.

use candela_scene::mitsuba::load_mitsuba;
use candela_scene::{LoadOptions, LoadedScene, SceneError};
use std::path::{Path, PathBuf};

/// A fresh folder for the files of one test.
pub fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("candela-mitsuba-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Loads `xml` as if read from `path`, with `-d` overrides `defines`.
pub fn try_load_with(
    path: &Path,
    xml: &str,
    defines: &[(&str, &str)],
) -> Result<LoadedScene, SceneError> {
    let opts = LoadOptions {
        defines: defines
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
        ..LoadOptions::default()
    };
    load_mitsuba(path, xml, &opts)
}

/// Loads `xml` as if read from `path`, panicking with the error and the text when it fails.
pub fn load_at(path: &Path, xml: &str) -> LoadedScene {
    try_load_with(path, xml, &[]).unwrap_or_else(|e| panic!("{e}\n--- in ---\n{xml}"))
}

/// Loads `xml` as if read from `scenes/test.xml`.
pub fn load(xml: &str) -> LoadedScene {
    load_at(Path::new("scenes/test.xml"), xml)
}

/// A scene with `body`.
pub fn scene(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n{body}\n</scene>")
}

/// `line:col: message` of the error that `xml` gives.
pub fn error_of(xml: &str) -> String {
    match try_load_with(Path::new("scenes/test.xml"), xml, &[]) {
        Ok(_) => panic!("no error for:\n{xml}"),
        Err(e) => {
            // Every error renders with its position, the source line and a caret.
            let shown = e.to_string();
            assert!(shown.starts_with("scenes/test.xml:"), "{shown}");
            format!(
                "{}: {}",
                e.pos.expect("an error with a position"),
                e.message
            )
        }
    }
}

/// Asserts that `xml` gives an error (`line:col: message`) starting with `prefix`.
#[track_caller]
pub fn assert_error_starts_with(xml: &str, prefix: &str) {
    let e = error_of(xml);
    assert!(e.starts_with(prefix), "{e}");
}
