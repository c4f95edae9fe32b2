//! Parsing helpers of the candela-language tests.

use candela_scene::lang::{parse_scene, SceneDescription};
use candela_scene::SceneError;
use std::path::Path;

/// Parses `text` as `scenes/test.txt` with the given overrides.
pub fn parse_with(text: &str, overrides: &[(&str, f32)]) -> Result<SceneDescription, SceneError> {
    let overrides = overrides.iter().map(|&(k, v)| (k.to_owned(), v)).collect();
    parse_scene(text, Path::new("scenes/test.txt"), &overrides)
}

/// Parses `text`, panicking with the error and the text when it fails.
pub fn parse(text: &str) -> SceneDescription {
    parse_with(text, &[]).unwrap_or_else(|e| panic!("{e}\n--- in ---\n{text}"))
}

/// `line:col: message` of the error `text` gives.
pub fn error_of(text: &str) -> String {
    match parse_with(text, &[]) {
        Ok(_) => panic!("no error for:\n{text}"),
        Err(e) => format!("{}: {}", e.pos.unwrap_or_default(), e.message),
    }
}
