//! Random numbers, per-pixel samplers and sampling warps.

pub mod distribution;
pub mod guide;
pub mod pcg;
pub mod sampler;
pub mod warp;

pub use distribution::{Distribution1D, Distribution2D};
pub use pcg::Pcg32;
pub use sampler::{SampleCursor, Sampler, SamplerKind};
