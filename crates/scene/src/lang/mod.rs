//! The candela scene language: [`lexer`], [`parser`] and the scene description ([`ast`]).
//!
//! ```
//! use candela_scene::lang::{parse_scene, ShapeKind};
//! use std::collections::HashMap;
//! use std::path::Path;
//!
//! let text = "material m(diffuse(<0.5, 0.5, 0.5>))\nsphere(m, translation([0, 0, 1]))";
//! let scene = parse_scene(text, Path::new("scene.txt"), &HashMap::new()).unwrap();
//! assert!(matches!(scene.shapes[0].kind, ShapeKind::Sphere { .. }));
//! ```
//!
//! The user's reference of the language is `docs/scene-language.md` at the repository root.

pub mod ast;
pub mod lexer;
pub mod parser;

pub use ast::*;
pub use parser::{parse_define, parse_scene, parse_scene_file, MAX_DEPTH};
