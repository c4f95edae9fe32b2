//! Mitsuba 3 XML import (in progress).

use crate::error::SceneError;
use crate::load::{LoadOptions, LoadedScene};
use std::path::Path;

/// Loads a Mitsuba 3 scene.
pub fn load_mitsuba(path: &Path, _text: &str, _opts: &LoadOptions) -> Result<LoadedScene, SceneError> {
    Err(SceneError::new(path, "Mitsuba XML import is not supported yet"))
}
