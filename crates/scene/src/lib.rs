//! candela's scene files: the candela scene language, Mitsuba 3 XML, OBJ/PLY meshes.
//!
//! - [`error`]: [`SceneError`] and source positions, shared by every reader of the crate.
//! - [`lang`]: the lexer and parser of the candela language, producing a [`SceneDescription`].
//! - [`builder`]: the description → a render scene, validating files and geometry.
//! - [`mesh`]: OBJ and PLY meshes.
//! - [`mitsuba`]: Mitsuba 3 XML import.
//! - [`loaded`]: what loading needs and produces, shared by both formats.
//! - [`load`]: loading either format, and the built-in demo scene.
//! - `inputs`: the files a load reads (for the scene hash of partial renders).

pub mod builder;
pub mod error;
mod inputs;
pub mod lang;
pub mod load;
pub mod loaded;
pub mod mesh;
pub mod mitsuba;
mod ply_binary;
pub mod serialized;

pub use error::{Pos, SceneError, SourceFile};
pub use lang::{parse_define, parse_scene, parse_scene_file, SceneDescription};
pub use load::{
    demo_scene, is_xml_text, load_scene, load_scene_text, read_stdin_scene, DEMO_SCENE,
};
pub use loaded::{LoadOptions, LoadedScene, RenderHints, STDIN_NAME};
