//! candela's render core: geometry, sampling, shapes, accelerators, materials, lights,
//! integrators and the film.
//!
//! The core knows nothing about files: scenes arrive already built (see the `candela-scene`
//! crate), images leave as [`Image`] values (see `candela-imageio`). Once a [`Scene`] is
//! built, rendering cannot fail.

pub mod accel;
pub mod aov;
pub mod camera;
pub mod color;
pub mod film;
pub mod filter;
pub mod geometry;
pub mod image;
pub mod instance;
pub mod integrator;
pub mod interaction;
pub mod light;
pub mod material;
pub mod math;
pub(crate) mod mem;
pub mod radiosity;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod shape;
pub(crate) mod simd;
pub mod spectrum;
pub mod splat;
pub mod stats;
pub mod texture;

pub use color::Rgb;
pub use image::Image;
pub use scene::{Scene, SceneBuilder};
